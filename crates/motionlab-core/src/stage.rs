//! The stage traits — one per kind of pluggable step — and the plain records they exchange.
//!
//! A plugin is a params struct (serde + schemars, `deny_unknown_fields`, documented defaults)
//! that [`ParamGuard::check`]s into a validated type implementing one of these traits, plus one
//! `register_plugin!` line. See `crates/motionlab-segment/src/speed_minima.rs` for the shortest
//! complete example.

use std::any::Any;
use std::collections::HashMap;
use std::path::Path;
use std::sync::{Arc, Mutex};

use serde::{Deserialize, Serialize};

use crate::motion::{Dimensionality, Motion};
use crate::segmentation::Segmentation;
use crate::table::Table;
use crate::{Error, ErrorKind, Result};

// ---------------------------------------------------------------------------------------------
// Shared records
// ---------------------------------------------------------------------------------------------

/// A per-frame signal (one value per frame of the motion; NaN where undefined), kept so
/// figures can show what a stage decided on.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Trace {
    /// Column-safe name with its unit as suffix (`V_mm_per_s`, `C`, `D_mm3_per_frame`).
    pub name: String,
    /// Unit for axis labels (`mm/s`, `mm³/frame`, `deg`, or empty for dimensionless).
    pub unit: String,
    pub values: Vec<f64>,
}

impl Trace {
    pub fn new(name: impl Into<String>, unit: impl Into<String>, values: Vec<f64>) -> Self {
        Trace { name: name.into(), unit: unit.into(), values }
    }
}

/// A per-frame categorical signal (e.g. which marker is fastest).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LabelTrace {
    pub name: String,
    pub values: Vec<String>,
}

/// A threshold a stage compared a trace against (drawn as a horizontal line).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Threshold {
    pub name: String,
    /// The trace it applies to.
    pub trace: String,
    pub value: f64,
}

/// What a feature extractor computes for one motion.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FeatureSet {
    pub traces: Vec<Trace>,
    pub labels: Vec<LabelTrace>,
}

/// What a segmenter finds in one motion.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SegmenterOutput {
    /// Candidate boundary frames, sorted and unique.
    pub candidates: Vec<usize>,
    /// The signals behind the decision, for figures (V, the tracked marker's speed, C, D…).
    pub traces: Vec<Trace>,
    pub thresholds: Vec<Threshold>,
    /// Frames flagged as unreliable (e.g. hull degenerate: fewer than 4 non-coplanar markers).
    pub flagged_frames: Vec<usize>,
    /// The penalty path the candidates were chosen on (`kernel_cpd` with `penalty = { path
    /// }`): every segmentation of it, fewest change points first; empty without one. The
    /// segmentation workflow writes it as the table `penalty_path` and a figure.
    #[serde(default)]
    pub penalty_path: Vec<PathPoint>,
}

/// One segmentation of a penalty path: optimal for every penalty in `[pen_min, pen_max]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PathPoint {
    /// The penalty interval it owns, in the cost's units.
    pub pen_min: f64,
    pub pen_max: f64,
    /// Its unpenalised cost (the sum of its segments' costs).
    pub cost: f64,
    /// Its change points (first frames of every segment but the first).
    pub change_points: Vec<usize>,
    /// Whether the segmenter's rule chose it (its change points are the candidates).
    pub chosen: bool,
}

/// One method's candidates, as handed to a fuser.
#[derive(Clone, Copy, Debug)]
pub struct MethodCandidates<'a> {
    pub method: &'a str,
    pub frames: &'a [usize],
}

// ---------------------------------------------------------------------------------------------
// Evaluator inputs
// ---------------------------------------------------------------------------------------------

/// One method's candidates on one sequence.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MethodResult {
    pub method: String,
    pub candidates: Vec<usize>,
}

/// Everything a segmentation evaluator needs about one sequence.
#[derive(Clone, Debug)]
pub struct SequenceResult {
    pub sequence: String,
    pub motion: Arc<Motion>,
    pub truth: Option<Segmentation>,
    /// Each segmenter in experiment order, then the fuser's output (method name = fuser name).
    pub methods: Vec<MethodResult>,
}

