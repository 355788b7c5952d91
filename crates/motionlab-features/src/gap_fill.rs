//! Gap filling: the preprocessor `fill_gaps`, like the MoCap Toolbox's `mcfillgaps`.
//!
//! Written here rather than taken from a crate: the interpolation crates (`splines`,
//! `enterpolation`, `bspline`) interpolate whole curves from control points and know nothing of
//! missing-sample masks, gap lengths or which neighbours to trust; what is needed is a short
//! not-a-knot spline through a handful of samples around each gap, ~40 lines with a tridiagonal
//! solve. It is checked against scipy's `CubicSpline` values in the tests.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{Error, ErrorKind, Motion, Point3, Preprocessor, Result, TimeSpan};

/// Fills short gaps (runs of missing frames) in every marker's trajectory by interpolation,
/// like the MoCap Toolbox's `mcfillgaps`; longer gaps stay missing.
///
/// Per marker, every run of consecutive missing frames of length ≤ `max_gap` that has a present
/// sample on both sides is filled, each coordinate separately:
/// - `linear`: the straight line between the last sample before and the first after the gap.
/// - `cubic`: a cubic spline through up to `support` present samples on **each** side of the gap
///   — the ones nearest to it, stepping over other gaps of length ≤ `max_gap` (their frames are
///   never used, only originally present samples are) and stopping at a longer gap or the end of
///   the recording. With ≥ 4 samples it is the *not-a-knot* spline (MATLAB `spline`, scipy
///   `CubicSpline` default), which reproduces any cubic exactly; with 3, the parabola through
///   them; with 2, the line. (Not the *natural* spline: its zero end curvature bends the fill
///   toward a straight line and does not restore even a cubic trajectory.)
///
/// Gaps touching the start or the end of the recording have only one side: with
/// `edges = "leave"` they stay missing; with `"hold"` they take the nearest present
/// value (`mcfillgaps(…, 'fillall')`), again only when ≤ `max_gap`. A marker missing in every
/// frame stays missing. `mcfillgaps` instead writes 0 into unfilled edges by default; here a
/// sample is never invented as 0.
///
/// Missing samples: this stage is what fills them; the missing mask is recomputed afterwards,
/// so samples it could not fill stay missing (NaN) for later stages.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FillGapsParams {
    /// The longest run of missing frames that is filled, in frames or seconds (resolved at the
    /// motion's rate; a run of n frames is filled when n ≤ max_gap); the default fills short
    /// occlusions. Measured on gaps cut into the complete MoCap
    /// Toolbox recordings walk2, dance1 and dance2 (`examples/gap_fill_accuracy.rs`): `cubic`
    /// restores 0.2 s gaps to 6–8 mm RMS (95 % of samples within 16 mm), 0.3 s gaps to
    /// 12.5–15 mm and 0.5 s gaps only to 27–49 mm; `linear` is 2–3× worse at 0.2 s.
    #[serde(default = "default_max_gap")]
    pub max_gap: TimeSpan,
    /// `"linear"` or `"cubic"`.
    #[serde(default)]
    pub method: GapFillMethod,
    /// Present samples used on each side of a gap by `cubic` (≥ 2).
    #[serde(default = "default_support")]
    pub support: usize,
    /// Gaps at the start or end of the recording: `"leave"` them missing or `"hold"` the
    /// nearest present value.
    #[serde(default)]
    pub edges: EdgeFill,
}

fn default_max_gap() -> TimeSpan {
    TimeSpan::Seconds(0.2)
}

fn default_support() -> usize {
    4
}

/// How a gap is interpolated.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum GapFillMethod {
    /// Straight line between the samples either side of the gap.
    Linear,
    /// Not-a-knot cubic spline through `support` samples on each side.
    #[default]
    Cubic,
}

/// What happens to gaps that touch the start or the end of the recording.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum EdgeFill {
    /// They stay missing.
    #[default]
    Leave,
    /// They take the nearest present value.
    Hold,
}

/// The validated preprocessor.
#[derive(Clone, Debug, PartialEq)]
pub struct FillGaps {
    pub max_gap: TimeSpan,
    pub method: GapFillMethod,
    pub support: usize,
    pub edges: EdgeFill,
}

