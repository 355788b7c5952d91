//! ruptures' median heuristic for the rbf bandwidth, without its O(n²) distance matrix.
//!
//! ruptures (`CostRbf.gram`) sets `γ = 1 / median(pdist(x, "sqeuclidean"))` (γ = 1 when that
//! median is 0), which stores all n(n−1)/2 squared distances. Here the same median — the same
//! float, since every distance is computed as scipy does (differences squared and summed over
//! channels in order) — is found in O(n) memory:
//! - one channel: the samples sorted, the k-th smallest distance found by bisection on the
//!   float's bits, counting pairs under a threshold with two pointers (O(n log n) time);
//! - several channels: radix selection on the distances' bit patterns (non-negative floats
//!   order as their bits do), 16 bits a pass over all pairs, until the rank's bucket is small
//!   enough to collect (usually three passes, O(n²) time each, O(1) memory beyond a histogram).

use super::cost::squared_distance;
use crate::signal::Signal;

/// `γ` as ruptures' median heuristic sets it.
pub(crate) fn median_heuristic_gamma(signal: &Signal) -> f64 {
    let n = signal.n_samples as u64;
    let pairs = n * n.saturating_sub(1) / 2;
    if pairs == 0 {
        return 1.0;
    }
    let median = if signal.n_channels == 1 {
        let mut x = signal.channel(0);
        x.sort_by(f64::total_cmp);
        if pairs % 2 == 1 {
            kth_distance_1d(&x, pairs / 2)
        } else {
            (kth_distance_1d(&x, pairs / 2 - 1) + kth_distance_1d(&x, pairs / 2)) / 2.0
        }
    } else {
        let k = if pairs % 2 == 1 { pairs / 2 } else { pairs / 2 - 1 };
        let (lo, hi) = kth_pair_multichannel(signal, k, COLLECT_AT_MOST);
        if pairs % 2 == 1 { lo } else { (lo + hi) / 2.0 }
    };
    if median != 0.0 { 1.0 / median } else { 1.0 }
}

/// Pairs `i < j` of the sorted samples with `(x_j − x_i)² ≤ threshold`. For a fixed `x_i` the
/// rounded difference grows with `x_j` (rounding is monotone), so two pointers count them.
fn count_at_most(sorted: &[f64], threshold: f64) -> u64 {
    let mut count = 0u64;
    let mut i = 0usize;
    for j in 0..sorted.len() {
        while i < j && (sorted[j] - sorted[i]) * (sorted[j] - sorted[i]) > threshold {
            i += 1;
        }
        count += (j - i) as u64;
    }
    count
}