/// The kind of results an evaluator reads, named by their Rust type: a workflow hands its
/// results as one value of that type ([`EvalInput::new`]), and an evaluator that reads another
/// type is refused when the experiment is validated. Open: a workflow of any crate defines
/// its own results type, and evaluators of any crate read it — core knows neither.
#[derive(Clone, Copy, Debug)]
pub struct EvalInputType {
    id: std::any::TypeId,
    /// What the results are, for messages (`segmentation results`).
    pub name: &'static str,
}

impl PartialEq for EvalInputType {
    fn eq(&self, other: &Self) -> bool {
        self.id == other.id
    }
}

impl Eq for EvalInputType {}

impl EvalInputType {
    /// Results of type `T`, described as `name` in messages.
    pub fn of<T: Any>(name: &'static str) -> Self {
        EvalInputType { id: std::any::TypeId::of::<T>(), name }
    }
    /// Every sequence's methods and candidates (`Vec<SequenceResult>`): what the
    /// segmentation workflows hand their evaluators.
    pub fn segmentation() -> Self {
        Self::of::<Vec<SequenceResult>>("segmentation results")
    }
}

/// What an evaluator is given: a workflow's results, as one value of the type the evaluator
/// reads ([`Evaluator::input_type`]).
#[derive(Clone, Copy)]
pub struct EvalInput<'a> {
    results: &'a (dyn Any + Send + Sync),
    type_name: &'static str,
}

impl std::fmt::Debug for EvalInput<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EvalInput").field("type", &self.type_name).finish()
    }
}

impl<'a> EvalInput<'a> {
    /// Results of type `T` (a `Vec<SequenceResult>` for segmentation evaluators).
    pub fn new<T: Any + Send + Sync>(results: &'a T) -> Self {
        EvalInput { results, type_name: std::any::type_name::<T>() }
    }
    /// Segmentation results (every sequence's methods and candidates).
    pub fn segmentation(sequences: &'a Vec<SequenceResult>) -> Self {
        Self::new(sequences)
    }
    /// The results as a `T`, when they are one.
    pub fn get<T: Any>(&self) -> Option<&'a T> {
        self.results.downcast_ref::<T>()
    }
    /// The results as the `T` of `expected`, or an error naming `evaluator`, what it reads
    /// and what it was given (a workflow that wires an evaluator wrongly).
    pub fn read<T: Any>(&self, expected: EvalInputType, evaluator: &str) -> Result<&'a T> {
        self.get::<T>().ok_or_else(|| {
            Error::new(
                ErrorKind::Mismatch,
                format!(
                    "{evaluator} evaluates {}, but was given `{}`",
                    expected.name, self.type_name
                ),
            )
        })
    }
}

// ---------------------------------------------------------------------------------------------
// Feature cache
// ---------------------------------------------------------------------------------------------

/// Features computed once per motion and shared by every stage that needs them (the fastest
/// marker speed used by two segmenters, the hull volumes used by a segmenter and a figure).
/// Keys must encode every parameter the value depends on.
#[derive(Default)]
pub struct FeatureCache {
    map: Mutex<HashMap<String, Arc<dyn Any + Send + Sync>>>,
}

impl FeatureCache {
    pub fn new() -> Self {
        Self::default()
    }
    /// Returns the cached value under `key`, computing it with `compute` the first time.
    pub fn get_or_compute<T: Any + Send + Sync>(
        &self,
        key: &str,
        compute: impl FnOnce() -> Result<T>,
    ) -> Result<Arc<T>> {
        if let Some(v) = self.lock().get(key) {
            return Arc::clone(v).downcast::<T>().map_err(|_| {
                Error::new(
                    ErrorKind::Mismatch,
                    format!("feature cache key {key:?} holds another type"),
                )
            });
        }
        // Computed outside the lock so independent features can run concurrently.
        let value: Arc<T> = Arc::new(compute()?);
        self.lock().insert(key.to_string(), value.clone() as Arc<dyn Any + Send + Sync>);
        Ok(value)
    }
    fn lock(&self) -> std::sync::MutexGuard<'_, HashMap<String, Arc<dyn Any + Send + Sync>>> {
        // A poisoned lock only means another thread panicked mid-insert; the map is still valid.
        self.map.lock().unwrap_or_else(|p| p.into_inner())
    }
}

