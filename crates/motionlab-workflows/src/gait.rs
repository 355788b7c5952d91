//! The `[gait]` workflow (Osafune et al.): per trial, joint angles → gait cycles → waveform
//! parameters; per combination, the gait study, its evaluators (`change_rates`: K, μ, σ, CV,
//! feature channels), the paper's Tables 2–3, and optionally the control of a skeleton walk
//! (a BVH file, the angle curves, the paper's Fig 5) and the leave-one-subject-out evaluation.
//!
//! ```toml
//! [[dataset]]                       # trials: every dataset with a `condition` tag
//! name = "normal"
//! files = ["../data/schreiber2019/*/dynamic/*_C4_*.c3d.gz"]
//! loader = { type = "c3d" }
//! tags = { condition = "normal" }
//! # … one dataset per condition (fast, slow, …)
//!
//! [gait]
//! normal_condition = "normal"               # G; every other condition is compared with it
//! subject = { separator = "_", field = 0 }  # subject id = field 0 of the file stem split at "_"
//! joint_angles = { type = "isb_joint_angles", absent_markers = "nan" }
//! cycles = { type = "c3d_events" }
//! waveform = { type = "waveform_parameters" }
//! synthesizer = { type = "feature_channel_control" }   # needed by [gait.control] and [gait.loso]
//!
//! [gait.control]                    # optional: synthesise a changed skeleton walk
//! dataset = "cmu131_01"             # the dataset (by name) holding the walk to change
//! condition = "fast"                # whose change rates to apply
//! joint_angles = { type = "skeleton_joint_angles" }
//! cycles = { type = "heel_height", left_heel = "LeftAnkle", right_heel = "RightAnkle" }
//! channel_map = { "knee_l.flexion" = "LeftKnee.Xrotation" }
//!
//! [gait.loso]                       # optional: leave-one-subject-out evaluation
//! condition = "fast"
//!
//! [[evaluate]]
//! type = "change_rates"             # required: its analysis feeds Tables 2–3, control and LOSO
//! ```
//!
//! Nothing names a condition: any pair (normal vs fast, normal vs slow) or more works.
//!
//! ## Items and outputs
//!
//! One item per file: each trial (and the control walk) runs its angle source, cycle detector
//! and waveform analyzer; the item keeps the angle curves, cycles and parameters (the leave-one-
//! out needs the curves). Per combination, tables:
//!
//! - `trials`: subject, condition, cycles per foot, frequency, channels without a complete cycle;
//! - the evaluators' tables (`change_rates`: `gait_parameters`, `change_rates`,
//!   `change_rate_summary`, `frequency_changes` — the frequency change K_j per subject);
//! - `table2_posture` / `table3_size`: the paper's Tables 2–3 — mean, s.d. and CV of K of the DC
//!   / amplitude feature channels of every condition, plus the channels the experiment's
//!   `[[published]]` rows for these tables name (flagged `in_paper`, kept when no feature here);
//! - with `[gait.control]`: `control_changes` (μ applied per mapped channel, DC and amplitude
//!   measured before and after), `control_walk` (time factor, frame counts), `control_curves`
//!   (the synthesised curves of the mapped channels) and `files/<walk>_<condition>.bvh`;
//! - with `[gait.loso]`: `loso_subjects` (with the mean row), `loso_channels`,
//!   `loso_channel_means` and `loso_verdict` (does control beat the unchanged normal walk?).
//!
//! Figures: the mean gait cycle of each `figure_channels` channel per condition (across
//! subjects), K_j per subject, the paper's Fig 5 (stick figures of the recorded normal and the
//! synthesised walk), each changed control channel over time, and the leave-one-out RMS per
//! subject. Viewer pages (first combination; `[gait] viewers = "all" | "none" | [...]`):
//! `viewers/<sequence>.html` per walk — markers (the skeleton for a skeleton walk), the file's
//! events per side and label (foot strike, foot off; the detected strikes when it has none),
//! the gait cycles per side and the `figure_channels` angles (the control walk's through its
//! `channel_map`).
//!
//! Missing samples: a channel without a complete gait cycle in a trial (absent markers, gaps)
//! has NaN parameters; the change-rate evaluator excludes those subject-channel pairs (flagged
//! `missing`), `trials` counts them, and the leave-one-out leaves them out of that subject's
//! comparison. The control walk is a skeleton motion, which has no missing samples.

use std::any::TypeId;
use std::collections::BTreeMap;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry;
use motionlab_core::{
    AngleCurves, ChannelKind, Error, ErrorKind, EvalDomain, EvalInput, Evaluator, FeatureCache, FeatureExtractor, GaitCycle,
    GaitCycleDetector, LengthUnit, Location, Motion, PointKind, Result, SkeletonMotion, Table, WalkChanges, WalkSynthesizer,
    WaveformAnalyzer, WaveformParameters,
};
use motionlab_features::joint_angles::angle_curves_from_features;
use motionlab_features::waveform::{cycles_by_side, mean_gait_cycle};
use motionlab_gait::change_rates::{ChangeRateAnalysis, Component, StudyChanges};
use motionlab_gait::loso::{leave_one_subject_out, LosoResult};
use motionlab_gait::study::{study_of, AnalysedWalk, SubjectWalk, Walk};
use motionlab_figure::{Chart, Figure, Pose, RefLine, Series, StickRow};

use motionlab_core::viewer::{EventKind, EventLane, Interval, IntervalKind, IntervalLane, Lane, Mark, TraceLane, ViewerMotion, ViewerSpec};
use motionlab_core::Trace;

use crate::drawing::{axis_name, main_floor_axis, stick_strip};
use motionlab_experiment::workflow::{build_evaluators, sanitize, ItemData, ItemOutput, Output, WorkItem, Workflow, WorkflowPlugin, BuildContext};
use motionlab_experiment::{build_stage, Datasets, Source};
use motionlab_experiment::spec::StageSpec;

/// Name of the Table 2 (posture) result table; `[[published]]` rows for it name its channels.
pub const TABLE_POSTURE: &str = "table2_posture";
/// Name of the Table 3 (size) result table.
pub const TABLE_SIZE: &str = "table3_size";

/// Walk analysis and control (Osafune et al.): per trial, joint angles → gait cycles → waveform
/// parameters; per combination, the gait study and its evaluators (`[[evaluate]]`, gait
/// domain — one of them must produce the change-rate analysis, `change_rates`), the paper's
/// Tables 2–3, and optionally the control of a skeleton walk (`[gait.control]`) and the
/// leave-one-subject-out evaluation (`[gait.loso]`).
///
/// Trials are the datasets with a condition tag (`tags = { condition = "fast" }`).
///
/// Missing samples: a channel without a complete gait cycle in a trial has NaN parameters; the
/// change rates exclude those subject-channel pairs and `trials` counts them.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct GaitSection {
    /// The dataset tag that holds a trial's condition (`tags = { condition = "fast" }`). Every
    /// dataset with this tag holds trials.
    #[serde(default = "default_condition_tag")]
    pub condition_tag: String,
    /// The normal condition G (a value of the condition tag); every other condition X is
    /// compared with it: `K = (X − G) / G × 100`.
    pub normal_condition: String,
    /// How the subject id is read from a trial's file stem.
    #[serde(default)]
    pub subject: SubjectRule,
    /// Angle source of the trials: a feature extractor whose `deg` traces are joint angles.
    pub joint_angles: StageSpec,
    /// Gait-cycle detector of the trials.
    pub cycles: StageSpec,
    /// Waveform analyzer (DC, amplitude, frequency).
    pub waveform: StageSpec,
    /// Walk synthesizer used by `[gait.control]` and `[gait.loso]` (required by either).
    #[serde(default)]
    pub synthesizer: Option<StageSpec>,
    /// Channels whose mean gait cycle (across subjects, per condition) is drawn.
    #[serde(default = "default_figure_channels")]
    pub figure_channels: Vec<String>,
    /// `[gait.control]`: synthesise a changed skeleton walk.
    #[serde(default)]
    pub control: Option<ControlSection>,
    /// `[gait.loso]`: leave-one-subject-out evaluation.
    #[serde(default)]
    pub loso: Option<LosoSection>,
    /// Which walks get a viewer page (`viewers/<sequence>.html`: markers, foot events, gait
    /// cycles per side, the `figure_channels` angles): `"all"`, `"none"`, or a list
    /// of sequence names (`normal/2014001_C4_05`, as in the `trials` table) and subject ids
    /// (`2014001`: every trial of that subject). The control walk is `"all"`'s too.
    #[serde(default)]
    pub viewers: ViewerChoice,
}

/// `[gait] viewers`: `"all"`, `"none"` or a list of sequences and subjects.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema, PartialEq)]
#[serde(untagged)]
pub enum ViewerChoice {
    /// `"all"` or `"none"`.
    Keyword(ViewerKeyword),
    /// Sequence names and subject ids.
    Only(Vec<String>),
}

