//! Workflows: what an experiment does with its datasets.
//!
//! Every workflow is a map–reduce over work items (normally one per input file): `run_item`
//! does the per-item work and returns a serialisable result (persisted under `items/`, which is
//! what makes sharded runs and `merge` possible) plus per-item figures; `finish` turns all item
//! results of one sweep combination into tables and figures; `summarize` may add tables and
//! figures across combinations (precision–recall curves of a sweep).

use motionlab_core::registry;
use motionlab_core::{Error, ErrorKind, EvalDomain, Evaluator, Result, Table};
use motionlab_report::Figure;

use crate::plan::{build_stage, Combo, Datasets, Source};
use crate::toml_paths::KeyPath;
use crate::spec::WorkflowKind;

pub mod features;
pub mod gait;
pub mod matching;
pub mod segmentation;
pub mod shared;

/// One unit of work.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct WorkItem {
    /// Unique within a combination, file-name safe (`86_01`, `13_29`).
    pub id: String,
    pub dataset: usize,
    pub file: usize,
}

/// A persisted item result: MessagePack (unlike JSON it keeps NaN, which marks undefined
/// samples throughout motionlab).
#[derive(Clone, Debug, PartialEq)]
pub struct ItemData(pub Vec<u8>);

impl ItemData {
    pub fn encode<T: serde::Serialize>(value: &T) -> Result<Self> {
        rmp_serde::to_vec_named(value)
            .map(ItemData)
            .map_err(|e| motionlab_core::Error::new(motionlab_core::ErrorKind::Report, format!("cannot encode an item result: {e}")))
    }
    pub fn decode<T: serde::de::DeserializeOwned>(&self) -> Result<T> {
        rmp_serde::from_slice(&self.0)
            .map_err(|e| motionlab_core::Error::new(motionlab_core::ErrorKind::Mismatch, format!("cannot decode an item result: {e}")))
    }
}

/// What one item produced.
pub struct ItemOutput {
    pub result: ItemData,
    pub figures: Vec<Figure>,
}

/// What a combination (or the whole sweep) produced.
#[derive(Default)]
pub struct Output {
    pub tables: Vec<Table>,
    pub figures: Vec<Figure>,
    /// Other files (`name`, bytes), e.g. a synthesised BVH.
    pub files: Vec<(String, Vec<u8>)>,
    /// Interactive viewer pages, one per sequence, written as `viewers/<name>.html`.
    pub viewers: Vec<motionlab_core::viewer::ViewerSpec>,
}

/// A completed combination, for [`Workflow::summarize`].
pub struct ComboOutput<'a> {
    pub combo: &'a Combo,
    pub output: &'a Output,
}

pub trait Workflow: Send + Sync {
    /// The work items (default: every file of every dataset).
    fn items(&self, data: &Datasets) -> Vec<WorkItem> {
        default_items(data)
    }
    /// Per-item work. Must be deterministic: sharded and single-machine runs are compared.
    fn run_item(&self, item: &WorkItem, data: &Datasets, draw_figures: bool) -> Result<ItemOutput>;
    /// All items of one combination → tables and figures.
    fn finish(&self, items: &[(WorkItem, ItemData)], data: &Datasets, draw_figures: bool) -> Result<Output>;
    /// Tables and figures across sweep combinations (called once, even without a sweep).
    fn summarize(&self, _combos: &[ComboOutput<'_>]) -> Result<Output> {
        Ok(Output::default())
    }
}

/// Builds `[[evaluate]]` stages, checking each accepts this workflow's results.
pub fn build_evaluators(source: &Source, combo: &Combo, domain: EvalDomain) -> Result<Vec<(String, Box<dyn Evaluator>)>> {
    let root = KeyPath::parse("evaluate")?;
    combo
        .file
        .evaluators
        .iter()
        .enumerate()
        .map(|(k, s)| {
            let e = build_stage(source, combo, s, &root.index(k), registry::build_evaluator)?;
            if e.domain() != domain {
                return Err(source.locate(
                    Error::new(
                        ErrorKind::InvalidParameter,
                        format!("evaluator {:?} evaluates {:?} results, but this experiment produces {domain:?} results", s.kind, e.domain()),
                    ),
                    &root.index(k).key("type"),
                    &combo.doc,
                ));
            }
            Ok((s.display_name(), e))
        })
        .collect()
}

/// One item per file of every dataset, ids from sequence names (made unique).
pub fn default_items(data: &Datasets) -> Vec<WorkItem> {
    let mut items: Vec<WorkItem> = Vec::new();
    for d in &data.datasets {
        for f in 0..d.files.len() {
            let base = sanitize(&d.sequence_name(f));
            let mut id = base.clone();
            let mut k = 2;
            while items.iter().any(|i| i.id == id) {
                id = format!("{base}_{k}");
                k += 1;
            }
            items.push(WorkItem { id, dataset: d.index, file: f });
        }
    }
    items
}

/// A file-name-safe version of a name.
pub fn sanitize(name: &str) -> String {
    name.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' || c == '_' { c } else { '_' }).collect()
}

/// Builds the workflow of a combination (validating every workflow-specific plugin).
pub fn build(kind: WorkflowKind, source: &Source, combo: &Combo, data: &Datasets) -> Result<Box<dyn Workflow>> {
    match kind {
        WorkflowKind::Features => Ok(Box::new(features::FeaturesWorkflow::build(source, combo)?)),
        WorkflowKind::Segmentation => Ok(Box::new(segmentation::SegmentationWorkflow::build(source, combo, data)?)),
        WorkflowKind::Matching => matching::build(source, combo, data),
        WorkflowKind::Gait => gait::build(source, combo, data),
    }
}
