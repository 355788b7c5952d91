//! Retrieval across a corpus: the `k` most similar and the `k` most dissimilar stretches of a
//! set of takes to one model motion, by the two-stage multistream match (Yabe & Tanaka §3.1.3),
//! exactly as an exhaustive search finds them but with most candidates never matched.
//!
//! ## What is ranked
//!
//! **Candidates** are windows: in each take, `window_frames` consecutive frames starting at
//! every multiple of `stride_frames` (and one more window ending at the take's last frame when
//! the stride does not land there; a take shorter than a window is one window). Each candidate
//! is matched to the model by the two-stage match ([`crate::multistream`]) as if the window had
//! been cut out: common end `b = argmin_j G(j)`, common start `a`, distance `H = Σ_l h_l` over
//! the stretch `[a, b]` — the paper's matching of a cut repetition, applied to every window.
//!
//! - **Most similar**: candidates by `H` ascending. **Most dissimilar**: candidates by `H`
//!   descending — the windows whose *best* match to the model is the worst: even the stretch
//!   that resembles the model most is far from it.
//! - **Non-overlapping**: each list is chosen greedily — the best remaining candidate is taken
//!   unless its matched stretch `[a, b]` shares a frame with a stretch already in the list (same
//!   take), until `k` are taken or the candidates run out (then the list is shorter than `k`).
//!   Ties in `H` go to the earlier candidate (takes in the given order, windows by start).
//! - The lists are independent: a stretch may be in both (only when there are few candidates).
//!
//! ## Exact pruning
//!
//! Both lists are the same greedy selections run **lazily** (best-first): a priority queue
//! holds each candidate under a *bound* of its `H`; the best entry is popped; if it holds a bound
//! the candidate is matched and pushed back under its exact `H`; if it holds an exact `H`, that
//! `H` is at least as good as every bound in the queue, and so as every remaining candidate's
//! true `H` — it is exactly the candidate the exhaustive greedy takes next (ties by the same
//! order: key, then candidate index), and it is kept unless it overlaps a kept stretch, as there.
//! The search stops when `k` are kept; candidates whose bound never reaches the top are never
//! matched. Nothing valid is dropped as long as each bound is on the right side of the true `H`:
//!
//! - **Lower bound (similar list).** One forward pass per take over the *whole* take gives
//!   `G*(j) = Σ_l h*_l(j)`, `h*_l(j)` the least cost of matching the whole model to any stretch
//!   of the take ending at `j` (free start anywhere). A window's `H = Σ_l C_l(a, b)` with
//!   `C_l(a, b)` the cost of the best path from `(0, a)` to `(n−1, b)`, a path with a start
//!   inside the window, so `C_l(a, b) ≥ h*_l(b)` for each marker and
//!   `H ≥ G*(b) ≥ min_{j ∈ window} G*(j)` (`b` lies in the window). In floating point the
//!   forward and backward passes add the same path's distances in opposite orders; each
//!   computed path sum of `N ≤ n + W − 1` non-negative terms is within a factor `1 ± γ_N`
//!   (`γ_N = N·u/(1 − N·u)`, `u = 2⁻⁵³`) of the exact sum, and the sum over `L` markers within
//!   `1 ± γ_L`; the bound used is therefore `min G* · (1 − 4(N + L + 2)·u)`, below
//!   `(1−γ_N)(1−γ_L)/((1+γ_N)(1+γ_L)) · min G*` by a margin that also covers the product's own
//!   rounding ([`lower_bound_factor`]).
//! - **Upper bound (dissimilar list).** `H` is the least summed cost over the starts the
//!   two-stage match compares at its end `b`, and each start's cost is at most that of any one
//!   path. Two paths ending at `b`: down column `b` (every model frame matched to frame `b`,
//!   start `b`), summed over markers `U(b)`; and the lockstep path (model frame `i` to frame
//!   `b − n + 1 + i`, start `b − n + 1`, when that is inside the window), `D(b)`. So
//!   `H ≤ min(U(b), D(b)) ≤ max_{j ∈ window} min(U(j), D(j))` (`D` left out where its start
//!   falls before the window). `U` and `D` are added by the backward pass's own additions in
//!   its own order ([`crate::lanes`]), and the computed DP cells are minima over paths of such
//!   sums (float addition of non-negative numbers is monotone): the bound holds exactly in
//!   floating point, with no margin.
//!
//! The bounds cost one pass over each take (`n·m·L` cells for `G*`, twice as many distances for
//! `U` and `D`),
//! against `≈ 2·W/stride` passes for matching every window. Matching in the lazy phase runs a
//! fixed batch of [`BATCH`] queue entries at a time in parallel (an entry matched early only
//! makes its key exact sooner; the selection does not change), and the bound passes run in
//! parallel over the takes (rayon).
//!
//! ## Missing samples
//!
//! Refused, as by the two-stage matcher: the caller extracts finite trajectories
//! ([`crate::input::trajectories`] refuses missing samples, naming the marker and frame).

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use rayon::prelude::*;

