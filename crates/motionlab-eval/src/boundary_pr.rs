//! Evaluator plugin `boundary_pr`: the paper's Table 1 / Table 2 — precision, recall and F1 of
//! every method on every sequence, and pooled over sequences.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{
    Analysis, Error, ErrorKind, EvalInput, EvalInputType, Evaluation, Evaluator, Millimetres,
    Result, Table, TimeSpan,
};

use crate::boundary_analysis::{
    BoundaryAnalysis, BoundaryMatch, ChanceSetup, Counts, MatchOutcome, MethodBoundaries,
    SequenceBoundaries,
};

use crate::boundaries::{
    MatchRule, PoseRule, TruthWindow, default_tolerance, evaluate_boundaries, max_matching_windows,
    ratios, tolerance_frames,
};
use crate::chance::{
    ChanceCounts, ChanceScores, ChanceSettings, chance_counts, periodic_candidates, row_seed,
};
use crate::sequences::{location_of, nothing_to_evaluate, segmentation_input, truth_of};
use crate::span::{Span, counted};

// How a mark was judged (`boundary_matches`) is a result, not a row name (`motionlab compare`).
motionlab_core::declare_outcome_column!("outcome");

/// Precision, recall and F1 of each method against the ground truth, per sequence and pooled
/// (Sonoda et al. §3, Tables 1 and 2).
///
/// A found frame `a` and a truth `r` may match when `|a − r| ≤ tolerance` (and, with
/// `use_windows`, anywhere in the truth's annotated transition window widened by the
/// tolerance); with `pose_mm`, also when the root-aligned mean marker distance between the two
/// frames is below `pose_mm` (optionally only within `pose_max_gap`). Each truth and each found
/// frame is used at most once, in a **maximum** one-to-one matching (greedy nearest-first can
/// miss pairs). `precision = matched / found`, `recall = matched / truth`,
/// `F1 = 2·matched / (found + truth)`.
///
/// Empty sets: precision is NaN (empty cell) when a method found nothing, recall is NaN when a
/// sequence has no truth boundaries; F1 is NaN only when both are empty. The Hausdorff distance
/// between found and truth frames is 0 when both are empty and infinite (empty cell) when one is.
///
/// Output tables:
/// - `table1_precision_recall`: one row per (sequence, method) in experiment order, then one
///   `pooled` row per method over all sequences with ground truth — ratios of the summed counts
///   (not means of ratios); its `hausdorff_s` is the largest per-sequence value (the Hausdorff
///   distance of the sequences laid end to end infinitely far apart).
///   Beside each method's numbers, two trivial baselines over the evaluated span (the motion's
///   frames `0..n_frames`, or with `span = "annotated"` the annotated span widened by the
///   tolerance, with the method's count of found frames in it), scored by the time rule (module `chance`, which documents every
///   choice): **chance** — the same number of distinct frames drawn uniformly at random:
///   `chance_matched` (expected matched count), `chance_precision`, `chance_recall`,
///   `chance_f1` (expectations; `chance_expectation` says `exact` — truth windows disjoint, closed
///   form — or `monte_carlo`), `chance_f1_se` (standard error of `chance_f1`, 0 when exact),
///   `p_value` (one-sided Monte Carlo, `(1 + #{draws matching ≥ the method}) / (1 + chance_draws)`;
///   with the pose rule on, the method's time-rule matches are compared) and `above_chance`
///   (`yes` when `p_value < 0.05`); **periodic** — as many candidates as truths, equally spaced
///   and centred in the span: `periodic_n_found`, `periodic_precision`, `periodic_recall`,
///   `periodic_f1`. Pooled rows pool the baselines too (sums of expected and periodic counts;
///   the pooled p-value from the per-draw sums over sequences).
/// - `boundary_matches`: every truth (matched, matched_by_pose or missed) and every unmatched
///   found frame (extra), with the offset found − truth in seconds.
/// - `chance_windows`: the chance baseline's null model per sequence — the evaluated span
///   (`span_start..span_end`, frames), each truth's time-rule window `[window_lo, window_hi]`
///   (frames; one row per truth, one row without a window when a sequence has none), and
///   `chance_draws`, `chance_seed`. With these and [`crate::chance::chance_counts`] anyone can
///   redraw the baseline of any number of candidates; the `[segmentation]` workflow does so for
///   the held-out operating points of a sweep (`heldout_f1`), which get the same draws as this
///   table's row of the chosen combination.
/// - `claim_fused_recall` (when there are ≥ 2 methods): does the last method — the fuser's
///   output, which the segmentation workflow appends after the segmenters — reach a higher pooled recall than
///   every other method? (The paper's central claim.)
///
/// Sequences without ground truth are skipped; it is an error when none has any.
/// Missing samples: only the pose rule reads positions — markers missing at either frame are
/// left out of the mean distance, and a missing root means no pose match.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct BoundaryPrParams {
    /// Largest offset between a found frame and a truth that still matches, in frames or
    /// seconds (resolved at each motion's rate). The default reads the paper's 5 frames
    /// (ballet) and 10 frames (street dance) as one duration: 60 Hz and 120 Hz captures.
    #[serde(default = "default_tolerance")]
    pub tolerance: TimeSpan,
    /// Also accept a found frame anywhere in the truth's annotated transition window (CMU-86
    /// labels give one per boundary), widened by `tolerance`; off, only points count, as in the
    /// paper.
    #[serde(default)]
    pub use_windows: bool,
    /// Second match rule: two frames also match when their root-aligned mean marker distance is
    /// below this many mm.
    #[serde(default)]
    #[schemars(extend("x-default" = "the time rule only"))]
    pub pose_mm: Option<Millimetres>,
    /// Limit the pose rule to frames at most this far apart (the paper sets no limit, which in
    /// repetitive motion lets a pose match a truth far away).
    #[serde(default)]
    #[schemars(extend("x-default" = "no limit"))]
    pub pose_max_gap: Option<TimeSpan>,
    /// The point subtracted before comparing poses (the CMU skeletons have a `root` joint;
    /// marker sets without one can add it with the `add_centroid` preprocessor).
    #[serde(default = "default_root")]
    pub root: String,
    /// The single methods the fused method's recall is compared with in `claim_fused_recall`
    /// (the paper compares its fusion with the methods it fuses, not with baselines).
    #[serde(default)]
    #[schemars(extend("x-default" = "every other method"))]
    pub claim_against: Option<Vec<String>>,
    /// Which found frames count: `"whole"` (every one) or `"annotated"` (only those from the
    /// first to the last annotation of the sequence, ± `tolerance`: recordings start and end
    /// with stretches nobody annotated).
    #[serde(default)]
    pub span: Span,
    /// Number of random draws of the chance baseline's Monte Carlo (p-value, and the expectation
    /// when truth windows overlap), ≥ 100; N draws resolve p-values down to 1/(N + 1). Cost per
    /// method and sequence at 86_01's size: 0.4 ms for 2 candidates to 81 ms for 278
    /// (`examples/chance_timing.rs`, debug build).
    #[serde(default = "crate::chance::default_draws")]
    pub chance_draws: usize,
    /// Base seed of the chance draws (mixed with the sequence and method names).
    #[serde(default = "crate::chance::default_seed")]
    pub chance_seed: u64,
}

