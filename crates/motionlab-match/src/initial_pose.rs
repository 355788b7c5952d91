//! Preprocessor `initial_pose_normalisation`: every marker starts at the origin (§5.2.1).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{Motion, Preprocessor, Result};

/// Subtracts each marker's initial position from all of its frames (Yabe & Tanaka §5.2.1).
///
/// `p'[i][k] = p[i][k] − p[f_k][k]`, where `f_k` is frame 0 when marker `k` is present there.
///
/// Absolute capture coordinates carry the performer's build, height and place in the room;
/// after this step two performers doing the same movement produce similar trajectories, which
/// is what the DP matching compares.
///
/// Missing samples stay missing (NaN stays NaN). **Choice** (the paper assumes complete data):
/// a marker missing at frame 0 is referred to its **first valid frame** `f_k` instead; a marker
/// that is never present stays missing throughout.
///
/// The skeleton (joint hierarchy and channel values), when the motion has one, is dropped:
/// the normalised positions no longer follow from its joint rotations by forward kinematics,
/// and a stage that recomputed positions from it would silently undo the normalisation.
#[derive(Clone, Debug, Default, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct InitialPoseNormalisationParams {}

/// The validated stage (it has no parameters).
#[derive(Clone, Copy, Debug, Default)]
pub struct InitialPoseNormalisation;

impl ParamGuard for InitialPoseNormalisationParams {
    type Checked = InitialPoseNormalisation;
    fn check(self) -> Result<InitialPoseNormalisation> {
        Ok(InitialPoseNormalisation)
    }
}

impl Preprocessor for InitialPoseNormalisation {
    fn apply(&self, mut motion: Motion) -> Result<Motion> {
        let (f, m) = (motion.n_frames(), motion.n_points());
        let initial: Vec<Option<[f64; 3]>> = (0..m)
            .map(|k| (0..f).find(|&i| !motion.is_missing(i, k)).map(|i| motion.position(i, k)))
            .collect();
        for frame in motion.positions_mut().chunks_exact_mut(m) {
            for (p, origin) in frame.iter_mut().zip(&initial) {
                if let Some(o) = origin {
                    *p = [p[0] - o[0], p[1] - o[1], p[2] - o[2]];
                }
            }
        }
        // NaN − x is NaN, so the mask is unchanged; refreshed anyway as positions_mut asks.
        motion.refresh_missing();
        motion.skeleton = None;
        Ok(motion)
    }
}

motionlab_core::register_plugin!(
    Preprocessor,
    InitialPoseNormalisationParams,
    "initial_pose_normalisation"
);

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_core::registry::{build_preprocessor, default_params};
    use motionlab_testkit::motion_from_fn;

    #[test]
    fn every_marker_starts_at_the_origin_and_keeps_its_displacements() {
        let m = motion_from_fn(5, 60.0, 3, |i, k| {
            [100.0 * k as f64 + i as f64, 2.0 * i as f64 - k as f64, 1700.0]
        });
        let out = build_preprocessor("initial_pose_normalisation", &default_params())
            .unwrap()
            .apply(m.clone())
            .unwrap();
        for k in 0..3 {
            assert_eq!(out.position(0, k), [0.0, 0.0, 0.0]);
            for i in 0..5 {
                let (a, b, c) = (m.position(i, k), m.position(0, k), out.position(i, k));
                assert_eq!(c, [a[0] - b[0], a[1] - b[1], a[2] - b[2]]);
            }
        }
    }

    #[test]
    fn a_marker_missing_at_frame_zero_uses_its_first_valid_frame() {
        let m = motion_from_fn(4, 60.0, 3, |i, k| match (i, k) {
            (0 | 1, 1) => [f64::NAN; 3],
            (_, 2) => [f64::NAN; 3],
            _ => [10.0 * i as f64, 5.0, -3.0 * k as f64],
        });
        let out = InitialPoseNormalisation.apply(m).unwrap();
        assert!(out.is_missing(0, 1) && out.is_missing(1, 1));
        assert_eq!(out.position(2, 1), [0.0, 0.0, 0.0]); // first valid frame of marker 1
        assert_eq!(out.position(3, 1), [10.0, 0.0, 0.0]);
        assert_eq!(out.position(3, 0), [30.0, 0.0, 0.0]);
        assert!((0..4).all(|i| out.is_missing(i, 2))); // never present: stays missing
        assert_eq!(out.missing_count(), 6);
    }

    #[test]
    fn unknown_parameters_are_rejected() {
        let v: toml::Value = toml::from_str("frame = 0").unwrap();
        assert!(build_preprocessor("initial_pose_normalisation", &v).is_err());
    }
}