/// The k-th smallest (0-based) of the pairwise squared distances of sorted 1-D samples.
fn kth_distance_1d(sorted: &[f64], k: u64) -> f64 {
    let span = sorted[sorted.len() - 1] - sorted[0];
    // Non-negative floats order as their bit patterns: bisect on the bits.
    let (mut lo, mut hi) = (0u64, (span * span).to_bits());
    while lo < hi {
        let mid = lo + (hi - lo) / 2;
        if count_at_most(sorted, f64::from_bits(mid)) > k {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    f64::from_bits(lo)
}

/// Every pairwise squared distance's bit pattern, pairs `i < j`.
fn for_each_distance(signal: &Signal, mut f: impl FnMut(u64)) {
    for j in 1..signal.n_samples {
        let xj = signal.row(j);
        for i in 0..j {
            f(squared_distance(signal.row(i), xj).to_bits());
        }
    }
}

/// Radix selection collects the values left in the rank's bucket once they are this few
/// (32 MiB of bit patterns).
const COLLECT_AT_MOST: u64 = 1 << 22;

/// The k-th and (k+1)-th smallest (0-based) pairwise squared distances of a multichannel
/// signal, by radix selection on the bits (the (k+1)-th is NaN when there is none).
fn kth_pair_multichannel(signal: &Signal, k: u64, collect_at_most: u64) -> (f64, f64) {
    const BITS: u32 = 16;
    let mut prefix = 0u64; // the fixed leading bits of the k-th value
    let mut fixed = 0u32; // how many leading bits are fixed
    let mut rank = k; // the k-th value's rank among values sharing the prefix
    let mut upper: Option<f64> = None; // the (k+1)-th once it is known to lie outside the prefix
    let matches = |bits: u64, prefix: u64, fixed: u32| {
        fixed == 0 || bits >> (64 - fixed) == prefix >> (64 - fixed)
    };
    loop {
        // Count the values sharing the prefix; collect them when few.
        let mut in_prefix = 0u64;
        for_each_distance(signal, |b| in_prefix += matches(b, prefix, fixed) as u64);
        if in_prefix <= collect_at_most || fixed >= 64 - BITS {
            let mut values = Vec::with_capacity(in_prefix as usize);
            for_each_distance(signal, |b| {
                if matches(b, prefix, fixed) {
                    values.push(b)
                }
            });
            values.sort_unstable();
            let lo = f64::from_bits(values[rank as usize]);
            let hi = upper.unwrap_or_else(|| {
                values.get(rank as usize + 1).map_or(f64::NAN, |&b| f64::from_bits(b))
            });
            return (lo, hi);
        }
        let shift = 64 - fixed - BITS;
        let mut counts = vec![0u64; 1 << BITS];
        let mut mins = vec![u64::MAX; 1 << BITS];
        for_each_distance(signal, |b| {
            if matches(b, prefix, fixed) {
                let bucket = ((b >> shift) & ((1 << BITS) - 1)) as usize;
                counts[bucket] += 1;
                mins[bucket] = mins[bucket].min(b);
            }
        });
        let mut bucket = 0usize;
        while rank >= counts[bucket] {
            rank -= counts[bucket];
            bucket += 1;
        }
        if upper.is_none() && rank + 1 == counts[bucket] {
            // The (k+1)-th is the smallest value of the next non-empty bucket (if any).
            upper = Some(
                counts[bucket + 1..]
                    .iter()
                    .position(|&c| c > 0)
                    .map_or(f64::NAN, |off| f64::from_bits(mins[bucket + 1 + off])),
            );
        }
        prefix |= (bucket as u64) << shift;
        fixed += BITS;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::signal::{Missing, Signal};

    fn brute_median(x: &[f64], d: usize) -> f64 {
        let n = x.len() / d;
        let mut all = Vec::new();
        for i in 0..n {
            for j in i + 1..n {
                all.push(squared_distance(&x[i * d..(i + 1) * d], &x[j * d..(j + 1) * d]));
            }
        }
        all.sort_by(f64::total_cmp);
        let m = all.len();
        if m % 2 == 1 { all[m / 2] } else { (all[m / 2 - 1] + all[m / 2]) / 2.0 }
    }

    #[test]
    fn equals_the_median_of_every_distance() {
        let mut rng = fastrand::Rng::with_seed(11);
        for (n, d) in [(2, 1), (3, 1), (50, 1), (51, 1), (40, 2), (41, 3), (7, 2)] {
            // Repeated values too (ties among distances).
            let x: Vec<f64> = (0..n * d).map(|_| (rng.f64() * 8.0).round() / 4.0 - 1.0).collect();
            let sig = Signal::new(&x, d, "t", Missing::Refuse).unwrap();
            let want = brute_median(&x, d);
            let want = if want != 0.0 { 1.0 / want } else { 1.0 };
            assert_eq!(median_heuristic_gamma(&sig), want, "n {n} d {d}");
        }
    }

    #[test]
    fn radix_selection_walks_buckets_and_finds_the_next_value() {
        // A collect limit the data exceed forces the histogram passes; compare with brute force
        // at several ranks, including the last (no next value).
        let mut rng = fastrand::Rng::with_seed(5);
        let x: Vec<f64> = (0..2 * 120).map(|_| rng.f64() * 100.0).collect();
        let sig = Signal::new(&x, 2, "t", Missing::Refuse).unwrap();
        let mut all = Vec::new();
        for i in 0..120 {
            for j in i + 1..120 {
                all.push(squared_distance(sig.row(i), sig.row(j)));
            }
        }
        all.sort_by(f64::total_cmp);
        for k in [0u64, 1, 100, 3569, 7138] {
            let (lo, hi) = kth_pair_multichannel(&sig, k, 3);
            assert_eq!(lo, all[k as usize]);
            assert_eq!(hi.to_bits(), all.get(k as usize + 1).map_or(f64::NAN, |v| *v).to_bits());
        }
    }

    #[test]
    fn constant_signal_gives_gamma_one() {
        let sig = Signal::new(&[2.0; 10], 1, "t", Missing::Refuse).unwrap();
        assert_eq!(median_heuristic_gamma(&sig), 1.0);
    }
}
