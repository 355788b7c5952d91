//! What `boundary_pr` found, as typed values: the contract between the boundary evaluator and
//! the workflows that build on it.
//!
//! The segmentation workflow's viewer pages draw each truth's tolerance band and each mark's
//! status (matched, missed, false positive); its sweeps choose operating points on training
//! sequences and redraw the chance baseline at them (`heldout_f1`), and draw precision–recall
//! curves. All of that reads a [`BoundaryAnalysis`] — the same counts, matches and null models
//! the evaluator's tables show — instead of finding those tables by name and parsing cells.

use std::ops::Range;

use serde::{Deserialize, Serialize};

use crate::boundaries::{PrScores, TruthWindow};
use crate::chance::{ChanceCounts, chance_counts, row_seed};

/// One boundary evaluation: every evaluated sequence, in input order.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct BoundaryAnalysis {
    pub sequences: Vec<SequenceBoundaries>,
}

/// One sequence's evaluation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SequenceBoundaries {
    pub sequence: String,
    /// The tolerance at this sequence's rate (frames), as the evaluator judged with it.
    pub tolerance_frames: f64,
    /// The chance baseline's null model on this sequence.
    pub chance: ChanceSetup,
    /// Each method in input order.
    pub methods: Vec<MethodBoundaries>,
}

/// One method on one sequence.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MethodBoundaries {
    pub method: String,
    pub counts: Counts,
    /// Every truth (matched or missed) and every unmatched found frame, in frame order.
    pub matches: Vec<BoundaryMatch>,
}

/// How one truth or found frame was judged.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MatchOutcome {
    /// Matched by the time rule.
    Matched,
    /// Matched only by the pose rule.
    MatchedByPose,
    /// A truth no found frame matched.
    Missed,
    /// A found frame that matched no truth (a false positive).
    Extra,
}

impl MatchOutcome {
    /// The `outcome` cell of the `boundary_matches` table.
    pub fn as_str(self) -> &'static str {
        match self {
            MatchOutcome::Matched => "matched",
            MatchOutcome::MatchedByPose => "matched_by_pose",
            MatchOutcome::Missed => "missed",
            MatchOutcome::Extra => "extra",
        }
    }
    /// Matched by either rule.
    pub fn is_match(self) -> bool {
        matches!(self, MatchOutcome::Matched | MatchOutcome::MatchedByPose)
    }
}

/// One row of a method's matches: a pair, a missed truth or an extra found frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct BoundaryMatch {
    pub outcome: MatchOutcome,
    pub truth_frame: Option<usize>,
    pub found_frame: Option<usize>,
}

/// Counts of one (sequence, method): what pooled scores sum (never the ratios).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Counts {
    pub n_truth: usize,
    pub n_found: usize,
    pub n_matched: usize,
    /// Pairs only the pose rule allowed (0 without it).
    pub n_matched_by_pose: usize,
}

/// The sum of two counts.
impl std::ops::Add for Counts {
    type Output = Counts;
    fn add(self, o: Counts) -> Counts {
        Counts {
            n_truth: self.n_truth + o.n_truth,
            n_found: self.n_found + o.n_found,
            n_matched: self.n_matched + o.n_matched,
            n_matched_by_pose: self.n_matched_by_pose + o.n_matched_by_pose,
        }
    }
}

impl Counts {
    /// The counts with (precision, recall, F1) exactly as `boundary_pr` computes them.
    pub fn scores(self) -> PrScores {
        PrScores::of(self.n_truth, self.n_found, self.n_matched)
    }
    /// Matched by the time rule alone (what the chance baseline's p-value compares).
    pub fn time_matched(self) -> usize {
        self.n_matched.saturating_sub(self.n_matched_by_pose)
    }
}

/// The chance baseline's null model on one sequence: what [`chance_counts`] needs besides the
/// number of candidates.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ChanceSetup {
    /// The evaluated span (frames, end exclusive).
    pub span: Range<usize>,
    /// Each truth's time-rule window.
    pub windows: Vec<TruthWindow>,
    pub draws: usize,
    /// Base seed, mixed with the sequence and method names by [`row_seed`].
    pub seed: u64,
}

impl ChanceSetup {
    /// The chance counts of `n_found` random candidates for `method` on `sequence`: the draws
    /// `boundary_pr` makes for that row.
    pub fn counts(&self, sequence: &str, method: &str, n_found: usize) -> ChanceCounts {
        chance_counts(
            n_found,
            &self.windows,
            self.span.clone(),
            self.draws,
            row_seed(self.seed, sequence, method),
        )
    }
}

impl BoundaryAnalysis {
    /// The sequence named `name`.
    pub fn sequence(&self, name: &str) -> Option<&SequenceBoundaries> {
        self.sequences.iter().find(|s| s.sequence == name)
    }
    /// Every method's counts pooled over the sequences, methods in order of first appearance.
    pub fn pooled(&self) -> Vec<(String, Counts)> {
        let mut out: Vec<(String, Counts)> = Vec::new();
        for m in self.sequences.iter().flat_map(|s| &s.methods) {
            match out.iter_mut().find(|(n, _)| *n == m.method) {
                Some((_, c)) => *c = *c + m.counts,
                None => out.push((m.method.clone(), m.counts)),
            }
        }
        out
    }
}

impl SequenceBoundaries {
    /// The method named `name`.
    pub fn method(&self, name: &str) -> Option<&MethodBoundaries> {
        self.methods.iter().find(|m| m.method == name)
    }
}
