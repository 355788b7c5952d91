//! Volume of the 3-D convex hull of a frame's markers and its change (Sonoda et al. §2.3).
//!
//! `Vol[i]` = volume (mm³) of the convex hull of every valid marker at frame `i`;
//! `D[i] = |Vol[i] − Vol[i−1]|` (mm³ per frame).
//!
//! # Why the hull is written here
//!
//! A body has 20–45 markers, and a sequence has thousands of frames. `parry3d-f64` (measured
//! here at 12 µs per 41-point frame) and `scipy.spatial.ConvexHull` (qhull, 61.5 µs with Python
//! overhead) are general-purpose and allocate per call, and neither can re-use last frame's
//! hull. The hull below is a quickhull with reusable buffers, and [`HullTracker`] exploits
//! temporal coherence: consecutive frames usually have the same hull combinatorics, which can be
//! *certified* much faster than rebuilt, and when they do not, the change is almost always local
//! (an edge flip, a point coming out, a vertex sinking in) and is *repaired* in place, then
//! certified, instead of rebuilt. See `crates/motionlab-features/benches/README.md` for the
//! measured numbers.
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
//! bound. When it fails (a point pokes out, an edge became reflex, or a hull vertex sank inward)
//! the tracker first tries local repairs of the triangles — edge flips, beneath–beyond insertion
//! of the point, removal of a degree-3 vertex — that keep the surface closed, and certifies the
//! result the same way (so the proof covers repaired triangles too); only when no repair applies
//! is the hull rebuilt. On CMU 86_01 39 % of the frames change combinatorics; all but 38 of
//! those 1778 frames are repaired.
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
    /// Frames whose hull was last frame's triangles after local repairs (edge flips, point
    /// insertions, vertex removals), then certified.
    pub repaired: usize,
    /// Frames built from scratch (first frame, changed marker set, or certification failed).
    pub rebuilt: usize,
    /// Degenerate frames (no hull).
    pub degenerate: usize,
    /// Local repairs made (in repaired frames and in frames whose repair failed).
    pub repairs: usize,
}

/// Per-frame hull volumes of a marker sequence, re-using the previous frame's triangles —
/// unchanged or locally repaired — when they are certified to still be the hull (see the module
/// docs for the proof), and rebuilding only when no local repair applies.
///
/// Exact duplicates (skeletons put several joints on one spot: CMU's `lthumb` starts where
/// `lhand` does) are dropped before the hull is built or certified: a duplicate of a hull vertex
/// lies *on* its triangles' planes and would defeat the strict certification.
///
/// # Local repairs
///
/// Most changes of the hull's combinatorics between consecutive frames are local: a nearly flat
/// quadrilateral changes its diagonal, a point comes out through a few triangles, a hull vertex
/// of degree 3 sinks in. When a triangle fails certification the tracker tries one such change
/// (edge flip, beneath–beyond insertion, degree-3 vertex removal; see `HullTracker::repair`)
/// and certifies the triangles it created. Each change keeps the surface closed with every
/// directed edge matched by its reverse exactly once and no triangle repeated, which is all the
/// certification's proof needs besides every triangle being certified; how the triangles were
/// obtained does not matter. The closure is also checked explicitly on every repaired frame
/// (`HullTracker::is_closed`), so a mistake in the repair code could cost a rebuild but never
/// give a wrong volume. A point on a plane (exactly), a visible region that is not a disc,
/// or too many repairs in one frame falls back to the quickhull rebuild. On 86_01 this turns
/// 1740 of the 1778 rebuilds into repairs (`crates/motionlab-features/benches/README.md`).
#[derive(Default)]
pub struct HullTracker {
    builder: HullBuilder,
    /// The distinct valid points of the current frame.
    compact: Vec<Point3>,
    /// Their indices in the frame (valid, first of each group of exact duplicates).
    keep: Vec<u32>,
    /// The distinct valid points, structure of arrays for the certification loop.
    xs: Vec<f64>,
    ys: Vec<f64>,
    zs: Vec<f64>,
    /// Which markers were valid at the last structure change (= last frame).
    prev_valid: Vec<bool>,
    /// `(k, j)`: marker `k` equalled marker `j < k` exactly at the last structure change.
    dups: Vec<(u32, u32)>,
    /// Last frame's triangles, as indices into the distinct valid points. During a repair,
    /// removed triangles are marked `[NONE; 3]` (and dropped once the frame is certified).
    prev_tris: Vec<[u32; 3]>,
    /// Triangles still to certify this frame.
    work: Vec<u32>,
    /// Repair scratch: triangles visible from an inserted point, and their boundary.
    visible: Vec<u32>,
    horizon: Vec<(u32, u32)>,
    /// Closure check scratch: `edge_seen[u·n + v] == edge_stamp` when directed edge (u, v) is
    /// present.
    edge_seen: Vec<u32>,
    edge_stamp: u32,
    /// Repairs disabled: certify unchanged triangles or rebuild (for comparison benchmarks).
    no_repairs: bool,
    stats: TrackerStats,
}

