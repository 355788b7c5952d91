//! Evaluator plugin `boundary_metrics`: F1 at several tolerances in one table, and the
//! change-point metrics of TCPDBench/TSSB (F1 with several annotators, segment covering).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{
    Error, ErrorKind, EvalInput, EvalInputType, Evaluator, Result, Table, TimeSpan,
};

use crate::boundaries::{MatchRule, PrScores, TruthWindow, evaluate_boundaries, tolerance_frames};
use crate::chance::{
    ChanceCounts, ChanceScores, ChanceSettings, chance_counts, metric_chance, row_seed,
};
use crate::cpd_metrics::{covering, tcpd_f_measure};
use crate::sequences::{nothing_to_evaluate, segmentation_input, truth_of};

/// The metrics people compare change-point detectors with, beside `boundary_pr`'s Table 1.
///
/// Output tables:
/// - `boundary_f1_by_tolerance`: precision, recall and F1 of `boundary_pr` (time rule, maximum
///   one-to-one matching, same empty-set rules) at **each** of `tolerances`, per sequence and
///   method, then `pooled` rows per method and tolerance (ratios of summed counts). Beside
///   each row, **chance**: `boundary_pr`'s null model (as many distinct frames drawn uniformly
///   over the whole motion, matched by the same rule; exact expectation where the truth
///   windows are disjoint, Monte Carlo p-value) at that tolerance — the `chance_*`, `p_value`
///   and `above_chance` columns. Every tolerance of a (sequence, method) uses the same draws
///   (seeded by the two names, as `boundary_pr` seeds them), so at `boundary_pr`'s tolerance
///   and span the numbers are its own.
/// - `tcpd_metrics`: per sequence and method, TCPDBench's F1 (`tcpd_f1`, with
///   `tcpd_precision`, `tcpd_recall`: frame 0 counted as a change point on both sides, greedy
///   nearest matching within `margin`, precision over the union of the annotators, recall
///   averaged over them) and its segment `covering` (Jaccard-weighted covering of each
///   annotator's segments by the found ones, averaged) — definitions in the crate's
///   `cpd_metrics` module, cross-checked with Python re-implementations by
///   `bench/metrics_crosscheck.py`. Each annotator's truth is kept separately: when the ground
///   truth is the consensus of several annotators (`boundaries_csv` with an annotator column,
///   `elan_eaf` with several tiers, `consensus = { … }`), these metrics take every annotator's
///   own boundaries (`n_annotators` of them), not the consensus; otherwise the one annotator's.
///   No pooled rows: TCPDBench reports per-series scores (average them if wanted). Beside each
///   row, chance by Monte Carlo (`chance_draws` sets of as many distinct frames, uniformly over
///   the motion): `chance_tcpd_f1` and `chance_covering` (the means) with one-sided p-values
///   `p_value_tcpd_f1` and `p_value_covering` (`(1 + #{draws ≥ the method}) / (1 + N)`).
///
/// Sequences without ground truth are skipped; it is an error when none has any.
/// Missing samples: not read (only frame numbers are compared).
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct BoundaryMetricsParams {
    /// The match tolerances of `boundary_f1_by_tolerance`, in frames or seconds (each resolved
    /// at the motion's rate). The default list starts with `boundary_pr`'s default tolerance.
    #[serde(default = "default_tolerances")]
    pub tolerances: Vec<TimeSpan>,
    /// TCPDBench's margin: a found frame within this many frames of a truth can count (whole
    /// frames, rounded down, as TCPDBench's integer margin).
    #[serde(default = "default_margin")]
    pub margin: TimeSpan,
    /// Random draws of the chance baselines (≥ 100; p-values resolve down to 1/(N + 1)).
    #[serde(default = "crate::chance::default_draws")]
    pub chance_draws: usize,
    /// Base seed of the chance draws (mixed with the sequence and method names).
    #[serde(default = "crate::chance::default_seed")]
    pub chance_seed: u64,
}

/// The default tolerances of the evaluators that score at several (this one, `human_agreement`).
pub(crate) fn default_tolerances() -> Vec<TimeSpan> {
    vec![
        TimeSpan::Seconds(1.0 / 12.0),
        TimeSpan::Seconds(0.25),
        TimeSpan::Seconds(0.5),
        TimeSpan::Seconds(1.0),
    ]
}

