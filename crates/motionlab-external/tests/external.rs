//! The external plugins end to end: a real program over the real protocol.
//!
//! - `python_speed_minima_equals_the_built_in`: examples/external-segmenter/speed_minima.py
//!   (numpy) gives the built-in `speed_minima`'s candidates on CMU 86_01 and MCT dance1. It
//!   needs a Python with numpy in `MOTIONLAB_TEST_PYTHON` (`examples/external-segmenter/
//!   setup_venv.sh` prints one; .ci/run sets it) and prints a SKIPPED line without it.
//! - The error cases use `sh` only; the protocol check uses `python3`'s standard library.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use motionlab_core::registry::{
    build_feature_extractor, build_loader, build_segmenter, default_params,
};
use motionlab_core::{ErrorKind, FeatureCache, Motion, Result, SegmenterOutput, programs};
use motionlab_testkit::{data_path, motion_from_fn, repo_root};

// Link the plugin crates whose registrations the tests look up.
use motionlab_external as _;
use motionlab_io as _;
use motionlab_segment as _;

fn toml_table(text: &str) -> toml::Value {
    toml::Value::Table(toml::from_str(text).unwrap())
}

/// Runs the `external` segmenter with `command` (and extra TOML lines) on `motion`, the
/// command line allowed first (as the engine does after the user's consent).
fn external(command: &[&str], extra: &str, motion: &Motion) -> Result<SegmenterOutput> {
    let args: Vec<String> = command.iter().map(|s| s.to_string()).collect();
    programs::allow([args.as_slice()]);
    external_unallowed(command, extra, motion)
}

/// [`external`] without allowing the command line.
fn external_unallowed(command: &[&str], extra: &str, motion: &Motion) -> Result<SegmenterOutput> {
    let cmd: Vec<String> = command.iter().map(|s| format!("{s:?}")).collect();
    let params = toml_table(&format!("command = [{}]\n{extra}", cmd.join(", ")));
    build_segmenter("external", &params)?.segment(motion, &FeatureCache::new())
}

fn small_motion() -> Motion {
    motion_from_fn(10, 100.0, 2, |i, k| {
        if (i, k) == (4, 1) { [f64::NAN; 3] } else { [i as f64 * (k + 1) as f64, 0.5, -1.0] }
    })
}

fn load(loader: &str, file: &str) -> Motion {
    build_loader(loader, &default_params()).unwrap().load(&data_path(file)).unwrap()
}

/// The interpreter with numpy, or None (and a SKIPPED line).
fn test_python(test: &str) -> Option<PathBuf> {
    match std::env::var_os("MOTIONLAB_TEST_PYTHON") {
        Some(p) if !p.is_empty() => Some(PathBuf::from(p)),
        _ if std::env::var_os("MOTIONLAB_CI").is_some() => {
            panic!(
                "{test}: MOTIONLAB_CI is set (nothing may skip) but MOTIONLAB_TEST_PYTHON is not"
            )
        }
        _ => {
            println!(
                "SKIPPED {test}: set MOTIONLAB_TEST_PYTHON to a python with numpy (examples/external-segmenter/setup_venv.sh prints one)"
            );
            None
        }
    }
}

