//! The segment costs of ruptures: `l2` (`CostL2`), `linear` (`CostLinear`) and the rbf kernel
//! (`CostRbf`, and the clipped single-precision kernel of ruptures' C `KernelCPD`).
//!
//! Costs are computed accurately rather than in ruptures' summation order (which is numpy's
//! pairwise summation of a Gram sub-matrix or of deviations from a segment mean): a cost here is
//! within a few units in the last place of the exact value, as numpy's is, so the two can differ
//! only where two candidate segmentations tie to within rounding.

use crate::signal::Signal;

/// A segment cost `c(start, end)` over the samples `start..end`.
pub(crate) trait SegmentCost {
    /// The cost of `start..end` (at least the cost's own minimum length: 2 samples for
    /// `linear`, 1 otherwise, as ruptures' `cost.min_size`).
    fn error(&self, start: usize, end: usize) -> f64;
}

// ---------------------------------------------------------------------------------------------
// Double-double arithmetic (Dekker / Knuth), for prefix sums whose differences keep every bit.

#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Dd {
    hi: f64,
    lo: f64,
}

#[inline]
fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

#[inline]
fn quick_two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    (s, b - (s - a))
}

#[inline]
fn split(a: f64) -> (f64, f64) {
    let c = 134_217_729.0 * a; // 2^27 + 1
    let hi = c - (c - a);
    (hi, a - hi)
}

#[inline]
fn two_prod(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    let (ah, al) = split(a);
    let (bh, bl) = split(b);
    (p, ((ah * bh - p) + ah * bl + al * bh) + al * bl)
}

impl Dd {
    #[inline]
    pub fn from_f64(x: f64) -> Dd {
        Dd { hi: x, lo: 0.0 }
    }
    #[inline]
    pub fn square_of(x: f64) -> Dd {
        let (hi, lo) = two_prod(x, x);
        Dd { hi, lo }
    }
    #[inline]
    pub fn add(self, b: Dd) -> Dd {
        let (s, e) = two_sum(self.hi, b.hi);
        let (t, f) = two_sum(self.lo, b.lo);
        let (s, e) = quick_two_sum(s, e + t);
        let (hi, lo) = quick_two_sum(s, e + f);
        Dd { hi, lo }
    }
    #[inline]
    pub fn neg(self) -> Dd {
        Dd { hi: -self.hi, lo: -self.lo }
    }
    #[inline]
    pub fn sub(self, b: Dd) -> Dd {
        self.add(b.neg())
    }
    #[inline]
    pub fn mul(self, b: Dd) -> Dd {
        let (p, e) = two_prod(self.hi, b.hi);
        let (hi, lo) = quick_two_sum(p, e + (self.hi * b.lo + self.lo * b.hi));
        Dd { hi, lo }
    }
    #[inline]
    pub fn div_f64(self, b: f64) -> Dd {
        let q1 = self.hi / b;
        let (p, e) = two_prod(q1, b);
        let r = self.sub(Dd { hi: p, lo: e });
        let q2 = r.hi / b;
        let (p, e) = two_prod(q2, b);
        let r = r.sub(Dd { hi: p, lo: e });
        let q3 = r.hi / b;
        let (hi, lo) = quick_two_sum(q1, q2);
        Dd { hi, lo }.add(Dd::from_f64(q3))
    }
    #[inline]
    pub fn to_f64(self) -> f64 {
        self.hi + self.lo
    }
}

// ---------------------------------------------------------------------------------------------
// l2: the summed squared deviation from the segment mean, over every channel.

/// ruptures' `CostL2`: `Σ_channels Σ_{i∈segment} (x_i − mean)²` (`var(axis=0).sum() × length`),
/// from double-double prefix sums of x and x², so each cost is one subtraction away.
pub(crate) struct L2Cost {
    n_channels: usize,
    /// `(n + 1) × n_channels` prefix sums of x.
    sum: Vec<Dd>,
    /// `(n + 1) × n_channels` prefix sums of x².
    sum_sq: Vec<Dd>,
}

