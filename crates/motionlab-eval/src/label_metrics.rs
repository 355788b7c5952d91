//! Agreement of two labellings of the same samples — the true states and the found ones — by
//! the adjusted mutual information (AMI), the adjusted Rand index (ARI) and the normalised
//! mutual information (NMI), per sample, as scikit-learn computes them
//! (`adjusted_mutual_info_score`, `adjusted_rand_score`, `normalized_mutual_info_score`, the
//! arithmetic mean as the normaliser of AMI and NMI; equal to 1e-12, checked in CI by
//! `bench/label_metrics_vs_sklearn.py` on random and real label sequences), each beside a chance
//! baseline.
//!
//! The formulas are scikit-learn's, step for step, so the two agree beyond the last digits of
//! summation order: the contingency table of the two labellings; MI from its non-zero cells as
//! `n_ij/N · (ln n_ij − ln N) + n_ij/N · (ln N_a + ln N_b − ln(a_i b_j))`, cells under machine
//! epsilon zeroed, the sum clipped at 0; entropies from the label counts; the expected MI of
//! Vinh, Epps & Bailey (2010) under the hypergeometric model, in log-gamma space; the ARI from
//! the pair confusion matrix in exact integers (`i128`: `tp · tn` overflows 64 bits from
//! about 55,000 samples; scikit-learn uses Python's unbounded integers). Special cases as
//! scikit-learn's: both labellings a single label (or both empty) score 1 (AMI, NMI; ARI 1 when
//! no pair is split differently); MI 0 gives NMI 0.
//!
//! **Chance**: the found labels permuted across the found segments (the maximal runs of one
//! found label): the method's own segmentation with its labels shuffled, `draws` times from a
//! seed; chance is the mean score of the draws and the p-value the add-one rule of
//! [`chance_of_draws`] (`(1 + #{draw ≥ score}) / (1 + draws)`). It asks whether the labels add
//! anything to the segmentation they sit on: a labeller that merely segments scores near its
//! chance.

use std::collections::HashMap;
use std::hash::Hash;

use motionlab_core::{Error, ErrorKind, Result};
use serde::{Deserialize, Serialize};

use crate::chance::{ChanceSettings, chance_of_draws};
use crate::series_scores::ScoreWithChance;

/// The contingency table of two labellings of `n` samples: the row (true label) and column
/// (found label) sums and the non-zero cells `(row, column, count)`.
#[derive(Clone, Debug, PartialEq)]
pub struct Contingency {
    pub n: usize,
    pub rows: Vec<usize>,
    pub columns: Vec<usize>,
    pub cells: Vec<(usize, usize, usize)>,
}

/// Dense indices of `labels` in order of first appearance.
fn indices<T: Eq + Hash>(labels: &[T]) -> (Vec<usize>, usize) {
    let mut ids: HashMap<&T, usize> = HashMap::new();
    let out = labels
        .iter()
        .map(|l| {
            let next = ids.len();
            *ids.entry(l).or_insert(next)
        })
        .collect();
    (out, ids.len())
}

impl Contingency {
    /// The table of `truth` against `found`; they must label the same samples.
    pub fn of<T: Eq + Hash, U: Eq + Hash>(truth: &[T], found: &[U]) -> Result<Contingency> {
        if truth.len() != found.len() {
            return Err(Error::new(
                ErrorKind::WrongValueCount,
                format!(
                    "{} found labels for {} true labels; expected one label per sample in each",
                    found.len(),
                    truth.len()
                ),
            ));
        }
        let (t, n_rows) = indices(truth);
        let (f, n_columns) = indices(found);
        Ok(Contingency::of_indices(&t, n_rows, &f, n_columns))
    }

    fn of_indices(t: &[usize], n_rows: usize, f: &[usize], n_columns: usize) -> Contingency {
        let mut rows = vec![0; n_rows];
        let mut columns = vec![0; n_columns];
        let mut cells: HashMap<(usize, usize), usize> = HashMap::new();
        for (&i, &j) in t.iter().zip(f) {
            rows[i] += 1;
            columns[j] += 1;
            *cells.entry((i, j)).or_insert(0) += 1;
        }
        let mut cells: Vec<(usize, usize, usize)> =
            cells.into_iter().map(|((i, j), c)| (i, j, c)).collect();
        // A fixed order (row, column): sums do not depend on the hash map's.
        cells.sort_unstable();
        Contingency { n: t.len(), rows, columns, cells }
    }

    /// Both labellings a single label, or both empty: scikit-learn's perfect-match case.
    fn trivial(&self) -> bool {
        self.rows.len() == self.columns.len() && self.rows.len() <= 1
    }
}

