//! Binary segmentation with ruptures' `Binseg` semantics (`ruptures/detection/binseg.py`).
//!
//! - A segment `start..end` splits at the grid point `bkp ∈ start, start+jump, …` (all
//!   multiples of `jump`, since every start is) with `bkp − start ≥ min_size` and
//!   `end − bkp ≥ min_size` of largest gain `c(start,end) − c(start,bkp) − c(bkp,end)`; equal
//!   gains go to the larger `bkp` (Python's `max` over `(gain, bkp)` tuples).
//! - Each round takes, over the current segments in order, the first of largest gain; a segment
//!   with no admissible split counts as gain 0 and, if it is that first maximum, ends the search.
//! - With `n_bkps` it stops after that many breakpoints (fewer when no segment can split); with
//!   `pen` when the best gain is not above `pen`.
//!
//! The rbf cost comes from running Gram block sums from both ends of the segment (O(L²) kernel
//! evaluations for a segment of L samples, O(L) memory), where ruptures slices an n × n Gram
//! matrix per cost.

use std::collections::HashMap;

use super::ar::{ArDesign, QrFit};
use super::cost::{SegmentCost, rbf_cost_from_block, rbf_off_diagonal, squared_distance};
use crate::signal::Signal;

/// The stopping rule.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Stop {
    Penalty(f64),
    Count(usize),
}

/// The split gains of one segment over its admissible grid points, and the segment's cost.
pub(crate) trait SplitGains {
    fn gains(&self, start: usize, end: usize, min_size: usize, jump: usize) -> Vec<(usize, f64)>;
}

/// Gains from a cost evaluated segment by segment.
pub(crate) struct DirectGains<'c, C: SegmentCost>(pub &'c C);

impl<C: SegmentCost> SplitGains for DirectGains<'_, C> {
    fn gains(&self, start: usize, end: usize, min_size: usize, jump: usize) -> Vec<(usize, f64)> {
        let segment = self.0.error(start, end);
        (start..end)
            .step_by(jump)
            .filter(|&b| b - start >= min_size && end - b >= min_size)
            .map(|b| (b, segment - self.0.error(start, b) - self.0.error(b, end)))
            .collect()
    }
}

/// ruptures' `CostRbf` gains from block sums grown from the left (`start..b`) and from the
/// right (`b..end`).
pub(crate) struct RbfGains<'a> {
    pub signal: Signal<'a>,
    pub gamma: f64,
}

impl SplitGains for RbfGains<'_> {
    fn gains(&self, start: usize, end: usize, min_size: usize, jump: usize) -> Vec<(usize, f64)> {
        let k = |i: usize, j: usize| {
            rbf_off_diagonal(self.gamma, squared_distance(self.signal.row(i), self.signal.row(j)))
        };
        let slots = (end - start).div_ceil(jump);
        // left[g] = block sum of start..start+g·jump; right[g] = block sum of start+g·jump..end.
        let mut left = vec![0.0; slots + 1];
        let mut right = vec![0.0; slots + 1];
        let mut block = 0.0;
        for u in start..end {
            let cross: f64 = (start..u).rev().map(|i| k(i, u)).sum();
            block += 2.0 * cross + 1.0;
            if (u + 1 - start).is_multiple_of(jump) {
                left[(u + 1 - start) / jump] = block;
            }
        }
        let segment = rbf_cost_from_block(end - start, block);
        let mut block = 0.0;
        for u in (start..end).rev() {
            let cross: f64 = (u + 1..end).map(|j| k(u, j)).sum();
            block += 2.0 * cross + 1.0;
            if (u - start).is_multiple_of(jump) {
                right[(u - start) / jump] = block;
            }
        }
        (start..end)
            .step_by(jump)
            .enumerate()
            .filter(|&(_, b)| b - start >= min_size && end - b >= min_size)
            .map(|(g, b)| {
                (
                    b,
                    segment
                        - rbf_cost_from_block(b - start, left[g])
                        - rbf_cost_from_block(end - b, right[g]),
                )
            })
            .collect()
    }
}

