//! Matching found boundaries to ground truth: maximum one-to-one matching, precision, recall,
//! F1 and the Hausdorff distance (Sonoda et al. §3).
//!
//! # The match rule
//!
//! A found frame `a` and a truth `r` *may* match when
//!
//! - **time**: `|a − r| ≤ tol` (frames; a tolerance in seconds is resolved at the motion's rate by
//!   [`tolerance_frames`]), or — with `use_windows` and a truth that carries an annotated
//!   transition window `[w₀, w₁]` (CMU-86 labels) — `a ∈ [min(r, w₀) − tol, max(r, w₁) + tol]`;
//! - **pose** (optional, [`PoseRule`]): the two frames' poses are almost the same — the mean
//!   marker distance after subtracting the root point is below `pose_mm`.
//!
//! Each truth and each found frame is used at most once, and the number of pairs is the
//! **maximum** possible. Greedy nearest-first matching is not maximal: truths {0, 6}, found
//! {4, 10}, tol 5 — nearest-first pairs 4↔6 (distance 2) and then 10 has no partner, one pair;
//! the maximum is two (4↔0, 10↔6). See the tests.
//!
//! # Algorithms (written here; why no crate)
//!
//! - Time rule only: every truth accepts a closed *interval* of frames, every found frame is a
//!   point, so the graph is a point–interval graph and an exact O((|A|+|R|) log(|A|+|R|)) sweep
//!   exists ([`max_matching_windows`], proof in its doc comment).
//! - With the pose rule the graph has no such structure: Hopcroft–Karp
//!   ([`max_matching_graph`], O(E √V)), iterative so deep augmenting paths cannot overflow the
//!   stack.
//!
//! Both are short; the crates that offer matchings would add a dependency for less:
//! `petgraph::algo::maximum_matching` is Gabow's O(V³) general-graph algorithm on a petgraph
//! graph built first, `pathfinding`'s Kuhn–Munkres solves the weighted assignment problem in
//! O(n³). The two algorithms here are cross-checked against exhaustive search on random small
//! cases in the tests, and against scipy's Hopcroft–Karp on graphs of up to 10⁵ vertices
//! (`bench/matching_vs_scipy.py`).
//!
//! # Empty sets (documented choice)
//!
//! - `precision = matched / |A|` is **NaN** when nothing was found (|A| = 0): 0/0 is undefined,
//!   and reporting 0 or 1 would invent a number. Likewise `recall` is NaN when |R| = 0.
//! - `F1 = 2·matched / (|A| + |R|)` — the harmonic mean of precision and recall whenever both are
//!   defined (and 0 when nothing matched), and still defined when only one of them is: with
//!   |A| = 0 < |R|, F1 = 0. F1 is NaN only when both sets are empty.
//! - The Hausdorff distance `H(A, R) = max(max_a min_r |a − r|, max_r min_a |a − r|)` is 0 when
//!   both sets are empty (they are equal) and +∞ when exactly one is (a point has no partner at
//!   any distance). Tables write +∞ as an empty cell (null), since CSV/JSON carry no infinity.

use std::cmp::{Ordering, Reverse};
use std::collections::BinaryHeap;

use motionlab_core::{Boundary, Error, ErrorKind, FrameRate, Motion, Result, TimeSpan};

/// The default match tolerance of the evaluators: 1/12 s.
///
/// The paper accepts 5 frames for ballet and 10 frames for street dance "because their sampling
/// rates differ", without giving the rates. 1/12 s is 5 frames at 60 Hz and 10 frames at
/// 120 Hz — the reading under which both of the paper's tolerances are the same duration.
pub fn default_tolerance() -> TimeSpan {
    TimeSpan::Seconds(1.0 / 12.0)
}

/// Relative slack when a tolerance given in seconds is turned into frames: `1/24 s × 120 Hz`
/// is 4.999999999… in floating point and must still accept a 5-frame offset.
const SLACK: f64 = 1e-9;

/// The tolerance in (fractional) frames at `rate`, with a 1e-9 relative slack so that a time
/// that equals a whole number of frames is not lost to rounding.
pub fn tolerance_frames(tolerance: TimeSpan, rate: FrameRate) -> f64 {
    let t = tolerance.frames_at(rate);
    t + SLACK * t.max(1.0)
}

/// The frames a truth accepts under the time rule: the closed interval `[lo, hi]`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TruthWindow {
    /// The truth's own frame (what distances and the Hausdorff distance are measured from).
    pub frame: usize,
    pub lo: f64,
    pub hi: f64,
}