/// `"all"` or `"none"`.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, JsonSchema, PartialEq)]
#[serde(rename_all = "snake_case")]
pub enum ViewerKeyword {
    All,
    None,
}

impl Default for ViewerChoice {
    fn default() -> Self {
        ViewerChoice::Keyword(ViewerKeyword::All)
    }
}

impl ViewerChoice {
    /// Whether the walk `sequence` of `subject` (empty for the control walk) gets a viewer.
    fn wants(&self, sequence: &str, subject: &str) -> bool {
        match self {
            ViewerChoice::Keyword(k) => *k == ViewerKeyword::All,
            ViewerChoice::Only(list) => list.iter().any(|x| x == sequence || (!subject.is_empty() && x == subject)),
        }
    }
}

fn default_condition_tag() -> String {
    "condition".into()
}

fn default_figure_channels() -> Vec<String> {
    ["knee_l.flexion", "hip_l.flexion", "ankle_l.flexion"].iter().map(|s| s.to_string()).collect()
}

/// The subject id is field `field` (0-based) of the file stem split at `separator`
/// (`2014001_C4_05.c3d.gz` → `2014001` with `separator = "_"` and `field = 0`).
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SubjectRule {
    /// Separator of the stem's fields.
    #[serde(default = "default_separator")]
    pub separator: String,
    /// The field holding the subject id, 0-based.
    #[serde(default)]
    pub field: usize,
}

fn default_separator() -> String {
    "_".into()
}

impl Default for SubjectRule {
    fn default() -> Self {
        SubjectRule { separator: default_separator(), field: 0 }
    }
}

impl SubjectRule {
    pub fn subject_of(&self, stem: &str) -> Option<String> {
        stem.split(self.separator.as_str()).nth(self.field).filter(|s| !s.is_empty()).map(str::to_string)
    }
}

/// `[gait.control]`: one skeleton walk (BVH/AMC) changed by a condition's mean change rates.
///
/// The change rates are measured on the trials' channels (marker-derived: `knee_l.flexion`);
/// `channel_map` names the walk's channel that takes each (`"knee_l.flexion" =
/// "LeftKnee.Xrotation"`), and only mapped feature channels change. No sign is needed: scaling
/// a DC about 0 and an amplitude about the DC commute with negating the channel. An offset is:
/// when the walk channel reads `o` where the marker channel reads 0 (a different neutral
/// pose), give `offset_deg = { "LeftKnee.Xrotation" = o }` and its DC is scaled about `o`.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ControlSection {
    /// Name of the dataset holding the walk (one file, a skeleton motion).
    pub dataset: String,
    /// The condition whose change rates are applied (not the normal one).
    pub condition: String,
    /// Angle source of the walk (`skeleton_joint_angles`): its channels must be the skeleton's
    /// rotation channels, so the changed curves can be written back.
    pub joint_angles: StageSpec,
    /// Gait-cycle detector of the walk (the DC is measured over its cycles).
    pub cycles: StageSpec,
    /// Trial channel → walk channel.
    pub channel_map: BTreeMap<String, String>,
    /// Walk channel → its value (degrees) at the trial channel's zero.
    #[serde(default)]
    #[schemars(extend("x-default" = "0 for every channel"))]
    pub offset_deg: BTreeMap<String, f64>,
    /// Fig 5: a stick figure every this many frames (the default is the paper's).
    #[serde(default = "default_strip_every")]
    pub strip_every_frames: usize,
    /// Fig 5: poses per walk.
    #[serde(default = "default_strip_poses")]
    pub strip_poses: usize,
    /// Fig 5 starts, inside the walk's middle gait cycle, at the frame where these two walk
    /// channels are closest (the paper: both hips' X rotation — the thighs overlap).
    #[serde(default)]
    #[schemars(extend("x-default" = "the middle cycle's first frame"))]
    pub strip_start: Option<[String; 2]>,
}

fn default_strip_every() -> usize {
    5
}
fn default_strip_poses() -> usize {
    10
}

/// `[gait.loso]`: leave-one-subject-out evaluation of the synthesizer on the trials.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct LosoSection {
    /// The condition to synthesise from each held-out subject's normal walk.
    pub condition: String,
    /// Samples of the time-normalised mean gait cycle compared (101 = every 1 %).
    #[serde(default = "default_points")]
    pub points: usize,
}

fn default_points() -> usize {
    101
}

/// What a dataset holds.
#[derive(Clone, Debug, PartialEq)]
enum Role {
    Trials { condition: String },
    Control,
}

struct BuiltControl {
    spec: ControlSection,
    dataset: usize,
    angles: Box<dyn FeatureExtractor>,
    detector: Box<dyn GaitCycleDetector>,
}

pub struct GaitWorkflow {
    section: GaitSection,
    roles: Vec<Role>,
    /// Subject of each file of each trial dataset (empty for the control dataset).
    subjects: Vec<Vec<String>>,
    angles: Box<dyn FeatureExtractor>,
    detector: Box<dyn GaitCycleDetector>,
    analyzer: Box<dyn WaveformAnalyzer>,
    /// The evaluators; one produces the change-rate analysis (checked by
    /// [`Evaluator::analysis_type`] when built).
    evaluators: Vec<(String, Box<dyn Evaluator>)>,
    synthesizer: Option<Box<dyn WalkSynthesizer>>,
    control: Option<BuiltControl>,
    /// Channels the `[[published]]` rows of Tables 2 and 3 name, by table.
    published_channels: BTreeMap<String, Vec<String>>,
    /// The sweep combination (0 without a sweep): other combinations' files get a suffix.
    combo_index: usize,
    /// The experiment file and this combination's document, to locate configuration errors
    /// found only once the data is seen (a figure channel no trial has).
    source: Source,
    doc: toml::Table,
}

/// One analysed walk (an item's result).
#[derive(Clone, Debug, Serialize, Deserialize)]
struct WalkRecord {
    sequence: String,
    /// Empty for the control walk.
    subject: String,
    condition: String,
    control: bool,
    n_frames: usize,
    curves: AngleCurves,
    cycles: Vec<GaitCycle>,
    parameters: WaveformParameters,
}

