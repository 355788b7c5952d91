//! The evaluators on the real sequences of the paper-reproduction experiment: CMU 86_01 with its
//! HACA labels and mocap6 13_29–13_31 with their block labels, loaded through the registered
//! loaders and ground-truth readers. Candidate lists are built from the labels themselves, so
//! every expected number below follows from the label files.

use std::path::Path;
use std::sync::{Arc, OnceLock};

use motionlab_core::registry::{build_evaluator, build_ground_truth, build_loader, default_params};
use motionlab_core::{
    ColumnValues, EvalInput, Evaluator, MethodResult, Motion, Segmentation, SequenceResult, Table,
};
use motionlab_eval::boundaries::{PoseRule, root_aligned_pose_distance};
use motionlab_testkit::{Rng, data_path};
// Linked for its registered loaders and ground-truth readers.
use motionlab_io as _;

fn load(amc: &str) -> Motion {
    build_loader("asf_amc", &default_params()).unwrap().load(&data_path(amc)).unwrap()
}

fn truth(reader: &str, params: &str, path: &Path, motion: &Motion) -> Segmentation {
    let v: toml::Value = toml::from_str(params).unwrap();
    build_ground_truth(reader, &v).unwrap().read(path, motion).unwrap()
}

fn evaluator(name: &str, params: &str) -> Box<dyn Evaluator> {
    let v: toml::Value = toml::from_str(params).unwrap();
    build_evaluator(name, &v).unwrap()
}

fn column_f64(t: &Table, name: &str) -> Vec<f64> {
    match t.column(name) {
        Some(ColumnValues::F64(v)) => v.clone(),
        Some(ColumnValues::I64(v)) => v.iter().map(|&x| x as f64).collect(),
        other => panic!("{name}: {other:?}"),
    }
}

fn cells(t: &Table, name: &str) -> Vec<String> {
    (0..t.n_rows()).map(|i| t.column(name).unwrap().cell(i)).collect()
}

/// 86_01 with three "methods" made from its labels: the annotated window starts (50 frames =
/// 0.42 s before each boundary), the boundaries themselves, and their union (last = "fused").
fn cmu86_01() -> (SequenceResult, Vec<usize>) {
    // Loaded once for both tests (an unoptimised test build parses the AMC slowly).
    static MOTION: OnceLock<Arc<Motion>> = OnceLock::new();
    let motion = MOTION.get_or_init(|| Arc::new(load("cmu86/86_01.amc.gz"))).clone();
    assert_eq!(motion.n_frames(), 4579);
    let truth = truth("cmu86_labels", "trial = \"86_01\"", &data_path("cmu86/mocap.txt"), &motion);
    let frames = truth.frames();
    // mocap.txt: `walk 500 550 600` … — boundary b − 1, window start a − 1 (0-based).
    assert_eq!(frames, vec![549, 1149, 1979, 2499, 3199, 4064]);
    let starts: Vec<usize> = truth.boundaries.iter().map(|b| b.window.unwrap().0).collect();
    assert_eq!(starts, vec![499, 1099, 1929, 2449, 3149, 4014]);
    let mut union: Vec<usize> = starts.iter().chain(&frames).copied().collect();
    union.sort_unstable();
    let seq = SequenceResult {
        sequence: "86_01".into(),
        motion,
        truth: Some(truth),
        methods: vec![
            MethodResult { method: "window_start".into(), candidates: starts },
            MethodResult { method: "boundary".into(), candidates: frames.clone() },
            MethodResult { method: "fused".into(), candidates: union },
        ],
    };
    (seq, frames)
}