#[test]
fn python_speed_minima_equals_the_built_in() {
    let Some(python) = test_python("python_speed_minima_equals_the_built_in") else { return };
    let script = repo_root().join("examples/external-segmenter/speed_minima.py");
    // (loader, file, speed_minima's params, fewest candidates for the case to mean something).
    let cases = [
        // The defaults (v_low 0.3 × p90 after 0.2 s smoothing): 93 candidates on 86_01.
        ("asf_amc", "cmu86/86_01.amc.gz", "", 50),
        // A dance is never slow for long: a threshold of 0.15 × p90 of V finds one minimum.
        (
            "qualisys_tsv",
            "mct/dance1.tsv.gz",
            "v_low = { fraction_of_p90 = 0.15 }\nsmoothing = { seconds = 0.0 }",
            1,
        ),
        ("qualisys_tsv", "mct/dance1.tsv.gz", "v_low = { fraction_of_p90 = 0.5 }", 50),
        // The other code paths: smoothing, an absolute threshold, real gaps (walk1: 27 of them).
        (
            "qualisys_tsv",
            "mct/dance1.tsv.gz",
            "smoothing = { seconds = 0.05 }\nv_low = { mm_per_s = 400.0 }",
            10,
        ),
        ("asf_amc", "cmu86/86_01.amc.gz", "smoothing = { frames = 6 }", 50),
        (
            "qualisys_tsv",
            "mct/walk1.tsv.gz",
            "v_low = { fraction_of_p90 = 0.5 }\nsmoothing = { frames = 3 }",
            5,
        ),
    ];
    for (loader, file, params, fewest) in cases {
        let motion = load(loader, file);
        let built_in = build_segmenter("speed_minima", &toml_table(params))
            .unwrap()
            .segment(&motion, &FeatureCache::new())
            .unwrap();
        let inline = params.replace('\n', ", ");
        let extra = format!("params = {{ {inline} }}");
        let ext = external(&[python.to_str().unwrap(), script.to_str().unwrap()], &extra, &motion)
            .unwrap();
        println!(
            "{file} [{inline}]: built-in {} candidates, external {} candidates ({} frames, {} missing samples)",
            built_in.candidates.len(),
            ext.candidates.len(),
            motion.n_frames(),
            motion.missing_count()
        );
        assert!(
            built_in.candidates.len() >= fewest,
            "{file} [{params}]: too few candidates to be a test"
        );
        assert_eq!(ext.candidates, built_in.candidates, "{file} [{params}]");
        // The trace behind them too: same NaN frames, same values to the last bit.
        let (a, b) = (&ext.traces[0].values, &built_in.traces[0].values);
        assert_eq!(a.len(), b.len());
        for (i, (x, y)) in a.iter().zip(b).enumerate() {
            assert!(
                x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()),
                "{file}: V[{i}] = {x} vs {y}"
            );
        }
        assert_eq!(
            ext.thresholds[0].value.to_bits(),
            built_in.thresholds[0].value.to_bits(),
            "{file}: v_low"
        );
    }
}

/// Whether the process `pid` is gone (or a zombie awaiting its reaper).
fn is_dead(pid: u32) -> bool {
    match std::fs::read_to_string(format!("/proc/{pid}/stat")) {
        Err(_) => true,
        Ok(stat) => stat.rsplit(')').next().is_some_and(|rest| rest.trim_start().starts_with('Z')),
    }
}

#[test]
fn a_timeout_kills_the_program_and_what_it_started() {
    let dir = tempfile::tempdir().unwrap();
    let pid_file = dir.path().join("pid");
    let script = format!("sleep 30 & echo $! > {}; wait", pid_file.display());
    let started = Instant::now();
    let e = external(&["sh", "-c", &script], "timeout_s = 0.5", &small_motion()).unwrap_err();
    assert!(started.elapsed() < Duration::from_secs(10), "took {:?}", started.elapsed());
    assert_eq!(e.kind(), ErrorKind::Io);
    assert!(e.to_string().starts_with("external `sh -c \"sleep 30 &"), "{e}");
    assert!(e.to_string().contains("timed out after 0.5 s (timeout_s) and was killed"), "{e}");
    let pid: u32 = std::fs::read_to_string(&pid_file).unwrap().trim().parse().unwrap();
    let deadline = Instant::now() + Duration::from_secs(5);
    while !is_dead(pid) && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(20));
    }
    assert!(is_dead(pid), "the program's child {pid} survived the timeout");
}