impl ParamGuard for FillGapsParams {
    type Checked = FillGaps;
    fn check(self) -> Result<FillGaps> {
        let max_gap = self.max_gap.check("max_gap", true)?;
        if self.support < 2 {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                format!(
                    "must be at least 2 samples per side (1 would make the cubic a line), found {}",
                    self.support
                ),
            )
            .with_field("support"));
        }
        Ok(FillGaps { max_gap, method: self.method, support: self.support, edges: self.edges })
    }
}

impl Preprocessor for FillGaps {
    fn apply(&self, mut motion: Motion) -> Result<Motion> {
        let filled = self.fill(&motion);
        motion.positions_mut().copy_from_slice(&filled);
        motion.refresh_missing();
        Ok(motion)
    }
}

motionlab_core::register_plugin!(Preprocessor, FillGapsParams, "fill_gaps");

impl FillGaps {
    /// The filled positions (frame-major like [`Motion::positions`]); unfilled samples stay NaN.
    pub fn fill(&self, motion: &Motion) -> Vec<Point3> {
        let n = motion.n_frames();
        let m = motion.n_points();
        let max_run = self.max_gap.frames_at(motion.frame_rate());
        // A run of `len` frames is short enough; the slack keeps a span in seconds that equals a
        // whole number of frames from losing that frame to rounding.
        let short = |len: usize| len as f64 <= max_run + 1e-9 * max_run.max(1.0);
        let src = motion.positions();
        let mut out = src.to_vec();
        let mut xs: Vec<f64> = Vec::with_capacity(2 * self.support);
        let mut ys: Vec<f64> = Vec::with_capacity(2 * self.support);
        let mut frames: Vec<usize> = Vec::with_capacity(2 * self.support);
        for k in 0..m {
            let missing = |i: usize| motion.is_missing(i, k);
            let mut i = 0;
            while i < n {
                if !missing(i) {
                    i += 1;
                    continue;
                }
                let start = i;
                while i < n && missing(i) {
                    i += 1;
                }
                let end = i; // frames start..end are missing
                if !short(end - start) || (start == 0 && end == n) {
                    continue;
                }
                if start == 0 || end == n {
                    if self.edges == EdgeFill::Hold {
                        let keep = src[if start == 0 { end } else { start - 1 } * m + k];
                        (start..end).for_each(|f| out[f * m + k] = keep);
                    }
                    continue;
                }
                match self.method {
                    GapFillMethod::Linear => {
                        let (a, b) = (start - 1, end);
                        let (pa, pb) = (src[a * m + k], src[b * m + k]);
                        for f in start..end {
                            let t = (f - a) as f64 / (b - a) as f64;
                            out[f * m + k] = std::array::from_fn(|c| pa[c] + (pb[c] - pa[c]) * t);
                        }
                    }
                    GapFillMethod::Cubic => {
                        frames.clear();
                        support_frames(&missing, n, start, end, self.support, &short, &mut frames);
                        xs.clear();
                        xs.extend(frames.iter().map(|&f| f as f64));
                        for c in 0..3 {
                            ys.clear();
                            ys.extend(frames.iter().map(|&f| src[f * m + k][c]));
                            let spline = Spline::through(&xs, &ys);
                            for f in start..end {
                                out[f * m + k][c] = spline.at(f as f64);
                            }
                        }
                    }
                }
            }
        }
        out
    }
}

/// The present frames used for the gap `start..end` (exclusive), ascending: up to `per_side`
/// nearest on each side, stepping over short gaps, stopping at a long gap or the recording's end.
fn support_frames(
    missing: &impl Fn(usize) -> bool,
    n: usize,
    start: usize,
    end: usize,
    per_side: usize,
    short: &impl Fn(usize) -> bool,
    out: &mut Vec<usize>,
) {
    let mut run = 0;
    for f in (0..start).rev() {
        if out.len() == per_side {
            break;
        }
        if missing(f) {
            run += 1;
            if !short(run) {
                break;
            }
        } else {
            run = 0;
            out.push(f);
        }
    }
    out.reverse();
    let left = out.len();
    run = 0;
    for f in end..n {
        if out.len() - left == per_side {
            break;
        }
        if missing(f) {
            run += 1;
            if !short(run) {
                break;
            }
        } else {
            run = 0;
            out.push(f);
        }
    }
}

