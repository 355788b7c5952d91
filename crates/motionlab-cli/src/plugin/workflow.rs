//! The `[template_workflow]` workflow: how often each segmenter cuts each sequence.
//!
//! Written by `motionlab plugin new --kind workflow` as a working placeholder in the shape
//! every workflow has (CONTRIBUTING.md, "A workflow is one file"): a section struct whose doc comment
//! is what `motionlab describe template_workflow` prints, a `WorkflowPlugin::build` that checks
//! the section and builds every stage it names (errors located at their key and line), the
//! `Workflow` impl (one work item per sequence, then the tables) and one `register_workflow!`
//! line, with a known-answer test. Replace the pipeline, its doc comment and its test together.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::{Error, ErrorKind, FeatureCache, Result, Segmenter, Table, registry};
use motionlab_experiment::spec::StageSpec;
use motionlab_experiment::toml_paths::KeyPath;
use motionlab_experiment::workflow::{
    BuildContext, ItemData, ItemOutput, Output, WorkItem, Workflow, WorkflowPlugin,
};
use motionlab_experiment::{Datasets, build_named_stages};

/// Runs each segmenter on every sequence and counts its candidates: one row per sequence and
/// segmenter (`template_workflow`: sequence, method, frames, duration in s, candidates,
/// candidates per minute).
///
/// No `[[evaluate]]`: there is nothing to compare the counts with.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TemplateWorkflowSection {
    /// The segmenters (`[[template_workflow.segmenter]]`, `{ type = "<segmenter>", … }`);
    /// names (`name = "…"`, else the type) must be unique. At least one is required.
    #[serde(rename = "segmenter")]
    pub segmenters: Vec<StageSpec>,
}

pub struct TemplateWorkflow {
    segmenters: Vec<(String, Box<dyn Segmenter>)>,
}

/// One row of the `template_workflow` table (also the persisted item result).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TemplateWorkflowRow {
    pub sequence: String,
    pub method: String,
    pub frames: usize,
    pub duration_s: f64,
    pub candidates: usize,
    pub candidates_per_min: f64,
}

impl WorkflowPlugin for TemplateWorkflow {
    type Section = TemplateWorkflowSection;
    fn build(section: TemplateWorkflowSection, cx: &BuildContext<'_>) -> Result<Self> {
        let segmenters = build_named_stages(
            cx,
            &section.segmenters,
            &cx.root.key("segmenter"),
            "segmenters",
            registry::build_segmenter,
        )?;
        if segmenters.is_empty() {
            let msg = format!("at least one [[{}.segmenter]] is required", cx.root);
            return Err(cx.locate(Error::new(ErrorKind::MissingKey, msg), &cx.root));
        }
        if !cx.combo.file.evaluators.is_empty() {
            let msg = format!("[{}] runs no evaluators; remove the [[evaluate]] tables", cx.root);
            return Err(cx.locate(
                Error::new(ErrorKind::InvalidParameter, msg),
                KeyPath::default().key("evaluate"),
            ));
        }
        Ok(TemplateWorkflow { segmenters })
    }
}

motionlab_experiment::register_workflow!(TemplateWorkflow, "template_workflow");

impl Workflow for TemplateWorkflow {
    fn run_item(&self, item: &WorkItem, data: &Datasets, _draw: bool) -> Result<ItemOutput> {
        let loaded = data.load(item.dataset, item.file)?;
        let motion = &loaded.motion;
        let file = motion.source.clone().unwrap_or_default();
        let cache = FeatureCache::new();
        let mut rows = Vec::new();
        for (name, s) in &self.segmenters {
            let out = s
                .segment(motion, &cache)
                .map_err(|e| e.in_file(&file).under_field(format!("segmenter {name}")))?;
            let duration_s = motion.n_frames() as f64 / motion.frame_rate().hz();
            rows.push(TemplateWorkflowRow {
                sequence: loaded.name.clone(),
                method: name.clone(),
                frames: motion.n_frames(),
                duration_s,
                candidates: out.candidates.len(),
                candidates_per_min: per_minute(out.candidates.len(), duration_s),
            });
        }
        Ok(ItemOutput::new(ItemData::encode(&rows)?, Vec::new()))
    }

    fn finish(
        &self,
        items: &[(WorkItem, ItemData)],
        _data: &Datasets,
        _draw: bool,
    ) -> Result<Output> {
        let mut rows: Vec<TemplateWorkflowRow> = Vec::new();
        for (_, value) in items {
            rows.extend(value.decode::<Vec<TemplateWorkflowRow>>()?);
        }
        let mut out = Output::default();
        out.tables.push(Table::from_records(
            "template_workflow",
            "Candidates per sequence and segmenter",
            &rows,
        )?);
        Ok(out)
    }
}

/// `count` events over `duration_s` seconds, per minute (NaN for an empty motion).
pub fn per_minute(count: usize, duration_s: f64) -> f64 {
    if duration_s > 0.0 { count as f64 * 60.0 / duration_s } else { f64::NAN }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rate_per_minute_of_known_counts() {
        assert_eq!(per_minute(3, 30.0), 6.0);
        assert_eq!(per_minute(0, 12.5), 0.0);
        assert!(per_minute(2, 0.0).is_nan());
    }

    #[test]
    fn the_section_documents_its_keys_and_refuses_unknown_ones() {
        let entry = motionlab_experiment::workflow::find_workflow("template_workflow").unwrap();
        assert!(entry.summary().starts_with("Runs each segmenter on every sequence"));
        let bad: std::result::Result<TemplateWorkflowSection, _> =
            toml::from_str("segmenter = []\nsegmenters = []\n");
        assert!(bad.is_err());
    }
}
