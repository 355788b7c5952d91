//! `clasp`: ClaSP, the classification score profile segmenter (Ermshaus, Schäfer & Leser,
//! "ClaSP: parameter-free time series segmentation", DMKD 37, 2023), as its reference
//! implementation claspy 0.2.8 computes it (`BinaryClaSPSegmentation().fit_predict`).

mod knn;
mod score;
mod segmentation;
mod suss;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{Error, ErrorKind, Result, SegmenterOutput, Threshold, Trace};

use crate::input;
use segmentation::Settings;

/// Name of the profile trace: per sample, the best accepted ClaSP's score for a change point
/// at that sample (NaN where no ClaSP scored it).
pub const CLASP_TRACE: &str = "clasp_score";

/// How the subsequence width is chosen.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum WindowRule {
    /// SuSS (summary statistics subsequence, claspy's `suss`): per channel, half the width
    /// SuSS finds (at least 3); the smallest over the channels.
    Suss,
}

/// A subsequence width: a rule, or a number of samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize, JsonSchema)]
#[serde(untagged)]
pub enum WindowWidth {
    Rule(WindowRule),
    Samples(usize),
}

/// `"learn"`: the number of segments is decided by the validation (claspy's default).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum SegmentRule {
    Learn,
}

/// The number of segments: learned, or at most this many.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize, JsonSchema)]
#[serde(untagged)]
pub enum SegmentCount {
    Rule(SegmentRule),
    Count(usize),
}

/// The classification score of a split.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Score {
    /// Area under the ROC curve of the cross-validated k-NN predictions (claspy's `roc_auc`).
    RocAuc,
    /// Mean F1 of both sides (claspy's `f1`).
    F1,
}

/// How a candidate change point is accepted.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Validation {
    /// Wilcoxon rank-sum test between the predicted labels left and right of the split;
    /// accepted when p ≤ `threshold`.
    SignificanceTest,
    /// Accepted when the split's score ≥ `threshold`.
    ScoreThreshold,
}

fn default_window() -> WindowWidth {
    WindowWidth::Rule(WindowRule::Suss)
}
fn default_n_segments() -> SegmentCount {
    SegmentCount::Rule(SegmentRule::Learn)
}
fn default_n_estimators() -> usize {
    10
}
fn default_k_neighbours() -> usize {
    3
}
fn default_score() -> Score {
    Score::RocAuc
}
fn default_true() -> bool {
    true
}
fn default_validation() -> Validation {
    Validation::SignificanceTest
}
fn default_excl_radius() -> usize {
    5
}
fn default_random_state() -> u32 {
    2357
}

