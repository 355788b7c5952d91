//! The `[benchmark]` workflow: every listed segmenter on every labelled sequence, scored by
//! segment covering and TCPDBench's F1 beside chance, ranked across methods, with a
//! critical-difference diagram and, optionally, published scores beside ours.

use std::time::Instant;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry;
use motionlab_core::{
    Error, ErrorKind, FeatureCache, Fuser, MethodCandidates, Result, Table, TimeSpan,
};
use motionlab_eval::boundaries::tolerance_frames;
use motionlab_eval::chance::{ALPHA, ChanceSettings, row_seed};
use motionlab_eval::label_metrics::{LabelScores, label_scores, truth_states};
use motionlab_eval::ranks::{RankComparison, Ties, compare_methods};
use motionlab_eval::series_scores::{ScoreWithChance, SeriesScores, score_series};
use motionlab_figure::{CriticalDifference, Figure, FigureKind, RankedMethod};
use motionlab_io::scores_csv::{PublishedScores, read_scores_csv};

use crate::parameter_choice::{MethodChoices, StageChoice};
use motionlab_experiment::labellers::{NamedLabeller, build_labellers};
use motionlab_experiment::segmenters::{NamedSegmenter, build_segmenters};
use motionlab_experiment::spec::StageSpec;
use motionlab_experiment::toml_paths::KeyPath;
use motionlab_experiment::workflow::{
    BuildContext, ComboOutput, ItemData, ItemOutput, Output, WorkItem, Workflow, WorkflowPlugin,
};
use motionlab_experiment::{Datasets, build_stage};

/// A segmentation benchmark: every segmenter of `segmenter` (built-in, an `external` program or
/// a plugin of one's own — one line each) on every sequence of every dataset, each of which
/// must have ground truth (channel files — `loader = { type = "channels" }` — or mocap takes,
/// where a segmenter that reads channels takes `input = { features = […] }`).
///
/// Per sequence and method, and as the mean over sequences (rows `sequence = "mean"`):
/// - `benchmark_covering`: segment covering (TCPDBench's, as TSSB scores), the chance
///   baseline (as many distinct frames drawn uniformly over the sequence, `chance_draws`
///   times, seeded by `chance_seed` mixed with the sequence and method names — the draws of
///   `boundary_metrics`' `tcpd_metrics`) and the one-sided p-value; the mean row's chance is
///   the mean of each draw over the sequences. With `published`, the published score of the
///   method it names beside ours, and the difference.
/// - `benchmark_f1`: TCPDBench's F1 (with precision and recall) at each of `margins`, with
///   its chance baseline and p-value likewise.
/// - `benchmark_ranks`: per method (ours, then the published ones, labelled
///   `NAME (published)`), the mean rank by covering over the sequences every method scored
///   (rank 1 the best, ties by `ties`), the number of first places, and the mean covering;
///   `benchmark_rank_test`: Friedman's test and Nemenyi's critical difference at `alpha`,
///   drawn as the figure `critical_difference`.
/// - `benchmark_runtime`: each segmenter's wall time per sequence (its feature extraction
///   included, measured where it was computed and kept with its cached output: a cached run
///   reports the time of the run that computed it) and per sample. Runtimes differ from run to
///   run; keep this table out of a run of record (`record_tables`).
///
/// - `benchmark_change_points`: every change point each method found (`sequence, method,
///   sample`), so a run can be re-scored with another metric or fed to a later stage.
/// - `benchmark_detection_delay`, when a segmenter is a streaming one (it decides as samples
///   arrive: `bocpd_online`, the `*_online` trackers; it runs on the whole series through the
///   same session it runs live with, so its time is its streaming throughput): per sequence and
///   in total, how many true changes (the consensus boundaries) it detected within the first
///   margin and how late — `decided_at − true change`, in samples and seconds, median and 90th
///   percentile (negative: decided before the true change, a boundary placed early). Each true
///   change takes, among the unused change points within the margin, the one decided first.
///   Its throughput is `benchmark_runtime`'s time per sample.
///
/// Every evaluation table says how each method's parameters were chosen
/// (`parameters_chosen`: plugin defaults, set in the experiment, swept).
///
/// With a sweep and `selection = "leave_one_sequence_out"`, `heldout_covering`: for each
/// sequence in turn, each method's combination with the best mean covering on the *other*
/// sequences (each grid contributes its `focus` method, or every method without one; the first
/// combination in grid order among equal means), its covering on the held-out sequence beside
/// that combination's chance baseline there; a `mean` row pools them (the mean of each chance
/// draw, as the mean rows above); and a row `all sequences` gives the same rule applied to every
/// sequence — the value such a protocol would make the default, whose mean covering there is an
/// oracle (chosen on the very sequences it reports).
/// A method that cannot take a sequence (its segmenter's error: FLUSS on several channels, a
/// series shorter than its window) is recorded as failed on that sequence with its reason and
/// the benchmark goes on, as TCPDBench records failures: the per-sequence rows then carry
/// `status` (`ok`/`failed`) and `failure` (the reason) — columns present only when a method
/// failed —, its scores are NaN, the mean rows are over the sequences it scored (their
/// `status` says how many failed), and in the ranks a failure ranks last on its sequence
/// (`benchmark_ranks.n_failed`).
///
/// Missing samples: as each segmenter treats them (most refuse NaN: fill gaps first, or let a
/// feature input's `fill` do it).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct BenchmarkSection {
    /// The segmenters, one line each: `segmenter = [{ type = "clasp" }, { type = "kernel_cpd",
    /// name = "PELT", search = "pelt" }, …]` (or `[[benchmark.segmenter]]` tables); names
    /// (`name`, else the type) must be unique. At least one.
    #[serde(rename = "segmenter")]
    pub segmenters: Vec<StageSpec>,
    /// An optional fuser combining the segmenters' candidates into one more method (Sonoda's
    /// `union_merge`); its runtime is its own plus that of the segmenters it fuses.
    #[serde(default)]
    pub fuser: Option<StageSpec>,
    /// Names of the segmenters the fuser combines.
    #[serde(default)]
    #[schemars(extend("x-default" = "all of them"))]
    pub fuse: Option<Vec<String>>,
    /// TCPDBench margins of `benchmark_f1`, in frames or seconds (a found frame within this
    /// many whole frames of a truth can count); the default is TCPDBench's 5 samples.
    #[serde(default = "default_margins")]
    pub margins: Vec<TimeSpan>,
    /// Random draws of the chance baselines (≥ 100).
    #[serde(default = "motionlab_eval::chance::default_draws")]
    pub chance_draws: usize,
    /// Base seed of the chance draws (mixed with the sequence and method names).
    #[serde(default = "motionlab_eval::chance::default_seed")]
    pub chance_seed: u64,
    /// How tied coverings are ranked: `"average"` (the mean of the tied ranks; what Friedman's
    /// and Nemenyi's tests assume) or `"min"` (the lowest, as TSSB's notebook ranks).
    #[serde(default)]
    pub ties: Ties,
    /// Significance level of the critical difference, in (0, 1).
    #[serde(default = "default_alpha")]
    pub alpha: f64,
    /// Published per-sequence scores to show beside ours and to rank with ours.
    #[serde(default)]
    pub published: Option<PublishedSpec>,
    /// With a sweep: `"leave_one_sequence_out"` adds `heldout_covering` (see above); `"none"`
    /// only reports every combination.
    #[serde(default)]
    pub selection: BenchmarkSelection,
    /// State labellers (`labeller = [{ type = "segment_clusters" }, { type = "multistream_dp" }]`),
    /// each run on the segments of every segmentation of `label_segments`: which segments are
    /// the same motion. Scored per sample against the truth's segment labels in
    /// `benchmark_states` (AMI, ARI, NMI beside chance); their segments and states in
    /// `benchmark_segment_states`.
    #[serde(default, rename = "labeller")]
    pub labellers: Vec<StageSpec>,
    /// The segmentations the labellers label: method names of this benchmark, and `"truth"` —
    /// the truth's own boundaries (an oracle segmentation: how well the labeller does when
    /// the cuts are right).
    #[serde(default)]
    #[schemars(extend("x-default" = "every method, then \"truth\""))]
    pub label_segments: Option<Vec<String>>,
}

