//! `kernel_cpd`: penalised and binary-segmentation change-point detection with ruptures'
//! costs and searches (Truong, Oudre & Vayatis 2020), giving ruptures' breakpoints.
//!
//! Submodules: `cost` (l2, linear, rbf), `ar` (the autoregressive cost), `median` (the rbf
//! bandwidth), one per search: `pelt` (ruptures `Pelt`), `binseg` (ruptures `Binseg`),
//! `kernel_pelt` (ruptures' C `KernelCPD`).

pub(crate) mod ar;
mod binseg;
pub(crate) mod cost;
pub mod crops;
pub(crate) mod glibc_exp;
mod kernel_pelt;
pub(crate) mod median;
mod pelt;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{Error, ErrorKind, Result, SegmenterOutput, Threshold, Trace};

use crate::signal::{Missing, Normalize, Signal, candidates_from_breakpoints};
use ar::{ArDesign, DEFAULT_AR_ORDER, ar_min_size};
use binseg::{ArGains, DirectGains, RbfGains, Stop, binseg};
use cost::{L2Cost, LinearCost, SegmentCost};
pub use crops::{PathChoice, PathSegmentation};
use kernel_pelt::{CKernel, kernel_pelt, kernel_pelt_solve};
use pelt::{ArEndCosts, DirectEndCosts, RbfEndCosts, pelt, pelt_solve};

/// A segment cost of ruptures.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum CostModel {
    /// Mean change: `Σ_channels Σ (x − segment mean)²` (ruptures `CostL2`; `KernelCPD`'s
    /// `kernel="linear"` under `search = "kernel_pelt"`).
    L2,
    /// Kernel mean change with the Gaussian kernel `exp(−γ‖x − y‖²)`, its exponent clipped to
    /// [0.01, 100] as ruptures does (ruptures `CostRbf`; `KernelCPD`'s `kernel="rbf"`).
    Rbf,
    /// Linear-regression change: the residual sum of squares of channel 0 regressed on the other
    /// channels, no intercept added (ruptures `CostLinear`); needs at least two channels.
    Linear,
    /// Autoregressive change: the residual sum of squares of a least-squares fit of each sample
    /// on the `ar_order` samples before it and an intercept (ruptures `CostAR`, its first
    /// `ar_order` samples padded as ruptures does); one channel only.
    Ar,
}

/// A search of ruptures.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Search {
    /// PELT (Killick, Fearnhead & Eckley 2012) on the grid of multiples of `jump`: ruptures
    /// `Pelt(model=cost, min_size, jump).fit(x).predict(pen)`. Takes `pen`.
    Pelt,
    /// Binary segmentation on the grid of multiples of `jump`: ruptures
    /// `Binseg(model=cost, min_size, jump).fit(x).predict(pen=…)` or `predict(n_bkps=…)`.
    Binseg,
    /// PELT over every sample as ruptures' C implementation runs it: ruptures
    /// `KernelCPD(kernel, min_size).fit(x).predict(pen)` (cost `l2` is its `kernel="linear"`,
    /// `rbf` its `kernel="rbf"`; its Gaussian kernel is clipped in single precision and is
    /// exp(−0.01) on the diagonal). Takes `pen`; `jump` is 1.
    KernelPelt,
}