fn default_margin() -> TimeSpan {
    TimeSpan::Seconds(0.5)
}

/// The validated evaluator.
#[derive(Clone, Debug)]
pub struct BoundaryMetrics {
    tolerances: Vec<TimeSpan>,
    margin: TimeSpan,
    chance: ChanceSettings,
}

impl ParamGuard for BoundaryMetricsParams {
    type Checked = BoundaryMetrics;
    fn check(self) -> Result<BoundaryMetrics> {
        if self.tolerances.is_empty() {
            return Err(Error::new(ErrorKind::OutOfRange, "must list at least one tolerance")
                .with_field("tolerances"));
        }
        let tolerances = self
            .tolerances
            .into_iter()
            .enumerate()
            .map(|(i, t)| t.check(&format!("tolerances[{i}]"), false))
            .collect::<Result<_>>()?;
        let margin = self.margin.check("margin", false)?;
        let chance = ChanceSettings::checked(self.chance_draws, self.chance_seed)?;
        Ok(BoundaryMetrics { tolerances, margin, chance })
    }
}

/// A row of `boundary_f1_by_tolerance`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ToleranceRow {
    /// Sequence name, or `pooled`.
    pub sequence: String,
    pub method: String,
    /// The tolerance as given (`0.5 s`, `0.0833 s`, `10 frames`).
    pub tolerance: String,
    /// At this sequence's rate; None on pooled rows.
    pub tolerance_frames: Option<f64>,
    #[serde(flatten)]
    pub scores: PrScores,
    /// As many uniformly random distinct frames, the same rule at this tolerance.
    #[serde(flatten)]
    pub chance: ChanceScores,
}

/// `0.0833 s` or `10 frames`: the tolerance as a short label (4 decimals of a second are
/// finer than any frame period).
pub(crate) fn tolerance_label(t: TimeSpan) -> String {
    match t {
        TimeSpan::Seconds(s) => format!("{} s", (s * 1e4).round() / 1e4),
        TimeSpan::Frames(n) => format!("{n} frames"),
    }
}

/// A row of `tcpd_metrics`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TcpdRow {
    pub sequence: String,
    pub method: String,
    pub n_annotators: usize,
    pub margin_frames: usize,
    pub tcpd_f1: f64,
    pub tcpd_precision: f64,
    pub tcpd_recall: f64,
    /// Segment covering in [0, 1].
    pub covering: f64,
    /// Mean TCPDBench F1 of as many uniformly random distinct frames (Monte Carlo).
    pub chance_tcpd_f1: f64,
    /// One-sided Monte Carlo p-value that `tcpd_f1` exceeds chance.
    pub p_value_tcpd_f1: f64,
    /// Mean covering of as many uniformly random distinct frames (Monte Carlo).
    pub chance_covering: f64,
    /// One-sided Monte Carlo p-value that `covering` exceeds chance.
    pub p_value_covering: f64,
}

impl Evaluator for BoundaryMetrics {
    fn input_type(&self) -> EvalInputType {
        EvalInputType::segmentation()
    }

