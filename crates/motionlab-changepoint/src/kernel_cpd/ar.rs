//! ruptures' autoregressive cost (`CostAR`, `model="ar"`): the residual sum of squares of a
//! least-squares fit of each sample on the `order` samples before it and an intercept, per
//! segment.
//!
//! The design is ruptures' own, padding included (`ruptures/costs/costautoregressive.py`):
//! row t regresses `y_t = x_t` on `(x_{t−order}, …, x_{t−1}, 1)`; the first `order` rows, which
//! have no past, take the covariates of row `order` (`(x_0, …, x_{order−1}, 1)`) and the
//! response `x_order`. As numpy's `lstsq` (which ruptures calls) reports no residual when the
//! fit has no more rows than columns or is rank deficient (a singular value at most
//! `ε·max(rows, columns)` times the largest), such a segment costs 0.
//!
//! **How it is computed.** A segment's fit is a QR factorisation grown one row at a time by
//! Givens rotations (O(order²) per row, backward stable like numpy's own QR-based solver):
//! the searches keep one growing factorisation per segment start (PELT), sweep each segment
//! once from either end (binary segmentation), or merge two half-window factorisations
//! (`window`), where ruptures solves every segment from scratch — O(segment length · order²)
//! per cost. Costs agree with numpy's to rounding, so only segmentations whose penalised costs
//! tie to within rounding could be ordered differently.

use super::cost::SegmentCost;

/// ruptures' default autoregressive order (`CostAR(order=4)`).
pub const DEFAULT_AR_ORDER: usize = 4;

/// ruptures' `CostAR.min_size`: at least 5 samples, and one more than the order.
pub fn ar_min_size(order: usize) -> usize {
    (order + 1).max(5)
}

/// The regression design of one channel: response and covariates per sample, as ruptures
/// builds them.
pub(crate) struct ArDesign {
    /// Number of columns: `order` lags and the intercept.
    pub columns: usize,
    /// Response per sample.
    pub y: Vec<f64>,
    /// Covariates, `n × columns` row-major: lags oldest first, the intercept last.
    pub x: Vec<f64>,
}

impl ArDesign {
    /// The design of `values` (one channel, more than `order` samples).
    pub fn new(values: &[f64], order: usize) -> ArDesign {
        let n = values.len();
        let p = order + 1;
        let mut y = values.to_vec();
        let mut x = vec![1.0; n * p];
        for t in 0..n {
            // Rows before `order` repeat the first full lag vector (numpy's edge padding).
            let first = t.max(order) - order;
            x[t * p..t * p + order].copy_from_slice(&values[first..first + order]);
        }
        let pad = values[order];
        y[..order].fill(pad);
        ArDesign { columns: p, y, x }
    }

    #[inline]
    pub fn row(&self, t: usize) -> (&[f64], f64) {
        (&self.x[t * self.columns..(t + 1) * self.columns], self.y[t])
    }

    /// The factorisation of `start..end`, from scratch.
    pub fn fit(&self, start: usize, end: usize) -> QrFit {
        let mut fit = QrFit::new(self.columns);
        for t in start..end {
            let (x, y) = self.row(t);
            fit.push(x, y);
        }
        fit
    }
}

/// A least-squares fit grown row by row: the triangular factor R of the rows seen, Qᵀy, and
/// the residual sum of squares of the rows already rotated out.
#[derive(Clone, Debug)]
pub(crate) struct QrFit {
    p: usize,
    /// `p × p` upper triangular, row-major.
    r: Vec<f64>,
    qty: Vec<f64>,
    rss: f64,
    rows: usize,
}

impl QrFit {
    pub fn new(p: usize) -> QrFit {
        QrFit { p, r: vec![0.0; p * p], qty: vec![0.0; p], rss: 0.0, rows: 0 }
    }

    /// Adds the row `(x, y)`: Givens rotations fold x into R, and what is left of y after them
    /// is residual.
    #[inline]
    pub fn push(&mut self, x: &[f64], y: f64) {
        let p = self.p;
        if p <= 16 {
            let mut buf = [0.0f64; 16];
            buf[..p].copy_from_slice(x);
            self.rotate_in(&mut buf[..p], y);
        } else {
            self.rotate_in(&mut x.to_vec(), y);
        }
    }

