//! The experiment file schema.
//!
//! ```toml
//! [experiment]
//! name = "quickstart"
//! description = "Fastest-marker speed of a dance"
//!
//! [[dataset]]
//! files = ["../data/mct/dance1.tsv.gz"]      # paths or globs, relative to this file
//! loader = { type = "qualisys_tsv" }
//!
//! [features]
//! extractors = [{ type = "marker_speed" }]
//! ```
//!
//! Exactly one workflow section is present, named after a registered workflow (`[features]`,
//! `[segmentation]`, … — see [`crate::workflow`]); it is parsed by that workflow into its own
//! typed parameters. Every other top-level key is fixed here. Stage tables (`loader`, `segmenter`, `evaluate`, …) are `{ type = "<plugin>",
//! <params>… }`; their parameters are checked by the plugin itself when the experiment is
//! validated. Every table denies unknown keys.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

/// `{ type = "name", …params }` — a plugin and its parameters.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StageSpec {
    /// The plugin's registered name.
    #[serde(rename = "type")]
    pub kind: String,
    /// Parameters (every key but `type`), checked by the plugin.
    #[serde(flatten)]
    pub params: toml::Table,
}

impl StageSpec {
    /// The plugin's parameter table: every key but `type`, and but the keys the engine reads
    /// itself — `name` (a display name) and `input` (a channel segmenter's features,
    /// [`crate::segmenters`]) — unless the plugin has a parameter of that name
    /// (`add_centroid`'s `name`).
    pub fn plugin_params(&self) -> toml::Value {
        let mut p = self.params.clone();
        let params =
            motionlab_core::registry::find(&self.kind).map(|e| e.params()).unwrap_or_default();
        for engine_key in ["name", "input"] {
            if !params.iter().any(|d| d.name == engine_key) {
                p.remove(engine_key);
            }
        }
        toml::Value::Table(p)
    }
    /// The `input` key of a segmenter that reads channels (see [`crate::segmenters`]), unless
    /// the plugin has an `input` parameter of its own.
    pub fn channel_input(&self) -> Option<&toml::Value> {
        let own = motionlab_core::registry::find(&self.kind)
            .is_ok_and(|e| e.params().iter().any(|d| d.name == "input"));
        if own { None } else { self.params.get("input") }
    }
    /// Display name: the `name` key when given, else the plugin type.
    pub fn display_name(&self) -> String {
        match self.params.get("name") {
            Some(toml::Value::String(s)) => s.clone(),
            _ => self.kind.clone(),
        }
    }
}

/// `[experiment]`: what this experiment is.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExperimentMeta {
    /// Identifier used for `reports/<name>/`; letters, digits, `_` and `-`.
    pub name: String,
    #[serde(default)]
    pub description: String,
    /// The paper it reproduces (file under `../shared/papers/` or a citation).
    #[serde(default)]
    pub paper: Option<String>,
    /// Numbers shown for this experiment on the reproduction index.
    #[serde(default)]
    pub headline: Vec<Headline>,
    /// Figures kept in the committed run of record (`reports/<name>/record/`), by file stem;
    /// `*` matches any run of characters (`"86_01_*"`).
    #[serde(default)]
    pub record_figures: Vec<String>,
    /// Tables kept in the run of record, by name with the same wildcards. Unset keeps every
    /// table; a sweep's per-combination tables (megabytes) are better left to the run itself.
    #[serde(default)]
    pub record_tables: Option<Vec<String>>,
}

/// One headline number: a cell of a result table, picked by column and text values.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Headline {
    pub label: String,
    pub table: String,
    pub column: String,
    /// Text columns and values that pick the row (`{ method = "fused", sequence = "pooled" }`).
    #[serde(default, rename = "where")]
    pub filter: BTreeMap<String, String>,
}

/// A cut of a longer take, in frames (`frames = [start, end]`, end exclusive) or seconds.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase", deny_unknown_fields)]
pub enum Cut {
    Frames([usize; 2]),
    Seconds([f64; 2]),
}

