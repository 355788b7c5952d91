//! The two-stage matcher's cost passes with the markers in SIMD lanes: eight markers' DPs
//! advance together, one marker per lane of a 512-bit register (or two 256-bit ones).
//!
//! The recurrences are those of [`crate::dp`] (forward subsequence pass, backward pass anchored
//! at `b`), with the euclidean local distance computed inside the sweep (no distance row is
//! written and read back). Each lane performs exactly the operations of the scalar kernel in
//! the same order — `dx·dx + dy·dy + dz·dz` without fused multiply-add, an exactly rounded
//! square root, `d + min(min(up, diag), left)` with `min(a, b) = if a < b { a } else { b }`
//! (what `minpd` computes) — so every cost is bit-for-bit the scalar kernel's, at every
//! instruction-set level ([`crate::simd::Level`]).
//!
//! ## Layout
//!
//! [`MarkerBlocks`]: markers in blocks of eight; per block and frame one [`Frame8`] (x, y, z,
//! each eight lanes, 64-byte aligned), frames contiguous, so a DP row streams one block's
//! frames in order. A block of fewer than eight markers repeats its first marker in the spare
//! lanes (finite numbers whose results are ignored).
//!
//! ## Paths without a third pass
//!
//! The backward pass can record, per cell and lane, which successor the path walk would take
//! (diagonal, model step or target step, ties in that order): the three successors are exactly
//! the three costs the cell's `min` reads. The cells of columns `≥ a` never read columns `< a`,
//! so these decisions are the ones [`crate::dp::anchored_path`] takes on its restricted matrix,
//! and each marker's path over `[a, b]` is then a walk of `n + b − a` steps.
//!
//! ## The square root (AVX-512 level)
//!
//! `vsqrtpd` is the slowest instruction in a cell (≈ 2.9 cycles per lane here, more than the
//! rest of the cell). The AVX-512 level instead refines `vrsqrt14pd` (relative error < 2⁻¹⁴) by
//! two Goldschmidt iterations and one Markstein step (fused multiply-adds), then *proves* per
//! lane that the result `y` is the correctly rounded `√x`, falling back to `vsqrtpd` for the
//! register when any lane is not proven. The proof: with `r = fma(−y, y, x)` and `u⁻` the gap
//! from `y` down to the previous double, `|r| < y·u⁻` implies `y = RN(√x)`. (`x − y²` is a
//! multiple of `ulp(y)²`, exactly representable below `2⁵³·ulp(y)² > y·u⁻`, so `r` is exact
//! whenever the test can pass; `y` is correct iff `−y·u⁻ < r ≤ y·ulp(y)` up to terms far below
//! the precision of those products, and `u⁻ ≤ ulp(y)`.) Inputs below `2⁻⁹⁰⁰` (where `y·u⁻`
//! would be subnormal), zero, infinite or NaN take the fallback.

use crate::dp::Trajectory3;
use crate::simd::Level;

/// Markers per block: the lanes of one 512-bit register of `f64`.
pub const LANES: usize = 8;

/// One value per lane.
pub type Lanes = [f64; LANES];

/// A DP cell of a block: eight markers' accumulated costs (mm), one cache line.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(64))]
pub struct Cell8(pub Lanes);

/// One frame of a block of eight markers (mm).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(64))]
pub struct Frame8 {
    pub x: Lanes,
    pub y: Lanes,
    pub z: Lanes,
}

/// Per-marker trajectories regrouped eight markers to a block, frames contiguous per block.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MarkerBlocks {
    markers: usize,
    frames: usize,
    /// `blocks[k][j]`: markers `8k .. 8k+8` at frame `j`.
    blocks: Vec<Vec<Frame8>>,
}