    fn evaluate(&self, input: EvalInput<'_>) -> Result<Vec<Table>> {
        let sequences = segmentation_input(input, "boundary_metrics")?;
        let mut by_tol = Vec::new();
        let mut tcpd = Vec::new();
        // (method, tolerance index) → (truth, found, matched) and each sequence's chance, in
        // order of first appearance.
        let mut pools: Vec<(String, usize, [usize; 3], Vec<ChanceCounts>)> = Vec::new();
        let mut n_evaluated = 0;
        for seq in sequences {
            let Some(truth) = truth_of(seq)? else { continue };
            n_evaluated += 1;
            let rate = seq.motion.frame_rate();
            let annotators = truth.annotator_frames();
            let margin_frames = tolerance_frames(self.margin, rate).floor() as usize;
            let n_frames = seq.motion.n_frames();
            for m in &seq.methods {
                let seed = row_seed(self.chance.seed, &seq.sequence, &m.method);
                for (ti, &tol) in self.tolerances.iter().enumerate() {
                    let rule = MatchRule::time(tolerance_frames(tol, rate));
                    let s = evaluate_boundaries(&m.candidates, &truth.boundaries, &rule);
                    let windows: Vec<TruthWindow> = truth
                        .boundaries
                        .iter()
                        .map(|b| {
                            TruthWindow::from_boundary(b, rule.tolerance_frames, rule.use_windows)
                        })
                        .collect();
                    let chance = chance_counts(
                        m.candidates.len(),
                        &windows,
                        0..n_frames,
                        self.chance.draws,
                        seed,
                    );
                    by_tol.push(ToleranceRow {
                        sequence: seq.sequence.clone(),
                        method: m.method.clone(),
                        tolerance: tolerance_label(tol),
                        tolerance_frames: Some(tol.frames_at(rate)),
                        scores: s.scores,
                        chance: ChanceScores::of(&chance, s.scores.n_truth, s.scores.n_matched),
                    });
                    match pools.iter_mut().find(|(name, t, ..)| *name == m.method && *t == ti) {
                        Some((_, _, c, parts)) => {
                            c[0] += s.scores.n_truth;
                            c[1] += s.scores.n_found;
                            c[2] += s.scores.n_matched;
                            parts.push(chance);
                        }
                        None => pools.push((
                            m.method.clone(),
                            ti,
                            [s.scores.n_truth, s.scores.n_found, s.scores.n_matched],
                            vec![chance],
                        )),
                    }
                }
                let (f1, precision, recall) =
                    tcpd_f_measure(&annotators, &m.candidates, margin_frames);
                let cover = covering(&annotators, &m.candidates, n_frames);
                let k = m.candidates.len();
                let (chance_f1, p_f1) =
                    metric_chance(k, 0..n_frames, self.chance.draws, seed, f1, |c| {
                        tcpd_f_measure(&annotators, c, margin_frames).0
                    });
                let (chance_cover, p_cover) =
                    metric_chance(k, 0..n_frames, self.chance.draws, seed, cover, |c| {
                        covering(&annotators, c, n_frames)
                    });
                tcpd.push(TcpdRow {
                    sequence: seq.sequence.clone(),
                    method: m.method.clone(),
                    n_annotators: annotators.len(),
                    margin_frames,
                    tcpd_f1: f1,
                    tcpd_precision: precision,
                    tcpd_recall: recall,
                    covering: cover,
                    chance_tcpd_f1: chance_f1,
                    p_value_tcpd_f1: p_f1,
                    chance_covering: chance_cover,
                    p_value_covering: p_cover,
                });
            }
        }
        if n_evaluated == 0 {
            return Err(nothing_to_evaluate("boundary_metrics", "ground truth", sequences.len()));
        }
        for (method, ti, [n_truth, n_found, n_matched], parts) in pools {
            by_tol.push(ToleranceRow {
                sequence: "pooled".into(),
                method,
                tolerance: tolerance_label(self.tolerances[ti]),
                tolerance_frames: None,
                scores: PrScores::of(n_truth, n_found, n_matched),
                chance: ChanceScores::of(&ChanceCounts::pooled(&parts), n_truth, n_matched),
            });
        }
        Ok(vec![
            Table::from_records(
                "boundary_f1_by_tolerance",
                "Precision, recall and F1 at several tolerances (time rule, maximum one-to-one matching)",
                &by_tol,
            )?,
            Table::from_records(
                "tcpd_metrics",
                format!(
                    "TCPDBench F1 (margin {}) and segment covering per sequence and method",
                    self.margin
                ),
                &tcpd,
            )?,
        ])
    }
}