/// `[[dataset]]`: files loaded the same way.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DatasetSpec {
    /// Name used in tables; unset, the file stem (one name per file when a glob matches
    /// several files).
    #[serde(default)]
    pub name: Option<String>,
    /// Paths or glob patterns, relative to the experiment file's folder.
    pub files: Vec<String>,
    pub loader: StageSpec,
    /// `{ type = "<reader>", file = "<path>", …params }`; `{stem}` in the path stands for each
    /// motion file's stem (`file = "labels/{stem}.txt"`).
    #[serde(default)]
    pub ground_truth: Option<StageSpec>,
    /// Preprocessors applied to this dataset only, before the experiment-wide ones.
    #[serde(default)]
    pub preprocess: Vec<StageSpec>,
    /// Keep only this stretch of each file.
    #[serde(default)]
    pub cut: Option<Cut>,
    /// Free labels the workflow reads (`role = "model"`, `condition = "fast"`, `repetitions = "6"`).
    #[serde(default)]
    pub tags: BTreeMap<String, String>,
}

/// One grid of parameter values; the experiment runs once per combination.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepGrid {
    /// Label of this grid in result tables; unset, `sweep<k>`.
    #[serde(default)]
    pub name: Option<String>,
    /// The method the grid is about (e.g. the segmenter whose threshold it sweeps), for
    /// precision–recall curves and best-operating-point tables.
    #[serde(default)]
    pub focus: Option<String>,
    /// Key path → values. Paths use dots and `[index]` or `[name]` for arrays of stages:
    /// `"segmentation.segmenter[speed].v_low.fraction_of_p90" = [0.1, 0.2]`.
    pub grid: BTreeMap<String, Vec<toml::Value>>,
}

/// `[sweep]` (one grid) or `[[sweep]]` (several grids, run one after the other — their union,
/// not their product).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum SweepSpec {
    One(SweepGrid),
    Many(Vec<SweepGrid>),
}

impl SweepSpec {
    pub fn grids(&self) -> Vec<SweepGrid> {
        match self {
            SweepSpec::One(g) => vec![g.clone()],
            SweepSpec::Many(v) => v.clone(),
        }
    }
}

/// Published numbers the experiment reproduces, written once here (never typed into HTML):
/// `[[published]] table = "table1", rows = [{ method = "speed", precision = 0.64, recall = 0.59 }]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Published {
    /// The result table these numbers correspond to.
    pub table: String,
    /// Where in the paper (`Table 1`).
    pub source: String,
    #[serde(default)]
    pub note: String,
    pub rows: Vec<toml::Table>,
}

/// The whole experiment file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExperimentFile {
    pub experiment: ExperimentMeta,
    #[serde(rename = "dataset")]
    pub datasets: Vec<DatasetSpec>,
    /// Preprocessors applied to every dataset (after each dataset's own).
    #[serde(default)]
    pub preprocess: Vec<StageSpec>,
    #[serde(default, rename = "evaluate")]
    pub evaluators: Vec<StageSpec>,
    #[serde(default)]
    pub sweep: Option<SweepSpec>,
    #[serde(default)]
    pub published: Vec<Published>,
    /// The workflow this experiment runs: the name of its one workflow section (which the
    /// workflow parses itself, from the document).
    #[serde(skip)]
    pub workflow: String,
}

/// The top-level keys [`ExperimentFile`] holds; every other top-level key is a workflow section.
pub const FIXED_KEYS: [&str; 6] =
    ["experiment", "dataset", "preprocess", "evaluate", "sweep", "published"];

impl ExperimentFile {
    /// The top-level keys of a document that are not fixed keys: its workflow sections.
    pub fn section_names(doc: &toml::Table) -> Vec<String> {
        doc.keys().filter(|k| !FIXED_KEYS.contains(&k.as_str())).cloned().collect()
    }
    /// The document without its workflow sections: what deserialises as an `ExperimentFile`.
    pub fn fixed_part(doc: &toml::Table) -> toml::Table {
        doc.iter()
            .filter(|(k, _)| FIXED_KEYS.contains(&k.as_str()))
            .map(|(k, v)| (k.clone(), v.clone()))
            .collect()
    }
}

impl StageSpec {
    /// A stage with every parameter at its default.
    pub fn of_type(kind: &str) -> Self {
        StageSpec { kind: kind.to_string(), params: toml::Table::new() }
    }
}

/// Documented as `{ type = "<plugin>", <parameter> = <value>, … }` (`motionlab describe`).
impl schemars::JsonSchema for StageSpec {
    fn schema_name() -> std::borrow::Cow<'static, str> {
        "StageSpec".into()
    }
    fn json_schema(_: &mut schemars::SchemaGenerator) -> schemars::Schema {
        schemars::json_schema!({
            "type": "object",
            "description": "a plugin: `{ type = \"<plugin>\", <parameter> = <value>, … }`",
            "properties": { "type": { "type": "string" } },
            "required": ["type"],
        })
    }
}
