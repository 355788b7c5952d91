//! The `[segmentation]` workflow (Sonoda et al.): segmenters → fuser → evaluators, with the
//! paper's figures per sequence and, for sweeps, precision–recall curves and best operating
//! points.

use std::sync::Arc;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry;
use motionlab_core::viewer::{
    AnnotationSpec, EventKind, EventLane, Lane, MarkStatus, TraceLane, ViewerMotion, ViewerSpec,
};
use motionlab_core::{
    Error, ErrorKind, EvalInput, EvalInputType, Evaluation, Evaluator, FeatureCache, Fuser,
    MethodCandidates, MethodResult, PathPoint, Result, Segment, Segmentation, SegmenterOutput,
    SequenceResult, Table, Threshold, Trace,
};
use motionlab_eval::boundaries::default_tolerance;
use motionlab_eval::boundary_analysis::{BoundaryAnalysis, MatchOutcome, SequenceBoundaries};
use motionlab_figure::{BarRow, Chart, Figure, FigureKind, Series, TimelinePoses};
use motionlab_io::labels::tiers::{MarkTier, RunBoundaries, SequenceTiers, TierMark};

use crate::drawing::{
    axis_name, bones_for, frames_to_seconds, main_floor_axis, stick_row, stick_row_at, stick_strip,
    time_axis, traces_charts,
};
use crate::heldout::{Selection, heldout_tables};
use crate::parameter_choice::{MethodChoices, StageChoice};
use motionlab_experiment::segmenters::{NamedSegmenter, build_segmenters};
use motionlab_experiment::spec::StageSpec;
use motionlab_experiment::toml_paths::KeyPath;
use motionlab_experiment::workflow::{
    BuildContext, ComboOutput, ItemData, ItemOutput, Output, WorkItem, Workflow, WorkflowPlugin,
    build_evaluators, sanitize,
};
use motionlab_experiment::{Datasets, Locator, build_stage};

/// Segmenters → an optional fuser → evaluators, per sequence (Sonoda et al.): every method's
/// candidate frames (`candidates`), the evaluators' tables (`[[evaluate]]`, segmentation
/// domain), figures per sequence (each method's traces with thresholds and candidate bars and
/// a close-up, the root path with candidates, the timeline with ground truth, a stick-figure
/// strip of one segment) and, across a sweep, precision–recall curves with each method's
/// best-F1 operating point (`best_f1`) — an oracle, chosen on the sequences it is reported
/// on — and, with `selection`, operating points chosen on other sequences (`heldout_f1`,
/// `heldout_choices`).
///
/// A segmenter that chose its candidates on a penalty path (`kernel_cpd` with `penalty = {
/// path }`, or unset at its pelt/kernel_pelt defaults) adds the table `penalty_path` — every
/// segmentation of the path per sequence, with its penalty interval, cost, number of change
/// points and the chosen one flagged — and a figure per sequence, `…_penalty_path`, its cost
/// against its number of change points with the chosen point marked.
///
/// Missing samples: as each segmenter treats them; figures leave gaps where a trace is NaN.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SegmentationSection {
    /// The segmenters (`[[segmentation.segmenter]]`, `{ type = "<segmenter>", … }`); names
    /// (`name = "…"`, else the type) must be unique. At least one is required.
    #[serde(rename = "segmenter")]
    pub segmenters: Vec<StageSpec>,
    /// The fuser combining the segmenters' candidates.
    #[serde(default)]
    pub fuser: Option<StageSpec>,
    /// Names of the segmenters whose candidates the fuser combines.
    #[serde(default)]
    #[schemars(extend("x-default" = "all of them"))]
    pub fuse: Option<Vec<String>>,
    /// Marker pairs joined in stick figures (`[["Head_FL", "Head_FR"], …]`).
    #[serde(default)]
    #[schemars(extend("x-default" = "the skeleton's bones, when the source has one"))]
    pub bones: Vec<[String; 2]>,
    /// The root point (after preprocessing) for the floor-path figure and the stick figures.
    #[serde(default = "default_root")]
    pub root: String,
    /// Which figures to draw per sequence: any of `traces`, `root_path`, `timeline`,
    /// `timeline_poses` (the timeline with the pose at each fused boundary underneath) and
    /// `stick_strip`.
    #[serde(default = "default_seg_figures")]
    pub figures: Vec<SegmentationFigure>,
    /// How a sweep chooses each method's operating point (used only across a `[[sweep]]`):
    /// `"oracle"` (only `best_f1`, chosen on the evaluation data itself),
    /// `"leave_one_sequence_out"` (also `heldout_f1` and `heldout_choices`: for each sequence,
    /// each grid's focus method takes the combination with the best pooled F1 on the other
    /// sequences — the last in grid order on ties, as `best_f1` — and its counts on that sequence are pooled
    /// over all sequences) or `{ train = ["86_01", …] }` (choose on these sequences, report on
    /// the others).
    #[serde(default)]
    pub selection: Selection,
}