/// An interpolant through samples `(x_i, y_i)` with strictly increasing `x`: the not-a-knot
/// cubic spline for ≥ 4 samples, the parabola for 3, the line for 2 (see [`FillGapsParams`]).
struct Spline<'a> {
    x: &'a [f64],
    y: &'a [f64],
    /// Second derivatives at the knots (≥ 4 samples only).
    second: Vec<f64>,
}

impl<'a> Spline<'a> {
    /// `x` and `y` have equal length ≥ 2 (a gap always has a sample on each side).
    fn through(x: &'a [f64], y: &'a [f64]) -> Self {
        let n = x.len();
        if n < 4 {
            return Spline { x, y, second: Vec::new() };
        }
        // Unknowns M_1 … M_{n−2}; the not-a-knot conditions (third derivative continuous at x_1
        // and x_{n−2}) give M_0 = (1 + h0/h1)·M_1 − (h0/h1)·M_2 and the mirror at the other end,
        // which are substituted into the first and last interior rows. The system stays
        // tridiagonal and diagonally dominant, so the Thomas algorithm is stable.
        let h: Vec<f64> = x.windows(2).map(|w| w[1] - w[0]).collect();
        let slope: Vec<f64> = (0..n - 1).map(|i| (y[i + 1] - y[i]) / h[i]).collect();
        let size = n - 2;
        let (mut sub, mut diag, mut sup, mut rhs) =
            (vec![0.0; size], vec![0.0; size], vec![0.0; size], vec![0.0; size]);
        for r in 0..size {
            let i = r + 1;
            sub[r] = h[i - 1];
            diag[r] = 2.0 * (h[i - 1] + h[i]);
            sup[r] = h[i];
            rhs[r] = 6.0 * (slope[i] - slope[i - 1]);
        }
        let (h0, h1) = (h[0], h[1]);
        diag[0] += h0 * (1.0 + h0 / h1);
        sup[0] -= h0 * h0 / h1;
        let (ha, hb) = (h[n - 2], h[n - 3]); // last and second-to-last interval
        diag[size - 1] += ha * (1.0 + ha / hb);
        sub[size - 1] -= ha * ha / hb;
        // (With 4 samples there are two unknowns and both rows are end rows; the two
        // substitutions touch different rows, so the same code covers it.)
        for r in 1..size {
            let w = sub[r] / diag[r - 1];
            diag[r] -= w * sup[r - 1];
            rhs[r] -= w * rhs[r - 1];
        }
        let mut inner = vec![0.0; size];
        inner[size - 1] = rhs[size - 1] / diag[size - 1];
        for r in (0..size - 1).rev() {
            inner[r] = (rhs[r] - sup[r] * inner[r + 1]) / diag[r];
        }
        let mut second = Vec::with_capacity(n);
        second.push((1.0 + h0 / h1) * inner[0] - (h0 / h1) * inner[1]);
        second.extend_from_slice(&inner);
        second.push((1.0 + ha / hb) * inner[size - 1] - (ha / hb) * inner[size - 2]);
        Spline { x, y, second }
    }