use crate::Alignment;
use motionlab_core::{Error, ErrorKind, Result};

use crate::dp::Trajectory3;
use crate::lanes::{self, Cell8, MarkerBlocks};
use crate::multistream::{marker_blocks, summed_end_costs, two_stage_at};
use crate::simd::{self, Level};

/// Queue entries matched together in the lazy phase (fixed, so the number of matched candidates
/// does not depend on the machine's thread count).
pub const BATCH: usize = 4;

/// What to retrieve and how.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RetrievalSettings {
    /// Length of the most similar list (0: none).
    pub k_similar: usize,
    /// Length of the most dissimilar list (0: none).
    pub k_dissimilar: usize,
    /// Candidate window length (frames, ≥ 1).
    pub window_frames: usize,
    /// Step between window starts (frames, ≥ 1).
    pub stride_frames: usize,
    /// Bounds and lazy search (true) or every window matched (false); same lists either way.
    pub pruning: bool,
}

/// One candidate window and what the search learnt about it.
#[derive(Clone, Debug, PartialEq)]
pub struct Candidate {
    /// Index of the take (in the order given).
    pub take: usize,
    /// First frame of the window in the take.
    pub window_start: usize,
    /// One past the window's last frame.
    pub window_end: usize,
    /// Lower bound on `H` (mm; pruned search with a similar list only).
    pub lower_bound: Option<f64>,
    /// Upper bound on `H` (mm; pruned search with a dissimilar list only).
    pub upper_bound: Option<f64>,
    /// The match, when the search matched this window.
    pub matched: Option<Matched>,
}

/// A window's two-stage match: the stretch in frames of the take, and `H`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Matched {
    /// `a` (frame of the take).
    pub start: usize,
    /// `b` (frame of the take, inclusive).
    pub end: usize,
    /// `H` (mm).
    pub total_distance: f64,
}

/// One retrieved stretch.
#[derive(Clone, Debug, PartialEq)]
pub struct Hit {
    /// 1 = most similar (or most dissimilar, in that list).
    pub rank: usize,
    /// Index into [`Retrieval::candidates`].
    pub candidate: usize,
    pub take: usize,
    pub window_start: usize,
    pub window_end: usize,
    /// The full match with every marker's path; its frame indices count from `window_start`.
    pub alignment: Alignment,
}

/// The two lists and every candidate.
#[derive(Clone, Debug, PartialEq)]
pub struct Retrieval {
    pub candidates: Vec<Candidate>,
    pub similar: Vec<Hit>,
    pub dissimilar: Vec<Hit>,
    /// How many candidates were matched to rank them (the exhaustive search: all).
    pub matched_candidates: usize,
}

