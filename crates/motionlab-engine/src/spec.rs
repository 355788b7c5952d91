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
//! Exactly one workflow section is present: `[features]`, `[segmentation]`, `[matching]` or
//! `[gait]`. Stage tables (`loader`, `segmenter`, `evaluate`, …) are `{ type = "<plugin>",
//! <params>… }`; their parameters are checked by the plugin itself when the experiment is
//! validated. Every table denies unknown keys.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use motionlab_core::{Error, ErrorKind, Result};

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
    /// The plugin's parameter table: every key but `type`, and but `name` — a display name
    /// for the engine — unless the plugin itself has a `name` parameter (`add_centroid`).
    pub fn plugin_params(&self) -> toml::Value {
        let mut p = self.params.clone();
        let plugin_has_name = motionlab_core::registry::find(&self.kind).is_ok_and(|e| e.params().iter().any(|d| d.name == "name"));
        if !plugin_has_name {
            p.remove("name");
        }
        toml::Value::Table(p)
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
    /// Name used in tables; default: the file stem (one name per file when a glob matches
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
    /// Label of this grid in result tables; default `sweep<k>`.
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

/// `[features]`: per-frame features as tables and figures.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FeaturesSection {
    pub extractors: Vec<StageSpec>,
}

/// `[segmentation]`: segmenters, then an optional fuser; evaluators come from `[[evaluate]]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SegmentationSection {
    #[serde(rename = "segmenter")]
    pub segmenters: Vec<StageSpec>,
    #[serde(default)]
    pub fuser: Option<StageSpec>,
    /// Names of the segmenters whose candidates the fuser combines; default: all of them.
    #[serde(default)]
    pub fuse: Option<Vec<String>>,
    /// Marker pairs joined in stick figures (`[["Head_FL", "Head_FR"], …]`); default: the
    /// skeleton's bones when the source has one.
    #[serde(default)]
    pub bones: Vec<[String; 2]>,
    /// The root point (after preprocessing) for the floor-path figure and the stick figures;
    /// default `"root"`.
    #[serde(default = "default_root")]
    pub root: String,
    /// Which figures to draw per sequence (default: all of `traces`, `root_path`, `timeline`,
    /// `timeline_poses` — the timeline with the pose at each fused boundary underneath —, and
    /// `stick_strip`).
    #[serde(default = "default_seg_figures")]
    pub figures: Vec<String>,
}

fn default_root() -> String {
    "root".into()
}

fn default_seg_figures() -> Vec<String> {
    ["traces", "root_path", "timeline", "timeline_poses", "stick_strip"].iter().map(|s| s.to_string()).collect()
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
    #[serde(default)]
    pub features: Option<FeaturesSection>,
    #[serde(default)]
    pub segmentation: Option<SegmentationSection>,
    /// Parsed by the matching workflow (`motionlab_engine::workflows::matching`).
    #[serde(default)]
    pub matching: Option<toml::Table>,
    /// Parsed by the gait workflow (`motionlab_engine::workflows::gait`).
    #[serde(default)]
    pub gait: Option<toml::Table>,
    #[serde(default, rename = "evaluate")]
    pub evaluators: Vec<StageSpec>,
    #[serde(default)]
    pub sweep: Option<SweepSpec>,
    #[serde(default)]
    pub published: Vec<Published>,
}

/// Which workflow an experiment runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum WorkflowKind {
    Features,
    Segmentation,
    Matching,
    Gait,
}

impl ExperimentFile {
    pub fn workflow(&self) -> Result<WorkflowKind> {
        let present: Vec<WorkflowKind> = [
            (self.features.is_some(), WorkflowKind::Features),
            (self.segmentation.is_some(), WorkflowKind::Segmentation),
            (self.matching.is_some(), WorkflowKind::Matching),
            (self.gait.is_some(), WorkflowKind::Gait),
        ]
        .into_iter()
        .filter_map(|(p, k)| p.then_some(k))
        .collect();
        match present.as_slice() {
            [one] => Ok(*one),
            [] => Err(Error::new(
                ErrorKind::MissingKey,
                "expected one workflow section: [features], [segmentation], [matching] or [gait]",
            )),
            _ => Err(Error::new(ErrorKind::InvalidParameter, format!("expected one workflow section, found {present:?}"))),
        }
    }
}
