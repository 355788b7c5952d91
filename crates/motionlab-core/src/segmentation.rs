//! Segmentations: human ground truth and what segmenters find, both as frame indices at the
//! motion's own rate.

use crate::units::FrameRate;
use crate::{Error, ErrorKind, Result};

/// One labelled stretch of a motion, frames `start..end` (end exclusive).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Segment {
    pub start: usize,
    pub end: usize,
    pub label: String,
}

/// A boundary between two segments as an annotator gave it.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Boundary {
    /// The boundary frame (0-based, at the motion's rate).
    pub frame: usize,
    /// The annotated transition window `[a, c]` when the source gives one (CMU-86 labels).
    pub window: Option<(usize, usize)>,
}

/// A ground-truth segmentation: boundaries, and the labelled segments they separate when the
/// source labels them.
#[derive(Clone, Debug, PartialEq)]
pub struct Segmentation {
    pub frame_rate: FrameRate,
    /// Sorted by frame.
    pub boundaries: Vec<Boundary>,
    /// Labelled segments in order (may be empty when the source only marks points).
    pub segments: Vec<Segment>,
    /// Each annotator's own boundary frames (sorted), when `boundaries` combine several (a
    /// consensus); empty when they are one annotator's. Metrics defined over several
    /// annotators (TCPDBench's F1 and covering) read these, kept separately.
    pub annotators: Vec<Vec<usize>>,
    /// The names of [`Segmentation::annotators`], in the same order (the file's annotator or
    /// tier names); empty when the source names none.
    pub annotator_names: Vec<String>,
}

impl Segmentation {
    /// Builds a segmentation from consecutive labelled segments: a boundary wherever one segment
    /// ends and the next begins.
    pub fn from_segments(frame_rate: FrameRate, segments: Vec<Segment>) -> Result<Self> {
        for w in segments.windows(2) {
            if w[0].end != w[1].start || w[0].start >= w[0].end {
                return Err(Error::new(
                    ErrorKind::OutOfRange,
                    format!("segments {:?} and {:?} are not consecutive and non-empty", w[0], w[1]),
                ));
            }
        }
        let boundaries =
            segments.iter().skip(1).map(|s| Boundary { frame: s.start, window: None }).collect();
        Ok(Segmentation {
            frame_rate,
            boundaries,
            segments,
            annotators: Vec::new(),
            annotator_names: Vec::new(),
        })
    }
    pub fn frames(&self) -> Vec<usize> {
        self.boundaries.iter().map(|b| b.frame).collect()
    }
    /// Each annotator's boundary frames: [`Segmentation::annotators`], or the boundaries as the
    /// one annotator's when there is no list.
    pub fn annotator_frames(&self) -> Vec<Vec<usize>> {
        if self.annotators.is_empty() { vec![self.frames()] } else { self.annotators.clone() }
    }
    /// Consecutive pairs of labelled segments: the transitions of the paper's Table 3.
    pub fn transitions(&self) -> Vec<Transition> {
        self.segments
            .windows(2)
            .map(|w| Transition {
                frame: w[1].start,
                from: w[0].label.clone(),
                to: w[1].label.clone(),
            })
            .collect()
    }
}

/// A change from one labelled segment to the next.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Transition {
    pub frame: usize,
    pub from: String,
    pub to: String,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn boundaries_and_transitions_from_segments() {
        let r = FrameRate::new(120.0).unwrap();
        let s = Segmentation::from_segments(
            r,
            vec![
                Segment { start: 0, end: 10, label: "walk".into() },
                Segment { start: 10, end: 25, label: "jump".into() },
                Segment { start: 25, end: 30, label: "walk".into() },
            ],
        )
        .unwrap();
        assert_eq!(s.frames(), vec![10, 25]);
        let t = s.transitions();
        assert_eq!(t.len(), 2);
        assert_eq!((t[1].frame, t[1].from.as_str(), t[1].to.as_str()), (25, "jump", "walk"));
    }

    #[test]
    fn gaps_between_segments_are_rejected() {
        let r = FrameRate::new(120.0).unwrap();
        let e = Segmentation::from_segments(
            r,
            vec![
                Segment { start: 0, end: 10, label: "a".into() },
                Segment { start: 11, end: 20, label: "b".into() },
            ],
        );
        assert!(e.is_err());
    }
}
