//! Walk control on a real skeleton walk: CMU 131_01 (BVH, start–walk–stop, 120 fps), changed
//! through a marker-channel → BVH-channel map, written as BVH and read back, and its joint
//! positions written as OpenSim TRC and read back.

use motionlab_core::registry::ParamGuard;
use motionlab_features::gait_cycles::HeelHeightParams;
use motionlab_features::joint_angles::{ChannelNaming, skeleton_angle_curves};
use motionlab_features::waveform::WaveformParametersParams;
use motionlab_features::{GaitCycleDetector, WaveformAnalyzer};
use motionlab_gait::WalkChanges;
use motionlab_gait::synthesis::{FeatureChannelControlParams, skeleton_rotation_channels};
use motionlab_io::bvh::{BvhOptions, bvh_motion, parse_bvh, parse_bvh_channels, write_bvh};

#[test]
fn a_bvh_walk_is_changed_resampled_written_and_read_back() {
    let path = motionlab_testkit::data_path("cmu131/131_01.bvh.gz");
    let text = motionlab_io::read::read_text(&path).unwrap();
    let data = parse_bvh_channels(&text, &path, &BvhOptions::default()).unwrap();
    let motion = bvh_motion(data.clone(), &path, motionlab_core::Axis::Y).unwrap();
    let cycles = HeelHeightParams {
        left_heel: "LeftAnkle".into(),
        right_heel: "RightAnkle".into(),
        ..Default::default()
    }
    .check()
    .unwrap()
    .cycles(&motion)
    .unwrap();
    assert!(!cycles.is_empty());
    assert!(
        skeleton_rotation_channels(&data.motion.skeleton)
            .contains(&"LeftKnee.Xrotation".to_string())
    );

    let control = FeatureChannelControlParams {
        channel_map: [
            ("knee_l.flexion", "LeftKnee.Xrotation"),
            ("hip_r.flexion", "RightHip.Xrotation"),
        ]
        .iter()
        .map(|(a, b)| (a.to_string(), b.to_string()))
        .collect(),
        ..Default::default()
    }
    .check()
    .unwrap();
    // +20 % frequency; knee DC +10 %, hip amplitude +30 %; an unmapped channel is dropped.
    let changes = WalkChanges {
        dc_percent: [("knee_l.flexion".to_string(), 10.0), ("elbow_l.flexion".to_string(), 50.0)]
            .into(),
        amplitude_percent: [("hip_r.flexion".to_string(), 30.0)].into(),
        frequency_percent: 20.0,
    };
    let synthesized =
        control.synthesize_skeleton(&data.motion, data.frame_rate, &cycles, &changes).unwrap();
    let n = data.motion.n_frames();
    assert_eq!(synthesized.n_frames(), ((n - 1) as f64 / 1.2).floor() as usize + 1);

    let mut bytes = Vec::new();
    write_bvh(&synthesized, data.frame_rate, data.length_unit, &mut bytes).unwrap();
    let reread = parse_bvh(
        std::str::from_utf8(&bytes).unwrap(),
        std::path::Path::new("131_01_fast.bvh"),
        &BvhOptions::default(),
    )
    .unwrap();
    assert_eq!(reread.n_frames(), synthesized.n_frames());
    assert_eq!(reread.frame_rate(), data.frame_rate);

    // Measured with waveform_parameters on the cycles scaled by 1/1.2 (whole frames: every
    // cycle bound of a multiple of 6 frames maps to a frame, others are rounded).
    let analyzer = WaveformParametersParams::default().check().unwrap();
    let before = skeleton_angle_curves(&data.motion, data.frame_rate, ChannelNaming::Bvh).unwrap();
    let after = skeleton_angle_curves(
        reread.skeleton.as_ref().unwrap(),
        reread.frame_rate(),
        ChannelNaming::Bvh,
    )
    .unwrap();
    let scaled: Vec<_> = cycles
        .iter()
        .map(|c| motionlab_features::GaitCycle {
            start: (c.start as f64 / 1.2).round() as usize,
            end: (c.end as f64 / 1.2).round() as usize,
            side: c.side.clone(),
        })
        .collect();
    let p0 = analyzer.parameters(&before, &cycles).unwrap();
    let p1 = analyzer.parameters(&after, &scaled).unwrap();
    let get = |p: &motionlab_features::WaveformParameters, ch: &str| {
        let i = p.channels.iter().position(|c| c == ch).unwrap();
        (p.dc[i], p.amplitude[i])
    };
    let (knee0, knee1) = (get(&p0, "LeftKnee.Xrotation"), get(&p1, "LeftKnee.Xrotation"));
    let (hip0, hip1) = (get(&p0, "RightHip.Xrotation"), get(&p1, "RightHip.Xrotation"));
    let (elbow0, elbow1) = (get(&p0, "LeftElbow.Yrotation"), get(&p1, "LeftElbow.Yrotation"));
    println!(
        "knee DC {:.2} → {:.2}, hip amplitude {:.2} → {:.2}",
        knee0.0, knee1.0, hip0.1, hip1.1
    );
    // Rounded cycle bounds, resampling and the BVH's printed precision cost a little accuracy.
    assert!((knee1.0 / knee0.0 - 1.1).abs() < 0.01, "{knee0:?} → {knee1:?}");
    assert!((hip1.1 / hip0.1 - 1.3).abs() < 0.02, "{hip0:?} → {hip1:?}");
    assert!(
        (elbow1.0 - elbow0.0).abs() < 0.5 && (elbow1.1 / elbow0.1 - 1.0).abs() < 0.02,
        "{elbow0:?} → {elbow1:?}"
    );
    assert!((p1.frequency_hz / p0.frequency_hz - 1.2).abs() < 0.01);
    // The skeleton (bone offsets) is unchanged.
    assert_eq!(
        reread.skeleton.as_ref().unwrap().skeleton.joints.len(),
        data.motion.skeleton.joints.len()
    );

    // The synthesised walk's joint positions as OpenSim TRC (in metres, as OpenSim models
    // are), read back: same joints, frames and rate, every position equal to within the
    // writer's shortest round-trip decimals (1e-12 relative, after mm → m → mm).
    let mut trc = Vec::new();
    motionlab_io::trc::write_trc(
        &reread,
        motionlab_core::LengthUnit::Metre,
        "131_01_fast.trc",
        &mut trc,
    )
    .unwrap();
    let back = motionlab_io::trc::parse_trc(
        std::str::from_utf8(&trc).unwrap(),
        std::path::Path::new("131_01_fast.trc"),
    )
    .unwrap()
    .into_motion(std::path::Path::new("131_01_fast.trc"), reread.up_axis())
    .unwrap();
    assert_eq!(back.point_names(), reread.point_names());
    assert_eq!(back.n_frames(), synthesized.n_frames());
    assert!((back.frame_rate().hz() - reread.frame_rate().hz()).abs() < 1e-9);
    assert_eq!(back.missing_count(), 0);
    for (a, b) in back.positions().iter().zip(reread.positions()) {
        for k in 0..3 {
            assert!((a[k] - b[k]).abs() <= 1e-12 * b[k].abs().max(1.0), "{a:?} vs {b:?}");
        }
    }
}

#[test]
fn osafune_plugins_are_registered_and_documented() {
    // Linking the crates registers their plugins; the registry's own invariants must hold for ours.
    let ours = [
        "isb_joint_angles",
        "skeleton_joint_angles",
        "c3d_events",
        "heel_height",
        "waveform_parameters",
        "change_rates",
        "feature_channel_control",
    ];
    for name in ours {
        // Core's kinds, or a kind a family crate declares (gait-cycle detectors, walk synthesizers…).
        let (doc, params) = match (
            motionlab_core::registry::find(name),
            motionlab_core::registry::find_custom(name),
        ) {
            (Ok(p), _) => (p.doc(), p.params()),
            (Err(_), Some(p)) => (p.doc(), p.params()),
            (Err(e), None) => panic!("{e}"),
        };
        assert!(doc.len() > 200, "{name}: {doc}");
        for param in params {
            assert!(!param.description.is_empty(), "{name}.{}", param.name);
        }
    }
    let problems: Vec<String> = motionlab_core::registry::check_registry()
        .into_iter()
        .filter(|p| ours.iter().any(|n| p.contains(&format!("{n:?}"))))
        .collect();
    assert!(problems.is_empty(), "{problems:?}");
}
