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

use std::collections::BTreeMap;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry;
use motionlab_core::{
    Alignment, Error, ErrorKind, EvalDomain, EvalInput, Evaluator, FrameRate, Matcher, MatchingResult, Motion,
    PointDetection, PointDetector, RepetitionResult, Result, Seconds, Synchronisation, Synchroniser, Table,
};
use motionlab_core::viewer::{EventKind, EventLane, Interval, IntervalKind, IntervalLane, Lane, Mark, TraceLane, ViewerMotion, ViewerSpec};
use motionlab_core::{Threshold, Trace};
use motionlab_figure::{BarRow, Chart, Figure, RefLine, Series};
use motionlab_match::judgement::{ranks, scores, Scores};

use crate::drawing::bones_of_merged_skeleton;
use motionlab_experiment::workflow::{build_evaluators, sanitize, ItemData, ItemOutput, Output, WorkItem, Workflow, WorkflowPlugin, BuildContext};
use motionlab_experiment::{build_stage, BuiltDataset, Combo, Datasets, Source};
use motionlab_experiment::spec::{Cut, StageSpec};
use motionlab_experiment::toml_paths::KeyPath;

/// The figures this workflow can draw (`[matching] figures`).
const FIGURES: [&str; 3] = ["velocity", "paths", "scatter"];

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
    pub figures: Vec<String>,
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

fn default_figures() -> Vec<String> {
    FIGURES.iter().map(|s| s.to_string()).collect()
}

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

/// A row of the `repetitions` table.
#[derive(Serialize)]
struct RepetitionRow {
    take: String,
    repetition: String,
    group: Option<String>,
    /// Velocity peaks (file frames), `;`-separated; empty for explicit windows.
    peak_frames: String,
    /// The detector's threshold on the velocity function (NaN for explicit windows).
    threshold_mm_per_frame: Option<f64>,
    window_start_frame: usize,
    /// Last frame of the window (inclusive).
    window_end_frame: usize,
    window_start_s: f64,
    window_end_s: f64,
    a_frame: usize,
    b_frame: usize,
    a_s: f64,
    b_s: f64,
    matched_frames: usize,
    model_frames: usize,
    #[serde(rename = "H_mm")]
    h_mm: f64,
    #[serde(rename = "R_frames2")]
    r_frames2: f64,
}

impl WorkflowPlugin for MatchingWorkflow {
    type Section = MatchingSection;
    fn build(section: MatchingSection, cx: &BuildContext<'_>) -> Result<Self> {
        let (source, combo, data, root) = (cx.source, cx.combo, cx.data, cx.root.clone());
        let locate = |e: Error, key: &str| source.locate(e, root.join_field(key), &combo.doc);
        if section.peaks_per_repetition == 0 {
            return Err(locate(
                Error::new(ErrorKind::OutOfRange, "expected at least one velocity peak per repetition, found 0"),
                "peaks_per_repetition",
            ));
        }
        if let Some(bad) = section.figures.iter().find(|f| !FIGURES.contains(&f.as_str())) {
            return Err(locate(
                Error::new(ErrorKind::UnknownName, format!("no figure named {bad:?}; expected any of {FIGURES:?}")),
                "figures",
            ));
        }
        if let Some(points) = &section.points {
            check_point_list(points).map_err(|e| locate(e, "points"))?;
            if let Some(pm) = &section.path_markers
                && let Some(m) = pm.iter().find(|m| !points.contains(m))
            {
                return Err(locate(
                    Error::new(ErrorKind::UnknownName, format!("path marker {m:?} is not among the matched `points`")),
                    "path_markers",
                ));
            }
        }
        let model = find_model(&section.model, data).map_err(|e| locate(e, "model"))?;
        let matcher = build_stage(source, combo, &section.matcher, &root.key("matcher"), registry::build_matcher)?;
        let synchroniser = build_stage(source, combo, &section.synchroniser, &root.key("synchroniser"), registry::build_synchroniser)?;
        let matcher_points = stage_points(&section.matcher);
        let evaluators = build_evaluators(source, combo, EvalDomain::Matching)?;
        let takes = build_takes(source, combo, data, &section, model, &root)?;
        if takes.is_empty() {
            return Err(locate(
                Error::new(
                    ErrorKind::MissingKey,
                    "no user take: every [[dataset]] but the model is a take (tag it `repetitions = \"N\"`, or `take = \"<name>\"` for one repetition per dataset)",
                ),
                "model",
            ));
        }
        Ok(MatchingWorkflow { section, model, takes, matcher, matcher_points, synchroniser, evaluators })
    }
}

motionlab_experiment::register_workflow!(MatchingWorkflow, "matching");

impl MatchingWorkflow {
    fn wants(&self, figure: &str) -> bool {
        self.section.figures.iter().any(|f| f == figure)
    }

    /// The model as matched: loaded (cut, preprocessed) and reduced to `points`.
    fn load_model(&self, data: &Datasets) -> Result<Motion> {
        let loaded = data.load(self.model, 0).map_err(|e| e.under_field("model"))?;
        self.select((*loaded.motion).clone())
    }

    fn select(&self, motion: Motion) -> Result<Motion> {
        match &self.section.points {
            Some(p) => motion.select_points(p),
            None => Ok(motion),
        }
    }

    /// The names of the per-point distances of an alignment, checked against their count.
    fn point_names(&self, model: &Motion, alignment: &Alignment) -> Result<Vec<String>> {
        let names = self.matcher_points.clone().unwrap_or_else(|| model.point_names().to_vec());
        if names.len() != alignment.point_distances.len() {
            return Err(Error::new(
                ErrorKind::Mismatch,
                format!(
                    "the matcher {:?} returned {} per-point distances for {} points ({}); expected one per point",
                    self.section.matcher.kind,
                    alignment.point_distances.len(),
                    names.len(),
                    names.join(", ")
                ),
            )
            .with_field("matching.matcher"));
        }
        Ok(names)
    }

