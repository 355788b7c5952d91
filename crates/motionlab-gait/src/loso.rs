//! Leave-one-subject-out evaluation of walk control — the evaluation Osafune et al. ask for in
//! §5 but never ran: how close is a synthesised walk to the recorded one?
//!
//! For each subject `j` with a walk in both the normal and the target condition:
//! 1. change rates, feature channels and μ are estimated from the **other** subjects only
//!    ([`ChangeRates::analyse`] on the study without `j`);
//! 2. `j`'s target walk is synthesised from `j`'s normal walk with those μ (any
//!    [`WalkSynthesizer`], normally `feature_channel_control`);
//! 3. synthesised and — as the baseline — unchanged normal walk are compared with `j`'s recorded
//!    target walk, channel by channel.
//!
//! ## Alignment and distances
//!
//! Each walk is reduced, per channel and per foot, to its **mean gait cycle time-normalised to
//! `points` samples** (cycles of the same foot averaged point by point, as `waveform_parameters`
//! does; the synthesised walk's cycles are the normal walk's cycles divided by the time factor
//! `s = 1 + μ_f/100`). Time normalisation removes the tempo, which is compared separately as the
//! gait frequency. Per channel:
//! - **RMS error** (degrees): `√(mean over feet and samples of (a − b)²)`;
//! - **DTW distance** (degrees): full DTW (`motionlab_match::dp::dtw_full_1d`, `|a − b|` summed
//!   along the best path) of the two mean cycles of each foot, divided by the path length (so it
//!   is a mean absolute deviation after warping, comparable to the RMS), averaged over feet.
//!
//! A channel or foot with no complete cycle in one of the three walks is left out (not counted
//! in `n_channels`), and a feature channel whose DC or amplitude is undefined in the held-out
//! normal walk is not changed for that subject. Means over channels skip NaN.

use serde::Serialize;

use crate::{WalkChanges, WalkSynthesizer};
use motionlab_core::{Error, ErrorKind, Result, Table};
use motionlab_features::waveform::{cycles_by_side, mean_cycle_between};
use motionlab_match::dp::dtw_full_1d;

use crate::change_rates::ChangeRates;
use crate::study::{SubjectWalk, Walk, study_of};
use crate::synthesis::speed_factor;

/// One channel of one held-out subject.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LosoChannelRecord {
    pub subject: String,
    pub channel: String,
    /// Which components the synthesis changed: `dc`, `amplitude`, `dc+amplitude` or `none`.
    pub controlled: &'static str,
    pub rms_synth_deg: f64,
    pub rms_normal_deg: f64,
    pub dtw_synth_deg: f64,
    pub dtw_normal_deg: f64,
}

/// One held-out subject (or the mean over subjects, `subject = "mean"`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LosoSubjectRecord {
    pub subject: String,
    /// Channels compared.
    pub n_channels: usize,
    /// Of those, channels the synthesis changed (feature channels of this fold).
    pub n_controlled: usize,
    /// Mean over all compared channels.
    pub rms_synth_deg: f64,
    pub rms_normal_deg: f64,
    /// Mean over the controlled channels only.
    pub rms_synth_controlled_deg: f64,
    pub rms_normal_controlled_deg: f64,
    pub dtw_synth_deg: f64,
    pub dtw_normal_deg: f64,
    pub frequency_normal_hz: f64,
    pub frequency_synth_hz: f64,
    pub frequency_recorded_hz: f64,
}

/// Per-channel means over subjects.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LosoChannelMean {
    pub channel: String,
    pub n_subjects: usize,
    /// In how many folds the channel was controlled.
    pub n_controlled: usize,
    pub rms_synth_deg: f64,
    pub rms_normal_deg: f64,
    pub dtw_synth_deg: f64,
    pub dtw_normal_deg: f64,
}

/// The evaluation: per channel and subject, per subject, per channel, and the mean.
#[derive(Clone, Debug, PartialEq)]
pub struct LosoResult {
    pub target_condition: String,
    pub channels: Vec<LosoChannelRecord>,
    pub subjects: Vec<LosoSubjectRecord>,
    pub channel_means: Vec<LosoChannelMean>,
    pub mean: LosoSubjectRecord,
    /// The change rates used for each held-out subject.
    pub changes: Vec<(String, WalkChanges)>,
    /// Subjects without a walk in one of the two conditions.
    pub skipped: Vec<String>,
}

