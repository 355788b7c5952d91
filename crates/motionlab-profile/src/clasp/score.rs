//! The classification score profile from the neighbours of one temporal constraint (claspy's
//! `_profile` with `cross_val_labels`), and the significance test of a split.
//!
//! For a split `s`, claspy labels every window left (0) or right (1) of `s`, predicts each
//! window's label by the majority of its k neighbours' labels, forces the `w` windows just
//! before `s` to 1 and scores the predictions. A window's prediction is 1 exactly while `s` is
//! at most the m-th largest of its neighbour offsets (m = ⌊k/2⌋ + 1), so every count the score
//! needs changes by a few windows from one split to the next: the profile is computed from
//! running counts in O(n) rather than claspy's O(n·k) per split, with claspy's arithmetic on
//! those counts.

use crate::clasp::Score;

/// `threshold[i]`: the m-th largest neighbour offset of window i; window i is predicted right
/// of split s exactly when `s <= threshold[i]`.
fn majority_thresholds(offsets: &[u32], k: usize) -> Vec<usize> {
    let m = k / 2 + 1;
    let mut row = vec![0u32; k];
    offsets
        .chunks_exact(k)
        .map(|o| {
            row.copy_from_slice(o);
            row.sort_unstable_by(|a, b| b.cmp(a));
            row[m - 1] as usize
        })
        .collect()
}

/// claspy's ROC AUC (`roc_auc_score(y_true, y_pred)`, the true labels as scores), from counts:
/// `n` windows, `p` of them right of the split, `ones` predicted right, `right_ones` of those
/// right of the split.
fn roc_auc(n: usize, p: usize, ones: usize, right_ones: usize) -> f64 {
    let zeros = n - ones;
    if zeros == 0 || ones == 0 {
        return f64::NEG_INFINITY;
    }
    let fpr = (p - right_ones) as f64 / zeros as f64;
    let tpr = right_ones as f64 / ones as f64;
    let d0 = fpr - 0.0;
    let d1 = 1.0 - fpr;
    let y0 = (tpr + 0.0) / 2.0;
    let y1 = (1.0 + tpr) / 2.0;
    (0.0 + d0 * y0) + d1 * y1
}

/// claspy's macro F1 over both labels, from the same counts (`s` windows left of the split).
fn f1(s: usize, p: usize, ones: usize, right_ones: usize) -> f64 {
    let left_ones = ones - right_ones;
    let per_label = |tp: usize, fp: usize, fn_: usize| -> Option<f64> {
        if tp + fp == 0 || tp + fn_ == 0 {
            return None;
        }
        let pr = tp as f64 / (tp + fp) as f64;
        let re = tp as f64 / (tp + fn_) as f64;
        if pr + re == 0.0 {
            return None;
        }
        Some(2.0 * (pr * re) / (pr + re))
    };
    let Some(f0) = per_label(s - left_ones, p - right_ones, left_ones) else {
        return f64::NEG_INFINITY;
    };
    let Some(f1) = per_label(right_ones, left_ones, p - right_ones) else {
        return f64::NEG_INFINITY;
    };
    (0.0 + f0 + f1) / 2.0
}

/// The profile of one ClaSP over a series of `len` samples with window `w`: one score per
/// split point `0..len - w + 1`, −∞ outside `[min_seg, len - min_seg + 1)` (claspy's range).
pub(crate) fn profile(
    offsets: &[u32],
    k: usize,
    len: usize,
    w: usize,
    min_seg: usize,
    score: Score,
) -> Vec<f64> {
    let n = len + 1 - w;
    let mut out = vec![f64::NEG_INFINITY; n];
    let (start, end) = (min_seg, (len + 1).saturating_sub(min_seg).min(n));
    if start >= end || start < w {
        return out;
    }
    let thr = majority_thresholds(offsets, k);
    // ge[v]: windows with threshold >= v; left_eq[v]: windows i < v with threshold == v;
    // zone_eq[v]: windows i in (v - w, v) with threshold == v.
    let mut count = vec![0usize; n + 1];
    let mut left_eq = vec![0usize; n + 1];
    let mut zone_eq = vec![0usize; n + 1];
    for (i, &t) in thr.iter().enumerate() {
        count[t] += 1;
        if t > i {
            left_eq[t] += 1;
            if i + w > t {
                zone_eq[t] += 1;
            }
        }
    }
    let mut ge = vec![0usize; n + 2];
    for v in (0..=n).rev() {
        ge[v] = ge[v + 1] + count[v];
    }
    let s0 = start;
    // left(s): windows i < s predicted right; zone(s): those among the w before s.
    let mut left = (0..s0).filter(|&i| thr[i] >= s0).count();
    let mut zone = (s0 - w..s0).filter(|&i| thr[i] >= s0).count();
    for s in s0..end {
        if s > s0 {
            let prev = s - 1;
            // Window prev joins the left side; windows whose threshold was prev stop being
            // predicted right; window prev - w leaves the zone.
            left = left + usize::from(thr[prev] >= s) - left_eq[prev];
            zone = zone + usize::from(thr[prev] >= s)
                - zone_eq[prev]
                - usize::from(thr[prev - w] >= prev);
        }
        let base = ge[s];
        let right_ones = base - left;
        // The zone's windows are predicted right whatever their neighbours say.
        let ones = base - zone + w;
        let p = n - s;
        out[s] = match score {
            Score::RocAuc => roc_auc(n, p, ones, right_ones),
            Score::F1 => f1(s, p, ones, right_ones),
        };
    }
    out
}

