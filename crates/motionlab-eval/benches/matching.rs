//! Cost of the boundary matching and of the Table 1 evaluator (divan, one core).
//!
//! `cargo bench -p motionlab-eval` — results and the comparison with scipy are in
//! `benches/README.md`.

use std::sync::Arc;

use divan::counter::ItemsCount;
use divan::{Bencher, black_box};
use motionlab_core::registry::{build_evaluator, default_params};
use motionlab_core::{
    Boundary, EvalInput, FrameRate, MethodResult, Segment, Segmentation, SequenceResult,
};
use motionlab_eval::boundaries::{
    MatchRule, TruthWindow, evaluate_boundaries, hausdorff_frames, max_matching_graph,
    max_matching_windows,
};
use motionlab_testkit::{Rng, motion_from_fn};

fn main() {
    divan::main();
}

/// n found frames and n truths uniform over 10·n frames, tolerance 20 frames: every window
/// holds about four found frames, so many matchings compete.
fn instance(n: usize) -> (Vec<usize>, Vec<TruthWindow>) {
    let mut rng = Rng::new(42);
    let span = 10.0 * n as f64;
    let found = (0..n).map(|_| (rng.uniform() * span) as usize).collect();
    let windows =
        (0..n).map(|_| TruthWindow::around((rng.uniform() * span) as usize, 20.0)).collect();
    (found, windows)
}

/// Which windows contain each found frame (all windows have the same width, so those are the
/// truths within the tolerance: a binary search in the truths sorted by frame).
fn adjacency(found: &[usize], windows: &[TruthWindow]) -> Vec<Vec<usize>> {
    let mut order: Vec<usize> = (0..windows.len()).collect();
    order.sort_by_key(|&j| windows[j].frame);
    found
        .iter()
        .map(|&a| {
            let lo = order.partition_point(|&j| windows[j].hi < a as f64);
            let hi = order.partition_point(|&j| windows[j].lo <= a as f64);
            order[lo..hi].to_vec()
        })
        .collect()
}

#[divan::bench(args = [1_000, 10_000, 100_000])]
fn window_sweep(bencher: Bencher, n: usize) {
    let (found, windows) = instance(n);
    bencher
        .counter(ItemsCount::new(2 * n))
        .bench(|| max_matching_windows(black_box(&found), black_box(&windows)).len());
}

#[divan::bench(args = [1_000, 10_000, 100_000])]
fn hopcroft_karp(bencher: Bencher, n: usize) {
    let (found, windows) = instance(n);
    let adj = adjacency(&found, &windows);
    bencher.counter(ItemsCount::new(2 * n)).bench(|| max_matching_graph(n, black_box(&adj)).len());
}

#[divan::bench(args = [1_000, 100_000])]
fn hausdorff(bencher: Bencher, n: usize) {
    let (found, windows) = instance(n);
    let truth: Vec<usize> = windows.iter().map(|w| w.frame).collect();
    bencher
        .counter(ItemsCount::new(2 * n))
        .bench(|| hausdorff_frames(black_box(&found), black_box(&truth)));
}

/// One method on one sequence the size of CMU 86_01: 6 truths, 120 candidates.
#[divan::bench]
fn evaluate_one_method(bencher: Bencher) {
    let mut rng = Rng::new(1);
    let truth: Vec<Boundary> = [549, 1149, 1979, 2499, 3199, 4064]
        .iter()
        .map(|&frame| Boundary { frame, window: None })
        .collect();
    let mut found: Vec<usize> = (0..120).map(|_| (rng.uniform() * 4579.0) as usize).collect();
    found.sort_unstable();
    bencher.bench(|| {
        evaluate_boundaries(black_box(&found), black_box(&truth), &MatchRule::time(10.0))
            .scores
            .n_matched
    });
}

/// The whole `boundary_pr` evaluator on a Table-1-sized input: 4 sequences × 4 methods, ~100
/// candidates each, 6 truths per sequence — including building the output tables.
#[divan::bench]
fn boundary_pr_table1(bencher: Bencher) {
    let mut rng = Rng::new(2);
    let rate = FrameRate::new(120.0).unwrap();
    let sequences: Vec<SequenceResult> = (0..4)
        .map(|s| {
            let n = 4600;
            let cuts = [0, 549, 1149, 1979, 2499, 3199, 4064, n];
            let segments = cuts
                .windows(2)
                .map(|w| Segment { start: w[0], end: w[1], label: format!("a{}", w[0]) })
                .collect();
            let methods = ["speed", "direction", "hull", "fused"]
                .iter()
                .map(|m| {
                    let mut c: Vec<usize> =
                        (0..100).map(|_| (rng.uniform() * n as f64) as usize).collect();
                    c.sort_unstable();
                    c.dedup();
                    MethodResult { method: m.to_string(), candidates: c }
                })
                .collect();
            SequenceResult {
                sequence: format!("s{s}"),
                motion: Arc::new(motion_from_fn(n, 120.0, 1, |_, _| [0.0; 3])),
                truth: Some(Segmentation::from_segments(rate, segments).unwrap()),
                methods,
            }
        })
        .collect();
    let evaluator = build_evaluator("boundary_pr", &default_params()).unwrap();
    bencher.bench(|| {
        evaluator.evaluate(EvalInput::segmentation(black_box(&sequences))).unwrap().len()
    });
}