fn default_root() -> String {
    "root".into()
}

/// The validated evaluator.
#[derive(Clone, Debug)]
pub struct BoundaryPr {
    tolerance: TimeSpan,
    use_windows: bool,
    pose_mm: Option<f64>,
    pose_max_gap: Option<TimeSpan>,
    root: String,
    claim_against: Option<Vec<String>>,
    span: Span,
    chance: ChanceSettings,
}

impl ParamGuard for BoundaryPrParams {
    type Checked = BoundaryPr;
    fn check(self) -> Result<BoundaryPr> {
        let tolerance = self.tolerance.check("tolerance", false)?;
        let pose_max_gap = self.pose_max_gap.map(|g| g.check("pose_max_gap", false)).transpose()?;
        let pose_mm = match self.pose_mm {
            None => None,
            Some(Millimetres(v)) if v.is_finite() && v > 0.0 => Some(v),
            Some(Millimetres(v)) => {
                return Err(Error::new(
                    ErrorKind::OutOfRange,
                    format!("must be a finite distance > 0 mm, found {v}"),
                )
                .with_field("pose_mm"));
            }
        };
        if pose_max_gap.is_some() && pose_mm.is_none() {
            return Err(Error::new(
                ErrorKind::InvalidParameter,
                "pose_max_gap limits the pose rule, which is off: set pose_mm too",
            )
            .with_field("pose_max_gap"));
        }
        if self.root.trim().is_empty() {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                "must name a marker or joint, found an empty name",
            )
            .with_field("root"));
        }
        if self.claim_against.as_ref().is_some_and(|v| v.is_empty()) {
            return Err(Error::new(ErrorKind::OutOfRange, "must name at least one method")
                .with_field("claim_against"));
        }
        let chance = ChanceSettings::checked(self.chance_draws, self.chance_seed)?;
        Ok(BoundaryPr {
            tolerance,
            use_windows: self.use_windows,
            pose_mm,
            pose_max_gap,
            root: self.root,
            claim_against: self.claim_against,
            span: self.span,
            chance,
        })
    }
}

/// A row of `table1_precision_recall`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PrecisionRecallRow {
    /// Sequence name, or `pooled`.
    pub sequence: String,
    pub method: String,
    pub n_truth: usize,
    pub n_found: usize,
    pub n_matched: usize,
    /// Pairs only the pose rule allowed.
    pub n_matched_by_pose: usize,
    pub precision: f64,
    pub recall: f64,
    pub f1: f64,
    /// None when infinite, and on pooled rows (frames at different rates do not compare).
    pub hausdorff_frames: Option<f64>,
    /// None when infinite.
    pub hausdorff_s: Option<f64>,
    /// The tolerance at this sequence's rate; None on pooled rows.
    pub tolerance_frames: Option<f64>,
    /// `n_found` uniformly random distinct frames: the `chance_*`, `p_value` and
    /// `above_chance` columns.
    #[serde(flatten)]
    pub chance: ChanceScores,
    /// The periodic baseline: as many candidates as truths, equally spaced.
    pub periodic_n_found: usize,
    pub periodic_precision: f64,
    pub periodic_recall: f64,
    pub periodic_f1: f64,
}

/// The baselines' columns of a row, from the chance counts, the method's time-rule matched
/// count, and the periodic baseline's counts.
struct Baselines {
    chance: ChanceCounts,
    method_time_matched: usize,
    n_truth: usize,
    periodic_found: usize,
    periodic_matched: usize,
}

impl Baselines {
    fn fill(&self, row: &mut PrecisionRecallRow) {
        row.chance = ChanceScores::of(&self.chance, self.n_truth, self.method_time_matched);
        let (p, r, f) = ratios(self.periodic_found, self.n_truth, self.periodic_matched);
        row.periodic_n_found = self.periodic_found;
        (row.periodic_precision, row.periodic_recall, row.periodic_f1) = (p, r, f);
    }
}

