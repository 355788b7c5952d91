//! Running the `[matching]` workflow: each take's repetitions found (continuous takes) and
//! matched against the model, then per combination the tables and the evaluators.

use serde::Serialize;

use motionlab_core::{Error, ErrorKind, EvalInput, FrameRate, Motion, Result, Seconds, Table};
use motionlab_experiment::spec::Cut;
use motionlab_experiment::workflow::{ItemData, ItemOutput, Output, WorkItem, Workflow};
use motionlab_experiment::{BuiltDataset, Datasets};
use motionlab_match::{
    Alignment, MatchingResult, PointDetection, RepetitionResult, Synchronisation,
};

use super::analysis::timing_test;
use super::figures::scatter_figures;
use super::section::MatchingFigure;
use super::{ItemResult, MatchingWorkflow, RepetitionRecord, TakeKind};

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

impl MatchingWorkflow {
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
            return Err(self.locator.locate(
                Error::new(
                    ErrorKind::Mismatch,
                    format!(
                        "the matcher {:?} returned {} per-point distances for {} points ({}); expected one per point",
                        self.section.matcher.kind,
                        alignment.point_distances.len(),
                        names.len(),
                        names.join(", ")
                    ),
                ),
                "matching.matcher",
            ));
        }
        Ok(names)
    }

    fn match_one(&self, model: &Motion, target: &Motion) -> Result<(Alignment, Synchronisation)> {
        let alignment = self
            .matcher
            .align(model, target)
            .map_err(|e| e.under_field(format!("matcher {}", self.section.matcher.kind)))?;
        let sync = self.synchroniser.synchronise(&alignment, model.n_frames()).map_err(|e| {
            e.under_field(format!("synchroniser {}", self.section.synchroniser.kind))
        })?;
        Ok((alignment, sync))
    }
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
        let take = self.takes.iter().find(|t| t.id == item.id).ok_or_else(|| {
            Error::new(
                ErrorKind::Mismatch,
                format!("work item {:?} is no take of this experiment", item.id),
            )
        })?;
        let model = self.load_model(data)?;
        let rate = model.frame_rate();
        let mut reps: Vec<RepetitionRecord> = Vec::new();
        let mut paths: Vec<Vec<Vec<(usize, usize)>>> = Vec::new();
        let mut point_names: Option<Vec<String>> = None;
        let mut detection: Option<(PointDetection, usize)> = None;
        let mut record = |label: String,
                          group: Option<String>,
                          pair: Option<String>,
                          peaks: Vec<usize>,
                          window: (usize, usize),
                          target: &Motion|
         -> Result<()> {
            let (alignment, sync) = self
                .match_one(&model, target)
                .map_err(|e| e.under_field(format!("repetition {label:?}")))?;
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
                    let e = e.under_field(format!(
                        "point_detector, take {:?} with {count} repetitions × {per} peaks",
                        take.name
                    ));
                    match &loaded.motion.source {
                        Some(f) => e.in_file(f),
                        None => e,
                    }
                })?;
                let user = self.select((*loaded.motion).clone())?;
                for (k, (peaks, (s, e))) in
                    group_repetitions(&found, self.section.peaks_per_repetition)
                        .into_iter()
                        .enumerate()
                {
                    let window = user.slice_frames(s, e)?;
                    let peaks = peaks.iter().map(|p| p + offset).collect();
                    record(
                        format!("rep {}", k + 1),
                        None,
                        None,
                        peaks,
                        (s + offset, e + offset),
                        &window,
                    )?;
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
                    let (group, pair) =
                        (ds.tag("group").map(str::to_string), ds.tag("pair").map(str::to_string));
                    record(
                        loaded.name.clone(),
                        group,
                        pair,
                        Vec::new(),
                        (offset, offset + n),
                        &target,
                    )?;
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
            velocity: if draw {
                detection
                    .as_ref()
                    .map(|(d, _)| (d.velocity.values.clone(), d.velocity.unit.clone()))
            } else {
                None
            },
        };
        let figures = if draw {
            self.item_figures(&item.id, &result, detection.as_ref(), &paths)?
        } else {
            Vec::new()
        };
        Ok(ItemOutput::new(ItemData::encode(&result)?, figures))
    }

    fn finish(
        &self,
        items: &[(WorkItem, ItemData)],
        data: &Datasets,
        draw: bool,
    ) -> Result<Output> {
        let results: Vec<ItemResult> =
            items.iter().map(|(_, d)| d.decode()).collect::<Result<_>>()?;
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
                    peak_frames: rep
                        .peaks
                        .iter()
                        .map(usize::to_string)
                        .collect::<Vec<_>>()
                        .join(";"),
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
            let tables = e
                .evaluate(EvalInput::new(&matching))
                .map_err(|err| err.under_field(format!("evaluate {name}")))?;
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
        if draw && self.wants(MatchingFigure::Scatter) {
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

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_core::Trace;

    #[test]
    fn consecutive_peaks_form_one_repetition_whose_window_is_their_union() {
        let d = PointDetection {
            velocity: Trace::new("v", "mm/frame", vec![]),
            threshold: 1.0,
            peaks: vec![20, 60, 150, 190],
            windows: vec![(0, 41), (40, 81), (130, 171), (170, 211)],
        };
        assert_eq!(
            group_repetitions(&d, 2),
            vec![(vec![20, 60], (0, 81)), (vec![150, 190], (130, 211))]
        );
        assert_eq!(group_repetitions(&d, 1).len(), 4);
        assert_eq!(group_repetitions(&d, 1)[2], (vec![150], (130, 171)));
    }
}