#[test]
fn cmu86_table1_and_table3_from_the_real_labels() {
    let (seq, _) = cmu86_01();
    let seqs = vec![seq];
    // Default tolerance 1/12 s = 10 frames at 120 Hz: window starts (50 early) never match.
    let tables = evaluator("boundary_pr", "").evaluate(EvalInput::segmentation(&seqs)).unwrap();
    let t1 = &tables[0];
    assert_eq!(cells(t1, "sequence"), ["86_01", "86_01", "86_01", "pooled", "pooled", "pooled"]);
    assert_eq!(column_f64(t1, "n_matched")[..3], [0.0, 6.0, 6.0]);
    assert_eq!(column_f64(t1, "precision")[..3], [0.0, 1.0, 0.5]);
    assert_eq!(column_f64(t1, "recall")[..3], [0.0, 1.0, 1.0]);
    assert_eq!(column_f64(t1, "hausdorff_frames")[..3], [50.0, 0.0, 50.0]);
    assert!((column_f64(t1, "tolerance_frames")[0] - 10.0).abs() < 1e-9);
    // Fused recall equals (not exceeds) the best single method's: the claim does not hold.
    let claim = &tables[2];
    assert_eq!(cells(claim, "best_other_method"), ["boundary"]);
    assert_eq!(claim.column("fused_exceeds_all"), Some(&ColumnValues::Bool(vec![false])));
    // The annotated windows (±50 frames here) accept the window starts; one-to-one matching
    // still lets the fused list (12 frames, two per window) match only the 6 truths.
    let windowed = evaluator("boundary_pr", "use_windows = true")
        .evaluate(EvalInput::segmentation(&seqs))
        .unwrap();
    assert_eq!(column_f64(&windowed[0], "n_matched")[..3], [6.0, 6.0, 6.0]);
    assert_eq!(column_f64(&windowed[0], "precision")[..3], [1.0, 1.0, 0.5]);

    // Table 3 on the fused method: every labelled transition found; on the window starts none,
    // each 50 frames (0.4167 s) from its nearest candidate.
    let t3 =
        evaluator("transitions", "").evaluate(EvalInput::segmentation(&seqs)).unwrap().remove(0);
    assert_eq!(cells(&t3, "from"), ["walk", "jump", "walk", "punch", "walk", "leg_kick"]);
    assert_eq!(cells(&t3, "to"), ["jump", "walk", "punch", "walk", "leg_kick", "punch"]);
    assert_eq!(cells(&t3, "detected"), ["○"; 6]);
    let t3 = evaluator("transitions", "method = \"window_start\"")
        .evaluate(EvalInput::segmentation(&seqs))
        .unwrap()
        .remove(0);
    assert_eq!(cells(&t3, "detected"), ["×"; 6]);
    assert!(column_f64(&t3, "distance_s").iter().all(|d| (d - 50.0 / 120.0).abs() < 1e-12));
}

