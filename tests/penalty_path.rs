//! A run with `kernel_cpd`'s penalty path writes the path: the table `penalty_path` (every
//! segmentation with its penalty interval, cost, number of change points, the chosen one
//! flagged) and a figure per sequence — on a hand-made series of three clear steps.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::own_annotations::read_table;

fn motionlab() -> Command {
    crate::motionlab_command()
}

/// 400 samples: levels 0, 1.5, 0.5, 3 for 100 samples each, plus a deterministic ripple
/// (no random generator: the test's answer must not move with a crate's version).
fn steps(dir: &Path) -> PathBuf {
    let text: String = (0..400)
        .map(|i| {
            let ripple = ((i * 7919) % 101) as f64 / 101.0 * 0.6 + 0.3 * (i as f64 * 0.7).sin();
            format!("{}\n", [0.0, 1.5, 0.5, 3.0][i / 100] + ripple)
        })
        .collect();
    let path = dir.join("steps.txt");
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn a_run_on_the_path_writes_its_table_and_figure_with_the_chosen_segmentation() {
    let tmp = tempfile::tempdir().unwrap();
    let series = steps(tmp.path());
    let experiment = tmp.path().join("path.toml");
    std::fs::write(
        &experiment,
        format!(
            "[experiment]\nname = \"penalty_path_toy\"\n\n[[dataset]]\nfiles = [{:?}]\nloader = {{ type = \"channels\", rate_hz = 1.0 }}\n\n\
             [segmentation]\nfigures = []\n\n[[segmentation.segmenter]]\ntype = \"kernel_cpd\"\nname = \"crops\"\n\
             search = \"pelt\"\ncost = \"l2\"\njump = 1\npenalty = {{ path = [0.05, 400.0], choose = \"elbow\" }}\n\n\
             [[segmentation.segmenter]]\ntype = \"kernel_cpd\"\nname = \"single\"\nsearch = \"pelt\"\ncost = \"l2\"\njump = 1\npen = 2.0\n",
            series.to_string_lossy()
        ),
    )
    .unwrap();
    let reports = tmp.path().join("reports");
    let out = motionlab()
        .args(["run", experiment.to_str().unwrap(), "--quiet", "--reports"])
        .arg(&reports)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let run = PathBuf::from(String::from_utf8_lossy(&out.stdout).split(": ").next().unwrap());
    let path = read_table(&run.join("tables/penalty_path.csv"));
    // Only the method on a path has rows.
    assert!(path.iter().all(|r| r["method"] == "crops" && r["sequence"] == "steps"));
    assert!(path.len() >= 3, "{path:?}");
    let num = |r: &std::collections::BTreeMap<String, String>, c: &str| -> f64 {
        r[c].parse().unwrap_or_else(|_| panic!("{c}: {:?}", r[c]))
    };
    // The range, contiguous intervals, ever more change points and lower cost.
    assert_eq!((num(&path[0], "pen_max"), num(&path[path.len() - 1], "pen_min")), (400.0, 0.05));
    for w in path.windows(2) {
        assert_eq!(num(&w[0], "pen_min"), num(&w[1], "pen_max"));
        assert!(num(&w[1], "n_changes") > num(&w[0], "n_changes"));
        assert!(num(&w[1], "cost") < num(&w[0], "cost"));
    }
    for r in &path {
        let listed = r["change_points"].split_whitespace().count();
        assert_eq!(listed as f64, num(r, "n_changes"), "{r:?}");
    }
    // One chosen: the three steps (the elbow), and the method's candidates are its points.
    let chosen: Vec<_> = path.iter().filter(|r| r["chosen"] == "true").collect();
    assert_eq!(chosen.len(), 1, "{path:?}");
    let found: Vec<usize> =
        chosen[0]["change_points"].split_whitespace().map(|c| c.parse().unwrap()).collect();
    assert_eq!(found.len(), 3, "{found:?}");
    for (f, want) in found.iter().zip([100, 200, 300]) {
        assert!(f.abs_diff(want) <= 3, "{found:?}");
    }
    let candidates: Vec<usize> = read_table(&run.join("tables/candidates.csv"))
        .iter()
        .filter(|r| r["method"] == "crops")
        .map(|r| r["frame"].parse().unwrap())
        .collect();
    assert_eq!(candidates, found);
    // The figure (PNG and SVG): one per sequence and method on a path, none for the single
    // penalty.
    let figures: Vec<String> = std::fs::read_dir(run.join("figures"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains("penalty_path") && n.ends_with(".png"))
        .collect();
    assert_eq!(figures, ["steps_crops_penalty_path.png"]);
}
