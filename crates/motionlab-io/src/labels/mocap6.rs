//! `mocap6_labels`: the mocap6 exercise labels (`data/mocap6/truelabels/<trial>.txt`).

use std::path::Path;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{Error, ErrorKind, GroundTruthReader, Motion, Result, Segment, Segmentation};

/// The 12 actions of the mocap6 dataset, label 1 first (`data/mocap6/README.md`).
pub const MOCAP6_ACTIONS: [&str; 12] = [
    "JumpJack",
    "Jog",
    "Squat",
    "KneeRaise",
    "ArmCircle",
    "Twist",
    "SideReach",
    "Box",
    "UpDown",
    "ToeTouchOneHand",
    "SideBend",
    "ToeTouchTwoHands",
];

/// Reads the mocap6 exercise labels of Fox, Hughes, Sudderth & Jordan (Annals of Applied
/// Statistics 8(3), 2014): one action number 1–12 per block of `block_frames` motion frames
/// (12 AMC frames at 120 fps = the dataset's 10 fps), whitespace-separated on any number of
/// lines.
///
/// Block i (1-based) covers motion frames `block_frames·(i−1) … block_frames·i − 1` (0-based).
/// Consecutive blocks with the same number form one segment, labelled with the action name
/// (1 JumpJack, 2 Jog, 3 Squat, 4 KneeRaise, 5 ArmCircle, 6 Twist, 7 SideReach, 8 Box,
/// 9 UpDown, 10 ToeTouchOneHand, 11 SideBend, 12 ToeTouchTwoHands); a boundary is placed where
/// the number changes (no transition window).
///
/// Length: the dataset block-averaged the motion into `floor(F / block_frames) + 1` blocks for
/// a motion of F frames (all five shipped takes: 13_29 has 4592 frames and 383 labels, the last
/// block 8 frames long; 14_20 has 4644 = 387 × 12 frames and 388 labels). The last block is cut
/// at the motion's end; when F is a multiple of `block_frames` it starts at F, covers no frame
/// and is ignored. More labels than that is an error. Fewer labels leave the frames after the
/// last block in no segment. Missing samples in the motion do not
/// matter: only its frame count is used.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Mocap6LabelsParams {
    /// Motion frames per label block (frames, ≥ 1; the default turns 120 fps into 10 fps).
    #[serde(default = "default_block_frames")]
    pub block_frames: usize,
}

fn default_block_frames() -> usize {
    12
}

/// The validated reader.
#[derive(Clone, Debug)]
pub struct Mocap6Labels {
    block_frames: usize,
}

impl ParamGuard for Mocap6LabelsParams {
    type Checked = Mocap6Labels;
    fn check(self) -> Result<Mocap6Labels> {
        if self.block_frames == 0 {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                "is 0; expected at least 1 frame per block",
            )
            .with_field("block_frames"));
        }
        Ok(Mocap6Labels { block_frames: self.block_frames })
    }
}

/// One block label with where it was written.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlockLabel {
    /// 1..=12.
    pub label: usize,
    pub line: usize,
}

/// Parses a label file into its block labels (checked to be 1–12).
pub fn parse_mocap6_labels(text: &str, origin: &Path) -> Result<Vec<BlockLabel>> {
    let text = crate::text::strip_bom(text);
    let mut out = Vec::new();
    for (i, raw) in text.split('\n').enumerate() {
        for w in raw.split_ascii_whitespace() {
            // A word that is no whole number is a syntax error; a number outside 1–12 is out
            // of range (tests assert the two apart).
            let kind =
                if w.parse::<usize>().is_ok() { ErrorKind::OutOfRange } else { ErrorKind::Syntax };
            let label = w
                .parse::<usize>()
                .ok()
                .filter(|l| (1..=MOCAP6_ACTIONS.len()).contains(l))
                .ok_or_else(|| {
                    Error::at_line(
                        kind,
                        origin,
                        i + 1,
                        format!(
                            "label {} is {w:?}; expected an action number 1 to 12",
                            out.len() + 1
                        ),
                    )
                })?;
            out.push(BlockLabel { label, line: i + 1 });
        }
    }
    Ok(out)
}

/// Segments of a motion of `n_frames` frames from its block labels (see
/// [`Mocap6LabelsParams`]).
pub fn block_segmentation(
    labels: &[BlockLabel],
    origin: &Path,
    block_frames: usize,
    motion: &Motion,
) -> Result<Segmentation> {
    let n_frames = motion.n_frames();
    if labels.is_empty() {
        return Err(Error::at_line(
            ErrorKind::EmptySequence,
            origin,
            1,
            "no labels; expected one action number per block",
        ));
    }
    let max_blocks = n_frames / block_frames + 1;
    if labels.len() > max_blocks {
        let first_extra = &labels[max_blocks];
        return Err(Error::at_line(
            ErrorKind::OutOfRange,
            origin,
            first_extra.line,
            format!(
                "{} labels of {block_frames} frames need a motion of at least {} frames, but {} has {n_frames} (at most {max_blocks} blocks)",
                labels.len(),
                (labels.len() - 1).saturating_mul(block_frames),
                motion.name
            ),
        ));
    }
    let mut segments: Vec<Segment> = Vec::new();
    for (i, l) in labels.iter().enumerate() {
        // Saturating: a huge block_frames must not overflow (the length check above bounds i).
        let start = i.saturating_mul(block_frames);
        if start >= n_frames {
            // The empty final block of a motion whose length is a multiple of block_frames.
            break;
        }
        let end = (i + 1).saturating_mul(block_frames).min(n_frames);
        let name = MOCAP6_ACTIONS[l.label - 1];
        match segments.last_mut() {
            Some(s) if s.label == name => s.end = end,
            _ => segments.push(Segment { start, end, label: name.to_string() }),
        }
    }
    Segmentation::from_segments(motion.frame_rate(), segments).map_err(|e| e.in_file(origin))
}

