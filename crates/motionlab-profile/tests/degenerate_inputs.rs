//! `clasp` and `floss`, in a range of settings, on degenerate series: each run gives `Ok` with
//! candidates inside `(0, n)` (sorted, unique) or one error — never a panic.

use motionlab_profile::{ClaspParams, FlossParams};
use motionlab_testkit::degenerate::{
    Series, check_segmenter_run, checked, degenerate_series, sweep_segmenter,
};

fn series() -> Vec<Series> {
    let mut v = degenerate_series(&[1, 2, 3, 5, 8, 20, 61, 200]);
    // Two regimes (a sine, then a sawtooth), so each setting finds something.
    let two = (0..1200).map(|i| {
        let noise = (((i * 7919) % 101) as f64 / 101.0 - 0.5) * 0.1;
        if i < 700 {
            (i as f64 * std::f64::consts::TAU / 20.0).sin() + noise
        } else {
            (i % 13) as f64 / 6.5 - 1.0 + noise
        }
    });
    v.push(("two regimes".into(), two.collect(), 1));
    v
}

#[test]
fn clasp_never_panics_on_degenerate_series() {
    let settings = [
        "",
        "window = 3",
        "window = 10\nn_segments = 3",
        "window = 5\nvalidation = \"score_threshold\"\nscore = \"f1\"",
        "n_estimators = 1\nk_neighbours = 1\nexcl_radius = 2",
    ];
    sweep_segmenter("clasp", &settings, &series(), checked::<ClaspParams>, |s, v, d| {
        s.segment_values(v, d)
    });
}

#[test]
fn floss_never_panics_on_degenerate_series() {
    let settings = [
        "n_regimes = 2",
        "window = 3\nn_regimes = 4",
        "window = 10\ncac_threshold = 0.45\nexcl_factor = 5",
        "cac_threshold = 1.0\nexcl_factor = 1",
    ];
    sweep_segmenter("floss", &settings, &series(), checked::<FlossParams>, |s, v, d| {
        s.segment_values(v, d)
    });
    // n_regimes = 1 asks for no change point, on every series.
    let one = checked::<FlossParams>("window = 4\nn_regimes = 1");
    for s in series() {
        assert!(
            !check_segmenter_run("floss [n_regimes = 1]", &s, || one.segment_values(&s.1, s.2)),
            "{}",
            s.0
        );
    }
}
