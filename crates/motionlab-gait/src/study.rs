//! One walk through the analysis stages: angles → gait cycles → waveform parameters, and the
//! gait study assembled from many such walks (what an experiment workflow runs per file).

use crate::{GaitStudy, GaitTrial};
use motionlab_core::{FeatureCache, FeatureExtractor, Motion, Result};
use motionlab_features::joint_angles::angle_curves_from_features;
use motionlab_features::{
    AngleCurves, GaitCycle, GaitCycleDetector, WaveformAnalyzer, WaveformParameters,
};

/// A walk's angle curves and its gait cycles.
#[derive(Clone, Debug, PartialEq)]
pub struct Walk {
    pub curves: AngleCurves,
    pub cycles: Vec<GaitCycle>,
}

/// A walk analysed: curves, cycles and waveform parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct AnalysedWalk {
    pub walk: Walk,
    pub parameters: WaveformParameters,
}

/// Runs an angle extractor (any feature extractor whose traces in degrees are joint angles:
/// `isb_joint_angles`, `skeleton_joint_angles`), a gait-cycle detector and a waveform analyzer
/// on one motion. Errors carry the stage's own location (file, field).
pub fn analyse_walk(
    motion: &Motion,
    angles: &dyn FeatureExtractor,
    detector: &dyn GaitCycleDetector,
    analyzer: &dyn WaveformAnalyzer,
) -> Result<AnalysedWalk> {
    let features = angles.extract(motion, &FeatureCache::new())?;
    let curves = angle_curves_from_features(&features, motion.frame_rate())?;
    let cycles = detector.cycles(motion)?;
    let parameters = analyzer.parameters(&curves, &cycles)?;
    Ok(AnalysedWalk { walk: Walk { curves, cycles }, parameters })
}

/// A labelled analysed walk: which subject, which condition.
#[derive(Clone, Debug, PartialEq)]
pub struct SubjectWalk {
    pub subject: String,
    pub condition: String,
    pub analysed: AnalysedWalk,
}

/// The gait study of labelled walks.
pub fn study_of(normal_condition: &str, walks: &[SubjectWalk]) -> GaitStudy {
    GaitStudy {
        normal_condition: normal_condition.to_string(),
        trials: walks
            .iter()
            .map(|w| GaitTrial {
                subject: w.subject.clone(),
                condition: w.condition.clone(),
                parameters: w.analysed.parameters.clone(),
            })
            .collect(),
    }
}