impl LosoResult {
    pub fn tables(&self) -> Result<Vec<Table>> {
        let mut subjects = self.subjects.clone();
        subjects.push(self.mean.clone());
        Ok(vec![
            Table::from_records(
                "loso_subjects",
                format!(
                    "Leave-one-subject-out: synthesised vs unchanged normal walk against the recorded {} walk, per subject",
                    self.target_condition
                ),
                &subjects,
            )?,
            Table::from_records(
                "loso_channels",
                "Leave-one-subject-out errors per subject and channel",
                &self.channels,
            )?,
            Table::from_records(
                "loso_channel_means",
                "Leave-one-subject-out errors per channel, mean over subjects",
                &self.channel_means,
            )?,
        ])
    }
}

fn mean_finite(v: impl IntoIterator<Item = f64>) -> f64 {
    let (s, n) =
        v.into_iter().filter(|x| x.is_finite()).fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    if n == 0 { f64::NAN } else { s / n as f64 }
}

/// Per-foot mean gait cycles of one channel, keyed by side; the walk's cycles are divided by
/// `scale` (the synthesised walk plays `scale` times faster than the walk its cycles came from).
fn side_cycles(values: &[f64], walk: &Walk, scale: f64, points: usize) -> Vec<(String, Vec<f64>)> {
    cycles_by_side(&walk.cycles)
        .into_iter()
        .filter_map(|(side, group)| {
            let spans: Vec<(f64, f64)> =
                group.iter().map(|c| (c.start as f64 / scale, c.end as f64 / scale)).collect();
            mean_cycle_between(values, &spans, points).map(|m| (side.to_string(), m))
        })
        .collect()
}

/// RMS and DTW path-mean distance between two sets of per-foot mean cycles (feet in both only).
fn distances(a: &[(String, Vec<f64>)], b: &[(String, Vec<f64>)]) -> Result<(f64, f64)> {
    let (mut sq, mut n, mut dtw, mut feet) = (0.0, 0usize, 0.0, 0usize);
    for (side, ca) in a {
        let Some((_, cb)) = b.iter().find(|(s, _)| s == side) else { continue };
        sq += ca.iter().zip(cb).map(|(x, y)| (x - y) * (x - y)).sum::<f64>();
        n += ca.len();
        let (cost, path) = dtw_full_1d(ca, cb)?;
        dtw += cost / path.len() as f64;
        feet += 1;
    }
    Ok(if feet == 0 { (f64::NAN, f64::NAN) } else { ((sq / n as f64).sqrt(), dtw / feet as f64) })
}

