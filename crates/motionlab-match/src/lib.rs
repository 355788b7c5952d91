//! # motionlab-match
//!
//! Multistream matching after Yabe & Tanaka (see `../shared/papers/SPEC.md`, section 002).