impl TruthWindow {
    /// `[frame − tol, frame + tol]`.
    pub fn around(frame: usize, tol_frames: f64) -> Self {
        let f = frame as f64;
        TruthWindow { frame, lo: f - tol_frames, hi: f + tol_frames }
    }
    /// From a ground-truth boundary; with `use_windows`, its annotated window (if any) widened
    /// by the tolerance on both sides.
    pub fn from_boundary(b: &Boundary, tol_frames: f64, use_windows: bool) -> Self {
        match (use_windows, b.window) {
            (true, Some((w0, w1))) => TruthWindow {
                frame: b.frame,
                lo: w0.min(b.frame) as f64 - tol_frames,
                hi: w1.max(b.frame) as f64 + tol_frames,
            },
            _ => TruthWindow::around(b.frame, tol_frames),
        }
    }
    pub fn contains(&self, frame: usize) -> bool {
        let f = frame as f64;
        self.lo <= f && f <= self.hi
    }
}

/// Maximum matching between found frames (points) and truth windows (intervals): pairs
/// `(index into found, index into truths)`, sorted by found index.
///
/// Sweep the found frames in increasing order; keep the windows that have opened
/// (`lo ≤ a`) and not yet closed (`hi ≥ a`) in a min-heap by `hi`; match `a` to the window
/// that closes first.
///
/// *Why this is maximum* (exchange argument, "earliest deadline first"): let `a` be the
/// smallest unprocessed point and `I` the open window with the smallest `hi` that greedy picks.
/// Take any maximum matching `M` that agrees with greedy so far. If `M` leaves `a` unmatched,
/// give `I` to `a` (dropping `I`'s partner in `M`, if any): the size does not shrink. If `M`
/// pairs `a` with `J ≠ I`: when `I` is free in `M`, swap `J` for `I`; when `I` is paired with a
/// later point `q ≥ a`, swap partners — `q` fits `J` because `J.lo ≤ a ≤ q ≤ I.hi ≤ J.hi`.
/// Either way a maximum matching agrees with greedy one step further. Windows dropped from the
/// heap close before the current point and so before every later one; and when the heap is
/// empty no unused window contains `a`, so leaving `a` unmatched loses nothing.
pub fn max_matching_windows(found: &[usize], truths: &[TruthWindow]) -> Vec<(usize, usize)> {
    let mut points: Vec<usize> = (0..found.len()).collect();
    points.sort_by_key(|&i| (found[i], i));
    let mut opening: Vec<usize> = (0..truths.len()).collect();
    opening.sort_by(|&x, &y| truths[x].lo.total_cmp(&truths[y].lo).then(x.cmp(&y)));

    let mut open: BinaryHeap<Reverse<ByEnd>> = BinaryHeap::new();
    let mut next = 0;
    let mut pairs = Vec::with_capacity(found.len().min(truths.len()));
    for i in points {
        let a = found[i] as f64;
        while next < opening.len() && truths[opening[next]].lo <= a {
            let t = opening[next];
            open.push(Reverse(ByEnd(truths[t].hi, t)));
            next += 1;
        }
        while open.peek().is_some_and(|Reverse(ByEnd(hi, _))| *hi < a) {
            open.pop();
        }
        if let Some(Reverse(ByEnd(_, t))) = open.pop() {
            pairs.push((i, t));
        }
    }
    pairs.sort_unstable();
    pairs
}

/// A window in the sweep's heap, ordered by its end then its index (total order on f64).
#[derive(Clone, Copy, Debug, PartialEq)]
struct ByEnd(f64, usize);

