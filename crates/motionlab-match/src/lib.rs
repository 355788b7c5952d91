//! # motionlab-match
//!
//! Multistream matching after Yabe & Tanaka (see `../shared/papers/SPEC.md`, section 002).

pub mod dp;
pub mod input;
pub mod multistream;
pub mod sync;
pub mod initial_pose;
pub mod judgement;
pub mod subsequence;
pub mod peaks;
