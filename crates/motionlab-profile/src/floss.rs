//! `floss`: FLUSS, the corrected arc curve of the matrix profile (Gharghabi, Ding, Yeh,
//! Kamgar, Ulanova & Keogh, "Matrix Profile VIII: Domain Agnostic Online Semantic Segmentation
//! at Superhuman Performance Levels", ICDM 2017), as stumpy 1.14 computes it (`stumpy.stump`,
//! `stumpy.fluss`).

mod matrix_profile;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{Error, ErrorKind, Result, SegmenterOutput, Threshold, Trace};

use crate::clasp::{WindowRule, WindowWidth};
use crate::input;
pub use matrix_profile::MatrixProfile;

/// Name of the trace: the corrected arc curve per sample (NaN after the last window).
pub const FLOSS_TRACE: &str = "corrected_arc_curve";

fn default_window() -> WindowWidth {
    WindowWidth::Rule(WindowRule::Suss)
}
fn default_excl_factor() -> usize {
    5
}

/// FLUSS: regime changes where few nearest-neighbour arcs cross (Gharghabi et al., "Matrix
/// Profile VIII: Domain Agnostic Online Semantic Segmentation at Superhuman Performance
/// Levels", ICDM 2017).
///
/// The matrix profile index links every window of `window` samples to its nearest other
/// window (z-normalised Euclidean distance, windows within ⌈window/4⌉ excluded: stumpy's
/// `stump`). The arc curve counts, at each sample, the links that pass over it; divided by
/// the idealised arc curve of a series without regimes — the parabola 2·i·(n − i)/n of the
/// paper, n the number of windows — and capped at 1 it is the corrected arc curve (CAC), low
/// where a regime changes. The first and last `excl_factor × window` values are set to 1
/// (stumpy's edge correction). Regimes are extracted as stumpy's `_rea`: the minimum of the
/// CAC is a change point, the `excl_factor × window` samples on either side of it are set to
/// 1, and so on — `n_regimes − 1` times, or while the minimum is below `cac_threshold`
/// (exactly one of the two must be set: stumpy has no rule for an unknown number of regimes,
/// and the paper leaves the threshold to the application).
///
/// **Defaults**: `excl_factor` is stumpy's; the paper has no default width ("about one
/// period") and stumpy requires one, so `"suss"` takes claspy's data-driven SuSS width
/// (unhalved). None was tuned on a benchmark series.
///
/// **Peer equality**: the matrix profile index is stumpy's (ties broken in stumpy's traversal
/// order) and the CAC is `stumpy.fluss`'s given the same idealised arc curve; stumpy's own
/// default curve is a beta density fitted to random draws — close to the parabola, not equal
/// (`bench/profile_vs_peers.py`).
///
/// **Degenerate input**: one channel only (FLUSS is univariate: select a channel first);
/// flat windows match each other exactly and other windows at half correlation (stumpy's
/// rule); a series with no window outside the exclusion zone, and missing samples, are refused
/// with an error naming the input.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FlossParams {
    /// Subsequence width m in samples, or `"suss"`.
    #[serde(default = "default_window")]
    pub window: WindowWidth,
    /// Number of regimes (change points + 1), as `stumpy.fluss`'s `n_regimes`.
    #[serde(default)]
    pub n_regimes: Option<usize>,
    /// Change points while the CAC's minimum is below this (in (0, 1]).
    #[serde(default)]
    pub cac_threshold: Option<f64>,
    /// Edge and regime exclusion in multiples of the window (stumpy's `excl_factor`; its `L`
    /// is the window).
    #[serde(default = "default_excl_factor")]
    pub excl_factor: usize,
}

/// The validated `floss` stage.
#[derive(Clone, Debug)]
pub struct Floss {
    params: FlossParams,
}

impl ParamGuard for FlossParams {
    type Checked = Floss;
    fn check(self) -> Result<Floss> {
        if let WindowWidth::Samples(w) = self.window
            && w < 3
        {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                format!("window is {w} samples; expected at least 3 (or \"suss\")"),
            )
            .with_field("window"));
        }
        match (self.n_regimes, self.cac_threshold) {
            (Some(_), Some(_)) | (None, None) => {
                return Err(Error::new(ErrorKind::InvalidParameter, "floss needs exactly one of n_regimes (the number of regimes) and cac_threshold (a bound on the corrected arc curve)").with_field("n_regimes"));
            }
            (Some(0), None) => {
                return Err(Error::new(
                    ErrorKind::OutOfRange,
                    "n_regimes is 0; expected at least 1",
                )
                .with_field("n_regimes"));
            }
            (None, Some(t)) if !(t > 0.0 && t <= 1.0) => {
                return Err(Error::new(
                    ErrorKind::OutOfRange,
                    format!("cac_threshold is {t}; expected a value in (0, 1]"),
                )
                .with_field("cac_threshold"));
            }
            _ => {}
        }
        if self.excl_factor == 0 {
            return Err(Error::new(ErrorKind::OutOfRange, "excl_factor is 0; expected at least 1")
                .with_field("excl_factor"));
        }
        Ok(Floss { params: self })
    }
}

