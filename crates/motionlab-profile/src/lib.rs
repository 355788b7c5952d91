//! Profile-based segmenters on sliding-window nearest neighbours.
//!
//! - [`clasp`]: ClaSP — the classification score profile of Ermshaus, Schäfer & Leser (DMKD
//!   2023) with SuSS window widths, an ensemble over temporal constraints, binary segmentation
//!   and the significance test, computed as the authors' reference implementation claspy does.
//! - [`floss`]: FLUSS/FLOSS — the corrected arc curve of Gharghabi et al. (ICDM 2017) on a
//!   matrix profile index computed here, with stumpy's exclusion zone and regime extraction.
//!
//! Each segmenter's checked stage has `segment_values(values, n_channels)` on sample-major
//! channel data (`values[sample * n_channels + channel]`) and returns change-point sample
//! indices and the profile it decided on as a trace.
//!
//! **Why written here.** No Rust crate computes ClaSP or FLUSS, and the matrix-profile crates
//! do not reproduce stumpy's exclusion zone, Pearson recurrence and tie order. The peers'
//! numerics are mirrored deliberately — claspy's cumulative-sum window statistics and STOMP
//! dot-product recurrence, pandas' compensated rolling statistics inside SuSS, NumPy's
//! pairwise summation and legacy Mersenne Twister (claspy's ensemble draws its temporal
//! constraints from it) — so that profiles agree with the peers' to rounding and change points
//! are identical (`bench/profile_vs_peers.py`). The speed comes from doing the same arithmetic
//! without the peers' per-split allocations: ClaSP's score profile is computed from running
//! counts in O(n) instead of O(n²·k), the k-NN rows in one fused pass per row over threads.

/// How many plugins this crate registers (the registry test checks the binary holds them all).
pub const PLUGIN_COUNT: usize = 2;

pub mod clasp;
pub mod floss;
mod input;
mod numpy;
mod sliding;

pub use clasp::{Clasp, ClaspParams};
pub use floss::{Floss, FlossParams};
