//! # motionlab-segment
//!
//! Segmenters and fusers, one file each. A new segmenter is one file like
//! [`speed_minima`]: a documented params struct, a `ParamGuard` into the checked stage, the
//! `Segmenter` impl and one `register_plugin!` line — plus its `mod` line below.

pub mod speed_minima;
pub mod thresholds;
pub mod fastest_marker_speed;
pub mod direction_change;
pub mod hull_volume_change;
pub mod pca_error_rise;
pub mod union_merge;
#[cfg(test)]
mod test_data;
