//! The `[matching]` section of the experiment file: its keys, their defaults and documentation.

use std::collections::BTreeMap;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_experiment::spec::StageSpec;

/// A model basic motion against a user's repetitions, marker by marker (Yabe & Tanaka): point
/// detection, two-stage DP matching, synchronisation, the evaluators' judgement and tendency
/// (`[[evaluate]]`, matching domain), the paper's figures and its (a)/(b)/(c) timing test.
///
/// Every dataset but the model is a user take: *continuous* (tag `repetitions = "N"`, cut into
/// N repetitions by the point detector) or *explicit windows* (tag `take = "<name>"`, one
/// repetition per dataset; tags `group = "a" | "b" | "c"` and `pair` turn on the timing test).
///
/// Missing samples: the matchers refuse them (fill gaps first with `fill_gaps`).
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MatchingSection {
    /// Name of the dataset holding the model basic motion (its `name`, or the file stem of its
    /// single file). It must resolve to exactly one file, usually cut to one repetition.
    pub model: String,
    /// Markers (or joints) to match, in this order (the order of the per-part tables). Model and
    /// takes are reduced to them before matching.
    #[serde(default)]
    #[schemars(extend("x-default" = "every point of the model"))]
    pub points: Option<Vec<String>>,
    /// `{ type = "velocity_peaks", … }`: finds the repetitions of continuous takes. Its `count`
    /// is set per take by this workflow (from the `repetitions` tag), so it must not be given.
    /// Required when there is a continuous take.
    #[serde(default)]
    pub point_detector: Option<StageSpec>,
    /// Velocity peaks per repetition (2 for a back-and-forth movement; the default is the
    /// paper's).
    #[serde(default = "one")]
    pub peaks_per_repetition: usize,
    /// The matcher (the default is the paper's method).
    #[serde(default = "default_matcher")]
    pub matcher: StageSpec,
    /// The synchroniser (the default is the paper's, with its parameters at their defaults).
    #[serde(default = "default_synchroniser")]
    pub synchroniser: StageSpec,
    /// Per-take override of the number of repetitions `N`: `{ "13_29" = 3 }` (take = sequence
    /// name). Wins over the dataset tag `repetitions`.
    #[serde(default)]
    pub repetitions: BTreeMap<String, usize>,
    /// The two markers whose warping paths are drawn (Fig. 4).
    #[serde(default)]
    #[schemars(extend("x-default" = "per repetition, the two most out of step (largest summed difference of matched frames at the examined frames)"))]
    pub path_markers: Option<[String; 2]>,
    /// Which figures to draw: any of `velocity`, `paths`, `scatter`.
    #[serde(default = "default_figures")]
    pub figures: Vec<MatchingFigure>,
}

/// A figure `[matching]` draws (`figures = ["velocity", …]`); a name that is none of these is
/// an error when the experiment is validated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum MatchingFigure {
    /// Per continuous take: the velocity function with its threshold, peaks by repetition and
    /// windows (Fig. 2).
    Velocity,
    /// Per repetition: the warping paths of two markers (Fig. 4).
    Paths,
    /// Per combination: the H–R scatter (Fig. 5) and the normalised H'–R' scatter (Fig. 6).
    Scatter,
}

fn one() -> usize {
    1
}

fn default_matcher() -> StageSpec {
    StageSpec::of_type("multistream_two_stage")
}

fn default_synchroniser() -> StageSpec {
    StageSpec::of_type("synchronisation")
}

fn default_figures() -> Vec<MatchingFigure> {
    vec![MatchingFigure::Velocity, MatchingFigure::Paths, MatchingFigure::Scatter]
}