/// claspy's `significance_test`: the predictions at split `split` (relative to the
/// constraint), a rank-sum test between the predictions before and after `cut` (claspy slices
/// at the change point's position in the whole series), accepted when p ≤ `threshold`.
pub(crate) fn significant(
    offsets: &[u32],
    k: usize,
    w: usize,
    split: usize,
    cut: usize,
    threshold: f64,
) -> bool {
    let thr = majority_thresholds(offsets, k);
    let n = thr.len();
    let mut pred: Vec<bool> = thr.iter().map(|&t| t >= split).collect();
    for p in &mut pred[split.saturating_sub(w).min(n)..split.min(n)] {
        *p = true;
    }
    let cut = cut.min(n);
    let (n1, n2) = (cut, n - cut);
    let ones_total = pred.iter().filter(|&&p| p).count();
    let zeros_total = n - ones_total;
    let ones_x = pred[..cut].iter().filter(|&&p| p).count();
    let zeros_x = cut - ones_x;
    // Average ranks of the two tied groups (exact half-integers, as NumPy's sums of them).
    let zero_mean = if zeros_total > 0 { (zeros_total as f64 - 1.0) / 2.0 + 1.0 } else { 0.0 };
    let one_mean = if ones_total > 0 { (zeros_total + n - 1) as f64 / 2.0 + 1.0 } else { 0.0 };
    let rank_sum = zeros_x as f64 * zero_mean + ones_x as f64 * one_mean;
    let expected = (n1 * (n1 + n2 + 1)) as f64 / 2.0;
    let z = (rank_sum - expected) / ((n1 * n2 * (n1 + n2 + 1)) as f64 / 12.0).sqrt();
    // scipy's norm.sf(|z|) = ndtr(-|z|) = erfc(|z|/√2)/2 for |z| ≥ 1.
    let x = z.abs() * std::f64::consts::FRAC_1_SQRT_2;
    let p = if x < std::f64::consts::FRAC_1_SQRT_2 {
        2.0 * (0.5 + 0.5 * libm::erf(-x))
    } else {
        2.0 * (0.5 * libm::erfc(x))
    };
    p <= threshold
}

#[cfg(test)]
mod tests {
    use super::*;

    /// claspy's cross_val_labels and scores written out per split.
    fn naive(
        offsets: &[u32],
        k: usize,
        len: usize,
        w: usize,
        min_seg: usize,
        score: Score,
    ) -> Vec<f64> {
        let n = len + 1 - w;
        let mut out = vec![f64::NEG_INFINITY; n];
        for s in min_seg..(len + 1 - min_seg).min(n) {
            let y_true: Vec<usize> = (0..n).map(|i| usize::from(i >= s)).collect();
            let mut y_pred: Vec<usize> = offsets
                .chunks_exact(k)
                .map(|o| {
                    let ones: usize = o.iter().map(|&j| y_true[j as usize]).sum();
                    usize::from(ones > k - ones)
                })
                .collect();
            for p in &mut y_pred[s - w..s] {
                *p = 1;
            }
            let ones = y_pred.iter().sum::<usize>();
            let right_ones = y_pred[s..].iter().sum::<usize>();
            out[s] = match score {
                Score::RocAuc => roc_auc(n, n - s, ones, right_ones),
                Score::F1 => f1(s, n - s, ones, right_ones),
            };
        }
        out
    }

    #[test]
    fn running_counts_equal_the_per_split_labels() {
        let (len, w, k) = (200, 5, 3);
        let n = len + 1 - w;
        // Neighbours mostly on the same side of 90, some noise.
        let offsets: Vec<u32> = (0..n * k)
            .map(|x| {
                let (i, j) = (x / k, x % k);
                let h = (i * 7919 + j * 104_729) % 97;
                let side = if (i < 90) ^ (h < 15) { h % 90 } else { 90 + h % (n - 90) };
                side as u32
            })
            .collect();
        for score in [Score::RocAuc, Score::F1] {
            {
                let k_used = 3;
                assert_eq!(
                    profile(&offsets, k_used, len, w, 25, score),
                    naive(&offsets, k_used, len, w, 25, score)
                );
            }
        }
    }

    #[test]
    fn roc_auc_of_a_perfect_split_is_one() {
        // 10 windows, split at 4, predictions exactly the labels.
        assert_eq!(roc_auc(10, 6, 6, 6), 1.0);
        assert_eq!(roc_auc(10, 6, 10, 6), f64::NEG_INFINITY, "one predicted class");
    }
}