/// Change points that minimise a segment cost plus a penalty per change (PELT), or found by
/// binary segmentation — ruptures' searches and costs (Truong, Oudre & Vayatis, "Selective
/// review of offline change point detection methods", Signal Processing 167, 2020), giving
/// exactly ruptures' breakpoints.
///
/// **What it returns.** ruptures returns breakpoints as segment ends, the last being n (the
/// number of samples); the candidates here are those ends without n — the first sample of
/// every segment but the first, sorted, never 0 or n. A series with no change has none.
///
/// **Costs** (`cost`): `l2` (a change in the mean of any channel), `rbf` (a change in the
/// distribution, through the kernel mean; the bandwidth `gamma` by ruptures' median heuristic
/// unless given), `linear` (a change in the regression of channel 0 on the others) and `ar` (a
/// change in the autoregressive dynamics of one channel: ruptures' `CostAR`, whose
/// least-squares fits are grown here one row at a time instead of solved from scratch per
/// segment). `l2` and `rbf` use every channel together, as ruptures does.
///
/// **Normalisation** (`normalize`): `min_max` rescales each channel to [0, 1] first — how the
/// TSSB benchmark's scripts feed a fixed penalty a comparable scale; `z_score` standardises.
///
/// **Searches** (`search`): `pelt` and `binseg` are ruptures' `Pelt` and `Binseg`, step for
/// step — candidates on the grid of multiples of `jump`, segments of at least `min_size`
/// samples, ruptures' tie-breaking (PELT: the first minimum; binary segmentation: the larger
/// breakpoint among equal gains, the first segment among equal best gains). `kernel_pelt` is
/// ruptures' C `KernelCPD` PELT, operation for operation. The rbf cost needs no Gram matrix
/// here (ruptures' Python costs store all n² kernel values): running kernel sums keep memory at
/// O(n), so PELT on 100 000 samples fits in a few megabytes.
///
/// **Stopping** (`pen`, `n_bkps` or `penalty`): PELT minimises `Σ cost + pen × (number of
/// segments)`; binary segmentation adds a breakpoint while its gain exceeds `pen`, or until
/// `n_bkps` breakpoints. `pen = "bic"` is a BIC-style penalty (Schwarz 1978), the one ruptures'
/// documentation suggests, `pen = log(n) · σ²` per parameter, with the variance measured on the
/// whole series — never tuned on any data: `l2`: `log(n) · Σ_channels var` (the cost of the
/// whole series divided by n: each channel's mean is one parameter with its own variance);
/// `rbf`: `log(n)` (the kernel's feature-space variance is at most k(x, x) = 1); `linear`:
/// `log(n) · p · RSS/n` (p covariates, the residual variance of one fit to the whole series);
/// `ar`: `log(n) · (ar_order + 1) · RSS/n` (the same with the lags and the intercept). With none
/// of the three given, binary segmentation stops at that penalty, and the PELT searches choose
/// on the penalty path from it to the whole series' cost by the rule below (see "When nothing
/// is given").
///
/// **A penalty path** (`penalty = { path = [min, max] }`, searches `pelt` and `kernel_pelt`):
/// instead of one penalty, every segmentation that is optimal for some penalty in
/// `[min, max]`, each with the penalty interval it owns and its unpenalised cost, by CROPS
/// (Haynes, Eckley & Fearnhead, "Computationally efficient changepoint detection for a range
/// of penalties", JCGS 26(1), 2017) — about two PELT runs per segmentation on the path, the
/// same segmentations and interval ends as ruptures-rs 0.1.1's `Crops` (checked in CI on TSSB
/// series). The candidates are then the segmentation `choose` picks on the path: `elbow` (the
/// elbow of the cost against the number of change points, by the Kneedle rule of Satopää et
/// al. 2011: both rescaled to [0, 1] over the path, the point farthest below the chord joining
/// its ends; with fewer than three segmentations, the one with fewest change points), `bic`
/// (the one optimal at the BIC-style penalty below, or at the nearer end of the range) or
/// `widest` (the one optimal over the widest span of log-penalty). The ends of the range may
/// be `"bic"` (the BIC-style penalty below) and `"whole_cost"` (the cost of the whole series
/// as one segment, where the path reaches no change; when that cost is no more than the
/// BIC-style penalty, the path is the one segment). The whole path, as a table: a run's
/// `penalty_path` (with a figure of cost against number of change points, the chosen point
/// marked) and Python's `motionlab.penalty_path(values, path, choose, …)`.
///
/// **When nothing is given** (no `pen`, `n_bkps` or `penalty`; searches `pelt` and
/// `kernel_pelt`): the candidates are chosen on the path from `"bic"` to `"whole_cost"` by the
/// rule the note of `penalty` names (`motionlab describe kernel_cpd`). Why: at motion
/// capture rates the BIC-style penalty alone cuts every few frames (417 change points on the
/// four limb speeds of seven labelled CMU takes at 120 Hz, 35 true). How it was chosen — a
/// written protocol, `experiments/changepoint_defaults.toml`, run by `motionlab run
/// experiments/changepoint_defaults.toml`: the seven labelled takes of `mocap_benchmark` (CMU 86_01,
/// 86_09, and 13_29–13_31, 14_14, 14_20 of mocap6; never TSSB or other evaluation data), the
/// four limb speeds (`marker_speed` of both hands and feet); the candidates `bic` (the
/// segmentation at the BIC-style penalty: the earlier behaviour), `elbow` and `widest` on the
/// path from `"bic"` to `"whole_cost"`; the one with the best mean segment covering
/// (TCPDBench's) over the takes, the first in that order among equal means. Its honest estimate
/// is leave-one-take-out: each take scored at the rule chosen on the other six, beside chance
/// (as many change points drawn uniformly). Outcome (the run of record, `heldout_covering`):
/// `elbow`, chosen in every fold; held out, mean covering 0.588 against 0.512 by chance (p =
/// 0.006), with 100 change points for the 35 true, where the BIC-style penalty alone scored
/// 0.282 against 0.281 (p = 0.46) with 417; `widest` kept no change on any take (0.184). Those
/// takes are listed by SHA-256 at the end of `motionlab describe`, so an evaluation table's
/// `parameters_chosen` says `tuned on this sequence (oracle)` for them and `held-out` for any
/// other. The TSSB benchmark's run of record keeps ruptures' BIC-style penalty written out.
///
/// **Degenerate inputs.** Missing samples (NaN) are refused (one error naming the first; fill
/// them first with `fill_gaps`). A constant series has no change: no candidates when stopping
/// by a penalty, an error when `n_bkps` asks for some. A series too short for `min_size` (and
/// `n_bkps`, `jump`) is an error, where ruptures raises `BadSegmentationParameters`; binary
/// segmentation asked for more breakpoints than admissible splits exist returns the ones it
/// found, as ruptures does.
///
/// **Where ruptures can differ**: costs here are computed accurately (double-double prefix sums
/// for `l2`, running kernel sums for `rbf`) rather than in numpy's summation order, so
/// segmentations whose penalised costs tie to within rounding may be broken the other way;
/// `kernel_pelt` reproduces ruptures' C arithmetic and cannot differ. ruptures under Python ≥ 3.12
/// adds PELT totals with a compensated `sum`, a change of the same size.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
#[schemars(extend("x-defaults-tuned-on" = MOCAP_DEFAULTS_CHOSEN_ON))]
pub struct KernelCpdParams {
    /// The search: `pelt`, `binseg` or `kernel_pelt` (`kernel_pelt` with `rbf` is ruptures'
    /// `KernelCPD` with its rbf kernel, the common untuned kernel baseline).
    #[serde(default = "default_search")]
    pub search: Search,
    /// The segment cost: `l2`, `rbf`, `linear` or `ar` (`kernel_pelt` takes `l2` or `rbf`).
    #[serde(default = "default_cost")]
    pub cost: CostModel,
    /// Penalty per change: a number in the cost's units (> 0), or `"bic"` (the BIC-style
    /// penalty described above, computed from the series). Give one of `pen`, `n_bkps` and
    /// `penalty`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("x-default" = "unset: see penalty"))]
    pub pen: Option<Pen>,
    /// A penalty path instead of one penalty: `{ path = [min, max], choose = "elbow" }`, the
    /// penalties in the cost's units (0 < min < max), `choose` one of `elbow`, `bic`, `widest`
    /// (see above); searches `pelt` and `kernel_pelt`. Not with `pen` or `n_bkps`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("x-default" = "with neither pen nor n_bkps: searches pelt and kernel_pelt take { path = [\"bic\", \"whole_cost\"], choose = \"elbow\" }, the rule the protocol above chose at mocap rates; binseg stops at the BIC-style penalty"))]
    pub penalty: Option<PenaltyPath>,
    /// Number of change points to find (binary segmentation only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub n_bkps: Option<usize>,
    /// Minimum segment length in samples (raised to the cost's own minimum: 2 for `linear`,
    /// max(5, `ar_order` + 1) for `ar`, 1 otherwise); ruptures' value.
    #[serde(default = "default_min_size")]
    pub min_size: usize,
    /// Candidate breakpoints are the multiples of `jump` (samples); `kernel_pelt` takes only 1.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("x-default" = "5 for pelt and binseg (ruptures' value), 1 for kernel_pelt"))]
    pub jump: Option<usize>,
    /// rbf bandwidth γ in `exp(−γ‖x − y‖²)`, in 1/(signal unit)² (> 0; `rbf` only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("x-default" = "ruptures' median heuristic: 1 / the median squared distance between two samples (1 if that is 0)"))]
    pub gamma: Option<f64>,
    /// Autoregressive order of the `ar` cost, in samples (≥ 1; `ar` only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend("x-default" = "4, ruptures' CostAR order"))]
    pub ar_order: Option<usize>,
    /// Per-channel rescaling before the search: `none`, `min_max` or `z_score`.
    #[serde(default)]
    pub normalize: Normalize,
}

/// `penalty = { path = [min, max], choose = "elbow" }`: a range of penalties and the rule that
/// picks one segmentation on its path.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PenaltyPath {
    /// The lowest and highest penalty per change: numbers in the cost's units (0 < min < max),
    /// or `"bic"` (the BIC-style penalty of the series) and `"whole_cost"` (the cost of the
    /// whole series as one segment: at that penalty no change pays, so a path ending there
    /// reaches the segmentation without change).
    pub path: [PathEnd; 2],
    /// The rule that picks the segmentation on the path: `elbow`, `bic` or `widest`.
    #[serde(default)]
    pub choose: PathChoice,
}

/// A penalty per change: a number, or `"bic"`.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize, Serialize, JsonSchema)]
#[serde(untagged)]
pub enum Pen {
    /// A penalty in the cost's units.
    Value(f64),
    /// `"bic"`: the BIC-style penalty of the series.
    Named(BicPenalty),
}

/// The BIC-style penalty, by name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum BicPenalty {
    /// The BIC-style penalty described above.
    Bic,
}

