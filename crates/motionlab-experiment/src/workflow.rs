//! Workflows are plugins: what an experiment does with its datasets.
//!
//! A workflow owns one top-level section of the experiment file, named after it
//! (`[segmentation]`), parsed into its own typed parameters (`deny_unknown_fields`, documented
//! like a stage's: `motionlab describe segmentation`). It registers itself with one line,
//!
//! ```ignore
//! motionlab_experiment::register_workflow!(SegmentationWorkflow, "segmentation");
//! ```
//!
//! and the engine finds it by the section an experiment has; an unknown section is an error
//! naming the closest registered ones. As with stages, a crate the binary never names is not
//! linked and its workflows vanish: the CLI names every workflow crate, and the registry test
//! counts them (each workflow crate states its `WORKFLOW_COUNT`).
//!
//! Every workflow is a map–reduce over work items (normally one per input file): `run_item`
//! does the per-item work and returns a serialisable result (persisted under `items/`, which is
//! what makes sharded runs and `merge` possible) plus per-item figures and files; `finish` turns
//! all item results of one sweep combination into tables, figures and files; `summarize` may
//! add tables and figures across combinations (precision–recall curves of a sweep).

use schemars::JsonSchema;
use serde::de::DeserializeOwned;

use motionlab_core::registry::{self, ParamDoc, closest_names, schema_doc, schema_params};
use motionlab_core::{Error, ErrorKind, EvalInputType, Evaluator, Result, Table};
use motionlab_figure::Figure;

use crate::context::{Combo, Datasets, Source, build_stage, deserialize_section};
use crate::spec::{ExperimentFile, FIXED_KEYS, StageSpec};
use crate::toml_paths::KeyPath;

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
        rmp_serde::to_vec_named(value).map(ItemData).map_err(|e| {
            motionlab_core::Error::new(
                motionlab_core::ErrorKind::Report,
                format!("cannot encode an item result: {e}"),
            )
        })
    }
    pub fn decode<T: serde::de::DeserializeOwned>(&self) -> Result<T> {
        rmp_serde::from_slice(&self.0).map_err(|e| {
            motionlab_core::Error::new(
                motionlab_core::ErrorKind::Mismatch,
                format!("cannot decode an item result: {e}"),
            )
        })
    }
}

/// What one item produced.
pub struct ItemOutput {
    pub result: ItemData,
    pub figures: Vec<Figure>,
    /// Other files of this item (`name`, bytes), written under the run's `files/` as the item
    /// finishes (per-item data for a page, say). Names must be unique across items.
    pub files: Vec<(String, Vec<u8>)>,
}

impl ItemOutput {
    /// An item's result and figures, with no other files.
    pub fn new(result: ItemData, figures: Vec<Figure>) -> Self {
        ItemOutput { result, figures, files: Vec::new() }
    }

    /// The result to persist (what `finish` is later given) and the output to write now.
    pub fn into_parts(self) -> (ItemData, Output) {
        (self.result, Output { figures: self.figures, files: self.files, ..Output::default() })
    }
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
    /// The evaluators' typed analyses (evaluator name, analysis), for
    /// [`Workflow::summarize`] to build on across combinations; not written anywhere.
    pub analyses: Vec<(String, motionlab_core::Analysis)>,
}

impl Output {
    /// The first analysis that reads as a `T` (live or restored from the cache).
    pub fn analysis<T: Clone + serde::de::DeserializeOwned + 'static>(&self) -> Option<T> {
        self.analyses.iter().find_map(|(_, a)| a.read::<T>())
    }
}

impl Output {
    /// A run's whole output from its combinations' (the base combination first) and the
    /// summary's: `tables` — the combinations' tables as the engine joined them (with sweep
    /// columns) — then the summary's; the base combination's figures and viewers (the others
    /// ran with `draw_figures` false: a sweep would multiply them); every combination's files;
    /// then the summary's figures and files.
    pub fn of_run(tables: Vec<Table>, combos: Vec<Output>, summary: Output) -> Output {
        let mut all = Output { tables, ..Output::default() };
        for (c, out) in combos.into_iter().enumerate() {
            if c == 0 {
                all.figures = out.figures;
                all.viewers = out.viewers;
            }
            all.files.extend(out.files);
        }
        all.tables.extend(summary.tables);
        all.figures.extend(summary.figures);
        all.files.extend(summary.files);
        all.viewers.extend(summary.viewers);
        all
    }
}

