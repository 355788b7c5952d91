//! Volume of the 3-D convex hull of a frame's markers and its change (Sonoda et al. §2.3).
//!
//! `Vol[i]` = volume (mm³) of the convex hull of every valid marker at frame `i`;
//! `D[i] = |Vol[i] − Vol[i−1]|` (mm³ per frame).
//!
//! # Why the hull is written here
//!
//! A body has 20–45 markers, and a sequence has thousands of frames. `parry3d-f64` (measured
//! here at 12 µs per 41-point frame) and `scipy.spatial.ConvexHull` (qhull, 61.5 µs with Python
//! overhead) are general-purpose and allocate per call. The hull below is a quickhull with
//! reusable buffers, and [`HullTracker`] exploits temporal coherence: consecutive frames usually
//! have the same hull combinatorics, which can be *certified* much faster than rebuilt. See
//! `crates/motionlab-features/benches/README.md` for the measured numbers.
//!
//! # Robustness
//!
//! Real marker sets contain duplicates (two markers on one spot), coplanar and collinear subsets,
//! and missing samples. Every orientation decision ("is q above the plane of face f?") is exact:
//! a floating-point evaluation whose rounding error is bounded a priori (see [`Plane`]) decides
//! when the bound allows, and Shewchuk's adaptive exact `orient3d` (crate `robust`) decides the
//! rest. A point is added to the hull only when it is *strictly* above a face, so points on the
//! hull surface and duplicates are simply absorbed, and the quickhull invariants (visible region
//! is a disc, its horizon a simple cycle, orphaned outside points see a new face) hold exactly.
//! A frame with fewer than 4 valid points, or whose valid points are all collinear or coplanar
//! (exactly), has volume 0 and is **flagged** ([`Degeneracy`]); nothing panics and no NaN is
//! produced for a frame with valid points.
//!
//! # Temporal coherence ([`HullTracker`])
//!
//! Given last frame's triangles (as marker triples) and this frame's positions, the triangles
//! are still the hull when, for every triangle, every other valid point lies *strictly* below
//! its plane. Proof: such a triangle is then a facet of the convex hull (its plane supports the
//! set and touches it only at the triangle's three vertices); distinct facets that together form
//! a closed surface without boundary must be the whole boundary of the hull. The check is a
//! vectorisable loop of one plane evaluation per (triangle, point) with the same certified error
//! bound; when it fails (a point pokes out, or a hull vertex sank inward), the hull is rebuilt.
//!
//! **Missing samples:** the hull is taken over the valid markers of the frame only. `D[i]` is
//! NaN when the set of valid markers differs between frames `i−1` and `i` (a marker dropping out
//! changes the hull without any movement, so its jump is not a body change), or when either frame
//! is degenerate (flagged), and at `i = 0`.

use std::sync::Arc;

use motionlab_core::registry::ParamGuard;
use motionlab_core::{FeatureCache, FeatureExtractor, FeatureSet, Motion, Point3, Result, Trace};
use robust::Coord3D;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

const NONE: u32 = u32::MAX;

/// Multiplier of the a-priori rounding-error bound of [`Plane::eval`]: the evaluation has at
/// most 8 roundings per monomial, so |error| ≤ γ₈·P with γ₈ ≈ 8u = 8.9e-16 and P the sum of the
/// monomials' magnitudes (bounded by `m · extent`). 2e-15 leaves a factor 2.2 of margin.
const ERR: f64 = 2e-15;
/// Absolute floor of the bound, covering underflow (subnormal products) in degenerate inputs.
const TINY: f64 = 1e-290;

/// Why a frame has no proper hull (its volume is reported as 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Degeneracy {
    /// Fewer than 4 valid points.
    TooFewPoints,
    /// All valid points coincide or lie on one line.
    Collinear,
    /// All valid points lie in one plane.
    Coplanar,
}

/// The hull of one point set.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HullVolume {
    /// Volume in mm³ (0 when degenerate).
    pub volume_mm3: f64,
    /// Set when the valid points span less than 3 dimensions.
    pub degenerate: Option<Degeneracy>,
}

#[inline(always)]
fn sub(a: Point3, b: Point3) -> Point3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline(always)]
fn c3(p: Point3) -> Coord3D<f64> {
    Coord3D { x: p[0], y: p[1], z: p[2] }
}

/// Exact sign source: `det[b−a, c−a, q−a]`, positive when `q` is above the plane of the
/// counter-clockwise triangle `(a, b, c)` (on the side its normal `(b−a)×(c−a)` points to).
#[inline]
fn orient_exact(a: Point3, b: Point3, c: Point3, q: Point3) -> f64 {
    // robust::orient3d is positive when q lies *below* (a, b, c); flip it.
    -robust::orient3d(c3(a), c3(b), c3(c), c3(q))
}

/// A triangle's plane with an a-priori error bound, so most side tests cost 6 flops.
///
/// `eval(q) = n̂ · (q − a)` with `n̂ = (b−a)×(c−a)` evaluated in floating point in a fixed order.
/// Its difference from the exact `det[b−a, c−a, q−a]` is at most `bound` for every `q` within
/// the point set's bounding box (extent per axis `ext`), so `|eval| > bound` decides the sign.
#[derive(Clone, Copy, Debug)]
struct Plane {
    o: Point3,
    n: Point3,
    bound: f64,
}