/// Most local repairs tried in one frame before falling back to a rebuild.
const MAX_REPAIRS: usize = 16;

impl HullTracker {
    pub fn new() -> Self {
        Self::default()
    }

    /// A tracker that never repairs: it re-uses last frame's triangles only when they are
    /// certified unchanged, else rebuilds (the same volumes; for benchmarking the repairs).
    pub fn without_repairs() -> Self {
        HullTracker { no_repairs: true, ..Self::default() }
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
        // Same markers valid as last frame, and last rebuild's duplicates still duplicates: the
        // distinct points are gathered by index, no search.
        let same_structure = !self.prev_tris.is_empty()
            && points.len() == self.prev_valid.len()
            && points.iter().zip(&self.prev_valid).all(|(p, &v)| p.iter().all(|c| c.is_finite()) == v)
            && self.dups.iter().all(|&(k, j)| points[k as usize] == points[j as usize]);
        if same_structure {
            self.compact.clear();
            self.compact.extend(self.keep.iter().map(|&i| points[i as usize]));
            self.fill_soa();
            let mut repairs = 0;
            let mut ok = self.certify(&mut repairs);
            self.stats.repairs += repairs;
            if ok && repairs > 0 {
                // The proof needs a closed surface. Every repair keeps it closed by construction;
                // checking it explicitly (cheap, repaired frames only) makes the volume's
                // correctness independent of the repair code.
                self.prev_tris.retain(|t| t[0] != NONE);
                ok = self.is_closed();
            }
            if ok {
                if repairs == 0 {
                    self.stats.reused += 1;
                } else {
                    self.stats.repaired += 1;
                }
                // The mean of the points is inside their hull: a safe apex for the volume sum.
                let k = self.xs.len() as f64;
                let o = [self.xs.iter().sum::<f64>() / k, self.ys.iter().sum::<f64>() / k, self.zs.iter().sum::<f64>() / k];
                return HullVolume { volume_mm3: volume_of_triangles(&self.compact, o, &self.prev_tris), degenerate: None };
            }
        } else {
            self.prev_valid.clear();
            self.keep.clear();
            for (i, p) in points.iter().enumerate() {
                let ok = p.iter().all(|c| c.is_finite());
                self.prev_valid.push(ok);
                if ok {
                    self.keep.push(i as u32);
                }
            }
            self.find_dups(points);
            self.compact.clear();
            self.compact.extend(self.keep.iter().map(|&i| points[i as usize]));
            self.fill_soa();
        }
        let h = self.builder.volume(&self.compact);
        self.prev_tris.clear();
        if h.degenerate.is_some() {
            self.stats.degenerate += 1;
        } else {
            self.stats.rebuilt += 1;
            self.prev_tris.extend(self.builder.triangles());
        }
        h
    }

