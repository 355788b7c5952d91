//! Trivial baselines for boundary detection: what the same number of candidates placed **at
//! random**, or **periodically**, scores under the same match rule — so that a precision/recall
//! table says whether a method does better than guessing.
//!
//! # The chance model (documented choices)
//!
//! - A method that found `k` frames on a sequence is compared with `k` **distinct integer
//!   frames drawn uniformly without replacement** from the evaluated span `[start, end)` of
//!   `n = end − start` frames (a detector reports each frame at most once, so "without
//!   replacement" is the matching null model). When `k > n`, all `n` frames are taken.
//! - The random candidates are matched to the truth's windows by the **time rule** (tolerance,
//!   and the annotated windows when `use_windows` is on) with the same maximum one-to-one
//!   matching as the method ([`max_matching_windows`]). The pose rule is **not** applied to
//!   chance (it would need the pose at every random frame of every draw); when the evaluator's
//!   pose rule is on, the p-value compares chance with the method's *time-rule* matches, so a
//!   match the pose rule adds cannot make a method look better than chance.
//! - Since `k` and the number of truths `r` are fixed, precision `M/k`, recall `M/r` and
//!   `F1 = 2M/(k + r)` are linear in the matched count `M`: their expectations are
//!   `E[M]/k`, `E[M]/r` and `2·E[M]/(k + r)`.
//!
//! # Exact where tractable, else Monte Carlo
//!
//! When the truth windows cover **pairwise disjoint** sets of integer frames (truths more than
//! `2·tol` apart, the usual case), a random frame lies in at most one window, so the maximum
//! matching pairs exactly the windows that contain at least one candidate:
//! `M = #{windows hit}`, and with `w_j` the frames of window `j` inside the span,
//!
//! ```text
//! E[M] = Σ_j (1 − C(n − w_j, k) / C(n, k)),   C(n − w, k)/C(n, k) = Π_{i<k} (n − w − i)/(n − i)
//! ```
//!
//! (one candidate, one truth with tolerance `t` away from the span's edges:
//! `P(match) = (2t + 1)/n`). Overlapping windows make the matching interact; there `E[M]` is
//! the Monte Carlo mean and its standard error `sd(M)/√N` is reported.
//!
//! The **p-value** is always Monte Carlo: `N` draws with a fixed seed (parameters of
//! `boundary_pr`: `chance_draws` and `chance_seed`), one-sided,
//! `p = (1 + #{draws with M ≥ M_method}) / (1 + N)` (the add-one rule makes it a valid p-value
//! for a finite number of draws, never 0). The seed of each (sequence, method) is the base seed
//! mixed with a hash of both names, so results do not depend on the order of the experiment and
//! sequences draw independently; pooled over sequences, draw `i` of the pooled count is the sum
//! of draw `i` of every sequence (independent sequences ⇒ a draw of the pooled null), and the
//! pooled expectation is the sum of the per-sequence ones.
//!
//! RNG: `fastrand` (wyrand; a small, well-kept crate of smol-rs with no dependencies), seeded;
//! its stream is fixed by the version in Cargo.lock.
//!
//! # The periodic baseline
//!
//! `r` candidates (the truth count — the truth's mean rate over the span) equally spaced,
//! centred in the span: frame `start + ⌊(i + ½)·n / r⌋` for `i = 0…r−1` (phase: half a spacing
//! from each edge, so the grid is symmetric and depends on nothing but `n` and `r`), scored
//! with the same time rule.

use crate::boundaries::{TruthWindow, max_matching_windows};

// Whether a score beat chance and how chance was computed are results, not row names
// (`motionlab compare` compares them as text).
motionlab_core::declare_outcome_column!("chance_expectation");
motionlab_core::declare_outcome_column!("above_chance");

/// Monte Carlo settings of the chance baseline.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChanceSettings {
    /// Number of random draws `N`.
    pub draws: usize,
    /// Base seed (mixed with the sequence and method names).
    pub seed: u64,
}