impl Eq for ByEnd {}
impl PartialOrd for ByEnd {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for ByEnd {
    fn cmp(&self, other: &Self) -> Ordering {
        self.0.total_cmp(&other.0).then(self.1.cmp(&other.1))
    }
}

/// Maximum bipartite matching (Hopcroft–Karp) of a general graph: `adjacency[u]` lists the
/// right vertices (`< n_right`) left vertex `u` may match. Returns `(u, v)` pairs sorted by `u`.
/// Out-of-range right vertices are ignored.
pub fn max_matching_graph(n_right: usize, adjacency: &[Vec<usize>]) -> Vec<(usize, usize)> {
    const FREE: usize = usize::MAX;
    const FAR: usize = usize::MAX;
    let n_left = adjacency.len();
    // Flattened (CSR) copy: one allocation, and the inner loops stay in cache.
    let mut start = Vec::with_capacity(n_left + 1);
    let mut targets = Vec::with_capacity(adjacency.iter().map(Vec::len).sum());
    start.push(0);
    for a in adjacency {
        targets.extend(a.iter().copied().filter(|&v| v < n_right));
        start.push(targets.len());
    }
    let adj = |u: usize| &targets[start[u]..start[u + 1]];
    let mut match_left = vec![FREE; n_left];
    let mut match_right = vec![FREE; n_right];
    let mut dist = vec![FAR; n_left];
    let mut next_edge = vec![0usize; n_left];
    let mut queue = Vec::with_capacity(n_left);
    let mut stack: Vec<usize> = Vec::new();

    // Greedy start: most vertices match directly, leaving few phases for the layered search.
    for (u, partner) in match_left.iter_mut().enumerate() {
        if let Some(&v) = adj(u).iter().find(|&&v| match_right[v] == FREE) {
            *partner = v;
            match_right[v] = u;
        }
    }
    loop {
        // BFS layers from every free left vertex along alternating paths.
        queue.clear();
        for u in 0..n_left {
            if match_left[u] == FREE {
                dist[u] = 0;
                queue.push(u);
            } else {
                dist[u] = FAR;
            }
        }
        // `shortest`: the layer of the first free right vertex reached — only augmenting paths
        // of that (shortest) length are used in this phase, which bounds the phases by O(√V).
        let mut shortest = FAR;
        let mut head = 0;
        while head < queue.len() {
            let u = queue[head];
            head += 1;
            if dist[u] >= shortest {
                continue;
            }
            for &v in adj(u) {
                let w = match_right[v];
                if w == FREE {
                    shortest = shortest.min(dist[u]);
                } else if dist[w] == FAR {
                    dist[w] = dist[u] + 1;
                    queue.push(w);
                }
            }
        }
        if shortest == FAR {
            break;
        }
        // DFS along the layers (iterative; `next_edge` skips edges already known to fail).
        next_edge.iter_mut().for_each(|e| *e = 0);
        for root in 0..n_left {
            if match_left[root] != FREE {
                continue;
            }
            stack.clear();
            stack.push(root);
            while let Some(&u) = stack.last() {
                if next_edge[u] == adj(u).len() {
                    // Dead end: no augmenting path through u in this phase.
                    dist[u] = FAR;
                    stack.pop();
                    if let Some(&parent) = stack.last() {
                        next_edge[parent] += 1;
                    }
                    continue;
                }
                let v = adj(u)[next_edge[u]];
                let w = match_right[v];
                if w == FREE && dist[u] == shortest {
                    // Augment along the stack: each u on it takes its current edge.
                    for &x in &stack {
                        let y = adj(x)[next_edge[x]];
                        match_left[x] = y;
                        match_right[y] = x;
                    }
                    break;
                }
                if w != FREE && dist[w] != FAR && dist[w] == dist[u] + 1 {
                    stack.push(w);
                } else {
                    next_edge[u] += 1;
                }
            }
        }
    }
    match_left.iter().enumerate().filter(|(_, v)| **v != FREE).map(|(u, v)| (u, *v)).collect()
}

/// The optional second match rule: two frames match when their poses are almost the same.
///
/// Pose distance between frames `a` and `b`: the mean, over markers `k ≠ root` present at both
/// frames, of `|(p[a][k] − p[a][root]) − (p[b][k] − p[b][root])|` (mm) — positions relative to
/// the root point, so where the body stands does not count; which way it faces does.
/// **Missing samples:** markers missing at either frame are left out of the mean; when the root
/// is missing at either frame, or no other marker is present at both, the distance is undefined
/// and the pose rule does not match.
#[derive(Clone, Copy, Debug)]
pub struct PoseRule<'m> {
    motion: &'m Motion,
    root: usize,
    pose_mm: f64,
    max_gap_frames: Option<f64>,
}

impl<'m> PoseRule<'m> {
    /// `root` names the point subtracted before comparing (error names the field `root`);
    /// `max_gap`, when given, limits the rule to frames at most that far apart.
    pub fn new(
        motion: &'m Motion,
        root: &str,
        pose_mm: f64,
        max_gap: Option<TimeSpan>,
    ) -> Result<Self> {
        if !(pose_mm.is_finite() && pose_mm > 0.0) {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                format!("must be a finite distance > 0 mm, found {pose_mm}"),
            )
            .with_field("pose_mm"));
        }
        let root = motion.point_index(root).map_err(|e| e.with_field("root"))?;
        let max_gap_frames = max_gap.map(|g| tolerance_frames(g, motion.frame_rate()));
        Ok(PoseRule { motion, root, pose_mm, max_gap_frames })
    }

    /// The root-aligned mean marker distance (mm), or None where it is undefined (see the type
    /// docs; also for frames outside the motion).
    pub fn distance_mm(&self, a: usize, b: usize) -> Option<f64> {
        root_aligned_pose_distance(self.motion, self.root, a, b)
    }

    /// True when the poses at `a` and `b` are closer than `pose_mm` (and, with a `max_gap`,
    /// the frames are close enough in time).
    pub fn matches(&self, a: usize, b: usize) -> bool {
        if let Some(g) = self.max_gap_frames
            && (a as f64 - b as f64).abs() > g
        {
            return false;
        }
        self.distance_mm(a, b).is_some_and(|d| d < self.pose_mm)
    }
}