impl MarkerBlocks {
    /// Regroups trajectories of equal length; None when there are none or lengths differ.
    pub fn gather(trajectories: &[Trajectory3]) -> Option<Self> {
        let first = trajectories.first()?;
        let frames = first.len();
        if trajectories.iter().any(|t| t.len() != frames) {
            return None;
        }
        let blocks = trajectories
            .chunks(LANES)
            .map(|group| {
                let lane = |l: usize| group.get(l).unwrap_or(&group[0]);
                (0..frames)
                    .map(|j| Frame8 {
                        x: std::array::from_fn(|l| lane(l).x[j]),
                        y: std::array::from_fn(|l| lane(l).y[j]),
                        z: std::array::from_fn(|l| lane(l).z[j]),
                    })
                    .collect()
            })
            .collect();
        Some(MarkerBlocks { markers: trajectories.len(), frames, blocks })
    }
    pub fn markers(&self) -> usize {
        self.markers
    }
    pub fn frames(&self) -> usize {
        self.frames
    }
    /// Block `k`'s frames.
    pub fn block(&self, k: usize) -> &[Frame8] {
        &self.blocks[k]
    }
    pub fn block_count(&self) -> usize {
        self.blocks.len()
    }
    /// How many lanes of block `k` hold real markers.
    pub fn used(&self, k: usize) -> usize {
        (self.markers - k * LANES).min(LANES)
    }
}

/// The path decisions of one backward-pass cell, one bit per lane: `diagonal` when the
/// diagonal successor is the least (ties included), else `model_step` when the model step is
/// not more than the target step, else the target step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Step8 {
    pub diagonal: u8,
    pub model_step: u8,
}

// ---------------------------------------------------------------------------------------------
// Lane arithmetic, one implementation per level
// ---------------------------------------------------------------------------------------------

/// Eight `f64` lanes and the operations a cell needs. Implementations must compute exactly the
/// IEEE operation named, lane by lane.
trait Vector: Copy {
    fn load(l: &Lanes) -> Self;
    fn store(self, l: &mut Lanes);
    fn zero() -> Self;
    fn add(self, o: Self) -> Self;
    fn sub(self, o: Self) -> Self;
    fn mul(self, o: Self) -> Self;
    /// `if self < o { self } else { o }` per lane.
    fn min(self, o: Self) -> Self;
    /// The exactly rounded square root.
    fn sqrt(self) -> Self;
    /// Bit `l` set when `self[l] <= o[l]`.
    fn le(self, o: Self) -> u8;
}

/// Plain arrays: LLVM turns each lane loop into packed instructions of the enabled target.
#[derive(Clone, Copy)]
struct Portable(Lanes);

impl Vector for Portable {
    #[inline(always)]
    fn load(l: &Lanes) -> Self {
        Portable(*l)
    }
    #[inline(always)]
    fn store(self, l: &mut Lanes) {
        *l = self.0;
    }
    #[inline(always)]
    fn zero() -> Self {
        Portable([0.0; LANES])
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Portable(std::array::from_fn(|l| self.0[l] + o.0[l]))
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Portable(std::array::from_fn(|l| self.0[l] - o.0[l]))
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        Portable(std::array::from_fn(|l| self.0[l] * o.0[l]))
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        Portable(std::array::from_fn(|l| if self.0[l] < o.0[l] { self.0[l] } else { o.0[l] }))
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        Portable(std::array::from_fn(|l| self.0[l].sqrt()))
    }
    #[inline(always)]
    fn le(self, o: Self) -> u8 {
        (0..LANES).fold(0u8, |bits, l| bits | (u8::from(self.0[l] <= o.0[l]) << l))
    }
}

#[cfg(target_arch = "x86_64")]
mod avx512 {
    use std::arch::x86_64::*;

    use super::{LANES, Lanes, Vector};

    /// One `zmm` register. Only constructed inside the `#[target_feature(enable = "avx512f")]`
    /// kernels, which run after the CPU was found to have AVX-512F.
    #[derive(Clone, Copy)]
    pub(super) struct Zmm(__m512d);