impl Plane {
    #[inline]
    fn new(a: Point3, b: Point3, c: Point3, ext: Point3) -> Plane {
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
    #[inline(always)]
    fn eval(&self, q: Point3) -> f64 {
        // Fixed evaluation order (no FMA contraction in Rust): the error analysis depends on it.
        (self.n[0] * (q[0] - self.o[0]) + self.n[1] * (q[1] - self.o[1])) + self.n[2] * (q[2] - self.o[2])
    }
}

/// A triangle of the hull under construction (its plane is kept apart, in `HullBuilder::planes`,
/// so the topology walks touch less memory).
#[derive(Clone, Copy, Debug)]
struct Face {
    v: [u32; 3],
    /// `nbr[e]` is the face across edge `e` = (v[e], v[(e+1)%3]).
    nbr: [u32; 3],
    /// Head of this face's outside set (a linked list through `HullBuilder::next`).
    head: u32,
    /// The outside point farthest above the plane, and its plane value.
    far: u32,
    far_dist: f64,
    /// Visit stamp of the visibility search, and its verdict.
    mark: u32,
    visible: bool,
    alive: bool,
}

/// Quickhull with exact predicates and buffers reused across calls (no allocation once warm).
#[derive(Default)]
pub struct HullBuilder {
    pts: Vec<Point3>,
    faces: Vec<Face>,
    planes: Vec<Plane>,
    next: Vec<u32>,
    stack: Vec<u32>,
    visible: Vec<u32>,
    dfs: Vec<u32>,
    horizon: Vec<(u32, u8)>,
    new_faces: Vec<u32>,
    by_start: Vec<u32>,
    ext: Point3,
    /// An interior point (centroid of the initial tetrahedron), the apex for the volume sum.
    inside: Point3,
    stamp: u32,
}

impl HullBuilder {
    pub fn new() -> Self {
        Self::default()
    }

    /// Hull volume of `points` (all must be finite; callers drop missing samples).
    pub fn volume(&mut self, points: &[Point3]) -> HullVolume {
        match self.build(points) {
            Ok(()) => HullVolume { volume_mm3: self.current_volume(), degenerate: None },
            Err(d) => HullVolume { volume_mm3: 0.0, degenerate: Some(d) },
        }
    }

    /// The triangles of the last successful [`HullBuilder::volume`] call, counter-clockwise seen
    /// from outside, as indices into the points given.
    pub fn triangles(&self) -> impl Iterator<Item = [u32; 3]> + Clone + '_ {
        self.faces.iter().filter(|f| f.alive).map(|f| f.v)
    }

    fn current_volume(&self) -> f64 {
        let o = self.inside;
        let mut six_v = 0.0;
        for f in self.faces.iter().filter(|f| f.alive) {
            let [a, b, c] = f.v;
            six_v += orient_fast(o, self.pts[a as usize], self.pts[b as usize], self.pts[c as usize]);
        }
        six_v / 6.0
    }

    fn add_face(&mut self, v: [u32; 3]) -> u32 {
        let [a, b, c] = v.map(|i| self.pts[i as usize]);
        let id = self.faces.len() as u32;
        self.faces.push(Face {
            v,
            nbr: [NONE; 3],
            head: NONE,
            far: NONE,
            far_dist: 0.0,
            mark: 0,
            visible: false,
            alive: true,
        });
        self.planes.push(Plane::new(a, b, c, self.ext));
        id
    }

    /// Is point `q` strictly above face `f`? Returns the plane value when it is (for ranking).
    #[inline]
    fn above(&self, f: u32, q: u32) -> Option<f64> {
        let p = self.pts[q as usize];
        let plane = &self.planes[f as usize];
        let s = plane.eval(p);
        if s > plane.bound {
            Some(s)
        } else if s < -plane.bound {
            None
        } else {
            let [a, b, c] = self.faces[f as usize].v.map(|i| self.pts[i as usize]);
            (orient_exact(a, b, c, p) > 0.0).then_some(0.0)
        }
    }

    fn push_outside(&mut self, f: u32, q: u32, dist: f64) {
        let face = &mut self.faces[f as usize];
        self.next[q as usize] = face.head;
        face.head = q;
        if face.far == NONE || dist > face.far_dist {
            face.far = q;
            face.far_dist = dist;
        }
    }

    fn build(&mut self, points: &[Point3]) -> std::result::Result<(), Degeneracy> {
        self.pts.clear();
        self.pts.extend_from_slice(points);
        self.faces.clear();
        self.planes.clear();
        self.stack.clear();
        let n = self.pts.len();
        if n < 4 {
            return Err(Degeneracy::TooFewPoints);
        }
        self.next.clear();
        self.next.resize(n, NONE);
        self.by_start.clear();
        self.by_start.resize(n, NONE);
        let simplex = initial_simplex(&self.pts)?;
        self.ext = extent(&self.pts);
        let corners = simplex.map(|i| self.pts[i]);
        self.inside = [0, 1, 2].map(|k| corners.iter().map(|c| c[k]).sum::<f64>() / 4.0);

        // Outward faces of the tetrahedron (a, b, c, d) with d below (a, b, c).
        let [a, b, c, d] = simplex.map(|i| i as u32);
        for v in [[a, b, c], [a, d, b], [b, d, c], [c, d, a]] {
            self.add_face(v);
        }
        link_tetrahedron(&mut self.faces);

        // Initial outside sets: each point goes to the first face it is strictly above.
        for q in 0..n as u32 {
            if simplex.contains(&(q as usize)) {
                continue;
            }
            for f in 0..4u32 {
                if let Some(dist) = self.above(f, q) {
                    self.push_outside(f, q, dist);
                    break;
                }
            }
        }
        self.stack.extend(0..4u32);

        while let Some(f) = self.stack.pop() {
            let face = &self.faces[f as usize];
            if face.alive && face.far != NONE {
                self.add_point(f, face.far);
            }
        }
        Ok(())
    }

