//! Change rates `K`, their mean, spread and coefficient of variation over subjects, and the
//! feature channels they select (Osafune et al. §2.3–2.4, Tables 1–3).

use std::collections::BTreeMap;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::{GaitStudy, GaitTrial, WalkChanges};
use motionlab_core::registry::ParamGuard;
use motionlab_core::{
    Analysis, Error, ErrorKind, EvalInput, EvalInputType, Evaluation, Evaluator, Result, Table,
};

/// Change rates of every channel from the normal walk to each other condition, their mean,
/// population s.d. and coefficient of variation over subjects, and the feature channels
/// (Osafune et al. §2.3–2.4, eqs. 1–4, Tables 1–3).
///
/// For each condition X other than the study's normal condition G, each subject j with a trial
/// in both, each channel i and each component (DC, amplitude):
/// `K_ij = (X_ij − G_ij) / G_ij × 100` (%); over the valid subjects `μ_i = (1/J) Σ_j K_ij`,
/// `σ_i = √((1/J) Σ_j (K_ij − μ_i)²)` (population) and the signed `CV_i = σ_i / μ_i × 100` (%).
/// A channel-component is a **feature** when `|CV_i| ≤ max_abs_cv_pct` and at least
/// `min_subjects` subjects are valid. Speed: `K_j` of the gait frequency per subject, with its
/// μ, σ and CV (always controlled, so always a feature).
///
/// Near-zero guard: a DC near 0° (or an amplitude near 0°) makes `K` a ratio of noise, so a
/// subject-channel pair is **excluded** (flagged `normal_near_zero`, never divided) when
/// `|G_ij| < min_abs_normal_dc_deg` (DC) or `G_ij < min_normal_amplitude_deg` (amplitude). The
/// paper (20 subjects, BVH channels) excluded nothing.
///
/// Missing samples: a parameter that is NaN (no complete gait cycle for that channel) or a
/// channel absent from one of the two trials excludes that subject-channel pair, flagged
/// `missing`. Subjects without a trial in X are not counted for X.
///
/// Tables: `gait_parameters` (subject, condition, channel, dc_deg, amplitude_deg,
/// frequency_hz), `change_rates` (per subject: normal_condition, condition, subject, channel,
/// component, normal_value, changed_value, k_pct, excluded, reason), `change_rate_summary` (the
/// paper's Tables 1–3: normal_condition, condition, channel, component, mean_pct, sd_pct,
/// cv_pct, feature, n_subjects, n_excluded, note) and `frequency_changes` (normal_condition,
/// condition, subject, normal_hz, changed_hz, k_pct). `bench/osafune_check.py` recomputes K, μ,
/// σ and CV from the first table.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ChangeRatesParams {
    /// A channel-component is a feature when `|CV| ≤` this (%; the default is the paper's value).
    #[serde(default = "default_max_abs_cv")]
    pub max_abs_cv_pct: f64,
    /// Exclude a subject's DC change when its normal DC is closer to 0 than this (degrees).
    #[serde(default = "default_min_dc")]
    pub min_abs_normal_dc_deg: f64,
    /// Exclude a subject's amplitude change when its normal amplitude is below this (degrees).
    #[serde(default = "default_min_amplitude")]
    pub min_normal_amplitude_deg: f64,
    /// A channel-component needs at least this many valid subjects to be a feature.
    #[serde(default = "default_min_subjects")]
    pub min_subjects: usize,
}

fn default_max_abs_cv() -> f64 {
    250.0
}
fn default_min_dc() -> f64 {
    5.0
}
fn default_min_amplitude() -> f64 {
    2.0
}
fn default_min_subjects() -> usize {
    5
}

impl Default for ChangeRatesParams {
    fn default() -> Self {
        ChangeRatesParams {
            max_abs_cv_pct: default_max_abs_cv(),
            min_abs_normal_dc_deg: default_min_dc(),
            min_normal_amplitude_deg: default_min_amplitude(),
            min_subjects: default_min_subjects(),
        }
    }
}