/// Leave-one-subject-out evaluation of a walk synthesizer (see the module docs).
///
/// `walks` holds every subject's analysed walks (at least the `normal` and `target`
/// conditions; one walk per subject and condition). `points` is the time normalisation
/// (101 = every 1 % of the cycle).
pub fn leave_one_subject_out(
    walks: &[SubjectWalk],
    normal: &str,
    target: &str,
    rates: &ChangeRates,
    synthesizer: &dyn WalkSynthesizer,
    points: usize,
) -> Result<LosoResult> {
    if points < 2 {
        return Err(Error::new(
            ErrorKind::OutOfRange,
            format!("points must be at least 2, found {points}"),
        )
        .with_field("points"));
    }
    let mut subjects: Vec<&str> = Vec::new();
    for w in walks {
        if !subjects.contains(&w.subject.as_str()) {
            subjects.push(&w.subject);
        }
    }
    let find = |s: &str, c: &str| walks.iter().find(|w| w.subject == s && w.condition == c);
    let mut channels = Vec::new();
    let mut per_subject = Vec::new();
    let mut used_changes = Vec::new();
    let mut skipped = Vec::new();
    for &subject in &subjects {
        let (Some(nw), Some(tw)) = (find(subject, normal), find(subject, target)) else {
            skipped.push(subject.to_string());
            continue;
        };
        let others: Vec<SubjectWalk> =
            walks.iter().filter(|w| w.subject != subject).cloned().collect();
        let analysis = rates.analyse(&study_of(normal, &others)).map_err(|e| {
            Error::new(
                e.kind(),
                format!("estimating change rates without subject {subject:?}: {}", e.message()),
            )
        })?;
        let mut changes = analysis.condition(target)?.walk_changes();
        // A feature channel this subject lacks (NaN parameters: absent markers, no complete
        // cycle) cannot be changed; it is left out of this subject's synthesis.
        let p = &nw.analysed.parameters;
        let defined = |ch: &String, values: &[f64]| {
            p.channels.iter().position(|c| c == ch).is_some_and(|i| values[i].is_finite())
        };
        changes.dc_percent.retain(|ch, _| defined(ch, &p.dc));
        changes.amplitude_percent.retain(|ch, _| defined(ch, &p.amplitude));
        let s = speed_factor(&changes)?;
        let normal_walk = &nw.analysed.walk;
        let synth = synthesizer.synthesize(&normal_walk.curves, &normal_walk.cycles, &changes)?;
        let recorded = &tw.analysed.walk;
        let mut records = Vec::new();
        for (c, name) in normal_walk.curves.channels.iter().enumerate() {
            let Ok(t) = recorded.curves.channel_index(name) else { continue };
            let Ok(sc) = synth.channel_index(name) else { continue };
            let rec = side_cycles(&recorded.curves.values[t], recorded, 1.0, points);
            let nor = side_cycles(&normal_walk.curves.values[c], normal_walk, 1.0, points);
            let syn = side_cycles(&synth.values[sc], normal_walk, s, points);
            let (rms_synth_deg, dtw_synth_deg) = distances(&syn, &rec)?;
            let (rms_normal_deg, dtw_normal_deg) = distances(&nor, &rec)?;
            if !(rms_synth_deg.is_finite() && rms_normal_deg.is_finite()) {
                continue;
            }
            let controlled = match (
                changes.dc_percent.contains_key(name),
                changes.amplitude_percent.contains_key(name),
            ) {
                (true, true) => "dc+amplitude",
                (true, false) => "dc",
                (false, true) => "amplitude",
                (false, false) => "none",
            };
            records.push(LosoChannelRecord {
                subject: subject.to_string(),
                channel: name.clone(),
                controlled,
                rms_synth_deg,
                rms_normal_deg,
                dtw_synth_deg,
                dtw_normal_deg,
            });
        }
        let controlled: Vec<&LosoChannelRecord> =
            records.iter().filter(|r| r.controlled != "none").collect();
        per_subject.push(LosoSubjectRecord {
            subject: subject.to_string(),
            n_channels: records.len(),
            n_controlled: controlled.len(),
            rms_synth_deg: mean_finite(records.iter().map(|r| r.rms_synth_deg)),
            rms_normal_deg: mean_finite(records.iter().map(|r| r.rms_normal_deg)),
            rms_synth_controlled_deg: mean_finite(controlled.iter().map(|r| r.rms_synth_deg)),
            rms_normal_controlled_deg: mean_finite(controlled.iter().map(|r| r.rms_normal_deg)),
            dtw_synth_deg: mean_finite(records.iter().map(|r| r.dtw_synth_deg)),
            dtw_normal_deg: mean_finite(records.iter().map(|r| r.dtw_normal_deg)),
            frequency_normal_hz: nw.analysed.parameters.frequency_hz,
            frequency_synth_hz: nw.analysed.parameters.frequency_hz * s,
            frequency_recorded_hz: tw.analysed.parameters.frequency_hz,
        });
        channels.extend(records);
        used_changes.push((subject.to_string(), changes));
    }
    if per_subject.is_empty() {
        return Err(Error::new(
            ErrorKind::EmptySequence,
            format!(
                "no subject has walks in both {normal:?} and {target:?}; leave-one-subject-out needs at least one"
            ),
        ));
    }
    let avg = |f: fn(&LosoSubjectRecord) -> f64| mean_finite(per_subject.iter().map(f));
    let mean = LosoSubjectRecord {
        subject: "mean".into(),
        n_channels: per_subject.iter().map(|r| r.n_channels).sum::<usize>() / per_subject.len(),
        n_controlled: per_subject.iter().map(|r| r.n_controlled).sum::<usize>() / per_subject.len(),
        rms_synth_deg: avg(|r| r.rms_synth_deg),
        rms_normal_deg: avg(|r| r.rms_normal_deg),
        rms_synth_controlled_deg: avg(|r| r.rms_synth_controlled_deg),
        rms_normal_controlled_deg: avg(|r| r.rms_normal_controlled_deg),
        dtw_synth_deg: avg(|r| r.dtw_synth_deg),
        dtw_normal_deg: avg(|r| r.dtw_normal_deg),
        frequency_normal_hz: avg(|r| r.frequency_normal_hz),
        frequency_synth_hz: avg(|r| r.frequency_synth_hz),
        frequency_recorded_hz: avg(|r| r.frequency_recorded_hz),
    };
    let mut channel_names: Vec<&str> = Vec::new();
    for r in &channels {
        if !channel_names.contains(&r.channel.as_str()) {
            channel_names.push(&r.channel);
        }
    }
    let channel_means = channel_names
        .iter()
        .map(|name| {
            let rs: Vec<&LosoChannelRecord> =
                channels.iter().filter(|r| r.channel == *name).collect();
            LosoChannelMean {
                channel: name.to_string(),
                n_subjects: rs.len(),
                n_controlled: rs.iter().filter(|r| r.controlled != "none").count(),
                rms_synth_deg: mean_finite(rs.iter().map(|r| r.rms_synth_deg)),
                rms_normal_deg: mean_finite(rs.iter().map(|r| r.rms_normal_deg)),
                dtw_synth_deg: mean_finite(rs.iter().map(|r| r.dtw_synth_deg)),
                dtw_normal_deg: mean_finite(rs.iter().map(|r| r.dtw_normal_deg)),
            }
        })
        .collect();
    Ok(LosoResult {
        target_condition: target.to_string(),
        channels,
        subjects: per_subject,
        channel_means,
        mean,
        changes: used_changes,
        skipped,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::change_rates::ChangeRatesParams;
    use crate::study::AnalysedWalk;
    use crate::synthesis::FeatureChannelControl;
    use motionlab_core::FrameRate;
    use motionlab_core::registry::ParamGuard;
    use motionlab_features::waveform::WaveformParametersParams;
    use motionlab_features::{AngleCurves, GaitCycle, WaveformAnalyzer};
    use std::f64::consts::TAU;

    /// A two-channel walk: `knee` with DC `dc` and amplitude `amp`, `hip` a fixed waveform,
    /// `period` frames per cycle, three left cycles.
    fn walk(subject: &str, condition: &str, dc: f64, amp: f64, period: usize) -> SubjectWalk {
        let n = 3 * period + 5;
        let knee: Vec<f64> =
            (0..n).map(|i| dc + amp * (TAU * i as f64 / period as f64).sin()).collect();
        let hip: Vec<f64> =
            (0..n).map(|i| 10.0 + 20.0 * (TAU * i as f64 / period as f64).cos()).collect();
        let curves = AngleCurves {
            frame_rate: FrameRate::new(100.0).unwrap(),
            channels: vec!["knee".into(), "hip".into()],
            values: vec![knee, hip],
        };
        let cycles: Vec<GaitCycle> = (0..3)
            .map(|k| GaitCycle { start: k * period, end: (k + 1) * period, side: "Left".into() })
            .collect();
        let parameters = WaveformParametersParams::default()
            .check()
            .unwrap()
            .parameters(&curves, &cycles)
            .unwrap();
        SubjectWalk {
            subject: subject.into(),
            condition: condition.into(),
            analysed: AnalysedWalk { walk: Walk { curves, cycles }, parameters },
        }
    }

    #[test]
    fn control_with_the_population_change_recovers_a_consistent_subject() {
        // Every subject's fast walk has knee DC × 1.2, knee amplitude × 0.8 and frequency × 1.25
        // (120 → 96 frames per cycle): the leave-one-out μ is exactly that, so the synthesised
        // walk matches the recorded one (up to interpolation), while the normal walk does not.
        let mut walks = Vec::new();
        for (k, s) in ["a", "b", "c", "d", "e", "f"].iter().enumerate() {
            let (dc, amp) = (20.0 + 3.0 * k as f64, 30.0 - 2.0 * k as f64);
            walks.push(walk(s, "normal", dc, amp, 120));
            walks.push(walk(s, "fast", dc * 1.2, amp * 0.8, 96));
        }
        let rates = ChangeRatesParams::default().check().unwrap();
        let r = leave_one_subject_out(
            &walks,
            "normal",
            "fast",
            &rates,
            &FeatureChannelControl::default(),
            101,
        )
        .unwrap();
        assert_eq!(r.subjects.len(), 6);
        for (subject, c) in &r.changes {
            assert!((c.dc_percent["knee"] - 20.0).abs() < 1e-9, "{subject}");
            assert!((c.amplitude_percent["knee"] + 20.0).abs() < 1e-9, "{subject}");
            assert!((c.frequency_percent - 25.0).abs() < 1e-9, "{subject}");
        }
        for rec in r.channels.iter().filter(|c| c.channel == "knee") {
            assert_eq!(rec.controlled, "dc+amplitude");
            assert!(rec.rms_synth_deg < 0.05, "{rec:?}");
            assert!(rec.rms_normal_deg > 3.0, "{rec:?}");
            assert!(
                rec.dtw_synth_deg <= rec.rms_synth_deg + 1e-12 && rec.dtw_normal_deg > 1.0,
                "{rec:?}"
            );
        }
        // The hip never changes: both errors are only the time normalisation's interpolation.
        for rec in r.channels.iter().filter(|c| c.channel == "hip") {
            assert_eq!(rec.controlled, "none");
            assert!(rec.rms_normal_deg < 0.01 && rec.rms_synth_deg < 0.01, "{rec:?}");
        }
        assert!((r.mean.frequency_synth_hz - r.mean.frequency_recorded_hz).abs() < 1e-9);
        let t = r.tables().unwrap();
        assert_eq!(t[0].n_rows(), 7); // six subjects + mean
    }

    #[test]
    fn estimates_never_use_the_held_out_subject() {
        // Subject "x" alone changes its knee DC by +100 %; the others by +10 %. When x is held
        // out its μ must be 10 % (the others'), not a mean that includes its own 100 %.
        let mut walks = Vec::new();
        for s in ["a", "b", "c", "d", "e"] {
            walks.push(walk(s, "normal", 20.0, 30.0, 100));
            walks.push(walk(s, "fast", 22.0, 30.0, 100));
        }
        walks.push(walk("x", "normal", 20.0, 30.0, 100));
        walks.push(walk("x", "fast", 40.0, 30.0, 100));
        let rates =
            ChangeRatesParams { max_abs_cv_pct: 1000.0, ..Default::default() }.check().unwrap();
        let r = leave_one_subject_out(
            &walks,
            "normal",
            "fast",
            &rates,
            &FeatureChannelControl::default(),
            101,
        )
        .unwrap();
        let x = &r.changes.iter().find(|(s, _)| s == "x").unwrap().1;
        assert!((x.dc_percent["knee"] - 10.0).abs() < 1e-9);
        let a = &r.changes.iter().find(|(s, _)| s == "a").unwrap().1;
        assert!((a.dc_percent["knee"] - (10.0 * 4.0 + 100.0) / 5.0).abs() < 1e-9);
    }

    #[test]
    fn subjects_missing_a_condition_are_skipped_and_none_left_is_an_error() {
        let walks = vec![walk("a", "normal", 20.0, 30.0, 100), walk("b", "fast", 20.0, 30.0, 100)];
        let rates = ChangeRatesParams { min_subjects: 1, ..Default::default() }.check().unwrap();
        let e = leave_one_subject_out(
            &walks,
            "normal",
            "fast",
            &rates,
            &FeatureChannelControl::default(),
            101,
        )
        .unwrap_err();
        assert_eq!(e.kind(), ErrorKind::EmptySequence);
    }
}
