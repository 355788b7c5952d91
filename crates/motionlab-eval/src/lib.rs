//! # motionlab-eval
//!
//! Evaluation of segmentations against ground truth (Sonoda et al. §3).