motionlab_core::register_plugin!(Evaluator, BoundaryMetricsParams, "boundary_metrics");

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sequences::fixtures::sequence;
    use motionlab_core::ColumnValues;
    use motionlab_core::registry::build_evaluator;

    fn evaluator(toml_text: &str) -> Box<dyn Evaluator> {
        let v: toml::Value = toml::from_str(toml_text).unwrap();
        build_evaluator("boundary_metrics", &v).unwrap()
    }

    fn f64s(t: &Table, name: &str) -> Vec<f64> {
        match t.column(name) {
            Some(ColumnValues::F64(v)) => v.clone(),
            Some(ColumnValues::I64(v)) => v.iter().map(|&x| x as f64).collect(),
            other => panic!("{name}: {other:?}"),
        }
    }

    #[test]
    fn f1_grows_with_the_tolerance_and_tcpd_rows_follow_the_definitions() {
        // 100 Hz, truths 100 and 300 (segments 0..100..300..600); found 104 and 320.
        // Tolerance 2 frames: 0 matched; 5: 1; 25: 2.
        let seqs = vec![sequence(
            "a",
            600,
            100.0,
            Some(vec![(0, 100, "x"), (100, 300, "y"), (300, 600, "z")]),
            &[("m", &[104, 320])],
        )];
        let tables = evaluator("tolerances = [{ frames = 2 }, { frames = 5 }, { seconds = 0.25 }]\nmargin = { frames = 5 }")
            .evaluate(EvalInput::segmentation(&seqs))
            .unwrap();
        let t = &tables[0];
        assert_eq!(t.name, "boundary_f1_by_tolerance");
        assert_eq!(
            f64s(t, "n_matched"),
            [0.0, 1.0, 2.0, 0.0, 1.0, 2.0],
            "3 sequence rows, then 3 pooled"
        );
        assert_eq!(f64s(t, "f1")[..3], [0.0, 0.5, 1.0]);
        let labels: Vec<String> = (0..3).map(|i| t.column("tolerance").unwrap().cell(i)).collect();
        assert_eq!(labels, ["2 frames", "5 frames", "0.25 s"]);
        assert_eq!(tolerance_label(TimeSpan::Seconds(1.0 / 12.0)), "0.0833 s");
        let c = &tables[1];
        assert_eq!(c.name, "tcpd_metrics");
        // X = {0, 104, 320}, T = {0, 100, 300}, margin 5: 0↔0, 100↔104 → P = R = 2/3.
        assert!((f64s(c, "tcpd_precision")[0] - 2.0 / 3.0).abs() < 1e-15);
        assert!((f64s(c, "tcpd_f1")[0] - 2.0 / 3.0).abs() < 1e-15);
        // Covering: truth [0,100) by found [0,104): 100/104; [100,300) by [104,320): 196/220;
        // [300,600) by [320,600): 280/300.
        let expected =
            (100.0 * (100.0 / 104.0) + 200.0 * (196.0 / 220.0) + 300.0 * (280.0 / 300.0)) / 600.0;
        assert!((f64s(c, "covering")[0] - expected).abs() < 1e-12);
    }

    #[test]
    fn tcpd_metrics_keep_each_annotator_of_a_consensus_separately() {
        // Consensus truth 100 from two annotators, [100] and [100, 300]; found 104; margin 5.
        // X = {0, 104}; union {0, 100, 300}: P = 2/2. Recall per annotator: {0, 100} 2/2,
        // {0, 100, 300} 2/3 → R = 5/6 (the consensus alone would give R = 1).
        let mut seqs = vec![sequence(
            "a",
            600,
            100.0,
            Some(vec![(0, 100, "x"), (100, 600, "y")]),
            &[("m", &[104])],
        )];
        if let Some(t) = seqs[0].truth.as_mut() {
            t.annotators = vec![vec![100], vec![100, 300]];
        }
        let tables =
            evaluator("margin = { frames = 5 }").evaluate(EvalInput::segmentation(&seqs)).unwrap();
        let c = &tables[1];
        assert_eq!(f64s(c, "n_annotators"), [2.0]);
        assert_eq!(f64s(c, "tcpd_precision"), [1.0]);
        assert!((f64s(c, "tcpd_recall")[0] - 5.0 / 6.0).abs() < 1e-15);
        let (f, _, _) = tcpd_f_measure(&[vec![100], vec![100, 300]], &[104], 5);
        assert_eq!(f64s(c, "tcpd_f1"), [f]);
        // Covering averaged over the two annotators' partitions.
        let expected =
            (covering(&[vec![100]], &[104], 600) + covering(&[vec![100, 300]], &[104], 600)) / 2.0;
        assert!((f64s(c, "covering")[0] - expected).abs() < 1e-15);
    }

    #[test]
    fn chance_columns_are_boundary_prs_at_its_tolerance_and_known_answers_otherwise() {
        // 600 frames at 100 Hz, truths 100 and 300 (span: the whole motion), 2 found frames.
        let seqs = vec![sequence(
            "a",
            600,
            100.0,
            Some(vec![(0, 100, "x"), (100, 300, "y"), (300, 600, "z")]),
            &[("m", &[104, 320])],
        )];
        let tables =
            evaluator("tolerances = [{ frames = 5 }, { seconds = 0.25 }]\nmargin = { frames = 5 }")
                .evaluate(EvalInput::segmentation(&seqs))
                .unwrap();
        let t = &tables[0];
        // Exact expectation (disjoint windows of 11 frames, k = 2 of n = 600):
        // E[M] = 2·(1 − C(589, 2)/C(600, 2)); chance precision E[M]/2.
        let e = 2.0 * (1.0 - (589.0 * 588.0) / (600.0 * 599.0));
        assert!(
            (f64s(t, "chance_matched")[0] - e).abs() < 1e-12,
            "{:?}",
            f64s(t, "chance_matched")
        );
        assert!((f64s(t, "chance_precision")[0] - e / 2.0).abs() < 1e-12);
        assert_eq!(t.column("chance_expectation").unwrap().cell(0), "exact");
        // The pooled row of one sequence is that sequence's.
        assert_eq!(f64s(t, "chance_f1")[2], f64s(t, "chance_f1")[0]);
        // At boundary_pr's tolerance and (whole) span, with the same seed, both evaluators
        // give the same chance numbers, p-value included.
        let pr: toml::Value = toml::from_str("tolerance = { seconds = 0.25 }").unwrap();
        let pr = build_evaluator("boundary_pr", &pr)
            .unwrap()
            .evaluate(EvalInput::segmentation(&seqs))
            .unwrap();
        let p = pr.iter().find(|t| t.name == "table1_precision_recall").unwrap();
        for c in ["chance_matched", "chance_precision", "chance_recall", "chance_f1", "p_value"] {
            assert_eq!(f64s(t, c)[1], f64s(p, c)[0], "{c}");
        }
        // TCPDBench chance: a random pair of frames rarely lands within 5 frames of both
        // truths, so the perfect method's F1 beats nearly every draw.
        let perfect = vec![sequence(
            "a",
            600,
            100.0,
            Some(vec![(0, 100, "x"), (100, 300, "y"), (300, 600, "z")]),
            &[("m", &[100, 300])],
        )];
        let c = evaluator("margin = { frames = 5 }\nchance_draws = 500")
            .evaluate(EvalInput::segmentation(&perfect))
            .unwrap()
            .remove(1);
        assert_eq!(f64s(&c, "tcpd_f1"), [1.0]);
        let (chance_f1, p_f1) = (f64s(&c, "chance_tcpd_f1")[0], f64s(&c, "p_value_tcpd_f1")[0]);
        assert!(chance_f1 > 0.3 && chance_f1 < 0.6, "{chance_f1}");
        assert!(p_f1 < 0.01, "{p_f1}");
        assert!(
            f64s(&c, "chance_covering")[0] < f64s(&c, "covering")[0]
                && f64s(&c, "p_value_covering")[0] < 0.05
        );
    }

    #[test]
    fn parameters_and_missing_truth_are_errors() {
        let field = |t: &str| {
            let v: toml::Value = toml::from_str(t).unwrap();
            build_evaluator("boundary_metrics", &v)
                .err()
                .map(|e| e.location().field.clone().unwrap_or_default())
        };
        assert_eq!(field("tolerances = []").as_deref(), Some("tolerances"));
        assert_eq!(field("tolerances = [{ frames = -1 }]").as_deref(), Some("tolerances[0]"));
        assert_eq!(field("margin = { seconds = -1.0 }").as_deref(), Some("margin"));
        let seqs = vec![sequence("x", 100, 50.0, None, &[("m", &[3])])];
        assert_eq!(
            evaluator("").evaluate(EvalInput::segmentation(&seqs)).unwrap_err().kind(),
            ErrorKind::MissingKey
        );
        let entry = motionlab_core::registry::find("boundary_metrics").unwrap();
        assert!(entry.doc().contains("Missing samples"));
    }
}
