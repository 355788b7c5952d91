//! Consensus ground truth from several annotators' boundary lists (Sonoda et al. §3.1:
//! "points marked by at least 4 of the 8 annotators, and points marked by fewer where, for
//! example, the motion stops completely").
//!
//! # Clustering (precise definition)
//!
//! 1. Pool every mark of every annotator and sort by frame (ties by annotator).
//! 2. Chain: a mark starts a new cluster when it lies **more than** `tol` after the previous
//!    mark in that order; otherwise it joins the previous mark's cluster (single linkage). So two
//!    marks are in one cluster exactly when the gaps between consecutive marks between them are
//!    all ≤ `tol` — a cluster may span more than `tol` end to end; its span `[first, last]` is
//!    reported so such chains are visible.
//! 3. Votes = the number of **distinct** annotators with a mark in the cluster (an annotator who
//!    marks twice within one cluster votes once).
//! 4. Representative frame = the median of the cluster's marks (all of them); for an even count,
//!    the mean of the two middle marks rounded down (ties go to the earlier frame).
//! 5. Kept when votes ≥ `min_votes`; with the optional stop rule, a cluster with fewer votes (but
//!    at least the stop rule's own `min_votes`) is also kept when the fastest-marker speed V
//!    (Sonoda §2.1, `motionlab_features::speed`) is ≤ `max_speed` at some frame of
//!    `[first − tol, last + tol]`: the body fully stops there.
//!
//! Consensus is a plain function for now; a ground-truth reader for several annotator files can
//! wrap [`Consensus`] later (its params already deserialise from TOML).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{
    Boundary, Error, ErrorKind, MillimetresPerSecond, Motion, Result, Segmentation, TimeSpan,
};
use motionlab_features::speed::marker_speeds;

use crate::boundaries::tolerance_frames;

/// Consensus ground truth from several annotators' boundary marks.
///
/// Pools all marks, chains marks at most `tolerance` apart into one point (single linkage),
/// counts one vote per annotator per point, keeps points with at least `min_votes` votes, and
/// places each at the median of its marks. Optional stop rule: points with fewer votes are kept
/// where the fastest-marker speed V drops to `stop_rule.max_speed` (Sonoda et al. §3.1).
/// Missing samples: only the stop rule reads the motion; frames where V is undefined (a marker
/// missing everywhere, the last frame) are skipped when looking for a stop.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ConsensusParams {
    /// Marks at most this far after the previous mark (all annotators pooled, in time order)
    /// belong to the same point. The paper gives no number; the default allows for the spread
    /// of people clicking on a playing animation.
    #[serde(default = "default_tolerance")]
    pub tolerance: TimeSpan,
    /// A point is kept when at least this many distinct annotators marked it (≥ 1; the paper:
    /// 4 of 8).
    #[serde(default)]
    #[schemars(extend("x-default" = "half the annotators, rounded up"))]
    pub min_votes: Option<usize>,
    /// Keep points with fewer votes where the motion fully stops.
    #[serde(default)]
    #[schemars(extend("x-default" = "off"))]
    pub stop_rule: Option<StopRuleParams>,
}

/// The optional stop rule of [`ConsensusParams`].
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct StopRuleParams {
    /// The body counts as stopped where the fastest-marker speed V (mm/s) is at most this.
    /// Required: the noise floor of V depends on the capture system.
    pub max_speed: MillimetresPerSecond,
    /// A stopped point still needs this many annotators (≥ 1).
    #[serde(default = "default_stop_votes")]
    pub min_votes: usize,
}

fn default_tolerance() -> TimeSpan {
    TimeSpan::Seconds(0.25)
}

fn default_stop_votes() -> usize {
    1
}

/// The validated consensus rule.
#[derive(Clone, Debug, PartialEq)]
pub struct Consensus {
    pub tolerance: TimeSpan,
    pub min_votes: Option<usize>,
    pub stop_rule: Option<StopRule>,
}

/// The validated stop rule.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StopRule {
    pub max_speed_mm_per_s: f64,
    pub min_votes: usize,
}