    /// Adds outside point `p` (strictly above face `start`) to the hull.
    fn add_point(&mut self, start: u32, p: u32) {
        self.stamp = self.stamp.wrapping_add(1).max(1);
        let stamp = self.stamp;
        self.visible.clear();
        self.horizon.clear();
        self.dfs.clear();
        {
            let f = &mut self.faces[start as usize];
            f.mark = stamp;
            f.visible = true;
        }
        self.dfs.push(start);
        // Depth-first search over faces strictly visible from p; its boundary is the horizon.
        while let Some(f) = self.dfs.pop() {
            self.visible.push(f);
            let nbr = self.faces[f as usize].nbr;
            for (e, g) in nbr.into_iter().enumerate() {
                let (mark, seen_visible) = {
                    let gf = &self.faces[g as usize];
                    (gf.mark, gf.visible)
                };
                let vis = if mark == stamp {
                    seen_visible
                } else {
                    let vis = self.above(g, p).is_some();
                    let gm = &mut self.faces[g as usize];
                    gm.mark = stamp;
                    gm.visible = vis;
                    if vis {
                        self.dfs.push(g);
                    }
                    vis
                };
                if !vis {
                    self.horizon.push((f, e as u8));
                }
            }
        }

        // The cone of new faces from p over the horizon edges.
        self.new_faces.clear();
        for h in 0..self.horizon.len() {
            let (f, e) = self.horizon[h];
            let (fv, fn_) = (self.faces[f as usize].v, self.faces[f as usize].nbr);
            let (u, v) = (fv[e as usize], fv[(e as usize + 1) % 3]);
            let g = fn_[e as usize];
            let nf = self.add_face([u, v, p]);
            self.faces[nf as usize].nbr[0] = g;
            // g holds the same edge reversed, (v, u): point that slot at the new face.
            let gface = &mut self.faces[g as usize];
            for k in 0..3 {
                if gface.v[k] == v && gface.v[(k + 1) % 3] == u {
                    gface.nbr[k] = nf;
                }
            }
            self.by_start[u as usize] = nf;
            self.new_faces.push(nf);
        }
        for k in 0..self.new_faces.len() {
            let nf = self.new_faces[k];
            let v = self.faces[nf as usize].v[1];
            let succ = self.by_start[v as usize];
            self.faces[nf as usize].nbr[1] = succ;
            self.faces[succ as usize].nbr[2] = nf;
        }

        // Orphaned outside points: each goes to a new face it is above, or is inside for good.
        for k in 0..self.visible.len() {
            let f = self.visible[k];
            self.faces[f as usize].alive = false;
            let mut q = self.faces[f as usize].head;
            while q != NONE {
                let nq = self.next[q as usize];
                if q != p {
                    for j in 0..self.new_faces.len() {
                        let nf = self.new_faces[j];
                        if let Some(dist) = self.above(nf, q) {
                            self.push_outside(nf, q, dist);
                            break;
                        }
                    }
                }
                q = nq;
            }
        }
        for k in 0..self.new_faces.len() {
            let nf = self.new_faces[k];
            if self.faces[nf as usize].far != NONE {
                self.stack.push(nf);
            }
        }
    }
}

/// Links the neighbours of the four faces of the initial tetrahedron by shared edges.
fn link_tetrahedron(faces: &mut [Face]) {
    for f in 0..4 {
        for e in 0..3 {
            let (u, v) = (faces[f].v[e], faces[f].v[(e + 1) % 3]);
            // The neighbour holds the same edge reversed (v, u).
            for (g, face) in faces.iter().enumerate().take(4) {
                if g != f && (0..3).any(|k| face.v[k] == v && face.v[(k + 1) % 3] == u) {
                    faces[f].nbr[e] = g as u32;
                    break;
                }
            }
        }
    }
}

/// Per-axis extent (max − min) of the points.
fn extent(pts: &[Point3]) -> Point3 {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in pts {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]]
}

/// Four affinely independent points `[a, b, c, d]` with `d` strictly below the counter-clockwise
/// triangle `(a, b, c)`, chosen large (extreme points) so most points fall inside at once; or
/// why none exist. Float heuristics choose, exact predicates decide.
fn initial_simplex(pts: &[Point3]) -> std::result::Result<[usize; 4], Degeneracy> {
    // Extreme points along each axis; the farthest-apart pair of them.
    let mut ext = [0usize; 6];
    for (i, p) in pts.iter().enumerate() {
        for k in 0..3 {
            if p[k] < pts[ext[2 * k]][k] {
                ext[2 * k] = i;
            }
            if p[k] > pts[ext[2 * k + 1]][k] {
                ext[2 * k + 1] = i;
            }
        }
    }
    let d2 = |a: Point3, b: Point3| {
        let d = sub(a, b);
        d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
    };
    let (mut i0, mut i1, mut best) = (0, 0, -1.0);
    for x in 0..6 {
        for y in x + 1..6 {
            let dd = d2(pts[ext[x]], pts[ext[y]]);
            if dd > best {
                (i0, i1, best) = (ext[x], ext[y], dd);
            }
        }
    }
    if best <= 0.0 {
        return Err(Degeneracy::Collinear); // all points coincide
    }
    let (a, b) = (pts[i0], pts[i1]);
    // Third: farthest from the line ab (float), confirmed non-collinear exactly.
    let ab = sub(b, a);
    let cross2 = |q: Point3| {
        let aq = sub(q, a);
        let c = [ab[1] * aq[2] - ab[2] * aq[1], ab[2] * aq[0] - ab[0] * aq[2], ab[0] * aq[1] - ab[1] * aq[0]];
        c[0] * c[0] + c[1] * c[1] + c[2] * c[2]
    };
    let i2 = argmax(pts.len(), |q| cross2(pts[q]));
    let i2 = if collinear_exact(a, b, pts[i2]) {
        (0..pts.len()).find(|&q| !collinear_exact(a, b, pts[q])).ok_or(Degeneracy::Collinear)?
    } else {
        i2
    };
    let c = pts[i2];
    // Fourth: farthest from the plane abc (float), confirmed off the plane exactly.
    let i3 = argmax(pts.len(), |q| orient_fast(a, b, c, pts[q]).abs());
    let i3 = if orient_exact(a, b, c, pts[i3]) == 0.0 {
        (0..pts.len()).find(|&q| orient_exact(a, b, c, pts[q]) != 0.0).ok_or(Degeneracy::Coplanar)?
    } else {
        i3
    };
    if orient_exact(a, b, c, pts[i3]) > 0.0 {
        Ok([i0, i2, i1, i3]) // d above (a, b, c): swap b and c so it is below
    } else {
        Ok([i0, i1, i2, i3])
    }
}

