//! SuSS, the summary-statistics subsequence window width (claspy's `suss`), with pandas'
//! compensated rolling mean and variance so the search takes the same steps as claspy.

use crate::numpy;

/// pandas' rolling-mean state (Kahan-compensated sum; separate compensations for adding and
/// removing, as pandas).
#[derive(Default)]
struct MeanState {
    sum: f64,
    comp_add: f64,
    comp_rem: f64,
    nobs: i64,
    neg_ct: i64,
}

/// pandas' rolling-variance state (Welford with Kahan compensation).
#[derive(Default)]
struct VarState {
    mean: f64,
    ssqdm: f64,
    nobs: f64,
    comp_add: f64,
    comp_rem: f64,
}

impl MeanState {
    fn add(&mut self, v: f64) {
        self.nobs += 1;
        let y = v - self.comp_add;
        let t = self.sum + y;
        self.comp_add = t - self.sum - y;
        self.sum = t;
        if v.is_sign_negative() {
            self.neg_ct += 1;
        }
    }
    fn remove(&mut self, v: f64) {
        self.nobs -= 1;
        let y = -v - self.comp_rem;
        let t = self.sum + y;
        self.comp_rem = t - self.sum - y;
        self.sum = t;
        if v.is_sign_negative() {
            self.neg_ct -= 1;
        }
    }
}

impl VarState {
    fn add(&mut self, v: f64) {
        self.nobs += 1.0;
        let prev_mean = self.mean - self.comp_add;
        let y = v - self.comp_add;
        let t = y - self.mean;
        self.comp_add = t + self.mean - y;
        self.mean = if self.nobs != 0.0 { self.mean + t / self.nobs } else { 0.0 };
        self.ssqdm += (v - prev_mean) * (v - self.mean);
    }
    fn remove(&mut self, v: f64) {
        self.nobs -= 1.0;
        if self.nobs != 0.0 {
            let prev_mean = self.mean - self.comp_rem;
            let y = v - self.comp_rem;
            let t = y - self.mean;
            self.comp_rem = t + self.mean - y;
            self.mean -= t / self.nobs;
            self.ssqdm -= (v - prev_mean) * (v - self.mean);
        } else {
            self.mean = 0.0;
            self.ssqdm = 0.0;
        }
    }
}

/// pandas' `rolling(w).mean()` and `.std(ddof=0)` for the full windows ending at index
/// `w - 1..n` (pandas' running states, its repeated-value and sign special cases).
fn rolling_mean_std(t: &[f64], w: usize) -> (Vec<f64>, Vec<f64>) {
    let n = t.len();
    let (mut means, mut stds) = (Vec::with_capacity(n), Vec::with_capacity(n));
    let (mut ms, mut vs) = (MeanState::default(), VarState::default());
    // Consecutive repeats of the last added value (pandas' guard against rounding artefacts
    // on constant stretches), the same for both statistics.
    let (mut same, mut prev_value) = (0i64, 0.0f64);
    for i in 0..n {
        let s = (i + 1).saturating_sub(w);
        let e = i + 1;
        let added = if i == 0 || s >= i {
            ms = MeanState::default();
            vs = VarState::default();
            same = 0;
            prev_value = t[s];
            &t[s..e]
        } else {
            for &v in &t[i.saturating_sub(w)..s] {
                ms.remove(v);
                vs.remove(v);
            }
            &t[i..e]
        };
        for &v in added {
            ms.add(v);
            vs.add(v);
            same = if v == prev_value { same + 1 } else { 1 };
            prev_value = v;
        }
        if e < w {
            continue;
        }
        let mut mean = ms.sum / ms.nobs as f64;
        if same >= ms.nobs {
            mean = prev_value;
        } else if (ms.neg_ct == 0 && mean < 0.0) || (ms.neg_ct == ms.nobs && mean > 0.0) {
            // pandas: a mean of one-signed values cannot change sign.
            mean = 0.0;
        }
        let var = if vs.nobs == 1.0 || same as f64 >= vs.nobs { 0.0 } else { vs.ssqdm / vs.nobs };
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
    let (lo, hi) =
        t.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    if lo == hi {
        return LBOUND;
    }
    let scaled: Vec<f64> = t.iter().map(|&v| (v - lo) / (hi - lo)).collect();
    let (smin, smax) =
        scaled.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    let stats = (numpy::mean(&scaled), numpy::std(&scaled), smax - smin);
    let max_score = suss_score(&scaled, 1, stats);
    let min_score = suss_score(&scaled, n - 1, stats);
    if min_score == max_score {
        return LBOUND;
    }
    let score =
        |w: usize| 1.0 - (suss_score(&scaled, w, stats) - min_score) / (max_score - min_score);
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
        let t: Vec<f64> =
            (0..2000).map(|i| (i as f64 * 2.0 * std::f64::consts::PI / 50.0).sin()).collect();
        let w = suss(&t);
        assert!((25..=100).contains(&w), "{w}");
    }
}