    fn match_one(&self, model: &Motion, target: &Motion) -> Result<(Alignment, Synchronisation)> {
        let alignment = self.matcher.align(model, target).map_err(|e| e.under_field(format!("matcher {}", self.section.matcher.kind)))?;
        let sync = self
            .synchroniser
            .synchronise(&alignment, model.n_frames())
            .map_err(|e| e.under_field(format!("synchroniser {}", self.section.synchroniser.kind)))?;
        Ok((alignment, sync))
    }
}

fn check_point_list(points: &[String]) -> Result<()> {
    if points.is_empty() {
        return Err(Error::new(ErrorKind::InvalidParameter, "expected at least one marker name, found an empty list"));
    }
    for (i, p) in points.iter().enumerate() {
        if points[..i].contains(p) {
            return Err(Error::new(ErrorKind::DuplicateName, format!("marker {p:?} is listed twice")));
        }
    }
    Ok(())
}

/// The points a stage's parameters name (`points = [...]` or `marker = "..."`), if any.
fn stage_points(spec: &StageSpec) -> Option<Vec<String>> {
    match (spec.params.get("points"), spec.params.get("marker")) {
        (Some(toml::Value::Array(a)), _) => a.iter().map(|v| v.as_str().map(str::to_string)).collect(),
        (_, Some(toml::Value::String(m))) => Some(vec![m.clone()]),
        _ => None,
    }
}

pub(crate) fn dataset_label(d: &BuiltDataset) -> String {
    d.spec.name.clone().unwrap_or_else(|| (0..d.files.len()).map(|k| d.sequence_name(k)).collect::<Vec<_>>().join(", "))
}

pub(crate) fn find_model(name: &str, data: &Datasets) -> Result<usize> {
    let hits: Vec<&BuiltDataset> = data
        .datasets
        .iter()
        .filter(|d| d.spec.name.as_deref() == Some(name) || (d.spec.name.is_none() && d.files.len() == 1 && d.sequence_name(0) == name))
        .collect();
    match hits.as_slice() {
        [d] if d.files.len() == 1 => Ok(d.index),
        [d] => Err(Error::new(
            ErrorKind::InvalidParameter,
            format!("the model dataset {name:?} resolves to {} files; expected exactly one (one basic motion)", d.files.len()),
        )),
        [] => Err(Error::new(
            ErrorKind::UnknownName,
            format!(
                "no dataset named {name:?}; the datasets are: {}",
                data.datasets.iter().map(|d| format!("{:?}", dataset_label(d))).collect::<Vec<_>>().join(", ")
            ),
        )),
        _ => Err(Error::new(ErrorKind::DuplicateName, format!("{} datasets are named {name:?}; name the model uniquely", hits.len()))),
    }
}

/// Every user take, its detector built with its own count (so validation checks them all).
fn build_takes(source: &Source, combo: &Combo, data: &Datasets, section: &MatchingSection, model: usize, root: &KeyPath) -> Result<Vec<Take>> {
    let datasets = KeyPath::parse("dataset")?;
    let mut takes: Vec<Take> = Vec::new();
    let mut used_overrides: Vec<&str> = Vec::new();
    let detector_path = root.key("point_detector");
    if let Some(spec) = &section.point_detector
        && spec.params.contains_key("count")
    {
        return Err(source.locate(
            Error::new(
                ErrorKind::InvalidParameter,
                "`count` is set per take by the workflow: tag the take's dataset `repetitions = \"N\"` or set `[matching.repetitions]`",
            ),
            detector_path.key("count"),
            &combo.doc,
        ));
    }
    for d in data.datasets.iter().filter(|d| d.index != model) {
        let here = datasets.index(d.index);
        let at_tag = |key: &str, e: Error| source.locate(e, here.key("tags").key(key), &combo.doc);
        if let Some(take) = d.tag("take") {
            if d.tag("repetitions").is_some() {
                return Err(at_tag(
                    "repetitions",
                    Error::new(
                        ErrorKind::InvalidParameter,
                        "a dataset is either one repetition of an explicit take (`take`) or a continuous take (`repetitions`), not both",
                    ),
                ));
            }
            if let Some(g) = d.tag("group")
                && !["a", "b", "c"].contains(&g)
            {
                return Err(at_tag(
                    "group",
                    Error::new(ErrorKind::InvalidParameter, format!("group {g:?}: expected \"a\" (close), \"b\" (timing-shifted) or \"c\" (wrong)")),
                ));
            }
            let members: Vec<(usize, usize)> = (0..d.files.len()).map(|f| (d.index, f)).collect();
            match takes.iter_mut().find(|t| t.name == take) {
                Some(Take { kind: TakeKind::Explicit { members: m }, .. }) => m.extend(members),
                Some(_) => {
                    return Err(at_tag("take", Error::new(ErrorKind::DuplicateName, format!("take {take:?} is also the name of a continuous take"))));
                }
                None => takes.push(Take { id: String::new(), name: take.to_string(), kind: TakeKind::Explicit { members } }),
            }
            continue;
        }
        for file in 0..d.files.len() {
            let name = d.sequence_name(file);
            let count = match (section.repetitions.get(&name), d.tag("repetitions")) {
                (Some(&n), _) => {
                    used_overrides.push(section.repetitions.get_key_value(&name).map(|(k, _)| k.as_str()).unwrap_or(""));
                    if n == 0 {
                        return Err(source.locate(
                            Error::new(ErrorKind::OutOfRange, "expected at least one repetition, found 0"),
                            root.key("repetitions").key(&name),
                            &combo.doc,
                        ));
                    }
                    n
                }
                (None, Some(text)) => match text.trim().parse::<usize>() {
                    Ok(n) if n >= 1 => n,
                    _ => {
                        return Err(at_tag(
                            "repetitions",
                            Error::new(ErrorKind::WrongType, format!("repetitions = {text:?}: expected a whole number of repetitions >= 1")),
                        ));
                    }
                },
                (None, None) => {
                    return Err(source.locate(
                        Error::new(
                            ErrorKind::MissingKey,
                            format!(
                                "dataset {:?} is a user take but says neither how many repetitions it holds (tag `repetitions = \"N\"` or `[matching.repetitions]`) nor that it is one repetition of an explicit take (tag `take = \"<name>\"`)",
                                dataset_label(d)
                            ),
                        ),
                        &here,
                        &combo.doc,
                    ));
                }
            };
            let Some(spec) = &section.point_detector else {
                return Err(source.locate(
                    Error::new(ErrorKind::MissingKey, format!("take {name:?} is continuous, so [matching] needs a `point_detector`")),
                    root,
                    &combo.doc,
                ));
            };
            let mut with_count = spec.clone();
            with_count.params.insert("count".into(), toml::Value::Integer((count * section.peaks_per_repetition) as i64));
            let detector = build_stage(source, combo, &with_count, &detector_path, registry::build_point_detector)?;
            if takes.iter().any(|t| t.name == name) {
                return Err(source.locate(
                    Error::new(ErrorKind::DuplicateName, format!("two takes are named {name:?}; give the datasets distinct `name`s")),
                    &here,
                    &combo.doc,
                ));
            }
            takes.push(Take { id: String::new(), name, kind: TakeKind::Continuous { dataset: d.index, file, count, detector } });
        }
    }
    if let Some(unused) = section.repetitions.keys().find(|k| !used_overrides.contains(&k.as_str())) {
        let names: Vec<String> =
            takes.iter().filter(|t| matches!(t.kind, TakeKind::Continuous { .. })).map(|t| format!("{:?}", t.name)).collect();
        return Err(source.locate(
            Error::new(ErrorKind::UnknownName, format!("{unused:?} names no continuous take; the continuous takes are: {}", names.join(", "))),
            root.key("repetitions").key(unused),
            &combo.doc,
        ));
    }
    let mut ids: Vec<String> = Vec::new();
    for t in &mut takes {
        let base = item_id(&t.name);
        let mut id = base.clone();
        let mut k = 2;
        while ids.contains(&id) {
            id = format!("{base}_{k}");
            k += 1;
        }
        ids.push(id.clone());
        t.id = id;
    }
    Ok(takes)
}

