//! `template_evaluator`: how many candidates each method finds per stretch of time.
//!
//! Written by `motionlab plugin new` as a working placeholder in the shape every plugin has
//! (CONTRIBUTING.md, "A plugin is one file"): a params struct whose doc comment is what
//! `motionlab describe template_evaluator` prints, a `ParamGuard` that validates it into the
//! stage that runs, the `Evaluator` impl, one `register_plugin!` line and a known-answer test.
//! Replace the evaluation, its doc comment and its test together.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{
    Error, ErrorKind, EvalInput, EvalInputType, Evaluator, Result, SequenceResult, Table,
};

/// The rate of candidates of every method on every sequence of a segmentation: one row per
/// (sequence, method) in the table `candidate_rate` — candidates, the sequence's duration in
/// seconds, and candidates per `per_s` seconds.
///
/// Needs no ground truth. Missing samples: irrelevant (only candidate counts and durations are
/// read).
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TemplateEvaluatorParams {
    /// The stretch of time (s, > 0) the rate is counted per.
    #[serde(default = "default_per_s")]
    pub per_s: f64,
}

fn default_per_s() -> f64 {
    60.0
}

/// The validated stage.
#[derive(Clone, Debug)]
pub struct TemplateEvaluator {
    per_s: f64,
}

impl ParamGuard for TemplateEvaluatorParams {
    type Checked = TemplateEvaluator;
    fn check(self) -> Result<TemplateEvaluator> {
        if !(self.per_s.is_finite() && self.per_s > 0.0) {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                format!("expected a duration > 0 s, found {}", self.per_s),
            )
            .with_field("per_s"));
        }
        Ok(TemplateEvaluator { per_s: self.per_s })
    }
}

/// A row of `candidate_rate`.
#[derive(Serialize)]
struct RateRow {
    sequence: String,
    method: String,
    candidates: usize,
    duration_s: f64,
    candidates_per_period: f64,
}

impl Evaluator for TemplateEvaluator {
    fn input_type(&self) -> EvalInputType {
        EvalInputType::segmentation()
    }

    fn evaluate(&self, input: EvalInput<'_>) -> Result<Vec<Table>> {
        let sequences = input
            .read::<Vec<SequenceResult>>(EvalInputType::segmentation(), "template_evaluator")?;
        let rows: Vec<RateRow> = sequences
            .iter()
            .flat_map(|s| {
                let duration_s = s.motion.duration().0;
                s.methods.iter().map(move |m| RateRow {
                    sequence: s.sequence.clone(),
                    method: m.method.clone(),
                    candidates: m.candidates.len(),
                    duration_s,
                    candidates_per_period: m.candidates.len() as f64 * self.per_s / duration_s,
                })
            })
            .collect();
        let title = format!("Candidates of each method per {} s of each sequence", self.per_s);
        Ok(vec![Table::from_records("candidate_rate", title, &rows)?])
    }
}

motionlab_core::register_plugin!(Evaluator, TemplateEvaluatorParams, "template_evaluator");

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;
    use motionlab_core::registry::build_evaluator;
    use motionlab_core::{Axis, ColumnValues, FrameRate, MethodResult, Motion, PointKind};

    /// A 30-second sequence (3,000 frames at 100 Hz) on which `fast` finds 6 candidates and
    /// `slow` 1.
    fn sequence() -> SequenceResult {
        let motion = Motion::new(
            "s",
            FrameRate::new(100.0).unwrap(),
            Axis::Z,
            PointKind::Marker,
            vec!["m".into()],
            vec![[0.0; 3]; 3000],
        )
        .unwrap();
        let method =
            |name: &str, candidates: Vec<usize>| MethodResult { method: name.into(), candidates };
        SequenceResult {
            sequence: "s".into(),
            motion: Arc::new(motion),
            truth: None,
            methods: vec![
                method("fast", vec![100, 600, 1100, 1600, 2100, 2600]),
                method("slow", vec![1500]),
            ],
        }
    }

    fn rates(params: &str) -> Result<Vec<f64>> {
        let params: toml::Value = toml::from_str(params).unwrap();
        let tables = build_evaluator("template_evaluator", &params)?
            .evaluate(EvalInput::segmentation(&vec![sequence()]))?;
        match tables[0].column("candidates_per_period") {
            Some(ColumnValues::F64(v)) => Ok(v.clone()),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn candidates_per_minute_and_per_second() {
        // 30 s: 6 candidates are 12 per minute, 0.2 per second; 1 is 2 per minute.
        assert_eq!(rates("").unwrap(), [12.0, 2.0]);
        let per_second = rates("per_s = 1.0").unwrap();
        assert!(
            (per_second[0] - 0.2).abs() < 1e-12 && (per_second[1] - 1.0 / 30.0).abs() < 1e-12,
            "{per_second:?}"
        );
    }

    #[test]
    fn a_bad_period_names_its_field() {
        let e = rates("per_s = -1.0").unwrap_err();
        assert_eq!(
            (e.kind(), e.location().field.as_deref()),
            (ErrorKind::OutOfRange, Some("per_s"))
        );
    }
}
