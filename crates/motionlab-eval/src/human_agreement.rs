//! Evaluator plugin `human_agreement`: how well several annotators agree with each other — the
//! ceiling a method's score is read against, beside the chance floor.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{
    Error, ErrorKind, EvalInput, EvalInputType, Evaluator, Result, Table, TimeSpan,
};

use crate::boundaries::{TruthWindow, max_matching_windows, ratios, tolerance_frames};
use crate::boundary_metrics::{default_tolerances, tolerance_label};
use crate::chance::{ChanceSettings, chance_counts, exact_expected_matches, row_seed};
use crate::sequences::{nothing_to_evaluate, segmentation_input, truth_of};

/// Human agreement as the ceiling of boundary detection: when a sequence's ground truth comes
/// from several annotators (`boundaries_csv` with an `annotator` column or `elan_eaf` with
/// several tiers, read with `consensus = { … }`, which keeps every annotator's own marks), how
/// well each pair of annotators agrees, and where each method's score lies between chance and
/// that agreement.
///
/// **Agreement of two sets of boundary frames** `A` and `B` at a tolerance `t` (frames): `M`
/// is the size of the maximum one-to-one matching with `|a − b| ≤ t` (`boundary_pr`'s time
/// rule, which is symmetric in the two sets), and
///
/// - `f1 = 2M / (|A| + |B|)` — `boundary_pr`'s F1 with either set taken as the truth;
/// - `chance_matched` `E`: `boundary_pr`'s chance model applied in both directions and
///   averaged, so that it stays symmetric — `|A|` distinct frames drawn uniformly over the
///   whole motion matched to `B`'s windows, and `|B|` such frames matched to `A`'s (exact
///   expectation where the windows are disjoint, else the Monte Carlo mean of `chance_draws`
///   draws); `chance_f1 = 2E / (|A| + |B|)`;
/// - `kappa = (M − E) / ((|A| + |B|)/2 − E)` = `(f1 − chance_f1) / (1 − chance_f1)`: Cohen's
///   form `(p_o − p_e) / (1 − p_e)` with F1 (the Dice agreement of the two sets) as the
///   agreement and the chance model's as the expected — 1 only when the sets match
///   boundary for boundary, 0 at chance, negative below it; NaN when chance alone agrees
///   fully.
///
/// Over several pairs, sequences or annotators, counts (`M`, `E`, `|A| + |B|`) are summed
/// before the ratios.
///
/// Output tables (rows at each of `tolerances`):
/// - `annotator_agreement`: per sequence and pair of annotators (`annotator_a`,
///   `annotator_b`, by their names in the file), then `pooled` rows per pair over the
///   sequences: `n_a`, `n_b`, `n_matched`, `f1`, `chance_matched`, `chance_f1`, `kappa`.
/// - `human_ceiling`: per sequence and method, then `pooled` per method: the method's
///   agreement with the annotators (`f1`, `chance_f1`, `kappa`: the method's candidates
///   against each annotator's marks in turn, summed), the annotators' agreement with each
///   other (`human_f1`, `human_kappa`: every pair, summed) and `fraction_of_ceiling` =
///   `(f1 − chance_f1) / (human_f1 − chance_f1)`: 0 at chance, 1 where the method agrees
///   with the annotators as well as they agree with each other.
///
/// Sequences whose ground truth is one annotator's are skipped; it is an error when no
/// sequence has several. Missing samples: not read (only frame numbers are compared).
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct HumanAgreementParams {
    /// The match tolerances, in frames or seconds (each resolved at the motion's rate); the
    /// default list is `boundary_metrics`'.
    #[serde(default = "default_tolerances")]
    pub tolerances: Vec<TimeSpan>,
    /// Random draws of the chance expectation where windows overlap (≥ 100).
    #[serde(default = "crate::chance::default_draws")]
    pub chance_draws: usize,
    /// Base seed of the chance draws (mixed with the sequence's and the two sets' names).
    #[serde(default = "crate::chance::default_seed")]
    pub chance_seed: u64,
}

/// The validated evaluator.
#[derive(Clone, Debug)]
pub struct HumanAgreement {
    tolerances: Vec<TimeSpan>,
    chance: ChanceSettings,
}

impl ParamGuard for HumanAgreementParams {
    type Checked = HumanAgreement;
    fn check(self) -> Result<HumanAgreement> {
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
        Ok(HumanAgreement {
            tolerances,
            chance: ChanceSettings::checked(self.chance_draws, self.chance_seed)?,
        })
    }
}