/// The matrix profile (nearest-neighbour index and distance of every window of `window`
/// samples) of a univariate series, as `stumpy.stump(values, window)[:, :2]`.
pub fn matrix_profile(values: &[f64], window: usize) -> Result<MatrixProfile> {
    let ch = input::channels(values, 1, "matrix_profile")?;
    matrix_profile::self_join(&ch.channels[0], window)
}

/// The paper's idealised arc curve over `k` windows: 2·i·(k − i)/k.
pub fn idealized_arc_curve(k: usize) -> Vec<f64> {
    (0..k).map(|i| 2.0 * i as f64 * (k - i) as f64 / k as f64).collect()
}

/// The corrected arc curve of a matrix profile index (stumpy's `_cac` with a given idealised
/// arc curve): arc counts over the IAC, capped at 1, the first and last `edge` values 1.
pub fn corrected_arc_curve(index: &[i64], iac: &[f64], edge: usize) -> Vec<f64> {
    let k = index.len();
    let mut marks = vec![0i64; k + 1];
    for (i, &j) in index.iter().enumerate() {
        let j = if j < 0 { i } else { j as usize };
        marks[i.min(j)] += 1;
        marks[i.max(j)] -= 1;
    }
    let mut ac = 0i64;
    let mut cac: Vec<f64> = (0..k)
        .map(|i| {
            ac += marks[i];
            let iac = if iac[i] == 0.0 { 1e-10 } else { iac[i] };
            (ac as f64 / iac).min(1.0)
        })
        .collect();
    let edge = edge.min(k);
    cac[..edge].fill(1.0);
    cac[k - edge..].fill(1.0);
    cac
}

/// stumpy's `_rea`: repeated first minima, each followed by an exclusion of `excl` values on
/// either side; `count` change points, or while the minimum is below `below`.
fn regimes(cac: &[f64], count: Option<usize>, below: Option<f64>, excl: usize) -> Vec<usize> {
    let mut tmp = cac.to_vec();
    let mut out = Vec::new();
    loop {
        if count.is_some_and(|c| out.len() + 1 >= c) || tmp.is_empty() {
            break;
        }
        let mut at = 0;
        for (i, &v) in tmp.iter().enumerate() {
            if v < tmp[at] {
                at = i;
            }
        }
        if below.is_some_and(|t| tmp[at] >= t || tmp[at].is_nan()) {
            break;
        }
        out.push(at);
        let (s, e) = (at.saturating_sub(excl), (at + excl).min(tmp.len()));
        tmp[s..e].fill(1.0);
        if below.is_some() && out.len() > cac.len() {
            break;
        }
    }
    out
}

impl Floss {
    /// The parameters this stage runs with.
    pub fn params(&self) -> &FlossParams {
        &self.params
    }

    /// The subsequence width used on this (univariate) input.
    pub fn window_width(&self, values: &[f64], n_channels: usize) -> Result<usize> {
        let ch = self.channel(values, n_channels)?;
        Ok(self.resolve_window(&ch))
    }

    fn channel(&self, values: &[f64], n_channels: usize) -> Result<Vec<f64>> {
        if n_channels > 1 {
            return Err(Error::new(
                ErrorKind::WrongValueCount,
                format!("floss: {n_channels} channels; FLUSS is univariate, select one channel"),
            )
            .with_field("n_channels"));
        }
        let ch = input::channels(values, n_channels, "floss")?;
        Ok(ch.channels.into_iter().next().unwrap_or_default())
    }

    fn resolve_window(&self, t: &[f64]) -> usize {
        match self.params.window {
            WindowWidth::Samples(w) => w,
            WindowWidth::Rule(WindowRule::Suss) => crate::clasp::suss_width(t).max(3),
        }
    }

    /// Segments a univariate series (`n_channels` must be 1). Candidates: regime-change sample
    /// indices, sorted, unique, inside `(0, n)`. Trace [`FLOSS_TRACE`], one value per sample.
    pub fn segment_values(&self, values: &[f64], n_channels: usize) -> Result<SegmenterOutput> {
        let t = self.channel(values, n_channels)?;
        let w = self.resolve_window(&t);
        let mp = matrix_profile::self_join(&t, w)?;
        let k = mp.index.len();
        let excl = self.params.excl_factor * w;
        let cac = corrected_arc_curve(&mp.index, &idealized_arc_curve(k), excl);
        let mut candidates: Vec<usize> =
            regimes(&cac, self.params.n_regimes, self.params.cac_threshold, excl)
                .into_iter()
                .filter(|&c| c > 0 && c < t.len())
                .collect();
        candidates.sort_unstable();
        candidates.dedup();
        let mut trace = vec![f64::NAN; t.len()];
        trace[..k].copy_from_slice(&cac);
        let thresholds = self
            .params
            .cac_threshold
            .map(|v| Threshold {
                name: "cac_threshold".into(),
                trace: FLOSS_TRACE.into(),
                value: v,
            })
            .into_iter()
            .collect();
        Ok(SegmenterOutput {
            candidates,
            traces: vec![Trace::new(FLOSS_TRACE, "", trace)],
            thresholds,
            flagged_frames: Vec::new(),
            penalty_path: Vec::new(),
        })
    }
}