/// See [`PoseRule`]: mean distance between the root-relative positions of the markers present
/// at both frames; None when undefined.
pub fn root_aligned_pose_distance(motion: &Motion, root: usize, a: usize, b: usize) -> Option<f64> {
    let n = motion.n_frames();
    if a >= n
        || b >= n
        || root >= motion.n_points()
        || motion.is_missing(a, root)
        || motion.is_missing(b, root)
    {
        return None;
    }
    let (pa, pb) = (motion.frame(a), motion.frame(b));
    let (ma, mb) = (motion.frame_missing(a), motion.frame_missing(b));
    let (ra, rb) = (pa[root], pb[root]);
    let mut sum = 0.0;
    let mut count = 0usize;
    for k in 0..motion.n_points() {
        if k == root || ma[k] || mb[k] {
            continue;
        }
        let d: [f64; 3] = std::array::from_fn(|c| (pa[k][c] - ra[c]) - (pb[k][c] - rb[c]));
        sum += (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        count += 1;
    }
    (count > 0).then(|| sum / count as f64)
}

/// How found frames and truths may match (see the module docs).
#[derive(Clone, Copy, Debug)]
pub struct MatchRule<'m> {
    /// Tolerance in frames at the motion's rate ([`tolerance_frames`]).
    pub tolerance_frames: f64,
    /// Accept the truth's annotated transition window (widened by the tolerance).
    pub use_windows: bool,
    /// The optional pose rule.
    pub pose: Option<PoseRule<'m>>,
}

impl MatchRule<'_> {
    /// Time rule only, no windows.
    pub fn time(tolerance_frames: f64) -> Self {
        MatchRule { tolerance_frames, use_windows: false, pose: None }
    }
}

/// One matched pair, as frames.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MatchedPair {
    pub found: usize,
    pub truth: usize,
    /// True when only the pose rule allowed this pair (outside the time window).
    pub by_pose: bool,
}

/// Precision, recall, F1 and the Hausdorff distance of one method on one sequence.
#[derive(Clone, Debug, PartialEq)]
pub struct BoundaryScores {
    /// Counts, precision, recall and `F1 = 2·matched / (|A| + |R|)`.
    pub scores: PrScores,
    /// 0 when both sets are empty, +∞ when exactly one is.
    pub hausdorff_frames: f64,
    /// The pairs of a maximum matching, sorted by found frame.
    pub pairs: Vec<MatchedPair>,
}

/// The counts and ratios every precision/recall table shows, as its columns in this order
/// (flattened into the rows of `boundary_f1_by_tolerance`, `heldout_f1` and `heldout_choices`).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct PrScores {
    pub n_truth: usize,
    pub n_found: usize,
    pub n_matched: usize,
    /// NaN when nothing was found.
    pub precision: f64,
    /// NaN when there is no truth.
    pub recall: f64,
    /// `2·matched / (found + truth)`; NaN only when both are 0.
    pub f1: f64,
}

impl PrScores {
    /// The ratios of the counts by [`ratios`].
    pub fn of(n_truth: usize, n_found: usize, n_matched: usize) -> Self {
        let (precision, recall, f1) = ratios(n_found, n_truth, n_matched);
        PrScores { n_truth, n_found, n_matched, precision, recall, f1 }
    }
}

/// `(precision, recall, f1)` from counts, with the empty-set rules of the module docs.
pub fn ratios(n_found: usize, n_truth: usize, n_matched: usize) -> (f64, f64, f64) {
    let div = |num: usize, den: usize| if den == 0 { f64::NAN } else { num as f64 / den as f64 };
    (div(n_matched, n_found), div(n_matched, n_truth), div(2 * n_matched, n_found + n_truth))
}

