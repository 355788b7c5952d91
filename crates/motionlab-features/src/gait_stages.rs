//! The gait family's records and stage kinds that belong to features (Osafune et al. §2):
//! gait cycles, joint-angle curves, and the posture/size/speed of a walk's channels.
//!
//! The kinds `gait_cycle_detector` and `waveform_analyzer` are declared here, beside their
//! traits, not in core. Their plugins register with
//! `register_custom_plugin!(GaitCycleDetector, Params, "name", kind = "gait_cycle_detector")` and
//! are built with [`build_gait_cycle_detector`] and [`build_waveform_analyzer`].

use serde::{Deserialize, Serialize};

use motionlab_core::registry::build_custom;
use motionlab_core::{Error, ErrorKind, FrameRate, Motion, Result};

motionlab_core::declare_stage_kind!(
    "gait_cycle_detector",
    label = "gait-cycle detector",
    list_order = 54
);
motionlab_core::declare_stage_kind!(
    "waveform_analyzer",
    label = "waveform analyzer",
    list_order = 55
);

/// One gait cycle: same-side foot strike to the next foot strike, frames `start..end`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GaitCycle {
    pub start: usize,
    pub end: usize,
    /// `Left` / `Right`.
    pub side: String,
}

/// Joint-angle waveforms: channel-major curves in degrees at a frame rate.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AngleCurves {
    pub frame_rate: FrameRate,
    /// `joint.axis` names (`knee_l.flexion`, `lfemur.rx`).
    pub channels: Vec<String>,
    /// `values[channel][frame]`, degrees.
    pub values: Vec<Vec<f64>>,
}

impl AngleCurves {
    pub fn n_frames(&self) -> usize {
        self.values.first().map(Vec::len).unwrap_or(0)
    }
    pub fn channel_index(&self, name: &str) -> Result<usize> {
        self.channels.iter().position(|c| c == name).ok_or_else(|| {
            let close = motionlab_core::registry::closest_names(
                name,
                self.channels.iter().map(String::as_str),
            );
            Error::new(
                ErrorKind::UnknownName,
                format!("no angle channel {name:?} (closest: {})", close.join(", ")),
            )
            .with_field(name)
        })
    }
}

/// Posture, size and speed of a walk's channels (Osafune et al. §2.2).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct WaveformParameters {
    pub channels: Vec<String>,
    /// DC component (mean angle) per channel, degrees.
    pub dc: Vec<f64>,
    /// Amplitude per channel, degrees.
    pub amplitude: Vec<f64>,
    /// Gait frequency (1 / cycle duration), Hz — common to all channels.
    pub frequency_hz: f64,
}

/// Finds gait cycles in a walk.
pub trait GaitCycleDetector: Send + Sync {
    fn cycles(&self, motion: &Motion) -> Result<Vec<GaitCycle>>;
}

/// Computes posture (DC), size (amplitude) and speed (frequency) of angle curves over cycles.
pub trait WaveformAnalyzer: Send + Sync {
    fn parameters(&self, curves: &AngleCurves, cycles: &[GaitCycle]) -> Result<WaveformParameters>;
}

/// Builds a gait-cycle detector by name from its TOML table (without the `type` key).
pub fn build_gait_cycle_detector(
    name: &str,
    params: &motionlab_core::toml::Value,
) -> Result<Box<dyn GaitCycleDetector>> {
    build_custom::<dyn GaitCycleDetector>("gait_cycle_detector", name, params)
}

/// Builds a waveform analyzer by name from its TOML table (without the `type` key).
pub fn build_waveform_analyzer(
    name: &str,
    params: &motionlab_core::toml::Value,
) -> Result<Box<dyn WaveformAnalyzer>> {
    build_custom::<dyn WaveformAnalyzer>("waveform_analyzer", name, params)
}