/// How a benchmark's sweep chooses each method's combination (`[benchmark] selection = …`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum BenchmarkSelection {
    /// No choice: every combination's tables.
    #[default]
    None,
    /// Each sequence held out in turn; the combination with the best mean covering on the
    /// others (`heldout_covering`).
    LeaveOneSequenceOut,
}

/// Every (sequence, method, covering) of one combination, for `summarize`.
struct CoveringScores(Vec<(String, String, ScoreWithChance)>);

/// `published = { file = "…", metric = "covering", methods = { clasp = "ClaSP" } }`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PublishedSpec {
    /// A CSV of per-sequence scores (header `dataset,MethodA,…`, one row per sequence named as
    /// the sequences here; `motionlab_io::scores_csv`), relative to the experiment file.
    pub file: String,
    /// What its scores are; only `covering` is ranked beside ours.
    pub metric: PublishedMetric,
    /// Which published column each of our methods is shown beside (`our name = "column"`).
    #[serde(default)]
    pub methods: std::collections::BTreeMap<String, String>,
    /// A sequence of the run that the sheet has no row for: `"error"` (the experiment
    /// is refused, naming the sheet and the first missing sequence) or `"skip"`
    /// (the published columns and the ranks leave it out, and `benchmark_rank_test` and the
    /// mean rows say how many were left out).
    #[serde(default)]
    pub missing: MissingPublished,
}

/// What a published sheet missing a sequence of the run does (`published.missing`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum MissingPublished {
    /// Refuse the experiment (a silently shorter ranking is the failure this prevents).
    #[default]
    Error,
    /// Leave the sequence out of the published columns and the ranks, and say so.
    Skip,
}

/// The metric of a published scores file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum PublishedMetric {
    Covering,
}

fn default_margins() -> Vec<TimeSpan> {
    vec![TimeSpan::Frames(5.0)]
}

fn default_alpha() -> f64 {
    ALPHA
}

pub struct BenchmarkWorkflow {
    section: BenchmarkSection,
    segmenters: Vec<NamedSegmenter>,
    fuser: Option<(String, Box<dyn Fuser>)>,
    fuse: Vec<usize>,
    chance: ChanceSettings,
    published: Option<(PublishedScores, PublishedSpec)>,
    /// The run's sequences the published sheet has no row for (`missing = "skip"`), in order.
    published_missing: Vec<String>,
    choices: MethodChoices,
    labellers: Vec<NamedLabeller>,
    /// What the labellers label: method names and `truth`, in order.
    label_segments: Vec<String>,
}

/// The segmentation name that stands for the truth's own boundaries in `label_segments`.
const TRUTH_SEGMENTS: &str = "truth";

/// What one sequence produced.
#[derive(Serialize, Deserialize)]
struct ItemResult {
    sequence: String,
    n_samples: usize,
    n_truth: usize,
    methods: Vec<MethodRun>,
    /// The consensus true changes (samples), for detection delays.
    #[serde(default)]
    truth: Vec<usize>,
    /// Samples per second.
    #[serde(default)]
    rate_hz: f64,
    /// Each labeller on each segmentation of `label_segments` (empty without labellers).
    #[serde(default)]
    labels: Vec<LabelRun>,
}

/// One labeller on one segmentation of one sequence.
#[derive(Serialize, Deserialize)]
struct LabelRun {
    /// The segmentation labelled: a method's name or `truth`.
    segmentation: String,
    labeller: String,
    seconds: f64,
    /// `(start, end, state)` of each segment (samples, end exclusive).
    segments: Vec<(usize, usize, usize)>,
    /// The true states on the samples the truth labels (how many), and the scores; `Err`:
    /// the labeller (or the segmentation it needed) failed, with the reason.
    scores: std::result::Result<LabelScores, String>,
}

#[derive(Serialize, Deserialize)]
struct MethodRun {
    method: String,
    seconds: f64,
    /// The change points it found (samples), kept for `benchmark_change_points`.
    found: Vec<usize>,
    /// `Err(reason)`: the method could not take this series (its error, one line).
    scores: std::result::Result<SeriesScores, String>,
    /// For a streaming segmenter, the sample at which each of `found` was decided.
    #[serde(default)]
    decided_at: Option<Vec<usize>>,
}

impl MethodRun {
    fn scored(&self) -> Option<&SeriesScores> {
        self.scores.as_ref().ok()
    }
    fn failure(&self) -> Option<&str> {
        self.scores.as_ref().err().map(String::as_str)
    }
}

/// A segmenter's candidates and the wall time that computed them (cached together).
#[derive(Serialize, Deserialize)]
struct TimedCandidates {
    candidates: Vec<usize>,
    seconds: f64,
    /// For a streaming segmenter, the sample at which each candidate was decided.
    #[serde(default)]
    decided_at: Option<Vec<usize>>,
}