/// A completed combination, for [`Workflow::summarize`].
pub struct ComboOutput<'a> {
    pub combo: &'a Combo,
    pub output: &'a Output,
}

/// A workflow: what an experiment does with its datasets, as a map–reduce over work items.
/// Built per sweep combination by its [`WorkflowPlugin::build`]; registered with
/// [`register_workflow!`](crate::register_workflow).
pub trait Workflow: Send + Sync {
    /// The work items (default: every file of every dataset).
    fn items(&self, data: &Datasets) -> Vec<WorkItem> {
        default_items(data)
    }
    /// Per-item work. Must be deterministic: sharded and single-machine runs are compared.
    fn run_item(&self, item: &WorkItem, data: &Datasets, draw_figures: bool) -> Result<ItemOutput>;
    /// All items of one combination → tables and figures.
    fn finish(
        &self,
        items: &[(WorkItem, ItemData)],
        data: &Datasets,
        draw_figures: bool,
    ) -> Result<Output>;
    /// Tables and figures across sweep combinations (called once, even without a sweep).
    fn summarize(&self, _combos: &[ComboOutput<'_>]) -> Result<Output> {
        Ok(Output::default())
    }
}

/// Builds `[[evaluate]]` stages, checking each reads this workflow's results (`produces`).
pub fn build_evaluators(
    source: &Source,
    combo: &Combo,
    produces: EvalInputType,
) -> Result<Vec<(String, Box<dyn Evaluator>)>> {
    let root = KeyPath::parse("evaluate")?;
    combo
        .file
        .evaluators
        .iter()
        .enumerate()
        .map(|(k, s)| {
            let e = build_stage(source, combo, s, &root.index(k), registry::build_evaluator)?;
            if e.input_type() != produces {
                return Err(source.locate(
                    Error::new(
                        ErrorKind::InvalidParameter,
                        format!(
                            "evaluator {:?} evaluates {}, but this experiment produces {}",
                            s.kind,
                            e.input_type().name,
                            produces.name
                        ),
                    ),
                    root.index(k).key("type"),
                    &combo.doc,
                ));
            }
            Ok((s.display_name(), e))
        })
        .collect()
}

/// Builds a list of stages a section names (`[[segmentation.segmenter]]`, `extractors = [...]`),
/// each under its display name (its `name`, else its type) and in order, with the stage errors
/// located at `at[k]` as [`build_stage`] locates them. Two stages of one name are an error at
/// the second one's `name` key (at its `type` when it has none), saying what the list holds
/// (`what`, plural: "segmenters"). An empty list is the caller's to refuse or allow.
pub fn build_named_stages<T: ?Sized>(
    cx: &BuildContext<'_>,
    specs: &[StageSpec],
    at: &KeyPath,
    what: &str,
    builder: fn(&str, &toml::Value) -> Result<Box<T>>,
) -> Result<Vec<(String, Box<T>)>> {
    let mut stages: Vec<(String, Box<T>)> = Vec::with_capacity(specs.len());
    for (k, spec) in specs.iter().enumerate() {
        let name = spec.display_name();
        if stages.iter().any(|(n, _)| *n == name) {
            let key = if spec.params.contains_key("name") { "name" } else { "type" };
            return Err(cx.locate(
                Error::new(
                    ErrorKind::DuplicateName,
                    format!("two {what} are named {name:?}; give one a `name = \"…\"`"),
                ),
                at.index(k).key(key),
            ));
        }
        stages.push((name, build_stage(cx.source, cx.combo, spec, &at.index(k), builder)?));
    }
    Ok(stages)
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
    name.chars()
        .map(|c| if c.is_ascii_alphanumeric() || c == '-' || c == '_' { c } else { '_' })
        .collect()
}

/// What a workflow is built from: the experiment, one combination, its datasets (plugins
/// built, files resolved — or none, when only validating in memory).
pub struct BuildContext<'a> {
    pub source: &'a Source,
    pub combo: &'a Combo,
    pub data: &'a Datasets,
    /// The workflow's section (`segmentation`), for locating errors under it.
    pub root: KeyPath,
}

