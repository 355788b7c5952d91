//! Labelled boundary tiers of one sequence — each annotator's or each method's boundary frames,
//! with the motion's rate and length — as the annotation files motionlab writes hold them.
//!
//! The writers ([`super::boundaries_csv::write_boundaries_csv`],
//! [`super::elan_eaf::write_eaf`]) are the inverse of the readers: what they write reads back
//! (`boundaries_csv` with `annotator = "<tier>"`, `elan_eaf` with `tier = "<tier>"`) to the
//! same frames, for every mark on an inner frame (`1 ..= n_frames − 2`: the first and last
//! frames are the recording's edges, which the readers never take for boundaries) and at any
//! rate up to 1000 Hz for ELAN (its whole milliseconds are finer than a frame there).
//!
//! A mark's label names the stretch that **starts** at it (the boundary is where that action
//! begins): in `.eaf` it labels the annotation from the mark to the next one (the last to the
//! motion's last frame); in CSV it is the mark's row's `label`.

use serde::{Deserialize, Serialize};

/// One boundary of a tier.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct TierMark {
    /// Frame of the motion (0-based, at its own rate).
    pub frame: usize,
    /// The label of the stretch that starts here; empty for none.
    pub label: String,
}

/// One annotator's or one method's boundaries.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct MarkTier {
    /// The annotator (CSV `annotator` cell, ELAN `TIER_ID`), or the method's name.
    pub name: String,
    /// Sorted by frame, at most one per frame.
    pub marks: Vec<TierMark>,
}

impl MarkTier {
    /// A tier of unlabelled marks (sorted and deduplicated).
    pub fn unlabelled(name: impl Into<String>, frames: &[usize]) -> Self {
        let mut frames = frames.to_vec();
        frames.sort_unstable();
        frames.dedup();
        MarkTier {
            name: name.into(),
            marks: frames
                .into_iter()
                .map(|frame| TierMark { frame, label: String::new() })
                .collect(),
        }
    }
    pub fn frames(&self) -> Vec<usize> {
        self.marks.iter().map(|m| m.frame).collect()
    }
}

/// Every tier of one sequence, with what a writer needs of its motion.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SequenceTiers {
    /// The run's name of the sequence (a dataset's `name`, or `name/stem`): what exported
    /// files are named after.
    pub name: String,
    /// The motion file's stem (`86_01`): the CSV `sequence` cell, as the `boundaries_csv`
    /// reader matches it.
    pub sequence: String,
    /// SHA-256 of the motion's input file, lower-case hex (empty when unknown).
    pub input_sha256: String,
    pub frame_rate_hz: f64,
    pub n_frames: usize,
    pub tiers: Vec<MarkTier>,
}

/// What a segmentation run keeps of each sequence for `motionlab export`
/// (`files/segmentation_boundaries.json`): the truth (tier `truth`, labelled with the truth's
/// segments) and each method's candidates, one tier each.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunBoundaries {
    /// [`RunBoundaries::FORMAT`]: a reader refuses another.
    pub format: String,
    pub sequences: Vec<SequenceTiers>,
}

impl RunBoundaries {
    pub const FORMAT: &'static str = "motionlab segmentation boundaries 1";
    /// The file's name under a run's `files/`.
    pub const FILE_NAME: &'static str = "segmentation_boundaries.json";
    pub fn new(sequences: Vec<SequenceTiers>) -> Self {
        RunBoundaries { format: Self::FORMAT.into(), sequences }
    }
}
