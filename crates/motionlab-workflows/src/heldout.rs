//! Held-out operating points for the `[segmentation]` workflow's sweeps: the
//! `selection` rule, and the `heldout_f1` / `heldout_choices` tables.
//!
//! `best_f1` picks each method's combination on the very sequences it then reports on (an
//! oracle). Here the combination is chosen on *training* sequences and its counts are taken on
//! the others: leave-one-sequence-out (each sequence in turn is the test set, the rest train)
//! or one explicit split. Only counts (matches, found, truth) are summed, never ratios, as in
//! the evaluator's `pooled` rows; nothing is re-run — the counts are read from the per-sequence
//! rows the evaluator already wrote for every combination.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::{ColumnValues, Error, ErrorKind, Result, Table};
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

/// Counts of one (sequence, method) row.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Counts {
    pub n_truth: usize,
    pub n_found: usize,
    pub n_matched: usize,
}

impl Counts {
    fn add(self, o: Counts) -> Counts {
        Counts { n_truth: self.n_truth + o.n_truth, n_found: self.n_found + o.n_found, n_matched: self.n_matched + o.n_matched }
    }
    /// (precision, recall, F1) as the boundary_pr evaluator defines them: matched / found,
    /// matched / truth, 2·matched / (found + truth); NaN where the denominator is 0.
    pub fn ratios(self) -> (f64, f64, f64) {
        let div = |a: usize, b: usize| if b == 0 { f64::NAN } else { a as f64 / b as f64 };
        (div(self.n_matched, self.n_found), div(self.n_matched, self.n_truth), div(2 * self.n_matched, self.n_found + self.n_truth))
    }
}

/// One sweep combination's per-sequence counts for the method it is a point of.
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    pub combination: usize,
    /// The swept values (`Combo::label`).
    pub parameters: String,
    /// (sequence, counts) for every sequence evaluated.
    pub per_sequence: Vec<(String, Counts)>,
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
    pub n_truth: usize,
    pub n_found: usize,
    pub n_matched: usize,
    pub precision: f64,
    pub recall: f64,
    pub f1: f64,
}

/// A row of `heldout_f1`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Summary {
    pub method: String,
    pub sweep: String,
    pub selection: String,
    pub n_truth: usize,
    pub n_found: usize,
    pub n_matched: usize,
    pub precision: f64,
    pub recall: f64,
    pub f1: f64,
}

pub const ORACLE: &str = "oracle (chosen on the evaluation data)";

fn pooled(p: &Point, sequences: &[String]) -> Counts {
    p.per_sequence.iter().filter(|(s, _)| sequences.contains(s)).fold(Counts::default(), |acc, (_, c)| acc.add(*c))
}