impl WorkflowPlugin for GaitWorkflow {
    type Section = GaitSection;
    fn build(section: GaitSection, cx: &BuildContext<'_>) -> Result<Self> {
        let (source, combo, data, root) = (cx.source, cx.combo, cx.data, cx.root.clone());
        let here = |path: &str, err: Error| cx.locate(err, path);
        let angles = build_stage(source, combo, &section.joint_angles, &root.key("joint_angles"), registry::build_feature_extractor)?;
        let detector = build_stage(source, combo, &section.cycles, &root.key("cycles"), registry::build_gait_cycle_detector)?;
        let analyzer = build_stage(source, combo, &section.waveform, &root.key("waveform"), registry::build_waveform_analyzer)?;
        let synthesizer = match &section.synthesizer {
            Some(s) => {
                if s.params.contains_key("channel_map") {
                    return Err(here(
                        "gait.synthesizer.channel_map",
                        Error::new(
                            ErrorKind::InvalidParameter,
                            "the synthesizer works on the trials' channels here; map them to the control walk's in [gait.control] channel_map",
                        ),
                    ));
                }
                Some(build_stage(source, combo, s, &root.key("synthesizer"), registry::build_walk_synthesizer)?)
            }
            None => None,
        };
        let evaluators = build_evaluators(source, combo, EvalDomain::Gait)?;
        // Tables 2–3, the control and the leave-one-out build on the change-rate analysis: one
        // evaluator must hand it over (found by the type of its analysis, not by its name).
        if !evaluators.iter().any(|(_, e)| e.analysis_type() == Some(TypeId::of::<ChangeRateAnalysis>())) {
            return Err(here(
                "gait",
                Error::new(
                    ErrorKind::MissingKey,
                    "the [gait] workflow needs an `[[evaluate]] type = \"change_rates\"`: its change rates feed Tables 2–3, the control and the leave-one-out",
                ),
            ));
        }
        // Roles of the datasets: the control walk (by name), else trials (by condition tag).
        let control_dataset = match &section.control {
            Some(c) => Some(data.datasets.iter().position(|d| d.spec.name.as_deref() == Some(c.dataset.as_str())).ok_or_else(|| {
                let names: Vec<String> = data.datasets.iter().filter_map(|d| d.spec.name.clone()).collect();
                here("gait.control.dataset", Error::new(ErrorKind::UnknownName, format!("no [[dataset]] is named {:?} (named datasets: {names:?})", c.dataset)))
            })?),
            None => None,
        };
        let mut roles = Vec::new();
        let mut subjects = Vec::new();
        for d in &data.datasets {
            if Some(d.index) == control_dataset {
                if d.files.len() != 1 {
                    return Err(here(
                        &format!("dataset[{}].files", d.index),
                        Error::new(ErrorKind::WrongValueCount, format!("the control walk's dataset must hold one file, it holds {}", d.files.len())),
                    ));
                }
                roles.push(Role::Control);
                subjects.push(Vec::new());
                continue;
            }
            let Some(condition) = d.tag(&section.condition_tag) else {
                return Err(here(
                    &format!("dataset[{}]", d.index),
                    Error::new(
                        ErrorKind::MissingKey,
                        format!(
                            "this dataset has no `{}` tag and is not the control walk; give its trials a condition (`tags = {{ {} = \"…\" }}`)",
                            section.condition_tag, section.condition_tag
                        ),
                    ),
                ));
            };
            let mut ids = Vec::new();
            for f in &d.files {
                let stem = motionlab_core::paths::stem(f);
                let id = section.subject.subject_of(&stem).ok_or_else(|| {
                    here(
                        "gait.subject",
                        Error::new(
                            ErrorKind::InvalidParameter,
                            format!(
                                "cannot read a subject from {:?}: the stem {stem:?} split at {:?} has no non-empty field {}",
                                f.display().to_string(),
                                section.subject.separator,
                                section.subject.field
                            ),
                        ),
                    )
                })?;
                ids.push(id);
            }
            roles.push(Role::Trials { condition: condition.to_string() });
            subjects.push(ids);
        }
        // One trial per subject and condition: change rates pair them.
        let mut seen: BTreeMap<(String, String), String> = BTreeMap::new();
        for (d, role) in data.datasets.iter().zip(&roles) {
            let Role::Trials { condition } = role else { continue };
            for (f, id) in d.files.iter().zip(&subjects[d.index]) {
                if let Some(other) = seen.insert((id.clone(), condition.clone()), f.display().to_string()) {
                    return Err(here(
                        "gait.subject",
                        Error::new(
                            ErrorKind::DuplicateName,
                            format!("subject {id:?} has two trials in condition {condition:?}: {other} and {}; keep one per subject and condition", f.display()),
                        ),
                    ));
                }
            }
        }
        if let ViewerChoice::Only(list) = &section.viewers {
            for (k, x) in list.iter().enumerate() {
                let known = data.datasets.iter().any(|d| (0..d.files.len()).any(|f| d.sequence_name(f) == *x))
                    || subjects.iter().flatten().any(|s| s == x);
                if !known {
                    return Err(here(
                        &format!("gait.viewers[{k}]"),
                        Error::new(ErrorKind::UnknownName, format!("{x:?} is neither a sequence (`normal/2014001_C4_05`) nor a subject id of this experiment")),
                    ));
                }
            }
        }
        let conditions: Vec<&str> = roles
            .iter()
            .filter_map(|r| match r {
                Role::Trials { condition } => Some(condition.as_str()),
                Role::Control => None,
            })
            .collect();
        if !conditions.contains(&section.normal_condition.as_str()) {
            return Err(here(
                "gait.normal_condition",
                Error::new(ErrorKind::UnknownName, format!("no dataset has `{} = {:?}` (conditions: {conditions:?})", section.condition_tag, section.normal_condition)),
            ));
        }
        if !conditions.iter().any(|c| *c != section.normal_condition) {
            return Err(here(
                "gait.normal_condition",
                Error::new(ErrorKind::EmptySequence, format!("every trial is in the normal condition {:?}; change rates need another condition", section.normal_condition)),
            ));
        }
        let check_target = |path: &str, c: &str| -> Result<()> {
            if c == section.normal_condition || !conditions.contains(&c) {
                let others: Vec<&&str> = conditions.iter().filter(|x| **x != section.normal_condition).collect();
                return Err(here(path, Error::new(ErrorKind::UnknownName, format!("expected a condition other than the normal one, one of {others:?}; found {c:?}"))));
            }
            Ok(())
        };
        let needs_synth = |path: &str| {
            here(path, Error::new(ErrorKind::MissingKey, "needs `[gait] synthesizer = { type = \"feature_channel_control\" }` (or another walk synthesizer)"))
        };
        let control = match (&section.control, control_dataset) {
            (Some(c), Some(dataset)) => {
                check_target("gait.control.condition", &c.condition)?;
                if synthesizer.is_none() {
                    return Err(needs_synth("gait.control"));
                }
                if c.channel_map.is_empty() {
                    return Err(here("gait.control.channel_map", Error::new(ErrorKind::MissingKey, "map at least one trial channel to a walk channel")));
                }
                let mut targets = std::collections::HashSet::new();
                for (from, to) in &c.channel_map {
                    if !targets.insert(to.as_str()) {
                        return Err(here(&format!("gait.control.channel_map.{from}"), Error::new(ErrorKind::DuplicateName, format!("two trial channels map to {to:?}"))));
                    }
                }
                for (ch, o) in &c.offset_deg {
                    if !o.is_finite() || !targets.contains(ch.as_str()) {
                        return Err(here(
                            "gait.control.offset_deg",
                            Error::new(ErrorKind::InvalidParameter, format!("offset of {ch:?} ({o}): expected a finite number for a channel_map target")),
                        ));
                    }
                }
                if c.strip_every_frames == 0 || c.strip_poses < 2 {
                    return Err(here(
                        if c.strip_every_frames == 0 { "gait.control.strip_every_frames" } else { "gait.control.strip_poses" },
                        Error::new(ErrorKind::OutOfRange, "expected strip_every_frames >= 1 and strip_poses >= 2"),
                    ));
                }
                let cr = root.key("control");
                Some(BuiltControl {
                    spec: c.clone(),
                    dataset,
                    angles: build_stage(source, combo, &c.joint_angles, &cr.key("joint_angles"), registry::build_feature_extractor)?,
                    detector: build_stage(source, combo, &c.cycles, &cr.key("cycles"), registry::build_gait_cycle_detector)?,
                })
            }
            _ => None,
        };
        if let Some(l) = &section.loso {
            check_target("gait.loso.condition", &l.condition)?;
            if synthesizer.is_none() {
                return Err(needs_synth("gait.loso"));
            }
            if l.points < 2 {
                return Err(here("gait.loso.points", Error::new(ErrorKind::OutOfRange, format!("expected at least 2 samples per cycle, found {}", l.points))));
            }
        }
        let mut published_channels: BTreeMap<String, Vec<String>> = BTreeMap::new();
        for p in combo.file.published.iter().filter(|p| p.table == TABLE_POSTURE || p.table == TABLE_SIZE) {
            let list = published_channels.entry(p.table.clone()).or_default();
            list.extend(p.rows.iter().filter_map(|r| r.get("channel").and_then(|v| v.as_str()).map(str::to_string)));
        }
        Ok(GaitWorkflow {
            section,
            roles,
            subjects,
            angles,
            detector,
            analyzer,
            evaluators,
            synthesizer,
            control,
            published_channels,
            combo_index: combo.index,
            source: source.clone(),
            doc: combo.doc.clone(),
        })
    }
}

motionlab_experiment::register_workflow!(GaitWorkflow, "gait");