// ---------------------------------------------------------------------------------------------
// The traits
// ---------------------------------------------------------------------------------------------

/// What a motion carries for a stage to read: marker or joint positions, or [`Channels`](crate::Channels)
/// — what a [`Loader`]'s motions have and what a [`Segmenter`] consumes, so an
/// experiment that gives a segmenter the wrong kind fails at validation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum DataKind {
    /// Marker or joint positions (mm).
    Points,
    /// Sampled signals: a channel file's columns, or features of a take's points.
    Channels,
}

impl DataKind {
    /// `marker or joint positions` / `channels`, for messages.
    pub fn describe(self) -> &'static str {
        match self {
            DataKind::Points => "marker or joint positions",
            DataKind::Channels => "channels",
        }
    }
}

/// Reads one motion file (any `.gz`-compressed text format transparently).
pub trait Loader: Send + Sync {
    /// What its motions carry: positions (the default) or channels only.
    fn gives(&self) -> DataKind {
        DataKind::Points
    }
    /// File extensions (without dot, lower case, without `.gz`) this loader reads; used by
    /// `motionlab inspect` to pick a loader.
    fn extensions(&self) -> &'static [&'static str];
    /// Whether its motions are 3-D world positions (the default) or 2-D image positions
    /// (video pose estimation): validation refuses a 2-D dataset to a stage that needs depth.
    fn dimensionality(&self) -> Dimensionality {
        Dimensionality::Three
    }
    /// Whether a motion is a folder (OpenPose writes one JSON file per frame) rather than a
    /// file: datasets then list folders, and `inspect` and `new` pick it for a folder.
    fn reads_folders(&self) -> bool {
        false
    }
    fn load(&self, path: &Path) -> Result<Motion>;
}

/// Reads human ground truth for a motion into a [`Segmentation`] at the motion's rate.
pub trait GroundTruthReader: Send + Sync {
    fn read(&self, path: &Path, motion: &Motion) -> Result<Segmentation>;
    /// Files beside `path` the reading also depends on (TSSB's `properties.txt` beside
    /// `desc.txt`): the on-disk cache keys a loaded truth on their bytes too, so editing one
    /// is never answered from the cache. Default: none.
    fn companions(&self, _path: &Path) -> Vec<std::path::PathBuf> {
        Vec::new()
    }
}

/// Transforms a motion before analysis (gap filling, initial-pose normalisation, …).
pub trait Preprocessor: Send + Sync {
    fn apply(&self, motion: Motion) -> Result<Motion>;
}

/// Computes per-frame features of a motion.
pub trait FeatureExtractor: Send + Sync {
    /// Whether it gives a meaningful result on 2-D image positions (px); `false` (the
    /// default) for features that need depth, refused 2-D datasets at validation.
    fn accepts_2d(&self) -> bool {
        false
    }
    fn extract(&self, motion: &Motion, cache: &FeatureCache) -> Result<FeatureSet>;
}

/// Finds candidate segmentation frames.
pub trait Segmenter: Send + Sync {
    /// What it reads of a motion: its points (the default) or its [`Channels`](crate::Channels)
    /// — a channel file's, or features of a take's points that the experiment names
    /// (`input = { features = … }`).
    fn consumes(&self) -> DataKind {
        DataKind::Points
    }
    /// Whether, reading positions, it works on 2-D image positions (px) as well: `false` (the
    /// default) for methods that need depth (hull volumes, the floor plane), which validation
    /// refuses 2-D datasets. A segmenter that reads channels reads no positions, so this is
    /// not asked of it (its `input` features are asked instead).
    fn accepts_2d(&self) -> bool {
        false
    }
    fn segment(&self, motion: &Motion, cache: &FeatureCache) -> Result<SegmenterOutput>;
    /// Its streaming form, when it decides boundaries as samples arrive (a plugin registered
    /// as [`Streamed`](crate::streaming::Streamed)): what the `live` command and streaming
    /// benchmarks run. `None` for a segmenter that needs the whole series.
    fn streaming(&self) -> Option<&dyn crate::streaming::StreamingSegmenter> {
        None
    }
}

