//! The viewer pages: the model, each continuous take and each repetition of an explicit take.

use motionlab_core::viewer::{
    EventKind, EventLane, Interval, IntervalKind, IntervalLane, Lane, Mark, TraceLane,
    ViewerMotion, ViewerSpec,
};
use motionlab_core::{Motion, Result, Threshold, Trace};
use motionlab_experiment::Datasets;
use motionlab_experiment::workflow::{ItemData, WorkItem};
use motionlab_match::judgement::{ranks, scores};

use crate::drawing::bones_of_merged_skeleton;

use super::analysis::fmt;
use super::build::item_id;
use super::run::cut_offset;
use super::{ItemResult, MatchingWorkflow, TakeKind};

impl MatchingWorkflow {
    /// Bones for the viewer of a loaded (preprocessed) motion: its skeleton's, through the
    /// points a preprocessor merged ([`bones_of_merged_skeleton`] of the file as loaded, read
    /// again), or none (markers only) when the file has no skeleton or cannot be read again.
    fn bones(
        &self,
        data: &Datasets,
        dataset: usize,
        file: usize,
        motion: &Motion,
    ) -> Vec<[String; 2]> {
        if motion.skeleton.is_some() {
            return Vec::new();
        }
        let d = &data.datasets[dataset];
        match d.loader.load(&d.files[file]) {
            Ok(raw) => bones_of_merged_skeleton(&raw, motion),
            Err(_) => Vec::new(),
        }
    }

    /// The viewer pages: the model, each continuous take (velocity function with threshold,
    /// peaks, cut windows and matched stretches) and each repetition of an explicit take (its
    /// matched stretch). Every interval is labelled with its repetition, `H`, `R`, score and
    /// rank by score within the take (1 = most similar).
    pub(super) fn viewers(
        &self,
        items: &[(WorkItem, ItemData)],
        results: &[ItemResult],
        data: &Datasets,
    ) -> Result<Vec<ViewerSpec>> {
        let mut out = Vec::new();
        let model = data.load(self.model, 0).map_err(|e| e.under_field("model"))?;
        let model_name =
            if items.iter().any(|(i, _)| i.id == "model") { "model_basic_motion" } else { "model" };
        let vm = ViewerMotion::from_motion(
            &model.motion,
            &self.bones(data, self.model, 0, &model.motion),
            Some("root"),
        )?;
        let mut spec = ViewerSpec::new(
            model_name,
            format!("model basic motion {} — matching", model.name),
            vm,
        );
        spec.lanes.push(Lane::Intervals(IntervalLane {
            name: "model".into(),
            kind: IntervalKind::Other,
            intervals: vec![Interval {
                start: 0,
                end: model.motion.n_frames().saturating_sub(1),
                label: model.name.clone(),
            }],
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
                let group = rep
                    .group
                    .as_ref()
                    .filter(|g| !rep.label.contains(&format!("({g})")))
                    .map(|g| format!(" ({g})"))
                    .unwrap_or_default();
                let best = if rank[k] == 1 && n > 1 { ", most similar" } else { "" };
                format!(
                    "{}{group}: rank {} of {n}{best} — score {}, H {} mm, R {} frames²",
                    rep.label,
                    rank[k],
                    fmt(score[k]),
                    fmt(h[k]),
                    fmt(rr[k])
                )
            };
            // `[a, b]` of repetition k in frames of a motion whose first frame is file frame `offset`.
            let matched = |k: usize, offset: usize| {
                let rep = &r.repetitions[k];
                Interval {
                    start: (rep.window_start + rep.start).saturating_sub(offset),
                    end: (rep.window_start + rep.end).saturating_sub(offset),
                    label: label(k),
                }
            };
            match &take.kind {
                TakeKind::Continuous { dataset, file, .. } => {
                    let loaded = data.load(*dataset, *file)?;
                    let offset = cut_offset(&data.datasets[*dataset], loaded.motion.frame_rate());
                    let vm = ViewerMotion::from_motion(
                        &loaded.motion,
                        &self.bones(data, *dataset, *file, &loaded.motion),
                        Some("root"),
                    )?;
                    let mut spec =
                        ViewerSpec::new(item.id.clone(), format!("{} — matching", r.take), vm);
                    let mut peaks = EventLane::new("velocity peaks", EventKind::Other, &[]);
                    for rep in &r.repetitions {
                        for &p in &rep.peaks {
                            peaks.marks.push(Mark {
                                frame: p.saturating_sub(offset),
                                label: rep.label.clone(),
                                status: None,
                            });
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
                        let threshold: Vec<Threshold> = r
                            .threshold
                            .map(|t| Threshold {
                                name: "threshold".into(),
                                trace: "v".into(),
                                value: t,
                            })
                            .into_iter()
                            .collect();
                        spec.lanes.extend(
                            TraceLane::from_traces(
                                "velocity function",
                                &[trace],
                                &threshold,
                                loaded.motion.n_frames(),
                            )
                            .into_iter()
                            .map(Lane::Trace),
                        );
                    }
                    out.push(spec);
                }
                TakeKind::Explicit { members } => {
                    for (k, &(d, f)) in members.iter().enumerate().take(n) {
                        let loaded = data.load(d, f)?;
                        let offset = cut_offset(&data.datasets[d], loaded.motion.frame_rate());
                        let vm = ViewerMotion::from_motion(
                            &loaded.motion,
                            &self.bones(data, d, f, &loaded.motion),
                            Some("root"),
                        )?;
                        let name = format!("{}_{}", item.id, item_id(&r.repetitions[k].label));
                        let mut spec = ViewerSpec::new(
                            name,
                            format!("{} — {} — matching", r.take, r.repetitions[k].label),
                            vm,
                        );
                        spec.lanes.push(Lane::Intervals(IntervalLane {
                            name: "matched [a, b]".into(),
                            kind: IntervalKind::Matched,
                            intervals: vec![matched(k, offset)],
                        }));
                        out.push(spec);
                    }
                }
            }
        }
        Ok(out)
    }
}