/// A file-name-safe id for a take: [`sanitize`]d, runs of `_` collapsed, no `_` at the ends
/// (`jumping jacks (a)(b)(c)` → `jumping_jacks_a_b_c`).
fn item_id(name: &str) -> String {
    let safe = sanitize(name);
    let mut id = String::with_capacity(safe.len());
    for c in safe.chars() {
        if !(c == '_' && (id.is_empty() || id.ends_with('_'))) {
            id.push(c);
        }
    }
    let id = id.trim_end_matches('_').to_string();
    if id.is_empty() { "take".into() } else { id }
}

/// First frame of a loaded file within the original file (the dataset's `cut`, rounded as
/// [`Datasets::load`] rounds it).
pub(crate) fn cut_offset(d: &BuiltDataset, rate: FrameRate) -> usize {
    match d.spec.cut {
        Some(Cut::Frames([a, _])) => a,
        Some(Cut::Seconds([a, _])) => rate.seconds_to_frames(Seconds(a)).round() as usize,
        None => 0,
    }
}

/// Groups consecutive peaks `per` at a time; each group's window is the union of its peaks'
/// windows. Returns (peaks, window) per repetition.
fn group_repetitions(detection: &PointDetection, per: usize) -> Vec<(Vec<usize>, (usize, usize))> {
    detection
        .peaks
        .chunks(per)
        .zip(detection.windows.chunks(per))
        .map(|(peaks, windows)| {
            let start = windows.iter().map(|w| w.0).min().unwrap_or(0);
            let end = windows.iter().map(|w| w.1).max().unwrap_or(0);
            (peaks.to_vec(), (start, end))
        })
        .collect()
}

/// Mean matched target frame of each model frame on a path (model frames without a pair: NaN).
fn mean_target_frames(path: &[(usize, usize)], model_frames: usize) -> Vec<f64> {
    let mut sum = vec![0.0; model_frames];
    let mut count = vec![0usize; model_frames];
    for &(i, j) in path {
        if i < model_frames {
            sum[i] += j as f64;
            count[i] += 1;
        }
    }
    sum.iter().zip(&count).map(|(s, &c)| if c == 0 { f64::NAN } else { s / c as f64 }).collect()
}

/// The two points whose matched frames at the examined model frames differ most (summed).
fn most_out_of_step(paths: &[Vec<(usize, usize)>], frames: &[usize], model_frames: usize) -> Option<(usize, usize)> {
    let u: Vec<Vec<f64>> = paths.iter().map(|p| mean_target_frames(p, model_frames)).collect();
    let at = |l: usize, i: usize| u[l].get(i).copied().unwrap_or(f64::NAN);
    let mut best: Option<(f64, usize, usize)> = None;
    for l1 in 0..u.len() {
        for l2 in l1 + 1..u.len() {
            let d: f64 = frames.iter().map(|&i| (at(l1, i) - at(l2, i)).abs()).filter(|v| v.is_finite()).sum();
            if best.is_none_or(|(b, _, _)| d > b) {
                best = Some((d, l1, l2));
            }
        }
    }
    best.map(|(_, a, b)| (a, b))
}

impl Workflow for MatchingWorkflow {
    fn items(&self, _data: &Datasets) -> Vec<WorkItem> {
        self.takes
            .iter()
            .map(|t| {
                let (dataset, file) = match &t.kind {
                    TakeKind::Continuous { dataset, file, .. } => (*dataset, *file),
                    TakeKind::Explicit { members } => members.first().copied().unwrap_or((0, 0)),
                };
                WorkItem { id: t.id.clone(), dataset, file }
            })
            .collect()
    }

