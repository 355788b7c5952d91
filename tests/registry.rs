//! The plugin registry: every expected plugin is linked into the binary's crates and
//! documented (a plugin crate the CLI forgets to name would vanish silently).

use motionlab_core::registry::{self, StageKind};

// The same plugin crates the CLI names.
use motionlab_eval as _;
use motionlab_features as _;
use motionlab_gait as _;
use motionlab_io as _;
use motionlab_match as _;
use motionlab_segment as _;

/// Every plugin the project ships, by kind. Adding a plugin means adding it here.
const EXPECTED: &[(StageKind, &str)] = &[
    (StageKind::Loader, "asf_amc"),
    (StageKind::Loader, "bvh"),
    (StageKind::Loader, "c3d"),
    (StageKind::Loader, "qualisys_tsv"),
    (StageKind::GroundTruth, "cmu86_labels"),
    (StageKind::GroundTruth, "mocap6_labels"),
    (StageKind::Preprocessor, "add_centroid"),
    (StageKind::Preprocessor, "butterworth"),
    (StageKind::Preprocessor, "delay_points"),
    (StageKind::Preprocessor, "distinct_points"),
    (StageKind::Preprocessor, "fill_gaps"),
    (StageKind::Preprocessor, "initial_pose_normalisation"),
    (StageKind::FeatureExtractor, "hull_volume"),
    (StageKind::FeatureExtractor, "isb_joint_angles"),
    (StageKind::FeatureExtractor, "marker_speed"),
    (StageKind::FeatureExtractor, "root_curvature"),
    (StageKind::FeatureExtractor, "skeleton_joint_angles"),
    (StageKind::Segmenter, "direction_change"),
    (StageKind::Segmenter, "fastest_marker_speed"),
    (StageKind::Segmenter, "hull_volume_change"),
    (StageKind::Segmenter, "pca_error_rise"),
    (StageKind::Segmenter, "speed_minima"),
    (StageKind::Fuser, "union_merge"),
    (StageKind::PointDetector, "velocity_peaks"),
    (StageKind::Matcher, "multistream_two_stage"),
    (StageKind::Matcher, "subsequence_dp"),
    (StageKind::Synchroniser, "synchronisation"),
    (StageKind::GaitCycleDetector, "c3d_events"),
    (StageKind::GaitCycleDetector, "heel_height"),
    (StageKind::WaveformAnalyzer, "waveform_parameters"),
    (StageKind::WalkSynthesizer, "feature_channel_control"),
    (StageKind::Evaluator, "boundary_metrics"),
    (StageKind::Evaluator, "boundary_pr"),
    (StageKind::Evaluator, "change_rates"),
    (StageKind::Evaluator, "judgement"),
    (StageKind::Evaluator, "transitions"),
];

#[test]
fn every_expected_plugin_is_registered_with_its_kind() {
    let all = registry::plugins();
    for (kind, name) in EXPECTED {
        let p = all.iter().find(|p| p.name == *name).unwrap_or_else(|| panic!("plugin {name:?} is not registered (crate not linked?)"));
        assert_eq!(p.kind, *kind, "{name}");
    }
}

#[test]
fn every_registered_plugin_is_expected_and_documented() {
    let problems = registry::check_registry();
    assert!(problems.is_empty(), "{problems:#?}");
    for p in registry::plugins() {
        assert!(EXPECTED.iter().any(|(_, n)| *n == p.name), "plugin {:?} is registered but missing from EXPECTED", p.name);
    }
}