/// ruptures' `CostAR` gains: the fits of `start..b` grown from the left and of `b..end` grown
/// from the right, read at every grid point.
pub(crate) struct ArGains<'d>(pub &'d ArDesign);

impl SplitGains for ArGains<'_> {
    fn gains(&self, start: usize, end: usize, min_size: usize, jump: usize) -> Vec<(usize, f64)> {
        let design = self.0;
        let slots = (end - start).div_ceil(jump);
        let mut left = vec![0.0; slots + 1];
        let mut right = vec![0.0; slots + 1];
        let mut fit = QrFit::new(design.columns);
        for t in start..end {
            if (t - start).is_multiple_of(jump) {
                left[(t - start) / jump] = fit.cost();
            }
            let (x, y) = design.row(t);
            fit.push(x, y);
        }
        let segment = fit.cost();
        let mut fit = QrFit::new(design.columns);
        for t in (start..end).rev() {
            let (x, y) = design.row(t);
            fit.push(x, y);
            if (t - start).is_multiple_of(jump) {
                right[(t - start) / jump] = fit.cost();
            }
        }
        (start..end)
            .step_by(jump)
            .enumerate()
            .filter(|&(_, b)| b - start >= min_size && end - b >= min_size)
            .map(|(g, b)| (b, segment - left[g] - right[g]))
            .collect()
    }
}

/// The best split of a gain list as ruptures' `single_bkp` picks it.
fn best_split(gains: &[(usize, f64)]) -> (Option<usize>, f64) {
    let mut best: Option<(usize, f64)> = None;
    for &(b, g) in gains {
        // Tuples (gain, bkp) in increasing bkp: a later equal gain is the larger tuple.
        if best.is_none_or(|(_, bg)| g >= bg) {
            best = Some((b, g));
        }
    }
    match best {
        Some((b, g)) => (Some(b), g),
        None => (None, 0.0),
    }
}

/// What binary segmentation found: breakpoints (ends, the last being n) and the gain of every
/// admissible first split of the whole series.
pub(crate) struct BinsegResult {
    pub breakpoints: Vec<usize>,
    pub first_gains: Vec<(usize, f64)>,
}