/// The validated evaluator.
#[derive(Clone, Debug, PartialEq)]
pub struct ChangeRates {
    pub max_abs_cv_pct: f64,
    pub min_abs_normal_dc_deg: f64,
    pub min_normal_amplitude_deg: f64,
    pub min_subjects: usize,
}

impl ParamGuard for ChangeRatesParams {
    type Checked = ChangeRates;
    fn check(self) -> Result<ChangeRates> {
        let non_negative = |field: &str, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(v)
            } else {
                Err(Error::new(
                    ErrorKind::OutOfRange,
                    format!("must be a finite number >= 0, found {v}"),
                )
                .with_field(field))
            }
        };
        if self.min_subjects == 0 {
            return Err(
                Error::new(ErrorKind::OutOfRange, "must be at least 1").with_field("min_subjects")
            );
        }
        Ok(ChangeRates {
            max_abs_cv_pct: non_negative("max_abs_cv_pct", self.max_abs_cv_pct)?,
            min_abs_normal_dc_deg: non_negative(
                "min_abs_normal_dc_deg",
                self.min_abs_normal_dc_deg,
            )?,
            min_normal_amplitude_deg: non_negative(
                "min_normal_amplitude_deg",
                self.min_normal_amplitude_deg,
            )?,
            min_subjects: self.min_subjects,
        })
    }
}

/// DC (posture) or amplitude (size).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Component {
    Dc,
    Amplitude,
}

impl Component {
    pub fn name(self) -> &'static str {
        match self {
            Component::Dc => "dc",
            Component::Amplitude => "amplitude",
        }
    }
}

/// Why a subject-channel pair has no change rate.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Exclusion {
    /// `|G| <` the near-zero threshold of the component.
    NormalNearZero,
    /// The channel is absent from a trial or its value is NaN.
    Missing,
}

impl Exclusion {
    pub fn name(self) -> &'static str {
        match self {
            Exclusion::NormalNearZero => "normal_near_zero",
            Exclusion::Missing => "missing",
        }
    }
}

/// One subject's change of one channel-component.
#[derive(Clone, Debug, PartialEq)]
pub struct SubjectChange {
    pub subject: String,
    pub channel: String,
    pub component: Component,
    /// `G_ij` (degrees; NaN when missing).
    pub normal: f64,
    /// `X_ij` (degrees; NaN when missing).
    pub changed: f64,
    /// `K_ij` in %, `None` when excluded.
    pub k_pct: Option<f64>,
    pub excluded: Option<Exclusion>,
}

/// μ, σ and CV of one channel-component over the valid subjects.
#[derive(Clone, Debug, PartialEq)]
pub struct ChannelSummary {
    pub channel: String,
    pub component: Component,
    pub mean_pct: f64,
    pub sd_pct: f64,
    pub cv_pct: f64,
    pub feature: bool,
    pub n_subjects: usize,
    pub n_excluded: usize,
    /// Why a channel is not a feature for a reason other than its CV (`too_few_subjects`,
    /// `mean_zero`), empty otherwise.
    pub note: String,
}

/// Mean, population s.d. and signed CV (%) of a sample; NaN CV when the mean is 0.
pub fn mean_sd_cv(k: &[f64]) -> (f64, f64, f64) {
    if k.is_empty() {
        return (f64::NAN, f64::NAN, f64::NAN);
    }
    let n = k.len() as f64;
    let mean = k.iter().sum::<f64>() / n;
    let sd = (k.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / n).sqrt();
    let cv = if mean == 0.0 { f64::NAN } else { sd / mean * 100.0 };
    (mean, sd, cv)
}

/// One subject's frequency change.
#[derive(Clone, Debug, PartialEq)]
pub struct FrequencyChange {
    pub subject: String,
    pub normal_hz: f64,
    pub changed_hz: f64,
    /// `K_j` in %; NaN when either frequency is not finite and > 0.
    pub k_pct: f64,
}