impl GroundTruthReader for Mocap6Labels {
    fn read(&self, path: &Path, motion: &Motion) -> Result<Segmentation> {
        let text = crate::read::read_text(path)?;
        let labels = parse_mocap6_labels(&text, path)?;
        block_segmentation(&labels, path, self.block_frames, motion)
    }
}

motionlab_core::register_plugin!(GroundTruth, Mocap6LabelsParams, "mocap6_labels");

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_testkit::motion_from_fn;

    fn labels(text: &str) -> Vec<BlockLabel> {
        parse_mocap6_labels(text, Path::new("l.txt")).unwrap()
    }

    #[test]
    fn runs_of_equal_labels_become_segments_and_the_last_block_is_cut() {
        let m = motion_from_fn(10, 120.0, 1, |_, _| [0.0; 3]);
        // Blocks of 3 frames: [0,3) 1, [3,6) 1, [6,9) 2, [9,10) 2 (partial).
        let s = block_segmentation(&labels("1 1\n2\t2 "), Path::new("l.txt"), 3, &m).unwrap();
        let spans: Vec<(usize, usize, &str)> =
            s.segments.iter().map(|g| (g.start, g.end, g.label.as_str())).collect();
        assert_eq!(spans, vec![(0, 6, "JumpJack"), (6, 10, "Jog")]);
        assert_eq!(s.frames(), vec![6]);
    }

    #[test]
    fn too_many_labels_is_an_error_too_few_leaves_the_tail_unlabelled() {
        let m = motion_from_fn(9, 120.0, 1, |_, _| [0.0; 3]);
        let e = block_segmentation(&labels("1 1 2\n3 3"), Path::new("l.txt"), 3, &m).unwrap_err();
        assert_eq!((e.kind(), e.location().line), (ErrorKind::OutOfRange, Some(2)));
        // 9 frames = 3 blocks of 3: a 4th label is the dataset's empty final block, ignored
        // (no segment, no boundary at frame 9).
        let s = block_segmentation(&labels("1 1 2\n3"), Path::new("l.txt"), 3, &m).unwrap();
        let spans: Vec<(usize, usize)> = s.segments.iter().map(|g| (g.start, g.end)).collect();
        assert_eq!(spans, vec![(0, 6), (6, 9)]);
        assert_eq!(s.frames(), vec![6]);
        let s = block_segmentation(&labels("12 12"), Path::new("l.txt"), 3, &m).unwrap();
        assert_eq!(
            s.segments,
            vec![Segment { start: 0, end: 6, label: "ToeTouchTwoHands".into() }]
        );
        assert!(s.boundaries.is_empty());
    }

    #[test]
    fn labels_outside_1_to_12_name_their_line() {
        for (bad, kind) in [
            ("1 1\n13", ErrorKind::OutOfRange),
            ("1 1\n0", ErrorKind::OutOfRange),
            ("1 1\nx", ErrorKind::Syntax),
        ] {
            let e = parse_mocap6_labels(bad, Path::new("l.txt")).unwrap_err();
            assert_eq!((e.kind(), e.location().line), (kind, Some(2)), "{bad}");
        }
        let e = motionlab_core::registry::build_ground_truth(
            "mocap6_labels",
            &toml::from_str("block_frames = 0").unwrap(),
        )
        .err()
        .unwrap();
        assert_eq!(e.location().field.as_deref(), Some("block_frames"));
    }

    /// The shipped label files against their takes' frame counts (counted in the AMC files:
    /// 13_29 4592, 13_30 2465, 13_31 3017, 14_14 4653, 14_20 4644): every file has
    /// floor(F / 12) + 1 labels, so 14_20 (a multiple of 12) ends with an empty block.
    #[test]
    fn every_shipped_label_file_fits_its_take() {
        for (take, n_frames) in
            [("13_29", 4592), ("13_30", 2465), ("13_31", 3017), ("14_14", 4653), ("14_20", 4644)]
        {
            let path = motionlab_testkit::data_path(&format!("mocap6/truelabels/{take}.txt"));
            let l = parse_mocap6_labels(&std::fs::read_to_string(&path).unwrap(), &path).unwrap();
            assert_eq!(l.len(), n_frames / 12 + 1, "{take}");
            let m = motion_from_fn(n_frames, 120.0, 1, |_, _| [0.0; 3]);
            let s = block_segmentation(&l, &path, 12, &m).unwrap();
            assert_eq!(s.segments.last().map(|g| g.end), Some(n_frames), "{take}");
        }
    }
}
