//! [`HullTracker`]: per-frame hulls re-using the previous frame's triangles, certified unchanged
//! or after local repairs, rebuilt only when no repair applies.

use motionlab_core::Point3;

use super::kernel::{Soa, uncertain_triangles};
use super::predicates::{Plane, orient_exact};
use super::quickhull::HullBuilder;
use super::{HullVolume, NONE, is_finite};

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
/// give a wrong volume. A failed triangle none of these applies to is put back behind the other
/// failed triangles (their repairs often rewrite it) a bounded number of times. A point on a
/// plane (exactly), a visible region that is not a disc, or too many repairs in one frame falls
/// back to the quickhull rebuild. On 86_01 this turns 1772 of the 1778 rebuilds into repairs
/// (`crates/motionlab-features/benches/README.md`). Neighbours are found in O(1) through a
/// directed-edge table kept up to date by every triangle write; only the repairs' choices and an
/// early exit of the exact re-check read it (a point above a triangle fails it, neighbour or
/// not), never what passes a triangle or the closure check.
#[derive(Default)]
pub struct HullTracker {
    pub(super) builder: HullBuilder,
    /// The distinct valid points of the current frame.
    pub(super) compact: Vec<Point3>,
    /// Their indices in the frame (valid, first of each group of exact duplicates).
    pub(super) keep: Vec<u32>,
    /// The distinct valid points in the certification's layouts.
    pub(super) soa: Soa,
    /// Number of markers, and which were missing (not finite), at the last structure change.
    pub(super) n_markers: usize,
    pub(super) missing: Vec<u32>,
    /// `(k, j)`: marker `k` equalled marker `j < k` exactly at the last structure change.
    pub(super) dups: Vec<(u32, u32)>,
    /// Last frame's triangles, as indices into the distinct valid points. During a repair,
    /// removed triangles are marked `[NONE; 3]` (and dropped once the frame is certified).
    pub(super) prev_tris: Vec<[u32; 3]>,
    /// Triangles that failed certification this frame and still need a repair, with their
    /// vertices when they failed (an entry whose triangle was rewritten since is stale).
    pub(super) work: Vec<(u32, [u32; 3])>,
    /// Triangles a repair just wrote, as indices and as vertices (scratch).
    pub(super) fresh: Vec<u32>,
    pub(super) fresh_tris: Vec<[u32; 3]>,
    /// Triangles the fast test could not certify (scratch).
    pub(super) uncertain: Vec<u32>,
    /// `tri_six[j]`: six times the volume of the tetrahedron from the points' mean to triangle
    /// `j`, from its certification (their sum over the certified triangles is six times the
    /// hull's volume); `fresh_six` the same for `fresh_tris` (scratch).
    pub(super) tri_six: Vec<f64>,
    pub(super) fresh_six: Vec<f64>,
    /// Repair scratch: triangles visible from an inserted point, and their boundary.
    pub(super) visible: Vec<u32>,
    pub(super) horizon: Vec<(u32, u32)>,
    /// `edge_tri[u·n + v]`: the triangle of `prev_tris` holding directed edge (u, v), or NONE
    /// (`n` points), kept up to date by every write so a repair finds a neighbour in O(1). Only
    /// the repairs' choices depend on it, never a volume: what they produce is certified and
    /// checked closed like any other triangles.
    pub(super) edge_tri: Vec<u32>,
    /// Closure check scratch: `edge_seen[u·n + v] == edge_stamp` when directed edge (u, v) is
    /// present.
    pub(super) edge_seen: Vec<u32>,
    pub(super) edge_stamp: u32,
    /// Repairs disabled: certify unchanged triangles or rebuild (for comparison benchmarks).
    pub(super) no_repairs: bool,
    pub(super) stats: TrackerStats,
}