    fn run_item(&self, item: &WorkItem, data: &Datasets, draw: bool) -> Result<ItemOutput> {
        let take = self
            .takes
            .iter()
            .find(|t| t.id == item.id)
            .ok_or_else(|| Error::new(ErrorKind::Mismatch, format!("work item {:?} is no take of this experiment", item.id)))?;
        let model = self.load_model(data)?;
        let rate = model.frame_rate();
        let mut reps: Vec<RepetitionRecord> = Vec::new();
        let mut paths: Vec<Vec<Vec<(usize, usize)>>> = Vec::new();
        let mut point_names: Option<Vec<String>> = None;
        let mut detection: Option<(PointDetection, usize)> = None;
        let mut record = |label: String, group: Option<String>, pair: Option<String>, peaks: Vec<usize>, window: (usize, usize), target: &Motion| -> Result<()> {
            let (alignment, sync) = self.match_one(&model, target).map_err(|e| e.under_field(format!("repetition {label:?}")))?;
            let names = self.point_names(&model, &alignment)?;
            point_names.get_or_insert(names);
            reps.push(RepetitionRecord {
                label,
                group,
                pair,
                peaks,
                window_start: window.0,
                window_end: window.1,
                start: alignment.start,
                end: alignment.end,
                point_distances: alignment.point_distances.clone(),
                total_distance: alignment.total_distance,
                sync_frames: sync.model_frames.clone(),
                section_values: sync.section_values.clone(),
                sync_total: sync.total,
            });
            paths.push(alignment.paths);
            Ok(())
        };
        match &take.kind {
            TakeKind::Continuous { dataset, file, count, detector } => {
                let loaded = data.load(*dataset, *file)?;
                let offset = cut_offset(&data.datasets[*dataset], loaded.motion.frame_rate());
                let found = detector.detect(&loaded.motion).map_err(|e| {
                    let per = self.section.peaks_per_repetition;
                    let e = e.under_field(format!("point_detector, take {:?} with {count} repetitions × {per} peaks", take.name));
                    match &loaded.motion.source {
                        Some(f) => e.in_file(f),
                        None => e,
                    }
                })?;
                let user = self.select((*loaded.motion).clone())?;
                for (k, (peaks, (s, e))) in group_repetitions(&found, self.section.peaks_per_repetition).into_iter().enumerate() {
                    let window = user.slice_frames(s, e)?;
                    let peaks = peaks.iter().map(|p| p + offset).collect();
                    record(format!("rep {}", k + 1), None, None, peaks, (s + offset, e + offset), &window)?;
                }
                detection = Some((found, offset));
            }
            TakeKind::Explicit { members } => {
                for &(d, f) in members {
                    let loaded = data.load(d, f)?;
                    let ds = &data.datasets[d];
                    let offset = cut_offset(ds, loaded.motion.frame_rate());
                    let n = loaded.motion.n_frames();
                    let target = self.select((*loaded.motion).clone())?;
                    let (group, pair) = (ds.tag("group").map(str::to_string), ds.tag("pair").map(str::to_string));
                    record(loaded.name.clone(), group, pair, Vec::new(), (offset, offset + n), &target)?;
                }
            }
        }
        let result = ItemResult {
            take: take.name.clone(),
            continuous: matches!(take.kind, TakeKind::Continuous { .. }),
            frame_rate_hz: rate.hz(),
            model_frames: model.n_frames(),
            point_names: point_names.unwrap_or_default(),
            threshold: detection.as_ref().map(|(d, _)| d.threshold),
            repetitions: reps,
            velocity: if draw { detection.as_ref().map(|(d, _)| (d.velocity.values.clone(), d.velocity.unit.clone())) } else { None },
        };
        let figures = if draw { self.item_figures(&item.id, &result, detection.as_ref(), &paths)? } else { Vec::new() };
        Ok(ItemOutput::new(ItemData::encode(&result)?, figures))
    }

    fn finish(&self, items: &[(WorkItem, ItemData)], data: &Datasets, draw: bool) -> Result<Output> {
        let results: Vec<ItemResult> = items.iter().map(|(_, d)| d.decode()).collect::<Result<_>>()?;
        let mut out = Output::default();
        let mut rows = Vec::new();
        for r in &results {
            let rate = r.frame_rate_hz;
            for rep in &r.repetitions {
                let (a, b) = (rep.window_start + rep.start, rep.window_start + rep.end);
                rows.push(RepetitionRow {
                    take: r.take.clone(),
                    repetition: rep.label.clone(),
                    group: rep.group.clone(),
                    peak_frames: rep.peaks.iter().map(usize::to_string).collect::<Vec<_>>().join(";"),
                    threshold_mm_per_frame: r.threshold,
                    window_start_frame: rep.window_start,
                    window_end_frame: rep.window_end.saturating_sub(1),
                    window_start_s: rep.window_start as f64 / rate,
                    window_end_s: rep.window_end.saturating_sub(1) as f64 / rate,
                    a_frame: a,
                    b_frame: b,
                    a_s: a as f64 / rate,
                    b_s: b as f64 / rate,
                    matched_frames: b - a + 1,
                    model_frames: r.model_frames,
                    h_mm: rep.total_distance,
                    r_frames2: rep.sync_total,
                });
            }
        }
        out.tables.push(Table::from_records(
            "repetitions",
            "Each repetition: its window (first and last frame), the matched stretch [a, b] (frames of the file, and seconds), distance H and synchronisation R",
            &rows,
        )?);
        let matching: Vec<MatchingResult> = results.iter().map(to_matching_result).collect();
        for (name, e) in &self.evaluators {
            let tables = e.evaluate(EvalInput::Matching(&matching)).map_err(|err| err.under_field(format!("evaluate {name}")))?;
            out.tables.extend(tables);
        }
        let (ranks_rows, verdict_rows) = timing_test(&results);
        if !verdict_rows.is_empty() {
            out.tables.push(Table::from_records(
                "timing_ranks",
                "The (a)/(b)/(c) test: each repetition's H, R and score with its rank by each (1 = least; §5.2.2)",
                &ranks_rows,
            )?);
            out.tables.push(Table::from_records(
                "timing_verdict",
                "The (a)/(b)/(c) test: does R mark the timing-shifted (b) as less synchronised, does the score rank (a) most similar? (§5.2.3)",
                &verdict_rows,
            )?);
        }
        if draw && self.wants("scatter") {
            out.figures.extend(scatter_figures(&results));
        }
        if draw {
            out.viewers = self.viewers(items, &results, data)?;
        }
        Ok(out)
    }
}

fn to_matching_result(r: &ItemResult) -> MatchingResult {
    MatchingResult {
        take: r.take.clone(),
        point_names: r.point_names.clone(),
        repetitions: r
            .repetitions
            .iter()
            .map(|rep| RepetitionResult {
                repetition: rep.label.clone(),
                window_start: rep.window_start,
                alignment: Alignment {
                    start: rep.start,
                    end: rep.end,
                    point_distances: rep.point_distances.clone(),
                    total_distance: rep.total_distance,
                    paths: Vec::new(),
                },
                synchronisation: Synchronisation {
                    model_frames: rep.sync_frames.clone(),
                    section_values: rep.section_values.clone(),
                    total: rep.sync_total,
                },
            })
            .collect(),
    }
}

