//! Matcher `subsequence_dp`: the paper's single-stream DP with free start and free end (§3.1.2).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::{Alignment, Matcher};
use motionlab_core::registry::ParamGuard;
use motionlab_core::{Motion, Result};

use crate::dp::{Euclidean3, Workspace, subsequence_match};
use crate::input::{check_names, trajectories};

/// Single-stream subsequence DP of one marker, free start and free end (Yabe & Tanaka §3.1.2).
///
/// Finds the stretch of the target that best matches the whole model, for that one marker.
///
/// `d(i, j) = |s_i − t_j|` (3-D euclidean, mm); `g(0, j) = d(0, j)` (free start);
/// `g(i, 0) = d(i, 0) + g(i−1, 0)`; `g(i, j) = d(i, j) + min(g(i−1, j), g(i−1, j−1), g(i, j−1))`
/// (0-based; the paper's `g(i+1, j+1)`). The end is `b = argmin_j g(n−1, j)` (the earliest
/// among ties), the distance `D = g(n−1, b)`, and the path is found by backtracking from
/// `(n−1, b)` to model frame 0, whose target frame is the start `a` (predecessor ties:
/// diagonal, then model step, then target step).
///
/// The result is an alignment with one point: `point_distances = [D]`, `total_distance = D`,
/// one path. This is the baseline the paper improves on: run per marker, each body part may
/// pick its own `[a, b]` (§3.1.2, Fig. 3); `multistream_two_stage` aligns them all.
///
/// Memory O(n·m) (the matrix is kept for the path).
///
/// Missing samples: **refused** for the chosen marker (error naming the first missing frame;
/// fill gaps first with the `fill_gaps` preprocessor); other markers are not read.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SubsequenceDpParams {
    /// Name of the marker (or joint) to match; model and target must both have it. Required.
    pub marker: String,
}

/// The validated stage.
#[derive(Clone, Debug)]
pub struct SubsequenceDp {
    marker: String,
}

impl ParamGuard for SubsequenceDpParams {
    type Checked = SubsequenceDp;
    fn check(self) -> Result<SubsequenceDp> {
        check_names(std::slice::from_ref(&self.marker), "marker")?;
        Ok(SubsequenceDp { marker: self.marker })
    }
}

impl Matcher for SubsequenceDp {
    fn align(&self, model: &Motion, target: &Motion) -> Result<Alignment> {
        let names = std::slice::from_ref(&self.marker);
        let s = trajectories(model, names, "model", "subsequence_dp")?;
        let t = trajectories(target, names, "target", "subsequence_dp")?;
        let found = subsequence_match(&Euclidean3::new(&s[0], &t[0]), &mut Workspace::new())?;
        Ok(Alignment {
            start: found.start,
            end: found.end,
            point_distances: vec![found.cost],
            total_distance: found.cost,
            paths: vec![found.path],
        })
    }
}

motionlab_core::register_custom_plugin!(
    crate::Matcher,
    SubsequenceDpParams,
    "subsequence_dp",
    kind = "matcher"
);

#[cfg(test)]
mod tests {
    use crate::build_matcher;
    use motionlab_core::ErrorKind;
    use motionlab_core::registry::default_params;
    use motionlab_testkit::motion_from_fn;

    fn wave(i: usize) -> [f64; 3] {
        let t = i as f64 * 0.2;
        [100.0 * t.sin(), 50.0 * (2.0 * t).cos(), 10.0 * t]
    }

    #[test]
    fn finds_the_model_inside_a_longer_take() {
        // The target is the model's movement preceded by 12 and followed by 9 frames far away.
        let model = motion_from_fn(30, 60.0, 2, |i, _| wave(i));
        let target = motion_from_fn(51, 60.0, 2, |j, k| {
            if (12..42).contains(&j) { wave(j - 12) } else { [5000.0 + k as f64, 0.0, 0.0] }
        });
        let v: toml::Value = toml::from_str("marker = \"m1\"").unwrap();
        let a = build_matcher("subsequence_dp", &v).unwrap().align(&model, &target).unwrap();
        assert_eq!((a.start, a.end, a.total_distance), (12, 41, 0.0));
        assert_eq!(a.paths, vec![(0..30).map(|i| (i, i + 12)).collect::<Vec<_>>()]);
    }

    #[test]
    fn marker_is_required_and_must_exist() {
        let e = build_matcher("subsequence_dp", &default_params()).err().unwrap();
        assert_eq!(e.kind(), ErrorKind::MissingKey);
        let v: toml::Value = toml::from_str("marker = \"wrist\"").unwrap();
        let m = motion_from_fn(5, 60.0, 1, |i, _| wave(i));
        let e = build_matcher("subsequence_dp", &v).unwrap().align(&m, &m).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::UnknownName);
    }

    #[test]
    fn missing_samples_of_the_marker_are_refused() {
        let v: toml::Value = toml::from_str("marker = \"m0\"").unwrap();
        let model = motion_from_fn(5, 60.0, 2, |i, _| wave(i));
        let target =
            motion_from_fn(
                9,
                60.0,
                2,
                |j, k| if j == 4 && k == 0 { [f64::NAN; 3] } else { wave(j) },
            );
        let e = build_matcher("subsequence_dp", &v).unwrap().align(&model, &target).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::MissingData);
        assert!(e.to_string().contains("frame 4"), "{e}");
    }
}