    /// Records every valid point that exactly equals an earlier one, as `(k, j)` indices into
    /// `points`, and drops the later ones from `keep` (O(n²), on structure changes only).
    fn find_dups(&mut self, points: &[Point3]) {
        self.dups.clear();
        for (x, &k) in self.keep.iter().enumerate().skip(1) {
            if let Some(&j) = self.keep[..x].iter().find(|&&j| points[j as usize] == points[k as usize]) {
                self.dups.push((k, j));
            }
        }
        let dups = &self.dups;
        let mut d = 0;
        self.keep.retain(|&k| {
            let drop = d < dups.len() && dups[d].0 == k;
            d += drop as usize;
            !drop
        });
    }

    /// Fills the structure-of-arrays copy of `compact`.
    fn fill_soa(&mut self) {
        self.xs.clear();
        self.ys.clear();
        self.zs.clear();
        for p in &self.compact {
            self.xs.push(p[0]);
            self.ys.push(p[1]);
            self.zs.push(p[2]);
        }
    }

    /// True when the previous triangles, possibly repaired, have every other point strictly
    /// below their planes. Counts the repairs made in `repairs`. A triangle certified once stays
    /// certified while others change (its test depends only on the points), so after a repair
    /// only the triangles it created are queued.
    fn certify(&mut self, repairs: &mut usize) -> bool {
        let ext = extent(&self.compact);
        self.work.clear();
        self.work.extend((0..self.prev_tris.len() as u32).rev());
        while let Some(ti) = self.work.pop() {
            let t = self.prev_tris[ti as usize];
            if t[0] == NONE || self.certify_triangle(&t, ext) {
                continue;
            }
            if self.no_repairs || *repairs >= MAX_REPAIRS {
                return false;
            }
            let before = self.prev_tris.len() as u32;
            match self.repair(ti, ext) {
                Repair::Replaced(tj) => {
                    self.work.push(tj);
                    self.work.push(ti);
                }
                Repair::Appended(tj) => {
                    // Triangles from `before` on are new, and `tj` was rewritten in place.
                    self.work.extend(before..self.prev_tris.len() as u32);
                    self.work.extend(tj);
                }
                Repair::Failed => return false,
            }
            *repairs += 1;
        }
        true
    }

    /// Does triangle `t` have every other point strictly below its plane?
    #[inline]
    fn certify_triangle(&self, t: &[u32; 3], ext: Point3) -> bool {
        let (xs, ys, zs) = (&self.xs[..], &self.ys[..], &self.zs[..]);
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
        uncertain == 3 || self.certify_slow(t, &pl)
    }

    /// Exact re-check of the points the fast loop could not certify for one triangle.
    fn certify_slow(&self, t: &[u32; 3], pl: &Plane) -> bool {
        let [a, b, c] = t.map(|i| self.compact[i as usize]);
        self.compact.iter().enumerate().all(|(q, &p)| {
            t.contains(&(q as u32)) || pl.eval(p) < -pl.bound || orient_exact(a, b, c, p) < 0.0
        })
    }

    /// One local change for failed triangle `ti`: flip a reflex edge of it (or, when the flip
    /// is blocked, remove a degree-3 end of that edge), else insert the non-vertex point
    /// farthest above it.
    fn repair(&mut self, ti: u32, ext: Point3) -> Repair {
        if let Some(r) = self.flip_reflex_edge(ti, ext) {
            return r;
        }
        let t = self.prev_tris[ti as usize];
        let [a, b, c] = t.map(|i| self.compact[i as usize]);
        let pl = Plane::new(a, b, c, ext);
        let mut far = None;
        let mut far_s = pl.bound;
        for (q, &p) in self.compact.iter().enumerate() {
            let s = pl.eval(p);
            if s > far_s {
                (far, far_s) = (Some(q as u32), s);
            }
        }
        match far {
            Some(q) if !self.prev_tris.iter().any(|s| s.contains(&q)) => self.insert_point(q, ext),
            _ => Repair::Failed,
        }
    }

