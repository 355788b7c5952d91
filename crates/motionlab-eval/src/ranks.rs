//! Comparing several methods over many series by their ranks: rank per series, mean rank per
//! method, the Friedman test and the Nemenyi critical difference (Demšar, "Statistical
//! Comparisons of Classifiers over Multiple Data Sets", JMLR 7, 2006, §3.2.2) — what the TSSB
//! and ClaSP papers draw as a critical-difference diagram.
//!
//! - **Ranks**: on each series the methods are ranked by score, rank 1 the best (the highest
//!   score when higher is better). Ties get the mean of the ranks they span ([`Ties::Average`],
//!   Demšar's rule and the one the Friedman and Nemenyi tests assume) or the lowest
//!   ([`Ties::Min`], pandas' `rank(method="min")` — what TSSB's `competitor_evaluation`
//!   notebook uses). A NaN score (a method that produced nothing to score) ranks last, tied
//!   with the other NaNs.
//! - **Friedman**: `χ² = 12N/(k(k+1)) · Σ_j (R̄_j − (k+1)/2)²` over `N` series and `k`
//!   methods with mean ranks `R̄_j`, divided by scipy's tie correction
//!   `1 − Σ(t³ − t)/(N·k·(k² − 1))` over every group of `t` tied values, as
//!   `scipy.stats.friedmanchisquare` computes it (on average ranks); p-value from the χ²
//!   distribution with `k − 1` degrees of freedom.
//! - **Nemenyi**: two methods differ when their mean ranks differ by at least
//!   `CD = q_α · √(k(k+1)/(6N))`, with `q_α` the studentised range's upper-α quantile for `k`
//!   groups and infinite degrees of freedom divided by √2 (Demšar's Table 5). It is computed
//!   here rather than tabulated: `P(range ≤ q) = k ∫ φ(z) (Φ(z) − Φ(z − q))^{k−1} dz`,
//!   integrated by Simpson's rule and inverted by bisection; it agrees with scipy's
//!   `studentized_range.ppf(1 − α, k, inf) / √2` to 1e-9 for k = 2…20 (tested), and so with the
//!   table Orange's `compute_CD` — which drew TSSB's diagram — holds to its six decimals.
//! - **Cliques**: the groups of methods, in mean-rank order, whose ranks all lie within CD of
//!   each other, each maximal (not inside another) and of at least two methods — the thick
//!   bars of the diagram (Orange's `graph_ranks` rule).
//!
//! Written by hand: a rank, a mean and one integral; no statistics crate is a dependency of
//! this crate, and the incomplete gamma function of the χ² tail is twenty lines
//! ([`chi2_sf`], a series and a continued fraction).

use serde::{Deserialize, Serialize};

/// How tied scores are ranked.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "lowercase")]
pub enum Ties {
    /// The mean of the ranks the tie spans (Demšar 2006; what Friedman and Nemenyi assume).
    #[default]
    Average,
    /// The lowest rank the tie spans (pandas' `method="min"`, TSSB's notebook).
    Min,
}

/// The ranks of `scores` (1 = best); `higher_is_better` says which end is best. NaN ranks last.
pub fn rank_scores(scores: &[f64], higher_is_better: bool, ties: Ties) -> Vec<f64> {
    let key = |v: f64| {
        if v.is_nan() {
            f64::INFINITY
        } else if higher_is_better {
            -v
        } else {
            v
        }
    };
    let mut order: Vec<usize> = (0..scores.len()).collect();
    order.sort_by(|&a, &b| key(scores[a]).total_cmp(&key(scores[b])));
    let mut ranks = vec![0.0; scores.len()];
    let mut i = 0;
    while i < order.len() {
        let mut j = i + 1;
        while j < order.len() && key(scores[order[j]]) == key(scores[order[i]]) {
            j += 1;
        }
        // Positions i..j (0-based) share ranks i+1 ..= j.
        let rank = match ties {
            Ties::Average => (i + 1 + j) as f64 / 2.0,
            Ties::Min => (i + 1) as f64,
        };
        for &o in &order[i..j] {
            ranks[o] = rank;
        }
        i = j;
    }
    ranks
}

