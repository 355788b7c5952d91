//! Ground-truth reader `elan_eaf`: annotations made in ELAN (`.eaf`), the standard annotation
//! tool of dance and movement research.

use std::path::Path;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{Error, ErrorKind, GroundTruthReader, Location, Motion, Result, Segmentation};
use motionlab_io::labels::annotations::{AnnotatorTrack, EndRule};
use motionlab_io::labels::elan_eaf::parse_eaf;

use crate::consensus::ConsensusParams;
use crate::truth_annotators::Annotators;

/// Reads the annotations of one ELAN tier (or every tier, one per annotator) as boundaries:
/// every annotation's start and end is a boundary.
///
/// ELAN stores times in milliseconds on the video's time line (`TIME_SLOT` values); the
/// motion's frame is `(t_ms − offset_ms) / 1000 × rate`, rounded to the nearest frame (halves
/// away from zero). Instants on the motion's first or last frame are its edges, not
/// boundaries; a time before the motion's start or after its end is an error naming the line.
/// Annotations keep their values as segment labels (for the `transitions` evaluator).
///
/// Tiers: `tier = "…"` reads that tier; without it the file must have exactly one
/// time-aligned tier with annotations; `consensus = { … }` treats every such tier as one
/// annotator and combines them (the consensus rule: marks chained within `tolerance`, one vote
/// per tier, kept with ≥ `min_votes`; each tier's own marks stay beside the consensus for
/// `boundary_metrics`' TCPDBench F1 and covering). Dependent tiers of reference annotations
/// carry no times and are skipped.
///
/// Errors name the file, the line and the attribute: XML that does not parse, a root that is
/// not `ANNOTATION_DOCUMENT`, `TIME_UNITS` other than milliseconds, a slot used but not
/// declared or declared twice or without `TIME_VALUE`, a non-numeric or negative time, an
/// annotation ending before it starts, an unknown or empty tier (the message lists the tiers).
/// One `.eaf` per motion: `file = "annotations/{stem}.eaf"`. Missing samples in the motion do
/// not matter: only its frame count and rate are used.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ElanEafParams {
    /// The tier (`TIER_ID`) to read.
    #[serde(default)]
    #[schemars(extend("x-default" = "the file's only time-aligned tier"))]
    pub tier: Option<String>,
    /// Combine every time-aligned tier as one annotator each, by consensus.
    #[serde(default)]
    pub consensus: Option<ConsensusParams>,
    /// ELAN time of the motion's first frame, ms (video and mocap rarely start together).
    #[serde(default)]
    pub offset_ms: f64,
}

/// The validated reader.
#[derive(Clone, Debug)]
pub struct ElanEaf {
    annotators: Annotators,
    offset_ms: f64,
}

impl ParamGuard for ElanEafParams {
    type Checked = ElanEaf;
    fn check(self) -> Result<ElanEaf> {
        if !self.offset_ms.is_finite() {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                format!("must be a finite time in ms, found {}", self.offset_ms),
            )
            .with_field("offset_ms"));
        }
        Ok(ElanEaf {
            annotators: Annotators::from_params(self.tier, self.consensus, "tier")?,
            offset_ms: self.offset_ms,
        })
    }
}

impl GroundTruthReader for ElanEaf {
    fn read(&self, path: &Path, motion: &Motion) -> Result<Segmentation> {
        let text = motionlab_io::read::read_text(path)?;
        let tiers = parse_eaf(&text, path)?;
        let aligned: Vec<&_> = tiers.iter().filter(|t| t.time_aligned).collect();
        let tracks: Vec<AnnotatorTrack> = match &self.annotators {
            // A named tier may be empty: say so rather than "unknown".
            Annotators::Named(name) => match aligned.iter().find(|t| &t.id == name) {
                Some(t) if t.track.items.is_empty() => {
                    return Err(Error::at_line(
                        ErrorKind::EmptySequence,
                        path,
                        t.line,
                        format!("tier {name:?} has no time-aligned annotations"),
                    )
                    .with_field("tier"));
                }
                _ => aligned.iter().map(|t| t.track.clone()).collect(),
            },
            _ => aligned
                .iter()
                .filter(|t| !t.track.items.is_empty())
                .map(|t| t.track.clone())
                .collect(),
        };
        if tracks.is_empty() {
            let all: Vec<String> = tiers.iter().map(|t| format!("{:?}", t.id)).collect();
            return Err(Error::new(
                ErrorKind::EmptySequence,
                format!("no time-aligned annotations in any tier (tiers: {}); expected annotations with TIME_SLOT_REF1/REF2", all.join(", ")),
            )
            .with_location(Location::file(path).field("tier")));
        }
        let rate = motion.frame_rate().hz();
        let offset = self.offset_ms;
        self.annotators.truth(
            &tracks,
            move |ms| (ms - offset) / 1000.0 * rate,
            EndRule::EveryEnd,
            path,
            motion,
            "tier",
            "the file",
        )
    }
}

motionlab_core::register_plugin!(GroundTruth, ElanEafParams, "elan_eaf");

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_core::registry::build_ground_truth;
    use motionlab_testkit::{motion_from_fn, repo_root};

    fn read(params: &str, file: &str, n_frames: usize) -> Result<Segmentation> {
        let m = motion_from_fn(n_frames, 100.0, 1, |_, _| [0.0; 3]);
        let path = repo_root().join("tests/fixtures/annotations").join(file);
        build_ground_truth("elan_eaf", &toml::from_str(params).unwrap())?.read(&path, &m)
    }

    /// `dance_steps.eaf` (hand-written): tier "steps" 1.000–2.500 step, 2.500–4.005 turn,
    /// 6.000–7.250 step; tier "ben" 1.040–2.450, 6.020–7.300; a dependent tier "notes".
    #[test]
    fn hand_written_file_tiers_offset_and_consensus() {
        let s = read("tier = \"steps\"", "dance_steps.eaf", 1000).unwrap();
        // 4.005 s × 100 = 400.5 → 401 (halves away from zero).
        assert_eq!(s.frames(), vec![100, 250, 401, 600, 725]);
        assert_eq!(
            s.segments.iter().map(|g| g.label.as_str()).collect::<Vec<_>>(),
            vec!["step", "turn", "step"]
        );
        // Offset: the motion starts 500 ms into the video.
        assert_eq!(
            read("tier = \"steps\"\noffset_ms = 500.0", "dance_steps.eaf", 1000).unwrap().frames(),
            vec![50, 200, 351, 550, 675]
        );
        // Two tiers: a choice is needed; consensus of both within 6 frames keeps what both marked.
        let e = read("", "dance_steps.eaf", 1000).unwrap_err();
        assert!(e.to_string().contains("\"steps\", \"ben\""), "{e}");
        let c = read(
            "consensus = { tolerance = { frames = 6 }, min_votes = 2 }",
            "dance_steps.eaf",
            1000,
        )
        .unwrap();
        assert_eq!(c.frames(), vec![102, 247, 601, 727]);
        // Annotations past a short motion's end.
        let e = read("tier = \"steps\"", "dance_steps.eaf", 500).unwrap_err();
        assert_eq!(
            (e.kind(), e.location().field.as_deref()),
            (ErrorKind::OutOfRange, Some("TIME_SLOT_REF1"))
        );
        let e = read("tier = \"nope\"", "dance_steps.eaf", 1000).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::UnknownName);
    }
}
