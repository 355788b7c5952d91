//! Ground truth from users' own annotation files with one or several annotators (shared by the
//! `boundaries_csv` and `elan_eaf` readers): pick one annotator, combine them all with the
//! [`Consensus`] rule, or take the only one there is.
//!
//! A [`Segmentation`]'s boundaries are one ground truth, so several annotators become one here,
//! at read time: per-annotator evaluation is one run per annotator (`annotator = "…"`, which a
//! sweep can vary), consensus is `consensus = { … }`. A consensus keeps every annotator's own
//! boundaries beside it ([`Segmentation::annotators`]), for the metrics defined over several
//! annotators (`boundary_metrics`' TCPDBench F1 and covering).

use std::path::Path;

use motionlab_core::registry::ParamGuard;
use motionlab_core::{Error, ErrorKind, FrameRate, Location, Motion, Result, Segmentation};
use motionlab_io::labels::annotations::{AnnotatorTrack, EndRule, track_segmentation};

use crate::consensus::{Consensus, ConsensusParams};

/// How the annotators of a file become one ground truth (validated reader state).
#[derive(Clone, Debug)]
pub(crate) enum Annotators {
    /// The only annotator of the file (an error when there are several).
    Only,
    /// The annotator (CSV) or tier (ELAN) of this name.
    Named(String),
    /// Every annotator, combined by the consensus rule.
    Consensus(Consensus),
}

impl Annotators {
    /// From the readers' `annotator`/`tier` and `consensus` parameters (`field` names the
    /// former); both at once is an error.
    pub(crate) fn from_params(
        name: Option<String>,
        consensus: Option<ConsensusParams>,
        field: &str,
    ) -> Result<Self> {
        match (name, consensus) {
            (Some(_), Some(_)) => Err(Error::new(
                ErrorKind::InvalidParameter,
                format!("{field} picks one annotator and consensus combines them all; set one of the two"),
            )
            .with_field("consensus")),
            (Some(n), None) if n.trim().is_empty() => {
                Err(Error::new(ErrorKind::OutOfRange, "is empty; expected a name from the file").with_field(field))
            }
            (Some(n), None) => Ok(Annotators::Named(n)),
            (None, Some(c)) => Ok(Annotators::Consensus(c.check().map_err(|e| e.under_field("consensus"))?)),
            (None, None) => Ok(Annotators::Only),
        }
    }

    /// The ground truth of `motion` from its annotators' tracks; `to_frame` maps the format's
    /// values to fractional motion frames. `field` (`annotator` / `tier`) and `where_` (what
    /// the tracks are of, for messages) name things in errors.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn truth(
        &self,
        tracks: &[AnnotatorTrack],
        to_frame: impl Fn(f64) -> f64 + Copy,
        rule: EndRule,
        origin: &Path,
        motion: &Motion,
        field: &str,
        where_: &str,
    ) -> Result<Segmentation> {
        let (rate, n): (FrameRate, usize) = (motion.frame_rate(), motion.n_frames());
        let names =
            || tracks.iter().map(|t| format!("{:?}", t.annotator)).collect::<Vec<_>>().join(", ");
        match self {
            Annotators::Named(name) => {
                let Some(t) = tracks.iter().find(|t| &t.annotator == name) else {
                    return Err(Error::new(ErrorKind::UnknownName, format!("no {field} {name:?} in {where_}; it has {}", names()))
                        .with_location(Location::file(origin).field(field)));
                };
                track_segmentation(t, to_frame, rule, origin, rate, n)
            }
            Annotators::Only => match tracks {
                [one] => track_segmentation(one, to_frame, rule, origin, rate, n),
                _ => Err(Error::new(
                    ErrorKind::InvalidParameter,
                    format!(
                        "{} {field}s in {where_} ({}); choose one with `{field} = \"…\"` or combine them with `consensus = {{ min_votes = … }}`",
                        tracks.len(),
                        names()
                    ),
                )
                .with_location(Location::file(origin).field(field))),
            },
            Annotators::Consensus(rule_c) => {
                let marks = tracks
                    .iter()
                    .map(|t| track_segmentation(t, to_frame, rule, origin, rate, n).map(|s| s.frames()))
                    .collect::<Result<Vec<_>>>()?;
                let mut truth = rule_c.segmentation(&marks, motion).map_err(|e| e.in_file(origin))?;
                truth.annotator_names = tracks.iter().map(|t| t.annotator.clone()).collect();
                Ok(truth)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_io::labels::annotations::AnnotatedItem;
    use motionlab_testkit::motion_from_fn;

    fn track(who: &str, frames: &[f64]) -> AnnotatorTrack {
        let items = frames
            .iter()
            .enumerate()
            .map(|(i, &f)| AnnotatedItem {
                line: i + 2,
                start_field: "frame".into(),
                start: f,
                end: None,
                label: String::new(),
            })
            .collect();
        AnnotatorTrack { annotator: who.into(), items }
    }

    #[test]
    fn one_named_or_the_consensus_of_all() {
        let m = motion_from_fn(300, 100.0, 1, |_, _| [0.0; 3]);
        let o = Path::new("a.csv");
        let tracks =
            [track("ana", &[100.0, 200.0]), track("ben", &[103.0]), track("cy", &[98.0, 250.0])];
        let run = |a: Annotators| {
            a.truth(&tracks, |v| v, EndRule::LastEndOnly, o, &m, "annotator", "the file")
                .map(|s| s.frames())
        };
        assert_eq!(run(Annotators::Named("ben".into())).unwrap(), vec![103]);
        // Default min_votes = 2 of 3, tolerance 5 frames: 98, 100, 103 chain (median 100); 200 and 250 alone.
        let c: ConsensusParams = motionlab_core::registry::parse_params(
            &toml::from_str("tolerance = { frames = 5 }").unwrap(),
        )
        .unwrap();
        let consensus = Annotators::from_params(None, Some(c), "annotator").unwrap();
        assert_eq!(run(consensus.clone()).unwrap(), vec![100]);
        // Each annotator's own marks stay beside the consensus (for TCPDBench's metrics).
        let kept = consensus
            .truth(&tracks, |v| v, EndRule::LastEndOnly, o, &m, "annotator", "the file")
            .unwrap();
        assert_eq!(kept.annotators, vec![vec![100, 200], vec![103], vec![98, 250]]);
        assert_eq!(kept.annotator_names, vec!["ana", "ben", "cy"]);
        assert_eq!(kept.annotator_frames().len(), 3);
        // One named annotator is one annotator's truth.
        let one = Annotators::Named("ana".into())
            .truth(&tracks, |v| v, EndRule::LastEndOnly, o, &m, "annotator", "the file")
            .unwrap();
        assert!(one.annotators.is_empty());
        assert_eq!(one.annotator_frames(), vec![vec![100, 200]]);
        let e = run(Annotators::Only).unwrap_err();
        assert_eq!(
            (e.kind(), e.location().field.as_deref()),
            (ErrorKind::InvalidParameter, Some("annotator"))
        );
        assert!(e.to_string().contains("\"ana\", \"ben\", \"cy\""), "{e}");
        let e = run(Annotators::Named("dan".into())).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::UnknownName);
        let single = [track("", &[10.0])];
        assert_eq!(
            Annotators::Only
                .truth(&single, |v| v, EndRule::EveryEnd, o, &m, "annotator", "x")
                .unwrap()
                .frames(),
            vec![10]
        );
    }
}
