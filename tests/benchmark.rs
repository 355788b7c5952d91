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
    assert_eq!(a.len(), 8, "covering, f1, ranks, rank test: csv and md");
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