impl ChanceSettings {
    /// The settings of an evaluator's `chance_draws` and `chance_seed` parameters: at least 100
    /// draws (an error naming `chance_draws` otherwise).
    pub fn checked(draws: usize, seed: u64) -> motionlab_core::Result<Self> {
        if draws < 100 {
            return Err(motionlab_core::Error::new(
                motionlab_core::ErrorKind::OutOfRange,
                format!(
                    "must be at least 100 draws (p-values below 0.01 need them), found {draws}"
                ),
            )
            .with_field("chance_draws"));
        }
        Ok(ChanceSettings { draws, seed })
    }
}

/// The serde default of an evaluator's `chance_draws`.
pub fn default_draws() -> usize {
    ChanceSettings::default().draws
}

/// The serde default of an evaluator's `chance_seed`.
pub fn default_seed() -> u64 {
    ChanceSettings::default().seed
}

impl Default for ChanceSettings {
    fn default() -> Self {
        ChanceSettings { draws: 2000, seed: 16 }
    }
}

/// The chance baseline of one method on one sequence (or pooled).
#[derive(Clone, Debug, PartialEq)]
pub struct ChanceCounts {
    /// Number of random candidates per draw (`min(k, n)`).
    pub n_found: usize,
    /// `E[M]`, exact or the Monte Carlo mean.
    pub expected_matched: f64,
    /// Standard error of `expected_matched` (0 when exact).
    pub expected_matched_se: f64,
    /// True when `expected_matched` is the exact formula (disjoint windows).
    pub exact: bool,
    /// The matched count of every draw, in draw order (for p-values and pooling).
    pub draws: Vec<u32>,
}

impl ChanceCounts {
    /// Pools per-sequence baselines of one method: sums of expectations, counts and draws
    /// (draw `i` of each); the standard error adds in quadrature. All must have the same draws.
    pub fn pooled<'a>(parts: impl IntoIterator<Item = &'a ChanceCounts>) -> ChanceCounts {
        let mut out = ChanceCounts {
            n_found: 0,
            expected_matched: 0.0,
            expected_matched_se: 0.0,
            exact: true,
            draws: Vec::new(),
        };
        let mut var = 0.0;
        for p in parts {
            out.n_found += p.n_found;
            out.expected_matched += p.expected_matched;
            var += p.expected_matched_se * p.expected_matched_se;
            out.exact &= p.exact;
            if out.draws.is_empty() {
                out.draws = p.draws.clone();
            } else {
                out.draws.iter_mut().zip(&p.draws).for_each(|(a, b)| *a += b);
            }
        }
        out.expected_matched_se = var.sqrt();
        out
    }

    /// One-sided Monte Carlo p-value that `observed` matches exceed chance:
    /// `(1 + #{draws ≥ observed}) / (1 + N)`; NaN without draws.
    pub fn p_value(&self, observed: usize) -> f64 {
        if self.draws.is_empty() {
            return f64::NAN;
        }
        let at_least = self.draws.iter().filter(|&&m| m as usize >= observed).count();
        (1 + at_least) as f64 / (1 + self.draws.len()) as f64
    }
}

/// Significance level of `above_chance`.
pub const ALPHA: f64 = 0.05;

/// A row's chance columns: the expected precision, recall and F1 of the baseline's `n_found`
/// random frames against `n_truth` truths, and the p-value of `observed` (time-rule) matches.
/// Serialised under the column names of the tables that flatten it (`table1_precision_recall`,
/// `boundary_f1_by_tolerance`, `heldout_f1`, `heldout_choices`), in this order.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ChanceScores {
    /// `exact` or `monte_carlo`: how the chance expectations were computed; empty when there is
    /// no baseline.
    #[serde(rename = "chance_expectation")]
    pub expectation: &'static str,
    /// Expected matched count of the baseline's uniformly random distinct frames (time rule).
    #[serde(rename = "chance_matched")]
    pub matched: f64,
    #[serde(rename = "chance_precision")]
    pub precision: f64,
    #[serde(rename = "chance_recall")]
    pub recall: f64,
    #[serde(rename = "chance_f1")]
    pub f1: f64,
    /// Standard error of `chance_f1` (0 when exact).
    #[serde(rename = "chance_f1_se")]
    pub f1_se: f64,
    /// One-sided Monte Carlo p-value that the observed matches exceed chance.
    pub p_value: f64,
    /// `yes` when `p_value < ALPHA`, else `no`; empty when there is no baseline.
    #[serde(rename = "above_chance")]
    pub above: &'static str,
}