fn default_root() -> String {
    "root".into()
}

/// A figure `[segmentation]` draws per sequence (`figures = ["traces", …]`); a name that is
/// none of these is an error when the experiment is validated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum SegmentationFigure {
    /// Each method's traces with its thresholds and candidate bars, and a close-up around one
    /// candidate (the paper's Fig. 3).
    Traces,
    /// The root's path on the floor with the fused candidates' frame numbers.
    RootPath,
    /// Every method's candidates and the ground truth on one time axis.
    Timeline,
    /// The timeline with the pose at each fused boundary underneath.
    TimelinePoses,
    /// Poses along one segment between two fused candidates, as a strip of stick figures.
    StickStrip,
}

fn default_seg_figures() -> Vec<SegmentationFigure> {
    use SegmentationFigure::*;
    vec![Traces, RootPath, Timeline, TimelinePoses, StickStrip]
}

pub struct SegmentationWorkflow {
    section: SegmentationSection,
    /// Each with its cache key: its type, parameters and input as resolved in this
    /// combination, under the input's key in the on-disk cache.
    segmenters: Vec<NamedSegmenter>,
    fuser: Option<(String, Box<dyn Fuser>)>,
    /// Indices into `segmenters` that the fuser combines.
    fuse: Vec<usize>,
    evaluators: Vec<(String, Box<dyn Evaluator>)>,
    /// Each evaluator's type and parameters as resolved (its key in the on-disk cache).
    evaluator_params: Vec<String>,
    experiment: String,
    /// How each method's parameters were chosen: the evaluation tables' `parameters_chosen`.
    choices: MethodChoices,
    /// The base combination of a sweep (the only one without a sweep): it alone writes the
    /// boundaries `motionlab export` reads, as it alone draws the viewer pages.
    base_combination: bool,
    /// Locates the held-out selection's errors, which only a sweep's summary can find.
    locator: Locator,
}

#[derive(Serialize, Deserialize)]
struct ItemResult {
    sequence: String,
    frame_rate_hz: f64,
    n_frames: usize,
    /// Each segmenter, then the fuser.
    methods: Vec<MethodRecord>,
    /// Each segmenter's traces and thresholds, for the viewer pages (base combination only).
    #[serde(default)]
    traces: Vec<(String, Vec<Trace>, Vec<Threshold>)>,
    /// Each segmenter that chose on a penalty path: that path (the table `penalty_path`).
    #[serde(default)]
    paths: Vec<(String, Vec<PathPoint>)>,
}

/// A row of `penalty_path`: one segmentation of one method's path on one sequence.
#[derive(Serialize)]
struct PathRow {
    sequence: String,
    method: String,
    n_changes: usize,
    pen_min: f64,
    pen_max: f64,
    cost: f64,
    chosen: bool,
    /// Space-separated frames (first frames of every segment but the first).
    change_points: String,
}

/// The figure of a penalty path: its cost against its number of change points, the chosen
/// segmentation marked.
fn penalty_path_chart(sequence: &str, method: &str, path: &[PathPoint]) -> Chart {
    let mut sorted: Vec<&PathPoint> = path.iter().collect();
    sorted.sort_by_key(|p| p.change_points.len());
    let xy = |ps: &[&PathPoint]| -> (Vec<f64>, Vec<f64>) {
        (
            ps.iter().map(|p| p.change_points.len() as f64).collect(),
            ps.iter().map(|p| p.cost).collect(),
        )
    };
    let (x, y) = xy(&sorted);
    let chosen: Vec<&PathPoint> = sorted.iter().copied().filter(|p| p.chosen).collect();
    let (cx, cy) = xy(&chosen);
    Chart {
        title: format!("{sequence} — {method}: the penalty path (cost against change points)"),
        x_label: "number of change points".into(),
        y_label: "cost (unpenalised)".into(),
        lines: vec![Series::new("segmentations on the path", x, y)],
        points: vec![Series {
            label: "chosen".into(),
            point_labels: chosen
                .iter()
                .map(|p| format!("chosen: {}", p.change_points.len()))
                .collect(),
            x: cx,
            y: cy,
        }],
        ..Default::default()
    }
}

#[derive(Serialize, Deserialize)]
struct MethodRecord {
    method: String,
    candidates: Vec<usize>,
    flagged_frames: usize,
}

