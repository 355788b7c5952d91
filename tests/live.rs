//! `motionlab live` end to end: a real take replayed over TCP gives the boundaries of the
//! offline streaming run, decided at the same samples; a malformed line and a dropped
//! connection are each one message, and what was decided stands.

use std::io::{BufRead, BufReader, Write};
use std::net::TcpStream;
use std::process::{Child, Stdio};

use motionlab_core::registry::build_segmenter;
use motionlab_core::streaming::run_offline;
use motionlab_core::{DataKind, Decision, StreamLayout};

fn motionlab() -> std::process::Command {
    crate::motionlab_command()
}

/// Starts `motionlab live --listen 127.0.0.1:0` with these arguments and returns it with the
/// address it listens on (its first line on standard error).
fn listener(args: &[&str]) -> (Child, String, BufReader<std::process::ChildStderr>) {
    let mut child = motionlab()
        .args(["live", "--listen", "127.0.0.1:0"])
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut err = BufReader::new(child.stderr.take().unwrap());
    let mut first = String::new();
    err.read_line(&mut first).unwrap();
    let addr = first.trim().strip_prefix("listening on ").unwrap_or_else(|| panic!("{first}"));
    (child, addr.to_string(), err)
}

/// The JSON lines a finished `live` printed, as decisions.
fn decisions(stdout: &[u8]) -> Vec<Decision> {
    String::from_utf8_lossy(stdout)
        .lines()
        .map(|l| {
            let v: serde_json::Value = serde_json::from_str(l).unwrap();
            Decision {
                boundary: v["boundary"].as_u64().unwrap() as usize,
                decided_at: v["decided_at"].as_u64().unwrap() as usize,
            }
        })
        .collect()
}

const SPEED: [&str; 6] = [
    "--segmenter",
    "fastest_marker_speed_online",
    "--set",
    "v_high_mm_per_s=1500",
    "--set",
    "v_low_mm_per_s=600",
];

#[test]
fn a_real_take_replayed_over_tcp_gives_the_offline_streaming_boundaries() {
    let take = motionlab_testkit::data_path("cmu86/86_01.amc.gz");
    let (mut server, addr, mut err) = listener(&SPEED);
    let sent = motionlab()
        .args(["live", "--replay"])
        .arg(&take)
        .args(["--to", &addr, "--speed", "10"])
        .args(SPEED)
        .output()
        .unwrap();
    assert!(sent.status.success(), "{}", String::from_utf8_lossy(&sent.stderr));
    let out = std::mem::take(&mut server.stdout).unwrap();
    let mut stdout = Vec::new();
    std::io::Read::read_to_end(&mut BufReader::new(out), &mut stdout).unwrap();
    let status = server.wait().unwrap();
    let mut rest = String::new();
    std::io::Read::read_to_string(&mut err, &mut rest).unwrap();
    assert!(status.success(), "{rest}");
    let live = decisions(&stdout);
    // The offline streaming run: the whole take pushed at once through the same stage.
    let (_, loader) = motionlab_engine::front::loader_for(&take).unwrap();
    let motion = loader.load(&take).unwrap();
    let mut params = toml::Table::new();
    params.insert("v_high_mm_per_s".into(), 1500.0.into());
    params.insert("v_low_mm_per_s".into(), 600.0.into());
    let stage =
        build_segmenter("fastest_marker_speed_online", &toml::Value::Table(params)).unwrap();
    let (layout, samples) = StreamLayout::of_motion(&motion, DataKind::Points, "t").unwrap();
    let offline = run_offline(stage.streaming().unwrap(), &layout, samples).unwrap();
    assert!(offline.len() >= 3, "the take should have stops: {offline:?}");
    assert_eq!(live, offline, "{rest}");
    // Decided two frames after each stop (no smoothing), and said once at the end.
    assert!(live.iter().all(|d| d.decided_at == d.boundary + 2));
    assert!(
        rest.contains(&format!("live: {} samples, {} boundaries", motion.n_frames(), live.len()))
            && rest.contains("per line read"),
        "{rest}"
    );
}

