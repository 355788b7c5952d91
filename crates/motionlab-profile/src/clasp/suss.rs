//! SuSS, the summary-statistics subsequence window width (claspy's `suss`), with pandas'
//! compensated rolling mean and variance so the search takes the same steps as claspy.

use crate::numpy;

/// pandas' `rolling(w).mean()` and `.std(ddof=0)` for the full windows ending at index
/// `w - 1..n` (Kahan-compensated running sums, Welford variance, pandas' special cases).
fn rolling_mean_std(t: &[f64], w: usize) -> (Vec<f64>, Vec<f64>) {
    let n = t.len();
    let (mut means, mut stds) = (Vec::with_capacity(n), Vec::with_capacity(n));
    // Rolling mean state.
    let (mut sum, mut comp_add, mut comp_rem) = (0.0f64, 0.0f64, 0.0f64);
    let (mut nobs, mut neg_ct) = (0i64, 0i64);
    let (mut same, mut prev_value) = (0i64, 0.0f64);
    // Rolling variance state.
    let (mut vmean, mut ssqdm, mut vnobs, mut vcomp_add, mut vcomp_rem) = (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0.0f64);
    let (mut vsame, mut vprev) = (0i64, 0.0f64);
    let add_mean = |v: f64, nobs: &mut i64, sum: &mut f64, neg: &mut i64, comp: &mut f64, same: &mut i64, prev: &mut f64| {
        *nobs += 1;
        let y = v - *comp;
        let t = *sum + y;
        *comp = t - *sum - y;
        *sum = t;
        if v.is_sign_negative() {
            *neg += 1;
        }
        if v == *prev {
            *same += 1;
        } else {
            *same = 1;
        }
        *prev = v;
    };
    let add_var = |v: f64, nobs: &mut f64, mean: &mut f64, ssq: &mut f64, comp: &mut f64, same: &mut i64, prev: &mut f64| {
        *nobs += 1.0;
        if v == *prev {
            *same += 1;
        } else {
            *same = 1;
        }
        *prev = v;
        let prev_mean = *mean - *comp;
        let y = v - *comp;
        let t = y - *mean;
        *comp = t + *mean - y;
        *mean = if *nobs != 0.0 { *mean + t / *nobs } else { 0.0 };
        *ssq += (v - prev_mean) * (v - *mean);
    };
    for i in 0..n {
        let s = (i + 1).saturating_sub(w);
        let e = i + 1;
        let reset = i == 0 || s >= i;
        if reset {
            sum = 0.0;
            comp_add = 0.0;
            comp_rem = 0.0;
            nobs = 0;
            neg_ct = 0;
            prev_value = t[s];
            same = 0;
            vmean = 0.0;
            ssqdm = 0.0;
            vnobs = 0.0;
            vcomp_add = 0.0;
            vcomp_rem = 0.0;
            vprev = t[s];
            vsame = 0;
            for &v in &t[s..e] {
                add_mean(v, &mut nobs, &mut sum, &mut neg_ct, &mut comp_add, &mut same, &mut prev_value);
                add_var(v, &mut vnobs, &mut vmean, &mut ssqdm, &mut vcomp_add, &mut vsame, &mut vprev);
            }
        } else {
            let prev_s = i.saturating_sub(w);
            for &v in &t[prev_s..s] {
                nobs -= 1;
                let y = -v - comp_rem;
                let tt = sum + y;
                comp_rem = tt - sum - y;
                sum = tt;
                if v.is_sign_negative() {
                    neg_ct -= 1;
                }
                vnobs -= 1.0;
                if vnobs != 0.0 {
                    let prev_mean = vmean - vcomp_rem;
                    let y = v - vcomp_rem;
                    let tt = y - vmean;
                    vcomp_rem = tt + vmean - y;
                    vmean -= tt / vnobs;
                    ssqdm -= (v - prev_mean) * (v - vmean);
                } else {
                    vmean = 0.0;
                    ssqdm = 0.0;
                }
            }
            let v = t[i];
            add_mean(v, &mut nobs, &mut sum, &mut neg_ct, &mut comp_add, &mut same, &mut prev_value);
            add_var(v, &mut vnobs, &mut vmean, &mut ssqdm, &mut vcomp_add, &mut vsame, &mut vprev);
        }
        if e < w {
            continue;
        }
        let mut mean = sum / nobs as f64;
        if same >= nobs {
            mean = prev_value;
        } else if (neg_ct == 0 && mean < 0.0) || (neg_ct == nobs && mean > 0.0) {
            // pandas: a mean of one-signed values cannot change sign.
            mean = 0.0;
        }
        let var = if vnobs == 1.0 || vsame as f64 >= vnobs { 0.0 } else { ssqdm / vnobs };
        means.push(mean);
        stds.push(if var < 0.0 { 0.0 } else { var.sqrt() });
    }
    (means, stds)
}

