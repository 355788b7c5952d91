//! The figures of the study: mean gait cycles, frequency changes, the paper's Fig 5 and the
//! leave-one-subject-out errors.

use motionlab_core::registry;
use motionlab_core::{Error, ErrorKind, Motion, Result};
use motionlab_experiment::workflow::sanitize;
use motionlab_features::waveform::{cycles_by_side, mean_gait_cycle};
use motionlab_features::{AngleCurves, GaitCycle};
use motionlab_figure::{Chart, Figure, Pose, RefLine, Series, StickRow};
use motionlab_gait::change_rates::StudyChanges;
use motionlab_gait::loso::LosoResult;

use crate::drawing::{axis_name, main_floor_axis, stick_strip};

use super::{BuiltControl, GaitWorkflow, WalkRecord};

/// The other conditions, in order of first appearance, after the normal one.
pub(super) fn conditions_in_order(trials: &[WalkRecord], normal: &str) -> Vec<String> {
    let mut v = vec![normal.to_string()];
    for t in trials {
        if !v.contains(&t.condition) {
            v.push(t.condition.clone());
        }
    }
    v
}

/// The foot whose cycles frame a channel: its own side (`_l.` / `Left…` → Left), else the left.
pub(super) fn side_of(channel: &str) -> &'static str {
    let lower = channel.to_ascii_lowercase();
    if lower.contains("_r.") || lower.starts_with("right") { "Right" } else { "Left" }
}

const CYCLE_POINTS: usize = 101;

/// Mean gait cycle of one channel per condition, averaged over subjects (each subject's mean
/// cycle of the channel's own foot, time-normalised to 0–100 %).
pub(super) fn mean_cycle_figure(
    trials: &[WalkRecord],
    channel: &str,
    normal: &str,
    conditions: &[String],
) -> Result<Figure> {
    let side = side_of(channel);
    let mut lines = Vec::new();
    let mut found = false;
    for cond in conditions {
        let mut sum = vec![0.0; CYCLE_POINTS];
        let mut n = 0usize;
        for t in trials.iter().filter(|t| t.condition == *cond) {
            let Ok(k) = t.curves.channel_index(channel) else { continue };
            found = true;
            let groups = cycles_by_side(&t.cycles);
            let Some((_, cycles)) = groups.iter().find(|(s, _)| s.eq_ignore_ascii_case(side))
            else {
                continue;
            };
            if let Some(m) = mean_gait_cycle(&t.curves.values[k], cycles, CYCLE_POINTS) {
                sum.iter_mut().zip(&m).for_each(|(s, v)| *s += v);
                n += 1;
            }
        }
        if n > 0 {
            let x: Vec<f64> =
                (0..CYCLE_POINTS).map(|i| i as f64 * 100.0 / (CYCLE_POINTS - 1) as f64).collect();
            lines.push(Series::new(
                format!("{cond} (mean of {n} subjects)"),
                x,
                sum.iter().map(|s| s / n as f64).collect(),
            ));
        }
    }
    if !found {
        let names = trials.first().map(|t| t.curves.channels.clone()).unwrap_or_default();
        let close = registry::closest_names(channel, names.iter().map(String::as_str));
        return Err(Error::new(
            ErrorKind::UnknownName,
            format!(
                "figure channel {channel:?} is not a channel of the trials (closest: {})",
                close.join(", ")
            ),
        ));
    }
    Ok(Figure::chart(
        format!("mean_cycle_{}", sanitize(channel)),
        Chart {
            title: format!(
                "{channel}: mean gait cycle ({side} foot strike to strike), {normal} vs other conditions"
            ),
            x_label: "gait cycle (%)".into(),
            y_label: format!("{channel} (deg)"),
            lines,
            ..Default::default()
        },
    ))
}

/// K_j of the gait frequency per subject, one chart per condition, with μ as a line.
pub(super) fn frequency_figures(analysis: &StudyChanges) -> Result<Vec<Figure>> {
    Ok(analysis
        .conditions
        .iter()
        .map(|c| {
            let valid: Vec<(usize, &motionlab_gait::change_rates::FrequencyChange)> =
                c.frequency.iter().enumerate().filter(|(_, f)| f.k_pct.is_finite()).collect();
            let mut pts = Series::new("K_j", valid.iter().map(|(i, _)| (*i + 1) as f64).collect(), valid.iter().map(|(_, f)| f.k_pct).collect());
            pts.point_labels = valid.iter().map(|(_, f)| f.subject.clone()).collect();
            Figure::chart(
                format!("frequency_change_{}", sanitize(&c.condition)),
                Chart {
                    title: format!("Gait frequency change K_j per subject, {} vs {} (μ = {:.1} %, CV = {:.1} %)", c.condition, analysis.normal_condition, c.frequency_mean_pct, c.frequency_cv_pct),
                    x_label: "subject (number in study order)".into(),
                    y_label: "K_j (%)".into(),
                    points: vec![pts],
                    hlines: vec![RefLine { label: "μ".into(), value: c.frequency_mean_pct }],
                    // Room for the last point's label.
                    x_range: Some((0.5, c.frequency.len() as f64 + 1.5)),
                    ..Default::default()
                },
            )
        })
        .collect())
}

