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
use motionlab_eval::ranks::{RankComparison, Ties, compare_methods};
use motionlab_eval::series_scores::{ScoreWithChance, SeriesScores, score_series};
use motionlab_figure::{CriticalDifference, Figure, FigureKind, RankedMethod};
use motionlab_io::scores_csv::{PublishedScores, read_scores_csv};

use crate::parameter_choice::{MethodChoices, StageChoice};
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
    choices: MethodChoices,
}

/// What one sequence produced.
#[derive(Serialize, Deserialize)]
struct ItemResult {
    sequence: String,
    n_truth: usize,
    methods: Vec<MethodRun>,
}

#[derive(Serialize, Deserialize)]
struct MethodRun {
    method: String,
    seconds: f64,
    scores: SeriesScores,
}

/// A segmenter's candidates and the wall time that computed them (cached together).
#[derive(Serialize, Deserialize)]
struct TimedCandidates {
    candidates: Vec<usize>,
    seconds: f64,
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
        Ok(BenchmarkWorkflow {
            section,
            segmenters,
            fuser,
            fuse,
            chance,
            published,
            choices: MethodChoices { methods },
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
        let mut runs: Vec<(String, TimedCandidates)> = Vec::new();
        for s in &self.segmenters {
            let name = &s.name;
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
                    let out = s
                        .segment(motion, &cache)
                        .map_err(|e| e.in_file(&file).under_field(format!("segmenter {name}")))?;
                    Ok(TimedCandidates {
                        candidates: out.candidates,
                        seconds: start.elapsed().as_secs_f64(),
                    })
                },
            )?;
            runs.push((name.clone(), timed));
        }
        if let Some((name, fuser)) = &self.fuser {
            let inputs: Vec<MethodCandidates<'_>> = self
                .fuse
                .iter()
                .map(|&i| MethodCandidates { method: &runs[i].0, frames: &runs[i].1.candidates })
                .collect();
            let start = Instant::now();
            let fused = fuser
                .fuse(motion, &inputs)
                .map_err(|e| e.in_file(&file).under_field(format!("fuser {name}")))?;
            let seconds = start.elapsed().as_secs_f64()
                + self.fuse.iter().map(|&i| runs[i].1.seconds).sum::<f64>();
            data.record(
                item.dataset,
                item.file,
                &format!("fuser {name}"),
                motionlab_experiment::Origin::Computed,
            );
            runs.push((name.clone(), TimedCandidates { candidates: fused, seconds }));
        }
        let methods = runs
            .into_iter()
            .map(|(method, t)| {
                let seed = row_seed(self.chance.seed, &loaded.name, &method);
                let scores =
                    score_series(&annotators, &t.candidates, n_frames, &margins, self.chance, seed);
                MethodRun { method, seconds: t.seconds, scores }
            })
            .collect();
        let result =
            ItemResult { sequence: loaded.name.clone(), n_truth: truth.boundaries.len(), methods };
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
        out.figures.extend(figure);
        if self.section.selection == BenchmarkSelection::LeaveOneSequenceOut {
            let scores = results
                .iter()
                .flat_map(|r| {
                    r.methods
                        .iter()
                        .map(|m| (r.sequence.clone(), m.method.clone(), m.scores.covering.clone()))
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

impl BenchmarkWorkflow {
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
                let s = &m.scores;
                let published = self.published_of(&m.method, &r.sequence);
                rows.push(CoveringRow {
                    sequence: r.sequence.clone(),
                    method: m.method.clone(),
                    n_samples: s.n_frames,
                    n_truth: r.n_truth,
                    n_found: Some(s.n_found),
                    covering: s.covering.value,
                    chance_covering: s.covering.chance,
                    p_value_covering: s.covering.p_value,
                    above_chance: above(s.covering.p_value),
                    published_covering: published.as_ref().map(|p| p.1),
                    covering_minus_published: published.as_ref().map(|p| s.covering.value - p.1),
                    published_method: published.map(|p| p.0),
                });
            }
        }
        for method in methods {
            let runs = scores_of(method);
            let mean = ScoreWithChance::mean(runs.iter().map(|(_, m)| &m.scores.covering));
            let published: Option<(String, Vec<f64>)> = runs
                .iter()
                .map(|(seq, _)| self.published_of(method, seq))
                .collect::<Option<Vec<_>>>()
                .and_then(|v| {
                    let column = v.first()?.0.clone();
                    Some((column, v.into_iter().map(|p| p.1).collect()))
                });
            let published_mean =
                published.as_ref().map(|(_, v)| v.iter().sum::<f64>() / v.len() as f64);
            rows.push(CoveringRow {
                sequence: "mean".into(),
                method: method.clone(),
                n_samples: runs.iter().map(|(_, m)| m.scores.n_frames).sum(),
                n_truth: runs
                    .iter()
                    .filter_map(|(seq, _)| results.iter().find(|r| r.sequence == *seq))
                    .map(|r| r.n_truth)
                    .sum(),
                n_found: Some(runs.iter().map(|(_, m)| m.scores.n_found).sum()),
                covering: mean.value,
                chance_covering: mean.chance,
                p_value_covering: mean.p_value,
                above_chance: above(mean.p_value),
                covering_minus_published: published_mean.map(|p| mean.value - p),
                published_covering: published_mean,
                published_method: published.map(|p| p.0),
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
                for (f, &margin) in m.scores.f1.iter().zip(&self.section.margins) {
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
                    });
                }
            }
        }
        for method in methods {
            let runs = scores_of(method);
            for (i, &margin) in self.section.margins.iter().enumerate() {
                let parts: Vec<_> = runs.iter().filter_map(|(_, m)| m.scores.f1.get(i)).collect();
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
                });
            }
        }
        Table::from_records(
            "benchmark_f1",
            "TCPDBench F1 per sequence, method and margin, beside chance, then the mean over sequences",
            &rows,
        )
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
        // Sequences every method scored (and the published sheet lists, when given).
        let mut scores: Vec<Vec<f64>> = Vec::new();
        for r in results {
            let ours: Option<Vec<f64>> = methods
                .iter()
                .map(|m| r.methods.iter().find(|x| x.method == *m).map(|x| x.scores.covering.value))
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
                mean_covering: scores.iter().map(|row| row[j]).sum::<f64>() / n as f64,
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
        };
        let ranks = Table::from_records(
            "benchmark_ranks",
            "Mean rank by covering per method (1 = best) over the sequences every method scored",
            &rows,
        )?;
        let test = Table::from_records(
            "benchmark_rank_test",
            "Friedman's test and Nemenyi's critical difference of the mean ranks",
            &[test],
        )?;
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
            let n = m.scores.n_frames;
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
        let runs: Vec<&MethodRun> =
            results.iter().flat_map(|r| &r.methods).filter(|m| m.method == *method).collect();
        let n: usize = runs.iter().map(|m| m.scores.n_frames).sum();
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