impl PrecisionRecallRow {
    /// A row with no numbers yet (the baselines' columns are filled by `Baselines::fill`).
    fn blank() -> Self {
        PrecisionRecallRow {
            sequence: String::new(),
            method: String::new(),
            n_truth: 0,
            n_found: 0,
            n_matched: 0,
            n_matched_by_pose: 0,
            precision: f64::NAN,
            recall: f64::NAN,
            f1: f64::NAN,
            hausdorff_frames: None,
            hausdorff_s: None,
            tolerance_frames: None,
            chance: ChanceScores::none(),
            periodic_n_found: 0,
            periodic_precision: f64::NAN,
            periodic_recall: f64::NAN,
            periodic_f1: f64::NAN,
        }
    }
}

/// A row of `boundary_matches`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BoundaryMatchRow {
    pub sequence: String,
    pub method: String,
    /// `matched`, `matched_by_pose`, `missed` (a truth nobody matched) or `extra` (a found frame
    /// that matched no truth).
    pub outcome: &'static str,
    pub truth_frame: Option<usize>,
    pub found_frame: Option<usize>,
    /// found − truth, seconds (matched rows only).
    pub offset_s: Option<f64>,
}

/// A row of `chance_windows`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ChanceWindowRow {
    pub sequence: String,
    /// The evaluated span `span_start..span_end` (frames, end exclusive).
    pub span_start: usize,
    pub span_end: usize,
    /// The truth's own frame (None on the row of a sequence without truths).
    pub truth_frame: Option<usize>,
    /// The truth's time-rule window, fractional frames.
    pub window_lo: Option<f64>,
    pub window_hi: Option<f64>,
    /// Monte Carlo draws.
    pub chance_draws: usize,
    /// Base seed (mixed with the sequence and method names by `chance::row_seed`), in decimal:
    /// text, because a table's integer column holds only `i64`.
    pub chance_seed: String,
}

/// The one row of `claim_fused_recall`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FusedRecallClaim {
    /// The last method (the fuser's output).
    pub fused_method: String,
    pub fused_recall: f64,
    /// The other method with the highest pooled recall.
    pub best_other_method: String,
    pub best_other_recall: f64,
    /// fused_recall > every other method's pooled recall (false when any recall is NaN).
    pub fused_exceeds_all: bool,
    pub n_sequences: usize,
}

#[derive(Default)]
struct Pool {
    n_truth: usize,
    n_found: usize,
    n_matched: usize,
    n_by_pose: usize,
    hausdorff_s: f64,
    chance: Vec<ChanceCounts>,
    time_matched: usize,
    periodic_found: usize,
    periodic_matched: usize,
}

impl Evaluator for BoundaryPr {
    fn input_type(&self) -> EvalInputType {
        EvalInputType::segmentation()
    }

    fn evaluate(&self, input: EvalInput<'_>) -> Result<Vec<Table>> {
        self.evaluate_with_analysis(input).map(|e| e.tables)
    }

    fn analysis_type(&self) -> Option<std::any::TypeId> {
        Some(std::any::TypeId::of::<BoundaryAnalysis>())
    }

