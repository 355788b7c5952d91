//! C3D analog channels as channels at their own rate, against ezc3d and py-c3d.
//!
//! `tests/fixtures/analog/` holds three analog-only C3D files (no 3-D point: an EMG system's
//! export, an unsigned converter, an isokinetic dynamometer) written by
//! `bench/analog_fixtures.py` with a writer of its own, and `reference.json`: every value as
//! the C3D letter gives it (py-c3d 0.6.0 agrees on every channel, ezc3d 1.7.2 on the channels
//! it lists), plus ezc3d's reading of a real marker file's 20 analog channels. Each file loads
//! as channels equal to that reading to 1e-9 relative.

use std::path::PathBuf;
use std::sync::LazyLock;

use motionlab_core::registry::build_loader;
use motionlab_core::{DataKind, ErrorKind, Motion};
use motionlab_testkit::repo_root;
// Links the crate, so its loaders are registered.
use motionlab_io as _;
use serde_json::Value;

static REFERENCE: LazyLock<Value> = LazyLock::new(|| {
    let text =
        std::fs::read_to_string(repo_root().join("tests/fixtures/analog/reference.json")).unwrap();
    serde_json::from_str(&text).unwrap()
});

fn fixture(name: &str) -> PathBuf {
    repo_root().join("tests/fixtures/analog").join(name)
}

fn loader(params: &str) -> Box<dyn motionlab_core::Loader> {
    build_loader("c3d", &toml::from_str(params).unwrap()).unwrap()
}

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"))
}

fn strings(v: &Value) -> Vec<String> {
    v.as_array().unwrap().iter().map(|s| s.as_str().unwrap().to_string()).collect()
}

fn close(a: f64, b: f64, scale: f64) -> bool {
    (a - b).abs() <= 1e-9 * scale.abs().max(1.0)
}

/// Loads an analog-only fixture with the default `c3d` loader and checks it against the
/// reference: no points, the labels, units and rate, and every value.
fn check_analog_only(name: &str) -> Motion {
    let r = &REFERENCE["files"][name];
    let m = loader("").load(&fixture(name)).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(m.n_points(), 0, "{name}");
    assert_eq!(m.format, "c3d");
    let c = m.channels();
    assert_eq!(c.names(), strings(&r["labels"]), "{name}");
    assert_eq!(c.units(), strings(&r["units"]), "{name}");
    assert_eq!(m.frame_rate().hz(), f(&r["rate_hz"]), "{name}");
    let want = r["values"].as_array().unwrap();
    assert_eq!(m.n_frames(), want.len(), "{name}");
    assert_eq!(c.n_samples(), want.len(), "{name}");
    let d = c.n_channels();
    for (s, row) in want.iter().enumerate() {
        for (k, v) in row.as_array().unwrap().iter().enumerate() {
            let got = c.values()[s * d + k];
            assert!(close(got, f(v), f(v)), "{name} sample {s} channel {k}: {got} vs {v}");
        }
    }
    assert!(m.load_notes.repairs.is_empty(), "{:?}", m.load_notes.repairs);
    m
}

#[test]
fn emg_int16_equals_the_c3d_letter_and_ezc3d_on_its_emg_channels() {
    let m = check_analog_only("emg_int16.c3d");
    // 12 frames at 100 Hz of 10 samples: 1000 Hz. ezc3d agrees on EMG1 and EMG2 (offsets 0
    // and 10); on Trigger (OFFSET −3) it subtracts |−3| and gives −1.75 where the letter gives
    // (17 + 3) × −0.25 × 0.5 = −2.5.
    assert_eq!(m.duration().value(), 0.12);
    assert_eq!(REFERENCE["files"]["emg_int16.c3d"]["ezc3d_agrees"], serde_json::json!([0, 1]));
    assert_eq!(m.channels().channel(2).next(), Some(-2.5));
    // EMG1 is a 50 Hz sine of amplitude 3000 words × 0.001 V × GEN_SCALE 0.5.
    let emg1: Vec<f64> = m.channels().channel(0).collect();
    let peak = emg1.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    assert!((peak - 1.5).abs() < 1e-6, "{peak}");
}

#[test]
fn unsigned_words_and_offsets_are_read_unsigned() {
    let m = check_analog_only("emg_unsigned.c3d");
    // Word 32768 minus OFFSET 32768 (stored as the signed word −32768) is 0: the first sample.
    assert_eq!(m.channels().channel(0).next(), Some(0.0));
    // 65535 − 32768 = 32767 words × 0.5 × 0.5.
    assert_eq!(m.channels().channel(1).next(), Some(8191.75));
    assert_eq!(m.frame_rate().hz(), 1000.0);
}

