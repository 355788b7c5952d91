//! Video pose estimation end to end through the command: `inspect` on an OpenPose frame folder,
//! COCO and MediaPipe files; `motionlab new` + `run` on a folder of OpenPose frame folders with
//! a truth CSV, as on C3D and TRC; validation refusing a 2-D dataset to a stage that needs
//! depth with one line, and running those that do not (speeds in px/s, channel segmenters).

use crate::own_annotations::{motionlab_ok, read_table, run_dir};

fn repo(p: &str) -> String {
    motionlab_testkit::repo_root().join(p).to_str().unwrap().to_string()
}

const OPENPOSE: &str = "data/formats/pose2sim/openpose_balancing_cam01_json";

#[test]
fn inspect_describes_keypoint_files_as_2d_at_an_unknown_rate() {
    let said = motionlab_ok(&[
        "inspect",
        &repo(OPENPOSE),
        &repo("data/formats/mmpose-coco/test_coco.json"),
        &repo("data/formats/mediapipe/pose_landmarks.pbtxt"),
    ]);
    for expected in [
        "format    openpose",
        "frames    100 at an unknown rate (the openpose format stores none; give the loader rate_hz)",
        "space     2-D image positions (px, x right, y down), with a confidence per sample",
        "unit      pixels (2-D image coordinates); layout: 25 keypoints: BODY_25",
        "repaired  100 of 100 frames hold several people: one chosen per frame by highest mean confidence",
        "format    coco_keypoints",
        "frames    4 at an unknown rate",
        "format    mediapipe",
        "markers   33: nose left_eye_inner",
    ] {
        assert!(said.contains(expected), "{expected:?} not in:\n{said}");
    }
}

/// Two OpenPose frame folders (the Pose2Sim camera's 100 frames split in two takes) with a
/// truth CSV: `new` picks the `openpose` loader for the folders, writes the rate it assumes
/// and only the speed method (2-D); the experiment validates and runs to its precision/recall
/// table, whose speed traces are in px/s.
#[test]
fn new_and_run_on_a_folder_of_openpose_frame_folders() {
    let tmp = tempfile::tempdir().unwrap();
    let folder = tmp.path().join("videos");
    let src = motionlab_testkit::repo_root().join(OPENPOSE);
    for (take, range) in [("take_a", 0..50), ("take_b", 50..100)] {
        let dir = folder.join(take);
        std::fs::create_dir_all(&dir).unwrap();
        for k in range {
            let name = format!("cam01.{k:04}.json");
            std::fs::copy(src.join(&name), dir.join(&name)).unwrap();
        }
    }
    std::fs::write(
        folder.join("truth.csv"),
        "sequence,time_s,label,annotator\ntake_a,0.4,shift,a\ntake_b,0.5,shift,a\n",
    )
    .unwrap();
    let toml = tmp.path().join("videos.toml");
    let said = motionlab_ok(&[
        "new",
        folder.to_str().unwrap(),
        "--truth",
        folder.join("truth.csv").to_str().unwrap(),
        "-o",
        toml.to_str().unwrap(),
    ]);
    assert!(said.contains("(valid)"), "{said}");
    let text = std::fs::read_to_string(&toml).unwrap();
    assert!(text.contains("loader = { type = \"openpose\", rate_hz = 30.0 }"), "{text}");
    assert!(text.contains("store no frame rate: 30 is assumed"), "{text}");
    assert!(text.contains("fuse = [\"speed\"]") && !text.contains("hull_volume_change"), "{text}");
    let reports = tmp.path().join("reports");
    motionlab_ok(&[
        "run",
        toml.to_str().unwrap(),
        "--reports",
        reports.to_str().unwrap(),
        "--quiet",
    ]);
    let name = toml::from_str::<toml::Table>(&text).unwrap()["experiment"]["name"]
        .as_str()
        .unwrap()
        .to_string();
    let rows = read_table(&run_dir(&reports, &name).join("tables/table1_precision_recall.csv"));
    let mut sequences: Vec<&str> =
        rows.iter().filter(|r| r["method"] == "fused").map(|r| r["sequence"].as_str()).collect();
    sequences.sort();
    assert_eq!(sequences, ["pooled", "take_a", "take_b"]);
}

fn experiment(dir: &std::path::Path, segmenters: &str) -> std::path::PathBuf {
    let toml = dir.join("x.toml");
    std::fs::write(
        &toml,
        format!(
            "[experiment]\nname = \"pose_2d\"\n\n[[dataset]]\nfiles = [\"{}\"]\nloader = {{ type = \"openpose\", rate_hz = 60.0, model = \"body_25b\" }}\n\n[segmentation]\nroot = \"Neck\"\n\n{segmenters}",
            repo(OPENPOSE)
        ),
    )
    .unwrap();
    toml
}

#[test]
fn validation_refuses_a_2d_dataset_to_stages_that_need_depth_in_one_line() {
    let tmp = tempfile::tempdir().unwrap();
    for (segmenter, stage) in [
        ("type = \"hull_volume_change\"", "hull_volume_change"),
        ("type = \"direction_change\"", "direction_change"),
        (
            "type = \"kernel_cpd\"\ninput = { features = [{ type = \"hull_volume\" }] }",
            "hull_volume",
        ),
    ] {
        let toml = experiment(tmp.path(), &format!("[[segmentation.segmenter]]\n{segmenter}\n"));
        let out =
            crate::motionlab_command().args(["validate", toml.to_str().unwrap()]).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{stage} validated on 2-D data");
        let line = format!(
            "{stage} needs 3-D positions, and dataset[0] (loader `openpose`) gives 2-D image positions (px)"
        );
        assert!(err.contains(&line), "{line:?} not in: {err}");
        assert_eq!(err.trim_end().lines().filter(|l| l.contains("needs 3-D")).count(), 1, "{err}");
    }
    // Speeds (px/s) and a channel segmenter on them run.
    let toml = experiment(
        tmp.path(),
        "[[segmentation.segmenter]]\ntype = \"fastest_marker_speed\"\n\n[[segmentation.segmenter]]\ntype = \"kernel_cpd\"\ninput = { features = [{ type = \"marker_speed\" }] }\n",
    );
    let reports = tmp.path().join("reports");
    motionlab_ok(&[
        "run",
        toml.to_str().unwrap(),
        "--reports",
        reports.to_str().unwrap(),
        "--quiet",
    ]);
}