impl WorkflowPlugin for BenchmarkWorkflow {
    type Section = BenchmarkSection;
    fn build(section: BenchmarkSection, cx: &BuildContext<'_>) -> Result<Self> {
        let root = cx.root.clone();
        let invalid = |msg: String, at: KeyPath| {
            Err(cx.locate(Error::new(ErrorKind::InvalidParameter, msg), at))
        };
        if section.segmenters.is_empty() {
            return Err(cx.locate(Error::new(ErrorKind::MissingKey, "lists no segmenter; expected at least one (`segmenter = [{ type = \"clasp\" }]`)"), root.key("segmenter")));
        }
        let segmenters = build_segmenters(cx, &section.segmenters, &root.key("segmenter"))?;
        if !cx.combo.file.evaluators.is_empty() {
            return invalid(
                "a benchmark scores with its own metrics (`margins`, `chance_draws` in [benchmark]); [[evaluate]] belongs to [segmentation]".into(),
                KeyPath::parse("evaluate")?,
            );
        }
        if let Some(d) = cx.data.datasets.iter().find(|d| d.spec.ground_truth.is_none()) {
            return Err(cx.locate(
                Error::new(ErrorKind::MissingKey, "a benchmark scores against ground truth: every dataset needs `ground_truth = { type = … }`"),
                KeyPath::parse("dataset")?.index(d.index),
            ));
        }
        for (i, m) in section.margins.iter().enumerate() {
            m.check(&format!("margins[{i}]"), false).map_err(|e| cx.locate(e, &root))?;
        }
        if section.margins.is_empty() {
            return invalid(
                "lists no margin; expected at least one (`margins = [{ frames = 5 }]`)".into(),
                root.key("margins"),
            );
        }
        if !(section.alpha > 0.0 && section.alpha < 1.0) {
            return invalid(
                format!("must lie in (0, 1), found {}", section.alpha),
                root.key("alpha"),
            );
        }
        let chance = ChanceSettings::checked(section.chance_draws, section.chance_seed)
            .map_err(|e| cx.locate(e, &root))?;
        let fuse = match &section.fuse {
            None => (0..segmenters.len()).collect(),
            Some(names) => names
                .iter()
                .map(|n| {
                    segmenters.iter().position(|s| s.name == *n).ok_or_else(|| {
                        cx.locate(
                            Error::new(
                                ErrorKind::UnknownName,
                                format!(
                                    "fuse names {n:?}, which is not a segmenter of this benchmark"
                                ),
                            ),
                            root.key("fuse"),
                        )
                    })
                })
                .collect::<Result<Vec<_>>>()?,
        };
        let fuser = match &section.fuser {
            Some(f) => {
                let name = f.display_name();
                if segmenters.iter().any(|s| s.name == name) {
                    return Err(cx.locate(Error::new(ErrorKind::DuplicateName, format!("the fuser is named {name:?} like a segmenter; give it another `name`")), root.key("fuser")));
                }
                Some((
                    name,
                    build_stage(cx.source, cx.combo, f, &root.key("fuser"), registry::build_fuser)?,
                ))
            }
            None => None,
        };
        let method_names: Vec<String> = segmenters
            .iter()
            .map(|s| s.name.clone())
            .chain(fuser.iter().map(|(n, _)| n.clone()))
            .collect();
        let published = match &section.published {
            None => None,
            Some(p) => {
                let at = root.key("published");
                let path = cx.source.base_dir().join(&p.file);
                let scores = read_scores_csv(&path)
                    .map_err(|e| cx.locate(Error::new(e.kind(), e.to_string()), at.key("file")))?;
                for (ours, theirs) in &p.methods {
                    if !method_names.contains(ours) {
                        return Err(cx.locate(
                            Error::new(
                                ErrorKind::UnknownName,
                                format!(
                                    "names {ours:?}, which is not a method of this benchmark ({})",
                                    method_names.join(", ")
                                ),
                            ),
                            at.key("methods"),
                        ));
                    }
                    if scores.method_index(theirs).is_none() {
                        return Err(cx.locate(
                            Error::new(
                                ErrorKind::UnknownName,
                                format!(
                                    "{theirs:?} is not a column of {} ({})",
                                    path.display(),
                                    scores.methods.join(", ")
                                ),
                            ),
                            at.key("methods").key(ours),
                        ));
                    }
                }
                Some((scores, p.clone()))
            }
        };
        let mut published_missing = Vec::new();
        if let (Some((scores, spec)), Some(p)) = (&published, &section.published) {
            let sequences = cx
                .data
                .datasets
                .iter()
                .flat_map(|d| (0..d.files.len()).map(move |k| d.sequence_name(k)));
            published_missing = sequences.filter(|s| scores.series(s).is_none()).collect();
            let n_sequences: usize = cx.data.datasets.iter().map(|d| d.files.len()).sum();
            if let (Some(first), MissingPublished::Error) =
                (published_missing.first(), spec.missing)
            {
                let path = cx.source.base_dir().join(&p.file);
                return Err(cx.locate(
                    Error::new(
                        ErrorKind::MissingData,
                        format!(
                            "{} has no row for sequence {first:?} ({} of the run's {n_sequences} sequences are missing); give every sequence its published score, or set `missing = \"skip\"` to leave them out of the published columns and the ranks",
                            path.display(),
                            published_missing.len()
                        ),
                    ),
                    root.key("published").key("file"),
                ));
            }
        }
        let swept: Vec<String> = cx
            .combo
            .params
            .iter()
            .map(|(k, _)| KeyPath::parse(k).map_or_else(|_| k.clone(), |p| p.to_string()))
            .collect();
        let stage_choices: Vec<StageChoice> = section
            .segmenters
            .iter()
            .enumerate()
            .map(|(k, s)| {
                StageChoice::of(
                    s,
                    &[
                        format!("{}[{}]", root.key("segmenter"), s.display_name()),
                        root.key("segmenter").index(k).to_string(),
                    ],
                    &swept,
                )
            })
            .collect();
        let mut methods: Vec<(String, Vec<StageChoice>)> = segmenters
            .iter()
            .zip(&stage_choices)
            .map(|(s, c)| (s.name.clone(), vec![c.clone()]))
            .collect();
        if let (Some((name, _)), Some(spec)) = (&fuser, &section.fuser) {
            let own = StageChoice::of(spec, &[root.key("fuser").to_string()], &swept);
            methods.push((
                name.clone(),
                std::iter::once(own)
                    .chain(fuse.iter().map(|&i| stage_choices[i].clone()))
                    .collect(),
            ));
        }
        let labellers = build_labellers(cx, &section.labellers, &root.key("labeller"))?;
        let label_segments = match &section.label_segments {
            None => method_names.iter().cloned().chain([TRUTH_SEGMENTS.to_string()]).collect(),
            Some(names) => {
                for n in names {
                    if n != TRUTH_SEGMENTS && !method_names.contains(n) {
                        return Err(cx.locate(
                            Error::new(
                                ErrorKind::UnknownName,
                                format!(
                                    "names {n:?}, which is neither a method of this benchmark ({}) nor \"truth\"",
                                    method_names.join(", ")
                                ),
                            ),
                            root.key("label_segments"),
                        ));
                    }
                }
                if names.is_empty() && !labellers.is_empty() {
                    return invalid(
                        "lists no segmentation for the labellers; expected method names or \"truth\"".into(),
                        root.key("label_segments"),
                    );
                }
                names.clone()
            }
        };
        if section.label_segments.is_some() && labellers.is_empty() {
            return invalid(
                "names segmentations to label, but the benchmark has no `labeller`".into(),
                root.key("label_segments"),
            );
        }
        Ok(BenchmarkWorkflow {
            section,
            segmenters,
            fuser,
            fuse,
            chance,
            published,
            published_missing,
            choices: MethodChoices { methods },
            labellers,
            label_segments,
        })
    }
}

motionlab_experiment::register_workflow!(BenchmarkWorkflow, "benchmark");

impl Workflow for BenchmarkWorkflow {
    fn run_item(&self, item: &WorkItem, data: &Datasets, _draw: bool) -> Result<ItemOutput> {
        let loaded = data.load(item.dataset, item.file)?;
        let motion = &loaded.motion;
        let file = motion.source.clone().unwrap_or_default();
        let truth = loaded.truth.as_ref().ok_or_else(|| {
            Error::new(
                ErrorKind::MissingData,
                format!(
                    "sequence {} has no ground truth; a benchmark scores every sequence against it",
                    loaded.name
                ),
            )
            .with_location(motionlab_core::Location::file(&file))
        })?;
        let annotators = truth.annotator_frames();
        let n_frames = motion.n_frames();
        let rate = motion.frame_rate();
        let margins: Vec<usize> = self
            .section
            .margins
            .iter()
            .map(|&m| tolerance_frames(m, rate).floor() as usize)
            .collect();
        // Each method's candidates, or why it could not take this series (`Err`).
        let mut runs: Vec<(String, std::result::Result<TimedCandidates, String>)> = Vec::new();
        for s in &self.segmenters {
            let name = &s.name;
            // A segmenter's own error (it cannot take this series: FLUSS on several channels,
            // too few samples for its window…) is recorded as its failure on this series and
            // the benchmark goes on, as TCPDBench records failures; any other error (the
            // cache, the input) still stops the run. Failures are not cached.
            let mut failure: Option<String> = None;
            let timed = data.stage_cached(
                &loaded,
                (item.dataset, item.file),
                &format!("segmenter {name}"),
                "benchmark_segmenter",
                &s.cache_key,
                || {
                    // A cache of its own: each method's time includes the features it reads.
                    let cache = FeatureCache::new();
                    let start = Instant::now();
                    let out = s.segment(motion, &cache).map_err(|e| {
                        failure = Some(e.message().to_string());
                        e.in_file(&file).under_field(format!("segmenter {name}"))
                    })?;
                    let seconds = start.elapsed().as_secs_f64();
                    // A streaming segmenter's offline output says when each point was decided.
                    let decided_at = s.stage.streaming().and_then(|_| {
                        let delay =
                            out.traces.iter().find(|t| t.name == "decision_delay_samples")?;
                        out.candidates
                            .iter()
                            .map(|&c| {
                                let d = *delay.values.get(c)?;
                                d.is_finite().then(|| c + d as usize)
                            })
                            .collect::<Option<Vec<usize>>>()
                    });
                    Ok(TimedCandidates { candidates: out.candidates, seconds, decided_at })
                },
            );
            match (timed, failure) {
                (Ok(t), _) => runs.push((name.clone(), Ok(t))),
                (Err(_), Some(reason)) => runs.push((name.clone(), Err(reason))),
                (Err(e), None) => return Err(e),
            }
        }
        if let Some((name, fuser)) = &self.fuser {
            let fused = match self.fuse.iter().find_map(|&i| runs[i].1.as_ref().err()) {
                Some(reason) => Err(format!("a fused method failed: {reason}")),
                None => {
                    let inputs: Vec<MethodCandidates<'_>> = self
                        .fuse
                        .iter()
                        .filter_map(|&i| {
                            let t = runs[i].1.as_ref().ok()?;
                            Some(MethodCandidates { method: &runs[i].0, frames: &t.candidates })
                        })
                        .collect();
                    let start = Instant::now();
                    let fused = fuser
                        .fuse(motion, &inputs)
                        .map_err(|e| e.in_file(&file).under_field(format!("fuser {name}")))?;
                    let seconds = start.elapsed().as_secs_f64()
                        + self
                            .fuse
                            .iter()
                            .filter_map(|&i| runs[i].1.as_ref().ok())
                            .map(|t| t.seconds)
                            .sum::<f64>();
                    Ok(TimedCandidates { candidates: fused, seconds, decided_at: None })
                }
            };
            data.record(
                item.dataset,
                item.file,
                &format!("fuser {name}"),
                motionlab_experiment::Origin::Computed,
            );
            runs.push((name.clone(), fused));
        }
        let methods: Vec<MethodRun> = runs
            .into_iter()
            .map(|(method, t)| match t {
                Ok(t) => {
                    let seed = row_seed(self.chance.seed, &loaded.name, &method);
                    let scores = score_series(
                        &annotators,
                        &t.candidates,
                        n_frames,
                        &margins,
                        self.chance,
                        seed,
                    );
                    MethodRun {
                        method,
                        seconds: t.seconds,
                        found: t.candidates,
                        scores: Ok(scores),
                        decided_at: t.decided_at,
                    }
                }
                Err(reason) => MethodRun {
                    method,
                    seconds: f64::NAN,
                    found: Vec::new(),
                    scores: Err(reason),
                    decided_at: None,
                },
            })
            .collect();
        let labels = self.label_item(&loaded.name, motion, truth, &methods, &file)?;
        let result = ItemResult {
            sequence: loaded.name.clone(),
            n_samples: n_frames,
            n_truth: truth.boundaries.len(),
            methods,
            truth: truth.frames(),
            rate_hz: rate.hz(),
            labels,
        };
        Ok(ItemOutput::new(ItemData::encode(&result)?, Vec::new()))
    }

