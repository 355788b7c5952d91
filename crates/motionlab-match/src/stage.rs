//! The matching family's records and stage kinds (Yabe & Tanaka): what a point detector
//! finds in a take of repetitions, how a model aligns to a stretch of a take, how synchronised
//! the points are along it — and the results the matching workflow hands its evaluators.
//!
//! The kinds (`point_detector`, `matcher`, `synchroniser`) are declared here, beside their
//! traits, not in core: core knows neither the traits nor the records. Their plugins register
//! with `register_custom_plugin!(Matcher, Params, "name", kind = "matcher")` and are built with
//! [`build_matcher`] and its siblings.

use serde::{Deserialize, Serialize};

use motionlab_core::registry::build_custom;
use motionlab_core::{EvalInputType, Motion, Result, Trace};

motionlab_core::declare_stage_kind!("point_detector", label = "point detector", list_order = 51);
motionlab_core::declare_stage_kind!("matcher", label = "matcher", list_order = 52);
motionlab_core::declare_stage_kind!("synchroniser", label = "synchroniser", list_order = 53);

/// What a point detector finds in a continuous take of repetitions (Yabe & Tanaka §3.1.1).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PointDetection {
    /// The velocity function `v(i) = |s_i − s_{i+1}|` of the chosen marker (mm per frame).
    pub velocity: Trace,
    /// The threshold at which exactly N peaks stood above it.
    pub threshold: f64,
    /// Frame of each peak's maximum, in time order.
    pub peaks: Vec<usize>,
    /// Window `start..end` (end exclusive) cut around each peak.
    pub windows: Vec<(usize, usize)>,
}

/// A model motion aligned to a stretch of a target motion (Yabe & Tanaka §3.1).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Alignment {
    /// First matched target frame `a` (0-based, into the target given to the matcher).
    pub start: usize,
    /// Last matched target frame `b` (inclusive).
    pub end: usize,
    /// Per-point distance `h_l`, in the order of the model's points (mm, summed along the path).
    pub point_distances: Vec<f64>,
    /// `H = Σ h_l`.
    pub total_distance: f64,
    /// Per-point warping path as (model frame i, target frame j) pairs from `(0, start)` to
    /// `(n−1, end)`; empty when the matcher was asked not to keep paths.
    pub paths: Vec<Vec<(usize, usize)>>,
}

/// Synchronisation of the points along an alignment (Yabe & Tanaka §3.2).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Synchronisation {
    /// The k model frames examined (dividing the model into k+1 equal sections).
    pub model_frames: Vec<usize>,
    /// `r_q`: population variance over points of the matched target index at each model frame.
    pub section_values: Vec<f64>,
    /// `R = Σ r_q`.
    pub total: f64,
}

/// One repetition matched against the model.
#[derive(Clone, Debug)]
pub struct RepetitionResult {
    /// Label for tables (`rep1`, `(b) delayed`).
    pub repetition: String,
    /// Start frame of the cut window in the user's take.
    pub window_start: usize,
    pub alignment: Alignment,
    pub synchronisation: Synchronisation,
}

/// The matched repetitions of one user take against one model.
#[derive(Clone, Debug)]
pub struct MatchingResult {
    pub take: String,
    pub point_names: Vec<String>,
    pub repetitions: Vec<RepetitionResult>,
}

/// Finds the repetitions in a continuous take and cuts a window around each.
pub trait PointDetector: Send + Sync {
    fn detect(&self, motion: &Motion) -> Result<PointDetection>;
}

/// Aligns a model motion to (a stretch of) a target motion with the same points.
pub trait Matcher: Send + Sync {
    fn align(&self, model: &Motion, target: &Motion) -> Result<Alignment>;
}

/// Measures how synchronised the points of an alignment are.
pub trait Synchroniser: Send + Sync {
    fn synchronise(&self, alignment: &Alignment, model_frames: usize) -> Result<Synchronisation>;
}

/// Builds a point detector by name from its TOML table (without the `type` key).
pub fn build_point_detector(
    name: &str,
    params: &motionlab_core::toml::Value,
) -> Result<Box<dyn PointDetector>> {
    build_custom::<dyn PointDetector>("point_detector", name, params)
}

/// Builds a matcher by name from its TOML table (without the `type` key).
pub fn build_matcher(name: &str, params: &motionlab_core::toml::Value) -> Result<Box<dyn Matcher>> {
    build_custom::<dyn Matcher>("matcher", name, params)
}

/// Builds a synchroniser by name from its TOML table (without the `type` key).
pub fn build_synchroniser(
    name: &str,
    params: &motionlab_core::toml::Value,
) -> Result<Box<dyn Synchroniser>> {
    build_custom::<dyn Synchroniser>("synchroniser", name, params)
}

/// Every user take's matched repetitions (`Vec<MatchingResult>`): what the matching workflow
/// hands its evaluators.
pub fn matching_results() -> EvalInputType {
    EvalInputType::of::<Vec<MatchingResult>>("matching results")
}
