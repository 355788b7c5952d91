//! The `[retrieval]` workflow: the stretches of a whole corpus most similar and most dissimilar
//! to one model motion, by Yabe & Tanaka's two-stage multistream match
//! ([`motionlab_match::retrieval`]).
//!
//! ```toml
//! [[dataset]]                       # the model: one repetition, cut from a take
//! name = "model"
//! files = ["../data/mocap6/amc/13_30.amc.gz"]
//! loader = { type = "asf_amc" }
//! cut = { frames = [56, 180] }
//!
//! [[dataset]]                       # the corpus: every other dataset, any number of files
//! files = ["../data/**/*.amc.gz"]
//! loader = { type = "asf_amc" }
//!
//! [[preprocess]]
//! type = "distinct_points"
//!
//! [retrieval]
//! model = "model"
//! reference_point = "root"
//! similar = 5
//! dissimilar = 5
//! ```
//!
//! One work item holds the whole corpus: the search is global (the k-th best stretch of one take
//! prunes the windows of every other), and it runs in parallel over takes and candidates inside
//! the item. Frames in tables count from the start of each file (a dataset's `cut` is added
//! back).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::{Error, ErrorKind, Motion, Result, Table, TimeSpan};
use motionlab_figure::{BarRow, Chart, Figure, Series};
use motionlab_match::Synchroniser;
use motionlab_match::dp::Trajectory3;
use motionlab_match::input::trajectories;
use motionlab_match::retrieval::{Hit, RetrievalSettings, relative_to_point, retrieve};

use crate::matching::{cut_offset, find_model};
use motionlab_experiment::build_stage;
use motionlab_experiment::spec::StageSpec;
use motionlab_experiment::workflow::{
    BuildContext, ItemData, ItemOutput, Output, WorkItem, Workflow, WorkflowPlugin,
};
use motionlab_experiment::{Datasets, Locator};

/// The `k` stretches of a corpus most similar, and the `k` most dissimilar, to one model motion
/// (Yabe & Tanaka's two-stage multistream match, across every take).
///
/// Every dataset but the model is the corpus (globs: `files = ["../data/**/*.amc.gz"]`). Each
/// take is cut into candidate windows (`window` frames every `stride`); each window is matched
/// to the model by `multistream_two_stage` — common stretch `[a, b]`, distance `H` — and the
/// windows are ranked by `H`: ascending for the **most similar** list, descending for the
/// **most dissimilar** (the windows whose best match to the model is the worst). Each list is
/// chosen greedily without overlap: a stretch sharing a frame with one already listed (same
/// take) is skipped. `R` (synchronisation, `synchroniser`) is reported for every listed stretch.
///
/// **Exact pruning** (`pruning = true`, the default): a lower bound on `H` for every window
/// (from one forward pass over each take) and an upper bound (the model matched to one frame,
/// or in lockstep) let a best-first search match only the windows whose bound can still beat
/// the listed ones; the lists are provably those of matching every window (`pruning = false`),
/// which the tests check. The argument: `motionlab_match::retrieval`'s documentation. The
/// lower bound is tight (the similar list of `yabe_retrieval` matches 45 of 882 windows); the
/// upper bound is loose (both lists: 503), so a dissimilar list costs about an exhaustive
/// search.
///
/// Positions are compared as loaded (after the preprocessors) or, with `reference_point`,
/// relative to that point in every frame, so the same movement anywhere in the room matches.
/// Model and takes must share their frame rate and hold the matched points.
///
/// Tables: `retrieval_top_k` (list, rank, take, window, `[a, b]` in frames and seconds, `H`,
/// `R`), `retrieval_candidates` (every window: bounds, and `[a, b]`, `H` where matched) and
/// `retrieval_summary`. Figure `retrieval_candidates`: every window's bounds and `H` along the
/// corpus, the listed stretches marked.
///
/// Missing samples: refused (fill gaps first with `fill_gaps`).
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RetrievalSection {
    /// Name of the dataset holding the model motion (its `name`, or the file stem of its single
    /// file). It must resolve to exactly one file, usually cut to one repetition. Required.
    pub model: String,
    /// Markers (or joints) to match.
    #[serde(default)]
    #[schemars(extend("x-default" = "every point of the model"))]
    pub points: Option<Vec<String>>,
    /// Point whose position is subtracted from every point in every frame before matching (the
    /// place in the room removed; e.g. `"root"`).
    #[serde(default)]
    #[schemars(extend("x-default" = "none: positions as loaded"))]
    pub reference_point: Option<String>,
    /// How many most similar stretches to list (0: none).
    #[serde(default = "five")]
    pub similar: usize,
    /// How many most dissimilar stretches to list (0: none).
    #[serde(default = "five")]
    pub dissimilar: usize,
    /// Candidate window length (`{ frames = 250 }` or `{ seconds = 2.0 }`).
    #[serde(default)]
    #[schemars(extend("x-default" = "twice the model's length"))]
    pub window: Option<TimeSpan>,
    /// Step between window starts.
    #[serde(default)]
    #[schemars(extend("x-default" = "a quarter of the model's length, at least 1 frame"))]
    pub stride: Option<TimeSpan>,
    /// Bounds and best-first search (true) or every window matched (false); the lists are the
    /// same.
    #[serde(default = "yes")]
    pub pruning: bool,
    /// The synchroniser giving `R` of each listed stretch (the default is the paper's, k = 8).
    #[serde(default = "default_synchroniser")]
    pub synchroniser: StageSpec,
}

