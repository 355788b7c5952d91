//! The `[matching]` workflow end to end: the two Yabe & Tanaka experiments run from
//! the binary and write their tables, figures and the (a)/(b)/(c) verdict; a sharded run merges
//! to the plain run's tables; a bad `[matching]` key fails validation with one located line.

use std::path::{Path, PathBuf};
use std::process::Command;

fn motionlab() -> Command {
    let mut c = crate::motionlab_command();
    c.current_dir(motionlab_testkit::repo_root());
    c
}

fn ok(c: &mut Command) -> String {
    let out = c.output().unwrap();
    assert!(out.status.success(), "{:?}: {}", c, String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Runs an experiment into `reports`; returns the run directory.
fn run(experiment: &str, reports: &Path) -> PathBuf {
    let out = ok(motionlab().args([
        "run",
        experiment,
        "--quiet",
        "--reports",
        reports.to_str().unwrap(),
    ]));
    PathBuf::from(out.split(": ").next().unwrap())
}

/// A CSV as a header and rows of cells (no cell here holds a quoted comma but `detail` and
/// `parameters`, which the tests do not split).
fn csv(run: &Path, table: &str) -> (Vec<String>, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(run.join("tables").join(format!("{table}.csv"))).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().unwrap().split(',').map(str::to_string).collect();
    (header, lines.map(split_csv).collect())
}

fn split_csv(line: &str) -> Vec<String> {
    let (mut out, mut cur, mut quoted) = (Vec::new(), String::new(), false);
    for c in line.chars() {
        match (c, quoted) {
            ('"', _) => quoted = !quoted,
            (',', false) => out.push(std::mem::take(&mut cur)),
            (c, _) => cur.push(c),
        }
    }
    out.push(cur);
    out
}

fn col(header: &[String], name: &str) -> usize {
    header
        .iter()
        .position(|h| h == name)
        .unwrap_or_else(|| panic!("no column {name:?} in {header:?}"))
}

#[test]
fn the_timing_experiment_writes_its_tables_figures_and_verdict() {
    let tmp = tempfile::tempdir().unwrap();
    let run = run("experiments/yabe_timing.toml", tmp.path());
    // Two sweep combinations (model from the same take, from another take) × six repetitions.
    let (h, rows) = csv(&run, "timing_ranks");
    assert_eq!(rows.len(), 12, "{rows:?}");
    let (sweep, group) = (col(&h, "sweep"), col(&h, "group"));
    for s in ["model_same_take", "model_other_take"] {
        let groups: Vec<&str> =
            rows.iter().filter(|r| r[sweep] == s).map(|r| r[group].as_str()).collect();
        assert_eq!(groups, ["a", "a", "b", "b", "c", "c"], "{s}");
    }
    let (h, rows) = csv(&run, "judgement");
    assert_eq!(rows.len(), 12);
    for c in ["H_mm", "R_frames2", "H_norm", "R_norm", "score", "rank", "most_similar"] {
        col(&h, c);
    }
    let (h, rows) = csv(&run, "repetitions");
    assert_eq!(rows.len(), 12);
    // Explicit windows are matched whole: each window starts where its dataset is cut, and the
    // real jacks are matched over most of the 134-frame model (not collapsed).
    let (ws, a, b) = (col(&h, "window_start_frame"), col(&h, "a_frame"), col(&h, "b_frame"));
    let starts: Vec<&str> = rows[..6].iter().map(|r| r[ws].as_str()).collect();
    assert_eq!(starts, ["0", "270", "0", "270", "2960", "500"]);
    for r in &rows[..4] {
        let len = r[b].parse::<i64>().unwrap() - r[a].parse::<i64>().unwrap() + 1;
        assert!(
            (110..=150).contains(&len),
            "{} matched over {len} frames",
            r[col(&h, "repetition")]
        );
    }
    // The workflow's own H', R' and score (timing_ranks) equal the judgement evaluator's,
    // computed independently in motionlab-match.
    let (hr, ranks) = csv(&run, "timing_ranks");
    for c in ["H_norm", "R_norm", "score"] {
        for (x, y) in ranks.iter().zip(&rows_judgement(&run)) {
            let (p, q): (f64, f64) =
                (x[col(&hr, c)].parse().unwrap(), y.1[col(&y.0, c)].parse().unwrap());
            assert!((p - q).abs() <= 1e-12 * p.abs().max(1.0), "{c}: {p} vs {q}");
        }
    }
    // The verdict: one row per check per combination, each stating whether it held.
    let (h, rows) = csv(&run, "timing_verdict");
    assert_eq!(rows.len(), 12, "{rows:?}");
    let (check, held) = (col(&h, "check"), col(&h, "held"));
    // With the model from the same take (the paper's setting) every check holds on this data:
    // a 0.1 s late arm raises R over its original, and the score ranks an (a) first.
    let same: Vec<(&str, &str)> = rows
        .iter()
        .filter(|r| r[sweep] == "model_same_take")
        .map(|r| (r[check].as_str(), r[held].as_str()))
        .collect();
    assert_eq!(same.len(), 6);
    assert!(same.iter().all(|(_, h)| *h == "true"), "{same:?}");
    assert!(rows.iter().all(|r| r[held] == "true" || r[held] == "false"));
    // Per-item figures (combination 0): one warping-path figure per repetition; scatters.
    for f in ["scatter_H_R", "scatter_H_R_normalised", "jumping_jacks_a_b_c_paths_3"] {
        assert!(run.join("figures").join(format!("{f}.png")).is_file(), "{f}");
        assert!(run.join("figures").join(format!("{f}.svg")).is_file(), "{f}");
    }
    // Viewer pages (combination 0): the model, and each repetition of the explicit take with
    // its matched stretch — the `repetitions` table's [a, b] from its window's start — labelled
    // with its rank by score among the six (`timing_ranks`).
    let pages = motionlab_testkit::viewer_pages(&run);
    assert_eq!(pages.len(), 7, "{:?}", pages.iter().map(|p| &p.0).collect::<Vec<_>>());
    assert!(pages.iter().any(|p| p.0 == "model.html"));
    let (h, reps) = csv(&run, "repetitions");
    let (hr, ranks) = csv(&run, "timing_ranks");
    for (r, k) in reps[..6].iter().zip(&ranks[..6]) {
        let label = &r[col(&h, "repetition")];
        let title = format!("jumping jacks (a)(b)(c) — {label} — matching");
        let (name, page) = pages
            .iter()
            .find(|p| p.1["title"] == title)
            .unwrap_or_else(|| panic!("no viewer titled {title:?}"));
        assert!(name.starts_with("jumping_jacks_a_b_c_"), "{name}");
        let lane = motionlab_testkit::viewer_lane(page, "matched [a, b]");
        let iv = &lane["intervals"][0];
        let frame = |c: &str| {
            r[col(&h, c)].parse::<u64>().unwrap()
                - r[col(&h, "window_start_frame")].parse::<u64>().unwrap()
        };
        assert_eq!(
            (iv[0].as_u64().unwrap(), iv[1].as_u64().unwrap()),
            (frame("a_frame"), frame("b_frame")),
            "{label}"
        );
        let rank = format!("rank {} of 6", k[col(&hr, "rank_score")]);
        assert!(iv[2].as_str().unwrap().contains(&rank), "{label}: {} lacks {rank}", iv[2]);
    }
}

fn rows_judgement(run: &Path) -> Vec<(Vec<String>, Vec<String>)> {
    let (h, rows) = csv(run, "judgement");
    rows.into_iter().map(|r| (h.clone(), r)).collect()
}

#[test]
fn per_part_tables_name_the_points_the_matcher_compared_in_its_order() {
    // `[matching] points` reduces model and takes to four joints; the matcher's own `points`
    // then picks two of them, in its order: the per-part rows must follow that list.
    let tmp = tempfile::tempdir().unwrap();
    let out = ok(motionlab().args([
        "run",
        "experiments/yabe_exercises.toml",
        "matching.points=[\"head\", \"lhand\", \"rhand\", \"rfoot\"]",
        "matching.matcher.points=[\"rfoot\", \"lhand\"]",
        "--quiet",
        "--reports",
        tmp.path().to_str().unwrap(),
    ]));
    let run = PathBuf::from(out.split(": ").next().unwrap());
    let (h, rows) = csv(&run, "tendency_parts");
    let parts: Vec<(&str, &str)> =
        rows.iter().map(|r| (r[col(&h, "take")].as_str(), r[col(&h, "point")].as_str())).collect();
    assert_eq!(
        parts,
        [("13_29", "rfoot"), ("13_29", "lhand"), ("13_31", "rfoot"), ("13_31", "lhand")]
    );
}

#[test]
fn a_sharded_exercises_run_merges_to_the_plain_run() {
    let tmp = tempfile::tempdir().unwrap();
    let exp = "experiments/yabe_exercises.toml";
    let plain = run(exp, &tmp.path().join("reports"));
    let sharded = tmp.path().join("sharded");
    for i in [1, 0] {
        ok(motionlab().args([
            "run",
            exp,
            "--quiet",
            "--shard",
            &format!("{i}/2"),
            "--run-dir",
            sharded.to_str().unwrap(),
        ]));
    }
    ok(motionlab().args(["merge", "--quiet", sharded.to_str().unwrap()]));
    for t in ["repetitions", "judgement", "tendency_parts", "tendency_sections"] {
        let read = |run: &Path| {
            std::fs::read_to_string(run.join("tables").join(format!("{t}.csv"))).unwrap()
        };
        assert_eq!(read(&plain), read(&sharded), "{t}");
    }
    // The continuous takes: 3 jacks in 13_29, 2 in 13_31, each from two velocity peaks.
    let (h, rows) = csv(&plain, "repetitions");
    let takes: Vec<&str> = rows.iter().map(|r| r[col(&h, "take")].as_str()).collect();
    assert_eq!(takes, ["13_29", "13_29", "13_29", "13_31", "13_31"]);
    assert!(rows.iter().all(|r| r[col(&h, "peak_frames")].split(';').count() == 2), "{rows:?}");
    assert!(plain.join("figures/13_29_velocity.png").is_file());

    // Viewer pages: the model and each take. A take's matched stretches are the `repetitions`
    // table's [a, b] in frames of the loaded (cut) take — 13_31 is cut from frame 2749 — with
    // the table's H in their labels, and two velocity peaks per repetition.
    let pages = motionlab_testkit::viewer_pages(&plain);
    let names: Vec<&str> = pages.iter().map(|p| p.0.as_str()).collect();
    assert_eq!(names, ["13_29.html", "13_31.html", "model.html"]);
    assert_eq!(
        pages,
        motionlab_testkit::viewer_pages(&sharded),
        "merged viewers must equal the plain run's"
    );
    for (page, cut) in [(&pages[0].1, 0), (&pages[1].1, 2749)] {
        let take = page["title"].as_str().unwrap().split(' ').next().unwrap().to_string();
        let mine: Vec<&Vec<String>> = rows.iter().filter(|r| r[col(&h, "take")] == take).collect();
        let stretches = motionlab_testkit::viewer_lane(page, "matched [a, b]")["intervals"]
            .as_array()
            .unwrap()
            .clone();
        assert_eq!(stretches.len(), mine.len(), "{take}");
        for (iv, r) in stretches.iter().zip(&mine) {
            let frame = |c: &str| r[col(&h, c)].parse::<u64>().unwrap() - cut;
            assert_eq!(
                (iv[0].as_u64().unwrap(), iv[1].as_u64().unwrap()),
                (frame("a_frame"), frame("b_frame")),
                "{take}"
            );
            let h_mm: f64 = r[col(&h, "H_mm")].parse().unwrap();
            let label = iv[2].as_str().unwrap();
            assert!(
                label.starts_with(&r[col(&h, "repetition")])
                    && label.contains(&format!("H {} mm", motionlab_core::table::fmt_num(h_mm))),
                "{label} vs H {h_mm}"
            );
        }
        let peaks = motionlab_testkit::viewer_lane(page, "velocity peaks")["marks"]
            .as_array()
            .unwrap()
            .len();
        assert_eq!(peaks, 2 * mine.len(), "{take}");
        let velocity = motionlab_testkit::viewer_lane(page, "velocity function");
        assert_eq!(
            velocity["thresholds"].as_array().unwrap().len(),
            1,
            "the detector's threshold is drawn"
        );
    }
}

#[test]
fn a_bad_matching_key_fails_validation_with_one_located_line() {
    let out = motionlab()
        .args(["validate", "experiments/yabe_timing.toml", "matching.model=(a) jack 2"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    let err = err.trim();
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains("yabe_timing.toml")
            && err.contains("matching.model")
            && err.contains("no dataset named \"(a) jack 2\""),
        "{err}"
    );
    let out = motionlab()
        .args(["validate", "experiments/yabe_exercises.toml", "matching.peaks_per_repetition=0"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("matching.peaks_per_repetition") && err.contains("at least one"), "{err}");
    // A figure name is checked when the file is validated (a typo would otherwise draw nothing).
    let out = motionlab()
        .args([
            "validate",
            "experiments/yabe_exercises.toml",
            r#"matching.figures=["velocity", "pathz"]"#,
        ])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("matching.figures[1]")
            && err.contains(
                "unknown variant `pathz`, expected one of `velocity`, `paths`, `scatter`"
            ),
        "{err}"
    );
}