impl BuildContext<'_> {
    /// [`Source::locate`] in this combination's document: the one way a workflow attaches the
    /// experiment file, line and key path to an error while it builds.
    pub fn locate(&self, err: Error, at: impl Into<crate::context::At>) -> Error {
        self.source.locate(err, at, &self.combo.doc)
    }

    /// What [`BuildContext::locate`] needs, owned: kept by a workflow whose configuration can
    /// only be checked once the data is seen (a channel no trial has), so that those errors are
    /// located the same way, at run time.
    pub fn locator(&self) -> Locator {
        Locator { source: self.source.clone(), doc: self.combo.doc.clone() }
    }

    /// Refuses, located at `at`, a stage that needs 3-D positions (`accepts_2d` false) when a
    /// dataset's loader gives 2-D image positions (video pose estimation): one line naming the
    /// stage, the dataset and its loader. The one check every workflow makes for depth.
    pub fn require_3d_unless(
        &self,
        stage: &str,
        accepts_2d: bool,
        at: impl Into<crate::context::At>,
    ) -> Result<()> {
        if accepts_2d {
            return Ok(());
        }
        match self
            .data
            .datasets
            .iter()
            .find(|d| d.loader.dimensionality() == motionlab_core::Dimensionality::Two)
        {
            None => Ok(()),
            Some(d) => Err(self.locate(
                Error::new(
                    ErrorKind::InvalidParameter,
                    format!(
                        "{stage} needs 3-D positions, and dataset[{}] (loader `{}`) gives 2-D image positions (px)",
                        d.index, d.spec.loader.kind
                    ),
                ),
                at,
            )),
        }
    }
}

/// [`BuildContext::locate`] after the build: the experiment file and one combination's document.
#[derive(Clone, Debug)]
pub struct Locator {
    source: Source,
    doc: toml::Table,
}

impl Locator {
    /// The error at key path `at` of the experiment (file, line, key path), as
    /// [`BuildContext::locate`] places it.
    pub fn locate(&self, err: Error, at: impl Into<crate::context::At>) -> Error {
        self.source.locate(err, at, &self.doc)
    }
}

/// A workflow with its section's typed parameters: what [`register_workflow!`](crate::register_workflow) registers.
pub trait WorkflowPlugin: Workflow + Sized + 'static {
    /// The section's parameters. Its doc comment and its fields' are the user documentation
    /// (`motionlab describe <workflow>`), as for a stage's params struct.
    type Section: DeserializeOwned + JsonSchema;
    /// Validates the section against the datasets and builds every stage it names (errors
    /// located with [`BuildContext::locate`] or [`build_stage`]).
    fn build(section: Self::Section, cx: &BuildContext<'_>) -> Result<Self>;
}

