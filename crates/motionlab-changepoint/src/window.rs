//! `window`: the sliding-window discrepancy segmenter with ruptures' `Window` semantics
//! (`ruptures/detection/window.py`).

use std::cell::RefCell;
use std::collections::HashMap;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{Error, ErrorKind, Result, SegmenterOutput, Threshold, Trace};

use crate::kernel_cpd::ar::{ArCost, ArDesign, DEFAULT_AR_ORDER, QrFit};
use crate::kernel_cpd::cost::{L2Cost, LinearCost, RbfCost, SegmentCost, rbf_cost_from_block};
use crate::kernel_cpd::{
    CostModel, admissible, bic_penalty, check_ar_order, check_pen_or_n_bkps, cost_min_size, median,
    require_regression_channels, too_short,
};
use crate::signal::{Missing, Normalize, Signal, candidates_from_breakpoints};

/// Change points at the peaks of a sliding-window discrepancy: at each sample k on the grid of
/// multiples of `jump`, the gain of cutting the window of `width` samples centred on k in two,
/// `c(k−w/2, k+w/2) − c(k−w/2, k) − c(k, k+w/2)` (Truong, Oudre & Vayatis, Signal Processing
/// 167, 2020, §5.2.2), exactly as ruptures' `Window(width, model=cost, min_size, jump)` computes
/// and reads it, giving ruptures' breakpoints.
///
/// - The width is rounded down to an even number (ruptures: `2·(width // 2)`); scores exist for
///   grid samples k with `w/2 ≤ k < n − w/2`.
/// - Peaks are strict local maxima over ±`order` scores, `order = max(max(w, 2·min_size) //
///   (2·jump), 1)`, the score sequence wrapping around at its ends (scipy's `argrelmax` with
///   `mode="wrap"`, as ruptures calls it).
/// - Peaks are taken in decreasing score (equal scores: the later sample first). With `n_bkps`
///   the first `n_bkps` peaks are the change points; with `pen`, peaks are added while adding
///   one lowers the total cost of the segmentation by more than `pen`, stopping at the first
///   that does not.
/// - Without `pen` or `n_bkps`, the penalty is the BIC-style one of `kernel_cpd` (see
///   `motionlab describe kernel_cpd`): `log(n)·Σ var` for `l2`, `log(n)` for `rbf`,
///   `log(n)·p·RSS/n` for `linear`, `log(n)·(ar_order + 1)·RSS/n` for `ar`.
/// - Cost `ar` (ruptures' `CostAR`, one channel) fits each half window once and the whole
///   window by merging the two halves' least-squares factorisations.
/// - `normalize = "min_max"` rescales each channel to [0, 1] first (`z_score` standardises).
///
/// **No penalty path, no expected segment length here** (unlike `kernel_cpd` and `bocpd`):
/// `pen` stops a greedy walk down the peaks, not a search for the segmentation optimal at that
/// penalty, so CROPS's path — every segmentation optimal for some penalty, each with the
/// interval it owns — has nothing to recover (a penalty here only sets how far down the one
/// fixed order of peaks the walk goes); and the threshold is a gain in the cost's units, with
/// no segment length in it for a data rate to set. Its settings remain ruptures' and were not
/// chosen on any data; at mocap rates give `pen` or `n_bkps` (and `width` in samples at the
/// data's rate).
///
/// Candidates are ruptures' breakpoints without the final n. The trace `window_discrepancy`
/// holds the score at each grid sample (NaN elsewhere). A series shorter than the width has no
/// score and no candidates, as in ruptures. Missing samples (NaN) are refused (fill them first
/// with `fill_gaps`); a constant series has no change (an error when `n_bkps` asks for some).
/// Costs are computed accurately rather than in numpy's summation order, so peaks whose scores
/// tie to within rounding may be ordered the other way.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct WindowParams {
    /// Window length in samples (rounded down to even, at least 2); ruptures' value.
    #[serde(default = "default_width")]
    pub width: usize,
    /// The segment cost: `l2`, `rbf`, `linear` or `ar` (as in `kernel_cpd`).
    #[serde(default = "default_cost")]
    pub cost: CostModel,
    /// Penalty per change, in the cost's units (> 0). Give `pen` or `n_bkps`, not both.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("x-default" = "the BIC-style penalty of kernel_cpd, computed from the series"))]
    pub pen: Option<f64>,
    /// Number of change points to find.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub n_bkps: Option<usize>,
    /// Minimum segment length in samples: sets the peak neighbourhood (`order`) and the length
    /// check; ruptures' value.
    #[serde(default = "default_min_size")]
    pub min_size: usize,
    /// Scores are computed at the multiples of `jump` (samples); ruptures' value.
    #[serde(default = "default_jump")]
    pub jump: usize,
    /// rbf bandwidth γ in `exp(−γ‖x − y‖²)`, in 1/(signal unit)² (> 0; `rbf` only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("x-default" = "ruptures' median heuristic: 1 / the median squared distance between two samples (1 if that is 0)"))]
    pub gamma: Option<f64>,
    /// Autoregressive order of the `ar` cost, in samples (≥ 1; `ar` only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("x-default" = "4, ruptures' CostAR order"))]
    pub ar_order: Option<usize>,
    /// Per-channel rescaling before scoring: `none`, `min_max` or `z_score`.
    #[serde(default)]
    pub normalize: Normalize,
}