/// One channel: 0 for 150 samples, then 6, with a small deterministic wobble.
fn levels() -> Vec<f64> {
    (0..300)
        .map(|i| if i < 150 { 0.0 } else { 6.0 } + 0.3 * ((i * 7919) % 13) as f64 / 13.0)
        .collect()
}

const BOCPD: [&str; 6] =
    ["--segmenter", "bocpd_online", "--set", "drop_threshold=40", "--set", "lambda=200"];

#[test]
fn a_malformed_line_and_a_dropped_connection_are_said_once_and_decisions_stand() {
    let x = levels();
    let (server, addr, mut err) = listener(&BOCPD);
    let mut client = TcpStream::connect(&addr).unwrap();
    writeln!(client, "{{\"rate_hz\": 50, \"channels\": [\"level\"]}}").unwrap();
    for (i, v) in x.iter().enumerate() {
        if i == 100 {
            // A frame garbled in transit: line 102 (the header is line 1).
            writeln!(client, "[0.1, oops]").unwrap();
        } else {
            writeln!(client, "[{v:?}]").unwrap();
        }
    }
    client.flush().unwrap();
    // Dropped: no end line.
    drop(client);
    let out = server.wait_with_output().unwrap();
    let mut rest = String::new();
    std::io::Read::read_to_string(&mut err, &mut rest).unwrap();
    assert_eq!(out.status.code(), Some(2), "{rest}");
    let lines: Vec<&str> = rest.lines().collect();
    let malformed: Vec<&&str> = lines.iter().filter(|l| l.contains("line 102")).collect();
    assert_eq!(malformed.len(), 1, "{rest}");
    assert!(malformed[0].contains("not JSON") && malformed[0].contains("missing sample 100"));
    let dropped: Vec<&&str> =
        lines.iter().filter(|l| l.contains("closed after 300 samples")).collect();
    assert_eq!(dropped.len(), 1, "{rest}");
    // What was decided: the stream's decisions with the garbled sample missing.
    let mut with_gap = x.clone();
    with_gap[100] = f64::NAN;
    let mut params = toml::Table::new();
    params.insert("drop_threshold".into(), 40.0.into());
    params.insert("lambda".into(), 200.0.into());
    let stage = build_segmenter("bocpd_online", &toml::Value::Table(params)).unwrap();
    let rate = motionlab_core::FrameRate::new(50.0).unwrap();
    let layout = StreamLayout::channels(vec!["level".into()], rate);
    let expected = run_offline(stage.streaming().unwrap(), &layout, &with_gap).unwrap();
    assert!(!expected.is_empty(), "the level change should be decided");
    assert_eq!(decisions(&out.stdout), expected);
    // The same lines on standard input, with an end line, give the same decisions.
    let mut child = motionlab()
        .arg("live")
        .args(BOCPD)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    {
        let mut stdin = child.stdin.take().unwrap();
        writeln!(stdin, "{{\"rate_hz\": 50, \"channels\": [\"level\"]}}").unwrap();
        // In blocks of 10 samples this time, NaN as null.
        for block in with_gap.chunks(10) {
            let rows: Vec<String> = block
                .iter()
                .map(|v| if v.is_nan() { "[null]".to_string() } else { format!("[{v:?}]") })
                .collect();
            writeln!(stdin, "[{}]", rows.join(",")).unwrap();
        }
        writeln!(stdin, "{{\"end\": true}}").unwrap();
    }
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(decisions(&out.stdout), expected);
}

#[test]
fn a_segmenter_that_needs_the_whole_series_is_refused_by_name() {
    let out =
        motionlab().args(["live", "--segmenter", "bocpd"]).stdin(Stdio::null()).output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("bocpd needs the whole series") && err.contains("bocpd_online"), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
}
