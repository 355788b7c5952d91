//! The k nearest neighbours of every window (claspy's `KSubsequenceNeighbours`): z-normalised
//! squared Euclidean distances from claspy's dot-product recurrence, an exclusion zone of
//! half a window around each window, and the k nearest inside each temporal constraint.

use rayon::prelude::*;

use crate::sliding::{claspy_mean_std, window_dots};

/// The neighbours of every window, for every temporal constraint.
pub(crate) struct Neighbours {
    pub k: usize,
    pub n_constraints: usize,
    /// `offsets[(row * n_constraints + c) * k + j]`: the j-th nearest window (index in the
    /// series) of window `row` inside constraint `c`; only rows inside the constraint are set.
    pub offsets: Vec<u32>,
}

impl Neighbours {
    /// The neighbour offsets of constraint `c` for its rows `[lbound, ubound - w + 1)`,
    /// relative to `lbound` (claspy's `constrain`), row-major with `k` per row.
    pub fn constrained(&self, c: usize, lbound: usize, ubound: usize, w: usize) -> Vec<u32> {
        let mut out = Vec::with_capacity((ubound + 1 - w - lbound) * self.k);
        for row in lbound..ubound + 1 - w {
            let at = (row * self.n_constraints + c) * self.k;
            out.extend(self.offsets[at..at + self.k].iter().map(|&o| o - lbound as u32));
        }
        out
    }
}

/// The k smallest `(value, index)` pairs seen, in lexicographic order — what claspy's
/// repeated first-minimum search (`_argkmin`) selects.
#[derive(Clone)]
struct TopK {
    vals: Vec<f64>,
    idx: Vec<u32>,
}

impl TopK {
    fn new(k: usize) -> Self {
        TopK { vals: Vec::with_capacity(k), idx: Vec::with_capacity(k) }
    }
    fn clear(&mut self) {
        self.vals.clear();
        self.idx.clear();
    }
    #[inline]
    fn offer(&mut self, k: usize, v: f64, i: u32) {
        let full = self.vals.len() == k;
        if full {
            let (lv, li) = (self.vals[k - 1], self.idx[k - 1]);
            if !(v < lv || (v == lv && i < li)) {
                return;
            }
        } else if v.is_nan() {
            return;
        }
        let mut pos = self.vals.len();
        while pos > 0
            && (v < self.vals[pos - 1] || (v == self.vals[pos - 1] && i < self.idx[pos - 1]))
        {
            pos -= 1;
        }
        if full {
            self.vals.pop();
            self.idx.pop();
        }
        self.vals.insert(pos, v);
        self.idx.insert(pos, i);
    }
}