impl GaitWorkflow {
    /// The viewer page of one walk: its markers (or skeleton), the file's events (foot strike,
    /// foot off) per side, the gait cycles per side (foot strike to the next of the same foot)
    /// and the `figure_channels` angles the walk has.
    fn viewer(&self, item: &WorkItem, r: &WalkRecord, data: &Datasets) -> Result<ViewerSpec> {
        let loaded = data.load(item.dataset, item.file)?;
        let motion = &loaded.motion;
        let n = motion.n_frames();
        let vm = ViewerMotion::from_motion(motion, &[], None)?;
        let what = if r.control { "control walk".to_string() } else { format!("subject {}, {}", r.subject, r.condition) };
        let mut spec = ViewerSpec::new(viewer_name(&r.sequence), format!("{} — {what}", r.sequence), vm);
        // Events per "context label" (`Left Foot Strike`), in order of first appearance.
        let mut lanes: Vec<EventLane> = Vec::new();
        for e in &motion.events {
            let f = e.frame.round();
            if !(f.is_finite() && f >= 0.0 && (f as usize) < n) {
                continue;
            }
            // Files number repeated labels (`Foot Strike1`, `Foot Strike2`): one lane for all.
            let label = e.label.trim().trim_end_matches(|c: char| c.is_ascii_digit()).trim_end();
            let name = format!("{} {label}", e.context.trim()).trim().to_string();
            let mark = Mark { frame: f as usize, label: format!("{name}, {:.3} s", e.time.value()), status: None };
            match lanes.iter_mut().find(|l| l.name == name) {
                Some(l) => l.marks.push(mark),
                None => {
                    let mut l = EventLane::new(name, EventKind::Other, &[]);
                    l.marks.push(mark);
                    lanes.push(l);
                }
            }
        }
        let mut sides: Vec<&str> = Vec::new();
        for c in &r.cycles {
            if !sides.contains(&c.side.as_str()) {
                sides.push(&c.side);
            }
        }
        // A walk without file events (a skeleton walk, cycles from heel height): its detector's
        // foot strikes, the cycles' bounds.
        if lanes.is_empty() {
            for side in &sides {
                let mut frames: Vec<usize> = r.cycles.iter().filter(|c| c.side == *side).flat_map(|c| [c.start, c.end]).filter(|f| *f < n).collect();
                frames.dedup();
                lanes.push(EventLane::new(format!("{side} foot strikes (detected)"), EventKind::Other, &frames));
            }
        }
        for mut l in lanes {
            l.marks.sort_by_key(|m| m.frame);
            spec.lanes.push(Lane::Events(l));
        }
        let rate = motion.frame_rate().hz();
        for side in sides {
            let intervals = r
                .cycles
                .iter()
                .filter(|c| c.side == side && c.start < n)
                .enumerate()
                .map(|(k, c)| Interval {
                    start: c.start,
                    end: c.end.min(n - 1).max(c.start),
                    label: format!("{side} cycle {}: {:.2} s", k + 1, c.end.saturating_sub(c.start) as f64 / rate),
                })
                .collect();
            spec.lanes.push(Lane::Intervals(IntervalLane { name: format!("gait cycles ({side})"), kind: IntervalKind::GaitCycle, intervals }));
        }
        // The control walk names its channels after its skeleton: the figure channels through
        // `[gait.control] channel_map`.
        let map = self.control.as_ref().filter(|_| r.control).map(|c| &c.spec.channel_map);
        let traces: Vec<Trace> = self
            .section
            .figure_channels
            .iter()
            .filter_map(|ch| {
                let ch = map.and_then(|m| m.get(ch)).unwrap_or(ch);
                let k = r.curves.channels.iter().position(|c| c == ch)?;
                let mut v = r.curves.values[k].clone();
                v.resize(n, f64::NAN);
                Some(Trace::new(ch.clone(), "deg", v))
            })
            .collect();
        if !traces.is_empty() {
            spec.lanes.extend(TraceLane::from_traces("joint angles", &traces, &[], n).into_iter().map(Lane::Trace));
        }
        Ok(spec)
    }

    /// An error about the configuration at key `path` (file, line, key path).
    fn config_error(&self, path: &str, err: Error) -> Error {
        self.source.locate(err, path, &self.doc)
    }

    /// Angles → cycles → parameters of one walk; errors name the stage.
    fn analyse(&self, motion: &Motion, angles: &dyn FeatureExtractor, detector: &dyn GaitCycleDetector, prefix: &str) -> Result<AnalysedWalk> {
        let features = angles.extract(motion, &FeatureCache::new()).map_err(|e| e.under_field(format!("{prefix}.joint_angles")))?;
        let curves = angle_curves_from_features(&features, motion.frame_rate()).map_err(|e| e.under_field(format!("{prefix}.joint_angles")))?;
        let cycles = detector.cycles(motion).map_err(|e| e.under_field(format!("{prefix}.cycles")))?;
        let parameters = self.analyzer.parameters(&curves, &cycles).map_err(|e| e.under_field("gait.waveform"))?;
        Ok(AnalysedWalk { walk: Walk { curves, cycles }, parameters })
    }
}

impl Workflow for GaitWorkflow {
    fn run_item(&self, item: &WorkItem, data: &Datasets, _draw: bool) -> Result<ItemOutput> {
        let loaded = data.load(item.dataset, item.file)?;
        let (subject, condition, control, analysed) = match &self.roles[item.dataset] {
            Role::Trials { condition } => {
                let a = self.analyse(&loaded.motion, self.angles.as_ref(), self.detector.as_ref(), "gait")?;
                (self.subjects[item.dataset][item.file].clone(), condition.clone(), false, a)
            }
            Role::Control => {
                let c = self.control.as_ref().ok_or_else(|| Error::new(ErrorKind::Mismatch, "control dataset without [gait.control]"))?;
                let a = self.analyse(&loaded.motion, c.angles.as_ref(), c.detector.as_ref(), "gait.control")?;
                (String::new(), c.spec.condition.clone(), true, a)
            }
        };
        let record = WalkRecord {
            sequence: loaded.name.clone(),
            subject,
            condition,
            control,
            n_frames: loaded.motion.n_frames(),
            curves: analysed.walk.curves,
            cycles: analysed.walk.cycles,
            parameters: analysed.parameters,
        };
        Ok(ItemOutput::new(ItemData::encode(&record)?, Vec::new()))
    }

    fn finish(&self, items: &[(WorkItem, ItemData)], data: &Datasets, draw: bool) -> Result<Output> {
        let mut trials: Vec<WalkRecord> = Vec::new();
        let mut control_walk: Option<WalkRecord> = None;
        let mut viewers = Vec::new();
        for (item, value) in items {
            let r: WalkRecord = value.decode()?;
            if draw && self.section.viewers.wants(&r.sequence, &r.subject) {
                viewers.push(self.viewer(item, &r, data)?);
            }
            if r.control {
                control_walk = Some(r);
            } else {
                trials.push(r);
            }
        }
        let normal = self.section.normal_condition.clone();
        let walks: Vec<SubjectWalk> = trials
            .iter()
            .map(|r| SubjectWalk {
                subject: r.subject.clone(),
                condition: r.condition.clone(),
                analysed: AnalysedWalk { walk: Walk { curves: r.curves.clone(), cycles: r.cycles.clone() }, parameters: r.parameters.clone() },
            })
            .collect();
        let study = study_of(&normal, &walks);
        let mut out = Output { viewers, ..Output::default() };
        out.tables.push(trials_table(&trials)?);
        let mut change_rates: Option<Box<ChangeRateAnalysis>> = None;
        for (name, e) in &self.evaluators {
            let evaluation = e.evaluate_with_analysis(EvalInput::Gait(&study)).map_err(|err| err.under_field(format!("evaluate {name}")))?;
            out.tables.extend(evaluation.tables);
            if change_rates.is_none() {
                change_rates = evaluation.analysis.and_then(|a| a.downcast::<ChangeRateAnalysis>().ok());
            }
        }
        let ChangeRateAnalysis { rates, changes: analysis } =
            *change_rates.ok_or_else(|| self.config_error("gait", Error::new(ErrorKind::MissingKey, "no evaluator produced the change-rate analysis")))?;
        out.tables.extend(self.paper_tables(&analysis, rates.max_abs_cv_pct)?);
        if draw {
            for (k, ch) in self.section.figure_channels.iter().enumerate() {
                let figure = mean_cycle_figure(&trials, ch, &normal, &conditions_in_order(&trials, &normal))
                    .map_err(|e| self.config_error(&format!("gait.figure_channels[{k}]"), e))?;
                out.figures.push(figure);
            }
            out.figures.extend(frequency_figures(&analysis)?);
        }
        if let (Some(c), Some(walk)) = (&self.control, control_walk) {
            self.control_walk(c, &walk, &analysis, data, draw, &mut out)?;
        }
        if let Some(l) = &self.section.loso {
            let synth = self.synthesizer.as_deref().ok_or_else(|| Error::new(ErrorKind::MissingKey, "[gait.loso] needs a synthesizer"))?;
            let loso = leave_one_subject_out(&walks, &normal, &l.condition, &rates, synth, l.points).map_err(|e| e.under_field("gait.loso"))?;
            out.tables.extend(loso.tables()?);
            out.tables.push(loso_verdict(&loso, &normal)?);
            if draw {
                out.figures.push(loso_figure(&loso, &normal));
            }
        }
        Ok(out)
    }
}

/// A viewer page's file stem for a sequence (`normal/2014001_C4_05` → `normal_2014001_C4_05`).
fn viewer_name(sequence: &str) -> String {
    let name: String = sequence.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' || c == '_' { c } else { '_' }).collect();
    if name.is_empty() { "walk".into() } else { name }
}

// ---------------------------------------------------------------------------------------------
// Tables of the study
// ---------------------------------------------------------------------------------------------

#[derive(Serialize)]
struct TrialRow {
    sequence: String,
    subject: String,
    condition: String,
    n_frames: usize,
    n_cycles_left: usize,
    n_cycles_right: usize,
    mean_cycle_s: f64,
    frequency_hz: f64,
    n_channels: usize,
    /// Channels without a complete cycle (NaN DC): absent markers or gaps, excluded from K.
    n_channels_undefined: usize,
}