/// Matched boundaries of two sets and their chance expectation, summable over pairs.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Agreement {
    pub n_a: usize,
    pub n_b: usize,
    pub matched: usize,
    /// `E`, the symmetric chance expectation of `matched`.
    pub expected: f64,
    /// True while every part's expectation is exact.
    pub exact: bool,
}

impl Agreement {
    /// `a` against `b` at `tol_frames`, chance over frames `0..n_frames`.
    pub fn of(
        a: &[usize],
        b: &[usize],
        tol_frames: f64,
        n_frames: usize,
        chance: ChanceSettings,
        seed: u64,
    ) -> Self {
        let around =
            |s: &[usize]| s.iter().map(|&f| TruthWindow::around(f, tol_frames)).collect::<Vec<_>>();
        let (wa, wb) = (around(a), around(b));
        let matched = max_matching_windows(a, &wb).len();
        let mut exact = true;
        let mut expect = |k: usize, windows: &[TruthWindow], seed: u64| match exact_expected_matches(
            k,
            windows,
            0..n_frames,
        ) {
            Some(e) => e,
            None => {
                exact = false;
                chance_counts(k, windows, 0..n_frames, chance.draws, seed).expected_matched
            }
        };
        let expected =
            0.5 * (expect(a.len(), &wb, seed) + expect(b.len(), &wa, seed ^ 0x9e37_79b9_7f4a_7c15));
        Agreement { n_a: a.len(), n_b: b.len(), matched, expected, exact }
    }
    fn add(&mut self, o: &Agreement) {
        self.n_a += o.n_a;
        self.n_b += o.n_b;
        self.matched += o.matched;
        self.expected += o.expected;
        self.exact &= o.exact;
    }
    pub fn f1(&self) -> f64 {
        ratios(self.n_a, self.n_b, self.matched).2
    }
    pub fn chance_f1(&self) -> f64 {
        let n = self.n_a + self.n_b;
        if n == 0 { f64::NAN } else { 2.0 * self.expected / n as f64 }
    }
    pub fn kappa(&self) -> f64 {
        let room = (self.n_a + self.n_b) as f64 / 2.0 - self.expected;
        if room > 0.0 { (self.matched as f64 - self.expected) / room } else { f64::NAN }
    }
}

/// A sum of [`Agreement`]s that starts empty and exact.
fn total<'a>(parts: impl IntoIterator<Item = &'a Agreement>) -> Agreement {
    let mut sum = Agreement { exact: true, ..Agreement::default() };
    parts.into_iter().for_each(|p| sum.add(p));
    sum
}

/// A row of `annotator_agreement`.
#[derive(Clone, Debug, PartialEq, Serialize)]
struct PairRow {
    sequence: String,
    annotator_a: String,
    annotator_b: String,
    tolerance: String,
    tolerance_frames: Option<f64>,
    n_a: usize,
    n_b: usize,
    n_matched: usize,
    f1: f64,
    chance_expectation: &'static str,
    chance_matched: f64,
    chance_f1: f64,
    kappa: f64,
}

impl PairRow {
    fn new(
        sequence: &str,
        (a, b): (&str, &str),
        tolerance: TimeSpan,
        tolerance_frames: Option<f64>,
        g: &Agreement,
    ) -> Self {
        PairRow {
            sequence: sequence.into(),
            annotator_a: a.into(),
            annotator_b: b.into(),
            tolerance: tolerance_label(tolerance),
            tolerance_frames,
            n_a: g.n_a,
            n_b: g.n_b,
            n_matched: g.matched,
            f1: g.f1(),
            chance_expectation: if g.exact { "exact" } else { "monte_carlo" },
            chance_matched: g.expected,
            chance_f1: g.chance_f1(),
            kappa: g.kappa(),
        }
    }
}

/// A row of `human_ceiling`.
#[derive(Clone, Debug, PartialEq, Serialize)]
struct CeilingRow {
    sequence: String,
    method: String,
    tolerance: String,
    tolerance_frames: Option<f64>,
    n_annotators: usize,
    f1: f64,
    chance_f1: f64,
    human_f1: f64,
    kappa: f64,
    human_kappa: f64,
    fraction_of_ceiling: f64,
}

