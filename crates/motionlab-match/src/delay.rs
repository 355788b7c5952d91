//! Preprocessor `delay_points`: shifts chosen markers later in time by a known amount, for the
//! paper's timing test (Yabe & Tanaka §5.2.2, repetition kind (b) "timing shifted").

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{Error, ErrorKind, Location, Motion, Preprocessor, Result, TimeSpan};

use crate::input::check_names;

/// Delays the listed markers by a fixed time, the others unchanged (a timing-shifted limb).
///
/// With `N` = `delay` in whole frames at the motion's rate (rounded to the nearest frame), each
/// listed marker `k` becomes
///
/// `p'[i][k] = p[i − N][k]` for `i ≥ N`, and `p'[i][k] = p[0][k]` for `i < N`:
///
/// the first `N` frames **hold the marker's first recorded position** (the limb waits, then
/// moves exactly as recorded, `N` frames late). Nothing else is invented: the motion keeps its
/// length, so the listed markers' last `N` recorded frames fall beyond the end and are dropped.
/// `N = 0` leaves the motion unchanged. Built for Yabe & Tanaka's test (§5.2.2): a repetition
/// "(b) whose timing is shifted" made from a real repetition "(a)" with a known shift, so the
/// synchronisation `R` can be checked against it.
///
/// Missing samples move with their marker: a sample missing at frame `i` is missing at frame
/// `i + N`; when a listed marker is missing at frame 0, the held frames `0..N` are missing too
/// (its first position is unknown, so it is not guessed). The missing mask is recomputed.
///
/// The skeleton (joint hierarchy and channel values), when the motion has one, is dropped: the
/// shifted positions no longer follow from its joint rotations, and a stage that recomputed
/// positions from it would silently undo the delay.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DelayPointsParams {
    /// Names of the markers (or joints) to delay, e.g. one limb's. Required, at least one, no
    /// repeats.
    pub points: Vec<String>,
    /// How much later the listed markers move: `{ frames = 12 }` or `{ seconds = 0.1 }`
    /// (rounded to whole frames at the motion's rate). Required, ≥ 0, and shorter than the
    /// motion.
    pub delay: TimeSpan,
}

/// The validated stage.
#[derive(Clone, Debug)]
pub struct DelayPoints {
    points: Vec<String>,
    delay: TimeSpan,
}

impl ParamGuard for DelayPointsParams {
    type Checked = DelayPoints;
    fn check(self) -> Result<DelayPoints> {
        check_names(&self.points, "points")?;
        Ok(DelayPoints { points: self.points, delay: self.delay.check("delay", false)? })
    }
}

impl DelayPoints {
    /// The delay in whole frames at `motion`'s rate.
    pub fn frames(&self, motion: &Motion) -> usize {
        self.delay.whole_frames_at(motion.frame_rate())
    }
}

impl Preprocessor for DelayPoints {
    fn apply(&self, mut motion: Motion) -> Result<Motion> {
        let shift = self.frames(&motion);
        let (f, m) = (motion.n_frames(), motion.n_points());
        if shift >= f {
            let loc = motion.source.as_ref().map(Location::file).unwrap_or_default();
            return Err(Error::new(
                ErrorKind::OutOfRange,
                format!(
                    "a delay of {} ({shift} frames) leaves nothing of the recorded trajectories in {} ({f} frames); \
                     expected a delay shorter than the motion",
                    self.delay, motion.name
                ),
            )
            .with_location(loc.field("delay")));
        }
        let indices: Vec<usize> =
            self.points.iter().map(|n| motion.point_index(n)).collect::<Result<_>>()?;
        if shift > 0 {
            let positions = motion.positions_mut();
            // Walk backwards so every source frame i − N is read before it is overwritten.
            for i in (0..f).rev() {
                let src = i.saturating_sub(shift);
                for &k in &indices {
                    positions[i * m + k] = positions[src * m + k];
                }
            }
            motion.refresh_missing();
        }
        motion.skeleton = None;
        Ok(motion)
    }
}

motionlab_core::register_plugin!(Preprocessor, DelayPointsParams, "delay_points");

#[cfg(test)]
mod tests {
    use super::*;
    use crate::build_matcher;
    use motionlab_core::registry::{build_loader, build_preprocessor, default_params};
    use motionlab_testkit::motion_from_fn;
    // Links the loaders the real-data test looks up by name.
    use motionlab_io as _;

    fn stage(text: &str) -> Box<dyn Preprocessor> {
        build_preprocessor("delay_points", &toml::from_str::<toml::Value>(text).unwrap()).unwrap()
    }

    /// Marker k at frame i sits at (10 i + k, 100 k, −i).
    fn ramp(frames: usize, rate: f64) -> Motion {
        motion_from_fn(frames, rate, 3, |i, k| {
            [10.0 * i as f64 + k as f64, 100.0 * k as f64, -(i as f64)]
        })
    }