#[derive(Serialize)]
struct CandidateRow {
    sequence: String,
    method: String,
    frame: usize,
    time_s: f64,
}

impl WorkflowPlugin for SegmentationWorkflow {
    type Section = SegmentationSection;
    fn build(section: SegmentationSection, cx: &BuildContext<'_>) -> Result<Self> {
        let (source, combo, root) = (cx.source, cx.combo, cx.root.clone());
        let segmenters = build_segmenters(cx, &section.segmenters, &root.key("segmenter"))?;
        if segmenters.is_empty() {
            return Err(cx.locate(
                Error::new(
                    ErrorKind::MissingKey,
                    "at least one [[segmentation.segmenter]] is required",
                ),
                root.clone(),
            ));
        }
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
                                    "fuse names {n:?}, which is not a segmenter of this experiment"
                                ),
                            ),
                            root.key("fuse"),
                        )
                    })
                })
                .collect::<Result<Vec<_>>>()?,
        };
        let fuser = match &section.fuser {
            Some(f) => Some((
                f.display_name(),
                build_stage(source, combo, f, &root.key("fuser"), registry::build_fuser)?,
            )),
            None => None,
        };
        let evaluators = build_evaluators(source, combo, EvalInputType::segmentation())?;
        let evaluator_params = combo
            .file
            .evaluators
            .iter()
            .map(|s| format!("{} {}", s.kind, s.plugin_params()))
            .collect();
        let experiment = combo.file.experiment.name.clone();
        // How each method's parameters were chosen in this combination (`parameters_chosen`).
        let swept: Vec<String> = combo
            .params
            .iter()
            .map(|(k, _)| KeyPath::parse(k).map_or_else(|_| k.clone(), |p| p.to_string()))
            .collect();
        let stage_choices: Vec<StageChoice> = section
            .segmenters
            .iter()
            .enumerate()
            .map(|(k, s)| {
                let places = [
                    format!("{}[{}]", root.key("segmenter"), s.display_name()),
                    root.key("segmenter").index(k).to_string(),
                ];
                StageChoice::of(s, &places, &swept)
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
        let choices = MethodChoices { methods };
        let base_combination = combo.index == 0;
        let locator = cx.locator();
        Ok(SegmentationWorkflow {
            section,
            segmenters,
            fuser,
            fuse,
            evaluators,
            evaluator_params,
            experiment,
            choices,
            base_combination,
            locator,
        })
    }
}

motionlab_experiment::register_workflow!(SegmentationWorkflow, "segmentation");

impl SegmentationWorkflow {
    fn method_names(&self) -> Vec<String> {
        self.segmenters
            .iter()
            .map(|s| s.name.clone())
            .chain(self.fuser.iter().map(|(n, _)| n.clone()))
            .collect()
    }
}

impl Workflow for SegmentationWorkflow {
    fn run_item(&self, item: &WorkItem, data: &Datasets, draw: bool) -> Result<ItemOutput> {
        let loaded = data.load(item.dataset, item.file)?;
        let motion = &loaded.motion;
        let file = motion.source.clone().unwrap_or_default();
        let cache = FeatureCache::new();
        let mut outputs: Vec<(String, SegmenterOutput)> = Vec::new();
        for s in &self.segmenters {
            let name = &s.name;
            // The output depends on the input and the segmenter's parameters (and features)
            // only: cached on disk under both (the features it computes on the way are not kept).
            let out = data.stage_cached(
                &loaded,
                (item.dataset, item.file),
                &format!("segmenter {name}"),
                "segmenter",
                &s.cache_key,
                || {
                    s.segment(motion, &cache)
                        .map_err(|e| e.in_file(&file).under_field(format!("segmenter {name}")))
                },
            )?;
            outputs.push((name.clone(), out));
        }
        let mut methods: Vec<MethodRecord> = outputs
            .iter()
            .map(|(n, o)| MethodRecord {
                method: n.clone(),
                candidates: o.candidates.clone(),
                flagged_frames: o.flagged_frames.len(),
            })
            .collect();
        if let Some((name, fuser)) = &self.fuser {
            let inputs: Vec<MethodCandidates<'_>> = self
                .fuse
                .iter()
                .map(|&i| MethodCandidates {
                    method: &outputs[i].0,
                    frames: &outputs[i].1.candidates,
                })
                .collect();
            let fused = fuser
                .fuse(motion, &inputs)
                .map_err(|e| e.in_file(&file).under_field(format!("fuser {name}")))?;
            // Cheap (a merge of candidate lists): never cached, logged for the provenance.
            data.record(
                item.dataset,
                item.file,
                &format!("fuser {name}"),
                motionlab_experiment::Origin::Computed,
            );
            methods.push(MethodRecord {
                method: name.clone(),
                candidates: fused,
                flagged_frames: 0,
            });
        }
        let mut figures = if draw {
            self.figures(&item.id, &loaded.name, motion, loaded.truth.as_ref(), &outputs, &methods)?
        } else {
            Vec::new()
        };
        let paths: Vec<(String, Vec<PathPoint>)> = outputs
            .iter()
            .filter(|(_, o)| !o.penalty_path.is_empty())
            .map(|(n, o)| (n.clone(), o.penalty_path.clone()))
            .collect();
        if draw {
            for (method, path) in &paths {
                figures.push(Figure::chart(
                    format!("{}_{}_penalty_path", item.id, sanitize(method)),
                    penalty_path_chart(&loaded.name, method, path),
                ));
            }
        }
        let traces = if draw {
            outputs
                .iter()
                .map(|(n, o)| (n.clone(), o.traces.clone(), o.thresholds.clone()))
                .collect()
        } else {
            Vec::new()
        };
        let result = ItemResult {
            sequence: loaded.name.clone(),
            frame_rate_hz: motion.frame_rate().hz(),
            n_frames: motion.n_frames(),
            methods,
            traces,
            paths,
        };
        Ok(ItemOutput::new(ItemData::encode(&result)?, figures))
    }