fn trials_table(trials: &[WalkRecord]) -> Result<Table> {
    let rows: Vec<TrialRow> = trials
        .iter()
        .map(|r| {
            let count = |side: &str| r.cycles.iter().filter(|c| c.side.eq_ignore_ascii_case(side)).count();
            let rate = r.curves.frame_rate.hz();
            let mean_frames = if r.cycles.is_empty() { f64::NAN } else { r.cycles.iter().map(|c| (c.end - c.start) as f64).sum::<f64>() / r.cycles.len() as f64 };
            TrialRow {
                sequence: r.sequence.clone(),
                subject: r.subject.clone(),
                condition: r.condition.clone(),
                n_frames: r.n_frames,
                n_cycles_left: count("left"),
                n_cycles_right: count("right"),
                mean_cycle_s: mean_frames / rate,
                frequency_hz: r.parameters.frequency_hz,
                n_channels: r.parameters.channels.len(),
                n_channels_undefined: r.parameters.dc.iter().filter(|v| !v.is_finite()).count(),
            }
        })
        .collect();
    Table::from_records("trials", "Trials: subject, condition, gait cycles and channels without a complete cycle", &rows)
}

#[derive(Serialize)]
struct PaperRow {
    normal_condition: String,
    condition: String,
    channel: String,
    mean_pct: f64,
    sd_pct: f64,
    cv_pct: f64,
    n_subjects: usize,
    n_excluded: usize,
    /// |CV| within the threshold (and enough subjects): a feature channel here.
    feature: bool,
    /// Listed in the paper's table (`[[published]]`): kept even when it is no feature here.
    in_paper: bool,
}

/// Table 2 (posture: `Component::Dc`) or 3 (size: `Component::Amplitude`) in the paper's form:
/// mean, s.d. and CV of K for the feature channels of each condition, plus the channels in
/// `listed` (the paper's rows, from `[[published]]`) even when they are no feature here.
fn paper_table(analysis: &StudyChanges, component: Component, listed: &[String], max_abs_cv_pct: f64) -> Result<Table> {
    let rows: Vec<PaperRow> = analysis
        .conditions
        .iter()
        .flat_map(|c| {
            c.summary.iter().filter(move |s| s.component == component && (s.feature || listed.contains(&s.channel))).map(move |s| PaperRow {
                normal_condition: analysis.normal_condition.clone(),
                condition: c.condition.clone(),
                channel: s.channel.clone(),
                mean_pct: s.mean_pct,
                sd_pct: s.sd_pct,
                cv_pct: s.cv_pct,
                n_subjects: s.n_subjects,
                n_excluded: s.n_excluded,
                feature: s.feature,
                in_paper: listed.contains(&s.channel),
            })
        })
        .collect();
    let (name, what, number) = match component {
        Component::Dc => (TABLE_POSTURE, "posture (DC)", 2),
        Component::Amplitude => (TABLE_SIZE, "size (amplitude)", 3),
    };
    Table::from_records(
        name,
        format!("Feature channels of {what}: mean, s.d. and CV of K over subjects (|CV| ≤ {max_abs_cv_pct} %; Osafune et al. Table {number})"),
        &rows,
    )
}

impl GaitWorkflow {
    fn paper_tables(&self, analysis: &StudyChanges, max_abs_cv_pct: f64) -> Result<Vec<Table>> {
        [(TABLE_POSTURE, Component::Dc), (TABLE_SIZE, Component::Amplitude)]
            .into_iter()
            .map(|(name, component)| {
                let listed = self.published_channels.get(name).cloned().unwrap_or_default();
                paper_table(analysis, component, &listed, max_abs_cv_pct)
            })
            .collect()
    }
}

// ---------------------------------------------------------------------------------------------
// Figures of the study
// ---------------------------------------------------------------------------------------------

/// The other conditions, in order of first appearance, after the normal one.
fn conditions_in_order(trials: &[WalkRecord], normal: &str) -> Vec<String> {
    let mut v = vec![normal.to_string()];
    for t in trials {
        if !v.contains(&t.condition) {
            v.push(t.condition.clone());
        }
    }
    v
}

/// The foot whose cycles frame a channel: its own side (`_l.` / `Left…` → Left), else the left.
fn side_of(channel: &str) -> &'static str {
    let lower = channel.to_ascii_lowercase();
    if lower.contains("_r.") || lower.starts_with("right") {
        "Right"
    } else {
        "Left"
    }
}

const CYCLE_POINTS: usize = 101;

/// Mean gait cycle of one channel per condition, averaged over subjects (each subject's mean
/// cycle of the channel's own foot, time-normalised to 0–100 %).
fn mean_cycle_figure(trials: &[WalkRecord], channel: &str, normal: &str, conditions: &[String]) -> Result<Figure> {
    let side = side_of(channel);
    let mut lines = Vec::new();
    let mut found = false;
    for cond in conditions {
        let mut sum = vec![0.0; CYCLE_POINTS];
        let mut n = 0usize;
        for t in trials.iter().filter(|t| t.condition == *cond) {
            let Ok(k) = t.curves.channel_index(channel) else { continue };
            found = true;
            let groups = cycles_by_side(&t.cycles);
            let Some((_, cycles)) = groups.iter().find(|(s, _)| s.eq_ignore_ascii_case(side)) else { continue };
            if let Some(m) = mean_gait_cycle(&t.curves.values[k], cycles, CYCLE_POINTS) {
                sum.iter_mut().zip(&m).for_each(|(s, v)| *s += v);
                n += 1;
            }
        }
        if n > 0 {
            let x: Vec<f64> = (0..CYCLE_POINTS).map(|i| i as f64 * 100.0 / (CYCLE_POINTS - 1) as f64).collect();
            lines.push(Series::new(format!("{cond} (mean of {n} subjects)"), x, sum.iter().map(|s| s / n as f64).collect()));
        }
    }
    if !found {
        let names = trials.first().map(|t| t.curves.channels.clone()).unwrap_or_default();
        let close = registry::closest_names(channel, names.iter().map(String::as_str));
        return Err(Error::new(ErrorKind::UnknownName, format!("figure channel {channel:?} is not a channel of the trials (closest: {})", close.join(", "))));
    }
    Ok(Figure::chart(
        format!("mean_cycle_{}", sanitize(channel)),
        Chart {
            title: format!("{channel}: mean gait cycle ({side} foot strike to strike), {normal} vs other conditions"),
            x_label: "gait cycle (%)".into(),
            y_label: format!("{channel} (deg)"),
            lines,
            ..Default::default()
        },
    ))
}

/// K_j of the gait frequency per subject, one chart per condition, with μ as a line.
fn frequency_figures(analysis: &StudyChanges) -> Result<Vec<Figure>> {
    Ok(analysis
        .conditions
        .iter()
        .map(|c| {
            let valid: Vec<(usize, &motionlab_gait::change_rates::FrequencyChange)> =
                c.frequency.iter().enumerate().filter(|(_, f)| f.k_pct.is_finite()).collect();
            let mut pts = Series::new("K_j", valid.iter().map(|(i, _)| (*i + 1) as f64).collect(), valid.iter().map(|(_, f)| f.k_pct).collect());
            pts.point_labels = valid.iter().map(|(_, f)| f.subject.clone()).collect();
            Figure::chart(
                format!("frequency_change_{}", sanitize(&c.condition)),
                Chart {
                    title: format!("Gait frequency change K_j per subject, {} vs {} (μ = {:.1} %, CV = {:.1} %)", c.condition, analysis.normal_condition, c.frequency_mean_pct, c.frequency_cv_pct),
                    x_label: "subject (number in study order)".into(),
                    y_label: "K_j (%)".into(),
                    points: vec![pts],
                    hlines: vec![RefLine { label: "μ".into(), value: c.frequency_mean_pct }],
                    // Room for the last point's label.
                    x_range: Some((0.5, c.frequency.len() as f64 + 1.5)),
                    ..Default::default()
                },
            )
        })
        .collect())
}

// ---------------------------------------------------------------------------------------------
// Walk control
// ---------------------------------------------------------------------------------------------

#[derive(Serialize)]
struct ControlChangeRow {
    walk_channel: String,
    trial_channel: String,
    /// μ of the DC change (%); NaN when the trial channel's DC is no feature (unchanged).
    mu_dc_pct: f64,
    mu_amplitude_pct: f64,
    offset_deg: f64,
    recorded_dc_deg: f64,
    synthesised_dc_deg: f64,
    recorded_amplitude_deg: f64,
    synthesised_amplitude_deg: f64,
}

#[derive(Serialize)]
struct ControlWalkRow {
    sequence: String,
    condition: String,
    frequency_change_pct: f64,
    time_factor: f64,
    n_frames_recorded: usize,
    n_frames_synthesised: usize,
    n_cycles: usize,
    recorded_frequency_hz: f64,
    synthesised_frequency_hz: f64,
    bvh_file: String,
}

#[derive(Serialize)]
struct CurveRow {
    channel: String,
    frame: usize,
    time_s: f64,
    synthesised_deg: f64,
}