/// Most local repairs tried in one frame before falling back to a rebuild.
pub(super) const MAX_REPAIRS: usize = 16;
/// Most times in one frame a triangle no repair applies to is put back behind the others.
pub(super) const MAX_DEFERRALS: usize = 8;

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
        self.missing.clear();
        self.dups.clear();
    }

    /// Hull volume of the finite points of one frame (non-finite = missing, skipped).
    pub fn frame(&mut self, points: &[Point3]) -> HullVolume {
        // Same markers valid as last frame, and last rebuild's duplicates still duplicates: the
        // distinct points are gathered by index, no search. (The gather checks that the
        // gathered markers are all still valid; a duplicate equals a gathered marker, so it is.)
        let same_structure = !self.prev_tris.is_empty()
            && points.len() == self.n_markers
            && self.missing.iter().all(|&k| !is_finite(points[k as usize]))
            && self.dups.iter().all(|&(k, j)| points[k as usize] == points[j as usize])
            && self.soa.fill(points, &self.keep, &mut self.compact);
        if same_structure {
            let mut repairs = 0;
            let mut ok = self.certify(&mut repairs);
            self.stats.repairs += repairs;
            // Every triangle left was certified this frame, which computed its term (removed
            // ones are skipped): summed in triangle order, on every path alike (before the
            // removed ones are dropped, which renumbers the triangles).
            let six_volume: f64 = if ok {
                self.prev_tris
                    .iter()
                    .zip(&self.tri_six)
                    .filter(|(t, _)| t[0] != NONE)
                    .map(|(_, v)| v)
                    .sum()
            } else {
                0.0
            };
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
                return HullVolume { volume_mm3: six_volume / 6.0, degenerate: None };
            }
        } else {
            self.n_markers = points.len();
            self.missing.clear();
            self.keep.clear();
            for (i, &p) in points.iter().enumerate() {
                if is_finite(p) {
                    self.keep.push(i as u32);
                } else {
                    self.missing.push(i as u32);
                }
            }
            self.find_dups(points);
            self.soa.fill(points, &self.keep, &mut self.compact);
        }
        let h = self.builder.volume(&self.compact);
        self.prev_tris.clear();
        if h.degenerate.is_some() {
            self.stats.degenerate += 1;
        } else {
            self.stats.rebuilt += 1;
            self.prev_tris.extend(self.builder.triangles());
            self.index_edges();
        }
        h
    }

    /// Records every valid point that exactly equals an earlier one, as `(k, j)` indices into
    /// `points`, and drops the later ones from `keep` (O(n²), on structure changes only).
    pub(super) fn find_dups(&mut self, points: &[Point3]) {
        self.dups.clear();
        for (x, &k) in self.keep.iter().enumerate().skip(1) {
            if let Some(&j) =
                self.keep[..x].iter().find(|&&j| points[j as usize] == points[k as usize])
            {
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

    /// True when the previous triangles, possibly repaired, have every other point strictly
    /// below their planes. Counts the repairs made in `repairs`. A triangle certified once stays
    /// certified while others change (its test depends only on the points), so after a repair
    /// only the triangles it created are queued.
    pub(super) fn certify(&mut self, repairs: &mut usize) -> bool {
        let ext = self.soa.span.ext;
        // Every triangle first (the common case: all pass). The failed ones go on the `work`
        // stack with their vertices, in reverse so they are popped in index order.
        self.uncertain.clear();
        uncertain_triangles(
            &self.compact,
            &self.soa,
            &self.prev_tris,
            &mut self.uncertain,
            &mut self.tri_six,
        );
        self.work.clear();
        for x in (0..self.uncertain.len()).rev() {
            let ti = self.uncertain[x];
            let t = self.prev_tris[ti as usize];
            if !self.certify_slow(&t, ext) {
                self.work.push((ti, t));
            }
        }
        if !self.work.is_empty() && self.no_repairs {
            return false;
        }
        let mut deferrals = 0;
        while let Some((ti, t)) = self.work.pop() {
            if self.prev_tris[ti as usize] != t {
                // Rewritten or removed by a later repair, which certified what it wrote.
                continue;
            }
            if *repairs >= MAX_REPAIRS {
                return false;
            }
            let before = self.prev_tris.len() as u32;
            self.fresh.clear();
            match self.repair(ti, ext) {
                Repair::Replaced(tj) => self.fresh.extend([tj, ti]),
                Repair::Appended(tj) => {
                    // Triangles from `before` on are new, and `tj` was rewritten in place.
                    self.fresh.extend(before..self.prev_tris.len() as u32);
                    self.fresh.extend(tj);
                }
                Repair::Failed => {
                    // No repair of this triangle applies yet, but another failed triangle's may
                    // rewrite it (a fold elsewhere can show up here as a hull vertex above the
                    // plane): retry it after those, a bounded number of times.
                    let others_pending =
                        self.work.iter().any(|&(tj, s)| self.prev_tris[tj as usize] == s);
                    if others_pending && deferrals < MAX_DEFERRALS {
                        deferrals += 1;
                        self.work.insert(0, (ti, t));
                        continue;
                    }
                    return false;
                }
            }
            self.queue_failed();
            *repairs += 1;
        }
        true
    }

    /// Certifies the triangles a repair wrote (`fresh`, indices; removed ones are skipped) in
    /// one pass and pushes the failed ones onto `work` in the order given (the last is popped
    /// first). A triangle certified once stays certified while others change (its test depends
    /// only on its vertices and the points), so only these need it.
    pub(super) fn queue_failed(&mut self) {
        self.fresh_tris.clear();
        let mut kept = 0;
        for x in 0..self.fresh.len() {
            let ti = self.fresh[x];
            let t = self.prev_tris[ti as usize];
            if t[0] != NONE {
                self.fresh[kept] = ti;
                self.fresh_tris.push(t);
                kept += 1;
            }
        }
        self.fresh.truncate(kept);
        if kept == 0 {
            return;
        }
        self.uncertain.clear();
        uncertain_triangles(
            &self.compact,
            &self.soa,
            &self.fresh_tris,
            &mut self.uncertain,
            &mut self.fresh_six,
        );
        self.tri_six.resize(self.prev_tris.len(), 0.0);
        for (&j, &v) in self.fresh.iter().zip(&self.fresh_six) {
            self.tri_six[j as usize] = v;
        }
        for x in 0..self.uncertain.len() {
            let k = self.uncertain[x] as usize;
            let t = self.fresh_tris[k];
            if !self.certify_slow(&t, self.soa.span.ext) {
                self.work.push((self.fresh[k], t));
            }
        }
    }

    /// Exact re-check of the points the fast test could not certify for one triangle.
    pub(super) fn certify_slow(&self, t: &[u32; 3], ext: Point3) -> bool {
        let [a, b, c] = t.map(|i| self.compact[i as usize]);
        let pl = Plane::new(a, b, c, ext);
        // Most failures are a reflex edge: the far vertex of a neighbouring triangle is above.
        // Those three are looked up first.
        for e in 0..3 {
            if let Some((_, d)) = self.neighbour(t[(e + 1) % 3], t[e])
                && pl.eval(self.compact[d as usize]) > pl.bound
            {
                return false;
            }
        }
        self.compact.iter().enumerate().all(|(q, &p)| {
            let s = pl.eval(p);
            // Certainly above (most triangles that get here have such a point): fail without
            // the exact predicate.
            s < -pl.bound
                || (s <= pl.bound && (t.contains(&(q as u32)) || orient_exact(a, b, c, p) < 0.0))
        })
    }

    /// One local change for failed triangle `ti`: flip a reflex edge of it (or, when the flip
    /// is blocked, remove a degree-3 end of that edge), else insert the non-vertex point
    /// farthest above it.
    pub(super) fn repair(&mut self, ti: u32, ext: Point3) -> Repair {
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
    pub(super) fn flip_reflex_edge(&mut self, ti: u32, ext: Point3) -> Option<Repair> {
        let t = self.prev_tris[ti as usize];
        let [a, b, c] = t.map(|i| self.compact[i as usize]);
        let pl = Plane::new(a, b, c, ext);
        for e in 0..3 {
            let (u, v, w) = (t[e], t[(e + 1) % 3], t[(e + 2) % 3]);
            let Some((tj, d)) = self.neighbour(v, u) else {
                continue;
            };
            if d == w || pl.side_exact(a, b, c, self.compact[d as usize]) <= 0.0 {
                continue;
            }
            if self.has_edge(w, d) {
                if let Some(r) = self.remove_degree3(u, ext).or_else(|| self.remove_degree3(v, ext))
                {
                    return Some(r);
                }
                continue;
            }
            self.set_tri(ti, [u, d, w]);
            self.set_tri(tj, [d, v, w]);
            return Some(Repair::Replaced(tj));
        }
        None
    }

    /// Is every directed edge of the triangles present exactly once, and its reverse too?
    ///
    /// One pass: with no directed edge twice, counting the edges whose reverse was already seen
    /// counts each pair of opposite edges once, so every edge has its reverse exactly when that
    /// count is half the number of edges. (A triangle with a repeated vertex would pair an edge
    /// with itself, but it has a zero normal and never passes certification.)
    pub(super) fn is_closed(&mut self) -> bool {
        let n = self.compact.len();
        let tris = &self.prev_tris;
        if tris.as_flattened().iter().fold(0, |m, &v| m.max(v)) as usize >= n || tris.is_empty() {
            return false;
        }
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
        self.edge_tri.resize(self.edge_tri.len().max(n * n), NONE);
        let (seen, tri_of) = (self.edge_seen.as_mut_ptr(), self.edge_tri.as_mut_ptr());
        let (mut pairs, mut twice) = (0, false);
        for (j, t) in tris.iter().enumerate() {
            let [a, b, c] = t.map(|v| v as usize);
            let (an, bn, cn) = (a * n, b * n, c * n);
            for (edge, reverse) in [(an + b, bn + a), (bn + c, cn + b), (cn + a, an + c)] {
                // SAFETY: every vertex index is < n (checked above), so both keys are < n², and
                // both tables have at least n² entries.
                unsafe {
                    twice |= *seen.add(edge) == stamp;
                    *seen.add(edge) = stamp;
                    pairs += (*seen.add(reverse) == stamp) as usize;
                    // The triangles were renumbered by dropping the removed ones: index them again.
                    *tri_of.add(edge) = j as u32;
                }
            }
        }
        !twice && 2 * pairs == 3 * tris.len()
    }

    /// The triangle holding directed edge `(u, v)`, and its third vertex.
    pub(super) fn neighbour(&self, u: u32, v: u32) -> Option<(u32, u32)> {
        let j = *self.edge_tri.get(self.edge_key(u, v))?;
        let s = self.prev_tris.get(j as usize)?;
        (0..3).find(|&k| s[k] == u && s[(k + 1) % 3] == v).map(|k| (j, s[(k + 2) % 3]))
    }

    /// Is `{u, v}` an edge of the triangles (in either direction)?
    pub(super) fn has_edge(&self, u: u32, v: u32) -> bool {
        self.neighbour(u, v).is_some() || self.neighbour(v, u).is_some()
    }

    pub(super) fn edge_key(&self, u: u32, v: u32) -> usize {
        u as usize * self.compact.len() + v as usize
    }

    /// Writes triangle `j` (`[NONE; 3]` removes it), keeping `edge_tri` up to date.
    pub(super) fn set_tri(&mut self, j: u32, t: [u32; 3]) {
        let old = self.prev_tris[j as usize];
        if old[0] != NONE {
            for e in 0..3 {
                let key = self.edge_key(old[e], old[(e + 1) % 3]);
                if self.edge_tri[key] == j {
                    self.edge_tri[key] = NONE;
                }
            }
        }
        self.prev_tris[j as usize] = t;
        self.note_edges(j);
    }

    /// Records the directed edges of triangle `j` in `edge_tri`.
    pub(super) fn note_edges(&mut self, j: u32) {
        let t = self.prev_tris[j as usize];
        if t[0] != NONE {
            for e in 0..3 {
                let key = self.edge_key(t[e], t[(e + 1) % 3]);
                self.edge_tri[key] = j;
            }
        }
    }

    /// `edge_tri` from scratch.
    pub(super) fn index_edges(&mut self) {
        let n = self.compact.len();
        self.edge_tri.clear();
        self.edge_tri.resize(n * n, NONE);
        for j in 0..self.prev_tris.len() as u32 {
            self.note_edges(j);
        }
    }

    /// Replaces the three triangles around vertex `x` by the one spanned by its neighbours, when
    /// `x` has exactly three triangles forming a ring, is certainly below the new triangle, and
    /// the surface has more than four triangles.
    pub(super) fn remove_degree3(&mut self, x: u32, ext: Point3) -> Option<Repair> {
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
        let pl = Plane::new(
            self.compact[p0 as usize],
            self.compact[p1 as usize],
            self.compact[p2 as usize],
            ext,
        );
        if pl.eval(self.compact[x as usize]) >= -pl.bound {
            return None;
        }
        self.set_tri(around[0].0, new);
        self.set_tri(around[1].0, [NONE; 3]);
        self.set_tri(around[2].0, [NONE; 3]);
        Some(Repair::Appended(Some(around[0].0)))
    }

    /// Beneath–beyond insertion of non-vertex point `q`: the triangles it is strictly above
    /// (exact) are replaced by the cone from `q` over their boundary, when that boundary is one
    /// simple cycle.
    pub(super) fn insert_point(&mut self, q: u32, ext: Point3) -> Repair {
        let p = self.compact[q as usize];
        self.visible.clear();
        for (j, t) in self.prev_tris.iter().enumerate() {
            if t[0] == NONE {
                continue;
            }
            let [a, b, c] = t.map(|i| self.compact[i as usize]);
            let pl = Plane::new(a, b, c, ext);
            let side = pl.side_exact(a, b, c, p);
            if side == 0.0 {
                return Repair::Failed; // on a plane: leave it to a rebuild
            }
            if side > 0.0 {
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
        for x in 0..self.visible.len() {
            self.set_tri(self.visible[x], [NONE; 3]);
        }
        for x in 0..self.horizon.len() {
            let (u, v) = self.horizon[x];
            self.prev_tris.push([NONE; 3]);
            self.set_tri(self.prev_tris.len() as u32 - 1, [u, v, q]);
        }
        Repair::Appended(None)
    }
}

/// Outcome of [`HullTracker::repair`].
pub(super) enum Repair {
    /// Edge flipped: the failed triangle and this one were rewritten in place.
    Replaced(u32),
    /// Triangles appended (and possibly this one rewritten); removed ones marked `[NONE; 3]`.
    Appended(Option<u32>),
    /// No local repair applies: rebuild.
    Failed,
}
