//! The `[retrieval]` workflow end to end: the experiment of record finds the model's
//! own stretch first, its pruned search lists exactly what matching every window lists, and an
//! empty corpus glob or a bad key is one clear error.

use std::path::{Path, PathBuf};
use std::process::Command;

fn motionlab() -> Command {
    let mut c = crate::motionlab_command();
    c.current_dir(motionlab_testkit::repo_root());
    c
}

fn run(args: &[&str], reports: &Path) -> PathBuf {
    let mut c = motionlab();
    c.args([
        "run",
        "experiments/yabe_retrieval.toml",
        "--quiet",
        "--reports",
        reports.to_str().unwrap(),
    ])
    .args(args);
    let out = c.output().unwrap();
    assert!(out.status.success(), "{c:?}: {}", String::from_utf8_lossy(&out.stderr));
    PathBuf::from(String::from_utf8_lossy(&out.stdout).split(": ").next().unwrap())
}

fn table(run: &Path, name: &str) -> String {
    std::fs::read_to_string(run.join("tables").join(format!("{name}.csv"))).unwrap()
}

#[test]
fn the_pruned_search_lists_what_matching_every_window_lists_on_the_real_corpus() {
    let tmp = tempfile::tempdir().unwrap();
    let pruned = run(&[], tmp.path());
    let exhaustive = run(&["retrieval.pruning=false"], tmp.path());
    let top = table(&pruned, "retrieval_top_k");
    assert_eq!(top, table(&exhaustive, "retrieval_top_k"), "the lists differ");
    let rows: Vec<Vec<&str>> = top.lines().map(|l| l.split(',').collect()).collect();
    let header = &rows[0];
    let col = |name: &str| {
        header.iter().position(|h| *h == name).unwrap_or_else(|| panic!("no column {name}"))
    };
    // 5 similar, 5 dissimilar.
    assert_eq!(rows.len(), 11, "{top}");
    // The model (13_30 frames 56..180) is in the corpus: found first, exactly, at H = 0.
    let first = &rows[1];
    assert_eq!(
        (first[col("list")], first[col("rank")], first[col("take")]),
        ("similar", "1", "13_30")
    );
    assert_eq!((first[col("a_frame")], first[col("b_frame")]), ("56", "179"));
    assert_eq!(first[col("H_mm")].parse::<f64>().unwrap(), 0.0);
    // Every candidate the pruned search matched has the H the exhaustive search found.
    let cands = |run: &Path| -> Vec<Vec<String>> {
        table(run, "retrieval_candidates")
            .lines()
            .skip(1)
            .map(|l| l.split(',').map(str::to_string).collect())
            .collect()
    };
    let (p, e) = (cands(&pruned), cands(&exhaustive));
    assert_eq!(p.len(), e.len());
    let matched: Vec<usize> = (0..p.len()).filter(|&i| p[i][5] == "true").collect();
    // The dissimilar list needs most windows matched here (its upper bound is loose), the similar
    // list few (the unit tests and bench/retrieval_vs_peers.py measure each).
    assert!(matched.len() < p.len(), "pruning matched {} of {} windows", matched.len(), p.len());
    for i in matched {
        // a, b print as floats in the pruned table (unmatched windows leave them empty).
        let num =
            |row: &[String]| row[6..].iter().map(|v| v.parse::<f64>().unwrap()).collect::<Vec<_>>();
        assert_eq!(num(&p[i]), num(&e[i]), "candidate {i}");
    }
    let summary = table(&pruned, "retrieval_summary");
    assert!(summary.contains("bounds, best-first"), "{summary}");
}

#[test]
fn an_empty_corpus_glob_and_a_bad_key_are_one_clear_error() {
    let tmp = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(
        motionlab_testkit::repo_root().join("experiments/yabe_retrieval.toml"),
    )
    .unwrap();
    let data = motionlab_testkit::repo_root().join("data");
    let text = text
        .replace(
            "../data/mocap6/amc/13_30.amc.gz",
            &data.join("mocap6/amc/13_30.amc.gz").display().to_string(),
        )
        .replace("../data/**/*.amc.gz", &data.join("nothing/*.amc.gz").display().to_string());
    let exp = tmp.path().join("empty.toml");
    std::fs::write(&exp, text).unwrap();
    let out = motionlab().args(["validate", exp.to_str().unwrap()]).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("matches no file") && err.contains("nothing"), "{err}");
    let out = motionlab()
        .args(["validate", "experiments/yabe_retrieval.toml", "retrieval.simlar=3"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("yabe_retrieval.toml") && err.contains("simlar"), "{err}");
}