impl CeilingRow {
    fn new(
        sequence: &str,
        method: &str,
        tolerance: TimeSpan,
        tolerance_frames: Option<f64>,
        n_annotators: usize,
        m: &Agreement,
        h: &Agreement,
    ) -> Self {
        let (f1, chance_f1, human_f1) = (m.f1(), m.chance_f1(), h.f1());
        let room = human_f1 - chance_f1;
        CeilingRow {
            sequence: sequence.into(),
            method: method.into(),
            tolerance: tolerance_label(tolerance),
            tolerance_frames,
            n_annotators,
            f1,
            chance_f1,
            human_f1,
            kappa: m.kappa(),
            human_kappa: h.kappa(),
            fraction_of_ceiling: if room > 0.0 { (f1 - chance_f1) / room } else { f64::NAN },
        }
    }
}

/// Appends `g` to the pool keyed `key`, keeping keys in order of first appearance.
fn pool<K: PartialEq>(pools: &mut Vec<(K, Vec<Agreement>)>, key: K, g: Agreement) {
    match pools.iter_mut().find(|(k, _)| *k == key) {
        Some((_, v)) => v.push(g),
        None => pools.push((key, vec![g])),
    }
}

impl Evaluator for HumanAgreement {
    fn input_type(&self) -> EvalInputType {
        EvalInputType::segmentation()
    }

    fn evaluate(&self, input: EvalInput<'_>) -> Result<Vec<Table>> {
        let sequences = segmentation_input(input, "human_agreement")?;
        let mut pairs_rows = Vec::new();
        let mut ceiling_rows = Vec::new();
        // Pools over sequences: ((annotator a, b), tolerance) and (method, tolerance); the
        // humans' pool per tolerance; the most annotators any sequence had.
        let mut pair_pools: Vec<((String, String, usize), Vec<Agreement>)> = Vec::new();
        let mut method_pools: Vec<((String, usize), Vec<Agreement>)> = Vec::new();
        let mut human_pools: Vec<(usize, Vec<Agreement>)> = Vec::new();
        let (mut with_truth, mut most_annotators) = (0, 0);
        for seq in sequences {
            let Some(truth) = truth_of(seq)? else { continue };
            with_truth += 1;
            let marks = &truth.annotators;
            if marks.len() < 2 {
                continue;
            }
            most_annotators = most_annotators.max(marks.len());
            let names: Vec<String> = if truth.annotator_names.len() == marks.len() {
                truth.annotator_names.clone()
            } else {
                (1..=marks.len()).map(|i| format!("annotator {i}")).collect()
            };
            let (rate, n_frames) = (seq.motion.frame_rate(), seq.motion.n_frames());
            for (ti, &tol) in self.tolerances.iter().enumerate() {
                let tol_frames = tolerance_frames(tol, rate);
                let shown_frames = Some(tol.frames_at(rate));
                let mut humans = Vec::new();
                for i in 0..marks.len() {
                    for j in i + 1..marks.len() {
                        let seed = row_seed(
                            self.chance.seed,
                            &seq.sequence,
                            &format!("{}\u{0}{}", names[i], names[j]),
                        );
                        let g = Agreement::of(
                            &marks[i],
                            &marks[j],
                            tol_frames,
                            n_frames,
                            self.chance,
                            seed,
                        );
                        pairs_rows.push(PairRow::new(
                            &seq.sequence,
                            (&names[i], &names[j]),
                            tol,
                            shown_frames,
                            &g,
                        ));
                        pool(&mut pair_pools, (names[i].clone(), names[j].clone(), ti), g);
                        humans.push(g);
                    }
                }
                let human = total(&humans);
                pool(&mut human_pools, ti, human);
                for m in &seq.methods {
                    let per_annotator: Vec<Agreement> = marks
                        .iter()
                        .zip(&names)
                        .map(|(a, name)| {
                            let seed = row_seed(
                                self.chance.seed,
                                &seq.sequence,
                                &format!("{}\u{0}{name}", m.method),
                            );
                            Agreement::of(&m.candidates, a, tol_frames, n_frames, self.chance, seed)
                        })
                        .collect();
                    let method = total(&per_annotator);
                    ceiling_rows.push(CeilingRow::new(
                        &seq.sequence,
                        &m.method,
                        tol,
                        shown_frames,
                        marks.len(),
                        &method,
                        &human,
                    ));
                    pool(&mut method_pools, (m.method.clone(), ti), method);
                }
            }
        }
        if with_truth == 0 {
            return Err(nothing_to_evaluate("human_agreement", "ground truth", sequences.len()));
        }
        if most_annotators < 2 {
            return Err(Error::new(
                ErrorKind::MissingKey,
                format!(
                    "human_agreement needs several annotators' marks of a sequence, but each of the {with_truth} sequences with ground truth has one; read a file with several annotators (an `annotator` column, or several ELAN tiers) with `consensus = {{ … }}`, which keeps each annotator's marks"
                ),
            )
            .with_field("truth"));
        }
        for ((a, b, ti), parts) in &pair_pools {
            pairs_rows.push(PairRow::new(
                "pooled",
                (a, b),
                self.tolerances[*ti],
                None,
                &total(parts),
            ));
        }
        for ((method, ti), parts) in &method_pools {
            let human = human_pools
                .iter()
                .find(|(t, _)| t == ti)
                .map(|(_, h)| total(h))
                .unwrap_or_default();
            ceiling_rows.push(CeilingRow::new(
                "pooled",
                method,
                self.tolerances[*ti],
                None,
                most_annotators,
                &total(parts),
                &human,
            ));
        }
        Ok(vec![
            Table::from_records(
                "annotator_agreement",
                "Agreement between annotators: boundary F1 and chance-corrected kappa at each tolerance",
                &pairs_rows,
            )?,
            Table::from_records(
                "human_ceiling",
                "Each method between the chance floor and the annotators' agreement (F1 and kappa against the annotators)",
                &ceiling_rows,
            )?,
        ])
    }
}

