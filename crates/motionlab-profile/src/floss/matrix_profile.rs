//! The matrix profile of a self-join (stumpy's `stump`, k = 1): for every window its nearest
//! other window in z-normalised Euclidean distance, windows within ⌈m/4⌉ of it excluded,
//! computed along the diagonals with stumpy's Pearson-correlation recurrence.

use rayon::prelude::*;

use motionlab_core::{Error, ErrorKind, Result};

/// Nearest-neighbour index and distance of every window.
#[derive(Clone, Debug, PartialEq)]
pub struct MatrixProfile {
    /// `index[i]`: start of the window nearest to window i.
    pub index: Vec<i64>,
    /// `distance[i]`: its z-normalised Euclidean distance.
    pub distance: Vec<f64>,
}

/// Means of every window of `w` samples (pairwise sums, as NumPy's row means).
fn window_means(t: &[f64], w: usize) -> Vec<f64> {
    t.windows(w).map(crate::numpy::mean).collect()
}

/// Whether window `j` (correlation `rho`) beats the current best `(best, at)` of row `r`: a
/// higher correlation, or on a tie the nearer diagonal and then the earlier window — the
/// order in which stumpy's diagonal traversal meets the candidates.
#[inline]
fn better(r: usize, rho: f64, j: usize, best: f64, at: i64) -> bool {
    if rho > best {
        return true;
    }
    if rho < best || at < 0 || rho.is_nan() {
        return false;
    }
    let (gj, ga) = (r.abs_diff(j), r.abs_diff(at as usize));
    gj < ga || (gj == ga && j < at as usize)
}

