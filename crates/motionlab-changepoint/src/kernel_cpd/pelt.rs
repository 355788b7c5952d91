//! PELT with ruptures' `Pelt` semantics (`ruptures/detection/pelt.py`), step for step.
//!
//! - Ends are visited on ruptures' grid: every multiple of `jump` that is ≥ `min_size`, then n.
//! - At each end `bkp`, the start `⌊(bkp − min_size)/jump⌋·jump` joins the admissible list
//!   (appended, even when already there); starts with no optimal partition yet (multiples of
//!   `jump` strictly between 0 and `min_size`) are skipped.
//! - The total of a candidate is the left-to-right sum of its segments' `cost + pen` (Python's
//!   `sum` over the partition dict in insertion order), so `F(bkp) = F(t) + (c(t, bkp) + pen)`.
//! - The first minimum in admissible order wins; a start survives when its total is
//!   `≤ F(bkp) + pen` — pairing the admissible list with the evaluated totals as Python's `zip`
//!   does (a skipped start is always the last one appended, so the pairing never shifts).
//!
//! The rbf cost is computed from running Gram block sums per grid start (`RbfEndCosts`), in O(n)
//! memory, where ruptures slices an n × n Gram matrix; the autoregressive cost from one growing
//! least-squares factorisation per live start (`ArEndCosts`), where ruptures solves each
//! (start, end) pair from scratch.

use super::ar::{ArDesign, QrFit};
use super::cost::{SegmentCost, rbf_cost_from_block, rbf_off_diagonal, squared_distance};
use super::crops::Solved;
use crate::signal::Signal;

/// The costs `c(s, t)` of the admissible starts `s` at one end `t` (ends come in increasing
/// order, and no start below the smallest one asked will be asked again).
pub(crate) trait EndCosts {
    fn costs(&mut self, end: usize, starts: &[usize], out: &mut Vec<f64>);
}

/// Any cost with O(1)-or-so segments: evaluated one by one.
pub(crate) struct DirectEndCosts<'c, C: SegmentCost>(pub &'c C);

impl<C: SegmentCost> EndCosts for DirectEndCosts<'_, C> {
    fn costs(&mut self, end: usize, starts: &[usize], out: &mut Vec<f64>) {
        out.clear();
        out.extend(starts.iter().map(|&s| self.0.error(s, end)));
    }
}

/// ruptures' `CostRbf` for PELT from running sums: `block[g] = Σ_{i,j ∈ [g·jump, processed)} k`
/// for every grid start from the lowest still admissible. Adding sample u costs one kernel
/// evaluation per sample from the lowest start to u, as ruptures' C `KernelCPD` does.
pub(crate) struct RbfEndCosts<'a> {
    signal: Signal<'a>,
    gamma: f64,
    jump: usize,
    processed: usize,
    block: Vec<f64>,
}

impl<'a> RbfEndCosts<'a> {
    pub fn new(signal: Signal<'a>, gamma: f64, jump: usize) -> Self {
        let grid = signal.n_samples / jump + 1;
        RbfEndCosts { signal, gamma, jump, processed: 0, block: vec![0.0; grid] }
    }

    fn add_sample(&mut self, u: usize, lowest: usize) {
        let jump = self.jump;
        if u.is_multiple_of(jump) {
            self.block[u / jump] = 1.0;
        }
        if u == 0 {
            return;
        }
        let xu = self.signal.row(u);
        let mut cross = 0.0;
        // Grid starts g·jump ≤ u − 1, from the highest down to the lowest admissible one; the
        // kernel sum runs over every sample in between.
        let first_group = (u - 1) / jump;
        let last_group = lowest / jump;
        for g in (last_group..=first_group).rev() {
            let lo = g * jump;
            let hi = ((g + 1) * jump).min(u);
            for i in (lo..hi).rev() {
                cross += rbf_off_diagonal(self.gamma, squared_distance(self.signal.row(i), xu));
            }
            self.block[g] += 2.0 * cross + 1.0;
        }
    }
}

impl EndCosts for RbfEndCosts<'_> {
    fn costs(&mut self, end: usize, starts: &[usize], out: &mut Vec<f64>) {
        let lowest = starts.iter().copied().min().unwrap_or(end);
        while self.processed < end {
            self.add_sample(self.processed, lowest);
            self.processed += 1;
        }
        out.clear();
        out.extend(starts.iter().map(|&s| rbf_cost_from_block(end - s, self.block[s / self.jump])));
    }
}

/// ruptures' `CostAR` for PELT: every admissible start keeps the factorisation of its rows so
/// far and takes in the rows up to each new end (O(order²) per row and live start); a start
/// pruned from the admissible list is dropped with its factorisation.
pub(crate) struct ArEndCosts<'d> {
    design: &'d ArDesign,
    jump: usize,
    /// The factorisation of `start..` per grid start (`start / jump`), None once pruned.
    fits: Vec<Option<QrFit>>,
    /// The grid starts asked at the previous end.
    live: Vec<usize>,
    /// Per grid start, the last call that asked for it.
    seen: Vec<u64>,
    call: u64,
}

