//! The `[benchmark]` workflow end to end on hand-made channel files with known answers: the
//! covering of each method per series and its mean, ranks with a tie, published scores beside
//! ours and in the ranks; sharded runs merge into the same tables; malformed sections are one
//! clear error at validation.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use crate::own_annotations::read_table;

fn motionlab() -> Command {
    crate::motionlab_command()
}

fn ok(c: &mut Command) -> String {
    let out = c.output().unwrap();
    assert!(out.status.success(), "{:?}: {}", c, String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Three series: A (100 samples, a step at 50), B (120, a step at 40), C (80, constant, no
/// change); TSSB's formats (one value per line, `desc.txt`) and a published sheet.
fn toy(dir: &Path) {
    let step = |n: usize, at: usize| {
        (0..n).map(|i| if i < at { "0" } else { "10" }).collect::<Vec<_>>().join("\n") + "\n"
    };
    std::fs::write(dir.join("A.txt"), step(100, 50)).unwrap();
    std::fs::write(dir.join("B.txt"), step(120, 40)).unwrap();
    std::fs::write(dir.join("C.txt"), "3\n".repeat(80)).unwrap();
    std::fs::write(dir.join("desc.txt"), "A,10,50\nB,10,40\nC,10\n").unwrap();
    std::fs::write(
        dir.join("published.csv"),
        "dataset,Other,Step\nA,0.9,1.0\nB,0.9,1.0\nC,1.0,1.0\n",
    )
    .unwrap();
}

/// `step`: binary segmentation with a penalty only a step clears (finds 50 and 40, nothing on
/// C); `none`: a window wider than every series (never a candidate).
const SECTION: &str = r#"
[experiment]
name = "toy_benchmark"

[[dataset]]
files = ["[A-Z].txt"]
loader = { type = "channels", rate_hz = 1.0 }
ground_truth = { type = "tssb_desc", file = "desc.txt" }

[benchmark]
chance_draws = 200
segmenter = [
    { type = "kernel_cpd", name = "step", search = "binseg", cost = "l2", pen = 100.0 },
    { type = "window", name = "none", width = 1000 },
]
"#;

fn write_experiment(dir: &Path, extra: &str) -> PathBuf {
    let path = dir.join("toy.toml");
    std::fs::write(&path, format!("{SECTION}{extra}")).unwrap();
    path
}

/// A table's CSV as rows of (header → cell).
fn table(run: &Path, name: &str) -> Vec<BTreeMap<String, String>> {
    read_table(&run.join("tables").join(format!("{name}.csv")))
}

fn cell<'a>(
    rows: &'a [BTreeMap<String, String>],
    sequence: &str,
    method: &str,
    column: &str,
) -> &'a str {
    let row = rows
        .iter()
        .find(|r| r.get("sequence").map(String::as_str) == Some(sequence) && r["method"] == method)
        .unwrap_or_else(|| panic!("no row {sequence}/{method}"));
    &row[column]
}

fn num(s: &str) -> f64 {
    s.parse().unwrap_or_else(|_| panic!("{s:?} is not a number"))
}

fn run(experiment: &Path, reports: &Path) -> PathBuf {
    let out = ok(motionlab().args([
        "run",
        experiment.to_str().unwrap(),
        "--quiet",
        "--reports",
        reports.to_str().unwrap(),
    ]));
    PathBuf::from(out.split(": ").next().unwrap())
}

#[test]
fn a_two_method_toy_benchmark_has_the_known_coverings_ranks_and_published_scores() {
    let tmp = tempfile::tempdir().unwrap();
    toy(tmp.path());
    let published = "published = { file = \"published.csv\", metric = \"covering\", methods = { step = \"Step\" } }\n";
    let exp = write_experiment(tmp.path(), "");
    let text = std::fs::read_to_string(&exp)
        .unwrap()
        .replace("chance_draws = 200", &format!("chance_draws = 200\n{published}"));
    std::fs::write(&exp, text).unwrap();
    let run = run(&exp, &tmp.path().join("reports"));
    let cov = table(&run, "benchmark_covering");
    // step finds every change: covering 1 everywhere.
    for s in ["A", "B", "C"] {
        assert_eq!(num(cell(&cov, s, "step", "covering")), 1.0, "{s}");
    }
    // none: one segment. A: two halves, each Jaccard 1/2 → 0.5. B: [0,40) 40/120, [40,120)
    // 80/120 → (40/3 + 80·2/3)/120 = 5/9. C: no change, covered exactly → 1.
    assert_eq!(num(cell(&cov, "A", "none", "covering")), 0.5);
    assert!((num(cell(&cov, "B", "none", "covering")) - 5.0 / 9.0).abs() < 1e-12);
    assert_eq!(num(cell(&cov, "C", "none", "covering")), 1.0);
    assert!(
        (num(cell(&cov, "mean", "none", "covering")) - (0.5 + 5.0 / 9.0 + 1.0) / 3.0).abs() < 1e-12
    );
    assert_eq!(num(cell(&cov, "mean", "step", "covering")), 1.0);
    assert_eq!(cell(&cov, "A", "step", "n_found"), "1");
    assert_eq!(cell(&cov, "A", "none", "n_found"), "0");
    // Published beside ours (mapped for `step` only), and their difference.
    assert_eq!(cell(&cov, "A", "step", "published_method"), "Step");
    assert_eq!(num(cell(&cov, "A", "step", "published_covering")), 1.0);
    assert_eq!(
        cell(&cov, "A", "none", "published_covering"),
        "NaN",
        "none has no published column"
    );
    assert_eq!(num(cell(&cov, "mean", "step", "covering_minus_published")), 0.0);
    assert_eq!(cell(&cov, "A", "step", "parameters_chosen"), "set in the experiment");
    // Ranks by covering over A, B, C with the published Other and Step:
    // A: step 1, none 0.5, Other 0.9, Step 1 → step/Step 1.5, Other 3, none 4;
    // B: the same order → 1.5, 1.5, 3, 4; C: all 1 → 2.5 each.
    let ranks = table(&run, "benchmark_ranks");
    let rank = |m: &str| num(&ranks.iter().find(|r| r["method"] == m).unwrap()["mean_rank"]);
    assert!((rank("step") - (1.5 + 1.5 + 2.5) / 3.0).abs() < 1e-12);
    assert!((rank("none") - (4.0 + 4.0 + 2.5) / 3.0).abs() < 1e-12);
    assert!((rank("Other (published)") - (3.0 + 3.0 + 2.5) / 3.0).abs() < 1e-12);
    assert!((rank("Step (published)") - rank("step")).abs() < 1e-12);
    assert_eq!(
        ranks.iter().find(|r| r["method"] == "Other (published)").unwrap()["source"],
        "published"
    );
    assert_eq!(
        ranks.iter().find(|r| r["method"] == "step").unwrap()["wins"],
        "3",
        "a tie for first is a win"
    );
    let test = table(&run, "benchmark_rank_test");
    assert_eq!(test[0]["n_series"], "3");
    // CD = q(4) · √(4·5/(6·3)), q(4) = 2.569031772546482 (scipy).
    assert!(
        (num(&test[0]["critical_difference"]) - 2.569031772546482 * (20.0f64 / 18.0).sqrt()).abs()
            < 1e-6
    );
    // F1 at TCPDBench's default margin: step exact (1), none only the start point: on A,
    // P = 1/1, R = 1/2 → 2/3.
    let f1 = table(&run, "benchmark_f1");
    assert_eq!(num(cell(&f1, "A", "step", "tcpd_f1")), 1.0);
    assert!((num(cell(&f1, "A", "none", "tcpd_f1")) - 2.0 / 3.0).abs() < 1e-12);
    assert_eq!(cell(&f1, "A", "step", "margin"), "5 frames");
    // The runtime table and the diagram.
    let rt = table(&run, "benchmark_runtime");
    assert!(num(cell(&rt, "total", "step", "seconds")) >= 0.0);
    assert!(run.join("figures/critical_difference.png").exists());
}

#[test]
fn ties_min_ranks_as_tssbs_notebook() {
    let tmp = tempfile::tempdir().unwrap();
    toy(tmp.path());
    let exp = write_experiment(tmp.path(), "");
    let text = std::fs::read_to_string(&exp)
        .unwrap()
        .replace("chance_draws = 200", "chance_draws = 200\nties = \"min\"");
    std::fs::write(&exp, text).unwrap();
    let run = run(&exp, &tmp.path().join("reports"));
    let ranks = table(&run, "benchmark_ranks");
    let rank = |m: &str| num(&ranks.iter().find(|r| r["method"] == m).unwrap()["mean_rank"]);
    // A and B: step 1, none 2; C: tied → both 1.
    assert_eq!(rank("step"), 1.0);
    assert!((rank("none") - 5.0 / 3.0).abs() < 1e-12);
    // Without `published` the covering table has no published columns.
    let cov = table(&run, "benchmark_covering");
    assert!(!cov[0].contains_key("published_covering"));
}

fn tables(run: &Path) -> Vec<(String, String)> {
    let mut v: Vec<(String, String)> = std::fs::read_dir(run.join("tables"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "csv" || e == "md"))
        // Wall times differ from run to run.
        .filter(|p| !p.to_string_lossy().contains("benchmark_runtime"))
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

#[test]
fn sharded_and_merged_equals_a_plain_run() {
    let tmp = tempfile::tempdir().unwrap();
    toy(tmp.path());
    let exp = write_experiment(tmp.path(), "");
    let plain = run(&exp, &tmp.path().join("reports"));
    let sharded = tmp.path().join("sharded");
    for i in [1, 0] {
        ok(motionlab().args([
            "run",
            exp.to_str().unwrap(),
            "--quiet",
            "--no-cache",
            "--shard",
            &format!("{i}/2"),
            "--run-dir",
            sharded.to_str().unwrap(),
        ]));
    }
    ok(motionlab().args(["merge", "--quiet", sharded.to_str().unwrap()]));
    let (a, b) = (tables(&plain), tables(&sharded));
    assert_eq!(a.len(), 10, "covering, f1, ranks, rank test, change points: csv and md");
    assert_eq!(a, b, "merged tables must equal the plain run's, cell for cell");
    assert!(sharded.join("tables/benchmark_runtime.csv").exists());
}

/// `motionlab validate` on the toy with `segmenter` replaced: one error line naming the file,
/// the line and the key.
fn validate_error(dir: &Path, segmenters: &str, extra: &str) -> String {
    let text = SECTION.replace(
        "segmenter = [\n    { type = \"kernel_cpd\", name = \"step\", search = \"binseg\", cost = \"l2\", pen = 100.0 },\n    { type = \"window\", name = \"none\", width = 1000 },\n]",
        segmenters,
    );
    let path = dir.join("bad.toml");
    std::fs::write(&path, format!("{text}{extra}")).unwrap();
    let out = motionlab().args(["validate", path.to_str().unwrap()]).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr).trim().to_string();
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("bad.toml:"), "names the file and line: {err}");
    err
}