#[test]
fn a_crash_is_reported_with_the_exit_status_and_the_end_of_stderr() {
    let script = "echo 'Traceback (most recent call last):' >&2; echo '  File \"seg.py\", line 3' >&2; echo 'ZeroDivisionError: division by zero' >&2; exit 3";
    let e = external(&["sh", "-c", script], "", &small_motion()).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::Io);
    let msg = e.to_string();
    assert!(!msg.contains('\n'), "one line: {msg}");
    assert!(msg.starts_with("external `sh -c "), "{msg}");
    assert!(msg.contains("exited with status 3; last lines of stderr: Traceback (most recent call last): | File \"seg.py\", line 3 | ZeroDivisionError: division by zero"), "{msg}");
}

#[test]
fn malformed_and_invalid_output_are_one_error_each() {
    let motion = small_motion(); // 10 frames
    let cases: [(&str, ErrorKind, &str); 7] = [
        (
            r#"{"candidates": [1, 2"#,
            ErrorKind::Syntax,
            "stdout is not the expected JSON: EOF while parsing a list at line 2 column 0",
        ),
        (
            r#"{"candidates": [1, 2.5]}"#,
            ErrorKind::WrongType,
            "invalid type: floating point `2.5`, expected usize at line 1 column 22",
        ),
        (
            r#"{"candidates": [3, 10]}"#,
            ErrorKind::OutOfRange,
            "candidates[1] = 10 is out of range: the motion has 10 frames (0–9)",
        ),
        (
            r#"{"candidates": [5, 3]}"#,
            ErrorKind::OutOfRange,
            "candidates[1] = 3 follows 5 (not ascending)",
        ),
        (
            r#"{"candidates": [3, 3]}"#,
            ErrorKind::OutOfRange,
            "candidates[1] = 3 follows 3 (repeated)",
        ),
        (
            r#"{"candidates": [], "traces": [{"name": "V", "unit": "mm/s", "values": [1, 2, 3]}]}"#,
            ErrorKind::WrongValueCount,
            "trace \"V\" has 3 values, expected one per frame (10)",
        ),
        (
            r#"{"candidates": [], "traces": [{"name": "V", "values": [NaN, 1, 1, 1, 1, 1, 1, 1, 1, 1]}]}"#,
            ErrorKind::Syntax,
            "write null for a missing value",
        ),
    ];
    for (reply, kind, needle) in cases {
        let script = format!("printf '%s\\n' '{reply}'");
        let e = external(&["sh", "-c", &script], "", &motion).unwrap_err();
        assert_eq!(e.kind(), kind, "{reply}: {e}");
        let msg = e.to_string();
        assert!(msg.starts_with("external `sh -c "), "{msg}");
        assert!(msg.contains(needle), "{reply}: {msg}");
    }
    // null is how a trace says NaN.
    let ok = r#"{"candidates": [2], "traces": [{"name": "V", "values": [null, 1, 0, 1, 1, 1, 1, 1, 1, null]}]}"#;
    let out = external(&["sh", "-c", &format!("printf '%s' '{ok}'")], "", &motion).unwrap();
    assert_eq!(out.candidates, vec![2]);
    assert!(out.traces[0].values[0].is_nan() && out.traces[0].values[2] == 0.0);
}

#[test]
fn a_missing_program_fails_at_validation_naming_the_field() {
    let e = build_segmenter("external", &toml_table("command = [\"no-such-program-motionlab\"]"))
        .err()
        .unwrap();
    assert_eq!(e.kind(), ErrorKind::Io);
    assert_eq!(e.location().field.as_deref(), Some("command"));
    assert!(
        e.to_string().contains("program \"no-such-program-motionlab\" not found on PATH"),
        "{e}"
    );
    let e = build_segmenter("external", &toml_table("command = [\"./no/such/script.py\"]"))
        .err()
        .unwrap();
    assert!(e.to_string().contains("not found relative to the current directory"), "{e}");
    // Found but not executable: refused when started.
    let readme = repo_root().join("README.md");
    let e = external(&[readme.to_str().unwrap()], "", &small_motion()).unwrap_err();
    assert!(e.to_string().contains("cannot start the program: not executable"), "{e}");
    let e =
        build_segmenter("external", &toml_table("command = [\"sh\"]\ntimeout = 5")).err().unwrap();
    assert_eq!(e.kind(), ErrorKind::UnknownKey);
}