fn default_width() -> usize {
    100
}
fn default_cost() -> CostModel {
    CostModel::L2
}
fn default_min_size() -> usize {
    2
}
fn default_jump() -> usize {
    5
}

/// How the peak search stops.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum WindowStop {
    Penalty(f64),
    Count(usize),
    Bic,
}

/// The validated `window` stage.
#[derive(Clone, Debug, PartialEq)]
pub struct Window {
    /// The even window length used.
    pub width: usize,
    pub cost: CostModel,
    pub stop: WindowStop,
    pub min_size: usize,
    pub jump: usize,
    pub gamma: Option<f64>,
    /// The `ar` cost's order (None for other costs).
    pub ar_order: Option<usize>,
    pub normalize: Normalize,
}

impl ParamGuard for WindowParams {
    type Checked = Window;
    fn check(self) -> Result<Window> {
        let stop = match check_pen_or_n_bkps(self.pen, self.n_bkps)? {
            (Some(p), _) => WindowStop::Penalty(p),
            (None, Some(k)) => WindowStop::Count(k),
            (None, None) => WindowStop::Bic,
        };
        let width = 2 * (self.width / 2);
        let ar_order = check_ar_order(self.cost, self.ar_order)?;
        let cost_min = cost_min_size(self.cost, ar_order);
        if width / 2 < cost_min {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                format!("width is {}, expected at least {} samples (each half window needs {cost_min} for cost {})", self.width, 2 * cost_min, crate::kernel_cpd::cost_name(self.cost)),
            )
            .with_field("width"));
        }
        if self.min_size == 0 {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                "min_size is 0, expected at least 1 sample",
            )
            .with_field("min_size"));
        }
        if self.jump == 0 {
            return Err(Error::new(ErrorKind::OutOfRange, "jump is 0, expected at least 1 sample")
                .with_field("jump"));
        }
        if let Some(g) = self.gamma {
            if self.cost != CostModel::Rbf {
                return Err(Error::new(
                    ErrorKind::InvalidParameter,
                    "gamma is the rbf bandwidth; only cost rbf takes it",
                )
                .with_field("gamma"));
            }
            if !(g.is_finite() && g > 0.0) {
                return Err(Error::new(
                    ErrorKind::OutOfRange,
                    format!("gamma is {g}, expected a finite bandwidth > 0"),
                )
                .with_field("gamma"));
            }
        }
        Ok(Window {
            width,
            cost: self.cost,
            stop,
            min_size: self.min_size,
            jump: self.jump,
            gamma: self.gamma,
            ar_order,
            normalize: self.normalize,
        })
    }
}

/// A cost with its segments remembered (the penalty rule re-adds the same segments).
struct Memo<'c> {
    cost: &'c dyn SegmentCost,
    seen: RefCell<HashMap<(usize, usize), f64>>,
}

impl Memo<'_> {
    fn error(&self, start: usize, end: usize) -> f64 {
        *self.seen.borrow_mut().entry((start, end)).or_insert_with(|| self.cost.error(start, end))
    }
    fn sum_of_costs(&self, breakpoints: &[usize]) -> f64 {
        let mut start = 0;
        let mut total = 0.0;
        for &end in breakpoints {
            total += self.error(start, end);
            start = end;
        }
        total
    }
}

/// The `ar` discrepancy at each k of `inds`: each half window `k−h..k`, `k..k+h` is fitted once
/// (they recur as the other half of a neighbouring k), the whole window by merging the two.
fn ar_scores(design: &ArDesign, inds: &[usize], half: usize) -> Vec<f64> {
    let mut halves: HashMap<usize, QrFit> = HashMap::new();
    inds.iter()
        .map(|&k| {
            let left = match halves.remove(&(k - half)) {
                Some(fit) => fit,
                None => design.fit(k - half, k),
            };
            let right = halves.entry(k).or_insert_with(|| design.fit(k, k + half));
            left.merge(right).cost() - (left.cost() + right.cost())
        })
        .collect()
}

