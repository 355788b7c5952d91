//! The walk-control family's records and stage kind (Osafune et al. §3–4): the change rates
//! to apply to a walk, the walk synthesizer that applies them, and the gait study the gait
//! workflow hands its evaluators.
//!
//! The kind `walk_synthesizer` is declared here, beside its trait, not in core; its plugins
//! register with `register_custom_plugin!(WalkSynthesizer, Params, "name", kind =
//! "walk_synthesizer")` and are built with [`build_walk_synthesizer`].

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use motionlab_core::registry::build_custom;
use motionlab_core::{EvalInputType, Result};
use motionlab_features::gait_stages::{AngleCurves, GaitCycle, WaveformParameters};

motionlab_core::declare_stage_kind!(
    "walk_synthesizer",
    label = "walk synthesizer",
    list_order = 56
);

/// Change rates to apply to a walk: only the listed channels change (Osafune et al. §4).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct WalkChanges {
    /// Per channel: DC change rate μ_DC in %.
    pub dc_percent: BTreeMap<String, f64>,
    /// Per channel: amplitude change rate μ_A in %.
    pub amplitude_percent: BTreeMap<String, f64>,
    /// Frequency change rate μ_f in %.
    pub frequency_percent: f64,
}

/// Waveform parameters of one subject's walk in one condition.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GaitTrial {
    pub subject: String,
    pub condition: String,
    pub parameters: WaveformParameters,
}

/// A gait study: every subject in every condition, and which condition is "normal" (G).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GaitStudy {
    pub normal_condition: String,
    pub trials: Vec<GaitTrial>,
}

/// Produces a changed walk from a recorded one.
pub trait WalkSynthesizer: Send + Sync {
    fn synthesize(
        &self,
        walk: &AngleCurves,
        cycles: &[GaitCycle],
        changes: &WalkChanges,
    ) -> Result<AngleCurves>;
}

/// Builds a walk synthesizer by name from its TOML table (without the `type` key).
pub fn build_walk_synthesizer(
    name: &str,
    params: &motionlab_core::toml::Value,
) -> Result<Box<dyn WalkSynthesizer>> {
    build_custom::<dyn WalkSynthesizer>("walk_synthesizer", name, params)
}

/// A gait study (`GaitStudy`): what the gait workflow hands its evaluators.
pub fn gait_study() -> EvalInputType {
    EvalInputType::of::<GaitStudy>("a gait study")
}

impl GaitTrial {
    /// A hand-made trial with two channels, `knee_l.flexion` and `hip_l.rotation`, with the
    /// given DC and amplitude (degrees) of each and the gait frequency (Hz): hand-made studies
    /// for the change-rate tests.
    pub fn hand_made(
        subject: &str,
        condition: &str,
        dc: [f64; 2],
        amplitude: [f64; 2],
        frequency_hz: f64,
    ) -> GaitTrial {
        GaitTrial {
            subject: subject.into(),
            condition: condition.into(),
            parameters: WaveformParameters {
                channels: vec!["knee_l.flexion".into(), "hip_l.rotation".into()],
                dc: dc.to_vec(),
                amplitude: amplitude.to_vec(),
                frequency_hz,
            },
        }
    }
}