/// Computes the neighbours of every window of `channels` (each the same length) for the
/// temporal constraints `tcs` (`[lbound, ubound)` sample ranges; a window's neighbours in a
/// constraint are windows starting in `[lbound, ubound - w + 1)`).
pub(crate) fn k_subsequence_neighbours(
    channels: &[&[f64]],
    w: usize,
    k: usize,
    tcs: &[(usize, usize)],
) -> Neighbours {
    let n = channels[0].len();
    let l = n + 1 - w;
    let d = channels.len();
    let stats: Vec<(Vec<f64>, Vec<f64>)> = channels.iter().map(|t| claspy_mean_std(t, w)).collect();
    // Column 0 of every row: the dot products with window 0 (claspy's `dot_ref`).
    let first_row: Vec<Vec<f64>> = channels
        .iter()
        .map(|t| {
            let mut row = vec![0.0; l];
            window_dots(t, w, 0, &mut row);
            row
        })
        .collect();
    // Elementary intervals between the constraints' candidate ranges: each row is scanned
    // once, keeping the k nearest per interval, and a constraint merges its intervals'.
    let mut cuts: Vec<usize> = vec![0, l];
    for &(lb, ub) in tcs {
        cuts.push(lb.min(l));
        cuts.push((ub + 1 - w).min(l));
    }
    cuts.sort_unstable();
    cuts.dedup();
    let intervals: Vec<(usize, usize)> = cuts.windows(2).map(|c| (c[0], c[1])).collect();
    let covering: Vec<Vec<usize>> = tcs
        .iter()
        .map(|&(lb, ub)| {
            (0..intervals.len())
                .filter(|&i| intervals[i].0 >= lb && intervals[i].1 <= ub + 1 - w)
                .collect()
        })
        .collect();
    let w_means: Vec<Vec<f64>> =
        stats.iter().map(|(m, _)| m.iter().map(|&v| w as f64 * v).collect()).collect();
    let inv_stds: Vec<Vec<f64>> =
        stats.iter().map(|(_, s)| s.iter().map(|&v| 1.0 / v).collect()).collect();
    let n_tc = tcs.len();
    let mut offsets = vec![0u32; l * n_tc * k];
    let threads = rayon::current_num_threads().max(1);
    let rows_per_chunk = l.div_ceil(threads * 4).max(64);
    let excl = w / 2;
    let two_w = (2 * w) as f64;
    let wf = w as f64;

    offsets.par_chunks_mut(rows_per_chunk * n_tc * k).enumerate().for_each(|(chunk, out)| {
        let r0 = chunk * rows_per_chunk;
        let r1 = (r0 + rows_per_chunk).min(l);
        let mut prev: Vec<Vec<f64>> = vec![vec![0.0; l]; d];
        let mut cur: Vec<Vec<f64>> = vec![vec![0.0; l]; d];
        let mut dist: Vec<Vec<f64>> = vec![vec![0.0; l]; d];
        let mut summed = vec![0.0; if d > 1 { l } else { 0 }];
        let mut tops: Vec<TopK> = vec![TopK::new(k); intervals.len()];
        let mut merged = TopK::new(k);
        let mut needed = vec![false; intervals.len()];
        for r in r0..r1 {
            let (z0, z1) = (r.saturating_sub(excl), (r + excl + 1).min(l));
            for c in 0..d {
                let t = channels[c];
                let (means, stds) = &stats[c];
                let cur_c = &mut cur[c];
                if r == r0 {
                    window_dots(t, w, r, cur_c);
                } else {
                    let prev_c = &prev[c];
                    let (a, b) = (t[r + w - 1], t[r - 1]);
                    cur_c[0] = first_row[c][r];
                    for (((o, &p), &tn), &to) in cur_c[1..]
                        .iter_mut()
                        .zip(&prev_c[..l - 1])
                        .zip(&t[w..w + l - 1])
                        .zip(&t[..l - 1])
                    {
                        *o = p + a * tn - b * to;
                    }
                }
                let dist_c = &mut dist[c];
                let max = if d == 1 {
                    // One channel: the row is ranked on (w·μ_r·μ_j − dot_j)/σ_j, an increasing
                    // function of claspy's distance 2w(1 − (dot_j − w·μ_j·μ_r)/(w·σ_j·σ_r))
                    // for the fixed row r, without the division per window.
                    let mu_r = means[r];
                    let (mut lanes, chunks) = ([f64::NEG_INFINITY; 4], dist_c.len() / 4 * 4);
                    for (((dv, &dot), &am), &is) in
                        dist_c.iter_mut().zip(cur_c.iter()).zip(&w_means[c]).zip(&inv_stds[c])
                    {
                        *dv = (mu_r * am - dot) * is;
                    }
                    for quad in dist_c[..chunks].chunks_exact(4) {
                        for (m, &v) in lanes.iter_mut().zip(quad) {
                            *m = m.max(v);
                        }
                    }
                    dist_c[chunks..]
                        .iter()
                        .chain(lanes.iter())
                        .fold(f64::NEG_INFINITY, |a, &b| a.max(b))
                } else {
                    let (mu_r, sd_r) = (means[r], stds[r]);
                    let mut max = f64::NEG_INFINITY;
                    for (((dv, &dot), &mu), &sd) in
                        dist_c.iter_mut().zip(cur_c.iter()).zip(means.iter()).zip(stds.iter())
                    {
                        let v = two_w * (1.0 - (dot - wf * mu * mu_r) / (wf * sd * sd_r));
                        *dv = v;
                        max = max.max(v);
                    }
                    max
                };
                for v in &mut dist_c[z0..z1] {
                    *v = max;
                }
                if d > 1 {
                    // claspy normalises each channel's distances before summing them.
                    let mean = dist_c.iter().sum::<f64>() / l as f64;
                    let var =
                        dist_c.iter().map(|&v| (v - mean) * (v - mean)).sum::<f64>() / l as f64;
                    let sd = var.sqrt();
                    for v in dist_c.iter_mut() {
                        *v = (*v - mean) / sd;
                    }
                }
            }
            std::mem::swap(&mut prev, &mut cur);
            // A univariate row is selected on its own ranking values: claspy's normalisation
            // is monotone there and leaves the order of the nearest unchanged.
            let row: &[f64] = if d == 1 {
                &dist[0]
            } else {
                for j in 0..l {
                    let mut acc = 0.0;
                    for dist_c in &dist {
                        acc += dist_c[j];
                    }
                    summed[j] = acc / d as f64;
                }
                &summed
            };
            needed.fill(false);
            for (&(lb, ub), cov) in tcs.iter().zip(&covering) {
                if r >= lb && r < ub {
                    for &i in cov {
                        needed[i] = true;
                    }
                }
            }
            for (i, &(a, b)) in intervals.iter().enumerate() {
                let top = &mut tops[i];
                top.clear();
                if !needed[i] {
                    continue;
                }
                // Ascending indices: a later equal value never displaces an earlier one, so
                // only a strictly smaller value than the current k-th needs the insertion.
                // Blocks of 8 are tested at once (vectorised) and walked only when one of
                // their values beats the k-th.
                let mut kth = f64::INFINITY;
                let mut j = a;
                while j < b {
                    let end = (j + 8).min(b);
                    let block = &row[j..end];
                    let mut hit = top.vals.len() < k;
                    if let Ok(full) = <&[f64; 8]>::try_from(block) {
                        let mut lanes = [false; 8];
                        for (h, &v) in lanes.iter_mut().zip(full) {
                            *h = v < kth;
                        }
                        hit |= lanes.iter().any(|&h| h);
                    } else {
                        hit |= block.iter().any(|&v| v < kth);
                    }
                    if hit {
                        for (o, &v) in block.iter().enumerate() {
                            if v < kth || (top.vals.len() < k && !v.is_nan()) {
                                top.offer(k, v, (j + o) as u32);
                                if top.vals.len() == k {
                                    kth = top.vals[k - 1];
                                }
                            }
                        }
                    }
                    j = end;
                }
            }
            let out_row = &mut out[(r - r0) * n_tc * k..(r - r0 + 1) * n_tc * k];
            for (c, &(lb, ub)) in tcs.iter().enumerate() {
                if r < lb || r >= ub {
                    continue;
                }
                merged.clear();
                for &i in &covering[c] {
                    for (&v, &j) in tops[i].vals.iter().zip(&tops[i].idx) {
                        merged.offer(k, v, j);
                    }
                }
                let slot = &mut out_row[c * k..(c + 1) * k];
                for (s, o) in slot.iter_mut().enumerate() {
                    // Fewer than k finite distances only happen on overflowing input; the
                    // window itself fills the gap rather than an undefined index.
                    *o = merged.idx.get(s).copied().unwrap_or(r as u32);
                }
            }
        }
    });
    Neighbours { k, n_constraints: n_tc, offsets }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Brute force: exact dot products, the same distance formula and exclusion zone, the k
    /// smallest by (value, index).
    fn brute(t: &[f64], w: usize, k: usize, lb: usize, ub: usize) -> Vec<Vec<u32>> {
        let l = t.len() + 1 - w;
        let (means, stds) = claspy_mean_std(t, w);
        let wf = w as f64;
        (0..l)
            .map(|r| {
                let mut d: Vec<f64> = (0..l)
                    .map(|j| {
                        let dot: f64 = (0..w).map(|s| t[r + s] * t[j + s]).sum();
                        2.0 * wf
                            * (1.0 - (dot - wf * means[j] * means[r]) / (wf * stds[j] * stds[r]))
                    })
                    .collect();
                let max = d.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
                for v in &mut d[r.saturating_sub(w / 2)..(r + w / 2 + 1).min(l)] {
                    *v = max;
                }
                let mut order: Vec<usize> = (lb..ub + 1 - w).collect();
                order.sort_by(|&a, &b| d[a].total_cmp(&d[b]).then(a.cmp(&b)));
                order[..k].iter().map(|&j| j as u32).collect()
            })
            .collect()
    }

    #[test]
    fn recurrence_and_intervals_give_the_brute_force_neighbours() {
        let t: Vec<f64> =
            (0..300).map(|i| ((i * i) % 17) as f64 + (i as f64 * 0.3).sin()).collect();
        let w = 8;
        let tcs = [(0, 300), (40, 220), (100, 300)];
        let nn = k_subsequence_neighbours(&[&t], w, 3, &tcs);
        for (c, &(lb, ub)) in tcs.iter().enumerate() {
            let want = brute(&t, w, 3, lb, ub);
            for (r, exp) in want.iter().enumerate().take(ub + 1 - w).skip(lb) {
                let at = (r * tcs.len() + c) * 3;
                let mut got = nn.offsets[at..at + 3].to_vec();
                let mut exp = exp.clone();
                got.sort_unstable();
                exp.sort_unstable();
                assert_eq!(got, exp, "row {r}, constraint {c}");
            }
        }
    }
}