/// The entropy (nats) of a labelling with these label counts: scikit-learn's `entropy`.
pub fn entropy(counts: &[usize]) -> f64 {
    let pi: Vec<f64> = counts.iter().filter(|&&c| c > 0).map(|&c| c as f64).collect();
    if counts.iter().sum::<usize>() == 0 {
        return 1.0;
    }
    if pi.len() == 1 {
        return 0.0;
    }
    let sum: f64 = pi.iter().sum();
    let log_sum = sum.ln();
    -pi.iter().map(|&p| (p / sum) * (p.ln() - log_sum)).sum::<f64>()
}

/// Mutual information (nats) of the table: scikit-learn's `mutual_info_score`.
pub fn mutual_info(c: &Contingency) -> f64 {
    if c.rows.len() == 1 || c.columns.len() == 1 || c.n == 0 {
        return 0.0;
    }
    let total = c.n as f64;
    let (log_total, log_rows, log_columns) = (total.ln(), total.ln(), total.ln());
    let mi: f64 = c
        .cells
        .iter()
        .map(|&(i, j, nij)| {
            let p = nij as f64 / total;
            // The product in integers, as scikit-learn's int64 `outer`.
            let outer = (c.rows[i] as u128 * c.columns[j] as u128) as f64;
            let log_outer = -outer.ln() + log_rows + log_columns;
            let v = p * ((nij as f64).ln() - log_total) + p * log_outer;
            if v.abs() < f64::EPSILON { 0.0 } else { v }
        })
        .sum();
    mi.max(0.0)
}

/// The expected mutual information of two labellings with these label counts, drawn at random
/// (the hypergeometric model; Vinh, Epps & Bailey 2010): scikit-learn's
/// `expected_mutual_information`, term for term.
pub fn expected_mutual_info(rows: &[usize], columns: &[usize], n: usize) -> f64 {
    if rows.len() == 1 || columns.len() == 1 {
        return 0.0;
    }
    let lg = |x: f64| libm::lgamma(x);
    let nf = n as f64;
    let top = rows.iter().chain(columns).copied().max().unwrap_or(0);
    // nijs[0] is never used (1, as scikit-learn sets it, to keep the logs finite).
    let nijs: Vec<f64> = (0..=top).map(|k| if k == 0 { 1.0 } else { k as f64 }).collect();
    let term1: Vec<f64> = nijs.iter().map(|&x| x / nf).collect();
    let log_nnij: Vec<f64> = nijs.iter().map(|&x| nf.ln() + x.ln()).collect();
    let gln_nnij: Vec<f64> = nijs.iter().map(|&x| lg(x + 1.0) + lg(nf + 1.0)).collect();
    let mut emi = 0.0;
    for &a in rows {
        let (log_a, gln_a, gln_na) =
            ((a as f64).ln(), lg(a as f64 + 1.0), lg((n - a) as f64 + 1.0));
        for &b in columns {
            let (log_b, gln_b, gln_nb) =
                ((b as f64).ln(), lg(b as f64 + 1.0), lg((n - b) as f64 + 1.0));
            let start = (a + b).saturating_sub(n).max(1);
            let end = a.min(b) + 1;
            for nij in start..end {
                let term2 = log_nnij[nij] - log_a - log_b;
                let gln = gln_a + gln_b + gln_na + gln_nb
                    - gln_nnij[nij]
                    - lg((a - nij) as f64 + 1.0)
                    - lg((b - nij) as f64 + 1.0)
                    - lg((n + nij - a - b) as f64 + 1.0);
                emi += term1[nij] * term2 * gln.exp();
            }
        }
    }
    emi
}

/// Normalised mutual information (arithmetic mean of the entropies as the normaliser).
pub fn nmi_of(c: &Contingency) -> f64 {
    if c.trivial() {
        return 1.0;
    }
    let mi = mutual_info(c);
    if mi == 0.0 {
        return 0.0;
    }
    let normaliser = (entropy(&c.rows) + entropy(&c.columns)) / 2.0;
    mi / normaliser.max(f64::EPSILON)
}

/// Adjusted mutual information (arithmetic mean of the entropies as the normaliser).
pub fn ami_of(c: &Contingency) -> f64 {
    if c.trivial() {
        return 1.0;
    }
    if c.rows.len() == 1 || c.columns.len() == 1 {
        return 0.0;
    }
    let mi = mutual_info(c);
    let emi = expected_mutual_info(&c.rows, &c.columns, c.n);
    let normaliser = (entropy(&c.rows) + entropy(&c.columns)) / 2.0;
    // scikit-learn keeps the numerator's and denominator's signs and each at least machine
    // epsilon from 0 (so 0/0 — two samples apart in both labellings — is 1).
    let away = |x: f64| if x < 0.0 { x.min(-f64::EPSILON) } else { x.max(f64::EPSILON) };
    away(mi - emi) / away(normaliser - emi)
}

