//! Safe outputs: an interrupted run (`kill -9`) never leaves a run directory that looks
//! complete, and concurrent runs of one experiment get distinct, complete directories.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

fn motionlab() -> Command {
    let mut c = crate::motionlab_command();
    c.current_dir(motionlab_testkit::repo_root());
    c
}

/// Visible run directories (hidden `.…partial` folders are work in progress by design).
fn visible_runs(exp_dir: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(exp_dir)
        .map(|r| {
            r.map(|e| e.unwrap().path())
                .filter(|p| {
                    p.is_dir() && !p.file_name().unwrap().to_string_lossy().starts_with('.')
                })
                .collect()
        })
        .unwrap_or_default()
}

fn is_complete(run: &Path) -> bool {
    run.join("provenance.json").is_file()
        && run.join("index.html").is_file()
        && run.join("tables").is_dir()
}

#[test]
fn kill_9_mid_run_leaves_no_directory_that_looks_complete() {
    let tmp = tempfile::tempdir().unwrap();
    let reports = tmp.path().join("reports");
    // A sweep with many items, one thread: long enough to be killed mid-way.
    let delays = [150u64, 400, 800, 1500];
    for (k, ms) in delays.iter().enumerate() {
        let mut child = motionlab()
            .args([
                "run",
                "tests/slurm/sweep.toml",
                "--quiet",
                "--threads",
                "1",
                "--reports",
                reports.to_str().unwrap(),
            ])
            .args(["segmentation.segmenter[0].smoothing={ frames = 3 }"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        std::thread::sleep(Duration::from_millis(*ms));
        child.kill().unwrap(); // SIGKILL on Unix
        child.wait().unwrap();
        let exp = reports.join("shard_sweep");
        for run in visible_runs(&exp) {
            assert!(
                is_complete(&run),
                "after kill -9 at {ms} ms (attempt {k}), {} looks like a run but is incomplete",
                run.display()
            );
        }
        if let Ok(latest) = std::fs::read_to_string(exp.join("latest")) {
            assert!(is_complete(&exp.join(latest.trim())), "latest names an incomplete run");
        }
    }
    // The kills did land mid-run (otherwise this test would prove nothing): their work is left
    // in hidden `.…partial` folders, which never look like runs.
    let partial = std::fs::read_dir(reports.join("shard_sweep"))
        .unwrap()
        .filter(|e| e.as_ref().unwrap().file_name().to_string_lossy().ends_with(".partial"))
        .count();
    assert!(partial >= 1, "no kill interrupted a run; lengthen the experiment");
}

#[test]
fn concurrent_runs_get_distinct_complete_directories() {
    let tmp = tempfile::tempdir().unwrap();
    let reports = tmp.path().join("reports");
    let children: Vec<_> = (0..4)
        .map(|_| {
            motionlab()
                .args([
                    "run",
                    "experiments/quickstart.toml",
                    "--quiet",
                    "--threads",
                    "1",
                    "--reports",
                    reports.to_str().unwrap(),
                ])
                .stdout(Stdio::piped())
                .spawn()
                .unwrap()
        })
        .collect();
    let mut dirs = Vec::new();
    for c in children {
        let out = c.wait_with_output().unwrap();
        assert!(out.status.success());
        dirs.push(String::from_utf8_lossy(&out.stdout).split(": ").next().unwrap().to_string());
    }
    dirs.sort();
    dirs.dedup();
    assert_eq!(dirs.len(), 4, "four runs, four directories: {dirs:?}");
    let runs = visible_runs(&reports.join("quickstart"));
    assert_eq!(runs.len(), 4);
    assert!(runs.iter().all(|r| is_complete(r)));
}