/// One end of a penalty path: a number, or a penalty computed from the series.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize, Serialize, JsonSchema)]
#[serde(untagged)]
pub enum PathEnd {
    /// A penalty in the cost's units.
    Value(f64),
    /// `"bic"` or `"whole_cost"`.
    Named(NamedPenalty),
}

/// A penalty computed from the series.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum NamedPenalty {
    /// The BIC-style penalty described above.
    Bic,
    /// The cost of the whole series as one segment.
    WholeCost,
}

/// The rule on the penalty path from `"bic"` to `"whole_cost"` that `kernel_cpd` uses when
/// given neither `pen`, `n_bkps` nor `penalty` (searches `pelt` and `kernel_pelt`), chosen by
/// leave-one-take-out on the seven labelled mocap takes (`experiments/changepoint_defaults.toml`).
pub const MOCAP_PATH_CHOICE: PathChoice = PathChoice::Elbow;

/// The inputs the defaults of `kernel_cpd` and `bocpd` were chosen on
/// (`experiments/changepoint_defaults.toml`): SHA-256 of CMU 86_01, 86_09 and mocap6 13_29, 13_30,
/// 13_31, 14_14, 14_20 as shipped in `data/` (the digests `motionlab-segment` lists for the
/// Sonoda stages, tuned on the same takes). In both plugins' schemas
/// ([`motionlab_core::registry::DEFAULTS_TUNED_ON_KEY`]), so an evaluation at the defaults says
/// per sequence whether it is scored on the takes they were chosen on.
pub const MOCAP_DEFAULTS_CHOSEN_ON: [&str; 7] = [
    "f3d98b96940de9107bc9bfa5a5ecec2a029cdb45713e333d7bc69a0893cfac07",
    "e4baaca37a4e7feb6888083f6d1e2d9307884a834d8bd39a944f8089d99a41f5",
    "5d652718c31a6e56aea62d6057d0257ae1144a414398ad8e1ff9a974ddd59b8a",
    "fe22588ae74eee5e5034cca7ce4f7b5dd5460f96da40c176b3981f8707e87438",
    "0527685d3d25f5fcf2d0b9ba92da6af092379433e9c809d76964892780076c6b",
    "bdeb88b304e912b5b691e89225bef1f8b0fca026eacbd35509e82d929e4afa77",
    "4bb31962cb2a7fd7758f97dfe3778609ada26a5904a51793130808291b5dc72a",
];

fn default_search() -> Search {
    Search::KernelPelt
}
fn default_cost() -> CostModel {
    CostModel::Rbf
}
fn default_min_size() -> usize {
    2
}

/// How the search stops.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StopRule {
    /// A penalty per change.
    Penalty(f64),
    /// A number of change points (binary segmentation).
    Count(usize),
    /// The BIC-style penalty, computed from the series.
    Bic,
    /// Every optimal segmentation for a penalty in `[pen_min, pen_max]` (CROPS), and the one
    /// `choose` picks.
    Path { pen_min: PathEnd, pen_max: PathEnd, choose: PathChoice },
}

/// The validated `kernel_cpd` stage.
#[derive(Clone, Debug, PartialEq)]
pub struct KernelCpd {
    pub search: Search,
    pub cost: CostModel,
    pub stop: StopRule,
    pub min_size: usize,
    pub jump: usize,
    pub gamma: Option<f64>,
    /// The `ar` cost's order (None for other costs).
    pub ar_order: Option<usize>,
    pub normalize: Normalize,
}

/// One run of `kernel_cpd`, with what it resolved from the data.
#[derive(Clone, Debug, PartialEq)]
pub struct KernelCpdRun {
    /// ruptures' breakpoints: segment ends, the last being n.
    pub breakpoints: Vec<usize>,
    /// The penalty used (None when stopping at `n_bkps`).
    pub pen: Option<f64>,
    /// The rbf bandwidth used (None for other costs).
    pub gamma: Option<f64>,
    /// The minimum segment length used (`min_size` raised to the cost's own minimum).
    pub min_size: usize,
    /// Binary segmentation: the gain of splitting the whole series at each sample, NaN off the
    /// admissible grid (None for the PELT searches).
    pub first_split_gain: Option<Vec<f64>>,
    /// With a penalty path: every segmentation on it, fewest change points (highest
    /// penalties) first; `breakpoints` is the one at `chosen`.
    pub path: Option<Vec<PathSegmentation>>,
    /// The index into `path` of the segmentation `choose` picked.
    pub chosen: Option<usize>,
    /// The BIC-style penalty of the series (computed with a penalty path, for `choose = "bic"`
    /// and to show beside the path).
    pub bic_pen: Option<f64>,
}

impl ParamGuard for KernelCpdParams {
    type Checked = KernelCpd;
    fn check(self) -> Result<KernelCpd> {
        let invalid = |field: &str, msg: String| {
            Error::new(ErrorKind::InvalidParameter, msg).with_field(field.to_string())
        };
        let stop = if let Some(spec) = &self.penalty {
            if self.pen.is_some() || self.n_bkps.is_some() {
                return Err(invalid(
                    "penalty",
                    "penalty (a path) replaces pen and n_bkps; give one of them".into(),
                ));
            }
            if self.search == Search::Binseg {
                return Err(invalid(
                        "penalty",
                        "a penalty path needs an exact penalised search (pelt or kernel_pelt); binary segmentation is not optimal for each penalty".into(),
                    ));
            }
            let [lo, hi] = spec.path;
            let bad = |v: PathEnd| matches!(v, PathEnd::Value(x) if !(x.is_finite() && x > 0.0));
            let reversed =
                matches!((lo, hi), (PathEnd::Value(a), PathEnd::Value(b)) if a >= b) || lo == hi;
            if bad(lo) || bad(hi) || reversed {
                return Err(Error::new(
                    ErrorKind::OutOfRange,
                    format!(
                        "penalty.path is [{lo:?}, {hi:?}], expected finite penalties 0 < min < max"
                    ),
                )
                .with_field("penalty.path"));
            }
            StopRule::Path { pen_min: lo, pen_max: hi, choose: spec.choose }
        } else if self.pen == Some(Pen::Named(BicPenalty::Bic)) {
            if self.n_bkps.is_some() {
                return Err(invalid("pen", "give pen or n_bkps, not both".into()));
            }
            StopRule::Bic
        } else {
            let pen = match self.pen {
                Some(Pen::Value(v)) => Some(v),
                _ => None,
            };
            match check_pen_or_n_bkps(pen, self.n_bkps)? {
                (Some(p), None) => StopRule::Penalty(p),
                (_, Some(k)) => {
                    if self.search != Search::Binseg {
                        return Err(invalid(
                            "n_bkps",
                            format!(
                                "search {} stops by a penalty (pen); a number of change points needs search = \"binseg\"",
                                search_name(self.search)
                            ),
                        ));
                    }
                    StopRule::Count(k)
                }
                // Nothing given: the rule chosen at mocap rates (see the docs above), which
                // needs a search optimal at each penalty; binary segmentation keeps the BIC.
                (None, None) if self.search == Search::Binseg => StopRule::Bic,
                (None, None) => StopRule::Path {
                    pen_min: PathEnd::Named(NamedPenalty::Bic),
                    pen_max: PathEnd::Named(NamedPenalty::WholeCost),
                    choose: MOCAP_PATH_CHOICE,
                },
            }
        };
        if self.min_size == 0 {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                "min_size is 0, expected at least 1 sample",
            )
            .with_field("min_size"));
        }
        let jump = match (self.search, self.jump) {
            (_, Some(0)) => {
                return Err(Error::new(
                    ErrorKind::OutOfRange,
                    "jump is 0, expected at least 1 sample",
                )
                .with_field("jump"));
            }
            (Search::KernelPelt, Some(j)) if j != 1 => {
                return Err(invalid(
                    "jump",
                    format!(
                        "jump is {j}; search kernel_pelt (ruptures' KernelCPD) considers every sample, so jump must be 1"
                    ),
                ));
            }
            (Search::KernelPelt, _) => 1,
            (_, Some(j)) => j,
            (_, None) => 5,
        };
        if self.search == Search::KernelPelt && self.cost == CostModel::Linear {
            return Err(invalid(
                "cost",
                "search kernel_pelt takes cost l2 (ruptures' linear kernel) or rbf; the linear-regression cost needs search pelt or binseg".into(),
            ));
        }
        if self.search == Search::KernelPelt && self.cost == CostModel::Ar {
            return Err(invalid("cost", "search kernel_pelt takes cost l2 (ruptures' linear kernel) or rbf; the autoregressive cost needs search pelt or binseg".into()));
        }
        if let Some(g) = self.gamma {
            if self.cost != CostModel::Rbf {
                return Err(invalid(
                    "gamma",
                    format!("gamma is the rbf bandwidth; cost {} has none", cost_name(self.cost)),
                ));
            }
            if !(g.is_finite() && g > 0.0) {
                return Err(Error::new(
                    ErrorKind::OutOfRange,
                    format!("gamma is {g}, expected a finite bandwidth > 0"),
                )
                .with_field("gamma"));
            }
        }
        let ar_order = check_ar_order(self.cost, self.ar_order)?;
        Ok(KernelCpd {
            search: self.search,
            cost: self.cost,
            stop,
            min_size: self.min_size,
            jump,
            gamma: self.gamma,
            ar_order,
            normalize: self.normalize,
        })
    }
}