    /// Flips an edge `(u, v)` of triangle `ti = (u, v, w)` whose neighbour `(v, u, d)` has `d`
    /// strictly above `ti` (exact): the pair becomes `(u, d, w)`, `(d, v, w)`. When edge `wd`
    /// already exists the flip would not leave a manifold surface; then `u` or `v` has degree 3
    /// and is removed instead if it is certainly below its neighbours' plane.
    fn flip_reflex_edge(&mut self, ti: u32, ext: Point3) -> Option<Repair> {
        let t = self.prev_tris[ti as usize];
        let [a, b, c] = t.map(|i| self.compact[i as usize]);
        for e in 0..3 {
            let (u, v, w) = (t[e], t[(e + 1) % 3], t[(e + 2) % 3]);
            let Some((tj, d)) = self.neighbour(v, u) else {
                continue;
            };
            if d == w || orient_exact(a, b, c, self.compact[d as usize]) <= 0.0 {
                continue;
            }
            if self.prev_tris.iter().any(|s| s.contains(&w) && s.contains(&d)) {
                if let Some(r) = self.remove_degree3(u, ext).or_else(|| self.remove_degree3(v, ext)) {
                    return Some(r);
                }
                continue;
            }
            self.prev_tris[ti as usize] = [u, d, w];
            self.prev_tris[tj as usize] = [d, v, w];
            return Some(Repair::Replaced(tj));
        }
        None
    }

    /// Is every directed edge of the triangles present exactly once, and its reverse too?
    fn is_closed(&mut self) -> bool {
        let n = self.compact.len();
        let key = |u: u32, v: u32| u as usize * n + v as usize;
        self.edge_stamp = self.edge_stamp.wrapping_add(1);
        if self.edge_stamp == 0 {
            // Wrapped: forget every old stamp so none can be mistaken for the new one.
            self.edge_seen.fill(0);
            self.edge_stamp = 1;
        }
        let stamp = self.edge_stamp;
        if self.edge_seen.len() < n * n {
            self.edge_seen.clear();
            self.edge_seen.resize(n * n, 0);
        }
        for t in &self.prev_tris {
            for e in 0..3 {
                let Some(slot) = self.edge_seen.get_mut(key(t[e], t[(e + 1) % 3])) else {
                    return false;
                };
                if *slot == stamp {
                    return false; // directed edge twice
                }
                *slot = stamp;
            }
        }
        self.prev_tris.iter().all(|t| (0..3).all(|e| self.edge_seen.get(key(t[(e + 1) % 3], t[e])) == Some(&stamp)))
    }

    /// The triangle holding directed edge `(u, v)`, and its third vertex.
    fn neighbour(&self, u: u32, v: u32) -> Option<(u32, u32)> {
        self.prev_tris.iter().enumerate().find_map(|(j, s)| {
            (0..3).find(|&k| s[k] == u && s[(k + 1) % 3] == v).map(|k| (j as u32, s[(k + 2) % 3]))
        })
    }