    // SAFETY (every `unsafe` block below): the methods are inlined into the AVX-512F kernels
    // only, which `crate::simd::level` lets run on CPUs with AVX-512F; the loads and stores
    // read and write one `[f64; 8]` through a reference.
    impl Vector for Zmm {
        #[inline(always)]
        fn load(l: &Lanes) -> Self {
            unsafe { Zmm(_mm512_loadu_pd(l.as_ptr())) }
        }
        #[inline(always)]
        fn store(self, l: &mut Lanes) {
            unsafe { _mm512_storeu_pd(l.as_mut_ptr(), self.0) }
        }
        #[inline(always)]
        fn zero() -> Self {
            unsafe { Zmm(_mm512_setzero_pd()) }
        }
        #[inline(always)]
        fn add(self, o: Self) -> Self {
            unsafe { Zmm(_mm512_add_pd(self.0, o.0)) }
        }
        #[inline(always)]
        fn sub(self, o: Self) -> Self {
            unsafe { Zmm(_mm512_sub_pd(self.0, o.0)) }
        }
        #[inline(always)]
        fn mul(self, o: Self) -> Self {
            unsafe { Zmm(_mm512_mul_pd(self.0, o.0)) }
        }
        #[inline(always)]
        fn min(self, o: Self) -> Self {
            // vminpd dst = (a < b) ? a : b, the scalar kernel's min2.
            unsafe { Zmm(_mm512_min_pd(self.0, o.0)) }
        }
        #[inline(always)]
        fn sqrt(self) -> Self {
            unsafe { Zmm(exact_sqrt(self.0)) }
        }
        #[inline(always)]
        fn le(self, o: Self) -> u8 {
            unsafe { _mm512_cmp_pd_mask::<_CMP_LE_OQ>(self.0, o.0) }
        }
    }

    /// `√x` exactly rounded, from `vrsqrt14pd` refined and proven per lane (module docs), with
    /// `vsqrtpd` for the register when a lane is not proven.
    #[inline(always)]
    unsafe fn exact_sqrt(x: __m512d) -> __m512d {
        unsafe {
            let half = _mm512_set1_pd(0.5);
            let r = _mm512_rsqrt14_pd(x);
            // Goldschmidt: y → √x, h → 1/(2√x), each iteration squares the relative error.
            let mut y = _mm512_mul_pd(x, r);
            let mut h = _mm512_mul_pd(half, r);
            for _ in 0..2 {
                let e = _mm512_fnmadd_pd(y, h, half);
                y = _mm512_fmadd_pd(y, e, y);
                h = _mm512_fmadd_pd(h, e, h);
            }
            // Markstein's final step: almost always the correctly rounded value already.
            let d = _mm512_fnmadd_pd(y, y, x);
            y = _mm512_fmadd_pd(d, h, y);
            // Proof per lane: |x − y²| < y·(y − pred(y)), x in the range where that is exact.
            let rem = _mm512_fnmadd_pd(y, y, x);
            let pred =
                _mm512_castsi512_pd(_mm512_sub_epi64(_mm512_castpd_si512(y), _mm512_set1_epi64(1)));
            let gap_below = _mm512_sub_pd(y, pred);
            let bound = _mm512_mul_pd(y, gap_below);
            let abs_rem = _mm512_abs_pd(rem);
            let in_range = _mm512_cmp_pd_mask::<_CMP_GE_OQ>(
                x,
                _mm512_set1_pd(f64::from_bits(0x07B0_0000_0000_0000)),
            );
            let proven = _mm512_mask_cmp_pd_mask::<_CMP_LT_OQ>(in_range, abs_rem, bound);
            if proven == u8::MAX { y } else { _mm512_mask_sqrt_pd(y, !proven, x) }
        }
    }

    const _: () = assert!(LANES == 8);
}

// ---------------------------------------------------------------------------------------------
// The kernels, generic over the lane arithmetic
// ---------------------------------------------------------------------------------------------

/// The model frame's coordinates, loaded once per DP row.
#[inline(always)]
fn model_frame<V: Vector>(s: &Frame8) -> (V, V, V) {
    (V::load(&s.x), V::load(&s.y), V::load(&s.z))
}