    fn at(&self, t: f64) -> f64 {
        let (x, y) = (self.x, self.y);
        let n = x.len();
        // The interval [x_i, x_{i+1}] holding t (clamped to the first / last).
        let i = x.partition_point(|&v| v <= t).saturating_sub(1).min(n - 2);
        match n {
            2 => y[0] + (y[1] - y[0]) * (t - x[0]) / (x[1] - x[0]),
            3 => {
                // Lagrange form of the parabola through the three samples.
                let l0 = (t - x[1]) * (t - x[2]) / ((x[0] - x[1]) * (x[0] - x[2]));
                let l1 = (t - x[0]) * (t - x[2]) / ((x[1] - x[0]) * (x[1] - x[2]));
                let l2 = (t - x[0]) * (t - x[1]) / ((x[2] - x[0]) * (x[2] - x[1]));
                y[0] * l0 + y[1] * l1 + y[2] * l2
            }
            _ => {
                let h = x[i + 1] - x[i];
                let (a, b) = (x[i + 1] - t, t - x[i]);
                let (m0, m1) = (self.second[i], self.second[i + 1]);
                m0 * a * a * a / (6.0 * h)
                    + m1 * b * b * b / (6.0 * h)
                    + (y[i] / h - m0 * h / 6.0) * a
                    + (y[i + 1] / h - m1 * h / 6.0) * b
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_core::registry::{build_preprocessor, parse_params};
    use motionlab_testkit::{Rng, motion_from_fn};

    fn stage(method: GapFillMethod, max_gap_frames: f64) -> FillGaps {
        FillGapsParams {
            max_gap: TimeSpan::Frames(max_gap_frames),
            method,
            support: 4,
            edges: EdgeFill::Leave,
        }
        .check()
        .unwrap()
    }

    /// A one-marker motion following `f` with the listed frames missing.
    fn with_gaps(n: usize, gaps: &[usize], f: impl Fn(f64) -> Point3) -> Motion {
        motion_from_fn(
            n,
            100.0,
            1,
            |i, _| if gaps.contains(&i) { [f64::NAN; 3] } else { f(i as f64) },
        )
    }

    #[test]
    fn a_linear_trajectory_is_restored_exactly_by_both_methods() {
        let line = |t: f64| [3.0 + 2.5 * t, -t, 100.0];
        let gaps = [5, 6, 7, 8, 12];
        for method in [GapFillMethod::Linear, GapFillMethod::Cubic] {
            let out = stage(method, 10.0).apply(with_gaps(20, &gaps, line)).unwrap();
            assert_eq!(out.missing_count(), 0);
            for &f in &gaps {
                let (got, want) = (out.position(f, 0), line(f as f64));
                for c in 0..3 {
                    assert!(
                        (got[c] - want[c]).abs() < 1e-9,
                        "{method:?} frame {f}: {got:?} vs {want:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn a_cubic_trajectory_is_restored_exactly_by_the_spline_not_by_the_line() {
        let cubic =
            |t: f64| [0.02 * t * t * t - 0.5 * t * t + 3.0 * t + 7.0, 0.001 * t * t * t, -t * t];
        // Gap 8..12 plus a one-frame gap inside the right support.
        let gaps = [8, 9, 10, 11, 14];
        let cubic_fill =
            stage(GapFillMethod::Cubic, 5.0).apply(with_gaps(25, &gaps, cubic)).unwrap();
        let linear_fill =
            stage(GapFillMethod::Linear, 5.0).apply(with_gaps(25, &gaps, cubic)).unwrap();
        let mut linear_error: f64 = 0.0;
        for &f in &gaps {
            let want = cubic(f as f64);
            for (c, w) in want.iter().enumerate() {
                assert!((cubic_fill.position(f, 0)[c] - w).abs() < 1e-9, "frame {f}");
                linear_error = linear_error.max((linear_fill.position(f, 0)[c] - w).abs());
            }
        }
        assert!(linear_error > 1.0, "the line cannot follow a cubic: {linear_error}");
        // Even with the minimum support (2 + 2 samples = one cubic) the cubic is exact.
        let minimal = FillGapsParams {
            max_gap: TimeSpan::Frames(5.0),
            method: GapFillMethod::Cubic,
            support: 2,
            edges: EdgeFill::Leave,
        };
        let out = minimal.check().unwrap().apply(with_gaps(25, &[8, 9, 10, 11], cubic)).unwrap();
        assert!((out.position(10, 0)[0] - cubic(10.0)[0]).abs() < 1e-9);
    }

    #[test]
    fn the_spline_equals_scipy_cubic_spline_on_uneven_support() {
        // Present frames 0 1 3 4 | gap 5–7 | 8 9 11 12 (2 and 10 are one-frame gaps, stepped
        // over). Reference: scipy.interpolate.CubicSpline(x, y) (not-a-knot), scipy 1.17.1:
        //   x = [0,1,3,4,8,9,11,12], y = [10, 12.5, 11, 15, 30, 28, 35, 33] → at 5, 6, 7.
        let values = [
            10.0,
            12.5,
            f64::NAN,
            11.0,
            15.0,
            f64::NAN,
            f64::NAN,
            f64::NAN,
            30.0,
            28.0,
            f64::NAN,
            35.0,
            33.0,
        ];
        let m = motion_from_fn(13, 100.0, 1, |i, _| [values[i], 0.0, 0.0]);
        let out = stage(GapFillMethod::Cubic, 3.0).fill(&m);
        let scipy = [20.695430280116042, 26.08010335917313, 29.67472475864365];
        for (f, want) in [5, 6, 7].into_iter().zip(scipy) {
            assert!((out[f][0] - want).abs() < 1e-9, "frame {f}: {} vs scipy {want}", out[f][0]);
        }
        // Three samples give the parabola: scipy CubicSpline([0,1,3], [10,12.5,11])(1.5) = 12.9375.
        let (x, y) = ([0.0, 1.0, 3.0], [10.0, 12.5, 11.0]);
        assert!((Spline::through(&x, &y).at(1.5) - 12.9375).abs() < 1e-12);
    }

    #[test]
    fn the_spline_interpolates_its_samples_and_has_continuous_derivatives_on_random_data() {
        let mut rng = Rng::new(5);
        for _ in 0..200 {
            let n = 4 + (rng.uniform() * 6.0) as usize;
            let mut x = vec![0.0];
            for _ in 1..n {
                let last = *x.last().unwrap();
                x.push(last + 1.0 + (rng.uniform() * 3.0).floor());
            }
            let y: Vec<f64> = (0..n).map(|_| rng.normal() * 50.0).collect();
            let s = Spline::through(&x, &y);
            for i in 0..n {
                assert!((s.at(x[i]) - y[i]).abs() < 1e-9);
            }
            // First derivative continuous at interior knots (one-sided differences agree), and
            // the not-a-knot condition: third derivative equal on both sides of x_1 and x_{n−2}.
            let third = |i: usize| (s.second[i + 1] - s.second[i]) / (x[i + 1] - x[i]);
            assert!((third(0) - third(1)).abs() < 1e-7 * (1.0 + third(0).abs()));
            assert!((third(n - 2) - third(n - 3)).abs() < 1e-7 * (1.0 + third(n - 2).abs()));
            for (i, &knot) in x.iter().enumerate().take(n - 1).skip(1) {
                let e = 1e-6;
                let left = (s.at(knot) - s.at(knot - e)) / e;
                let right = (s.at(knot + e) - s.at(knot)) / e;
                assert!(
                    (left - right).abs() < 1e-3 * (1.0 + left.abs()),
                    "slope jump at knot {i}: {left} vs {right}"
                );
            }
        }
    }

    #[test]
    fn gaps_longer_than_max_gap_stay_missing() {
        // Gaps of 3 (frames 4–6) and 4 (frames 10–13) frames; max_gap 3 frames.
        let out = stage(GapFillMethod::Cubic, 3.0)
            .apply(with_gaps(20, &[4, 5, 6, 10, 11, 12, 13], |t| [t, t, t]))
            .unwrap();
        assert_eq!(out.missing_count(), 4);
        assert!((10..14).all(|f| out.is_missing(f, 0) && out.position(f, 0)[0].is_nan()));
        assert!((4..7).all(|f| !out.is_missing(f, 0)));
        // In seconds: 0.03 s at 100 Hz is 3 frames (not lost to 2.9999…).
        let secs = FillGapsParams {
            max_gap: TimeSpan::Seconds(0.03),
            ..FillGapsParams::default_for_tests()
        };
        let out = secs.check().unwrap().apply(with_gaps(20, &[4, 5, 6], |t| [t, t, t])).unwrap();
        assert_eq!(out.missing_count(), 0);
    }

    #[test]
    fn a_long_gap_stops_the_support_search() {
        // Gap 10–11 (filled) next to a long gap 3–8 (not filled): the left support is frame 9
        // only; the long gap's far side (0–2) must not be used. The trajectory jumps by 1000 mm
        // inside the long gap, so using frames 0–2 would pull the fill far off the line.
        let f = |t: f64| if t < 5.0 { [1000.0 + t, 0.0, 0.0] } else { [t, 0.0, 0.0] };
        let out =
            stage(GapFillMethod::Cubic, 3.0).fill(&with_gaps(20, &[3, 4, 5, 6, 7, 8, 10, 11], f));
        assert!(
            (out[10][0] - 10.0).abs() < 1e-9 && (out[11][0] - 11.0).abs() < 1e-9,
            "{:?}",
            &out[9..13]
        );
        assert!(out[5][0].is_nan());
    }

    #[test]
    fn edge_gaps_are_left_or_held_and_an_empty_marker_stays_missing() {
        let m = motion_from_fn(10, 100.0, 2, |i, k| {
            if k == 1 || !(2..=7).contains(&i) { [f64::NAN; 3] } else { [i as f64, 0.0, 0.0] }
        });
        let left = stage(GapFillMethod::Cubic, 5.0).apply(m.clone()).unwrap();
        assert_eq!(
            left.missing_count(),
            m.missing_count(),
            "ends untouched, empty marker untouched"
        );
        let hold = FillGapsParams {
            edges: EdgeFill::Hold,
            max_gap: TimeSpan::Frames(5.0),
            ..FillGapsParams::default_for_tests()
        };
        let held = hold.check().unwrap().apply(m.clone()).unwrap();
        assert_eq!(held.position(0, 0), [2.0, 0.0, 0.0]);
        assert_eq!(held.position(9, 0), [7.0, 0.0, 0.0]);
        assert_eq!(held.missing_count(), 10, "marker 1 is missing everywhere and stays so");
        // Holding also respects max_gap.
        let short = FillGapsParams {
            edges: EdgeFill::Hold,
            max_gap: TimeSpan::Frames(1.0),
            ..FillGapsParams::default_for_tests()
        };
        assert_eq!(short.check().unwrap().apply(m).unwrap().missing_count(), 14);
    }

    #[test]
    fn documented_in_the_registry() {
        let entry = motionlab_core::registry::find("fill_gaps").unwrap();
        assert_eq!(entry.kind, motionlab_core::StageKind::Preprocessor);
        assert!(entry.doc().contains("Missing samples"));
        let names: Vec<String> = entry.params().iter().map(|p| p.name.clone()).collect();
        assert_eq!(names, ["max_gap", "method", "support", "edges"]);
        for p in entry.params() {
            assert!(!p.description.is_empty() && p.default.is_some(), "{p:?}");
        }
        let problems: Vec<String> = motionlab_core::registry::check_registry()
            .into_iter()
            .filter(|p| p.contains("\"fill_gaps\""))
            .collect();
        assert!(problems.is_empty(), "{problems:?}");
    }

    #[test]
    fn registered_with_validated_parameters() {
        let v: toml::Value =
            toml::from_str("max_gap = { frames = 12 }\nmethod = \"linear\"").unwrap();
        assert!(build_preprocessor("fill_gaps", &v).is_ok());
        let field = |t: &str| {
            let v: toml::Value = toml::from_str(t).unwrap();
            build_preprocessor("fill_gaps", &v)
                .err()
                .map(|e| (e.kind(), e.location().field.clone().unwrap_or_default()))
        };
        assert_eq!(
            field("max_gap = { frames = 0 }"),
            Some((ErrorKind::OutOfRange, "max_gap".into()))
        );
        assert_eq!(field("support = 1"), Some((ErrorKind::OutOfRange, "support".into())));
        assert_eq!(field("method = \"spline\"").map(|f| f.0), Some(ErrorKind::WrongType));
        assert_eq!(field("max_gaps = { frames = 3 }").map(|f| f.0), Some(ErrorKind::UnknownKey));
        let p: FillGapsParams = parse_params(&motionlab_core::registry::default_params()).unwrap();
        assert_eq!(
            (p.max_gap, p.method, p.support, p.edges),
            (TimeSpan::Seconds(0.2), GapFillMethod::Cubic, 4, EdgeFill::Leave)
        );
    }

    fn load_tsv(name: &str) -> Motion {
        use motionlab_core::Loader;
        let loader =
            motionlab_io::qualisys_tsv::QualisysTsvParams { up_axis: motionlab_core::Axis::Z }
                .check()
                .unwrap();
        loader.load(&motionlab_testkit::data_path(&format!("mct/{name}.tsv.gz"))).unwrap()
    }

    fn distance(a: Point3, b: Point3) -> f64 {
        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
    }

    /// mct/walk1 has 27 missing samples: Head_FR frames 199–209 (11 frames, 0.18 s at 60 Hz) and
    /// Shoulder_R frames 304–319 (16 frames, 0.27 s). The default 0.2 s fills the first only.
    #[test]
    fn real_walk1_gaps_are_filled_up_to_max_gap_and_keep_the_head_rigid() {
        let walk = load_tsv("walk1");
        assert_eq!(walk.missing_count(), 27);
        let head_fr = walk.point_index("Head_FR").unwrap();
        let shoulder_r = walk.point_index("Shoulder_R").unwrap();
        let filled =
            FillGapsParams::default_for_tests().check().unwrap().apply(walk.clone()).unwrap();
        assert_eq!(filled.missing_count(), 16);
        assert!((199..210).all(|f| !filled.is_missing(f, head_fr)));
        assert!((304..320).all(|f| filled.is_missing(f, shoulder_r)));
        // Present samples are untouched.
        for (a, b) in walk.positions().iter().zip(filled.positions()) {
            assert!(a[0].is_nan() || a == b);
        }
        // The head is rigid: Head_FR's distance to the other three head markers at the filled
        // frames stays close to its median over the recorded frames.
        for other in ["Head_FL", "Head_BL", "Head_BR"] {
            let o = walk.point_index(other).unwrap();
            let mut recorded: Vec<f64> = (0..walk.n_frames())
                .filter(|&f| !walk.is_missing(f, head_fr))
                .map(|f| distance(walk.position(f, head_fr), walk.position(f, o)))
                .collect();
            recorded.sort_by(f64::total_cmp);
            let median = recorded[recorded.len() / 2];
            let worst = (199..210)
                .map(|f| {
                    (distance(filled.position(f, head_fr), filled.position(f, o)) - median).abs()
                })
                .fold(0.0, f64::max);
            // Measured: ≤ 0.65 mm, while the recorded distances spread over 2.5–16.6 mm.
            assert!(
                worst < 3.0,
                "{other}: filled Head_FR is {worst} mm off its rigid distance {median}"
            );
        }
        // A longer max_gap fills everything.
        let all = FillGapsParams {
            max_gap: TimeSpan::Seconds(0.3),
            ..FillGapsParams::default_for_tests()
        };
        assert_eq!(all.check().unwrap().apply(walk).unwrap().missing_count(), 0);
    }

    /// A gap-injected copy of a complete real recording (mct/walk2): every marker loses runs of
    /// 12 frames (0.2 s, the default max_gap) every 68 frames; the default fill restores them
    /// all, close to the recorded values (measured RMS: cubic 6.7 mm, linear 19.4 mm — see
    /// `examples/gap_fill_accuracy.rs`).
    #[test]
    fn real_walk2_with_injected_gaps_is_restored_close_to_the_recording() {
        let walk = load_tsv("walk2");
        assert_eq!(walk.missing_count(), 0);
        let (n, m) = (walk.n_frames(), walk.n_points());
        let mut damaged = walk.clone();
        let mut removed = Vec::new();
        for k in 0..m {
            let mut start = 10 + (k * 7) % 68;
            while start + 22 < n {
                for f in start..start + 12 {
                    damaged.positions_mut()[f * m + k] = [f64::NAN; 3];
                    removed.push((f, k));
                }
                start += 68;
            }
        }
        damaged.refresh_missing();
        assert_eq!(damaged.missing_count(), removed.len());
        let rms = |method| {
            let p = FillGapsParams { method, ..FillGapsParams::default_for_tests() };
            let filled = p.check().unwrap().apply(damaged.clone()).unwrap();
            assert_eq!(filled.missing_count(), 0);
            let sum: f64 = removed
                .iter()
                .map(|&(f, k)| distance(filled.position(f, k), walk.position(f, k)).powi(2))
                .sum();
            (sum / removed.len() as f64).sqrt()
        };
        let (cubic, linear) = (rms(GapFillMethod::Cubic), rms(GapFillMethod::Linear));
        assert!(cubic < 10.0, "cubic RMS {cubic} mm");
        assert!(cubic < 0.5 * linear, "cubic RMS {cubic} mm vs linear {linear} mm");
    }

    impl FillGapsParams {
        fn default_for_tests() -> Self {
            parse_params(&motionlab_core::registry::default_params()).unwrap()
        }
    }
}