/// `pen` (finite, > 0) or `n_bkps`, not both.
pub(crate) fn check_pen_or_n_bkps(
    pen: Option<f64>,
    n_bkps: Option<usize>,
) -> Result<(Option<f64>, Option<usize>)> {
    match (pen, n_bkps) {
        (Some(_), Some(_)) => {
            Err(Error::new(ErrorKind::InvalidParameter, "give pen or n_bkps, not both")
                .with_field("pen"))
        }
        (Some(p), None) if !(p.is_finite() && p > 0.0) => Err(Error::new(
            ErrorKind::OutOfRange,
            format!("pen is {p}, expected a finite penalty > 0"),
        )
        .with_field("pen")),
        other => Ok(other),
    }
}

pub(crate) fn cost_name(c: CostModel) -> &'static str {
    match c {
        CostModel::L2 => "l2",
        CostModel::Rbf => "rbf",
        CostModel::Linear => "linear",
        CostModel::Ar => "ar",
    }
}

/// `ar_order` only with cost `ar`, at least 1; the order used (None for other costs).
pub(crate) fn check_ar_order(cost: CostModel, ar_order: Option<usize>) -> Result<Option<usize>> {
    match (cost, ar_order) {
        (CostModel::Ar, None) => Ok(Some(DEFAULT_AR_ORDER)),
        (CostModel::Ar, Some(0)) => Err(Error::new(ErrorKind::OutOfRange, "ar_order is 0, expected at least 1 lag").with_field("ar_order")),
        (CostModel::Ar, Some(p)) => Ok(Some(p)),
        (_, None) => Ok(None),
        (other, Some(_)) => Err(Error::new(
            ErrorKind::InvalidParameter,
            format!("ar_order is the order of the autoregressive cost; cost {} has none (use cost = \"ar\")", cost_name(other)),
        )
        .with_field("ar_order")),
    }
}

/// The cost's own minimum segment length (ruptures' `cost.min_size`).
pub(crate) fn cost_min_size(cost: CostModel, ar_order: Option<usize>) -> usize {
    match cost {
        CostModel::Linear => 2,
        CostModel::Ar => ar_min_size(ar_order.unwrap_or(DEFAULT_AR_ORDER)),
        CostModel::L2 | CostModel::Rbf => 1,
    }
}

fn search_name(s: Search) -> &'static str {
    match s {
        Search::Pelt => "pelt",
        Search::Binseg => "binseg",
        Search::KernelPelt => "kernel_pelt",
    }
}

/// ruptures' median-heuristic rbf bandwidth of `values` (sample-major, `n_samples ×
/// n_channels`): 1 / the median squared distance between two samples (1 when that median is 0),
/// the same float ruptures computes, in O(n) memory.
pub fn median_heuristic(values: &[f64], n_channels: usize) -> Result<f64> {
    let signal = Signal::new(values, n_channels, "kernel_cpd", Missing::Refuse)?;
    Ok(median::median_heuristic_gamma(&signal))
}

/// Checks the inlined `exp` of the rbf `kernel_pelt` against the system's on every `stride`-th
/// single-precision argument of the kernel (`exp(−v)`, v in [0.01, 100]): (disagreements,
/// arguments compared); (0, 0) where the system `exp` is not glibc's FMA variant and the
/// system's own is called instead.
#[doc(hidden)]
pub fn verify_inlined_exp(stride: u32) -> (u64, u64) {
    glibc_exp::verify_against_libm(0.01, 100.0, stride)
}

/// ruptures' `sanity_check`: can `n_bkps` breakpoints on the `jump` grid leave segments of
/// `min_size` in `n` samples?
pub(crate) fn admissible(n: usize, n_bkps: usize, jump: usize, min_size: usize) -> bool {
    n_bkps <= n / jump && n_bkps * min_size.div_ceil(jump) * jump + min_size <= n
}

/// The error for a series that fails ruptures' sanity check.
pub(crate) fn too_short(
    stage: &str,
    n: usize,
    n_bkps: usize,
    jump: usize,
    min_size: usize,
    field: &str,
) -> Error {
    let kind = if n_bkps == 0 || field == "min_size" {
        ErrorKind::EmptySequence
    } else {
        ErrorKind::OutOfRange
    };
    Error::new(
        kind,
        format!(
            "{stage}: {n} samples cannot hold {n_bkps} breakpoint(s) on the jump-{jump} grid with segments of at least min_size = {min_size} samples"
        ),
    )
    .with_field(field.to_string())
}

/// The BIC-style penalty of the parameter docs.
pub(crate) fn bic_penalty(
    cost: CostModel,
    ar_order: Option<usize>,
    signal: &Signal,
    whole_cost: impl FnOnce() -> f64,
) -> f64 {
    let n = signal.n_samples as f64;
    match cost {
        CostModel::L2 => n.ln() * whole_cost() / n,
        CostModel::Rbf => n.ln(),
        CostModel::Linear => n.ln() * (signal.n_channels - 1) as f64 * whole_cost() / n,
        CostModel::Ar => {
            n.ln() * (ar_order.unwrap_or(DEFAULT_AR_ORDER) + 1) as f64 * whole_cost() / n
        }
    }
}

