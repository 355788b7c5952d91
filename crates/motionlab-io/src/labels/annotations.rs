//! What the user-annotation formats (`boundaries_csv`, `elan_eaf`) have in common: per
//! annotator, a list of marked instants or segments, turned into boundary frames at the
//! motion's rate by one rule.
//!
//! # From annotations to boundaries (precise rule)
//!
//! 1. Every instant is converted to a (fractional) frame of the motion by the format's own
//!    mapping (frames at a label rate, seconds, milliseconds with an offset), then rounded to
//!    the nearest frame, halves away from zero (`12.5 → 13`, `f64::round`).
//! 2. A point annotation is one boundary. A segment gives a boundary at its start, and at its
//!    end either always ([`EndRule::EveryEnd`], ELAN) or only for the annotator's last segment
//!    ([`EndRule::LastEndOnly`], the CSV rule "segment starts plus the last end").
//! 3. Instants on the motion's first frame (0) or at / after its last frame (`n_frames − 1`)
//!    are the recording's edges, not changes a segmenter could find, and are not boundaries
//!    (so a label file whose segments cover the whole take, like CMU-86's, gives the same
//!    boundaries as its own reader).
//! 4. Boundaries are sorted and duplicates merged. An instant before frame 0 or after the
//!    motion's end (rounded frame > `n_frames`) is an error naming the line and column.
//!
//! Segments keep their label (empty when the format has none) and are sorted by start; they
//! need not be consecutive.

use std::path::Path;

use motionlab_core::{Boundary, Error, ErrorKind, FrameRate, Result, Segment, Segmentation};

/// Which segment ends are boundaries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EndRule {
    /// Every segment's end (ELAN: annotations with gaps between them).
    EveryEnd,
    /// Only the end of the annotator's last segment (the CSV rule).
    LastEndOnly,
}

/// One annotated instant or segment, in the format's own unit (converted by the caller).
#[derive(Clone, Debug, PartialEq)]
pub struct AnnotatedItem {
    /// 1-based line in the file.
    pub line: usize,
    /// The column / attribute the start came from (for error messages).
    pub start_field: String,
    pub start: f64,
    /// The column / attribute of the end, and the end; None for a point annotation.
    pub end: Option<(String, f64)>,
    pub label: String,
}

/// One annotator's (or tier's) items for one sequence.
#[derive(Clone, Debug, PartialEq)]
pub struct AnnotatorTrack {
    pub annotator: String,
    pub items: Vec<AnnotatedItem>,
}

/// The boundaries and segments of one annotator at the motion's rate (see the module docs).
///
/// `to_frame` maps a value in the format's unit to a fractional motion frame.
pub fn track_segmentation(
    track: &AnnotatorTrack,
    to_frame: impl Fn(f64) -> f64,
    rule: EndRule,
    origin: &Path,
    rate: FrameRate,
    n_frames: usize,
) -> Result<Segmentation> {
    let frame_of = |value: f64, line: usize, field: &str| -> Result<usize> {
        let f = to_frame(value).round();
        if !f.is_finite() || f < 0.0 || f > n_frames as f64 {
            return Err(Error::at_line(
                ErrorKind::OutOfRange,
                origin,
                line,
                format!("{value} is motion frame {f}, outside the motion's frames 0..={n_frames}; wrong file, rate or offset?"),
            )
            .with_field(field));
        }
        Ok(f as usize)
    };
    if rule == EndRule::LastEndOnly {
        // The CSV's segment rows (`start_frame,end_frame,label`) are the state format; ELAN
        // tiers mark boundaries and may leave segments unlabelled.
        check_state_labels(track, origin)?;
    }
    let is_inner = |f: usize| f > 0 && f + 1 < n_frames;
    let mut boundaries = Vec::new();
    let mut segments = Vec::new();
    let mut last_end: Option<usize> = None;
    for item in &track.items {
        let start = frame_of(item.start, item.line, &item.start_field)?;
        if is_inner(start) {
            boundaries.push(start);
        }
        if let Some((end_field, end_value)) = &item.end {
            let end = frame_of(*end_value, item.line, end_field)?;
            match rule {
                EndRule::EveryEnd if is_inner(end) => boundaries.push(end),
                EndRule::EveryEnd => {}
                EndRule::LastEndOnly => {
                    last_end = Some(last_end.map_or(end, |e: usize| e.max(end)))
                }
            }
            segments.push(Segment { start, end, label: item.label.clone() });
        }
    }
    if let Some(end) = last_end.filter(|&e| is_inner(e)) {
        boundaries.push(end);
    }
    boundaries.sort_unstable();
    boundaries.dedup();
    segments.sort_by_key(|s| (s.start, s.end));
    Ok(Segmentation {
        frame_rate: rate,
        boundaries: boundaries.into_iter().map(|frame| Boundary { frame, window: None }).collect(),
        segments,
        annotators: Vec::new(),
        annotator_names: Vec::new(),
    })
}

