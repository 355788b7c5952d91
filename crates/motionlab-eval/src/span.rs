//! Which found frames a boundary evaluation counts: all of them, or only those within the
//! annotated span (`span = "annotated"` of `boundary_pr`).
//!
//! Recordings usually start and end with standing still or walking in that nobody annotated;
//! a segmenter's candidates there are neither right nor wrong, and counting them as false
//! positives measures the recording's margins, not the method.
//!
//! **Annotated span** (precise): `[first, last]`, where `first` is the earliest of the truth's
//! first boundary and first labelled segment's start, and `last` the latest of its last
//! boundary and last segment's end. A found frame `c` is counted when
//! `first − tolerance ≤ c ≤ last + tolerance` (tolerance in frames at the motion's rate, the
//! evaluation's own). A truth with neither boundaries nor segments annotates nothing: every
//! found frame is outside.

use std::borrow::Cow;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::Segmentation;

/// The stretch of a sequence whose found frames are counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Span {
    /// The whole motion (every found frame counts).
    #[default]
    Whole,
    /// From the first to the last annotation, widened by the tolerance.
    Annotated,
}

/// The annotated span `[first, last]` of a truth (frames), None when it annotates nothing.
pub fn annotated_span(truth: &Segmentation) -> Option<(usize, usize)> {
    let starts =
        truth.boundaries.iter().map(|b| b.frame).chain(truth.segments.iter().map(|s| s.start));
    let ends = truth.boundaries.iter().map(|b| b.frame).chain(truth.segments.iter().map(|s| s.end));
    Some((starts.min()?, ends.max()?))
}

/// The found frames counted under `span`.
pub fn counted<'a>(
    found: &'a [usize],
    truth: &Segmentation,
    span: Span,
    tolerance_frames: f64,
) -> Cow<'a, [usize]> {
    match span {
        Span::Whole => Cow::Borrowed(found),
        Span::Annotated => match annotated_span(truth) {
            None => Cow::Owned(Vec::new()),
            Some((first, last)) => {
                let (lo, hi) = (first as f64 - tolerance_frames, last as f64 + tolerance_frames);
                Cow::Owned(
                    found.iter().copied().filter(|&c| (lo..=hi).contains(&(c as f64))).collect(),
                )
            }
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_core::{Boundary, FrameRate, Segment};

    #[test]
    fn only_frames_within_the_annotations_and_tolerance_count() {
        let rate = FrameRate::new(100.0).unwrap();
        let b = |frame| Boundary { frame, window: None };
        let points = Segmentation {
            frame_rate: rate,
            boundaries: vec![b(300), b(500), b(700)],
            segments: vec![],
            annotators: vec![],
            annotator_names: vec![],
        };
        let found = [50, 289, 290, 600, 710, 711, 900];
        assert_eq!(counted(&found, &points, Span::Whole, 10.0).as_ref(), &found);
        assert_eq!(counted(&found, &points, Span::Annotated, 10.0).as_ref(), &[290, 600, 710]);
        // Segments widen the span to their start and end.
        let segs = Segmentation {
            frame_rate: rate,
            boundaries: vec![b(300)],
            segments: vec![
                Segment { start: 200, end: 300, label: "a".into() },
                Segment { start: 300, end: 720, label: "b".into() },
            ],
            annotators: vec![],
            annotator_names: vec![],
        };
        assert_eq!(annotated_span(&segs), Some((200, 720)));
        assert_eq!(
            counted(&found, &segs, Span::Annotated, 0.0).as_ref(),
            &[289, 290, 600, 710, 711]
        );
        let empty = Segmentation {
            frame_rate: rate,
            boundaries: vec![],
            segments: vec![],
            annotators: vec![],
            annotator_names: vec![],
        };
        assert!(counted(&found, &empty, Span::Annotated, 10.0).is_empty());
    }

    /// `boundary_pr` with `span = "annotated"` on a hand-made sequence: 1000 frames at 100 Hz,
    /// segments [200, 400) and [400, 600) (boundary 400; span 200–600), tolerance 0.1 s = 10
    /// frames. Found: 20 and 950 (standing still before and after: outside), 195 (inside the
    /// widened span, matches nothing), 405 (matches 400). Whole: 1 of 4 found; annotated: 1 of 2.
    #[test]
    fn boundary_pr_counts_only_the_annotated_span_when_asked() {
        use crate::sequences::fixtures::sequence;
        use motionlab_core::registry::build_evaluator;
        use motionlab_core::{ColumnValues, EvalInput};
        let seq = sequence(
            "a",
            1000,
            100.0,
            Some(vec![(200, 400, "x"), (400, 600, "y")]),
            &[("speed", &[20, 195, 405, 950])],
        );
        let run = |params: &str| {
            let e = build_evaluator("boundary_pr", &toml::from_str(params).unwrap()).unwrap();
            let tables = e.evaluate(EvalInput::segmentation(&vec![seq.clone()])).unwrap();
            let t = &tables[0];
            let col = |n: &str| match t.column(n) {
                Some(ColumnValues::F64(v)) => v[0],
                Some(ColumnValues::I64(v)) => v[0] as f64,
                other => panic!("{n}: {other:?}"),
            };
            (col("n_found"), col("n_matched"), col("precision"), col("recall"))
        };
        assert_eq!(run("tolerance = { seconds = 0.1 }"), (4.0, 1.0, 0.25, 1.0));
        assert_eq!(run("tolerance = { seconds = 0.1 }\nspan = \"whole\""), (4.0, 1.0, 0.25, 1.0));
        assert_eq!(
            run("tolerance = { seconds = 0.1 }\nspan = \"annotated\""),
            (2.0, 1.0, 0.5, 1.0)
        );
        let bad = build_evaluator("boundary_pr", &toml::from_str("span = \"labelled\"").unwrap())
            .err()
            .unwrap();
        assert!(bad.to_string().contains("annotated"), "{bad}");
    }
}
