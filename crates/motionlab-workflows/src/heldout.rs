//! Held-out operating points for the `[segmentation]` workflow's sweeps: the
//! `selection` rule, and the `heldout_f1` / `heldout_choices` tables.
//!
//! `best_f1` picks each method's combination on the very sequences it then reports on (an
//! oracle). Here the combination is chosen on *training* sequences and its counts are taken on
//! the others: leave-one-sequence-out (each sequence in turn is the test set, the rest train)
//! or one explicit split. Only counts (matches, found, truth) are summed, never ratios, as in
//! the evaluator's `pooled` rows; nothing is re-run — the counts and chance null models are
//! the boundary evaluation's typed analysis of every combination
//! ([`motionlab_eval::boundary_analysis`]).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::{Error, ErrorKind, Result, Table};
use motionlab_eval::boundaries::PrScores;
use motionlab_eval::boundary_analysis::{BoundaryAnalysis, ChanceSetup, Counts};
use motionlab_eval::chance::{ChanceCounts, ChanceScores};
use motionlab_experiment::workflow::ComboOutput;

/// How a sweep chooses each method's operating point (`[segmentation] selection = …`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Selection {
    /// `"oracle"`: only `best_f1`, each method's best pooled F1 over all
    /// sequences — chosen on the evaluation data itself.
    #[default]
    Oracle,
    /// `"leave_one_sequence_out"`: also `heldout_f1` and `heldout_choices`; for each sequence,
    /// each method's combination is the one with the best pooled F1 on the *other* sequences,
    /// and its counts on the held-out sequence are pooled over all sequences.
    LeaveOneSequenceOut,
    /// `{ train = ["86_01", "13_29"] }`: choose on these sequences (names as in the tables'
    /// `sequence` column), report on all the others.
    Train(Vec<String>),
}

/// One sweep combination's per-sequence counts for the method it is a point of.
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    pub combination: usize,
    /// The swept values (`Combo::label`).
    pub parameters: String,
    /// (sequence, counts) for every sequence evaluated.
    pub per_sequence: Vec<(String, Counts)>,
    /// (sequence, chance null model) of this combination, as the boundary evaluation drew it.
    pub chance: Vec<(String, ChanceSetup)>,
}

/// The chance columns of a `heldout_f1` or `heldout_choices` row: the chance baseline of
/// `method` at the (point, sequence) pairs `parts`, pooled — each part redrawn with
/// boundary_pr's seed for that sequence and method and the point's own found count; none when a
/// part has no null model.
fn chance_at(method: &str, parts: &[(&Point, &str)]) -> ChanceScores {
    let mut draws = Vec::new();
    let mut counts = Counts::default();
    for (p, seq) in parts {
        let (Some((_, c)), Some((_, setup))) = (
            p.per_sequence.iter().find(|(s, _)| s == seq),
            p.chance.iter().find(|(s, _)| s == seq),
        ) else {
            return ChanceScores::none();
        };
        counts = counts + *c;
        draws.push(setup.counts(seq, method, c.n_found));
    }
    if draws.is_empty() {
        return ChanceScores::none();
    }
    ChanceScores::of(&ChanceCounts::pooled(&draws), counts.n_truth, counts.time_matched())
}

/// One method's curve over one sweep grid, in grid order.
#[derive(Clone, Debug, PartialEq)]
pub struct Curve {
    pub method: String,
    pub sweep: String,
    pub points: Vec<Point>,
}

/// A row of `heldout_choices`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Choice {
    /// The test sequence(s) of this fold.
    pub held_out: String,
    pub method: String,
    pub sweep: String,
    pub combination: usize,
    pub parameters: String,
    /// Pooled F1 of the chosen combination on the fold's training sequences.
    pub train_f1: f64,
    /// On the fold's test sequence(s).
    #[serde(flatten)]
    pub scores: PrScores,
    /// Chance on the fold's test sequence(s): the same found count, boundary_pr's null model
    /// and draws.
    #[serde(flatten)]
    pub chance: ChanceScores,
}