    /// Replaces the three triangles around vertex `x` by the one spanned by its neighbours, when
    /// `x` has exactly three triangles forming a ring, is certainly below the new triangle, and
    /// the surface has more than four triangles.
    fn remove_degree3(&mut self, x: u32, ext: Point3) -> Option<Repair> {
        if self.prev_tris.iter().filter(|t| t[0] != NONE).count() <= 4 {
            return None;
        }
        let mut around = [(0u32, 0u32, 0u32); 3]; // (triangle, ring edge from, to)
        let mut k = 0;
        for (j, s) in self.prev_tris.iter().enumerate() {
            if let Some(i) = s.iter().position(|&y| y == x) {
                if k == 3 {
                    return None;
                }
                around[k] = (j as u32, s[(i + 1) % 3], s[(i + 2) % 3]);
                k += 1;
            }
        }
        if k != 3 {
            return None;
        }
        // The ring: p0 → p1 → p2 → p0.
        let (p0, p1) = (around[0].1, around[0].2);
        let &(_, _, p2) = around.iter().find(|r| r.1 == p1)?;
        if p2 == p0 || !around.iter().any(|r| r.1 == p2 && r.2 == p0) {
            return None;
        }
        let new = [p0, p1, p2];
        if self.prev_tris.iter().any(|s| new.iter().all(|y| s.contains(y))) {
            return None;
        }
        let pl = Plane::new(self.compact[p0 as usize], self.compact[p1 as usize], self.compact[p2 as usize], ext);
        if pl.eval(self.compact[x as usize]) >= -pl.bound {
            return None;
        }
        self.prev_tris[around[0].0 as usize] = new;
        self.prev_tris[around[1].0 as usize] = [NONE; 3];
        self.prev_tris[around[2].0 as usize] = [NONE; 3];
        Some(Repair::Appended(Some(around[0].0)))
    }

    /// Beneath–beyond insertion of non-vertex point `q`: the triangles it is strictly above
    /// (exact) are replaced by the cone from `q` over their boundary, when that boundary is one
    /// simple cycle.
    fn insert_point(&mut self, q: u32, ext: Point3) -> Repair {
        let p = self.compact[q as usize];
        self.visible.clear();
        for (j, t) in self.prev_tris.iter().enumerate() {
            if t[0] == NONE {
                continue;
            }
            let [a, b, c] = t.map(|i| self.compact[i as usize]);
            let pl = Plane::new(a, b, c, ext);
            let s = pl.eval(p);
            let above = if s > pl.bound {
                true
            } else if s < -pl.bound {
                false
            } else {
                let o = orient_exact(a, b, c, p);
                if o == 0.0 {
                    return Repair::Failed; // on a plane: leave it to a rebuild
                }
                o > 0.0
            };
            if above {
                self.visible.push(j as u32);
            }
        }
        self.horizon.clear();
        for &j in &self.visible {
            let t = self.prev_tris[j as usize];
            for e in 0..3 {
                let (u, v) = (t[e], t[(e + 1) % 3]);
                match self.neighbour(v, u) {
                    Some((k, _)) if self.visible.contains(&k) => {}
                    Some(_) => self.horizon.push((u, v)),
                    None => return Repair::Failed,
                }
            }
        }
        // One simple cycle: from every vertex exactly one horizon edge leaves, and walking from
        // the first edge visits all of them.
        let h = self.horizon.len();
        if h < 3 {
            return Repair::Failed;
        }
        let (start, mut at, mut steps) = (self.horizon[0].0, self.horizon[0].1, 1);
        while at != start {
            let mut next = self.horizon.iter().filter(|e| e.0 == at);
            let (Some(&(_, to)), None) = (next.next(), next.next()) else {
                return Repair::Failed;
            };
            at = to;
            steps += 1;
            if steps > h {
                return Repair::Failed;
            }
        }
        if steps != h {
            return Repair::Failed;
        }
        for &j in &self.visible {
            self.prev_tris[j as usize] = [NONE; 3];
        }
        self.prev_tris.extend(self.horizon.iter().map(|&(u, v)| [u, v, q]));
        Repair::Appended(None)
    }
}