/// ClaSP: change points where a k-nearest-neighbour classifier best tells the windows before
/// a split from those after it (Ermshaus, Schäfer & Leser, "ClaSP: parameter-free time series
/// segmentation", Data Mining and Knowledge Discovery 37, 1262–1300, 2023).
///
/// Every window of `window` samples is z-normalised and its `k_neighbours` nearest windows
/// found (squared z-normalised Euclidean distance, windows within half a width excluded). For
/// each split point s, the windows are labelled left/right of s, each window's label is
/// predicted by the majority of its neighbours' labels (the `window` windows just before s
/// count as right), and the split is scored (`score`, ROC AUC by default): the ClaSP profile.
/// Its maximum is the candidate change point, accepted by `validation` (a rank-sum test of
/// the predicted labels, p ≤ 1e-15 for one channel, 1e-30 for several). Binary segmentation
/// then splits each part again, best score first, until the validation rejects or
/// `n_segments` is reached; change points lie at least `excl_radius × window` samples from
/// each other and from the ends. Each profile is the best of an ensemble of `n_estimators`
/// ClaSPs over random sub-ranges (temporal constraints), each weighted by its share of the
/// series; with `early_stopping` the ensemble stops at the first accepted or non-improving one.
///
/// **Multichannel input** as claspy: each channel's distances are z-normalised over all
/// windows and averaged before the neighbours are chosen; SuSS takes the smallest channel width.
///
/// **Defaults** are claspy 0.2.8's, which are the paper's (never tuned on a benchmark series).
/// The computation mirrors claspy's numerics (window statistics from running sums, the STOMP
/// dot-product recurrence, pandas' rolling statistics inside SuSS, NumPy's legacy generator
/// for the ensemble's sub-ranges), so profiles agree with claspy's to rounding and change
/// points are identical (`bench/profile_vs_peers.py`; `bench/README.md` lists the exceptions).
///
/// **Degenerate input.** A window whose standard deviation is under 1e-3 (in the series' unit)
/// is treated as claspy does: its deviation is taken as 1. A series shorter than
/// 2 × `excl_radius` × window has no change point and an all-NaN trace (claspy's result); so
/// does a series constant in every channel (where claspy's distances are undefined).
/// **Missing samples** are refused (an error naming the first NaN sample): fill gaps first.
///
/// Trace `clasp_score`: for each sample, the largest score any accepted ClaSP gave a change
/// point there (NaN where none did); with `validation = "score_threshold"` the threshold is
/// drawn on it.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ClaspParams {
    /// Subsequence width in samples, or `"suss"` (learned from the data, as claspy does unless told a width).
    #[serde(default = "default_window")]
    pub window: WindowWidth,
    /// Number of segments: `"learn"` (the validation decides; at most n / (excl_radius ×
    /// window)) or an upper bound.
    #[serde(default = "default_n_segments")]
    pub n_segments: SegmentCount,
    /// ClaSPs in each ensemble (random temporal constraints; the whole series is the first);
    /// at most 1000.
    #[serde(default = "default_n_estimators")]
    pub n_estimators: usize,
    /// Nearest neighbours per window (k of the k-NN classifier).
    #[serde(default = "default_k_neighbours")]
    pub k_neighbours: usize,
    /// Classification score of a split.
    #[serde(default = "default_score")]
    pub score: Score,
    /// Stop an ensemble at its first accepted or non-improving ClaSP.
    #[serde(default = "default_true")]
    pub early_stopping: bool,
    /// How a candidate change point is accepted.
    #[serde(default = "default_validation")]
    pub validation: Validation,
    /// p-value bound of the significance test, or score bound of the score threshold.
    #[serde(default)]
    #[schemars(extend("x-default" = "1e-15 (one channel) or 1e-30 (several) for the significance test, 0.75 for the score threshold"))]
    pub threshold: Option<f64>,
    /// Minimal segment length in windows; must exceed `k_neighbours`.
    #[serde(default = "default_excl_radius")]
    pub excl_radius: usize,
    /// Seed of the ensemble's temporal constraints (NumPy's legacy generator, as claspy).
    #[serde(default = "default_random_state")]
    pub random_state: u32,
}

impl Default for ClaspParams {
    fn default() -> Self {
        ClaspParams {
            window: default_window(),
            n_segments: default_n_segments(),
            n_estimators: default_n_estimators(),
            k_neighbours: default_k_neighbours(),
            score: default_score(),
            early_stopping: true,
            validation: default_validation(),
            threshold: None,
            excl_radius: default_excl_radius(),
            random_state: default_random_state(),
        }
    }
}

/// The validated `clasp` stage.
#[derive(Clone, Debug)]
pub struct Clasp {
    params: ClaspParams,
}

fn invalid(field: &str, message: String) -> Error {
    Error::new(ErrorKind::OutOfRange, message).with_field(field)
}

impl ParamGuard for ClaspParams {
    type Checked = Clasp;
    fn check(self) -> Result<Clasp> {
        if let WindowWidth::Samples(w) = self.window
            && w < 3
        {
            return Err(invalid(
                "window",
                format!("window is {w} samples; expected at least 3 (or \"suss\")"),
            ));
        }
        if let SegmentCount::Count(0) = self.n_segments {
            return Err(invalid(
                "n_segments",
                "n_segments is 0; expected at least 1 (or \"learn\")".into(),
            ));
        }
        if self.n_estimators == 0 || self.n_estimators > 1000 {
            // Each constraint keeps k neighbours per window: the bound keeps that in memory.
            return Err(invalid(
                "n_estimators",
                format!("n_estimators is {}; expected 1 to 1000", self.n_estimators),
            ));
        }
        if self.k_neighbours == 0 {
            return Err(invalid("k_neighbours", "k_neighbours is 0; expected at least 1".into()));
        }
        if self.excl_radius <= self.k_neighbours {
            return Err(Error::new(
                ErrorKind::InvalidParameter,
                format!("excl_radius ({}) must exceed k_neighbours ({}): a minimal segment must hold the k neighbours of a window and the window itself", self.excl_radius, self.k_neighbours),
            )
            .with_field("excl_radius"));
        }
        if let Some(t) = self.threshold {
            let ok = match self.validation {
                Validation::SignificanceTest => t > 0.0 && t <= 1.0,
                Validation::ScoreThreshold => t.is_finite(),
            };
            if !ok {
                return Err(invalid(
                    "threshold",
                    format!(
                        "threshold is {t}; expected a p-value in (0, 1] for the significance test, a finite score for the score threshold"
                    ),
                ));
            }
        }
        Ok(Clasp { params: self })
    }
}

