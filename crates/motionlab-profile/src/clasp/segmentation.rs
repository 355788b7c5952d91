//! claspy's `ClaSPEnsemble` and `BinaryClaSPSegmentation`: ClaSPs over random temporal
//! constraints, the best kept, split at its maximum when the validation accepts it, and the
//! parts split again in order of their scores.

use crate::clasp::knn::k_subsequence_neighbours;
use crate::clasp::score::{profile, significant};
use crate::clasp::{Score, Validation};
use crate::numpy::LegacyRandomState;

/// What one segmentation runs with (all resolved: window, threshold).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Settings {
    pub window: usize,
    pub k: usize,
    pub excl_radius: usize,
    pub n_estimators: usize,
    pub early_stopping: bool,
    pub validation: Validation,
    pub threshold: f64,
    pub score: Score,
    pub random_state: u32,
}

impl Settings {
    fn min_seg(&self) -> usize {
        self.window * self.excl_radius
    }
}

/// A fitted ensemble on a series of `n` samples: the best constraint's profile placed at its
/// position (−∞ elsewhere) and that constraint's neighbours.
struct EnsembleFit {
    lbound: usize,
    profile: Vec<f64>,
    offsets: Vec<u32>,
}

/// claspy's `_calculate_temporal_constraints`: the whole series, then random ranges of at
/// least two minimal segments drawn with NumPy's legacy generator, longest first.
fn temporal_constraints(
    n: usize,
    min_seg: usize,
    n_estimators: usize,
    seed: u32,
) -> Vec<(usize, usize)> {
    let mut tcs = vec![(0, n)];
    let mut rng = LegacyRandomState::new(seed);
    while tcs.len() < n_estimators && n > 3 * min_seg {
        let lbound = rng.randint(n as u64) as usize;
        let mut area = rng.randint(n as u64) as usize;
        if n - lbound < area {
            area = n - lbound;
        }
        if area < 2 * min_seg {
            continue;
        }
        tcs.push((lbound, lbound + area));
    }
    // Stable, as Python's sorted.
    tcs.sort_by_key(|&(lb, ub)| std::cmp::Reverse(ub - lb));
    tcs
}

/// `np.argmax`: the first maximum.
fn argmax(v: &[f64]) -> usize {
    let mut best = 0;
    for (i, &x) in v.iter().enumerate() {
        if x > v[best] {
            best = i;
        }
    }
    best
}

/// claspy's `ClaSP.split` validation of the profile's maximum `cp` (an index into `profile`;
/// the neighbours' split is `cp - lbound`, the rank-sum test cuts at `cp` as claspy does).
fn validated(s: &Settings, profile: &[f64], offsets: &[u32], lbound: usize) -> Option<usize> {
    let cp = argmax(profile);
    if profile[cp] == f64::NEG_INFINITY || cp < lbound {
        return None;
    }
    let ok = match s.validation {
        Validation::SignificanceTest => {
            significant(offsets, s.k, s.window, cp - lbound, cp, s.threshold)
        }
        Validation::ScoreThreshold => profile[cp] >= s.threshold,
    };
    ok.then_some(cp)
}

fn fit_ensemble(channels: &[&[f64]], s: &Settings) -> EnsembleFit {
    let n = channels[0].len();
    let w = s.window;
    let min_seg = s.min_seg();
    let tcs = temporal_constraints(n, min_seg, s.n_estimators, s.random_state);
    let nn = k_subsequence_neighbours(channels, w, s.k, &tcs);
    let mut best: Option<(usize, Vec<f64>, Vec<u32>)> = None;
    let mut best_score = f64::NEG_INFINITY;
    for (idx, &(lb, ub)) in tcs.iter().enumerate() {
        let offsets = nn.constrained(idx, lb, ub, w);
        let mut prof = profile(&offsets, s.k, ub - lb, w, min_seg, s.score);
        let share = (ub - lb) as f64 / n as f64;
        for p in &mut prof {
            *p = (*p + share) / 2.0;
        }
        let max = prof.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        if max > best_score || (best.is_none() && idx == tcs.len() - 1) {
            best_score = max;
            best = Some((lb, prof, offsets));
        } else if s.early_stopping {
            break;
        }
        if s.early_stopping
            && let Some((_, prof, offsets)) = &best
            && validated(s, prof, offsets, 0).is_some()
        {
            break;
        }
    }
    let mut full = vec![f64::NEG_INFINITY; n + 1 - w];
    match best {
        Some((lb, prof, offsets)) => {
            full[lb..lb + prof.len()].copy_from_slice(&prof);
            EnsembleFit { lbound: lb, profile: full, offsets }
        }
        None => EnsembleFit { lbound: 0, profile: full, offsets: Vec::new() },
    }
}