/// Strict local maxima over ±order neighbours, indices wrapping (scipy `argrelmax`, `wrap`).
fn wrapped_strict_maxima(score: &[f64], order: usize) -> Vec<usize> {
    let len = score.len();
    (0..len)
        .filter(|&i| {
            (1..=order).all(|shift| {
                let plus = (i + shift) % len;
                let minus = (i + len - shift % len) % len;
                score[i] > score[plus] && score[i] > score[minus]
            })
        })
        .collect()
}

/// One run of `window`.
#[derive(Clone, Debug, PartialEq)]
pub struct WindowRun {
    /// ruptures' breakpoints: segment ends, the last being n.
    pub breakpoints: Vec<usize>,
    /// The discrepancy at each sample (NaN off the scored grid).
    pub score: Vec<f64>,
    /// The penalty used (None when stopping at `n_bkps`).
    pub pen: Option<f64>,
    /// The rbf bandwidth used (None for other costs).
    pub gamma: Option<f64>,
}

impl Window {
    /// Runs the segmenter on `values` (sample-major, `n_samples × n_channels`).
    pub fn run(&self, values: &[f64], n_channels: usize) -> Result<WindowRun> {
        const STAGE: &str = "window";
        Signal::new(values, n_channels, STAGE, Missing::Refuse)?;
        let normalized = self.normalize.apply(values, n_channels);
        let signal = Signal::new(&normalized, n_channels, STAGE, Missing::Refuse)?;
        require_regression_channels(STAGE, self.cost, &signal)?;
        let n = signal.n_samples;
        let n_bkps = if let WindowStop::Count(k) = self.stop { k } else { 0 };
        if !admissible(n, n_bkps, self.jump, self.min_size) {
            let field = if n_bkps > 0 && admissible(n, 0, self.jump, self.min_size) {
                "n_bkps"
            } else {
                "min_size"
            };
            return Err(too_short(STAGE, n, n_bkps, self.jump, self.min_size, field));
        }
        let mut run =
            WindowRun { breakpoints: vec![n], score: vec![f64::NAN; n], pen: None, gamma: None };
        if signal.is_constant() {
            if n_bkps > 0 {
                return Err(Error::new(
                    ErrorKind::OutOfRange,
                    format!("{STAGE}: the signal is constant, so every split gains nothing and {n_bkps} change point(s) cannot be placed"),
                )
                .with_field("n_bkps"));
            }
            return Ok(run);
        }
        if self.cost == CostModel::Ar && n <= self.ar_order.unwrap_or(DEFAULT_AR_ORDER) {
            // No autoregression row fits in the series (it is shorter than the width too): no
            // score and no change, the documented result for a series shorter than the width.
            if let WindowStop::Penalty(p) = self.stop {
                run.pen = Some(p);
            }
            return Ok(run);
        }
        let l2;
        let linear;
        let rbf;
        let ar;
        let cost: &dyn SegmentCost = match self.cost {
            CostModel::L2 => {
                l2 = L2Cost::new(&signal);
                &l2
            }
            CostModel::Linear => {
                linear = LinearCost::new(signal);
                &linear
            }
            CostModel::Rbf => {
                let gamma = self.gamma.unwrap_or_else(|| median::median_heuristic_gamma(&signal));
                run.gamma = Some(gamma);
                rbf = RbfCost { signal, gamma };
                &rbf
            }
            CostModel::Ar => {
                ar = ArCost {
                    design: ArDesign::new(signal.values, self.ar_order.unwrap_or(DEFAULT_AR_ORDER)),
                };
                &ar
            }
        };
        let half = self.width / 2;
        let inds: Vec<usize> = (0..n)
            .step_by(self.jump)
            .filter(|&k| k >= half && k < n.saturating_sub(half))
            .collect();
        let score: Vec<f64> = if self.cost == CostModel::Ar {
            ar_scores(
                &ArDesign::new(signal.values, self.ar_order.unwrap_or(DEFAULT_AR_ORDER)),
                &inds,
                half,
            )
        } else {
            inds.iter().map(|&k| self.score_at(cost, &signal, run.gamma, k, half)).collect()
        };
        for (&k, &s) in inds.iter().zip(&score) {
            run.score[k] = s;
        }
        let memo = Memo { cost, seen: RefCell::new(HashMap::new()) };
        run.pen = match self.stop {
            WindowStop::Penalty(p) => Some(p),
            WindowStop::Count(_) => None,
            WindowStop::Bic => {
                Some(bic_penalty(self.cost, self.ar_order, &signal, || memo.error(0, n)))
            }
        };
        if score.is_empty() {
            return Ok(run);
        }
        let order = ((self.width.max(2 * self.min_size)) / (2 * self.jump)).max(1);
        let peaks = wrapped_strict_maxima(&score, order);
        // Decreasing score, equal scores the later sample first (ruptures pops from a list
        // sorted by (score, index)).
        let mut peaks: Vec<(f64, usize)> = peaks.into_iter().map(|p| (score[p], inds[p])).collect();
        peaks.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let mut breakpoints = vec![n];
        let mut error = if matches!(self.stop, WindowStop::Count(_)) {
            0.0
        } else {
            memo.sum_of_costs(&breakpoints)
        };
        while let Some((_, bkp)) = peaks.pop() {
            let add = match (self.stop, run.pen) {
                (WindowStop::Count(k), _) => breakpoints.len() - 1 < k,
                (_, Some(pen)) => {
                    let mut with = breakpoints.clone();
                    with.push(bkp);
                    with.sort_unstable();
                    error - memo.sum_of_costs(&with) > pen
                }
                (_, None) => false,
            };
            if !add {
                break;
            }
            breakpoints.push(bkp);
            breakpoints.sort_unstable();
            if !matches!(self.stop, WindowStop::Count(_)) {
                error = memo.sum_of_costs(&breakpoints);
            }
        }
        run.breakpoints = breakpoints;
        Ok(run)
    }

