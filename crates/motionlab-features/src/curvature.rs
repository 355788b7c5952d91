//! Discrete curvature of the root's horizontal path (Sonoda et al. §2.2): the k-cosine of
//! Rosenfeld & Johnston.
//!
//! With `q[i]` the root's floor-plane position (the up axis dropped) and lag `L` frames:
//!
//! ```text
//! a[i] = q[i−L] − q[i],   b[i] = q[i+L] − q[i],   C[i] = cos θ = a·b / (|a| |b|)
//! ```
//!
//! Both vectors leave `q[i]`, so `C ≈ −1` on a straight path and `C → +1` at a sharp reversal.
//! `C[i]` is undefined (NaN) when `|a| < T` or `|b| < T` (the root hardly moves), within `L`
//! frames of either end, and when any of the three samples is missing.

use std::sync::Arc;

use motionlab_core::registry::ParamGuard;
use motionlab_core::{
    Axis, Error, ErrorKind, FeatureCache, FeatureExtractor, FeatureSet, Motion, Result, TimeSpan,
    Trace,
};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// `C[i]` for a floor-plane path `q` (mm; NaN = missing), lag `lag_frames` ≥ 1 and minimum leg
/// length `min_leg_mm` (the paper's T).
pub fn k_cosine(q: &[[f64; 2]], lag_frames: usize, min_leg_mm: f64) -> Vec<f64> {
    let n = q.len();
    let mut c = vec![f64::NAN; n];
    if lag_frames == 0 {
        return c;
    }
    for i in lag_frames..n.saturating_sub(lag_frames) {
        c[i] = k_cosine_at(q[i - lag_frames], q[i], q[i + lag_frames], min_leg_mm);
    }
    c
}

/// `C` at one sample from its three floor-plane positions (`before` = q[i−L], `p` = q[i],
/// `after` = q[i+L]): what [`k_cosine`] computes at each sample, for streams that get one
/// frame at a time. NaN when a leg is shorter than `min_leg_mm` or a position is missing.
pub fn k_cosine_at(before: [f64; 2], p: [f64; 2], after: [f64; 2], min_leg_mm: f64) -> f64 {
    let a = [before[0] - p[0], before[1] - p[1]];
    let b = [after[0] - p[0], after[1] - p[1]];
    let (la, lb) = (a[0].hypot(a[1]), b[0].hypot(b[1]));
    // NaN lengths (missing samples) fail both comparisons and stay undefined.
    if la >= min_leg_mm && lb >= min_leg_mm && la > 0.0 && lb > 0.0 {
        ((a[0] * b[0] + a[1] * b[1]) / (la * lb)).clamp(-1.0, 1.0)
    } else {
        f64::NAN
    }
}

/// The floor-plane path of one point: its two non-up coordinates per frame (NaN when missing).
pub fn horizontal_path(motion: &Motion, point: usize, up: Axis) -> Vec<[f64; 2]> {
    let [x, y] = up.others();
    motion.trajectory(point).map(|p| [p[x], p[y]]).collect()
}

/// Validated curvature settings shared by the feature extractor and the `direction_change`
/// segmenter.
#[derive(Clone, Debug, PartialEq)]
pub struct CurvatureSpec {
    pub root: String,
    pub lag: TimeSpan,
    pub min_leg_mm: f64,
    pub up_axis: Option<Axis>,
}

impl CurvatureSpec {
    /// Checks `lag > 0` and `min_leg_mm ≥ 0` (errors name the field).
    pub fn new(
        root: String,
        lag: TimeSpan,
        min_leg_mm: f64,
        up_axis: Option<Axis>,
    ) -> Result<Self> {
        let lag = lag.check("lag", true)?;
        if !(min_leg_mm.is_finite() && min_leg_mm >= 0.0) {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                format!("must be a finite length >= 0 mm, found {min_leg_mm}"),
            )
            .with_field("min_leg_mm"));
        }
        if root.is_empty() {
            return Err(Error::new(ErrorKind::InvalidParameter, "must name a marker or joint")
                .with_field("root"));
        }
        Ok(CurvatureSpec { root, lag, min_leg_mm, up_axis })
    }

    /// `L` in whole frames at the motion's rate (at least 1).
    pub fn lag_frames(&self, motion: &Motion) -> usize {
        self.lag.whole_frames_at(motion.frame_rate()).max(1)
    }

    /// `C` for a motion (cached under every parameter it depends on).
    pub fn compute(&self, motion: &Motion, cache: &FeatureCache) -> Result<Arc<Vec<f64>>> {
        let root = motion.point_index(&self.root)?;
        let up = self.up_axis.unwrap_or(motion.up_axis());
        let lag = self.lag_frames(motion);
        let key = format!("root_curvature/{}/{lag}/{}/{up}", self.root, self.min_leg_mm);
        cache.get_or_compute(&key, || {
            Ok(k_cosine(&horizontal_path(motion, root, up), lag, self.min_leg_mm))
        })
    }
}

