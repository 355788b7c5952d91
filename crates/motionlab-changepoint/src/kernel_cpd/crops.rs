//! CROPS — changepoints for a range of penalties (Haynes, Eckley & Fearnhead, "Computationally
//! efficient changepoint detection for a range of penalties", JCGS 26(1), 2017), over either
//! PELT of this crate.
//!
//! A segmentation with `m` segments and unpenalised cost `Q` costs `Q + β·m` at penalty β: a
//! line in β. The optimum at each β is the lower envelope of those lines, so the segmentations
//! optimal somewhere in `[β_min, β_max]` are the vertices of the lower convex hull of the
//! points `(m, Q)`. CROPS finds them with PELT runs only where two known optima's lines cross:
//! run at β_min and β_max; for an interval whose ends have optima with `m₀ > m₁ + 1`
//! segments, run at the crossing `β = (Q₁ − Q₀)/(m₀ − m₁)`, and split the interval there
//! unless the optimum found has `m₁` segments (then the two ends are adjacent on the hull).
//! Each distinct optimum costs about two PELT runs.
//!
//! The bookkeeping follows ruptures-rs 0.1.1's `Crops` (the peer CI compares with): intervals
//! explored last-in first-out, every run kept, the cheapest segmentation per segment count,
//! the hull by a cross product that drops collinear points (a segmentation optimal at one
//! penalty only), and each hull member's interval ends where its line crosses its neighbours',
//! clipped to the range. Where two segmentations with the same number of segments cost the
//! same, the one found first is kept.

/// One segmentation of a penalty path: optimal for every penalty in `[pen_min, pen_max]`.
#[derive(Clone, Debug, PartialEq)]
pub struct PathSegmentation {
    /// The lowest penalty of the range at which it is optimal, in the cost's units.
    pub pen_min: f64,
    /// The highest penalty of the range at which it is optimal, in the cost's units.
    pub pen_max: f64,
    /// ruptures' breakpoints: segment ends, the last being n.
    pub breakpoints: Vec<usize>,
    /// The unpenalised cost: the sum of its segments' costs.
    pub cost: f64,
}

impl PathSegmentation {
    /// Its number of change points (segments − 1).
    pub fn n_changes(&self) -> usize {
        self.breakpoints.len().saturating_sub(1)
    }
}

/// What one penalised search returns: its breakpoints and their unpenalised cost.
pub(crate) struct Solved {
    pub breakpoints: Vec<usize>,
    pub cost: f64,
}

/// Every segmentation optimal for a penalty in `[pen_min, pen_max]` (0 < pen_min < pen_max,
/// checked by the caller), fewest change points (highest penalties) first. `solve(β)` runs the
/// penalised search at β.
pub(crate) fn crops(
    pen_min: f64,
    pen_max: f64,
    solve: &mut dyn FnMut(f64) -> Solved,
) -> Vec<PathSegmentation> {
    // Every run, in the order made: (penalty bits, segments, cost, breakpoints).
    let mut runs: Vec<(u64, usize, f64, Vec<usize>)> = Vec::new();
    let mut run = |pen: f64, runs: &mut Vec<(u64, usize, f64, Vec<usize>)>| -> (usize, f64) {
        if let Some(r) = runs.iter().find(|r| r.0 == pen.to_bits()) {
            return (r.1, r.2);
        }
        let s = solve(pen);
        let m = s.breakpoints.len();
        runs.push((pen.to_bits(), m, s.cost, s.breakpoints));
        (m, s.cost)
    };
    let (m_lo, q_lo) = run(pen_min, &mut runs);
    let (m_hi, q_hi) = run(pen_max, &mut runs);
    let mut stack = vec![(pen_min, m_lo, q_lo, pen_max, m_hi, q_hi)];
    while let Some((p0, m0, q0, p1, m1, q1)) = stack.pop() {
        if m0 <= m1 + 1 {
            continue;
        }
        let crossing = (q1 - q0) / (m0 - m1) as f64;
        if !crossing.is_finite() || crossing <= p0 || crossing >= p1 {
            continue;
        }
        let (m, q) = run(crossing, &mut runs);
        if m != m1 {
            stack.push((p0, m0, q0, crossing, m, q));
            stack.push((crossing, m, q, p1, m1, q1));
        }
    }

    // The cheapest run per number of segments (the first found among equal costs).
    let mut best: Vec<(usize, f64, Vec<usize>)> = Vec::new();
    for (_, m, q, bkps) in runs {
        match best.iter_mut().find(|b| b.0 == m) {
            Some(b) if q < b.1 => *b = (m, q, bkps),
            Some(_) => {}
            None => best.push((m, q, bkps)),
        }
    }
    best.sort_by_key(|b| b.0);

    // The lower convex hull of (m, Q), by increasing m.
    let mut hull: Vec<(usize, f64, Vec<usize>)> = Vec::new();
    for p in best {
        while hull.len() >= 2 {
            let (a, b) = (&hull[hull.len() - 2], &hull[hull.len() - 1]);
            let cross =
                (b.0 as f64 - a.0 as f64) * (p.1 - a.1) - (p.0 as f64 - a.0 as f64) * (b.1 - a.1);
            if cross <= 0.0 {
                hull.pop();
            } else {
                break;
            }
        }
        hull.push(p);
    }

    // Each member owns the penalties between its crossings with its neighbours.
    let crossing = |a: &(usize, f64, Vec<usize>), b: &(usize, f64, Vec<usize>)| {
        (a.1 - b.1) / (b.0 as f64 - a.0 as f64)
    };
    (0..hull.len())
        .map(|i| {
            let hi = if i == 0 { pen_max } else { crossing(&hull[i - 1], &hull[i]) };
            let lo = if i + 1 == hull.len() { pen_min } else { crossing(&hull[i], &hull[i + 1]) };
            PathSegmentation {
                pen_min: lo.max(pen_min),
                pen_max: hi.min(pen_max),
                breakpoints: hull[i].2.clone(),
                cost: hull[i].1,
            }
        })
        .collect()
}