/// ruptures' `Binseg.predict(n_bkps=…)` or `predict(pen=…)`.
pub(crate) fn binseg(
    n_samples: usize,
    stop: Stop,
    min_size: usize,
    jump: usize,
    gains: &dyn SplitGains,
) -> BinsegResult {
    let mut cache: HashMap<(usize, usize), (Option<usize>, f64)> = HashMap::new();
    let first_gains = gains.gains(0, n_samples, min_size, jump);
    cache.insert((0, n_samples), best_split(&first_gains));
    let mut breakpoints = vec![n_samples];
    loop {
        let mut best: Option<(Option<usize>, f64)> = None;
        let mut start = 0;
        for &end in &breakpoints {
            let split = *cache
                .entry((start, end))
                .or_insert_with(|| best_split(&gains.gains(start, end, min_size, jump)));
            // Python's max keeps the first of equal keys.
            if best.is_none_or(|(_, g)| split.1 > g) {
                best = Some(split);
            }
            start = end;
        }
        let Some((Some(bkp), gain)) = best else { break };
        let go_on = match stop {
            Stop::Count(n_bkps) => breakpoints.len() - 1 < n_bkps,
            Stop::Penalty(pen) => gain > pen,
        };
        if !go_on {
            break;
        }
        breakpoints.push(bkp);
        breakpoints.sort_unstable();
    }
    BinsegResult { breakpoints, first_gains }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel_cpd::cost::{L2Cost, RbfCost};
    use crate::signal::{Missing, Signal};

    #[test]
    fn splits_the_largest_mean_change_first() {
        // Steps of 10 at 30 and of 1 at 60: with one breakpoint only the big one is found.
        let x: Vec<f64> = (0..90).map(|i| if i < 30 { 0.0 } else if i < 60 { 10.0 } else { 11.0 } + 0.01 * (i % 3) as f64).collect();
        let sig = Signal::new(&x, 1, "t", Missing::Refuse).unwrap();
        let cost = L2Cost::new(&sig);
        let one = binseg(90, Stop::Count(1), 2, 5, &DirectGains(&cost));
        assert_eq!(one.breakpoints, vec![30, 90]);
        let two = binseg(90, Stop::Count(2), 2, 5, &DirectGains(&cost));
        assert_eq!(two.breakpoints, vec![30, 60, 90]);
        // A penalty between the two gains keeps the big step alone.
        let gain_small = two.breakpoints.len();
        assert_eq!(gain_small, 3);
        let pen = binseg(90, Stop::Penalty(100.0), 2, 5, &DirectGains(&cost));
        assert_eq!(pen.breakpoints, vec![30, 90]);
        // The first-split gains peak at the big step.
        let top = pen
            .first_gains
            .iter()
            .copied()
            .fold((0, f64::MIN), |a, b| if b.1 > a.1 { b } else { a });
        assert_eq!(top.0, 30);
    }

    #[test]
    fn rbf_running_gains_equal_direct_costs() {
        let mut rng = fastrand::Rng::with_seed(4);
        let x: Vec<f64> = (0..70).map(|i| if i < 33 { 0.0 } else { 1.5 } + rng.f64()).collect();
        let sig = Signal::new(&x, 1, "t", Missing::Refuse).unwrap();
        let direct = RbfCost { signal: sig, gamma: 1.0 };
        for jump in [1, 4] {
            let a = RbfGains { signal: sig, gamma: 1.0 }.gains(3, 70, 2, jump);
            let b = DirectGains(&direct).gains(3, 70, 2, jump);
            assert_eq!(a.len(), b.len());
            for (p, q) in a.iter().zip(&b) {
                assert_eq!(p.0, q.0);
                assert!((p.1 - q.1).abs() < 1e-11);
            }
        }
    }

    #[test]
    fn ar_swept_gains_equal_direct_costs() {
        let mut rng = fastrand::Rng::with_seed(8);
        let x: Vec<f64> = (0..150)
            .map(|i| (i as f64 * if i < 70 { 0.3 } else { 1.1 }).sin() + 0.2 * rng.f64())
            .collect();
        let direct = crate::kernel_cpd::ar::ArCost { design: ArDesign::new(&x, 4) };
        let design = ArDesign::new(&x, 4);
        for (start, jump) in [(0, 5), (7, 1), (12, 4)] {
            let a = ArGains(&design).gains(start, 150, 10, jump);
            let b = DirectGains(&direct).gains(start, 150, 10, jump);
            assert_eq!(a.len(), b.len());
            for (p, q) in a.iter().zip(&b) {
                assert_eq!(p.0, q.0);
                assert!((p.1 - q.1).abs() <= 1e-9 * q.1.abs().max(1.0), "{p:?} vs {q:?}");
            }
        }
        let found = binseg(150, Stop::Count(1), 10, 5, &ArGains(&design));
        assert_eq!(found.breakpoints, vec![70, 150]);
    }

    #[test]
    fn equal_gains_go_to_the_larger_breakpoint_and_unsplittable_segments_stop() {
        assert_eq!(best_split(&[(5, 1.0), (10, 2.0), (15, 2.0)]), (Some(15), 2.0));
        assert_eq!(best_split(&[]), (None, 0.0));
        // Too short to split at all (min_size 5 on 8 samples): no breakpoint even when asked.
        let x = [0.0, 0.0, 0.0, 0.0, 5.0, 5.0, 5.0, 5.0];
        let sig = Signal::new(&x, 1, "t", Missing::Refuse).unwrap();
        let cost = L2Cost::new(&sig);
        assert_eq!(binseg(8, Stop::Count(1), 5, 1, &DirectGains(&cost)).breakpoints, vec![8]);
    }
}
