//! Shared input handling of the segmentation evaluators: segmentation results as input, and
//! ground truth at the motion's own rate.

use motionlab_core::{
    Error, ErrorKind, EvalInput, EvalInputType, Location, Result, Segmentation, SequenceResult,
};

/// The sequences of a segmentation input; any other input is a wiring error.
pub(crate) fn segmentation_input<'a>(
    input: EvalInput<'a>,
    evaluator: &str,
) -> Result<&'a [SequenceResult]> {
    input.read::<Vec<SequenceResult>>(EvalInputType::segmentation(), evaluator).map(Vec::as_slice)
}

/// The sequence's ground truth, checked to be at the motion's rate (candidates are frames of
/// the motion); None when the sequence has no ground truth.
pub(crate) fn truth_of(seq: &SequenceResult) -> Result<Option<&Segmentation>> {
    let Some(truth) = &seq.truth else { return Ok(None) };
    let (a, b) = (truth.frame_rate.hz(), seq.motion.frame_rate().hz());
    if (a - b).abs() > 1e-9 * b {
        return Err(Error::new(
            ErrorKind::Mismatch,
            format!(
                "ground truth of {} is at {a} Hz but its motion is at {b} Hz; frames would not compare",
                seq.sequence
            ),
        )
        .with_location(location_of(seq)));
    }
    Ok(Some(truth))
}

/// The motion's file (when known) as an error location.
pub(crate) fn location_of(seq: &SequenceResult) -> Location {
    seq.motion.source.as_ref().map(Location::file).unwrap_or_default()
}

/// The error when no sequence has what an evaluator needs.
pub(crate) fn nothing_to_evaluate(evaluator: &str, what: &str, n_sequences: usize) -> Error {
    Error::new(
        ErrorKind::MissingKey,
        format!("{evaluator} needs {what}, but none of the {n_sequences} sequences has any; give the dataset a ground-truth reader"),
    )
    .with_field("truth")
}

#[cfg(test)]
pub(crate) mod fixtures {
    //! Sequences for the evaluator tests.
    use std::sync::Arc;

    use motionlab_core::{FrameRate, MethodResult, Segment, Segmentation, SequenceResult};
    use motionlab_testkit::motion_from_fn;

    /// A still one-marker motion of `n_frames` at `rate_hz`.
    pub fn sequence(
        name: &str,
        n_frames: usize,
        rate_hz: f64,
        segments: Option<Vec<(usize, usize, &str)>>,
        methods: &[(&str, &[usize])],
    ) -> SequenceResult {
        let mut motion = motion_from_fn(n_frames, rate_hz, 1, |_, _| [0.0; 3]);
        motion.name = name.into();
        let rate = FrameRate::new(rate_hz).unwrap();
        let truth = segments.map(|s| {
            Segmentation::from_segments(
                rate,
                s.into_iter()
                    .map(|(start, end, label)| Segment { start, end, label: label.into() })
                    .collect(),
            )
            .unwrap()
        });
        SequenceResult {
            sequence: name.into(),
            motion: Arc::new(motion),
            truth,
            methods: methods
                .iter()
                .map(|(m, c)| MethodResult { method: m.to_string(), candidates: c.to_vec() })
                .collect(),
        }
    }
}