    /// The discrepancy at sample k: `c(k−h, k+h) − (c(k−h, k) + c(k, k+h))`.
    fn score_at(
        &self,
        cost: &dyn SegmentCost,
        signal: &Signal,
        gamma: Option<f64>,
        k: usize,
        half: usize,
    ) -> f64 {
        if let Some(gamma) = gamma {
            // One pass over the window's Gram matrix for all three rbf costs.
            let rbf = RbfCost { signal: *signal, gamma };
            let left = half as f64 + 2.0 * rbf.upper_sum(k - half, k);
            let right = half as f64 + 2.0 * rbf.upper_sum(k, k + half);
            let whole = left + right + 2.0 * rbf.cross_sum(k - half..k, k..k + half);
            return rbf_cost_from_block(2 * half, whole)
                - (rbf_cost_from_block(half, left) + rbf_cost_from_block(half, right));
        }
        cost.error(k - half, k + half) - (cost.error(k - half, k) + cost.error(k, k + half))
    }

    /// Change points of `values` (sample-major, `n_samples × n_channels`): ruptures'
    /// breakpoints without the final n, with the trace `window_discrepancy` and, stopping by a
    /// penalty, the threshold `pen` (the penalty applies to the total cost, not to the score:
    /// drawn for scale only).
    pub fn segment_values(&self, values: &[f64], n_channels: usize) -> Result<SegmenterOutput> {
        let run = self.run(values, n_channels)?;
        let n = run.score.len();
        let mut output = SegmenterOutput {
            candidates: candidates_from_breakpoints(&run.breakpoints, n),
            ..Default::default()
        };
        output.traces.push(Trace::new("window_discrepancy", "", run.score));
        if let Some(pen) = run.pen {
            output.thresholds.push(Threshold {
                name: "pen".into(),
                trace: "window_discrepancy".into(),
                value: pen,
            });
        }
        Ok(output)
    }
}

impl motionlab_core::Segmenter for Window {
    fn consumes(&self) -> motionlab_core::DataKind {
        motionlab_core::DataKind::Channels
    }
    fn segment(
        &self,
        motion: &motionlab_core::Motion,
        _cache: &motionlab_core::FeatureCache,
    ) -> Result<SegmenterOutput> {
        let channels = motion.require_channels("window")?;
        self.segment_values(channels.values(), channels.n_channels())
    }
}

motionlab_core::register_plugin!(Segmenter, WindowParams, "window");

#[cfg(test)]
mod tests {
    use super::*;

    fn params(text: &str) -> Result<Window> {
        let p: WindowParams =
            toml::from_str(text).map_err(|e| Error::new(ErrorKind::UnknownKey, e.to_string()))?;
        p.check()
    }

    fn steps(n: usize, at: &[usize]) -> Vec<f64> {
        let mut rng = fastrand::Rng::with_seed(12);
        (0..n).map(|i| at.iter().filter(|&&a| i >= a).count() as f64 * 4.0 + rng.f64()).collect()
    }