    /// The tables, and the same judgement as a [`BoundaryAnalysis`].
    fn evaluate_with_analysis(&self, input: EvalInput<'_>) -> Result<Evaluation> {
        let sequences = segmentation_input(input, "boundary_pr")?;
        let mut analysis = BoundaryAnalysis::default();
        let mut rows = Vec::new();
        let mut match_rows = Vec::new();
        let mut window_rows = Vec::new();
        // Per method, in order of first appearance.
        let mut pools: Vec<(String, Pool)> = Vec::new();
        let mut n_evaluated = 0;
        for seq in sequences {
            let Some(truth) = truth_of(seq)? else { continue };
            n_evaluated += 1;
            let rate = seq.motion.frame_rate();
            let period_s = rate.frame_period().value();
            let pose = match self.pose_mm {
                None => None,
                Some(mm) => Some(
                    PoseRule::new(&seq.motion, &self.root, mm, self.pose_max_gap).map_err(|e| {
                        if e.location().file.is_none() {
                            e.with_location(location_of(seq).field("root"))
                        } else {
                            e
                        }
                    })?,
                ),
            };
            let rule = MatchRule {
                tolerance_frames: tolerance_frames(self.tolerance, rate),
                use_windows: self.use_windows,
                pose,
            };
            // The baselines' span (the evaluated one: the whole motion, or the annotated span
            // widened by the tolerance) and time-rule windows (the chance module's docs).
            let n_frames = seq.motion.n_frames();
            let span = match (self.span, crate::span::annotated_span(truth)) {
                (Span::Annotated, Some((first, last))) => {
                    let lo = (first as f64 - rule.tolerance_frames).ceil().max(0.0) as usize;
                    let hi =
                        ((last as f64 + rule.tolerance_frames).floor() as usize + 1).min(n_frames);
                    lo.min(hi)..hi
                }
                (Span::Annotated, None) => 0..0,
                (Span::Whole, _) => 0..n_frames,
            };
            let windows: Vec<TruthWindow> = truth
                .boundaries
                .iter()
                .map(|b| TruthWindow::from_boundary(b, rule.tolerance_frames, rule.use_windows))
                .collect();
            let window_row = |w: Option<&TruthWindow>| ChanceWindowRow {
                sequence: seq.sequence.clone(),
                span_start: span.start,
                span_end: span.end,
                truth_frame: w.map(|w| w.frame),
                window_lo: w.map(|w| w.lo),
                window_hi: w.map(|w| w.hi),
                chance_draws: self.chance.draws,
                chance_seed: self.chance.seed.to_string(),
            };
            if windows.is_empty() {
                window_rows.push(window_row(None));
            }
            window_rows.extend(windows.iter().map(|w| window_row(Some(w))));
            let periodic = periodic_candidates(windows.len(), span.clone());
            let periodic_matched = max_matching_windows(&periodic, &windows).len();
            let mut judged = SequenceBoundaries {
                sequence: seq.sequence.clone(),
                tolerance_frames: self.tolerance.frames_at(rate),
                chance: ChanceSetup {
                    span: span.clone(),
                    windows: windows.clone(),
                    draws: self.chance.draws,
                    seed: self.chance.seed,
                },
                methods: Vec::new(),
            };
            for m in &seq.methods {
                let candidates = counted(&m.candidates, truth, self.span, rule.tolerance_frames);
                let s = evaluate_boundaries(&candidates, &truth.boundaries, &rule);
                let n_by_pose = s.pairs.iter().filter(|p| p.by_pose).count();
                let hausdorff_s = s.hausdorff_frames * period_s;
                let method_time_matched = if rule.pose.is_some() {
                    max_matching_windows(&candidates, &windows).len()
                } else {
                    s.scores.n_matched
                };
                let baselines = Baselines {
                    chance: chance_counts(
                        candidates.len(),
                        &windows,
                        span.clone(),
                        self.chance.draws,
                        row_seed(self.chance.seed, &seq.sequence, &m.method),
                    ),
                    method_time_matched,
                    n_truth: s.scores.n_truth,
                    periodic_found: periodic.len(),
                    periodic_matched,
                };
                let mut row = PrecisionRecallRow {
                    sequence: seq.sequence.clone(),
                    method: m.method.clone(),
                    n_truth: s.scores.n_truth,
                    n_found: s.scores.n_found,
                    n_matched: s.scores.n_matched,
                    n_matched_by_pose: n_by_pose,
                    precision: s.scores.precision,
                    recall: s.scores.recall,
                    f1: s.scores.f1,
                    hausdorff_frames: s.hausdorff_frames.is_finite().then_some(s.hausdorff_frames),
                    hausdorff_s: hausdorff_s.is_finite().then_some(hausdorff_s),
                    tolerance_frames: Some(self.tolerance.frames_at(rate)),
                    ..PrecisionRecallRow::blank()
                };
                baselines.fill(&mut row);
                rows.push(row);
                let at = match pools.iter().position(|(name, _)| *name == m.method) {
                    Some(i) => i,
                    None => {
                        pools.push((m.method.clone(), Pool::default()));
                        pools.len() - 1
                    }
                };
                let pool = &mut pools[at].1;
                pool.n_truth += s.scores.n_truth;
                pool.n_found += s.scores.n_found;
                pool.n_matched += s.scores.n_matched;
                pool.n_by_pose += n_by_pose;
                pool.hausdorff_s = pool.hausdorff_s.max(hausdorff_s);
                pool.time_matched += method_time_matched;
                pool.periodic_found += baselines.periodic_found;
                pool.periodic_matched += baselines.periodic_matched;
                pool.chance.push(baselines.chance);

                let matches = matches_of(&candidates, &truth.frames(), &s);
                match_rows.extend(
                    matches
                        .iter()
                        .map(|b| BoundaryMatchRow::of(&seq.sequence, &m.method, b, period_s)),
                );
                judged.methods.push(MethodBoundaries {
                    method: m.method.clone(),
                    counts: Counts {
                        n_truth: s.scores.n_truth,
                        n_found: s.scores.n_found,
                        n_matched: s.scores.n_matched,
                        n_matched_by_pose: n_by_pose,
                    },
                    matches,
                });
            }
            analysis.sequences.push(judged);
        }
        if n_evaluated == 0 {
            return Err(nothing_to_evaluate("boundary_pr", "ground truth", sequences.len()));
        }
        for (method, p) in &pools {
            let (precision, recall, f1) = ratios(p.n_found, p.n_truth, p.n_matched);
            let baselines = Baselines {
                chance: ChanceCounts::pooled(&p.chance),
                method_time_matched: p.time_matched,
                n_truth: p.n_truth,
                periodic_found: p.periodic_found,
                periodic_matched: p.periodic_matched,
            };
            let mut row = PrecisionRecallRow {
                sequence: "pooled".into(),
                method: method.clone(),
                n_truth: p.n_truth,
                n_found: p.n_found,
                n_matched: p.n_matched,
                n_matched_by_pose: p.n_by_pose,
                precision,
                recall,
                f1,
                hausdorff_frames: None,
                hausdorff_s: p.hausdorff_s.is_finite().then_some(p.hausdorff_s),
                tolerance_frames: None,
                ..PrecisionRecallRow::blank()
            };
            baselines.fill(&mut row);
            rows.push(row);
        }
        let pose_text = match self.pose_mm {
            Some(mm) => format!(", or pose within {mm} mm"),
            None => String::new(),
        };
        let mut tables = vec![
            Table::from_records(
                "table1_precision_recall",
                format!(
                    "Table 1: precision, recall and F1 per method (tolerance {}{pose_text}; maximum one-to-one matching)",
                    self.tolerance
                ),
                &rows,
            )?,
            Table::from_records(
                "boundary_matches",
                "Matched, missed and extra boundaries per method",
                &match_rows,
            )?,
        ];
        if let Some(claim) = fused_recall_claim(&rows, n_evaluated, self.claim_against.as_deref())?
        {
            tables.push(Table::from_records(
                "claim_fused_recall",
                "Does the fused method's pooled recall exceed every single method's?",
                &[claim],
            )?);
        }
        tables.push(Table::from_records(
            "chance_windows",
            "The chance baseline's null model: evaluated span and truth windows (frames) per sequence, draws and seed",
            &window_rows,
        )?);
        Ok(Evaluation { tables, analysis: Some(Analysis::cacheable(analysis)) })
    }
}