#[test]
fn isokinetic_floats_equal_ezc3d_on_every_channel() {
    let m = check_analog_only("isokinetic_float.c3d");
    assert_eq!(
        REFERENCE["files"]["isokinetic_float.c3d"]["ezc3d_agrees"],
        serde_json::json!([0, 1, 2, 3])
    );
    assert_eq!(m.frame_rate().hz(), 500.0);
    assert_eq!(m.channels().units(), ["deg", "deg/s", "Nm", "V"]);
}

#[test]
fn a_marker_files_analog_channels_equal_ezc3ds() {
    let rel = "data/schreiber2019/2014001/dynamic/2014001_C4_05.c3d.gz";
    let r = &REFERENCE["real"][rel];
    let analog = loader("analog = true");
    assert_eq!(analog.gives(), DataKind::Channels);
    assert_eq!(loader("").gives(), DataKind::Points);
    let m = analog.load(&repo_root().join(rel)).unwrap();
    let points = loader("").load(&repo_root().join(rel)).unwrap();
    assert_eq!(m.n_points(), 0);
    assert_eq!(m.frame_rate().hz(), f(&r["rate_hz"]));
    let c = m.channels();
    assert_eq!(c.names(), strings(&r["labels"]));
    assert_eq!(c.units(), strings(&r["units"]));
    assert_eq!(c.n_samples(), r["samples"].as_u64().unwrap() as usize);
    // 15 analog samples per 100 Hz frame.
    assert_eq!(c.n_samples(), 15 * points.n_frames());
    for k in 0..c.n_channels() {
        let v: Vec<f64> = c.channel(k).collect();
        let abs: f64 = v.iter().map(|x| x.abs()).sum();
        let sum: f64 = v.iter().sum();
        let weighted: f64 = v.iter().enumerate().map(|(i, x)| (i + 1) as f64 * x).sum();
        let scale = f(&r["abs_sum"][k]);
        assert!(close(sum, f(&r["sum"][k]), scale), "channel {k} sum {sum}");
        assert!((abs - scale).abs() <= 1e-9 * scale.max(1e-300), "channel {k} |sum| {abs}");
        let wscale = scale * v.len() as f64;
        assert!(
            close(weighted, f(&r["weighted_sum"][k]), wscale),
            "channel {k} weighted {weighted}"
        );
        for s in 0..3 {
            let want = f(&r["first"][s][k]);
            assert!(close(v[s], want, want), "channel {k} sample {s}: {} vs {want}", v[s]);
        }
    }
    // The gait events keep their times; their frames now count analog samples.
    assert_eq!(m.events.len(), points.events.len());
    assert!(!m.events.is_empty());
    for (a, p) in m.events.iter().zip(&points.events) {
        assert_eq!(a.time, p.time);
        assert!((a.frame - 15.0 * p.frame).abs() < 1e-9);
    }
}

#[test]
fn analog_channels_picks_channels_by_label_and_names_a_wrong_one() {
    let rel = "data/schreiber2019/2014001/dynamic/2014001_C4_05.c3d.gz";
    let path = repo_root().join(rel);
    let all = loader("analog = true").load(&path).unwrap();
    let m = loader("analog = true\nanalog_channels = [\"Fz1\", \"R_soleus\"]").load(&path).unwrap();
    assert_eq!(m.channels().names(), ["Fz1", "R_soleus"]);
    assert_eq!(m.channels().units(), ["N", "V"]);
    let fz: Vec<f64> = all.channels().channel(all.channels().index("Fz1").unwrap()).collect();
    assert_eq!(m.channels().channel(0).collect::<Vec<_>>(), fz);
    let e = loader("analog = true\nanalog_channels = [\"Fz3\"]").load(&path).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::UnknownName);
    let text = e.to_string();
    assert!(
        text.contains("2014001_C4_05") && text.contains("Fz3") && text.contains("Fz1"),
        "{text}"
    );
    // analog_channels without analog = true is refused when the loader is built.
    let e =
        build_loader("c3d", &toml::from_str("analog_channels = [\"Fz1\"]").unwrap()).err().unwrap();
    assert!(e.to_string().contains("set analog = true"), "{e}");
}

#[test]
fn a_file_with_neither_points_nor_analog_channels_is_refused_naming_analog_used() {
    // The marker-only MoCap Toolbox walk asked for its analog channels.
    let path = repo_root().join("data/mct/walk1.c3d.gz");
    let e = loader("analog = true").load(&path).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::EmptySequence);
    assert_eq!(e.location().field.as_deref(), Some("ANALOG:USED"));
    assert!(e.to_string().contains("walk1") && e.to_string().contains("no analog channels"), "{e}");
}