/// The analysis of one condition against the normal one.
#[derive(Clone, Debug, PartialEq)]
pub struct ConditionChanges {
    pub condition: String,
    /// Subjects with a trial in both conditions, in study order.
    pub subjects: Vec<String>,
    pub changes: Vec<SubjectChange>,
    pub summary: Vec<ChannelSummary>,
    pub frequency: Vec<FrequencyChange>,
    /// μ, σ, CV of the frequency change rates (%).
    pub frequency_mean_pct: f64,
    pub frequency_sd_pct: f64,
    pub frequency_cv_pct: f64,
}

impl ConditionChanges {
    /// The changes to apply to a normal walk to make this condition: μ of every feature
    /// channel (DC and amplitude separately) and μ of the frequency (Osafune et al. §4).
    pub fn walk_changes(&self) -> WalkChanges {
        let mut w =
            WalkChanges { frequency_percent: self.frequency_mean_pct, ..Default::default() };
        for s in self.summary.iter().filter(|s| s.feature) {
            let map = match s.component {
                Component::Dc => &mut w.dc_percent,
                Component::Amplitude => &mut w.amplitude_percent,
            };
            map.insert(s.channel.clone(), s.mean_pct);
        }
        w
    }
}

/// What `change_rates` hands a workflow beside its tables
/// ([`Evaluator::evaluate_with_analysis`]): the analysis, and the parameters it was made with
/// (a leave-one-out re-analyses each training fold with them).
#[derive(Clone, Debug, PartialEq)]
pub struct ChangeRateAnalysis {
    pub rates: ChangeRates,
    pub changes: StudyChanges,
}

/// Change rates of a study: one entry per condition other than the normal one.
#[derive(Clone, Debug, PartialEq)]
pub struct StudyChanges {
    pub normal_condition: String,
    pub conditions: Vec<ConditionChanges>,
}

impl StudyChanges {
    pub fn condition(&self, name: &str) -> Result<&ConditionChanges> {
        self.conditions.iter().find(|c| c.condition == name).ok_or_else(|| {
            let have: Vec<&str> = self.conditions.iter().map(|c| c.condition.as_str()).collect();
            Error::new(
                ErrorKind::UnknownName,
                format!(
                    "no condition {name:?} besides the normal {:?} (have: {have:?})",
                    self.normal_condition
                ),
            )
        })
    }
}

/// Checks a study: the normal condition has trials, another condition exists, no subject has
/// two trials in one condition, and each trial's channel and value lists have equal lengths.
pub fn check_study(study: &GaitStudy) -> Result<()> {
    let mut seen = std::collections::HashSet::new();
    for t in &study.trials {
        if !seen.insert((t.subject.as_str(), t.condition.as_str())) {
            return Err(Error::new(
                ErrorKind::DuplicateName,
                format!("subject {:?} has two trials in condition {:?}; give one per subject and condition (average upstream)", t.subject, t.condition),
            )
            .with_field(format!("{}/{}", t.subject, t.condition)));
        }
        let p = &t.parameters;
        if p.dc.len() != p.channels.len() || p.amplitude.len() != p.channels.len() {
            return Err(Error::new(
                ErrorKind::WrongValueCount,
                format!(
                    "trial {}/{} has {} channels but {} DC and {} amplitude values",
                    t.subject,
                    t.condition,
                    p.channels.len(),
                    p.dc.len(),
                    p.amplitude.len()
                ),
            ));
        }
    }
    if !study.trials.iter().any(|t| t.condition == study.normal_condition) {
        return Err(Error::new(
            ErrorKind::EmptySequence,
            format!("no trial in the normal condition {:?}", study.normal_condition),
        ));
    }
    if !study.trials.iter().any(|t| t.condition != study.normal_condition) {
        return Err(Error::new(
            ErrorKind::EmptySequence,
            format!(
                "every trial is in the normal condition {:?}; change rates need another condition",
                study.normal_condition
            ),
        ));
    }
    Ok(())
}

