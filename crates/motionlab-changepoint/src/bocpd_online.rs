//! `bocpd_online`: `bocpd`'s model deciding change points as the samples arrive.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::streaming::check_sample;
use motionlab_core::{
    Decision, Error, ErrorKind, Result, SegmenterSession, StreamLayout, Streamed,
    StreamingSegmenter, TimeSpan,
};

use crate::bocpd::{BocpdFilter, map_run_length_of};
use crate::{Bocpd, BocpdChangePoints, BocpdModel, BocpdParams, Normalize};

/// Online Bayesian change-point detection: the model of `bocpd` (Adams & MacKay 2007; its
/// Normal-Gamma observation model, constant hazard and the `bocd` package's update as
/// `model = "bocd_package"` — `motionlab describe bocpd` has the formulas), run one sample at
/// a time, deciding a change point the moment the most probable run length falls.
///
/// **Decisions.** After sample u the filter's most probable run length r*_u (the smallest of
/// equal maxima) is known; when r*_u − r*_{u−1} ≤ −`drop_threshold`, sample t = u − 1 — the
/// last sample of the old run, as the TSSB scripts report it and as `bocpd` with
/// `change_points = "run_length_drop"` reports it offline — is a change point, decided at
/// sample u: a detection delay of one sample after the drop, however late the drop itself
/// comes (the run length falls only once the new segment's samples outweigh the old run).
/// These are exactly the offline model's run-length drops (same filter code, same numbers),
/// as long as `max_run_length` is not reached.
///
/// **No rescaling.** `bocpd` standardises each channel with the whole series' mean and spread
/// before the prior applies; a stream has no whole series, so the values are used as given:
/// feed data on the prior's scale, or set `prior_mean` and `prior_beta` to the data's.
///
/// **Memory** is bounded: run lengths beyond `max_run_length` are dropped (and the posterior
/// renormalised) after every sample, so a session holds O(`max_run_length` × channels) numbers
/// however long the stream, and each sample costs as much. `truncate_below` can drop
/// improbable run lengths earlier.
///
/// **Missing samples (NaN)** are unobserved: a missing channel adds nothing to the predictive
/// and leaves its statistics unchanged, while the run length still advances (as `bocpd`).
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct BocpdOnlineParams {
    /// Expected segment length λ in samples (the hazard is 1/λ, ≥ 1); TCPDBench's value.
    #[serde(default = "default_lambda")]
    pub lambda: f64,
    /// Expected segment length in frames or seconds (`{ seconds = 10.0 }`), replacing `lambda`
    /// when given (seconds at the stream's rate).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub expected_segment: Option<TimeSpan>,
    /// Prior mean μ₀ of each channel, in the channel's own units.
    #[serde(default)]
    pub prior_mean: f64,
    /// Prior strength κ₀ of the mean, in pseudo-samples (> 0).
    #[serde(default = "one")]
    pub prior_kappa: f64,
    /// Gamma shape α₀ of the precision (> 0).
    #[serde(default = "one")]
    pub prior_alpha: f64,
    /// Gamma rate β₀ of the precision, in squared channel units (> 0).
    #[serde(default = "one")]
    pub prior_beta: f64,
    /// The conjugate update: `normal_gamma` (Murphy 2007) or `bocd_package` (the `bocd` 0.1.2
    /// package's, whose β update uses κ in place of β).
    #[serde(default)]
    pub model: BocpdModel,
    /// The fall of the most probable run length that makes a change point, in samples (> 0);
    /// the TSSB scripts' value.
    #[serde(default = "default_drop")]
    pub drop_threshold: f64,
    /// Drop the run lengths beyond the last one whose posterior probability is at least this
    /// (and renormalise), in [0, 1); 0 keeps every run length up to `max_run_length`.
    #[serde(default)]
    pub truncate_below: f64,
    /// The longest run length kept, in samples (more than `drop_threshold`): the session's
    /// memory bound.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(extend(
        "x-default" = "10 × the expected segment length, and at least 2 × drop_threshold"
    ))]
    pub max_run_length: Option<usize>,
}

fn default_lambda() -> f64 {
    100.0
}
fn one() -> f64 {
    1.0
}
fn default_drop() -> f64 {
    250.0
}

/// The validated `bocpd_online` stage.
#[derive(Clone, Debug, PartialEq)]
pub struct BocpdOnline {
    /// The model, with `change_points = "run_length_drop"` and no rescaling.
    pub model: Bocpd,
    pub drop_threshold: f64,
    pub max_run_length: Option<usize>,
}

