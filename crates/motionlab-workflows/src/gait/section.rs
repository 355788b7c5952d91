//! The `[gait]` section of the experiment file: its keys, their defaults and documentation.

use std::collections::BTreeMap;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_experiment::spec::StageSpec;

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
    pub(super) fn wants(&self, sequence: &str, subject: &str) -> bool {
        match self {
            ViewerChoice::Keyword(k) => *k == ViewerKeyword::All,
            ViewerChoice::Only(list) => {
                list.iter().any(|x| x == sequence || (!subject.is_empty() && x == subject))
            }
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
        stem.split(self.separator.as_str())
            .nth(self.field)
            .filter(|s| !s.is_empty())
            .map(str::to_string)
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
