//! Throughput of Sonoda et al.'s whole pipeline on a real take — fastest-marker speed tracking,
//! direction change, hull-volume change and union-merge fusion, every feature computed from
//! scratch (a fresh `FeatureCache` per run), one core — in frames per second, on CMU 86_01
//! (4579 frames × 38 joints, 120 fps) repeated 1×, 10× and 100× by concatenation (the cost per
//! frame must not grow with length). Per-stage benches show where the time goes.
//!
//! `cargo bench -p motionlab-segment --bench pipeline` (results in `README.md` beside this file).

use std::sync::LazyLock;

use divan::Bencher;
use divan::counter::ItemsCount;
use motionlab_core::registry::{build_fuser, build_segmenter};
use motionlab_core::{FeatureCache, FrameRate, Fuser, MethodCandidates, Motion, Segmenter};
use motionlab_features::hull::{HullBuilder, HullTracker, hull_volumes};
use motionlab_features::speed::marker_speeds;

fn main() {
    divan::main();
}

fn data(relative: &str) -> std::path::PathBuf {
    std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data").join(relative)
}

static TAKE: LazyLock<Motion> = LazyLock::new(|| {
    motionlab_io::asf_amc::load_asf_amc(
        &data("cmu86/86_01.amc.gz"),
        &data("cmu86/86.asf"),
        FrameRate::new(120.0).unwrap(),
    )
    .expect("86_01 loads")
});

/// 86_01 repeated `times` times, end to end.
fn repeated(times: usize) -> Motion {
    let m = &*TAKE;
    let positions: Vec<[f64; 3]> = (0..times).flat_map(|_| m.positions().iter().copied()).collect();
    Motion::new(
        m.name.clone(),
        m.frame_rate(),
        m.up_axis(),
        m.point_kind(),
        m.point_names().to_vec(),
        positions,
    )
    .unwrap()
}

static REPEATED: LazyLock<Vec<(usize, Motion)>> =
    LazyLock::new(|| [1, 10, 100].into_iter().map(|t| (t, repeated(t))).collect());

struct Pipeline {
    segmenters: Vec<(&'static str, Box<dyn Segmenter>)>,
    fuser: Box<dyn Fuser>,
}

fn pipeline() -> Pipeline {
    let empty = toml::Value::Table(Default::default());
    // Name something in this crate so it is linked and its plugins are registered.
    let _ = motionlab_segment::union_merge::cumulative_path_mm(std::iter::empty());
    let segmenters = ["fastest_marker_speed", "direction_change", "hull_volume_change"]
        .into_iter()
        .map(|n| (n, build_segmenter(n, &empty).unwrap()))
        .collect();
    Pipeline { segmenters, fuser: build_fuser("union_merge", &empty).unwrap() }
}

fn run(p: &Pipeline, m: &Motion) -> Vec<usize> {
    let cache = FeatureCache::new();
    let found: Vec<(&str, Vec<usize>)> =
        p.segmenters.iter().map(|(n, s)| (*n, s.segment(m, &cache).unwrap().candidates)).collect();
    let inputs: Vec<MethodCandidates> =
        found.iter().map(|(method, frames)| MethodCandidates { method, frames }).collect();
    p.fuser.fuse(m, &inputs).unwrap()
}

/// The whole pipeline, per repetition count of 86_01 (1×, 10×, 100×).
#[divan::bench(args = [1, 10, 100], sample_count = 25, sample_size = 1)]
fn whole_pipeline(bencher: Bencher, times: usize) {
    let m = &REPEATED.iter().find(|(t, _)| *t == times).unwrap().1;
    let p = pipeline();
    bencher.counter(ItemsCount::new(m.n_frames())).bench(|| run(&p, m));
}

/// Stage: per-marker speeds and V.
#[divan::bench]
fn stage_marker_speeds(bencher: Bencher) {
    bencher.counter(ItemsCount::new(TAKE.n_frames())).bench(|| marker_speeds(&TAKE, 0));
}

/// Stage: hull volumes of every frame (coherent tracker) and D.
#[divan::bench]
fn stage_hull_volumes(bencher: Bencher) {
    bencher.counter(ItemsCount::new(TAKE.n_frames())).bench(|| hull_volumes(&TAKE));
}

/// Stage: hull volumes with the tracker as it was before local repairs (certify unchanged
/// triangles, else rebuild), for comparison in the same run.
#[divan::bench]
fn stage_hull_volumes_without_repairs(bencher: Bencher) {
    let frames: Vec<Vec<[f64; 3]>> = (0..TAKE.n_frames()).map(|i| TAKE.frame(i).to_vec()).collect();
    bencher.counter(ItemsCount::new(TAKE.n_frames())).bench(|| {
        let mut t = HullTracker::without_repairs();
        frames.iter().map(|f| t.frame(f).volume_mm3).sum::<f64>()
    });
}

/// Stage: hull volumes, rebuilding every frame (no temporal coherence), for comparison.
#[divan::bench]
fn stage_hull_volumes_rebuilt(bencher: Bencher) {
    let frames: Vec<Vec<[f64; 3]>> = (0..TAKE.n_frames()).map(|i| TAKE.frame(i).to_vec()).collect();
    bencher.counter(ItemsCount::new(TAKE.n_frames())).bench(|| {
        let mut b = HullBuilder::new();
        frames.iter().map(|f| b.volume(f).volume_mm3).sum::<f64>()
    });
}

/// Stage: everything except the hull (speed tracking, curvature, fusion) — what the pipeline
/// would cost without its dominant feature.
#[divan::bench]
fn pipeline_without_hull(bencher: Bencher) {
    let empty = toml::Value::Table(Default::default());
    let p = pipeline();
    let segs: Vec<(&str, Box<dyn Segmenter>)> = ["fastest_marker_speed", "direction_change"]
        .into_iter()
        .map(|n| (n, build_segmenter(n, &empty).unwrap()))
        .collect();
    let p = Pipeline { segmenters: segs, fuser: p.fuser };
    bencher.counter(ItemsCount::new(TAKE.n_frames())).bench(|| run(&p, &TAKE));
}