/// Combines several methods' candidates into one list.
pub trait Fuser: Send + Sync {
    fn fuse(&self, motion: &Motion, inputs: &[MethodCandidates<'_>]) -> Result<Vec<usize>>;
}

/// One merge of an agglomerative labeller: clusters `a` and `b` (ids as scipy's linkage numbers
/// them: segments `0..n`, then each merge `n + k`) joined at `distance` into a cluster of
/// `size` segments.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Merge {
    pub a: usize,
    pub b: usize,
    pub distance: f64,
    pub size: usize,
}

/// What a [`Labeller`] says of one sequence's segments: a state per segment, and how it got
/// there when the method has it (the merge history and the segment-by-segment distances).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StateLabels {
    /// The state of each segment, in segment order, numbered `0..` in order of first appearance.
    pub segment_states: Vec<usize>,
    /// Agglomerative merges in order (empty for a method that does not merge).
    pub merges: Vec<Merge>,
    /// The segment-by-segment distances the method compared (row-major, `n × n`; empty when
    /// it has none), in the unit the labeller documents.
    pub distances: Vec<f64>,
}

impl StateLabels {
    /// One state per sample: segment `k`'s state on every sample of `segments[k]`. The segments
    /// must be consecutive from sample 0 (as [`segments_of`] makes them).
    pub fn per_sample(&self, segments: &[std::ops::Range<usize>]) -> Result<Vec<usize>> {
        if segments.len() != self.segment_states.len() {
            return Err(Error::new(
                ErrorKind::WrongValueCount,
                format!(
                    "{} states for {} segments; expected one state per segment",
                    self.segment_states.len(),
                    segments.len()
                ),
            ));
        }
        let mut out = Vec::with_capacity(segments.last().map_or(0, |s| s.end));
        for (s, &state) in segments.iter().zip(&self.segment_states) {
            if s.start != out.len() {
                return Err(Error::new(
                    ErrorKind::OutOfRange,
                    format!(
                        "segment {}..{} does not start where the one before ends ({})",
                        s.start,
                        s.end,
                        out.len()
                    ),
                ));
            }
            out.resize(s.end, state);
        }
        Ok(out)
    }
}

/// Renumbers states `0..` in order of first appearance (so equal partitions read equal).
pub fn canonical_states(states: &[usize]) -> Vec<usize> {
    let mut seen: Vec<usize> = Vec::new();
    states
        .iter()
        .map(|s| match seen.iter().position(|x| x == s) {
            Some(i) => i,
            None => {
                seen.push(*s);
                seen.len() - 1
            }
        })
        .collect()
}

/// The segments `0..c1, c1..c2, …, ck..n` of `n` samples cut at the change points `cuts`
/// (sorted; cuts at 0 or ≥ `n` and repeats are ignored).
pub fn segments_of(cuts: &[usize], n: usize) -> Vec<std::ops::Range<usize>> {
    let mut out = Vec::new();
    let mut start = 0;
    for &c in cuts {
        if c > start && c < n {
            out.push(start..c);
            start = c;
        }
    }
    if n > start || out.is_empty() {
        out.push(start..n);
    }
    out
}

/// What an evaluator produced: its tables and, for an evaluator whose analysis a workflow
/// builds on, that analysis as a typed value — the matches and tolerances behind a boundary
/// evaluation's tables, the change rates behind a gait study's control. Workflows read the
/// analysis by its type, never the tables by their names: a table is for people, its layout
/// may change, the type is the contract.
pub struct Evaluation {
    pub tables: Vec<Table>,
    /// The analysis behind the tables, of the type [`Evaluator::analysis_type`] names; `None`
    /// for evaluators that only write tables.
    pub analysis: Option<Analysis>,
}

impl Evaluation {
    /// The analysis as a `T`, when it is one.
    pub fn analysis<T: 'static>(&self) -> Option<&T> {
        self.analysis.as_ref().and_then(Analysis::get::<T>)
    }
}

