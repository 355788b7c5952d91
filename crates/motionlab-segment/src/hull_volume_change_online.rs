//! `hull_volume_change_online`: Sonoda et al.'s hull-volume candidates (§2.3) decided while
//! the frames arrive.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{
    DataKind, Decision, Error, ErrorKind, Point3, Result, SegmenterSession, StreamLayout, Streamed,
    StreamingSegmenter,
};
use motionlab_features::hull::HullTracker;

use crate::stream_frames::{frame_points, require_points};

/// Where the volume of the body's convex hull starts to change quickly (`hull_volume_change`,
/// Sonoda et al. §2.3), decided on a stream of frames: `Vol[i]` the hull volume of frame i's
/// valid markers (mm³), `D[i] = |Vol[i] − Vol[i−1]|` (mm³/frame); candidate i when
/// `D[i−1] > D[i] < D[i+1]` and `D[i] < t < D[i+1]`, t = `t_mm3_per_s` / the stream's rate —
/// exactly `hull_volume_change`'s candidates with `t = { mm3_per_s = … }`.
///
/// **Lag, stated:** candidate i is decided when frame i + 1 arrives (D[i+1] needs it): one
/// frame. **Threshold in mm³/s only**: `hull_volume_change`'s default is a fraction of the
/// take's own 90th-percentile D, which only the whole take gives.
///
/// **Memory**: one frame's hull (the tracker re-uses it), the last frame's missing markers and
/// three values of D. **Missing samples**: as `hull_volume_change` — the hull is taken over the
/// frame's valid markers; a frame with fewer than 4, or all coplanar, is degenerate; D is
/// undefined next to a degenerate frame and where the set of valid markers changes; an
/// undefined D is never a candidate nor the neighbour of one.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct HullVolumeChangeOnlineParams {
    /// The threshold t on D as a rate of volume change, mm³/s (per frame: divided by the
    /// stream's rate).
    pub t_mm3_per_s: f64,
}

/// The validated stage.
#[derive(Clone, Debug, PartialEq)]
pub struct HullVolumeChangeOnline {
    pub t_mm3_per_s: f64,
}

impl ParamGuard for HullVolumeChangeOnlineParams {
    type Checked = Streamed<HullVolumeChangeOnline>;
    fn check(self) -> Result<Streamed<HullVolumeChangeOnline>> {
        if !(self.t_mm3_per_s.is_finite() && self.t_mm3_per_s > 0.0) {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                format!("t_mm3_per_s is {}, expected a rate > 0 mm³/s", self.t_mm3_per_s),
            )
            .with_field("t_mm3_per_s"));
        }
        Ok(Streamed(HullVolumeChangeOnline { t_mm3_per_s: self.t_mm3_per_s }))
    }
}

impl StreamingSegmenter for HullVolumeChangeOnline {
    fn consumes(&self) -> DataKind {
        DataKind::Points
    }
    fn start(&self, layout: &StreamLayout) -> Result<Box<dyn SegmenterSession>> {
        let m = require_points(layout, "hull_volume_change_online")?;
        Ok(Box::new(HullSession {
            m,
            t: self.t_mm3_per_s / layout.rate.hz(),
            seen: 0,
            tracker: HullTracker::new(),
            prev: None,
            d: [f64::NAN; 3],
            points: Vec::with_capacity(m),
        }))
    }
}

struct HullSession {
    m: usize,
    /// The threshold, mm³ per frame.
    t: f64,
    seen: usize,
    tracker: HullTracker,
    /// The previous frame: its volume, whether degenerate, and which markers were missing.
    prev: Option<(f64, bool, Vec<bool>)>,
    /// D at the last three frames (oldest first).
    d: [f64; 3],
    points: Vec<Point3>,
}

impl SegmenterSession for HullSession {
    fn width(&self) -> usize {
        3 * self.m
    }
    fn samples_seen(&self) -> usize {
        self.seen
    }
    fn push_sample(&mut self, sample: &[f64], decided: &mut Vec<Decision>) -> Result<()> {
        let r = self.seen;
        frame_points(sample, self.m, r, "hull_volume_change_online", &mut self.points)?;
        let h = self.tracker.frame(&self.points);
        let missing: Vec<bool> = self.points.iter().map(|p| p[0].is_nan()).collect();
        let degenerate = h.degenerate.is_some();
        let d = match &self.prev {
            Some((vol, prev_degenerate, prev_missing))
                if *prev_missing == missing && !degenerate && !prev_degenerate =>
            {
                (h.volume_mm3 - vol).abs()
            }
            _ => f64::NAN,
        };
        self.prev = Some((h.volume_mm3, degenerate, missing));
        self.d = [self.d[1], self.d[2], d];
        self.seen += 1;
        // Centre i = r − 1: D[i−1] > D[i] < D[i+1] and D[i] < t < D[i+1].
        let [a, b, c] = self.d;
        if r >= 2 && a > b && b < c && b < self.t && self.t < c {
            decided.push(Decision { boundary: r - 1, decided_at: r });
        }
        Ok(())
    }
}

motionlab_core::register_plugin!(
    Segmenter,
    HullVolumeChangeOnlineParams,
    "hull_volume_change_online"
);

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_core::registry::build_segmenter;
    use motionlab_core::{FeatureCache, Segmenter};
    use motionlab_testkit::motion_from_fn;

    #[test]
    fn a_breathing_cube_starts_to_grow_where_offline_says_one_frame_later() {
        // Eight corners of a cube whose side holds still, grows, holds, shrinks (100 Hz); one
        // corner drops out for three frames.
        let side = |i: usize| -> f64 {
            let t = i as f64;
            match i {
                0..40 => 500.0,
                40..80 => 500.0 + 8.0 * (t - 40.0) + 0.02 * (t - 40.0).powi(2),
                80..120 => 852.0,
                _ => (852.0 - 5.0 * (t - 120.0)).max(300.0),
            }
        };
        let m = motion_from_fn(200, 100.0, 8, |i, k| {
            if k == 7 && (100..103).contains(&i) {
                return [f64::NAN; 3];
            }
            // A small jitter whose steps make D's still stretches wobble: frame 40, the last
            // before the growth, is a local minimum of D.
            let s = side(i) + [0.0, 0.01, 0.03][i % 3];
            [s * (k & 1) as f64, s * ((k >> 1) & 1) as f64, s * ((k >> 2) & 1) as f64]
        });
        let text = "t = { mm3_per_s = 1.0e8 }";
        let offline = build_segmenter("hull_volume_change", &toml::from_str(text).unwrap())
            .unwrap()
            .segment(&m, &FeatureCache::new())
            .unwrap()
            .candidates;
        let on = toml::from_str::<HullVolumeChangeOnlineParams>("t_mm3_per_s = 1.0e8")
            .unwrap()
            .check()
            .unwrap();
        let (layout, samples) = StreamLayout::of_motion(&m, DataKind::Points, "t").unwrap();
        let decided = motionlab_core::streaming::run_offline(&on.0, &layout, samples).unwrap();
        let boundaries: Vec<usize> = decided.iter().map(|d| d.boundary).collect();
        assert!(boundaries.contains(&40), "{boundaries:?}");
        assert_eq!(boundaries, offline);
        assert!(decided.iter().all(|d| d.decided_at == d.boundary + 1));
        assert_eq!(on.segment(&m, &FeatureCache::new()).unwrap().candidates, offline);
        assert!(
            toml::from_str::<HullVolumeChangeOnlineParams>("t_mm3_per_s = 0.0")
                .unwrap()
                .check()
                .is_err()
        );
    }
}