impl motionlab_core::Segmenter for Floss {
    fn consumes(&self) -> motionlab_core::DataKind {
        motionlab_core::DataKind::Channels
    }
    fn segment(
        &self,
        motion: &motionlab_core::Motion,
        _cache: &motionlab_core::FeatureCache,
    ) -> Result<SegmenterOutput> {
        let channels = motion.require_channels("floss")?;
        self.segment_values(channels.values(), channels.n_channels())
    }
}

motionlab_core::register_plugin!(Segmenter, FlossParams, "floss");

#[cfg(test)]
mod tests {
    use super::*;

    fn stage(text: &str) -> Result<Floss> {
        let p: FlossParams =
            toml::from_str(text).map_err(|e| Error::new(ErrorKind::WrongType, e.to_string()))?;
        p.check()
    }

    #[test]
    fn arc_curve_counts_the_arcs_over_each_sample() {
        // Arcs 0–3, 1–2, 2–1, 3–0, 4–5, 5–4 (stumpy's _nnmark): counts 2, 4, 2, 0, 2, 0.
        let cac = corrected_arc_curve(&[3, 2, 1, 0, 5, 4], &[1.0; 6], 0);
        assert_eq!(cac, vec![1.0, 1.0, 1.0, 0.0, 1.0, 0.0]);
        let cac = corrected_arc_curve(&[3, 2, 1, 0, 5, 4], &[2.0, 4.0, 4.0, 4.0, 4.0, 2.0], 0);
        assert_eq!(cac, vec![1.0, 1.0, 0.5, 0.0, 0.5, 0.0]);
        assert_eq!(corrected_arc_curve(&[1, 0, 3, 2], &[1.0; 4], 1), vec![1.0, 0.0, 1.0, 1.0]);
    }

    #[test]
    fn regime_extraction_as_stumpys_rea() {
        let cac = [1.0, 0.5, 0.2, 0.6, 1.0, 0.9, 0.1, 0.8, 1.0];
        assert_eq!(regimes(&cac, Some(3), None, 2), vec![6, 2]);
        assert_eq!(regimes(&cac, None, Some(0.3), 1), vec![6, 2]);
        assert_eq!(regimes(&cac, None, Some(0.05), 1), Vec::<usize>::new());
    }

    #[test]
    fn finds_a_change_between_two_shapes() {
        let x: Vec<f64> = (0..1500)
            .map(|i| {
                let noise = (((i * 7919) % 101) as f64 / 101.0 - 0.5) * 0.1;
                if i < 800 {
                    (i as f64 * std::f64::consts::TAU / 25.0).sin() + noise
                } else {
                    ((i % 17) as f64 / 8.5 - 1.0) + noise
                }
            })
            .collect();
        let out = stage("window = 25\nn_regimes = 2").unwrap().segment_values(&x, 1).unwrap();
        assert_eq!(out.candidates.len(), 1);
        assert!((out.candidates[0] as i64 - 800).abs() < 30, "{:?}", out.candidates);
        assert_eq!(out.traces[0].name, FLOSS_TRACE);
        assert!(out.traces[0].values[1499].is_nan());
    }

    #[test]
    fn malformed_parameters_and_degenerate_inputs() {
        assert_eq!(
            stage("window = 10").err().unwrap().location().field.as_deref(),
            Some("n_regimes")
        );
        assert_eq!(
            stage("n_regimes = 2\ncac_threshold = 0.5").err().unwrap().location().field.as_deref(),
            Some("n_regimes")
        );
        assert_eq!(
            stage("cac_threshold = 1.5").err().unwrap().location().field.as_deref(),
            Some("cac_threshold")
        );
        assert_eq!(
            stage("window = 1\nn_regimes = 2").err().unwrap().location().field.as_deref(),
            Some("window")
        );
        assert!(stage("n_regime = 2").is_err());
        let f = stage("window = 10\nn_regimes = 3").unwrap();
        assert_eq!(f.segment_values(&[1.0; 12], 1).err().unwrap().kind(), ErrorKind::EmptySequence);
        assert_eq!(
            f.segment_values(&[1.0; 40], 2).err().unwrap().location().field.as_deref(),
            Some("n_channels")
        );
        assert_eq!(f.segment_values(&[], 1).err().unwrap().kind(), ErrorKind::EmptySequence);
        // A constant series: every window matches its nearest flat neighbour, every arc is
        // short, the CAC is low away from the edges and the result is defined.
        let flat = f.segment_values(&[4.0; 300], 1).unwrap();
        assert_eq!(flat.candidates.len(), 2);
    }
}