/// stumpy's `stump(T, m)[:, :2]` for a finite series `t`.
pub(crate) fn self_join(t: &[f64], m: usize) -> Result<MatrixProfile> {
    let n = t.len();
    if m < 3 || m > n {
        return Err(Error::new(
            ErrorKind::OutOfRange,
            format!("window is {m} samples for a series of {n}; expected 3 ≤ window ≤ n"),
        )
        .with_field("window"));
    }
    let l = n - m + 1;
    let excl = m.div_ceil(4);
    if l <= excl + 1 {
        return Err(Error::new(
            ErrorKind::EmptySequence,
            format!("{n} samples leave no window outside the exclusion zone of window {m} (needs more than {} windows)", excl + 1),
        )
        .with_field("values"));
    }
    let means = window_means(t, m);
    let isconstant: Vec<bool> = t.windows(m).map(|s| s.iter().all(|&v| v == s[0])).collect();
    let inv_std: Vec<f64> = t
        .windows(m)
        .zip(&means)
        .zip(&isconstant)
        .map(|((s, &mu), &c)| {
            if c {
                return 1.0;
            }
            let sq: Vec<f64> = s.iter().map(|&v| (v - mu) * (v - mu)).collect();
            1.0 / (crate::numpy::pairwise_sum(&sq) / m as f64).sqrt()
        })
        .collect();
    let means_m1 = window_means(t, m - 1);
    let cov_a: Vec<f64> = (0..l).map(|j| t[j + m - 1] - means_m1[j]).collect();
    let cov_c: Vec<f64> =
        (0..l).map(|j| if j == 0 { t[n - 1] } else { t[j - 1] } - means_m1[j]).collect();
    let m_inv = 1.0 / m as f64;
    let constant = (m - 1) as f64 * m_inv * m_inv;

    // Diagonals excl+1..l in contiguous ranges of about equal work, one best-so-far per range.
    let diags: Vec<usize> = (excl + 1..l).collect();
    let work: usize = diags.iter().map(|g| l - g).sum();
    let parts = (rayon::current_num_threads() * 4).max(1);
    let mut ranges = Vec::new();
    let (mut start, mut acc) = (0, 0);
    for (i, g) in diags.iter().enumerate() {
        acc += l - g;
        if acc * parts >= work * (ranges.len() + 1) || i + 1 == diags.len() {
            ranges.push((start, i + 1));
            start = i + 1;
        }
    }
    let partial: Vec<(Vec<f64>, Vec<i64>)> = ranges
        .par_iter()
        .map(|&(d0, d1)| {
            let mut rho = vec![f64::NEG_INFINITY; l];
            let mut idx = vec![-1i64; l];
            for &g in &diags[d0..d1] {
                let mut cov = 0.0;
                for i in 0..l - g {
                    let j = i + g;
                    if i == 0 {
                        let mut acc = 0.0;
                        for s in 0..m {
                            acc += (t[j + s] - means[j]) * (t[i + s] - means[i]);
                        }
                        cov = acc * m_inv;
                    } else {
                        cov += constant * (cov_a[j] * cov_a[i] - cov_c[j] * cov_c[i]);
                    }
                    let pearson = match (isconstant[i], isconstant[j]) {
                        (true, true) => 1.0,
                        (true, false) | (false, true) => 0.5,
                        _ => (cov * inv_std[j] * inv_std[i]).min(1.0),
                    };
                    if better(i, pearson, j, rho[i], idx[i]) {
                        rho[i] = pearson;
                        idx[i] = j as i64;
                    }
                    if better(j, pearson, i, rho[j], idx[j]) {
                        rho[j] = pearson;
                        idx[j] = i as i64;
                    }
                }
            }
            (rho, idx)
        })
        .collect();
    let mut rho = vec![f64::NEG_INFINITY; l];
    let mut index = vec![-1i64; l];
    for (prho, pidx) in &partial {
        for r in 0..l {
            if pidx[r] >= 0 && better(r, prho[r], pidx[r] as usize, rho[r], index[r]) {
                rho[r] = prho[r];
                index[r] = pidx[r];
            }
        }
    }
    let distance = rho
        .iter()
        .map(|&p| {
            let d = (2.0 * m as f64 * (1.0 - p)).abs();
            if d < 1e-14 { 0.0 } else { d.sqrt() }
        })
        .collect();
    Ok(MatrixProfile { index, distance })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equals_a_brute_force_nearest_neighbour_search() {
        let t: Vec<f64> =
            (0..240).map(|i| ((i * i * 31) % 23) as f64 + (i as f64 * 0.2).cos() * 3.0).collect();
        let m = 12;
        let mp = self_join(&t, m).unwrap();
        let z = |i: usize| -> Vec<f64> {
            let s = &t[i..i + m];
            let mu = s.iter().sum::<f64>() / m as f64;
            let sd = (s.iter().map(|v| (v - mu).powi(2)).sum::<f64>() / m as f64).sqrt();
            s.iter().map(|v| (v - mu) / sd).collect()
        };
        let l = t.len() - m + 1;
        for r in 0..l {
            let zr = z(r);
            let (mut best, mut at) = (f64::INFINITY, 0);
            for j in 0..l {
                if r.abs_diff(j) <= m.div_ceil(4) {
                    continue;
                }
                let d = z(j).iter().zip(&zr).map(|(a, b)| (a - b).powi(2)).sum::<f64>().sqrt();
                if d < best - 1e-9 {
                    best = d;
                    at = j;
                }
            }
            assert_eq!(mp.index[r], at as i64, "row {r}");
            assert!((mp.distance[r] - best).abs() < 1e-6, "row {r}: {} vs {best}", mp.distance[r]);
        }
    }

    #[test]
    fn constant_windows_match_each_other() {
        let mut t = vec![1.0; 60];
        for (i, v) in t.iter_mut().enumerate().skip(30) {
            *v = (i as f64).sin();
        }
        let mp = self_join(&t, 8).unwrap();
        // Windows 0..=22 are flat: their nearest is the nearest flat window outside the zone.
        assert_eq!(mp.index[0], 3);
        assert_eq!(mp.distance[0], 0.0);
    }
}