fn value_of(trial: &GaitTrial, channel: &str, component: Component) -> f64 {
    let p = &trial.parameters;
    match p.channels.iter().position(|c| c == channel) {
        Some(i) => match component {
            Component::Dc => p.dc[i],
            Component::Amplitude => p.amplitude[i],
        },
        None => f64::NAN,
    }
}

impl ChangeRates {
    /// Is `G` too close to zero for a meaningful rate?
    fn near_zero(&self, component: Component, normal: f64) -> bool {
        match component {
            Component::Dc => normal.abs() < self.min_abs_normal_dc_deg,
            Component::Amplitude => normal < self.min_normal_amplitude_deg,
        }
    }

    /// The full analysis of a study (every condition against the normal one).
    pub fn analyse(&self, study: &GaitStudy) -> Result<StudyChanges> {
        check_study(study)?;
        let g = &study.normal_condition;
        let mut conditions: Vec<&str> = Vec::new();
        let mut channels: Vec<&str> = Vec::new();
        for t in &study.trials {
            if t.condition != *g && !conditions.contains(&t.condition.as_str()) {
                conditions.push(&t.condition);
            }
            for c in &t.parameters.channels {
                if !channels.contains(&c.as_str()) {
                    channels.push(c);
                }
            }
        }
        let out = conditions
            .into_iter()
            .map(|x| {
                let pairs: Vec<(&GaitTrial, &GaitTrial)> = study
                    .trials
                    .iter()
                    .filter(|t| t.condition == *g)
                    .filter_map(|n| {
                        study
                            .trials
                            .iter()
                            .find(|t| t.condition == x && t.subject == n.subject)
                            .map(|c| (n, c))
                    })
                    .collect();
                self.analyse_condition(x, &pairs, &channels)
            })
            .collect();
        Ok(StudyChanges { normal_condition: g.clone(), conditions: out })
    }

    fn analyse_condition(
        &self,
        condition: &str,
        pairs: &[(&GaitTrial, &GaitTrial)],
        channels: &[&str],
    ) -> ConditionChanges {
        let mut changes = Vec::new();
        let mut summary = Vec::new();
        for component in [Component::Dc, Component::Amplitude] {
            for &channel in channels {
                let mut k = Vec::new();
                let mut n_excluded = 0;
                for (normal, changed) in pairs {
                    let (gv, xv) = (
                        value_of(normal, channel, component),
                        value_of(changed, channel, component),
                    );
                    let excluded = if !(gv.is_finite() && xv.is_finite()) {
                        Some(Exclusion::Missing)
                    } else if self.near_zero(component, gv) {
                        Some(Exclusion::NormalNearZero)
                    } else {
                        None
                    };
                    let k_pct = excluded.is_none().then(|| (xv - gv) / gv * 100.0);
                    match k_pct {
                        Some(v) => k.push(v),
                        None => n_excluded += 1,
                    }
                    changes.push(SubjectChange {
                        subject: normal.subject.clone(),
                        channel: channel.to_string(),
                        component,
                        normal: gv,
                        changed: xv,
                        k_pct,
                        excluded,
                    });
                }
                let (mean, sd, cv) = mean_sd_cv(&k);
                let note = if k.len() < self.min_subjects {
                    "too_few_subjects"
                } else if cv.is_nan() {
                    "mean_zero"
                } else {
                    ""
                };
                summary.push(ChannelSummary {
                    channel: channel.to_string(),
                    component,
                    mean_pct: mean,
                    sd_pct: sd,
                    cv_pct: cv,
                    feature: note.is_empty() && cv.abs() <= self.max_abs_cv_pct,
                    n_subjects: k.len(),
                    n_excluded,
                    note: note.to_string(),
                });
            }
        }
        let frequency: Vec<FrequencyChange> = pairs
            .iter()
            .map(|(n, c)| {
                let (gf, xf) = (n.parameters.frequency_hz, c.parameters.frequency_hz);
                let ok = gf.is_finite() && gf > 0.0 && xf.is_finite() && xf > 0.0;
                FrequencyChange {
                    subject: n.subject.clone(),
                    normal_hz: gf,
                    changed_hz: xf,
                    k_pct: if ok { (xf - gf) / gf * 100.0 } else { f64::NAN },
                }
            })
            .collect();
        let valid: Vec<f64> = frequency.iter().map(|f| f.k_pct).filter(|v| v.is_finite()).collect();
        let (frequency_mean_pct, frequency_sd_pct, frequency_cv_pct) = mean_sd_cv(&valid);
        ConditionChanges {
            condition: condition.to_string(),
            subjects: pairs.iter().map(|(n, _)| n.subject.clone()).collect(),
            changes,
            summary,
            frequency,
            frequency_mean_pct,
            frequency_sd_pct,
            frequency_cv_pct,
        }
    }

