//! Marker speeds and the fastest-marker speed `V` (Sonoda et al. §2.1).
//!
//! `v[i][k] = |p[i+1][k] − p[i][k]| · fps` (mm/s) for `i < F−1`; `V[i] = max_k v[i][k]`.
//! The last frame has no successor, so `v[F−1][k]` is NaN.
//!
//! **Missing samples:** a marker missing at `i` or `i+1` has `v[i][k] = NaN` and is skipped
//! when taking the maximum; `V[i]` is NaN only when no marker is valid at both frames.

use motionlab_core::registry::ParamGuard;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use motionlab_core::{FeatureCache, FeatureExtractor, FeatureSet, LabelTrace, Motion, Result, TimeSpan, Trace};

use crate::smoothing::moving_average_positions;

/// Per-marker speeds of a motion, frame-major like its positions.
#[derive(Clone, Debug, PartialEq)]
pub struct MarkerSpeeds {
    pub n_points: usize,
    /// `speeds[i * M + k]` = `v[i][k]` in mm/s (NaN where undefined).
    pub speeds: Vec<f64>,
    /// `V[i]`, mm/s.
    pub fastest: Vec<f64>,
    /// The marker giving `V[i]` (None where `V[i]` is NaN).
    pub fastest_marker: Vec<Option<usize>>,
}

impl MarkerSpeeds {
    pub fn n_frames(&self) -> usize {
        self.fastest.len()
    }
    /// `v[i][k]`.
    pub fn speed(&self, frame: usize, point: usize) -> f64 {
        self.speeds[frame * self.n_points + point]
    }
    /// One marker's speed over all frames.
    pub fn marker_speed(&self, point: usize) -> Vec<f64> {
        (0..self.n_frames()).map(|i| self.speed(i, point)).collect()
    }
}

/// Computes `v` and `V` from positions smoothed by a centred moving average of
/// `smoothing_frames` frames (≤ 1 = no smoothing).
pub fn marker_speeds(motion: &Motion, smoothing_frames: usize) -> MarkerSpeeds {
    let f = motion.n_frames();
    let m = motion.n_points();
    let fps = motion.frame_rate().hz();
    let smoothed;
    let positions = if smoothing_frames > 1 {
        smoothed = moving_average_positions(motion, smoothing_frames);
        &smoothed[..]
    } else {
        motion.positions()
    };
    let mut speeds = Vec::with_capacity(f * m);
    let mut fastest = vec![f64::NAN; f];
    let mut fastest_marker = vec![None; f];
    for i in 0..f.saturating_sub(1) {
        let (a, b) = (&positions[i * m..(i + 1) * m], &positions[(i + 1) * m..(i + 2) * m]);
        // All speeds of the frame first, in branch-free loops (squared distances, then the
        // square roots over a contiguous row, which vectorise), then the fastest among them.
        speeds.extend(a.iter().zip(b).map(|(a, b)| {
            let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            d[0] * d[0] + d[1] * d[1] + d[2] * d[2] // NaN propagates from missing samples
        }));
        let row = &mut speeds[i * m..];
        for v in row.iter_mut() {
            *v = v.sqrt() * fps;
        }
        let (mut best, mut best_k) = (f64::NEG_INFINITY, usize::MAX);
        for (k, &v) in row.iter().enumerate() {
            if v > best {
                (best, best_k) = (v, k);
            }
        }
        if best_k != usize::MAX {
            (fastest[i], fastest_marker[i]) = (best, Some(best_k));
        }
    }
    speeds.resize(f * m, f64::NAN); // the last frame has no successor
    MarkerSpeeds { n_points: m, speeds, fastest, fastest_marker }
}

/// Cached [`marker_speeds`]: the speed segmenters and the feature extractor share one computation.
pub fn cached_marker_speeds(
    motion: &Motion,
    cache: &FeatureCache,
    smoothing_frames: usize,
) -> Result<std::sync::Arc<MarkerSpeeds>> {
    cache.get_or_compute(&format!("marker_speeds/smooth={smoothing_frames}"), || Ok(marker_speeds(motion, smoothing_frames)))
}