/// When an annotator of a CSV labels segments (any segment of the track has a label), the
/// labels are states — one per sample — so every segment must have one and no two may overlap; the
/// error names the file and the line of the offending segment. Tracks without labels (plain
/// boundaries) are not checked.
fn check_state_labels(track: &AnnotatorTrack, origin: &Path) -> Result<()> {
    let segments: Vec<(&AnnotatedItem, f64)> =
        track.items.iter().filter_map(|i| Some((i, i.end.as_ref()?.1))).collect();
    if !segments.iter().any(|(i, _)| !i.label.trim().is_empty()) {
        return Ok(());
    }
    if let Some((i, _)) = segments.iter().find(|(i, _)| i.label.trim().is_empty()) {
        return Err(Error::at_line(
            ErrorKind::MissingData,
            origin,
            i.line,
            format!(
                "segment of annotator {:?} without a label, while its other segments have one; expected a state label on every segment",
                track.annotator
            ),
        )
        .with_field("label"));
    }
    let mut sorted = segments.clone();
    sorted.sort_by(|a, b| a.0.start.total_cmp(&b.0.start));
    for w in sorted.windows(2) {
        let ((a, a_end), (b, _)) = (w[0], w[1]);
        if a_end > b.start {
            return Err(Error::at_line(
                ErrorKind::OutOfRange,
                origin,
                b.line,
                format!(
                    "segment {:?} starting at {} overlaps segment {:?} of line {} (ending at {a_end}); expected one state label per sample",
                    b.label, b.start, a.label, a.line
                ),
            )
            .with_field(b.start_field.clone()));
        }
    }
    Ok(())
}

/// Parses a number cell: finite and ≥ 0, else an error naming line and column.
pub(crate) fn parse_instant(cell: &str, origin: &Path, line: usize, column: &str) -> Result<f64> {
    let cell = cell.trim();
    let v: f64 = cell.parse().map_err(|_| {
        Error::at_line(
            ErrorKind::Syntax,
            origin,
            line,
            format!("{cell:?} is not a number; expected a time or frame ≥ 0"),
        )
        .with_field(column)
    })?;
    if !v.is_finite() {
        return Err(Error::at_line(
            ErrorKind::NonFinite,
            origin,
            line,
            format!("{cell:?}; expected a finite time or frame ≥ 0"),
        )
        .with_field(column));
    }
    if v < 0.0 {
        return Err(Error::at_line(
            ErrorKind::OutOfRange,
            origin,
            line,
            format!("{cell} is negative; expected a time or frame ≥ 0"),
        )
        .with_field(column));
    }
    Ok(v)
}