    /// The evaluator's tables (see [`ChangeRatesParams`]).
    pub fn tables(&self, study: &GaitStudy) -> Result<Vec<Table>> {
        self.tables_of(study, &self.analyse(study)?)
    }

    /// The evaluator's tables from an analysis of `study` already made.
    pub fn tables_of(&self, study: &GaitStudy, analysis: &StudyChanges) -> Result<Vec<Table>> {
        let g = &analysis.normal_condition;
        let parameters: Vec<ParameterRecord> = study
            .trials
            .iter()
            .flat_map(|t| {
                let p = &t.parameters;
                (0..p.channels.len()).map(move |i| ParameterRecord {
                    subject: t.subject.clone(),
                    condition: t.condition.clone(),
                    channel: p.channels[i].clone(),
                    dc_deg: p.dc[i],
                    amplitude_deg: p.amplitude[i],
                    frequency_hz: p.frequency_hz,
                })
            })
            .collect();
        let mut per_subject = Vec::new();
        let mut summary = Vec::new();
        let mut frequency = Vec::new();
        for c in &analysis.conditions {
            per_subject.extend(c.changes.iter().map(|s| ChangeRecord {
                normal_condition: g.clone(),
                condition: c.condition.clone(),
                subject: s.subject.clone(),
                channel: s.channel.clone(),
                component: s.component.name(),
                normal_value: s.normal,
                changed_value: s.changed,
                k_pct: s.k_pct.unwrap_or(f64::NAN),
                excluded: s.excluded.is_some(),
                reason: s.excluded.map(Exclusion::name).unwrap_or(""),
            }));
            summary.extend(c.summary.iter().map(|s| SummaryRecord {
                normal_condition: g.clone(),
                condition: c.condition.clone(),
                channel: s.channel.clone(),
                component: s.component.name(),
                mean_pct: s.mean_pct,
                sd_pct: s.sd_pct,
                cv_pct: s.cv_pct,
                feature: s.feature,
                n_subjects: s.n_subjects,
                n_excluded: s.n_excluded,
                note: s.note.clone(),
            }));
            let n_valid = c.frequency.iter().filter(|f| f.k_pct.is_finite()).count();
            summary.push(SummaryRecord {
                normal_condition: g.clone(),
                condition: c.condition.clone(),
                channel: "gait".into(),
                component: "frequency",
                mean_pct: c.frequency_mean_pct,
                sd_pct: c.frequency_sd_pct,
                cv_pct: c.frequency_cv_pct,
                feature: true,
                n_subjects: n_valid,
                n_excluded: c.frequency.len() - n_valid,
                note: String::new(),
            });
            frequency.extend(c.frequency.iter().map(|f| FrequencyRecord {
                normal_condition: g.clone(),
                condition: c.condition.clone(),
                subject: f.subject.clone(),
                normal_hz: f.normal_hz,
                changed_hz: f.changed_hz,
                k_pct: f.k_pct,
            }));
        }
        Ok(vec![
            Table::from_records(
                "gait_parameters",
                "Waveform parameters per subject, condition and channel",
                &parameters,
            )?,
            Table::from_records(
                "change_rates",
                "Change rates K per subject (Osafune et al. eq. 1)",
                &per_subject,
            )?,
            Table::from_records(
                "change_rate_summary",
                "Mean, s.d. and CV of K per channel (Osafune et al. Tables 1-3; feature = |CV| within the threshold)",
                &summary,
            )?,
            Table::from_records(
                "frequency_changes",
                "Gait frequency change K_j per subject (Osafune et al. §2.4)",
                &frequency,
            )?,
        ])
    }
}