/// What motionlab writes, read back by a stdlib-only Python (no numpy): meta.json's fields and
/// the .npy header and values.
const PROTOCOL_PROBE: &str = r#"
import json, math, os, struct, sys
d = sys.argv[-1]
meta = json.load(open(os.path.join(d, "meta.json")))
raw = open(os.path.join(d, meta["positions"]["file"]), "rb").read()
assert raw[:8] == b"\x93NUMPY\x01\x00", raw[:8]
n = struct.unpack("<H", raw[8:10])[0]
header = raw[10:10 + n].decode("ascii")
assert (10 + n) % 64 == 0 and header.endswith("\n"), header
shape = eval(header)["shape"]
f, m, _ = shape
values = struct.unpack("<%dd" % (f * m * 3), raw[10 + n:])
x0 = [values[(i * m + 0) * 3] for i in range(f)]
x1 = [values[(i * m + 1) * 3] for i in range(f)]
mo = meta["motion"]
out = {"candidates": [f - 1],
       "traces": [{"name": "x0", "unit": "mm", "values": x0},
                  {"name": "x1", "unit": "mm", "values": [None if math.isnan(v) else v for v in x1]}],
       "thresholds": [{"name": "rate", "trace": "x0", "value": mo["rate_hz"]},
                      {"name": "shape_ok", "trace": "x0", "value": float(list(shape) == meta["positions"]["shape"] == [mo["n_frames"], mo["n_points"], 3])},
                      {"name": "missing", "trace": "x0", "value": mo["n_missing_samples"]},
                      {"name": "param", "trace": "x0", "value": meta["params"]["k"]}]}
assert meta["protocol"] == 1 and meta["plugin"] == "external" and meta["expects"] == "segmenter"
assert mo["point_names"] == ["m0", "m1"] and mo["up_axis"] in "xyz"
print(json.dumps(out))
"#;

fn python3() -> Option<&'static str> {
    let found = std::process::Command::new("python3")
        .arg("-c")
        .arg("pass")
        .status()
        .is_ok_and(|s| s.success());
    if !found {
        assert!(
            std::env::var_os("MOTIONLAB_CI").is_none(),
            "protocol probe: no python3 on PATH, and MOTIONLAB_CI forbids skipping"
        );
        println!("SKIPPED protocol probe: no python3 on PATH");
    }
    found.then_some("python3")
}

#[test]
fn the_program_reads_exactly_the_motion_and_params_motionlab_sent() {
    let Some(py) = python3() else { return };
    let motion = small_motion();
    let out = external(&[py, "-c", PROTOCOL_PROBE], "params = { k = 7.5 }", &motion).unwrap();
    assert_eq!(out.candidates, vec![9]);
    let x0: Vec<f64> = (0..10).map(|i| motion.position(i, 0)[0]).collect();
    assert_eq!(out.traces[0].values, x0);
    assert!(out.traces[1].values[4].is_nan());
    assert_eq!(out.traces[1].values[5], 10.0);
    let t: Vec<f64> = out.thresholds.iter().map(|t| t.value).collect();
    assert_eq!(t, vec![100.0, 1.0, 1.0, 7.5]);
}