/// Reads each sweep point's per-sequence counts from the first table of each combination with
/// `sequence`, `method`, `n_truth`, `n_found` and `n_matched` columns (boundary_pr's
/// `table1_precision_recall`), skipping `pooled` rows. As `best_f1`, each grid contributes its
/// focus method (every method when it has none).
pub fn curves_from(combos: &[ComboOutput<'_>]) -> Vec<Curve> {
    let mut curves: Vec<Curve> = Vec::new();
    for co in combos {
        let Some(t) = co.output.tables.iter().find(|t| ["sequence", "method", "n_truth", "n_found", "n_matched"].iter().all(|c| t.column(c).is_some()))
        else {
            continue;
        };
        let (Some(ColumnValues::Str(seq)), Some(ColumnValues::Str(meth))) = (t.column("sequence"), t.column("method")) else { continue };
        let count = |c: &str| match t.column(c) {
            Some(ColumnValues::I64(v)) => v.iter().map(|x| usize::try_from(*x).ok()).collect(),
            _ => vec![None; t.n_rows()],
        };
        let (truth, found, matched) = (count("n_truth"), count("n_found"), count("n_matched"));
        let sweep = co.combo.sweep.clone().unwrap_or_default();
        for i in 0..t.n_rows() {
            let (Some(s), Some(m), Some(n_truth), Some(n_found), Some(n_matched)) = (&seq[i], &meth[i], truth[i], found[i], matched[i]) else {
                continue;
            };
            if s == "pooled" || co.combo.focus.as_ref().is_some_and(|fm| fm != m) {
                continue;
            }
            let ci = match curves.iter().position(|c| c.method == *m && c.sweep == sweep) {
                Some(ci) => ci,
                None => {
                    curves.push(Curve { method: m.clone(), sweep: sweep.clone(), points: Vec::new() });
                    curves.len() - 1
                }
            };
            let points = &mut curves[ci].points;
            let pi = match points.iter().position(|p| p.combination == co.combo.index) {
                Some(pi) => pi,
                None => {
                    points.push(Point { combination: co.combo.index, parameters: co.combo.label(), per_sequence: Vec::new() });
                    points.len() - 1
                }
            };
            points[pi].per_sequence.push((s.clone(), Counts { n_truth, n_found, n_matched }));
        }
    }
    for c in &mut curves {
        c.points.sort_by_key(|p| p.combination);
    }
    curves
}

/// One fold: the sequences reported on (test) and those the combination is chosen on (train).
pub type Fold = (Vec<String>, Vec<String>);

/// The folds of a selection rule over `sequences` (in table order): (test, train) pairs, plus
/// the `selection` column's text. `Oracle` gives none.
pub fn folds(selection: &Selection, sequences: &[String]) -> Result<(String, Vec<Fold>)> {
    match selection {
        Selection::Oracle => Ok((ORACLE.into(), Vec::new())),
        Selection::LeaveOneSequenceOut => {
            if sequences.len() < 2 {
                return Err(Error::new(
                    ErrorKind::InvalidParameter,
                    format!("leave_one_sequence_out needs at least 2 evaluated sequences, found {}", sequences.len()),
                )
                .with_field("segmentation.selection"));
            }
            let folds = sequences.iter().map(|s| (vec![s.clone()], sequences.iter().filter(|o| *o != s).cloned().collect())).collect();
            Ok(("held-out (leave-one-sequence-out)".into(), folds))
        }
        Selection::Train(train) => {
            if let Some(unknown) = train.iter().find(|t| !sequences.contains(t)) {
                return Err(Error::new(
                    ErrorKind::UnknownName,
                    format!("{unknown:?} is not an evaluated sequence; expected some of {}", sequences.join(", ")),
                )
                .with_field("segmentation.selection.train"));
            }
            let test: Vec<String> = sequences.iter().filter(|s| !train.contains(s)).cloned().collect();
            if train.is_empty() || test.is_empty() {
                return Err(Error::new(
                    ErrorKind::InvalidParameter,
                    format!("must name at least one sequence and leave at least one of {} to test on", sequences.join(", ")),
                )
                .with_field("segmentation.selection.train"));
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
            let f1 = pooled(p, train).ratios().2;
            if f1.is_finite() && best.is_none_or(|(_, b)| f1 >= b) {
                best = Some((k, f1));
            }
        }
        best
    };
    let mut choices = Vec::new();
    let mut summaries = Vec::new();
    for c in curves {
        if let Some((k, _)) = best_on(c, &sequences) {
            let counts = pooled(&c.points[k], &sequences);
            summaries.push(summary(c, ORACLE, counts));
        }
        let mut total = Counts::default();
        for (test, train) in &folds {
            let Some((k, train_f1)) = best_on(c, train) else { continue };
            let p = &c.points[k];
            let counts = pooled(p, test);
            total = total.add(counts);
            let (precision, recall, f1) = counts.ratios();
            choices.push(Choice {
                held_out: test.join(", "),
                method: c.method.clone(),
                sweep: c.sweep.clone(),
                combination: p.combination,
                parameters: p.parameters.clone(),
                train_f1,
                n_truth: counts.n_truth,
                n_found: counts.n_found,
                n_matched: counts.n_matched,
                precision,
                recall,
                f1,
            });
        }
        summaries.push(summary(c, &label, total));
    }
    Ok((choices, summaries))
}

fn summary(c: &Curve, selection: &str, counts: Counts) -> Summary {
    let (precision, recall, f1) = counts.ratios();
    Summary {
        method: c.method.clone(),
        sweep: c.sweep.clone(),
        selection: selection.into(),
        n_truth: counts.n_truth,
        n_found: counts.n_found,
        n_matched: counts.n_matched,
        precision,
        recall,
        f1,
    }
}

/// The `heldout_f1` and `heldout_choices` tables (none under `Oracle`), methods in `methods`
/// order.
pub fn heldout_tables(combos: &[ComboOutput<'_>], methods: &[String], selection: &Selection) -> Result<Vec<Table>> {
    if *selection == Selection::Oracle {
        return Ok(Vec::new());
    }
    let mut curves = curves_from(combos);
    curves.sort_by_key(|c| methods.iter().position(|m| *m == c.method).unwrap_or(usize::MAX));
    let (choices, summaries) = heldout(&curves, selection)?;
    Ok(vec![
        Table::from_records(
            "heldout_f1",
            "Each method's pooled precision, recall and F1 at the oracle operating point (chosen on the evaluation data) and at held-out ones (chosen on other sequences)",
            &summaries,
        )?,
        Table::from_records(
            "heldout_choices",
            "The combination each fold chose on its training sequences (best pooled F1, last in grid order on ties) and its counts on the held-out sequence(s)",
            &choices,
        )?,
    ])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn c(n_truth: usize, n_found: usize, n_matched: usize) -> Counts {
        Counts { n_truth, n_found, n_matched }
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
                Point { combination: 0, parameters: "v=0.1".into(), per_sequence: vec![("A".into(), c(10, 10, 10)), ("B".into(), c(10, 10, 0))] },
                Point { combination: 1, parameters: "v=0.2".into(), per_sequence: vec![("A".into(), c(10, 10, 6)), ("B".into(), c(10, 10, 6))] },
            ],
        }
    }

    #[test]
    fn leave_one_out_differs_from_oracle_by_hand() {
        let (choices, summaries) = heldout(&[curve()], &Selection::LeaveOneSequenceOut).unwrap();
        assert_eq!(summaries.len(), 2);
        assert_eq!(summaries[0].selection, ORACLE);
        assert_eq!((summaries[0].n_matched, summaries[0].n_found, summaries[0].n_truth), (12, 20, 20));
        assert!((summaries[0].f1 - 0.6).abs() < 1e-12);
        assert_eq!(summaries[1].selection, "held-out (leave-one-sequence-out)");
        assert_eq!((summaries[1].n_matched, summaries[1].n_found, summaries[1].n_truth), (6, 20, 20));
        assert!((summaries[1].f1 - 0.3).abs() < 1e-12 && (summaries[1].precision - 0.3).abs() < 1e-12 && (summaries[1].recall - 0.3).abs() < 1e-12);
        assert_eq!(choices.len(), 2);
        assert_eq!((choices[0].held_out.as_str(), choices[0].combination, choices[0].parameters.as_str()), ("A", 1, "v=0.2"));
        assert!((choices[0].train_f1 - 0.6).abs() < 1e-12 && (choices[0].f1 - 0.6).abs() < 1e-12);
        assert_eq!((choices[1].held_out.as_str(), choices[1].combination), ("B", 0));
        assert!((choices[1].train_f1 - 1.0).abs() < 1e-12 && choices[1].f1 == 0.0);
    }

    #[test]
    fn explicit_split_and_ties_take_last_in_grid_order() {
        // Train on B: comb 0 F1 0, comb 1 0.6 → comb 1; test on A: 6/10.
        let (choices, summaries) = heldout(&[curve()], &Selection::Train(vec!["B".into()])).unwrap();
        assert_eq!(choices.len(), 1);
        assert_eq!((choices[0].held_out.as_str(), choices[0].combination, choices[0].n_matched), ("A", 1, 6));
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
        assert!(e.to_string().contains("\"C\"") && e.to_string().contains("selection.train"), "{e}");
        let e = heldout(&[curve()], &Selection::Train(vec!["A".into(), "B".into()])).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::InvalidParameter);
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
}