impl ParamGuard for BocpdOnlineParams {
    type Checked = Streamed<BocpdOnline>;
    fn check(self) -> Result<Streamed<BocpdOnline>> {
        let model = BocpdParams {
            // `expected_segment` replaces `lambda` when given (its documented meaning here).
            lambda: if self.expected_segment.is_some() { None } else { Some(self.lambda) },
            expected_segment: self.expected_segment,
            prior_mean: self.prior_mean,
            prior_kappa: self.prior_kappa,
            prior_alpha: self.prior_alpha,
            prior_beta: self.prior_beta,
            normalize: Normalize::None,
            model: self.model,
            change_points: BocpdChangePoints::RunLengthDrop,
            drop_threshold: Some(self.drop_threshold),
            truncate_below: self.truncate_below,
        }
        .check()?;
        if let Some(max) = self.max_run_length
            && max as f64 <= self.drop_threshold
        {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                format!(
                    "max_run_length is {max}, expected more than drop_threshold ({}): the run length could never fall that far",
                    self.drop_threshold
                ),
            )
            .with_field("max_run_length"));
        }
        Ok(Streamed(BocpdOnline {
            model,
            drop_threshold: self.drop_threshold,
            max_run_length: self.max_run_length,
        }))
    }
}

impl BocpdOnline {
    /// The run-length cap at this hazard: `max_run_length`, else 10 expected segments and at
    /// least twice the drop threshold.
    pub fn run_length_cap(&self, hazard: f64) -> usize {
        self.max_run_length.unwrap_or_else(|| {
            ((10.0 / hazard).round() as usize).max((2.0 * self.drop_threshold).ceil() as usize)
        })
    }
}

impl StreamingSegmenter for BocpdOnline {
    fn start(&self, layout: &StreamLayout) -> Result<Box<dyn SegmenterSession>> {
        let d = layout.width();
        if d == 0 {
            return Err(Error::new(
                ErrorKind::EmptySequence,
                "bocpd_online: the stream has no channel, expected at least one",
            ));
        }
        let model = self.model.at_rate(layout.rate.hz());
        model.require_hazard()?;
        let cap = self.run_length_cap(model.hazard);
        Ok(Box::new(BocpdSession {
            filter: BocpdFilter::new(&model, d, Some(cap)),
            d,
            seen: 0,
            last_map: None,
            drop_threshold: self.drop_threshold,
        }))
    }
}

struct BocpdSession {
    filter: BocpdFilter,
    d: usize,
    seen: usize,
    last_map: Option<usize>,
    drop_threshold: f64,
}

impl SegmenterSession for BocpdSession {
    fn width(&self) -> usize {
        self.d
    }
    fn samples_seen(&self) -> usize {
        self.seen
    }
    fn push_sample(&mut self, sample: &[f64], decided: &mut Vec<Decision>) -> Result<()> {
        check_sample(sample, self.d, self.seen, "bocpd_online")?;
        let map = map_run_length_of(self.filter.step(sample));
        if let Some(prev) = self.last_map
            && map as f64 - prev as f64 <= -self.drop_threshold
            && self.seen > 1
        {
            decided.push(Decision { boundary: self.seen - 1, decided_at: self.seen });
        }
        self.last_map = Some(map);
        self.seen += 1;
        Ok(())
    }
}