    #[test]
    fn listed_markers_hold_their_first_position_then_move_n_frames_late() {
        let m = ramp(6, 100.0);
        let out =
            stage("points = [\"m1\", \"m2\"]\ndelay = { frames = 2 }").apply(m.clone()).unwrap();
        assert_eq!(out.n_frames(), 6);
        for i in 0..6 {
            // Unlisted marker: untouched.
            assert_eq!(out.position(i, 0), m.position(i, 0));
            for k in 1..3 {
                let expected = if i < 2 { m.position(0, k) } else { m.position(i - 2, k) };
                assert_eq!(out.position(i, k), expected, "frame {i}, marker {k}");
            }
        }
        // Known values: marker 1 at frame 5 is where it was at frame 3.
        assert_eq!(out.position(5, 1), [31.0, 100.0, -3.0]);
        assert_eq!(out.position(1, 2), [2.0, 200.0, 0.0]);
    }

    #[test]
    fn a_delay_in_seconds_is_rounded_to_frames_at_the_motion_rate() {
        let m = ramp(10, 100.0);
        // 0.034 s at 100 Hz = 3.4 frames → 3.
        let out = stage("points = [\"m0\"]\ndelay = { seconds = 0.034 }").apply(m.clone()).unwrap();
        assert_eq!(out.position(3, 0), m.position(0, 0));
        assert_eq!(out.position(4, 0), m.position(1, 0));
        assert_eq!(out.position(2, 0), m.position(0, 0));
        // Zero delay: identity.
        let same = stage("points = [\"m0\"]\ndelay = { frames = 0 }").apply(m.clone()).unwrap();
        assert_eq!(same.positions(), m.positions());
    }

    #[test]
    fn missing_samples_move_with_their_marker_and_are_never_filled() {
        // m0 missing at frame 0 (so its held frames are missing too), m1 missing at frame 2.
        let m = motion_from_fn(6, 50.0, 2, |i, k| match (i, k) {
            (0, 0) | (2, 1) => [f64::NAN; 3],
            _ => [i as f64, k as f64, 0.0],
        });
        let out = stage("points = [\"m0\", \"m1\"]\ndelay = { frames = 1 }").apply(m).unwrap();
        let missing: Vec<(usize, usize)> = (0..6)
            .flat_map(|i| (0..2).map(move |k| (i, k)))
            .filter(|&(i, k)| out.is_missing(i, k))
            .collect();
        assert_eq!(missing, vec![(0, 0), (1, 0), (3, 1)]);
        assert_eq!(out.missing_count(), 3);
        assert_eq!(out.position(2, 0), [1.0, 0.0, 0.0]);
        assert_eq!(out.position(2, 1), [1.0, 1.0, 0.0]);
    }

    #[test]
    fn bad_parameters_and_impossible_delays_are_refused_naming_the_field() {
        let bad = |text: &str| {
            build_preprocessor("delay_points", &toml::from_str::<toml::Value>(text).unwrap())
                .err()
                .unwrap()
        };
        let e = bad("points = [\"m0\"]\ndelay = { frames = -1 }");
        assert_eq!(
            (e.kind(), e.location().field.as_deref()),
            (ErrorKind::OutOfRange, Some("delay"))
        );
        let e = bad("points = []\ndelay = { frames = 1 }");
        assert_eq!(e.location().field.as_deref(), Some("points"));
        let e = bad("points = [\"m0\", \"m0\"]\ndelay = { frames = 1 }");
        assert_eq!(e.kind(), ErrorKind::DuplicateName);
        assert_eq!(bad("points = [\"m0\"]").kind(), ErrorKind::MissingKey);
        // At run time: a delay as long as the motion, and an unknown marker.
        let e =
            stage("points = [\"m0\"]\ndelay = { frames = 6 }").apply(ramp(6, 100.0)).unwrap_err();
        assert_eq!(
            (e.kind(), e.location().field.as_deref()),
            (ErrorKind::OutOfRange, Some("delay"))
        );
        assert!(e.to_string().contains("6 frames"), "{e}");
        let e =
            stage("points = [\"hand\"]\ndelay = { frames = 1 }").apply(ramp(6, 100.0)).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::UnknownName);
    }

    /// Real data: the left hand of 13_29 delayed by 12 frames (0.1 s). One jumping jack of the
    /// original (frames 138..270) is found in the delayed take exactly 12 frames later, at zero
    /// distance, by the single-marker subsequence DP; the right hand is found where it was.
    #[test]
    fn on_a_real_take_a_delayed_hand_matches_its_original_twelve_frames_later() {
        let path = motionlab_testkit::data_path("mocap6/amc/13_29.amc.gz");
        let take = build_loader("asf_amc", &default_params())
            .unwrap()
            .load(&path)
            .unwrap()
            .slice_frames(0, 468)
            .unwrap();
        assert!(take.skeleton.is_some());
        let model = take.slice_frames(138, 270).unwrap();
        let delayed = stage("points = [\"lhand\"]\ndelay = { seconds = 0.1 }").apply(take).unwrap();
        assert!(delayed.skeleton.is_none());
        let find = |marker: &str| {
            let params: toml::Value = toml::from_str(&format!("marker = \"{marker}\"")).unwrap();
            build_matcher("subsequence_dp", &params).unwrap().align(&model, &delayed).unwrap()
        };
        let left = find("lhand");
        assert_eq!((left.start, left.end, left.total_distance), (150, 281, 0.0));
        let right = find("rhand");
        assert_eq!((right.start, right.end, right.total_distance), (138, 269, 0.0));
    }
}