    fn finish(
        &self,
        items: &[(WorkItem, ItemData)],
        data: &Datasets,
        draw: bool,
    ) -> Result<Output> {
        let mut sequences = Vec::new();
        let mut rows = Vec::new();
        let mut viewer_traces = Vec::new();
        // What the evaluation reads of each sequence (its input's cache key, name and every
        // method's candidates), for the evaluation's key in the on-disk cache.
        let mut reads: Vec<(Option<motionlab_experiment::run_cache::Key>, Vec<u8>)> = Vec::new();
        // Each sequence's input file (SHA-256, hex): was a method's default tuned on it?
        let mut inputs: Vec<(String, String)> = Vec::new();
        let mut path_rows = Vec::new();
        for (item, value) in items {
            let mut r: ItemResult = value.decode()?;
            viewer_traces.push((item.id.clone(), std::mem::take(&mut r.traces)));
            for (method, path) in &r.paths {
                path_rows.extend(path.iter().map(|p| PathRow {
                    sequence: r.sequence.clone(),
                    method: method.clone(),
                    n_changes: p.change_points.len(),
                    pen_min: p.pen_min,
                    pen_max: p.pen_max,
                    cost: p.cost,
                    chosen: p.chosen,
                    change_points:
                        p.change_points.iter().map(|c| c.to_string()).collect::<Vec<_>>().join(" "),
                }));
            }
            for m in &r.methods {
                rows.extend(m.candidates.iter().map(|&f| CandidateRow {
                    sequence: r.sequence.clone(),
                    method: m.method.clone(),
                    frame: f,
                    time_s: f as f64 / r.frame_rate_hz,
                }));
            }
            // Evaluators may compare poses, so they get the motion itself (reloaded: item results
            // are kept small so shards stay cheap to merge).
            let loaded = data.load(item.dataset, item.file)?;
            let mut read = r.sequence.clone().into_bytes();
            for m in &r.methods {
                read.push(0);
                read.extend(m.method.as_bytes());
                read.push(0);
                read.extend(m.candidates.iter().flat_map(|&c| (c as u64).to_le_bytes()));
            }
            reads.push((loaded.key, read));
            let sha = data.cache.file_sha256(&data.datasets[item.dataset].files[item.file])?;
            inputs.push((r.sequence.clone(), motionlab_experiment::run_cache::hex(&sha)));
            sequences.push(SequenceResult {
                sequence: r.sequence,
                motion: Arc::clone(&loaded.motion),
                truth: loaded.truth,
                methods: r
                    .methods
                    .into_iter()
                    .map(|m| MethodResult { method: m.method, candidates: m.candidates })
                    .collect(),
            });
        }
        let mut out = Output::default();
        out.tables.push(Table::from_records(
            "candidates",
            "Candidate frames per sequence and method",
            &rows,
        )?);
        if !path_rows.is_empty() {
            out.tables.push(Table::from_records(
                "penalty_path",
                "Each penalty path a method chose on (kernel_cpd's penalty = { path }): every segmentation optimal for a penalty of the range, fewest change points first, with its penalty interval, unpenalised cost and whether the method's rule chose it",
                &path_rows,
            )?);
        }
        let logged: Vec<(usize, usize)> = items.iter().map(|(i, _)| (i.dataset, i.file)).collect();
        for ((name, e), params) in self.evaluators.iter().zip(&self.evaluator_params) {
            let Evaluation { mut tables, analysis } = data.evaluation_cached(
                &format!("evaluate {name}"),
                params,
                &reads,
                &logged,
                || {
                    e.evaluate_with_analysis(EvalInput::segmentation(&sequences))
                        .map_err(|err| err.under_field(format!("evaluate {name}")))
                },
            )?;
            // Added after the cache: it depends on the combination, not on what was evaluated.
            self.choices.annotate(&mut tables, &inputs);
            out.tables.extend(tables);
            out.analyses.extend(analysis.map(|a| (name.clone(), a)));
        }
        if draw {
            let judged = out.analysis::<BoundaryAnalysis>();
            // A channel file has no figure to play: its traces are in the figures.
            for (((id, traces), seq), (_, sha)) in viewer_traces
                .iter()
                .zip(&sequences)
                .zip(&inputs)
                .filter(|((_, seq), _)| seq.motion.n_points() > 0)
            {
                out.viewers.push(self.viewer(
                    id,
                    seq,
                    traces,
                    judged.as_ref().and_then(|j| j.sequence(&seq.sequence)),
                    sha,
                )?);
            }
        }
        if self.base_combination {
            let tiers = sequences
                .iter()
                .zip(&inputs)
                .map(|(seq, (_, sha))| boundary_tiers(seq, sha))
                .collect();
            let json = serde_json::to_vec_pretty(&RunBoundaries::new(tiers)).map_err(|e| {
                Error::new(ErrorKind::Report, format!("{}: {e}", RunBoundaries::FILE_NAME))
            })?;
            out.files.push((RunBoundaries::FILE_NAME.into(), json));
        }
        Ok(out)
    }

