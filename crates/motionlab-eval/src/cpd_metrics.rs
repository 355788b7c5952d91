//! The change-point metrics people compare with: TCPDBench's F1 with several annotators and
//! its segment covering (van den Burg & Williams 2020, "An Evaluation of Change Point Detection
//! Algorithms"; TSSB, Ermshaus et al., uses the same two functions with one annotator).
//!
//! Both are re-implemented here exactly as TCPDBench's `analysis/scripts/metrics.py` computes
//! them, operation for operation, so that the numbers agree to the last bits
//! (`bench/metrics_crosscheck.py` compares them, and the max-matching P/R and Hausdorff
//! distance of [`crate::boundaries`], with independent Python implementations and ruptures on
//! random cases; run by CI).
//!
//! # TCPDBench F1 (`f_measure`)
//!
//! Annotators `T_1 … T_K` (each a set of frames, each with frame 0 added — "the start is a
//! change point", so P and R are never 0/0), predictions `X` (a set, with 0 added),
//! `T* = ∪ T_k`, margin `M` frames:
//!
//! - `TP(T, X)`: for each truth `τ` of `T` in **ascending** order, the closest still unused
//!   prediction within `M` (ties: the smaller frame) is used up and `τ` counts — a greedy
//!   matching, not a maximum one (TCPDBench iterates a Python set, whose order for small
//!   non-negative integers is ascending; ascending is the documented choice here).
//! - `P = |TP(T*, X)| / |X|`; `R = (1/K) Σ_k |TP(T_k, X)| / |T_k|`;
//!   `F = P·R / (α·R + (1 − α)·P)` with `α = ½`.
//!
//! Differences from `boundary_pr`'s numbers, on purpose of TCPDBench: the extra point at 0 on
//! both sides, sets (duplicates count once), greedy matching, and recall averaged over
//! annotators.
//!
//! # Segment covering (`covering`)
//!
//! A change-point list splits frames `0..n` into segments `[0, c_1), [c_1, c_2), …, [c_k, n)`
//! (distinct points with `0 < c < n`; others are ignored). The covering of annotator `k`'s
//! partition `S_k` by the predicted one `S'` is `C = (1/n) Σ_{A ∈ S_k} |A| · max_{A' ∈ S'} J(A, A')`
//! with the Jaccard index `J = |A ∩ A'| / |A ∪ A'|`, averaged over the annotators.

/// TCPDBench's greedy true positives: the truths of `truth` (sorted, distinct) that got a
/// prediction of `predictions` (sorted, distinct) within `margin` frames.
fn true_positives(truth: &[usize], predictions: &[usize], margin: usize) -> usize {
    let mut free = vec![true; predictions.len()];
    let mut count = 0;
    for &tau in truth {
        let lo = predictions.partition_point(|&x| x + margin < tau);
        // Closest free prediction within the margin; ties go to the smaller frame (first seen).
        let mut best: Option<(usize, usize)> = None;
        for (i, &x) in predictions.iter().enumerate().skip(lo) {
            if x > tau + margin {
                break;
            }
            if free[i] && best.is_none_or(|(d, _)| x.abs_diff(tau) < d) {
                best = Some((x.abs_diff(tau), i));
            }
        }
        if let Some((_, i)) = best {
            free[i] = false;
            count += 1;
        }
    }
    count
}

/// A sorted, distinct copy of `frames` with frame 0 added.
fn with_start(frames: &[usize]) -> Vec<usize> {
    let mut v: Vec<usize> = frames.iter().copied().chain([0]).collect();
    v.sort_unstable();
    v.dedup();
    v
}

/// TCPDBench's F1 (`f_measure`, α = ½) with its precision and recall: `(f1, precision, recall)`.
/// `annotators` holds each annotator's boundary frames separately (as [`crate::consensus`]
/// takes them); NaN when there is no annotator.
pub fn tcpd_f_measure(
    annotators: &[Vec<usize>],
    predictions: &[usize],
    margin_frames: usize,
) -> (f64, f64, f64) {
    if annotators.is_empty() {
        return (f64::NAN, f64::NAN, f64::NAN);
    }
    let alpha = 0.5;
    let x = with_start(predictions);
    let tks: Vec<Vec<usize>> = annotators.iter().map(|a| with_start(a)).collect();
    let mut union: Vec<usize> = tks.iter().flatten().copied().collect();
    union.sort_unstable();
    union.dedup();
    let k = tks.len() as f64;
    let precision = true_positives(&union, &x, margin_frames) as f64 / x.len() as f64;
    let recall_sum: f64 =
        tks.iter().map(|t| true_positives(t, &x, margin_frames) as f64 / t.len() as f64).sum();
    // Python evaluates `1 / K * sum(...)` left to right: (1/K)·Σ.
    let recall = 1.0 / k * recall_sum;
    (precision * recall / (alpha * recall + (1.0 - alpha) * precision), precision, recall)
}