    // Row k of R and the entries of z from k on, rotated in lockstep: the textbook's index
    // loops (Golub & Van Loan, Givens QR update) read closer to the algorithm than zipped slices.
    #[allow(clippy::needless_range_loop)]
    #[inline]
    fn rotate_in(&mut self, z: &mut [f64], y: f64) {
        let p = self.p;
        let mut yz = y;
        for k in 0..p {
            let b = z[k];
            if b == 0.0 {
                continue;
            }
            let a = self.r[k * p + k];
            let h = givens_norm(a, b);
            let (c, s) = (a / h, b / h);
            self.r[k * p + k] = h;
            for j in k + 1..p {
                let rkj = self.r[k * p + j];
                let zj = z[j];
                self.r[k * p + j] = c * rkj + s * zj;
                z[j] = c * zj - s * rkj;
            }
            let q = self.qty[k];
            self.qty[k] = c * q + s * yz;
            yz = c * yz - s * q;
        }
        self.rss += yz * yz;
        self.rows += 1;
    }

    /// Number of rows taken in.
    #[inline]
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// The fit of both row sets: `other`'s R rows (with its Qᵀy) are rows of the same least
    /// squares problem, its residual adds.
    pub fn merge(&self, other: &QrFit) -> QrFit {
        let p = self.p;
        let mut out = self.clone();
        let mut row = vec![0.0; p];
        for k in 0..p {
            row.fill(0.0);
            row[k..].copy_from_slice(&other.r[k * p + k..(k + 1) * p]);
            out.push(&row, other.qty[k]);
        }
        out.rss += other.rss;
        out.rows = self.rows + other.rows;
        out
    }

    /// numpy `lstsq`'s residual: the residual sum of squares, or 0 where numpy reports none
    /// (no more rows than columns, or rank deficient at its threshold).
    pub fn cost(&self) -> f64 {
        if self.rows <= self.p || self.rank_deficient() {
            return 0.0;
        }
        self.rss
    }

    /// numpy's rank test on the singular values σ of the rows (those of R): deficient when
    /// σ_min ≤ ε·max(rows, columns)·σ_max. Norm bounds decide almost every case (σ_min/σ_max
    /// lies in [ρ, p·ρ] with ρ = 1/(‖R‖_F·‖R⁻¹‖_F)); the singular values themselves are computed
    /// only in between.
    fn rank_deficient(&self) -> bool {
        let p = self.p;
        let threshold = f64::EPSILON * self.rows.max(p) as f64;
        if (0..p).any(|k| self.r[k * p + k] == 0.0) {
            return true;
        }
        let norm_r = self.r.iter().map(|v| v * v).sum::<f64>().sqrt();
        let Some(norm_inv) = upper_inverse_frobenius(&self.r, p) else { return true };
        let rho = 1.0 / (norm_r * norm_inv);
        if rho > threshold {
            return false;
        }
        if p as f64 * rho <= threshold {
            return true;
        }
        let sigma = singular_values(&self.r, p);
        let max = sigma.iter().copied().fold(0.0, f64::max);
        let min = sigma.iter().copied().fold(f64::INFINITY, f64::min);
        min <= threshold * max
    }
}

/// `√(a² + b²)` for a Givens rotation, without overflow or underflow.
#[inline]
fn givens_norm(a: f64, b: f64) -> f64 {
    let h = (a * a + b * b).sqrt();
    if h > 0.0 && h.is_finite() { h } else { a.hypot(b) }
}