/// Matches `found` frames to `truth` boundaries under `rule` (maximum one-to-one matching) and
/// scores the result.
pub fn evaluate_boundaries(
    found: &[usize],
    truth: &[Boundary],
    rule: &MatchRule<'_>,
) -> BoundaryScores {
    let windows: Vec<TruthWindow> = truth
        .iter()
        .map(|b| TruthWindow::from_boundary(b, rule.tolerance_frames, rule.use_windows))
        .collect();
    let index_pairs = match &rule.pose {
        None => max_matching_windows(found, &windows),
        Some(pose) => {
            let adjacency: Vec<Vec<usize>> = found
                .iter()
                .map(|&a| {
                    (0..windows.len())
                        .filter(|&j| windows[j].contains(a) || pose.matches(a, windows[j].frame))
                        .collect()
                })
                .collect();
            max_matching_graph(windows.len(), &adjacency)
        }
    };
    let mut pairs: Vec<MatchedPair> = index_pairs
        .iter()
        .map(|&(i, j)| MatchedPair {
            found: found[i],
            truth: truth[j].frame,
            by_pose: !windows[j].contains(found[i]),
        })
        .collect();
    pairs.sort_by_key(|p| (p.found, p.truth));
    let truth_frames: Vec<usize> = truth.iter().map(|b| b.frame).collect();
    BoundaryScores {
        scores: PrScores::of(truth.len(), found.len(), pairs.len()),
        hausdorff_frames: hausdorff_frames(found, &truth_frames),
        pairs,
    }
}

/// Hausdorff distance between two frame sets, in frames: 0 when both are empty, +∞ when
/// exactly one is. O((|a| + |b|) log) by binary search in sorted copies.
pub fn hausdorff_frames(a: &[usize], b: &[usize]) -> f64 {
    match (a.is_empty(), b.is_empty()) {
        (true, true) => return 0.0,
        (true, false) | (false, true) => return f64::INFINITY,
        _ => {}
    }
    let (mut sa, mut sb) = (a.to_vec(), b.to_vec());
    sa.sort_unstable();
    sb.sort_unstable();
    directed_hausdorff(&sa, &sb).max(directed_hausdorff(&sb, &sa))
}

/// `max_{x ∈ from} min_{y ∈ to} |x − y|` for sorted non-empty `to`.
fn directed_hausdorff(from: &[usize], to: &[usize]) -> f64 {
    from.iter()
        .map(|&x| {
            let i = to.partition_point(|&y| y < x);
            let right = to.get(i).map(|&y| y - x);
            let left = i.checked_sub(1).map(|k| x - to[k]);
            left.into_iter().chain(right).min().unwrap_or(usize::MAX) as f64
        })
        .fold(0.0, f64::max)
}