/// The window starts and ends (`[start, end)`) of a take of `frames` frames.
pub fn windows(frames: usize, window_frames: usize, stride_frames: usize) -> Vec<(usize, usize)> {
    if frames == 0 || window_frames == 0 || stride_frames == 0 {
        return Vec::new();
    }
    if frames <= window_frames {
        return vec![(0, frames)];
    }
    let last = frames - window_frames;
    let mut out: Vec<(usize, usize)> =
        (0..=last).step_by(stride_frames).map(|s| (s, s + window_frames)).collect();
    if out.last().is_some_and(|&(s, _)| s != last) {
        out.push((last, frames));
    }
    out
}

/// The factor a minimum of `G*` is multiplied by to stay below every computed `H` it bounds
/// (module docs): `1 − 4(N + L + 2)·2⁻⁵³` for paths of at most `N` cells over `L` markers.
pub fn lower_bound_factor(max_path_cells: usize, markers: usize) -> f64 {
    1.0 - 4.0 * (max_path_cells + markers + 2) as f64 * f64::EPSILON / 2.0
}

/// Per-marker trajectories positioned relative to one of them in every frame
/// (`p_l(i) − p_r(i)`): the same movement anywhere in the room gives the same trajectories.
pub fn relative_to_point(trajectories: &mut [Trajectory3], reference: usize) -> Result<()> {
    let Some(r) = trajectories.get(reference).cloned() else {
        return Err(Error::new(
            ErrorKind::OutOfRange,
            format!("reference point {reference} of {} points does not exist", trajectories.len()),
        ));
    };
    for t in trajectories.iter_mut() {
        if t.len() != r.len() {
            return Err(Error::new(
                ErrorKind::WrongValueCount,
                "marker trajectories of unequal lengths",
            ));
        }
        for (v, o) in [(&mut t.x, &r.x), (&mut t.y, &r.y), (&mut t.z, &r.z)] {
            v.iter_mut().zip(o).for_each(|(p, q)| *p -= q);
        }
    }
    Ok(())
}

struct Prepared {
    level: Level,
    model: MarkerBlocks,
    takes: Vec<MarkerBlocks>,
    candidates: Vec<Candidate>,
}

fn prepare(
    model: &[Trajectory3],
    takes: &[Vec<Trajectory3>],
    settings: &RetrievalSettings,
) -> Result<Prepared> {
    if takes.is_empty() {
        return Err(Error::new(
            ErrorKind::EmptySequence,
            "retrieval needs at least one take to search, found none",
        ));
    }
    if settings.window_frames == 0 || settings.stride_frames == 0 {
        return Err(Error::new(
            ErrorKind::OutOfRange,
            format!(
                "windows need a length and a stride of at least one frame, found {} and {}",
                settings.window_frames, settings.stride_frames
            ),
        ));
    }
    let mut model_blocks = None;
    let mut blocks = Vec::with_capacity(takes.len());
    for (k, take) in takes.iter().enumerate() {
        let (s, t) = marker_blocks(model, take).map_err(|e| e.under_field(format!("take {k}")))?;
        model_blocks.get_or_insert(s);
        blocks.push(t);
    }
    let model = model_blocks.ok_or_else(|| Error::new(ErrorKind::EmptySequence, "no take"))?;
    let mut candidates = Vec::new();
    for (k, t) in blocks.iter().enumerate() {
        for (s, e) in windows(t.frames(), settings.window_frames, settings.stride_frames) {
            candidates.push(Candidate {
                take: k,
                window_start: s,
                window_end: e,
                lower_bound: None,
                upper_bound: None,
                matched: None,
            });
        }
    }
    Ok(Prepared { level: simd::level(), model, takes: blocks, candidates })
}

impl Prepared {
    fn match_window(&self, c: &Candidate, keep_paths: bool) -> Result<Alignment> {
        let t = &self.takes[c.take];
        Ok(two_stage_at(self.level, &self.model, t, c.window_start..c.window_end, keep_paths)?
            .alignment)
    }