/// The segments `[start, end)` of frames `0..n_frames` cut at `change_points`.
pub fn partition(change_points: &[usize], n_frames: usize) -> Vec<(usize, usize)> {
    let mut cuts: Vec<usize> =
        change_points.iter().copied().filter(|&c| c > 0 && c < n_frames).collect();
    cuts.sort_unstable();
    cuts.dedup();
    let mut out = Vec::with_capacity(cuts.len() + 1);
    let mut start = 0;
    for c in cuts {
        out.push((start, c));
        start = c;
    }
    out.push((start, n_frames));
    out
}

/// Covering of partition `truth` by partition `found` (both of the same frames).
fn cover_single(truth: &[(usize, usize)], found: &[(usize, usize)], n_frames: usize) -> f64 {
    let mut c = 0.0;
    for &(s, e) in truth {
        let best = found
            .iter()
            .map(|&(s2, e2)| {
                let inter = e.min(e2).saturating_sub(s.max(s2));
                let union = (e - s) + (e2 - s2) - inter;
                inter as f64 / union as f64
            })
            .fold(f64::NEG_INFINITY, f64::max);
        c += (e - s) as f64 * best;
    }
    c / n_frames as f64
}

/// TCPDBench's segment covering of each annotator's partition by the predicted one, averaged
/// over annotators; NaN without annotators or frames.
pub fn covering(annotators: &[Vec<usize>], predictions: &[usize], n_frames: usize) -> f64 {
    if annotators.is_empty() || n_frames == 0 {
        return f64::NAN;
    }
    let found = partition(predictions, n_frames);
    let cs: Vec<f64> = annotators
        .iter()
        .map(|a| cover_single(&partition(a, n_frames), &found, n_frames))
        .collect();
    cs.iter().sum::<f64>() / cs.len() as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn true_positives_match_tcpdbench_doctests() {
        // TCPDBench metrics.py doctests (margin 5).
        assert_eq!(true_positives(&[1, 10, 20, 23], &[3, 8, 20], 5), 3);
        assert_eq!(true_positives(&[1, 10, 20, 23], &[1, 3, 8, 20], 5), 3);
        assert_eq!(true_positives(&[1, 10, 20, 23], &[1, 3, 5, 8, 20], 5), 3);
        assert_eq!(true_positives(&[], &[1, 2, 3], 5), 0);
        assert_eq!(true_positives(&[1, 2, 3], &[], 5), 0);
    }

    #[test]
    fn f_measure_by_hand() {
        // TCPDBench doctest: f_measure({1: [10, 20], 2: [11, 20], 3: [10], 4: [0, 5]}, [10, 20])
        // = 1.0 (P = 1, R = 1 with the start point counted).
        let ann = vec![vec![10, 20], vec![11, 20], vec![10], vec![0, 5]];
        let (f, p, r) = tcpd_f_measure(&ann, &[10, 20], 5);
        assert_eq!((f, p, r), (1.0, 1.0, 1.0));
        // Predictions {0, 10, 20}; annotators: {0, 10, 20} hit 3/3, {0, 5} hit 2/2 → R = 1; the
        // union {0, 5, 10, 11, 20} is served by 3 of 3 predictions. With [10] only: X = {0, 10};
        // annotator 1 {0, 10, 20}: 2/3; annotator 2 {0, 11, 20}: 2/3; 3 {0, 10}: 1; 4 {0, 5}: 1
        // (5 takes 10: |10 − 5| ≤ 5). R = (2/3 + 2/3 + 1 + 1)/4 = 5/6; P = 2/2.
        let (f, p, r) = tcpd_f_measure(&ann, &[10], 5);
        assert_eq!(p, 1.0);
        assert!((r - 5.0 / 6.0).abs() < 1e-15);
        assert!((f - 2.0 * r / (1.0 + r)).abs() < 1e-15);
        assert!(tcpd_f_measure(&[], &[1], 5).0.is_nan());
    }

    #[test]
    fn covering_by_hand() {
        // TCPDBench doctest: covering({1: [10, 20], 2: [10], 3: [0, 5]}, [10, 20], 45)
        // = 0.7962962962962963.
        let c = covering(&[vec![10, 20], vec![10], vec![0, 5]], &[10, 20], 45);
        assert!((c - 0.7962962962962963).abs() < 1e-15, "{c}");
        // Equal partitions cover each other fully; one segment covering three is 1/3-ish.
        assert_eq!(covering(&[vec![30, 60]], &[30, 60], 90), 1.0);
        assert!((covering(&[vec![30, 60]], &[], 90) - 1.0 / 3.0).abs() < 1e-15);
        assert_eq!(partition(&[0, 5, 5, 99, 100], 100), [(0, 5), (5, 99), (99, 100)]);
    }
}
