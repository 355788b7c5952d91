//! The certification kernels with AVX2 + FMA: four triangles per register, one per lane.

use motionlab_core::Point3;

use super::kernel::Soa;
use super::predicates::{ERR, TINY};

impl Soa {
    /// [`Soa::fill`] for the AVX2 plane test: each coordinate broadcast once into `wide`, and
    /// the running min, max and sum (in point order, as the portable loop) taken on one
    /// register holding `(x, y, z, z)`.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    pub(super) fn fill_wide_avx2(
        &mut self,
        points: &[Point3],
        keep: &[u32],
        compact: &mut [Point3],
    ) -> bool {
        use std::arch::x86_64::*;
        self.wide.resize(keep.len(), [[0.0; 4]; 3]);
        let mut lo = _mm256_set1_pd(f64::INFINITY);
        let mut hi = _mm256_set1_pd(f64::NEG_INFINITY);
        let mut sum = _mm256_setzero_pd();
        for ((&i, c), w) in keep.iter().zip(compact.iter_mut()).zip(&mut self.wide) {
            let p = points[i as usize];
            *c = p;
            // SAFETY: `p` is a `[f64; 3]`: the 16-byte load reads x and y.
            let v = _mm256_set_m128d(_mm_set1_pd(p[2]), unsafe { _mm_loadu_pd(p.as_ptr()) });
            // vminpd/vmaxpd return the second operand when either is NaN; a NaN is caught by
            // the sum.
            lo = _mm256_min_pd(v, lo);
            hi = _mm256_max_pd(v, hi);
            sum = _mm256_add_pd(sum, v);
            for k in 0..3 {
                // SAFETY: `w[k]` is a `[f64; 4]` (unaligned 32-byte store).
                unsafe { _mm256_storeu_pd(w[k].as_mut_ptr(), _mm256_set1_pd(p[k])) };
            }
        }
        let xyz = |v: __m256d| {
            let mut lanes = [0.0; 4];
            // SAFETY: `lanes` is 4 × f64 = 32 bytes, the width of the unaligned store.
            unsafe { _mm256_storeu_pd(lanes.as_mut_ptr(), v) };
            [lanes[0], lanes[1], lanes[2]]
        };
        self.set_span_and_mean(xyz(lo), xyz(hi), xyz(sum), keep.len())
    }
}

/// Triangles tested together by the AVX2 kernel: one per f64 lane of a 256-bit register.
pub(super) const BATCH: usize = 4;