    fn matched(&self, c: &Candidate) -> Result<Matched> {
        let a = self.match_window(c, false)?;
        Ok(Matched {
            start: c.window_start + a.start,
            end: c.window_start + a.end,
            total_distance: a.total_distance,
        })
    }

    /// `U(j)` (with `pass = lanes::column`) or `D(j)` (`lanes::diagonal`) for every frame of
    /// take `k`, markers added in order as the two-stage match adds its start costs.
    fn path_costs(
        &self,
        k: usize,
        pass: fn(Level, &[lanes::Frame8], &[lanes::Frame8], &mut Vec<Cell8>),
    ) -> Vec<f64> {
        let t = &self.takes[k];
        let mut u = vec![0.0; t.frames()];
        let mut cells: Vec<Cell8> = Vec::new();
        for b in 0..self.model.block_count() {
            pass(self.level, self.model.block(b), t.block(b), &mut cells);
            for (acc, c) in u.iter_mut().zip(&cells) {
                for v in &c.0[..self.model.used(b)] {
                    *acc += v;
                }
            }
        }
        u
    }

    /// Fills the bounds of every candidate (parallel over takes).
    fn bound(&mut self, lower: bool, upper: bool) {
        let factor = lower_bound_factor(
            self.model.frames()
                + self.candidates.iter().map(|c| c.window_end - c.window_start).max().unwrap_or(0),
            self.model.markers(),
        );
        type PathCosts = (Vec<f64>, Vec<f64>);
        let per_take: Vec<(Option<Vec<f64>>, Option<PathCosts>)> = (0..self.takes.len())
            .into_par_iter()
            .map(|k| {
                let t = &self.takes[k];
                let g = lower.then(|| {
                    summed_end_costs(self.level, &self.model, t, 0..t.frames(), &mut Vec::new())
                });
                let u = upper.then(|| {
                    (self.path_costs(k, lanes::column), self.path_costs(k, lanes::diagonal))
                });
                (g, u)
            })
            .collect();
        let n = self.model.frames();
        for c in &mut self.candidates {
            let (g, u) = &per_take[c.take];
            let span = c.window_start..c.window_end;
            c.lower_bound = g
                .as_ref()
                .map(|g| g[span.clone()].iter().copied().fold(f64::INFINITY, f64::min) * factor);
            // The lockstep path ending at b starts at b − n + 1: inside the window or not a path.
            c.upper_bound = u.as_ref().map(|(column, diagonal)| {
                span.clone()
                    .map(|b| {
                        if b + 1 >= c.window_start + n {
                            column[b].min(diagonal[b])
                        } else {
                            column[b]
                        }
                    })
                    .fold(f64::NEG_INFINITY, f64::max)
            });
        }
    }

    fn hits(&self, chosen: &[usize]) -> Result<Vec<Hit>> {
        chosen
            .par_iter()
            .enumerate()
            .map(|(rank, &i)| {
                let c = &self.candidates[i];
                Ok(Hit {
                    rank: rank + 1,
                    candidate: i,
                    take: c.take,
                    window_start: c.window_start,
                    window_end: c.window_end,
                    alignment: self.match_window(c, true)?,
                })
            })
            .collect()
    }
}

/// Which list: the order of `H` that counts as better.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Side {
    Similar,
    Dissimilar,
}

impl Side {
    /// `Less` when `(x, i)` comes before `(y, j)`: better `H`, then the earlier candidate.
    fn order(self, x: f64, i: usize, y: f64, j: usize) -> Ordering {
        // `+ 0.0` makes −0 and +0 one key.
        let by_value = (x + 0.0).total_cmp(&(y + 0.0));
        let by_value = if self == Side::Similar { by_value } else { by_value.reverse() };
        by_value.then(i.cmp(&j))
    }
}