/// The nearest frame of a sorted list to `x` (ties: the earlier frame), or None when empty.
pub fn nearest_frame(sorted: &[usize], x: usize) -> Option<usize> {
    let i = sorted.partition_point(|&y| y < x);
    let right = sorted.get(i).copied();
    let left = i.checked_sub(1).map(|k| sorted[k]);
    match (left, right) {
        (Some(l), Some(r)) => Some(if x - l <= r - x { l } else { r }),
        (l, r) => l.or(r),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_testkit::{Rng, motion_from_fn};

    fn points(frames: &[usize]) -> Vec<Boundary> {
        frames.iter().map(|&frame| Boundary { frame, window: None }).collect()
    }

    /// Size of a maximum matching by exhaustive search (exponential; tiny inputs only).
    fn brute_force_max(n_right: usize, adjacency: &[Vec<usize>]) -> usize {
        fn go(u: usize, adjacency: &[Vec<usize>], used: &mut Vec<bool>) -> usize {
            if u == adjacency.len() {
                return 0;
            }
            let mut best = go(u + 1, adjacency, used); // leave u unmatched
            for &v in &adjacency[u] {
                if !used[v] {
                    used[v] = true;
                    best = best.max(1 + go(u + 1, adjacency, used));
                    used[v] = false;
                }
            }
            best
        }
        go(0, adjacency, &mut vec![false; n_right])
    }

    /// A valid matching: every pair is an edge, every vertex used once.
    fn assert_valid(pairs: &[(usize, usize)], n_right: usize, adjacency: &[Vec<usize>]) {
        let mut left = vec![false; adjacency.len()];
        let mut right = vec![false; n_right];
        for &(u, v) in pairs {
            assert!(adjacency[u].contains(&v), "({u}, {v}) is not an edge");
            assert!(!left[u] && !right[v], "vertex used twice in {pairs:?}");
            left[u] = true;
            right[v] = true;
        }
    }

    /// Nearest-first greedy: repeatedly take the closest remaining (found, truth) pair.
    fn greedy_nearest_first(found: &[usize], truth: &[usize], tol: f64) -> usize {
        let mut edges: Vec<(usize, usize, usize)> = Vec::new();
        for (i, &a) in found.iter().enumerate() {
            for (j, &r) in truth.iter().enumerate() {
                if (a.abs_diff(r) as f64) <= tol {
                    edges.push((a.abs_diff(r), i, j));
                }
            }
        }
        edges.sort();
        let (mut uf, mut ut) = (vec![false; found.len()], vec![false; truth.len()]);
        let mut n = 0;
        for (_, i, j) in edges {
            if !uf[i] && !ut[j] {
                uf[i] = true;
                ut[j] = true;
                n += 1;
            }
        }
        n
    }

    #[test]
    fn greedy_nearest_first_is_not_maximal_but_this_is() {
        // Truths {0, 6}, found {4, 10}, tol 5: nearest-first takes 4↔6 (distance 2), then 10
        // has no free partner (10↔0 is 10 frames). The maximum pairs 4↔0 and 10↔6.
        let truth = points(&[0, 6]);
        let found = [4, 10];
        assert_eq!(greedy_nearest_first(&found, &[0, 6], 5.0), 1);
        let s = evaluate_boundaries(&found, &truth, &MatchRule::time(5.0));
        assert_eq!(s.scores.n_matched, 2);
        assert_eq!(
            s.pairs,
            vec![
                MatchedPair { found: 4, truth: 0, by_pose: false },
                MatchedPair { found: 10, truth: 6, by_pose: false }
            ]
        );
        assert_eq!((s.scores.precision, s.scores.recall, s.scores.f1), (1.0, 1.0, 1.0));
        // Hausdorff: 4→6 is 2, 10→6 is 4; 0→4 is 4, 6→4 is 2: H = 4.
        assert_eq!(s.hausdorff_frames, 4.0);
    }

    #[test]
    fn hand_computed_precision_recall_f1() {
        // Truth at 100, 200, 300, 400; found at 103, 196, 250, 309, 500, 505; tol 5.
        // 103↔100 (3), 196↔200 (4); 250, 309 (9 from 300), 500, 505 unmatched; 300, 400 missed.
        // precision 2/6, recall 2/4, F1 = 2·2/(6+4) = 0.4 (= 2·(1/3)(1/2)/(1/3 + 1/2)).
        let s = evaluate_boundaries(
            &[103, 196, 250, 309, 500, 505],
            &points(&[100, 200, 300, 400]),
            &MatchRule::time(5.0),
        );
        assert_eq!((s.scores.n_found, s.scores.n_truth, s.scores.n_matched), (6, 4, 2));
        assert!((s.scores.precision - 1.0 / 3.0).abs() < 1e-15);
        assert_eq!(s.scores.recall, 0.5);
        assert!((s.scores.f1 - 0.4).abs() < 1e-15);
        let hm =
            2.0 * s.scores.precision * s.scores.recall / (s.scores.precision + s.scores.recall);
        assert!((s.scores.f1 - hm).abs() < 1e-15);
        // Hausdorff: found→truth max is 505→400 = 105; truth→found max is 400→309 = 91.
        assert_eq!(s.hausdorff_frames, 105.0);
    }

    #[test]
    fn tolerance_boundary_is_inclusive_and_seconds_resolve_without_rounding_loss() {
        let r120 = FrameRate::new(120.0).unwrap();
        // 1/24 s at 120 Hz is 5 frames but 4.999… in floating point without the slack.
        let tol = tolerance_frames(TimeSpan::Seconds(1.0 / 24.0), r120);
        assert!((5.0..5.0 + 1e-6).contains(&tol));
        let s = evaluate_boundaries(&[15, 26], &points(&[10, 20]), &MatchRule::time(tol));
        assert_eq!(
            s.scores.n_matched, 1,
            "15 is exactly 5 frames from 10 (match), 26 is 6 from 20 (no match)"
        );
        assert_eq!(s.pairs[0], MatchedPair { found: 15, truth: 10, by_pose: false });
    }

    #[test]
    fn one_result_matches_one_truth_only() {
        // One found frame between two truths: one pair, not two.
        let s = evaluate_boundaries(&[10], &points(&[8, 12]), &MatchRule::time(5.0));
        assert_eq!((s.scores.n_matched, s.scores.precision, s.scores.recall), (1, 1.0, 0.5));
        // Two found frames near one truth: one pair.
        let s = evaluate_boundaries(&[9, 11], &points(&[10]), &MatchRule::time(5.0));
        assert_eq!((s.scores.n_matched, s.scores.precision, s.scores.recall), (1, 0.5, 1.0));
    }

    #[test]
    fn empty_sets_follow_the_documented_rules() {
        let none = evaluate_boundaries(&[], &points(&[10, 20]), &MatchRule::time(5.0));
        assert!(none.scores.precision.is_nan());
        assert_eq!((none.scores.recall, none.scores.f1), (0.0, 0.0));
        assert_eq!(none.hausdorff_frames, f64::INFINITY);
        let no_truth = evaluate_boundaries(&[3], &[], &MatchRule::time(5.0));
        assert!(no_truth.scores.recall.is_nan());
        assert_eq!((no_truth.scores.precision, no_truth.scores.f1), (0.0, 0.0));
        assert_eq!(no_truth.hausdorff_frames, f64::INFINITY);
        let both = evaluate_boundaries(&[], &[], &MatchRule::time(5.0));
        assert!(
            both.scores.precision.is_nan()
                && both.scores.recall.is_nan()
                && both.scores.f1.is_nan()
        );
        assert_eq!(both.hausdorff_frames, 0.0);
    }

    #[test]
    fn annotated_windows_widen_the_match_region_only_when_asked() {
        // CMU-86 style: boundary 549 with window [499, 599]; found at 510 (39 frames early).
        let truth = vec![Boundary { frame: 549, window: Some((499, 599)) }];
        let plain = evaluate_boundaries(&[510], &truth, &MatchRule::time(10.0));
        assert_eq!(plain.scores.n_matched, 0);
        let windowed = evaluate_boundaries(
            &[510, 489, 488],
            &truth,
            &MatchRule { tolerance_frames: 10.0, use_windows: true, pose: None },
        );
        assert_eq!(windowed.scores.n_matched, 1);
        // 489 is exactly tol before the window, 510 inside: either may take it, never both.
        let w = TruthWindow::from_boundary(&truth[0], 10.0, true);
        assert!(w.contains(489) && !w.contains(488) && w.contains(609) && !w.contains(610));
    }

    #[test]
    fn window_sweep_and_hopcroft_karp_equal_exhaustive_search_on_random_cases() {
        let mut rng = Rng::new(7);
        for case in 0..3000 {
            let n_found = (rng.uniform() * 7.0) as usize;
            let n_truth = (rng.uniform() * 7.0) as usize;
            let span = 10.0 + rng.uniform() * 40.0;
            let found: Vec<usize> = (0..n_found).map(|_| (rng.uniform() * span) as usize).collect();
            let tol = (rng.uniform() * 8.0).floor();
            // Some truths get annotated windows of random width around them.
            let truth: Vec<Boundary> = (0..n_truth)
                .map(|_| {
                    let frame = (rng.uniform() * span) as usize;
                    let window = (rng.uniform() < 0.4).then(|| {
                        (
                            frame.saturating_sub((rng.uniform() * 6.0) as usize),
                            frame + (rng.uniform() * 6.0) as usize,
                        )
                    });
                    Boundary { frame, window }
                })
                .collect();
            let windows: Vec<TruthWindow> =
                truth.iter().map(|b| TruthWindow::from_boundary(b, tol, true)).collect();
            let adjacency: Vec<Vec<usize>> = found
                .iter()
                .map(|&a| (0..n_truth).filter(|&j| windows[j].contains(a)).collect())
                .collect();
            let best = brute_force_max(n_truth, &adjacency);
            let sweep = max_matching_windows(&found, &windows);
            assert_valid(&sweep, n_truth, &adjacency);
            assert_eq!(sweep.len(), best, "case {case}: sweep on {found:?} vs {truth:?} tol {tol}");
            let hk = max_matching_graph(n_truth, &adjacency);
            assert_valid(&hk, n_truth, &adjacency);
            assert_eq!(hk.len(), best, "case {case}: Hopcroft–Karp");
        }
    }

    #[test]
    fn hopcroft_karp_equals_exhaustive_search_on_random_general_graphs() {
        let mut rng = Rng::new(11);
        for case in 0..3000 {
            let n_left = (rng.uniform() * 8.0) as usize;
            let n_right = (rng.uniform() * 8.0) as usize;
            let density = rng.uniform();
            let adjacency: Vec<Vec<usize>> = (0..n_left)
                .map(|_| (0..n_right).filter(|_| rng.uniform() < density).collect())
                .collect();
            let hk = max_matching_graph(n_right, &adjacency);
            assert_valid(&hk, n_right, &adjacency);
            assert_eq!(
                hk.len(),
                brute_force_max(n_right, &adjacency),
                "case {case}: {adjacency:?}"
            );
        }
    }

    #[test]
    fn hopcroft_karp_survives_a_long_augmenting_chain() {
        // Left u may match right u or u+1; a bad initial structure forces long alternating
        // paths. 200 000 vertices would overflow a recursive DFS's stack.
        let n = 200_000;
        let adjacency: Vec<Vec<usize>> =
            (0..n).map(|u| if u + 1 < n { vec![u + 1, u] } else { vec![u] }).collect();
        assert_eq!(max_matching_graph(n, &adjacency).len(), n);
    }

    #[test]
    fn pose_rule_matches_far_frames_with_the_same_pose_and_counts_them() {
        // Two markers: "root" walks along x; "hand" sits 100 mm above it, except at frames 40–49
        // where it is raised to 300 mm. Poses at 10 and 30 are the same (root-relative).
        let m = motion_from_fn(60, 10.0, 2, |i, k| {
            let x = 50.0 * i as f64;
            if k == 0 {
                [x, 0.0, 0.0]
            } else {
                [x, 0.0, if (40..50).contains(&i) { 300.0 } else { 100.0 }]
            }
        });
        let pose = PoseRule::new(&m, "m0", 1.0, None).unwrap();
        assert_eq!(pose.distance_mm(10, 30), Some(0.0));
        assert_eq!(pose.distance_mm(10, 45), Some(200.0));
        assert!(pose.distance_mm(10, 60).is_none(), "frame outside the motion");
        let rule = MatchRule { tolerance_frames: 2.0, use_windows: false, pose: Some(pose) };
        // Truth at 10 and 45; found at 30 (pose match to 10 only) and 44 (time match to 45).
        let s = evaluate_boundaries(&[30, 44], &points(&[10, 45]), &rule);
        assert_eq!(s.scores.n_matched, 2);
        assert_eq!(s.pairs[0], MatchedPair { found: 30, truth: 10, by_pose: true });
        assert_eq!(s.pairs[1], MatchedPair { found: 44, truth: 45, by_pose: false });
        // A time limit on the pose rule removes the far pose match.
        let limited = PoseRule::new(&m, "m0", 1.0, Some(TimeSpan::Frames(5.0))).unwrap();
        let s = evaluate_boundaries(
            &[30, 44],
            &points(&[10, 45]),
            &MatchRule { pose: Some(limited), ..rule },
        );
        assert_eq!(s.scores.n_matched, 1);
    }

    #[test]
    fn pose_rule_skips_missing_markers_and_refuses_a_missing_root() {
        // Three markers; m2 is missing at frame 1, the root m0 at frame 2.
        let m = motion_from_fn(3, 10.0, 3, |i, k| match (i, k) {
            (1, 2) | (2, 0) => [f64::NAN; 3],
            (_, 0) => [0.0; 3],
            (_, 1) => [10.0 * i as f64, 0.0, 0.0],
            _ => [0.0, 0.0, 500.0],
        });
        // Frames 0 and 1: only m1 is present at both: |10 − 0| = 10 mm.
        assert_eq!(root_aligned_pose_distance(&m, 0, 0, 1), Some(10.0));
        assert_eq!(root_aligned_pose_distance(&m, 0, 0, 2), None);
        let e = PoseRule::new(&m, "pelvis", 10.0, None).unwrap_err();
        assert_eq!(
            (e.kind(), e.location().field.as_deref()),
            (ErrorKind::UnknownName, Some("root"))
        );
        let e = PoseRule::new(&m, "m0", 0.0, None).unwrap_err();
        assert_eq!(e.location().field.as_deref(), Some("pose_mm"));
    }

    #[test]
    fn hausdorff_is_symmetric_and_zero_only_for_equal_sets() {
        let mut rng = Rng::new(3);
        for _ in 0..500 {
            let a: Vec<usize> = (0..1 + (rng.uniform() * 6.0) as usize)
                .map(|_| (rng.uniform() * 100.0) as usize)
                .collect();
            let b: Vec<usize> = (0..1 + (rng.uniform() * 6.0) as usize)
                .map(|_| (rng.uniform() * 100.0) as usize)
                .collect();
            // Independent O(n·m) definition.
            let d = |x: &[usize], y: &[usize]| {
                x.iter().map(|&p| y.iter().map(|&q| p.abs_diff(q)).min().unwrap()).max().unwrap()
                    as f64
            };
            let h = hausdorff_frames(&a, &b);
            assert_eq!(h, d(&a, &b).max(d(&b, &a)));
            assert_eq!(h, hausdorff_frames(&b, &a));
            let same = a.iter().all(|x| b.contains(x)) && b.iter().all(|x| a.contains(x));
            assert_eq!(h == 0.0, same);
        }
    }

    #[test]
    fn nearest_frame_prefers_the_earlier_on_ties() {
        assert_eq!(nearest_frame(&[10, 20], 15), Some(10));
        assert_eq!(nearest_frame(&[10, 20], 16), Some(20));
        assert_eq!(nearest_frame(&[10, 20], 0), Some(10));
        assert_eq!(nearest_frame(&[10, 20], 99), Some(20));
        assert_eq!(nearest_frame(&[], 5), None);
    }
}