/// Per-frame speed of every marker and the fastest-marker speed V (mm/s), with the name of the
/// fastest marker at each frame (Sonoda et al. §2.1).
///
/// `v[i][k] = |p[i+1][k] − p[i][k]| · fps`; `V[i] = max_k v[i][k]`. The last frame is NaN
/// (no successor). Missing samples: a marker missing at either frame is skipped; V is NaN only
/// when no marker is valid.
#[derive(Clone, Debug, Default, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MarkerSpeedParams {
    /// Centred moving-average window applied to positions before differentiating
    /// (`{ frames = 5 }` or `{ seconds = 0.05 }`). Default: none (raw positions).
    #[serde(default)]
    pub smoothing: Option<TimeSpan>,
    /// Also output every marker's own speed as `v_<marker>_mm_per_s`. Default: false.
    #[serde(default)]
    pub per_marker: bool,
}

impl ParamGuard for MarkerSpeedParams {
    type Checked = MarkerSpeedParams;
    fn check(self) -> Result<Self> {
        if let Some(s) = self.smoothing {
            s.check("smoothing", false)?;
        }
        Ok(self)
    }
}

impl FeatureExtractor for MarkerSpeedParams {
    fn extract(&self, motion: &Motion, cache: &FeatureCache) -> Result<FeatureSet> {
        motion.require_frames(2, "marker_speed")?;
        let smoothing = self.smoothing.map(|s| s.whole_frames_at(motion.frame_rate())).unwrap_or(0);
        let s = cached_marker_speeds(motion, cache, smoothing)?;
        let names = motion.point_names();
        let mut traces = vec![Trace::new("V_mm_per_s", "mm/s", s.fastest.clone())];
        if self.per_marker {
            for (k, n) in names.iter().enumerate() {
                traces.push(Trace::new(format!("v_{n}_mm_per_s"), "mm/s", s.marker_speed(k)));
            }
        }
        let labels = vec![LabelTrace {
            name: "fastest_marker".into(),
            values: s.fastest_marker.iter().map(|k| k.map(|k| names[k].clone()).unwrap_or_default()).collect(),
        }];
        Ok(FeatureSet { traces, labels })
    }
}

motionlab_core::register_plugin!(FeatureExtractor, MarkerSpeedParams, "marker_speed");

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_testkit::motion_from_fn;

    #[test]
    fn speed_of_uniform_motion_is_distance_times_rate() {
        // Marker 0 moves 2 mm per frame along x at 50 Hz = 100 mm/s; marker 1 is still.
        let m = motion_from_fn(5, 50.0, 2, |i, k| if k == 0 { [2.0 * i as f64, 0.0, 0.0] } else { [0.0; 3] });
        let s = marker_speeds(&m, 0);
        for i in 0..4 {
            assert!((s.fastest[i] - 100.0).abs() < 1e-12);
            assert_eq!(s.fastest_marker[i], Some(0));
            assert_eq!(s.speed(i, 1), 0.0);
        }
        assert!(s.fastest[4].is_nan());
    }

    #[test]
    fn missing_samples_are_skipped_not_counted() {
        let m = motion_from_fn(3, 10.0, 2, |i, k| match (i, k) {
            (1, 0) => [f64::NAN; 3],
            (_, 0) => [100.0 * i as f64, 0.0, 0.0],
            _ => [0.0, i as f64, 0.0],
        });
        let s = marker_speeds(&m, 0);
        // Marker 0 is missing at frame 1, so only marker 1 (1 mm/frame = 10 mm/s) counts.
        assert_eq!(s.fastest[0], 10.0);
        assert_eq!(s.fastest_marker[0], Some(1));
        assert!(s.speed(0, 0).is_nan());
    }
}
