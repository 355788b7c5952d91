//! # motionlab-features
//!
//! Per-frame features of motions, one file each. Each module documents how it treats missing
//! samples. Feature-extractor plugins registered here: `marker_speed`.

pub mod signal;
pub mod smoothing;
pub mod speed;
pub mod joint_angles;
pub mod gait_cycles;
pub mod waveform;
pub mod curvature;
pub mod hull;
pub mod virtual_markers;
pub mod gap_fill;
pub mod butterworth;
mod simd;