pub(crate) fn default_root() -> String {
    "root".into()
}
pub(crate) fn default_lag() -> TimeSpan {
    TimeSpan::Seconds(0.125)
}
pub(crate) fn default_min_leg_mm() -> f64 {
    100.0
}

/// Discrete curvature `C` of the root marker's horizontal path (Sonoda et al. §2.2, the k-cosine
/// of Rosenfeld & Johnston), output as the per-frame trace `C` (dimensionless, −1 … +1).
///
/// `a[i] = q[i−L] − q[i]`, `b[i] = q[i+L] − q[i]` with `q` the root's floor-plane position;
/// `C[i] = a·b / (|a||b|)`: ≈ −1 on a straight path, → +1 at a sharp reversal.
/// `C[i]` is NaN (undefined) when `|a| < T` or `|b| < T` (the root hardly moves) and within L
/// frames of either end. Missing samples: `C[i]` is NaN when the root is missing at `i−L`, `i`
/// or `i+L`; nothing is interpolated.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RootCurvatureParams {
    /// Name of the root marker or joint (for marker sets without one, add it with the
    /// `add_centroid` preprocessor).
    #[serde(default = "default_root")]
    pub root: String,
    /// The lag L between `q[i]` and `q[i±L]` (the default is the paper's 15 frames at 120 fps).
    #[serde(default = "default_lag")]
    pub lag: TimeSpan,
    /// The paper's T, mm: C is undefined when either leg is shorter.
    #[serde(default = "default_min_leg_mm")]
    pub min_leg_mm: f64,
    /// Up axis to drop for the floor plane (`"x"`, `"y"`, `"z"`).
    #[serde(default)]
    #[schemars(extend("x-default" = "the motion's own up axis"))]
    pub up_axis: Option<Axis>,
}

impl ParamGuard for RootCurvatureParams {
    type Checked = CurvatureSpec;
    fn check(self) -> Result<CurvatureSpec> {
        CurvatureSpec::new(self.root, self.lag, self.min_leg_mm, self.up_axis)
    }
}

impl FeatureExtractor for CurvatureSpec {
    fn extract(&self, motion: &Motion, cache: &FeatureCache) -> Result<FeatureSet> {
        let c = self.compute(motion, cache)?;
        Ok(FeatureSet { traces: vec![Trace::new("C", "", c.to_vec())], labels: Vec::new() })
    }
}

