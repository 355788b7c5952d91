//! The run cache: tables are byte-identical with and without the on-disk cache;
//! a warm run reads every load, segmenter output and evaluation from disk; changing one
//! segmenter parameter recomputes only that segmenter, the fuser and the evaluation; damaged
//! entries (a flipped byte, a truncation, two entries swapped) are recomputed, never trusted;
//! two concurrent processes share one cache; a process killed mid-write leaves no entry.

use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

const EXP: &str = "tests/cache/sweep.toml";

fn motionlab(cache: &Path) -> Command {
    let mut c = crate::motionlab_command();
    c.current_dir(motionlab_testkit::repo_root())
        .env("MOTIONLAB_CACHE_DIR", cache)
        .env_remove("MOTIONLAB_CACHE_TEST_PAUSE_MS");
    c
}

fn ok(c: &mut Command) -> String {
    let out = c.output().unwrap();
    assert!(out.status.success(), "{:?}: {}", c, String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Runs the sweep (with `extra` arguments) on one thread — so that which combination computes
/// a shared output first is fixed — and returns its run directory.
fn run(cache: &Path, reports: &Path, extra: &[&str]) -> PathBuf {
    let out = ok(motionlab(cache)
        .args(["run", EXP, "--quiet", "--threads", "1", "--reports", reports.to_str().unwrap()])
        .args(extra));
    PathBuf::from(out.split(": ").next().unwrap())
}

/// Every table file's bytes (CSV, Markdown, Parquet).
fn tables(run: &Path) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<(String, Vec<u8>)> = std::fs::read_dir(run.join("tables"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .map(|p| {
            (p.file_name().unwrap().to_string_lossy().into_owned(), std::fs::read(&p).unwrap())
        })
        .collect();
    v.sort();
    assert!(
        v.iter().any(|(n, _)| n == "boundary_pr.csv" || n.starts_with("boundary")),
        "tables: {:?}",
        v.iter().map(|t| &t.0).collect::<Vec<_>>()
    );
    v
}

/// One row of the provenance's cache record: combination, input, (stage, origin) pairs.
type OriginRow = (u64, String, Vec<(String, String)>);

/// `(combination, input) → {stage: origin}` from the run's provenance.
fn origins(run: &Path) -> Vec<OriginRow> {
    let p: Value =
        serde_json::from_slice(&std::fs::read(run.join("provenance.json")).unwrap()).unwrap();
    p["cache"]["stages"]
        .as_array()
        .unwrap()
        .iter()
        .map(|row| {
            let mut stages: Vec<(String, String)> = row
                .as_object()
                .unwrap()
                .iter()
                .filter(|(k, _)| *k != "combination" && *k != "input")
                .map(|(k, v)| (k.clone(), v.as_str().unwrap().to_string()))
                .collect();
            stages.sort();
            (
                row["combination"].as_u64().unwrap(),
                row["input"].as_str().unwrap().to_string(),
                stages,
            )
        })
        .collect()
}

/// The origin of `stage` in every combination.
fn stage_origins(run: &Path, stage: &str) -> Vec<String> {
    origins(run)
        .into_iter()
        .map(|(_, _, s)| {
            s.into_iter().find(|(k, _)| k == stage).map(|(_, v)| v).unwrap_or_default()
        })
        .collect()
}

fn entries(cache: &Path, kind: &str) -> Vec<PathBuf> {
    let mut v = Vec::new();
    for shard in std::fs::read_dir(cache.join(kind)).into_iter().flatten() {
        for f in std::fs::read_dir(shard.unwrap().path()).unwrap() {
            let p = f.unwrap().path();
            if p.extension().is_some_and(|e| e == "bin") {
                v.push(p);
            }
        }
    }
    v.sort();
    v
}

#[test]
fn cached_runs_equal_uncached_ones_and_a_changed_parameter_recomputes_only_its_segmenter() {
    let tmp = tempfile::tempdir().unwrap();
    let (cache, reports) = (tmp.path().join("cache"), tmp.path().join("reports"));
    let plain = run(&cache, &reports, &["--no-cache"]);
    assert!(!cache.exists(), "--no-cache writes nothing");
    // Load once per run: three combinations, one take, one load.
    let prov: Value =
        serde_json::from_slice(&std::fs::read(plain.join("provenance.json")).unwrap()).unwrap();
    assert_eq!(prov["cache"]["loads_from_files"], 1);
    assert_eq!(stage_origins(&plain, "load"), ["computed", "memory", "memory"]);

    let cold = run(&cache, &reports, &[]);
    let warm = run(&cache, &reports, &[]);
    assert_eq!(tables(&plain), tables(&cold), "a cold cache changes no table byte");
    assert_eq!(tables(&plain), tables(&warm), "a warm cache changes no table byte");
    assert_eq!(stage_origins(&cold, "load"), ["computed", "memory", "memory"]);
    // The direction segmenter is the same in every combination: computed once, then shared.
    assert_eq!(stage_origins(&cold, "segmenter direction"), ["computed", "disk", "disk"]);
    assert_eq!(stage_origins(&cold, "segmenter speed"), ["computed", "computed", "computed"]);
    assert_eq!(stage_origins(&warm, "load"), ["disk", "memory", "memory"]);
    assert_eq!(stage_origins(&warm, "segmenter speed"), ["disk", "disk", "disk"]);
    assert_eq!(stage_origins(&warm, "segmenter direction"), ["disk", "disk", "disk"]);
    assert_eq!(stage_origins(&warm, "fuser fused"), ["computed", "computed", "computed"]);
    assert_eq!(stage_origins(&cold, "evaluate boundary_pr"), ["computed", "computed", "computed"]);
    assert_eq!(stage_origins(&warm, "evaluate boundary_pr"), ["disk", "disk", "disk"]);
    assert_eq!(entries(&cache, "motion").len(), 1);
    assert_eq!(entries(&cache, "segmenter").len(), 4);

    // One segmenter parameter changed: only that segmenter, the fuser (never cached) and the
    // evaluation (its input, the fused candidates, changed) are recomputed.
    let changed = run(&cache, &reports, &["segmentation.segmenter[direction].lag={seconds=2.0}"]);
    for (c, input, stages) in origins(&changed) {
        let computed: Vec<&str> =
            stages.iter().filter(|(_, o)| o == "computed").map(|(s, _)| s.as_str()).collect();
        // The new direction output is computed once (combination 0) and shared from disk.
        let expected: &[&str] = if c == 0 {
            &["evaluate boundary_pr", "fuser fused", "segmenter direction"]
        } else {
            &["evaluate boundary_pr", "fuser fused"]
        };
        assert_eq!(computed, expected, "{input} combination {c}: {stages:?}");
    }
    let again = run(
        &cache,
        &reports,
        &["--no-cache", "segmentation.segmenter[direction].lag={seconds=2.0}"],
    );
    assert_eq!(tables(&changed), tables(&again));
    assert_ne!(tables(&changed), tables(&plain), "the parameter matters");

    // `cache info` and `cache clear`.
    let info = ok(motionlab(&cache).args(["cache", "info"]));
    assert!(info.contains("motion: 1 entries") && info.contains("segmenter: 5 entries"), "{info}");
    ok(motionlab(&cache).args(["cache", "clear"]));
    assert!(ok(motionlab(&cache).args(["cache", "info"])).contains("total: 0 entries"));
}

#[test]
fn damaged_entries_are_recomputed_never_trusted() {
    let tmp = tempfile::tempdir().unwrap();
    let (cache, reports) = (tmp.path().join("cache"), tmp.path().join("reports"));
    let reference = run(&cache, &reports, &[]);
    let motion = entries(&cache, "motion");
    let segs = entries(&cache, "segmenter");
    assert_eq!((motion.len(), segs.len()), (1, 4));
    // A flipped byte in the middle of the motion's positions.
    let mut bytes = std::fs::read(&motion[0]).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 0x40;
    std::fs::write(&motion[0], &bytes).unwrap();
    // A truncated segmenter output, and two others swapped.
    let b0 = std::fs::read(&segs[0]).unwrap();
    std::fs::write(&segs[0], &b0[..b0.len() - 3]).unwrap();
    let (b1, b2) = (std::fs::read(&segs[1]).unwrap(), std::fs::read(&segs[2]).unwrap());
    std::fs::write(&segs[1], &b2).unwrap();
    std::fs::write(&segs[2], &b1).unwrap();
    let after = run(&cache, &reports, &[]);
    assert_eq!(tables(&reference), tables(&after), "damaged entries must not change a table");
    assert_eq!(stage_origins(&after, "load"), ["computed", "memory", "memory"]);
    let computed = origins(&after)
        .iter()
        .flat_map(|(_, _, s)| {
            s.iter()
                .filter(|(k, o)| k.starts_with("segmenter") && o == "computed")
                .cloned()
                .collect::<Vec<_>>()
        })
        .count();
    assert_eq!(
        computed, 3,
        "the three damaged segmenter outputs are recomputed, the intact one read"
    );
    // Rewritten whole: a third run reads everything from disk again.
    let third = run(&cache, &reports, &[]);
    assert!(
        origins(&third)
            .iter()
            .all(|(_, _, s)| s.iter().all(|(k, o)| k.starts_with("fuser") || o != "computed"))
    );
}

#[test]
fn two_concurrent_processes_share_one_cache() {
    let tmp = tempfile::tempdir().unwrap();
    let (cache, reports) = (tmp.path().join("cache"), tmp.path().join("reports"));
    let reference = run(&cache, &reports, &["--no-cache"]);
    let spawn = || {
        motionlab(&cache)
            .args(["run", EXP, "--quiet", "--threads", "2", "--reports", reports.to_str().unwrap()])
            .stdout(std::process::Stdio::piped())
            .spawn()
            .unwrap()
    };
    let (a, b) = (spawn(), spawn());
    for child in [a, b] {
        let out = child.wait_with_output().unwrap();
        assert!(out.status.success());
        let dir = PathBuf::from(String::from_utf8_lossy(&out.stdout).split(": ").next().unwrap());
        assert_eq!(tables(&reference), tables(&dir));
    }
    let warm = run(&cache, &reports, &[]);
    assert_eq!(tables(&reference), tables(&warm));
    assert_eq!(stage_origins(&warm, "segmenter speed"), ["disk", "disk", "disk"]);
}

#[test]
#[cfg(unix)]
fn a_process_killed_mid_write_leaves_no_trusted_entry() {
    let tmp = tempfile::tempdir().unwrap();
    let (cache, reports) = (tmp.path().join("cache"), tmp.path().join("reports"));
    // The test hook pauses between writing an entry's temporary file and renaming it.
    let mut child = motionlab(&cache)
        .args(["run", EXP, "--quiet", "--threads", "1", "--reports", reports.to_str().unwrap()])
        .env("MOTIONLAB_CACHE_TEST_PAUSE_MS", "60000")
        .spawn()
        .unwrap();
    let started = std::time::Instant::now();
    let temporary = || -> usize {
        walk(&cache)
            .iter()
            .filter(|p| p.file_name().is_some_and(|n| n.to_string_lossy().starts_with(".tmp-")))
            .count()
    };
    while temporary() == 0 {
        assert!(started.elapsed().as_secs() < 120, "no cache write started");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    assert_eq!(temporary(), 1);
    assert!(
        walk(&cache).iter().all(|p| p.extension().is_none_or(|e| e != "bin")),
        "no entry is in place"
    );
    let info = ok(motionlab(&cache).args(["cache", "info"]));
    assert!(info.contains("total: 0 entries") && info.contains("1 temporary file"), "{info}");
    // The next run ignores the leftover and computes everything.
    let after = run(&cache, &reports, &[]);
    let reference = run(&cache, &reports, &["--no-cache"]);
    assert_eq!(tables(&reference), tables(&after));
    assert_eq!(stage_origins(&after, "load"), ["computed", "memory", "memory"]);
}

fn walk(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let Ok(rd) = std::fs::read_dir(dir) else { return out };
    for e in rd.flatten() {
        let p = e.path();
        if p.is_dir() {
            out.extend(walk(&p));
        } else {
            out.push(p);
        }
    }
    out
}
