//! # motionlab-features
//!
//! Per-frame features of motions, one file each. Each module documents how it treats missing
//! samples. Feature-extractor plugins registered here: `marker_speed`.

/// How many plugins this crate registers: the registry test (`tests/registry.rs`) checks the
/// binary holds exactly this many from this crate, so a plugin that silently vanishes (a
/// missing `mod` line, a crate left unlinked) fails it. Adding a plugin means counting it here.
pub const PLUGIN_COUNT: usize = 11;

pub mod butterworth;
pub mod clustering;
pub mod curvature;
pub mod gait_cycles;
pub mod gait_stages;
pub mod gap_fill;
pub mod hull;
pub mod joint_angles;
pub mod signal;
mod simd;
pub mod smoothing;
pub mod speed;
pub mod virtual_markers;
pub mod waveform;

pub use gait_stages::{
    AngleCurves, GaitCycle, GaitCycleDetector, WaveformAnalyzer, WaveformParameters,
    build_gait_cycle_detector, build_waveform_analyzer,
};
