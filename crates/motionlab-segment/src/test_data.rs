//! Real recordings for the segmenters' tests (loaded with motionlab-io, a dev-dependency).

use motionlab_core::registry::build_preprocessor;
use motionlab_core::{Axis, FrameRate, Motion};

/// A shipped recording: `*.amc.gz` (ASF found by the loader's rule, 120 fps) or a Qualisys
/// `*.tsv.gz`, to which a `root` marker is added at the centroid of the four hip markers (the
/// MoCap Toolbox marker set has none).
pub fn load(relative: &str) -> Motion {
    let path = motionlab_testkit::data_path(relative);
    if relative.contains(".amc") {
        let asf = motionlab_io::asf_amc::asf_candidates(&path)
            .into_iter()
            .find(|p| p.exists())
            .expect("ASF next to the AMC");
        motionlab_io::asf_amc::load_asf_amc(&path, &asf, FrameRate::new(120.0).unwrap()).unwrap()
    } else {
        let text = motionlab_io::read::read_text(&path).unwrap();
        let m = motionlab_io::qualisys_tsv::parse_qualisys_tsv(&text, &path, Axis::Z).unwrap();
        let p: toml::Value = toml::from_str(
            "name = \"root\"\nmarkers = [\"Hip_FL\", \"Hip_FR\", \"Hip_BL\", \"Hip_BR\"]",
        )
        .unwrap();
        build_preprocessor("add_centroid", &p).unwrap().apply(m).unwrap()
    }
}

/// `data/mct/walk1.tsv.gz` with its root; it has 27 missing samples (Head_FR at frames
/// 199–209, Shoulder_R at 304–319).
pub fn walk1() -> Motion {
    let m = load("mct/walk1.tsv.gz");
    assert_eq!(m.missing_count(), 27);
    m
}

/// Boundary frames (0-based) of `data/cmu86/86_01` from `mocap.txt` (1-based `b` column).
pub fn cmu86_01_boundaries() -> Vec<usize> {
    let text = std::fs::read_to_string(motionlab_testkit::data_path("cmu86/mocap.txt")).unwrap();
    text.lines()
        .skip_while(|l| l.trim() != "86 01")
        .skip(1)
        .take_while(|l| !l.trim().is_empty())
        .filter_map(|l| l.split_whitespace().nth(2)?.parse::<usize>().ok())
        .filter(|&b| b < 4579)
        .map(|b| b - 1)
        .collect()
}

#[test]
fn plugins_of_this_work_are_registered_and_documented() {
    // Link the feature crate's plugins too (named through a function of each module).
    let _ = motionlab_features::hull::convex_hull_volume(&[]);
    let mine = [
        "root_curvature",
        "hull_volume",
        "add_centroid",
        "fastest_marker_speed",
        "direction_change",
        "hull_volume_change",
        "pca_error_rise",
        "union_merge",
    ];
    let names: Vec<&str> = motionlab_core::registry::plugins().iter().map(|p| p.name).collect();
    for m in mine {
        assert!(names.contains(&m), "{m} is not registered: {names:?}");
    }
    let problems: Vec<String> = motionlab_core::registry::check_registry()
        .into_iter()
        .filter(|p| mine.iter().any(|m| p.contains(&format!("{m:?}"))))
        .collect();
    assert!(problems.is_empty(), "{problems:#?}");
}
