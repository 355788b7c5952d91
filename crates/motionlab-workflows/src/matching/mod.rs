//! The `[matching]` workflow (Yabe & Tanaka): a model basic motion against a user's
//! repetitions, marker by marker — point detection (§3.1.1), two-stage DP matching (§3.1.3),
//! synchronisation (§3.2), judgement and tendency (§4) — with the paper's figures (Fig. 2, 4,
//! 5, 6) and its (a)/(b)/(c) timing test (§5.2.2).
//!
//! ```toml
//! [[dataset]]                       # the model basic motion: one repetition, cut from a take
//! name = "model"
//! files = ["../data/mocap6/amc/13_30.amc.gz"]
//! loader = { type = "asf_amc" }
//! cut = { frames = [54, 180] }
//!
//! [[dataset]]                       # a continuous take of N repetitions, cut by the detector
//! files = ["../data/mocap6/amc/13_29.amc.gz"]
//! loader = { type = "asf_amc" }
//! cut = { frames = [0, 408] }
//! tags = { repetitions = "3" }
//!
//! [[dataset]]                       # or: explicit windows, one repetition per dataset
//! name = "(a) jack 1"
//! files = ["../data/mocap6/amc/13_29.amc.gz"]
//! loader = { type = "asf_amc" }
//! cut = { frames = [0, 150] }
//! tags = { take = "timing test", group = "a", pair = "jack 1" }
//!
//! [[preprocess]]
//! type = "initial_pose_normalisation"
//!
//! [matching]
//! model = "model"
//! point_detector = { type = "velocity_peaks", marker = "lhand", before = { seconds = 0.4 }, after = { seconds = 0.4 } }
//! peaks_per_repetition = 2
//! matcher = { type = "multistream_two_stage" }
//! synchroniser = { type = "synchronisation", k = 8 }
//!
//! [[evaluate]]
//! type = "judgement"
//! ```
//!
//! **Takes.** Every dataset but the model is a user take, given one of two ways:
//! - *continuous*: each file is one take of `N` repetitions (`N` from the dataset tag
//!   `repetitions = "N"`, or per take from `[matching.repetitions]`, which wins). The point
//!   detector is asked for `N × peaks_per_repetition` peaks; each run of
//!   `peaks_per_repetition` consecutive peaks is one repetition, whose window is the union of
//!   those peaks' windows. (A back-and-forth movement — an arm raised then lowered — shows two
//!   velocity "mountains" per repetition, where the paper's tennis swing shows one; the take
//!   must then start at the beginning of a repetition.)
//! - *explicit windows*: datasets tagged `take = "<name>"` are one take together, each file one
//!   repetition matched whole (no point detection), labelled by its dataset name. Optional tags
//!   `group = "a" | "b" | "c"` (the paper's close / timing-shifted / wrong repetitions) and
//!   `pair = "<label>"` (a (b) made from the (a) with the same label) turn on the timing test.
//!
//! Work items are the takes (one `MatchingResult` each); the model is reloaded in every item
//! (cheap) so items stay independent. Frames in tables and figures count from the start of the
//! file: a dataset's `cut` is added back, so they can be read against the data's labels.
//!
//! **Outputs.** Tables: `repetitions` (window, `[a, b]` in frames and seconds, `H`, `R`), the
//! evaluators' tables (`judgement`: `H'`, `R'`, score, rank; `tendency_parts`;
//! `tendency_sections`), and for the timing test `timing_ranks` and `timing_verdict` (each
//! check of §5.2.3 and whether it held). Figures: per continuous take the velocity function
//! with threshold, peaks and windows (Fig. 2); per repetition two markers' warping paths (Fig.
//! 4); per combination the `H`–`R` scatter (Fig. 5) and the normalised `H'`–`R'` scatter
//! (Fig. 6). Viewer pages (first combination): `viewers/model.html`, one per continuous take
//! (`<take>.html`: velocity peaks, matched stretches `[a, b]` labelled with rank by score, score,
//! `H` and `R`, the cut windows, the velocity function with its threshold) and one per
//! repetition of an explicit take (`<take>_<repetition>.html`: its matched stretch); the stick
//! figure is the skeleton's, through the points `distinct_points` merged.

mod analysis;
mod build;
mod figures;
mod run;
mod section;
mod viewers;

pub(crate) use build::find_model;
pub(crate) use run::cut_offset;
pub use section::{MatchingFigure, MatchingSection};

use serde::{Deserialize, Serialize};

use motionlab_core::Evaluator;
use motionlab_experiment::Locator;
use motionlab_match::{Matcher, PointDetector, Synchroniser};

/// How a take's repetitions are given.
enum TakeKind {
    /// One file cut into `count` repetitions by the point detector.
    Continuous { dataset: usize, file: usize, count: usize, detector: Box<dyn PointDetector> },
    /// Each (dataset, file) is one repetition, matched whole.
    Explicit { members: Vec<(usize, usize)> },
}

struct Take {
    id: String,
    name: String,
    kind: TakeKind,
}

pub struct MatchingWorkflow {
    section: MatchingSection,
    model: usize,
    takes: Vec<Take>,
    matcher: Box<dyn Matcher>,
    /// The points the matcher reports distances for, when its parameters name them.
    matcher_points: Option<Vec<String>>,
    synchroniser: Box<dyn Synchroniser>,
    evaluators: Vec<(String, Box<dyn Evaluator>)>,
    /// Locates configuration errors found only once the data is seen (a path marker the
    /// matcher reports no distance for).
    locator: Locator,
}

/// One matched repetition, as persisted (paths are left out: they are drawn per item).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct RepetitionRecord {
    label: String,
    group: Option<String>,
    pair: Option<String>,
    /// Velocity peaks of this repetition (file frames; empty for explicit windows).
    peaks: Vec<usize>,
    /// Window `[window_start, window_end)` in file frames.
    window_start: usize,
    window_end: usize,
    /// `a`, `b` relative to the window (the matcher's indices).
    start: usize,
    end: usize,
    point_distances: Vec<f64>,
    total_distance: f64,
    sync_frames: Vec<usize>,
    section_values: Vec<f64>,
    sync_total: f64,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct ItemResult {
    take: String,
    continuous: bool,
    frame_rate_hz: f64,
    model_frames: usize,
    point_names: Vec<String>,
    /// The detector's threshold (mm per frame), continuous takes only.
    threshold: Option<f64>,
    repetitions: Vec<RepetitionRecord>,
    /// The detector's velocity function (frames of the loaded take) and its unit, for the
    /// viewer page; kept only when drawing, continuous takes only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    velocity: Option<(Vec<f64>, String)>,
}