/// One registered workflow.
pub struct WorkflowEntry {
    /// The section it owns (`segmentation` for `[segmentation]`).
    pub name: &'static str,
    /// The section type's Rust name (for docs).
    pub section_type: &'static str,
    /// The crate that registered it.
    pub crate_name: &'static str,
    /// JSON schema of the section, with doc comments as descriptions and defaults.
    pub schema: fn() -> schemars::Schema,
    pub build: fn(&BuildContext<'_>) -> Result<Box<dyn Workflow>>,
}

inventory::collect!(WorkflowEntry);

impl WorkflowEntry {
    /// The workflow's documentation: its section type's doc comment.
    pub fn doc(&self) -> String {
        schema_doc(&(self.schema)(), self.section_type)
    }
    /// First line of [`WorkflowEntry::doc`].
    pub fn summary(&self) -> String {
        self.doc().lines().next().unwrap_or("").to_string()
    }
    /// The section's keys: name, type, default and description.
    pub fn params(&self) -> Vec<ParamDoc> {
        schema_params(&(self.schema)())
    }
}

/// The generic builder [`register_workflow!`](crate::register_workflow) stores: parses the
/// section (errors at `<section>.<key>` and its line), then builds.
pub fn build_entry<W: WorkflowPlugin>(cx: &BuildContext<'_>) -> Result<Box<dyn Workflow>> {
    let name = cx.root.to_string();
    let value =
        cx.combo.doc.get(&name).cloned().unwrap_or_else(|| toml::Value::Table(toml::Table::new()));
    let section: W::Section = deserialize_section(cx.source, &cx.combo.doc, value, &cx.root)?;
    Ok(Box::new(W::build(section, cx)?))
}

/// Registers a workflow: `register_workflow!(SegmentationWorkflow, "segmentation");` — the type
/// implements [`WorkflowPlugin`]; the name is the section it owns.
#[macro_export]
macro_rules! register_workflow {
    ($workflow:ty, $name:literal) => {
        $crate::inventory::submit! {
            $crate::workflow::WorkflowEntry {
                name: $name,
                section_type: stringify!($workflow),
                crate_name: env!("CARGO_PKG_NAME"),
                schema: $crate::workflow::section_schema::<$workflow>,
                build: $crate::workflow::build_entry::<$workflow>,
            }
        }
    };
}

/// The JSON schema of a workflow's section (stored as a fn pointer in [`WorkflowEntry::schema`]).
pub fn section_schema<W: WorkflowPlugin>() -> schemars::Schema {
    registry::schema_of::<W::Section>()
}

/// Every registered workflow, sorted by name.
pub fn workflows() -> Vec<&'static WorkflowEntry> {
    let mut v: Vec<&'static WorkflowEntry> = inventory::iter::<WorkflowEntry>.into_iter().collect();
    v.sort_by_key(|w| w.name);
    v
}

/// The workflow registered under `name`.
pub fn find_workflow(name: &str) -> Option<&'static WorkflowEntry> {
    workflows().into_iter().find(|w| w.name == name)
}

/// The one workflow section of a document, checked against the registered workflows: an
/// unknown top-level key is an error naming the closest registered sections (and fixed keys).
pub fn workflow_section(source: &Source, doc: &toml::Table) -> Result<&'static WorkflowEntry> {
    let all = workflows();
    let names: Vec<String> = ExperimentFile::section_names(doc);
    let sections = || all.iter().map(|w| format!("[{}]", w.name)).collect::<Vec<_>>().join(", ");
    let mut found = Vec::new();
    for n in &names {
        match all.iter().find(|w| w.name == n) {
            Some(w) => found.push(*w),
            None => {
                let pool = all.iter().map(|w| w.name).chain(FIXED_KEYS);
                let close = closest_names(n, pool);
                let hint = if close.is_empty() {
                    String::new()
                } else {
                    format!(
                        "; did you mean {}?",
                        close.iter().map(|c| format!("`{c}`")).collect::<Vec<_>>().join(" or ")
                    )
                };
                return Err(source.locate(
                    Error::new(ErrorKind::UnknownKey, format!("unknown section `{n}`: expected a workflow section ({}) or one of {}{hint}", sections(), FIXED_KEYS.join(", "))),
                    KeyPath::default().key(n),
                    doc,
                ));
            }
        }
    }
    match found.as_slice() {
        [one] => Ok(one),
        [] => Err(Error::new(
            ErrorKind::MissingKey,
            format!("expected one workflow section: {}", sections()),
        )
        .with_location(motionlab_core::Location::file(&source.path))),
        many => Err(Error::new(
            ErrorKind::InvalidParameter,
            format!(
                "expected one workflow section, found {}",
                many.iter().map(|w| format!("[{}]", w.name)).collect::<Vec<_>>().join(", ")
            ),
        )
        .with_location(motionlab_core::Location::file(&source.path))),
    }
}