    fn summarize(&self, combos: &[ComboOutput<'_>]) -> Result<Output> {
        if combos.len() < 2 {
            return Ok(Output::default());
        }
        let mut out = pr_curves(combos, &self.method_names())?;
        let heldout = heldout_tables(combos, &self.method_names(), &self.section.selection);
        out.tables.extend(heldout.map_err(|e| self.locator.locate(e, "segmentation.selection"))?);
        Ok(out)
    }
}

/// A sequence's truth (tier `truth`, each boundary labelled with the truth segment that starts
/// there) and every method's candidates, one tier each: what `motionlab export` writes.
fn boundary_tiers(seq: &SequenceResult, input_sha256: &str) -> SequenceTiers {
    let mut tiers = Vec::with_capacity(seq.methods.len() + 1);
    if let Some(truth) = &seq.truth {
        let label = |f: usize| {
            truth
                .segments
                .iter()
                .find(|s| s.start == f)
                .map(|s| s.label.clone())
                .unwrap_or_default()
        };
        tiers.push(MarkTier {
            name: "truth".into(),
            marks: truth
                .frames()
                .into_iter()
                .map(|frame| TierMark { frame, label: label(frame) })
                .collect(),
        });
    }
    tiers.extend(seq.methods.iter().map(|m| MarkTier::unlabelled(m.method.clone(), &m.candidates)));
    SequenceTiers {
        name: seq.sequence.clone(),
        sequence: file_stem(seq),
        input_sha256: input_sha256.to_string(),
        frame_rate_hz: seq.motion.frame_rate().hz(),
        n_frames: seq.motion.n_frames(),
        tiers,
    }
}

/// The motion file's stem (`86_01`), which annotation files name the sequence by; the
/// sequence's name when the motion has no file.
fn file_stem(seq: &SequenceResult) -> String {
    seq.motion.source.as_deref().map_or_else(|| seq.sequence.clone(), motionlab_core::paths::stem)
}

impl SegmentationWorkflow {
    /// The viewer page of one sequence: ground truth (judged against the fused method), the
    /// fused candidates, then each segmenter's candidates and traces; statuses as the boundary
    /// evaluation judged them, and the band drawn around each truth the tolerance that judged
    /// them — both from the evaluation's analysis (`judged`), so the band and the statuses
    /// cannot disagree, whatever the evaluator's parameters say or leave to their defaults.
    /// Annotation mode keeps its marks under the input's SHA-256 and judges them at that
    /// tolerance.
    fn viewer(
        &self,
        id: &str,
        seq: &SequenceResult,
        traces: &[(String, Vec<Trace>, Vec<Threshold>)],
        judged: Option<&SequenceBoundaries>,
        input_sha256: &str,
    ) -> Result<ViewerSpec> {
        let motion = &seq.motion;
        let vm = ViewerMotion::from_motion(motion, &self.section.bones, Some(&self.section.root))?;
        let mut spec = ViewerSpec::new(id, format!("{} — {}", seq.sequence, self.experiment), vm);
        let judge = |lane: &mut EventLane, method: &str, truth_side: bool| {
            let Some(m) = judged.and_then(|j| j.method(method)) else { return };
            for b in &m.matches {
                let status = match (truth_side, b.outcome) {
                    (true, MatchOutcome::Missed) => b.truth_frame.map(|f| (f, MarkStatus::Missed)),
                    (true, o) if o.is_match() => b.truth_frame.map(|f| (f, MarkStatus::Matched)),
                    (false, MatchOutcome::Extra) => {
                        b.found_frame.map(|f| (f, MarkStatus::FalsePositive))
                    }
                    (false, o) if o.is_match() => b.found_frame.map(|f| (f, MarkStatus::Matched)),
                    _ => None,
                };
                if let Some((f, status)) = status {
                    lane.set_status(f, status);
                }
            }
        };
        let fused = self.fuser.as_ref().and_then(|_| seq.methods.last());
        let tolerance_frames = judged.map(|j| j.tolerance_frames).filter(|f| f.is_finite());
        // Without an evaluator's tolerance, marks are judged at boundary_pr's default.
        let judged_at =
            tolerance_frames.or_else(|| Some(default_tolerance().frames_at(motion.frame_rate())));
        spec.annotation = Some(AnnotationSpec {
            sequence: file_stem(seq),
            input_sha256: input_sha256.to_string(),
            tolerance_frames: judged_at,
        });
        if let Some(truth) = &seq.truth {
            let mut lane = EventLane::truth("ground truth", truth, tolerance_frames);
            if let Some(f) = fused {
                judge(&mut lane, &f.method, true);
                lane.judged_against = Some(f.method.clone());
            }
            spec.lanes.push(Lane::Events(lane));
        }
        if let Some(f) = fused {
            let mut lane = EventLane::new(f.method.clone(), EventKind::Fused, &f.candidates);
            judge(&mut lane, &f.method, false);
            spec.lanes.push(Lane::Events(lane));
        }
        for m in seq.methods.iter().take(self.segmenters.len()) {
            let mut lane = EventLane::new(m.method.clone(), EventKind::Candidates, &m.candidates);
            judge(&mut lane, &m.method, false);
            spec.lanes.push(Lane::Events(lane));
            if let Some((_, t, th)) = traces.iter().find(|(n, ..)| *n == m.method) {
                spec.lanes.extend(
                    TraceLane::from_traces(&m.method, t, th, motion.n_frames())
                        .into_iter()
                        .map(Lane::Trace),
                );
            }
        }
        Ok(spec)
    }

