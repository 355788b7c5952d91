//! The change-point scores of one method on one series, each beside its chance baseline, as a
//! typed value: what a benchmark keeps per (series, method) and averages over series.
//!
//! The metrics are [`cpd_metrics`](crate::cpd_metrics)' — TCPDBench's segment covering and its
//! F1 at each of several margins — and the chance baseline is `boundary_metrics`' (as many
//! distinct frames drawn uniformly over the series, the same draws for every metric, seeded by
//! [`row_seed`](crate::chance::row_seed) of the series and method names): on the same series,
//! method, margin, seed and number of draws the numbers here are `tcpd_metrics`' own (tested).
//! Every draw's score is kept, so a mean over series has a chance baseline too: draw `i` of the
//! mean is the mean of draw `i` of every series (the series drawn independently), and its
//! p-value is the add-one rule of [`chance`](crate::chance) on those means.

use serde::{Deserialize, Serialize};

use crate::chance::{ChanceSettings, chance_of_draws, metric_draws};
use crate::cpd_metrics::{covering, tcpd_f_measure};

/// A score with its chance baseline.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ScoreWithChance {
    pub value: f64,
    /// Mean score of the chance draws (NaN draws left out).
    pub chance: f64,
    /// One-sided Monte Carlo p-value that `value` exceeds chance.
    pub p_value: f64,
    /// Each draw's score, in draw order.
    pub draws: Vec<f64>,
}

impl ScoreWithChance {
    /// A score and its draws, summarised.
    pub fn of(value: f64, draws: Vec<f64>) -> Self {
        let (chance, p_value) = chance_of_draws(&draws, value);
        ScoreWithChance { value, chance, p_value, draws }
    }

    /// The mean over series: the mean value, and draw `i` the mean of every part's draw `i`
    /// (NaN when one of them is). All parts must have as many draws; NaN without parts.
    pub fn mean<'a>(parts: impl IntoIterator<Item = &'a ScoreWithChance>) -> ScoreWithChance {
        let parts: Vec<&ScoreWithChance> = parts.into_iter().collect();
        if parts.is_empty() {
            return ScoreWithChance {
                value: f64::NAN,
                chance: f64::NAN,
                p_value: f64::NAN,
                draws: Vec::new(),
            };
        }
        let n = parts.len() as f64;
        let value = parts.iter().map(|p| p.value).sum::<f64>() / n;
        let n_draws = parts.iter().map(|p| p.draws.len()).min().unwrap_or(0);
        let draws =
            (0..n_draws).map(|i| parts.iter().map(|p| p.draws[i]).sum::<f64>() / n).collect();
        ScoreWithChance::of(value, draws)
    }
}

/// TCPDBench's F1 at one margin.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct F1AtMargin {
    pub margin_frames: usize,
    pub precision: f64,
    pub recall: f64,
    pub f1: ScoreWithChance,
}

/// One method's scores on one series.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SeriesScores {
    pub n_frames: usize,
    pub n_found: usize,
    pub n_annotators: usize,
    pub covering: ScoreWithChance,
    /// At each margin, in the order given.
    pub f1: Vec<F1AtMargin>,
}

/// Scores `found` change points (frames, sorted and distinct) on a series of `n_frames`
/// against each annotator's boundaries, at each margin (frames), with `chance.draws` random
/// draws seeded by `seed`.
pub fn score_series(
    annotators: &[Vec<usize>],
    found: &[usize],
    n_frames: usize,
    margins_frames: &[usize],
    chance: ChanceSettings,
    seed: u64,
) -> SeriesScores {
    let k = found.len();
    let draws =
        |metric: &dyn Fn(&[usize]) -> f64| metric_draws(k, 0..n_frames, chance.draws, seed, metric);
    let cover = covering(annotators, found, n_frames);
    let covering = ScoreWithChance::of(cover, draws(&|c| covering(annotators, c, n_frames)));
    let f1 = margins_frames
        .iter()
        .map(|&m| {
            let (f1, precision, recall) = tcpd_f_measure(annotators, found, m);
            F1AtMargin {
                margin_frames: m,
                precision,
                recall,
                f1: ScoreWithChance::of(f1, draws(&|c| tcpd_f_measure(annotators, c, m).0)),
            }
        })
        .collect();
    SeriesScores { n_frames, n_found: k, n_annotators: annotators.len(), covering, f1 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chance::{metric_chance, row_seed};

    #[test]
    fn scores_are_the_metrics_and_chance_is_boundary_metrics_draws() {
        // 600 frames, truths 100 and 300, found 104 and 320 (boundary_metrics' hand-made case).
        let ann = vec![vec![100, 300]];
        let settings = ChanceSettings { draws: 300, seed: 16 };
        let seed = row_seed(settings.seed, "a", "m");
        let s = score_series(&ann, &[104, 320], 600, &[5, 25], settings, seed);
        let expected =
            (100.0 * (100.0 / 104.0) + 200.0 * (196.0 / 220.0) + 300.0 * (280.0 / 300.0)) / 600.0;
        assert!((s.covering.value - expected).abs() < 1e-12);
        assert!((s.f1[0].f1.value - 2.0 / 3.0).abs() < 1e-15, "margin 5: 0↔0, 100↔104");
        assert_eq!(s.f1[1].f1.value, 1.0, "margin 25: all three");
        // The chance columns are boundary_metrics' (same seed, same draws).
        let (c, p) =
            metric_chance(2, 0..600, 300, seed, s.covering.value, |c| covering(&ann, c, 600));
        assert_eq!((s.covering.chance, s.covering.p_value), (c, p));
        let (c, p) =
            metric_chance(2, 0..600, 300, seed, 2.0 / 3.0, |c| tcpd_f_measure(&ann, c, 5).0);
        assert_eq!((s.f1[0].f1.chance, s.f1[0].f1.p_value), (c, p));
        assert_eq!(s.covering.draws.len(), 300);
    }

    #[test]
    fn the_mean_pools_draw_by_draw() {
        let a = ScoreWithChance::of(0.5, vec![0.25, 0.5, 1.0]);
        let b = ScoreWithChance::of(1.0, vec![0.25, 1.0, 0.5]);
        // Draws of the mean: 0.25, 0.75, 0.75; value 0.75: two draws ≥ it → p = 3/4.
        let m = ScoreWithChance::mean([&a, &b]);
        assert_eq!(m.value, 0.75);
        assert!((m.chance - 1.75 / 3.0).abs() < 1e-15);
        assert_eq!(m.p_value, 0.75);
        assert_eq!(a.p_value, 0.75, "0.5 and 1.0 ≥ 0.5: (1 + 2)/(1 + 3)");
        assert!(ScoreWithChance::mean([]).value.is_nan());
    }
}