impl GaitWorkflow {
    /// The paper's Fig 5: recorded normal walk and synthesised walk, a stick figure every
    /// `strip_every_frames` frames from a frame inside each walk's middle gait cycle.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn fig5(
        &self,
        c: &BuiltControl,
        walk: &WalkRecord,
        recorded: &Motion,
        synthesised: &Motion,
        recorded_curves: &AngleCurves,
        synth_curves: &AngleCurves,
        synth_cycles: &[GaitCycle],
        analysis: &StudyChanges,
    ) -> Result<Figure> {
        let spec = &c.spec;
        let bones = recorded.skeleton.as_ref().map(|s| s.skeleton.bones()).unwrap_or_default();
        let start_in =
            |curves: &AngleCurves, cycles: &[GaitCycle], n_frames: usize| -> Result<usize> {
                let mut sorted: Vec<&GaitCycle> = cycles.iter().collect();
                sorted.sort_by_key(|c| c.start);
                let Some(mid) = sorted.get(sorted.len() / 2) else { return Ok(0) };
                let last_start =
                    n_frames.saturating_sub((spec.strip_poses - 1) * spec.strip_every_frames + 1);
                let (a, b) = (mid.start.min(last_start), mid.end.min(last_start));
                let Some([ca, cb]) = &spec.strip_start else { return Ok(a) };
                let index = |ch: &str| {
                    curves
                        .channel_index(ch)
                        .map_err(|e| self.config_error("gait.control.strip_start", e))
                };
                let (ia, ib) = (index(ca)?, index(cb)?);
                Ok((a..=b)
                    .min_by(|x, y| {
                        (curves.values[ia][*x] - curves.values[ib][*x])
                            .abs()
                            .total_cmp(&(curves.values[ia][*y] - curves.values[ib][*y]).abs())
                    })
                    .unwrap_or(a))
            };
        let root = Some(0);
        let row = |m: &Motion, label: &str, start: usize| {
            let frames: Vec<usize> = (0..spec.strip_poses)
                .map(|k| start + k * spec.strip_every_frames)
                .filter(|f| *f < m.n_frames())
                .collect();
            let axis = match (frames.first(), frames.last()) {
                (Some(&a), Some(&b)) => main_floor_axis(m, root, a, b),
                _ => m.up_axis().others()[0],
            };
            let up = m.up_axis().index();
            let rate = m.frame_rate().hz();
            (
                StickRow {
                    label: label.to_string(),
                    poses: frames
                        .iter()
                        .map(|&f| Pose {
                            label: format!("{f} ({:.2} s)", f as f64 / rate),
                            points: m.frame(f).iter().map(|p| [p[axis], p[up]]).collect(),
                        })
                        .collect(),
                },
                axis,
            )
        };
        let s0 = start_in(recorded_curves, &walk.cycles, recorded.n_frames())?;
        let s1 = start_in(synth_curves, synth_cycles, synthesised.n_frames())?;
        let (r0, axis) = row(recorded, &format!("recorded {}", analysis.normal_condition), s0);
        let (r1, _) = row(synthesised, &format!("synthesised {}", spec.condition), s1);
        Ok(Figure::sticks(
            format!("fig5_{}", sanitize(&walk.sequence)),
            stick_strip(
                format!(
                    "{}: recorded {} walk and the synthesised {} walk, every {} frames (Osafune et al. Fig 5)",
                    walk.sequence,
                    analysis.normal_condition,
                    spec.condition,
                    spec.strip_every_frames
                ),
                bones,
                vec![r0, r1],
                format!(
                    "side view: {} horizontal, {} up (mm); each pose centred",
                    axis_name(axis),
                    recorded.up_axis()
                ),
            ),
        ))
    }
}

pub(super) fn loso_figure(loso: &LosoResult, normal: &str) -> Figure {
    let x: Vec<f64> = (1..=loso.subjects.len()).map(|i| i as f64).collect();
    let series =
        |label: String, f: fn(&motionlab_gait::loso::LosoSubjectRecord) -> f64, labelled: bool| {
            let mut s = Series::new(label, x.clone(), loso.subjects.iter().map(f).collect());
            if labelled {
                s.point_labels = loso.subjects.iter().map(|r| r.subject.clone()).collect();
            }
            s
        };
    Figure::chart(
        format!("loso_rms_{}", sanitize(&loso.target_condition)),
        Chart {
            title: format!(
                "Leave-one-subject-out: mean RMS error per held-out subject against the recorded {} walk",
                loso.target_condition
            ),
            x_label: "held-out subject (number in study order)".into(),
            y_label: "mean RMS error over channels (deg)".into(),
            points: vec![
                series(format!("synthesised {}", loso.target_condition), |r| r.rms_synth_deg, true),
                series(format!("unchanged {normal}"), |r| r.rms_normal_deg, false),
            ],
            x_range: Some((0.5, loso.subjects.len() as f64 + 1.5)),
            hlines: vec![
                RefLine { label: "mean, synthesised".into(), value: loso.mean.rms_synth_deg },
                RefLine {
                    label: format!("mean, unchanged {normal}"),
                    value: loso.mean.rms_normal_deg,
                },
            ],
            ..Default::default()
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn side_of_reads_the_channel_side() {
        assert_eq!(side_of("knee_r.flexion"), "Right");
        assert_eq!(side_of("RightKnee.Xrotation"), "Right");
        assert_eq!(side_of("knee_l.flexion"), "Left");
        assert_eq!(side_of("lumbar.flexion"), "Left");
    }
}