/// ‖R⁻¹‖_F of an upper triangular `p × p` R with a non-zero diagonal (None if it overflows).
fn upper_inverse_frobenius(r: &[f64], p: usize) -> Option<f64> {
    // Column j of R⁻¹ solves R v = e_j by back substitution.
    let mut total = 0.0;
    let mut v = vec![0.0; p];
    for j in 0..p {
        v.fill(0.0);
        for i in (0..=j).rev() {
            let mut s = if i == j { 1.0 } else { 0.0 };
            for k in i + 1..=j {
                s -= r[i * p + k] * v[k];
            }
            v[i] = s / r[i * p + i];
        }
        total += v[..=j].iter().map(|a| a * a).sum::<f64>();
    }
    let norm = total.sqrt();
    norm.is_finite().then_some(norm)
}

/// Singular values of a small square matrix by one-sided Jacobi rotations (Hestenes), which
/// are accurate for the small ones too.
// Columns i and j rotated entry by entry: two mutable rows of `cols` at once, which an iterator
// over one of them cannot give without splitting the vector.
#[allow(clippy::needless_range_loop)]
fn singular_values(a: &[f64], p: usize) -> Vec<f64> {
    // Work on columns: cols[j] is column j.
    let mut cols: Vec<Vec<f64>> = (0..p).map(|j| (0..p).map(|i| a[i * p + j]).collect()).collect();
    for _sweep in 0..60 {
        let mut rotated = false;
        for i in 0..p {
            for j in i + 1..p {
                let alpha: f64 = cols[i].iter().map(|v| v * v).sum();
                let beta: f64 = cols[j].iter().map(|v| v * v).sum();
                let gamma: f64 = cols[i].iter().zip(&cols[j]).map(|(x, y)| x * y).sum();
                if gamma == 0.0 || gamma.abs() <= f64::EPSILON * (alpha * beta).sqrt() {
                    continue;
                }
                rotated = true;
                let zeta = (beta - alpha) / (2.0 * gamma);
                let t = zeta.signum() / (zeta.abs() + (1.0 + zeta * zeta).sqrt());
                let t = if zeta == 0.0 { 1.0 } else { t };
                let c = 1.0 / (1.0 + t * t).sqrt();
                let s = c * t;
                for k in 0..p {
                    let (x, y) = (cols[i][k], cols[j][k]);
                    cols[i][k] = c * x - s * y;
                    cols[j][k] = s * x + c * y;
                }
            }
        }
        if !rotated {
            break;
        }
    }
    cols.iter().map(|c| c.iter().map(|v| v * v).sum::<f64>().sqrt()).collect()
}

/// ruptures' `CostAR` on one channel, segment by segment from scratch (for the rules that
/// re-cost arbitrary segments: window's penalty rule, the BIC default).
pub(crate) struct ArCost {
    pub design: ArDesign,
}