impl L2Cost {
    pub fn new(signal: &Signal) -> L2Cost {
        let d = signal.n_channels;
        let mut sum = vec![Dd::default(); (signal.n_samples + 1) * d];
        let mut sum_sq = vec![Dd::default(); (signal.n_samples + 1) * d];
        for i in 0..signal.n_samples {
            for (c, &x) in signal.row(i).iter().enumerate() {
                sum[(i + 1) * d + c] = sum[i * d + c].add(Dd::from_f64(x));
                sum_sq[(i + 1) * d + c] = sum_sq[i * d + c].add(Dd::square_of(x));
            }
        }
        L2Cost { n_channels: d, sum, sum_sq }
    }
}

impl SegmentCost for L2Cost {
    #[inline]
    fn error(&self, start: usize, end: usize) -> f64 {
        let d = self.n_channels;
        let m = (end - start) as f64;
        let mut total = 0.0;
        for c in 0..d {
            let s1 = self.sum[end * d + c].sub(self.sum[start * d + c]);
            let s2 = self.sum_sq[end * d + c].sub(self.sum_sq[start * d + c]);
            // Exact arithmetic never goes below zero; rounding of a constant segment may.
            total += s2.sub(s1.mul(s1).div_f64(m)).to_f64().max(0.0);
        }
        total
    }
}

// ---------------------------------------------------------------------------------------------
// linear: the residual sum of squares of a least-squares fit of channel 0 on the others.

/// ruptures' `CostLinear`: channel 0 is the response, channels 1.. the covariates (no intercept
/// is added: give a constant channel for one); the cost is the residual sum of squares of the
/// least-squares fit on the segment. As numpy's `lstsq` (which ruptures calls) reports no
/// residual for a rank-deficient fit or a segment with no more samples than covariates, such a
/// segment costs 0. The rank is read from a column-pivoted Householder QR with numpy's
/// threshold (`|R_kk| ≤ ε·max(m, p)·|R_00|`) where numpy reads singular values.
pub(crate) struct LinearCost<'a> {
    signal: Signal<'a>,
}

impl<'a> LinearCost<'a> {
    pub fn new(signal: Signal<'a>) -> LinearCost<'a> {
        LinearCost { signal }
    }
}

impl SegmentCost for LinearCost<'_> {
    fn error(&self, start: usize, end: usize) -> f64 {
        let d = self.signal.n_channels;
        let p = d - 1;
        let m = end - start;
        if m <= p || p == 0 {
            // numpy: no residual when M ≤ N; with no covariate the residual is y itself.
            if p == 0 {
                return (start..end).map(|i| self.signal.row(i)[0].powi(2)).sum();
            }
            return 0.0;
        }
        // Column-major copy of X (m × p) and y.
        let mut x = vec![0.0; m * p];
        let mut y = vec![0.0; m];
        for (r, i) in (start..end).enumerate() {
            let row = self.signal.row(i);
            y[r] = row[0];
            for c in 0..p {
                x[c * m + r] = row[c + 1];
            }
        }
        let mut norms: Vec<f64> =
            (0..p).map(|c| x[c * m..(c + 1) * m].iter().map(|v| v * v).sum()).collect();
        let mut first_diag = 0.0_f64;
        let threshold_factor = f64::EPSILON * m.max(p) as f64;
        for k in 0..p {
            // Pivot: the remaining column of largest norm.
            let (pivot, _) = (k..p)
                .map(|c| (c, norms[c]))
                .fold((k, f64::NEG_INFINITY), |a, b| if b.1 > a.1 { b } else { a });
            if pivot != k {
                for r in 0..m {
                    x.swap(k * m + r, pivot * m + r);
                }
                norms.swap(k, pivot);
            }
            let col = &x[k * m..(k + 1) * m];
            let alpha = col[k..].iter().map(|v| v * v).sum::<f64>().sqrt();
            if k == 0 {
                first_diag = alpha;
            }
            if alpha <= threshold_factor * first_diag || alpha == 0.0 {
                return 0.0; // rank deficient: numpy's lstsq reports no residual
            }
            // Householder vector v = col[k..] + sign·alpha·e_1.
            let sign = if col[k] >= 0.0 { 1.0 } else { -1.0 };
            let mut v: Vec<f64> = col[k..].to_vec();
            v[0] += sign * alpha;
            let vnorm2: f64 = v.iter().map(|a| a * a).sum();
            if vnorm2 == 0.0 {
                continue;
            }
            // Apply H = I − 2vvᵀ/(vᵀv) to the remaining columns and to y.
            for c in k..p {
                let colc = &mut x[c * m..(c + 1) * m];
                let dot: f64 = v.iter().zip(&colc[k..]).map(|(a, b)| a * b).sum();
                let f = 2.0 * dot / vnorm2;
                for (a, b) in v.iter().zip(colc[k..].iter_mut()) {
                    *b -= f * a;
                }
            }
            let dot: f64 = v.iter().zip(&y[k..]).map(|(a, b)| a * b).sum();
            let f = 2.0 * dot / vnorm2;
            for (a, b) in v.iter().zip(y[k..].iter_mut()) {
                *b -= f * a;
            }
            // Downdate the remaining column norms (recomputed: p is small).
            for c in (k + 1)..p {
                norms[c] = x[c * m + k + 1..(c + 1) * m].iter().map(|v| v * v).sum();
            }
        }
        y[p..].iter().map(|v| v * v).sum()
    }
}