fn five() -> usize {
    5
}

fn yes() -> bool {
    true
}

fn default_synchroniser() -> StageSpec {
    StageSpec::of_type("synchronisation")
}

pub struct RetrievalWorkflow {
    section: RetrievalSection,
    model: usize,
    synchroniser: Box<dyn Synchroniser>,
    /// Locates configuration errors found only once the data is seen (a reference point a
    /// take lacks).
    locator: Locator,
}

impl WorkflowPlugin for RetrievalWorkflow {
    type Section = RetrievalSection;
    fn build(section: RetrievalSection, cx: &BuildContext<'_>) -> Result<Self> {
        // The matcher's features are 3-D marker distances and directions.
        cx.require_3d_unless("the retrieval workflow", false, &cx.root)?;
        let locate = |e: Error, key: &str| cx.locate(e, cx.root.join_field(key));
        for (key, span) in [("window", section.window), ("stride", section.stride)] {
            if let Some(s) = span {
                s.check(key, true).map_err(|e| locate(e, key))?;
            }
        }
        if let Some(p) = &section.points {
            motionlab_match::input::check_names(p, "points").map_err(|e| locate(e, "points"))?;
            if let Some(r) = &section.reference_point
                && !p.contains(r)
            {
                return Err(locate(
                    Error::new(
                        ErrorKind::UnknownName,
                        format!("reference point {r:?} is not among the matched `points`"),
                    ),
                    "reference_point",
                ));
            }
        }
        let model = find_model(&section.model, cx.data).map_err(|e| locate(e, "model"))?;
        if cx.data.datasets.iter().all(|d| d.index == model || d.files.is_empty()) {
            return Err(locate(
                Error::new(
                    ErrorKind::MissingKey,
                    "no take to search: every [[dataset]] but the model is the corpus, and there is none",
                ),
                "model",
            ));
        }
        let synchroniser = build_stage(
            cx.source,
            cx.combo,
            &section.synchroniser,
            &cx.root.key("synchroniser"),
            motionlab_match::build_synchroniser,
        )?;
        Ok(RetrievalWorkflow { section, model, synchroniser, locator: cx.locator() })
    }
}

motionlab_experiment::register_workflow!(RetrievalWorkflow, "retrieval");

