//! End-to-end tests of the `motionlab` binary.

use std::path::PathBuf;
use std::process::Command;

fn motionlab() -> Command {
    crate::motionlab_command()
}

fn repo() -> PathBuf {
    motionlab_testkit::repo_root()
}

#[test]
fn list_and_describe_print_plugins_from_their_docs() {
    let out = motionlab().arg("list").output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("speed_minima"), "{text}");
    let out = motionlab().args(["describe", "speed_minima"]).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("argue *against*") && text.contains("v_low"), "{text}");
    let out = motionlab().args(["describe", "speed_minimum"]).output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("did you mean \"speed_minima\""), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    // Defaults come from serde (`default 0`), or — decided at run time — the field's
    // `x-default` note; never from prose in the description.
    let out = motionlab().args(["describe", "boundaries_csv"]).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("first_frame : integer  (default 0)"), "{text}");
    assert!(text.contains("frame_rate_hz : float (optional)  (default: the motion's own rate (frames are motion frames))"), "{text}");
    // Defaults tuned on data name it: the Sonoda stages list their seven takes' digests (86_01
    // first); a plugin with untuned defaults lists none.
    let out = motionlab().args(["describe", "fastest_marker_speed"]).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("Defaults tuned on 7 input file(s) (SHA-256):\n  f3d98b96940de9107bc9bfa5a5ecec2a029cdb45713e333d7bc69a0893cfac07\n"), "{text}");
    let out = motionlab().args(["describe", "pca_error_rise"]).output().unwrap();
    assert!(!String::from_utf8_lossy(&out.stdout).contains("Defaults tuned on"));
    let _ = repo();
}

#[test]
fn list_and_describe_print_workflows_from_their_section_docs() {
    let out = motionlab().arg("list").output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    for section in ["[features]", "[segmentation]", "[matching]", "[gait]"] {
        assert!(text.contains(section), "{section} missing from:\n{text}");
    }
    let out = motionlab().args(["describe", "gait"]).output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    // The section struct's doc comment, and its keys with their own docs and defaults.
    assert!(text.contains("[gait] (workflow, from motionlab-workflows)"), "{text}");
    assert!(
        text.contains("Osafune")
            && text.contains("normal_condition")
            && text.contains("default \"condition\""),
        "{text}"
    );
}