motionlab_core::register_plugin!(FeatureExtractor, RootCurvatureParams, "root_curvature");

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_core::registry::build_feature_extractor;
    use motionlab_testkit::named_motion;

    /// Walks the perimeter of a square of side `side` mm at `step` mm per frame, starting at a
    /// corner; returns the path and the frames at the corners.
    fn square_path(side: f64, step: f64) -> (Vec<[f64; 2]>, Vec<usize>) {
        let per_side = (side / step) as usize;
        let corners = [[0.0, 0.0], [side, 0.0], [side, side], [0.0, side]];
        let mut q = Vec::new();
        let mut corner_frames = Vec::new();
        for s in 0..4 {
            let (a, b) = (corners[s], corners[(s + 1) % 4]);
            corner_frames.push(q.len());
            for k in 0..per_side {
                let t = k as f64 / per_side as f64;
                q.push([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
            }
        }
        q.push([0.0, 0.0]);
        (q, corner_frames)
    }

    #[test]
    fn square_path_peaks_at_the_corners_and_is_minus_one_on_the_sides() {
        let (q, corners) = square_path(2000.0, 20.0); // 100 frames per side
        let lag = 15;
        let c = k_cosine(&q, lag, 100.0);
        // Interior corners (the first is within L of the start): a right angle, cos = 0.
        for &k in &corners[1..] {
            assert!(c[k].abs() < 1e-12, "corner {k}: C = {}", c[k]);
            // A local maximum: larger than anything else within L frames.
            for j in k - lag..=k + lag {
                if j != k {
                    assert!(c[j] < c[k], "C[{j}] = {} >= C[{k}] = {}", c[j], c[k]);
                }
            }
        }
        // Straight parts, more than L from any corner: exactly −1.
        for (i, v) in c.iter().enumerate() {
            let near_corner = corners
                .iter()
                .chain(std::iter::once(&q.len()))
                .any(|&k| i + lag >= k && i <= k + lag);
            if i >= lag && i + lag < q.len() && !near_corner {
                assert!((v + 1.0).abs() < 1e-12, "frame {i}: C = {v}");
            }
        }
        // Ends are undefined.
        assert!(c[..lag].iter().all(|v| v.is_nan()));
        assert!(c[q.len() - lag..].iter().all(|v| v.is_nan()));
    }

    #[test]
    fn known_angle_and_reversal() {
        // Legs of 200 mm at 60° to each other: cos = 0.5. A full reversal: +1.
        let (l, d) = (1, 200.0);
        let ang = std::f64::consts::PI / 3.0;
        let q = [[d, 0.0], [0.0, 0.0], [d * ang.cos(), d * ang.sin()]];
        assert!((k_cosine(&q, l, 100.0)[1] - 0.5).abs() < 1e-12);
        let q = [[d, 0.0], [0.0, 0.0], [d, 0.0]];
        assert_eq!(k_cosine(&q, l, 100.0)[1], 1.0);
    }

    #[test]
    fn short_legs_and_missing_samples_are_undefined() {
        // Legs of 50 mm < T = 100 mm.
        let q = [[-50.0, 0.0], [0.0, 0.0], [50.0, 0.0]];
        assert!(k_cosine(&q, 1, 100.0)[1].is_nan());
        assert_eq!(k_cosine(&q, 1, 40.0)[1], -1.0);
        let q = [[-500.0, 0.0], [f64::NAN, f64::NAN], [500.0, 0.0], [1000.0, 0.0]];
        let c = k_cosine(&q, 1, 100.0);
        assert!(c[1].is_nan() && c[2].is_nan(), "{c:?}"); // missing at i and at i−L
    }

    #[test]
    fn plugin_uses_the_named_root_and_the_floor_plane() {
        // Root walks a right-angle turn in x/y while bobbing in z (up): z must not matter.
        let m = named_motion(61, 120.0, &["hip", "root"], |i, k| {
            let (x, y) =
                if i <= 30 { (20.0 * i as f64, 0.0) } else { (600.0, 20.0 * (i - 30) as f64) };
            if k == 0 { [0.0; 3] } else { [x, y, 1000.0 + 300.0 * (i as f64).sin()] }
        });
        let params: toml::Value = toml::from_str("lag = { frames = 15 }").unwrap();
        let fx = build_feature_extractor("root_curvature", &params).unwrap();
        let out = fx.extract(&m, &FeatureCache::new()).unwrap();
        let c = &out.traces[0].values;
        assert_eq!(c.len(), 61);
        assert!(c[30].abs() < 1e-12, "right angle at the turn: {}", c[30]);
        assert!(
            (c[15] + 1.0).abs() < 1e-12 && (c[45] + 1.0).abs() < 1e-12,
            "straight legs: {} {}",
            c[15],
            c[45]
        );
        // The root lives in "root"; "hip" stays at the origin (would give NaN everywhere).
        let bad: toml::Value = toml::from_str("root = \"pelvis\"").unwrap();
        let e = build_feature_extractor("root_curvature", &bad)
            .unwrap()
            .extract(&m, &FeatureCache::new())
            .unwrap_err();
        assert_eq!(e.kind(), ErrorKind::UnknownName);
        let neg: toml::Value = toml::from_str("min_leg_mm = -1.0").unwrap();
        let e = build_feature_extractor("root_curvature", &neg).err().unwrap();
        assert_eq!(e.location().field.as_deref(), Some("min_leg_mm"));
    }
}