/// A row of `timing_ranks`.
#[derive(Serialize)]
struct TimingRank {
    take: String,
    repetition: String,
    group: String,
    pair: Option<String>,
    #[serde(rename = "H_mm")]
    h_mm: f64,
    #[serde(rename = "R_frames2")]
    r_frames2: f64,
    #[serde(rename = "H_norm")]
    h_norm: f64,
    #[serde(rename = "R_norm")]
    r_norm: f64,
    score: f64,
    rank_score: usize,
    #[serde(rename = "rank_H")]
    rank_h: usize,
    #[serde(rename = "rank_R")]
    rank_r: usize,
}

/// A row of `timing_verdict`.
#[derive(Serialize)]
struct Verdict {
    take: String,
    check: String,
    held: bool,
    detail: String,
}

fn fmt(v: f64) -> String {
    motionlab_core::table::fmt_num(v)
}

/// The paper's (a)/(b)/(c) test on every explicit take whose repetitions carry groups.
fn timing_test(results: &[ItemResult]) -> (Vec<TimingRank>, Vec<Verdict>) {
    let mut ranks_out = Vec::new();
    let mut verdicts = Vec::new();
    for r in results.iter().filter(|r| r.repetitions.iter().any(|rep| rep.group.is_some())) {
        let reps = &r.repetitions;
        let h: Vec<f64> = reps.iter().map(|x| x.total_distance).collect();
        let rr: Vec<f64> = reps.iter().map(|x| x.sync_total).collect();
        // The judgement rule itself (§4.1), and its ranking applied to H and R alone.
        let Scores { h_norm: hn, r_norm: rn, score } = scores(&h, &rr);
        let (rank_s, rank_h, rank_r) = (ranks(&score), ranks(&h), ranks(&rr));
        let group = |k: usize| reps[k].group.clone().unwrap_or_default();
        for k in 0..reps.len() {
            ranks_out.push(TimingRank {
                take: r.take.clone(),
                repetition: reps[k].label.clone(),
                group: group(k),
                pair: reps[k].pair.clone(),
                h_mm: h[k],
                r_frames2: rr[k],
                h_norm: hn[k],
                r_norm: rn[k],
                score: score[k],
                rank_score: rank_s[k],
                rank_h: rank_h[k],
                rank_r: rank_r[k],
            });
        }
        let of = |g: &str| -> Vec<usize> { (0..reps.len()).filter(|&k| group(k) == g).collect() };
        let (a, b, c) = (of("a"), of("b"), of("c"));
        let list = |ks: &[usize], v: &[f64]| ks.iter().map(|&k| format!("{} {}", reps[k].label, fmt(v[k]))).collect::<Vec<_>>().join(", ");
        let mut add = |check: &str, held: bool, detail: String| {
            verdicts.push(Verdict { take: r.take.clone(), check: check.to_string(), held, detail });
        };
        if !a.is_empty() && !b.is_empty() {
            let pairs: Vec<(usize, usize)> = b
                .iter()
                .filter_map(|&kb| {
                    let p = reps[kb].pair.as_ref()?;
                    a.iter().find(|&&ka| reps[ka].pair.as_ref() == Some(p)).map(|&ka| (ka, kb))
                })
                .collect();
            if !pairs.is_empty() {
                let held = pairs.iter().all(|&(ka, kb)| rr[kb] > rr[ka]);
                let detail = pairs
                    .iter()
                    .map(|&(ka, kb)| format!("{}: R(a) {} → R(b) {}", reps[ka].pair.clone().unwrap_or_default(), fmt(rr[ka]), fmt(rr[kb])))
                    .collect::<Vec<_>>()
                    .join("; ");
                add("R: each timing-shifted (b) is less synchronised than the (a) it was made from", held, detail);
            }
            let max_a = a.iter().map(|&k| rr[k]).fold(f64::NEG_INFINITY, f64::max);
            let min_b = b.iter().map(|&k| rr[k]).fold(f64::INFINITY, f64::min);
            add(
                "R: every (b) is less synchronised than every (a)",
                min_b > max_a,
                format!("R of (a): {}; R of (b): {}", list(&a, &rr), list(&b, &rr)),
            );
        }
        let first = |rank: &[usize]| rank.iter().position(|&x| x == 1).unwrap_or(0);
        if !a.is_empty() {
            let top = first(&rank_s);
            add(
                "score: the most similar repetition is an (a)",
                group(top) == "a",
                format!("most similar: {} ({}), score {}", reps[top].label, group(top), fmt(score[top])),
            );
            let top_h = first(&rank_h);
            add(
                "H alone: the most similar repetition is an (a)",
                group(top_h) == "a",
                format!("least H: {} ({}), H {} mm", reps[top_h].label, group(top_h), fmt(h[top_h])),
            );
        }
        if !a.is_empty() && !c.is_empty() {
            let max_a = a.iter().map(|&k| score[k]).fold(f64::NEG_INFINITY, f64::max);
            let min_c = c.iter().map(|&k| score[k]).fold(f64::INFINITY, f64::min);
            add(
                "score: every wrong-motion (c) is less similar than every (a)",
                min_c > max_a,
                format!("score of (a): {}; score of (c): {}", list(&a, &score), list(&c, &score)),
            );
        }
        if !b.is_empty() || !c.is_empty() {
            let worst = rank_s.iter().position(|&x| x == reps.len()).unwrap_or(0);
            add(
                "score: the most dissimilar repetition is a (b) or a (c)",
                matches!(group(worst).as_str(), "b" | "c"),
                format!("most dissimilar: {} ({}), score {}", reps[worst].label, group(worst), fmt(score[worst])),
            );
        }
    }
    (ranks_out, verdicts)
}