/// A typed evaluation result, optionally in a form the on-disk cache can keep.
///
/// [`Analysis::new`] wraps any value; [`Analysis::cacheable`] also records how to encode it
/// (MessagePack, which keeps NaN), so a workflow that caches evaluations on disk can store the
/// analysis beside the tables ([`Analysis::encode`]) and a later run restore it
/// ([`Analysis::restored`]) and [`Analysis::read`] it as the type it asks for, checked by name.
pub struct Analysis {
    type_name: String,
    state: AnalysisState,
}

/// Encodes a live analysis value for the cache (`None`: it is not the type recorded).
type EncodeFn = fn(&(dyn Any + Send + Sync)) -> Option<Vec<u8>>;

enum AnalysisState {
    Live { value: Box<dyn Any + Send + Sync>, encode: Option<EncodeFn> },
    Encoded(Vec<u8>),
}

impl std::fmt::Debug for Analysis {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let state = match &self.state {
            AnalysisState::Live { encode: Some(_), .. } => "live, cacheable",
            AnalysisState::Live { encode: None, .. } => "live",
            AnalysisState::Encoded(_) => "encoded",
        };
        f.debug_struct("Analysis").field("type", &self.type_name).field("state", &state).finish()
    }
}

impl Analysis {
    /// An analysis the cache cannot keep (an evaluation that returns it is not cached).
    pub fn new<T: Any + Send + Sync>(value: T) -> Self {
        Analysis {
            type_name: std::any::type_name::<T>().to_string(),
            state: AnalysisState::Live { value: Box::new(value), encode: None },
        }
    }
    /// An analysis the on-disk cache can keep.
    pub fn cacheable<T: Any + Send + Sync + Serialize>(value: T) -> Self {
        fn encode<T: Any + Serialize>(v: &(dyn Any + Send + Sync)) -> Option<Vec<u8>> {
            v.downcast_ref::<T>().and_then(|v| rmp_serde::to_vec_named(v).ok())
        }
        Analysis {
            type_name: std::any::type_name::<T>().to_string(),
            state: AnalysisState::Live { value: Box::new(value), encode: Some(encode::<T>) },
        }
    }
    /// An analysis as [`Analysis::encode`] wrote it, with its [`Analysis::type_name`].
    pub fn restored(type_name: impl Into<String>, bytes: Vec<u8>) -> Self {
        Analysis { type_name: type_name.into(), state: AnalysisState::Encoded(bytes) }
    }
    /// Rust's name of the value's type (what [`Analysis::read`] checks a restored one by).
    pub fn type_name(&self) -> &str {
        &self.type_name
    }
    /// The value, when it is a live `T`.
    pub fn get<T: 'static>(&self) -> Option<&T> {
        match &self.state {
            AnalysisState::Live { value, .. } => value.downcast_ref::<T>(),
            AnalysisState::Encoded(_) => None,
        }
    }
    /// The value as a `T`, or the analysis back when it is not a live `T`.
    pub fn downcast<T: 'static>(self) -> std::result::Result<Box<T>, Analysis> {
        match self.state {
            AnalysisState::Live { value, encode } => value.downcast::<T>().map_err(|value| {
                Analysis { type_name: self.type_name, state: AnalysisState::Live { value, encode } }
            }),
            state => Err(Analysis { type_name: self.type_name, state }),
        }
    }
    /// A copy of the value as a `T`, live or restored; `None` when it is another type (or
    /// restored bytes that do not decode: an entry of another build).
    pub fn read<T: Clone + serde::de::DeserializeOwned + 'static>(&self) -> Option<T> {
        match &self.state {
            AnalysisState::Live { value, .. } => value.downcast_ref::<T>().cloned(),
            AnalysisState::Encoded(bytes) => (self.type_name == std::any::type_name::<T>())
                .then(|| rmp_serde::from_slice::<T>(bytes).ok())
                .flatten(),
        }
    }
    /// The encoded form, when the value was made [`Analysis::cacheable`] (or restored).
    pub fn encode(&self) -> Option<Vec<u8>> {
        match &self.state {
            AnalysisState::Live { value, encode } => encode.and_then(|f| f(value.as_ref())),
            AnalysisState::Encoded(bytes) => Some(bytes.clone()),
        }
    }
}

