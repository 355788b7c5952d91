//! The dynamic-programming kernels of Yabe & Tanaka §3.1, generic over the local distance.
//!
//! Three recurrences share one local distance `d(i, j)` between model frame `i` (`0..n`) and
//! target frame `j` (`0..m`), and one step set `{(i−1, j−1), (i−1, j), (i, j−1)}`:
//!
//! | kernel | start | end | result | memory |
//! |---|---|---|---|---|
//! | [`subsequence_costs`] | free (any `j` at `i = 0`) | free | `h(j) = g(n−1, j)` for every `j` | O(m) |
//! | [`subsequence_match`] | free | `argmin h` | cost, `[a, b]`, path | O(n·m) |
//! | [`anchored_costs`] | free | anchored at `b` | cost of every start `a ≤ b` | O(b) |
//! | [`anchored_path`] | `a` | `b` | cost, path | O(n·(b−a+1)) |
//! | [`dtw_full`] / [`dtw_full_cost`] | `(0, 0)` | `(n−1, m−1)` | cost (+ path) | O(n·m) / O(m) |
//!
//! ## Index mapping to the paper
//!
//! The paper is 1-based: `g(i, j)` with `1 ≤ i ≤ n`, `1 ≤ j ≤ m`. Here `g[i][j]` is the paper's
//! `g(i+1, j+1)`:
//!
//! - forward pass (§3.1.2): `g[0][j] = d(0, j)` (A: free start); `g[i][0] = d(i, 0) + g[i−1][0]`
//!   (B); `g[i][j] = d(i, j) + min(g[i−1][j], g[i−1][j−1], g[i][j−1])` (C); `h(j) = g[n−1][j]`.
//!   `h(j)` is the least cost of matching the whole model to a stretch of the target that ends
//!   at `j`; it equals `min over a ≤ j` of [`dtw_full`] of the model against `T[a..=j]`.
//! - backward pass (§3.1.3): the paper reverses both sequences from `b` (reversed element 1 is
//!   `s_n` and `t_b`; the paper writes `i' = n − i`, `j' = b − j`, one off in 1-based indexing)
//!   and makes the first reversed row cumulative. We run the same recurrence without copying
//!   reversed arrays: cell
//!   `G[i][j]` (original indices, `i` from `n−1` down to `0`, `j` from `b` down to `0`) is the
//!   paper's reversed `g(n−i, b−j+1)`, with `G[n−1][b] = d(n−1, b)`,
//!   `G[n−1][j] = d(n−1, j) + G[n−1][j+1]` (the cumulative first reversed row),
//!   `G[i][b] = d(i, b) + G[i+1][b]`, and
//!   `G[i][j] = d(i, j) + min(G[i+1][j], G[i+1][j+1], G[i][j+1])`. The additions happen in the
//!   paper's order, so the numbers are the ones the reversed formulation gives. `G[0][a]` is the
//!   cost of the best path from `(0, a)` to `(n−1, b)`, i.e. [`dtw_full`] of the model against
//!   `T[a..=b]`.
//!
//! ## Ties
//!
//! - [`subsequence_match`] takes the **earliest** end among equal costs ([`argmin_first`]);
//!   callers that want another rule scan the returned cost vectors (the two-stage matcher takes
//!   the latest start, see `multistream`).
//! - Paths: when several predecessors (or successors) hold the same accumulated cost, the
//!   diagonal step wins, then the step that advances the model (`i`), then the step that
//!   advances the target (`j`).
//!
//! ## Numbers
//!
//! The local distance must be finite and ≥ 0 (the matchers check their inputs are finite before
//! calling). Minima use `if a < b` comparisons, which compile to one `minsd` each; with a NaN
//! distance the result is unspecified but nothing panics.
//!
//! ## Speed
//!
//! The distance is computed a row at a time into a contiguous buffer ([`LocalDistance::row`]),
//! which for [`Euclidean3`] (structure-of-arrays coordinates) is a branch-free loop the compiler
//! vectorises, square roots included. The recurrence then runs over contiguous slices with
//! iterators (no bounds checks) and one rolling row updated in place, so no pass allocates per
//! cell and the cost-only passes keep O(m) memory. The two-stage matcher runs eight markers per
//! cell in SIMD lanes with the distance fused into the sweep ([`crate::lanes`]), bit-for-bit
//! the results of these kernels one marker at a time.

use motionlab_core::{Error, ErrorKind, Point3, Result};

// ---------------------------------------------------------------------------------------------
// Local distances
// ---------------------------------------------------------------------------------------------

