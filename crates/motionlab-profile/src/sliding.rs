//! Sliding-window machinery shared by the segmenters: window statistics and dot products of
//! every window with a fixed one, the starting rows of the STOMP recurrences.

/// claspy's `sliding_mean_std`: means and standard deviations of every window of `w` samples
/// from running sums (cumulative sum and sum of squares, as claspy), the variance clipped at 0
/// and a standard deviation under 1e-3 replaced by 1 — claspy's treatment of flat windows: a
/// flat window z-normalises to its deviations from the mean instead of dividing by ~0. Note
/// that 1e-3 is absolute, in the series' own unit.
pub(crate) fn claspy_mean_std(t: &[f64], w: usize) -> (Vec<f64>, Vec<f64>) {
    let n = t.len();
    let mut s = Vec::with_capacity(n + 1);
    let mut sq = Vec::with_capacity(n + 1);
    s.push(0.0);
    sq.push(0.0);
    let (mut acc, mut acc_sq) = (0.0f64, 0.0f64);
    for &v in t {
        acc += v;
        acc_sq += v * v;
        s.push(acc);
        sq.push(acc_sq);
    }
    let wf = w as f64;
    let l = n + 1 - w;
    let mut means = Vec::with_capacity(l);
    let mut stds = Vec::with_capacity(l);
    for i in 0..l {
        let seg_sum = s[i + w] - s[i];
        let seg_sum_sq = sq[i + w] - sq[i];
        let mean = seg_sum / wf;
        let var = seg_sum_sq / wf - (seg_sum / wf) * (seg_sum / wf);
        let sd = var.max(0.0).sqrt();
        means.push(mean);
        stds.push(if sd.abs() < 1e-3 { 1.0 } else { sd });
    }
    (means, stds)
}

/// Dot products of the window at `q` with every window: `out[j] = Σ_t t[q + t]·t[j + t]`,
/// summed directly (the exact start of a row of the diagonal recurrence).
pub(crate) fn window_dots(t: &[f64], w: usize, q: usize, out: &mut [f64]) {
    let query = &t[q..q + w];
    for (j, o) in out.iter_mut().enumerate() {
        let mut acc = 0.0;
        for (a, b) in query.iter().zip(&t[j..j + w]) {
            acc += a * b;
        }
        *o = acc;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flat_windows_get_unit_deviation() {
        let t = [1.0, 1.0, 1.0, 2.0, 4.0];
        let (m, s) = claspy_mean_std(&t, 3);
        assert_eq!(m, vec![1.0, 4.0 / 3.0, 7.0 / 3.0]);
        assert_eq!(s[0], 1.0, "a flat window's deviation is replaced by 1");
        assert!((s[2] - (14.0f64 / 9.0).sqrt()).abs() < 1e-12);
    }

    #[test]
    fn window_dots_are_plain_dot_products() {
        let t = [1.0, 2.0, 3.0, 4.0];
        let mut out = [0.0; 3];
        window_dots(&t, 2, 1, &mut out);
        assert_eq!(out, [2.0 + 6.0, 4.0 + 9.0, 6.0 + 12.0]);
    }
}
