//! Annotating where you watch: what the viewer pages and `motionlab export` write reads back
//! through the `boundaries_csv` and `elan_eaf` readers to the same frames, and the annotators'
//! agreement is the ceiling each method is shown under.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

// The run helpers of the users'-annotations tests: running motionlab, finding the run, reading
// a table.
use crate::own_annotations::{motionlab_ok, read_table, run_dir};

use motionlab_core::{Motion, Segmentation, registry};
use motionlab_io::labels::boundaries_csv::{parse_boundaries_csv, write_boundaries_csv};
use motionlab_io::labels::elan_eaf::{parse_eaf, write_eaf};
use motionlab_io::labels::tiers::{MarkTier, RunBoundaries, SequenceTiers, TierMark};

// Link the plugin crates so the registry holds their loaders and readers.
use motionlab_eval as _;

fn repo() -> PathBuf {
    motionlab_testkit::repo_root()
}

/// A still motion with a sequence's rate and length, named after it: all the annotation readers
/// use of a motion (and, without a source file, the CSV reader matches rows by this name).
fn stand_in(seq: &SequenceTiers) -> Motion {
    let mut m =
        motionlab_testkit::motion_from_fn(seq.n_frames, seq.frame_rate_hz, 1, |_, _| [0.0; 3]);
    m.name = seq.sequence.clone();
    m
}

fn read_truth(reader: &str, params: &str, path: &Path, motion: &Motion) -> Segmentation {
    let params: toml::Value = toml::from_str(params).unwrap();
    registry::build_ground_truth(reader, &params)
        .unwrap()
        .read(path, motion)
        .unwrap_or_else(|e| panic!("{reader} {params}: {e}"))
}

/// Size of a maximum one-to-one matching `|a − t| ≤ tol`, by augmenting paths (Kuhn) —
/// independent of the evaluators' sweep.
fn max_matching(found: &[usize], truths: &[usize], tol: f64) -> usize {
    fn augment(
        i: usize,
        found: &[usize],
        truths: &[usize],
        tol: f64,
        seen: &mut [bool],
        partner: &mut [Option<usize>],
    ) -> bool {
        for j in 0..truths.len() {
            if (found[i] as f64 - truths[j] as f64).abs() <= tol && !seen[j] {
                seen[j] = true;
                if partner[j].is_none_or(|k| augment(k, found, truths, tol, seen, partner)) {
                    partner[j] = Some(i);
                    return true;
                }
            }
        }
        false
    }
    let mut partner = vec![None; truths.len()];
    (0..found.len())
        .filter(|&i| augment(i, found, truths, tol, &mut vec![false; truths.len()], &mut partner))
        .count()
}

