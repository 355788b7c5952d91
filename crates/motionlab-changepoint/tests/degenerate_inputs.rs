//! Every segmenter of this crate, in a range of settings, on degenerate series: each run gives
//! `Ok` with candidates inside `(0, n)` (sorted, unique) or one error — never a panic.

use motionlab_changepoint::{BocpdParams, KernelCpdParams, WindowParams};
use motionlab_testkit::degenerate::{Series, checked, degenerate_series, sweep_segmenter};

fn series() -> Vec<Series> {
    let mut v = degenerate_series(&[1, 2, 3, 4, 5, 7, 10, 15, 30, 100]);
    // A clear change (noise around 0, then around 6 with more spread), so each setting finds something.
    let clear = (0..600).map(|i| {
        (((i * 7919) % 101) as f64 / 101.0 - 0.5) * if i < 300 { 1.0 } else { 3.0 }
            + if i < 300 { 0.0 } else { 6.0 }
    });
    v.push(("clear change".into(), clear.collect(), 1));
    v
}

const KERNEL_CPD: &[&str] = &[
    "",
    "cost = \"l2\"",
    "cost = \"rbf\"\ngamma = 0.5",
    "search = \"pelt\"",
    "pen = \"bic\"",
    "search = \"pelt\"\ncost = \"l2\"\npenalty = { path = [\"bic\", \"whole_cost\"], choose = \"widest\" }",
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
    "expected_segment = { seconds = 0.05 }",
    "normalize = \"min_max\"",
    "normalize = \"none\"",
    "model = \"bocd_package\"\nnormalize = \"min_max\"\nchange_points = \"run_length_drop\"\ndrop_threshold = 100.0",
    "model = \"bocd_package\"\nnormalize = \"none\"\nchange_points = \"run_length_drop\"\ndrop_threshold = 1.0",
    "truncate_below = 1e-6",
];

#[test]
fn kernel_cpd_never_panics_on_degenerate_series() {
    sweep_segmenter("kernel_cpd", KERNEL_CPD, &series(), checked::<KernelCpdParams>, |s, v, d| {
        s.segment_values(v, d)
    });
}

#[test]
fn window_never_panics_on_degenerate_series() {
    sweep_segmenter("window", WINDOW, &series(), checked::<WindowParams>, |s, v, d| {
        s.segment_values(v, d)
    });
}

#[test]
fn bocpd_never_panics_on_degenerate_series() {
    // At 120 Hz: an expected segment in seconds (the one unset) needs the data's rate.
    sweep_segmenter("bocpd", BOCPD, &series(), checked::<BocpdParams>, |s, v, d| {
        s.at_rate(120.0).segment_values(v, d)
    });
}