impl SegmentCost for ArCost {
    fn error(&self, start: usize, end: usize) -> f64 {
        self.design.fit(start, end).cost()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The residual of the normal equations solved in plain f64 (fine on well-conditioned data).
    fn normal_equations_rss(design: &ArDesign, start: usize, end: usize) -> f64 {
        let p = design.columns;
        let mut g = vec![0.0; p * p];
        let mut b = vec![0.0; p];
        let mut yy = 0.0;
        for t in start..end {
            let (x, y) = design.row(t);
            for i in 0..p {
                b[i] += x[i] * y;
                for j in 0..p {
                    g[i * p + j] += x[i] * x[j];
                }
            }
            yy += y * y;
        }
        // Gaussian elimination on G β = b.
        let mut a = g.clone();
        let mut beta = b.clone();
        for k in 0..p {
            for i in k + 1..p {
                let f = a[i * p + k] / a[k * p + k];
                for j in k..p {
                    a[i * p + j] -= f * a[k * p + j];
                }
                beta[i] -= f * beta[k];
            }
        }
        for k in (0..p).rev() {
            let mut s = beta[k];
            for j in k + 1..p {
                s -= a[k * p + j] * beta[j];
            }
            beta[k] = s / a[k * p + k];
        }
        let mut rss = 0.0;
        for t in start..end {
            let (x, y) = design.row(t);
            let fit: f64 = x.iter().zip(&beta).map(|(a, b)| a * b).sum();
            rss += (y - fit).powi(2);
        }
        let _ = yy;
        rss
    }

    fn noise(n: usize, seed: u64) -> Vec<f64> {
        let mut rng = fastrand::Rng::with_seed(seed);
        (0..n).map(|_| rng.f64() - 0.5).collect()
    }

    #[test]
    fn design_is_ruptures_padded_lag_matrix() {
        let v: Vec<f64> = (0..8).map(|i| (i * i) as f64).collect();
        let d = ArDesign::new(&v, 2);
        assert_eq!(d.columns, 3);
        // Rows 0 and 1 take row 2's covariates (x0, x1, 1) and response x2.
        assert_eq!(d.row(0), (&[0.0, 1.0, 1.0][..], 4.0));
        assert_eq!(d.row(1), (&[0.0, 1.0, 1.0][..], 4.0));
        assert_eq!(d.row(2), (&[0.0, 1.0, 1.0][..], 4.0));
        assert_eq!(d.row(5), (&[9.0, 16.0, 1.0][..], 25.0));
    }

    #[test]
    fn givens_fit_equals_the_normal_equations_residual() {
        let mut rng = fastrand::Rng::with_seed(3);
        // An AR(2) process with noise: well conditioned.
        let mut v = vec![0.0, 0.0];
        for _ in 0..400 {
            let n = v.len();
            v.push(0.6 * v[n - 1] - 0.3 * v[n - 2] + rng.f64() - 0.5);
        }
        let d = ArDesign::new(&v, 4);
        for (s, e) in [(0, 50), (17, 230), (100, 106), (300, 402)] {
            let got = d.fit(s, e).cost();
            let want = normal_equations_rss(&d, s, e);
            assert!((got - want).abs() <= 1e-10 * want, "{s}..{e}: {got} vs {want}");
        }
        // Merging two halves is the fit of the whole.
        let whole = d.fit(40, 200);
        let merged = d.fit(40, 120).merge(&d.fit(120, 200));
        assert!((whole.cost() - merged.cost()).abs() <= 1e-12 * whole.cost());
        assert_eq!(merged.rows, 160);
    }

    #[test]
    fn no_residual_where_numpy_reports_none() {
        let v = noise(60, 5);
        let d = ArDesign::new(&v, 4);
        // Five rows, five columns: numpy returns no residual.
        assert_eq!(d.fit(10, 15).cost(), 0.0);
        assert!(d.fit(10, 16).cost() > 0.0);
        // A constant stretch whose last value differs: the covariates are rank one, so numpy
        // reports no residual although the response is not fitted.
        let mut flat = vec![2.0; 40];
        flat[30] = 3.0;
        let d = ArDesign::new(&flat, 4);
        assert_eq!(d.fit(10, 31).cost(), 0.0);
        // A linear trend: lags and intercept are dependent (rank 2 of 5).
        let ramp: Vec<f64> = (0..50).map(|i| 0.5 * i as f64).collect();
        assert_eq!(ArDesign::new(&ramp, 4).fit(5, 45).cost(), 0.0);
    }

    #[test]
    fn singular_values_of_a_known_matrix() {
        // diag(3, 2, 1) rotated on the left by a permutation: singular values 3, 2, 1.
        let a = [0.0, 2.0, 0.0, 3.0, 0.0, 0.0, 0.0, 0.0, 1.0];
        let mut s = singular_values(&a, 3);
        s.sort_by(f64::total_cmp);
        for (g, w) in s.iter().zip([1.0, 2.0, 3.0]) {
            assert!((g - w).abs() < 1e-14, "{s:?}");
        }
        // [[1, 1], [0, ε]]: σ_min ≈ ε/√2.
        let e = 1e-9;
        let s = singular_values(&[1.0, 1.0, 0.0, e], 2);
        let min = s.iter().copied().fold(f64::INFINITY, f64::min);
        assert!((min - e / 2f64.sqrt()).abs() < 1e-18, "{s:?}");
    }

    #[test]
    fn min_size_is_ruptures() {
        assert_eq!(ar_min_size(4), 5);
        assert_eq!(ar_min_size(1), 5);
        assert_eq!(ar_min_size(7), 8);
    }
}