/// The skeleton's channels in storage order, each with the names it may carry as an angle
/// channel (BVH and ASF spelling) and whether it is a rotation.
fn skeleton_channels(sk: &SkeletonMotion) -> Vec<([String; 2], bool)> {
    sk.skeleton
        .joints
        .iter()
        .flat_map(|j| {
            j.channels
                .iter()
                .map(move |c| ([format!("{}.{}", j.name, c.bvh_name()), format!("{}.{}", j.name, c.short_name())], matches!(c, ChannelKind::Rotation(_))))
        })
        .collect()
}

/// Cycles of a walk played `s` times faster: bounds divided by `s`, rounded, inside the new walk.
fn scaled_cycles(cycles: &[GaitCycle], s: f64, n_frames: usize) -> Vec<GaitCycle> {
    cycles
        .iter()
        .filter_map(|c| {
            let start = (c.start as f64 / s).round() as usize;
            let end = ((c.end as f64 / s).round() as usize).min(n_frames.saturating_sub(1));
            (end > start).then(|| GaitCycle { start, end, side: c.side.clone() })
        })
        .collect()
}

impl GaitWorkflow {
    fn control_walk(&self, c: &BuiltControl, walk: &WalkRecord, analysis: &StudyChanges, data: &Datasets, draw: bool, out: &mut Output) -> Result<()> {
        let spec = &c.spec;
        let fail = |e: Error| e.under_field("gait.control");
        let synthesizer = self.synthesizer.as_deref().ok_or_else(|| fail(Error::new(ErrorKind::MissingKey, "needs a synthesizer")))?;
        let loaded = data.load(c.dataset, 0)?;
        let motion = &loaded.motion;
        let file = data.datasets[c.dataset].files[0].clone();
        let Some(sk) = &motion.skeleton else {
            return Err(fail(Error::new(ErrorKind::MissingData, "the control walk has no skeleton; expected a BVH or ASF/AMC motion").with_location(Location::file(&file))));
        };
        let changes = analysis.condition(&spec.condition).map_err(fail)?.walk_changes();
        // The trial channels' μ, renamed to the walk's channels.
        let mut walk_changes = WalkChanges { frequency_percent: changes.frequency_percent, ..Default::default() };
        for (from, to) in &spec.channel_map {
            if walk.curves.channel_index(to).is_err() {
                let close = registry::closest_names(to, walk.curves.channels.iter().map(String::as_str));
                return Err(self.config_error(
                    "gait.control.channel_map",
                    Error::new(ErrorKind::UnknownName, format!("{from:?} maps to {to:?}, which is not a channel of the control walk (closest: {})", close.join(", "))),
                ));
            }
            if let Some(v) = changes.dc_percent.get(from) {
                walk_changes.dc_percent.insert(to.clone(), *v);
            }
            if let Some(v) = changes.amplitude_percent.get(from) {
                walk_changes.amplitude_percent.insert(to.clone(), *v);
            }
        }
        // The walk's angle channels (offsets removed) plus its translation channels: passed
        // through the synthesizer unchanged, so they are retimed exactly like the angles.
        let channels = skeleton_channels(sk);
        let mut curves = walk.curves.clone();
        if curves.n_frames() != sk.n_frames() {
            return Err(fail(Error::new(ErrorKind::Mismatch, format!("the walk's angles have {} frames, its skeleton {}", curves.n_frames(), sk.n_frames()))));
        }
        for (ch, o) in &spec.offset_deg {
            let k = curves.channel_index(ch).map_err(fail)?;
            curves.values[k].iter_mut().for_each(|v| *v -= o);
        }
        let mut translations = Vec::new();
        for (index, (names, rotation)) in channels.iter().enumerate() {
            if !rotation {
                curves.channels.push(names[0].clone());
                curves.values.push(sk.channel(index));
                translations.push(names[0].clone());
            }
        }
        let mut synth = synthesizer.synthesize(&curves, &walk.cycles, &walk_changes).map_err(|e| e.in_file(&file).under_field("gait.synthesizer"))?;
        for (ch, o) in &spec.offset_deg {
            let k = synth.channel_index(ch).map_err(fail)?;
            synth.values[k].iter_mut().for_each(|v| *v += o);
        }
        let n_out = synth.n_frames();
        let mut columns: Vec<&Vec<f64>> = Vec::with_capacity(channels.len());
        for (names, _) in &channels {
            let k = synth.channels.iter().position(|c| names.contains(c)).ok_or_else(|| {
                fail(Error::new(
                    ErrorKind::UnknownName,
                    format!("the walk's angle source gives no channel {:?}; expected the skeleton's rotation channels (use skeleton_joint_angles)", names[0]),
                ))
            })?;
            columns.push(&synth.values[k]);
        }
        let frame_major: Vec<f64> = (0..n_out).flat_map(|f| columns.iter().map(move |c| c[f])).collect();
        let synthesised = SkeletonMotion::new(sk.skeleton.clone(), frame_major).map_err(fail)?;
        let mut bvh = Vec::new();
        motionlab_io::bvh::write_bvh(&synthesised, motion.frame_rate(), LengthUnit::Millimetre, &mut bvh).map_err(fail)?;
        let suffix = if self.combo_index == 0 { String::new() } else { format!("_c{}", self.combo_index) };
        let bvh_name = format!("{}_{}{suffix}.bvh", sanitize(&walk.sequence), sanitize(&spec.condition));
        out.files.push((bvh_name.clone(), bvh));

        // What was applied, and what the synthesised walk measures (over the scaled cycles).
        let s = 1.0 + walk_changes.frequency_percent / 100.0;
        let cycles_out = scaled_cycles(&walk.cycles, s, n_out);
        let angle_curves_out = AngleCurves {
            frame_rate: synth.frame_rate,
            channels: synth.channels.iter().filter(|c| !translations.contains(c)).cloned().collect(),
            values: synth.channels.iter().zip(&synth.values).filter(|(c, _)| !translations.contains(c)).map(|(_, v)| v.clone()).collect(),
        };
        let measured = self.analyzer.parameters(&angle_curves_out, &cycles_out).map_err(|e| e.under_field("gait.waveform"))?;
        let get = |p: &WaveformParameters, ch: &str| p.channels.iter().position(|c| c == ch).map(|i| (p.dc[i], p.amplitude[i])).unwrap_or((f64::NAN, f64::NAN));
        let rows: Vec<ControlChangeRow> = spec
            .channel_map
            .iter()
            .map(|(from, to)| {
                let (d0, a0) = get(&walk.parameters, to);
                let (d1, a1) = get(&measured, to);
                ControlChangeRow {
                    walk_channel: to.clone(),
                    trial_channel: from.clone(),
                    mu_dc_pct: changes.dc_percent.get(from).copied().unwrap_or(f64::NAN),
                    mu_amplitude_pct: changes.amplitude_percent.get(from).copied().unwrap_or(f64::NAN),
                    offset_deg: spec.offset_deg.get(to).copied().unwrap_or(0.0),
                    recorded_dc_deg: d0,
                    synthesised_dc_deg: d1,
                    recorded_amplitude_deg: a0,
                    synthesised_amplitude_deg: a1,
                }
            })
            .collect();
        out.tables.push(Table::from_records(
            "control_changes",
            format!("Control of {}: μ applied per mapped channel ({} vs {}; NaN = not a feature, unchanged) and the DC/amplitude measured before and after", walk.sequence, spec.condition, analysis.normal_condition),
            &rows,
        )?);
        out.tables.push(Table::from_records(
            "control_walk",
            format!("Control of {}: the whole walk played at (1 + μ_f/100) times its frequency", walk.sequence),
            &[ControlWalkRow {
                sequence: walk.sequence.clone(),
                condition: spec.condition.clone(),
                frequency_change_pct: walk_changes.frequency_percent,
                time_factor: s,
                n_frames_recorded: walk.n_frames,
                n_frames_synthesised: n_out,
                n_cycles: walk.cycles.len(),
                recorded_frequency_hz: walk.parameters.frequency_hz,
                synthesised_frequency_hz: measured.frequency_hz,
                bvh_file: format!("files/{bvh_name}"),
            }],
        )?);
        let rate = synth.frame_rate.hz();
        let curve_rows: Vec<CurveRow> = spec
            .channel_map
            .values()
            .filter_map(|to| synth.channel_index(to).ok().map(|k| (to, k)))
            .flat_map(|(to, k)| synth.values[k].iter().enumerate().map(move |(f, v)| CurveRow { channel: to.clone(), frame: f, time_s: f as f64 / rate, synthesised_deg: *v }))
            .collect();
        out.tables.push(Table::from_records("control_curves", format!("Synthesised {} angle curves of {} (mapped channels)", spec.condition, walk.sequence), &curve_rows)?);

        if draw {
            let names = sk.skeleton.point_names();
            let positions = synthesised.positions();
            let synth_motion = Motion::new(format!("{} ({})", walk.sequence, spec.condition), motion.frame_rate(), motion.up_axis(), PointKind::Joint, names, positions)?;
            out.figures.push(self.fig5(c, walk, motion, &synth_motion, &walk.curves, &synth, &cycles_out, analysis)?);
            for (to, k) in spec.channel_map.values().filter_map(|to| walk.curves.channel_index(to).ok().map(|k| (to, k))) {
                let changed = walk_changes.dc_percent.contains_key(to) || walk_changes.amplitude_percent.contains_key(to);
                let (Ok(ks), true) = (synth.channel_index(to), changed) else { continue };
                let t = |n: usize| (0..n).map(|f| f as f64 / rate).collect::<Vec<f64>>();
                out.figures.push(Figure::chart(
                    format!("control_{}", sanitize(to)),
                    Chart {
                        title: format!("{} — {to}: recorded {} vs synthesised {}", walk.sequence, analysis.normal_condition, spec.condition),
                        x_label: "time (s)".into(),
                        y_label: format!("{to} (deg)"),
                        lines: vec![
                            Series::new(format!("recorded {}", analysis.normal_condition), t(walk.curves.n_frames()), walk.curves.values[k].clone()),
                            Series::new(format!("synthesised {}", spec.condition), t(n_out), synth.values[ks].clone()),
                        ],
                        ..Default::default()
                    },
                ));
            }
        }
        Ok(())
    }