/// Mean ranks over series and the tests on them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RankComparison {
    /// Per method (in input order): its mean rank over the series.
    pub mean_ranks: Vec<f64>,
    /// Per method: on how many series it ranked first (ties included).
    pub wins: Vec<usize>,
    /// Series compared (those where every method has a score row).
    pub n_series: usize,
    /// Friedman's χ² (tie-corrected, on average ranks) and its p-value (k − 1 degrees of freedom).
    pub friedman_chi2: f64,
    pub friedman_p_value: f64,
    /// Significance level of the critical difference.
    pub alpha: f64,
    /// Nemenyi's `q_α` (the studentised range quantile / √2) for this many methods.
    pub q_alpha: f64,
    /// The critical difference of mean ranks.
    pub critical_difference: f64,
    /// Groups of methods (indices, best mean rank first) not significantly different.
    pub cliques: Vec<Vec<usize>>,
}

/// Ranks `scores[series][method]` per series and compares the methods. At least two methods
/// and one series are needed (else NaN statistics, no cliques).
pub fn compare_methods(
    scores: &[Vec<f64>],
    higher_is_better: bool,
    ties: Ties,
    alpha: f64,
) -> RankComparison {
    let k = scores.first().map_or(0, Vec::len);
    let n = scores.len();
    let mut sums = vec![0.0; k];
    let mut wins = vec![0; k];
    let mut avg_sums = vec![0.0; k];
    let mut tie_term = 0.0;
    for row in scores {
        let r = rank_scores(row, higher_is_better, ties);
        let avg = if ties == Ties::Average {
            r.clone()
        } else {
            rank_scores(row, higher_is_better, Ties::Average)
        };
        for j in 0..k {
            sums[j] += r[j];
            avg_sums[j] += avg[j];
            wins[j] += usize::from(avg[j] == best_average(&avg));
        }
        // Tie groups of this series, for the Friedman correction.
        let mut sorted = avg.clone();
        sorted.sort_by(f64::total_cmp);
        let mut i = 0;
        while i < sorted.len() {
            let j = sorted[i..].iter().take_while(|&&v| v == sorted[i]).count();
            tie_term += (j * j * j - j) as f64;
            i += j;
        }
    }
    let nf = n as f64;
    let kf = k as f64;
    let mean_ranks: Vec<f64> = sums.iter().map(|s| s / nf).collect();
    let (friedman_chi2, friedman_p_value) = if k >= 2 && n >= 1 {
        let centre = (kf + 1.0) / 2.0;
        let ss: f64 = avg_sums.iter().map(|s| (s / nf - centre).powi(2)).sum();
        let chi2 = 12.0 * nf / (kf * (kf + 1.0)) * ss;
        let correction = 1.0 - tie_term / (nf * kf * (kf * kf - 1.0));
        let chi2 = if correction > 0.0 { chi2 / correction } else { f64::NAN };
        (chi2, chi2_sf(chi2, kf - 1.0))
    } else {
        (f64::NAN, f64::NAN)
    };
    let q_alpha = if k >= 2 { nemenyi_q(k, alpha) } else { f64::NAN };
    let critical_difference = q_alpha * (kf * (kf + 1.0) / (6.0 * nf)).sqrt();
    let cliques = cliques(&mean_ranks, critical_difference);
    RankComparison {
        mean_ranks,
        wins,
        n_series: n,
        friedman_chi2,
        friedman_p_value,
        alpha,
        q_alpha,
        critical_difference,
        cliques,
    }
}

/// The best (lowest) average rank of a series.
fn best_average(ranks: &[f64]) -> f64 {
    ranks.iter().copied().fold(f64::INFINITY, f64::min)
}

