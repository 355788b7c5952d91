//! PELT as ruptures' `KernelCPD(...).predict(pen=…)` runs it: its C routine
//! `ekcpd_pelt_compute` (`ruptures/detection/_detection/ekcpd_pelt_computation.c`), operation
//! for operation, so the floating-point results are the same bits.
//!
//! - Every sample is a candidate (`jump` = 1). For each end t the running sums
//!   `S[s] = Σ_{i,j∈[s,t)} k(x_i, x_j)` of every start from `s_min` are updated by one kernel
//!   evaluation per start (`c_r += k(x_s, x_{t−1}); S[s] += 2·c_r − k(x_{t−1}, x_{t−1})`,
//!   starts descending), and the cost is `D[t] − D[s] − S[s]/(t − s)` with `D` the running sum
//!   of the kernel's diagonal.
//! - Ends below `2·min_size` hold one segment. From there the candidates are `s_min` and every
//!   `s` in `max(s_min + 1, min_size) ..= t − min_size`; the first strict minimum wins.
//! - Pruning moves only the lowest start: while its unpenalised total is ≥ the best penalised
//!   total, `s_min` advances (from 0 straight to `min_size`).
//!
//! The kernels are ruptures' C kernels: the linear kernel `Σ x·y` (this is cost `l2`) and the
//! Gaussian kernel clipped in single precision (`exp(−0.01)` on its diagonal, where the Python
//! `CostRbf` has 1 — so `KernelCPD` with penalty β solves Pelt(`rbf`)'s problem with penalty
//! β + 1 − exp(−0.01) per segment, up to that single-precision clip).
//!
//! What differs from the C is only what costs time without changing a bit: the kernel is
//! chosen once instead of by string comparisons per evaluation; a kernel row is computed
//! before it is summed, with glibc's `exp` inlined where that is the `exp` the C calls
//! (`glibc_exp.rs`), so it vectorises; the candidates' totals are computed before the first
//! minimum is searched.

use super::cost::rbf_c_kernel;
use super::crops::Solved;
use super::glibc_exp::{self, exp_normal_fma};
use super::pelt::breakpoints_from_path;
use crate::signal::Signal;

/// The kernel of ruptures' C `KernelCPD`.
#[derive(Clone, Copy, Debug)]
pub(crate) enum CKernel {
    /// `k(x, y) = Σ_d x_d·y_d` (ruptures `kernel="linear"`, cost `l2`).
    Linear,
    /// `k(x, y) = exp(−clip_f32(γ‖x − y‖², 0.01, 100))` (ruptures `kernel="rbf"`).
    Gaussian { gamma: f64 },
}

#[inline(always)]
fn kernel(kernel: CKernel, a: &[f64], b: &[f64]) -> f64 {
    match kernel {
        CKernel::Linear => {
            let mut v = 0.0;
            for (x, y) in a.iter().zip(b) {
                v += x * y;
            }
            v
        }
        CKernel::Gaussian { gamma } => {
            let mut sq = 0.0;
            for (x, y) in a.iter().zip(b) {
                sq += (x - y) * (x - y);
            }
            rbf_c_kernel(gamma, sq)
        }
    }
}

/// `row[i] = k(x_{s_low+i}, x_{t−1})` for `s_low + i < t`.
fn kernel_row(
    signal: &Signal,
    k: CKernel,
    t: usize,
    s_low: usize,
    fast_exp: bool,
    row: &mut Vec<f64>,
) {
    row.clear();
    let xt = signal.row(t - 1);
    match k {
        CKernel::Gaussian { gamma } if fast_exp => {
            row.resize(t - s_low, 0.0);
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `fast_exp` is only set when the CPU has FMA and AVX2.
            unsafe {
                gaussian_row_fma(signal, gamma, t, s_low, row)
            }
        }
        _ => row.extend((s_low..t).map(|s| kernel(k, signal.row(s), xt))),
    }
}

/// The Gaussian kernel row with glibc's FMA `exp` inlined (same bits as calling it).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "fma,avx2")]
unsafe fn gaussian_row_fma(signal: &Signal, gamma: f64, t: usize, s_low: usize, row: &mut [f64]) {
    let clip = |sq: f64| {
        let n = (gamma * sq) as f32;
        let upper_clipped = if n > 100.0_f32 { 100.0_f32 } else { n };
        -((if 0.01_f32 > upper_clipped { 0.01_f32 } else { upper_clipped }) as f64)
    };
    if signal.n_channels == 1 {
        let xt = signal.values[t - 1];
        for (out, &xs) in row.iter_mut().zip(&signal.values[s_low..t]) {
            let d = xs - xt;
            *out = exp_normal_fma(clip(d * d));
        }
    } else {
        let xt = signal.row(t - 1);
        for (out, s) in row.iter_mut().zip(s_low..t) {
            let mut sq = 0.0;
            for (x, y) in signal.row(s).iter().zip(xt) {
                sq += (x - y) * (x - y);
            }
            *out = exp_normal_fma(clip(sq));
        }
    }
}

