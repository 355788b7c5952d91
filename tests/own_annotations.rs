//! Bringing one's own annotated mocap: the users' annotation readers give exactly
//! the results of the datasets' own readers on the same run, C3D files with different Vicon
//! subject prefixes load into one experiment by plain marker names, and `motionlab new`
//! scaffolds an experiment that validates and runs.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use motionlab_core::registry;
use motionlab_core::{ErrorKind, Motion};

// Link the plugin crates so the registry holds their loaders and readers.
use motionlab_eval as _;
use motionlab_features as _;
use motionlab_io as _;

fn repo() -> PathBuf {
    motionlab_testkit::repo_root()
}

/// Runs motionlab from the repository root; panics with its stderr when it fails.
pub(crate) fn motionlab_ok(args: &[&str]) -> String {
    let out = crate::motionlab_command().args(args).current_dir(repo()).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "motionlab {args:?} failed: {err}");
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The single run directory under `reports/<experiment>/`.
pub(crate) fn run_dir(reports: &Path, experiment: &str) -> PathBuf {
    let runs: Vec<PathBuf> = std::fs::read_dir(reports.join(experiment))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_dir())
        .collect();
    assert_eq!(runs.len(), 1, "{runs:?}");
    runs[0].clone()
}

/// A CSV table as rows of column → cell.
pub(crate) fn read_table(path: &Path) -> Vec<BTreeMap<String, String>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().unwrap().split(',').map(str::to_string).collect();
    lines.map(|l| header.iter().cloned().zip(l.split(',').map(str::to_string)).collect()).collect()
}

/// `own_truth_equality.toml` runs 86_01 with `cmu86_labels`, with the same labels as a
/// `boundaries_csv` of segments and as an `elan_eaf` tier, and 13_29 with `mocap6_labels` and
/// as the CSV (fixtures from `tests/fixtures/annotations/make.py`): every method's counts,
/// precision, recall and F1 agree exactly.
#[test]
fn csv_and_elan_truth_give_the_precision_recall_of_the_datasets_own_readers() {
    let reports = tempfile::tempdir().unwrap();
    let r = reports.path().to_str().unwrap();
    motionlab_ok(&[
        "run",
        "tests/fixtures/annotations/own_truth_equality.toml",
        "--reports",
        r,
        "--quiet",
    ]);
    let rows = read_table(
        &run_dir(reports.path(), "own_truth_equality").join("tables/table1_precision_recall.csv"),
    );
    // Speed and hull run at their defaults, which were tuned on 86_01 and 13_29 among others
    // (`sonoda_defaults`): every row, pooled too, says it is scored on its tuning data.
    for r in rows.iter().filter(|r| r["method"] == "speed" || r["method"] == "hull") {
        let expected = if r["sequence"] == "pooled" {
            "every one of these sequences"
        } else {
            "this sequence"
        };
        assert_eq!(
            r["parameters_chosen"],
            format!("plugin defaults tuned on {expected} (oracle)"),
            "{r:?}"
        );
    }
    let pick = |seq: &str, method: &str| -> Vec<String> {
        let row = rows
            .iter()
            .find(|r| r["sequence"] == seq && r["method"] == method)
            .unwrap_or_else(|| panic!("{seq}/{method}"));
        ["n_truth", "n_found", "n_matched", "precision", "recall", "f1"]
            .iter()
            .map(|c| row[*c].clone())
            .collect()
    };
    let mut checked = 0;
    for method in ["speed", "direction", "hull", "fused"] {
        let reference = pick("86_01", method);
        assert_eq!(reference[0], "6", "86_01 has 6 labelled boundaries");
        assert_eq!(
            pick("86_01_csv", method),
            reference,
            "{method}: boundaries_csv vs cmu86_labels"
        );
        assert_eq!(pick("86_01_eaf", method), reference, "{method}: elan_eaf vs cmu86_labels");
        let reference = pick("13_29", method);
        assert_eq!(reference[0], "5", "13_29 has 5 labelled boundaries");
        assert_eq!(
            pick("13_29_csv", method),
            reference,
            "{method}: boundaries_csv vs mocap6_labels"
        );
        println!("86_01 {method}: {:?}; 13_29 {method}: {:?}", pick("86_01", method), reference);
        checked += 1;
    }
    assert_eq!(checked, 4);
}

fn c3d(params: &str, path: &Path) -> motionlab_core::Result<Motion> {
    registry::build_loader("c3d", &toml::from_str(params).unwrap()).unwrap().load(path)
}