/// Adjusted Rand index, from the pair confusion matrix in exact integers.
pub fn ari_of(c: &Contingency) -> f64 {
    let n = c.n as i128;
    let sum_squares: i128 = c.cells.iter().map(|&(_, _, x)| (x as i128) * (x as i128)).sum();
    // Σ_cells n_ij · b_j and Σ_cells n_ij · a_i: the pairs together in one labelling.
    let by_columns: i128 = c.cells.iter().map(|&(_, j, x)| x as i128 * c.columns[j] as i128).sum();
    let by_rows: i128 = c.cells.iter().map(|&(i, _, x)| x as i128 * c.rows[i] as i128).sum();
    let tp = sum_squares - n;
    let fp = by_columns - sum_squares;
    let fn_ = by_rows - sum_squares;
    let tn = n * n - fp - fn_ - sum_squares;
    if fn_ == 0 && fp == 0 {
        return 1.0;
    }
    // As Python evaluates `2.0 * (tp * tn - fn * fp) / (…)`: exact integers, one rounding each.
    2.0 * ((tp * tn - fn_ * fp) as f64) / (((tp + fn_) * (fn_ + tn) + (tp + fp) * (fp + tn)) as f64)
}

/// AMI of two labellings of the same samples (scikit-learn's `adjusted_mutual_info_score`).
pub fn ami<T: Eq + Hash, U: Eq + Hash>(truth: &[T], found: &[U]) -> Result<f64> {
    Ok(ami_of(&Contingency::of(truth, found)?))
}

/// ARI of two labellings of the same samples (scikit-learn's `adjusted_rand_score`).
pub fn ari<T: Eq + Hash, U: Eq + Hash>(truth: &[T], found: &[U]) -> Result<f64> {
    Ok(ari_of(&Contingency::of(truth, found)?))
}

/// NMI of two labellings of the same samples (scikit-learn's `normalized_mutual_info_score`).
pub fn nmi<T: Eq + Hash, U: Eq + Hash>(truth: &[T], found: &[U]) -> Result<f64> {
    Ok(nmi_of(&Contingency::of(truth, found)?))
}

/// AMI, ARI and NMI of one labelling, each beside its chance baseline.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LabelScores {
    pub n_samples: usize,
    /// The found segments (maximal runs of one found label) whose labels the draws permute.
    pub n_found_segments: usize,
    pub ami: ScoreWithChance,
    pub ari: ScoreWithChance,
    pub nmi: ScoreWithChance,
}

/// Scores `found` against `truth` (one label per sample each) with the chance baseline of
/// `chance.draws` permutations of the found labels across the found segments, from `seed`
/// (the same permutations for the three metrics).
pub fn label_scores<T: Eq + Hash, U: Eq + Hash>(
    truth: &[T],
    found: &[U],
    chance: ChanceSettings,
    seed: u64,
) -> Result<LabelScores> {
    let c = Contingency::of(truth, found)?;
    let (t, n_rows) = indices(truth);
    let (f, n_columns) = indices(found);
    // The found segments: start sample and label of each run.
    let mut starts: Vec<usize> = Vec::new();
    let mut labels: Vec<usize> = Vec::new();
    for (s, &l) in f.iter().enumerate() {
        if labels.last() != Some(&l) || s == 0 {
            starts.push(s);
            labels.push(l);
        }
    }
    let mut rng = fastrand::Rng::with_seed(seed);
    let mut permuted = vec![0; f.len()];
    let (mut ami_d, mut ari_d, mut nmi_d) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..chance.draws {
        rng.shuffle(&mut labels);
        for (k, &start) in starts.iter().enumerate() {
            let end = starts.get(k + 1).copied().unwrap_or(f.len());
            permuted[start..end].fill(labels[k]);
        }
        let d = Contingency::of_indices(&t, n_rows, &permuted, n_columns);
        ami_d.push(ami_of(&d));
        ari_d.push(ari_of(&d));
        nmi_d.push(nmi_of(&d));
    }
    let with = |value: f64, draws: Vec<f64>| {
        let (chance, p_value) = chance_of_draws(&draws, value);
        ScoreWithChance { value, chance, p_value, draws }
    };
    Ok(LabelScores {
        n_samples: c.n,
        n_found_segments: starts.len(),
        ami: with(ami_of(&c), ami_d),
        ari: with(ari_of(&c), ari_d),
        nmi: with(nmi_of(&c), nmi_d),
    })
}