/// How a segmentation is chosen on a penalty path.
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    Eq,
    serde::Deserialize,
    serde::Serialize,
    schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum PathChoice {
    /// The elbow of the cost against the number of change points: both rescaled to [0, 1]
    /// over the path, the segmentation farthest below the straight line joining the path's
    /// two ends (the "Kneedle" rule of Satopää, Albrecht, Irwin & Raghavan, "Finding a
    /// 'Kneedle' in a haystack", ICDCS workshops 2011; the elbow Haynes, Eckley & Fearnhead
    /// 2017 §4 read off this same plot). With fewer than three segmentations on the path
    /// there is no elbow: the one with the fewest change points.
    #[default]
    Elbow,
    /// The segmentation optimal at the BIC-style penalty (Schwarz 1978; the penalty `kernel_cpd`
    /// uses without `pen`), the nearest end of the range when that penalty is outside it.
    Bic,
    /// The segmentation optimal over the widest span of the logarithm of the penalty: the
    /// answer least sensitive to a penalty one cannot justify (the reading ruptures-rs'
    /// `Crops` documentation suggests).
    Widest,
}

/// The index into `path` (fewest change points first, as `crops` returns it) that `choice`
/// picks; `bic` is the BIC-style penalty of the series.
pub(crate) fn choose(path: &[PathSegmentation], choice: PathChoice, bic: f64) -> usize {
    match choice {
        PathChoice::Elbow => elbow(path),
        PathChoice::Bic => path
            .iter()
            .position(|p| p.pen_min <= bic && bic <= p.pen_max)
            .unwrap_or(if path.first().is_some_and(|p| bic > p.pen_max) {
                0
            } else {
                path.len().saturating_sub(1)
            }),
        PathChoice::Widest => {
            let mut best = 0;
            let width = |p: &PathSegmentation| p.pen_max.ln() - p.pen_min.ln();
            for (i, p) in path.iter().enumerate() {
                if width(p) > width(&path[best]) {
                    best = i;
                }
            }
            best
        }
    }
}

