//! Small signal helpers shared by segmenters: strict local extrema as the papers define them,
//! and percentiles that ignore NaN.

/// `x[i-1] > x[i] < x[i+1]` (strict, as in Sonoda et al.); false at the ends and where any of
/// the three is NaN.
pub fn is_local_min(x: &[f64], i: usize) -> bool {
    i > 0 && i + 1 < x.len() && x[i - 1] > x[i] && x[i] < x[i + 1]
}

/// `x[i-1] < x[i] > x[i+1]`; false at the ends and where any of the three is NaN.
pub fn is_local_max(x: &[f64], i: usize) -> bool {
    i > 0 && i + 1 < x.len() && x[i - 1] < x[i] && x[i] > x[i + 1]
}

/// The `p`-th percentile (0–100, linear interpolation between order statistics) of the finite
/// values; None when there are none.
pub fn percentile(x: &[f64], p: f64) -> Option<f64> {
    // Selection on integer keys that sort exactly as `f64::total_cmp` orders the values (same
    // order statistics, cheaper comparisons).
    let mut v: Vec<u64> = x.iter().filter(|v| v.is_finite()).map(|&v| total_order_key(v)).collect();
    if v.is_empty() {
        return None;
    }
    let rank = (p.clamp(0.0, 100.0) / 100.0) * (v.len() - 1) as f64;
    let (lo, hi) = (rank.floor() as usize, rank.ceil() as usize);
    // The two order statistics by selection, O(n) (a sort was most of a segmenter's cost): the
    // lo-th, then the smallest of those above it.
    let (_, &mut at_lo, above) = v.select_nth_unstable(lo);
    let at_hi = if hi == lo { at_lo } else { *above.iter().min()? };
    let (at_lo, at_hi) = (from_total_order_key(at_lo), from_total_order_key(at_hi));
    Some(at_lo + (at_hi - at_lo) * (rank - lo as f64))
}

/// An unsigned key whose order is `f64::total_cmp`'s: negative values have all bits flipped,
/// the others only the sign bit.
fn total_order_key(v: f64) -> u64 {
    let bits = v.to_bits();
    if bits >> 63 == 1 { !bits } else { bits | 1 << 63 }
}

/// The inverse of [`total_order_key`].
fn from_total_order_key(key: u64) -> f64 {
    f64::from_bits(if key >> 63 == 1 { key & !(1 << 63) } else { !key })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strict_extrema_ignore_plateaus_ends_and_nan() {
        let x = [3.0, 1.0, 2.0, 2.0, 5.0, f64::NAN, 1.0, 4.0];
        let mins: Vec<usize> = (0..x.len()).filter(|&i| is_local_min(&x, i)).collect();
        let maxs: Vec<usize> = (0..x.len()).filter(|&i| is_local_max(&x, i)).collect();
        assert_eq!(mins, vec![1]);
        assert!(maxs.is_empty());
    }

    #[test]
    fn percentile_interpolates_and_skips_nan() {
        let x = [4.0, f64::NAN, 1.0, 3.0, 2.0];
        assert_eq!(percentile(&x, 0.0), Some(1.0));
        assert_eq!(percentile(&x, 50.0), Some(2.5));
        assert_eq!(percentile(&x, 100.0), Some(4.0));
        assert_eq!(percentile(&[f64::NAN], 50.0), None);
    }

    #[test]
    fn percentile_by_selection_equals_interpolating_the_sorted_values() {
        // Deterministic scrambled values with many duplicates.
        let x: Vec<f64> = (0..1001).map(|i| ((i * 7919) % 613) as f64 * 0.37 - 50.0).collect();
        let mut sorted = x.clone();
        sorted.sort_by(f64::total_cmp);
        for p in [0.0, 1.0, 12.5, 50.0, 89.9, 90.0, 99.99, 100.0] {
            let rank = p / 100.0 * (sorted.len() - 1) as f64;
            let (lo, hi) = (rank.floor() as usize, rank.ceil() as usize);
            let want = sorted[lo] + (sorted[hi] - sorted[lo]) * (rank - lo as f64);
            assert_eq!(percentile(&x, p), Some(want), "p = {p}");
        }
    }

    #[test]
    fn total_order_keys_sort_as_total_cmp_and_round_trip() {
        let v = [
            f64::NEG_INFINITY,
            -1e300,
            -1.5,
            -5e-324,
            -0.0,
            0.0,
            5e-324,
            1e-310,
            2.0,
            1e300,
            f64::INFINITY,
        ];
        for w in v.windows(2) {
            assert_eq!(w[0].total_cmp(&w[1]), std::cmp::Ordering::Less);
            assert!(total_order_key(w[0]) < total_order_key(w[1]), "{} {}", w[0], w[1]);
        }
        for x in v {
            assert_eq!(from_total_order_key(total_order_key(x)).to_bits(), x.to_bits());
        }
    }
}