fn overlaps(candidates: &[Candidate], chosen: &[usize], i: usize) -> bool {
    let Some(m) = candidates[i].matched else { return false };
    chosen.iter().any(|&c| {
        candidates[c].take == candidates[i].take
            && candidates[c].matched.is_some_and(|o| o.start <= m.end && m.start <= o.end)
    })
}

/// The exhaustive greedy selection over matched candidates (every candidate matched).
fn select_exhaustive(candidates: &[Candidate], side: Side, k: usize) -> Vec<usize> {
    let h = |i: usize| candidates[i].matched.map_or(f64::NAN, |m| m.total_distance);
    let mut order: Vec<usize> = (0..candidates.len()).collect();
    order.sort_by(|&i, &j| side.order(h(i), i, h(j), j));
    let mut chosen = Vec::new();
    for i in order {
        if chosen.len() == k {
            break;
        }
        if !overlaps(candidates, &chosen, i) {
            chosen.push(i);
        }
    }
    chosen
}

/// A queue entry: the best-first order is the max-heap order.
struct Entry {
    side: Side,
    key: f64,
    candidate: usize,
    exact: bool,
}

impl PartialEq for Entry {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}
impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Entry {
    fn cmp(&self, o: &Self) -> Ordering {
        // Better comes out of the max-heap first.
        self.side.order(self.key, self.candidate, o.key, o.candidate).reverse()
    }
}

/// The lazy (best-first) greedy selection: the same list as [`select_exhaustive`] (module
/// docs), matching candidates only when their bound reaches the top of the queue.
fn select_lazy(p: &mut Prepared, side: Side, k: usize) -> Result<Vec<usize>> {
    let mut heap: BinaryHeap<Entry> = p
        .candidates
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let (key, exact) = match (c.matched, side) {
                (Some(m), _) => (m.total_distance, true),
                (None, Side::Similar) => (c.lower_bound.unwrap_or(0.0), false),
                (None, Side::Dissimilar) => (c.upper_bound.unwrap_or(f64::INFINITY), false),
            };
            Entry { side, key, candidate: i, exact }
        })
        .collect();
    let mut chosen = Vec::new();
    while chosen.len() < k {
        let Some(top) = heap.pop() else { break };
        if top.exact {
            if !overlaps(&p.candidates, &chosen, top.candidate) {
                chosen.push(top.candidate);
            }
            continue;
        }
        let mut batch = vec![top.candidate];
        while batch.len() < BATCH && heap.peek().is_some_and(|e| !e.exact) {
            if let Some(e) = heap.pop() {
                batch.push(e.candidate);
            }
        }
        let matched: Vec<Matched> =
            batch.par_iter().map(|&i| p.matched(&p.candidates[i])).collect::<Result<_>>()?;
        for (i, m) in batch.into_iter().zip(matched) {
            p.candidates[i].matched = Some(m);
            heap.push(Entry { side, key: m.total_distance, candidate: i, exact: true });
        }
    }
    Ok(chosen)
}