motionlab_core::register_plugin!(Segmenter, BocpdOnlineParams, "bocpd_online");

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_core::streaming::run_offline;
    use motionlab_core::{Channels, FeatureCache, FrameRate, Motion, Segmenter};

    fn online(text: &str) -> BocpdOnline {
        toml::from_str::<BocpdOnlineParams>(text).unwrap().check().unwrap().0
    }

    /// Three levels with uniform noise, two channels (the second level shifts only the first).
    fn series(n: usize, seed: u64) -> Vec<f64> {
        let mut rng = fastrand::Rng::with_seed(seed);
        (0..n)
            .flat_map(|i| {
                let level = if i < n / 3 {
                    0.0
                } else if i < 2 * n / 3 {
                    6.0
                } else {
                    -3.0
                };
                [level + 0.5 * rng.f64(), 1.0 + 0.5 * rng.f64()]
            })
            .collect()
    }

    #[test]
    fn decisions_are_the_offline_models_run_length_drops_one_sample_later() {
        let rate = FrameRate::new(100.0).unwrap();
        let layout = StreamLayout::channels(vec!["a".into(), "b".into()], rate);
        for (model, seed) in [("normal_gamma", 1), ("bocd_package", 2)] {
            let x = series(900, seed);
            let text = format!(
                "model = \"{model}\"\ndrop_threshold = 40.0\nlambda = 200.0\nmax_run_length = 100000"
            );
            let on = online(&text);
            // One sample at a time, in odd blocks, and all at once: the same decisions.
            let mut s = on.start(&layout).unwrap();
            let mut blocks = Vec::new();
            for chunk in x.chunks(2 * 7) {
                s.push(chunk, &mut blocks).unwrap();
            }
            s.finish(&mut blocks).unwrap();
            let decided = run_offline(&on, &layout, &x).unwrap();
            assert_eq!(blocks, decided);
            // The offline model, run on the whole series with the same settings.
            let offline = Bocpd { normalize: Normalize::None, ..on.model.clone() };
            let run = offline.run(&x, 2).unwrap();
            assert!(!run.candidates.is_empty(), "{model}: the test needs a change");
            let boundaries: Vec<usize> = decided.iter().map(|d| d.boundary).collect();
            assert_eq!(boundaries, run.candidates, "{model}");
            assert!(decided.iter().all(|d| d.decided_at == d.boundary + 1));
            // Each decision is a drop of the offline MAP run length.
            for d in &decided {
                let (a, b) = (run.map_run_length[d.boundary], run.map_run_length[d.decided_at]);
                assert!(b as f64 - a as f64 <= -40.0, "{model}: {a} → {b}");
            }
            // Through the offline adapter, as any segmenter runs.
            let c = Channels::new(vec!["a".into(), "b".into()], vec![String::new(); 2], x.clone())
                .unwrap();
            let m = Motion::from_channels("s", rate, c).unwrap();
            let out = Streamed(on).segment(&m, &FeatureCache::new()).unwrap();
            assert_eq!(out.candidates, run.candidates);
        }
    }

    #[test]
    fn memory_is_bounded_by_the_run_length_cap() {
        let b = online("max_run_length = 300\ndrop_threshold = 100.0");
        let mut f = BocpdFilter::new(&b.model, 1, b.max_run_length);
        let mut rng = fastrand::Rng::with_seed(3);
        let mut longest = 0;
        for _ in 0..5000 {
            f.step(&[rng.f64()]);
            longest = longest.max(f.runs());
        }
        assert_eq!(longest, 301);
        // The default cap: 10 expected segments, at least twice the threshold.
        assert_eq!(online("").run_length_cap(0.01), 1000);
        assert_eq!(online("drop_threshold = 900.0").run_length_cap(0.01), 1800);
        // Below the cap, the capped filter is the exact one.
        let x: Vec<f64> = (0..250).map(|i| if i < 120 { 0.0 } else { 3.0 } + rng.f64()).collect();
        let exact = Bocpd { normalize: Normalize::None, ..b.model.clone() };
        let rows = exact.run_length_posterior(&x, 1).unwrap();
        let mut f = BocpdFilter::new(&b.model, 1, Some(300));
        for (t, row) in rows.iter().enumerate() {
            assert_eq!(f.step(&x[t..t + 1]), &row[..]);
        }
    }

    #[test]
    fn bad_parameters_and_samples_are_one_clear_error() {
        let e = toml::from_str::<BocpdOnlineParams>("max_run_length = 200")
            .unwrap()
            .check()
            .unwrap_err();
        assert_eq!(e.location().field.as_deref(), Some("max_run_length"));
        let e = toml::from_str::<BocpdOnlineParams>("lambda = 0.5").unwrap().check().unwrap_err();
        assert_eq!(e.location().field.as_deref(), Some("lambda"));
        assert!(toml::from_str::<BocpdOnlineParams>("normalize = \"z_score\"").is_err());
        let rate = FrameRate::new(10.0).unwrap();
        let on = online("");
        let mut s = on.start(&StreamLayout::channels(vec!["a".into()], rate)).unwrap();
        let mut d = Vec::new();
        s.push_sample(&[1.0], &mut d).unwrap();
        let e = s.push_sample(&[1.0, 2.0], &mut d).unwrap_err();
        assert!(e.to_string().contains("sample 1 has 2 values, expected 1"), "{e}");
        // NaN is unobserved, not an error.
        s.push_sample(&[f64::NAN], &mut d).unwrap();
        assert_eq!(s.samples_seen(), 2);
        // Seconds resolve at the stream's rate.
        let secs = online("expected_segment = { seconds = 2.0 }");
        assert!(secs.start(&StreamLayout::channels(vec!["a".into()], rate)).is_ok());
        assert_eq!(secs.run_length_cap(1.0 / 20.0), 500);
    }
}
