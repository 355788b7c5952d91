//! The fast half of certification: a frame's points in the layouts the plane test reads, and
//! the test of every triangle against every point — dispatched at run time to the AVX2 + FMA
//! kernel (`kernel_avx2.rs`) or the portable loop here, which make the same decisions.

use motionlab_core::Point3;

#[cfg(target_arch = "x86_64")]
use super::kernel_avx2::uncertain_triangles_avx2;
use super::predicates::Plane;

/// A frame's distinct valid points in the layouts the certification reads, with their span
/// and mean.
#[derive(Default)]
pub(super) struct Soa {
    /// Structure of arrays: the portable plane test.
    pub(super) xs: Vec<f64>,
    pub(super) ys: Vec<f64>,
    pub(super) zs: Vec<f64>,
    /// Per point `[[x; 4], [y; 4], [z; 4]]`: the AVX2 plane test reads a point's coordinates as
    /// memory operands of its multiply–adds instead of broadcasting them for every triangle.
    pub(super) wide: Vec<[[f64; 4]; 3]>,
    pub(super) span: Span,
    /// The points' mean: inside their hull, the apex of the volume sum.
    pub(super) mean: Point3,
}

impl Soa {
    /// Gathers `points[keep[..]]` into `compact` and the layouts the plane test will use
    /// (`wide` with AVX2 + FMA, else `xs`, `ys`, `zs`), with their span and mean, in one pass.
    /// Returns false when a gathered point is not finite (a marker went missing): the sum of
    /// the coordinates is then not finite, so the check costs nothing per point.
    pub(super) fn fill(
        &mut self,
        points: &[Point3],
        keep: &[u32],
        compact: &mut Vec<Point3>,
    ) -> bool {
        compact.resize(keep.len(), [0.0; 3]);
        #[cfg(target_arch = "x86_64")]
        {
            if crate::simd::available() {
                // SAFETY: the CPU supports AVX2 and FMA (checked by `simd::available`), the only
                // requirement of the `target_feature` function.
                return unsafe { self.fill_wide_avx2(points, keep, compact) };
            }
        }
        let n = keep.len();
        self.xs.resize(n, 0.0);
        self.ys.resize(n, 0.0);
        self.zs.resize(n, 0.0);
        let (mut lo, mut hi, mut sum) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3], [0.0; 3]);
        let layouts = self.xs.iter_mut().zip(&mut self.ys).zip(&mut self.zs);
        for ((&i, c), ((x, y), z)) in keep.iter().zip(compact.iter_mut()).zip(layouts) {
            let p = points[i as usize];
            (*c, *x, *y, *z) = (p, p[0], p[1], p[2]);
            for k in 0..3 {
                // `if` rather than `f64::min` (no NaN here): one min/max instruction each.
                lo[k] = if p[k] < lo[k] { p[k] } else { lo[k] };
                hi[k] = if p[k] > hi[k] { p[k] } else { hi[k] };
                sum[k] += p[k];
            }
        }
        self.set_span_and_mean(lo, hi, sum, n)
    }

    /// Sets span and mean; false when the sum is not finite (some coordinate is not).
    pub(super) fn set_span_and_mean(
        &mut self,
        lo: Point3,
        hi: Point3,
        sum: Point3,
        n: usize,
    ) -> bool {
        self.span = Span {
            ext: [0, 1, 2].map(|k| hi[k] - lo[k]),
            abs_max: [0, 1, 2].map(|k| lo[k].abs().max(hi[k].abs())),
        };
        self.mean = sum.map(|s| s / n as f64);
        sum.iter().all(|s| s.is_finite())
    }
}

/// Per-axis quantities the fast certification's error bounds need, from one pass over the
/// points: the extent (max − min) and the largest magnitude |coordinate|.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Span {
    pub(super) ext: Point3,
    pub(super) abs_max: Point3,
}

/// The fast half of certification: appends to `uncertain` the index (into `tris`) of every
/// triangle for which some point other than its three vertices is *not* certified strictly
/// below its plane by a floating-point test with an a-priori error bound (such a triangle needs
/// the exact re-check, `HullTracker::certify_slow`). `pts` are the points, `soa` the same in
/// its layouts. A vertex of the triangle is never certified below (its exact value is 0 and
/// every evaluation is within its bound of it), so a triangle passes when exactly 3 points fail
/// the test.
///
/// Sets `six[k] = n·(a − o)` for triangle `k` (`n = (b−a)×(c−a)`, `o` = the points' mean):
/// summed over the certified hull, six times its volume, for free from the planes.
///
/// With AVX2 + FMA (detected at run time) four triangles are tested at once, one per lane: see
/// [`uncertain_triangles_avx2`] for its test and error bound. Otherwise each triangle's
/// [`Plane`] is evaluated at every point.
pub(super) fn uncertain_triangles(
    pts: &[Point3],
    soa: &Soa,
    tris: &[[u32; 3]],
    uncertain: &mut Vec<u32>,
    six: &mut Vec<f64>,
) {
    #[cfg(target_arch = "x86_64")]
    {
        if crate::simd::available() {
            // SAFETY: the CPU supports AVX2 and FMA (checked by `simd::available`), the only
            // requirement of the `target_feature` function.
            return unsafe { uncertain_triangles_avx2(soa, tris, uncertain, six) };
        }
    }
    uncertain_triangles_portable(pts, soa, tris, uncertain, six)
}

/// [`uncertain_triangles`] without SIMD intrinsics: each triangle's [`Plane`] at every point.
pub(super) fn uncertain_triangles_portable(
    pts: &[Point3],
    soa: &Soa,
    tris: &[[u32; 3]],
    uncertain: &mut Vec<u32>,
    six: &mut Vec<f64>,
) {
    six.clear();
    for (k, t) in tris.iter().enumerate() {
        let [a, b, c] = t.map(|i| pts[i as usize]);
        let pl = Plane::new(a, b, c, soa.span.ext);
        let (nb, o, n) = (-pl.bound, pl.o, pl.n);
        let mut not_below = 0u32;
        for ((&x, &y), &z) in soa.xs.iter().zip(&soa.ys).zip(&soa.zs) {
            let s = (n[0] * (x - o[0]) + n[1] * (y - o[1])) + n[2] * (z - o[2]);
            not_below += (s >= nb) as u32;
        }
        if not_below != 3 {
            uncertain.push(k as u32);
        }
        six.push(-pl.eval(soa.mean));
    }
}