/// `|s − t|` per lane, in the scalar kernel's order: `(dx·dx + dy·dy) + dz·dz`, then `√`.
#[inline(always)]
fn distance<V: Vector>(s: (V, V, V), t: &Frame8) -> V {
    let dx = s.0.sub(V::load(&t.x));
    let dy = s.1.sub(V::load(&t.y));
    let dz = s.2.sub(V::load(&t.z));
    dx.mul(dx).add(dy.mul(dy)).add(dz.mul(dz)).sqrt()
}

/// Forward subsequence pass of one block: on return `g[j]` is `h(j) = g(n−1, j)` per lane.
/// `g.len() == target.len()`; both sequences nonempty (checked by the caller).
#[inline(always)]
fn forward_block<V: Vector>(model: &[Frame8], target: &[Frame8], g: &mut [Cell8]) {
    let Some((s0, rows)) = model.split_first() else { return };
    let s = model_frame::<V>(s0);
    // Row 0: free start.
    for (gj, t) in g.iter_mut().zip(target) {
        distance(s, t).store(&mut gj.0);
    }
    let Some((t0, target_rest)) = target.split_first() else { return };
    for si in rows {
        let s = model_frame::<V>(si);
        let Some((g0, g_rest)) = g.split_first_mut() else { return };
        // First column accumulates down the model; then only `left` chains along the row.
        let mut diag = V::load(&g0.0);
        let mut left = distance(s, t0).add(diag);
        left.store(&mut g0.0);
        for (gj, t) in g_rest.iter_mut().zip(target_rest) {
            let up = V::load(&gj.0);
            let v = distance(s, t).add(up.min(diag).min(left));
            diag = up;
            v.store(&mut gj.0);
            left = v;
        }
    }
}

/// Backward pass of one block anchored at the last frame of `target` (`target = T[0..=b]`): on
/// return `c[a]` is the cost of matching the whole model to `T[a..=b]`, per lane. With
/// `STEPS`, `steps[i·w + j]` (`w = b + 1`, `i < n − 1`, `j < b`) receives the path decisions.
#[inline(always)]
fn backward_block<V: Vector, const STEPS: bool>(
    model: &[Frame8],
    target: &[Frame8],
    c: &mut [Cell8],
    steps: &mut [Step8],
) {
    let w = target.len();
    let Some((s_last, rows)) = model.split_last() else { return };
    let s = model_frame::<V>(s_last);
    // The model's last frame accumulates leftwards from b.
    let mut acc = V::zero();
    for (cj, t) in c.iter_mut().zip(target).rev() {
        acc = acc.add(distance(s, t));
        acc.store(&mut cj.0);
    }
    let Some((tb, target_rest)) = target.split_last() else { return };
    for (i, si) in rows.iter().enumerate().rev() {
        let s = model_frame::<V>(si);
        let Some((cb, c_rest)) = c.split_last_mut() else { return };
        let mut diag = V::load(&cb.0);
        let mut right = distance(s, tb).add(diag);
        right.store(&mut cb.0);
        if STEPS {
            let row = &mut steps[i * w..(i + 1) * w - 1];
            for ((cj, t), step) in
                c_rest.iter_mut().rev().zip(target_rest.iter().rev()).zip(row.iter_mut().rev())
            {
                let down = V::load(&cj.0);
                *step =
                    Step8 { diagonal: diag.le(down) & diag.le(right), model_step: down.le(right) };
                let v = distance(s, t).add(down.min(diag).min(right));
                diag = down;
                v.store(&mut cj.0);
                right = v;
            }
        } else {
            for (cj, t) in c_rest.iter_mut().rev().zip(target_rest.iter().rev()) {
                let down = V::load(&cj.0);
                let v = distance(s, t).add(down.min(diag).min(right));
                diag = down;
                v.store(&mut cj.0);
                right = v;
            }
        }
    }
}