/// The `k` most similar and `k` most dissimilar non-overlapping stretches of `takes` to `model`
/// (module docs). `model` and every take hold the same markers in the same order, finite
/// samples (`takes[t][l]` is marker `l` of take `t`).
///
/// Fails when there is no take, a take has no frames or other markers than the model, or the
/// window length or stride is 0.
pub fn retrieve(
    model: &[Trajectory3],
    takes: &[Vec<Trajectory3>],
    settings: &RetrievalSettings,
) -> Result<Retrieval> {
    let mut p = prepare(model, takes, settings)?;
    let (similar, dissimilar) = if settings.pruning {
        p.bound(settings.k_similar > 0, settings.k_dissimilar > 0);
        let s = select_lazy(&mut p, Side::Similar, settings.k_similar)?;
        let d = select_lazy(&mut p, Side::Dissimilar, settings.k_dissimilar)?;
        (s, d)
    } else {
        let matched: Vec<Matched> =
            p.candidates.par_iter().map(|c| p.matched(c)).collect::<Result<_>>()?;
        for (c, m) in p.candidates.iter_mut().zip(matched) {
            c.matched = Some(m);
        }
        (
            select_exhaustive(&p.candidates, Side::Similar, settings.k_similar),
            select_exhaustive(&p.candidates, Side::Dissimilar, settings.k_dissimilar),
        )
    };
    let matched_candidates = p.candidates.iter().filter(|c| c.matched.is_some()).count();
    Ok(Retrieval {
        similar: p.hits(&similar)?,
        dissimilar: p.hits(&dissimilar)?,
        matched_candidates,
        candidates: p.candidates,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::multistream::two_stage;
    use motionlab_testkit::Rng;

    /// A smooth movement per marker (mm), phase `t` in frames.
    fn movement(t: f64, l: usize) -> [f64; 3] {
        let l = l as f64;
        [
            300.0 * (0.11 * t + l).sin() + 20.0 * l,
            200.0 * (0.077 * t + 2.0 * l).cos(),
            150.0 * (0.143 * t - l).sin(),
        ]
    }

    fn traj(
        frames: usize,
        markers: usize,
        f: impl Fn(usize, usize) -> [f64; 3],
    ) -> Vec<Trajectory3> {
        (0..markers)
            .map(|l| Trajectory3::from_points(&(0..frames).map(|i| f(i, l)).collect::<Vec<_>>()))
            .collect()
    }

    fn settings(k: usize, window: usize, stride: usize, pruning: bool) -> RetrievalSettings {
        RetrievalSettings {
            k_similar: k,
            k_dissimilar: k,
            window_frames: window,
            stride_frames: stride,
            pruning,
        }
    }

    /// (take, a, b, H) of each listed stretch.
    type Listed = Vec<(usize, usize, usize, f64)>;

    fn summary(r: &Retrieval) -> (Listed, Listed) {
        let s = |h: &[Hit]| {
            h.iter()
                .map(|x| {
                    (
                        x.take,
                        x.window_start + x.alignment.start,
                        x.window_start + x.alignment.end,
                        x.alignment.total_distance,
                    )
                })
                .collect()
        };
        (s(&r.similar), s(&r.dissimilar))
    }

    #[test]
    fn windows_cover_the_take_and_end_at_its_last_frame() {
        assert_eq!(windows(10, 4, 3), vec![(0, 4), (3, 7), (6, 10)]);
        assert_eq!(windows(11, 4, 3), vec![(0, 4), (3, 7), (6, 10), (7, 11)]);
        assert_eq!(windows(3, 4, 3), vec![(0, 3)]);
        assert_eq!(windows(0, 4, 3), vec![]);
    }

    #[test]
    fn finds_planted_copies_in_known_order_and_the_far_stretch_as_most_dissimilar() {
        // Three takes of noise around a still pose; the model (30 frames) is planted exactly
        // in take 1 at 50, with 2 mm of jitter in take 0 at 120, and with 10 mm in take 2 at 20.
        // Take 2 also holds a stretch 5 m away (frames 100..160).
        let (n, markers) = (30usize, 5usize);
        let model = traj(n, markers, |i, l| movement(i as f64, l));
        let mut rng = Rng::new(8);
        let mut take = |frames: usize, at: usize, jitter: f64, far: Option<(usize, usize)>| {
            let noise: Vec<f64> = (0..frames * markers * 3).map(|_| rng.normal()).collect();
            traj(frames, markers, |j, l| {
                let e = &noise[(j * markers + l) * 3..];
                if (at..at + n).contains(&j) {
                    let p = movement((j - at) as f64, l);
                    [p[0] + jitter * e[0], p[1] + jitter * e[1], p[2] + jitter * e[2]]
                } else if far.is_some_and(|(a, b)| (a..b).contains(&j)) {
                    [5000.0 + 30.0 * e[0], 30.0 * e[1], 30.0 * e[2]]
                } else {
                    [400.0 + 30.0 * e[0], 30.0 * e[1], 30.0 * e[2]]
                }
            })
        };
        let takes = vec![
            take(200, 120, 2.0, None),
            take(150, 50, 0.0, None),
            take(220, 20, 10.0, Some((100, 160))),
        ];
        for pruning in [false, true] {
            let r = retrieve(&model, &takes, &settings(3, 60, 10, pruning)).unwrap();
            let (sim, dis) = summary(&r);
            let found: Vec<(usize, usize, usize)> =
                sim.iter().map(|&(t, a, b, _)| (t, a, b)).collect();
            assert_eq!(found, vec![(1, 50, 79), (0, 120, 149), (2, 20, 49)], "pruning {pruning}");
            assert_eq!(sim[0].3, 0.0);
            assert!(sim[1].3 < sim[2].3);
            // The most dissimilar stretch lies in the far stretch of take 2.
            assert_eq!(dis[0].0, 2);
            assert!((100..160).contains(&dis[0].1) && (100..160).contains(&dis[0].2), "{dis:?}");
            // Every hit's H is the two-stage match of its window cut out.
            for h in r.similar.iter().chain(&r.dissimilar) {
                let cut: Vec<Trajectory3> = takes[h.take]
                    .iter()
                    .map(|t| Trajectory3 {
                        x: t.x[h.window_start..h.window_end].to_vec(),
                        y: t.y[h.window_start..h.window_end].to_vec(),
                        z: t.z[h.window_start..h.window_end].to_vec(),
                    })
                    .collect();
                assert_eq!(two_stage(&model, &cut, true).unwrap().alignment, h.alignment);
            }
            if pruning {
                // Noise windows all match about equally badly, so the third most dissimilar
                // needs most of them matched; the similar list alone, and the most dissimilar
                // stretch alone, need few.
                for (ks, kd) in [(3, 0), (0, 1)] {
                    let few = RetrievalSettings {
                        k_similar: ks,
                        k_dissimilar: kd,
                        ..settings(3, 60, 10, true)
                    };
                    let r = retrieve(&model, &takes, &few).unwrap();
                    assert!(
                        r.matched_candidates * 2 < r.candidates.len(),
                        "{ks} {kd}: {} of {}",
                        r.matched_candidates,
                        r.candidates.len()
                    );
                }
            }
        }
    }

    #[test]
    fn pruned_and_exhaustive_searches_agree_on_random_corpora() {
        let mut rng = Rng::new(31);
        for case in 0..12 {
            let markers = 1 + (rng.next_u64() % 11) as usize;
            let n = 3 + (rng.next_u64() % 15) as usize;
            let model = traj(n, markers, |i, l| movement(i as f64 * 1.7, l + case));
            let takes: Vec<Vec<Trajectory3>> = (0..1 + rng.next_u64() % 4)
                .map(|_| {
                    let frames = 1 + (rng.next_u64() % 120) as usize;
                    let phase = rng.uniform() * 50.0;
                    let noise: Vec<f64> =
                        (0..frames * markers * 3).map(|_| rng.normal() * 20.0).collect();
                    traj(frames, markers, |j, l| {
                        let p = movement(phase + j as f64 * 0.9, l + case);
                        let e = &noise[(j * markers + l) * 3..];
                        [p[0] + e[0], p[1] + e[1], p[2] + e[2]]
                    })
                })
                .collect();
            let k = 1 + (rng.next_u64() % 6) as usize;
            let window = 1 + (rng.next_u64() % 40) as usize;
            let stride = 1 + (rng.next_u64() % 12) as usize;
            let full = retrieve(&model, &takes, &settings(k, window, stride, false)).unwrap();
            let lazy = retrieve(&model, &takes, &settings(k, window, stride, true)).unwrap();
            assert_eq!(
                (&full.similar, &full.dissimilar),
                (&lazy.similar, &lazy.dissimilar),
                "case {case}"
            );
            assert_eq!(full.matched_candidates, full.candidates.len());
            // The bounds hold for every candidate the pruned search left unmatched too.
            for (c, f) in lazy.candidates.iter().zip(&full.candidates) {
                let h = f.matched.unwrap().total_distance;
                assert!(
                    c.lower_bound.unwrap() <= h && h <= c.upper_bound.unwrap(),
                    "case {case}: {c:?} H {h}"
                );
                assert!(c.matched.is_none_or(|m| m == f.matched.unwrap()));
            }
            // Non-overlapping lists, in order of H.
            for list in [&full.similar, &full.dissimilar] {
                for (x, hx) in list.iter().enumerate() {
                    for hy in &list[x + 1..] {
                        let (a1, b1) = (
                            hx.window_start + hx.alignment.start,
                            hx.window_start + hx.alignment.end,
                        );
                        let (a2, b2) = (
                            hy.window_start + hy.alignment.start,
                            hy.window_start + hy.alignment.end,
                        );
                        assert!(hx.take != hy.take || b1 < a2 || b2 < a1, "case {case}: overlap");
                    }
                }
            }
            assert!(
                full.similar
                    .windows(2)
                    .all(|w| w[0].alignment.total_distance <= w[1].alignment.total_distance)
            );
            assert!(
                full.dissimilar
                    .windows(2)
                    .all(|w| w[0].alignment.total_distance >= w[1].alignment.total_distance)
            );
        }
    }

    #[test]
    fn k_beyond_the_candidates_returns_every_non_overlapping_stretch() {
        let model = traj(5, 2, |i, l| movement(i as f64, l));
        let takes = vec![traj(12, 2, |j, l| movement(j as f64 * 0.5, l))];
        for pruning in [false, true] {
            let r = retrieve(&model, &takes, &settings(50, 6, 3, pruning)).unwrap();
            assert_eq!(r.candidates.len(), 3);
            assert!(!r.similar.is_empty() && r.similar.len() <= 3);
            assert!(!r.dissimilar.is_empty() && r.dissimilar.len() <= 3);
            assert_eq!(r.matched_candidates, 3, "every candidate had to be matched");
        }
    }

    #[test]
    fn bad_inputs_are_clear_errors() {
        let model = traj(5, 2, |i, l| movement(i as f64, l));
        let e = retrieve(&model, &[], &settings(1, 6, 3, true)).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::EmptySequence);
        assert!(e.to_string().contains("at least one take"), "{e}");
        let takes = vec![traj(12, 3, |j, l| movement(j as f64, l))];
        assert_eq!(
            retrieve(&model, &takes, &settings(1, 6, 3, true)).unwrap_err().kind(),
            ErrorKind::WrongValueCount
        );
        let takes = vec![traj(12, 2, |j, l| movement(j as f64, l))];
        assert_eq!(
            retrieve(&model, &takes, &settings(1, 0, 3, true)).unwrap_err().kind(),
            ErrorKind::OutOfRange
        );
    }

    #[test]
    fn relative_positions_remove_the_place_in_the_room() {
        let mut a = traj(4, 3, |i, l| movement(i as f64, l));
        let mut b = traj(4, 3, |i, l| {
            let p = movement(i as f64, l);
            [p[0] + 1000.0 + i as f64, p[1] - 50.0, p[2]]
        });
        relative_to_point(&mut a, 0).unwrap();
        relative_to_point(&mut b, 0).unwrap();
        for (x, y) in a.iter().zip(&b) {
            assert!(x.x.iter().zip(&y.x).all(|(p, q)| (p - q).abs() < 1e-9));
        }
        assert_eq!(a[0].x, vec![0.0; 4]);
        assert!(relative_to_point(&mut a, 3).is_err());
    }
}
