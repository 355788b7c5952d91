//! # motionlab-eval
//!
//! Evaluation of segmentations against ground truth (Sonoda et al. §3):
//!
//! - [`boundaries`]: the match rule (tolerance in frames or seconds, optional annotated windows,
//!   optional pose rule), **maximum** one-to-one matching, precision / recall / F1 with the
//!   empty-set rules, and the Hausdorff distance.
//! - [`consensus`]: consensus ground truth from several annotators' marks (clustering by
//!   chaining, one vote per annotator, `min_votes`, median frame, optional stop rule).
//! - [`transitions`]: the paper's Table 3 (each labelled transition ○/×) and its evaluator plugin.
//! - [`boundary_pr`]: evaluator plugin for Tables 1/2 (per sequence and pooled), with the
//!   chance and periodic baselines of [`chance`] beside each method (p-value, above chance);
//!   [`span`]: its option to count only found frames within the annotated span.
//! - [`cpd_metrics`]: TCPDBench/TSSB's F1 with several annotators and segment covering;
//!   [`boundary_metrics`]: evaluator plugin for them and for F1 at several tolerances;
//!   [`series_scores`]: the same metrics of one (series, method) with their chance draws, as a
//!   typed value a benchmark averages over series.
//! - [`human_agreement`]: evaluator plugin for the annotators' agreement with each other (F1
//!   and a chance-corrected kappa per pair), the ceiling each method is shown under.
//! - [`label_metrics`]: agreement of found states with true states per sample — AMI, ARI and
//!   NMI as scikit-learn computes them — each beside the chance of the found labels permuted
//!   across the found segments.
//! - [`ranks`]: methods compared over many series — mean ranks, Friedman's test, the Nemenyi
//!   critical difference and its cliques (the critical-difference diagram's arithmetic).
//! - [`truth_csv`], [`truth_eaf`]: ground-truth readers for users' own annotations
//!   (`boundaries_csv`, `elan_eaf`; formats parsed in `motionlab-io`), one annotator or the
//!   consensus of several.
//!
//! Evaluator plugins registered here: `boundary_metrics`, `boundary_pr`, `human_agreement`,
//! `transitions`;
//! ground-truth readers: `boundaries_csv`, `elan_eaf`.
//!
//! Written by hand: the two matching algorithms (a point–interval sweep and Hopcroft–Karp, each
//! a few dozen lines, cross-checked against exhaustive search in the tests — see
//! [`boundaries`] for why no graph crate), the Hausdorff distance on sorted frame lists, and the
//! consensus clustering (a one-pass chain over sorted marks). The fastest-marker speed used by
//! the consensus stop rule comes from `motionlab_features::speed`, the one definition of V.

/// How many plugins this crate registers: the registry test (`tests/registry.rs`) checks the
/// binary holds exactly this many from this crate, so a plugin that silently vanishes (a
/// missing `mod` line, a crate left unlinked) fails it. Adding a plugin means counting it here.
pub const PLUGIN_COUNT: usize = 6;

pub mod boundaries;
pub mod boundary_analysis;
pub mod boundary_metrics;
pub mod boundary_pr;
pub mod chance;
pub mod consensus;
pub mod cpd_metrics;
pub mod human_agreement;
pub mod label_metrics;
pub mod ranks;
mod sequences;
pub mod series_scores;
pub mod span;
pub mod transitions;
mod truth_annotators;
pub mod truth_csv;
pub mod truth_eaf;

pub use boundaries::{
    BoundaryScores, MatchRule, MatchedPair, PoseRule, evaluate_boundaries, hausdorff_frames,
};
pub use consensus::{Consensus, ConsensusParams, ConsensusPoint, cluster_marks};
pub use transitions::{TransitionOutcome, detect_transitions};
