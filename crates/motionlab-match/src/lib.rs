//! # motionlab-match
//!
//! Multistream matching after Yabe & Tanaka (§3–§4 of their paper):
//! a user's continuous take of repetitions is compared with a model basic motion, marker by
//! marker, and every repetition is judged by its distance `H` and its synchronisation `R`.
//!
//! A workflow chains the plugins registered here as
//!
//! | step | plugin | kind | module |
//! |---|---|---|---|
//! | subtract each marker's initial position | `initial_pose_normalisation` | preprocessor | [`initial_pose`] |
//! | (timing test) shift one limb's markers later by a known time | `delay_points` | preprocessor | [`delay`] |
//! | one point per repetition on the user's take, a window around each | `velocity_peaks` | point detector | [`peaks`] |
//! | model against each window: common `[a, b]`, `h_l`, `H`, paths | `multistream_two_stage` | matcher | [`multistream`] |
//! | (baseline) one marker, free start and end | `subsequence_dp` | matcher | [`subsequence`] |
//! | `u_l(i)` from the paths, `r_q`, `R` | `synchronisation` | synchroniser | [`sync`] |
//! | `H'`, `R'`, score, rank; `h'_l`, `r'_q` | `judgement` | evaluator | [`judgement`] |
//!
//! Across a corpus, [`retrieval`] finds the `k` most similar and most dissimilar stretches of
//! many takes to one model with the same two-stage match, pruned by bounds that provably never
//! drop a true result (the `[retrieval]` workflow of `motionlab-workflows`).
//!
//! The DP kernels are in [`dp`]: the paper's forward subsequence pass (free start, free end),
//! its backward pass anchored at the common end, a full DTW with path (also used by
//! `motionlab-gait` on joint-angle curves through [`dp::dtw_full`] / [`dp::dtw_full_1d`]), all
//! generic over the local distance. The two-stage matcher runs the same recurrences with eight
//! markers per SIMD register ([`lanes`], instruction set chosen at run time by [`simd`]), bit
//! for bit the numbers of [`dp`]'s kernels one marker at a time.
//!
//! ## Written by hand, and why
//!
//! The DP kernels are written here. The Rust DTW crates (`dtw_rs`, `augurs-dtw`, `dtw`) compute
//! a full, both-ends-anchored DTW distance (some with a path); none exposes the paper's
//! subsequence recurrence with its free start and the whole last row `h(j)` for every end `j`
//! (needed to sum `G(j)` over markers), nor the backward pass anchored at `b` that yields the
//! cost of every start, and their local distances differ from the paper's (augurs' "euclidean"
//! is the square root of a sum of squares over the path). The kernels are short, and keeping
//! them here lets the hot loops run over structure-of-arrays coordinates with one rolling row
//! (see [`dp`]'s speed notes and `benches/README.md`). The velocity-peak threshold sweep and
//! the synchronisation variance are a few lines each. Smoothing reuses
//! `motionlab_features::smoothing`.
//!
//! ## Checked against
//!
//! `bench/dtw_crosscheck.py` compares the full DTW with dtaidistance and tslearn, and the
//! subsequence and anchored passes with a brute force (minimum over every start of a full DTW),
//! on random 3-D series: all agree to < 1e-9 relative.
//!
//! ## Missing samples
//!
//! The matchers and the point detector refuse them (an error names the marker and the first
//! missing frame, and points to the `fill_gaps` preprocessor); the normalisation keeps them
//! missing; the synchroniser and the judgement only see what the matchers produced.

/// How many plugins this crate registers: the registry test (`tests/registry.rs`) checks the
/// binary holds exactly this many from this crate, so a plugin that silently vanishes (a
/// missing `mod` line, a crate left unlinked) fails it. Adding a plugin means counting it here.
pub const PLUGIN_COUNT: usize = 9;

pub mod delay;
pub mod distinct_points;
pub mod dp;
pub mod initial_pose;
pub mod input;
pub mod judgement;
pub mod lanes;
pub mod multistream;
pub mod peaks;
pub mod retrieval;
pub mod simd;
pub mod stage;
pub mod state_labeller;
pub mod subsequence;
pub mod sync;

pub use stage::{
    Alignment, Matcher, MatchingResult, PointDetection, PointDetector, RepetitionResult,
    Synchronisation, Synchroniser, build_matcher, build_point_detector, build_synchroniser,
    matching_results,
};

#[cfg(test)]
mod tests {
    use motionlab_core::registry::{check_registry, find, find_custom};

    const PLUGINS: [&str; 8] = [
        "multistream_dp",
        "initial_pose_normalisation",
        "delay_points",
        "velocity_peaks",
        "multistream_two_stage",
        "subsequence_dp",
        "synchronisation",
        "judgement",
    ];

    #[test]
    fn every_plugin_is_registered_documented_and_has_documented_parameters() {
        for name in PLUGINS {
            // Core's kinds (normaliser, preprocessor) or this family's declared kinds.
            let (crate_name, doc) = match (find(name), find_custom(name)) {
                (Ok(p), None) => (p.crate_name, p.doc()),
                (Err(_), Some(p)) => (p.crate_name, p.doc()),
                (core, custom) => panic!(
                    "{name}: registered {} times",
                    core.is_ok() as u8 + custom.is_some() as u8
                ),
            };
            assert_eq!(crate_name, "motionlab-match");
            assert!(
                doc.contains("issing"),
                "{name}: the doc must say how missing samples are treated"
            );
        }
        let problems: Vec<String> = check_registry()
            .into_iter()
            .filter(|p| PLUGINS.iter().any(|n| p.contains(&format!("{n:?}"))))
            .collect();
        assert!(problems.is_empty(), "{problems:?}");
    }
}