    fn finish(
        &self,
        items: &[(WorkItem, ItemData)],
        data: &Datasets,
        _draw: bool,
    ) -> Result<Output> {
        let results: Vec<ItemResult> =
            items.iter().map(|(_, v)| v.decode()).collect::<Result<_>>()?;
        let mut inputs: Vec<(String, String)> = Vec::new();
        for ((item, _), r) in items.iter().zip(&results) {
            let sha = data.cache.file_sha256(&data.datasets[item.dataset].files[item.file])?;
            inputs.push((r.sequence.clone(), motionlab_experiment::run_cache::hex(&sha)));
        }
        let methods: Vec<String> = self
            .segmenters
            .iter()
            .map(|s| s.name.clone())
            .chain(self.fuser.iter().map(|(n, _)| n.clone()))
            .collect();
        let scores_of = |m: &str| -> Vec<(&str, &MethodRun)> {
            results
                .iter()
                .filter_map(|r| {
                    r.methods.iter().find(|x| x.method == m).map(|x| (r.sequence.as_str(), x))
                })
                .collect()
        };
        let mut out = Output::default();
        let mut tables = vec![
            self.covering_table(&results, &methods, &scores_of)?,
            self.f1_table(&results, &methods, &scores_of)?,
        ];
        let (ranks, test, figure) = self.rank_tables(&results, &methods)?;
        tables.push(ranks);
        self.choices.annotate(&mut tables, &inputs);
        out.tables.extend(tables);
        out.tables.push(test);
        out.tables.push(runtime_table(&results, &methods)?);
        out.tables.push(change_points_table(&results)?);
        if results.iter().flat_map(|r| &r.methods).any(|m| m.decided_at.is_some()) {
            let margin = self.section.margins.first().copied().unwrap_or(TimeSpan::Frames(0.0));
            out.tables.push(detection_delay_table(&results, &methods, margin)?);
        }
        if !self.labellers.is_empty() {
            out.tables.push(self.states_table(&results)?);
            out.tables.push(segment_states_table(&results)?);
        }
        out.figures.extend(figure);
        if self.section.selection == BenchmarkSelection::LeaveOneSequenceOut {
            let scores = results
                .iter()
                .flat_map(|r| {
                    // A method that failed on a sequence has no covering there to choose by.
                    r.methods.iter().filter_map(|m| {
                        let scores = m.scores.as_ref().ok()?;
                        Some((r.sequence.clone(), m.method.clone(), scores.covering.clone()))
                    })
                })
                .collect();
            out.analyses.push((
                "benchmark_covering".into(),
                motionlab_core::Analysis::new(CoveringScores(scores)),
            ));
        }
        Ok(out)
    }

    fn summarize(&self, combos: &[ComboOutput<'_>]) -> Result<Output> {
        let mut out = Output::default();
        if self.section.selection == BenchmarkSelection::LeaveOneSequenceOut {
            out.tables.push(heldout_covering(combos, &self.method_names())?);
        }
        Ok(out)
    }
}

/// A row of `heldout_covering`.
#[derive(Serialize)]
struct HeldOutRow {
    sequence: String,
    method: String,
    chosen: String,
    combination: usize,
    covering: f64,
    chance_covering: f64,
    p_value_covering: f64,
    above_chance: &'static str,
}

/// One grid point of a method: (combination, its swept values, sequence → covering).
type GridPoint<'a> = (usize, String, Vec<(&'a str, &'a ScoreWithChance)>);

/// The leave-one-sequence-out choice of each method's combination by mean covering.
fn heldout_covering(combos: &[ComboOutput<'_>], methods: &[String]) -> Result<Table> {
    let mut rows = Vec::new();
    for method in methods {
        // (combination, parameters, sequence → covering) of every point of this method.
        let points: Vec<GridPoint<'_>> = combos
            .iter()
            .filter(|co| co.combo.focus.as_ref().is_none_or(|f| f == method))
            .filter_map(|co| {
                let (_, a) = co.output.analyses.iter().find(|(n, _)| n == "benchmark_covering")?;
                let scores = a.get::<CoveringScores>()?;
                let per: Vec<(&str, &ScoreWithChance)> = scores
                    .0
                    .iter()
                    .filter(|(_, m, _)| m == method)
                    .map(|(s, _, c)| (s.as_str(), c))
                    .collect();
                Some((co.combo.index, co.combo.label(), per))
            })
            .filter(|p| !p.2.is_empty())
            .collect();
        let Some(first) = points.first() else { continue };
        let sequences: Vec<&str> = first.2.iter().map(|(s, _)| *s).collect();
        let mean_on = |p: &GridPoint<'_>, skip: Option<&str>| {
            let v: Vec<f64> =
                p.2.iter().filter(|(s, _)| Some(*s) != skip).map(|(_, c)| c.value).collect();
            v.iter().sum::<f64>() / v.len() as f64
        };
        let best = |skip: Option<&str>| {
            let mut best = 0;
            for i in 1..points.len() {
                if mean_on(&points[i], skip) > mean_on(&points[best], skip) {
                    best = i;
                }
            }
            best
        };
        let label = |p: &GridPoint<'_>| {
            if p.1.is_empty() { "(no sweep)".to_string() } else { p.1.clone() }
        };
        let mut held: Vec<&ScoreWithChance> = Vec::new();
        for seq in &sequences {
            let p = &points[best(Some(seq))];
            let Some((_, score)) = p.2.iter().find(|(s, _)| s == seq) else { continue };
            held.push(score);
            rows.push(HeldOutRow {
                sequence: seq.to_string(),
                method: method.clone(),
                chosen: label(p),
                combination: p.0,
                covering: score.value,
                chance_covering: score.chance,
                p_value_covering: score.p_value,
                above_chance: above(score.p_value),
            });
        }
        let pooled = ScoreWithChance::mean(held);
        rows.push(HeldOutRow {
            sequence: "mean".into(),
            method: method.clone(),
            chosen: "each sequence's own choice (above)".into(),
            combination: 0,
            covering: pooled.value,
            chance_covering: pooled.chance,
            p_value_covering: pooled.p_value,
            above_chance: above(pooled.p_value),
        });
        let p = &points[best(None)];
        let all = ScoreWithChance::mean(p.2.iter().map(|(_, c)| *c));
        rows.push(HeldOutRow {
            sequence: "all sequences (oracle)".into(),
            method: method.clone(),
            chosen: label(p),
            combination: p.0,
            covering: all.value,
            chance_covering: all.chance,
            p_value_covering: all.p_value,
            above_chance: above(all.p_value),
        });
    }
    Table::from_records(
        "heldout_covering",
        "Leave-one-sequence-out: each method's combination chosen by mean covering on the other sequences, scored on the held-out one beside chance; their mean; and the choice on all sequences (an oracle)",
        &rows,
    )
}