pub(crate) fn require_regression_channels(
    stage: &str,
    cost: CostModel,
    signal: &Signal,
) -> Result<()> {
    if cost == CostModel::Ar && signal.n_channels != 1 {
        return Err(Error::new(
            ErrorKind::InvalidParameter,
            format!(
                "{stage}: cost ar fits an autoregression to one channel, and this signal has {} channels; select one channel first",
                signal.n_channels
            ),
        )
        .with_field("cost"));
    }
    if cost == CostModel::Linear && signal.n_channels < 2 {
        return Err(Error::new(
            ErrorKind::InvalidParameter,
            format!(
                "{stage}: cost linear regresses channel 0 on the other channels, and this signal has {} channel; use l2 or rbf, or add covariate channels",
                signal.n_channels
            ),
        )
        .with_field("cost"));
    }
    Ok(())
}

impl KernelCpd {
    /// Runs the search on `values` (sample-major, `n_samples × n_channels`) and returns
    /// ruptures' breakpoints with the penalty and bandwidth it resolved.
    pub fn run(&self, values: &[f64], n_channels: usize) -> Result<KernelCpdRun> {
        const STAGE: &str = "kernel_cpd";
        Signal::new(values, n_channels, STAGE, Missing::Refuse)?;
        let normalized = self.normalize.apply(values, n_channels);
        let signal = Signal::new(&normalized, n_channels, STAGE, Missing::Refuse)?;
        require_regression_channels(STAGE, self.cost, &signal)?;
        let n = signal.n_samples;
        let min_size = self.min_size.max(cost_min_size(self.cost, self.ar_order));
        let n_bkps = match (self.search, self.stop) {
            (Search::KernelPelt, _) => 1,
            (_, StopRule::Count(k)) => k,
            _ => 0,
        };
        if !admissible(n, n_bkps, self.jump, min_size) {
            let field = if matches!(self.stop, StopRule::Count(_))
                && admissible(n, 0, self.jump, min_size)
            {
                "n_bkps"
            } else {
                "min_size"
            };
            return Err(too_short(STAGE, n, n_bkps, self.jump, min_size, field));
        }
        let mut result = KernelCpdRun {
            breakpoints: vec![n],
            pen: None,
            gamma: None,
            min_size,
            first_split_gain: None,
            path: None,
            chosen: None,
            bic_pen: None,
        };
        if signal.is_constant() {
            if let StopRule::Count(k) = self.stop
                && k > 0
            {
                return Err(Error::new(
                    ErrorKind::OutOfRange,
                    format!("{STAGE}: the signal is constant, so every split gains nothing and {k} change point(s) cannot be placed"),
                )
                .with_field("n_bkps"));
            }
            if let StopRule::Path { pen_min, pen_max, .. } = self.stop {
                // Every penalty gives the one segment, at no cost (a named end: 0).
                let value = |e: PathEnd| match e {
                    PathEnd::Value(v) => v,
                    PathEnd::Named(_) => 0.0,
                };
                result.path = Some(vec![PathSegmentation {
                    pen_min: value(pen_min),
                    pen_max: value(pen_max),
                    breakpoints: vec![n],
                    cost: 0.0,
                }]);
                result.chosen = Some(0);
            }
            return Ok(result);
        }
        let gamma = (self.cost == CostModel::Rbf)
            .then(|| self.gamma.unwrap_or_else(|| median::median_heuristic_gamma(&signal)));
        result.gamma = gamma;
        let ar_order = self.ar_order.unwrap_or(DEFAULT_AR_ORDER);
        let bic = || {
            bic_penalty(self.cost, self.ar_order, &signal, || match self.cost {
                CostModel::L2 => L2Cost::new(&signal).error(0, n),
                CostModel::Linear => LinearCost::new(signal).error(0, n),
                CostModel::Ar => ArDesign::new(signal.values, ar_order).fit(0, n).cost(),
                CostModel::Rbf => 0.0,
            })
        };
        let pen = match self.stop {
            StopRule::Penalty(p) => Some(p),
            StopRule::Count(_) | StopRule::Path { .. } => None,
            StopRule::Bic => Some(bic()),
        };
        result.pen = pen;
        if let StopRule::Path { pen_min, pen_max, choose } = self.stop {
            let bic_pen = bic();
            let resolve = |end: PathEnd| match end {
                PathEnd::Value(v) => v,
                PathEnd::Named(NamedPenalty::Bic) => bic_pen,
                PathEnd::Named(NamedPenalty::WholeCost) => self.whole_cost(signal, gamma, ar_order),
            };
            let reaches_no_change = pen_max == PathEnd::Named(NamedPenalty::WholeCost);
            let (pen_min, pen_max) = (resolve(pen_min), resolve(pen_max));
            if reaches_no_change && pen_min.is_finite() && pen_min > 0.0 && pen_max <= pen_min {
                // The whole series costs no more than one change's penalty: at every penalty
                // of the range no change pays, so the path is the one segment.
                result.path = Some(vec![PathSegmentation {
                    pen_min,
                    pen_max: pen_min,
                    breakpoints: vec![n],
                    cost: pen_max,
                }]);
                result.chosen = Some(0);
                result.bic_pen = Some(bic_pen);
                return Ok(result);
            }
            if !(pen_min.is_finite() && pen_min > 0.0 && pen_max > pen_min) {
                return Err(Error::new(
                    ErrorKind::OutOfRange,
                    format!("{STAGE}: the penalty path resolves to [{pen_min}, {pen_max}] on this series (BIC-style penalty {bic_pen}), expected 0 < min < max"),
                )
                .with_field("penalty.path"));
            }
            let path = self.penalty_path(signal, gamma, ar_order, min_size, pen_min, pen_max);
            let chosen = crops::choose(&path, choose, bic_pen);
            result.breakpoints = path[chosen].breakpoints.clone();
            result.path = Some(path);
            result.chosen = Some(chosen);
            result.bic_pen = Some(bic_pen);
            return Ok(result);
        }
        match self.search {
            Search::KernelPelt => {
                let kernel = match gamma {
                    Some(gamma) => CKernel::Gaussian { gamma },
                    None => CKernel::Linear,
                };
                result.breakpoints = kernel_pelt(&signal, kernel, pen.unwrap_or(0.0), min_size);
            }
            Search::Pelt => {
                let pen = pen.unwrap_or(0.0);
                result.breakpoints = match self.cost {
                    CostModel::L2 => pelt(
                        n,
                        pen,
                        min_size,
                        self.jump,
                        &mut DirectEndCosts(&L2Cost::new(&signal)),
                    ),
                    CostModel::Linear => pelt(
                        n,
                        pen,
                        min_size,
                        self.jump,
                        &mut DirectEndCosts(&LinearCost::new(signal)),
                    ),
                    CostModel::Rbf => pelt(
                        n,
                        pen,
                        min_size,
                        self.jump,
                        &mut RbfEndCosts::new(signal, gamma.unwrap_or(1.0), self.jump),
                    ),
                    CostModel::Ar => pelt(
                        n,
                        pen,
                        min_size,
                        self.jump,
                        &mut ArEndCosts::new(&ArDesign::new(signal.values, ar_order), self.jump),
                    ),
                };
            }
            Search::Binseg => {
                let stop = match (self.stop, pen) {
                    (StopRule::Count(k), _) => Stop::Count(k),
                    (_, Some(p)) => Stop::Penalty(p),
                    (_, None) => Stop::Count(0),
                };
                let found = match self.cost {
                    CostModel::L2 => {
                        binseg(n, stop, min_size, self.jump, &DirectGains(&L2Cost::new(&signal)))
                    }
                    CostModel::Linear => {
                        binseg(n, stop, min_size, self.jump, &DirectGains(&LinearCost::new(signal)))
                    }
                    CostModel::Rbf => binseg(
                        n,
                        stop,
                        min_size,
                        self.jump,
                        &RbfGains { signal, gamma: gamma.unwrap_or(1.0) },
                    ),
                    CostModel::Ar => binseg(
                        n,
                        stop,
                        min_size,
                        self.jump,
                        &ArGains(&ArDesign::new(signal.values, ar_order)),
                    ),
                };
                let mut curve = vec![f64::NAN; n];
                for (b, g) in found.first_gains {
                    curve[b] = g;
                }
                result.breakpoints = found.breakpoints;
                result.first_split_gain = Some(curve);
            }
        }
        Ok(result)
    }