/// Fig. 5 (H–R) and Fig. 6 (H'–R'), one point series per take, labelled by repetition.
fn scatter_figures(results: &[ItemResult]) -> Vec<Figure> {
    let mut raw = Vec::new();
    let mut norm = Vec::new();
    for r in results.iter().filter(|r| !r.repetitions.is_empty()) {
        let h: Vec<f64> = r.repetitions.iter().map(|x| x.total_distance).collect();
        let rr: Vec<f64> = r.repetitions.iter().map(|x| x.sync_total).collect();
        let labels: Vec<String> = r.repetitions.iter().map(|x| x.label.clone()).collect();
        let mut s = Series::new(r.take.clone(), h.clone(), rr.clone());
        s.point_labels = labels.clone();
        raw.push(s);
        let normalised = scores(&h, &rr);
        let mut n = Series::new(r.take.clone(), normalised.h_norm, normalised.r_norm);
        n.point_labels = labels;
        norm.push(n);
    }
    if raw.is_empty() {
        return Vec::new();
    }
    let upper = |series: &[Series], pick: fn(&Series) -> &Vec<f64>| {
        series.iter().flat_map(|s| pick(s).iter()).copied().filter(|v| v.is_finite()).fold(0.0, f64::max) * 1.15
    };
    let raw_range = (Some((0.0, upper(&raw, |s| &s.x).max(1.0))), Some((0.0, upper(&raw, |s| &s.y).max(1.0))));
    let norm_max = upper(&norm, |s| &s.x).max(upper(&norm, |s| &s.y)).max(1.2);
    // The unit circle, score = 1: as far from the origin as a repetition at both means.
    let steps = 90;
    let quarter = |k: usize| k as f64 / steps as f64 * std::f64::consts::FRAC_PI_2;
    let arc = Series::new("score = 1", (0..=steps).map(|k| quarter(k).cos()).collect(), (0..=steps).map(|k| quarter(k).sin()).collect());
    // Charts colour points after lines; an empty, unlabelled line (nothing drawn, no legend)
    // gives the H–R chart the same colour per take as the H'–R' chart with its circle.
    let colour_slot = Series::new("", Vec::new(), Vec::new());
    vec![
        Figure::chart(
            "scatter_H_R",
            Chart {
                title: "Distance H and synchronisation R of each repetition (Fig. 5)".into(),
                x_label: "H, distance summed over markers and path (mm)".into(),
                y_label: "R, synchronisation (frames²)".into(),
                lines: vec![colour_slot],
                points: raw,
                x_range: raw_range.0,
                y_range: raw_range.1,
                ..Default::default()
            },
        ),
        Figure::chart(
            "scatter_H_R_normalised",
            Chart {
                title: "Normalised H' = H / mean H and R' = R / mean R per take; score = distance from the origin (Fig. 6)".into(),
                x_label: "H' (dimensionless)".into(),
                y_label: "R' (dimensionless)".into(),
                lines: vec![arc],
                points: norm,
                equal_aspect: true,
                // The plot area is about twice as wide as high: H' gets the room, both from 0.
                x_range: Some((0.0, 2.0 * norm_max)),
                y_range: Some((0.0, norm_max)),
                ..Default::default()
            },
        ),
    ]
}

impl MatchingWorkflow {
    /// The viewer pages: the model, each continuous take (velocity function with threshold,
    /// peaks, cut windows and matched stretches) and each repetition of an explicit take (its
    /// matched stretch). Every interval is labelled with its repetition, `H`, `R`, score and
    /// rank by score within the take (1 = most similar).
    /// Bones for the viewer of a loaded (preprocessed) motion: its skeleton's, through the
    /// points a preprocessor merged ([`bones_of_merged_skeleton`] of the file as loaded, read
    /// again), or none (markers only) when the file has no skeleton or cannot be read again.
    fn bones(&self, data: &Datasets, dataset: usize, file: usize, motion: &Motion) -> Vec<[String; 2]> {
        if motion.skeleton.is_some() {
            return Vec::new();
        }
        let d = &data.datasets[dataset];
        match d.loader.load(&d.files[file]) {
            Ok(raw) => bones_of_merged_skeleton(&raw, motion),
            Err(_) => Vec::new(),
        }
    }

