//! Segmenters as an experiment names them: built by name, checked against what the datasets
//! give (positions or channels), and — for a segmenter that reads channels on a take with
//! points — with the features that become its channels.
//!
//! ```toml
//! [[segmentation.segmenter]]
//! type = "clasp"
//! input = { features = [{ type = "marker_speed" }], channels = ["lhand_mm_per_s", "rhand_mm_per_s"] }
//! ```
//!
//! `input` is read here, not by the plugin: every channel segmenter gets it the same way, and
//! a segmenter that reads positions refuses it at validation, as a dataset of the wrong kind is
//! refused — before any work.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry;
use motionlab_core::{
    Channels, DataKind, Error, ErrorKind, FeatureCache, FeatureExtractor, Motion, Result,
    Segmenter, SegmenterOutput,
};

use crate::context::{build_stage, deserialize_section};
use crate::spec::StageSpec;
use crate::toml_paths::KeyPath;
use crate::workflow::BuildContext;

/// `input = { … }` of a segmenter that reads channels, on datasets with marker or joint
/// positions: the feature extractors whose per-frame traces become its channels.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ChannelInput {
    /// Feature extractors (`{ type = "marker_speed", … }`), run on each take; their traces,
    /// in order, are the channels.
    pub features: Vec<StageSpec>,
    /// The traces to keep, by name, in this order.
    #[serde(default)]
    #[schemars(extend("x-default" = "every trace of every extractor"))]
    pub channels: Option<Vec<String>>,
    /// What happens to undefined samples of the features (the last frame of a speed, a frame
    /// where every marker is missing): `"linear"` interpolates each channel across a gap and
    /// holds the nearest value before its first and after its last defined sample (the
    /// segmenters refuse NaN); `"none"` hands them on as NaN. A channel with no defined
    /// sample is an error either way.
    #[serde(default)]
    pub fill: FeatureFill,
}

/// How undefined feature samples are filled (see [`ChannelInput::fill`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum FeatureFill {
    #[default]
    Linear,
    None,
}

/// Fills one channel's NaN samples by linear interpolation between defined neighbours,
/// holding the first and last defined values at the ends; false when none is defined.
fn fill_linear(v: &mut [f64]) -> bool {
    let defined: Vec<usize> = (0..v.len()).filter(|&i| !v[i].is_nan()).collect();
    let (Some(&first), Some(&last)) = (defined.first(), defined.last()) else { return false };
    for i in 0..first {
        v[i] = v[first];
    }
    for i in last + 1..v.len() {
        v[i] = v[last];
    }
    for w in defined.windows(2) {
        let (a, b) = (w[0], w[1]);
        for i in a + 1..b {
            let t = (i - a) as f64 / (b - a) as f64;
            v[i] = v[a] + t * (v[b] - v[a]);
        }
    }
    true
}

/// A segmenter with its display name and what it reads.
pub struct NamedSegmenter {
    /// `name = "…"`, else the plugin type; unique in the experiment.
    pub name: String,
    pub stage: Box<dyn Segmenter>,
    /// The features that become its channels (a channel segmenter on positions).
    pub input: Option<FeatureChannels>,
    /// Its type, parameters and input as resolved: its key in the on-disk cache.
    pub cache_key: String,
}

/// Feature extractors whose traces become a segmenter's channels.
pub struct FeatureChannels {
    extractors: Vec<(String, Box<dyn FeatureExtractor>)>,
    channels: Option<Vec<String>>,
    fill: FeatureFill,
}

impl FeatureChannels {
    /// A motion holding the features of `motion` as its channels (and no points): what the
    /// segmenter reads. Errors name the extractor, or the channel that is not a trace.
    pub fn of(&self, motion: &Motion, cache: &FeatureCache) -> Result<Motion> {
        let mut traces = Vec::new();
        for (name, x) in &self.extractors {
            traces.extend(
                x.extract(motion, cache)
                    .map_err(|e| e.under_field(format!("input.features {name}")))?
                    .traces,
            );
        }
        if self.fill == FeatureFill::Linear {
            for t in &mut traces {
                if !fill_linear(&mut t.values) {
                    return Err(Error::new(
                        ErrorKind::MissingData,
                        format!("feature {:?} has no defined sample in {}", t.name, motion.name),
                    )
                    .with_field("input.features"));
                }
            }
        }
        let all = Channels::from_traces(&traces).map_err(|e| e.under_field("input.features"))?;
        let channels = match &self.channels {
            Some(names) => all.select(names).map_err(|e| e.under_field("input.channels"))?,
            None => all,
        };
        let mut out = Motion::from_channels(motion.name.clone(), motion.frame_rate(), channels)?;
        out.source = motion.source.clone();
        out.format = motion.format.clone();
        Ok(out)
    }
}

impl NamedSegmenter {
    /// The segmenter's output on one motion: on its features when it has an `input`, else on
    /// the motion itself.
    pub fn segment(&self, motion: &Motion, cache: &FeatureCache) -> Result<SegmenterOutput> {
        match &self.input {
            Some(input) => self.stage.segment(&input.of(motion, cache)?, cache),
            None => self.stage.segment(motion, cache),
        }
    }
}