impl<'d> ArEndCosts<'d> {
    pub fn new(design: &'d ArDesign, jump: usize) -> Self {
        let grid = design.y.len() / jump + 1;
        ArEndCosts {
            design,
            jump,
            fits: vec![None; grid],
            live: Vec::new(),
            seen: vec![0; grid],
            call: 0,
        }
    }
}

impl EndCosts for ArEndCosts<'_> {
    fn costs(&mut self, end: usize, starts: &[usize], out: &mut Vec<f64>) {
        self.call += 1;
        out.clear();
        for &s in starts {
            let g = s / self.jump;
            self.seen[g] = self.call;
            let fit = self.fits[g].get_or_insert_with(|| QrFit::new(self.design.columns));
            for t in s + fit.rows()..end {
                let (x, y) = self.design.row(t);
                fit.push(x, y);
            }
            out.push(fit.cost());
        }
        // Pruning is final: a start not asked now is never asked again.
        for &s in &self.live {
            let g = s / self.jump;
            if self.seen[g] != self.call {
                self.fits[g] = None;
            }
        }
        self.live.clear();
        self.live.extend_from_slice(starts);
    }
}

/// Breakpoints (segment ends, the last being `n_samples`) as ruptures' `Pelt.predict(pen)`.
pub(crate) fn pelt(
    n_samples: usize,
    pen: f64,
    min_size: usize,
    jump: usize,
    costs: &mut dyn EndCosts,
) -> Vec<usize> {
    pelt_solve(n_samples, pen, min_size, jump, costs).breakpoints
}

/// `pelt`, with the unpenalised cost of the segmentation found: its segments' costs as PELT
/// evaluated them, summed left to right (the sum ruptures' `cost.sum_of_costs` makes).
pub(crate) fn pelt_solve(
    n_samples: usize,
    pen: f64,
    min_size: usize,
    jump: usize,
    costs: &mut dyn EndCosts,
) -> Solved {
    let n = n_samples;
    let mut segment_cost = vec![0.0; n + 1];
    let mut total = vec![f64::NAN; n + 1];
    let mut solved = vec![false; n + 1];
    let mut previous = vec![0usize; n + 1];
    total[0] = 0.0;
    solved[0] = true;
    let mut admissible: Vec<usize> = Vec::new();
    let mut evaluated: Vec<usize> = Vec::new();
    let mut cost_values: Vec<f64> = Vec::new();
    let mut totals: Vec<f64> = Vec::new();
    let ends = (0..n).step_by(jump).filter(|&k| k >= min_size).chain(std::iter::once(n));
    for bkp in ends {
        admissible.push((bkp - min_size) / jump * jump);
        evaluated.clear();
        evaluated.extend(admissible.iter().copied().filter(|&t| solved[t]));
        costs.costs(bkp, &evaluated, &mut cost_values);
        totals.clear();
        totals.extend(evaluated.iter().zip(&cost_values).map(|(&t, &c)| total[t] + (c + pen)));
        let mut best = 0;
        for (i, &v) in totals.iter().enumerate().skip(1) {
            if v < totals[best] {
                best = i;
            }
        }
        total[bkp] = totals[best];
        previous[bkp] = evaluated[best];
        segment_cost[bkp] = cost_values[best];
        solved[bkp] = true;
        let bound = total[bkp] + pen;
        let kept: Vec<usize> =
            admissible.iter().zip(&totals).filter(|&(_, &v)| v <= bound).map(|(&t, _)| t).collect();
        admissible = kept;
    }
    let breakpoints = breakpoints_from_path(&previous, n);
    let cost = breakpoints.iter().map(|&b| segment_cost[b]).sum();
    Solved { breakpoints, cost }
}