/// Maximal groups (≥ 2 methods, best mean rank first) whose mean ranks lie within `cd` of each
/// other; a group inside an earlier one is dropped.
pub fn cliques(mean_ranks: &[f64], cd: f64) -> Vec<Vec<usize>> {
    if !cd.is_finite() {
        return Vec::new();
    }
    let mut order: Vec<usize> = (0..mean_ranks.len()).collect();
    order.sort_by(|&a, &b| mean_ranks[a].total_cmp(&mean_ranks[b]).then(a.cmp(&b)));
    let mut out: Vec<(usize, usize)> = Vec::new();
    for i in 0..order.len() {
        let mut j = i;
        while j + 1 < order.len() && mean_ranks[order[j + 1]] - mean_ranks[order[i]] < cd {
            j += 1;
        }
        if j > i && out.last().is_none_or(|&(_, end)| j > end) {
            out.push((i, j));
        }
    }
    out.into_iter().map(|(i, j)| order[i..=j].to_vec()).collect()
}

/// Standard normal CDF.
fn phi_cdf(x: f64) -> f64 {
    0.5 * libm::erfc(-x / std::f64::consts::SQRT_2)
}

/// `P(range of k standard normals ≤ q)` (the studentised range with infinite degrees of freedom).
pub fn studentized_range_cdf(q: f64, k: usize) -> f64 {
    if q <= 0.0 {
        return 0.0;
    }
    // The integrand is smooth and negligible outside [-9, 9 + q]; Simpson's rule with
    // 4096 intervals is far below 1e-12 there.
    let (a, b) = (-9.0, 9.0 + q);
    let m = 4096;
    let h = (b - a) / m as f64;
    let f = |z: f64| {
        let density = (-0.5 * z * z).exp() / (2.0 * std::f64::consts::PI).sqrt();
        density * (phi_cdf(z) - phi_cdf(z - q)).max(0.0).powi(k as i32 - 1)
    };
    let mut s = f(a) + f(b);
    for i in 1..m {
        s += f(a + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    (k as f64 * s * h / 3.0).min(1.0)
}

/// Nemenyi's critical value: the studentised range's `1 − alpha` quantile for `k` groups and
/// infinite degrees of freedom, divided by √2 (Demšar 2006, Table 5).
pub fn nemenyi_q(k: usize, alpha: f64) -> f64 {
    if k < 2 || !(alpha > 0.0 && alpha < 1.0) {
        return f64::NAN;
    }
    let (mut lo, mut hi) = (0.0, 20.0);
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        if studentized_range_cdf(mid, k) < 1.0 - alpha {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi) / std::f64::consts::SQRT_2
}

/// The χ² survival function `P(X > x)` with `df` degrees of freedom: the regularised upper
/// incomplete gamma `Q(df/2, x/2)` (series below `a + 1`, Lentz's continued fraction above).
pub fn chi2_sf(x: f64, df: f64) -> f64 {
    if x.is_nan() || df <= 0.0 {
        return f64::NAN;
    }
    if x <= 0.0 {
        return 1.0;
    }
    let (a, x) = (df / 2.0, x / 2.0);
    let log_prefactor = a * x.ln() - x - libm::lgamma(a);
    if x < a + 1.0 {
        let (mut term, mut sum, mut ap) = (1.0 / a, 1.0 / a, a);
        for _ in 0..1000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-16 {
                break;
            }
        }
        (1.0 - sum * log_prefactor.exp()).max(0.0)
    } else {
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..1000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let delta = d * c;
            h *= delta;
            if (delta - 1.0).abs() < 1e-16 {
                break;
            }
        }
        log_prefactor.exp() * h
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranks_by_hand_with_ties_and_nan() {
        // Scores 0.9, 0.5, 0.9, NaN, 0.1 (higher is better): 0.9 and 0.9 share ranks 1–2.
        let s = [0.9, 0.5, 0.9, f64::NAN, 0.1];
        assert_eq!(rank_scores(&s, true, Ties::Average), [1.5, 3.0, 1.5, 5.0, 4.0]);
        assert_eq!(rank_scores(&s, true, Ties::Min), [1.0, 3.0, 1.0, 5.0, 4.0]);
        // Lower is better: runtimes.
        assert_eq!(rank_scores(&[3.0, 1.0, 2.0], false, Ties::Average), [3.0, 1.0, 2.0]);
        // All tied: every rank the mean of 1..=4.
        assert_eq!(rank_scores(&[0.5; 4], true, Ties::Average), [2.5; 4]);
    }

    #[test]
    fn nemenyi_q_equals_scipys_studentized_range() {
        // scipy 1.17.1: studentized_range.ppf(1 - alpha, k, inf) / sqrt(2).
        let at_05 = [
            1.9599639845400534,
            2.343700586378409,
            2.569031772546482,
            2.7277743708703763,
            2.8497054196100016,
            2.9483200175296744,
            3.030878449614413,
            3.1017303413033805,
            3.163683577053373,
            3.2186536073291525,
            3.268003924466142,
            3.31273859335082,
            3.3536177518523043,
            3.391230283765257,
            3.4260413793706097,
            3.4584247073473247,
            3.4886847993791976,
            3.517073008691811,
            3.5437991315177815,
        ];
        for (i, q) in at_05.iter().enumerate() {
            let k = i + 2;
            assert!(
                (nemenyi_q(k, 0.05) - q).abs() < 1e-9,
                "k = {k}: {} vs {q}",
                nemenyi_q(k, 0.05)
            );
        }
        assert!((nemenyi_q(7, 0.10) - 2.6927321009677594).abs() < 1e-9);
        // k = 2 is the two-sided normal quantile.
        assert!((nemenyi_q(2, 0.05) - 1.959963984540054).abs() < 1e-9);
        assert!(nemenyi_q(1, 0.05).is_nan());
    }

    #[test]
    fn chi2_tail_known_values() {
        // scipy.stats.chi2.sf: (3.84, 1) → 0.05004352124870519; (10, 6) → 0.12465201948308108;
        // (100, 6) → 2.509303552201055e-19.
        assert!((chi2_sf(3.84, 1.0) - 0.05004352124870519).abs() < 1e-12);
        assert!((chi2_sf(10.0, 6.0) - 0.12465201948308108).abs() < 1e-12);
        assert!((chi2_sf(100.0, 6.0) / 2.509303552201055e-19 - 1.0).abs() < 1e-9);
        assert_eq!(chi2_sf(0.0, 3.0), 1.0);
    }

    #[test]
    fn a_hand_made_comparison() {
        // Three methods on four series (higher is better). Average ranks per series:
        // [1, 2, 3], [1, 2, 3], [1.5, 1.5, 3], [2, 1, 3] → mean ranks 1.375, 1.625, 3.
        let scores = vec![
            vec![0.9, 0.8, 0.1],
            vec![0.7, 0.6, 0.5],
            vec![0.4, 0.4, 0.2],
            vec![0.5, 0.6, 0.3],
        ];
        let c = compare_methods(&scores, true, Ties::Average, 0.05);
        assert_eq!(c.mean_ranks, [1.375, 1.625, 3.0]);
        assert_eq!(c.wins, [3, 2, 0], "the tie on series 3 is a win for both");
        // CD = 2.3437 · √(3·4/(6·4)) = 2.3437 · √0.5.
        assert!((c.critical_difference - 2.343700586378409 * 0.5f64.sqrt()).abs() < 1e-9);
        // 1.375 and 1.625 within CD (1.657); 3.0 − 1.625 = 1.375 < CD too: one clique of all.
        assert_eq!(c.cliques, vec![vec![0, 1, 2]]);
        // scipy.stats.friedmanchisquare([.9,.7,.4,.5], [.8,.6,.4,.6], [.1,.5,.2,.3]):
        // statistic 6.533333333333333, p 0.03813332654704519.
        assert!((c.friedman_chi2 - 6.533333333333333).abs() < 1e-12, "{}", c.friedman_chi2);
        assert!((c.friedman_p_value - 0.03813332654704519).abs() < 1e-12);
        // Ties = min (pandas): series 3 gives [1, 1, 3] → mean ranks 1.25, 1.5 (Friedman unchanged).
        let m = compare_methods(&scores, true, Ties::Min, 0.05);
        assert_eq!(m.mean_ranks, [1.25, 1.5, 3.0]);
        assert_eq!(m.friedman_chi2, c.friedman_chi2);
    }

    #[test]
    fn tssbs_published_sheet_gives_the_notebooks_ranks() {
        let sheet = motionlab_io::scores_csv::read_scores_csv(&motionlab_testkit::data_path(
            "tssb/published_covering_unknown.csv",
        ))
        .unwrap();
        let scores: Vec<Vec<f64>> = sheet.series.iter().map(|(_, v)| v.clone()).collect();
        // competitor_evaluation.ipynb: pandas rank(method="min"), printed to 5 decimals.
        let notebook = [4.6, 4.26667, 4.25333, 2.90667, 2.81333, 3.12, 1.46667];
        let min = compare_methods(&scores, true, Ties::Min, 0.05);
        for (r, want) in min.mean_ranks.iter().zip(notebook) {
            assert!((r - want).abs() < 5e-6, "{r} vs {want}");
        }
        // The notebook's wins: ClaSP 54 (ties for first included).
        assert_eq!(min.wins[6], 54);
        // Average ranks and Friedman's test as scipy computes them (rankdata, friedmanchisquare):
        // 4.62, 4.62, 5.32667, 3.89333, 3.82667, 3.86667, 1.84667; χ² 135.31631520532733.
        let avg = compare_methods(&scores, true, Ties::Average, 0.05);
        let scipy = [
            4.62,
            4.62,
            5.326666666666667,
            3.8933333333333335,
            3.8266666666666667,
            3.8666666666666667,
            1.8466666666666667,
        ];
        for (r, want) in avg.mean_ranks.iter().zip(scipy) {
            assert!((r - want).abs() < 1e-12, "{r} vs {want}");
        }
        assert!((avg.friedman_chi2 - 135.31631520532733).abs() < 1e-9, "{}", avg.friedman_chi2);
        assert!(
            (avg.friedman_p_value / 9.747245671207445e-27 - 1.0).abs() < 1e-6,
            "{}",
            avg.friedman_p_value
        );
        // Orange's compute_CD(ranks, 75): q = 2.948320 for k = 7 → CD = 2.94832·√(7·8/(6·75)).
        assert!(
            (avg.critical_difference - 2.9483200175296744 * (56.0f64 / 450.0).sqrt()).abs() < 1e-9
        );
    }

    #[test]
    fn cliques_are_maximal_runs_within_cd() {
        // Orange's graph_ranks example shape: ranks 1, 1.5, 2.6, 3.0, 4.1 with CD 1.2 →
        // {1, 1.5}, {1.5, 2.6}, {2.6, 3.0}, {3.0, 4.1}; with CD 2: {1 … 2.6}, {1.5 … 3.0}, {2.6 … 4.1}.
        let r = [3.0, 1.0, 4.1, 1.5, 2.6];
        assert_eq!(cliques(&r, 1.2), vec![vec![1, 3], vec![3, 4], vec![4, 0], vec![0, 2]]);
        assert_eq!(cliques(&r, 2.0), vec![vec![1, 3, 4], vec![3, 4, 0], vec![4, 0, 2]]);
        assert_eq!(cliques(&r, 0.1), Vec::<Vec<usize>>::new());
        assert_eq!(cliques(&r, 10.0), vec![vec![1, 3, 4, 0, 2]]);
    }
}