fn split(fit: &EnsembleFit, s: &Settings) -> Option<usize> {
    validated(s, &fit.profile, &fit.offsets, fit.lbound)
}

/// The result of a binary segmentation: change points (sorted) and the profile (the maximum
/// of every accepted ClaSP's profile per split point, −∞ where none is defined).
pub(crate) struct Segmentation {
    pub change_points: Vec<usize>,
    pub profile: Vec<f64>,
}

/// claspy's `BinaryClaSPSegmentation.fit` with a resolved window; `n_segments` None = learn.
pub(crate) fn binary_segmentation(
    channels: &[&[f64]],
    s: &Settings,
    n_segments: Option<usize>,
) -> Segmentation {
    let n = channels[0].len();
    let min_seg = s.min_seg();
    if n < 2 * min_seg {
        let w = s.window.min(n / 2).max(1);
        return Segmentation {
            change_points: Vec::new(),
            profile: vec![f64::NEG_INFINITY; n + 1 - w],
        };
    }
    let n_segments = n_segments.unwrap_or(n / min_seg);
    let w = s.window;
    let valid = |candidate: usize, cps: &[usize]| {
        std::iter::once(0)
            .chain(cps.iter().copied())
            .chain(std::iter::once(n))
            .all(|cp| !(cp.saturating_sub(min_seg)..(cp + min_seg).min(n)).contains(&candidate))
    };
    // The tree of accepted ClaSPs and the queue of (−score, tree index), smallest first.
    let mut tree: Vec<((usize, usize), EnsembleFit)> = Vec::new();
    let mut queue: Vec<(f64, usize)> = Vec::new();
    let mut profile;
    if n_segments > 1 {
        let fit = fit_ensemble(channels, s);
        profile = fit.profile.clone();
        if let Some(cp) = split(&fit, s)
            && valid(cp, &[])
        {
            queue.push((-fit.profile[cp], tree.len()));
            tree.push(((0, n), fit));
        }
    } else {
        profile = vec![f64::NEG_INFINITY; n + 1 - w];
    }
    let mut change_points: Vec<usize> = Vec::new();
    for _ in 0..n_segments.saturating_sub(1) {
        let Some(at) = (0..queue.len())
            .min_by(|&a, &b| queue[a].0.total_cmp(&queue[b].0).then(queue[a].1.cmp(&queue[b].1)))
        else {
            break;
        };
        let (_, tree_idx) = queue.remove(at);
        let ((lbound, ubound), fit) = &tree[tree_idx];
        let (lbound, ubound) = (*lbound, *ubound);
        let Some(rel) = split(fit, s) else { break };
        let cp = lbound + rel;
        for (p, &q) in profile[lbound..ubound + 1 - w].iter_mut().zip(&fit.profile) {
            *p = p.max(q);
        }
        change_points.push(cp);
        if change_points.len() == n_segments - 1 {
            break;
        }
        for (lb, ub) in [(lbound, cp), (cp, ubound)] {
            if ub - lb < 2 * min_seg {
                continue;
            }
            let part: Vec<&[f64]> = channels.iter().map(|c| &c[lb..ub]).collect();
            let fit = fit_ensemble(&part, s);
            let Some(rel) = split(&fit, s) else { continue };
            if !valid(lb + rel, &change_points) {
                continue;
            }
            queue.push((-fit.profile[rel], tree.len()));
            tree.push(((lb, ub), fit));
        }
    }
    change_points.sort_unstable();
    Segmentation { change_points, profile }
}

/// One ClaSP (no ensemble) over the whole series: claspy's `ClaSP(window_size=w).fit(ts)`.
pub(crate) fn single_profile(channels: &[&[f64]], s: &Settings) -> Vec<f64> {
    let n = channels[0].len();
    let nn = k_subsequence_neighbours(channels, s.window, s.k, &[(0, n)]);
    let offsets = nn.constrained(0, 0, n, s.window);
    profile(&offsets, s.k, n, s.window, s.min_seg(), s.score)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn temporal_constraints_follow_numpys_draws() {
        // claspy 0.2.8: ClaSPEnsemble(window_size=10)._calculate_temporal_constraints() on a
        // series of 1000 samples (min_seg 50), printed with NumPy 2.2.6.
        let tcs = temporal_constraints(1000, 50, 10, 2357);
        assert_eq!(tcs, CLASPY_TCS_1000.to_vec());
    }

    const CLASPY_TCS_1000: [(usize, usize); 10] = [
        (0, 1000),
        (67, 908),
        (111, 936),
        (120, 852),
        (302, 957),
        (516, 1000),
        (301, 653),
        (705, 1000),
        (282, 490),
        (815, 978),
    ];
}