impl BoundaryMatchRow {
    fn of(sequence: &str, method: &str, b: &BoundaryMatch, period_s: f64) -> Self {
        BoundaryMatchRow {
            sequence: sequence.into(),
            method: method.into(),
            outcome: b.outcome.as_str(),
            truth_frame: b.truth_frame,
            found_frame: b.found_frame,
            offset_s: b
                .truth_frame
                .zip(b.found_frame)
                .map(|(t, f)| (f as f64 - t as f64) * period_s),
        }
    }
}

/// Every truth (matched or missed) and every unmatched found frame of one method on one
/// sequence, in frame order.
fn matches_of(
    found: &[usize],
    truth: &[usize],
    s: &crate::boundaries::BoundaryScores,
) -> Vec<BoundaryMatch> {
    let mark = |outcome, truth_frame: Option<usize>, found_frame: Option<usize>| BoundaryMatch {
        outcome,
        truth_frame,
        found_frame,
    };
    let mut out: Vec<(usize, BoundaryMatch)> = Vec::new();
    // Duplicated frames are counted: remove one occurrence per pair.
    let mut unmatched_truth = truth.to_vec();
    let mut unmatched_found = found.to_vec();
    for p in &s.pairs {
        if let Some(i) = unmatched_truth.iter().position(|&t| t == p.truth) {
            unmatched_truth.swap_remove(i);
        }
        if let Some(i) = unmatched_found.iter().position(|&f| f == p.found) {
            unmatched_found.swap_remove(i);
        }
        let outcome = if p.by_pose { MatchOutcome::MatchedByPose } else { MatchOutcome::Matched };
        out.push((p.truth, mark(outcome, Some(p.truth), Some(p.found))));
    }
    out.extend(unmatched_truth.into_iter().map(|t| (t, mark(MatchOutcome::Missed, Some(t), None))));
    out.extend(unmatched_found.into_iter().map(|f| (f, mark(MatchOutcome::Extra, None, Some(f)))));
    out.sort_by_key(|(frame, r)| (*frame, r.found_frame));
    out.into_iter().map(|(_, r)| r).collect()
}

/// The paper's central claim on the pooled rows: the last method's recall against the others'
/// (or against the named ones).
fn fused_recall_claim(
    rows: &[PrecisionRecallRow],
    n_sequences: usize,
    against: Option<&[String]>,
) -> Result<Option<FusedRecallClaim>> {
    let pooled: Vec<&PrecisionRecallRow> = rows.iter().filter(|r| r.sequence == "pooled").collect();
    let Some((fused, others)) = pooled.split_last() else { return Ok(None) };
    let others: Vec<&&PrecisionRecallRow> = match against {
        None => others.iter().collect(),
        Some(names) => {
            for n in names {
                if !others.iter().any(|o| &o.method == n) {
                    return Err(Error::new(
                        ErrorKind::UnknownName,
                        format!(
                            "claim_against names {n:?}, which is not a method of this experiment"
                        ),
                    )
                    .with_field("claim_against"));
                }
            }
            others.iter().filter(|o| names.contains(&o.method)).collect()
        }
    };
    let Some(best) = others.iter().max_by(|a, b| a.recall.total_cmp(&b.recall)) else {
        return Ok(None);
    };
    Ok(Some(FusedRecallClaim {
        fused_method: fused.method.clone(),
        fused_recall: fused.recall,
        best_other_method: best.method.clone(),
        best_other_recall: best.recall,
        fused_exceeds_all: others.iter().all(|o| fused.recall > o.recall),
        n_sequences,
    }))
}