#[derive(Serialize)]
struct ParameterRecord {
    subject: String,
    condition: String,
    channel: String,
    dc_deg: f64,
    amplitude_deg: f64,
    frequency_hz: f64,
}

#[derive(Serialize)]
struct ChangeRecord {
    normal_condition: String,
    condition: String,
    subject: String,
    channel: String,
    component: &'static str,
    normal_value: f64,
    changed_value: f64,
    k_pct: f64,
    excluded: bool,
    reason: &'static str,
}

#[derive(Serialize)]
struct SummaryRecord {
    normal_condition: String,
    condition: String,
    channel: String,
    component: &'static str,
    mean_pct: f64,
    sd_pct: f64,
    cv_pct: f64,
    feature: bool,
    n_subjects: usize,
    n_excluded: usize,
    note: String,
}

#[derive(Serialize)]
struct FrequencyRecord {
    normal_condition: String,
    condition: String,
    subject: String,
    normal_hz: f64,
    changed_hz: f64,
    k_pct: f64,
}

impl Evaluator for ChangeRates {
    fn input_type(&self) -> EvalInputType {
        crate::gait_study()
    }
    fn evaluate(&self, input: EvalInput<'_>) -> Result<Vec<Table>> {
        self.evaluate_with_analysis(input).map(|e| e.tables)
    }
    /// The tables and the [`ChangeRateAnalysis`] behind them (the gait workflow's Tables 2–3,
    /// control and leave-one-out build on it).
    fn evaluate_with_analysis(&self, input: EvalInput<'_>) -> Result<Evaluation> {
        let study: &GaitStudy = input.read(crate::gait_study(), "change_rates")?;
        let changes = self.analyse(study)?;
        let tables = self.tables_of(study, &changes)?;
        Ok(Evaluation {
            tables,
            analysis: Some(Analysis::new(ChangeRateAnalysis { rates: self.clone(), changes })),
        })
    }
    fn analysis_type(&self) -> Option<std::any::TypeId> {
        Some(std::any::TypeId::of::<ChangeRateAnalysis>())
    }
}

motionlab_core::register_plugin!(Evaluator, ChangeRatesParams, "change_rates");

/// The study without one subject (for leave-one-subject-out estimates).
pub fn without_subject(study: &GaitStudy, subject: &str) -> GaitStudy {
    GaitStudy {
        normal_condition: study.normal_condition.clone(),
        trials: study.trials.iter().filter(|t| t.subject != subject).cloned().collect(),
    }
}

/// Subjects of a study in order of first appearance.
pub fn subjects(study: &GaitStudy) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for t in &study.trials {
        if !out.contains(&t.subject) {
            out.push(t.subject.clone());
        }
    }
    out
}