/// Says which segments of a sequence are the same motion: a state per segment. The segments
/// come from any segmenter or fuser (or the truth's own boundaries, for an oracle-segmentation
/// study) and cover the sequence consecutively from sample 0.
pub trait Labeller: Send + Sync {
    /// What it reads of a motion: its [`Channels`](crate::Channels) (the default) or its points.
    fn consumes(&self) -> DataKind {
        DataKind::Channels
    }
    fn label(&self, motion: &Motion, segments: &[std::ops::Range<usize>]) -> Result<StateLabels>;
}

/// Turns results into tables.
pub trait Evaluator: Send + Sync {
    /// The results it reads: a workflow that produces another type cannot use it (checked at
    /// validation).
    fn input_type(&self) -> EvalInputType;
    fn evaluate(&self, input: EvalInput<'_>) -> Result<Vec<Table>>;
    /// The tables and the typed analysis behind them, computed once. Default: the tables only.
    fn evaluate_with_analysis(&self, input: EvalInput<'_>) -> Result<Evaluation> {
        Ok(Evaluation { tables: self.evaluate(input)?, analysis: None })
    }
    /// The type of the analysis [`Evaluator::evaluate_with_analysis`] returns, if any — so a
    /// workflow that builds on one can require it when the experiment is validated, by type
    /// rather than by plugin name.
    fn analysis_type(&self) -> Option<std::any::TypeId> {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_analysis_reads_back_as_its_own_type_only() {
        #[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
        struct Judged {
            tolerance: f64,
            frames: Vec<usize>,
        }
        let value = Judged { tolerance: f64::NAN.min(2.5), frames: vec![3, 9] };
        let live = Analysis::cacheable(value.clone());
        assert_eq!(live.get::<Judged>(), Some(&value));
        assert_eq!(live.read::<Judged>(), Some(value.clone()));
        assert_eq!(live.read::<Vec<usize>>(), None);
        let restored = Analysis::restored(live.type_name(), live.encode().unwrap());
        assert_eq!(restored.get::<Judged>(), None, "a restored analysis is not live");
        assert_eq!(restored.read::<Judged>(), Some(value));
        assert_eq!(restored.read::<Vec<usize>>(), None, "another type's name");
        assert_eq!(
            Analysis::restored(live.type_name(), vec![0xc1]).read::<Judged>(),
            None,
            "undecodable bytes"
        );
        // Not cacheable: no encoded form; downcast hands it back when the type is wrong.
        let plain = Analysis::new(7_u8);
        assert!(plain.encode().is_none());
        let plain = plain.downcast::<u16>().unwrap_err();
        assert_eq!(*plain.downcast::<u8>().unwrap(), 7);
    }

    /// Cuts make consecutive segments from 0 (cuts at the edges or repeated are ignored), and
    /// the states spread over them sample by sample.
    #[test]
    fn segments_and_states_per_sample() {
        assert_eq!(segments_of(&[3, 5], 8), vec![0..3, 3..5, 5..8]);
        assert_eq!(segments_of(&[0, 3, 3, 8, 9], 8), vec![0..3, 3..8]);
        assert_eq!(segments_of(&[], 4), vec![0..4]);
        assert_eq!(segments_of(&[], 0), vec![0..0]);
        let s = StateLabels { segment_states: vec![1, 0, 1], ..Default::default() };
        let segs = segments_of(&[2, 3], 5);
        assert_eq!(s.per_sample(&segs).unwrap(), vec![1, 1, 0, 1, 1]);
        assert!(s.per_sample(&segs[..2]).is_err(), "a state per segment");
        assert!(s.per_sample(&[0..2, 3..4, 4..5]).is_err(), "a gap");
        assert_eq!(canonical_states(&[7, 7, 3, 9, 3]), vec![0, 0, 1, 2, 1]);
    }

    #[test]
    fn feature_cache_computes_once() {
        let cache = FeatureCache::new();
        let mut calls = 0;
        let a = cache
            .get_or_compute("v", || {
                calls += 1;
                Ok(vec![1.0f64])
            })
            .unwrap();
        let b = cache.get_or_compute::<Vec<f64>>("v", || unreachable!()).unwrap();
        assert_eq!(calls, 1);
        assert!(Arc::ptr_eq(&a, &b));
        assert!(cache.get_or_compute::<String>("v", || Ok(String::new())).is_err());
    }
}