    /// The cost of the whole series as one segment, as this stage's search computes costs.
    fn whole_cost(&self, signal: Signal, gamma: Option<f64>, ar_order: usize) -> f64 {
        let n = signal.n_samples;
        match (self.search, self.cost) {
            (Search::KernelPelt, _) => {
                let kernel = match gamma {
                    Some(gamma) => CKernel::Gaussian { gamma },
                    None => CKernel::Linear,
                };
                kernel_pelt::whole_cost(&signal, kernel)
            }
            (_, CostModel::L2) => L2Cost::new(&signal).error(0, n),
            (_, CostModel::Linear) => LinearCost::new(signal).error(0, n),
            (_, CostModel::Ar) => ArDesign::new(signal.values, ar_order).fit(0, n).cost(),
            (_, CostModel::Rbf) => {
                let mut costs = RbfEndCosts::new(signal, gamma.unwrap_or(1.0), self.jump);
                let mut out = Vec::new();
                pelt::EndCosts::costs(&mut costs, n, &[0], &mut out);
                out[0]
            }
        }
    }

    /// CROPS over this stage's PELT search (the caller has checked the series and the range).
    fn penalty_path(
        &self,
        signal: Signal,
        gamma: Option<f64>,
        ar_order: usize,
        min_size: usize,
        pen_min: f64,
        pen_max: f64,
    ) -> Vec<PathSegmentation> {
        let (n, jump) = (signal.n_samples, self.jump);
        if self.search == Search::KernelPelt {
            let kernel = match gamma {
                Some(gamma) => CKernel::Gaussian { gamma },
                None => CKernel::Linear,
            };
            return crops::crops(pen_min, pen_max, &mut |pen| {
                kernel_pelt_solve(&signal, kernel, pen, min_size)
            });
        }
        match self.cost {
            CostModel::L2 => {
                let cost = L2Cost::new(&signal);
                crops::crops(pen_min, pen_max, &mut |pen| {
                    pelt_solve(n, pen, min_size, jump, &mut DirectEndCosts(&cost))
                })
            }
            CostModel::Linear => {
                let cost = LinearCost::new(signal);
                crops::crops(pen_min, pen_max, &mut |pen| {
                    pelt_solve(n, pen, min_size, jump, &mut DirectEndCosts(&cost))
                })
            }
            CostModel::Rbf => crops::crops(pen_min, pen_max, &mut |pen| {
                let mut costs = RbfEndCosts::new(signal, gamma.unwrap_or(1.0), jump);
                pelt_solve(n, pen, min_size, jump, &mut costs)
            }),
            CostModel::Ar => {
                let design = ArDesign::new(signal.values, ar_order);
                crops::crops(pen_min, pen_max, &mut |pen| {
                    pelt_solve(n, pen, min_size, jump, &mut ArEndCosts::new(&design, jump))
                })
            }
        }
    }

    /// Change points of `values` (sample-major, `n_samples × n_channels`): candidates are
    /// ruptures' breakpoints without the final n. Binary segmentation adds the trace
    /// `first_split_gain` (the gain of splitting the whole series at each sample, NaN off the
    /// grid) and, stopping by a penalty, the threshold `pen` on it.
    pub fn segment_values(&self, values: &[f64], n_channels: usize) -> Result<SegmenterOutput> {
        let run = self.run(values, n_channels)?;
        let n = values.len() / n_channels;
        let mut output = SegmenterOutput {
            candidates: candidates_from_breakpoints(&run.breakpoints, n),
            ..Default::default()
        };
        if let Some(path) = &run.path {
            output.penalty_path = path
                .iter()
                .enumerate()
                .map(|(i, p)| motionlab_core::PathPoint {
                    pen_min: p.pen_min,
                    pen_max: p.pen_max,
                    cost: p.cost,
                    change_points: candidates_from_breakpoints(&p.breakpoints, n),
                    chosen: run.chosen == Some(i),
                })
                .collect();
        }
        if let Some(curve) = run.first_split_gain {
            output.traces.push(Trace::new("first_split_gain", "", curve));
            if let Some(pen) = run.pen {
                output.thresholds.push(Threshold {
                    name: "pen".into(),
                    trace: "first_split_gain".into(),
                    value: pen,
                });
            }
        }
        Ok(output)
    }
}

impl motionlab_core::Segmenter for KernelCpd {
    fn consumes(&self) -> motionlab_core::DataKind {
        motionlab_core::DataKind::Channels
    }
    fn segment(
        &self,
        motion: &motionlab_core::Motion,
        _cache: &motionlab_core::FeatureCache,
    ) -> Result<SegmenterOutput> {
        let channels = motion.require_channels("kernel_cpd")?;
        self.segment_values(channels.values(), channels.n_channels())
    }
}

motionlab_core::register_plugin!(Segmenter, KernelCpdParams, "kernel_cpd");

#[cfg(test)]
mod tests {
    use super::*;

    fn params(toml_text: &str) -> Result<KernelCpd> {
        let p: KernelCpdParams = toml::from_str(toml_text)
            .map_err(|e| Error::new(ErrorKind::UnknownKey, e.to_string()))?;
        p.check()
    }

    fn step_signal(n: usize, at: &[usize], seed: u64) -> Vec<f64> {
        let mut rng = fastrand::Rng::with_seed(seed);
        (0..n).map(|i| at.iter().filter(|&&a| i >= a).count() as f64 * 3.0 + rng.f64()).collect()
    }

