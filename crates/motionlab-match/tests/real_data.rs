//! The matching stages on the real motion capture shipped in `data/` (CMU exercise takes from
//! mocap6, a Qualisys walk with gaps from the MoCap Toolbox).

use motionlab_core::registry::{build_loader, build_preprocessor, default_params};
use motionlab_core::{ErrorKind, Motion};
use motionlab_match::build_matcher;
use motionlab_match::build_point_detector;
use motionlab_match::build_synchroniser;
// Link the crates whose plugins the registry looks up by name.
use motionlab_io as _;
use motionlab_match as _;

fn load_amc(take: &str) -> Motion {
    let path = motionlab_testkit::data_path(&format!("mocap6/amc/{take}.amc.gz"));
    build_loader("asf_amc", &default_params()).unwrap().load(&path).unwrap()
}

fn toml(text: &str) -> toml::Value {
    toml::from_str(text).unwrap()
}

fn normalised(m: Motion) -> Motion {
    build_preprocessor("initial_pose_normalisation", &default_params()).unwrap().apply(m).unwrap()
}

/// 13_29 frames 0..468 are jumping jacks (truelabels: label 1 for the first 39 blocks of 12).
#[test]
fn velocity_peaks_find_the_alternating_arm_strokes_of_jumping_jacks() {
    let take = load_amc("13_29").slice_frames(0, 468).unwrap();
    let detector = build_point_detector(
        "velocity_peaks",
        &toml(
            "marker = \"lhand\"\ncount = 7\nsmoothing = { seconds = 0.2 }\nbefore = { seconds = 0.5 }\nafter = { seconds = 0.5 }",
        ),
    )
    .unwrap();
    let d = detector.detect(&take).unwrap();
    assert_eq!(d.peaks.len(), 7);
    // Independent check: the hand moves up (+Y, the AMC up axis) and down in turn, so the peaks'
    // vertical directions alternate, and same-direction strokes are one jack apart (≈ 1.1 s).
    let hand = take.point_index("lhand").unwrap();
    let up: Vec<bool> = d
        .peaks
        .iter()
        .map(|&p| take.position(p + 1, hand)[1] > take.position(p, hand)[1])
        .collect();
    assert!(up.windows(2).all(|w| w[0] != w[1]), "directions {up:?} at {:?}", d.peaks);
    for w in d.peaks.windows(3) {
        let period = w[2] - w[0];
        assert!((110..=150).contains(&period), "one jack = {period} frames at {:?}", d.peaks);
    }
    for (&(s, e), &p) in d.windows.iter().zip(&d.peaks) {
        assert!(s <= p && p < e && e <= take.n_frames());
        assert!(e - s <= 121, "0.5 s before and after at 120 fps");
    }
}

#[test]
fn one_repetition_cut_from_a_take_is_found_exactly_where_it_was_cut() {
    let take = load_amc("13_29").slice_frames(0, 468).unwrap();
    // One jack, from one downward arm stroke to the next (frames 114..249).
    let model = take.slice_frames(114, 249).unwrap();
    let a = build_matcher("multistream_two_stage", &default_params())
        .unwrap()
        .align(&model, &take)
        .unwrap();
    assert_eq!((a.start, a.end), (114, 248));
    assert_eq!(a.total_distance, 0.0);
    assert_eq!(a.point_distances.len(), take.n_points());
    let diagonal: Vec<(usize, usize)> = (0..135).map(|i| (i, 114 + i)).collect();
    assert!(a.paths.iter().all(|p| *p == diagonal));
    let s = build_synchroniser("synchronisation", &default_params())
        .unwrap()
        .synchronise(&a, model.n_frames())
        .unwrap();
    assert_eq!(s.total, 0.0);
}

/// Model: one jack of subject 13's take 29. User: take 31 (same subject, another day's take),
/// a stretch of jumping jacks and equally long stretches of four other exercises.
#[test]
fn across_takes_the_same_exercise_has_the_least_distance() {
    let model = normalised(load_amc("13_29").slice_frames(114, 249).unwrap());
    let take = load_amc("13_31");
    let matcher = build_matcher("multistream_two_stage", &default_params()).unwrap();
    // Labelled stretches of 13_31 (truelabels, 12-frame blocks): 1 JumpJack 2724..3024,
    // 4 KneeRaise 396..984, 5 ArmCircle 2052..2724, 6 Twist 0..396, 2 Jog 1608..2052.
    let stretches = [
        ("jumping jacks", 2724),
        ("knee raises", 400),
        ("arm circles", 2100),
        ("twists", 50),
        ("jogging", 1650),
    ];
    let mut h = Vec::new();
    for (name, start) in stretches {
        let user = normalised(take.slice_frames(start, start + 266).unwrap());
        let a = matcher.align(&model, &user).unwrap();
        h.push((name, a.total_distance, a.end - a.start + 1));
    }
    let (_, h_jacks, len_jacks) = h[0];
    assert!(h[1..].iter().all(|&(_, other, _)| other > 1.2 * h_jacks), "{h:?}");
    // The matched stretch is about one jack long (the model is 135 frames).
    assert!((95..=175).contains(&len_jacks), "{h:?}");
}

/// mct/walk1 has 27 missing samples (Head_FR from frame 199, Shoulder_R from frame 304).
#[test]
fn gaps_in_a_real_recording_are_refused_with_the_marker_and_frame() {
    let walk = build_loader("qualisys_tsv", &default_params())
        .unwrap()
        .load(&motionlab_testkit::data_path("mct/walk1.tsv.gz"))
        .unwrap();
    assert_eq!(walk.missing_count(), 27);
    let model = walk.slice_frames(0, 60).unwrap();
    let e = build_matcher("multistream_two_stage", &default_params())
        .unwrap()
        .align(&model, &walk)
        .unwrap_err();
    assert_eq!(e.kind(), ErrorKind::MissingData);
    assert_eq!(e.location().field.as_deref(), Some("Head_FR"));
    assert!(e.to_string().contains("frame 199") && e.to_string().contains("walk1"), "{e}");
    // Leaving the two gappy markers out with `points` works; so does a single complete marker.
    let complete: Vec<String> = walk
        .point_names()
        .iter()
        .filter(|n| !["Head_FR", "Shoulder_R"].contains(&n.as_str()))
        .cloned()
        .collect();
    let params = toml::Value::Table(toml::Table::from_iter([(
        "points".to_string(),
        toml::Value::Array(complete.iter().map(|n| toml::Value::String(n.clone())).collect()),
    )]));
    let a = build_matcher("multistream_two_stage", &params).unwrap().align(&model, &walk).unwrap();
    assert_eq!((a.start, a.end, a.total_distance), (0, 59, 0.0));
    let single = build_matcher("subsequence_dp", &toml("marker = \"Head_FR\""))
        .unwrap()
        .align(&model, &walk)
        .unwrap_err();
    assert_eq!(single.kind(), ErrorKind::MissingData);
    // Initial-pose normalisation keeps the gaps as gaps.
    assert_eq!(normalised(walk).missing_count(), 27);
}
