//! The tables of the study: the trials, the paper's Tables 2–3 and the leave-one-subject-out
//! verdict.

use serde::Serialize;

use motionlab_core::{Result, Table};
use motionlab_gait::change_rates::{Component, StudyChanges};
use motionlab_gait::loso::LosoResult;

use super::{GaitWorkflow, TABLE_POSTURE, TABLE_SIZE, WalkRecord};

#[derive(Serialize)]
struct TrialRow {
    sequence: String,
    subject: String,
    condition: String,
    n_frames: usize,
    n_cycles_left: usize,
    n_cycles_right: usize,
    mean_cycle_s: f64,
    frequency_hz: f64,
    n_channels: usize,
    /// Channels without a complete cycle (NaN DC): absent markers or gaps, excluded from K.
    n_channels_undefined: usize,
}

pub(super) fn trials_table(trials: &[WalkRecord]) -> Result<Table> {
    let rows: Vec<TrialRow> = trials
        .iter()
        .map(|r| {
            let count =
                |side: &str| r.cycles.iter().filter(|c| c.side.eq_ignore_ascii_case(side)).count();
            let rate = r.curves.frame_rate.hz();
            let mean_frames = if r.cycles.is_empty() {
                f64::NAN
            } else {
                r.cycles.iter().map(|c| (c.end - c.start) as f64).sum::<f64>()
                    / r.cycles.len() as f64
            };
            TrialRow {
                sequence: r.sequence.clone(),
                subject: r.subject.clone(),
                condition: r.condition.clone(),
                n_frames: r.n_frames,
                n_cycles_left: count("left"),
                n_cycles_right: count("right"),
                mean_cycle_s: mean_frames / rate,
                frequency_hz: r.parameters.frequency_hz,
                n_channels: r.parameters.channels.len(),
                n_channels_undefined: r.parameters.dc.iter().filter(|v| !v.is_finite()).count(),
            }
        })
        .collect();
    Table::from_records(
        "trials",
        "Trials: subject, condition, gait cycles and channels without a complete cycle",
        &rows,
    )
}

#[derive(Serialize)]
struct PaperRow {
    normal_condition: String,
    condition: String,
    channel: String,
    mean_pct: f64,
    sd_pct: f64,
    cv_pct: f64,
    n_subjects: usize,
    n_excluded: usize,
    /// |CV| within the threshold (and enough subjects): a feature channel here.
    feature: bool,
    /// Listed in the paper's table (`[[published]]`): kept even when it is no feature here.
    in_paper: bool,
}

/// Table 2 (posture: `Component::Dc`) or 3 (size: `Component::Amplitude`) in the paper's form:
/// mean, s.d. and CV of K for the feature channels of each condition, plus the channels in
/// `listed` (the paper's rows, from `[[published]]`) even when they are no feature here.
fn paper_table(
    analysis: &StudyChanges,
    component: Component,
    listed: &[String],
    max_abs_cv_pct: f64,
) -> Result<Table> {
    let rows: Vec<PaperRow> = analysis
        .conditions
        .iter()
        .flat_map(|c| {
            c.summary
                .iter()
                .filter(move |s| {
                    s.component == component && (s.feature || listed.contains(&s.channel))
                })
                .map(move |s| PaperRow {
                    normal_condition: analysis.normal_condition.clone(),
                    condition: c.condition.clone(),
                    channel: s.channel.clone(),
                    mean_pct: s.mean_pct,
                    sd_pct: s.sd_pct,
                    cv_pct: s.cv_pct,
                    n_subjects: s.n_subjects,
                    n_excluded: s.n_excluded,
                    feature: s.feature,
                    in_paper: listed.contains(&s.channel),
                })
        })
        .collect();
    let (name, what, number) = match component {
        Component::Dc => (TABLE_POSTURE, "posture (DC)", 2),
        Component::Amplitude => (TABLE_SIZE, "size (amplitude)", 3),
    };
    Table::from_records(
        name,
        format!(
            "Feature channels of {what}: mean, s.d. and CV of K over subjects (|CV| ≤ {max_abs_cv_pct} %; Osafune et al. Table {number})"
        ),
        &rows,
    )
}

impl GaitWorkflow {
    pub(super) fn paper_tables(
        &self,
        analysis: &StudyChanges,
        max_abs_cv_pct: f64,
    ) -> Result<Vec<Table>> {
        [(TABLE_POSTURE, Component::Dc), (TABLE_SIZE, Component::Amplitude)]
            .into_iter()
            .map(|(name, component)| {
                let listed = self.published_channels.get(name).cloned().unwrap_or_default();
                paper_table(analysis, component, &listed, max_abs_cv_pct)
            })
            .collect()
    }
}