fn argmax(n: usize, f: impl Fn(usize) -> f64) -> usize {
    let (mut bi, mut bv) = (0, f64::NEG_INFINITY);
    for i in 0..n {
        let v = f(i);
        if v > bv {
            (bi, bv) = (i, v);
        }
    }
    bi
}

#[inline]
fn orient_fast(a: Point3, b: Point3, c: Point3, q: Point3) -> f64 {
    let (d1, d2, e) = (sub(b, a), sub(c, a), sub(q, a));
    (d1[1] * d2[2] - d1[2] * d2[1]) * e[0] + (d1[2] * d2[0] - d1[0] * d2[2]) * e[1] + (d1[0] * d2[1] - d1[1] * d2[0]) * e[2]
}

/// Exactly collinear: `(b−a)×(q−a) = 0`, i.e. all three coordinate-plane projections collinear.
fn collinear_exact(a: Point3, b: Point3, q: Point3) -> bool {
    let o2 = |i: usize, j: usize| {
        robust::orient2d(
            robust::Coord { x: a[i], y: a[j] },
            robust::Coord { x: b[i], y: b[j] },
            robust::Coord { x: q[i], y: q[j] },
        )
    };
    o2(0, 1) == 0.0 && o2(1, 2) == 0.0 && o2(2, 0) == 0.0
}

/// Volume enclosed by outward triangles: Σ det(a−o, b−o, c−o)/6 about a point `o` inside the
/// hull (so every term is ≥ 0 and nothing cancels).
fn volume_of_triangles(pts: &[Point3], o: Point3, tris: &[[u32; 3]]) -> f64 {
    let mut six_v = 0.0;
    for &[a, b, c] in tris {
        six_v += orient_fast(o, pts[a as usize], pts[b as usize], pts[c as usize]);
    }
    six_v / 6.0
}

/// Hull volume of the finite points of `points` (non-finite ones are skipped as missing).
pub fn convex_hull_volume(points: &[Point3]) -> HullVolume {
    let valid: Vec<Point3> = points.iter().copied().filter(|p| p.iter().all(|c| c.is_finite())).collect();
    HullBuilder::new().volume(&valid)
}

/// Counts of how [`HullTracker`] obtained each frame's hull.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TrackerStats {
    /// Frames whose hull was last frame's triangles, certified.
    pub reused: usize,
    /// Frames built from scratch (first frame, changed marker set, or certification failed).
    pub rebuilt: usize,
    /// Degenerate frames (no hull).
    pub degenerate: usize,
}

/// Per-frame hull volumes of a marker sequence, re-using the previous frame's triangles when
/// they are certified to still be the hull (see the module docs for the proof).
///
/// Exact duplicates (skeletons put several joints on one spot: CMU's `lthumb` starts where
/// `lhand` does) are dropped before the hull is built or certified: a duplicate of a hull vertex
/// lies *on* its triangles' planes and would defeat the strict certification.
#[derive(Default)]
pub struct HullTracker {
    builder: HullBuilder,
    /// Valid points of the current frame, then (after [`HullTracker::dedup`]) the distinct ones.
    compact: Vec<Point3>,
    /// Distinct valid points, structure of arrays for the certification loop.
    xs: Vec<f64>,
    ys: Vec<f64>,
    zs: Vec<f64>,
    valid: Vec<bool>,
    prev_valid: Vec<bool>,
    /// `(k, j)`: valid point `k` equalled valid point `j < k` exactly at the last rebuild.
    dups: Vec<(u32, u32)>,
    /// Last frame's triangles, as indices into the distinct valid points.
    prev_tris: Vec<[u32; 3]>,
    stats: TrackerStats,
}

impl HullTracker {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn stats(&self) -> TrackerStats {
        self.stats
    }

    /// Forgets the previous frame (the next call rebuilds).
    pub fn reset(&mut self) {
        self.prev_tris.clear();
        self.prev_valid.clear();
        self.dups.clear();
    }

    /// Hull volume of the finite points of one frame (non-finite = missing, skipped).
    pub fn frame(&mut self, points: &[Point3]) -> HullVolume {
        self.valid.clear();
        self.compact.clear();
        for p in points {
            let ok = p.iter().all(|c| c.is_finite());
            self.valid.push(ok);
            if ok {
                self.compact.push(*p);
            }
        }
        let same_structure = !self.prev_tris.is_empty()
            && self.valid == self.prev_valid
            && self.dups.iter().all(|&(k, j)| self.compact[k as usize] == self.compact[j as usize]);
        if same_structure {
            self.drop_known_dups();
            if self.certify() {
                self.stats.reused += 1;
                // The mean of the points is inside their hull: a safe apex for the volume sum.
                let k = self.xs.len() as f64;
                let o = [self.xs.iter().sum::<f64>() / k, self.ys.iter().sum::<f64>() / k, self.zs.iter().sum::<f64>() / k];
                return HullVolume { volume_mm3: volume_of_triangles(&self.compact, o, &self.prev_tris), degenerate: None };
            }
        } else {
            self.find_dups();
            self.drop_known_dups();
        }
        let h = self.builder.volume(&self.compact);
        self.prev_tris.clear();
        if h.degenerate.is_some() {
            self.stats.degenerate += 1;
        } else {
            self.stats.rebuilt += 1;
            self.prev_tris.extend(self.builder.triangles());
        }
        std::mem::swap(&mut self.prev_valid, &mut self.valid);
        h
    }

    /// Records every valid point that exactly equals an earlier one (O(n²), rebuilds only).
    fn find_dups(&mut self) {
        self.dups.clear();
        for k in 1..self.compact.len() {
            if let Some(j) = (0..k).find(|&j| self.compact[j] == self.compact[k]) {
                self.dups.push((k as u32, j as u32));
            }
        }
    }

