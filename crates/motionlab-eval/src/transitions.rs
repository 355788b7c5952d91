//! The paper's Table 3: for each transition between consecutive labelled segments of the
//! ground truth, was it detected (○) — a candidate of the chosen method within the tolerance —
//! or not (×)? Plain function [`detect_transitions`] and evaluator plugin `transitions`.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::{ParamGuard, closest_names};
use motionlab_core::{
    Error, ErrorKind, EvalInput, EvalInputType, Evaluator, Result, Segmentation, Table, TimeSpan,
    Transition,
};

use crate::boundaries::{TruthWindow, default_tolerance, nearest_frame, tolerance_frames};
use crate::sequences::{location_of, nothing_to_evaluate, segmentation_input, truth_of};

// Whether a transition was detected is a result, not a row name (`motionlab compare`).
motionlab_core::declare_outcome_column!("detected");

/// What happened at one labelled transition.
#[derive(Clone, Debug, PartialEq)]
pub struct TransitionOutcome {
    pub transition: Transition,
    /// Some candidate lies in the transition's window.
    pub detected: bool,
    /// The candidate closest to the transition frame (ties: the earlier), if any.
    pub nearest: Option<usize>,
    /// `|nearest − frame|` in frames.
    pub distance_frames: Option<usize>,
}

/// Checks every transition of `truth` against `candidates` (frames at the same rate).
///
/// A transition at frame `t` is detected when a candidate lies in `[t − tol, t + tol]`, or —
/// with `use_windows` and an annotated window `[w₀, w₁]` on the boundary at `t` — in
/// `[min(t, w₀) − tol, max(t, w₁) + tol]`. Each transition is judged on its own (as in the
/// paper's table): one candidate may serve two transitions closer than 2·tol.
pub fn detect_transitions(
    truth: &Segmentation,
    candidates: &[usize],
    tol_frames: f64,
    use_windows: bool,
) -> Vec<TransitionOutcome> {
    let mut sorted = candidates.to_vec();
    sorted.sort_unstable();
    truth
        .transitions()
        .into_iter()
        .map(|transition| {
            let boundary = truth.boundaries.iter().find(|b| b.frame == transition.frame);
            let window = match boundary {
                Some(b) => TruthWindow::from_boundary(b, tol_frames, use_windows),
                None => TruthWindow::around(transition.frame, tol_frames),
            };
            // First candidate at or after the window's start; detected when it is inside.
            let first = sorted.partition_point(|&c| (c as f64) < window.lo);
            let detected = sorted.get(first).is_some_and(|&c| window.contains(c));
            let nearest = nearest_frame(&sorted, transition.frame);
            TransitionOutcome {
                detected,
                nearest,
                distance_frames: nearest.map(|c| c.abs_diff(transition.frame)),
                transition,
            }
        })
        .collect()
}

/// Table 3 of Sonoda et al.: every transition between consecutive labelled steps of the ground
/// truth, detected (○) when a candidate of the chosen method lies within `tolerance` of it,
/// else ×.
///
/// One row per transition: `sequence, method, frame, time_s, from, to, detected,
/// nearest_candidate_frame, distance_s` (distance from the transition to the method's nearest
/// candidate, seconds; empty when the method found nothing). Each transition is judged on its
/// own, as in the paper (no one-to-one matching here; `boundary_pr` does that).
///
/// Sequences without labelled segments are skipped; it is an error when none has any.
/// Missing samples: not read (this compares frame lists only).
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TransitionsParams {
    /// Largest offset between a transition and a candidate that still detects it, in frames or
    /// seconds (the default is `boundary_pr`'s, which says why).
    #[serde(default = "default_tolerance")]
    pub tolerance: TimeSpan,
    /// The method whose candidates are judged (the paper judges the fused result).
    #[serde(default)]
    #[schemars(extend("x-default" = "the last method, i.e. the fuser's output"))]
    pub method: Option<String>,
    /// Also accept a candidate anywhere in the boundary's annotated transition window (CMU-86
    /// labels), widened by `tolerance`.
    #[serde(default)]
    pub use_windows: bool,
}

/// The validated evaluator.
#[derive(Clone, Debug)]
pub struct Transitions {
    tolerance: TimeSpan,
    method: Option<String>,
    use_windows: bool,
}

impl ParamGuard for TransitionsParams {
    type Checked = Transitions;
    fn check(self) -> Result<Transitions> {
        let tolerance = self.tolerance.check("tolerance", false)?;
        if self.method.as_deref().is_some_and(|m| m.trim().is_empty()) {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                "must name a method, found an empty name",
            )
            .with_field("method"));
        }
        Ok(Transitions { tolerance, method: self.method, use_windows: self.use_windows })
    }
}