/// Builds the segmenters listed at `at` (`segmentation.segmenter`): names unique, each checked
/// against what every dataset gives — a segmenter that reads positions needs datasets with
/// points and refuses `input`; one that reads channels takes a channel file's as they are, and
/// on positions needs `input` (the features that become its channels). Errors point at the
/// file, line and key.
pub fn build_segmenters(
    cx: &BuildContext<'_>,
    specs: &[StageSpec],
    at: &KeyPath,
) -> Result<Vec<NamedSegmenter>> {
    let (source, combo) = (cx.source, cx.combo);
    let mut out: Vec<NamedSegmenter> = Vec::new();
    for (k, spec) in specs.iter().enumerate() {
        let here = at.index(k);
        let name = spec.display_name();
        if out.iter().any(|s| s.name == name) {
            return Err(cx.locate(
                Error::new(
                    ErrorKind::DuplicateName,
                    format!("two segmenters are named {name:?}; give one a `name = \"…\"`"),
                ),
                here,
            ));
        }
        let stage = build_stage(source, combo, spec, &here, registry::build_segmenter)?;
        let (input, input_text) =
            channel_input(cx, spec, &here, stage.consumes(), stage.accepts_2d(), "segmenters")?;
        let mut cache_key = format!("{} {}", spec.kind, spec.plugin_params());
        if let Some(t) = input_text {
            cache_key.push_str(&format!(" input {t}"));
        }
        out.push(NamedSegmenter { name, stage, input, cache_key });
    }
    Ok(out)
}

/// The `input = { features = … }` of a stage that reads channels (a segmenter, a labeller),
/// checked against what every dataset gives and built; with its text for the cache key.
/// `what` names the stages in messages (`segmenters`); a stage that reads positions and does not
/// `accepts_2d` is refused on 2-D data, as is each input feature that does not.
pub fn channel_input(
    cx: &BuildContext<'_>,
    spec: &StageSpec,
    here: &KeyPath,
    consumes: DataKind,
    accepts_2d: bool,
    what: &str,
) -> Result<(Option<FeatureChannels>, Option<String>)> {
    let (source, combo) = (cx.source, cx.combo);
    let here = here.clone();
    let input = match spec.channel_input() {
        None => None,
        Some(value) => Some(deserialize_section::<ChannelInput>(
            source,
            &combo.doc,
            value.clone(),
            &here.key("input"),
        )?),
    };
    let gives: Vec<(usize, DataKind, &str)> = cx
        .data
        .datasets
        .iter()
        .map(|d| (d.index, d.loader.gives(), d.spec.loader.kind.as_str()))
        .collect();
    let refuse = |msg: String, key: KeyPath| {
        Err(cx.locate(Error::new(ErrorKind::InvalidParameter, msg), key))
    };
    match (consumes, &input) {
        (DataKind::Points, Some(_)) => {
            return refuse(
                format!(
                    "{} reads marker or joint positions, not channels: `input` is for {what} that read channels",
                    spec.kind
                ),
                here.key("input"),
            );
        }
        (DataKind::Points, None) => {
            cx.require_3d_unless(&spec.kind, accepts_2d, here.key("type"))?;
            if let Some((d, _, loader)) = gives.iter().find(|g| g.1 == DataKind::Channels) {
                return refuse(
                    format!(
                        "{} reads marker or joint positions, and dataset[{d}] (loader `{loader}`) gives channels only",
                        spec.kind
                    ),
                    here.key("type"),
                );
            }
        }
        (DataKind::Channels, Some(_)) => {
            if let Some((d, _, loader)) = gives.iter().find(|g| g.1 == DataKind::Channels) {
                return refuse(
                    format!(
                        "`input` computes channels from marker or joint positions, and dataset[{d}] (loader `{loader}`) gives channels already: remove `input`"
                    ),
                    here.key("input"),
                );
            }
        }
        (DataKind::Channels, None) => {
            if let Some((d, _, loader)) = gives.iter().find(|g| g.1 == DataKind::Points) {
                return refuse(
                    format!(
                        "{} reads channels, and dataset[{d}] (loader `{loader}`) gives marker or joint positions: add `input = {{ features = [{{ type = \"marker_speed\" }}] }}` — the features whose traces become its channels",
                        spec.kind
                    ),
                    here.key("type"),
                );
            }
        }
    }
    let input_text = input.as_ref().map(|i| toml::to_string(i).unwrap_or_default());
    let input = match input {
        None => None,
        Some(i) => {
            let features = here.key("input").key("features");
            let extractors = i
                .features
                .iter()
                .enumerate()
                .map(|(j, f)| {
                    let x = build_stage(
                        source,
                        combo,
                        f,
                        &features.index(j),
                        registry::build_feature_extractor,
                    )?;
                    cx.require_3d_unless(&f.kind, x.accepts_2d(), features.index(j).key("type"))?;
                    Ok((f.display_name(), x))
                })
                .collect::<Result<Vec<_>>>()?;
            if extractors.is_empty() {
                return Err(cx.locate(
                    Error::new(
                        ErrorKind::MissingKey,
                        "lists no feature extractor; expected at least one",
                    ),
                    features,
                ));
            }
            Some(FeatureChannels { extractors, channels: i.channels, fill: i.fill })
        }
    };
    Ok((input, input_text))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linear_fill_interpolates_gaps_and_holds_the_ends() {
        let n = f64::NAN;
        let mut v = vec![n, 1.0, n, n, 4.0, n];
        assert!(fill_linear(&mut v));
        assert_eq!(v, vec![1.0, 1.0, 2.0, 3.0, 4.0, 4.0]);
        let mut none = vec![n, n];
        assert!(!fill_linear(&mut none));
        let mut empty: Vec<f64> = Vec::new();
        assert!(!fill_linear(&mut empty));
    }
}
