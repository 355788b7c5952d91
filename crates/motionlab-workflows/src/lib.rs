//! # motionlab-workflows
//!
//! The built-in workflows, one module each (the larger ones a folder split by responsibility:
//! section, build, run, analysis, figures, viewers), each registered with
//! `motionlab_experiment::register_workflow!` and owning its section of the experiment file:
//!
//! - [`features`] — `[features]`: per-frame features of each sequence as a table and figures.
//! - [`segmentation`] — `[segmentation]` (Sonoda et al.): segmenters → fuser → evaluators, the
//!   paper's figures, precision–recall curves across a sweep.
//! - [`matching`] — `[matching]` (Yabe & Tanaka): a model against a user's repetitions, the
//!   paper's figures and its (a)/(b)/(c) timing test.
//! - [`retrieval`] — `[retrieval]` (Yabe & Tanaka's match across a corpus): the stretches of
//!   every take most similar and most dissimilar to one model, exactly pruned.
//! - [`benchmark`] — `[benchmark]`: every listed segmenter on every labelled sequence,
//!   covering and TCPDBench F1 beside chance, mean ranks, a critical-difference diagram and
//!   published scores beside ours.
//! - [`gait`] — `[gait]` (Osafune et al.): walk analysis, the paper's Tables 2–3, the control
//!   of a skeleton walk and the leave-one-subject-out evaluation.
//!
//! [`heldout`] holds the segmentation sweeps' held-out selection (`selection = …`).
//! [`drawing`] holds the figure-building helpers they share. Everything here is polars- and
//! plotters-free: figures are specs (`motionlab-figure`), rendered by `motionlab-report`.

pub mod benchmark;
pub mod drawing;
pub mod features;
pub mod gait;
pub mod heldout;
pub mod matching;
pub mod parameter_choice;
pub mod retrieval;
pub mod segmentation;

/// How many workflows this crate registers (checked by the registry test, `tests/registry.rs`,
/// so a workflow that silently vanishes from the binary fails it).
pub const WORKFLOW_COUNT: usize = 6;
