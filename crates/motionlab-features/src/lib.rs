//! # motionlab-features
//!
//! Per-frame features of motions, one file each. Each module documents how it treats missing
//! samples. Feature-extractor plugins registered here: `marker_speed`.

pub mod signal;
pub mod smoothing;
pub mod speed;