/// The cost of matching the whole model to the single target frame `j`, for every `j`, per
/// lane: `c[j] = d(0, j) + (d(1, j) + (… + (0 + d(n−1, j))))`, the model's frames taken from
/// the last, as [`backward_block`] accumulates its last column. So `c[b]` is bit for bit the
/// backward pass's cost of the start `a = b` when anchored at `b` (the path down column `b`).
#[inline(always)]
fn column_block<V: Vector>(model: &[Frame8], target: &[Frame8], c: &mut [Cell8]) {
    let Some((s_last, rows)) = model.split_last() else { return };
    let s = model_frame::<V>(s_last);
    for (cj, t) in c.iter_mut().zip(target) {
        V::zero().add(distance(s, t)).store(&mut cj.0);
    }
    for si in rows.iter().rev() {
        let s = model_frame::<V>(si);
        for (cj, t) in c.iter_mut().zip(target) {
            distance(s, t).add(V::load(&cj.0)).store(&mut cj.0);
        }
    }
}

/// The cost of the lockstep path ending at target frame `b` — model frame `i` matched to
/// target frame `b − (n − 1 − i)` — for every `b ≥ n − 1`, per lane, added as the backward pass
/// adds along that path: `c[b] = d(0, b−n+1) + (d(1, b−n+2) + (… + (0 + d(n−1, b))))`. So the
/// backward pass anchored at `b` computes a cost `≤ c[b]` for the start `b − n + 1` (its cells
/// are minima over paths of these sums, and the float addition of non-negative numbers is
/// monotone). `c[b]` for `b < n − 1` (no such path) is left `+∞`.
#[inline(always)]
fn diagonal_block<V: Vector>(model: &[Frame8], target: &[Frame8], c: &mut [Cell8]) {
    let n = model.len();
    for (b, cb) in c.iter_mut().enumerate() {
        if b + 1 < n {
            *cb = Cell8([f64::INFINITY; LANES]);
            continue;
        }
        let start = b + 1 - n;
        let mut acc = V::zero();
        for (si, t) in model.iter().zip(&target[start..=b]).rev() {
            acc = distance(model_frame::<V>(si), t).add(acc);
        }
        acc.store(&mut cb.0);
    }
}

/// A pass over one block that sums the cost of one fixed path per target frame (the bounds of
/// [`crate::retrieval`]), generic over the lane arithmetic so one dispatch serves each.
trait PathPass {
    fn run<V: Vector>(model: &[Frame8], target: &[Frame8], c: &mut [Cell8]);
}

/// [`column_block`].
struct Column;
/// [`diagonal_block`].
struct Diagonal;

impl PathPass for Column {
    #[inline(always)]
    fn run<V: Vector>(model: &[Frame8], target: &[Frame8], c: &mut [Cell8]) {
        column_block::<V>(model, target, c)
    }
}