    /// The paper's Fig 5: recorded normal walk and synthesised walk, a stick figure every
    /// `strip_every_frames` frames from a frame inside each walk's middle gait cycle.
    #[allow(clippy::too_many_arguments)]
    fn fig5(
        &self,
        c: &BuiltControl,
        walk: &WalkRecord,
        recorded: &Motion,
        synthesised: &Motion,
        recorded_curves: &AngleCurves,
        synth_curves: &AngleCurves,
        synth_cycles: &[GaitCycle],
        analysis: &StudyChanges,
    ) -> Result<Figure> {
        let spec = &c.spec;
        let bones = recorded.skeleton.as_ref().map(|s| s.skeleton.bones()).unwrap_or_default();
        let start_in = |curves: &AngleCurves, cycles: &[GaitCycle], n_frames: usize| -> Result<usize> {
            let mut sorted: Vec<&GaitCycle> = cycles.iter().collect();
            sorted.sort_by_key(|c| c.start);
            let Some(mid) = sorted.get(sorted.len() / 2) else { return Ok(0) };
            let last_start = n_frames.saturating_sub((spec.strip_poses - 1) * spec.strip_every_frames + 1);
            let (a, b) = (mid.start.min(last_start), mid.end.min(last_start));
            let Some([ca, cb]) = &spec.strip_start else { return Ok(a) };
            let index = |ch: &str| curves.channel_index(ch).map_err(|e| self.config_error("gait.control.strip_start", e));
            let (ia, ib) = (index(ca)?, index(cb)?);
            Ok((a..=b).min_by(|x, y| (curves.values[ia][*x] - curves.values[ib][*x]).abs().total_cmp(&(curves.values[ia][*y] - curves.values[ib][*y]).abs())).unwrap_or(a))
        };
        let root = Some(0);
        let row = |m: &Motion, label: &str, start: usize| {
            let frames: Vec<usize> = (0..spec.strip_poses).map(|k| start + k * spec.strip_every_frames).filter(|f| *f < m.n_frames()).collect();
            let axis = match (frames.first(), frames.last()) {
                (Some(&a), Some(&b)) => main_floor_axis(m, root, a, b),
                _ => m.up_axis().others()[0],
            };
            let up = m.up_axis().index();
            let rate = m.frame_rate().hz();
            (
                StickRow {
                    label: label.to_string(),
                    poses: frames
                        .iter()
                        .map(|&f| Pose { label: format!("{f} ({:.2} s)", f as f64 / rate), points: m.frame(f).iter().map(|p| [p[axis], p[up]]).collect() })
                        .collect(),
                },
                axis,
            )
        };
        let s0 = start_in(recorded_curves, &walk.cycles, recorded.n_frames())?;
        let s1 = start_in(synth_curves, synth_cycles, synthesised.n_frames())?;
        let (r0, axis) = row(recorded, &format!("recorded {}", analysis.normal_condition), s0);
        let (r1, _) = row(synthesised, &format!("synthesised {}", spec.condition), s1);
        Ok(Figure::sticks(
            format!("fig5_{}", sanitize(&walk.sequence)),
            stick_strip(
                format!("{}: recorded {} walk and the synthesised {} walk, every {} frames (Osafune et al. Fig 5)", walk.sequence, analysis.normal_condition, spec.condition, spec.strip_every_frames),
                bones,
                vec![r0, r1],
                format!("side view: {} horizontal, {} up (mm); each pose centred", axis_name(axis), recorded.up_axis()),
            ),
        ))
    }
}

// ---------------------------------------------------------------------------------------------
// Leave-one-subject-out
// ---------------------------------------------------------------------------------------------

#[derive(Serialize)]
struct VerdictRow {
    normal_condition: String,
    condition: String,
    n_subjects: usize,
    rms_synth_deg: f64,
    rms_normal_deg: f64,
    rms_synth_controlled_deg: f64,
    rms_normal_controlled_deg: f64,
    dtw_synth_deg: f64,
    dtw_normal_deg: f64,
    /// Mean |f_synthesised − f_recorded| and |f_normal − f_recorded| (Hz).
    frequency_error_synth_hz: f64,
    frequency_error_normal_hz: f64,
    /// Subjects whose synthesised walk has the lower mean RMS error.
    subjects_synth_better_rms: usize,
    beats_baseline_rms: bool,
    beats_baseline_dtw: bool,
    verdict: String,
}

fn loso_verdict(loso: &LosoResult, normal: &str) -> Result<Table> {
    let m = &loso.mean;
    let mean_abs = |f: fn(&motionlab_gait::loso::LosoSubjectRecord) -> f64| {
        let v: Vec<f64> = loso.subjects.iter().map(f).filter(|x| x.is_finite()).collect();
        if v.is_empty() { f64::NAN } else { v.iter().sum::<f64>() / v.len() as f64 }
    };
    let beats_rms = m.rms_synth_deg < m.rms_normal_deg;
    let beats_dtw = m.dtw_synth_deg < m.dtw_normal_deg;
    let verdict = match (beats_rms, beats_dtw) {
        (true, true) => "feature-channel control beats the unchanged normal walk on shape (RMS and DTW)",
        (true, false) => "feature-channel control beats the unchanged normal walk on RMS but not on DTW",
        (false, true) => "feature-channel control beats the unchanged normal walk on DTW but not on RMS",
        (false, false) => "feature-channel control does not beat the unchanged normal walk on shape (RMS or DTW)",
    };
    Table::from_records(
        "loso_verdict",
        format!("Leave-one-subject-out verdict: synthesised {} walk vs the unchanged {normal} walk, mean over subjects", loso.target_condition),
        &[VerdictRow {
            normal_condition: normal.to_string(),
            condition: loso.target_condition.clone(),
            n_subjects: loso.subjects.len(),
            rms_synth_deg: m.rms_synth_deg,
            rms_normal_deg: m.rms_normal_deg,
            rms_synth_controlled_deg: m.rms_synth_controlled_deg,
            rms_normal_controlled_deg: m.rms_normal_controlled_deg,
            dtw_synth_deg: m.dtw_synth_deg,
            dtw_normal_deg: m.dtw_normal_deg,
            frequency_error_synth_hz: mean_abs(|r| (r.frequency_synth_hz - r.frequency_recorded_hz).abs()),
            frequency_error_normal_hz: mean_abs(|r| (r.frequency_normal_hz - r.frequency_recorded_hz).abs()),
            subjects_synth_better_rms: loso.subjects.iter().filter(|r| r.rms_synth_deg < r.rms_normal_deg).count(),
            beats_baseline_rms: beats_rms,
            beats_baseline_dtw: beats_dtw,
            verdict: verdict.to_string(),
        }],
    )
}