/// A row of `benchmark_covering`.
#[derive(Serialize)]
struct CoveringRow {
    sequence: String,
    method: String,
    n_samples: usize,
    n_truth: usize,
    n_found: Option<usize>,
    covering: f64,
    chance_covering: f64,
    p_value_covering: f64,
    above_chance: &'static str,
    published_method: Option<String>,
    published_covering: Option<f64>,
    covering_minus_published: Option<f64>,
    status: String,
    failure: String,
}

/// A row of `benchmark_states`.
#[derive(Serialize)]
struct StatesRow {
    sequence: String,
    segmentation: String,
    labeller: String,
    method: String,
    n_samples: usize,
    n_segments: Option<usize>,
    n_states: Option<usize>,
    ami: f64,
    chance_ami: f64,
    p_value_ami: f64,
    ari: f64,
    chance_ari: f64,
    p_value_ari: f64,
    nmi: f64,
    chance_nmi: f64,
    p_value_nmi: f64,
    above_chance_ami: &'static str,
    status: String,
    failure: String,
}

/// `benchmark_segment_states`: every labelled segment (`sequence, method, start, end, state`).
fn segment_states_table(results: &[ItemResult]) -> Result<Table> {
    #[derive(Serialize)]
    struct Row {
        sequence: String,
        method: String,
        segmentation: String,
        labeller: String,
        start: usize,
        end: usize,
        state: usize,
    }
    let rows: Vec<Row> = results
        .iter()
        .flat_map(|r| {
            r.labels.iter().flat_map(move |l| {
                l.segments.iter().map(move |&(start, end, state)| Row {
                    sequence: r.sequence.clone(),
                    method: format!("{} + {}", l.segmentation, l.labeller),
                    segmentation: l.segmentation.clone(),
                    labeller: l.labeller.clone(),
                    start,
                    end,
                    state,
                })
            })
        })
        .collect();
    Table::from_records(
        "benchmark_segment_states",
        "Every segment each labeller labelled (samples start..end, end exclusive) and its state",
        &rows,
    )
}

/// A row of `benchmark_f1`.
#[derive(Serialize)]
struct F1Row {
    sequence: String,
    method: String,
    margin: String,
    margin_frames: Option<usize>,
    tcpd_f1: f64,
    tcpd_precision: f64,
    tcpd_recall: f64,
    chance_tcpd_f1: f64,
    p_value_tcpd_f1: f64,
    above_chance: &'static str,
    status: String,
    failure: String,
}

fn above(p: f64) -> &'static str {
    if p.is_nan() {
        ""
    } else if p < ALPHA {
        "yes"
    } else {
        "no"
    }
}

/// The label of a margin (`5 frames`, `0.5 s`).
fn margin_label(t: TimeSpan) -> String {
    match t {
        TimeSpan::Seconds(s) => format!("{} s", (s * 1e4).round() / 1e4),
        TimeSpan::Frames(n) => format!("{n} frames"),
    }
}

type ScoresOf<'a> = dyn Fn(&str) -> Vec<(&'a str, &'a MethodRun)> + 'a;

/// A per-sequence row's status: `ok`, or `failed` (its reason in `failure`).
fn status_of(m: &MethodRun) -> (String, String) {
    match m.failure() {
        None => ("ok".into(), String::new()),
        Some(reason) => ("failed".into(), reason.to_string()),
    }
}

/// A mean row's status: over how many sequences it is, and how failures are treated.
fn mean_status(runs: &[(&str, &MethodRun)]) -> (String, String) {
    let failed: Vec<&str> =
        runs.iter().filter(|(_, m)| m.failure().is_some()).map(|(s, _)| *s).collect();
    let status = format!(
        "mean over {} scored sequence(s); {} failed (left out of the mean, ranked last)",
        runs.len() - failed.len(),
        failed.len()
    );
    (status, failed.join(" "))
}

/// Drops the `status` and `failure` columns when no method failed (the tables of a run without
/// failures keep their columns).
fn keep_status_columns(t: &mut Table, results: &[ItemResult]) {
    if !results.iter().flat_map(|r| &r.methods).any(|m| m.failure().is_some()) {
        t.columns.retain(|c| c.name != "status" && c.name != "failure");
    }
}

impl BenchmarkWorkflow {
    /// Every labeller on every segmentation of `label_segments` for one sequence, scored per
    /// sample against the truth's states (the samples in a labelled truth segment).
    fn label_item(
        &self,
        sequence: &str,
        motion: &motionlab_core::Motion,
        truth: &motionlab_core::Segmentation,
        methods: &[MethodRun],
        file: &std::path::Path,
    ) -> Result<Vec<LabelRun>> {
        if self.labellers.is_empty() {
            return Ok(Vec::new());
        }
        let n = motion.n_frames();
        let what = format!("the ground truth of {sequence} ({})", file.display());
        let states = truth_states(&truth.segments, n, &what)
            .map_err(|e| e.with_location(motionlab_core::Location::file(file)))?;
        let kept: Vec<usize> = (0..n).filter(|&i| states[i].is_some()).collect();
        let true_states: Vec<&str> = kept.iter().filter_map(|&i| states[i].as_deref()).collect();
        let cache = FeatureCache::new();
        let mut out = Vec::new();
        for seg in &self.label_segments {
            let cuts: std::result::Result<Vec<usize>, String> = if seg == TRUTH_SEGMENTS {
                Ok(truth.frames())
            } else {
                match methods.iter().find(|m| &m.method == seg) {
                    Some(m) => match m.failure() {
                        None => Ok(m.found.clone()),
                        Some(reason) => Err(format!("segmentation {seg} failed: {reason}")),
                    },
                    None => Err(format!("no segmentation {seg}")),
                }
            };
            for l in &self.labellers {
                let segments = cuts.as_ref().map(|c| motionlab_core::segments_of(c, n));
                let start = Instant::now();
                let labelled = match &segments {
                    Err(reason) => Err(reason.to_string()),
                    Ok(segments) => l
                        .label(motion, segments, &cache)
                        .and_then(|s| Ok((s.per_sample(segments)?, s)))
                        .map_err(|e| e.message().to_string()),
                };
                let seconds = start.elapsed().as_secs_f64();
                let (found_segments, scores) = match labelled {
                    Err(reason) => (Vec::new(), Err(reason)),
                    Ok((per_sample, s)) => {
                        let found: Vec<usize> = kept.iter().map(|&i| per_sample[i]).collect();
                        let seed =
                            row_seed(self.chance.seed, sequence, &format!("{seg} {}", l.name));
                        let scores = label_scores(&true_states, &found, self.chance, seed)
                            .map_err(|e| e.message().to_string());
                        let segs = segments
                            .as_ref()
                            .map(|v| {
                                v.iter()
                                    .zip(&s.segment_states)
                                    .map(|(r, &st)| (r.start, r.end, st))
                                    .collect()
                            })
                            .unwrap_or_default();
                        (segs, scores)
                    }
                };
                out.push(LabelRun {
                    segmentation: seg.clone(),
                    labeller: l.name.clone(),
                    seconds,
                    segments: found_segments,
                    scores,
                });
            }
        }
        Ok(out)
    }

