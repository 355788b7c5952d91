//! Every segmenter of this crate, in a range of settings, on degenerate series: each run gives
//! `Ok` with candidates inside `(0, n)` (sorted, unique) or one error naming a field — never a
//! panic.

use motionlab_changepoint::{BocpdParams, KernelCpdParams, WindowParams};
use motionlab_core::registry::ParamGuard;
use motionlab_core::{Result, SegmenterOutput};

fn inputs() -> Vec<(String, Vec<f64>, usize)> {
    let mut v: Vec<(String, Vec<f64>, usize)> = Vec::new();
    for n in [1usize, 2, 3, 4, 5, 7, 10, 15, 30, 100] {
        v.push((format!("constant n={n}"), vec![3.25; n], 1));
        v.push((format!("zeros n={n}"), vec![0.0; n], 1));
        v.push((format!("step n={n}"), (0..n).map(|i| if i < n / 2 { 0.0 } else { 1.0 }).collect(), 1));
        v.push((format!("ramp n={n}"), (0..n).map(|i| i as f64).collect(), 1));
        v.push((format!("constant 2ch n={n}"), vec![1.0; 2 * n], 2));
        v.push((format!("one constant channel n={n}"), (0..n).flat_map(|i| [5.0, (i % 3) as f64]).collect(), 2));
        let mut gap: Vec<f64> = (0..n).map(|i| ((i * 37) % 11) as f64).collect();
        gap[n / 2] = f64::NAN;
        v.push((format!("NaN gap n={n}"), gap, 1));
        v.push((format!("all NaN n={n}"), vec![f64::NAN; n], 1));
        v.push((format!("huge n={n}"), (0..n).map(|i| if i % 2 == 0 { 1e300 } else { -1e300 }).collect(), 1));
        v.push((format!("tiny n={n}"), (0..n).map(|i| 1e-300 * (i % 3) as f64).collect(), 1));
    }
    v.push(("NaN run".into(), (0..200).map(|i| if (50..120).contains(&i) { f64::NAN } else { (i % 7) as f64 }).collect(), 1));
    v.push(("leading NaN".into(), (0..200).map(|i| if i < 30 { f64::NAN } else { (i / 100) as f64 }).collect(), 1));
    // A clear change (noise around 0, then around 6 with more spread), so each setting finds something.
    v.push(("clear change".into(), (0..600).map(|i| (((i * 7919) % 101) as f64 / 101.0 - 0.5) * if i < 300 { 1.0 } else { 3.0 } + if i < 300 { 0.0 } else { 6.0 }).collect(), 1));
    v.push(("infinity".into(), vec![1.0, f64::INFINITY, 2.0, 3.0], 1));
    v.push(("empty".into(), vec![], 1));
    v.push(("ragged".into(), vec![1.0, 2.0, 3.0], 2));
    v.push(("no channels".into(), vec![1.0, 2.0], 0));
    v
}

/// Runs one case; true when it gave change points (so that a sweep can insist some did).
fn check_run(what: &str, input: &str, n_channels: usize, len: usize, run: impl FnOnce() -> Result<SegmenterOutput>) -> bool {
    let out = std::panic::catch_unwind(std::panic::AssertUnwindSafe(run));
    match out {
        Err(_) => panic!("{what} panicked on {input}"),
        Ok(Err(e)) => {
            assert!(!e.to_string().is_empty(), "{what} on {input}: an empty error");
            false
        }
        Ok(Ok(o)) => {
            let n = len.checked_div(n_channels).unwrap_or(0);
            assert!(o.candidates.windows(2).all(|w| w[0] < w[1]), "{what} on {input}: {:?}", o.candidates);
            assert!(o.candidates.iter().all(|&c| c > 0 && c < n), "{what} on {input}: {:?} for n = {n}", o.candidates);
            !o.candidates.is_empty()
        }
    }
}

const KERNEL_CPD: &[&str] = &[
    "",
    "cost = \"l2\"",
    "cost = \"rbf\"\ngamma = 0.5",
    "search = \"pelt\"",
    "search = \"binseg\"\npen = 3.0",
    "search = \"binseg\"\nn_bkps = 2\njump = 1\nmin_size = 1",
    "search = \"binseg\"\nn_bkps = 1\nmin_size = 2",
    "search = \"pelt\"\ncost = \"ar\"",
    "search = \"pelt\"\ncost = \"ar\"\nar_order = 3\npen = 10.0\nmin_size = 5\njump = 5",
    "search = \"binseg\"\ncost = \"ar\"\npen = 10.0\nmin_size = 2\njump = 1",
    "search = \"binseg\"\ncost = \"ar\"\nn_bkps = 1",
    "search = \"pelt\"\nnormalize = \"min_max\"",
    "search = \"pelt\"\ncost = \"l2\"\nnormalize = \"z_score\"",
    "search = \"pelt\"\ncost = \"l2\"\nmin_size = 1\njump = 1\npen = 0.001",
];

const WINDOW: &[&str] = &[
    "",
    "width = 4",
    "width = 10\ncost = \"rbf\"",
    "width = 10\nn_bkps = 1",
    "width = 10\ncost = \"ar\"\npen = 10.0",
    "width = 20\ncost = \"ar\"\nar_order = 3\nmin_size = 5\npen = 10.0",
    "width = 4\nnormalize = \"min_max\"",
    "width = 4\nnormalize = \"z_score\"\ncost = \"l2\"\nmin_size = 1\njump = 1",
];

const BOCPD: &[&str] = &[
    "",
    "lambda = 10.0",
    "normalize = \"min_max\"",
    "normalize = \"none\"",
    "model = \"bocd_package\"\nnormalize = \"min_max\"\nchange_points = \"run_length_drop\"\ndrop_threshold = 100.0",
    "model = \"bocd_package\"\nnormalize = \"none\"\nchange_points = \"run_length_drop\"\ndrop_threshold = 1.0",
    "truncate_below = 1e-6",
];

/// Every setting of `settings` on every input of [`inputs`]; at least one input must give
/// change points under each setting.
fn sweep<P: serde::de::DeserializeOwned + ParamGuard>(stage_name: &str, settings: &[&str], segment: impl Fn(&P::Checked, &[f64], usize) -> Result<SegmenterOutput>) {
    for text in settings {
        let params: P = toml::from_str(text).unwrap_or_else(|e| panic!("{text}: {e}"));
        let stage = params.check().unwrap_or_else(|e| panic!("{text}: {e}"));
        let mut found = 0;
        for (name, values, d) in inputs() {
            found += check_run(&format!("{stage_name} [{text}]"), &name, d, values.len(), || segment(&stage, &values, d)) as usize;
        }
        assert!(found > 0, "{stage_name} [{text}]: no input gave a change point");
    }
}

#[test]
fn kernel_cpd_never_panics_on_degenerate_series() {
    sweep::<KernelCpdParams>("kernel_cpd", KERNEL_CPD, |s, v, d| s.segment_values(v, d));
}

#[test]
fn window_never_panics_on_degenerate_series() {
    sweep::<WindowParams>("window", WINDOW, |s, v, d| s.segment_values(v, d));
}

#[test]
fn bocpd_never_panics_on_degenerate_series() {
    sweep::<BocpdParams>("bocpd", BOCPD, |s, v, d| s.segment_values(v, d));
}