#[derive(Serialize)]
struct VerdictRow {
    normal_condition: String,
    condition: String,
    n_subjects: usize,
    rms_synth_deg: f64,
    rms_normal_deg: f64,
    rms_synth_controlled_deg: f64,
    rms_normal_controlled_deg: f64,
    dtw_synth_deg: f64,
    dtw_normal_deg: f64,
    /// Mean |f_synthesised − f_recorded| and |f_normal − f_recorded| (Hz).
    frequency_error_synth_hz: f64,
    frequency_error_normal_hz: f64,
    /// Subjects whose synthesised walk has the lower mean RMS error.
    subjects_synth_better_rms: usize,
    beats_baseline_rms: bool,
    beats_baseline_dtw: bool,
    verdict: String,
}

pub(super) fn loso_verdict(loso: &LosoResult, normal: &str) -> Result<Table> {
    let m = &loso.mean;
    let mean_abs = |f: fn(&motionlab_gait::loso::LosoSubjectRecord) -> f64| {
        let v: Vec<f64> = loso.subjects.iter().map(f).filter(|x| x.is_finite()).collect();
        if v.is_empty() { f64::NAN } else { v.iter().sum::<f64>() / v.len() as f64 }
    };
    let beats_rms = m.rms_synth_deg < m.rms_normal_deg;
    let beats_dtw = m.dtw_synth_deg < m.dtw_normal_deg;
    let verdict = match (beats_rms, beats_dtw) {
        (true, true) => {
            "feature-channel control beats the unchanged normal walk on shape (RMS and DTW)"
        }
        (true, false) => {
            "feature-channel control beats the unchanged normal walk on RMS but not on DTW"
        }
        (false, true) => {
            "feature-channel control beats the unchanged normal walk on DTW but not on RMS"
        }
        (false, false) => {
            "feature-channel control does not beat the unchanged normal walk on shape (RMS or DTW)"
        }
    };
    Table::from_records(
        "loso_verdict",
        format!(
            "Leave-one-subject-out verdict: synthesised {} walk vs the unchanged {normal} walk, mean over subjects",
            loso.target_condition
        ),
        &[VerdictRow {
            normal_condition: normal.to_string(),
            condition: loso.target_condition.clone(),
            n_subjects: loso.subjects.len(),
            rms_synth_deg: m.rms_synth_deg,
            rms_normal_deg: m.rms_normal_deg,
            rms_synth_controlled_deg: m.rms_synth_controlled_deg,
            rms_normal_controlled_deg: m.rms_normal_controlled_deg,
            dtw_synth_deg: m.dtw_synth_deg,
            dtw_normal_deg: m.dtw_normal_deg,
            frequency_error_synth_hz: mean_abs(|r| {
                (r.frequency_synth_hz - r.frequency_recorded_hz).abs()
            }),
            frequency_error_normal_hz: mean_abs(|r| {
                (r.frequency_normal_hz - r.frequency_recorded_hz).abs()
            }),
            subjects_synth_better_rms: loso
                .subjects
                .iter()
                .filter(|r| r.rms_synth_deg < r.rms_normal_deg)
                .count(),
            beats_baseline_rms: beats_rms,
            beats_baseline_dtw: beats_dtw,
            verdict: verdict.to_string(),
        }],
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_core::registry::ParamGuard;
    use motionlab_gait::change_rates::ChangeRatesParams;

    fn trial(
        subject: &str,
        condition: &str,
        dc: [f64; 2],
        amplitude: [f64; 2],
        f: f64,
    ) -> motionlab_gait::stages::GaitTrial {
        motionlab_gait::stages::GaitTrial::hand_made(subject, condition, dc, amplitude, f)
    }

    /// Knee DC K = 20, 10, 30 % (CV 40.8 %: a feature); hip-rotation DC K = 20, −20, 0 %
    /// (μ = 0: no feature); amplitudes K = 10, 10, 10 % and 50, −50, 50 %.
    fn analysis(max_abs_cv_pct: f64) -> StudyChanges {
        let study = motionlab_gait::GaitStudy {
            normal_condition: "walk".into(),
            trials: vec![
                trial("a", "walk", [20.0, 10.0], [30.0, 4.0], 1.0),
                trial("b", "walk", [10.0, -10.0], [20.0, 4.0], 1.0),
                trial("c", "walk", [40.0, 10.0], [10.0, 4.0], 1.0),
                trial("a", "run", [24.0, 12.0], [33.0, 6.0], 1.2),
                trial("b", "run", [11.0, -8.0], [22.0, 2.0], 1.2),
                trial("c", "run", [52.0, 10.0], [11.0, 6.0], 1.2),
            ],
        };
        ChangeRatesParams { min_subjects: 2, max_abs_cv_pct, ..Default::default() }
            .check()
            .unwrap()
            .analyse(&study)
            .unwrap()
    }

    fn text(t: &Table, col: &str) -> Vec<String> {
        (0..t.n_rows()).map(|r| t.column(col).unwrap().cell(r)).collect()
    }

    #[test]
    fn paper_tables_hold_the_feature_channels_and_the_papers_rows() {
        let a = analysis(250.0);
        let t = paper_table(&a, Component::Dc, &[], 250.0).unwrap();
        assert_eq!(t.name, TABLE_POSTURE);
        assert_eq!(text(&t, "channel"), ["knee_l.flexion"]);
        assert_eq!(text(&t, "condition"), ["run"]);
        let sd = (200.0f64 / 3.0).sqrt();
        match (t.column("mean_pct"), t.column("cv_pct")) {
            (
                Some(motionlab_core::ColumnValues::F64(m)),
                Some(motionlab_core::ColumnValues::F64(v)),
            ) => {
                assert!(
                    (m[0] - 20.0).abs() < 1e-12 && (v[0] - sd / 20.0 * 100.0).abs() < 1e-12,
                    "{m:?} {v:?}"
                );
            }
            other => panic!("{other:?}"),
        }
        // A channel the paper lists stays, flagged: no feature here (μ = 0 → CV undefined).
        let t = paper_table(
            &a,
            Component::Dc,
            &["hip_l.rotation".to_string(), "upper chest".to_string()],
            250.0,
        )
        .unwrap();
        assert_eq!(text(&t, "channel"), ["knee_l.flexion", "hip_l.rotation"]);
        assert_eq!(text(&t, "feature"), ["true", "false"]);
        assert_eq!(text(&t, "in_paper"), ["false", "true"]);
        // Size: knee amplitude K = 10 % for all (CV 0); hip rotation 50, −50, 50 % (CV 282.8 %).
        let t = paper_table(&a, Component::Amplitude, &[], 250.0).unwrap();
        assert_eq!(t.name, TABLE_SIZE);
        assert_eq!(text(&t, "channel"), ["knee_l.flexion"]);
        // The feature flag is the analysis's (its threshold), not re-decided by the table.
        let t = paper_table(&analysis(300.0), Component::Amplitude, &[], 300.0).unwrap();
        assert_eq!(text(&t, "channel"), ["knee_l.flexion", "hip_l.rotation"]);
    }

    fn subject_record(
        subject: &str,
        rms: (f64, f64),
        dtw: (f64, f64),
        f: (f64, f64, f64),
    ) -> motionlab_gait::loso::LosoSubjectRecord {
        motionlab_gait::loso::LosoSubjectRecord {
            subject: subject.into(),
            n_channels: 2,
            n_controlled: 1,
            rms_synth_deg: rms.0,
            rms_normal_deg: rms.1,
            rms_synth_controlled_deg: rms.0,
            rms_normal_controlled_deg: rms.1,
            dtw_synth_deg: dtw.0,
            dtw_normal_deg: dtw.1,
            frequency_normal_hz: f.0,
            frequency_synth_hz: f.1,
            frequency_recorded_hz: f.2,
        }
    }

    #[test]
    fn the_verdict_follows_the_means_and_counts_subjects() {
        let subjects = vec![
            subject_record("a", (2.0, 3.0), (1.0, 1.5), (1.0, 1.2, 1.25)),
            subject_record("b", (4.0, 3.5), (2.0, 1.5), (0.8, 0.96, 0.9)),
        ];
        let mean = subject_record("mean", (3.0, 3.25), (1.5, 1.5), (0.9, 1.08, 1.075));
        let loso = LosoResult {
            target_condition: "run".into(),
            channels: vec![],
            subjects,
            channel_means: vec![],
            mean,
            changes: vec![],
            skipped: vec![],
        };
        let t = loso_verdict(&loso, "walk").unwrap();
        assert_eq!(t.n_rows(), 1);
        assert_eq!(text(&t, "beats_baseline_rms"), ["true"]);
        // DTW ties: not beaten.
        assert_eq!(text(&t, "beats_baseline_dtw"), ["false"]);
        assert_eq!(text(&t, "subjects_synth_better_rms"), ["1"]);
        // |1.2 − 1.25| and |0.96 − 0.9| → 0.055; |1 − 1.25| and |0.8 − 0.9| → 0.175.
        match (t.column("frequency_error_synth_hz"), t.column("frequency_error_normal_hz")) {
            (
                Some(motionlab_core::ColumnValues::F64(s)),
                Some(motionlab_core::ColumnValues::F64(n)),
            ) => {
                assert!(
                    (s[0] - 0.055).abs() < 1e-12 && (n[0] - 0.175).abs() < 1e-12,
                    "{s:?} {n:?}"
                );
            }
            other => panic!("{other:?}"),
        }
        assert!(text(&t, "verdict")[0].contains("on RMS but not on DTW"));
    }
}