    fn viewers(&self, items: &[(WorkItem, ItemData)], results: &[ItemResult], data: &Datasets) -> Result<Vec<ViewerSpec>> {
        let mut out = Vec::new();
        let model = data.load(self.model, 0).map_err(|e| e.under_field("model"))?;
        let model_name = if items.iter().any(|(i, _)| i.id == "model") { "model_basic_motion" } else { "model" };
        let vm = ViewerMotion::from_motion(&model.motion, &self.bones(data, self.model, 0, &model.motion), Some("root"))?;
        let mut spec = ViewerSpec::new(model_name, format!("model basic motion {} — matching", model.name), vm);
        spec.lanes.push(Lane::Intervals(IntervalLane {
            name: "model".into(),
            kind: IntervalKind::Other,
            intervals: vec![Interval { start: 0, end: model.motion.n_frames().saturating_sub(1), label: model.name.clone() }],
        }));
        out.push(spec);
        for ((item, _), r) in items.iter().zip(results) {
            let Some(take) = self.takes.iter().find(|t| t.id == item.id) else { continue };
            let h: Vec<f64> = r.repetitions.iter().map(|x| x.total_distance).collect();
            let rr: Vec<f64> = r.repetitions.iter().map(|x| x.sync_total).collect();
            let score = scores(&h, &rr).score;
            let rank = ranks(&score);
            let n = r.repetitions.len();
            let label = |k: usize| {
                let rep = &r.repetitions[k];
                let group = rep.group.as_ref().filter(|g| !rep.label.contains(&format!("({g})"))).map(|g| format!(" ({g})")).unwrap_or_default();
                let best = if rank[k] == 1 && n > 1 { ", most similar" } else { "" };
                format!("{}{group}: rank {} of {n}{best} — score {}, H {} mm, R {} frames²", rep.label, rank[k], fmt(score[k]), fmt(h[k]), fmt(rr[k]))
            };
            // `[a, b]` of repetition k in frames of a motion whose first frame is file frame `offset`.
            let matched = |k: usize, offset: usize| {
                let rep = &r.repetitions[k];
                Interval { start: (rep.window_start + rep.start).saturating_sub(offset), end: (rep.window_start + rep.end).saturating_sub(offset), label: label(k) }
            };
            match &take.kind {
                TakeKind::Continuous { dataset, file, .. } => {
                    let loaded = data.load(*dataset, *file)?;
                    let offset = cut_offset(&data.datasets[*dataset], loaded.motion.frame_rate());
                    let vm = ViewerMotion::from_motion(&loaded.motion, &self.bones(data, *dataset, *file, &loaded.motion), Some("root"))?;
                    let mut spec = ViewerSpec::new(item.id.clone(), format!("{} — matching", r.take), vm);
                    let mut peaks = EventLane::new("velocity peaks", EventKind::Other, &[]);
                    for rep in &r.repetitions {
                        for &p in &rep.peaks {
                            peaks.marks.push(Mark { frame: p.saturating_sub(offset), label: rep.label.clone(), status: None });
                        }
                    }
                    peaks.marks.sort_by_key(|m| m.frame);
                    spec.lanes.push(Lane::Events(peaks));
                    spec.lanes.push(Lane::Intervals(IntervalLane {
                        name: "matched [a, b]".into(),
                        kind: IntervalKind::Matched,
                        intervals: (0..n).map(|k| matched(k, offset)).collect(),
                    }));
                    spec.lanes.push(Lane::Intervals(IntervalLane {
                        name: "cut windows".into(),
                        kind: IntervalKind::Other,
                        intervals: r
                            .repetitions
                            .iter()
                            .map(|rep| Interval {
                                start: rep.window_start.saturating_sub(offset),
                                end: rep.window_end.saturating_sub(offset + 1),
                                label: rep.label.clone(),
                            })
                            .collect(),
                    }));
                    if let Some((values, unit)) = &r.velocity {
                        let trace = Trace::new("v", unit.clone(), values.clone());
                        let threshold: Vec<Threshold> = r.threshold.map(|t| Threshold { name: "threshold".into(), trace: "v".into(), value: t }).into_iter().collect();
                        spec.lanes.extend(TraceLane::from_traces("velocity function", &[trace], &threshold, loaded.motion.n_frames()).into_iter().map(Lane::Trace));
                    }
                    out.push(spec);
                }
                TakeKind::Explicit { members } => {
                    for (k, &(d, f)) in members.iter().enumerate().take(n) {
                        let loaded = data.load(d, f)?;
                        let offset = cut_offset(&data.datasets[d], loaded.motion.frame_rate());
                        let vm = ViewerMotion::from_motion(&loaded.motion, &self.bones(data, d, f, &loaded.motion), Some("root"))?;
                        let name = format!("{}_{}", item.id, item_id(&r.repetitions[k].label));
                        let mut spec = ViewerSpec::new(name, format!("{} — {} — matching", r.take, r.repetitions[k].label), vm);
                        spec.lanes.push(Lane::Intervals(IntervalLane { name: "matched [a, b]".into(), kind: IntervalKind::Matched, intervals: vec![matched(k, offset)] }));
                        out.push(spec);
                    }
                }
            }
        }
        Ok(out)
    }

