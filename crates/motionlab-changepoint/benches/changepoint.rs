//! Benchmarks of the change-point segmenters on seeded piecewise-Gaussian series (10 segments,
//! one channel unless said). `cargo bench -p motionlab-changepoint`; results and how to read
//! them in `benches/README.md`.

use motionlab_changepoint::{BocpdParams, KernelCpdParams, WindowParams};
use motionlab_core::registry::ParamGuard;

fn main() {
    divan::main();
}

/// n samples in 10 segments of random mean (N(0, 3²)) and unit noise, `channels` channels.
fn series(n: usize, channels: usize, seed: u64) -> Vec<f64> {
    let mut rng = fastrand::Rng::with_seed(seed);
    let mut gauss = move || {
        (-2.0 * rng.f64().max(1e-300).ln()).sqrt() * (std::f64::consts::TAU * rng.f64()).cos()
    };
    let means: Vec<f64> = (0..10 * channels).map(|_| 3.0 * gauss()).collect();
    (0..n * channels)
        .map(|i| means[(i / channels) * 10 / n * channels + i % channels] + gauss())
        .collect()
}

fn kernel_cpd(toml_text: &str) -> motionlab_changepoint::KernelCpd {
    toml::from_str::<KernelCpdParams>(toml_text).unwrap().check().unwrap()
}

/// ruptures' KernelCPD PELT with the rbf kernel (bandwidth given, penalty log n).
#[divan::bench(args = [2_000, 10_000, 100_000], sample_count = 5)]
fn kernel_pelt_rbf(bencher: divan::Bencher, n: usize) {
    let x = series(n, 1, 1);
    let stage = kernel_cpd(&format!(
        "search = \"kernel_pelt\"\ncost = \"rbf\"\ngamma = 0.05\npen = {}",
        (n as f64).ln()
    ));
    bencher.bench(|| stage.segment_values(divan::black_box(&x), 1).unwrap());
}

/// The same with the median-heuristic bandwidth (its O(n log n) selection included).
#[divan::bench(args = [10_000, 100_000], sample_count = 5)]
fn kernel_pelt_rbf_median_heuristic(bencher: divan::Bencher, n: usize) {
    let x = series(n, 1, 1);
    let stage = kernel_cpd("search = \"kernel_pelt\"\ncost = \"rbf\"\npen = \"bic\"");
    bencher.bench(|| stage.segment_values(divan::black_box(&x), 1).unwrap());
}

/// ruptures' median-heuristic bandwidth alone: one channel (sort and bisection, O(n log n)) and
/// three channels (radix selection over all pairs, O(n²)).
#[divan::bench(args = [(1, 10_000), (1, 100_000), (3, 2_000), (3, 10_000)], sample_count = 5)]
fn median_heuristic(bencher: divan::Bencher, (channels, n): (usize, usize)) {
    let x = series(n, channels, 2);
    bencher.bench(|| {
        motionlab_changepoint::kernel_cpd::median_heuristic(divan::black_box(&x), channels).unwrap()
    });
}

/// ruptures' Pelt semantics: l2 (prefix sums) and rbf (running kernel sums), jump 5, at the
/// BIC-style penalty.
#[divan::bench(args = ["l2", "rbf"], sample_count = 5)]
fn pelt_jump5_n10000(bencher: divan::Bencher, cost: &str) {
    let x = series(10_000, 1, 3);
    let stage = kernel_cpd(&format!("search = \"pelt\"\ncost = \"{cost}\"\npen = \"bic\""));
    bencher.bench(|| stage.segment_values(divan::black_box(&x), 1).unwrap());
}

/// Binary segmentation, 9 breakpoints asked, jump 5.
#[divan::bench(args = ["l2", "rbf"], sample_count = 5)]
fn binseg_n_bkps9_n5000(bencher: divan::Bencher, cost: &str) {
    let x = series(5_000, 1, 4);
    let stage = kernel_cpd(&format!("search = \"binseg\"\ncost = \"{cost}\"\nn_bkps = 9"));
    bencher.bench(|| stage.segment_values(divan::black_box(&x), 1).unwrap());
}

/// Window, width 100, jump 5, BIC penalty.
#[divan::bench(args = ["l2", "rbf"], sample_count = 5)]
fn window_n10000(bencher: divan::Bencher, cost: &str) {
    let x = series(10_000, 1, 5);
    let stage =
        toml::from_str::<WindowParams>(&format!("cost = \"{cost}\"")).unwrap().check().unwrap();
    bencher.bench(|| stage.segment_values(divan::black_box(&x), 1).unwrap());
}

/// BOCPD at λ = 100 samples, exact posterior (every run length) and truncated at 1e-6.
#[divan::bench(args = [0.0, 1e-6], sample_count = 5)]
fn bocpd_n5000(bencher: divan::Bencher, truncate_below: f64) {
    let x = series(5_000, 1, 6);
    let stage = toml::from_str::<BocpdParams>(&format!(
        "lambda = 100.0\ntruncate_below = {truncate_below}"
    ))
    .unwrap()
    .check()
    .unwrap();
    bencher.bench(|| stage.segment_values(divan::black_box(&x), 1).unwrap());
}
