//! # motionlab-segment
//!
//! Segmenters and fusers, one file each. A new segmenter is one file like
//! [`speed_minima`]: a documented params struct, a `ParamGuard` into the checked stage, the
//! `Segmenter` impl and one `register_plugin!` line — plus its `mod` line below.

/// How many plugins this crate registers: the registry test (`tests/registry.rs`) checks the
/// binary holds exactly this many from this crate, so a plugin that silently vanishes (a
/// missing `mod` line, a crate left unlinked) fails it. Adding a plugin means counting it here.
pub const PLUGIN_COUNT: usize = 6;

pub mod speed_minima;
pub mod thresholds;
pub mod fastest_marker_speed;
pub mod direction_change;
pub mod hull_volume_change;
pub mod pca_error_rise;
pub mod union_merge;
#[cfg(test)]
mod test_data;