/// A row of `table3_transitions`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TransitionRow {
    pub sequence: String,
    pub method: String,
    /// The transition frame (the first frame of the next segment).
    pub frame: usize,
    pub time_s: f64,
    pub from: String,
    pub to: String,
    /// `○` detected, `×` not.
    pub detected: &'static str,
    pub nearest_candidate_frame: Option<usize>,
    pub distance_s: Option<f64>,
}

impl Evaluator for Transitions {
    fn input_type(&self) -> EvalInputType {
        EvalInputType::segmentation()
    }

    fn evaluate(&self, input: EvalInput<'_>) -> Result<Vec<Table>> {
        let sequences = segmentation_input(input, "transitions")?;
        let mut rows = Vec::new();
        let mut n_labelled = 0;
        for seq in sequences {
            let Some(truth) = truth_of(seq)? else { continue };
            if truth.segments.len() < 2 {
                continue;
            }
            n_labelled += 1;
            let method = match &self.method {
                Some(name) => seq.methods.iter().find(|m| m.method == *name).ok_or_else(|| {
                    let close = closest_names(name, seq.methods.iter().map(|m| m.method.as_str()));
                    let present: Vec<&str> =
                        seq.methods.iter().map(|m| m.method.as_str()).collect();
                    Error::new(
                        ErrorKind::UnknownName,
                        format!(
                            "no method {name:?} on {} (methods: {}{})",
                            seq.sequence,
                            present.join(", "),
                            if close.is_empty() {
                                String::new()
                            } else {
                                format!("; closest: {}", close.join(", "))
                            }
                        ),
                    )
                    .with_location(location_of(seq).field("method"))
                })?,
                None => seq.methods.last().ok_or_else(|| {
                    Error::new(
                        ErrorKind::EmptySequence,
                        format!("no method produced candidates for {}", seq.sequence),
                    )
                    .with_location(location_of(seq).field("method"))
                })?,
            };
            let rate = seq.motion.frame_rate();
            let period_s = rate.frame_period().value();
            let tol = tolerance_frames(self.tolerance, rate);
            for o in detect_transitions(truth, &method.candidates, tol, self.use_windows) {
                rows.push(TransitionRow {
                    sequence: seq.sequence.clone(),
                    method: method.method.clone(),
                    frame: o.transition.frame,
                    time_s: rate.frame_to_seconds(o.transition.frame).value(),
                    from: o.transition.from,
                    to: o.transition.to,
                    detected: if o.detected { "○" } else { "×" },
                    nearest_candidate_frame: o.nearest,
                    distance_s: o.distance_frames.map(|d| d as f64 * period_s),
                });
            }
        }
        if n_labelled == 0 {
            return Err(nothing_to_evaluate(
                "transitions",
                "ground truth with labelled segments",
                sequences.len(),
            ));
        }
        let table = Table::from_records(
            "table3_transitions",
            format!(
                "Table 3: transitions between labelled steps detected (○) or not (×), tolerance {}",
                self.tolerance
            ),
            &rows,
        )?;
        Ok(vec![table])
    }
}