/// What a DP cell holds: one cost (`f64`). (The two-stage matcher's markers-in-lanes kernels
/// are in [`crate::lanes`], with the recurrences written out for the lane registers.)
pub trait Cost: Copy + Default + PartialEq + std::fmt::Debug {
    /// `self + other`, lane-wise.
    fn plus(self, other: Self) -> Self;
    /// `min(self, other)`, lane-wise.
    fn least(self, other: Self) -> Self;
}

impl Cost for f64 {
    #[inline(always)]
    fn plus(self, other: f64) -> f64 {
        self + other
    }
    #[inline(always)]
    fn least(self, other: f64) -> f64 {
        min2(self, other)
    }
}

/// A local distance `d(i, j) ≥ 0` between model frame `i` and target frame `j`, produced a row
/// at a time so the kernels' inner loops run over contiguous memory.
pub trait LocalDistance {
    /// The cell type (`f64`).
    type Cost: Cost;
    /// `n`: number of model frames.
    fn model_len(&self) -> usize;
    /// `m`: number of target frames.
    fn target_len(&self) -> usize;
    /// Writes `d(i, j0 + k)` into `out[k]` for `k in 0..out.len()`.
    ///
    /// Callers guarantee `i < model_len()` and `j0 + out.len() <= target_len()`.
    fn row(&self, i: usize, j0: usize, out: &mut [Self::Cost]);
}

/// Any `Fn(i, j) -> f64` as a [`LocalDistance`] over an `n × m` grid.
#[derive(Clone, Copy, Debug)]
pub struct FnDistance<F> {
    n: usize,
    m: usize,
    f: F,
}

impl<F: Fn(usize, usize) -> f64> FnDistance<F> {
    pub fn new(n: usize, m: usize, f: F) -> Self {
        FnDistance { n, m, f }
    }
}

impl<F: Fn(usize, usize) -> f64> LocalDistance for FnDistance<F> {
    type Cost = f64;
    fn model_len(&self) -> usize {
        self.n
    }
    fn target_len(&self) -> usize {
        self.m
    }
    #[inline]
    fn row(&self, i: usize, j0: usize, out: &mut [f64]) {
        for (k, o) in out.iter_mut().enumerate() {
            *o = (self.f)(i, j0 + k);
        }
    }
}

/// A 3-D trajectory stored as structure of arrays (mm): one contiguous `Vec` per axis, so a
/// distance row is three streaming loads per target frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Trajectory3 {
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub z: Vec<f64>,
}

impl Trajectory3 {
    pub fn with_capacity(frames: usize) -> Self {
        Trajectory3 {
            x: Vec::with_capacity(frames),
            y: Vec::with_capacity(frames),
            z: Vec::with_capacity(frames),
        }
    }
    pub fn from_points(points: &[Point3]) -> Self {
        let mut t = Trajectory3::with_capacity(points.len());
        for p in points {
            t.push(*p);
        }
        t
    }
    pub fn push(&mut self, p: Point3) {
        self.x.push(p[0]);
        self.y.push(p[1]);
        self.z.push(p[2]);
    }
    pub fn len(&self) -> usize {
        self.x.len()
    }
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }
    pub fn point(&self, i: usize) -> Point3 {
        [self.x[i], self.y[i], self.z[i]]
    }
}

/// The paper's local distance: `d(i, j) = |s_i − t_j|`, the euclidean distance (mm) between
/// model sample `i` and target sample `j` of one marker.
#[derive(Clone, Copy, Debug)]
pub struct Euclidean3<'a> {
    pub model: &'a Trajectory3,
    pub target: &'a Trajectory3,
}

impl<'a> Euclidean3<'a> {
    pub fn new(model: &'a Trajectory3, target: &'a Trajectory3) -> Self {
        Euclidean3 { model, target }
    }
}

impl LocalDistance for Euclidean3<'_> {
    type Cost = f64;
    fn model_len(&self) -> usize {
        self.model.len()
    }
    fn target_len(&self) -> usize {
        self.target.len()
    }
    #[inline]
    fn row(&self, i: usize, j0: usize, out: &mut [f64]) {
        let (sx, sy, sz) = (self.model.x[i], self.model.y[i], self.model.z[i]);
        let end = j0 + out.len();
        let (tx, ty, tz) =
            (&self.target.x[j0..end], &self.target.y[j0..end], &self.target.z[j0..end]);
        // Zipped slices of equal length: no bounds checks, and LLVM vectorises the whole body
        // (sub, mul, add and sqrtpd) because nothing in it depends on the previous element.
        for (((o, &x), &y), &z) in out.iter_mut().zip(tx).zip(ty).zip(tz) {
            let (dx, dy, dz) = (sx - x, sy - y, sz - z);
            *o = (dx * dx + dy * dy + dz * dz).sqrt();
        }
    }
}