/// `motionlab export` of sonoda_table1's run: every sequence's truth and each method's
/// candidates, as `.eaf` and as CSV, read back through `elan_eaf` (`tier = …`) and
/// `boundaries_csv` (`annotator = …`) to the same frames; the truth with its labels.
#[test]
fn export_of_sonoda_table1_reads_back_to_every_methods_frames() {
    let reports = tempfile::tempdir().unwrap();
    let r = reports.path().to_str().unwrap();
    // Figures are not what is tested: the viewer pages and the boundaries are written anyway.
    motionlab_ok(&[
        "run",
        "experiments/sonoda_table1.toml",
        "segmentation.figures=[]",
        "--reports",
        r,
        "--quiet",
    ]);
    let run = run_dir(reports.path(), "sonoda_table1");
    let kept: RunBoundaries = serde_json::from_slice(
        &std::fs::read(run.join("files").join(RunBoundaries::FILE_NAME)).unwrap(),
    )
    .unwrap();
    assert_eq!(kept.sequences.len(), 7);
    // The kept candidates are the run's candidates table, method by method.
    let table = read_table(&run.join("tables/candidates.csv"));
    for seq in &kept.sequences {
        for tier in seq.tiers.iter().filter(|t| t.name != "truth") {
            let rows: Vec<usize> = table
                .iter()
                .filter(|r| r["sequence"] == seq.name && r["method"] == tier.name)
                .map(|r| r["frame"].parse().unwrap())
                .collect();
            assert_eq!(tier.frames(), rows, "{} {}", seq.name, tier.name);
        }
    }
    let (eaf_dir, csv_dir) = (reports.path().join("eaf"), reports.path().join("csv"));
    let run_s = run.to_str().unwrap();
    let said =
        motionlab_ok(&["export", run_s, "--format", "eaf", "--out", eaf_dir.to_str().unwrap()]);
    assert_eq!(said.lines().count(), 7, "{said}");
    motionlab_ok(&["export", run_s, "--format", "csv", "--out", csv_dir.to_str().unwrap()]);
    let (mut checked, mut marks) = (0, 0);
    for seq in &kept.sequences {
        let motion = stand_in(seq);
        let inner = |t: &MarkTier| {
            t.frames().into_iter().filter(|&f| f > 0 && f + 1 < seq.n_frames).collect::<Vec<_>>()
        };
        assert_eq!(seq.tiers[0].name, "truth");
        assert_eq!(seq.tiers.len(), 7, "truth and six methods");
        for tier in &seq.tiers {
            let want = inner(tier);
            // Frames on the motion's edges are not boundaries to the readers; none are here.
            assert_eq!(
                want.len(),
                tier.marks.len(),
                "{} {}: a candidate on an edge frame",
                seq.name,
                tier.name
            );
            let eaf_file = eaf_dir.join(format!("{}.eaf", seq.name));
            if want.is_empty() {
                // A method that found nothing is an empty tier (which the reader refuses to
                // take for a ground truth) and no CSV rows.
                let tiers =
                    parse_eaf(&std::fs::read_to_string(&eaf_file).unwrap(), &eaf_file).unwrap();
                assert!(
                    tiers.iter().any(|t| t.id == tier.name && t.track.items.is_empty()),
                    "{} {}",
                    seq.name,
                    tier.name
                );
                checked += 1;
                continue;
            }
            let eaf =
                read_truth("elan_eaf", &format!("tier = {:?}", tier.name), &eaf_file, &motion);
            assert_eq!(eaf.frames(), want, "{} {} via .eaf", seq.name, tier.name);
            let csv = read_truth(
                "boundaries_csv",
                &format!("annotator = {:?}", tier.name),
                &csv_dir.join(format!("{}.csv", seq.name)),
                &motion,
            );
            assert_eq!(csv.frames(), want, "{} {} via CSV", seq.name, tier.name);
            if tier.name == "truth" {
                // The truth's labels come back as the labels of the ELAN annotations.
                let labels: Vec<(usize, &str)> =
                    eaf.segments.iter().map(|s| (s.start, s.label.as_str())).collect();
                let kept: Vec<(usize, &str)> =
                    tier.marks.iter().map(|m| (m.frame, m.label.as_str())).collect();
                assert_eq!(labels, kept, "{} truth labels", seq.name);
            }
            checked += 1;
            marks += want.len();
        }
    }
    assert_eq!(checked, 49);
    assert!(marks > 200, "{marks} marks compared");
    // 86_01's truth tier is its labels' six boundaries, each labelled with the action it starts.
    let s = &kept.sequences[0];
    assert_eq!(s.name, "86_01");
    assert_eq!(s.tiers[0].frames(), vec![549, 1149, 1979, 2499, 3199, 4064]);
    assert_eq!(s.tiers[0].marks[0].label, "jump");
    assert_eq!(s.input_sha256, "f3d98b96940de9107bc9bfa5a5ecec2a029cdb45713e333d7bc69a0893cfac07");
    // The same sequence's viewer page annotates under that SHA-256, at the run's tolerance.
    let page =
        motionlab_testkit::viewer_pages(&run).into_iter().find(|p| p.0 == "86_01.html").unwrap().1;
    assert_eq!(page["annotation"]["input_sha256"], s.input_sha256.as_str());
    assert_eq!(page["annotation"]["sequence"], "86_01");
    assert_eq!(page["annotation"]["tolerance_frames"], 60.0);
    // A run directory without the boundaries is one clear error.
    let out = crate::motionlab_command().args(["export", r, "--format", "csv"]).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("segmentation_boundaries.json"), "{err}");
}