impl Clasp {
    /// The parameters this stage runs with.
    pub fn params(&self) -> &ClaspParams {
        &self.params
    }

    fn settings(&self, window: usize, n_channels: usize) -> Settings {
        let p = &self.params;
        let threshold = p.threshold.unwrap_or(match p.validation {
            Validation::ScoreThreshold => 0.75,
            Validation::SignificanceTest if n_channels == 1 => 1e-15,
            Validation::SignificanceTest => 1e-30,
        });
        Settings {
            window,
            k: p.k_neighbours,
            excl_radius: p.excl_radius,
            n_estimators: p.n_estimators,
            early_stopping: p.early_stopping,
            validation: p.validation,
            threshold,
            score: p.score,
            random_state: p.random_state,
        }
    }

    /// The subsequence width the stage uses on this input: the fixed width, or per channel
    /// max(3, SuSS/2), the smallest over the channels (claspy's rule).
    pub fn window_width(&self, values: &[f64], n_channels: usize) -> Result<usize> {
        let ch = input::channels(values, n_channels, "clasp")?;
        Ok(self.resolve_window(&ch.channels))
    }

    fn resolve_window(&self, channels: &[Vec<f64>]) -> usize {
        match self.params.window {
            WindowWidth::Samples(w) => w,
            WindowWidth::Rule(WindowRule::Suss) => {
                channels.iter().map(|c| (suss::suss(c) / 2).max(3)).min().unwrap_or(10)
            }
        }
    }

    /// Segments `values` (`n_samples × n_channels`, sample-major). Candidates: change-point
    /// sample indices, sorted, unique, inside `(0, n_samples)`. Trace [`CLASP_TRACE`], one
    /// value per sample.
    pub fn segment_values(&self, values: &[f64], n_channels: usize) -> Result<SegmenterOutput> {
        let ch = input::channels(values, n_channels, "clasp")?;
        let n = ch.n_samples;
        let mut trace = vec![f64::NAN; n];
        let mut thresholds = Vec::new();
        if self.params.validation == Validation::ScoreThreshold {
            let t = self.settings(3, n_channels).threshold;
            thresholds.push(Threshold {
                name: "score_threshold".into(),
                trace: CLASP_TRACE.into(),
                value: t,
            });
        }
        let mut candidates = Vec::new();
        if !ch.all_constant() {
            let window = self.resolve_window(&ch.channels);
            let settings = self.settings(window, n_channels);
            let n_segments = match self.params.n_segments {
                SegmentCount::Rule(SegmentRule::Learn) => None,
                SegmentCount::Count(c) => Some(c),
            };
            let slices = ch.slices(0, n);
            let seg = segmentation::binary_segmentation(&slices, &settings, n_segments);
            for (t, &p) in trace.iter_mut().zip(&seg.profile) {
                if p.is_finite() {
                    *t = p;
                }
            }
            candidates = seg.change_points;
        }
        Ok(SegmenterOutput {
            candidates,
            traces: vec![Trace::new(CLASP_TRACE, "", trace)],
            thresholds,
            flagged_frames: Vec::new(),
            penalty_path: Vec::new(),
        })
    }

    /// The profile of one ClaSP (no ensemble, no segmentation) over the whole series with
    /// subsequence width `window`: claspy's `ClaSP(window_size=window, k_neighbours, score,
    /// excl_radius).fit(ts).profile`. One value per split point `0..n - window + 1`, −∞ where
    /// claspy leaves it undefined (within `excl_radius × window` of either end).
    pub fn profile(&self, values: &[f64], n_channels: usize, window: usize) -> Result<Vec<f64>> {
        let ch = input::channels(values, n_channels, "clasp")?;
        if window < 3 {
            return Err(invalid(
                "window",
                format!("window is {window} samples; expected at least 3"),
            ));
        }
        let settings = self.settings(window, n_channels);
        let min_len = 2 * window * self.params.excl_radius;
        if ch.n_samples < min_len {
            return Err(Error::new(
                ErrorKind::EmptySequence,
                format!("clasp: {} samples; a ClaSP with window {window} needs at least 2 × excl_radius × window = {min_len}", ch.n_samples),
            )
            .with_field("values"));
        }
        Ok(segmentation::single_profile(&ch.slices(0, ch.n_samples), &settings))
    }
}

/// claspy's `suss` width of one channel (before ClaSP halves it).
pub(crate) fn suss_width(t: &[f64]) -> usize {
    suss::suss(t)
}