    /// `benchmark_states`: AMI, ARI and NMI per sample of each labeller on each segmentation,
    /// each beside its chance baseline, per sequence and as the mean over sequences.
    fn states_table(&self, results: &[ItemResult]) -> Result<Table> {
        let mut rows = Vec::new();
        let row = |sequence: String,
                   segmentation: &str,
                   labeller: &str,
                   n_samples: usize,
                   n_segments: Option<usize>,
                   n_states: Option<usize>,
                   scores: [Option<&ScoreWithChance>; 3],
                   status: String,
                   failure: String| {
            let v = |k: usize, f: fn(&ScoreWithChance) -> f64| scores[k].map_or(f64::NAN, f);
            StatesRow {
                sequence,
                segmentation: segmentation.to_string(),
                labeller: labeller.to_string(),
                method: format!("{segmentation} + {labeller}"),
                n_samples,
                n_segments,
                n_states,
                ami: v(0, |s| s.value),
                chance_ami: v(0, |s| s.chance),
                p_value_ami: v(0, |s| s.p_value),
                ari: v(1, |s| s.value),
                chance_ari: v(1, |s| s.chance),
                p_value_ari: v(1, |s| s.p_value),
                nmi: v(2, |s| s.value),
                chance_nmi: v(2, |s| s.chance),
                p_value_nmi: v(2, |s| s.p_value),
                above_chance_ami: above(v(0, |s| s.p_value)),
                status,
                failure,
            }
        };
        for r in results {
            for l in &r.labels {
                let (status, failure) = match &l.scores {
                    Ok(_) => ("ok".to_string(), String::new()),
                    Err(e) => ("failed".to_string(), e.clone()),
                };
                let s = l.scores.as_ref().ok();
                let n_states = s.map(|_| {
                    let mut st: Vec<usize> = l.segments.iter().map(|x| x.2).collect();
                    st.sort_unstable();
                    st.dedup();
                    st.len()
                });
                rows.push(row(
                    r.sequence.clone(),
                    &l.segmentation,
                    &l.labeller,
                    s.map_or(0, |s| s.n_samples),
                    s.map(|_| l.segments.len()),
                    n_states,
                    [s.map(|s| &s.ami), s.map(|s| &s.ari), s.map(|s| &s.nmi)],
                    status,
                    failure,
                ));
            }
        }
        for seg in &self.label_segments {
            for lab in &self.labellers {
                let runs: Vec<(&str, &LabelRun)> = results
                    .iter()
                    .flat_map(|r| {
                        r.labels
                            .iter()
                            .filter(|l| &l.segmentation == seg && l.labeller == lab.name)
                            .map(move |l| (r.sequence.as_str(), l))
                    })
                    .collect();
                let ok: Vec<&LabelScores> =
                    runs.iter().filter_map(|(_, l)| l.scores.as_ref().ok()).collect();
                let failed: Vec<&str> =
                    runs.iter().filter(|(_, l)| l.scores.is_err()).map(|(s, _)| *s).collect();
                let ami = ScoreWithChance::mean(ok.iter().map(|s| &s.ami));
                let ari = ScoreWithChance::mean(ok.iter().map(|s| &s.ari));
                let nmi = ScoreWithChance::mean(ok.iter().map(|s| &s.nmi));
                rows.push(row(
                    "mean".into(),
                    seg,
                    &lab.name,
                    ok.iter().map(|s| s.n_samples).sum(),
                    None,
                    None,
                    [Some(&ami), Some(&ari), Some(&nmi)],
                    format!("mean over {} scored sequence(s); {} failed", ok.len(), failed.len()),
                    failed.join(" "),
                ));
            }
        }
        let mut t = Table::from_records(
            "benchmark_states",
            "State labelling per sequence, segmentation and labeller: AMI, ARI and NMI per sample against the truth's segment labels, each beside chance (the found labels permuted across the found segments) and its p-value; then the mean over sequences",
            &rows,
        )?;
        if results.iter().flat_map(|r| &r.labels).all(|l| l.scores.is_ok()) {
            t.columns.retain(|c| c.name != "failure");
        }
        Ok(t)
    }

    /// The published covering of `method`'s published column on `sequence`.
    /// Every method's name: the segmenters', then the fuser's.
    fn method_names(&self) -> Vec<String> {
        self.segmenters
            .iter()
            .map(|s| s.name.clone())
            .chain(self.fuser.iter().map(|(n, _)| n.clone()))
            .collect()
    }

    fn published_of(&self, method: &str, sequence: &str) -> Option<(String, f64)> {
        let (scores, spec) = self.published.as_ref()?;
        let column = spec.methods.get(method)?;
        let j = scores.method_index(column)?;
        Some((column.clone(), scores.series(sequence).map_or(f64::NAN, |v| v[j])))
    }

