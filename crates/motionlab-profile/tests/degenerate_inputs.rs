//! `clasp` and `floss`, in a range of settings, on degenerate series: each run gives `Ok` with
//! candidates inside `(0, n)` (sorted, unique) or one error naming what is wrong — never a
//! panic.

use motionlab_core::registry::ParamGuard;
use motionlab_core::{Result, SegmenterOutput};
use motionlab_profile::{ClaspParams, FlossParams};

fn inputs() -> Vec<(String, Vec<f64>, usize)> {
    let mut v: Vec<(String, Vec<f64>, usize)> = Vec::new();
    for n in [1usize, 2, 3, 5, 8, 20, 61, 200] {
        v.push((format!("constant n={n}"), vec![3.25; n], 1));
        v.push((format!("step n={n}"), (0..n).map(|i| if i < n / 2 { 0.0 } else { 1.0 }).collect(), 1));
        v.push((format!("ramp n={n}"), (0..n).map(|i| i as f64).collect(), 1));
        v.push((format!("periodic n={n}"), (0..n).map(|i| ((i * 37) % 11) as f64).collect(), 1));
        v.push((format!("constant 2ch n={n}"), vec![1.0; 2 * n], 2));
        v.push((format!("one constant channel n={n}"), (0..n).flat_map(|i| [5.0, (i % 3) as f64]).collect(), 2));
        let mut gap: Vec<f64> = (0..n).map(|i| ((i * 37) % 11) as f64).collect();
        gap[n / 2] = f64::NAN;
        v.push((format!("NaN gap n={n}"), gap, 1));
        v.push((format!("huge n={n}"), (0..n).map(|i| if i % 2 == 0 { 1e300 } else { -1e300 }).collect(), 1));
        v.push((format!("tiny n={n}"), (0..n).map(|i| 1e-300 * (i % 3) as f64).collect(), 1));
        v.push((format!("flat then noise n={n}"), (0..n).map(|i| if i < n / 2 { 0.0 } else { ((i * 7919) % 101) as f64 }).collect(), 1));
    }
    // Two regimes (a sine, then a sawtooth), so each setting finds something.
    v.push((
        "two regimes".into(),
        (0..1200).map(|i| if i < 700 { (i as f64 * std::f64::consts::TAU / 20.0).sin() } else { (i % 13) as f64 / 6.5 - 1.0 } + (((i * 7919) % 101) as f64 / 101.0 - 0.5) * 0.1).collect(),
        1,
    ));
    v.push(("infinity".into(), vec![1.0, f64::INFINITY, 2.0, 3.0], 1));
    v.push(("empty".into(), vec![], 1));
    v.push(("ragged".into(), vec![1.0, 2.0, 3.0], 2));
    v.push(("no channels".into(), vec![1.0, 2.0], 0));
    v
}

/// Runs one case; true when it gave change points (so that a sweep can insist some did).
fn check_run(what: &str, input: &str, n_channels: usize, len: usize, run: impl FnOnce() -> Result<SegmenterOutput>) -> bool {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(run)) {
        Err(_) => panic!("{what} panicked on {input}"),
        Ok(Err(e)) => {
            assert!(!e.to_string().is_empty(), "{what} on {input}: an empty error");
            false
        }
        Ok(Ok(o)) => {
            let n = len.checked_div(n_channels).unwrap_or(0);
            assert!(o.candidates.windows(2).all(|w| w[0] < w[1]), "{what} on {input}: {:?}", o.candidates);
            assert!(o.candidates.iter().all(|&c| c > 0 && c < n), "{what} on {input}: {:?} for n = {n}", o.candidates);
            assert!(o.traces.iter().all(|t| t.values.len() == n), "{what} on {input}: a trace of another length than the series");
            !o.candidates.is_empty()
        }
    }
}

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
fn clasp_never_panics_on_degenerate_series() {
    let settings = ["", "window = 3", "window = 10\nn_segments = 3", "window = 5\nvalidation = \"score_threshold\"\nscore = \"f1\"", "n_estimators = 1\nk_neighbours = 1\nexcl_radius = 2"];
    sweep::<ClaspParams>("clasp", &settings, |s, v, d| s.segment_values(v, d));
}

#[test]
fn floss_never_panics_on_degenerate_series() {
    // n_regimes = 1 asks for no change point: the sweep needs a setting that finds some, so
    // it is checked on its own.
    let settings = ["n_regimes = 2", "window = 3\nn_regimes = 4", "window = 10\ncac_threshold = 0.45\nexcl_factor = 5", "cac_threshold = 1.0\nexcl_factor = 1"];
    sweep::<FlossParams>("floss", &settings, |s, v, d| s.segment_values(v, d));
    let one: FlossParams = toml::from_str("window = 4\nn_regimes = 1").unwrap();
    let one = one.check().unwrap();
    for (name, values, d) in inputs() {
        assert!(!check_run("floss [n_regimes = 1]", &name, d, values.len(), || one.segment_values(&values, d)), "{name}");
    }
}