/// The true state of every sample from a ground truth's labelled segments (the segment's
/// label; `None` for a sample in no segment, which the scores leave out). `what` names the
/// truth in messages (its file). Refused, with what was expected: a truth without labelled
/// segments, a segment without a label, overlapping segments, a segment past the sequence's
/// `n_samples`.
pub fn truth_states(
    segments: &[motionlab_core::Segment],
    n_samples: usize,
    what: &str,
) -> Result<Vec<Option<String>>> {
    let bad = |msg: String| Err(Error::new(ErrorKind::InvalidParameter, format!("{what}: {msg}")));
    if segments.is_empty() {
        return bad("has no labelled segments; states are scored against a label per segment (a CSV truth's `label` column, mocap6 or CMU-86 labels, TSSB's properties.txt)".into());
    }
    let mut out: Vec<Option<String>> = vec![None; n_samples];
    let mut sorted: Vec<&motionlab_core::Segment> = segments.iter().collect();
    sorted.sort_by_key(|s| (s.start, s.end));
    for (k, s) in sorted.iter().enumerate() {
        if s.label.trim().is_empty() {
            return bad(format!(
                "segment {}..{} has no label; expected a state label on every segment",
                s.start, s.end
            ));
        }
        if s.end > n_samples || s.start >= s.end {
            return bad(format!(
                "segment {}..{} ({:?}) is empty or ends past the sequence's {n_samples} samples; a label file for another sequence?",
                s.start, s.end, s.label
            ));
        }
        if let Some(prev) = k.checked_sub(1).map(|j| sorted[j]).filter(|p| p.end > s.start) {
            return bad(format!(
                "segments {}..{} ({:?}) and {}..{} ({:?}) overlap; expected one state per sample",
                prev.start, prev.end, prev.label, s.start, s.end, s.label
            ));
        }
        out[s.start..s.end].fill(Some(s.label.clone()));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Hand-computed: truth [0,0,1,1], found [0,0,0,1]. Pairs (6): together in both {0,1};
    /// truth-only {2,3}; found-only {0,2},{1,2}; apart in both {0,3},{1,3}: tp 1·2 = 2 (ordered
    /// pairs), fn 2, fp 4, tn 4 → ARI 2(2·4 − 2·4)/… = 0. MI: cells (0,0) 2, (1,0) 1, (1,1) 1
    /// of 4 with rows (2,2), columns (3,1).
    #[test]
    fn known_answers_on_hand_made_labellings() {
        let (t, f) = ([0, 0, 1, 1], [0, 0, 0, 1]);
        assert_eq!(ari(&t, &f).unwrap(), 0.0);
        let mi = 0.5 * (2.0f64 * 4.0 / 6.0).ln()
            + 0.25 * (1.0f64 * 4.0 / 6.0).ln()
            + 0.25 * (1.0f64 * 4.0 / 2.0).ln();
        let c = Contingency::of(&t, &f).unwrap();
        assert!((mutual_info(&c) - mi).abs() < 1e-15);
        let (ht, hf) = (2f64.ln(), -(0.75 * 0.75f64.ln() + 0.25 * 0.25f64.ln()));
        assert!((nmi(&t, &f).unwrap() - mi / ((ht + hf) / 2.0)).abs() < 1e-15);
        // Identical partitions (up to renaming) score 1; a single found label scores 0.
        assert_eq!(ari(&[1, 1, 2, 2, 3], &["a", "a", "b", "b", "c"]).unwrap(), 1.0);
        assert!((ami(&[1, 1, 2, 2, 3], &[7, 7, 5, 5, 6]).unwrap() - 1.0).abs() < 1e-12);
        assert_eq!(nmi(&[1, 1, 2, 2], &[9, 9, 8, 8]).unwrap(), 1.0);
        assert_eq!(nmi(&[1, 1, 2, 2], &[0, 0, 0, 0]).unwrap(), 0.0);
        assert_eq!(ami(&[1, 1, 2, 2], &[0, 0, 0, 0]).unwrap(), 0.0);
        // scikit-learn's special cases: both one label, both empty.
        assert_eq!(ami(&[3, 3], &[4, 4]).unwrap(), 1.0);
        assert_eq!(nmi::<u8, u8>(&[], &[]).unwrap(), 1.0);
        assert_eq!(ari::<u8, u8>(&[], &[]).unwrap(), 1.0);
        let e = ami(&[1, 2], &[1]).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::WrongValueCount);
    }

    /// The expected MI of the hypergeometric model equals the mean MI over every permutation
    /// of a small labelling (exhaustive: 6!/(2!·2!·2!) = 90 distinct arrangements, each equally
    /// likely under a uniform permutation).
    #[test]
    fn expected_mutual_information_is_the_mean_over_all_permutations() {
        fn permutations(v: &mut Vec<usize>, k: usize, out: &mut Vec<Vec<usize>>) {
            if k == v.len() {
                out.push(v.clone());
                return;
            }
            for i in k..v.len() {
                v.swap(k, i);
                permutations(v, k + 1, out);
                v.swap(k, i);
            }
        }
        let truth = [0, 0, 1, 1, 2, 2];
        let mut found = vec![0, 0, 0, 1, 1, 2];
        let mut all = Vec::new();
        permutations(&mut found, 0, &mut all);
        let mean =
            all.iter().map(|f| mutual_info(&Contingency::of(&truth, f).unwrap())).sum::<f64>()
                / all.len() as f64;
        let emi = expected_mutual_info(&[2, 2, 2], &[3, 2, 1], 6);
        assert!((emi - mean).abs() < 1e-12, "{emi} vs {mean}");
    }

    /// 2 × 10^5 samples: the pair counts pass 2^63 (tp·tn ~ 10^20) and the ARI stays exact
    /// (in [−1, 1], 1 for a renamed copy).
    #[test]
    fn ari_does_not_overflow_on_long_sequences() {
        let n = 200_000;
        let t: Vec<usize> = (0..n).map(|i| i * 7 / n).collect();
        let f: Vec<usize> = (0..n).map(|i| (i * 5 / n) + 10).collect();
        let v = ari(&t, &f).unwrap();
        assert!(v > 0.0 && v < 1.0, "{v}");
        let renamed: Vec<usize> = t.iter().map(|x| 100 - x).collect();
        assert_eq!(ari(&t, &renamed).unwrap(), 1.0);
    }

    /// Chance: the found labels permuted over the found segments. Labels that follow the
    /// truth beat their chance; a labelling whose segments each carry a fresh label (no state
    /// repeats) is its own chance: every permutation gives the same partition (p = 1).
    #[test]
    fn chance_permutes_the_found_labels_across_the_found_segments() {
        // Truth A B A B A B in segments of 20; found the same with its labels.
        let truth: Vec<u8> = (0..120).map(|i| (i / 20 % 2) as u8).collect();
        let found: Vec<u8> = truth.iter().map(|&x| x + 5).collect();
        let chance = ChanceSettings { draws: 200, seed: 1 };
        let s = label_scores(&truth, &found, chance, 42).unwrap();
        assert_eq!(s.n_found_segments, 6);
        assert!((s.ami.value - 1.0).abs() < 1e-12 && s.ami.chance < 0.5, "{s:?}");
        // 6 segments, 3 of each label: C(6,3) = 20 arrangements, 2 of them perfect → p ≈ 0.1.
        assert!(s.ari.p_value < 0.2 && s.ari.p_value > 0.02, "{}", s.ari.p_value);
        assert_eq!(s.ari.draws.len(), 200);
        // The same seed gives the same draws.
        assert_eq!(label_scores(&truth, &found, chance, 42).unwrap(), s);
        // Every segment its own label: permuting renames, the partition stays: p = 1.
        let fresh: Vec<usize> = (0..120).map(|i| i / 20).collect();
        let s = label_scores(&truth, &fresh, chance, 42).unwrap();
        assert!(s.nmi.draws.iter().all(|&d| (d - s.nmi.value).abs() < 1e-12));
        assert_eq!(s.nmi.p_value, 1.0);
    }

    #[test]
    fn truth_states_refuse_unlabelled_overlapping_and_too_long_segments() {
        let seg =
            |start, end, label: &str| motionlab_core::Segment { start, end, label: label.into() };
        let ok = truth_states(&[seg(0, 2, "a"), seg(3, 5, "b")], 6, "t.csv").unwrap();
        assert_eq!(
            ok,
            vec![
                Some("a".into()),
                Some("a".into()),
                None,
                Some("b".into()),
                Some("b".into()),
                None
            ]
        );
        for (segments, needle) in [
            (vec![], "no labelled segments"),
            (vec![seg(0, 2, "a"), seg(2, 4, " ")], "segment 2..4 has no label"),
            (vec![seg(0, 3, "a"), seg(2, 4, "b")], "overlap"),
            (vec![seg(0, 3, "a"), seg(3, 9, "b")], "past the sequence's 6 samples"),
        ] {
            let e = truth_states(&segments, 6, "t.csv").unwrap_err();
            assert!(e.to_string().contains(needle) && e.to_string().contains("t.csv"), "{e}");
        }
    }
}
