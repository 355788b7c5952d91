//! Benchmarks of the profile segmenters on TSSB series (`benches/README.md`).

use motionlab_core::ParamGuard;
use motionlab_profile::{ClaspParams, FlossParams};

fn main() {
    divan::main();
}

fn tssb(name: &str) -> (Vec<f64>, usize) {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/tssb/datasets");
    let text = std::fs::read_to_string(format!("{dir}/{name}.txt")).expect("TSSB series");
    let values = text
        .lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| l.trim().parse().expect("float"))
        .collect();
    let desc = std::fs::read_to_string(format!("{dir}/desc.txt")).expect("desc.txt");
    let window = desc
        .lines()
        .find_map(|l| l.strip_prefix(&format!("{name},")))
        .and_then(|r| r.split(',').next())
        .and_then(|w| w.parse().ok())
        .expect("window");
    (values, window)
}

/// TSSB series of 1,506, 2,163 and 20,700 samples (Crop is the benchmark's longest).
const SERIES: [&str; 3] = ["ArrowHead", "Car", "Crop"];

#[divan::bench(args = SERIES, sample_count = 5)]
fn clasp_segment(bencher: divan::Bencher, name: &str) {
    let (x, _) = tssb(name);
    let stage = ClaspParams::default().check().unwrap();
    bencher.bench(|| stage.segment_values(divan::black_box(&x), 1).unwrap());
}

#[divan::bench(args = SERIES, sample_count = 5)]
fn clasp_profile(bencher: divan::Bencher, name: &str) {
    let (x, w) = tssb(name);
    let stage = ClaspParams::default().check().unwrap();
    bencher.bench(|| stage.profile(divan::black_box(&x), 1, w).unwrap());
}

#[divan::bench(args = SERIES, sample_count = 5)]
fn floss_segment(bencher: divan::Bencher, name: &str) {
    let (x, w) = tssb(name);
    let stage = FlossParams {
        window: motionlab_profile::clasp::WindowWidth::Samples(w),
        n_regimes: Some(3),
        cac_threshold: None,
        excl_factor: 5,
    }
    .check()
    .unwrap();
    bencher.bench(|| stage.segment_values(divan::black_box(&x), 1).unwrap());
}