/// Two annotators of 86_01 — the shipped labels and the same boundaries 30 frames (0.25 s)
/// later — in a sonoda_table1-like run: their agreement has known answers, each method's F1
/// against them equals an independent matching, and the run page and the index show each
/// method between chance and the annotators.
#[test]
fn two_annotators_agree_as_known_and_bound_every_method() {
    let reports = tempfile::tempdir().unwrap();
    let r = reports.path().to_str().unwrap();
    motionlab_ok(&[
        "run",
        "tests/fixtures/annotations/two_annotators.toml",
        "--reports",
        r,
        "--quiet",
    ]);
    let run = run_dir(reports.path(), "two_annotators");
    let pairs = read_table(&run.join("tables/annotator_agreement.csv"));
    // 86_01 only (86_09 has one annotator), at each of the four default tolerances, then pooled.
    assert_eq!(pairs.len(), 8, "{pairs:?}");
    let zhou = [549, 1149, 1979, 2499, 3199, 4064];
    let shifted: Vec<usize> = zhou.iter().map(|f| f + 30).collect();
    let n = 4579.0;
    // Chance (both directions alike): 6 distinct random frames of 4579 against six disjoint
    // windows of 2·tol + 1 frames, each hit with probability 1 − C(n − w, 6) / C(n, 6).
    let expected =
        |w: f64| 6.0 * (1.0 - (0..6).map(|i| (n - w - i as f64) / (n - i as f64)).product::<f64>());
    let num = |r: &BTreeMap<String, String>, c: &str| r[c].parse::<f64>().unwrap();
    for (row, (tolerance, w, matched)) in pairs.iter().zip([
        ("0.0833 s", 21.0, 0),
        ("0.25 s", 61.0, 6),
        ("0.5 s", 121.0, 6),
        ("1 s", 241.0, 6),
    ]) {
        assert_eq!(
            (row["sequence"].as_str(), row["annotator_a"].as_str(), row["annotator_b"].as_str()),
            ("86_01", "zhou", "shifted")
        );
        assert_eq!(row["tolerance"], tolerance);
        assert_eq!(num(row, "n_matched") as usize, matched, "{row:?}");
        assert_eq!(num(row, "f1"), matched as f64 / 6.0);
        let e = expected(w);
        assert!(
            (num(row, "chance_matched") - e).abs() < 1e-9,
            "{tolerance}: {} vs {e}",
            row["chance_matched"]
        );
        let kappa = (matched as f64 - e) / (6.0 - e);
        assert!(
            (num(row, "kappa") - kappa).abs() < 1e-9,
            "{tolerance}: {} vs {kappa}",
            row["kappa"]
        );
    }
    assert_eq!(pairs[4]["sequence"], "pooled");
    assert_eq!(pairs[4]["kappa"], pairs[0]["kappa"]);

    // Each method against both annotators, at 0.5 s (60 frames), from the run's candidates.
    let candidates = read_table(&run.join("tables/candidates.csv"));
    let ceiling = read_table(&run.join("tables/human_ceiling.csv"));
    let mut methods = 0;
    for row in ceiling.iter().filter(|r| r["sequence"] == "86_01" && r["tolerance"] == "0.5 s") {
        let found: Vec<usize> = candidates
            .iter()
            .filter(|c| c["sequence"] == "86_01" && c["method"] == row["method"])
            .map(|c| c["frame"].parse().unwrap())
            .collect();
        let matched = max_matching(&found, &zhou, 60.0) + max_matching(&found, &shifted, 60.0);
        let f1 = 2.0 * matched as f64 / (2 * found.len() + 12) as f64;
        assert!((num(row, "f1") - f1).abs() < 1e-12, "{}: {} vs {f1}", row["method"], row["f1"]);
        assert_eq!(num(row, "human_f1"), 1.0);
        let (chance, of_ceiling) = (num(row, "chance_f1"), num(row, "fraction_of_ceiling"));
        assert!(chance > 0.0 && chance < 1.0);
        assert!((of_ceiling - (f1 - chance) / (1.0 - chance)).abs() < 1e-12);
        methods += 1;
    }
    assert_eq!(methods, 6);
    // The run page and the index show the pooled rows between the floor and the ceiling.
    let page = std::fs::read_to_string(run.join("index.html")).unwrap();
    assert!(
        page.contains("Between chance and the annotators") && page.contains("class=\"score\""),
        "run page"
    );
    motionlab_ok(&["index", "--experiments", "tests/fixtures/annotations", "--reports", r]);
    let index = std::fs::read_to_string(reports.path().join("index.html")).unwrap();
    assert!(
        index.contains("Between chance and the annotators") && index.contains("speed_minima"),
        "index"
    );
}

