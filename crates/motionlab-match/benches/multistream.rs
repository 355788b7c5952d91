//! The two-stage multistream DP at the size of the Yabe experiments: 31 markers (a CMU skeleton's joints),
//! model 120 frames against a 600-frame window. Results and commands: `benches/README.md`.
//!
//! `cargo bench -p motionlab-match --bench multistream`
//!
//! The data are smooth synthetic trajectories (the DP's cost per cell does not depend on the
//! values: every cell does the same arithmetic and branch-free minima); the model is the
//! window's frames 240.. resampled at 1.1× speed, so the match lies inside the window as in a
//! real cut. `bench/multistream_vs_peers.py` feeds the same formula's data to our example
//! binary, dtaidistance and tslearn in one run.

use divan::counter::ItemsCount;
use divan::{Bencher, black_box};
use motionlab_match::dp::{
    Euclidean3, Trajectory3, Workspace, anchored_costs_into, anchored_path, subsequence_costs_into,
};
use motionlab_match::multistream::{end_costs, two_stage, two_stage_at_level};
use motionlab_match::simd::Level;

const MARKERS: usize = 31;
const MODEL: usize = 120;
const WINDOW: usize = 600;

/// Position of marker `l` at (fractional) frame `j` (mm) — the formula the peer script uses.
fn position(j: f64, l: usize) -> [f64; 3] {
    let l = l as f64;
    [
        300.0 * (0.05 * j + 0.3 * l).sin() + 20.0 * l,
        200.0 * (0.037 * j + 0.7 * l).cos(),
        150.0 * (0.021 * j - l).sin() + 900.0,
    ]
}

fn data() -> (Vec<Trajectory3>, Vec<Trajectory3>) {
    let model = (0..MARKERS)
        .map(|l| {
            Trajectory3::from_points(
                &(0..MODEL).map(|i| position(240.0 + 1.1 * i as f64, l)).collect::<Vec<_>>(),
            )
        })
        .collect();
    let target = (0..MARKERS)
        .map(|l| {
            Trajectory3::from_points(
                &(0..WINDOW).map(|j| position(j as f64, l)).collect::<Vec<_>>(),
            )
        })
        .collect();
    (model, target)
}

fn main() {
    divan::main();
}

/// Everything: forward pass, G, b, backward pass, a, h_l, H and the 31 paths.
#[divan::bench]
fn two_stage_with_paths(bencher: Bencher) {
    let (model, target) = data();
    let r = two_stage(&model, &target, true).expect("bench data are finite");
    let (a, b) = (r.alignment.start, r.alignment.end);
    let cells = MARKERS * MODEL * (WINDOW + (b + 1) + (b - a + 1));
    bencher
        .counter(ItemsCount::new(cells))
        .bench(|| two_stage(black_box(&model), black_box(&target), true));
}

/// The whole match with paths at each instruction-set level (capped at what the CPU runs: on a
/// CPU without AVX-512 the `Avx512` row repeats the best level it has).
#[divan::bench(args = [Level::Portable, Level::Avx2, Level::Avx512])]
fn two_stage_with_paths_at_level(bencher: Bencher, level: Level) {
    let (model, target) = data();
    let r = two_stage(&model, &target, true).expect("bench data are finite");
    let (a, b) = (r.alignment.start, r.alignment.end);
    let cells = MARKERS * MODEL * (WINDOW + (b + 1) + (b - a + 1));
    bencher
        .counter(ItemsCount::new(cells))
        .bench(|| two_stage_at_level(level, black_box(&model), black_box(&target), true));
}

/// The same without paths (the synchronisation stage needs them; H alone does not).
#[divan::bench]
fn two_stage_without_paths(bencher: Bencher) {
    let (model, target) = data();
    let r = two_stage(&model, &target, false).expect("bench data are finite");
    let b = r.alignment.end;
    let cells = MARKERS * MODEL * (WINDOW + (b + 1));
    bencher
        .counter(ItemsCount::new(cells))
        .bench(|| two_stage(black_box(&model), black_box(&target), false));
}

/// Stage 1 as `two_stage` runs it: markers eight to a DP cell (SIMD lanes), summed into G(j).
#[divan::bench]
fn forward_pass_31_markers_in_lanes(bencher: Bencher) {
    let (model, target) = data();
    bencher
        .counter(ItemsCount::new(MARKERS * MODEL * WINDOW))
        .bench(|| end_costs(black_box(&model), black_box(&target)));
}

/// Stage 1 one marker at a time (the scalar kernel), to show what the lanes buy.
#[divan::bench]
fn forward_pass_31_markers_one_by_one(bencher: Bencher) {
    let (model, target) = data();
    let mut ws = Workspace::new();
    let mut h = Vec::new();
    bencher.counter(ItemsCount::new(MARKERS * MODEL * WINDOW)).bench_local(|| {
        for (s, t) in model.iter().zip(&target) {
            subsequence_costs_into(&Euclidean3::new(s, t), &mut h, &mut ws).expect("finite");
            black_box(&h);
        }
    });
}

/// Stage 2 one marker at a time.
#[divan::bench]
fn backward_pass_31_markers_one_by_one(bencher: Bencher) {
    let (model, target) = data();
    let mut ws = Workspace::new();
    let mut c = Vec::new();
    bencher.counter(ItemsCount::new(MARKERS * MODEL * WINDOW)).bench_local(|| {
        for (s, t) in model.iter().zip(&target) {
            anchored_costs_into(&Euclidean3::new(s, t), WINDOW - 1, &mut c, &mut ws)
                .expect("finite");
            black_box(&c);
        }
    });
}

/// Paths alone, one marker at a time: 31 matrices over the whole window (a = 0, b = 599) and
/// their walks.
#[divan::bench]
fn paths_31_markers_full_window(bencher: Bencher) {
    let (model, target) = data();
    let mut ws = Workspace::new();
    bencher.counter(ItemsCount::new(MARKERS * MODEL * WINDOW)).bench_local(|| {
        for (s, t) in model.iter().zip(&target) {
            black_box(
                anchored_path(&Euclidean3::new(s, t), 0, WINDOW - 1, &mut ws).expect("finite"),
            );
        }
    });
}