motionlab_core::register_plugin!(Evaluator, HumanAgreementParams, "human_agreement");

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sequences::fixtures::sequence;
    use motionlab_core::ColumnValues;
    use motionlab_core::registry::build_evaluator;

    fn evaluator(toml_text: &str) -> Box<dyn Evaluator> {
        build_evaluator("human_agreement", &toml::from_str(toml_text).unwrap()).unwrap()
    }

    fn f64s(t: &Table, name: &str) -> Vec<f64> {
        match t.column(name) {
            Some(ColumnValues::F64(v)) => v.clone(),
            Some(ColumnValues::I64(v)) => v.iter().map(|&x| x as f64).collect(),
            other => panic!("{name}: {other:?}"),
        }
    }

    fn texts(t: &Table, name: &str) -> Vec<String> {
        (0..t.n_rows()).map(|r| t.column(name).unwrap().cell(r)).collect()
    }

    /// 100 frames; ana marks {20, 50}, ben {22, 80}; method "m" finds {21, 50, 90}.
    fn two_annotators() -> Vec<motionlab_core::SequenceResult> {
        let mut seqs = vec![sequence(
            "s",
            100,
            100.0,
            Some(vec![(0, 21, "x"), (21, 100, "y")]),
            &[("m", &[21, 50, 90])],
        )];
        let truth = seqs[0].truth.as_mut().unwrap();
        truth.annotators = vec![vec![20, 50], vec![22, 80]];
        truth.annotator_names = vec!["ana".into(), "ben".into()];
        seqs
    }

    #[test]
    fn two_annotators_have_a_known_f1_chance_and_kappa() {
        // Tolerance 5 frames: 20 ↔ 22 match, 50 and 80 do not: M = 1, F1 = 2/4.
        // Chance: 2 random frames of 100 against two disjoint windows of 11 frames, each hit
        // with probability 1 − C(89, 2)/C(100, 2), both directions alike (all windows inside
        // the motion): E = 2·(1 − 89·88/(100·99)).
        let tables = evaluator("tolerances = [{ frames = 5 }, { frames = 30 }]")
            .evaluate(EvalInput::segmentation(&two_annotators()))
            .unwrap();
        let t = &tables[0];
        assert_eq!(t.name, "annotator_agreement");
        assert_eq!(texts(t, "sequence"), ["s", "s", "pooled", "pooled"]);
        assert_eq!(
            (texts(t, "annotator_a")[0].as_str(), texts(t, "annotator_b")[0].as_str()),
            ("ana", "ben")
        );
        let e = 2.0 * (1.0 - (89.0 * 88.0) / (100.0 * 99.0));
        assert_eq!(f64s(t, "n_matched")[0], 1.0);
        assert_eq!(f64s(t, "f1")[0], 0.5);
        assert!((f64s(t, "chance_matched")[0] - e).abs() < 1e-12);
        assert!((f64s(t, "chance_f1")[0] - e / 2.0).abs() < 1e-12);
        assert!(
            (f64s(t, "kappa")[0] - (1.0 - e) / (2.0 - e)).abs() < 1e-12,
            "{}",
            f64s(t, "kappa")[0]
        );
        assert_eq!(texts(t, "chance_expectation")[0], "exact");
        // Tolerance 30: 20 ↔ 22 and 50 ↔ 80 (or 50 ↔ 22 …): both match, kappa 1. Windows of 61
        // frames overlap, so chance is the Monte Carlo mean.
        assert_eq!((f64s(t, "f1")[1], f64s(t, "kappa")[1]), (1.0, 1.0));
        assert_eq!(texts(t, "chance_expectation")[1], "monte_carlo");
        // One sequence: its pooled rows are its own.
        assert_eq!(f64s(t, "kappa")[2], f64s(t, "kappa")[0]);

        let c = &tables[1];
        assert_eq!(c.name, "human_ceiling");
        // m = {21, 50, 90} at 5 frames: vs ana {20, 50}: 2 matched; vs ben {22, 80}: 1.
        // Summed: M = 3 of (3 + 2) + (3 + 2) → F1 = 6/10.
        assert_eq!(f64s(c, "f1")[0], 0.6);
        assert_eq!(f64s(c, "human_f1")[0], 0.5);
        let row = |name: &str| f64s(c, name)[0];
        assert!(
            (row("fraction_of_ceiling")
                - (row("f1") - row("chance_f1")) / (row("human_f1") - row("chance_f1")))
            .abs()
                < 1e-15
        );
        assert!(row("chance_f1") > 0.0 && row("chance_f1") < 0.5);
        assert_eq!(texts(c, "sequence"), ["s", "s", "pooled", "pooled"]);
        assert_eq!(f64s(c, "n_annotators"), [2.0; 4]);
    }

    #[test]
    fn agreement_is_symmetric_and_sums_over_pairs() {
        let s = ChanceSettings::default();
        let (a, b) = (vec![10, 40, 70], vec![12, 75]);
        let ab = Agreement::of(&a, &b, 4.0, 100, s, 7);
        let ba = Agreement::of(&b, &a, 4.0, 100, s, 7);
        assert_eq!(ab.matched, ba.matched);
        assert!((ab.expected - ba.expected).abs() < 1e-12);
        let both = total([&ab, &ba]);
        assert_eq!((both.n_a + both.n_b, both.matched), (10, 2));
        assert_eq!(both.f1(), ab.f1());
        // Kappa is Cohen's form of F1 against chance F1.
        assert!((ab.kappa() - (ab.f1() - ab.chance_f1()) / (1.0 - ab.chance_f1())).abs() < 1e-12);
        // F1 is NaN only when both sets are empty; kappa when chance alone agrees fully.
        assert!(Agreement::of(&[], &[], 4.0, 100, s, 1).f1().is_nan());
        assert_eq!(Agreement::of(&[], &[5], 4.0, 100, s, 1).kappa(), 0.0);
        assert!(Agreement::of(&[0, 1], &[0, 1], 200.0, 2, s, 1).kappa().is_nan());
    }

    #[test]
    fn one_annotator_is_an_error_that_says_how_to_keep_several() {
        let seqs = vec![sequence(
            "s",
            100,
            100.0,
            Some(vec![(0, 21, "x"), (21, 100, "y")]),
            &[("m", &[21])],
        )];
        let e = evaluator("").evaluate(EvalInput::segmentation(&seqs)).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::MissingKey);
        assert!(e.to_string().contains("consensus"), "{e}");
        let none = vec![sequence("s", 100, 100.0, None, &[("m", &[21])])];
        assert_eq!(
            evaluator("").evaluate(EvalInput::segmentation(&none)).unwrap_err().kind(),
            ErrorKind::MissingKey
        );
        let bad = build_evaluator("human_agreement", &toml::from_str("tolerances = []").unwrap())
            .err()
            .unwrap();
        assert_eq!(bad.location().field.as_deref(), Some("tolerances"));
        assert!(
            motionlab_core::registry::find("human_agreement")
                .unwrap()
                .doc()
                .contains("Missing samples")
        );
    }
}