impl PathPass for Diagonal {
    #[inline(always)]
    fn run<V: Vector>(model: &[Frame8], target: &[Frame8], c: &mut [Cell8]) {
        diagonal_block::<V>(model, target, c)
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn path_pass_avx512<P: PathPass>(model: &[Frame8], target: &[Frame8], c: &mut [Cell8]) {
    P::run::<avx512::Zmm>(model, target, c)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn path_pass_avx2<P: PathPass>(model: &[Frame8], target: &[Frame8], c: &mut [Cell8]) {
    P::run::<Portable>(model, target, c)
}

/// A [`PathPass`] at the given level: `c` is resized to `target.len()` (empty model: `c` left
/// empty).
fn path_pass<P: PathPass>(level: Level, model: &[Frame8], target: &[Frame8], c: &mut Vec<Cell8>) {
    c.clear();
    if model.is_empty() {
        return;
    }
    c.resize(target.len(), Cell8::default());
    match level {
        // SAFETY: `level` comes from `crate::simd::level`, which detected the feature.
        #[cfg(target_arch = "x86_64")]
        Level::Avx512 => unsafe { path_pass_avx512::<P>(model, target, c) },
        #[cfg(target_arch = "x86_64")]
        Level::Avx2 => unsafe { path_pass_avx2::<P>(model, target, c) },
        _ => P::run::<Portable>(model, target, c),
    }
}

/// [`column_block`] at the given level, per lane, into `c` (resized to `target.len()`).
pub(crate) fn column(level: Level, model: &[Frame8], target: &[Frame8], c: &mut Vec<Cell8>) {
    path_pass::<Column>(level, model, target, c)
}

/// [`diagonal_block`] at the given level, per lane, into `c` (resized to `target.len()`).
pub(crate) fn diagonal(level: Level, model: &[Frame8], target: &[Frame8], c: &mut Vec<Cell8>) {
    path_pass::<Diagonal>(level, model, target, c)
}

#[cfg(all(test, target_arch = "x86_64"))]
#[target_feature(enable = "avx512f")]
unsafe fn sqrt_avx512(x: &Lanes) -> Lanes {
    let mut out = [0.0; LANES];
    avx512::Zmm::load(x).sqrt().store(&mut out);
    out
}

// One compiled copy per level. SAFETY of the `unsafe fn`s: callers check the CPU's features
// (`crate::simd::level`) before calling.

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn forward_avx512(model: &[Frame8], target: &[Frame8], g: &mut [Cell8]) {
    forward_block::<avx512::Zmm>(model, target, g)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn forward_avx2(model: &[Frame8], target: &[Frame8], g: &mut [Cell8]) {
    forward_block::<Portable>(model, target, g)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn backward_avx512<const STEPS: bool>(
    model: &[Frame8],
    target: &[Frame8],
    c: &mut [Cell8],
    steps: &mut [Step8],
) {
    backward_block::<avx512::Zmm, STEPS>(model, target, c, steps)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn backward_avx2<const STEPS: bool>(
    model: &[Frame8],
    target: &[Frame8],
    c: &mut [Cell8],
    steps: &mut [Step8],
) {
    backward_block::<Portable, STEPS>(model, target, c, steps)
}

/// Forward pass of one block at the given level: `g` is resized to `target.len()` and holds
/// `h(j)` per lane on return. Empty model or target: `g` is left empty.
pub(crate) fn forward(level: Level, model: &[Frame8], target: &[Frame8], g: &mut Vec<Cell8>) {
    g.clear();
    if model.is_empty() {
        return;
    }
    g.resize(target.len(), Cell8::default());
    match level {
        // SAFETY: `level` comes from `crate::simd::level`, which detected the feature.
        #[cfg(target_arch = "x86_64")]
        Level::Avx512 => unsafe { forward_avx512(model, target, g) },
        #[cfg(target_arch = "x86_64")]
        Level::Avx2 => unsafe { forward_avx2(model, target, g) },
        _ => forward_block::<Portable>(model, target, g),
    }
}

/// Backward pass of one block anchored at the last frame of `target` (pass `T[0..=b]`): `c` is
/// resized to `b + 1`; with `steps` given, it is resized to `n·(b+1)` and receives the path
/// decisions (read them with [`walk`]).
pub(crate) fn backward(
    level: Level,
    model: &[Frame8],
    target: &[Frame8],
    c: &mut Vec<Cell8>,
    steps: Option<&mut Vec<Step8>>,
) {
    c.clear();
    if model.is_empty() || target.is_empty() {
        return;
    }
    c.resize(target.len(), Cell8::default());
    let keep = steps.is_some();
    let mut none = Vec::new();
    let steps = steps.unwrap_or(&mut none);
    steps.clear();
    if keep {
        steps.resize(model.len() * target.len(), Step8::default());
    }
    match (level, keep) {
        // SAFETY: `level` comes from `crate::simd::level`, which detected the feature.
        #[cfg(target_arch = "x86_64")]
        (Level::Avx512, true) => unsafe { backward_avx512::<true>(model, target, c, steps) },
        #[cfg(target_arch = "x86_64")]
        (Level::Avx512, false) => unsafe { backward_avx512::<false>(model, target, c, steps) },
        #[cfg(target_arch = "x86_64")]
        (Level::Avx2, true) => unsafe { backward_avx2::<true>(model, target, c, steps) },
        #[cfg(target_arch = "x86_64")]
        (Level::Avx2, false) => unsafe { backward_avx2::<false>(model, target, c, steps) },
        (_, true) => backward_block::<Portable, true>(model, target, c, steps),
        (_, false) => backward_block::<Portable, false>(model, target, c, steps),
    }
}

/// Lane `lane`'s warping path from `(0, start)` to `(n−1, end)` by the decisions `steps` of a
/// [`backward`] pass over `T[0..=end]` (`n` model frames): the path
/// [`crate::dp::anchored_path`] returns, pair for pair.
pub(crate) fn walk(
    steps: &[Step8],
    n: usize,
    start: usize,
    end: usize,
    lane: usize,
) -> Vec<(usize, usize)> {
    let (w, bit) = (end + 1, 1u8 << lane);
    let mut path = Vec::with_capacity(n + end - start);
    let (mut i, mut j) = (0usize, start);
    path.push((i, j));
    while i + 1 < n || j < end {
        (i, j) = if i + 1 == n {
            (i, j + 1)
        } else if j == end {
            (i + 1, j)
        } else {
            let step = steps[i * w + j];
            if step.diagonal & bit != 0 {
                (i + 1, j + 1)
            } else if step.model_step & bit != 0 {
                (i + 1, j)
            } else {
                (i, j + 1)
            }
        };
        path.push((i, j));
    }
    path
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simd;
    use motionlab_testkit::Rng;

    /// Inputs where a square root is easy to get wrong: both sides of powers of two, exact
    /// squares and their neighbours, the ends of the range the fast path accepts, zero,
    /// subnormals, the largest double, infinity and NaN, plus random bit patterns.
    fn hard_inputs(rng: &mut Rng) -> Vec<f64> {
        let mut v = vec![
            0.0,
            -0.0,
            f64::MIN_POSITIVE,
            5e-324,
            f64::MAX,
            f64::INFINITY,
            f64::NAN,
            1.0,
            2.0,
            4.0,
        ];
        for e in -1060..1030 {
            let p = 2f64.powi(e);
            v.extend([p, p.next_up(), p.next_down()]);
        }
        for _ in 0..20_000 {
            let y = 1.0 + rng.uniform();
            let y = y * 2f64.powi((rng.next_u64() % 200) as i32 - 100);
            let sq = y * y;
            v.extend([sq, sq.next_up(), sq.next_down(), f64::from_bits(rng.next_u64() >> 1)]);
        }
        v
    }

    #[test]
    fn the_avx512_square_root_is_exactly_rounded() {
        if !simd::available().contains(&Level::Avx512) {
            return;
        }
        let mut rng = Rng::new(5);
        let inputs = hard_inputs(&mut rng);
        for chunk in inputs.chunks(LANES) {
            let mut x = [1.0; LANES];
            x[..chunk.len()].copy_from_slice(chunk);
            // SAFETY: AVX-512F was detected above.
            let got = unsafe { sqrt_avx512(&x) };
            for l in 0..LANES {
                let want = x[l].sqrt();
                assert!(
                    got[l].to_bits() == want.to_bits() || (got[l].is_nan() && want.is_nan()),
                    "√{:e}: {:e} vs {:e}",
                    x[l],
                    got[l],
                    want
                );
            }
        }
    }

    #[test]
    fn gather_pads_spare_lanes_and_refuses_unequal_lengths() {
        let a = Trajectory3::from_points(&[[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]);
        let b = Trajectory3::from_points(&[[7.0, 8.0, 9.0], [1.0, 1.0, 1.0]]);
        let blocks = MarkerBlocks::gather(
            &vec![a.clone(); 9].into_iter().chain([b.clone()]).collect::<Vec<_>>(),
        )
        .unwrap();
        assert_eq!((blocks.markers(), blocks.frames(), blocks.block_count()), (10, 2, 2));
        assert_eq!((blocks.used(0), blocks.used(1)), (8, 2));
        assert_eq!(blocks.block(1)[0].x, [1.0, 7.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0]);
        assert_eq!(blocks.block(1)[1].z, [6.0, 1.0, 6.0, 6.0, 6.0, 6.0, 6.0, 6.0]);
        let short = Trajectory3::from_points(&[[0.0; 3]]);
        assert!(MarkerBlocks::gather(&[a, short]).is_none());
        assert!(MarkerBlocks::gather(&[]).is_none());
    }
}