impl ParamGuard for ConsensusParams {
    type Checked = Consensus;
    fn check(self) -> Result<Consensus> {
        let tolerance = self.tolerance.check("tolerance", false)?;
        if self.min_votes == Some(0) {
            return Err(Error::new(ErrorKind::OutOfRange, "must be at least 1 annotator, found 0")
                .with_field("min_votes"));
        }
        let stop_rule = match self.stop_rule {
            None => None,
            Some(s) => {
                let v = s.max_speed.value();
                if !(v.is_finite() && v >= 0.0) {
                    return Err(Error::new(
                        ErrorKind::OutOfRange,
                        format!("must be a finite speed >= 0 mm/s, found {v}"),
                    )
                    .with_field("stop_rule.max_speed"));
                }
                if s.min_votes == 0 {
                    return Err(Error::new(
                        ErrorKind::OutOfRange,
                        "must be at least 1 annotator, found 0",
                    )
                    .with_field("stop_rule.min_votes"));
                }
                Some(StopRule { max_speed_mm_per_s: v, min_votes: s.min_votes })
            }
        };
        Ok(Consensus { tolerance, min_votes: self.min_votes, stop_rule })
    }
}

/// One cluster of marks (see the module docs).
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct MarkCluster {
    /// Representative frame: the median of the marks.
    pub frame: usize,
    /// Earliest and latest mark.
    pub first: usize,
    pub last: usize,
    /// Distinct annotators who marked it.
    pub votes: usize,
    /// All marks in it (an annotator may contribute several).
    pub n_marks: usize,
    /// Indices of the annotators who marked it, ascending.
    pub annotators: Vec<usize>,
}

/// Why a consensus point was kept.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum KeptBy {
    Votes,
    StopRule,
}

/// A point of the consensus ground truth.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct ConsensusPoint {
    pub cluster: MarkCluster,
    pub kept_by: KeptBy,
}

/// Clusters the pooled marks of all annotators (`annotators[i]` = annotator i's frames) by
/// chaining marks at most `tol_frames` apart. Clusters come out in time order.
pub fn cluster_marks(annotators: &[Vec<usize>], tol_frames: f64) -> Vec<MarkCluster> {
    let mut marks: Vec<(usize, usize)> = annotators
        .iter()
        .enumerate()
        .flat_map(|(who, frames)| frames.iter().map(move |&f| (f, who)))
        .collect();
    marks.sort_unstable();
    let mut clusters = Vec::new();
    let mut start = 0;
    for i in 1..=marks.len() {
        let split = i == marks.len() || (marks[i].0 - marks[i - 1].0) as f64 > tol_frames;
        if split && start < marks.len() {
            clusters.push(make_cluster(&marks[start..i]));
            start = i;
        }
    }
    clusters
}

/// A cluster from its sorted, non-empty marks.
fn make_cluster(marks: &[(usize, usize)]) -> MarkCluster {
    let n = marks.len();
    let frame = if n % 2 == 1 { marks[n / 2].0 } else { (marks[n / 2 - 1].0 + marks[n / 2].0) / 2 };
    let mut annotators: Vec<usize> = marks.iter().map(|m| m.1).collect();
    annotators.sort_unstable();
    annotators.dedup();
    MarkCluster {
        frame,
        first: marks[0].0,
        last: marks[n - 1].0,
        votes: annotators.len(),
        n_marks: n,
        annotators,
    }
}

/// The consensus points from clusters: votes ≥ `min_votes`, or — with `stop` = (V in mm/s per
/// frame, stop rule) — fewer votes where V ≤ max speed somewhere in `[first − tol, last + tol]`.
pub fn select_points(
    clusters: Vec<MarkCluster>,
    min_votes: usize,
    tol_frames: f64,
    stop: Option<(&[f64], StopRule)>,
) -> Vec<ConsensusPoint> {
    clusters
        .into_iter()
        .filter_map(|cluster| {
            if cluster.votes >= min_votes {
                return Some(ConsensusPoint { cluster, kept_by: KeptBy::Votes });
            }
            let (speed, rule) = stop?;
            if cluster.votes < rule.min_votes || speed.is_empty() {
                return None;
            }
            let reach = tol_frames.max(0.0).floor() as usize;
            let lo = cluster.first.saturating_sub(reach);
            let hi = cluster.last.saturating_add(reach).min(speed.len() - 1);
            // NaN (undefined V) compares false and so never counts as a stop.
            let stopped = lo <= hi && speed[lo..=hi].iter().any(|&v| v <= rule.max_speed_mm_per_s);
            stopped.then_some(ConsensusPoint { cluster, kept_by: KeptBy::StopRule })
        })
        .collect()
}

