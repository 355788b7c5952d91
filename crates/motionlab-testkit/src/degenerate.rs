//! Degenerate channel series for the segmenters' robustness sweeps: each run must give `Ok`
//! with valid candidates or one error — never a panic.

use motionlab_core::{Result, SegmenterOutput};

/// A named series: sample-major values and the channel count.
pub type Series = (String, Vec<f64>, usize);

/// For each length in `lengths`: constant, zeros, a step, a ramp, a periodic pattern, two
/// constant channels, one constant channel beside a varying one, a NaN gap, all NaN, ±1e300,
/// 1e-300 steps and flat-then-noise; then a NaN run, leading NaNs, an infinity, an empty, a
/// ragged and a zero-channel input.
pub fn degenerate_series(lengths: &[usize]) -> Vec<Series> {
    let mut v: Vec<Series> = Vec::new();
    for &n in lengths {
        v.push((format!("constant n={n}"), vec![3.25; n], 1));
        v.push((format!("zeros n={n}"), vec![0.0; n], 1));
        v.push((
            format!("step n={n}"),
            (0..n).map(|i| if i < n / 2 { 0.0 } else { 1.0 }).collect(),
            1,
        ));
        v.push((format!("ramp n={n}"), (0..n).map(|i| i as f64).collect(), 1));
        v.push((format!("periodic n={n}"), (0..n).map(|i| ((i * 37) % 11) as f64).collect(), 1));
        v.push((format!("constant 2ch n={n}"), vec![1.0; 2 * n], 2));
        v.push((
            format!("one constant channel n={n}"),
            (0..n).flat_map(|i| [5.0, (i % 3) as f64]).collect(),
            2,
        ));
        let mut gap: Vec<f64> = (0..n).map(|i| ((i * 37) % 11) as f64).collect();
        if n > 0 {
            gap[n / 2] = f64::NAN;
        }
        v.push((format!("NaN gap n={n}"), gap, 1));
        v.push((format!("all NaN n={n}"), vec![f64::NAN; n], 1));
        v.push((
            format!("huge n={n}"),
            (0..n).map(|i| if i % 2 == 0 { 1e300 } else { -1e300 }).collect(),
            1,
        ));
        v.push((format!("tiny n={n}"), (0..n).map(|i| 1e-300 * (i % 3) as f64).collect(), 1));
        v.push((
            format!("flat then noise n={n}"),
            (0..n).map(|i| if i < n / 2 { 0.0 } else { ((i * 7919) % 101) as f64 }).collect(),
            1,
        ));
    }
    v.push((
        "NaN run".into(),
        (0..200).map(|i| if (50..120).contains(&i) { f64::NAN } else { (i % 7) as f64 }).collect(),
        1,
    ));
    v.push((
        "leading NaN".into(),
        (0..200).map(|i| if i < 30 { f64::NAN } else { (i / 100) as f64 }).collect(),
        1,
    ));
    v.push(("infinity".into(), vec![1.0, f64::INFINITY, 2.0, 3.0], 1));
    v.push(("empty".into(), vec![], 1));
    v.push(("ragged".into(), vec![1.0, 2.0, 3.0], 2));
    v.push(("no channels".into(), vec![1.0, 2.0], 0));
    v
}

/// Runs one case, failing the test on a panic, an empty error message, candidates that are not
/// sorted, unique and inside `(0, n)`, or a trace of another length than the series. True when
/// the run gave change points.
pub fn check_segmenter_run(
    what: &str,
    series: &Series,
    run: impl FnOnce() -> Result<SegmenterOutput>,
) -> bool {
    let (input, values, n_channels) = series;
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(run)) {
        Err(_) => panic!("{what} panicked on {input}"),
        Ok(Err(e)) => {
            assert!(!e.to_string().is_empty(), "{what} on {input}: an empty error");
            false
        }
        Ok(Ok(o)) => {
            let n = values.len().checked_div(*n_channels).unwrap_or(0);
            assert!(
                o.candidates.windows(2).all(|w| w[0] < w[1]),
                "{what} on {input}: {:?}",
                o.candidates
            );
            assert!(
                o.candidates.iter().all(|&c| c > 0 && c < n),
                "{what} on {input}: {:?} for n = {n}",
                o.candidates
            );
            assert!(
                o.traces.iter().all(|t| t.values.len() == n),
                "{what} on {input}: a trace of another length than the series"
            );
            !o.candidates.is_empty()
        }
    }
}

/// A plugin's checked stage from its parameters as TOML text (a sweep's `build`); panics,
/// naming the text, when they do not parse or check.
pub fn checked<P: motionlab_core::registry::ParamGuard>(text: &str) -> P::Checked {
    let params: P = motionlab_core::toml::from_str(text).unwrap_or_else(|e| panic!("{text}: {e}"));
    params.check().unwrap_or_else(|e| panic!("{text}: {e}"))
}

/// Every setting (built by `build` from its text) on every series; at least one series must
/// give change points under each setting, so that a sweep cannot pass by refusing everything.
pub fn sweep_segmenter<S>(
    stage: &str,
    settings: &[&str],
    series: &[Series],
    build: impl Fn(&str) -> S,
    segment: impl Fn(&S, &[f64], usize) -> Result<SegmenterOutput>,
) {
    for text in settings {
        let checked = build(text);
        let found = series
            .iter()
            .filter(|s| {
                check_segmenter_run(&format!("{stage} [{text}]"), s, || {
                    segment(&checked, &s.1, s.2)
                })
            })
            .count();
        assert!(found > 0, "{stage} [{text}]: no series gave a change point");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    #[should_panic(expected = "panicked on step")]
    fn a_panicking_segmenter_fails_the_sweep() {
        let s: Series = ("step".into(), vec![0.0, 1.0], 1);
        check_segmenter_run("broken", &s, || panic!("index out of bounds"));
    }

    #[test]
    #[should_panic(expected = "for n = 2")]
    fn a_candidate_outside_the_series_fails_the_sweep() {
        let s: Series = ("step".into(), vec![0.0, 1.0], 1);
        check_segmenter_run("broken", &s, || {
            Ok(SegmenterOutput { candidates: vec![2], ..Default::default() })
        });
    }

    #[test]
    fn errors_are_accepted_and_change_points_counted() {
        let s: Series = ("step".into(), vec![0.0, 0.0, 1.0, 1.0], 1);
        assert!(!check_segmenter_run("refuses", &s, || Err(motionlab_core::Error::new(
            motionlab_core::ErrorKind::EmptySequence,
            "too short"
        ))));
        assert!(check_segmenter_run("finds", &s, || Ok(SegmenterOutput {
            candidates: vec![2],
            ..Default::default()
        })));
    }
}
