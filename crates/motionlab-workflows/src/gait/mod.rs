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

mod analysis;
mod build;
mod control;
mod figures;
mod run;
mod section;
mod viewers;

pub use section::{
    ControlSection, GaitSection, LosoSection, SubjectRule, ViewerChoice, ViewerKeyword,
};

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use motionlab_core::{Evaluator, FeatureExtractor};
use motionlab_experiment::Locator;
use motionlab_features::{
    AngleCurves, GaitCycle, GaitCycleDetector, WaveformAnalyzer, WaveformParameters,
};
use motionlab_gait::WalkSynthesizer;

/// Name of the Table 2 (posture) result table; `[[published]]` rows for it name its channels.
pub const TABLE_POSTURE: &str = "table2_posture";
/// Name of the Table 3 (size) result table.
pub const TABLE_SIZE: &str = "table3_size";

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
    /// Locates configuration errors found only once the data is seen (a figure channel no
    /// trial has).
    locator: Locator,
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