#[test]
fn malformed_sections_are_one_clear_error_at_validation() {
    let tmp = tempfile::tempdir().unwrap();
    toy(tmp.path());
    let d = tmp.path();
    let e = validate_error(d, "segmenter = [{ type = \"claps\" }]", "");
    assert!(
        e.contains("benchmark.segmenter[0].type") && e.contains("clasp"),
        "unknown segmenter, the closest named: {e}"
    );
    let e = validate_error(d, "segmenter = [{ type = \"speed_minima\" }]", "");
    assert!(
        e.contains("reads marker or joint positions") && e.contains("gives channels only"),
        "a positions segmenter on channel files: {e}"
    );
    let e = validate_error(d, "segmenter = []", "");
    assert!(e.contains("benchmark.segmenter") && e.contains("at least one"), "{e}");
    let e = validate_error(d, "segmenter = [{ type = \"clasp\" }, { type = \"clasp\" }]", "");
    assert!(e.contains("two segmenters are named \"clasp\""), "{e}");
    let e = validate_error(
        d,
        "segmenter = [{ type = \"clasp\" }]\npublished = { file = \"published.csv\", metric = \"covering\", methods = { clasp = \"ClaSP\" } }",
        "",
    );
    assert!(e.contains("\"ClaSP\" is not a column") && e.contains("Other, Step"), "{e}");
    let e = validate_error(
        d,
        "segmenter = [{ type = \"clasp\" }]\npublished = { file = \"missing.csv\", metric = \"covering\" }",
        "",
    );
    assert!(e.contains("benchmark.published.file") && e.contains("missing.csv"), "{e}");
    let e = validate_error(d, "segmenter = [{ type = \"clasp\" }]\nalpha = 1.5", "");
    assert!(e.contains("benchmark.alpha"), "{e}");
    let e = validate_error(
        d,
        "segmenter = [{ type = \"clasp\" }]",
        "\n[[evaluate]]\ntype = \"boundary_pr\"\n",
    );
    assert!(e.contains("[[evaluate]] belongs to [segmentation]"), "{e}");
}