    fn covering_table<'a>(
        &self,
        results: &'a [ItemResult],
        methods: &[String],
        scores_of: &ScoresOf<'a>,
    ) -> Result<Table> {
        let mut rows = Vec::new();
        for r in results {
            for m in &r.methods {
                let published = self.published_of(&m.method, &r.sequence);
                let (status, failure) = status_of(m);
                let covering = m.scored().map(|s| &s.covering);
                let value = covering.map_or(f64::NAN, |c| c.value);
                rows.push(CoveringRow {
                    sequence: r.sequence.clone(),
                    method: m.method.clone(),
                    n_samples: r.n_samples,
                    n_truth: r.n_truth,
                    n_found: m.scored().map(|s| s.n_found),
                    covering: value,
                    chance_covering: covering.map_or(f64::NAN, |c| c.chance),
                    p_value_covering: covering.map_or(f64::NAN, |c| c.p_value),
                    above_chance: above(covering.map_or(f64::NAN, |c| c.p_value)),
                    published_covering: published.as_ref().map(|p| p.1),
                    covering_minus_published: published.as_ref().map(|p| value - p.1),
                    published_method: published.map(|p| p.0),
                    status,
                    failure,
                });
            }
        }
        for method in methods {
            let all_runs = scores_of(method);
            let (status, failure) = mean_status(&all_runs);
            let runs: Vec<(&str, &MethodRun)> =
                all_runs.iter().copied().filter(|(_, m)| m.scored().is_some()).collect();
            let mean =
                ScoreWithChance::mean(runs.iter().filter_map(|(_, m)| Some(&m.scored()?.covering)));
            // Over the sequences the sheet lists (all of them unless `missing = "skip"`).
            let listed: Vec<&(&str, &MethodRun)> = runs
                .iter()
                .filter(|(seq, _)| !self.published_missing.iter().any(|m| m == seq))
                .collect();
            let published: Option<(String, Vec<f64>)> = listed
                .iter()
                .map(|(seq, _)| self.published_of(method, seq))
                .collect::<Option<Vec<_>>>()
                .and_then(|v| {
                    let mut column = v.first()?.0.clone();
                    if listed.len() < runs.len() {
                        column = format!(
                            "{column} (over {} of {} sequences; missing = skip)",
                            listed.len(),
                            runs.len()
                        );
                    }
                    Some((column, v.into_iter().map(|p| p.1).collect()))
                });
            let published_mean =
                published.as_ref().map(|(_, v)| v.iter().sum::<f64>() / v.len() as f64);
            rows.push(CoveringRow {
                sequence: "mean".into(),
                method: method.clone(),
                n_samples: runs.iter().filter_map(|(_, m)| m.scored()).map(|s| s.n_frames).sum(),
                n_truth: runs
                    .iter()
                    .filter_map(|(seq, _)| results.iter().find(|r| r.sequence == *seq))
                    .map(|r| r.n_truth)
                    .sum(),
                n_found: Some(runs.iter().filter_map(|(_, m)| m.scored()).map(|s| s.n_found).sum()),
                covering: mean.value,
                chance_covering: mean.chance,
                p_value_covering: mean.p_value,
                above_chance: above(mean.p_value),
                covering_minus_published: published_mean.map(|p| mean.value - p),
                published_covering: published_mean,
                published_method: published.map(|p| p.0),
                status,
                failure,
            });
        }
        let mut t = Table::from_records(
            "benchmark_covering",
            "Segment covering per sequence and method, beside chance (and the published score), then the mean over sequences",
            &rows,
        )?;
        if self.published.is_none() {
            t.columns
                .retain(|c| !c.name.starts_with("published") && !c.name.ends_with("published"));
        }
        keep_status_columns(&mut t, results);
        Ok(t)
    }

    fn f1_table<'a>(
        &self,
        results: &'a [ItemResult],
        methods: &[String],
        scores_of: &ScoresOf<'a>,
    ) -> Result<Table> {
        let mut rows = Vec::new();
        for r in results {
            for m in &r.methods {
                let (status, failure) = status_of(m);
                match m.scored() {
                    Some(scores) => {
                        for (f, &margin) in scores.f1.iter().zip(&self.section.margins) {
                            rows.push(F1Row {
                                sequence: r.sequence.clone(),
                                method: m.method.clone(),
                                margin: margin_label(margin),
                                margin_frames: Some(f.margin_frames),
                                tcpd_f1: f.f1.value,
                                tcpd_precision: f.precision,
                                tcpd_recall: f.recall,
                                chance_tcpd_f1: f.f1.chance,
                                p_value_tcpd_f1: f.f1.p_value,
                                above_chance: above(f.f1.p_value),
                                status: status.clone(),
                                failure: failure.clone(),
                            });
                        }
                    }
                    None => {
                        for &margin in &self.section.margins {
                            rows.push(F1Row {
                                sequence: r.sequence.clone(),
                                method: m.method.clone(),
                                margin: margin_label(margin),
                                margin_frames: None,
                                tcpd_f1: f64::NAN,
                                tcpd_precision: f64::NAN,
                                tcpd_recall: f64::NAN,
                                chance_tcpd_f1: f64::NAN,
                                p_value_tcpd_f1: f64::NAN,
                                above_chance: "",
                                status: status.clone(),
                                failure: failure.clone(),
                            });
                        }
                    }
                }
            }
        }
        for method in methods {
            let runs = scores_of(method);
            let (status, failure) = mean_status(&runs);
            for (i, &margin) in self.section.margins.iter().enumerate() {
                let parts: Vec<_> =
                    runs.iter().filter_map(|(_, m)| m.scored()?.f1.get(i)).collect();
                let mean = ScoreWithChance::mean(parts.iter().map(|f| &f.f1));
                let n = parts.len() as f64;
                rows.push(F1Row {
                    sequence: "mean".into(),
                    method: method.clone(),
                    margin: margin_label(margin),
                    margin_frames: None,
                    tcpd_f1: mean.value,
                    tcpd_precision: parts.iter().map(|f| f.precision).sum::<f64>() / n,
                    tcpd_recall: parts.iter().map(|f| f.recall).sum::<f64>() / n,
                    chance_tcpd_f1: mean.chance,
                    p_value_tcpd_f1: mean.p_value,
                    above_chance: above(mean.p_value),
                    status: status.clone(),
                    failure: failure.clone(),
                });
            }
        }
        let mut t = Table::from_records(
            "benchmark_f1",
            "TCPDBench F1 per sequence, method and margin, beside chance, then the mean over sequences",
            &rows,
        )?;
        keep_status_columns(&mut t, results);
        Ok(t)
    }

    /// Mean ranks by covering (ours and the published methods), the tests, and the diagram.
    fn rank_tables(
        &self,
        results: &[ItemResult],
        methods: &[String],
    ) -> Result<(Table, Table, Option<Figure>)> {
        let published = self.published.as_ref().map(|(s, _)| s);
        let mut labels: Vec<(String, &'static str)> =
            methods.iter().map(|m| (m.clone(), "ours")).collect();
        if let Some(p) = published {
            labels.extend(p.methods.iter().map(|m| (format!("{m} (published)"), "published")));
        }
        // Sequences every method ran on (and the published sheet lists, when given); a method
        // that failed on a sequence ranks last there (-inf: below every covering, tied with
        // the other failures).
        let mut scores: Vec<Vec<f64>> = Vec::new();
        for r in results {
            let ours: Option<Vec<f64>> = methods
                .iter()
                .map(|m| {
                    let x = r.methods.iter().find(|x| x.method == *m)?;
                    Some(x.scored().map_or(f64::NEG_INFINITY, |s| s.covering.value))
                })
                .collect();
            let theirs: Option<Vec<f64>> = match published {
                None => Some(Vec::new()),
                Some(p) => p.series(&r.sequence).map(<[f64]>::to_vec),
            };
            if let (Some(mut row), Some(theirs)) = (ours, theirs) {
                row.extend(theirs);
                scores.push(row);
            }
        }
        #[derive(Serialize)]
        struct RankRow {
            method: String,
            source: &'static str,
            mean_rank: f64,
            wins: usize,
            n_series: usize,
            mean_covering: f64,
            n_failed: usize,
        }
        #[derive(Serialize)]
        struct TestRow {
            n_methods: usize,
            n_series: usize,
            ties: &'static str,
            friedman_chi2: f64,
            friedman_p_value: f64,
            alpha: f64,
            nemenyi_q_alpha: f64,
            critical_difference: f64,
            cliques: String,
            published_missing: String,
        }
        let c: RankComparison =
            compare_methods(&scores, true, self.section.ties, self.section.alpha);
        let n = scores.len();
        let rows: Vec<RankRow> = labels
            .iter()
            .enumerate()
            .map(|(j, (label, source))| RankRow {
                method: label.clone(),
                source,
                mean_rank: c.mean_ranks.get(j).copied().unwrap_or(f64::NAN),
                wins: c.wins.get(j).copied().unwrap_or(0),
                n_series: n,
                // Over the sequences it scored (a failure has no covering).
                mean_covering: {
                    let ok: Vec<f64> =
                        scores.iter().map(|row| row[j]).filter(|v| v.is_finite()).collect();
                    ok.iter().sum::<f64>() / ok.len() as f64
                },
                n_failed: scores.iter().filter(|row| row[j] == f64::NEG_INFINITY).count(),
            })
            .collect();
        let cliques = c
            .cliques
            .iter()
            .map(|g| g.iter().map(|&i| labels[i].0.clone()).collect::<Vec<_>>().join(" = "))
            .collect::<Vec<_>>()
            .join("; ");
        let ties = match self.section.ties {
            Ties::Average => "average",
            Ties::Min => "min",
        };
        let test = TestRow {
            n_methods: labels.len(),
            n_series: n,
            ties,
            friedman_chi2: c.friedman_chi2,
            friedman_p_value: c.friedman_p_value,
            alpha: c.alpha,
            nemenyi_q_alpha: c.q_alpha,
            critical_difference: c.critical_difference,
            cliques,
            published_missing: match (self.published_missing.first(), &self.published) {
                (Some(first), Some((_, spec))) => format!(
                    "{} sequence(s) not in {} left out of the ranks (missing = skip; the first: {first})",
                    self.published_missing.len(),
                    spec.file
                ),
                _ => String::new(),
            },
        };
        let mut ranks = Table::from_records(
            "benchmark_ranks",
            "Mean rank by covering per method (1 = best) over the sequences every method ran on (a failure ranks last on its sequence; mean_covering is over the sequences scored)",
            &rows,
        )?;
        if rows.iter().all(|r| r.n_failed == 0) {
            ranks.columns.retain(|c| c.name != "n_failed");
        }
        let mut test = Table::from_records(
            "benchmark_rank_test",
            "Friedman's test and Nemenyi's critical difference of the mean ranks",
            &[test],
        )?;
        if self.published_missing.is_empty() {
            test.columns.retain(|c| c.name != "published_missing");
        }
        let figure = (labels.len() >= 2 && n > 0).then(|| Figure {
            name: "critical_difference".into(),
            figure: FigureKind::CriticalDifference(CriticalDifference {
                title: format!("Mean rank by covering over {n} sequences (1 = best)"),
                methods: labels.iter().zip(&c.mean_ranks).map(|((l, s), &r)| RankedMethod { label: l.clone(), mean_rank: r, secondary: *s == "published" }).collect(),
                critical_difference: c.critical_difference,
                cliques: c.cliques.clone(),
                caption: format!(
                    "Nemenyi critical difference at α = {} (q = {:.3}); thick lines join methods whose mean ranks differ by less; Friedman p = {:.2e}; ties ranked by {ties}",
                    c.alpha, c.q_alpha, c.friedman_p_value
                ),
            }),
        });
        Ok((ranks, test, figure))
    }
}