impl ChanceScores {
    /// No baseline: NaN numbers, empty labels.
    pub fn none() -> Self {
        let nan = f64::NAN;
        ChanceScores {
            expectation: "",
            matched: nan,
            precision: nan,
            recall: nan,
            f1: nan,
            f1_se: nan,
            p_value: nan,
            above: "",
        }
    }

    /// The columns of `chance` against `n_truth` truths, with `observed` matches for the p-value.
    pub fn of(chance: &ChanceCounts, n_truth: usize, observed: usize) -> Self {
        let m = chance.expected_matched;
        let div = |num: f64, den: usize| if den == 0 { f64::NAN } else { num / den as f64 };
        let p_value = chance.p_value(observed);
        ChanceScores {
            expectation: if chance.exact { "exact" } else { "monte_carlo" },
            matched: m,
            precision: div(m, chance.n_found),
            recall: div(m, n_truth),
            f1: div(2.0 * m, chance.n_found + n_truth),
            f1_se: div(2.0 * chance.expected_matched_se, chance.n_found + n_truth),
            p_value,
            above: if p_value < ALPHA { "yes" } else { "no" },
        }
    }
}

/// The seed of one (sequence, method): the base seed mixed with an FNV-1a hash of both names
/// (so the draws do not depend on the order of sequences or methods).
pub fn row_seed(base: u64, sequence: &str, method: &str) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in sequence.bytes().chain([0xff]).chain(method.bytes()) {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    // splitmix64 finaliser: nearby seeds give unrelated streams.
    let mut z = base ^ h;
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Exact `E[M]` for `k` uniform distinct frames of `span` when the windows' integer frames in
/// the span are pairwise disjoint; None when two windows share a frame (see the module docs).
pub fn exact_expected_matches(
    k: usize,
    windows: &[TruthWindow],
    span: std::ops::Range<usize>,
) -> Option<f64> {
    let n = span.len();
    let k = k.min(n);
    // Integer frames [lo, hi] of each window inside the span (empty when lo > hi).
    let mut frames: Vec<(usize, usize)> =
        windows.iter().filter_map(|w| integer_frames(w, &span)).collect();
    frames.sort_unstable();
    if frames.windows(2).any(|p| p[1].0 <= p[0].1) {
        return None;
    }
    let mut expected = 0.0;
    for (lo, hi) in frames {
        let w = hi - lo + 1;
        // P(no candidate in the window) = Π_{i<k} (n − w − i)/(n − i); 0 when n − w < k.
        let mut miss = 1.0;
        for i in 0..k {
            if n - i <= w {
                miss = 0.0;
                break;
            }
            miss *= (n - w - i) as f64 / (n - i) as f64;
        }
        expected += 1.0 - miss;
    }
    Some(expected)
}

/// The integer frames `[lo, hi]` of a window that lie in the span, or None.
fn integer_frames(w: &TruthWindow, span: &std::ops::Range<usize>) -> Option<(usize, usize)> {
    if span.is_empty() || w.lo.is_nan() || w.hi.is_nan() || w.lo > w.hi {
        return None;
    }
    let lo = w.lo.ceil().max(span.start as f64);
    let hi = w.hi.floor().min((span.end - 1) as f64);
    // Both are whole numbers inside the span here, so the casts are exact.
    (lo <= hi).then_some((lo as usize, hi as usize))
}

/// The chance baseline of `k` candidates against `windows` over `span` (module docs):
/// `settings.draws` draws seeded with `seed`; the expectation is exact when the windows are
/// disjoint, else the Monte Carlo mean with its standard error.
pub fn chance_counts(
    k: usize,
    windows: &[TruthWindow],
    span: std::ops::Range<usize>,
    draws: usize,
    seed: u64,
) -> ChanceCounts {
    let k = k.min(span.len());
    let mut draw = Draws::new(k, span.clone(), seed);
    let mut counts = Vec::with_capacity(draws);
    for _ in 0..draws {
        // At most k ≤ n pairs, so the count fits u32 for any span a motion can have.
        counts.push(
            u32::try_from(max_matching_windows(draw.next_draw(), windows).len())
                .unwrap_or(u32::MAX),
        );
    }
    let (mean, se) = mean_and_se(&counts);
    match exact_expected_matches(k, windows, span) {
        Some(e) => ChanceCounts {
            n_found: k,
            expected_matched: e,
            expected_matched_se: 0.0,
            exact: true,
            draws: counts,
        },
        None => ChanceCounts {
            n_found: k,
            expected_matched: mean,
            expected_matched_se: se,
            exact: false,
            draws: counts,
        },
    }
}

/// The chance model's random candidate sets: `k` distinct frames of `span`, uniformly, one
/// set per call, from a seeded stream.
pub struct Draws {
    k: usize,
    span: std::ops::Range<usize>,
    rng: fastrand::Rng,
    taken: Vec<bool>,
    picks: Vec<usize>,
}

impl Draws {
    /// `k` is capped at the span's length.
    pub fn new(k: usize, span: std::ops::Range<usize>, seed: u64) -> Self {
        let k = k.min(span.len());
        Draws {
            k,
            rng: fastrand::Rng::with_seed(seed),
            taken: vec![false; span.len()],
            picks: Vec::with_capacity(k),
            span,
        }
    }

    /// The next set, in draw order (not sorted).
    pub fn next_draw(&mut self) -> &[usize] {
        let n = self.span.len();
        // Floyd's algorithm: k distinct offsets of 0..n, uniformly, in O(k).
        self.picks.clear();
        for j in n - self.k..n {
            let t = self.rng.usize(0..=j);
            let pick = if self.taken[t] { j } else { t };
            self.taken[pick] = true;
            self.picks.push(self.span.start + pick);
        }
        for &p in &self.picks {
            self.taken[p - self.span.start] = false;
        }
        &self.picks
    }
}

/// A score's chance baseline by Monte Carlo: `metric` of `draws` random sets of `k` distinct
/// frames of `span` (sorted), its mean and the one-sided p-value of `observed` (the add-one
/// rule of the module docs: `(1 + #{draws scoring ≥ observed}) / (1 + N)`). NaN draws (a
/// metric undefined on a set) are left out of both.
pub fn metric_chance(
    k: usize,
    span: std::ops::Range<usize>,
    draws: usize,
    seed: u64,
    observed: f64,
    metric: impl FnMut(&[usize]) -> f64,
) -> (f64, f64) {
    chance_of_draws(&metric_draws(k, span, draws, seed, metric), observed)
}

/// `metric` of each of `draws` random sets of `k` distinct frames of `span` (sorted), in draw
/// order — the draws [`metric_chance`] summarises, kept for pooling: draw `i` of a mean over
/// sequences is the mean of draw `i` of each.
pub fn metric_draws(
    k: usize,
    span: std::ops::Range<usize>,
    draws: usize,
    seed: u64,
    mut metric: impl FnMut(&[usize]) -> f64,
) -> Vec<f64> {
    let mut d = Draws::new(k, span, seed);
    let mut sorted = Vec::with_capacity(k);
    (0..draws)
        .map(|_| {
            sorted.clear();
            sorted.extend_from_slice(d.next_draw());
            sorted.sort_unstable();
            metric(&sorted)
        })
        .collect()
}

/// The mean of the defined draws and the one-sided p-value of `observed` against them
/// (`(1 + #{draws ≥ observed}) / (1 + N)`, N the defined draws); NaN p-value when `observed`
/// is NaN, NaN mean when no draw is defined.
pub fn chance_of_draws(draws: &[f64], observed: f64) -> (f64, f64) {
    let (mut sum, mut n, mut at_least) = (0.0, 0usize, 0usize);
    for &v in draws.iter().filter(|v| !v.is_nan()) {
        sum += v;
        n += 1;
        at_least += usize::from(v >= observed);
    }
    if n == 0 || observed.is_nan() {
        return (if n == 0 { f64::NAN } else { sum / n as f64 }, f64::NAN);
    }
    (sum / n as f64, (1 + at_least) as f64 / (1 + n) as f64)
}

/// Mean and its standard error `sd/√N` (sample sd, N − 1); NaN mean without draws.
fn mean_and_se(xs: &[u32]) -> (f64, f64) {
    let n = xs.len() as f64;
    if xs.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    let mean = xs.iter().map(|&x| f64::from(x)).sum::<f64>() / n;
    if xs.len() < 2 {
        return (mean, f64::NAN);
    }
    let var = xs.iter().map(|&x| (f64::from(x) - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

/// The periodic baseline's candidates: `r` frames equally spaced and centred in `span`.
pub fn periodic_candidates(r: usize, span: std::ops::Range<usize>) -> Vec<usize> {
    let n = span.len();
    if n == 0 {
        return Vec::new();
    }
    (0..r.min(n)).map(|i| span.start + ((2 * i + 1) * n) / (2 * r.min(n))).collect()
}

#[cfg(test)]
mod tests {

    #[test]
    fn metric_chance_has_known_answers() {
        // The size of a set is always k: mean k; an observed k is matched by every draw (p = 1),
        // k + 1 by none (p = 1/(N + 1)).
        assert_eq!(metric_chance(7, 0..50, 99, 1, 7.0, |c| c.len() as f64), (7.0, 1.0));
        assert_eq!(metric_chance(7, 0..50, 99, 1, 8.0, |c| c.len() as f64), (7.0, 0.01));
        // Sets are sorted, distinct and inside the span; k is capped at the span's length.
        let (ok, _) = metric_chance(5, 10..15, 20, 2, 0.0, |c| {
            f64::from(u8::from(c == [10, 11, 12, 13, 14]))
        });
        assert_eq!(ok, 1.0);
        let (_, p) = metric_chance(3, 0..100, 50, 3, 1.0, |c| {
            f64::from(u8::from(c.windows(2).all(|w| w[0] < w[1]) && c[2] < 100))
        });
        assert_eq!(p, 1.0);
        // NaN draws and a NaN observation are left out.
        assert!(metric_chance(3, 0..10, 10, 4, 0.5, |_| f64::NAN).0.is_nan());
        assert!(metric_chance(3, 0..10, 10, 4, f64::NAN, |_| 0.0).1.is_nan());
    }
    use super::*;

    fn around(frames: &[usize], tol: f64) -> Vec<TruthWindow> {
        frames.iter().map(|&f| TruthWindow::around(f, tol)).collect()
    }

    #[test]
    fn one_candidate_one_truth_matches_with_probability_window_over_span() {
        // Truth 50, tol 3 frames, span 0..100: P(match) = 7/100.
        let w = around(&[50], 3.0);
        assert!((exact_expected_matches(1, &w, 0..100).unwrap() - 0.07).abs() < 1e-15);
        // At the edge the window is cut by the span: truth 1 → frames 0..=4, P = 5/100.
        assert!(
            (exact_expected_matches(1, &around(&[1], 3.0), 0..100).unwrap() - 0.05).abs() < 1e-15
        );
        // Two candidates: P(hit) = 1 − (93·92)/(100·99).
        let e = exact_expected_matches(2, &w, 0..100).unwrap();
        assert!((e - (1.0 - 93.0 * 92.0 / 9900.0)).abs() < 1e-15);
        // As many candidates as frames: every window is hit.
        assert_eq!(exact_expected_matches(100, &around(&[10, 50], 3.0), 0..100), Some(2.0));
        // Overlapping windows: no closed form here.
        assert_eq!(exact_expected_matches(2, &around(&[50, 55], 3.0), 0..100), None);
    }

    #[test]
    fn monte_carlo_agrees_with_the_exact_expectation_within_three_standard_errors() {
        for (k, truths, tol, span) in [
            (1usize, vec![50usize], 3.0, 0..100usize),
            (5, vec![20, 60, 90], 4.0, 0..100),
            (40, vec![100, 300, 500, 700], 12.0, 50..800),
            (3, vec![5, 200], 10.0, 0..210),
        ] {
            let w = around(&truths, tol);
            let c = chance_counts(k, &w, span.clone(), 20_000, 7);
            assert!(c.exact);
            let (mean, se) = mean_and_se(&c.draws);
            assert!(se > 0.0);
            assert!(
                (mean - c.expected_matched).abs() < 3.0 * se,
                "k {k}: mc {mean} ± {se}, exact {}",
                c.expected_matched
            );
        }
    }

    #[test]
    fn overlapping_windows_fall_back_to_monte_carlo_bounded_by_the_disjoint_case() {
        // Two truths 4 frames apart, tol 3: windows [47, 53] and [51, 57] share 51..=53.
        let w = around(&[50, 54], 3.0);
        let c = chance_counts(3, &w, 0..100, 5000, 1);
        assert!(!c.exact && c.expected_matched_se > 0.0);
        // The matched count can never exceed either side's size.
        assert!(c.draws.iter().all(|&m| m <= 2));
        // Fewer matches than with the same windows pulled apart (no shared frames to compete for).
        let apart = exact_expected_matches(3, &around(&[20, 70], 3.0), 0..100).unwrap();
        assert!(c.expected_matched < apart, "{} vs {apart}", c.expected_matched);
    }

    #[test]
    fn draws_are_distinct_uniform_frames_of_the_span() {
        // One truth covering only frame 10 (tol 0): P(hit) per draw with k = 1 is 1/20 over
        // span 5..25; a frame outside the span is never drawn (truth 3 is never hit).
        let c = chance_counts(1, &around(&[3], 0.0), 5..25, 2000, 3);
        assert!(c.draws.iter().all(|&m| m == 0));
        assert_eq!(c.expected_matched, 0.0);
        // k = n: every frame once, so every window in the span is hit in every draw.
        let c = chance_counts(20, &around(&[6, 10, 24], 0.0), 5..25, 50, 3);
        assert!(c.draws.iter().all(|&m| m == 3));
        // k > n is clamped to n.
        assert_eq!(chance_counts(30, &around(&[6], 0.0), 5..25, 5, 3).n_found, 20);
    }

    #[test]
    fn p_values_follow_the_add_one_rule_and_pooling_sums_draw_by_draw() {
        let c = ChanceCounts {
            n_found: 2,
            expected_matched: 1.0,
            expected_matched_se: 0.1,
            exact: false,
            draws: vec![0, 1, 2, 1],
        };
        assert_eq!(c.p_value(2), 2.0 / 5.0);
        assert_eq!(c.p_value(3), 1.0 / 5.0);
        assert_eq!(c.p_value(0), 1.0);
        let d = ChanceCounts {
            n_found: 3,
            expected_matched: 0.5,
            expected_matched_se: 0.2,
            exact: true,
            draws: vec![1, 0, 0, 1],
        };
        let p = ChanceCounts::pooled([&c, &d]);
        assert_eq!(p.draws, [1, 1, 2, 2]);
        assert_eq!((p.n_found, p.expected_matched, p.exact), (5, 1.5, false));
        assert!((p.expected_matched_se - 0.05f64.sqrt()).abs() < 1e-15);
        // A method with many matches on an easy case is far above chance.
        let hard = chance_counts(3, &around(&[100, 500, 900], 5.0), 0..1000, 2000, 5);
        assert!(hard.p_value(3) < 0.01 && hard.p_value(0) == 1.0);
    }

    #[test]
    fn the_seed_fixes_the_draws_and_names_change_them() {
        let w = around(&[20, 60], 5.0);
        assert_eq!(
            chance_counts(4, &w, 0..100, 100, 9).draws,
            chance_counts(4, &w, 0..100, 100, 9).draws
        );
        assert_ne!(row_seed(16, "a", "speed"), row_seed(16, "a", "hull"));
        assert_ne!(row_seed(16, "ab", "c"), row_seed(16, "a", "bc"));
    }

    #[test]
    fn periodic_candidates_are_centred_and_equally_spaced() {
        assert_eq!(periodic_candidates(4, 0..100), [12, 37, 62, 87]);
        assert_eq!(periodic_candidates(1, 10..20), [15]);
        assert_eq!(periodic_candidates(0, 0..100), Vec::<usize>::new());
        assert_eq!(periodic_candidates(5, 0..3), [0, 1, 2]);
    }
}