/// Adds end `t`'s sample (`x_{t−1}`) to the running sums `S[s]` for `s ∈ [s_low, t)`, in the
/// C code's order: `c_r += k(x_s, x_{t−1}); S[s] += 2·c_r − diag`, s descending.
#[inline(always)]
fn update_running_sums(row: &[f64], s_low: usize, diag: f64, sums: &mut [f64]) {
    let mut c_r = 0.0;
    for (k, sum) in row.iter().zip(&mut sums[s_low..]).rev() {
        c_r += k;
        *sum += 2.0 * c_r - diag;
    }
}

/// For the candidates `lo..hi` at end `t`: writes each unpenalised total
/// `M_V[s] + (D[t] − D[s] − S[s]/(t − s))` to `m_pruning[s]` and returns the offset of the
/// first minimum of the penalised totals and that minimum (the C loop's strict `>` keeps the
/// first of equal values; the minimum of a set is exact whatever order finds it).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn candidate_totals_body(
    m_v: &[f64],
    d: &[f64],
    s: &[f64],
    position: &[f64],
    t: usize,
    lo: usize,
    hi: usize,
    beta: f64,
    m_pruning: &mut [f64],
) -> (usize, f64) {
    let (d_t, t_f) = (d[t], position[t]);
    let out = &mut m_pruning[lo..hi];
    for (((o, &mv), (&dd, &ss)), &p) in out
        .iter_mut()
        .zip(&m_v[lo..hi])
        .zip(d[lo..hi].iter().zip(&s[lo..hi]))
        .zip(&position[lo..hi])
    {
        *o = mv + (d_t - dd - ss / (t_f - p));
    }
    // Eight independent lanes of `if c < m { c } else { m }`: elementwise, so it vectorises.
    let mut lanes = [f64::INFINITY; 8];
    let chunks = out.chunks_exact(8);
    let rest = chunks.remainder();
    for chunk in chunks {
        for (m, &v) in lanes.iter_mut().zip(chunk) {
            let c = v + beta;
            *m = if c < *m { c } else { *m };
        }
    }
    let mut best = f64::INFINITY;
    for m in lanes.into_iter().chain(rest.iter().map(|v| v + beta)) {
        best = if m < best { m } else { best };
    }
    let offset = out.iter().position(|&v| v + beta == best).unwrap_or(0);
    (offset, best)
}