/// Feature channels of a condition by component, for reports.
pub fn feature_channels(changes: &ConditionChanges) -> BTreeMap<&'static str, Vec<String>> {
    let mut out: BTreeMap<&'static str, Vec<String>> = BTreeMap::new();
    for s in changes.summary.iter().filter(|s| s.feature) {
        out.entry(s.component.name()).or_default().push(s.channel.clone());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_core::ColumnValues;
    use motionlab_core::registry::build_evaluator;

    fn trial(
        subject: &str,
        condition: &str,
        dc: [f64; 2],
        amplitude: [f64; 2],
        f: f64,
    ) -> crate::stages::GaitTrial {
        crate::stages::GaitTrial::hand_made(subject, condition, dc, amplitude, f)
    }

    /// Three subjects, normal and fast. Knee DC: 20 → 24, 10 → 11, 40 → 52 (K = 20, 10, 30 %);
    /// hip rotation DC: 2° for s1 (excluded: near zero), −10 → −12, 8 → 6 (K = 20, −25 %).
    fn study() -> GaitStudy {
        GaitStudy {
            normal_condition: "normal".into(),
            trials: vec![
                trial("s1", "normal", [20.0, 2.0], [30.0, 5.0], 1.0),
                trial("s2", "normal", [10.0, -10.0], [25.0, 4.0], 0.8),
                trial("s3", "normal", [40.0, 8.0], [20.0, 1.0], 0.9),
                trial("s1", "fast", [24.0, 3.0], [33.0, 6.0], 1.25),
                trial("s2", "fast", [11.0, -12.0], [30.0, 5.0], 1.0),
                trial("s3", "fast", [52.0, 6.0], [21.0, f64::NAN], 0.99),
            ],
        }
    }

    fn rates(min_subjects: usize) -> ChangeRates {
        ChangeRatesParams { min_subjects, ..Default::default() }.check().unwrap()
    }

    #[test]
    fn cv_on_a_hand_made_table_equals_the_hand_computation() {
        let a = rates(2).analyse(&study()).unwrap();
        let fast = a.condition("fast").unwrap();
        let find = |ch: &str, comp: Component| {
            fast.summary.iter().find(|s| s.channel == ch && s.component == comp).unwrap()
        };
        // Knee DC: K = 20, 10, 30 → μ = 20, σ = √((0 + 100 + 100)/3) = 8.1650, CV = 40.825 %.
        let knee = find("knee_l.flexion", Component::Dc);
        assert!((knee.mean_pct - 20.0).abs() < 1e-12);
        assert!((knee.sd_pct - (200.0f64 / 3.0).sqrt()).abs() < 1e-12);
        assert!((knee.cv_pct - (200.0f64 / 3.0).sqrt() / 20.0 * 100.0).abs() < 1e-12);
        assert!(knee.feature && knee.n_subjects == 3 && knee.n_excluded == 0);
        // Hip rotation DC: s1's 2° is below 5°: excluded, never divided. K = 20, −25 → μ = −2.5,
        // σ = 22.5, CV = −900 % → not a feature (signed CV, |CV| > 250).
        let hip = find("hip_l.rotation", Component::Dc);
        assert_eq!((hip.n_subjects, hip.n_excluded), (2, 1));
        assert!((hip.mean_pct + 2.5).abs() < 1e-12 && (hip.sd_pct - 22.5).abs() < 1e-12);
        assert!((hip.cv_pct + 900.0).abs() < 1e-9 && !hip.feature);
        let s1 = fast
            .changes
            .iter()
            .find(|c| {
                c.subject == "s1" && c.channel == "hip_l.rotation" && c.component == Component::Dc
            })
            .unwrap();
        assert_eq!((s1.k_pct, s1.excluded), (None, Some(Exclusion::NormalNearZero)));
        // Hip amplitude: s3's normal 1° < 2° (near zero) and its fast value is NaN: the NaN
        // is reported first (missing). K = 20, 25 → μ 22.5, σ 2.5, CV 11.11 %.
        let hipa = find("hip_l.rotation", Component::Amplitude);
        assert_eq!((hipa.n_subjects, hipa.n_excluded), (2, 1));
        assert!((hipa.cv_pct - 2.5 / 22.5 * 100.0).abs() < 1e-12);
        // Frequency: K = 25, 25, 10 → μ = 20, σ = √50.
        assert!((fast.frequency_mean_pct - 20.0).abs() < 1e-12);
        assert!((fast.frequency_sd_pct - 50.0f64.sqrt()).abs() < 1e-12);
        // The walk changes hold the feature channels' μ only.
        let w = fast.walk_changes();
        assert_eq!(w.dc_percent.keys().collect::<Vec<_>>(), ["knee_l.flexion"]);
        assert!((w.dc_percent["knee_l.flexion"] - 20.0).abs() < 1e-12);
        assert!(w.amplitude_percent.contains_key("hip_l.rotation"));
        assert!((w.frequency_percent - 20.0).abs() < 1e-12);
    }

    #[test]
    fn too_few_subjects_is_no_feature_whatever_the_cv() {
        let a = rates(3).analyse(&study()).unwrap();
        let fast = a.condition("fast").unwrap();
        let hipa = fast
            .summary
            .iter()
            .find(|s| s.channel == "hip_l.rotation" && s.component == Component::Amplitude)
            .unwrap();
        assert!(!hipa.feature);
        assert_eq!(hipa.note, "too_few_subjects");
    }

    #[test]
    fn any_pair_of_conditions_works() {
        // A slow condition added next to fast: both are analysed against "normal".
        let mut s = study();
        s.trials.push(trial("s1", "slow", [16.0, 1.0], [27.0, 4.0], 0.8));
        s.trials.push(trial("s2", "slow", [9.0, -9.0], [20.0, 3.0], 0.6));
        let a = rates(1).analyse(&s).unwrap();
        assert_eq!(
            a.conditions.iter().map(|c| c.condition.as_str()).collect::<Vec<_>>(),
            ["fast", "slow"]
        );
        let slow = a.condition("slow").unwrap();
        assert_eq!(slow.subjects, ["s1", "s2"]);
        let knee = slow
            .summary
            .iter()
            .find(|s| s.channel == "knee_l.flexion" && s.component == Component::Dc)
            .unwrap();
        assert!((knee.mean_pct - (-20.0 - 10.0) / 2.0).abs() < 1e-12);
    }

    #[test]
    fn tables_have_the_documented_columns() {
        let t = rates(2).tables(&study()).unwrap();
        let names: Vec<&str> = t.iter().map(|t| t.name.as_str()).collect();
        assert_eq!(
            names,
            ["gait_parameters", "change_rates", "change_rate_summary", "frequency_changes"]
        );
        let cols = |i: usize| t[i].columns.iter().map(|c| c.name.clone()).collect::<Vec<_>>();
        assert_eq!(
            cols(0),
            ["subject", "condition", "channel", "dc_deg", "amplitude_deg", "frequency_hz"]
        );
        assert_eq!(t[0].n_rows(), 12);
        assert_eq!(
            cols(2),
            [
                "normal_condition",
                "condition",
                "channel",
                "component",
                "mean_pct",
                "sd_pct",
                "cv_pct",
                "feature",
                "n_subjects",
                "n_excluded",
                "note"
            ]
        );
        // 2 channels × 2 components + the frequency row.
        assert_eq!(t[2].n_rows(), 5);
        match t[1].column("reason") {
            Some(ColumnValues::Str(v)) => {
                assert!(v.iter().any(|r| r.as_deref() == Some("normal_near_zero")))
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn bad_studies_and_params_are_errors() {
        let mut s = study();
        s.trials.push(trial("s1", "fast", [1.0, 1.0], [1.0, 1.0], 1.0));
        assert_eq!(rates(1).analyse(&s).unwrap_err().kind(), ErrorKind::DuplicateName);
        let only_normal =
            GaitStudy { normal_condition: "normal".into(), trials: study().trials[..3].to_vec() };
        assert_eq!(rates(1).analyse(&only_normal).unwrap_err().kind(), ErrorKind::EmptySequence);
        let t: toml::Value = toml::from_str("min_subjects = 0").unwrap();
        assert_eq!(
            build_evaluator("change_rates", &t).err().unwrap().location().field.as_deref(),
            Some("min_subjects")
        );
        let t: toml::Value = toml::from_str("max_abs_cv_pct = -1.0").unwrap();
        assert_eq!(
            build_evaluator("change_rates", &t).err().unwrap().location().field.as_deref(),
            Some("max_abs_cv_pct")
        );
        let e =
            build_evaluator("change_rates", &motionlab_core::registry::default_params()).unwrap();
        assert_eq!(e.input_type(), crate::gait_study());
        assert_eq!(
            e.evaluate(EvalInput::new(&Vec::<motionlab_match::MatchingResult>::new()))
                .unwrap_err()
                .kind(),
            ErrorKind::Mismatch
        );
    }
}