impl Consensus {
    /// The consensus points of `annotators` (each a list of frames at `motion`'s rate).
    ///
    /// Errors: no annotators; a mark outside the motion (names `annotator[i]`); `min_votes`
    /// larger than the number of annotators (no point could ever be kept).
    pub fn run(&self, annotators: &[Vec<usize>], motion: &Motion) -> Result<Vec<ConsensusPoint>> {
        if annotators.is_empty() {
            return Err(Error::new(
                ErrorKind::EmptySequence,
                "consensus needs the marks of at least one annotator",
            )
            .with_field("annotators"));
        }
        let n_frames = motion.n_frames();
        for (who, marks) in annotators.iter().enumerate() {
            if let Some(&bad) = marks.iter().find(|&&f| f >= n_frames) {
                return Err(Error::new(
                    ErrorKind::OutOfRange,
                    format!(
                        "mark at frame {bad} is outside {} (frames 0..{n_frames})",
                        motion.name
                    ),
                )
                .with_field(format!("annotator[{who}]")));
            }
        }
        let min_votes = self.min_votes.unwrap_or(annotators.len().div_ceil(2));
        if min_votes > annotators.len() {
            return Err(Error::new(
                ErrorKind::InvalidParameter,
                format!(
                    "{min_votes} votes required but only {} annotators marked {}",
                    annotators.len(),
                    motion.name
                ),
            )
            .with_field("min_votes"));
        }
        let tol = tolerance_frames(self.tolerance, motion.frame_rate());
        let clusters = cluster_marks(annotators, tol);
        let speeds;
        let stop = match self.stop_rule {
            None => None,
            Some(rule) => {
                speeds = marker_speeds(motion, 0);
                Some((speeds.fastest.as_slice(), rule))
            }
        };
        Ok(select_points(clusters, min_votes, tol, stop))
    }