/// Outcome of [`HullTracker::repair`].
enum Repair {
    /// Edge flipped: the failed triangle and this one were rewritten in place.
    Replaced(u32),
    /// Triangles appended (and possibly this one rewritten); removed ones marked `[NONE; 3]`.
    Appended(Option<u32>),
    /// No local repair applies: rebuild.
    Failed,
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
        assert_eq!(h.stats.reused + h.stats.repaired + h.stats.rebuilt + h.stats.degenerate, 400);
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
    fn a_point_crossing_a_face_is_caught() {
        // A tetrahedron (all facets triangles, so its triangles are certifiable) with a marker
        // moving from inside out through the face x + y + z = 300: the reused triangles must be
        // rejected the moment the point is above that face, even by 1e-9 mm.
        let mut tracker = HullTracker::new();
        let mut pts = vec![[0.0, 0.0, 0.0], [300.0, 0.0, 0.0], [0.0, 300.0, 0.0], [0.0, 0.0, 300.0], [100.0, 100.0, 99.0]];
        let tet = 300.0f64.powi(3) / 6.0;
        assert_eq!(tracker.frame(&pts).volume_mm3, tet);
        pts[4][2] = 99.5;
        assert_eq!(tracker.frame(&pts).volume_mm3, tet);
        assert_eq!(tracker.stats(), TrackerStats { reused: 1, repaired: 0, rebuilt: 1, degenerate: 0, repairs: 0 });
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
        // Repaired by inserting the point into last frame's triangles (not rebuilt), and the
        // repaired triangles were certified.
        assert_eq!(tracker.stats().rebuilt, 2);
        assert_eq!(tracker.stats().repaired, 1);
        // Back inside: the point (now a hull vertex of degree 3) is removed again.
        pts[4][2] = 99.0;
        assert_eq!(tracker.frame(&pts).volume_mm3, tet);
        assert_eq!((tracker.stats().rebuilt, tracker.stats().repaired), (2, 2));
        // Exactly coplanar facets (a cube's squares) are never certified, always rebuilt.
        let cube = cube_corners([0.0; 3], 100.0);
        let mut t2 = HullTracker::new();
        for _ in 0..3 {
            assert_eq!(t2.frame(&cube).volume_mm3, 1e6);
        }
        assert_eq!(t2.stats().reused, 0);
    }

    #[test]
    fn repairs_equal_rebuilding_on_jittering_point_clouds() {
        // Points near a sphere (many flips, points coming out and sinking in every frame),
        // jitter from tiny to large: every frame equals a from-scratch hull, and most frames
        // are repaired rather than rebuilt.
        for (seed, jitter) in [(1u64, 0.5), (2, 3.0), (3, 20.0), (4, 150.0)] {
            let mut rng = Rng::new(seed);
            let base: Vec<Point3> = (0..40).map(|_| {
                let v = [rng.normal(), rng.normal(), rng.normal()];
                let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                let r = 400.0 + 40.0 * rng.uniform();
                v.map(|c| r * c / n)
            }).collect();
            let mut walk = base.clone();
            let frames: Vec<Vec<Point3>> = (0..300).map(|_| {
                for p in walk.iter_mut() {
                    for c in p.iter_mut() {
                        *c += jitter * rng.normal();
                    }
                }
                walk.clone()
            }).collect();
            let m = motion_from_fn(300, 120.0, 40, |i, k| frames[i][k]);
            let mut t = HullTracker::new();
            let worst = max_rel_diff_tracker_vs_rebuild(&m, &mut t);
            assert!(worst <= 1e-12, "seed {seed}: {worst}");
            let st = t.stats();
            assert_eq!(st.reused + st.repaired + st.rebuilt + st.degenerate, 300);
            if jitter < 10.0 {
                assert!(st.rebuilt < 60, "seed {seed}: {st:?}");
            }
        }
    }