/// Builds the workflow of a combination (validating every workflow-specific plugin).
pub fn build(
    entry: &WorkflowEntry,
    source: &Source,
    combo: &Combo,
    data: &Datasets,
) -> Result<Box<dyn Workflow>> {
    let root = KeyPath::parse(entry.name)?;
    (entry.build)(&BuildContext { source, combo, data, root })
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;
    use crate::run_cache::RunCache;

    const EXPERIMENT: &str = r#"[experiment]
name = "named"

[[dataset]]
files = []
loader = { type = "any" }

[stats]
extractors = [
  { type = "speed" },
  { type = "speed", name = "fast" },
  { type = "curvature" },
]
"#;

    /// A stage builder that accepts any type but `broken` (a stage of one `String`: its type).
    // Boxed because a stage builder returns `Result<Box<S>>` (S a trait object in real stages).
    #[allow(clippy::box_collection)]
    fn build_text(kind: &str, _params: &toml::Value) -> Result<Box<String>> {
        if kind == "broken" {
            return Err(
                Error::new(ErrorKind::InvalidParameter, "a broken stage").with_field("level")
            );
        }
        Ok(Box::new(kind.to_string()))
    }

    /// The located error (or the names) of `build_named_stages` on `[stats] extractors` after
    /// `edit` of the experiment's text.
    fn built(edit: impl Fn(&str) -> String) -> std::result::Result<Vec<String>, String> {
        let text = edit(EXPERIMENT);
        let source = Source { path: "x/named.toml".into(), text: text.clone() };
        let doc: toml::Table = toml::from_str(&text).unwrap();
        let file: ExperimentFile =
            toml::Value::Table(ExperimentFile::fixed_part(&doc)).try_into().unwrap();
        let combo =
            Combo { index: 0, sweep: None, focus: None, params: vec![], doc: doc.clone(), file };
        let data = Datasets::new(vec![], vec![], vec![], Arc::new(RunCache::with_budget(0)));
        let cx = BuildContext {
            source: &source,
            combo: &combo,
            data: &data,
            root: KeyPath::parse("stats").unwrap(),
        };
        let specs: Vec<StageSpec> = doc["stats"]["extractors"].clone().try_into().unwrap();
        build_named_stages(&cx, &specs, &cx.root.key("extractors"), "extractors", build_text)
            .map(|v| v.into_iter().map(|(name, stage)| format!("{name}={stage}")).collect())
            .map_err(|e| e.to_string())
    }

    #[test]
    fn named_stages_keep_their_order_and_names() {
        assert_eq!(
            built(str::to_string).unwrap(),
            ["speed=speed", "fast=speed", "curvature=curvature"]
        );
    }

    #[test]
    fn a_repeated_name_is_located_at_the_second_stages_key() {
        // Two stages of one type, neither named: the second one's `type`, on its line.
        let err =
            built(|t| t.replace(r#"{ type = "curvature" }"#, r#"{ type = "speed" }"#)).unwrap_err();
        assert!(
            err.starts_with(
                "x/named.toml:12: stats.extractors[2].type: two extractors are named \"speed\""
            ),
            "{err}"
        );
        // A `name` that repeats another stage's: its `name` key.
        let err = built(|t| {
            t.replace(r#"{ type = "curvature" }"#, r#"{ type = "curvature", name = "fast" }"#)
        })
        .unwrap_err();
        assert!(
            err.starts_with(
                "x/named.toml:12: stats.extractors[2].name: two extractors are named \"fast\""
            ),
            "{err}"
        );
    }

    #[test]
    fn a_stage_error_is_located_at_its_element() {
        let err = built(|t| t.replace(r#"{ type = "curvature" }"#, r#"{ type = "broken" }"#))
            .unwrap_err();
        assert!(
            err.starts_with("x/named.toml:12: stats.extractors[2].level: a broken stage"),
            "{err}"
        );
    }
}