#[test]
fn new_scaffolds_a_valid_benchmark_over_a_folder_of_channel_files() {
    let tmp = tempfile::tempdir().unwrap();
    toy(tmp.path());
    let data = tmp.path().to_str().unwrap().to_string();
    let truth = tmp.path().join("desc.txt");
    let out = tmp.path().join("exp/toy_benchmark.toml");
    // Channel files imply --benchmark; the file is validated before `new` returns.
    let said = ok(motionlab().args([
        "new",
        &data,
        "--truth",
        truth.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]));
    assert!(said.contains("(valid)"), "{said}");
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(
        text.contains("[benchmark]")
            && text.contains("type = \"tssb_desc\"")
            && text.contains("rate_hz = 1.0"),
        "{text}"
    );
    // desc.txt names A, B and C: desc.txt itself is no series.
    assert!(text.contains("\"../A.txt\", \"../B.txt\", \"../C.txt\"]"), "{text}");
    for t in ["clasp", "kernel_cpd", "floss", "bocpd", "window"] {
        assert!(text.contains(&format!("type = \"{t}\"")), "{t}: {text}");
    }
    // Without ground truth there is nothing to benchmark: one clear error.
    let o = motionlab()
        .args(["new", &data, "--benchmark", "-o", tmp.path().join("x.toml").to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("pass --truth"));
}

/// A Parquet channel file (pyarrow's, of TSSB's ArrowHead) is a channel file like any other
/// through the binary: `new` scaffolds a benchmark over a folder holding it, and the run finds
/// the change points the series' text file gives. A CLI that does not link `motionlab-parquet`
/// fails here with "needs the crate motionlab-parquet".
#[test]
fn a_parquet_channel_file_benchmarks_like_its_text_file() {
    let tmp = tempfile::tempdir().unwrap();
    let root = motionlab_testkit::repo_root();
    let (pq, txt) = (tmp.path().join("parquet"), tmp.path().join("text"));
    for (dir, file, src) in [
        (&pq, "ArrowHead.parquet", "crates/motionlab-parquet/tests/fixtures/ArrowHead.parquet"),
        (&txt, "ArrowHead.txt", "data/tssb/datasets/ArrowHead.txt"),
    ] {
        std::fs::create_dir_all(dir).unwrap();
        std::fs::copy(root.join(src), dir.join(file)).unwrap();
        std::fs::write(dir.join("desc.txt"), "ArrowHead,10,753\n").unwrap();
    }
    let out = pq.join("exp/arrowhead.toml");
    let said = ok(motionlab().args([
        "new",
        pq.to_str().unwrap(),
        "--truth",
        pq.join("desc.txt").to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]));
    assert!(said.contains("(valid)"), "{said}");
    assert!(std::fs::read_to_string(&out).unwrap().contains("\"../ArrowHead.parquet\""));
    let candidates = |dir: &Path, file: &str| {
        let exp = dir.join("bench.toml");
        let text = SECTION
            .replace("[A-Z].txt", file)
            .replace("toy_benchmark", "arrowhead")
            .replace("pen = 100.0", "n_bkps = 1")
            .replace("    { type = \"window\", name = \"none\", width = 1000 },\n", "");
        std::fs::write(&exp, text).unwrap();
        let run = run(&exp, &dir.join("reports"));
        let cov = table(&run, "benchmark_covering");
        (
            cell(&cov, "ArrowHead", "step", "covering").to_string(),
            cell(&cov, "ArrowHead", "step", "n_found").to_string(),
        )
    };
    let from_parquet = candidates(&pq, "ArrowHead.parquet");
    assert_eq!(from_parquet, candidates(&txt, "ArrowHead.txt"));
    assert_eq!(from_parquet.1, "1");
}

/// Two-channel toy series (a step in both channels; `rate_hz` given) with `desc.txt`.
fn toy_two_channels(dir: &Path) {
    let step = |n: usize, at: usize| {
        let rows: String =
            (0..n).map(|i| if i < at { "0,1\n" } else { "10,-4\n" }).collect::<Vec<_>>().concat();
        format!("a,b\n{rows}")
    };
    std::fs::write(dir.join("A.csv"), step(100, 50)).unwrap();
    std::fs::write(dir.join("B.csv"), step(120, 40)).unwrap();
    std::fs::write(dir.join("desc.txt"), "A,10,50\nB,10,40\n").unwrap();
}

/// `floss` (FLUSS is univariate) on two-channel series fails on each; the failure is recorded
/// with its reason, the other method is scored, and the means and ranks say how failures count
/// (left out of the mean, ranked last).
#[test]
fn a_method_that_cannot_take_a_series_is_recorded_as_failed_and_the_benchmark_goes_on() {
    let tmp = tempfile::tempdir().unwrap();
    toy_two_channels(tmp.path());
    let exp = tmp.path().join("two.toml");
    let text = SECTION.replace("[A-Z].txt", "[A-Z].csv").replace(
        "    { type = \"window\", name = \"none\", width = 1000 },\n",
        "    { type = \"floss\", cac_threshold = 0.45 },\n",
    );
    std::fs::write(&exp, text).unwrap();
    let run = run(&exp, &tmp.path().join("reports"));
    let cov = table(&run, "benchmark_covering");
    for s in ["A", "B"] {
        assert_eq!(cell(&cov, s, "step", "status"), "ok");
        assert_eq!(num(cell(&cov, s, "step", "covering")), 1.0);
        assert_eq!(cell(&cov, s, "floss", "status"), "failed");
        assert!(cell(&cov, s, "floss", "failure").contains("FLUSS is univariate"), "{cov:?}");
        assert_eq!(cell(&cov, s, "floss", "covering"), "NaN");
        assert_eq!(cell(&cov, s, "floss", "n_found"), "NaN");
    }
    assert!(cell(&cov, "mean", "floss", "status").contains("0 scored sequence(s); 2 failed"));
    assert!(cell(&cov, "mean", "step", "status").contains("2 scored sequence(s); 0 failed"));
    assert_eq!(num(cell(&cov, "mean", "step", "covering")), 1.0);
    let f1 = table(&run, "benchmark_f1");
    assert_eq!(cell(&f1, "A", "floss", "status"), "failed");
    assert_eq!(num(cell(&f1, "A", "step", "tcpd_f1")), 1.0);
    // Ranked last on both series: step 1, floss 2; both series counted.
    let ranks = table(&run, "benchmark_ranks");
    let row = |m: &str| ranks.iter().find(|r| r["method"] == m).unwrap().clone();
    assert_eq!((num(&row("step")["mean_rank"]), num(&row("floss")["mean_rank"])), (1.0, 2.0));
    assert_eq!((row("floss")["n_failed"].as_str(), row("floss")["n_series"].as_str()), ("2", "2"));
    assert_eq!(row("step")["n_failed"], "0");
    // The change points kept: step's, none of floss.
    let cps = table(&run, "benchmark_change_points");
    let found: Vec<(&str, &str, &str)> = cps
        .iter()
        .map(|r| (r["sequence"].as_str(), r["method"].as_str(), r["sample"].as_str()))
        .collect();
    assert_eq!(found, [("A", "step", "50"), ("B", "step", "40")]);
}

/// Re-scores `benchmark_change_points` with TCPDBench's covering against the truth and finds
/// each (sequence, method)'s covering of `benchmark_covering`, bit for bit. A method with no
/// row found nothing on that sequence.
fn rescored_coverings_equal_the_runs(tables: &Path, truth: &BTreeMap<String, Vec<usize>>) -> usize {
    let cov = read_table(&tables.join("benchmark_covering.csv"));
    let cps = read_table(&tables.join("benchmark_change_points.csv"));
    let mut found: BTreeMap<(String, String), Vec<usize>> = BTreeMap::new();
    for r in &cps {
        found
            .entry((r["sequence"].clone(), r["method"].clone()))
            .or_default()
            .push(r["sample"].parse().unwrap());
    }
    let mut compared = 0;
    for r in cov.iter().filter(|r| r["sequence"] != "mean") {
        let key = (r["sequence"].clone(), r["method"].clone());
        let points = found.remove(&key).unwrap_or_default();
        assert_eq!(points.len().to_string(), r["n_found"], "{key:?}");
        let n: usize = r["n_samples"].parse().unwrap();
        let ours = motionlab_eval::cpd_metrics::covering(&[truth[&key.0].clone()], &points, n);
        // Bit for bit: the table's float reads back to the same f64.
        assert_eq!(ours, num(&r["covering"]), "{key:?}: re-scored {ours}");
        compared += 1;
    }
    assert!(found.is_empty(), "change points of no covering row: {found:?}");
    compared
}

#[test]
fn the_change_points_table_rescored_gives_the_runs_covering() {
    let tmp = tempfile::tempdir().unwrap();
    toy(tmp.path());
    let run = run(&write_experiment(tmp.path(), ""), &tmp.path().join("reports"));
    let truth: BTreeMap<String, Vec<usize>> =
        [("A", vec![50]), ("B", vec![40]), ("C", vec![])].map(|(s, v)| (s.to_string(), v)).into();
    assert_eq!(rescored_coverings_equal_the_runs(&run.join("tables"), &truth), 6);
}

/// A new user's files: four limb-speed channels (both hands, both feet; `marker_speed` of CMU
/// 86_01's joints) written as CSV at 120 Hz with `time_s` rounded to microseconds (0.008333,
/// 0.016667, …), cut in two files, and a boundaries CSV of the take's labelled boundaries.
/// `new` scaffolds a benchmark reading the rate from the files (no `floss`: FLUSS is
/// univariate) and `run` scores every scaffolded segmenter.
#[test]
fn new_and_run_on_multichannel_csv_with_rounded_times() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("limbs");
    std::fs::create_dir_all(&data).unwrap();
    let motion =
        motionlab_core::registry::build_loader("asf_amc", &toml::Value::Table(Default::default()))
            .unwrap()
            .load(&motionlab_testkit::data_path("cmu86/86_01.amc.gz"))
            .unwrap();
    let speeds = motionlab_features::speed::marker_speeds(&motion, 1);
    let joints = ["lhand", "rhand", "lfoot", "rfoot"];
    let index: Vec<usize> =
        joints.iter().map(|j| motion.point_names().iter().position(|n| n == j).unwrap()).collect();
    // The labelled boundaries of 86_01 (data/cmu86/mocap.txt, 120 Hz frames).
    let boundaries = [549usize, 1149, 1979, 2499, 3199, 4064];
    // Two files: frames [0, 2400) and [2400, last) (the last frame has no speed).
    let cut = 2400;
    let n = motion.n_frames() - 1;
    let mut truth = "sequence,frame\n".to_string();
    for (name, range) in [("first", 0..cut), ("second", cut..n)] {
        let mut csv = format!("time_s,{}\n", joints.join(","));
        for (i, f) in range.clone().enumerate() {
            let row: Vec<String> =
                index.iter().map(|&k| format!("{:.3}", speeds.speed(f, k))).collect();
            csv += &format!("{:.6},{}\n", i as f64 / 120.0, row.join(","));
        }
        std::fs::write(data.join(format!("{name}.csv")), csv).unwrap();
        for b in boundaries.iter().filter(|b| range.contains(b)) {
            truth += &format!("{name},{}\n", b - range.start);
        }
    }
    let text = std::fs::read_to_string(data.join("first.csv")).unwrap();
    assert!(text.contains("\n0.008333,") && text.contains("\n0.016667,"), "rounded times");
    let truth_path = tmp.path().join("truth.csv");
    std::fs::write(&truth_path, truth).unwrap();
    let out = tmp.path().join("limbs_benchmark.toml");
    let said = ok(motionlab().args([
        "new",
        data.to_str().unwrap(),
        "--truth",
        truth_path.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]));
    assert!(said.contains("(valid)"), "{said}");
    let scaffold = std::fs::read_to_string(&out).unwrap();
    assert!(scaffold.contains("rate 120 Hz, read from the time_s column"), "{scaffold}");
    assert!(!scaffold.contains("rate_hz"), "{scaffold}");
    assert!(!scaffold.contains("type = \"floss\"") && scaffold.contains("floss left out"));
    let run = run(&out, &tmp.path().join("reports"));
    let cov = table(&run, "benchmark_covering");
    let methods = ["clasp", "PELT", "BinSeg", "bocpd", "window"];
    for s in ["first", "second"] {
        for m in methods {
            let c = num(cell(&cov, s, m, "covering"));
            assert!((0.0..=1.0).contains(&c), "{s}/{m}: {c}");
        }
    }
    assert!(!cov[0].contains_key("status"), "no method failed: no status column");
    assert_eq!(cell(&cov, "first", "clasp", "n_samples"), cut.to_string());
    // inspect reads the same rate from the file.
    let said = ok(motionlab().args(["inspect", data.join("first.csv").to_str().unwrap()]));
    assert!(said.contains("2400 at 120 Hz"), "{said}");
    assert!(said.contains("channels  4: lhand rhand lfoot rfoot"), "{said}");
}