motionlab_core::register_plugin!(Evaluator, BoundaryPrParams, "boundary_pr");

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sequences::fixtures::sequence;
    use motionlab_core::ColumnValues;
    use motionlab_core::registry::{build_evaluator, parse_params};

    fn evaluator(toml_text: &str) -> Box<dyn Evaluator> {
        let v: toml::Value = toml::from_str(toml_text).unwrap();
        build_evaluator("boundary_pr", &v).unwrap()
    }

    fn f64s(t: &Table, name: &str) -> Vec<f64> {
        match t.column(name) {
            Some(ColumnValues::F64(v)) => v.clone(),
            Some(ColumnValues::I64(v)) => v.iter().map(|&x| x as f64).collect(),
            other => panic!("{name}: {other:?}"),
        }
    }

    fn strs(t: &Table, name: &str) -> Vec<String> {
        (0..t.n_rows()).map(|i| t.column(name).unwrap().cell(i)).collect()
    }

    /// The typed analysis says what the tables say: the counts of every (sequence, method) row,
    /// each sequence's tolerance, every `boundary_matches` row, and the chance null model of
    /// `chance_windows` — and the pooled counts are the `pooled` rows'.
    #[test]
    fn the_analysis_equals_the_tables() {
        let seqs = vec![
            sequence(
                "a",
                600,
                100.0,
                Some(vec![(0, 100, "x"), (100, 200, "y"), (200, 300, "x"), (300, 600, "z")]),
                &[("speed", &[105, 290, 500]), ("fused", &[100, 200, 300, 400])],
            ),
            sequence(
                "b",
                100,
                50.0,
                Some(vec![(0, 50, "x"), (50, 100, "y")]),
                &[("speed", &[]), ("fused", &[52])],
            ),
        ];
        let e = evaluator("tolerance = { seconds = 0.1 }\nchance_draws = 200")
            .evaluate_with_analysis(EvalInput::segmentation(&seqs))
            .unwrap();
        let a = e.analysis::<BoundaryAnalysis>().unwrap();
        let t1 = &e.tables[0];
        let (seq, method) = (strs(t1, "sequence"), strs(t1, "method"));
        let (truth, found, matched, tol) = (
            f64s(t1, "n_truth"),
            f64s(t1, "n_found"),
            f64s(t1, "n_matched"),
            strs(t1, "tolerance_frames"),
        );
        let mut rows = 0;
        for r in 0..t1.n_rows() {
            let counts = if seq[r] == "pooled" {
                a.pooled().into_iter().find(|(m, _)| *m == method[r]).unwrap().1
            } else {
                let s = a.sequence(&seq[r]).unwrap();
                assert_eq!(s.tolerance_frames.to_string(), tol[r]);
                s.method(&method[r]).unwrap().counts
            };
            assert_eq!(
                (counts.n_truth as f64, counts.n_found as f64, counts.n_matched as f64),
                (truth[r], found[r], matched[r]),
                "row {r}"
            );
            rows += 1;
        }
        assert_eq!(rows, 6);
        let bm = &e.tables[1];
        let listed: Vec<String> = a
            .sequences
            .iter()
            .flat_map(|s| {
                s.methods.iter().flat_map(move |m| {
                    m.matches.iter().map(move |b| {
                        format!(
                            "{} {} {} {:?} {:?}",
                            s.sequence,
                            m.method,
                            b.outcome.as_str(),
                            b.truth_frame,
                            b.found_frame
                        )
                    })
                })
            })
            .collect();
        let frame = |c: &str, r: usize| bm.column(c).unwrap().cell(r).parse::<usize>().ok();
        let tabled: Vec<String> = (0..bm.n_rows())
            .map(|r| {
                format!(
                    "{} {} {} {:?} {:?}",
                    strs(bm, "sequence")[r],
                    strs(bm, "method")[r],
                    strs(bm, "outcome")[r],
                    frame("truth_frame", r),
                    frame("found_frame", r)
                )
            })
            .collect();
        assert_eq!(listed, tabled);
        let cw = e.tables.iter().find(|t| t.name == "chance_windows").unwrap();
        let starts = f64s(cw, "span_start");
        let los = f64s(cw, "window_lo");
        let from_analysis: Vec<(f64, f64)> = a
            .sequences
            .iter()
            .flat_map(|s| s.chance.windows.iter().map(move |w| (s.chance.span.start as f64, w.lo)))
            .collect();
        assert_eq!(from_analysis, starts.into_iter().zip(los).collect::<Vec<_>>());
        // Restored from its encoded form (as a cached run reads it), it is the same value.
        let restored = motionlab_core::Analysis::restored(
            e.analysis.as_ref().unwrap().type_name(),
            e.analysis.as_ref().unwrap().encode().unwrap(),
        );
        assert_eq!(restored.read::<BoundaryAnalysis>().as_ref(), Some(a));
    }

    #[test]
    fn table1_rows_per_sequence_and_pooled_ratios_of_sums() {
        // Sequence a (100 Hz, tol 10 frames at 1/10 s): truth 100, 200, 300.
        //   speed: 105, 290, 500 → 2 matched of 3 found, 3 truths.
        //   fused: 100, 200, 300, 400 → 3 of 4.
        // Sequence b (50 Hz, tol 5 frames): truth 50.
        //   speed: nothing → precision NaN, recall 0.
        //   fused: 52 → 1 of 1.
        // Pooled speed: 2 matched / 3 found, 2 / 4 truths; fused: 4 / 5 found, 4 / 4 truths.
        let seqs = vec![
            sequence(
                "a",
                600,
                100.0,
                Some(vec![(0, 100, "x"), (100, 200, "y"), (200, 300, "x"), (300, 600, "z")]),
                &[("speed", &[105, 290, 500]), ("fused", &[100, 200, 300, 400])],
            ),
            sequence(
                "b",
                100,
                50.0,
                Some(vec![(0, 50, "x"), (50, 100, "y")]),
                &[("speed", &[]), ("fused", &[52])],
            ),
            sequence("no_truth", 100, 50.0, None, &[("speed", &[3]), ("fused", &[3])]),
        ];
        let tables = evaluator("tolerance = { seconds = 0.1 }")
            .evaluate(EvalInput::segmentation(&seqs))
            .unwrap();
        let t = &tables[0];
        assert_eq!(t.name, "table1_precision_recall");
        assert_eq!(strs(t, "sequence"), ["a", "a", "b", "b", "pooled", "pooled"]);
        assert_eq!(strs(t, "method"), ["speed", "fused", "speed", "fused", "speed", "fused"]);
        assert_eq!(f64s(t, "n_matched"), [2.0, 3.0, 0.0, 1.0, 2.0, 4.0]);
        let p = f64s(t, "precision");
        assert!((p[0] - 2.0 / 3.0).abs() < 1e-15 && p[1] == 0.75 && p[2].is_nan() && p[3] == 1.0);
        assert!((p[4] - 2.0 / 3.0).abs() < 1e-15 && p[5] == 0.8);
        assert_eq!(f64s(t, "recall")[4..], [0.5, 1.0]);
        // F1 pooled speed = 2·2 / (3 + 4) = 4/7.
        assert!((f64s(t, "f1")[4] - 4.0 / 7.0).abs() < 1e-15);
        // Hausdorff: a/speed: 500→300 = 200 frames = 2 s; b/speed: empty found → infinite.
        let h = f64s(t, "hausdorff_s");
        assert!((h[0] - 2.0).abs() < 1e-12 && h[2].is_nan());
        assert!(h[4].is_nan(), "pooled Hausdorff is infinite when one sequence's is");
        assert!((h[5] - 1.0).abs() < 1e-12, "fused: a 400→300 = 1 s; b 52→50 = 0.04 s");
        assert_eq!(f64s(t, "tolerance_frames")[..4], [10.0, 10.0, 5.0, 5.0]);

        let claim = &tables[2];
        assert_eq!(claim.name, "claim_fused_recall");
        assert_eq!(strs(claim, "fused_method"), ["fused"]);
        assert_eq!(claim.column("fused_exceeds_all"), Some(&ColumnValues::Bool(vec![true])));
        assert_eq!(f64s(claim, "n_sequences"), [2.0]);
    }

    #[test]
    fn chance_and_periodic_baselines_beside_each_method() {
        // 100 frames, one truth at 50, tolerance 3 frames: one random frame matches with
        // probability 7/100 (exact: a single window). "hit" finds 50, "miss" finds 80; the
        // periodic baseline puts its one candidate at 50 (centred) and matches.
        let seqs = vec![
            sequence(
                "a",
                100,
                100.0,
                Some(vec![(0, 50, "x"), (50, 100, "y")]),
                &[("hit", &[50]), ("miss", &[80])],
            ),
            sequence(
                "b",
                100,
                100.0,
                Some(vec![(0, 50, "x"), (50, 100, "y")]),
                &[("hit", &[51]), ("miss", &[])],
            ),
        ];
        let t = &evaluator("tolerance = { frames = 3 }")
            .evaluate(EvalInput::segmentation(&seqs))
            .unwrap()[0];
        assert_eq!(strs(t, "chance_expectation"), ["exact"; 6]);
        let cp = f64s(t, "chance_precision");
        assert!((cp[0] - 0.07).abs() < 1e-15 && (cp[1] - 0.07).abs() < 1e-15, "{cp:?}");
        assert!(cp[3].is_nan(), "nothing found: no chance precision");
        assert!((f64s(t, "chance_recall")[0] - 0.07).abs() < 1e-15);
        assert!((f64s(t, "chance_f1")[0] - 0.07).abs() < 1e-15);
        assert_eq!(f64s(t, "chance_f1_se")[0], 0.0);
        // p-value of one match: (1 + #draws that match) / 2001 ≈ 0.07 — not significant.
        let p = f64s(t, "p_value");
        assert!((p[0] - 0.07).abs() < 3.0 * (0.07f64 * 0.93 / 2000.0).sqrt(), "{p:?}");
        assert_eq!(p[1], 1.0, "no match is never above chance");
        assert_eq!(strs(t, "above_chance")[..2], ["no", "no"]);
        // Pooled "hit": expected 2·0.07 of 2 found and 2 truths; observed 2 of 2: p ≈ 0.07².
        assert_eq!(strs(t, "sequence")[4], "pooled");
        assert!((f64s(t, "chance_matched")[4] - 0.14).abs() < 1e-15);
        assert!(p[4] < 0.05 && strs(t, "above_chance")[4] == "yes", "{p:?}");
        // Periodic: one candidate at frame 50 per sequence.
        assert_eq!(f64s(t, "periodic_n_found"), [1.0, 1.0, 1.0, 1.0, 2.0, 2.0]);
        assert_eq!(f64s(t, "periodic_f1"), [1.0; 6]);
        // The same seed gives the same p-values; another seed other ones.
        let again = &evaluator("tolerance = { frames = 3 }")
            .evaluate(EvalInput::segmentation(&seqs))
            .unwrap()[0];
        assert_eq!(f64s(again, "p_value"), p);
        let other = &evaluator("tolerance = { frames = 3 }\nchance_seed = 1")
            .evaluate(EvalInput::segmentation(&seqs))
            .unwrap()[0];
        assert_ne!(f64s(other, "p_value"), p);
    }

    #[test]
    fn the_claim_compares_with_the_named_methods_only() {
        // Truths 100, 200, 300 at 100 Hz, tolerance 5 frames. Recall: a 1/3, b 3/3 (a baseline),
        // fused 2/3. Against every method fusion loses to b; against the fused inputs (a) it wins.
        let seqs = vec![sequence(
            "s",
            600,
            100.0,
            Some(vec![(0, 100, "x"), (100, 200, "y"), (200, 300, "x"), (300, 600, "z")]),
            &[("a", &[100]), ("b", &[100, 200, 300]), ("fused", &[100, 300])],
        )];
        let claim = |params: &str| {
            let tables = evaluator(params).evaluate(EvalInput::segmentation(&seqs)).unwrap();
            let t = tables.into_iter().find(|t| t.name == "claim_fused_recall").unwrap();
            (strs(&t, "best_other_method")[0].clone(), t.column("fused_exceeds_all").cloned())
        };
        assert_eq!(
            claim("tolerance = { frames = 5 }"),
            ("b".to_string(), Some(ColumnValues::Bool(vec![false])))
        );
        assert_eq!(
            claim("tolerance = { frames = 5 }\nclaim_against = [\"a\"]"),
            ("a".to_string(), Some(ColumnValues::Bool(vec![true])))
        );
        let bad = evaluator("claim_against = [\"zz\"]")
            .evaluate(EvalInput::segmentation(&seqs))
            .unwrap_err();
        assert_eq!(bad.location().field.as_deref(), Some("claim_against"));
    }

    #[test]
    fn boundary_matches_lists_matched_missed_and_extra() {
        let seqs = vec![sequence(
            "a",
            600,
            100.0,
            Some(vec![(0, 100, "x"), (100, 200, "y"), (200, 600, "x")]),
            &[("m", &[103, 400])],
        )];
        let tables = evaluator("tolerance = { frames = 5 }")
            .evaluate(EvalInput::segmentation(&seqs))
            .unwrap();
        let t = &tables[1];
        assert_eq!(strs(t, "outcome"), ["matched", "missed", "extra"]);
        // Absent frames are nulls, which a number column holds as NaN.
        assert_eq!(strs(t, "truth_frame"), ["100", "200", "NaN"]);
        assert_eq!(strs(t, "found_frame"), ["103", "NaN", "400"]);
        assert!(
            (t.column("offset_s").unwrap().cell(0).parse::<f64>().unwrap() - 0.03).abs() < 1e-12
        );
        assert_eq!(tables.len(), 3, "one method: no claim table");
        assert_eq!(tables[2].name, "chance_windows");
    }

    #[test]
    fn the_pose_rule_counts_pairs_outside_the_time_window() {
        // Root m0 still; marker m1 at height 100 except frames 40–59 (300). Truth at 20; a
        // method finding 70 matches by pose (same pose as 20), one finding 50 does not.
        let mut seq = sequence(
            "p",
            100,
            10.0,
            Some(vec![(0, 20, "x"), (20, 100, "y")]),
            &[("m", &[70]), ("n", &[50])],
        );
        let motion = motionlab_testkit::named_motion(100, 10.0, &["root", "hand"], |i, k| {
            if k == 0 {
                [0.0; 3]
            } else {
                [0.0, 0.0, if (40..60).contains(&i) { 300.0 } else { 100.0 }]
            }
        });
        seq.motion = std::sync::Arc::new(motion);
        let tables = evaluator("tolerance = { frames = 2 }\npose_mm = 10.0")
            .evaluate(EvalInput::segmentation(&vec![seq.clone()]))
            .unwrap();
        assert_eq!(f64s(&tables[0], "n_matched")[..2], [1.0, 0.0]);
        assert_eq!(f64s(&tables[0], "n_matched_by_pose")[..2], [1.0, 0.0]);
        assert_eq!(strs(&tables[1], "outcome")[0], "matched_by_pose");
        // Without pose_mm the same input matches nothing.
        let tables = evaluator("tolerance = { frames = 2 }")
            .evaluate(EvalInput::segmentation(&vec![seq.clone()]))
            .unwrap();
        assert_eq!(f64s(&tables[0], "n_matched")[..2], [0.0, 0.0]);
        // A root that does not exist is an error naming the field.
        let e = evaluator("pose_mm = 10.0\nroot = \"pelvis\"")
            .evaluate(EvalInput::segmentation(&vec![seq]))
            .unwrap_err();
        assert_eq!(
            (e.kind(), e.location().field.as_deref()),
            (ErrorKind::UnknownName, Some("root"))
        );
    }

    #[test]
    fn no_ground_truth_anywhere_and_wrong_inputs_are_errors() {
        let seqs = vec![sequence("x", 100, 50.0, None, &[("m", &[3])])];
        let e = evaluator("").evaluate(EvalInput::segmentation(&seqs)).unwrap_err();
        assert_eq!(
            (e.kind(), e.location().field.as_deref()),
            (ErrorKind::MissingKey, Some("truth"))
        );
        // Results of another workflow: an error naming what it reads and what it got.
        let e = evaluator("").evaluate(EvalInput::new(&vec![1_u8])).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::Mismatch);
        assert!(
            e.to_string().contains("boundary_pr evaluates segmentation results")
                && e.to_string().contains("Vec<u8>"),
            "{e}"
        );
        // Ground truth at another rate than its motion.
        let mut s =
            sequence("r", 100, 50.0, Some(vec![(0, 50, "x"), (50, 100, "y")]), &[("m", &[3])]);
        s.truth.as_mut().unwrap().frame_rate = motionlab_core::FrameRate::new(120.0).unwrap();
        let e = evaluator("").evaluate(EvalInput::segmentation(&vec![s])).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::Mismatch);
    }

    #[test]
    fn registry_invariants_hold_for_this_crates_plugins() {
        for name in ["boundary_pr", "transitions"] {
            let entry = motionlab_core::registry::find(name).unwrap();
            assert_eq!(entry.kind, motionlab_core::StageKind::Evaluator);
            assert!(entry.doc().contains("Missing samples"), "{name} documents missing samples");
            for p in entry.params() {
                assert!(
                    !p.description.is_empty() && (p.required || p.default.is_some()),
                    "{name}.{}: {p:?}",
                    p.name
                );
            }
        }
        let problems: Vec<String> = motionlab_core::registry::check_registry()
            .into_iter()
            .filter(|p| p.contains("\"boundary_pr\"") || p.contains("\"transitions\""))
            .collect();
        assert!(problems.is_empty(), "{problems:?}");
    }

    #[test]
    fn parameters_are_validated_naming_the_field() {
        let field = |t: &str| {
            let v: toml::Value = toml::from_str(t).unwrap();
            build_evaluator("boundary_pr", &v)
                .err()
                .map(|e| (e.kind(), e.location().field.clone().unwrap_or_default()))
        };
        assert_eq!(
            field("tolerance = { frames = -1 }"),
            Some((ErrorKind::OutOfRange, "tolerance".into()))
        );
        assert_eq!(field("pose_mm = 0.0"), Some((ErrorKind::OutOfRange, "pose_mm".into())));
        assert_eq!(
            field("pose_max_gap = { seconds = 1.0 }"),
            Some((ErrorKind::InvalidParameter, "pose_max_gap".into()))
        );
        assert_eq!(field("root = \" \""), Some((ErrorKind::OutOfRange, "root".into())));
        assert_eq!(
            field("chance_draws = 10"),
            Some((ErrorKind::OutOfRange, "chance_draws".into()))
        );
        assert_eq!(field("tolerance = 5"), Some((ErrorKind::WrongType, "tolerance".into())));
        assert_eq!(field("tolerence = { frames = 5 }").map(|f| f.0), Some(ErrorKind::UnknownKey));
        assert_eq!(field(""), None);
        let p: BoundaryPrParams =
            parse_params(&motionlab_core::registry::default_params()).unwrap();
        assert_eq!(p.tolerance, TimeSpan::Seconds(1.0 / 12.0));
        assert_eq!(evaluator("").input_type(), EvalInputType::segmentation());
    }
}