    #[test]
    fn peaks_of_the_discrepancy_are_the_steps() {
        let x = steps(400, &[150, 250]);
        for cost in ["l2", "rbf"] {
            let w = params(&format!("width = 40\ncost = \"{cost}\"")).unwrap();
            let out = w.segment_values(&x, 1).unwrap();
            assert_eq!(out.candidates, vec![150, 250], "{cost}");
            let s = &out.traces[0].values;
            assert!(s[0].is_nan() && s[150] > s[145] && s[150] > s[155]);
            let w = params(&format!("width = 40\ncost = \"{cost}\"\nn_bkps = 1")).unwrap();
            assert_eq!(w.segment_values(&x, 1).unwrap().candidates.len(), 1);
        }
    }

    #[test]
    fn wrapped_maxima_follow_scipy() {
        // Strict: a plateau has no peak; wrapping compares the last score with the first.
        assert_eq!(wrapped_strict_maxima(&[1.0, 3.0, 2.0, 5.0, 4.0], 1), vec![1, 3]);
        assert_eq!(wrapped_strict_maxima(&[5.0, 1.0, 2.0, 1.0, 4.0], 1), vec![0, 2]);
        assert_eq!(wrapped_strict_maxima(&[2.0, 2.0, 1.0], 1), Vec::<usize>::new());
        // An order as long as the sequence compares a score with itself: no peak.
        assert_eq!(wrapped_strict_maxima(&[1.0, 3.0], 2), Vec::<usize>::new());
        assert_eq!(wrapped_strict_maxima(&[3.0], 1), Vec::<usize>::new());
    }

    #[test]
    fn degenerate_inputs() {
        // Shorter than the width: no score, no candidates (ruptures' result).
        let w = params("width = 100").unwrap();
        let out = w.segment_values(&steps(60, &[30]), 1).unwrap();
        assert!(out.candidates.is_empty() && out.traces[0].values.iter().all(|v| v.is_nan()));
        // Constant, NaN, malformed.
        assert!(w.segment_values(&[1.0; 300], 1).unwrap().candidates.is_empty());
        let e = params("n_bkps = 2").unwrap().segment_values(&[1.0; 300], 1).unwrap_err();
        assert_eq!(e.location().field.as_deref(), Some("n_bkps"));
        let mut gap = steps(300, &[100]);
        gap[10] = f64::NAN;
        assert_eq!(w.segment_values(&gap, 1).unwrap_err().kind(), ErrorKind::MissingData);
        for (text, field) in [
            ("width = 1", "width"),
            ("pen = -3.0", "pen"),
            ("pen = 1.0\nn_bkps = 1", "pen"),
            ("jump = 0", "jump"),
            ("gamma = 1.0", "gamma"),
            ("cost = \"linear\"\nwidth = 3", "width"),
        ] {
            assert_eq!(
                params(text).unwrap_err().location().field.as_deref(),
                Some(field),
                "{text}"
            );
        }
        let e = params("n_bkps = 30\nmin_size = 10")
            .unwrap()
            .segment_values(&steps(300, &[100]), 1)
            .unwrap_err();
        assert_eq!(e.location().field.as_deref(), Some("n_bkps"));
    }

    #[test]
    fn degenerate_inputs_with_the_ar_cost_and_normalisation() {
        // Fewer samples than the autoregression order, and shorter than the width: no score, no
        // candidates, the penalty kept.
        let ar = params("width = 20\ncost = \"ar\"\npen = 10.0").unwrap();
        for n in [2, 4, 5, 19] {
            let out = ar.segment_values(&steps(n, &[]), 1).unwrap();
            assert!(
                out.candidates.is_empty() && out.traces[0].values.iter().all(|v| v.is_nan()),
                "n = {n}"
            );
            assert_eq!(out.thresholds[0].value, 10.0);
        }
        assert_eq!(ar.segment_values(&steps(200, &[100]), 1).unwrap().candidates, vec![100]);
        assert!(ar.segment_values(&[2.0; 200], 1).unwrap().candidates.is_empty());
        let mut gap = steps(200, &[100]);
        gap[150] = f64::NAN;
        assert_eq!(ar.segment_values(&gap, 1).unwrap_err().kind(), ErrorKind::MissingData);
        assert_eq!(
            ar.segment_values(&steps(200, &[100]), 2).unwrap_err().location().field.as_deref(),
            Some("cost")
        );
        // min-max normalisation of a constant series leaves zeros: no change.
        let w = params("width = 10\nnormalize = \"min_max\"").unwrap();
        assert!(w.segment_values(&[7.0; 100], 1).unwrap().candidates.is_empty());
    }
}