/// One listed stretch, as persisted.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct HitRecord {
    list: String,
    rank: usize,
    take: usize,
    /// Window and `[a, b]` in frames of the file.
    window_start: usize,
    window_end: usize,
    start: usize,
    end: usize,
    h_mm: f64,
    r_frames2: f64,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct CandidateRecord {
    take: usize,
    window_start: usize,
    window_end: usize,
    lower_bound: Option<f64>,
    upper_bound: Option<f64>,
    matched: Option<(usize, usize, f64)>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct ItemResult {
    frame_rate_hz: f64,
    model_frames: usize,
    points: usize,
    window_frames: usize,
    stride_frames: usize,
    takes: Vec<String>,
    take_frames: Vec<usize>,
    /// First frame of each loaded take in its file.
    take_offsets: Vec<usize>,
    hits: Vec<HitRecord>,
    candidates: Vec<CandidateRecord>,
    matched_candidates: usize,
}

impl RetrievalWorkflow {
    fn prepare(&self, motion: &Motion, role: &str) -> Result<Vec<Trajectory3>> {
        let names = match &self.section.points {
            Some(p) => p.clone(),
            None => motion.point_names().to_vec(),
        };
        let mut t = trajectories(motion, &names, role, "retrieval")?;
        if let Some(r) = &self.section.reference_point {
            let k = names.iter().position(|n| n == r).ok_or_else(|| {
                self.locator.locate(
                    Error::new(
                        ErrorKind::UnknownName,
                        format!("the {role} {:?} has no point {r:?}", motion.name),
                    ),
                    "retrieval.reference_point",
                )
            })?;
            relative_to_point(&mut t, k)?;
        }
        Ok(t)
    }
}

impl Workflow for RetrievalWorkflow {
    fn items(&self, data: &Datasets) -> Vec<WorkItem> {
        let first = data.datasets.iter().find(|d| d.index != self.model).map_or(0, |d| d.index);
        vec![WorkItem { id: "corpus".into(), dataset: first, file: 0 }]
    }

    fn run_item(&self, _item: &WorkItem, data: &Datasets, _draw: bool) -> Result<ItemOutput> {
        let model = data.load(self.model, 0).map_err(|e| e.under_field("model"))?;
        let rate = model.motion.frame_rate();
        let model_names: Vec<String> = match &self.section.points {
            Some(p) => p.clone(),
            None => model.motion.point_names().to_vec(),
        };
        let model_t = self.prepare(&model.motion, "model")?;
        let n = model.motion.n_frames();
        let window_frames = self.section.window.map_or(2 * n, |w| w.whole_frames_at(rate)).max(1);
        let stride_frames = self.section.stride.map_or(n / 4, |s| s.whole_frames_at(rate)).max(1);
        let (mut names, mut frames, mut offsets, mut takes) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for d in data.datasets.iter().filter(|d| d.index != self.model) {
            for f in 0..d.files.len() {
                let loaded = data.load(d.index, f)?;
                let m = &loaded.motion;
                if m.frame_rate() != rate {
                    return Err(Error::new(
                        ErrorKind::Mismatch,
                        format!("take {:?} runs at {} Hz but the model at {} Hz; the DP compares frame by frame", loaded.name, m.frame_rate().hz(), rate.hz()),
                    )
                    .in_file(&d.files[f]));
                }
                let t = self.prepare(m, "take").map_err(|e| e.in_file(&d.files[f]))?;
                names.push(loaded.name.clone());
                frames.push(m.n_frames());
                offsets.push(cut_offset(d, m.frame_rate()));
                takes.push(t);
            }
        }
        let settings = RetrievalSettings {
            k_similar: self.section.similar,
            k_dissimilar: self.section.dissimilar,
            window_frames,
            stride_frames,
            pruning: self.section.pruning,
        };
        let r = retrieve(&model_t, &takes, &settings)?;
        let mut hits = Vec::new();
        for (list, listed) in [("similar", &r.similar), ("dissimilar", &r.dissimilar)] {
            for h in listed {
                hits.push(self.hit_record(list, h, &offsets, n)?);
            }
        }
        let candidates = r
            .candidates
            .iter()
            .map(|c| {
                let o = offsets[c.take];
                CandidateRecord {
                    take: c.take,
                    window_start: c.window_start + o,
                    window_end: c.window_end + o,
                    lower_bound: c.lower_bound,
                    upper_bound: c.upper_bound,
                    matched: c.matched.map(|m| (m.start + o, m.end + o, m.total_distance)),
                }
            })
            .collect();
        let result = ItemResult {
            frame_rate_hz: rate.hz(),
            model_frames: n,
            points: model_names.len(),
            window_frames,
            stride_frames,
            takes: names,
            take_frames: frames,
            take_offsets: offsets,
            hits,
            candidates,
            matched_candidates: r.matched_candidates,
        };
        Ok(ItemOutput::new(ItemData::encode(&result)?, Vec::new()))
    }

    fn finish(
        &self,
        items: &[(WorkItem, ItemData)],
        _data: &Datasets,
        draw: bool,
    ) -> Result<Output> {
        let mut out = Output::default();
        for (_, data) in items {
            let r: ItemResult = data.decode()?;
            out.tables.extend(tables(&r)?);
            if draw {
                out.figures.push(candidates_figure(&r));
            }
        }
        Ok(out)
    }
}

impl RetrievalWorkflow {
    fn hit_record(
        &self,
        list: &str,
        h: &Hit,
        offsets: &[usize],
        model_frames: usize,
    ) -> Result<HitRecord> {
        let sync = self.synchroniser.synchronise(&h.alignment, model_frames).map_err(|e| {
            e.under_field(format!("synchroniser {}", self.section.synchroniser.kind))
        })?;
        let o = offsets[h.take] + h.window_start;
        Ok(HitRecord {
            list: list.into(),
            rank: h.rank,
            take: h.take,
            window_start: o,
            window_end: offsets[h.take] + h.window_end,
            start: o + h.alignment.start,
            end: o + h.alignment.end,
            h_mm: h.alignment.total_distance,
            r_frames2: sync.total,
        })
    }
}

/// A row of `retrieval_top_k`.
#[derive(Serialize)]
struct TopRow {
    list: String,
    rank: usize,
    take: String,
    window_start_frame: usize,
    /// Last frame of the window (inclusive).
    window_end_frame: usize,
    a_frame: usize,
    b_frame: usize,
    a_s: f64,
    b_s: f64,
    matched_frames: usize,
    #[serde(rename = "H_mm")]
    h_mm: f64,
    #[serde(rename = "R_frames2")]
    r_frames2: f64,
}

/// A row of `retrieval_candidates`.
#[derive(Serialize)]
struct CandidateRow {
    take: String,
    window_start_frame: usize,
    window_end_frame: usize,
    lower_bound_mm: Option<f64>,
    upper_bound_mm: Option<f64>,
    matched: bool,
    a_frame: Option<usize>,
    b_frame: Option<usize>,
    #[serde(rename = "H_mm")]
    h_mm: Option<f64>,
}

/// The row of `retrieval_summary`.
#[derive(Serialize)]
struct SummaryRow {
    takes: usize,
    frames: usize,
    points: usize,
    model_frames: usize,
    window_frames: usize,
    stride_frames: usize,
    candidates: usize,
    matched_candidates: usize,
    pruning: String,
}

fn tables(r: &ItemResult) -> Result<Vec<Table>> {
    let rate = r.frame_rate_hz;
    let top: Vec<TopRow> = r
        .hits
        .iter()
        .map(|h| TopRow {
            list: h.list.clone(),
            rank: h.rank,
            take: r.takes[h.take].clone(),
            window_start_frame: h.window_start,
            window_end_frame: h.window_end.saturating_sub(1),
            a_frame: h.start,
            b_frame: h.end,
            a_s: h.start as f64 / rate,
            b_s: h.end as f64 / rate,
            matched_frames: h.end - h.start + 1,
            h_mm: h.h_mm,
            r_frames2: h.r_frames2,
        })
        .collect();
    let candidates: Vec<CandidateRow> = r
        .candidates
        .iter()
        .map(|c| CandidateRow {
            take: r.takes[c.take].clone(),
            window_start_frame: c.window_start,
            window_end_frame: c.window_end.saturating_sub(1),
            lower_bound_mm: c.lower_bound,
            upper_bound_mm: c.upper_bound,
            matched: c.matched.is_some(),
            a_frame: c.matched.map(|m| m.0),
            b_frame: c.matched.map(|m| m.1),
            h_mm: c.matched.map(|m| m.2),
        })
        .collect();
    let pruned = r.candidates.iter().any(|c| c.lower_bound.is_some() || c.upper_bound.is_some());
    let summary = [SummaryRow {
        takes: r.takes.len(),
        frames: r.take_frames.iter().sum(),
        points: r.points,
        model_frames: r.model_frames,
        window_frames: r.window_frames,
        stride_frames: r.stride_frames,
        candidates: r.candidates.len(),
        matched_candidates: r.matched_candidates,
        pruning: if pruned {
            "bounds, best-first".into()
        } else {
            "none (every window matched)".into()
        },
    }];
    Ok(vec![
        Table::from_records(
            "retrieval_top_k",
            "The most similar and most dissimilar stretches of the corpus to the model (non-overlapping): window, matched stretch [a, b] (frames of the file, and seconds), distance H and synchronisation R",
            &top,
        )?,
        Table::from_records(
            "retrieval_candidates",
            "Every candidate window: the bounds on H the pruned search used, and [a, b] and H where it matched the window",
            &candidates,
        )?,
        Table::from_records(
            "retrieval_summary",
            "The corpus, the windows, and how many the search matched",
            &summary,
        )?,
    ])
}

/// Every window along the corpus (takes end to end, seconds): its bounds as lines, its `H`
/// where matched, the listed stretches labelled by rank.
fn candidates_figure(r: &ItemResult) -> Figure {
    let rate = r.frame_rate_hz;
    let mut start_s = Vec::with_capacity(r.takes.len());
    let mut total = 0.0;
    for &f in &r.take_frames {
        start_s.push(total);
        total += f as f64 / rate;
    }
    // A window's place: the corpus time of its centre.
    let at = |take: usize, first: usize, last: usize| {
        start_s[take] + ((first + last) as f64 / 2.0 - r.take_offsets[take] as f64) / rate
    };
    let xs: Vec<f64> =
        r.candidates.iter().map(|c| at(c.take, c.window_start, c.window_end)).collect();
    let mut lines = Vec::new();
    for (label, pick) in [
        (
            "lower bound on H (mm)",
            (|c: &CandidateRecord| c.lower_bound) as fn(&CandidateRecord) -> Option<f64>,
        ),
        ("upper bound on H (mm)", |c: &CandidateRecord| c.upper_bound),
    ] {
        if r.candidates.iter().any(|c| pick(c).is_some()) {
            lines.push(Series::new(
                label,
                xs.clone(),
                r.candidates.iter().map(|c| pick(c).unwrap_or(f64::NAN)).collect(),
            ));
        }
    }
    let matched: Vec<&CandidateRecord> =
        r.candidates.iter().filter(|c| c.matched.is_some()).collect();
    let mut points = vec![Series::new(
        "H of a matched window",
        matched.iter().map(|c| at(c.take, c.window_start, c.window_end)).collect(),
        matched.iter().map(|c| c.matched.map_or(f64::NAN, |m| m.2)).collect(),
    )];
    for list in ["similar", "dissimilar"] {
        let hits: Vec<&HitRecord> = r.hits.iter().filter(|h| h.list == list).collect();
        let mut s = Series::new(
            format!("most {list}"),
            hits.iter().map(|h| at(h.take, h.start, h.end + 1)).collect(),
            hits.iter().map(|h| h.h_mm).collect(),
        );
        s.point_labels = hits.iter().map(|h| h.rank.to_string()).collect();
        points.push(s);
    }
    let bar_rows = r
        .takes
        .iter()
        .enumerate()
        .map(|(k, name)| BarRow {
            label: name.clone(),
            marks: vec![],
            bands: vec![(start_s[k], start_s[k] + r.take_frames[k] as f64 / rate)],
        })
        .collect();
    Figure::chart(
        "retrieval_candidates",
        Chart {
            title: format!(
                "Corpus windows against the model: bounds on H, H where matched ({} of {}), the listed stretches",
                r.matched_candidates,
                r.candidates.len()
            ),
            x_label: "time in the corpus, takes end to end (s)".into(),
            y_label: "H, distance summed over markers and path (mm)".into(),
            lines,
            points,
            bar_rows,
            ..Default::default()
        },
    )
}