fn loso_figure(loso: &LosoResult, normal: &str) -> Figure {
    let x: Vec<f64> = (1..=loso.subjects.len()).map(|i| i as f64).collect();
    let series = |label: String, f: fn(&motionlab_gait::loso::LosoSubjectRecord) -> f64, labelled: bool| {
        let mut s = Series::new(label, x.clone(), loso.subjects.iter().map(f).collect());
        if labelled {
            s.point_labels = loso.subjects.iter().map(|r| r.subject.clone()).collect();
        }
        s
    };
    Figure::chart(
        format!("loso_rms_{}", sanitize(&loso.target_condition)),
        Chart {
            title: format!("Leave-one-subject-out: mean RMS error per held-out subject against the recorded {} walk", loso.target_condition),
            x_label: "held-out subject (number in study order)".into(),
            y_label: "mean RMS error over channels (deg)".into(),
            points: vec![
                series(format!("synthesised {}", loso.target_condition), |r| r.rms_synth_deg, true),
                series(format!("unchanged {normal}"), |r| r.rms_normal_deg, false),
            ],
            x_range: Some((0.5, loso.subjects.len() as f64 + 1.5)),
            hlines: vec![
                RefLine { label: "mean, synthesised".into(), value: loso.mean.rms_synth_deg },
                RefLine { label: format!("mean, unchanged {normal}"), value: loso.mean.rms_normal_deg },
            ],
            ..Default::default()
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_core::registry::ParamGuard;
    use motionlab_gait::change_rates::ChangeRatesParams;
    use motionlab_testkit::gait_trial as trial;

    #[test]
    fn subject_rule_reads_a_field_of_the_stem() {
        let r = SubjectRule::default();
        assert_eq!(r.subject_of("2014001_C4_05").as_deref(), Some("2014001"));
        let r = SubjectRule { separator: "_".into(), field: 1 };
        assert_eq!(r.subject_of("2014001_C4_05").as_deref(), Some("C4"));
        let r = SubjectRule { separator: "-".into(), field: 1 };
        assert_eq!(r.subject_of("2014001_C4_05"), None);
        assert_eq!(SubjectRule::default().subject_of("_x"), None);
    }

    #[test]
    fn scaled_cycles_stay_inside_the_faster_walk() {
        let cycles = vec![GaitCycle { start: 10, end: 110, side: "Left".into() }, GaitCycle { start: 110, end: 219, side: "Left".into() }];
        // 220 frames at s = 1.25 → 176 frames (0..=175).
        let out = scaled_cycles(&cycles, 1.25, 176);
        assert_eq!(out[0], GaitCycle { start: 8, end: 88, side: "Left".into() });
        assert_eq!(out[1].start, 88);
        assert_eq!(out[1].end, 175); // 219 / 1.25 = 175.2
    }

    /// Knee DC K = 20, 10, 30 % (CV 40.8 %: a feature); hip-rotation DC K = 20, −20, 0 %
    /// (μ = 0: no feature); amplitudes K = 10, 10, 10 % and 50, −50, 50 %.
    fn analysis(max_abs_cv_pct: f64) -> StudyChanges {
        let study = motionlab_core::GaitStudy {
            normal_condition: "walk".into(),
            trials: vec![
                trial("a", "walk", [20.0, 10.0], [30.0, 4.0], 1.0),
                trial("b", "walk", [10.0, -10.0], [20.0, 4.0], 1.0),
                trial("c", "walk", [40.0, 10.0], [10.0, 4.0], 1.0),
                trial("a", "run", [24.0, 12.0], [33.0, 6.0], 1.2),
                trial("b", "run", [11.0, -8.0], [22.0, 2.0], 1.2),
                trial("c", "run", [52.0, 10.0], [11.0, 6.0], 1.2),
            ],
        };
        ChangeRatesParams { min_subjects: 2, max_abs_cv_pct, ..Default::default() }.check().unwrap().analyse(&study).unwrap()
    }

    fn text(t: &Table, col: &str) -> Vec<String> {
        (0..t.n_rows()).map(|r| t.column(col).unwrap().cell(r)).collect()
    }

    #[test]
    fn paper_tables_hold_the_feature_channels_and_the_papers_rows() {
        let a = analysis(250.0);
        let t = paper_table(&a, Component::Dc, &[], 250.0).unwrap();
        assert_eq!(t.name, TABLE_POSTURE);
        assert_eq!(text(&t, "channel"), ["knee_l.flexion"]);
        assert_eq!(text(&t, "condition"), ["run"]);
        let sd = (200.0f64 / 3.0).sqrt();
        match (t.column("mean_pct"), t.column("cv_pct")) {
            (Some(motionlab_core::ColumnValues::F64(m)), Some(motionlab_core::ColumnValues::F64(v))) => {
                assert!((m[0] - 20.0).abs() < 1e-12 && (v[0] - sd / 20.0 * 100.0).abs() < 1e-12, "{m:?} {v:?}");
            }
            other => panic!("{other:?}"),
        }
        // A channel the paper lists stays, flagged: no feature here (μ = 0 → CV undefined).
        let t = paper_table(&a, Component::Dc, &["hip_l.rotation".to_string(), "upper chest".to_string()], 250.0).unwrap();
        assert_eq!(text(&t, "channel"), ["knee_l.flexion", "hip_l.rotation"]);
        assert_eq!(text(&t, "feature"), ["true", "false"]);
        assert_eq!(text(&t, "in_paper"), ["false", "true"]);
        // Size: knee amplitude K = 10 % for all (CV 0); hip rotation 50, −50, 50 % (CV 282.8 %).
        let t = paper_table(&a, Component::Amplitude, &[], 250.0).unwrap();
        assert_eq!(t.name, TABLE_SIZE);
        assert_eq!(text(&t, "channel"), ["knee_l.flexion"]);
        // The feature flag is the analysis's (its threshold), not re-decided by the table.
        let t = paper_table(&analysis(300.0), Component::Amplitude, &[], 300.0).unwrap();
        assert_eq!(text(&t, "channel"), ["knee_l.flexion", "hip_l.rotation"]);
    }

    fn subject_record(subject: &str, rms: (f64, f64), dtw: (f64, f64), f: (f64, f64, f64)) -> motionlab_gait::loso::LosoSubjectRecord {
        motionlab_gait::loso::LosoSubjectRecord {
            subject: subject.into(),
            n_channels: 2,
            n_controlled: 1,
            rms_synth_deg: rms.0,
            rms_normal_deg: rms.1,
            rms_synth_controlled_deg: rms.0,
            rms_normal_controlled_deg: rms.1,
            dtw_synth_deg: dtw.0,
            dtw_normal_deg: dtw.1,
            frequency_normal_hz: f.0,
            frequency_synth_hz: f.1,
            frequency_recorded_hz: f.2,
        }
    }

    #[test]
    fn the_verdict_follows_the_means_and_counts_subjects() {
        let subjects = vec![subject_record("a", (2.0, 3.0), (1.0, 1.5), (1.0, 1.2, 1.25)), subject_record("b", (4.0, 3.5), (2.0, 1.5), (0.8, 0.96, 0.9))];
        let mean = subject_record("mean", (3.0, 3.25), (1.5, 1.5), (0.9, 1.08, 1.075));
        let loso = LosoResult { target_condition: "run".into(), channels: vec![], subjects, channel_means: vec![], mean, changes: vec![], skipped: vec![] };
        let t = loso_verdict(&loso, "walk").unwrap();
        assert_eq!(t.n_rows(), 1);
        assert_eq!(text(&t, "beats_baseline_rms"), ["true"]);
        // DTW ties: not beaten.
        assert_eq!(text(&t, "beats_baseline_dtw"), ["false"]);
        assert_eq!(text(&t, "subjects_synth_better_rms"), ["1"]);
        // |1.2 − 1.25| and |0.96 − 0.9| → 0.055; |1 − 1.25| and |0.8 − 0.9| → 0.175.
        match (t.column("frequency_error_synth_hz"), t.column("frequency_error_normal_hz")) {
            (Some(motionlab_core::ColumnValues::F64(s)), Some(motionlab_core::ColumnValues::F64(n))) => {
                assert!((s[0] - 0.055).abs() < 1e-12 && (n[0] - 0.175).abs() < 1e-12, "{s:?} {n:?}");
            }
            other => panic!("{other:?}"),
        }
        assert!(text(&t, "verdict")[0].contains("on RMS but not on DTW"));
    }

    #[test]
    fn skeleton_channels_carry_both_spellings_in_storage_order() {
        use motionlab_core::{Axis, Joint, Skeleton};
        let root = Joint::new("Hips", None, [0.0; 3], vec![ChannelKind::Translation(Axis::X), ChannelKind::Rotation(Axis::Z)]);
        let knee = Joint::new("LeftKnee", Some(0), [0.0, -400.0, 0.0], vec![ChannelKind::Rotation(Axis::X)]);
        let sk = SkeletonMotion::new(Skeleton { joints: vec![root, knee] }, vec![0.0; 6]).unwrap();
        let ch = skeleton_channels(&sk);
        assert_eq!(ch.len(), 3);
        assert_eq!(ch[0], (["Hips.Xposition".to_string(), "Hips.tx".to_string()], false));
        assert_eq!(ch[2], (["LeftKnee.Xrotation".to_string(), "LeftKnee.rx".to_string()], true));
    }

    #[test]
    fn side_of_reads_the_channel_side() {
        assert_eq!(side_of("knee_r.flexion"), "Right");
        assert_eq!(side_of("RightKnee.Xrotation"), "Right");
        assert_eq!(side_of("knee_l.flexion"), "Left");
        assert_eq!(side_of("lumbar.flexion"), "Left");
    }
}