#[allow(clippy::too_many_arguments)]
fn candidate_totals(
    m_v: &[f64],
    d: &[f64],
    s: &[f64],
    position: &[f64],
    t: usize,
    lo: usize,
    hi: usize,
    beta: f64,
    m_pruning: &mut [f64],
    simd: bool,
) -> (usize, f64) {
    #[cfg(target_arch = "x86_64")]
    if simd {
        // SAFETY: `simd` is only set when the CPU has AVX2 and FMA.
        return unsafe { candidate_totals_avx2(m_v, d, s, position, t, lo, hi, beta, m_pruning) };
    }
    let _ = simd;
    candidate_totals_body(m_v, d, s, position, t, lo, hi, beta, m_pruning)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[allow(clippy::too_many_arguments)]
unsafe fn candidate_totals_avx2(
    m_v: &[f64],
    d: &[f64],
    s: &[f64],
    position: &[f64],
    t: usize,
    lo: usize,
    hi: usize,
    beta: f64,
    m_pruning: &mut [f64],
) -> (usize, f64) {
    candidate_totals_body(m_v, d, s, position, t, lo, hi, beta, m_pruning)
}

/// The cost of the whole series as one segment under ruptures' C kernel: `D[n] − S[0]/n`.
pub(crate) fn whole_cost(signal: &Signal, k: CKernel) -> f64 {
    let n = signal.n_samples;
    let mut s = vec![0.0; n + 1];
    let mut d = 0.0;
    let mut row = Vec::new();
    for t in 1..=n {
        let xt = signal.row(t - 1);
        let diag = kernel(k, xt, xt);
        d += diag;
        kernel_row(signal, k, t, 0, false, &mut row);
        update_running_sums(&row, 0, diag, &mut s);
    }
    d - s[0] / n as f64
}

/// Breakpoints (segment ends, the last being n) as `KernelCPD.predict(pen=beta)`; the caller
/// has checked `n ≥ 2·min_size` (ruptures' sanity check for this search).
pub(crate) fn kernel_pelt(signal: &Signal, k: CKernel, beta: f64, min_size: usize) -> Vec<usize> {
    kernel_pelt_solve(signal, k, beta, min_size).breakpoints
}

/// `kernel_pelt`, with the unpenalised cost of the segmentation found: each chosen segment's
/// cost `D[t] − D[s] − S[s]/(t − s)` as the search computed it, summed left to right.
pub(crate) fn kernel_pelt_solve(signal: &Signal, k: CKernel, beta: f64, min_size: usize) -> Solved {
    let n = signal.n_samples;
    let mut segment_cost = vec![0.0; n + 1];
    let mut d = vec![0.0; n + 1];
    let mut s = vec![0.0; n + 1];
    let mut m_v = vec![0.0; n + 1];
    let mut m_pruning = vec![0.0; n + 1];
    let mut m_path = vec![0usize; n + 1];
    let mut s_min = 0usize;
    // glibc's FMA exp is the system's, and AVX2 is there for the loops.
    let simd = glibc_exp::fma_exp_matches_libm();
    let fast_exp = simd;
    let mut row = Vec::new();
    // Positions as floats: `t as f64 − position[s]` is `(t − s) as f64` exactly, and vectorises.
    let position: Vec<f64> = (0..=n).map(|i| i as f64).collect();

    for t in 1..2 * min_size {
        let xt = signal.row(t - 1);
        let diag = kernel(k, xt, xt);
        d[t] = d[t - 1] + diag;
        kernel_row(signal, k, t, 0, fast_exp, &mut row);
        update_running_sums(&row, 0, diag, &mut s);
        let c_cost = d[t] - d[0] - s[0] / t as f64;
        m_v[t] = c_cost + beta;
        segment_cost[t] = c_cost;
    }

    for t in 2 * min_size..n + 1 {
        let xt = signal.row(t - 1);
        let diag = kernel(k, xt, xt);
        d[t] = d[t - 1] + diag;
        kernel_row(signal, k, t, s_min, fast_exp, &mut row);
        update_running_sums(&row, s_min, diag, &mut s);

        let c_cost = d[t] - d[s_min] - s[s_min] / (t - s_min) as f64;
        let mut c_cost_sum = m_v[s_min] + c_cost;
        m_pruning[s_min] = c_cost_sum;
        c_cost_sum += beta;
        m_v[t] = c_cost_sum;
        m_path[t] = s_min;
        // The other candidates: their unpenalised totals (vectorised), then the first strict
        // minimum of the penalised ones — the candidate the C loop ends with.
        let (lo, hi) = ((s_min + 1).max(min_size), t + 1 - min_size);
        if lo < hi {
            let (offset, best) =
                candidate_totals(&m_v, &d, &s, &position, t, lo, hi, beta, &mut m_pruning, simd);
            if m_v[t] > best {
                m_v[t] = best;
                m_path[t] = lo + offset;
            }
        }
        let chosen = m_path[t];
        segment_cost[t] = d[t] - d[chosen] - s[chosen] / (t - chosen) as f64;
        while m_pruning[s_min] >= m_v[t] && s_min < t + 1 - min_size {
            if s_min == 0 {
                s_min += min_size;
            } else {
                s_min += 1;
            }
        }
    }

    let breakpoints = breakpoints_from_path(&m_path, n);
    let cost = breakpoints.iter().map(|&b| segment_cost[b]).sum();
    Solved { breakpoints, cost }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel_cpd::cost::{L2Cost, SegmentCost};
    use crate::kernel_cpd::pelt::{DirectEndCosts, pelt};
    use crate::signal::{Missing, Signal};

    #[test]
    fn linear_kernel_solves_the_l2_problem() {
        // KernelCPD(linear) and Pelt(l2, jump 1) optimise the same penalised l2 cost.
        let mut rng = fastrand::Rng::with_seed(21);
        for trial in 0..20 {
            let n = 60 + trial;
            let x: Vec<f64> = (0..2 * n).map(|i| if i < n { 0.0 } else { 4.0 } + if i % 2 == 0 { rng.f64() } else { 2.0 * rng.f64() }).collect();
            let sig = Signal::new(&x, 2, "t", Missing::Refuse).unwrap();
            let a = kernel_pelt(&sig, CKernel::Linear, 3.0, 2);
            let cost = L2Cost::new(&sig);
            let b = pelt(n, 3.0, 2, 1, &mut DirectEndCosts(&cost));
            assert_eq!(a, b, "trial {trial}");
            assert!(cost.error(0, n) > 0.0);
        }
    }

    #[test]
    fn gaussian_kernel_finds_a_variance_change() {
        // A change in spread only (same mean): a mean-change l2 cost cannot see it, rbf can.
        let mut rng = fastrand::Rng::with_seed(2);
        let x: Vec<f64> =
            (0..400).map(|i| (rng.f64() - 0.5) * if i < 200 { 0.2 } else { 6.0 }).collect();
        let sig = Signal::new(&x, 1, "t", Missing::Refuse).unwrap();
        let b = kernel_pelt(&sig, CKernel::Gaussian { gamma: 1.0 }, 5.0, 2);
        assert_eq!(b.len(), 2, "{b:?}");
        assert!((b[0] as i64 - 200).abs() <= 3, "{b:?}");
    }
}
