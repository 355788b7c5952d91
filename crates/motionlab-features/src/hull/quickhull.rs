//! Quickhull with exact predicates and buffers reused across calls: the rebuild path of the
//! tracker, and [`convex_hull_volume`] for one point set.

use motionlab_core::Point3;

use super::predicates::{Plane, collinear_exact, orient_exact, orient_fast};
use super::{Degeneracy, HullVolume, NONE, is_finite, sub};

/// A triangle of the hull under construction (its plane is kept apart, in `HullBuilder::planes`,
/// so the topology walks touch less memory).
#[derive(Clone, Copy, Debug)]
pub(super) struct Face {
    pub(super) v: [u32; 3],
    /// `nbr[e]` is the face across edge `e` = (v[e], v[(e+1)%3]).
    pub(super) nbr: [u32; 3],
    /// Head of this face's outside set (a linked list through `HullBuilder::next`).
    pub(super) head: u32,
    /// The outside point farthest above the plane, and its plane value.
    pub(super) far: u32,
    pub(super) far_dist: f64,
    /// Visit stamp of the visibility search, and its verdict.
    pub(super) mark: u32,
    pub(super) visible: bool,
    pub(super) alive: bool,
}

/// Quickhull with exact predicates and buffers reused across calls (no allocation once warm).
#[derive(Default)]
pub struct HullBuilder {
    pub(super) pts: Vec<Point3>,
    pub(super) faces: Vec<Face>,
    pub(super) planes: Vec<Plane>,
    pub(super) next: Vec<u32>,
    pub(super) stack: Vec<u32>,
    pub(super) visible: Vec<u32>,
    pub(super) dfs: Vec<u32>,
    pub(super) horizon: Vec<(u32, u8)>,
    pub(super) new_faces: Vec<u32>,
    pub(super) by_start: Vec<u32>,
    pub(super) ext: Point3,
    /// An interior point (centroid of the initial tetrahedron), the apex for the volume sum.
    pub(super) inside: Point3,
    pub(super) stamp: u32,
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

    pub(super) fn current_volume(&self) -> f64 {
        let o = self.inside;
        let mut six_v = 0.0;
        for f in self.faces.iter().filter(|f| f.alive) {
            let [a, b, c] = f.v;
            six_v +=
                orient_fast(o, self.pts[a as usize], self.pts[b as usize], self.pts[c as usize]);
        }
        six_v / 6.0
    }

    pub(super) fn add_face(&mut self, v: [u32; 3]) -> u32 {
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
    pub(super) fn above(&self, f: u32, q: u32) -> Option<f64> {
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

    pub(super) fn push_outside(&mut self, f: u32, q: u32, dist: f64) {
        let face = &mut self.faces[f as usize];
        self.next[q as usize] = face.head;
        face.head = q;
        if face.far == NONE || dist > face.far_dist {
            face.far = q;
            face.far_dist = dist;
        }
    }

    pub(super) fn build(&mut self, points: &[Point3]) -> std::result::Result<(), Degeneracy> {
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
    pub(super) fn add_point(&mut self, start: u32, p: u32) {
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
pub(super) fn link_tetrahedron(faces: &mut [Face]) {
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
pub(super) fn extent(pts: &[Point3]) -> Point3 {
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
pub(super) fn initial_simplex(pts: &[Point3]) -> std::result::Result<[usize; 4], Degeneracy> {
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
        let c = [
            ab[1] * aq[2] - ab[2] * aq[1],
            ab[2] * aq[0] - ab[0] * aq[2],
            ab[0] * aq[1] - ab[1] * aq[0],
        ];
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
        (0..pts.len())
            .find(|&q| orient_exact(a, b, c, pts[q]) != 0.0)
            .ok_or(Degeneracy::Coplanar)?
    } else {
        i3
    };
    if orient_exact(a, b, c, pts[i3]) > 0.0 {
        Ok([i0, i2, i1, i3]) // d above (a, b, c): swap b and c so it is below
    } else {
        Ok([i0, i1, i2, i3])
    }
}

pub(super) fn argmax(n: usize, f: impl Fn(usize) -> f64) -> usize {
    let (mut bi, mut bv) = (0, f64::NEG_INFINITY);
    for i in 0..n {
        let v = f(i);
        if v > bv {
            (bi, bv) = (i, v);
        }
    }
    bi
}

/// Hull volume of the finite points of `points` (non-finite ones are skipped as missing).
pub fn convex_hull_volume(points: &[Point3]) -> HullVolume {
    let valid: Vec<Point3> = points.iter().copied().filter(|&p| is_finite(p)).collect();
    HullBuilder::new().volume(&valid)
}