    fn item_figures(
        &self,
        id: &str,
        result: &ItemResult,
        detection: Option<&(PointDetection, usize)>,
        paths: &[Vec<Vec<(usize, usize)>>],
    ) -> Result<Vec<Figure>> {
        let rate = result.frame_rate_hz;
        let mut figs = Vec::new();
        if self.wants("velocity")
            && let Some((d, offset)) = detection
        {
            let marker = self
                .section
                .point_detector
                .as_ref()
                .and_then(|s| s.params.get("marker"))
                .and_then(|m| m.as_str())
                .unwrap_or("the detector's marker");
            let t = |f: usize| (f + offset) as f64 / rate;
            let time: Vec<f64> = (0..d.velocity.values.len()).map(t).collect();
            let mut peaks = Series::new(
                "peaks",
                d.peaks.iter().map(|&p| t(p)).collect(),
                d.peaks.iter().map(|&p| d.velocity.values.get(p).copied().unwrap_or(f64::NAN)).collect(),
            );
            let per = self.section.peaks_per_repetition;
            peaks.point_labels = (0..d.peaks.len()).map(|k| format!("{}", k / per + 1)).collect();
            let reps = &result.repetitions;
            let s = |f: usize| f as f64 / rate;
            figs.push(Figure::chart(
                format!("{id}_velocity"),
                Chart {
                    title: format!("{} — velocity function of {marker}, threshold, peaks by repetition, windows (Fig. 2)", result.take),
                    x_label: "time in the file (s)".into(),
                    y_label: format!("v = |s(i) − s(i+1)| ({})", d.velocity.unit),
                    lines: vec![Series::new(format!("v ({marker})"), time, d.velocity.values.clone())],
                    points: vec![peaks],
                    hlines: vec![RefLine { label: "threshold".into(), value: d.threshold }],
                    bar_rows: vec![
                        BarRow { label: "cut windows".into(), marks: vec![], bands: reps.iter().map(|r| (s(r.window_start), s(r.window_end.saturating_sub(1)))).collect() },
                        BarRow {
                            label: "matched [a, b]".into(),
                            marks: reps.iter().flat_map(|r| [s(r.window_start + r.start), s(r.window_start + r.end)]).collect(),
                            bands: reps.iter().map(|r| (s(r.window_start + r.start), s(r.window_start + r.end))).collect(),
                        },
                    ],
                    ..Default::default()
                },
            ));
        }
        if self.wants("paths") {
            for (k, (rep, rep_paths)) in result.repetitions.iter().zip(paths).enumerate() {
                if rep_paths.len() < 2 {
                    continue;
                }
                let pair = match &self.section.path_markers {
                    Some([m1, m2]) => {
                        let find = |m: &str| {
                            result.point_names.iter().position(|n| n == m).ok_or_else(|| {
                                Error::new(ErrorKind::UnknownName, format!("path marker {m:?} is not among the matched points"))
                                    .with_field("matching.path_markers")
                            })
                        };
                        (find(m1)?, find(m2)?)
                    }
                    None => match most_out_of_step(rep_paths, &rep.sync_frames, result.model_frames) {
                        Some(p) => p,
                        None => continue,
                    },
                };
                let mut lines = Vec::new();
                let mut points = Vec::new();
                for l in [pair.0, pair.1] {
                    let name = result.point_names.get(l).cloned().unwrap_or_default();
                    let path = &rep_paths[l];
                    lines.push(Series::new(
                        format!("{name} (h = {} mm)", fmt(rep.point_distances.get(l).copied().unwrap_or(f64::NAN))),
                        path.iter().map(|&(i, _)| i as f64).collect(),
                        path.iter().map(|&(_, j)| (rep.window_start + j) as f64).collect(),
                    ));
                    let u = mean_target_frames(path, result.model_frames);
                    points.push(Series::new(
                        format!("{name} at the examined model frames"),
                        rep.sync_frames.iter().map(|&i| i as f64).collect(),
                        rep.sync_frames.iter().map(|&i| u.get(i).copied().unwrap_or(f64::NAN) + rep.window_start as f64).collect(),
                    ));
                }
                figs.push(Figure::chart(
                    format!("{id}_paths_{}", k + 1),
                    Chart {
                        title: format!(
                            "{} — {}: warping paths of two markers, R = {} frames² (Fig. 4)",
                            result.take,
                            rep.label,
                            fmt(rep.sync_total)
                        ),
                        x_label: format!("model frame i (frames at {} Hz)", fmt(rate)),
                        y_label: format!("matched frame j of the file (frames at {} Hz)", fmt(rate)),
                        lines,
                        points,
                        ..Default::default()
                    },
                ));
            }
        }
        Ok(figs)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn consecutive_peaks_form_one_repetition_whose_window_is_their_union() {
        let d = PointDetection {
            velocity: Trace::new("v", "mm/frame", vec![]),
            threshold: 1.0,
            peaks: vec![20, 60, 150, 190],
            windows: vec![(0, 41), (40, 81), (130, 171), (170, 211)],
        };
        assert_eq!(group_repetitions(&d, 2), vec![(vec![20, 60], (0, 81)), (vec![150, 190], (130, 211))]);
        assert_eq!(group_repetitions(&d, 1).len(), 4);
        assert_eq!(group_repetitions(&d, 1)[2], (vec![150], (130, 171)));
    }

    #[test]
    fn item_ids_are_tidy_file_names() {
        assert_eq!(item_id("jumping jacks (a)(b)(c)"), "jumping_jacks_a_b_c");
        assert_eq!(item_id("13_29"), "13_29");
        assert_eq!(item_id("(()) "), "take");
    }

    #[test]
    fn mean_target_frames_average_runs_and_leave_gaps_nan() {
        // Model frame 1 matched to target frames 3, 4, 5; frame 3 never reached.
        let path = [(0, 2), (1, 3), (1, 4), (1, 5), (2, 6)];
        let u = mean_target_frames(&path, 4);
        assert_eq!(&u[..3], &[2.0, 4.0, 6.0]);
        assert!(u[3].is_nan());
    }

    #[test]
    fn the_most_out_of_step_pair_is_found() {
        let diag = |shift: usize| (0..10).map(|i| (i, i + shift)).collect::<Vec<_>>();
        let paths = vec![diag(0), diag(1), diag(5), diag(2)];
        assert_eq!(most_out_of_step(&paths, &[2, 5, 8], 10), Some((0, 2)));
        assert_eq!(most_out_of_step(&paths[..1], &[2], 10), None);
    }

    fn rep(label: &str, group: &str, pair: &str, h: f64, r: f64) -> RepetitionRecord {
        RepetitionRecord {
            label: label.into(),
            group: Some(group.into()),
            pair: (!pair.is_empty()).then(|| pair.to_string()),
            peaks: vec![],
            window_start: 0,
            window_end: 10,
            start: 0,
            end: 9,
            point_distances: vec![h],
            total_distance: h,
            sync_frames: vec![5],
            section_values: vec![r],
            sync_total: r,
        }
    }

    fn take(reps: Vec<RepetitionRecord>) -> ItemResult {
        ItemResult {
            take: "t".into(),
            continuous: false,
            frame_rate_hz: 120.0,
            model_frames: 10,
            point_names: vec!["p".into()],
            threshold: None,
            repetitions: reps,
            velocity: None,
        }
    }

    #[test]
    fn the_timing_verdict_states_each_check_and_whether_it_held() {
        // (a) close: small H and R; (b) its delayed copy: same H, larger R; (c) wrong: large H.
        let ok = take(vec![rep("a1", "a", "1", 10.0, 1.0), rep("b1", "b", "1", 11.0, 4.0), rep("c", "c", "", 30.0, 2.0)]);
        let (ranks_rows, v) = timing_test(&[ok]);
        assert_eq!(ranks_rows.len(), 3);
        assert_eq!(ranks_rows.iter().map(|r| r.rank_score).collect::<Vec<_>>(), vec![1, 2, 3]);
        let held: Vec<(&str, bool)> = v.iter().map(|x| (x.check.as_str(), x.held)).collect();
        assert_eq!(held.len(), 6, "{held:?}");
        assert!(held.iter().all(|(_, h)| *h), "{held:?}");
        assert!(v[0].detail.contains("R(a) 1 → R(b) 4"), "{}", v[0].detail);
        // A (b) that is *better* synchronised than its (a), and an (a) ranked last by score.
        let bad = take(vec![rep("a1", "a", "1", 10.0, 9.0), rep("b1", "b", "1", 10.0, 2.0), rep("c", "c", "", 9.0, 1.0)]);
        let (_, v) = timing_test(&[bad]);
        let held: Vec<bool> = v.iter().map(|x| x.held).collect();
        // pairwise R, every-b-vs-every-a R, score top is (a), H top is (a), c worse than a, worst is b/c
        assert_eq!(held, vec![false, false, false, false, false, false], "{:?}", v.iter().map(|x| &x.detail).collect::<Vec<_>>());
        // Without groups there is no timing test.
        let mut plain = take(vec![rep("r1", "a", "", 1.0, 1.0)]);
        plain.repetitions[0].group = None;
        assert!(timing_test(&[plain]).1.is_empty());
    }
}
