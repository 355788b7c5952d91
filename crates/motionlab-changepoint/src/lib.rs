//! # motionlab-changepoint
//!
//! Change-point segmenters on multichannel signals, one file each:
//! - [`kernel_cpd`] — PELT and binary segmentation with the `l2`, `rbf`, `linear` and `ar` costs, and
//!   ruptures' C `KernelCPD` PELT, giving exactly ruptures' breakpoints;
//! - [`bocpd`] — Bayesian online change-point detection (Adams & MacKay 2007), Gaussian model
//!   with unknown mean and variance, constant hazard;
//! - [`bocpd_online`] — the same model deciding change points as samples arrive (a streaming
//!   segmenter, `motionlab_core::streaming`);
//! - [`window`] — the sliding-window discrepancy segmenter (ruptures' `Window`).
//!
//! Each has a params struct whose doc comment is its user documentation, a `ParamGuard` into
//! the checked stage, and on the checked stage
//! `segment_values(values, n_channels) -> SegmenterOutput`: `values` sample-major
//! (`n_samples × n_channels`), candidates the change-point sample indices (the first sample of
//! every segment but the first), sorted, unique, never 0 or n.
//!
//! **Why written here.** The searches must reproduce ruptures (the field's reference) to the
//! breakpoint — its admissible grid, its tie-breaking, its clipped kernels — while the rbf cost
//! runs in O(n) memory, where ruptures' Python costs store the n × n Gram matrix; no Rust crate
//! does either. BOCPD is a few conjugate updates on top of a log-gamma (the `libm` crate's).

/// How many plugins this crate registers (the registry test checks the binary holds them all).
pub const PLUGIN_COUNT: usize = 4;

pub mod bocpd;
pub mod bocpd_online;
pub mod kernel_cpd;
mod signal;
pub mod window;

pub use bocpd::{Bocpd, BocpdChangePoints, BocpdModel, BocpdParams, BocpdRun};
pub use bocpd_online::{BocpdOnline, BocpdOnlineParams};
pub use kernel_cpd::{CostModel, KernelCpd, KernelCpdParams, KernelCpdRun, Search, StopRule};
pub use signal::Normalize;
pub use window::{Window, WindowParams, WindowRun, WindowStop};