/// `dance1_vsk.c3d` / `dance1_vsk2.c3d` (tests/fixtures/prefixes/make.py): dance1's first 60
/// frames with every label prefixed `vsk:` / `vsk2:`.
#[test]
fn subject_prefixes_are_stripped_so_one_experiment_uses_plain_marker_names() {
    let dir = repo().join("tests/fixtures/prefixes");
    let original = c3d("", &repo().join("data/mct/dance1.c3d.gz")).unwrap();
    for file in ["dance1_vsk.c3d", "dance1_vsk2.c3d"] {
        let m = c3d("", &dir.join(file)).unwrap();
        assert_eq!(m.point_names(), original.point_names(), "{file}");
        assert_eq!(m.n_frames(), 60);
        for f in 0..60 {
            assert_eq!(m.frame(f), original.frame(f), "{file} frame {f}");
        }
        let kept = c3d("strip_subject_prefix = false", &dir.join(file)).unwrap();
        assert!(
            kept.point_names()[0].ends_with(":Head_FL")
                && kept.point_names()[0].len() > "Head_FL".len()
        );
        // An unknown marker still lists the closest (plain) names.
        let e = m.point_index("Hip_F").map(|_| ()).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::UnknownName);
        assert!(e.to_string().contains("Hip_FL"), "{e}");
    }
    // The experiment addresses Hip_FL … by plain names in both files.
    let reports = tempfile::tempdir().unwrap();
    let r = reports.path().to_str().unwrap();
    motionlab_ok(&["validate", "tests/fixtures/prefixes/plain_names.toml"]);
    motionlab_ok(&["run", "tests/fixtures/prefixes/plain_names.toml", "--reports", r, "--quiet"]);
    let tables = run_dir(reports.path(), "plain_names").join("tables");
    for stem in ["dance1_vsk", "dance1_vsk2"] {
        assert!(tables.join(format!("{stem}_features.csv")).is_file(), "{stem}");
    }
    // Without stripping, the plain names are unknown: one error naming the marker.
    let out = crate::motionlab_command()
        .args([
            "run",
            "tests/fixtures/prefixes/plain_names.toml",
            "--reports",
            r,
            "--quiet",
            "dataset[0].loader.strip_subject_prefix=false",
        ])
        .current_dir(repo())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("Hip_FL"), "{err}");
}

/// `motionlab new data/mct/ --truth <csv>` writes an experiment that validates and runs: the
/// C3D loader, the hip-centroid root, the annotated dances only, consensus of the two
/// annotators, and a precision/recall table.
#[test]
fn motionlab_new_scaffolds_an_experiment_that_validates_and_runs() {
    let out = tempfile::tempdir().unwrap();
    let toml_path = out.path().join("exp/mct.toml");
    let t = toml_path.to_str().unwrap();
    let said = motionlab_ok(&[
        "new",
        "data/mct/",
        "--truth",
        "tests/fixtures/annotations/mct_dances.csv",
        "-o",
        t,
    ]);
    assert!(said.contains("(valid)"), "{said}");
    let text = std::fs::read_to_string(&toml_path).unwrap();
    for expected in [
        "loader = { type = \"c3d\" }",
        "markers = [\"Hip_FL\", \"Hip_FR\", \"Hip_BL\", \"Hip_BR\"]",
        "# Not annotated, so left out: walk1, walk2.",
        "type = \"boundaries_csv\"",
        "consensus = {",
        "type = \"boundary_pr\"",
        "span = \"annotated\"",
    ] {
        assert!(text.contains(expected), "{expected:?} not in:\n{text}");
    }
    // It will not overwrite.
    let again = crate::motionlab_command()
        .args(["new", "data/mct/", "-o", t])
        .current_dir(repo())
        .output()
        .unwrap();
    assert!(!again.status.success() && String::from_utf8_lossy(&again.stderr).contains("--force"));
    motionlab_ok(&["validate", t]);
    let reports = out.path().join("reports");
    motionlab_ok(&["run", t, "--reports", reports.to_str().unwrap(), "--quiet"]);
    let rows = read_table(
        &run_dir(&reports, "mct_segmentation").join("tables/table1_precision_recall.csv"),
    );
    let sequences: Vec<&str> =
        rows.iter().filter(|r| r["method"] == "fused").map(|r| r["sequence"].as_str()).collect();
    assert_eq!(sequences, vec!["dance1", "dance2", "pooled"]);
    // The MoCap Toolbox dances are not among the takes the Sonoda defaults were tuned on.
    let speed: Vec<&str> = rows
        .iter()
        .filter(|r| r["method"] == "speed")
        .map(|r| r["parameters_chosen"].as_str())
        .collect();
    assert_eq!(speed, vec!["plugin defaults tuned on other data (held-out)"; 3]);
    // The viewer's band around each truth is the tolerance that judged it: the 0.5 s the
    // scaffold writes is 30 frames at dance1's 60 Hz.
    assert_eq!(
        truth_band_frames(&run_dir(&reports, "mct_segmentation"), "dance1.html"),
        Some(30.0)
    );

    // With boundary_pr's tolerance left to its default (1/12 s: 5 frames at 60 Hz), the band
    // follows it too; it used to be drawn only when the TOML named a `tolerance`.
    let defaulted = out.path().join("exp/mct_default_tolerance.toml");
    std::fs::write(
        &defaulted,
        text.replace("tolerance = { seconds = 0.5 }", "")
            .replace("name = \"mct_segmentation\"", "name = \"mct_default\""),
    )
    .unwrap();
    motionlab_ok(&[
        "run",
        defaulted.to_str().unwrap(),
        "--reports",
        reports.to_str().unwrap(),
        "--quiet",
    ]);
    let run = run_dir(&reports, "mct_default");
    let rows = read_table(&run.join("tables/table1_precision_recall.csv"));
    assert!(
        rows.iter().filter(|r| r["sequence"] == "dance1").all(|r| r["tolerance_frames"] == "5.0"),
        "{rows:?}"
    );
    assert_eq!(truth_band_frames(&run, "dance1.html"), Some(5.0));
}

/// `tolerance_frames` of the "ground truth" lane of a segmentation viewer page.
fn truth_band_frames(run: &Path, page: &str) -> Option<f64> {
    let pages = motionlab_testkit::viewer_pages(run);
    let meta = &pages.iter().find(|p| p.0 == page).unwrap_or_else(|| panic!("no viewer {page}")).1;
    motionlab_testkit::viewer_lane(meta, "ground truth")["tolerance_frames"].as_f64()
}
