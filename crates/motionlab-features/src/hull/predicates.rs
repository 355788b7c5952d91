//! Exact orientation predicates: a floating-point plane test with an a-priori error bound
//! ([`Plane`]) that decides when the bound allows, Shewchuk's adaptive `orient3d` / `orient2d`
//! (crate `robust`) for the rest.

use motionlab_core::Point3;
use robust::Coord3D;

use super::sub;

/// Multiplier of the a-priori rounding-error bound of [`Plane::eval`]: the evaluation has at
/// most 8 roundings per monomial, so |error| ≤ γ₈·P with γ₈ ≈ 8u = 8.9e-16 and P the sum of the
/// monomials' magnitudes (bounded by `m · extent`). 2e-15 leaves a factor 2.2 of margin.
pub(super) const ERR: f64 = 2e-15;
/// Absolute floor of the bound, covering underflow (subnormal products) in degenerate inputs.
pub(super) const TINY: f64 = 1e-290;

#[inline(always)]
pub(super) fn c3(p: Point3) -> Coord3D<f64> {
    Coord3D { x: p[0], y: p[1], z: p[2] }
}

/// Exact sign source: `det[b−a, c−a, q−a]`, positive when `q` is above the plane of the
/// counter-clockwise triangle `(a, b, c)` (on the side its normal `(b−a)×(c−a)` points to).
#[inline]
pub(super) fn orient_exact(a: Point3, b: Point3, c: Point3, q: Point3) -> f64 {
    // robust::orient3d is positive when q lies *below* (a, b, c); flip it.
    -robust::orient3d(c3(a), c3(b), c3(c), c3(q))
}

/// A triangle's plane with an a-priori error bound, so most side tests cost 6 flops.
///
/// `eval(q) = n̂ · (q − a)` with `n̂ = (b−a)×(c−a)` evaluated in floating point in a fixed order.
/// Its difference from the exact `det[b−a, c−a, q−a]` is at most `bound` for every `q` within
/// the point set's bounding box (extent per axis `ext`), so `|eval| > bound` decides the sign.
#[derive(Clone, Copy, Debug)]
pub(super) struct Plane {
    pub(super) o: Point3,
    pub(super) n: Point3,
    pub(super) bound: f64,
}

impl Plane {
    #[inline]
    pub(super) fn new(a: Point3, b: Point3, c: Point3, ext: Point3) -> Plane {
        let d1 = sub(b, a);
        let d2 = sub(c, a);
        let (p1, p2) = (d1[1] * d2[2], d1[2] * d2[1]);
        let (p3, p4) = (d1[2] * d2[0], d1[0] * d2[2]);
        let (p5, p6) = (d1[0] * d2[1], d1[1] * d2[0]);
        let n = [p1 - p2, p3 - p4, p5 - p6];
        let m = [p1.abs() + p2.abs(), p3.abs() + p4.abs(), p5.abs() + p6.abs()];
        let bound = ERR * (m[0] * ext[0] + m[1] * ext[1] + m[2] * ext[2]) + TINY;
        Plane { o: a, n, bound }
    }
    /// A value with the sign of the exact orientation of `q` (positive above): the plane's
    /// evaluation when its bound decides, else the exact predicate.
    #[inline]
    pub(super) fn side_exact(&self, a: Point3, b: Point3, c: Point3, q: Point3) -> f64 {
        let s = self.eval(q);
        if s > self.bound || s < -self.bound { s } else { orient_exact(a, b, c, q) }
    }
    #[inline(always)]
    pub(super) fn eval(&self, q: Point3) -> f64 {
        // Fixed evaluation order (no FMA contraction in Rust): the error analysis depends on it.
        (self.n[0] * (q[0] - self.o[0]) + self.n[1] * (q[1] - self.o[1]))
            + self.n[2] * (q[2] - self.o[2])
    }
}

#[inline]
pub(super) fn orient_fast(a: Point3, b: Point3, c: Point3, q: Point3) -> f64 {
    let (d1, d2, e) = (sub(b, a), sub(c, a), sub(q, a));
    (d1[1] * d2[2] - d1[2] * d2[1]) * e[0]
        + (d1[2] * d2[0] - d1[0] * d2[2]) * e[1]
        + (d1[0] * d2[1] - d1[1] * d2[0]) * e[2]
}

/// Exactly collinear: `(b−a)×(q−a) = 0`, i.e. all three coordinate-plane projections collinear.
pub(super) fn collinear_exact(a: Point3, b: Point3, q: Point3) -> bool {
    let o2 = |i: usize, j: usize| {
        robust::orient2d(
            robust::Coord { x: a[i], y: a[j] },
            robust::Coord { x: b[i], y: b[j] },
            robust::Coord { x: q[i], y: q[j] },
        )
    };
    o2(0, 1) == 0.0 && o2(1, 2) == 0.0 && o2(2, 0) == 0.0
}
