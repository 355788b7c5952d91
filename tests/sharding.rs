//! Sharded runs: `--shard i/n` into one run directory, then `merge`, gives exactly the
//! tables of a plain run; a missing shard and a shard of another configuration are refused.

use std::path::{Path, PathBuf};
use std::process::Command;

fn motionlab() -> Command {
    let mut c = crate::motionlab_command();
    c.current_dir(motionlab_testkit::repo_root());
    c
}

const EXP: &str = "tests/slurm/sweep.toml";

fn ok(c: &mut Command) -> String {
    let out = c.output().unwrap();
    assert!(out.status.success(), "{:?}: {}", c, String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn tables(run: &Path) -> Vec<(String, String)> {
    let mut v: Vec<(String, String)> = std::fs::read_dir(run.join("tables"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "csv" || e == "md"))
        .map(|p| {
            (
                p.file_name().unwrap().to_string_lossy().into_owned(),
                std::fs::read_to_string(&p).unwrap(),
            )
        })
        .collect();
    v.sort();
    v
}

fn run_shard(dir: &Path, i: usize, n: usize, extra: &[&str]) {
    let shard = format!("{i}/{n}");
    let mut c = motionlab();
    c.args(["run", EXP]).args(extra).args([
        "--quiet",
        "--shard",
        &shard,
        "--run-dir",
        dir.to_str().unwrap(),
    ]);
    ok(&mut c);
}

#[test]
fn three_shards_then_merge_equal_a_plain_run() {
    let tmp = tempfile::tempdir().unwrap();
    let reports = tmp.path().join("reports");
    let out = ok(motionlab().args(["run", EXP, "--quiet", "--reports", reports.to_str().unwrap()]));
    let plain = PathBuf::from(out.split(": ").next().unwrap());
    let sharded = tmp.path().join("sharded");
    for i in [2, 0, 1] {
        run_shard(&sharded, i, 3, &[]);
    }
    ok(motionlab().args(["merge", "--quiet", sharded.to_str().unwrap()]));
    let (a, b) = (tables(&plain), tables(&sharded));
    assert!(!a.is_empty());
    assert_eq!(a, b, "merged tables must equal the plain run's, cell for cell");
    // Viewer pages (one per sequence of the base combination) are the same too, and linked.
    let viewers = |run: &Path| -> Vec<(String, Vec<u8>)> {
        let mut v: Vec<_> = std::fs::read_dir(run.join("viewers"))
            .unwrap()
            .map(|e| e.unwrap().path())
            .map(|p| {
                (p.file_name().unwrap().to_string_lossy().into_owned(), std::fs::read(&p).unwrap())
            })
            .collect();
        v.sort();
        v
    };
    let (va, vb) = (viewers(&plain), viewers(&sharded));
    assert_eq!(va.iter().map(|v| v.0.as_str()).collect::<Vec<_>>(), ["dance1.html", "walk1.html"]);
    assert!(va == vb, "merged viewers must equal the plain run's");
    let page = std::fs::read_to_string(plain.join("index.html")).unwrap().replace("&#x2f;", "/");
    assert!(page.contains("href=\"viewers/dance1.html\""), "the run page links its viewers");
    // Shards never wrote the same item twice: 6 items, each once.
    let items = std::fs::read_dir(sharded.join("items"))
        .unwrap()
        .filter(|e| e.as_ref().unwrap().path().extension().is_some_and(|x| x == "msgpack"))
        .count();
    assert_eq!(items, 6);
}

#[test]
fn a_missing_shard_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    run_shard(&dir, 0, 3, &[]);
    run_shard(&dir, 2, 3, &[]);
    let out = motionlab().args(["merge", "--quiet", dir.to_str().unwrap()]).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("shard(s) 1 of 3 have not finished"), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
}

#[test]
fn a_shard_from_another_configuration_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    run_shard(&dir, 0, 2, &["segmentation.segmenter[0].smoothing={ frames = 3 }"]);
    run_shard(&dir, 1, 2, &[]);
    let out = motionlab().args(["merge", "--quiet", dir.to_str().unwrap()]).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("was produced by a different configuration"), "{err}");
    assert!(err.contains("shard-0-of-2.json"), "the error names the odd shard: {err}");
}