/// `benchmark_runtime`: wall seconds per sequence and method, and per sample; then each
/// method's total.
fn runtime_table(results: &[ItemResult], methods: &[String]) -> Result<Table> {
    #[derive(Serialize)]
    struct Row {
        sequence: String,
        method: String,
        n_samples: usize,
        seconds: f64,
        microseconds_per_sample: f64,
    }
    let mut rows = Vec::new();
    for r in results {
        for m in &r.methods {
            let n = r.n_samples;
            rows.push(Row {
                sequence: r.sequence.clone(),
                method: m.method.clone(),
                n_samples: n,
                seconds: m.seconds,
                microseconds_per_sample: m.seconds * 1e6 / n.max(1) as f64,
            });
        }
    }
    for method in methods {
        let runs: Vec<&MethodRun> = results
            .iter()
            .flat_map(|r| &r.methods)
            .filter(|m| m.method == *method && m.scored().is_some())
            .collect();
        let n: usize = runs.iter().filter_map(|m| m.scored()).map(|s| s.n_frames).sum();
        let seconds: f64 = runs.iter().map(|m| m.seconds).sum();
        rows.push(Row {
            sequence: "total".into(),
            method: method.clone(),
            n_samples: n,
            seconds,
            microseconds_per_sample: seconds * 1e6 / n.max(1) as f64,
        });
    }
    Table::from_records(
        "benchmark_runtime",
        "Wall time of each segmenter per sequence (feature extraction included), as measured where it was computed",
        &rows,
    )
}

/// `benchmark_change_points`: every change point each method found, one row per point
/// (`sequence, method, sample`, samples 0-based as the segmenters give them), so a run can be
/// re-scored with another metric or fed to a later stage. A method that found none, or failed,
/// has no row: `benchmark_covering` lists every sequence and method with its `n_found`.
fn change_points_table(results: &[ItemResult]) -> Result<Table> {
    #[derive(Serialize)]
    struct Row<'a> {
        sequence: &'a str,
        method: &'a str,
        sample: usize,
    }
    let rows: Vec<Row<'_>> = results
        .iter()
        .flat_map(|r| {
            r.methods.iter().flat_map(move |m| {
                m.found.iter().map(move |&sample| Row {
                    sequence: &r.sequence,
                    method: &m.method,
                    sample,
                })
            })
        })
        .collect();
    Table::from_records(
        "benchmark_change_points",
        "Every change point each method found (samples, 0-based), one row per point",
        &rows,
    )
}

/// For each true change (in order), the delay `decided_at − change` (samples) of the change
/// point that detects it: among the unused points within `margin` samples of it, the one
/// decided first (the nearest among equals). Undetected changes are left out.
fn detection_delays(
    truth: &[usize],
    found: &[usize],
    decided_at: &[usize],
    margin: usize,
) -> Vec<i64> {
    let mut used = vec![false; found.len()];
    let mut out = Vec::new();
    for &t in truth {
        let best = (0..found.len())
            .filter(|&j| !used[j] && found[j].abs_diff(t) <= margin)
            .min_by_key(|&j| (decided_at[j], found[j].abs_diff(t)));
        if let Some(j) = best {
            used[j] = true;
            out.push(decided_at[j] as i64 - t as i64);
        }
    }
    out
}

/// The `q` quantile (0–1) of `v` by linear interpolation between order statistics (numpy's
/// default); NaN when `v` is empty.
fn quantile(v: &[i64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut s = v.to_vec();
    s.sort_unstable();
    let pos = q * (s.len() - 1) as f64;
    let (lo, hi) = (pos.floor() as usize, pos.ceil() as usize);
    s[lo] as f64 + (pos - lo as f64) * (s[hi] - s[lo]) as f64
}

/// `benchmark_detection_delay`: each streaming method's detection delays and throughput, per
/// sequence and in total (see [`BenchmarkSection`]).
fn detection_delay_table(
    results: &[ItemResult],
    methods: &[String],
    margin: TimeSpan,
) -> Result<Table> {
    #[derive(Serialize)]
    struct Row {
        sequence: String,
        method: String,
        n_true: usize,
        n_detected: usize,
        delay_median_samples: f64,
        delay_p90_samples: f64,
        delay_median_s: f64,
        delay_p90_s: f64,
    }
    let mut rows = Vec::new();
    for method in methods {
        let (mut all, mut all_s) = (Vec::new(), Vec::new());
        let mut n_true = 0;
        let mut streamed = false;
        for r in results {
            let Some(m) = r.methods.iter().find(|m| &m.method == method) else { continue };
            let Some(decided) = &m.decided_at else { continue };
            streamed = true;
            let rate = motionlab_core::FrameRate::new(r.rate_hz)
                .map_err(|e| e.under_field("benchmark_detection_delay"))?;
            let margin_samples = tolerance_frames(margin, rate).floor() as usize;
            let delays = detection_delays(&r.truth, &m.found, decided, margin_samples);
            let hz = r.rate_hz;
            rows.push(Row {
                sequence: r.sequence.clone(),
                method: method.clone(),
                n_true: r.truth.len(),
                n_detected: delays.len(),
                delay_median_samples: quantile(&delays, 0.5),
                delay_p90_samples: quantile(&delays, 0.9),
                delay_median_s: quantile(&delays, 0.5) / hz,
                delay_p90_s: quantile(&delays, 0.9) / hz,
            });
            n_true += r.truth.len();
            all_s.extend(delays.iter().map(|&d| (d as f64 / hz * 1e6).round() as i64));
            all.extend(delays);
        }
        if streamed {
            rows.push(Row {
                sequence: "total".into(),
                method: method.clone(),
                n_true,
                n_detected: all.len(),
                delay_median_samples: quantile(&all, 0.5),
                delay_p90_samples: quantile(&all, 0.9),
                // Pooled over sequences of any rate: the quantiles of the delays in seconds
                // (kept in whole microseconds to sort exactly).
                delay_median_s: quantile(&all_s, 0.5) / 1e6,
                delay_p90_s: quantile(&all_s, 0.9) / 1e6,
            });
        }
    }
    Table::from_records(
        "benchmark_detection_delay",
        "Streaming segmenters: true changes detected within the first margin, and how many samples and seconds after each change they were decided (median, 90th percentile)",
        &rows,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn detection_delays_take_the_first_decided_point_within_the_margin() {
        // Changes at 100 and 200; points at 95 (decided at 130), 104 (decided at 106), 260.
        let d = detection_delays(&[100, 200], &[95, 104, 260], &[130, 106, 262], 10);
        assert_eq!(d, vec![6]);
        // Each point detects one change: 104 cannot serve both 100 and 108.
        let d = detection_delays(&[100, 108], &[104], &[107], 10);
        assert_eq!(d, vec![7]);
        // Decided before the change: a negative delay.
        assert_eq!(detection_delays(&[50], &[45], &[47], 10), vec![-3]);
        assert_eq!(quantile(&[1, 2, 3, 4], 0.5), 2.5);
        assert_eq!(quantile(&[0, 10], 0.9), 9.0);
        assert!(quantile(&[], 0.5).is_nan());
    }
}