/// ruptures' breakpoints read back from the best previous end of every end, from n.
pub(crate) fn breakpoints_from_path(previous: &[usize], n: usize) -> Vec<usize> {
    let mut breakpoints = Vec::new();
    let mut t = n;
    while t > 0 {
        breakpoints.push(t);
        t = previous[t];
    }
    breakpoints.reverse();
    breakpoints
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel_cpd::ar::ArCost;
    use crate::kernel_cpd::cost::{L2Cost, RbfCost};
    use crate::signal::{Missing, Signal};

    /// Exhaustive optimum of the penalised l2 problem over ruptures' grid, for tiny n.
    fn brute_force(
        cost: &dyn SegmentCost,
        n: usize,
        pen: f64,
        min_size: usize,
        jump: usize,
    ) -> (f64, Vec<usize>) {
        let grid: Vec<usize> = (min_size..n).filter(|k| k % jump == 0).collect();
        let mut best = (f64::INFINITY, vec![n]);
        for mask in 0u32..(1 << grid.len()) {
            let mut ends: Vec<usize> = grid
                .iter()
                .enumerate()
                .filter(|(i, _)| mask >> i & 1 == 1)
                .map(|(_, &b)| b)
                .collect();
            ends.push(n);
            let mut start = 0;
            let mut value = 0.0;
            let mut ok = true;
            for &e in &ends {
                if e - start < min_size {
                    ok = false;
                }
                value += cost.error(start, e.max(start + 1)) + pen;
                start = e;
            }
            if ok && value < best.0 - 1e-9 {
                best = (value, ends);
            }
        }
        best
    }

    #[test]
    fn finds_the_exhaustive_optimum_on_small_series() {
        let mut rng = fastrand::Rng::with_seed(7);
        for trial in 0..30 {
            let n = 12 + trial % 7;
            let x: Vec<f64> =
                (0..n).map(|i| if i < n / 2 { 0.0 } else { 3.0 } + rng.f64()).collect();
            let sig = Signal::new(&x, 1, "t", Missing::Refuse).unwrap();
            let cost = L2Cost::new(&sig);
            // jump 1 makes PELT exact; min_size 2.
            let got = pelt(n, 0.5, 2, 1, &mut DirectEndCosts(&cost));
            let (_, want) = brute_force(&cost, n, 0.5, 2, 1);
            assert_eq!(got, want, "trial {trial}");
        }
    }

    #[test]
    fn rbf_running_sums_equal_the_direct_cost() {
        let mut rng = fastrand::Rng::with_seed(9);
        let x: Vec<f64> = (0..2 * 80).map(|i| if i < 80 { 0.0 } else { 2.0 } + rng.f64()).collect();
        let sig = Signal::new(&x, 2, "t", Missing::Refuse).unwrap();
        for jump in [1, 3, 5] {
            let direct = RbfCost { signal: sig, gamma: 0.5 };
            let mut running = RbfEndCosts::new(sig, 0.5, jump);
            let mut out = Vec::new();
            for end in (jump.max(2)..=80).step_by(jump) {
                let starts: Vec<usize> = (0..end - 1).step_by(jump).collect();
                running.costs(end, &starts, &mut out);
                for (&s, &c) in starts.iter().zip(&out) {
                    assert!((c - direct.error(s, end)).abs() < 1e-11, "jump {jump} {s}..{end}");
                }
            }
            let a = pelt(80, 1.0, 2, jump, &mut RbfEndCosts::new(sig, 0.5, jump));
            let b = pelt(80, 1.0, 2, jump, &mut DirectEndCosts(&direct));
            assert_eq!(a, b);
            assert_eq!(a.len(), 2);
            assert!((a[0] as i64 - 40).abs() < jump as i64, "{a:?}");
        }
    }

    #[test]
    fn ar_growing_fits_equal_fits_from_scratch() {
        // An AR(1) whose coefficient flips sign at 120: PELT finds it, and the growing
        // factorisations give the from-scratch costs.
        let mut rng = fastrand::Rng::with_seed(21);
        let mut x = vec![0.0];
        for i in 1..240 {
            let phi = if i < 120 { 0.9 } else { -0.9 };
            let prev = x[i - 1];
            x.push(phi * prev + rng.f64() - 0.5);
        }
        let design = ArDesign::new(&x, 4);
        let direct = ArCost { design: ArDesign::new(&x, 4) };
        let mut growing = ArEndCosts::new(&design, 5);
        let mut out = Vec::new();
        for end in (10..=240).step_by(5) {
            let starts: Vec<usize> =
                (0..end - 5).step_by(5).filter(|s| s % 15 != 5 || end < 100).collect();
            growing.costs(end, &starts, &mut out);
            for (&s, &c) in starts.iter().zip(&out) {
                let want = direct.error(s, end);
                assert!((c - want).abs() <= 1e-9 * want.max(1e-12), "{s}..{end}: {c} vs {want}");
            }
        }
        let a = pelt(240, 1.0, 20, 5, &mut ArEndCosts::new(&design, 5));
        let b = pelt(240, 1.0, 20, 5, &mut DirectEndCosts(&direct));
        assert_eq!(a, b);
        assert_eq!(a, vec![120, 240]);
    }

    #[test]
    fn the_grid_is_multiples_of_jump_at_least_min_size() {
        // A step at 23 is not on the jump-5 grid: the breakpoint lands on a multiple of 5.
        let x: Vec<f64> = (0..50).map(|i| if i < 23 { 0.0 } else { 10.0 }).collect();
        let sig = Signal::new(&x, 1, "t", Missing::Refuse).unwrap();
        let cost = L2Cost::new(&sig);
        let b = pelt(50, 1.0, 2, 5, &mut DirectEndCosts(&cost));
        assert_eq!(b.len(), 3);
        assert!(b[0].is_multiple_of(5) && b[1].is_multiple_of(5) && b[2] == 50, "{b:?}");
    }
}