/// Runs motionlab with `args` from the repository root; returns (exit code, stdout, stderr).
fn run_in_repo(args: &[&str]) -> (i32, String, String) {
    let out = motionlab().args(args).current_dir(repo()).output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Bad input gives one line naming the file and the line/field, a non-zero exit, and no panic.
fn assert_one_line_error(args: &[&str], file: &str, place: &str, expect: &str) {
    let (code, _, err) = run_in_repo(args);
    assert_eq!(code, 1, "{args:?}: {err}");
    let err = err.trim();
    assert_eq!(err.lines().count(), 1, "{args:?}: more than one line: {err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(err.starts_with("error: ") && err.contains(file), "{args:?}: {err}");
    assert!(err.contains(place), "{args:?}: expected {place:?} in {err}");
    assert!(err.contains(expect), "{args:?}: expected {expect:?} in {err}");
}

#[test]
fn malformed_motion_files_fail_with_one_located_line() {
    let m = "tests/fixtures/malformed/";
    assert_one_line_error(
        &["inspect", &format!("{m}truncated.bvh")],
        "truncated.bvh",
        ":198:",
        "Frames: 994",
    );
    assert_one_line_error(
        &["inspect", &format!("{m}wrong_value_count.bvh")],
        "wrong_value_count.bvh",
        ":191:",
        "found 95 values, expected 96",
    );
    assert_one_line_error(
        &["inspect", &format!("{m}cut_in_hierarchy.bvh")],
        "cut_in_hierarchy.bvh",
        ":41:",
        "RightHip",
    );
    assert_one_line_error(
        &["inspect", &format!("{m}86_unknown_bone.amc")],
        "86_unknown_bone.amc",
        ":60:",
        "\"lfemurx\"",
    );
    assert_one_line_error(
        &["inspect", &format!("{m}short_row.tsv")],
        "short_row.tsv",
        ":13:",
        "expected 3 × 28 markers = 84",
    );
    assert_one_line_error(
        &["inspect", &format!("{m}corrupt_header.c3d")],
        "corrupt_header.c3d",
        "(byte 1)",
        "expected 0x50",
    );
}

#[test]
fn bad_experiments_fail_validation_with_one_located_line() {
    let m = "tests/fixtures/malformed/";
    assert_one_line_error(
        &["validate", &format!("{m}unknown_key.toml")],
        "unknown_key.toml",
        ":7: dataset[0].frame_rate",
        "unknown field `frame_rate`",
    );
    assert_one_line_error(
        &["validate", &format!("{m}unknown_plugin.toml")],
        "unknown_plugin.toml",
        ":10: segmentation.segmenter[0].type",
        "no segmenter named \"fastest_marker_sped\"",
    );
    assert_one_line_error(
        &["validate", &format!("{m}wrong_type.toml")],
        "wrong_type.toml",
        ":11: segmentation.segmenter[0].v_low",
        "expected `mm_per_s` or `fraction_of_p90`",
    );
    assert_one_line_error(
        &["validate", &format!("{m}unknown_param.toml")],
        "unknown_param.toml",
        ":9: features.extractors[0].per_markers",
        "unknown field `per_markers`",
    );
    // A parameter of the wrong type given as an override names the override.
    assert_one_line_error(
        &["validate", "experiments/quickstart.toml", "features.extractors[0].per_marker=7"],
        "quickstart.toml",
        "features.extractors[0].per_marker",
        "invalid type: integer `7`, expected a boolean",
    );
    // A misspelt figure name is refused before anything runs (it would otherwise draw nothing).
    assert_one_line_error(
        &[
            "validate",
            "experiments/sonoda_sweep.toml",
            "segmentation.figures=[\"timeline\", \"root_paths\"]",
        ],
        "sonoda_sweep.toml",
        "segmentation.figures",
        "unknown variant `root_paths`, expected one of `traces`, `root_path`, `timeline`, `timeline_poses`, `stick_strip`",
    );
}

#[test]
fn quickstart_writes_a_table_and_figure_into_a_fresh_run_directory_each_time() {
    let reports = tempfile::tempdir().unwrap();
    let r = reports.path().to_str().unwrap();
    let (code, out, err) =
        run_in_repo(&["run", "experiments/quickstart.toml", "--reports", r, "--quiet"]);
    assert_eq!(code, 0, "{err}");
    let (code2, out2, _) =
        run_in_repo(&["run", "experiments/quickstart.toml", "--reports", r, "--quiet"]);
    assert_eq!(code2, 0);
    assert_ne!(out, out2, "two runs, two directories");
    let runs: Vec<PathBuf> = std::fs::read_dir(reports.path().join("quickstart"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_dir())
        .collect();
    assert_eq!(runs.len(), 2, "{runs:?}");
    let latest = std::fs::read_to_string(reports.path().join("quickstart/latest")).unwrap();
    for run in &runs {
        let csv = std::fs::read_to_string(run.join("tables/dance1_features.csv")).unwrap();
        let mut lines = csv.lines();
        assert_eq!(lines.next(), Some("frame,time_s,V_mm_per_s,fastest_marker"));
        assert_eq!(lines.count(), 1500, "one row per frame of dance1");
        assert!(
            run.join("figures/dance1_marker_speed.png").is_file()
                && run.join("figures/dance1_marker_speed.svg").is_file()
        );
        assert!(
            run.join("provenance.json").is_file()
                && run.join("config.toml").is_file()
                && run.join("index.html").is_file()
        );
    }
    assert!(runs.iter().any(|r| r.ends_with(latest.trim())));
}

#[test]
fn inspect_describes_real_files() {
    let (code, out, err) =
        run_in_repo(&["inspect", "data/mct/walk1.c3d.gz", "data/cmu131/131_01.bvh.gz"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("missing   27 samples"), "{out}");
    assert!(out.contains("frames    994 at 120 Hz"), "{out}");
    // One bad file among good ones: the good ones are still described, the exit is non-zero.
    let (code, out, err) = run_in_repo(&[
        "inspect",
        "data/mct/walk1.tsv.gz",
        "tests/fixtures/malformed/short_row.tsv",
    ]);
    assert_eq!(code, 1);
    assert!(out.contains("walk1.tsv.gz") && err.contains("short_row.tsv:13"), "{out}\n{err}");
}