    #[test]
    fn closure_check_rejects_open_and_doubled_surfaces() {
        let mut t = HullTracker::new();
        let pts = [[0.0, 0.0, 0.0], [300.0, 0.0, 0.0], [0.0, 300.0, 0.0], [0.0, 0.0, 300.0]];
        assert_eq!(t.frame(&pts).volume_mm3, 4.5e6);
        assert!(t.is_closed());
        let tri = t.prev_tris.pop().unwrap();
        assert!(!t.is_closed()); // a hole
        t.prev_tris.push(tri);
        t.prev_tris.push(tri);
        assert!(!t.is_closed()); // a triangle twice
        t.prev_tris.pop();
        let [a, b, c] = tri;
        t.prev_tris.pop();
        t.prev_tris.push([a, c, b]);
        assert!(!t.is_closed()); // a triangle turned inside out
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

    /// Largest relative difference between the tracker's volume (certification, repairs,
    /// rebuilds) and a from-scratch quickhull of the frame's valid points, over every frame.
    fn max_rel_diff_tracker_vs_rebuild(m: &Motion, tracker: &mut HullTracker) -> f64 {
        let mut builder = HullBuilder::new();
        let mut worst: f64 = 0.0;
        for i in 0..m.n_frames() {
            let fast = tracker.frame(m.frame(i));
            let valid: Vec<Point3> = m.frame(i).iter().copied().filter(|p| p[0].is_finite()).collect();
            let want = builder.volume(&valid);
            assert_eq!(fast.degenerate, want.degenerate, "frame {i}");
            let rel = (fast.volume_mm3 - want.volume_mm3).abs() / want.volume_mm3.abs().max(f64::MIN_POSITIVE);
            if want.volume_mm3 != 0.0 || fast.volume_mm3 != 0.0 {
                worst = worst.max(rel);
            }
        }
        worst
    }

    #[test]
    fn fast_path_equals_rebuild_every_frame_on_real_takes() {
        for take in ["cmu86/86_01.amc.gz", "mct/dance1.tsv.gz", "mct/walk1.tsv.gz"] {
            let m = load(take);
            let mut fast = HullTracker::new();
            let worst = max_rel_diff_tracker_vs_rebuild(&m, &mut fast);
            let mut plain = HullTracker::without_repairs();
            let worst_plain = max_rel_diff_tracker_vs_rebuild(&m, &mut plain);
            eprintln!("{take}: max relative volume difference vs rebuild every frame {worst:.3e} (without repairs {worst_plain:.3e}); stats {:?}, without repairs {:?}", fast.stats(), plain.stats());
            assert!(worst <= 1e-9 && worst_plain <= 1e-9, "{take}: {worst} {worst_plain}");
        }
    }

    #[test]
    fn interior_points_racing_outward_are_caught() {
        // A fixed outer shell and interior points that move fast, leave the hull, come back and
        // sit exactly on faces: every frame must equal a from-scratch hull.
        let mut rng = Rng::new(19);
        let shell: Vec<Point3> = (0..14).map(|_| {
            let v = [rng.normal(), rng.normal(), rng.normal()];
            let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            v.map(|c| 500.0 * c / n)
        }).collect();
        let inner: Vec<(Point3, Point3)> = (0..12).map(|_| {
            ([rng.normal() * 60.0, rng.normal() * 60.0, rng.normal() * 60.0], [rng.normal(), rng.normal(), rng.normal()])
        }).collect();
        let m = motion_from_fn(600, 120.0, 26, |i, k| {
            let t = i as f64 / 120.0;
            if k < 14 {
                let p = shell[k];
                let w = 1.0 + 0.05 * (t * (1.0 + k as f64)).sin();
                [p[0] * w, p[1] * w, p[2] * w]
            } else {
                let (c, d) = inner[k - 14];
                // Speeds up to ~ 1000 mm per frame at the peaks.
                let s = 700.0 * (t * (2.0 + k as f64 * 0.3)).sin().powi(3);
                if i % 97 == 0 && k == 14 {
                    return shell[0]; // a duplicate of a shell vertex for one frame
                }
                [c[0] + s * d[0], c[1] + s * d[1], c[2] + s * d[2]]
            }
        });
        let mut t = HullTracker::new();
        let worst = max_rel_diff_tracker_vs_rebuild(&m, &mut t);
        assert!(worst <= 1e-12, "{worst}");
        assert!(t.stats().reused > 0, "{:?}", t.stats());
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