    #[test]
    fn defaults_are_kernel_pelt_with_rbf_on_the_path_and_pen_bic_is_ruptures_bic() {
        let k = params("").unwrap();
        let mocap_rule = StopRule::Path {
            pen_min: PathEnd::Named(NamedPenalty::Bic),
            pen_max: PathEnd::Named(NamedPenalty::WholeCost),
            choose: MOCAP_PATH_CHOICE,
        };
        assert_eq!(
            k,
            KernelCpd {
                search: Search::KernelPelt,
                cost: CostModel::Rbf,
                stop: mocap_rule,
                min_size: 2,
                jump: 1,
                gamma: None,
                ar_order: None,
                normalize: Normalize::None
            }
        );
        assert_eq!(params("search = \"pelt\"").unwrap().stop, mocap_rule);
        assert_eq!(params("search = \"pelt\"").unwrap().jump, 5);
        // Binary segmentation has no path: it stops at the BIC-style penalty.
        assert_eq!(params("search = \"binseg\"").unwrap().stop, StopRule::Bic);
        let x = step_signal(300, &[100, 200], 1);
        let run = k.run(&x, 1).unwrap();
        assert!(run.bic_pen == Some(300f64.ln()));
        // The candidates are the chosen member of the path, which ends at the BIC's answer.
        let path = run.path.unwrap();
        let chosen = &path[run.chosen.unwrap()];
        assert_eq!(chosen.breakpoints, run.breakpoints);
        assert_eq!(path.last().unwrap().breakpoints, vec![100, 200, 300]);
        assert_eq!(path[0].breakpoints, vec![300]);
        // pen = "bic" is ruptures' suggested penalty, one PELT run.
        let bic = params("pen = \"bic\"").unwrap();
        assert_eq!(bic.stop, StopRule::Bic);
        let run = bic.run(&x, 1).unwrap();
        assert_eq!(run.pen, Some(300f64.ln()));
        assert!(run.gamma.unwrap() > 0.0 && run.path.is_none());
        assert_eq!(bic.segment_values(&x, 1).unwrap().candidates, vec![100, 200]);
        assert_eq!(
            params("pen = \"bic\"\nsearch = \"binseg\"\nn_bkps = 2")
                .unwrap_err()
                .location()
                .field
                .as_deref(),
            Some("pen")
        );
        assert!(params("pen = \"whole_cost\"").is_err());
        assert_eq!(params("pen = 2.5").unwrap().stop, StopRule::Penalty(2.5));
        // A near-constant series: the whole series costs less than one change's penalty, so
        // the unset rule's path is the one segment (no error, no change).
        // (One sample off by 1e-3: the median distance is 0, so γ = 1, and every kernel value
        // is clipped to exp(−0.01): the whole series costs 0 < log n.)
        let mut flat = vec![1.0; 200];
        flat[50] = 1.001;
        let run = k.run(&flat, 1).unwrap();
        assert_eq!((run.breakpoints.clone(), run.path.map(|p| p.len())), (vec![200], Some(1)));
        assert!(k.segment_values(&flat, 1).unwrap().candidates.is_empty());
    }

    #[test]
    fn every_search_and_cost_finds_clear_steps() {
        let x = step_signal(240, &[80, 160], 2);
        for search in ["pelt", "binseg", "kernel_pelt"] {
            for cost in ["l2", "rbf"] {
                let k = params(&format!(
                    "search = \"{search}\"\ncost = \"{cost}\"\npen = \"bic\"\njump = {}",
                    if search == "kernel_pelt" { 1 } else { 5 }
                ))
                .unwrap();
                assert_eq!(
                    k.segment_values(&x, 1).unwrap().candidates,
                    vec![80, 160],
                    "{search} {cost}"
                );
            }
        }
        let k = params("search = \"binseg\"\nn_bkps = 2").unwrap();
        let out = k.segment_values(&x, 1).unwrap();
        assert_eq!(out.candidates, vec![80, 160]);
        assert_eq!(out.traces[0].values.len(), 240);
        assert!(out.traces[0].values[1].is_nan() && out.traces[0].values[80] > 0.0);
    }

    #[test]
    fn linear_cost_finds_a_slope_change_and_needs_covariates() {
        // y = t on 0..60, then y = 60 − 2(t − 60); covariates: intercept and t.
        let mut x = Vec::new();
        let mut rng = fastrand::Rng::with_seed(5);
        for i in 0..120 {
            let t = i as f64;
            let y = if i < 60 { t } else { 60.0 - 2.0 * (t - 60.0) } + 0.1 * rng.f64();
            x.extend_from_slice(&[y, 1.0, t]);
        }
        let k = params("search = \"pelt\"\ncost = \"linear\"\npen = \"bic\"").unwrap();
        assert_eq!(k.segment_values(&x, 3).unwrap().candidates, vec![60]);
        let e = k.segment_values(&step_signal(50, &[], 1), 1).unwrap_err();
        assert_eq!(e.location().field.as_deref(), Some("cost"));
    }

    #[test]
    fn malformed_parameters_name_their_field() {
        for (text, field) in [
            ("pen = -1.0", "pen"),
            ("pen = 0.0", "pen"),
            ("pen = 1.0\nn_bkps = 2\nsearch = \"binseg\"", "pen"),
            ("n_bkps = 2", "n_bkps"),
            ("min_size = 0", "min_size"),
            ("search = \"pelt\"\njump = 0", "jump"),
            ("jump = 5", "jump"),
            ("cost = \"linear\"", "cost"),
            ("cost = \"l2\"\ngamma = 1.0", "gamma"),
            ("gamma = -2.0", "gamma"),
        ] {
            let e = params(text).unwrap_err();
            assert_eq!(e.location().field.as_deref(), Some(field), "{text}: {e}");
        }
        assert!(params("pelt = 1").is_err());
    }

    #[test]
    fn degenerate_series_give_one_clear_error_or_no_change() {
        let k = params("search = \"binseg\"\nn_bkps = 3\nmin_size = 10\njump = 1").unwrap();
        // 3 breakpoints with min_size 10 need 40 samples.
        let e = k.segment_values(&step_signal(35, &[], 1), 1).unwrap_err();
        assert_eq!(
            (e.kind(), e.location().field.as_deref()),
            (ErrorKind::OutOfRange, Some("n_bkps"))
        );
        assert!(k.segment_values(&step_signal(40, &[20], 1), 1).is_ok());
        // Shorter than min_size itself.
        let e = params("min_size = 10")
            .unwrap()
            .segment_values(&step_signal(15, &[], 1), 1)
            .unwrap_err();
        assert_eq!(
            (e.kind(), e.location().field.as_deref()),
            (ErrorKind::EmptySequence, Some("min_size"))
        );
        // Constant: no change with a penalty, an error when change points are asked for.
        let flat = vec![4.0; 100];
        for search in ["pelt", "kernel_pelt", "binseg"] {
            let k = params(&format!("search = \"{search}\"\ncost = \"l2\"")).unwrap();
            assert!(k.segment_values(&flat, 1).unwrap().candidates.is_empty());
        }
        let e = k.segment_values(&flat, 1).unwrap_err();
        assert_eq!(e.location().field.as_deref(), Some("n_bkps"));
        // NaN gaps and empty input.
        let mut gap = step_signal(100, &[50], 1);
        gap[30] = f64::NAN;
        assert_eq!(
            params("").unwrap().segment_values(&gap, 1).unwrap_err().kind(),
            ErrorKind::MissingData
        );
        assert_eq!(
            params("").unwrap().segment_values(&[], 1).unwrap_err().kind(),
            ErrorKind::EmptySequence
        );
    }