/// The files the viewer page downloaded in the browser test (`tests/browser/check_annotate.py`
/// with `KEEP_DIR`: two annotators of CMU 86_01, one label with a comma and quotes) read back
/// through both readers to the frames marked, and are byte for byte what the Rust writers give
/// for the same marks — the page and `motionlab export` write one format.
#[test]
fn the_viewers_downloads_read_back_and_match_the_rust_writers() {
    let dir = repo().join("tests/fixtures/annotations");
    let motion = registry::build_loader("asf_amc", &toml::Value::Table(Default::default()))
        .unwrap()
        .load(&motionlab_testkit::data_path("cmu86/86_01.amc.gz"))
        .unwrap();
    let (csv, eaf) = (dir.join("viewer_86_01.csv"), dir.join("viewer_86_01.eaf"));
    let cmu = vec![549, 1149, 1979, 2499, 3199, 4064];
    for (who, frames) in [("tester", vec![600, 1993, 3211]), ("actions", cmu)] {
        assert_eq!(
            read_truth("boundaries_csv", &format!("annotator = {who:?}"), &csv, &motion).frames(),
            frames,
            "{who} via CSV"
        );
        assert_eq!(
            read_truth("elan_eaf", &format!("tier = {who:?}"), &eaf, &motion).frames(),
            frames,
            "{who} via .eaf"
        );
    }
    // The same marks through the Rust writers.
    let text = std::fs::read_to_string(&csv).unwrap();
    let parsed = parse_boundaries_csv(&text, &csv).unwrap();
    let tiers: Vec<MarkTier> = parsed
        .tracks("86_01")
        .into_iter()
        .map(|t| MarkTier {
            name: t.annotator,
            marks: t
                .items
                .iter()
                .map(|i| TierMark { frame: i.start as usize, label: i.label.clone() })
                .collect(),
        })
        .collect();
    let seq = SequenceTiers {
        name: "86_01".into(),
        sequence: "86_01".into(),
        input_sha256: motionlab_cache::hex(&motionlab_cache::sha256(
            &std::fs::read(motionlab_testkit::data_path("cmu86/86_01.amc.gz")).unwrap(),
        )),
        frame_rate_hz: motion.frame_rate().hz(),
        n_frames: motion.n_frames(),
        tiers,
    };
    assert_eq!(write_boundaries_csv(&seq), text);
    let page_eaf = std::fs::read_to_string(&eaf).unwrap();
    let date = page_eaf.split("DATE=\"").nth(1).and_then(|s| s.split('"').next()).unwrap();
    assert_eq!(write_eaf(&seq, date).unwrap(), page_eaf);
}