    /// The consensus as a [`Segmentation`] (boundaries only, each with its cluster's span as the
    /// annotated window, so evaluators' `use_windows` can accept the whole spread of marks).
    pub fn segmentation(&self, annotators: &[Vec<usize>], motion: &Motion) -> Result<Segmentation> {
        let boundaries = self
            .run(annotators, motion)?
            .into_iter()
            .map(|p| Boundary {
                frame: p.cluster.frame,
                window: Some((p.cluster.first, p.cluster.last)),
            })
            .collect();
        let annotators = annotators
            .iter()
            .map(|a| {
                let mut a = a.clone();
                a.sort_unstable();
                a
            })
            .collect();
        Ok(Segmentation {
            frame_rate: motion.frame_rate(),
            boundaries,
            segments: Vec::new(),
            annotators,
            annotator_names: Vec::new(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_testkit::{data_path, motion_from_fn};

    fn rule(toml_text: &str) -> Consensus {
        let v: toml::Value = toml::from_str(toml_text).unwrap();
        motionlab_core::registry::parse_params::<ConsensusParams>(&v).unwrap().check().unwrap()
    }

    #[test]
    fn hand_made_marks_cluster_vote_and_take_the_median() {
        // Four annotators, tol 3 frames.
        //  around 100: A 100, B 102, C 99, D 104 → chain 99,100,102,104 (gaps 1,2,2): 4 votes,
        //              median of 4 marks = (100 + 102) / 2 = 101.
        //  around 200: A 200, A 201, B 203 → 2 votes (A once), 3 marks, median 201.
        //  at 300:     C 300 → 1 vote.
        //  chain 400–409: D 400, C 403, B 406, A 409 (gaps of 3): one cluster spanning 9 frames.
        let marks =
            vec![vec![100, 200, 201, 409], vec![102, 203, 406], vec![99, 300, 403], vec![104, 400]];
        let c = cluster_marks(&marks, 3.0);
        let summary: Vec<(usize, usize, usize, usize, usize)> =
            c.iter().map(|c| (c.frame, c.first, c.last, c.votes, c.n_marks)).collect();
        assert_eq!(
            summary,
            vec![
                (101, 99, 104, 4, 4),
                (201, 200, 203, 2, 3),
                (300, 300, 300, 1, 1),
                (404, 400, 409, 4, 4)
            ]
        );
        assert_eq!(c[1].annotators, vec![0, 1]);
        // A gap of 4 > tol splits.
        let split = cluster_marks(&[vec![10], vec![14]], 3.0);
        assert_eq!(split.len(), 2);
        // Default min_votes for 4 annotators = 2: keeps 101, 201 and 404.
        let m = motion_from_fn(500, 120.0, 1, |_, _| [0.0; 3]);
        let kept = rule("tolerance = { frames = 3 }").run(&marks, &m).unwrap();
        let frames: Vec<usize> = kept.iter().map(|p| p.cluster.frame).collect();
        assert_eq!(frames, vec![101, 201, 404]);
        let kept = rule("tolerance = { frames = 3 }\nmin_votes = 3").run(&marks, &m).unwrap();
        assert_eq!(kept.iter().map(|p| p.cluster.frame).collect::<Vec<_>>(), vec![101, 404]);
    }

    #[test]
    fn the_stop_rule_adds_lone_marks_where_the_body_stops() {
        // One marker moving 10 mm/frame at 100 Hz (1000 mm/s) except frames 48–52 (still).
        // Lone marks at 50 (inside the stop) and 150 (moving): only 50 is added.
        let x = |i: usize| 10.0 * i.min(48) as f64 + 10.0 * i.saturating_sub(52) as f64;
        let m = motion_from_fn(200, 100.0, 1, |i, _| [x(i), 0.0, 0.0]);
        let marks = vec![vec![50], vec![150], vec![], vec![]];
        let c = rule("tolerance = { frames = 0 }\nmin_votes = 2\nstop_rule = { max_speed = 50.0 }");
        let kept = c.run(&marks, &m).unwrap();
        assert_eq!(kept.len(), 1);
        assert_eq!((kept[0].cluster.frame, kept[0].kept_by), (50, KeptBy::StopRule));
        // Without the stop rule nothing has two votes.
        assert!(
            rule("tolerance = { frames = 0 }\nmin_votes = 2").run(&marks, &m).unwrap().is_empty()
        );
        // The stop rule's own vote minimum applies.
        let strict = rule(
            "tolerance = { frames = 0 }\nmin_votes = 3\nstop_rule = { max_speed = 50.0, min_votes = 2 }",
        );
        assert!(strict.run(&marks, &m).unwrap().is_empty());
        // A marker missing everywhere near the mark: V is NaN there, which is never a stop.
        let gone = motion_from_fn(200, 100.0, 1, |i, _| {
            if (40..60).contains(&i) { [f64::NAN; 3] } else { [x(i), 0.0, 0.0] }
        });
        assert!(c.run(&marks, &gone).unwrap().is_empty());
    }

    #[test]
    fn segmentation_carries_the_cluster_span_as_window() {
        let m = motion_from_fn(300, 120.0, 1, |_, _| [0.0; 3]);
        let s = rule("tolerance = { frames = 5 }\nmin_votes = 2")
            .segmentation(&[vec![100, 200], vec![104]], &m)
            .unwrap();
        assert_eq!(s.boundaries, vec![Boundary { frame: 102, window: Some((100, 104)) }]);
        assert!(s.segments.is_empty());
    }

    #[test]
    fn bad_inputs_and_parameters_are_errors_naming_the_field() {
        let m = motion_from_fn(100, 120.0, 1, |_, _| [0.0; 3]);
        let c = rule("");
        assert_eq!(c.tolerance, TimeSpan::Seconds(0.25));
        let e = c.run(&[], &m).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::EmptySequence);
        let e = c.run(&[vec![5], vec![100]], &m).unwrap_err();
        assert_eq!(
            (e.kind(), e.location().field.as_deref()),
            (ErrorKind::OutOfRange, Some("annotator[1]"))
        );
        let e = rule("min_votes = 3").run(&[vec![5], vec![6]], &m).unwrap_err();
        assert_eq!(
            (e.kind(), e.location().field.as_deref()),
            (ErrorKind::InvalidParameter, Some("min_votes"))
        );
        let parse = |t: &str| {
            let v: toml::Value = toml::from_str(t).unwrap();
            motionlab_core::registry::parse_params::<ConsensusParams>(&v).and_then(|p| p.check())
        };
        assert_eq!(
            parse("min_votes = 0").unwrap_err().location().field.as_deref(),
            Some("min_votes")
        );
        assert_eq!(
            parse("tolerance = { seconds = -1.0 }").unwrap_err().location().field.as_deref(),
            Some("tolerance")
        );
        let e = parse("stop_rule = { max_speed = -5.0 }").unwrap_err();
        assert_eq!(e.location().field.as_deref(), Some("stop_rule.max_speed"));
        let e = parse("stop_rule = { min_votes = 1 }").unwrap_err();
        assert_eq!(e.kind(), ErrorKind::MissingKey);
        let e = parse("min_vote = 2").unwrap_err();
        assert_eq!(e.kind(), ErrorKind::UnknownKey);
    }

    /// The CMU-86 labels ship twice (mocap.txt and groundtruth86.json), transcribed separately:
    /// as two "annotators" they agree on every boundary of the 14 trials except trial 04 row 5
    /// (b = 5050 in the text, 5052 in the JSON). Boundaries are b − 1 (0-based); the last row of
    /// each trial is its length, not a boundary.
    #[test]
    fn real_cmu86_label_copies_agree_except_where_the_manifest_says() {
        let text = std::fs::read_to_string(data_path("cmu86/mocap.txt")).unwrap();
        let mut from_text: Vec<Vec<usize>> = Vec::new();
        for block in text.split("\n86 ").filter(|b| !b.trim().is_empty()) {
            let rows: Vec<usize> = block
                .lines()
                .skip(1)
                .filter_map(|l| l.split_whitespace().nth(2).and_then(|b| b.parse().ok()))
                .collect();
            from_text.push(rows[..rows.len() - 1].iter().map(|b| b - 1).collect());
        }
        let json: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(data_path("cmu86/groundtruth86.json")).unwrap(),
        )
        .unwrap();
        let from_json: Vec<Vec<usize>> = json["gt"]
            .as_array()
            .unwrap()
            .iter()
            .map(|trial| {
                let rows = trial.as_array().unwrap();
                rows[..rows.len() - 1].iter().map(|r| r[1].as_u64().unwrap() as usize - 1).collect()
            })
            .collect();
        assert_eq!(from_text.len(), 14);
        assert_eq!(from_json.len(), 14);
        let mut disagreements = Vec::new();
        for (trial, (a, b)) in from_text.iter().zip(&from_json).enumerate() {
            let exact = cluster_marks(&[a.clone(), b.clone()], 0.0);
            let kept = select_points(exact.clone(), 2, 0.0, None);
            for c in exact.iter().filter(|c| c.votes < 2) {
                disagreements.push((trial + 1, c.frame));
            }
            assert_eq!(kept.len(), a.len() - exact.iter().filter(|c| c.votes < 2).count() / 2);
            // With a 2-frame tolerance every boundary is agreed on, at the median of the two.
            let loose = select_points(cluster_marks(&[a.clone(), b.clone()], 2.0), 2, 2.0, None);
            assert_eq!(loose.len(), a.len(), "trial {}", trial + 1);
            for (p, (x, y)) in loose.iter().zip(a.iter().zip(b)) {
                assert_eq!(p.cluster.frame, (x + y) / 2);
            }
        }
        assert_eq!(disagreements, vec![(4, 5049), (4, 5051)]);
    }
}