#[test]
fn external_features_become_a_feature_set() {
    for script in [
        r#"printf '%s' '{"traces": [{"name": "one", "unit": "", "values": [1,1,1,1,1,1,1,1,1,1]}], "labels": [{"name": "dir", "values": ["a","a","a","a","a","b","b","b","b","b"]}]}'"#,
        "echo '{}'",
    ] {
        programs::allow([["sh".to_string(), "-c".to_string(), script.to_string()].as_slice()]);
    }
    let params = toml_table(
        r#"command = ["sh", "-c", "printf '%s' '{\"traces\": [{\"name\": \"one\", \"unit\": \"\", \"values\": [1,1,1,1,1,1,1,1,1,1]}], \"labels\": [{\"name\": \"dir\", \"values\": [\"a\",\"a\",\"a\",\"a\",\"a\",\"b\",\"b\",\"b\",\"b\",\"b\"]}]}'"]"#,
    );
    let set = build_feature_extractor("external_features", &params)
        .unwrap()
        .extract(&small_motion(), &FeatureCache::new())
        .unwrap();
    assert_eq!(set.traces[0].values, vec![1.0; 10]);
    assert_eq!(set.labels[0].values[5], "b");
    let e = build_feature_extractor(
        "external_features",
        &toml_table("command = [\"sh\", \"-c\", \"echo '{}'\"]"),
    )
    .unwrap()
    .extract(&small_motion(), &FeatureCache::new())
    .unwrap_err();
    assert!(
        e.to_string()
            .starts_with("external_features `sh -c \"echo '{}'\"`: returned no trace and no label"),
        "{e}"
    );
}

#[test]
fn a_command_nobody_allowed_is_never_started() {
    let dir = tempfile::tempdir().unwrap();
    let marker = dir.path().join("ran");
    let script = format!("touch {} && echo '{{\"candidates\": []}}'", marker.display());
    let e = external_unallowed(&["sh", "-c", &script], "", &small_motion()).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::NotAllowed);
    assert!(
        e.to_string().starts_with("external `sh -c \"touch ")
            && e.to_string().contains("not started"),
        "{e}"
    );
    assert!(!marker.exists(), "the program ran");
    // Allowed, the same command line runs; one more argument is another command line.
    let out = external(&["sh", "-c", &script], "", &small_motion()).unwrap();
    assert!(out.candidates.is_empty() && marker.exists());
    std::fs::remove_file(&marker).unwrap();
    assert_eq!(
        external_unallowed(&["sh", "-c", &script, "x"], "", &small_motion()).unwrap_err().kind(),
        ErrorKind::NotAllowed
    );
    assert!(!marker.exists());
}

#[test]
fn a_program_that_prints_without_end_is_stopped_at_max_output_mb() {
    let started = Instant::now();
    // `yes` writes forever: stdout is read up to 1 MiB, then the program is killed.
    let e =
        external(&["sh", "-c", "yes 12345"], "max_output_mb = 1\ntimeout_s = 60", &small_motion())
            .unwrap_err();
    assert!(started.elapsed() < Duration::from_secs(20), "took {:?}", started.elapsed());
    assert_eq!(e.kind(), ErrorKind::TooLarge, "{e}");
    assert!(
        e.to_string().contains("printed more than 1 MiB on stdout (max_output_mb) and was killed"),
        "{e}"
    );
    // 50 MB on stderr is read and dropped (the end kept for messages): no block, no failure.
    let flood = "head -c 50000000 /dev/zero | tr '\\0' e >&2; echo '{\"candidates\": [3]}'";
    assert_eq!(
        external(&["sh", "-c", flood], "max_output_mb = 1", &small_motion()).unwrap().candidates,
        vec![3]
    );
}

#[test]
fn a_program_that_writes_a_huge_file_is_stopped_at_max_output_mb() {
    // The program itself (exec) writes 3 MB into the exchange folder: the kernel stops it at
    // 1 MiB (RLIMIT_FSIZE, SIGXFSZ), and the error says why.
    let e = external(
        &["sh", "-c", "exec head -c 3000000 /dev/zero > \"$0/huge.npy\""],
        "max_output_mb = 1",
        &small_motion(),
    )
    .unwrap_err();
    assert_eq!(e.kind(), ErrorKind::Io, "{e}");
    assert!(
        e.to_string().contains(
            "was killed by signal 25 (SIGXFSZ: it wrote a file larger than 1 MiB, max_output_mb)"
        ),
        "{e}"
    );
}