/// The error for a segment whose start is after its end.
pub(crate) fn start_after_end(
    origin: &Path,
    line: usize,
    end_field: &str,
    start: f64,
    end: f64,
) -> Error {
    Error::at_line(
        ErrorKind::OutOfRange,
        origin,
        line,
        format!("the segment ends at {end}, before its start {start}; expected start ≤ end"),
    )
    .with_field(end_field)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn item(line: usize, start: f64, end: Option<f64>) -> AnnotatedItem {
        AnnotatedItem {
            line,
            start_field: "s".into(),
            start,
            end: end.map(|e| ("e".into(), e)),
            label: "x".into(),
        }
    }

    #[test]
    fn rounding_edges_and_end_rules() {
        let r = FrameRate::new(100.0).unwrap();
        let o = Path::new("a.csv");
        // Segments [0, 10.5), [10.5, 30), a gap, [40.4, 99]: 100 frames.
        let t = AnnotatorTrack {
            annotator: "A".into(),
            items: vec![
                item(2, 0.0, Some(10.5)),
                item(3, 10.5, Some(30.0)),
                item(4, 40.4, Some(99.0)),
            ],
        };
        let last = track_segmentation(&t, |v| v, EndRule::LastEndOnly, o, r, 100).unwrap();
        // 0 is an edge, 10.5 → 11, 40.4 → 40, the last end 99 = n − 1 is an edge.
        assert_eq!(last.frames(), vec![11, 40]);
        let every = track_segmentation(&t, |v| v, EndRule::EveryEnd, o, r, 100).unwrap();
        assert_eq!(every.frames(), vec![11, 30, 40]);
        assert_eq!(
            every.segments.iter().map(|s| (s.start, s.end)).collect::<Vec<_>>(),
            vec![(0, 11), (11, 30), (40, 99)]
        );
        // Points, doubled by a scale: 2.25 × 2 = 4.5 → 5.
        let p = AnnotatorTrack {
            annotator: "A".into(),
            items: vec![item(2, 2.25, None), item(3, 2.5, None)],
        };
        assert_eq!(
            track_segmentation(&p, |v| 2.0 * v, EndRule::EveryEnd, o, r, 100).unwrap().frames(),
            vec![5]
        );
        // Past the end: names line and field.
        let far = AnnotatorTrack { annotator: "A".into(), items: vec![item(7, 1.0, Some(100.6))] };
        let e = track_segmentation(&far, |v| v, EndRule::EveryEnd, o, r, 100).unwrap_err();
        assert_eq!(
            (e.kind(), e.location().line, e.location().field.as_deref()),
            (ErrorKind::OutOfRange, Some(7), Some("e"))
        );
    }

    /// Labelled segments are states: one without a label among labelled ones, or two that
    /// overlap, is refused at its line; unlabelled boundary tracks are not checked.
    #[test]
    fn state_labels_need_a_label_per_segment_and_no_overlap() {
        let r = FrameRate::new(100.0).unwrap();
        let o = Path::new("truth.csv");
        let labelled = |items: Vec<AnnotatedItem>| AnnotatorTrack { annotator: "A".into(), items };
        let mut unlabelled = item(3, 10.0, Some(20.0));
        unlabelled.label = String::new();
        let e = track_segmentation(
            &labelled(vec![item(2, 0.0, Some(10.0)), unlabelled.clone()]),
            |v| v,
            EndRule::LastEndOnly,
            o,
            r,
            100,
        )
        .unwrap_err();
        assert_eq!((e.kind(), e.location().line), (ErrorKind::MissingData, Some(3)));
        assert!(
            e.to_string().contains("truth.csv") && e.to_string().contains("without a label"),
            "{e}"
        );
        let e = track_segmentation(
            &labelled(vec![item(2, 0.0, Some(12.0)), item(3, 10.0, Some(20.0))]),
            |v| v,
            EndRule::LastEndOnly,
            o,
            r,
            100,
        )
        .unwrap_err();
        assert_eq!((e.kind(), e.location().line), (ErrorKind::OutOfRange, Some(3)));
        assert!(e.to_string().contains("overlaps"), "{e}");
        // Touching segments are fine; so are unlabelled overlapping ones (plain boundaries).
        let ok = vec![item(2, 0.0, Some(10.0)), item(3, 10.0, Some(20.0))];
        assert!(track_segmentation(&labelled(ok), |v| v, EndRule::LastEndOnly, o, r, 100).is_ok());
        let mut a = unlabelled.clone();
        a.end = Some(("e".into(), 30.0));
        assert!(
            track_segmentation(
                &labelled(vec![a, unlabelled]),
                |v| v,
                EndRule::LastEndOnly,
                o,
                r,
                100
            )
            .is_ok()
        );
    }
}