/// The Kneedle elbow of (number of change points, cost) over the path.
fn elbow(path: &[PathSegmentation]) -> usize {
    if path.len() < 3 {
        return 0;
    }
    let (first, last) = (&path[0], &path[path.len() - 1]);
    let (k0, k1) = (first.n_changes() as f64, last.n_changes() as f64);
    let (q0, q1) = (first.cost, last.cost);
    if k1 <= k0 || q0 <= q1 || q0.is_nan() || q1.is_nan() {
        return 0;
    }
    // Rescaled: k from 0 to 1, cost from 1 down to 0; the chord is 1 − k. A convex decreasing
    // curve lies below it, farthest at the elbow; the first of equal distances wins.
    let mut best = (0, 0.0);
    for (i, p) in path.iter().enumerate() {
        let k = (p.n_changes() as f64 - k0) / (k1 - k0);
        let q = (p.cost - q1) / (q0 - q1);
        let below = (1.0 - k) - q;
        if below > best.1 {
            best = (i, below);
        }
    }
    best.0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every segmentation of a tiny series, exhaustively: (segments, cost, breakpoints).
    fn all_segmentations(
        cost: &dyn Fn(usize, usize) -> f64,
        n: usize,
    ) -> Vec<(usize, f64, Vec<usize>)> {
        (0u32..1 << (n - 1))
            .map(|mask| {
                let mut ends: Vec<usize> = (1..n).filter(|b| mask >> (b - 1) & 1 == 1).collect();
                ends.push(n);
                let mut start = 0;
                let mut q = 0.0;
                for &e in &ends {
                    q += cost(start, e);
                    start = e;
                }
                (ends.len(), q, ends)
            })
            .collect()
    }

    fn exhaustive_optimum(all: &[(usize, f64, Vec<usize>)], pen: f64) -> &(usize, f64, Vec<usize>) {
        let mut best = &all[0];
        for s in all {
            if s.1 + pen * (s.0 as f64) < best.1 + pen * best.0 as f64 {
                best = s;
            }
        }
        best
    }

    #[test]
    fn the_path_is_every_exhaustive_optimum_with_its_interval() {
        let mut rng = fastrand::Rng::with_seed(3);
        for trial in 0..20 {
            let n = 9 + trial % 4;
            let x: Vec<f64> =
                (0..n).map(|i| (i / 3) as f64 * 2.0 * rng.f64() + rng.f64()).collect();
            let cost = |s: usize, e: usize| {
                let m = x[s..e].iter().sum::<f64>() / (e - s) as f64;
                x[s..e].iter().map(|v| (v - m) * (v - m)).sum::<f64>()
            };
            let all = all_segmentations(&cost, n);
            let mut solve = |pen: f64| {
                let o = exhaustive_optimum(&all, pen);
                Solved { breakpoints: o.2.clone(), cost: o.1 }
            };
            let (lo, hi) = (1e-3, 50.0);
            let path = crops(lo, hi, &mut solve);
            // Contiguous intervals covering the range, fewest change points first.
            assert_eq!(path[0].pen_max, hi, "trial {trial}");
            assert_eq!(path.last().unwrap().pen_min, lo);
            for w in path.windows(2) {
                assert_eq!(w[0].pen_min, w[1].pen_max);
                assert!(w[0].n_changes() < w[1].n_changes());
            }
            // At a dense grid of penalties, the exhaustive optimum is the path's member there.
            for j in 0..400 {
                let pen = lo * (hi / lo).powf(j as f64 / 399.0);
                let want = exhaustive_optimum(&all, pen);
                let got = path.iter().find(|p| p.pen_min <= pen && pen <= p.pen_max).unwrap();
                let at = |q: f64, m: usize| q + pen * m as f64;
                assert!(
                    (at(got.cost, got.breakpoints.len()) - at(want.1, want.0)).abs() < 1e-9,
                    "trial {trial} pen {pen}"
                );
            }
            // A member's interval ends where it ties with its neighbour.
            for w in path.windows(2) {
                let b = w[0].pen_min;
                let a = w[0].cost + b * w[0].breakpoints.len() as f64;
                let c = w[1].cost + b * w[1].breakpoints.len() as f64;
                assert!((a - c).abs() < 1e-9 * a.abs().max(1.0));
            }
        }
    }

    fn member(k: usize, cost: f64, lo: f64, hi: f64) -> PathSegmentation {
        PathSegmentation { pen_min: lo, pen_max: hi, breakpoints: (1..=k + 1).collect(), cost }
    }

    #[test]
    fn the_rules_pick_the_elbow_the_bic_member_and_the_widest() {
        // Costs 100, 40, 10, 8, 7 at 0..4 changes: the elbow is at 2 changes.
        let path = vec![
            member(0, 100.0, 60.0, 1000.0),
            member(1, 40.0, 30.0, 60.0),
            member(2, 10.0, 2.0, 30.0),
            member(3, 8.0, 1.0, 2.0),
            member(4, 7.0, 0.5, 1.0),
        ];
        assert_eq!(choose(&path, PathChoice::Elbow, 5.0), 2);
        assert_eq!(choose(&path, PathChoice::Bic, 5.0), 2);
        assert_eq!(choose(&path, PathChoice::Bic, 45.0), 1);
        assert_eq!(choose(&path, PathChoice::Bic, 5000.0), 0);
        assert_eq!(choose(&path, PathChoice::Bic, 0.1), 4);
        // ln(1000/60) = 2.8 is the widest span; ln(30/2) = 2.7 next.
        assert_eq!(choose(&path, PathChoice::Widest, 5.0), 0);
        assert_eq!(choose(&path[..2], PathChoice::Elbow, 5.0), 0);
        assert_eq!(choose(&path[..1], PathChoice::Elbow, 5.0), 0);
    }
}