/// `kernel::uncertain_triangles` with AVX2 + FMA, four triangles per register (one per f64
/// lane).
///
/// Each lane holds a triangle's normal `n = (b−a)×(c−a)` built as in `Plane::new` (same
/// operations, same order, no FMA) and the threshold `thr = fl(fl(n·a) − bound)`; a point `q`
/// is certified strictly below when `fl(n·q) < thr`, i.e. one product, two FMAs and a
/// comparison per (point, triangle) — no per-pair subtraction of `a`.
///
/// Error bound (`u = 2⁻⁵³`, `N` the exact normal of the exact differences, `m` and `ext` as in
/// `Plane`, `Q` the largest |coordinate| per axis): the exact side value is
/// `T = N·(q−a) = (N−n)·(q−a) + n·q − n·a`. `|N−n|·|q−a| ≤ γ₄·Σ m_k·ext_k` (two roundings in
/// each difference, one in each product, one in the subtraction); a 3-term dot product has at
/// most 3 roundings per term, with or without FMA, so `fl(n·q)` and `fl(n·a)` are each within
/// `γ₃·(1+u)·Σ m_k·Q_k` of `n·q` and `n·a`; forming `thr` costs at most `u·(|n·a| + bound)`.
/// So `fl(n·q) < thr` implies `T < −bound·(1−u) + γ₄·Σ m_k·ext_k + 2γ₃(1+u)·Σ m_k·Q_k +
/// u·(1+γ₃)(1+u)·Σ m_k·Q_k`, which is negative for `bound = ERR·Σ m_k·(ext_k + 2·Q_k) + TINY`
/// (`ERR = 2e-15` is more than 3× the ≈ 6e-16 these terms need). The vertex `a` itself gives
/// `fl(n·a) ≥ thr` exactly (same operations, `thr ≤ fl(n·a)` by monotone rounding), `b` and
/// `c` have `T = 0` so never pass; a triangle passes when exactly 3 points fail the test.
/// Lanes past the end of `tris` repeat its last triangle and are not reported.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
pub(super) fn uncertain_triangles_avx2(
    soa: &Soa,
    tris: &[[u32; 3]],
    uncertain: &mut Vec<u32>,
    six: &mut Vec<f64>,
) {
    use std::arch::x86_64::*;
    let span = soa.span;
    let reach = [0, 1, 2].map(|k| span.ext[k] + 2.0 * span.abs_max[k]);
    let (ox, oy, oz) =
        (_mm256_set1_pd(soa.mean[0]), _mm256_set1_pd(soa.mean[1]), _mm256_set1_pd(soa.mean[2]));
    // Whole batches of lanes are stored; the padding lanes are cut off at the end.
    // (Every entry is overwritten below, so only a longer tail needs filling.)
    six.resize(tris.len().next_multiple_of(BATCH), 0.0);
    let (rx, ry, rz) =
        (_mm256_set1_pd(reach[0]), _mm256_set1_pd(reach[1]), _mm256_set1_pd(reach[2]));
    let (err, tiny) = (_mm256_set1_pd(ERR), _mm256_set1_pd(TINY));
    let abs = _mm256_castsi256_pd(_mm256_set1_epi64x(i64::MAX));
    let three = _mm256_set1_epi64x(3);
    let wide = &soa.wide;
    // Every vertex index in range, checked once (a vectorised max) so the gathers below need no
    // per-load bounds check; and every byte offset (index × 96, below) fits in a u32.
    assert!(
        tris.as_flattened().iter().fold(0, |m, &i| m.max(i)) < wide.len() as u32 || tris.is_empty()
    );
    assert!(wide.len() < (u32::MAX / 96) as usize && std::mem::size_of::<[[f64; 4]; 3]>() == 96);
    // Full batches, then the last partial one padded with copies of its last triangle.
    let (full, rest) = tris.as_chunks::<BATCH>();
    let padded =
        rest.last().map(|&l| std::array::from_fn::<_, BATCH, _>(|k| *rest.get(k).unwrap_or(&l)));
    for (c, t) in full.iter().chain(padded.as_ref()).enumerate() {
        let in_batch = (tris.len() - c * BATCH).min(BATCH);
        // The byte offsets in `wide` of the batch's 12 vertices (index × 96 = (i << 6) + (i << 5)),
        // scaled in two registers rather than one multiply per vertex.
        let mut offsets = [0u32; 3 * BATCH];
        // SAFETY: `t` is 12 u32 = 48 bytes: a 32-byte load from its start and a 16-byte load
        // from byte 32; `offsets` has the same size (unaligned stores).
        unsafe {
            let (lo, hi) = (
                _mm256_loadu_si256(t.as_ptr().cast()),
                _mm_loadu_si128(t.as_ptr().cast::<u32>().add(8).cast()),
            );
            let lo = _mm256_add_epi32(_mm256_slli_epi32::<6>(lo), _mm256_slli_epi32::<5>(lo));
            let hi = _mm_add_epi32(_mm_slli_epi32::<6>(hi), _mm_slli_epi32::<5>(hi));
            _mm256_storeu_si256(offsets.as_mut_ptr().cast(), lo);
            _mm_storeu_si128(offsets.as_mut_ptr().add(8).cast(), hi);
        }
        let base = wide.as_ptr().cast::<u8>();
        // Coordinate d of vertex j of each lane's triangle: lane k is blended in from the
        // 4-lane copy of that vertex's coordinate.
        macro_rules! lanes {
            ($j:expr, $d:expr) => {{
                // SAFETY: every vertex index is < `wide.len()` (asserted above), so each offset
                // plus 32·d addresses the `[f64; 4]` of coordinate d of a point (unaligned
                // 32-byte loads).
                unsafe {
                    let at = |k: usize| {
                        _mm256_loadu_pd(base.add(offsets[3 * k + $j] as usize + 32 * $d).cast())
                    };
                    let v = _mm256_blend_pd::<0b0010>(at(0), at(1));
                    let v = _mm256_blend_pd::<0b0100>(v, at(2));
                    _mm256_blend_pd::<0b1000>(v, at(3))
                }
            }};
        }
        let (ax, ay, az) = (lanes!(0, 0), lanes!(0, 1), lanes!(0, 2));
        let (d1x, d1y, d1z) = (
            _mm256_sub_pd(lanes!(1, 0), ax),
            _mm256_sub_pd(lanes!(1, 1), ay),
            _mm256_sub_pd(lanes!(1, 2), az),
        );
        let (d2x, d2y, d2z) = (
            _mm256_sub_pd(lanes!(2, 0), ax),
            _mm256_sub_pd(lanes!(2, 1), ay),
            _mm256_sub_pd(lanes!(2, 2), az),
        );
        let (p1, p2) = (_mm256_mul_pd(d1y, d2z), _mm256_mul_pd(d1z, d2y));
        let (p3, p4) = (_mm256_mul_pd(d1z, d2x), _mm256_mul_pd(d1x, d2z));
        let (p5, p6) = (_mm256_mul_pd(d1x, d2y), _mm256_mul_pd(d1y, d2x));
        let (nx, ny, nz) = (_mm256_sub_pd(p1, p2), _mm256_sub_pd(p3, p4), _mm256_sub_pd(p5, p6));
        let mx = _mm256_add_pd(_mm256_and_pd(p1, abs), _mm256_and_pd(p2, abs));
        let my = _mm256_add_pd(_mm256_and_pd(p3, abs), _mm256_and_pd(p4, abs));
        let mz = _mm256_add_pd(_mm256_and_pd(p5, abs), _mm256_and_pd(p6, abs));
        let sum = _mm256_fmadd_pd(mz, rz, _mm256_fmadd_pd(my, ry, _mm256_mul_pd(mx, rx)));
        let bound = _mm256_fmadd_pd(err, sum, tiny);
        // n·a with exactly the operations used for n·q below, so the vertex a compares equal.
        let na = _mm256_fmadd_pd(nz, az, _mm256_fmadd_pd(ny, ay, _mm256_mul_pd(nx, ax)));
        let thr = _mm256_sub_pd(na, bound);
        // n·(a − o), per lane.
        let six_lanes = _mm256_fmadd_pd(
            nz,
            _mm256_sub_pd(az, oz),
            _mm256_fmadd_pd(ny, _mm256_sub_pd(ay, oy), _mm256_mul_pd(nx, _mm256_sub_pd(ax, ox))),
        );
        // SAFETY: `six` has a whole batch of lanes from `c·BATCH` on (resized above).
        unsafe { _mm256_storeu_pd(six[c * BATCH..c * BATCH + BATCH].as_mut_ptr(), six_lanes) };
        // `fl(n·q) ≥ thr` per lane, as all ones (−1) or 0. Ordered comparison: a NaN plane fails
        // it, so its triangle is never passed here.
        let not_below_mask = |w: &[[f64; 4]; 3]| {
            // SAFETY: each pointer addresses a `[f64; 4]` (unaligned 32-byte loads).
            let (x, y, z) = unsafe {
                (
                    _mm256_loadu_pd(w[0].as_ptr()),
                    _mm256_loadu_pd(w[1].as_ptr()),
                    _mm256_loadu_pd(w[2].as_ptr()),
                )
            };
            let nq = _mm256_fmadd_pd(nz, z, _mm256_fmadd_pd(ny, y, _mm256_mul_pd(nx, x)));
            _mm256_castpd_si256(_mm256_cmp_pd::<_CMP_GE_OQ>(nq, thr))
        };
        // Four points per step (one loop overhead per four); subtracting the masks counts.
        let mut not_below = _mm256_setzero_si256();
        let mut quads = wide.chunks_exact(4);
        for w in &mut quads {
            let pair0 = _mm256_add_epi64(not_below_mask(&w[0]), not_below_mask(&w[1]));
            let pair1 = _mm256_add_epi64(not_below_mask(&w[2]), not_below_mask(&w[3]));
            not_below = _mm256_sub_epi64(not_below, _mm256_add_epi64(pair0, pair1));
        }
        for w in quads.remainder() {
            not_below = _mm256_sub_epi64(not_below, not_below_mask(w));
        }
        let bad =
            _mm256_movemask_pd(_mm256_castsi256_pd(_mm256_cmpeq_epi64(not_below, three))) ^ 0b1111;
        let mut bad = (bad as u32) & ((1 << in_batch) - 1);
        while bad != 0 {
            uncertain.push((c * BATCH) as u32 + bad.trailing_zeros());
            bad &= bad - 1;
        }
    }
    six.truncate(tris.len());
}