motionlab_core::register_plugin!(Evaluator, TransitionsParams, "transitions");

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sequences::fixtures::sequence;
    use motionlab_core::registry::build_evaluator;
    use motionlab_core::{Boundary, FrameRate, Segment};

    fn evaluator(toml_text: &str) -> Box<dyn Evaluator> {
        let v: toml::Value = toml::from_str(toml_text).unwrap();
        build_evaluator("transitions", &v).unwrap()
    }

    fn cells(t: &Table, name: &str) -> Vec<String> {
        (0..t.n_rows()).map(|i| t.column(name).unwrap().cell(i)).collect()
    }

    fn steps() -> Segmentation {
        // toprock 0–100, bronx 100–250, entry 250–400, toprock 400–500 at 100 Hz.
        let seg = |start, end, label: &str| Segment { start, end, label: label.into() };
        Segmentation::from_segments(
            FrameRate::new(100.0).unwrap(),
            vec![
                seg(0, 100, "toprock"),
                seg(100, 250, "bronx"),
                seg(250, 400, "entry"),
                seg(400, 500, "toprock"),
            ],
        )
        .unwrap()
    }

    #[test]
    fn each_transition_is_detected_within_the_tolerance_only() {
        // Candidates 96 (4 before 100), 262 (12 after 250), 399 (1 before 400); tol 10.
        let out = detect_transitions(&steps(), &[399, 96, 262], 10.0, false);
        let summary: Vec<(usize, bool, Option<usize>, Option<usize>)> = out
            .iter()
            .map(|o| (o.transition.frame, o.detected, o.nearest, o.distance_frames))
            .collect();
        assert_eq!(
            summary,
            vec![
                (100, true, Some(96), Some(4)),
                (250, false, Some(262), Some(12)),
                (400, true, Some(399), Some(1))
            ]
        );
        assert_eq!(
            (out[1].transition.from.as_str(), out[1].transition.to.as_str()),
            ("bronx", "entry")
        );
        // Exactly at the tolerance counts.
        assert!(detect_transitions(&steps(), &[262], 12.0, false)[1].detected);
        // No candidates: nothing detected, no nearest.
        let none = detect_transitions(&steps(), &[], 10.0, false);
        assert!(none.iter().all(|o| !o.detected && o.nearest.is_none()));
    }

    #[test]
    fn annotated_windows_count_only_with_use_windows() {
        let mut truth = steps();
        truth.boundaries[1] = Boundary { frame: 250, window: Some((230, 270)) };
        assert!(!detect_transitions(&truth, &[275], 5.0, false)[1].detected);
        assert!(detect_transitions(&truth, &[275], 5.0, true)[1].detected);
        assert!(!detect_transitions(&truth, &[276], 5.0, true)[1].detected);
    }

    #[test]
    fn table3_uses_the_last_method_by_default_and_writes_circles_and_crosses() {
        let segments = Some(vec![
            (0, 100, "toprock"),
            (100, 250, "bronx"),
            (250, 400, "entry"),
            (400, 500, "toprock"),
        ]);
        let seqs = vec![
            sequence(
                "A",
                500,
                100.0,
                segments.clone(),
                &[("speed", &[100, 250, 400]), ("fused", &[96, 262])],
            ),
            sequence("unlabelled", 100, 100.0, None, &[("speed", &[1]), ("fused", &[1])]),
        ];
        let t = evaluator("tolerance = { seconds = 0.1 }")
            .evaluate(EvalInput::segmentation(&seqs))
            .unwrap()
            .remove(0);
        assert_eq!(t.name, "table3_transitions");
        assert_eq!(cells(&t, "method"), ["fused", "fused", "fused"]);
        assert_eq!(cells(&t, "detected"), ["○", "×", "×"]);
        assert_eq!(cells(&t, "from"), ["toprock", "bronx", "entry"]);
        assert_eq!(cells(&t, "nearest_candidate_frame"), ["96", "262", "262"]);
        assert_eq!(cells(&t, "time_s"), ["1", "2.5", "4"]);
        let d: Vec<f64> = cells(&t, "distance_s").iter().map(|c| c.parse().unwrap()).collect();
        assert!(
            (d[0] - 0.04).abs() < 1e-12
                && (d[1] - 0.12).abs() < 1e-12
                && (d[2] - 1.38).abs() < 1e-12
        );
        // A named method.
        let t = evaluator("method = \"speed\"")
            .evaluate(EvalInput::segmentation(&seqs))
            .unwrap()
            .remove(0);
        assert_eq!(cells(&t, "detected"), ["○", "○", "○"]);
    }

    #[test]
    fn unknown_method_and_unlabelled_inputs_are_errors() {
        let seqs = vec![sequence(
            "A",
            500,
            100.0,
            Some(vec![(0, 100, "a"), (100, 500, "b")]),
            &[("speed", &[100])],
        )];
        let e =
            evaluator("method = \"sped\"").evaluate(EvalInput::segmentation(&seqs)).unwrap_err();
        assert_eq!(
            (e.kind(), e.location().field.as_deref()),
            (ErrorKind::UnknownName, Some("method"))
        );
        assert!(e.to_string().contains("speed"), "{e}");
        let unlabelled = vec![sequence("B", 100, 100.0, None, &[("speed", &[1])])];
        let e = evaluator("").evaluate(EvalInput::segmentation(&unlabelled)).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::MissingKey);
        let v: toml::Value = toml::from_str("method = \"\"").unwrap();
        let e = build_evaluator("transitions", &v).err().unwrap();
        assert_eq!(e.location().field.as_deref(), Some("method"));
        let v: toml::Value = toml::from_str("tolerance = { seconds = -0.1 }").unwrap();
        assert_eq!(
            build_evaluator("transitions", &v).err().unwrap().location().field.as_deref(),
            Some("tolerance")
        );
    }
}