    /// Removes the recorded duplicates from `compact` (keeping first occurrences, in order) and
    /// fills the structure-of-arrays copy.
    fn drop_known_dups(&mut self) {
        if !self.dups.is_empty() {
            let mut d = 0;
            let mut k = 0;
            self.compact.retain(|_| {
                let drop = d < self.dups.len() && self.dups[d].0 == k;
                d += drop as usize;
                k += 1;
                !drop
            });
        }
        self.xs.clear();
        self.ys.clear();
        self.zs.clear();
        for p in &self.compact {
            self.xs.push(p[0]);
            self.ys.push(p[1]);
            self.zs.push(p[2]);
        }
    }

    /// True when every previous triangle has every other current point strictly below its plane.
    fn certify(&self) -> bool {
        let ext = extent(&self.compact);
        let (xs, ys, zs) = (&self.xs[..], &self.ys[..], &self.zs[..]);
        for t in &self.prev_tris {
            let [a, b, c] = t.map(|i| self.compact[i as usize]);
            let pl = Plane::new(a, b, c, ext);
            let (nb, o, n) = (-pl.bound, pl.o, pl.n);
            // Branch-free so it vectorises: count points not certified strictly below. The
            // triangle's own three vertices always count (their exact value is 0).
            let mut uncertain = 0u32;
            for q in 0..xs.len() {
                let s = (n[0] * (xs[q] - o[0]) + n[1] * (ys[q] - o[1])) + n[2] * (zs[q] - o[2]);
                uncertain += (s >= nb) as u32;
            }
            if uncertain != 3 && !self.certify_slow(t, &pl) {
                return false;
            }
        }
        true
    }

    /// Exact re-check of the points the fast loop could not certify for one triangle.
    fn certify_slow(&self, t: &[u32; 3], pl: &Plane) -> bool {
        let [a, b, c] = t.map(|i| self.compact[i as usize]);
        self.compact.iter().enumerate().all(|(q, &p)| {
            t.contains(&(q as u32)) || pl.eval(p) < -pl.bound || orient_exact(a, b, c, p) < 0.0
        })
    }
}

/// Per-frame hull volumes and their changes for a motion.
#[derive(Clone, Debug, PartialEq)]
pub struct HullVolumes {
    /// `Vol[i]`, mm³ (0 on degenerate frames).
    pub volume_mm3: Vec<f64>,
    /// `D[i] = |Vol[i] − Vol[i−1]|`, mm³ per frame; NaN at 0, next to a degenerate frame, or
    /// where the set of valid markers changed.
    pub change_mm3_per_frame: Vec<f64>,
    /// Why a frame is degenerate (None = proper hull). These are the flagged frames.
    pub degenerate: Vec<Option<Degeneracy>>,
    /// Number of valid markers per frame.
    pub n_valid: Vec<usize>,
    pub stats: TrackerStats,
}

impl HullVolumes {
    /// Indices of the flagged (degenerate) frames.
    pub fn flagged_frames(&self) -> Vec<usize> {
        self.degenerate.iter().enumerate().filter(|(_, d)| d.is_some()).map(|(i, _)| i).collect()
    }
}

/// `Vol` and `D` for every frame of a motion.
pub fn hull_volumes(motion: &Motion) -> HullVolumes {
    let f = motion.n_frames();
    let mut tracker = HullTracker::new();
    let mut volume_mm3 = Vec::with_capacity(f);
    let mut degenerate = Vec::with_capacity(f);
    let mut n_valid = Vec::with_capacity(f);
    for i in 0..f {
        let h = tracker.frame(motion.frame(i));
        volume_mm3.push(h.volume_mm3);
        degenerate.push(h.degenerate);
        n_valid.push(motion.frame_missing(i).iter().filter(|m| !**m).count());
    }
    let mut change = vec![f64::NAN; f];
    for i in 1..f {
        let same_markers = motion.frame_missing(i) == motion.frame_missing(i - 1);
        if same_markers && degenerate[i].is_none() && degenerate[i - 1].is_none() {
            change[i] = (volume_mm3[i] - volume_mm3[i - 1]).abs();
        }
    }
    HullVolumes { volume_mm3, change_mm3_per_frame: change, degenerate, n_valid, stats: tracker.stats() }
}

/// Cached [`hull_volumes`]: the hull segmenter and the feature extractor share one computation.
pub fn cached_hull_volumes(motion: &Motion, cache: &FeatureCache) -> Result<Arc<HullVolumes>> {
    cache.get_or_compute("hull_volumes/all_valid_markers", || Ok(hull_volumes(motion)))
}

/// Per-frame volume of the 3-D convex hull of all valid markers, `Vol` (mm³), and its change
/// `D[i] = |Vol[i] − Vol[i−1]|` (mm³/frame) — "the space made by the body" of Sonoda et al. §2.3.
///
/// Outputs `Vol_mm3`, `D_mm3_per_frame` and `hull_degenerate` (1 on flagged frames, else 0).
/// Missing samples: the hull is taken over the frame's valid markers. A frame with fewer than 4
/// valid markers, or whose valid markers are all collinear or coplanar, has `Vol = 0` and is
/// flagged. `D` is NaN at frame 0, next to a flagged frame, and where the set of valid markers
/// changes from the previous frame (a marker dropping out is not a body change).
#[derive(Clone, Debug, Default, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct HullVolumeParams {}

impl ParamGuard for HullVolumeParams {
    type Checked = HullVolumeParams;
    fn check(self) -> Result<Self> {
        Ok(self)
    }
}

impl FeatureExtractor for HullVolumeParams {
    fn extract(&self, motion: &Motion, cache: &FeatureCache) -> Result<FeatureSet> {
        motion.require_frames(1, "hull_volume")?;
        let h = cached_hull_volumes(motion, cache)?;
        let flags = h.degenerate.iter().map(|d| if d.is_some() { 1.0 } else { 0.0 }).collect();
        Ok(FeatureSet {
            traces: vec![
                Trace::new("Vol_mm3", "mm³", h.volume_mm3.clone()),
                Trace::new("D_mm3_per_frame", "mm³/frame", h.change_mm3_per_frame.clone()),
                Trace::new("hull_degenerate", "", flags),
            ],
            labels: Vec::new(),
        })
    }
}

