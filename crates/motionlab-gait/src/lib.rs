//! # motionlab-gait
//!
//! Walk analysis and control after Osafune et al. (see SPEC section 003):
//!
//! - [`change_rates`]: evaluator `change_rates` — `K_ij`, μ, σ, signed CV, feature channels,
//!   with a stated near-zero guard (Tables 1–3).
//! - [`synthesis`]: walk synthesizer `feature_channel_control` — scale the feature channels'
//!   DC and amplitude, resample to the changed frequency (§4); also for BVH skeletons.
//! - [`loso`]: the evaluation the paper leaves open (§5): leave-one-subject-out synthesis
//!   against the recorded walk, RMS and DTW per channel, with the unchanged walk as baseline.
//! - [`study`]: one walk through angles → gait cycles → waveform parameters, and the study.
//!
//! The joint angles, gait-cycle detectors and waveform parameters live in
//! `motionlab-features` (`joint_angles`, `gait_cycles`, `waveform`). Everything here is plain
//! arithmetic over a few hundred numbers per subject, written by hand; the one algorithm with
//! a shared implementation — DTW — comes from `motionlab_match::dp`.

/// How many plugins this crate registers: the registry test (`tests/registry.rs`) checks the
/// binary holds exactly this many from this crate, so a plugin that silently vanishes (a
/// missing `mod` line, a crate left unlinked) fails it. Adding a plugin means counting it here.
pub const PLUGIN_COUNT: usize = 2;

pub mod change_rates;
pub mod loso;
pub mod stages;
pub mod study;
pub mod synthesis;

pub use stages::{
    GaitStudy, GaitTrial, WalkChanges, WalkSynthesizer, build_walk_synthesizer, gait_study,
};