/// A row of `heldout_f1`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Summary {
    pub method: String,
    pub sweep: String,
    /// `oracle (chosen on the evaluation data)` or `held-out (…)`.
    pub selection: String,
    /// The oracle row's combination (chosen on all sequences); `per fold: heldout_choices` on
    /// held-out rows.
    pub parameters: String,
    /// How many of the `n_folds` folds chose the oracle row's combination (the same on both
    /// rows of a method).
    pub folds_choosing_it: usize,
    pub n_folds: usize,
    /// Pooled over the row's sequences (and folds).
    #[serde(flatten)]
    pub scores: PrScores,
    /// Chance: the same number of uniformly random distinct frames on each of the row's
    /// sequences (and folds), boundary_pr's null model and draws, pooled.
    #[serde(flatten)]
    pub chance: ChanceScores,
}

pub const ORACLE: &str = "oracle (chosen on the evaluation data)";

fn pooled(p: &Point, sequences: &[String]) -> Counts {
    p.per_sequence
        .iter()
        .filter(|(s, _)| sequences.contains(s))
        .fold(Counts::default(), |acc, (_, c)| acc + *c)
}

/// Each sweep point's per-sequence counts and chance null models, from the boundary
/// evaluation of each combination (its [`BoundaryAnalysis`]: the first evaluator that gives
/// one). As `best_f1`, each grid contributes its focus method (every method when it has none).
pub fn curves_from(combos: &[ComboOutput<'_>]) -> Vec<Curve> {
    let mut curves: Vec<Curve> = Vec::new();
    for co in combos {
        let Some(judged) = co.output.analysis::<BoundaryAnalysis>() else { continue };
        let sweep = co.combo.sweep.clone().unwrap_or_default();
        add_points(
            &mut curves,
            co.combo.index,
            &sweep,
            co.combo.focus.as_deref(),
            &co.combo.label(),
            &judged,
        );
    }
    for c in &mut curves {
        c.points.sort_by_key(|p| p.combination);
    }
    curves
}

/// Adds one combination's points (its boundary evaluation) to the curves.
fn add_points(
    curves: &mut Vec<Curve>,
    combination: usize,
    sweep: &str,
    focus: Option<&str>,
    label: &str,
    judged: &BoundaryAnalysis,
) {
    let chance: Vec<(String, ChanceSetup)> =
        judged.sequences.iter().map(|s| (s.sequence.clone(), s.chance.clone())).collect();
    for seq in &judged.sequences {
        for m in &seq.methods {
            if focus.is_some_and(|fm| fm != m.method) {
                continue;
            }
            let ci = match curves.iter().position(|c| c.method == m.method && c.sweep == sweep) {
                Some(ci) => ci,
                None => {
                    curves.push(Curve {
                        method: m.method.clone(),
                        sweep: sweep.to_string(),
                        points: Vec::new(),
                    });
                    curves.len() - 1
                }
            };
            let points = &mut curves[ci].points;
            let pi = match points.iter().position(|p| p.combination == combination) {
                Some(pi) => pi,
                None => {
                    points.push(Point {
                        combination,
                        parameters: label.to_string(),
                        per_sequence: Vec::new(),
                        chance: chance.clone(),
                    });
                    points.len() - 1
                }
            };
            points[pi].per_sequence.push((seq.sequence.clone(), m.counts));
        }
    }
}

/// One fold: the sequences reported on (test) and those the combination is chosen on (train).
pub type Fold = (Vec<String>, Vec<String>);

/// The folds of a selection rule over `sequences` (in table order): (test, train) pairs, plus
/// the `selection` column's text. `Oracle` gives none. A selection that does not fit the
/// sequences is an error whose field is relative to the `selection` key (`train`), for the
/// workflow to locate.
pub fn folds(selection: &Selection, sequences: &[String]) -> Result<(String, Vec<Fold>)> {
    match selection {
        Selection::Oracle => Ok((ORACLE.into(), Vec::new())),
        Selection::LeaveOneSequenceOut => {
            if sequences.len() < 2 {
                return Err(Error::new(
                    ErrorKind::InvalidParameter,
                    format!(
                        "leave_one_sequence_out needs at least 2 evaluated sequences, found {}",
                        sequences.len()
                    ),
                ));
            }
            let folds = sequences
                .iter()
                .map(|s| (vec![s.clone()], sequences.iter().filter(|o| *o != s).cloned().collect()))
                .collect();
            Ok(("held-out (leave-one-sequence-out)".into(), folds))
        }
        Selection::Train(train) => {
            if let Some(unknown) = train.iter().find(|t| !sequences.contains(t)) {
                return Err(Error::new(
                    ErrorKind::UnknownName,
                    format!(
                        "{unknown:?} is not an evaluated sequence; expected some of {}",
                        sequences.join(", ")
                    ),
                )
                .with_field("train"));
            }
            let test: Vec<String> =
                sequences.iter().filter(|s| !train.contains(s)).cloned().collect();
            if train.is_empty() || test.is_empty() {
                return Err(Error::new(
                    ErrorKind::InvalidParameter,
                    format!(
                        "must name at least one sequence and leave at least one of {} to test on",
                        sequences.join(", ")
                    ),
                )
                .with_field("train"));
            }
            Ok((format!("held-out (chosen on {})", train.join(", ")), vec![(test, train.clone())]))
        }
    }
}

/// Held-out choices per fold and method, and per method the oracle and held-out pooled rows.
///
/// In each fold, each curve's combination is the one with the highest pooled F1 (summed
/// counts) on the training sequences; ties go to the last in grid order (the rule of
/// `best_f1`, whose `Iterator::max_by` keeps the last maximum), and combinations whose
/// training F1 is NaN (nothing found, no truth) are never chosen. The held-out row pools the
/// chosen combinations' test counts over all folds. The oracle row is `best_f1`'s choice (the
/// highest pooled F1 over all sequences, last in grid order on ties).
pub fn heldout(curves: &[Curve], selection: &Selection) -> Result<(Vec<Choice>, Vec<Summary>)> {
    let mut sequences: Vec<String> = Vec::new();
    for s in curves.iter().flat_map(|c| &c.points).flat_map(|p| &p.per_sequence).map(|(s, _)| s) {
        if !sequences.contains(s) {
            sequences.push(s.clone());
        }
    }
    let (label, folds) = folds(selection, &sequences)?;
    if folds.is_empty() {
        return Ok((Vec::new(), Vec::new()));
    }
    let best_on = |c: &Curve, train: &[String]| -> Option<(usize, f64)> {
        let mut best: Option<(usize, f64)> = None;
        for (k, p) in c.points.iter().enumerate() {
            let f1 = pooled(p, train).scores().f1;
            if f1.is_finite() && best.is_none_or(|(_, b)| f1 >= b) {
                best = Some((k, f1));
            }
        }
        best
    };
    let mut choices = Vec::new();
    let mut summaries = Vec::new();
    for c in curves {
        let oracle = best_on(c, &sequences).map(|(k, _)| k);
        let fold_choices: Vec<Option<(usize, f64)>> =
            folds.iter().map(|(_, train)| best_on(c, train)).collect();
        let n_folds = fold_choices.iter().flatten().count();
        let agreeing = fold_choices.iter().flatten().filter(|(k, _)| Some(*k) == oracle).count();
        if let Some(k) = oracle {
            let p = &c.points[k];
            let parts: Vec<(&Point, &str)> = sequences.iter().map(|s| (p, s.as_str())).collect();
            let chance = chance_at(&c.method, &parts);
            summaries.push(summary(
                c,
                ORACLE,
                p.parameters.clone(),
                (agreeing, n_folds),
                pooled(p, &sequences),
                chance,
            ));
        }
        let mut total = Counts::default();
        let mut parts: Vec<(&Point, &str)> = Vec::new();
        for ((test, _), choice) in folds.iter().zip(&fold_choices) {
            let Some((k, train_f1)) = *choice else { continue };
            let p = &c.points[k];
            let counts = pooled(p, test);
            total = total + counts;
            let fold_parts: Vec<(&Point, &str)> = test.iter().map(|s| (p, s.as_str())).collect();
            let chance = chance_at(&c.method, &fold_parts);
            parts.extend(fold_parts);
            choices.push(Choice {
                held_out: test.join(", "),
                method: c.method.clone(),
                sweep: c.sweep.clone(),
                combination: p.combination,
                parameters: p.parameters.clone(),
                train_f1,
                scores: counts.scores(),
                chance,
            });
        }
        let chance = chance_at(&c.method, &parts);
        summaries.push(summary(
            c,
            &label,
            "per fold: heldout_choices".into(),
            (agreeing, n_folds),
            total,
            chance,
        ));
    }
    Ok((choices, summaries))
}

fn summary(
    c: &Curve,
    selection: &str,
    parameters: String,
    agreement: (usize, usize),
    counts: Counts,
    chance: ChanceScores,
) -> Summary {
    Summary {
        method: c.method.clone(),
        sweep: c.sweep.clone(),
        selection: selection.into(),
        parameters,
        folds_choosing_it: agreement.0,
        n_folds: agreement.1,
        scores: counts.scores(),
        chance,
    }
}

/// The `heldout_f1` and `heldout_choices` tables (none under `Oracle`), methods in `methods`
/// order; errors as [`folds`] gives them.
pub fn heldout_tables(
    combos: &[ComboOutput<'_>],
    methods: &[String],
    selection: &Selection,
) -> Result<Vec<Table>> {
    if *selection == Selection::Oracle {
        return Ok(Vec::new());
    }
    let mut curves = curves_from(combos);
    curves.sort_by_key(|c| methods.iter().position(|m| *m == c.method).unwrap_or(usize::MAX));
    let (choices, summaries) = heldout(&curves, selection)?;
    Ok(vec![
        Table::from_records(
            "heldout_f1",
            "Each method's pooled precision, recall and F1 at the oracle operating point (chosen on the evaluation data) and at held-out ones (chosen on other sequences), each beside the chance baseline of its own found counts",
            &summaries,
        )?,
        Table::from_records(
            "heldout_choices",
            "The combination each fold chose on its training sequences (best pooled F1, last in grid order on ties), its counts on the held-out sequence(s) and their chance baseline",
            &choices,
        )?,
    ])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn leave_one_out_needs_two_sequences() {
        let seqs = vec!["a".to_string(), "b".to_string()];
        let e = folds(&Selection::LeaveOneSequenceOut, &seqs[..1]).unwrap_err();
        assert_eq!(
            (e.kind(), e.location().field.as_deref()),
            (ErrorKind::InvalidParameter, None),
            "{e}"
        );
        let (_, two) = folds(&Selection::LeaveOneSequenceOut, &seqs).unwrap();
        assert_eq!(
            two,
            vec![
                (vec!["a".to_string()], vec!["b".to_string()]),
                (vec!["b".to_string()], vec!["a".to_string()])
            ]
        );
    }

    fn c(n_truth: usize, n_found: usize, n_matched: usize) -> Counts {
        Counts { n_truth, n_found, n_matched, n_matched_by_pose: 0 }
    }

    /// Two sequences A, B; two thresholds. Combination 0 is great on A only, combination 1 is
    /// middling on both.
    ///   comb 0: A (truth 10, found 10, matched 10), B (10, 10, 0)
    ///   comb 1: A (10, 10, 6),                      B (10, 10, 6)
    /// Oracle (pooled over A+B): comb 0 F1 = 2·10/40 = 0.5, comb 1 F1 = 2·12/40 = 0.6 → comb 1,
    /// F1 0.6.
    /// Leave-one-out: test A, train B: comb 0 F1 0, comb 1 F1 0.6 → comb 1, on A 6/10.
    ///                test B, train A: comb 0 F1 1.0, comb 1 0.6 → comb 0, on B 0/10.
    /// Held-out pooled: matched 6, found 20, truth 20 → P = R = F1 = 0.3 (oracle differs in the
    /// fold holding out B).
    fn curve() -> Curve {
        Curve {
            method: "speed".into(),
            sweep: "speed v_low".into(),
            points: vec![
                Point {
                    combination: 0,
                    parameters: "v=0.1".into(),
                    per_sequence: vec![("A".into(), c(10, 10, 10)), ("B".into(), c(10, 10, 0))],
                    chance: Vec::new(),
                },
                Point {
                    combination: 1,
                    parameters: "v=0.2".into(),
                    per_sequence: vec![("A".into(), c(10, 10, 6)), ("B".into(), c(10, 10, 6))],
                    chance: Vec::new(),
                },
            ],
        }
    }

    #[test]
    fn leave_one_out_differs_from_oracle_by_hand() {
        let (choices, summaries) = heldout(&[curve()], &Selection::LeaveOneSequenceOut).unwrap();
        assert_eq!(summaries.len(), 2);
        assert_eq!(summaries[0].selection, ORACLE);
        assert_eq!(
            (
                summaries[0].scores.n_matched,
                summaries[0].scores.n_found,
                summaries[0].scores.n_truth
            ),
            (12, 20, 20)
        );
        assert!((summaries[0].scores.f1 - 0.6).abs() < 1e-12);
        assert_eq!(summaries[1].selection, "held-out (leave-one-sequence-out)");
        assert_eq!(
            (
                summaries[1].scores.n_matched,
                summaries[1].scores.n_found,
                summaries[1].scores.n_truth
            ),
            (6, 20, 20)
        );
        assert!(
            (summaries[1].scores.f1 - 0.3).abs() < 1e-12
                && (summaries[1].scores.precision - 0.3).abs() < 1e-12
                && (summaries[1].scores.recall - 0.3).abs() < 1e-12
        );
        assert_eq!(choices.len(), 2);
        assert_eq!(
            (choices[0].held_out.as_str(), choices[0].combination, choices[0].parameters.as_str()),
            ("A", 1, "v=0.2")
        );
        assert!(
            (choices[0].train_f1 - 0.6).abs() < 1e-12 && (choices[0].scores.f1 - 0.6).abs() < 1e-12
        );
        assert_eq!((choices[1].held_out.as_str(), choices[1].combination), ("B", 0));
        assert!((choices[1].train_f1 - 1.0).abs() < 1e-12 && choices[1].scores.f1 == 0.0);
    }

    #[test]
    fn explicit_split_and_ties_take_last_in_grid_order() {
        // Train on B: comb 0 F1 0, comb 1 0.6 → comb 1; test on A: 6/10.
        let (choices, summaries) =
            heldout(&[curve()], &Selection::Train(vec!["B".into()])).unwrap();
        assert_eq!(choices.len(), 1);
        assert_eq!(
            (choices[0].held_out.as_str(), choices[0].combination, choices[0].scores.n_matched),
            ("A", 1, 6)
        );
        assert_eq!(summaries[1].selection, "held-out (chosen on B)");
        // Two identical points: the last wins, as in best_f1.
        let mut tie = curve();
        tie.points[0].per_sequence = tie.points[1].per_sequence.clone();
        tie.points[0].combination = 7;
        tie.points[1].combination = 8;
        let (choices, _) = heldout(&[tie], &Selection::Train(vec!["A".into()])).unwrap();
        assert_eq!(choices[0].combination, 8);
    }

    #[test]
    fn bad_splits_are_one_clear_error() {
        let e = heldout(&[curve()], &Selection::Train(vec!["C".into()])).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::UnknownName);
        // Its field is relative to the `selection` key: the workflow locates it there.
        assert!(e.to_string().contains("\"C\""), "{e}");
        assert_eq!(e.location().field.as_deref(), Some("train"));
        let e = heldout(&[curve()], &Selection::Train(vec!["A".into(), "B".into()])).unwrap_err();
        assert_eq!(
            (e.kind(), e.location().field.as_deref()),
            (ErrorKind::InvalidParameter, Some("train"))
        );
    }

    #[test]
    fn oracle_default_adds_nothing() {
        #[derive(Deserialize)]
        struct S {
            #[serde(default)]
            selection: Selection,
        }
        let s: S = toml::from_str("").unwrap();
        assert_eq!(s.selection, Selection::Oracle);
        assert_eq!(heldout(&[curve()], &Selection::Oracle).unwrap(), (Vec::new(), Vec::new()));
        assert!(heldout_tables(&[], &[], &Selection::Oracle).unwrap().is_empty());
        let s: S = toml::from_str("selection = \"leave_one_sequence_out\"").unwrap();
        assert_eq!(s.selection, Selection::LeaveOneSequenceOut);
        let s: S = toml::from_str("selection = { train = [\"86_01\"] }").unwrap();
        assert_eq!(s.selection, Selection::Train(vec!["86_01".into()]));
        assert!(toml::from_str::<S>("selection = \"best\"").is_err());
    }

    /// The held-out rows' chance columns redraw boundary_pr's own: each fold's equal the
    /// `table1_precision_recall` row of the chosen combination and held-out sequence, and a
    /// row pooled over every sequence at one combination equals its `pooled` row.
    #[test]
    fn chance_columns_are_boundary_prs_own_draws() {
        use motionlab_core::{
            EvalInput, FrameRate, MethodResult, Segment, Segmentation, SequenceResult,
        };
        fn seq(name: &str, cuts: &[usize], found: &[usize]) -> SequenceResult {
            let mut motion = motionlab_testkit::motion_from_fn(400, 100.0, 1, |_, _| [0.0; 3]);
            motion.name = name.into();
            let mut bounds = vec![0];
            bounds.extend_from_slice(cuts);
            bounds.push(400);
            let segments = bounds
                .windows(2)
                .map(|w| Segment { start: w[0], end: w[1], label: "x".into() })
                .collect();
            SequenceResult {
                sequence: name.into(),
                motion: std::sync::Arc::new(motion),
                truth: Some(
                    Segmentation::from_segments(FrameRate::new(100.0).unwrap(), segments).unwrap(),
                ),
                methods: vec![MethodResult { method: "speed".into(), candidates: found.to_vec() }],
            }
        }
        let v: toml::Value =
            toml::from_str("tolerance = { frames = 4 }\nchance_draws = 500").unwrap();
        let pr = motionlab_core::registry::build_evaluator("boundary_pr", &v).unwrap();
        // Two combinations: the first finds the truths of A only, the second a bit of both.
        let combos = [
            vec![seq("A", &[100, 250], &[101, 249]), seq("B", &[80, 300], &[10, 200, 390])],
            vec![seq("A", &[100, 250], &[103, 180, 330]), seq("B", &[80, 300], &[82, 302])],
        ];
        let mut curves = Vec::new();
        let mut tables = Vec::new();
        for (i, seqs) in combos.iter().enumerate() {
            let e = pr.evaluate_with_analysis(EvalInput::segmentation(seqs)).unwrap();
            add_points(
                &mut curves,
                i,
                "grid",
                Some("speed"),
                &format!("c={i}"),
                e.analysis::<BoundaryAnalysis>().unwrap(),
            );
            tables.push(e.tables);
        }
        assert_eq!(curves[0].points[0].chance.len(), 2);
        assert_eq!(curves[0].points[0].chance[0].1.windows.len(), 2);
        let (choices, summaries) = heldout(&curves, &Selection::LeaveOneSequenceOut).unwrap();
        let row =
            |t: &Table, r: usize, c: &str| t.column(c).unwrap().cell(r).parse::<f64>().unwrap();
        let seq_row = |t: &Table, s: &str| {
            (0..t.n_rows()).find(|&r| t.column("sequence").unwrap().cell(r) == s).unwrap()
        };
        for ch in &choices {
            let t = &tables[ch.combination][0];
            let r = seq_row(t, &ch.held_out);
            assert_eq!(ch.chance.f1, row(t, r, "chance_f1"), "fold {}", ch.held_out);
            assert_eq!(ch.chance.precision, row(t, r, "chance_precision"));
            assert_eq!(ch.chance.p_value, row(t, r, "p_value"));
        }
        // The oracle row is one combination over all sequences: boundary_pr's pooled row.
        let oracle = &summaries[0];
        assert_eq!(oracle.selection, ORACLE);
        let k: usize = oracle.parameters.trim_start_matches("c=").parse().unwrap();
        let t = &tables[k][0];
        let r = seq_row(t, "pooled");
        assert_eq!(
            (oracle.chance.f1, oracle.chance.p_value, oracle.chance.recall),
            (row(t, r, "chance_f1"), row(t, r, "p_value"), row(t, r, "chance_recall"))
        );
        // By hand: A's truths 100 and 250 with tolerance 4 are windows of 9 frames in 0..400; 2
        // random frames hit a given window with probability 1 − (391·390)/(400·399).
        let a = seq_row(&tables[0][0], "A");
        let e = 2.0 * (1.0 - 391.0 * 390.0 / (400.0 * 399.0));
        assert!((row(&tables[0][0], a, "chance_matched") - e).abs() < 1e-12);
        let held = &summaries[1];
        assert_eq!((held.n_folds, oracle.n_folds), (2, 2));
        // Combination 1 (the oracle's) was chosen when A was held out, not when B was.
        assert_eq!((held.folds_choosing_it, oracle.folds_choosing_it), (1, 1));
        assert!(
            held.chance.f1 > 0.0
                && held.chance.f1 < held.scores.f1
                && held.chance.p_value > 0.0
                && held.chance.p_value <= 1.0
        );
    }
}