// ---------------------------------------------------------------------------------------------
// rbf: the kernel mean-change cost.

/// Squared euclidean distance, summed over channels in order (as scipy's `sqeuclidean` and
/// ruptures' C kernel do).
#[inline]
pub(crate) fn squared_distance(a: &[f64], b: &[f64]) -> f64 {
    let mut s = 0.0;
    for (x, y) in a.iter().zip(b) {
        s += (x - y) * (x - y);
    }
    s
}

/// ruptures' Python `CostRbf` kernel: `exp(−clip(γ·‖x−y‖², 0.01, 100))` off the diagonal, and 1
/// on it (its Gram matrix is `exp(−squareform(K))`, whose diagonal is never clipped).
#[inline]
pub(crate) fn rbf_off_diagonal(gamma: f64, squared_distance: f64) -> f64 {
    (-(squared_distance * gamma).clamp(0.01, 100.0)).exp()
}

/// ruptures' C `KernelCPD` Gaussian kernel: the same clip, done in single precision (its `clip`
/// takes and returns `float`), applied on the diagonal too (`exp(−0.01)` there).
#[inline]
pub(crate) fn rbf_c_kernel(gamma: f64, squared_distance: f64) -> f64 {
    let n = (gamma * squared_distance) as f32;
    let upper_clipped = if n > 100.0_f32 { 100.0_f32 } else { n };
    let clipped = if 0.01_f32 > upper_clipped { 0.01_f32 } else { upper_clipped };
    (-(clipped as f64)).exp()
}

/// ruptures' `CostRbf` on one segment, from scratch: `m − (Σ_{i,j} k(x_i, x_j))/m`. O(m²)
/// kernel evaluations and O(1) memory; the searches that need many costs keep running sums
/// instead (`pelt.rs`, `binseg.rs`).
pub(crate) struct RbfCost<'a> {
    pub signal: Signal<'a>,
    pub gamma: f64,
}

impl RbfCost<'_> {
    /// `Σ_{i<j} k(x_i, x_j)` over `start..end` (twice this plus the diagonal is the block sum).
    pub fn upper_sum(&self, start: usize, end: usize) -> f64 {
        let mut total = 0.0;
        for j in start + 1..end {
            let xj = self.signal.row(j);
            let mut column = 0.0;
            for i in start..j {
                column += rbf_off_diagonal(self.gamma, squared_distance(self.signal.row(i), xj));
            }
            total += column;
        }
        total
    }
    /// `Σ_{i∈a, j∈b} k(x_i, x_j)` for two disjoint ranges.
    pub fn cross_sum(&self, a: std::ops::Range<usize>, b: std::ops::Range<usize>) -> f64 {
        let mut total = 0.0;
        for j in b {
            let xj = self.signal.row(j);
            let mut column = 0.0;
            for i in a.clone() {
                column += rbf_off_diagonal(self.gamma, squared_distance(self.signal.row(i), xj));
            }
            total += column;
        }
        total
    }
}

/// The rbf cost from a block's length and its full Gram sum (diagonal included).
#[inline]
pub(crate) fn rbf_cost_from_block(length: usize, block_sum: f64) -> f64 {
    let m = length as f64;
    m - block_sum / m
}