motionlab_core::register_plugin!(FeatureExtractor, HullVolumeParams, "hull_volume");

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_core::Motion;
    use motionlab_testkit::{Rng, cube_corners, motion_from_fn};

    fn vol(points: &[Point3]) -> f64 {
        let h = convex_hull_volume(points);
        assert_eq!(h.degenerate, None, "{points:?}");
        h.volume_mm3
    }

    fn close(a: f64, b: f64, rel: f64) -> bool {
        (a - b).abs() <= rel * a.abs().max(b.abs())
    }

    /// Independent computation: parry3d's convex hull (`try_convex_hull`), its volume by the
    /// divergence theorem about the points' centroid. (parry's `ConvexPolyhedron` mass
    /// properties were not used: they merge nearly coplanar faces with a tolerance and were
    /// found up to 1e-6 relative off on real frames, e.g. dance1 frame 237, where scipy/qhull
    /// and parry's own triangles agree with ours to 1e-15.)
    fn parry_volume(points: &[Point3]) -> f64 {
        let pts: Vec<parry3d_f64::math::Vector> = points.iter().map(|p| parry3d_f64::math::Vector::new(p[0], p[1], p[2])).collect();
        let (verts, idx) = parry3d_f64::transformation::try_convex_hull(&pts).expect("parry hull");
        let c = points.iter().fold([0.0; 3], |a, q| [a[0] + q[0], a[1] + q[1], a[2] + q[2]]).map(|x| x / points.len() as f64);
        let v = |i: u32| {
            let p = verts[i as usize];
            [p.x, p.y, p.z]
        };
        idx.iter()
            .map(|t| {
                let (a, b, d) = (sub(v(t[0]), c), sub(v(t[1]), c), sub(v(t[2]), c));
                a[0] * (b[1] * d[2] - b[2] * d[1]) - a[1] * (b[0] * d[2] - b[2] * d[0]) + a[2] * (b[0] * d[1] - b[1] * d[0])
            })
            .sum::<f64>()
            / 6.0
    }

    fn rotate(p: Point3, axis: Point3, angle: f64) -> Point3 {
        // Rodrigues' rotation about a unit axis.
        let (s, c) = angle.sin_cos();
        let k = axis;
        let kxp = [k[1] * p[2] - k[2] * p[1], k[2] * p[0] - k[0] * p[2], k[0] * p[1] - k[1] * p[0]];
        let kdp = k[0] * p[0] + k[1] * p[1] + k[2] * p[2];
        [0, 1, 2].map(|i| p[i] * c + kxp[i] * s + k[i] * kdp * (1.0 - c))
    }

    #[test]
    fn unit_cube_is_one_also_with_interior_surface_and_duplicate_points() {
        let cube = cube_corners([0.0; 3], 1.0);
        assert_eq!(vol(&cube), 1.0);
        let mut more = cube.clone();
        more.extend_from_slice(&cube); // every corner twice
        more.push([0.5, 0.5, 0.5]); // centre
        more.extend([[0.5, 0.5, 0.0], [0.5, 0.5, 1.0], [0.0, 0.5, 0.5], [0.5, 0.0, 0.0], [1.0, 1.0, 0.5]]); // on faces/edges
        assert!(close(vol(&more), 1.0, 1e-15), "{}", vol(&more));
        // A regular grid on the cube: many exactly coplanar facets and collinear edge points.
        let grid: Vec<Point3> = (0..125).map(|i| [(i % 5) as f64 * 0.25, (i / 5 % 5) as f64 * 0.25, (i / 25) as f64 * 0.25]).collect();
        assert!(close(vol(&grid), 1.0, 1e-15), "{}", vol(&grid));
    }

    #[test]
    fn regular_tetrahedron_has_its_exact_volume() {
        // Alternate corners of a cube of side s: a regular tetrahedron of edge a = s√2.
        let s = 300.0;
        let tet = [[0.0, 0.0, 0.0], [s, s, 0.0], [s, 0.0, s], [0.0, s, s]];
        let a = s * 2f64.sqrt();
        let exact = a * a * a / (6.0 * 2f64.sqrt());
        assert!(close(vol(&tet), exact, 1e-14), "{} vs {exact}", vol(&tet));
        assert!(close(exact, s * s * s / 3.0, 1e-14)); // the same number another way
    }

    #[test]
    fn random_points_in_a_cube_never_exceed_it_and_match_parry() {
        let mut rng = Rng::new(7);
        for trial in 0..200 {
            let n = 4 + trial % 60;
            let pts: Vec<Point3> = (0..n).map(|_| [rng.uniform() * 1000.0, rng.uniform() * 1000.0, rng.uniform() * 1000.0]).collect();
            let v = vol(&pts);
            assert!(v > 0.0 && v <= 1e9, "trial {trial}: {v}");
            let p = parry_volume(&pts);
            assert!(close(v, p, 1e-9), "trial {trial}, {n} points: ours {v}, parry {p}");
        }
    }

    #[test]
    fn planar_collinear_and_tiny_sets_are_flagged_with_volume_zero() {
        let square: Vec<Point3> = (0..20).map(|i| [(i % 5) as f64 * 10.0, (i / 5) as f64 * 7.0, 250.0]).collect();
        assert_eq!(convex_hull_volume(&square), HullVolume { volume_mm3: 0.0, degenerate: Some(Degeneracy::Coplanar) });
        // A tilted plane through non-representable coefficients: still exactly coplanar points?
        // Use integer coordinates on x + 2y − z = 5 so the plane is exact.
        let tilted: Vec<Point3> = (0..30).map(|i| {
            let (x, y) = ((i % 6) as f64 * 3.0, (i / 6) as f64 * 5.0);
            [x, y, x + 2.0 * y - 5.0]
        }).collect();
        assert_eq!(convex_hull_volume(&tilted).degenerate, Some(Degeneracy::Coplanar));
        let line: Vec<Point3> = (0..10).map(|i| [i as f64, 2.0 * i as f64, -3.0 * i as f64]).collect();
        assert_eq!(convex_hull_volume(&line).degenerate, Some(Degeneracy::Collinear));
        assert_eq!(convex_hull_volume(&[[1.0, 2.0, 3.0]; 9]).degenerate, Some(Degeneracy::Collinear));
        let three = [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        assert_eq!(convex_hull_volume(&three), HullVolume { volume_mm3: 0.0, degenerate: Some(Degeneracy::TooFewPoints) });
        // NaN points are skipped: 8 cube corners with 5 missing leave 3 -> too few.
        let mut cube = cube_corners([0.0; 3], 1.0);
        for p in cube.iter_mut().take(5) {
            *p = [f64::NAN; 3];
        }
        assert_eq!(convex_hull_volume(&cube).degenerate, Some(Degeneracy::TooFewPoints));
        // Coplanar points plus one off the plane: a proper (thin) hull, not flagged.
        let mut thin = square.clone();
        thin.push([20.0, 10.0, 250.5]);
        let v = vol(&thin);
        assert!(close(v, 40.0 * 21.0 * 0.5 / 3.0, 1e-12), "{v}"); // pyramid: base · height / 3
    }

    #[test]
    fn duplicates_do_not_change_the_volume() {
        let mut rng = Rng::new(11);
        let pts: Vec<Point3> = (0..30).map(|_| [rng.normal() * 300.0, rng.normal() * 300.0, rng.normal() * 500.0 + 1000.0]).collect();
        let v = vol(&pts);
        let mut dup = pts.clone();
        dup.extend(pts.iter().step_by(3).copied());
        dup.insert(0, pts[7]);
        assert_eq!(vol(&dup).to_bits(), v.to_bits().max(vol(&dup).to_bits()).min(vol(&dup).to_bits()));
        assert!(close(vol(&dup), v, 1e-14), "{} vs {v}", vol(&dup));
    }

    #[test]
    fn volume_is_invariant_under_rotation_and_translation() {
        let mut rng = Rng::new(3);
        let pts: Vec<Point3> = (0..40).map(|_| [rng.normal() * 200.0, rng.normal() * 150.0, rng.normal() * 600.0]).collect();
        let v = vol(&pts);
        let axis = {
            let a: Point3 = [0.3, -0.5, 0.81];
            let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
            a.map(|c| c / n)
        };
        for (angle, shift) in [(0.7, [1000.0, -2500.0, 800.0]), (2.9, [-3.0e4, 1.0e4, 5.0]), (-1.3, [0.0; 3])] {
            let moved: Vec<Point3> = pts.iter().map(|&p| {
                let r = rotate(p, axis, angle);
                [r[0] + shift[0], r[1] + shift[1], r[2] + shift[2]]
            }).collect();
            assert!(close(vol(&moved), v, 1e-9), "angle {angle}: {} vs {v}", vol(&moved));
        }
    }

    #[test]
    fn tracker_equals_rebuilding_every_frame_and_reuses_hulls() {
        // 30 markers drifting smoothly, one of them missing for a stretch, one frame flattened.
        let mut rng = Rng::new(5);
        let base: Vec<Point3> = (0..30).map(|_| [rng.normal() * 300.0, rng.normal() * 300.0, rng.normal() * 600.0]).collect();
        let phase: Vec<f64> = (0..30).map(|_| rng.uniform() * std::f64::consts::TAU).collect();
        let m = motion_from_fn(400, 120.0, 30, |i, k| {
            if (100..120).contains(&i) && k == 4 {
                return [f64::NAN; 3];
            }
            let t = i as f64 / 120.0;
            let p = base[k];
            let z = if i == 300 { 0.0 } else { p[2] * (1.0 + 0.2 * (3.0 * t + phase[k]).sin()) };
            [p[0] + 50.0 * (2.0 * t + phase[k]).sin(), p[1] + 40.0 * (1.5 * t).cos(), z]
        });
        let h = hull_volumes(&m);
        let mut scratch = HullBuilder::new();
        for i in 0..m.n_frames() {
            let valid: Vec<Point3> = m.frame(i).iter().copied().filter(|p| p[0].is_finite()).collect();
            let want = scratch.volume(&valid);
            assert_eq!(h.degenerate[i], want.degenerate, "frame {i}");
            assert!(close(h.volume_mm3[i], want.volume_mm3, 1e-12), "frame {i}: {} vs {}", h.volume_mm3[i], want.volume_mm3);
        }
        assert_eq!(h.flagged_frames(), vec![300]);
        assert!(h.stats.reused > 200, "{:?}", h.stats);
        assert_eq!(h.stats.reused + h.stats.rebuilt + h.stats.degenerate, 400);
        // D: NaN at 0, where the marker set changes (100 and 120) and next to the flat frame.
        let d = &h.change_mm3_per_frame;
        for i in [0, 100, 120, 300, 301] {
            assert!(d[i].is_nan(), "D[{i}] = {}", d[i]);
        }
        assert!(d[101].is_finite() && d[200].is_finite());
        assert_eq!(d[200], (h.volume_mm3[200] - h.volume_mm3[199]).abs());
        assert_eq!(h.n_valid[110], 29);
    }

    #[test]
    fn a_point_crossing_a_face_forces_a_rebuild() {
        // A tetrahedron (all facets triangles, so its triangles are certifiable) with a marker
        // moving from inside out through the face x + y + z = 300: the reused triangles must be
        // rejected the moment the point is above that face, even by 1e-9 mm.
        let mut tracker = HullTracker::new();
        let mut pts = vec![[0.0, 0.0, 0.0], [300.0, 0.0, 0.0], [0.0, 300.0, 0.0], [0.0, 0.0, 300.0], [100.0, 100.0, 99.0]];
        let tet = 300.0f64.powi(3) / 6.0;
        assert_eq!(tracker.frame(&pts).volume_mm3, tet);
        pts[4][2] = 99.5;
        assert_eq!(tracker.frame(&pts).volume_mm3, tet);
        assert_eq!(tracker.stats(), TrackerStats { reused: 1, rebuilt: 1, degenerate: 0 });
        // On the face: still the tetrahedron, but certification demands *strictly* below, so
        // the hull is rebuilt (same volume).
        pts[4][2] = 100.0;
        assert_eq!(tracker.frame(&pts).volume_mm3, tet);
        assert_eq!(tracker.stats().rebuilt, 2);
        pts[4][2] = 100.0 + 1e-9;
        let v = tracker.frame(&pts).volume_mm3;
        // The added sliver: det[b−a, c−a, p−a]/6 = 90000 · 1e-9 / 6 = 1.5e-5 mm³.
        assert!(v > tet, "{v}");
        assert!((v - (tet + 1.5e-5)).abs() < 1e-8, "{v}");
        assert_eq!(tracker.stats().rebuilt, 3);
        // Exactly coplanar facets (a cube's squares) are never certified, always rebuilt.
        let cube = cube_corners([0.0; 3], 100.0);
        let mut t2 = HullTracker::new();
        for _ in 0..3 {
            assert_eq!(t2.frame(&cube).volume_mm3, 1e6);
        }
        assert_eq!(t2.stats().reused, 0);
    }

    fn load(relative: &str) -> Motion {
        let path = motionlab_testkit::data_path(relative);
        if relative.contains(".amc") {
            let asf = motionlab_io::asf_amc::asf_candidates(&path).into_iter().find(|p| p.exists()).expect("asf");
            motionlab_io::asf_amc::load_asf_amc(&path, &asf, motionlab_core::FrameRate::new(120.0).unwrap()).unwrap()
        } else {
            let text = motionlab_io::read::read_text(&path).unwrap();
            motionlab_io::qualisys_tsv::parse_qualisys_tsv(&text, &path, motionlab_core::Axis::Z).unwrap()
        }
    }

    /// Exact check that `tris` bound the convex hull of `pts`: every directed edge appears once
    /// and its reverse once (a closed oriented surface), and no point is strictly above any
    /// triangle (Shewchuk's exact orient3d, independent of the builder's filtered predicates).
    fn is_exact_hull(pts: &[Point3], tris: &[[u32; 3]]) -> bool {
        let mut edges = std::collections::HashMap::new();
        for t in tris {
            for e in 0..3 {
                *edges.entry((t[e], t[(e + 1) % 3])).or_insert(0) += 1;
            }
        }
        let closed = edges.iter().all(|(&(u, v), &n)| n == 1 && edges.get(&(v, u)) == Some(&1));
        let supporting = tris.iter().all(|t| {
            let [a, b, c] = t.map(|i| pts[i as usize]);
            pts.iter().all(|&q| orient_exact(a, b, c, q) <= 0.0)
        });
        closed && supporting
    }

    /// Every frame of a real recording: our triangles are exactly the hull, the tracker agrees
    /// with rebuilding, and the volume equals parry3d's to 1e-9 relative.
    fn agrees_with_parry_on_every_frame(relative: &str) -> HullVolumes {
        let m = load(relative);
        let h = hull_volumes(&m);
        let mut builder = HullBuilder::new();
        for i in 0..m.n_frames() {
            let valid: Vec<Point3> = m.frame(i).iter().copied().filter(|p| p[0].is_finite()).collect();
            assert_eq!(h.degenerate[i], None, "{relative} frame {i}");
            let ours = builder.volume(&valid).volume_mm3;
            assert!(close(ours, h.volume_mm3[i], 1e-13), "{relative} frame {i}: tracker {} builder {ours}", h.volume_mm3[i]);
            let tris: Vec<[u32; 3]> = builder.triangles().collect();
            assert!(is_exact_hull(&valid, &tris), "{relative} frame {i}: not the exact hull");
            let p = parry_volume(&valid);
            assert!(close(ours, p, 1e-9), "{relative} frame {i}: ours {ours}, parry {p}");
        }
        h
    }

    #[test]
    fn real_cmu_skeleton_with_duplicate_joints_matches_parry() {
        // 86_01: 38 joints and end sites, several on one spot (root = lhipjoint = rhipjoint =
        // lowerback, lhand = lthumb, …). A standing adult's hull is tens of litres.
        let h = agrees_with_parry_on_every_frame("cmu86/86_01.amc.gz");
        assert_eq!(h.volume_mm3.len(), 4579);
        let median = { let mut v = h.volume_mm3.clone(); v.sort_by(f64::total_cmp); v[v.len() / 2] };
        assert!((2e7..3e8).contains(&median), "median hull {median} mm³");
        assert!(h.stats.reused > h.stats.rebuilt, "{:?}", h.stats); // duplicates do not defeat re-use
    }

    #[test]
    fn real_marker_data_with_missing_samples_matches_parry() {
        agrees_with_parry_on_every_frame("mct/dance1.tsv.gz");
        // walk1 has 27 missing samples: the hull is over the valid markers, D is NaN where the
        // set of valid markers changes, and nothing else is.
        let m = load("mct/walk1.tsv.gz");
        assert_eq!(m.missing_count(), 27);
        let h = agrees_with_parry_on_every_frame("mct/walk1.tsv.gz");
        let d = &h.change_mm3_per_frame;
        for (i, di) in d.iter().enumerate().skip(1) {
            let changed = m.frame_missing(i) != m.frame_missing(i - 1);
            assert_eq!(di.is_nan(), changed, "frame {i}");
        }
        assert!(h.n_valid.iter().any(|&n| n < 28));
    }

}