/// Sliding minimum and maximum of every full window (exact, order-free).
fn rolling_min_max(t: &[f64], w: usize) -> (Vec<f64>, Vec<f64>) {
    let mut mins = std::collections::VecDeque::new();
    let mut maxs = std::collections::VecDeque::new();
    let (mut lo, mut hi) = (Vec::new(), Vec::new());
    for i in 0..t.len() {
        while mins.back().is_some_and(|&b: &usize| t[i] <= t[b]) {
            mins.pop_back();
        }
        mins.push_back(i);
        while maxs.back().is_some_and(|&b: &usize| t[i] >= t[b]) {
            maxs.pop_back();
        }
        maxs.push_back(i);
        if i + 1 >= w {
            while mins.front().is_some_and(|&f| f + w <= i) {
                mins.pop_front();
            }
            while maxs.front().is_some_and(|&f| f + w <= i) {
                maxs.pop_front();
            }
            lo.push(t[mins[0]]);
            hi.push(t[maxs[0]]);
        }
    }
    (lo, hi)
}

/// claspy's `_suss_score`: the mean distance between the windows' summary statistics and the
/// whole series', per √w. Windows start after the first full one, as claspy slices `[w:]`.
fn suss_score(t: &[f64], w: usize, stats: (f64, f64, f64)) -> f64 {
    let (means, stds) = rolling_mean_std(t, w);
    let (mins, maxs) = rolling_min_max(t, w);
    let sqrt_w = (w as f64).sqrt();
    let x: Vec<f64> = (1..means.len())
        .map(|i| {
            let a = means[i] - stats.0;
            let b = stds[i] - stats.1;
            let c = (maxs[i] - mins[i]) - stats.2;
            ((a * a + b * b) + c * c).sqrt() / sqrt_w
        })
        .collect();
    if x.is_empty() { f64::NAN } else { numpy::mean(&x) }
}

/// claspy's `suss(time_series, lbound=10, threshold=0.89)`. Where claspy's exponential search
/// would pass the series length (it never terminates there), the search stops there.
pub(crate) fn suss(t: &[f64]) -> usize {
    const LBOUND: usize = 10;
    const THRESHOLD: f64 = 0.89;
    let n = t.len();
    if n < LBOUND {
        return n;
    }
    let (lo, hi) = t.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    if lo == hi {
        return LBOUND;
    }
    let scaled: Vec<f64> = t.iter().map(|&v| (v - lo) / (hi - lo)).collect();
    let (smin, smax) = scaled.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    let stats = (numpy::mean(&scaled), numpy::std(&scaled), smax - smin);
    let max_score = suss_score(&scaled, 1, stats);
    let min_score = suss_score(&scaled, n - 1, stats);
    if min_score == max_score {
        return LBOUND;
    }
    let score = |w: usize| 1.0 - (suss_score(&scaled, w, stats) - min_score) / (max_score - min_score);
    let mut exp = 0u32;
    loop {
        let w = 1usize << exp;
        if w < LBOUND {
            exp += 1;
            continue;
        }
        if w >= n || score(w) > THRESHOLD {
            break;
        }
        exp += 1;
    }
    let (mut lb, mut ub) = (LBOUND.max(1 << exp.saturating_sub(1)), (1usize << exp) + 1);
    while lb <= ub {
        let w = (lb + ub) / 2;
        let s = score(w);
        if s < THRESHOLD {
            lb = w + 1;
        } else if s > THRESHOLD {
            ub = w - 1;
        } else {
            break;
        }
    }
    2 * lb
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rolling_statistics_match_a_direct_computation() {
        let t: Vec<f64> = (0..50).map(|i| ((i * 37) % 11) as f64 * 0.1 - 0.3).collect();
        let (m, s) = rolling_mean_std(&t, 7);
        let (lo, hi) = rolling_min_max(&t, 7);
        for (i, win) in t.windows(7).enumerate() {
            let mean = win.iter().sum::<f64>() / 7.0;
            let var = win.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / 7.0;
            assert!((m[i] - mean).abs() < 1e-12 && (s[i] - var.sqrt()).abs() < 1e-12);
            assert_eq!(lo[i], win.iter().cloned().fold(f64::INFINITY, f64::min));
            assert_eq!(hi[i], win.iter().cloned().fold(f64::NEG_INFINITY, f64::max));
        }
    }

    #[test]
    fn constant_and_short_series_get_claspys_fallbacks() {
        assert_eq!(suss(&[3.0; 100]), 10);
        assert_eq!(suss(&[1.0, 2.0, 3.0]), 3);
    }

    #[test]
    fn a_sine_gets_a_window_near_its_period() {
        let t: Vec<f64> = (0..2000).map(|i| (i as f64 * 2.0 * std::f64::consts::PI / 50.0).sin()).collect();
        let w = suss(&t);
        assert!((25..=100).contains(&w), "{w}");
    }
}
