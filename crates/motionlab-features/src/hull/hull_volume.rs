//! Feature extractor `hull_volume`: `Vol` and `D` for every frame of a motion.

use std::sync::Arc;

use motionlab_core::registry::ParamGuard;
use motionlab_core::{FeatureCache, FeatureExtractor, FeatureSet, Motion, Result, Trace};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::Degeneracy;
use super::tracker::{HullTracker, TrackerStats};

/// Per-frame hull volumes and their changes for a motion.
#[derive(Clone, Debug, PartialEq)]
pub struct HullVolumes {
    /// `Vol[i]`, mm³ (0 on degenerate frames).
    pub volume_mm3: Vec<f64>,
    /// `D[i] = |Vol[i] − Vol[i−1]|`, mm³ per frame; NaN at 0, next to a degenerate frame, or
    /// where the set of valid markers changed.
    pub change_mm3_per_frame: Vec<f64>,
    /// Why a frame is degenerate (None = proper hull). These are the flagged frames.
    pub degenerate: Vec<Option<Degeneracy>>,
    /// Number of valid markers per frame.
    pub n_valid: Vec<usize>,
    pub stats: TrackerStats,
}

impl HullVolumes {
    /// Indices of the flagged (degenerate) frames.
    pub fn flagged_frames(&self) -> Vec<usize> {
        self.degenerate.iter().enumerate().filter(|(_, d)| d.is_some()).map(|(i, _)| i).collect()
    }
}

/// `Vol` and `D` for every frame of a motion.
pub fn hull_volumes(motion: &Motion) -> HullVolumes {
    let f = motion.n_frames();
    let mut tracker = HullTracker::new();
    let mut volume_mm3 = Vec::with_capacity(f);
    let mut degenerate = Vec::with_capacity(f);
    let mut n_valid = Vec::with_capacity(f);
    // A complete recording (the usual case) needs no per-frame look at the missing flags.
    let complete = motion.missing_count() == 0;
    for i in 0..f {
        let h = tracker.frame(motion.frame(i));
        volume_mm3.push(h.volume_mm3);
        degenerate.push(h.degenerate);
        n_valid.push(if complete {
            motion.n_points()
        } else {
            motion.frame_missing(i).iter().filter(|m| !**m).count()
        });
    }
    let mut change = vec![f64::NAN; f];
    for i in 1..f {
        let same_markers = complete || motion.frame_missing(i) == motion.frame_missing(i - 1);
        if same_markers && degenerate[i].is_none() && degenerate[i - 1].is_none() {
            change[i] = (volume_mm3[i] - volume_mm3[i - 1]).abs();
        }
    }
    HullVolumes {
        volume_mm3,
        change_mm3_per_frame: change,
        degenerate,
        n_valid,
        stats: tracker.stats(),
    }
}

/// Cached [`hull_volumes`]: the hull segmenter and the feature extractor share one computation.
pub fn cached_hull_volumes(motion: &Motion, cache: &FeatureCache) -> Result<Arc<HullVolumes>> {
    cache.get_or_compute("hull_volumes/all_valid_markers", || Ok(hull_volumes(motion)))
}

/// Per-frame volume of the 3-D convex hull of all valid markers, `Vol` (mm³), and its change
/// `D[i] = |Vol[i] − Vol[i−1]|` (mm³/frame) — "the space made by the body" of Sonoda et al. §2.3.
///
/// Outputs `Vol_mm3`, `D_mm3_per_frame` and `hull_degenerate` (1 on flagged frames, else 0).
/// Missing samples: the hull is taken over the frame's valid markers. A frame with fewer than 4
/// valid markers, or whose valid markers are all collinear or coplanar, has `Vol = 0` and is
/// flagged. `D` is NaN at frame 0, next to a flagged frame, and where the set of valid markers
/// changes from the previous frame (a marker dropping out is not a body change).
#[derive(Clone, Debug, Default, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct HullVolumeParams {}

impl ParamGuard for HullVolumeParams {
    type Checked = HullVolumeParams;
    fn check(self) -> Result<Self> {
        Ok(self)
    }
}

impl FeatureExtractor for HullVolumeParams {
    fn extract(&self, motion: &Motion, cache: &FeatureCache) -> Result<FeatureSet> {
        motion.require_frames(1, "hull_volume")?;
        let h = cached_hull_volumes(motion, cache)?;
        let flags = h.degenerate.iter().map(|d| if d.is_some() { 1.0 } else { 0.0 }).collect();
        Ok(FeatureSet {
            traces: vec![
                Trace::new("Vol_mm3", "mm³", h.volume_mm3.clone()),
                Trace::new("D_mm3_per_frame", "mm³/frame", h.change_mm3_per_frame.clone()),
                Trace::new("hull_degenerate", "", flags),
            ],
            labels: Vec::new(),
        })
    }
}

motionlab_core::register_plugin!(FeatureExtractor, HullVolumeParams, "hull_volume");