impl motionlab_core::Segmenter for Clasp {
    fn consumes(&self) -> motionlab_core::DataKind {
        motionlab_core::DataKind::Channels
    }
    fn segment(
        &self,
        motion: &motionlab_core::Motion,
        _cache: &motionlab_core::FeatureCache,
    ) -> Result<SegmenterOutput> {
        let channels = motion.require_channels("clasp")?;
        self.segment_values(channels.values(), channels.n_channels())
    }
}

motionlab_core::register_plugin!(Segmenter, ClaspParams, "clasp");

#[cfg(test)]
mod tests {
    use super::*;

    fn stage(toml_text: &str) -> Result<Clasp> {
        let p: ClaspParams = toml::from_str(toml_text)
            .map_err(|e| Error::new(ErrorKind::WrongType, e.to_string()))?;
        p.check()
    }

    /// Two regimes: a sine of period 20 then a sawtooth of period 13, with a little noise.
    fn two_regimes(n: usize, change: usize) -> Vec<f64> {
        (0..n)
            .map(|i| {
                let noise = (((i * 7919) % 101) as f64 / 101.0 - 0.5) * 0.1;
                if i < change {
                    (i as f64 * std::f64::consts::TAU / 20.0).sin() + noise
                } else {
                    (i % 13) as f64 / 6.5 - 1.0 + noise
                }
            })
            .collect()
    }

    #[test]
    fn finds_the_regime_change() {
        let x = two_regimes(1200, 700);
        let out = ClaspParams::default().check().unwrap().segment_values(&x, 1).unwrap();
        assert_eq!(out.candidates.len(), 1, "{:?}", out.candidates);
        assert!((out.candidates[0] as i64 - 700).abs() <= 20, "{:?}", out.candidates);
        let trace = &out.traces[0];
        assert_eq!((trace.name.as_str(), trace.values.len()), (CLASP_TRACE, 1200));
        assert!(trace.values[0].is_nan() && trace.values[700].is_finite());
    }

    #[test]
    fn two_channels_carrying_the_same_change_find_it() {
        let a = two_regimes(1000, 400);
        let b: Vec<f64> = a.iter().map(|v| -2.0 * v + 1.0).collect();
        let values: Vec<f64> = a.iter().zip(&b).flat_map(|(x, y)| [*x, *y]).collect();
        let out = ClaspParams::default().check().unwrap().segment_values(&values, 2).unwrap();
        assert_eq!(out.candidates.len(), 1, "{:?}", out.candidates);
        assert!((out.candidates[0] as i64 - 400).abs() <= 20);
    }

    #[test]
    fn degenerate_inputs_give_documented_results() {
        let c = ClaspParams::default().check().unwrap();
        let flat = c.segment_values(&[2.5; 500], 1).unwrap();
        assert!(flat.candidates.is_empty() && flat.traces[0].values.iter().all(|v| v.is_nan()));
        let short = c.segment_values(&two_regimes(40, 20), 1).unwrap();
        assert!(short.candidates.is_empty() && short.traces[0].values.len() == 40);
        assert_eq!(c.segment_values(&[], 1).err().unwrap().kind(), ErrorKind::EmptySequence);
        let mut gap = two_regimes(300, 150);
        gap[77] = f64::NAN;
        let e = c.segment_values(&gap, 1).err().unwrap();
        assert_eq!(
            (e.kind(), e.location().field.as_deref()),
            (ErrorKind::MissingData, Some("values[77][0]"))
        );
        assert_eq!(
            c.profile(&two_regimes(100, 50), 1, 20).err().unwrap().kind(),
            ErrorKind::EmptySequence
        );
    }

    #[test]
    fn malformed_parameters_name_the_field() {
        for (text, field) in [
            ("window = 2", "window"),
            ("excl_radius = 3", "excl_radius"),
            ("k_neighbours = 0", "k_neighbours"),
            ("n_estimators = 0", "n_estimators"),
            ("n_estimators = 5000", "n_estimators"),
            ("n_segments = 0", "n_segments"),
            ("threshold = 0.0", "threshold"),
        ] {
            let e = stage(text).err().unwrap_or_else(|| panic!("{text} accepted"));
            assert_eq!(e.location().field.as_deref(), Some(field), "{text}");
        }
        assert!(stage("windw = 10").is_err(), "unknown keys are refused");
        assert!(stage("window = \"fft\"").is_err());
        let ok =
            stage("window = 25\nn_segments = 3\nscore = \"f1\"\nvalidation = \"score_threshold\"")
                .unwrap();
        assert_eq!(ok.params().window, WindowWidth::Samples(25));
    }
}