#[test]
fn cmu86_pose_rule_on_the_real_skeleton() {
    let (seq, frames) = cmu86_01();
    let motion = seq.motion.clone();
    let root = motion.point_index("root").unwrap();
    // Independent formula: |(p_a − p_b) − (r_a − r_b)| averaged over the non-root points.
    let mut rng = Rng::new(86);
    for _ in 0..50 {
        let (a, b) = ((rng.uniform() * 4579.0) as usize, (rng.uniform() * 4579.0) as usize);
        let (pa, pb) = (motion.frame(a), motion.frame(b));
        let mut sum = 0.0;
        for k in (0..motion.n_points()).filter(|&k| k != root) {
            let d: Vec<f64> =
                (0..3).map(|c| (pa[k][c] - pb[k][c]) - (pa[root][c] - pb[root][c])).collect();
            sum += d.iter().map(|x| x * x).sum::<f64>().sqrt();
        }
        let expected = sum / (motion.n_points() - 1) as f64;
        let got = root_aligned_pose_distance(&motion, root, a, b).unwrap();
        assert!((got - expected).abs() < 1e-9 * (1.0 + expected), "{a} {b}: {got} vs {expected}");
    }
    // Candidates 30 frames (0.25 s) after each boundary: outside the 10-frame tolerance.
    let late: Vec<usize> = frames.iter().map(|f| f + 30).collect();
    let pose = PoseRule::new(&motion, "root", 1.0, None).unwrap();
    let distances: Vec<f64> =
        frames.iter().zip(&late).map(|(&b, &l)| pose.distance_mm(b, l).unwrap()).collect();
    // A real body moves in 0.25 s: every distance is positive and below a body length.
    assert!(distances.iter().all(|&d| d > 1.0 && d < 1000.0), "{distances:?}");
    let largest = distances.iter().copied().fold(0.0, f64::max);
    let smallest = distances.iter().copied().fold(f64::INFINITY, f64::min);
    let mut s = seq.clone();
    s.methods = vec![MethodResult { method: "late".into(), candidates: late }];
    let matched = |params: &str| -> f64 {
        let t = evaluator("boundary_pr", params)
            .evaluate(EvalInput::segmentation(&vec![s.clone()]))
            .unwrap();
        column_f64(&t[0], "n_matched_by_pose")[0]
    };
    assert_eq!(matched(""), 0.0);
    assert_eq!(matched(&format!("pose_mm = {}", largest * 1.001)), 6.0);
    assert_eq!(matched(&format!("pose_mm = {}", smallest * 0.999)), 0.0);
    // The pose rule's time limit: 0.25 s apart is inside 0.3 s, outside 0.2 s.
    assert_eq!(
        matched(&format!("pose_mm = {}\npose_max_gap = {{ seconds = 0.3 }}", largest * 1.001)),
        6.0
    );
    assert_eq!(
        matched(&format!("pose_mm = {}\npose_max_gap = {{ seconds = 0.2 }}", largest * 1.001)),
        0.0
    );
}

#[test]
fn mocap6_pooled_over_three_sequences() {
    let mut seqs = Vec::new();
    let mut n_truth = 0;
    for name in ["13_29", "13_30", "13_31"] {
        let motion = load(&format!("mocap6/amc/{name}.amc.gz"));
        let truth = truth(
            "mocap6_labels",
            "",
            &data_path(&format!("mocap6/truelabels/{name}.txt")),
            &motion,
        );
        n_truth += truth.boundaries.len();
        // Block labels are 12 frames (0.1 s) coarse: shift by 6 frames (half a block, inside
        // the 10-frame default tolerance) and by 12 (a whole block, outside it).
        let half: Vec<usize> = truth.frames().iter().map(|f| f + 6).collect();
        let whole: Vec<usize> = truth.frames().iter().map(|f| f + 12).collect();
        seqs.push(SequenceResult {
            sequence: name.into(),
            motion: Arc::new(motion),
            truth: Some(truth),
            methods: vec![
                MethodResult { method: "whole_block".into(), candidates: whole },
                MethodResult { method: "half_block".into(), candidates: half },
            ],
        });
    }
    // Label changes (from the files): 13_29 at 468 1212 1920 2700 3804, 13_30 at 216 804 1416
    // 1932, 13_31 at 396 984 1392 1608 2052 2724 — at least 216 frames apart, so a 12-frame
    // shift never reaches the next boundary.
    assert_eq!(n_truth, 15);
    let tables = evaluator("boundary_pr", "").evaluate(EvalInput::segmentation(&seqs)).unwrap();
    let t1 = &tables[0];
    assert_eq!(t1.n_rows(), 3 * 2 + 2);
    let pooled_truth = column_f64(t1, "n_truth");
    assert_eq!(pooled_truth[6..], [n_truth as f64, n_truth as f64]);
    assert_eq!(column_f64(t1, "recall")[6..], [0.0, 1.0]);
    assert_eq!(cells(&tables[2], "fused_exceeds_all"), ["true"]);
    // Table 3 has one row per labelled transition of the three sequences.
    let t3 =
        evaluator("transitions", "").evaluate(EvalInput::segmentation(&seqs)).unwrap().remove(0);
    assert_eq!(t3.n_rows(), n_truth);
    assert!(cells(&t3, "detected").iter().all(|d| d == "○"));
}