    fn figures(
        &self,
        id: &str,
        name: &str,
        motion: &motionlab_core::Motion,
        truth: Option<&Segmentation>,
        outputs: &[(String, SegmenterOutput)],
        methods: &[MethodRecord],
    ) -> Result<Vec<Figure>> {
        let rate = motion.frame_rate().hz();
        let time = time_axis(motion);
        let wants = |f: SegmentationFigure| self.section.figures.contains(&f);
        let mut figs = Vec::new();
        if wants(SegmentationFigure::Traces) {
            for (method, out) in outputs {
                if out.traces.is_empty() {
                    continue;
                }
                let bars = vec![BarRow {
                    label: method.clone(),
                    marks: frames_to_seconds(&out.candidates, rate),
                    bands: vec![],
                }];
                let charts = traces_charts(
                    &format!("{name} — {method}: candidates (bars)"),
                    &time,
                    &out.traces,
                    &out.thresholds,
                    bars,
                );
                let Some(chart) = charts.first().cloned() else { continue };
                for (k, c) in charts.into_iter().enumerate() {
                    let suffix = if k == 0 { String::new() } else { format!("_{k}") };
                    figs.push(Figure::chart(format!("{id}_{}{suffix}", sanitize(method)), c));
                }
                // The paper's Fig 3: a close-up around one candidate, where the tracked marker's
                // speed can be read against V.
                if let Some(&c) = out.candidates.get(out.candidates.len() / 2) {
                    let t = c as f64 / rate;
                    let mut zoom = chart;
                    zoom.title = format!("{name} — {method}: close-up around frame {c}");
                    zoom.x_range = Some((t - 1.25, t + 1.25));
                    for l in zoom.lines.iter_mut() {
                        let keep: Vec<usize> =
                            (0..l.x.len()).filter(|&i| (l.x[i] - t).abs() <= 1.25).collect();
                        l.x = keep.iter().map(|&i| l.x[i]).collect();
                        l.y = keep.iter().map(|&i| l.y[i]).collect();
                    }
                    for b in zoom.bar_rows.iter_mut() {
                        b.marks.retain(|m| (m - t).abs() <= 1.25);
                    }
                    figs.push(Figure::chart(format!("{id}_{}_zoom", sanitize(method)), zoom));
                }
            }
        }
        let root = motion.point_index(&self.section.root).ok();
        let fused = methods.last().map(|m| m.candidates.clone()).unwrap_or_default();
        if wants(SegmentationFigure::RootPath)
            && let Some(k) = root
        {
            let path: Vec<[f64; 2]> = motion.trajectory(k).map(|p| motion.horizontal(p)).collect();
            let [a, b] = motion.up_axis().others();
            let pts: Vec<usize> = fused.iter().copied().filter(|&f| f < path.len()).collect();
            let mut cands = Series::new(
                format!("{} candidates", methods.last().map(|m| m.method.as_str()).unwrap_or("")),
                pts.iter().map(|&f| path[f][0]).collect(),
                pts.iter().map(|&f| path[f][1]).collect(),
            );
            cands.point_labels = pts.iter().map(|f| f.to_string()).collect();
            figs.push(Figure::chart(
                format!("{id}_root_path"),
                Chart {
                    title: format!(
                        "{name} — root path on the floor with candidates (frame numbers)"
                    ),
                    x_label: format!("{} (mm)", axis_name(a)),
                    y_label: format!("{} (mm)", axis_name(b)),
                    lines: vec![Series::new(
                        "root",
                        path.iter().map(|p| p[0]).collect(),
                        path.iter().map(|p| p[1]).collect(),
                    )],
                    points: vec![cands],
                    equal_aspect: true,
                    ..Default::default()
                },
            ));
        }
        if wants(SegmentationFigure::Timeline) || wants(SegmentationFigure::TimelinePoses) {
            let mut rows = Vec::new();
            if let Some(t) = truth {
                rows.push(BarRow {
                    label: "ground truth".into(),
                    marks: frames_to_seconds(&t.frames(), rate),
                    bands: t
                        .boundaries
                        .iter()
                        .filter_map(|b| b.window)
                        .map(|(a, c)| (a as f64 / rate, c as f64 / rate))
                        .collect(),
                });
            }
            rows.extend(methods.iter().map(|m| BarRow {
                label: m.method.clone(),
                marks: frames_to_seconds(&m.candidates, rate),
                bands: vec![],
            }));
            let timeline = Chart {
                title: format!("{name} — ground truth and each method's candidates"),
                x_label: "time (s)".into(),
                bar_rows: rows,
                x_range: Some((0.0, motion.n_frames() as f64 / rate)),
                ..Default::default()
            };
            // Poses need points: a channel file has the timeline alone.
            if wants(SegmentationFigure::TimelinePoses) && motion.n_points() > 0 {
                let axis = main_floor_axis(motion, root, 0, motion.n_frames().saturating_sub(1));
                let row = stick_row_at(motion, &fused, axis);
                let fuser = methods.last().map(|m| m.method.clone()).unwrap_or_default();
                figs.push(Figure {
                    name: format!("{id}_timeline_poses"),
                    figure: FigureKind::TimelinePoses(TimelinePoses {
                        timeline: Chart { title: format!("{name} — candidates and the pose at each {fuser} boundary"), ..timeline.clone() },
                        bones: bones_for(motion, &self.section.bones)?,
                        poses: fused.iter().map(|&f| f as f64 / rate).zip(row.poses).collect(),
                        caption: format!("poses at the {fuser} candidates (frame numbers), side view: {} horizontal, {} up", axis_name(axis), motion.up_axis()),
                    }),
                });
            }
            if wants(SegmentationFigure::Timeline) {
                figs.push(Figure::chart(format!("{id}_timeline"), timeline));
            }
        }
        if wants(SegmentationFigure::StickStrip)
            && motion.n_points() > 0
            && let Some((a, b)) = pick_segment(&fused, truth, motion.n_frames(), rate)
        {
            let bones = bones_for(motion, &self.section.bones)?;
            let axis = main_floor_axis(motion, root, a, b);
            let row = stick_row(motion, &format!("frames {a}–{b}"), a, b, 8, axis);
            figs.push(Figure {
                name: format!("{id}_segment"),
                figure: FigureKind::Sticks(stick_strip(
                    format!("{name} — one segment between two fused candidates"),
                    bones,
                    vec![row],
                    format!(
                        "side view: {} horizontal, {} up (mm); each pose centred",
                        axis_name(axis),
                        motion.up_axis()
                    ),
                )),
            });
        }
        Ok(figs)
    }
}

/// The segment to show as a stick strip: between consecutive fused candidates, the one that
/// best matches a ground-truth segment (largest overlap), else the longest ≥ 0.5 s.
fn pick_segment(
    fused: &[usize],
    truth: Option<&Segmentation>,
    n_frames: usize,
    rate: f64,
) -> Option<(usize, usize)> {
    let pairs: Vec<(usize, usize)> = fused
        .windows(2)
        .map(|w| (w[0], w[1]))
        .filter(|(a, b)| (b - a) as f64 >= 0.5 * rate && *b < n_frames)
        .collect();
    let score = |(a, b): &(usize, usize)| -> f64 {
        match truth {
            Some(t) if !t.segments.is_empty() => t
                .segments
                .iter()
                .map(|s: &Segment| {
                    let inter = (s.end.min(*b) as f64 - s.start.max(*a) as f64).max(0.0);
                    let union = (s.end.max(*b) - s.start.min(*a)) as f64;
                    inter / union
                })
                .fold(0.0, f64::max),
            _ => (b - a) as f64,
        }
    };
    pairs.into_iter().max_by(|x, y| score(x).total_cmp(&score(y)))
}

/// Precision–recall curves across a sweep and the best-F1 operating point of each method.
///
/// Reads each combination's boundary evaluation (its [`BoundaryAnalysis`]), pooled over the
/// sequences. Each sweep grid contributes the curve of its focus method (or of every method
/// when the grid has no focus).
fn pr_curves(combos: &[ComboOutput<'_>], methods: &[String]) -> Result<Output> {
    #[derive(Serialize)]
    struct Best {
        method: String,
        sweep: String,
        combination: usize,
        parameters: String,
        precision: f64,
        recall: f64,
        f1: f64,
    }
    /// (recall, precision, F1, combination, parameters) of one sweep point.
    type Point = (f64, f64, f64, usize, String);
    let mut curves: Vec<(String, Vec<Point>)> = Vec::new();
    for co in combos {
        let Some(judged) = co.output.analysis::<BoundaryAnalysis>() else { continue };
        for (m, counts) in judged.pooled() {
            if co.combo.focus.as_ref().is_some_and(|fm| *fm != m) {
                continue;
            }
            let key = format!("{m} ({})", co.combo.sweep.clone().unwrap_or_default());
            let s = counts.scores();
            let point = (s.recall, s.precision, s.f1, co.combo.index, co.combo.label());
            match curves.iter_mut().find(|(k, _)| *k == key) {
                Some((_, pts)) => pts.push(point),
                None => curves.push((key, vec![point])),
            }
        }
    }
    let mut out = Output::default();
    if curves.is_empty() {
        return Ok(out);
    }
    let mut best = Vec::new();
    for (key, pts) in &curves {
        if let Some(b) = pts.iter().filter(|p| p.2.is_finite()).max_by(|a, b| a.2.total_cmp(&b.2)) {
            let (method, sweep) = key
                .split_once(" (")
                .map(|(m, s)| (m.to_string(), s.trim_end_matches(')').to_string()))
                .unwrap_or((key.clone(), String::new()));
            best.push(Best {
                method,
                sweep,
                combination: b.3,
                parameters: b.4.clone(),
                precision: b.1,
                recall: b.0,
                f1: b.2,
            });
        }
    }
    best.sort_by_key(|b| methods.iter().position(|m| *m == b.method).unwrap_or(usize::MAX));
    out.tables.push(Table::from_records(
        "best_f1",
        "Best-F1 operating point per method (pooled over sequences)",
        &best,
    )?);
    let mut lines = Vec::new();
    for (key, pts) in curves {
        let mut pts = pts;
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        lines.push(Series::new(
            key,
            pts.iter().map(|p| p.0).collect(),
            pts.iter().map(|p| p.1).collect(),
        ));
    }
    let points = vec![Series {
        label: "best F1".into(),
        x: best.iter().map(|b| b.recall).collect(),
        y: best.iter().map(|b| b.precision).collect(),
        point_labels: best.iter().map(|b| b.method.clone()).collect(),
    }];
    out.figures.push(Figure::chart(
        "precision_recall",
        Chart {
            title: "Precision–recall over each method's threshold sweep (pooled)".into(),
            x_label: "recall".into(),
            y_label: "precision".into(),
            lines,
            points,
            x_range: Some((0.0, 1.02)),
            y_range: Some((0.0, 1.02)),
            ..Default::default()
        },
    ));
    Ok(out)
}