    #[test]
    fn degenerate_series_with_the_ar_cost_and_normalisation() {
        for search in ["pelt", "binseg"] {
            let k = params(&format!("search = \"{search}\"\ncost = \"ar\"\npen = 10.0\njump = 1"))
                .unwrap();
            // Shorter than the cost's own minimum (5 samples for order 4): one error naming min_size.
            let e = k.segment_values(&step_signal(4, &[], 1), 1).unwrap_err();
            assert_eq!(
                (e.kind(), e.location().field.as_deref()),
                (ErrorKind::EmptySequence, Some("min_size")),
                "{search}"
            );
            assert!(k.segment_values(&step_signal(5, &[], 1), 1).unwrap().candidates.is_empty());
            assert!(
                k.segment_values(&[2.0; 100], 1).unwrap().candidates.is_empty(),
                "{search}: constant"
            );
            let mut gap = step_signal(100, &[50], 1);
            gap[70] = f64::NAN;
            assert_eq!(k.segment_values(&gap, 1).unwrap_err().kind(), ErrorKind::MissingData);
            assert_eq!(
                k.segment_values(&step_signal(100, &[50], 1), 2)
                    .unwrap_err()
                    .location()
                    .field
                    .as_deref(),
                Some("cost")
            );
        }
        // min-max normalisation maps a constant channel to zeros (numpy would give NaN): no change.
        for norm in ["min_max", "z_score"] {
            let k = params(&format!("search = \"pelt\"\nnormalize = \"{norm}\"")).unwrap();
            assert!(k.segment_values(&[7.0; 100], 1).unwrap().candidates.is_empty(), "{norm}");
        }
        assert!(params("cost = \"l2\"\nar_order = 2").is_err());
    }

    #[test]
    fn each_path_member_is_what_pelt_finds_inside_its_interval() {
        // Three steps of different heights in noise: the path over a wide range holds several
        // segmentations; PELT at any penalty strictly inside a member's interval finds that
        // member, for every search and cost that takes a path.
        let mut rng = fastrand::Rng::with_seed(11);
        let x: Vec<f64> = (0..400)
            .map(|i| [0.0, 1.5, 0.5, 3.0][i / 100] + 0.6 * rng.f64() + 0.3 * (i as f64 * 0.7).sin())
            .collect();
        for (search, cost, extra) in [
            ("pelt", "l2", "jump = 5"),
            ("pelt", "l2", "jump = 1"),
            ("pelt", "rbf", "jump = 5\ngamma = 2.0"),
            ("pelt", "ar", "jump = 5\nmin_size = 20"),
            ("kernel_pelt", "l2", ""),
            ("kernel_pelt", "rbf", ""),
        ] {
            let base = format!("search = \"{search}\"\ncost = \"{cost}\"\n{extra}");
            let k = params(&format!("{base}\npenalty = {{ path = [0.05, 400.0] }}")).unwrap();
            let run = k.run(&x, 1).unwrap();
            let path = run.path.as_ref().unwrap();
            assert!(path.len() >= 3, "{base}: {path:?}");
            assert_eq!((path[0].pen_max, path[path.len() - 1].pen_min), (400.0, 0.05));
            for (i, p) in path.iter().enumerate() {
                if i > 0 {
                    assert_eq!(p.pen_max, path[i - 1].pen_min, "{base}: contiguous");
                    assert!(p.n_changes() > path[i - 1].n_changes());
                }
                let mid = (p.pen_min * p.pen_max).sqrt();
                let single = params(&format!("{base}\npen = {mid:e}")).unwrap().run(&x, 1).unwrap();
                assert_eq!(single.breakpoints, p.breakpoints, "{base} at pen {mid}");
            }
            assert_eq!(run.breakpoints, path[run.chosen.unwrap()].breakpoints);
        }
        // The steps are found by the elbow on the l2 path.
        let k = params(
            "search = \"pelt\"\ncost = \"l2\"\njump = 1\npenalty = { path = [0.05, 400.0] }",
        )
        .unwrap();
        let out = k.segment_values(&x, 1).unwrap();
        assert_eq!(out.candidates.len(), 3, "{:?}", out.candidates);
        for (c, want) in out.candidates.iter().zip([100, 200, 300]) {
            assert!((*c as i64 - want).abs() <= 3, "{:?}", out.candidates);
        }
        // A constant series: one segmentation over the whole range.
        let run = k.run(&[2.0; 50], 1).unwrap();
        assert_eq!(run.path.unwrap().len(), 1);
        // Malformed paths name their field.
        for (text, field) in [
            ("penalty = { path = [0.0, 1.0] }", "penalty.path"),
            ("penalty = { path = [2.0, 1.0] }", "penalty.path"),
            ("penalty = { path = [1.0, 2.0] }\npen = 1.0", "penalty"),
            ("search = \"binseg\"\npenalty = { path = [1.0, 2.0] }", "penalty"),
        ] {
            let e = params(text).unwrap_err();
            assert_eq!(e.location().field.as_deref(), Some(field), "{text}: {e}");
        }
        assert!(params("penalty = { path = [1.0, 2.0], choose = \"knee\" }").is_err());
        // Named ends: from the BIC-style penalty to the whole series' cost, the path ends at
        // no change and starts at what PELT finds at the BIC penalty.
        for search in ["pelt", "kernel_pelt"] {
            let base = format!("search = \"{search}\"\ncost = \"l2\"");
            let named =
                params(&format!("{base}\npenalty = {{ path = [\"bic\", \"whole_cost\"] }}"))
                    .unwrap()
                    .run(&x, 1)
                    .unwrap();
            let path = named.path.unwrap();
            assert_eq!(path[0].n_changes(), 0, "{search}");
            let at_bic = params(&format!("{base}\npen = \"bic\"")).unwrap().run(&x, 1).unwrap();
            assert_eq!(path.last().unwrap().breakpoints, at_bic.breakpoints, "{search}");
            assert_eq!(path.last().unwrap().pen_min, at_bic.pen.unwrap());
        }
        assert!(params("penalty = { path = [\"bic\", \"bic\"] }").is_err());
        assert!(params("penalty = { path = [\"bic\", \"whole\"] }").is_err());
    }

    #[test]
    fn multichannel_change_in_one_channel_is_found() {
        let mut rng = fastrand::Rng::with_seed(8);
        let x: Vec<f64> = (0..200)
            .flat_map(|i| [rng.f64(), if i < 120 { 0.0 } else { 2.0 } + rng.f64(), rng.f64()])
            .collect();
        for text in [
            "pen = \"bic\"",
            "cost = \"l2\"\npen = \"bic\"",
            "search = \"pelt\"\npen = \"bic\"",
            "search = \"binseg\"\nn_bkps = 1",
        ] {
            assert_eq!(
                params(text).unwrap().segment_values(&x, 3).unwrap().candidates,
                vec![120],
                "{text}"
            );
        }
    }
}