/// mct/walk1 has 27 real missing samples (Head_FR frames 199–209, Shoulder_R 304–319). The pose
/// rule leaves missing markers out of its mean and refuses a missing root; the consensus stop
/// rule reads V, which skips missing markers.
#[test]
fn walk1_missing_samples_in_the_pose_and_stop_rules() {
    let walk = build_loader("qualisys_tsv", &default_params())
        .unwrap()
        .load(&data_path("mct/walk1.tsv.gz"))
        .unwrap();
    assert_eq!(walk.missing_count(), 27);
    let head_fr = walk.point_index("Head_FR").unwrap();
    let sternum = walk.point_index("Sternum").unwrap();
    assert!(walk.is_missing(200, head_fr) && !walk.is_missing(150, head_fr));
    // Independent computation over the 26 markers that are neither the root nor missing.
    let (a, b) = (200, 150);
    let others: Vec<usize> =
        (0..walk.n_points()).filter(|&k| k != sternum && k != head_fr).collect();
    assert_eq!(others.len(), 26);
    let expected = others
        .iter()
        .map(|&k| {
            let d: Vec<f64> = (0..3)
                .map(|c| {
                    (walk.position(a, k)[c] - walk.position(a, sternum)[c])
                        - (walk.position(b, k)[c] - walk.position(b, sternum)[c])
                })
                .collect();
            d.iter().map(|x| x * x).sum::<f64>().sqrt()
        })
        .sum::<f64>()
        / 26.0;
    let got = root_aligned_pose_distance(&walk, sternum, a, b).unwrap();
    assert!(got.is_finite() && (got - expected).abs() < 1e-9, "{got} vs {expected}");
    assert_eq!(root_aligned_pose_distance(&walk, head_fr, a, b), None, "missing root: undefined");

    // Through the evaluator: a found frame 50 frames from the truth matches by pose only when
    // the root is present at both frames.
    let segments = vec![
        motionlab_core::Segment { start: 0, end: 200, label: "a".into() },
        motionlab_core::Segment { start: 200, end: walk.n_frames(), label: "b".into() },
    ];
    let seq = SequenceResult {
        sequence: "walk1".into(),
        truth: Some(Segmentation::from_segments(walk.frame_rate(), segments).unwrap()),
        motion: Arc::new(walk.clone()),
        methods: vec![MethodResult { method: "m".into(), candidates: vec![150] }],
    };
    let by_pose = |root: &str| {
        let params = format!("pose_mm = {}\nroot = \"{root}\"", expected * 1.01);
        let t = evaluator("boundary_pr", &params)
            .evaluate(EvalInput::segmentation(&vec![seq.clone()]))
            .unwrap();
        column_f64(&t[0], "n_matched_by_pose")[0]
    };
    assert_eq!(by_pose("Sternum"), 1.0);
    assert_eq!(by_pose("Head_FR"), 0.0);

    // Consensus stop rule: V at frames 199–209 is still defined (the other 27 markers), so a
    // lone mark there is kept exactly when V drops to max_speed somewhere within ±tol.
    let v = motionlab_features::speed::marker_speeds(&walk, 0).fastest;
    assert!(v[199..210].iter().all(|x| x.is_finite()));
    let slowest = v[199..=209].iter().copied().fold(f64::INFINITY, f64::min);
    let rule = |max_speed: f64| {
        let text = format!(
            "tolerance = {{ frames = 5 }}\nmin_votes = 2\nstop_rule = {{ max_speed = {max_speed} }}"
        );
        let v: toml::Value = toml::from_str(&text).unwrap();
        use motionlab_core::registry::ParamGuard;
        motionlab_core::registry::parse_params::<motionlab_eval::ConsensusParams>(&v)
            .unwrap()
            .check()
            .unwrap()
    };
    let marks = vec![vec![204], vec![]];
    assert_eq!(rule(slowest).run(&marks, &walk).unwrap().len(), 1);
    assert!(rule(slowest * 0.999).run(&marks, &walk).unwrap().is_empty());
}