/// `inspect` describes a channel file without a time column (a TSSB series) with its rate
/// unknown; `new` on a folder whose first file cannot be read says why, naming file and line,
/// instead of declaring a rate.
#[test]
fn inspect_and_new_on_channel_files_without_a_rate_or_unreadable() {
    let root = motionlab_testkit::repo_root();
    let series = root.join("data/tssb/datasets/ArrowHead.txt");
    let said = ok(motionlab().args(["inspect", series.to_str().unwrap()]));
    assert!(said.contains("1506 at an unknown rate"), "{said}");
    assert!(said.contains("channels  1: value"), "{said}");
    let json = ok(motionlab().args(["inspect", "--json", series.to_str().unwrap()]));
    assert!(
        json.contains("\"frame_rate_hz\": null") && json.contains("\"frames\": 1506"),
        "{json}"
    );
    // A time column with a dropped sample: new fails naming the file and line.
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("bad");
    std::fs::create_dir_all(&data).unwrap();
    std::fs::write(data.join("A.csv"), "time_s,x\n0.00,1\n0.01,2\n0.02,3\n0.04,4\n0.05,5\n")
        .unwrap();
    let truth = tmp.path().join("truth.csv");
    std::fs::write(&truth, "sequence,frame\nA,2\n").unwrap();
    let o = motionlab()
        .args(["new", data.to_str().unwrap(), "--truth", truth.to_str().unwrap(), "-o"])
        .arg(tmp.path().join("x.toml"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("A.csv:5") && err.contains("equally spaced"), "{err}");
    assert!(!tmp.path().join("x.toml").exists());
}

/// A published sheet without a row for a sequence of the run is refused at validation, naming
/// the sheet and the first missing sequence; with `missing = "skip"` the run leaves it out of
/// the published columns and the ranks, and the tables say so.
#[test]
fn a_published_sheet_missing_a_sequence_is_refused_unless_skipped() {
    let tmp = tempfile::tempdir().unwrap();
    toy(tmp.path());
    std::fs::write(tmp.path().join("partial.csv"), "dataset,Other,Step\nA,0.9,1.0\nB,0.9,1.0\n")
        .unwrap();
    let published = |ours: &str, extra: &str| {
        format!(
            "published = {{ file = \"partial.csv\", metric = \"covering\", methods = {{ {ours} = \"Step\" }}{extra} }}\n"
        )
    };
    let e = validate_error(
        tmp.path(),
        &format!("segmenter = [{{ type = \"clasp\" }}]\n{}", published("clasp", "")),
        "",
    );
    assert!(
        e.contains("benchmark.published.file")
            && e.contains("partial.csv has no row for sequence \"C\"")
            && e.contains("1 of the run's 3 sequences")
            && e.contains("missing = \"skip\""),
        "{e}"
    );
    let exp = write_experiment(tmp.path(), "");
    let text = std::fs::read_to_string(&exp).unwrap().replace(
        "chance_draws = 200",
        &format!("chance_draws = 200\n{}", published("step", ", missing = \"skip\"")),
    );
    std::fs::write(&exp, text).unwrap();
    let run = run(&exp, &tmp.path().join("reports"));
    let test = table(&run, "benchmark_rank_test");
    assert_eq!(test[0]["n_series"], "2", "C left out of the ranks");
    assert_eq!(
        test[0]["published_missing"],
        "1 sequence(s) not in partial.csv left out of the ranks (missing = skip; the first: C)"
    );
    let cov = table(&run, "benchmark_covering");
    assert_eq!(
        cell(&cov, "mean", "step", "published_method"),
        "Step (over 2 of 3 sequences; missing = skip)"
    );
    assert_eq!(num(cell(&cov, "mean", "step", "published_covering")), 1.0);
    assert_eq!(cell(&cov, "C", "step", "published_covering"), "NaN");
}

/// Two series with repeated states, TSSB's files plus CLaP's `properties.txt` (one state label
/// per segment): S = levels 0, 10, 0 (states 0 1 0), T = 0, 10, 20, 10 (a b c b); 20 samples
/// per segment.
fn toy_states(dir: &Path) {
    let levels = |ls: &[u32]| {
        ls.iter().flat_map(|l| std::iter::repeat_n(format!("{l}\n"), 20)).collect::<String>()
    };
    std::fs::write(dir.join("S.txt"), levels(&[0, 10, 0])).unwrap();
    std::fs::write(dir.join("T.txt"), levels(&[0, 10, 20, 10])).unwrap();
    std::fs::write(dir.join("desc.txt"), "S,10,20,40\nT,10,20,40,60\n").unwrap();
    std::fs::write(dir.join("properties.txt"), "S,0,1,0\nT,a,b,c,b\n").unwrap();
}

const STATES: &str = r#"
[experiment]
name = "toy_states"

[[dataset]]
files = ["[A-Z].txt"]
loader = { type = "channels", rate_hz = 1.0 }
ground_truth = { type = "tssb_desc", file = "desc.txt" }

[benchmark]
chance_draws = 200
segmenter = [{ type = "kernel_cpd", name = "step", search = "binseg", cost = "l2", pen = 100.0 }]
labeller = [{ type = "segment_clusters" }]
"#;

/// The labeller on the truth's segments (an oracle segmentation) and on `step`'s: by hand,
/// segment means 0 10 0 give two clusters by the silhouette rule ({0, 2}, {1}) and 0 10 20 10
/// three ({0}, {1, 3}, {2}): the truth's partitions, AMI = ARI = NMI = 1, above their chance
/// (the same segments with the labels permuted); the segments and states are kept.
#[test]
fn labellers_label_states_and_score_them_beside_chance() {
    let tmp = tempfile::tempdir().unwrap();
    toy_states(tmp.path());
    let exp = tmp.path().join("states.toml");
    std::fs::write(&exp, STATES).unwrap();
    let run = run(&exp, &tmp.path().join("reports"));
    let st = table(&run, "benchmark_states");
    for s in ["S", "T"] {
        for m in ["truth + segment_clusters", "step + segment_clusters"] {
            for metric in ["ami", "ari", "nmi"] {
                assert!((num(cell(&st, s, m, metric)) - 1.0).abs() < 1e-12, "{s} {m} {metric}");
            }
            let chance = num(cell(&st, s, m, "chance_ami"));
            assert!(chance < 1.0 && chance > -1.0, "{s} {m}: {chance}");
        }
    }
    assert_eq!(cell(&st, "T", "truth + segment_clusters", "n_samples"), "80");
    assert_eq!(num(cell(&st, "T", "truth + segment_clusters", "n_states")), 3.0);
    assert!((num(cell(&st, "mean", "truth + segment_clusters", "ami")) - 1.0).abs() < 1e-12);
    let segs = table(&run, "benchmark_segment_states");
    let t: Vec<(&str, &str, &str)> = segs
        .iter()
        .filter(|r| r["sequence"] == "T" && r["method"] == "truth + segment_clusters")
        .map(|r| (r["start"].as_str(), r["end"].as_str(), r["state"].as_str()))
        .collect();
    assert_eq!(t, [("0", "20", "0"), ("20", "40", "1"), ("40", "60", "2"), ("60", "80", "1")]);
    // A label file for other segments: one error naming properties.txt and its line.
    std::fs::write(tmp.path().join("properties.txt"), "S,0,1,0\nT,a,b,c\n").unwrap();
    let out = motionlab()
        .args(["run", exp.to_str().unwrap(), "--quiet", "--reports"])
        .arg(tmp.path().join("reports2"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("properties.txt:2") && err.contains("3 state label(s) for the 4 segment(s)"),
        "{err}"
    );
    // Segmentations to label are names of the benchmark's methods or "truth".
    let bad = STATES.replace("labeller = [", "label_segments = [\"truht\"]\nlabeller = [");
    std::fs::write(&exp, bad).unwrap();
    let out = motionlab().args(["validate", exp.to_str().unwrap()]).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("benchmark.label_segments") && err.contains("\"truht\""), "{err}");
}

/// A labelled truth CSV (`start_frame,end_frame,label` rows): `new` scaffolds a benchmark that
/// labels states and `run` reports AMI with chance; a segment without a label is one error
/// naming the CSV and its line.
#[test]
fn new_with_a_labelled_truth_scaffolds_state_labelling() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("series");
    std::fs::create_dir_all(&data).unwrap();
    toy_states(&data);
    for f in ["desc.txt", "properties.txt"] {
        std::fs::remove_file(data.join(f)).unwrap();
    }
    let truth = tmp.path().join("truth.csv");
    let csv = "sequence,start_frame,end_frame,label\nS,0,20,rest\nS,20,40,move\nS,40,60,rest\nT,0,20,low\nT,20,40,mid\nT,40,60,high\nT,60,80,mid\n";
    std::fs::write(&truth, csv).unwrap();
    let out = tmp.path().join("states_benchmark.toml");
    let said = ok(motionlab().args([
        "new",
        data.to_str().unwrap(),
        "--truth",
        truth.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]));
    assert!(said.contains("(valid)"), "{said}");
    let scaffold = std::fs::read_to_string(&out).unwrap();
    assert!(
        scaffold.contains("type = \"segment_clusters\"") && scaffold.contains("benchmark_states"),
        "{scaffold}"
    );
    let run = run(&out, &tmp.path().join("reports"));
    let st = table(&run, "benchmark_states");
    for s in ["S", "T"] {
        assert!((num(cell(&st, s, "truth + segment_clusters", "ami")) - 1.0).abs() < 1e-12);
        assert!(num(cell(&st, s, "truth + segment_clusters", "chance_ami")) < 1.0);
        assert!(!cell(&st, s, "truth + segment_clusters", "p_value_ami").is_empty());
    }
    // A segment without a label: the CSV and its line.
    std::fs::write(&truth, csv.replace("T,20,40,mid", "T,20,40,")).unwrap();
    let out = motionlab()
        .args(["run", out.to_str().unwrap(), "--quiet", "--reports"])
        .arg(tmp.path().join("reports2"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("truth.csv:6") && err.contains("without a label"), "{err}");
}
