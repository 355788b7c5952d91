//! State labellers as an experiment names them (`labeller = [{ type = "segment_clusters" }]`):
//! built by name like the segmenters ([`crate::segmenters`]), with the same `input = { features
//! = … }` for a labeller that reads channels on takes with points.

use std::ops::Range;

use motionlab_core::registry;
use motionlab_core::{
    DataKind, Error, ErrorKind, FeatureCache, Labeller, Motion, Result, StateLabels,
};

use crate::context::build_stage;
use crate::segmenters::{FeatureChannels, channel_input};
use crate::spec::StageSpec;
use crate::toml_paths::KeyPath;
use crate::workflow::BuildContext;

/// A labeller with its display name and what it reads.
pub struct NamedLabeller {
    /// `name = "…"`, else the plugin type; unique among the labellers.
    pub name: String,
    pub stage: Box<dyn Labeller>,
    /// The features that become its channels (a channel labeller on positions).
    pub input: Option<FeatureChannels>,
}

impl NamedLabeller {
    /// The states of `segments` of one motion: on its features when it has an `input`, else on
    /// the motion itself.
    pub fn label(
        &self,
        motion: &Motion,
        segments: &[Range<usize>],
        cache: &FeatureCache,
    ) -> Result<StateLabels> {
        match &self.input {
            Some(input) => self.stage.label(&input.of(motion, cache)?, segments),
            None => self.stage.label(motion, segments),
        }
    }
}

/// Builds the labellers listed at `at` (`benchmark.labeller`): names unique, each checked
/// against what every dataset gives, as [`crate::segmenters::build_segmenters`] checks the
/// segmenters. Errors point at the file, line and key.
pub fn build_labellers(
    cx: &BuildContext<'_>,
    specs: &[StageSpec],
    at: &KeyPath,
) -> Result<Vec<NamedLabeller>> {
    let mut out: Vec<NamedLabeller> = Vec::new();
    for (k, spec) in specs.iter().enumerate() {
        let here = at.index(k);
        let name = spec.display_name();
        if out.iter().any(|s| s.name == name) {
            return Err(cx.locate(
                Error::new(
                    ErrorKind::DuplicateName,
                    format!("two labellers are named {name:?}; give one a `name = \"…\"`"),
                ),
                here,
            ));
        }
        let stage = build_stage(cx.source, cx.combo, spec, &here, registry::build_labeller)?;
        let consumes: DataKind = stage.consumes();
        // Labellers of positions (multistream_dp) compare them in mm: 2-D input is refused.
        let (input, _) = channel_input(cx, spec, &here, consumes, false, "labellers")?;
        out.push(NamedLabeller { name, stage, input });
    }
    Ok(out)
}