impl SegmentCost for RbfCost<'_> {
    fn error(&self, start: usize, end: usize) -> f64 {
        let m = end - start;
        rbf_cost_from_block(m, m as f64 + 2.0 * self.upper_sum(start, end))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::signal::{Missing, Signal};

    fn naive_l2(x: &[f64], d: usize, s: usize, e: usize) -> f64 {
        (0..d)
            .map(|c| {
                let v: Vec<f64> = (s..e).map(|i| x[i * d + c]).collect();
                let mean = v.iter().sum::<f64>() / v.len() as f64;
                v.iter().map(|a| (a - mean).powi(2)).sum::<f64>()
            })
            .sum()
    }

    #[test]
    fn l2_equals_the_two_pass_variance_even_far_from_zero() {
        let mut rng = fastrand::Rng::with_seed(3);
        // A large offset: single-precision prefix sums of x² would lose the variance entirely.
        let x: Vec<f64> = (0..600).map(|_| 1e7 + rng.f64()).collect();
        let sig = Signal::new(&x, 2, "t", Missing::Refuse).unwrap();
        let cost = L2Cost::new(&sig);
        for (s, e) in [(0, 300), (5, 6), (17, 250), (100, 101), (0, 2)] {
            let want = naive_l2(&x, 2, s, e);
            let got = cost.error(s, e);
            assert!((got - want).abs() <= 1e-9 * want.max(1e-12), "{s}..{e}: {got} vs {want}");
        }
        assert_eq!(cost.error(7, 8), 0.0);
    }

    #[test]
    fn linear_is_the_residual_of_an_exact_fit_plus_noise() {
        // y = 2 + 3·t exactly on 0..10, then off the line at 10..20.
        let mut x = Vec::new();
        for i in 0..20 {
            let t = i as f64;
            let y = if i < 10 {
                2.0 + 3.0 * t
            } else {
                2.0 + 3.0 * t + if i % 2 == 0 { 1.0 } else { -1.0 }
            };
            x.extend_from_slice(&[y, 1.0, t]);
        }
        let sig = Signal::new(&x, 3, "t", Missing::Refuse).unwrap();
        let cost = LinearCost::new(sig);
        assert!(cost.error(0, 10) < 1e-20);
        // Alternating ±1 around the line on 10 points: the fit absorbs a little of it.
        let c = cost.error(10, 20);
        assert!(c > 9.0 && c <= 10.0, "{c}");
        // Two samples, two covariates: no residual (numpy reports none when M ≤ N).
        assert_eq!(cost.error(3, 5), 0.0);
        // A constant covariate repeated: rank deficient, numpy reports no residual.
        let dup: Vec<f64> = (0..10).flat_map(|i| [i as f64 * 0.5, 1.0, 1.0]).collect();
        let sig = Signal::new(&dup, 3, "t", Missing::Refuse).unwrap();
        assert_eq!(LinearCost::new(sig).error(0, 10), 0.0);
    }

    #[test]
    fn rbf_kernels_clip_as_ruptures_does() {
        assert_eq!(rbf_off_diagonal(1.0, 0.0), (-0.01f64).exp());
        assert_eq!(rbf_off_diagonal(1.0, 1e9), (-100.0f64).exp());
        // C: the clip happens on a float, so the argument is rounded to single precision.
        let g = 0.123456789;
        assert_eq!(rbf_c_kernel(g, 1.0), (-((g as f32) as f64)).exp());
        assert_ne!(rbf_c_kernel(g, 1.0), rbf_off_diagonal(g, 1.0));
        assert_eq!(rbf_c_kernel(g, 0.0), (-((0.01f32) as f64)).exp());
    }

    #[test]
    fn rbf_cost_matches_its_definition() {
        let x = [0.0, 0.1, 0.5, 2.0, 2.2];
        let sig = Signal::new(&x, 1, "t", Missing::Refuse).unwrap();
        let cost = RbfCost { signal: sig, gamma: 0.7 };
        let mut g = 0.0;
        for i in 1..4 {
            for j in 1..4 {
                g +=
                    if i == j { 1.0 } else { rbf_off_diagonal(0.7, (x[i] - x[j]) * (x[i] - x[j])) };
            }
        }
        assert!((cost.error(1, 4) - (3.0 - g / 3.0)).abs() < 1e-15);
    }
}