/// `|a_i − b_j|` between two 1-D series (a joint-angle curve, a speed profile).
#[derive(Clone, Copy, Debug)]
pub struct Absolute1<'a> {
    pub model: &'a [f64],
    pub target: &'a [f64],
}

impl LocalDistance for Absolute1<'_> {
    type Cost = f64;
    fn model_len(&self) -> usize {
        self.model.len()
    }
    fn target_len(&self) -> usize {
        self.target.len()
    }
    #[inline]
    fn row(&self, i: usize, j0: usize, out: &mut [f64]) {
        let s = self.model[i];
        let target = &self.target[j0..j0 + out.len()];
        for (o, &t) in out.iter_mut().zip(target) {
            *o = (s - t).abs();
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------------------------

/// `min(a, b)` as one `minsd`: unlike `f64::min` it does not special-case NaN, which would add
/// two instructions to the recurrence's critical path.
#[inline(always)]
fn min2(a: f64, b: f64) -> f64 {
    if a < b { a } else { b }
}

/// Index of the least value, the earliest among equal values; None for an empty slice or when
/// every value is NaN.
pub fn argmin_first(values: &[f64]) -> Option<usize> {
    let mut best: Option<(usize, f64)> = None;
    for (j, &v) in values.iter().enumerate() {
        // Strictly less: a later equal value never replaces an earlier one.
        if !v.is_nan() && best.is_none_or(|(_, b)| v < b) {
            best = Some((j, v));
        }
    }
    best.map(|(j, _)| j)
}

fn require_nonempty(d: &impl LocalDistance) -> Result<(usize, usize)> {
    let (n, m) = (d.model_len(), d.target_len());
    if n == 0 || m == 0 {
        let which = if n == 0 { "the model" } else { "the target" };
        return Err(Error::new(
            ErrorKind::EmptySequence,
            format!(
                "DP matching needs at least one frame in each sequence, but {which} has none (model {n}, target {m} frames)"
            ),
        ));
    }
    Ok((n, m))
}

/// Scratch buffers reused across calls so repeated matching (one call per marker) does not
/// reallocate; every kernel also has a convenience form that allocates its own.
#[derive(Clone, Debug, Default)]
pub struct Workspace<C = f64> {
    dist_row: Vec<C>,
    matrix: Vec<C>,
}

impl<C: Cost> Workspace<C> {
    pub fn new() -> Self {
        Workspace { dist_row: Vec::new(), matrix: Vec::new() }
    }
    fn row(&mut self, len: usize) -> &mut [C] {
        if self.dist_row.len() < len {
            self.dist_row.resize(len, C::default());
        }
        &mut self.dist_row[..len]
    }
}

// ---------------------------------------------------------------------------------------------
// Forward subsequence pass (free start, free end)
// ---------------------------------------------------------------------------------------------

/// The paper's forward pass: writes `h(j) = g(n−1, j)` for every target frame into `h`
/// (resized to `m`), keeping one rolling row (O(m) memory besides `h` itself).
pub fn subsequence_costs_into<D: LocalDistance>(
    d: &D,
    h: &mut Vec<D::Cost>,
    ws: &mut Workspace<D::Cost>,
) -> Result<()> {
    let (n, m) = require_nonempty(d)?;
    h.clear();
    h.resize(m, D::Cost::default());
    // Row 0 (A): g[0][j] = d(0, j) — the model may start at any target frame.
    d.row(0, 0, h);
    let drow = ws.row(m);
    for i in 1..n {
        d.row(i, 0, drow);
        forward_row_update(h, drow);
    }
    Ok(())
}

/// One row of the forward recurrence, in place: on entry `g` holds row `i−1`, on exit row `i`.
#[inline(always)]
fn forward_row_update<C: Cost>(g: &mut [C], drow: &[C]) {
    let Some((g0, rest)) = g.split_first_mut() else { return };
    let Some((&d0, drest)) = drow.split_first() else { return };
    // (B): the first column accumulates down the model.
    let mut diag = *g0;
    let mut left = d0.plus(diag);
    *g0 = left;
    // (C): `up` and `diag` come from row i−1 (off the critical path); only `left` chains.
    for (gj, &dj) in rest.iter_mut().zip(drest) {
        let up = *gj;
        let v = dj.plus(up.least(diag).least(left));
        diag = up;
        *gj = v;
        left = v;
    }
}

/// [`subsequence_costs_into`] with its own buffers.
pub fn subsequence_costs<D: LocalDistance>(d: &D) -> Result<Vec<D::Cost>> {
    let mut h = Vec::new();
    subsequence_costs_into(d, &mut h, &mut Workspace::new())?;
    Ok(h)
}

/// A stretch `[start, end]` of the target (inclusive, 0-based) matched to the whole model.
#[derive(Clone, Debug, PartialEq)]
pub struct SubsequenceMatch {
    /// `a`: first target frame matched (to model frame 0).
    pub start: usize,
    /// `b = argmin_j h(j)` (earliest among ties): last target frame matched (to model frame n−1).
    pub end: usize,
    /// `h(b)`: the summed local distance along the path.
    pub cost: f64,
    /// `(i, j)` pairs from `(0, start)` to `(n−1, end)`.
    pub path: Vec<(usize, usize)>,
    /// `h(j)` for every target frame (the last row of the matrix).
    pub end_costs: Vec<f64>,
}

/// The forward pass keeping the whole `n × m` matrix (O(n·m) memory), then the path by
/// backtracking from `(n−1, b)` until it reaches model frame 0 (the free start).
pub fn subsequence_match(
    d: &impl LocalDistance<Cost = f64>,
    ws: &mut Workspace,
) -> Result<SubsequenceMatch> {
    let (n, m) = require_nonempty(d)?;
    let mut g = std::mem::take(&mut ws.matrix);
    g.clear();
    g.resize(n * m, 0.0);
    d.row(0, 0, &mut g[..m]);
    let drow = ws.row(m);
    for i in 1..n {
        d.row(i, 0, drow);
        let (done, rest) = g.split_at_mut(i * m);
        let (prev, cur) = (&done[(i - 1) * m..], &mut rest[..m]);
        cur.copy_from_slice(prev);
        forward_row_update(cur, drow);
    }
    let end_costs = g[(n - 1) * m..].to_vec();
    let end = argmin_first(&end_costs).ok_or_else(non_finite_costs)?;
    let cost = end_costs[end];
    let at = |i: usize, j: usize| g[i * m + j];
    let mut path = Vec::with_capacity(n + m);
    let (mut i, mut j) = (n - 1, end);
    path.push((i, j));
    while i > 0 {
        (i, j) = if j == 0 {
            (i - 1, 0)
        } else {
            best_predecessor(at(i - 1, j - 1), at(i - 1, j), at(i, j - 1), i, j)
        };
        path.push((i, j));
    }
    path.reverse();
    ws.matrix = g;
    Ok(SubsequenceMatch { start: j, end, cost, path, end_costs })
}

/// Diagonal, then model step, then target step among equal accumulated costs.
#[inline]
fn best_predecessor(diag: f64, up: f64, left: f64, i: usize, j: usize) -> (usize, usize) {
    if diag <= up && diag <= left {
        (i - 1, j - 1)
    } else if up <= left {
        (i - 1, j)
    } else {
        (i, j - 1)
    }
}

fn non_finite_costs() -> Error {
    Error::new(
        ErrorKind::NonFinite,
        "every accumulated DP cost is NaN; the local distances must be finite numbers",
    )
}

// ---------------------------------------------------------------------------------------------
// Backward pass anchored at b (free start)
// ---------------------------------------------------------------------------------------------

fn check_end(d: &impl LocalDistance, end: usize) -> Result<(usize, usize)> {
    let (n, m) = require_nonempty(d)?;
    if end >= m {
        return Err(Error::new(
            ErrorKind::OutOfRange,
            format!("the anchored end b = {end} is outside the target's frames 0..{m}"),
        ));
    }
    Ok((n, m))
}

/// The paper's backward pass anchored at `end = b`: writes into `costs` (resized to `b+1`) the
/// cost `G[0][a]` of matching the whole model to `T[a..=b]` for every start `a ≤ b`, keeping one
/// rolling row (O(b) memory).
pub fn anchored_costs_into<D: LocalDistance>(
    d: &D,
    end: usize,
    costs: &mut Vec<D::Cost>,
    ws: &mut Workspace<D::Cost>,
) -> Result<()> {
    let (n, _) = check_end(d, end)?;
    let w = end + 1;
    costs.clear();
    costs.resize(w, D::Cost::default());
    // The model's last frame (the paper's first reversed row) accumulates leftwards from b.
    d.row(n - 1, 0, costs);
    accumulate(costs.iter_mut().rev());
    let drow = ws.row(w);
    for i in (0..n - 1).rev() {
        d.row(i, 0, drow);
        backward_row_update(costs, drow);
    }
    Ok(())
}

/// One row of the backward recurrence, in place: on entry `g` holds row `i+1`, on exit row `i`.
#[inline(always)]
fn backward_row_update<C: Cost>(g: &mut [C], drow: &[C]) {
    let Some((gb, rest)) = g.split_last_mut() else { return };
    let Some((&db, drest)) = drow.split_last() else { return };
    let mut diag = *gb;
    let mut right = db.plus(diag);
    *gb = right;
    for (gj, &dj) in rest.iter_mut().rev().zip(drest.iter().rev()) {
        let down = *gj;
        let v = dj.plus(down.least(diag).least(right));
        diag = down;
        *gj = v;
        right = v;
    }
}

/// Running sums in iteration order: `c_k ← c_0 + … + c_k` (the cumulative first row).
fn accumulate<'a, C: Cost + 'a>(cells: impl Iterator<Item = &'a mut C>) {
    let mut acc = C::default();
    for c in cells {
        acc = acc.plus(*c);
        *c = acc;
    }
}

/// [`anchored_costs_into`] with its own buffers.
pub fn anchored_costs<D: LocalDistance>(d: &D, end: usize) -> Result<Vec<D::Cost>> {
    let mut c = Vec::new();
    anchored_costs_into(d, end, &mut c, &mut Workspace::new())?;
    Ok(c)
}

/// The backward pass restricted to columns `start..=end`, keeping that `n × (end−start+1)`
/// matrix, and the path walked forwards from `(0, start)` to `(n−1, end)` (successor ties:
/// diagonal, then model step, then target step).
///
/// The returned cost is bit-for-bit `anchored_costs(d, end)[start]`: the cells of columns
/// `≥ start` never read columns `< start`, and each is computed by the same operations in the
/// same order.
pub fn anchored_path(
    d: &impl LocalDistance<Cost = f64>,
    start: usize,
    end: usize,
    ws: &mut Workspace,
) -> Result<(f64, Vec<(usize, usize)>)> {
    let (n, _) = check_end(d, end)?;
    if start > end {
        return Err(Error::new(
            ErrorKind::OutOfRange,
            format!("the start a = {start} is after the end b = {end}"),
        ));
    }
    let w = end - start + 1;
    let mut g = std::mem::take(&mut ws.matrix);
    g.clear();
    g.resize(n * w, 0.0);
    {
        let last = &mut g[(n - 1) * w..];
        d.row(n - 1, start, last);
        accumulate(last.iter_mut().rev());
    }
    let drow = ws.row(w);
    for i in (0..n - 1).rev() {
        d.row(i, start, drow);
        let (head, below) = g.split_at_mut((i + 1) * w);
        let cur = &mut head[i * w..];
        cur.copy_from_slice(&below[..w]);
        backward_row_update(cur, drow);
    }
    let at = |i: usize, k: usize| g[i * w + k];
    let cost = at(0, 0);
    let mut path = Vec::with_capacity(n + w);
    let (mut i, mut k) = (0usize, 0usize);
    path.push((0, start));
    while i + 1 < n || k + 1 < w {
        (i, k) = if i + 1 == n {
            (i, k + 1)
        } else if k + 1 == w {
            (i + 1, k)
        } else {
            let (diag, down, right) = (at(i + 1, k + 1), at(i + 1, k), at(i, k + 1));
            if diag <= down && diag <= right {
                (i + 1, k + 1)
            } else if down <= right {
                (i + 1, k)
            } else {
                (i, k + 1)
            }
        };
        path.push((i, start + k));
    }
    ws.matrix = g;
    Ok((cost, path))
}

// ---------------------------------------------------------------------------------------------
// Full DTW (both ends anchored)
// ---------------------------------------------------------------------------------------------

/// Full DTW cost, both ends anchored (`(0,0)` to `(n−1, m−1)`), same steps, O(m) memory.
pub fn dtw_full_cost_with<D: LocalDistance>(d: &D, ws: &mut Workspace<D::Cost>) -> Result<D::Cost> {
    let (n, m) = require_nonempty(d)?;
    let mut g = std::mem::take(&mut ws.matrix);
    g.clear();
    g.resize(m, D::Cost::default());
    first_row_cumulative(d, &mut g);
    let drow = ws.row(m);
    for i in 1..n {
        d.row(i, 0, drow);
        forward_row_update(&mut g, drow);
    }
    let cost = g[m - 1];
    ws.matrix = g;
    Ok(cost)
}

fn first_row_cumulative<D: LocalDistance>(d: &D, g: &mut [D::Cost]) {
    d.row(0, 0, g);
    accumulate(g.iter_mut());
}

/// Full DTW keeping the `n × m` matrix; the path by backtracking from `(n−1, m−1)` to `(0, 0)`.
pub fn dtw_full_with(
    d: &impl LocalDistance<Cost = f64>,
    ws: &mut Workspace,
) -> Result<(f64, Vec<(usize, usize)>)> {
    let (n, m) = require_nonempty(d)?;
    let mut g = std::mem::take(&mut ws.matrix);
    g.clear();
    g.resize(n * m, 0.0);
    first_row_cumulative(d, &mut g[..m]);
    let drow = ws.row(m);
    for i in 1..n {
        d.row(i, 0, drow);
        let (done, rest) = g.split_at_mut(i * m);
        let cur = &mut rest[..m];
        cur.copy_from_slice(&done[(i - 1) * m..]);
        forward_row_update(cur, drow);
    }
    let at = |i: usize, j: usize| g[i * m + j];
    let cost = at(n - 1, m - 1);
    let mut path = Vec::with_capacity(n + m);
    let (mut i, mut j) = (n - 1, m - 1);
    path.push((i, j));
    while i > 0 || j > 0 {
        (i, j) = if i == 0 {
            (0, j - 1)
        } else if j == 0 {
            (i - 1, 0)
        } else {
            best_predecessor(at(i - 1, j - 1), at(i - 1, j), at(i, j - 1), i, j)
        };
        path.push((i, j));
    }
    path.reverse();
    ws.matrix = g;
    Ok((cost, path))
}

/// Full DTW between sequences of `n` and `m` samples under any local distance
/// `dist(i, j) ≥ 0`: the summed distance along the best path from `(0, 0)` to `(n−1, m−1)` and
/// that path. Fails only when `n` or `m` is 0.
pub fn dtw_full(
    n: usize,
    m: usize,
    dist: impl Fn(usize, usize) -> f64,
) -> Result<(f64, Vec<(usize, usize)>)> {
    dtw_full_with(&FnDistance::new(n, m, dist), &mut Workspace::new())
}

/// [`dtw_full`] without the path (O(m) memory).
pub fn dtw_full_cost(n: usize, m: usize, dist: impl Fn(usize, usize) -> f64) -> Result<f64> {
    dtw_full_cost_with(&FnDistance::new(n, m, dist), &mut Workspace::new())
}

/// Full DTW of two 1-D series with `d = |a_i − b_j|` (e.g. joint-angle curves in degrees).
/// Fails when either is empty or holds a non-finite value.
pub fn dtw_full_1d(a: &[f64], b: &[f64]) -> Result<(f64, Vec<(usize, usize)>)> {
    for (name, s) in [("first", a), ("second", b)] {
        if let Some(k) = s.iter().position(|v| !v.is_finite()) {
            return Err(Error::new(
                ErrorKind::NonFinite,
                format!(
                    "DTW needs finite samples, but the {name} series holds {} at index {k}",
                    s[k]
                ),
            ));
        }
    }
    dtw_full_with(&Absolute1 { model: a, target: b }, &mut Workspace::new())
}

/// Full DTW of two 3-D point series with the euclidean local distance (mm).
pub fn dtw_full_3d(a: &[Point3], b: &[Point3]) -> Result<(f64, Vec<(usize, usize)>)> {
    let (ta, tb) = (Trajectory3::from_points(a), Trajectory3::from_points(b));
    dtw_full_with(&Euclidean3::new(&ta, &tb), &mut Workspace::new())
}

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_testkit::Rng;

    fn random_traj(rng: &mut Rng, len: usize) -> Trajectory3 {
        let pts: Vec<Point3> = (0..len)
            .map(|_| [rng.normal() * 10.0, rng.normal() * 10.0, rng.normal() * 10.0])
            .collect();
        Trajectory3::from_points(&pts)
    }

    /// Textbook full-matrix DP with explicit ±inf borders: the independent reference.
    fn reference_dp(
        n: usize,
        m: usize,
        d: impl Fn(usize, usize) -> f64,
        free_start: bool,
    ) -> Vec<Vec<f64>> {
        let mut g = vec![vec![f64::INFINITY; m + 1]; n + 1];
        for (j, c) in g[0].iter_mut().enumerate() {
            *c = if free_start || j == 0 { 0.0 } else { f64::INFINITY };
        }
        for i in 1..=n {
            for j in 1..=m {
                let best = g[i - 1][j].min(g[i - 1][j - 1]).min(g[i][j - 1]);
                g[i][j] = d(i - 1, j - 1) + best;
            }
        }
        g
    }

    fn path_cost(path: &[(usize, usize)], d: impl Fn(usize, usize) -> f64) -> f64 {
        path.iter().map(|&(i, j)| d(i, j)).sum()
    }

    fn assert_valid_steps(path: &[(usize, usize)]) {
        for w in path.windows(2) {
            let (di, dj) = (w[1].0 - w[0].0, w[1].1 - w[0].1);
            assert!(
                matches!((di, dj), (1, 1) | (1, 0) | (0, 1)),
                "bad step {:?} -> {:?}",
                w[0],
                w[1]
            );
        }
    }

    #[test]
    fn a_sequence_against_itself_costs_zero_along_the_diagonal() {
        let mut rng = Rng::new(7);
        let s = random_traj(&mut rng, 25);
        let d = Euclidean3::new(&s, &s);
        let (cost, path) = dtw_full_with(&d, &mut Workspace::new()).unwrap();
        assert_eq!(cost, 0.0);
        assert_eq!(path, (0..25).map(|i| (i, i)).collect::<Vec<_>>());
        let sub = subsequence_match(&d, &mut Workspace::new()).unwrap();
        assert_eq!((sub.start, sub.end, sub.cost), (0, 24, 0.0));
        assert_eq!(sub.path, path);
        let back = anchored_costs(&d, 24).unwrap();
        assert_eq!(back[0], 0.0);
        assert_eq!(anchored_path(&d, 0, 24, &mut Workspace::new()).unwrap(), (0.0, path));
    }

    #[test]
    fn small_case_worked_by_hand() {
        // Model S = [0, 2, 4], target T = [5, 0, 1, 3, 4, 9] (1-D, d = |s_i - t_j|).
        //
        //   d(i,j)   t=5  0  1  3  4  9
        //   s=0        5  0  1  3  4  9
        //   s=2        3  2  1  1  2  7
        //   s=4        1  4  3  1  0  5
        //
        // Forward subsequence matrix g (row 0 free start, column 0 accumulating):
        //   row 0:  5  0  1  3  4  9
        //   row 1:  8  2  1  2  4 11     e.g. g(1,2) = 1 + min(1, 0, 2) = 1
        //   row 2:  9  6  4  2  2  7     e.g. g(2,4) = 0 + min(4, 2, 2) = 2
        // h = row 2; min h = 2 first at j = 3; path (2,3) <- (1,2) <- (0,1): start 1.
        let s = [0.0, 2.0, 4.0];
        let t = [5.0, 0.0, 1.0, 3.0, 4.0, 9.0];
        let d = Absolute1 { model: &s, target: &t };
        assert_eq!(subsequence_costs(&d).unwrap(), vec![9.0, 6.0, 4.0, 2.0, 2.0, 7.0]);
        let sub = subsequence_match(&d, &mut Workspace::new()).unwrap();
        assert_eq!((sub.start, sub.end, sub.cost), (1, 3, 2.0));
        assert_eq!(sub.path, vec![(0, 1), (1, 2), (2, 3)]);
        // Backward pass anchored at b = 4 (t = 4), columns 0..=4, computed from (2,4):
        //   row 2 (cumulative leftwards from b):  9  8  4  1  0
        //   row 1: G(1,4) = 2 + 0 = 2; G(1,3) = 1 + min(1, 0, 2) = 1;
        //          G(1,2) = 1 + min(4, 1, 1) = 2; G(1,1) = 2 + min(8, 4, 2) = 4;
        //          G(1,0) = 3 + min(9, 8, 4) = 7           -> 7 4 2 1 2
        //   row 0: G(0,4) = 4 + 2 = 6; G(0,3) = 3 + min(1, 2, 6) = 4;
        //          G(0,2) = 1 + min(2, 1, 4) = 2; G(0,1) = 0 + min(4, 2, 2) = 2;
        //          G(0,0) = 5 + min(7, 4, 2) = 7           -> 7 2 2 4 6
        assert_eq!(anchored_costs(&d, 4).unwrap(), vec![7.0, 2.0, 2.0, 4.0, 6.0]);
        // From a = 1: successors of (0,1) are diag (1,2)=2, down (1,1)=4, right (0,2)=2: the
        // diagonal wins the tie; from (1,2): diag (2,3)=1, down (2,2)=4, right (1,3)=1 -> diag;
        // then (2,3) -> (2,4) along the last row.
        let (cost, path) = anchored_path(&d, 1, 4, &mut Workspace::new()).unwrap();
        assert_eq!(cost, 2.0);
        assert_eq!(path, vec![(0, 1), (1, 2), (2, 3), (2, 4)]);
        // Full DTW of S against T: an independent hand check of the anchored variant.
        let (full, fpath) = dtw_full_1d(&s, &t).unwrap();
        // d along (0,0)(0,1)(0,2)(1,3)(2,4)(2,5): 5+0+1+1+0+5 = 12.
        assert_eq!(full, 12.0);
        assert_eq!(fpath, vec![(0, 0), (0, 1), (0, 2), (1, 3), (2, 4), (2, 5)]);
    }

    #[test]
    fn kernels_equal_a_textbook_dp_and_brute_force_on_random_cases() {
        let mut rng = Rng::new(42);
        for case in 0..60 {
            let n = 1 + (rng.next_u64() % 9) as usize;
            let m = 1 + (rng.next_u64() % 14) as usize;
            let (s, t) = (random_traj(&mut rng, n), random_traj(&mut rng, m));
            let d = Euclidean3::new(&s, &t);
            let f = |i: usize, j: usize| {
                let (p, q) = (s.point(i), t.point(j));
                ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
            };
            let free = reference_dp(n, m, f, true);
            let h = subsequence_costs(&d).unwrap();
            for j in 0..m {
                assert!(
                    (h[j] - free[n][j + 1]).abs() <= 1e-9 * free[n][j + 1].max(1.0),
                    "case {case} j {j}"
                );
                // h(j) = min over starts of a full DTW against T[a..=j].
                let brute = (0..=j)
                    .map(|a| dtw_full_cost(n, j - a + 1, |i, k| f(i, a + k)).unwrap())
                    .fold(f64::INFINITY, f64::min);
                assert!(
                    (h[j] - brute).abs() <= 1e-9 * brute.max(1.0),
                    "case {case} j {j}: {} vs {brute}",
                    h[j]
                );
            }
            let full = reference_dp(n, m, f, false)[n][m];
            let (cost, path) = dtw_full_with(&d, &mut Workspace::new()).unwrap();
            assert!((cost - full).abs() <= 1e-9 * full.max(1.0));
            assert_eq!((path[0], *path.last().unwrap()), ((0, 0), (n - 1, m - 1)));
            assert_valid_steps(&path);
            assert!((path_cost(&path, f) - cost).abs() <= 1e-9 * cost.max(1.0));
            assert_eq!(dtw_full_cost_with(&d, &mut Workspace::new()).unwrap(), cost);

            let sub = subsequence_match(&d, &mut Workspace::new()).unwrap();
            assert_eq!(sub.end_costs, h);
            assert_eq!(sub.end, argmin_first(&h).unwrap());
            assert_eq!(
                (sub.path[0], *sub.path.last().unwrap()),
                ((0, sub.start), (n - 1, sub.end))
            );
            assert_valid_steps(&sub.path);
            assert!((path_cost(&sub.path, f) - sub.cost).abs() <= 1e-9 * sub.cost.max(1.0));

            let b = (rng.next_u64() % m as u64) as usize;
            let back = anchored_costs(&d, b).unwrap();
            assert_eq!(back.len(), b + 1);
            for (a, &c) in back.iter().enumerate() {
                let brute = dtw_full_cost(n, b - a + 1, |i, k| f(i, a + k)).unwrap();
                assert!((c - brute).abs() <= 1e-9 * brute.max(1.0), "case {case} a {a} b {b}");
                let (pc, p) = anchored_path(&d, a, b, &mut Workspace::new()).unwrap();
                assert_eq!(pc, c, "restricted pass must equal the rolling pass bit for bit");
                assert_eq!((p[0], *p.last().unwrap()), ((0, a), (n - 1, b)));
                assert_valid_steps(&p);
                assert!((path_cost(&p, f) - c).abs() <= 1e-9 * c.max(1.0));
            }
        }
    }

    #[test]
    fn generic_closure_and_1d_forms_agree() {
        let a = [1.0, 3.0, 9.0, 2.0, 1.0];
        let b = [2.0, 0.0, 0.0, 8.0, 7.0, 2.0];
        let (c1, p1) = dtw_full_1d(&a, &b).unwrap();
        let (c2, p2) = dtw_full(a.len(), b.len(), |i, j| (a[i] - b[j]).abs()).unwrap();
        assert_eq!((c1, &p1), (c2, &p2));
        let want =
            reference_dp(a.len(), b.len(), |i, j| (a[i] - b[j]).abs(), false)[a.len()][b.len()];
        assert_eq!(c1, want);
    }

    #[test]
    fn empty_and_out_of_range_inputs_are_errors_not_panics() {
        let e = dtw_full(0, 3, |_, _| 0.0).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::EmptySequence);
        assert!(e.to_string().contains("the model"), "{e}");
        let s = [1.0, 2.0];
        let d = Absolute1 { model: &s, target: &s };
        assert_eq!(anchored_costs(&d, 2).unwrap_err().kind(), ErrorKind::OutOfRange);
        assert_eq!(
            anchored_path(&d, 2, 1, &mut Workspace::new()).unwrap_err().kind(),
            ErrorKind::OutOfRange
        );
        let e = dtw_full_1d(&[1.0, f64::NAN], &[1.0]).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::NonFinite);
        assert!(e.to_string().contains("index 1"), "{e}");
    }

    #[test]
    fn argmin_takes_the_earliest_and_skips_nan() {
        assert_eq!(argmin_first(&[3.0, 1.0, 1.0, 2.0]), Some(1));
        assert_eq!(argmin_first(&[f64::NAN, 2.0, f64::NAN, 1.0]), Some(3));
        assert_eq!(argmin_first(&[f64::NAN]), None);
        assert_eq!(argmin_first(&[]), None);
    }
}
