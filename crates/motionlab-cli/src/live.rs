//! `motionlab live`: a streaming segmenter on samples as they arrive — from standard input, a
//! local TCP socket, or a motion file replayed at its capture rate — printing each boundary as
//! a JSON line the moment it is decided.
//!
//! **The line protocol** (UTF-8 JSON, one value per line; also what `--to` sends):
//!
//! 1. a header object: `{"rate_hz": 120, "points": ["LFHD", …], "up_axis": "z"}` for frames of
//!    marker positions (x, y, z per point, mm), or `{"rate_hz": 100, "channels": ["a", …]}` for
//!    channel rows (`up_axis` defaults to `"y"`);
//! 2. samples: `[x0, y0, z0, x1, …]` (points) or `[a, b, …]` (channels), one sample per line,
//!    or `[[…], […]]` for a block of samples; `null` is a missing value;
//! 3. `{"end": true}`: the stream is over (decisions only the end can make are printed).
//!
//! Output, one line per boundary: `{"boundary": 412, "decided_at": 414, "boundary_s": 3.433,
//! "delay_s": 0.017}` (samples counted from the first sample, seconds at the header's rate).
//!
//! **What goes wrong is said and survived**, on standard error, one line each: a malformed
//! sample line (not JSON, a wrong number of values, an infinite value) is counted as one
//! missing sample (every value NaN, so sample numbers stay those of the capture) and the stream
//! goes on; a TCP stall (no line for `--stall-s` seconds) is said once per stall; a dropped
//! connection (the socket closes or fails before `{"end": true}`) ends the session with what
//! was decided — every line already printed stands — and exit code 2. Standard input that ends
//! without an end line is a normal end (a file piped in).

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use motionlab_core::{
    Axis, DataKind, Decision, Error, ErrorKind, FrameRate, Motion, Result, SegmenterSession,
    StreamLayout,
};

/// What `motionlab live` was asked.
#[derive(clap::Args, Clone, Debug)]
pub struct LiveArgs {
    /// The streaming segmenter's registered name (`bocpd_online`, `fastest_marker_speed_online`,
    /// … — `motionlab list` shows them, `describe` their parameters).
    #[arg(long)]
    pub segmenter: String,
    /// A parameter of the segmenter, `key=value` with a TOML value (`v_high_mm_per_s=500`,
    /// `smoothing={ frames = 5 }`); repeat for more.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Listen on this local TCP address (`127.0.0.1:7878`; port 0 picks a free one, printed on
    /// standard error as `listening on ADDR`) for one connection speaking the line protocol.
    #[arg(long, conflicts_with = "replay")]
    pub listen: Option<String>,
    /// Replay a motion file (any format `motionlab inspect` reads) instead of reading samples:
    /// its positions, or its channels for a segmenter that reads channels.
    #[arg(long)]
    pub replay: Option<PathBuf>,
    /// With --replay: send the file's samples over the line protocol to this TCP address (a
    /// `motionlab live --listen` elsewhere) instead of segmenting them here.
    #[arg(long, requires = "replay")]
    pub to: Option<String>,
    /// With --replay: pace the samples at this multiple of the capture rate; 0 sends them as
    /// fast as they are taken.
    #[arg(long, default_value_t = 1.0)]
    pub speed: f64,
    /// Say a stall when no line arrives on the socket for this many seconds.
    #[arg(long, default_value_t = 2.0)]
    pub stall_s: f64,
}

/// Runs `motionlab live`.
pub fn run(args: &LiveArgs) -> Result<ExitCode> {
    if !(args.speed.is_finite() && args.speed >= 0.0) {
        return Err(Error::new(
            ErrorKind::InvalidParameter,
            format!("--speed is {}, expected a multiple of the capture rate ≥ 0", args.speed),
        ));
    }
    let params = set_params(&args.set)?;
    let stage = motionlab_core::registry::build_segmenter(&args.segmenter, &params)
        .map_err(|e| e.under_field(format!("--segmenter {}", args.segmenter)))?;
    let Some(streaming) = stage.streaming() else {
        return Err(Error::new(
            ErrorKind::InvalidParameter,
            format!(
                "{} needs the whole series: only a streaming segmenter runs live (the built-in ones are the `*_online` segmenters of `motionlab list`: bocpd_online, fastest_marker_speed_online, direction_change_online, hull_volume_change_online)",
                args.segmenter
            ),
        ));
    };
    if let Some(path) = &args.replay {
        let (_, loader) = motionlab_engine::front::loader_for(path)?;
        let motion = loader.load(path)?;
        let (layout, samples) =
            StreamLayout::of_motion(&motion, streaming.consumes(), &motion.name)?;
        if let Some(addr) = &args.to {
            return send(addr, &motion, &layout, samples, args.speed);
        }
        let mut live = Live::start(streaming.start(&layout)?, layout.rate.hz());
        let w = layout.width();
        let pace = Pace::new(layout.rate.hz(), args.speed);
        for (i, s) in samples.chunks_exact(w.max(1)).enumerate() {
            pace.wait(i);
            live.push(s)?;
        }
        live.end()?;
        live.summary();
        return Ok(ExitCode::SUCCESS);
    }
    match &args.listen {
        Some(addr) => {
            let listener = TcpListener::bind(addr)
                .map_err(|e| Error::new(ErrorKind::Io, format!("cannot listen on {addr}: {e}")))?;
            let local =
                listener.local_addr().map_err(|e| Error::new(ErrorKind::Io, e.to_string()))?;
            eprintln!("listening on {local}");
            let (stream, peer) = listener
                .accept()
                .map_err(|e| Error::new(ErrorKind::Io, format!("accepting on {local}: {e}")))?;
            eprintln!("live: connection from {peer}");
            let stall = Duration::from_secs_f64(args.stall_s.max(0.001));
            stream
                .set_read_timeout(Some(stall))
                .map_err(|e| Error::new(ErrorKind::Io, e.to_string()))?;
            serve(BufReader::new(stream), streaming, true, args.stall_s)
        }
        None => serve(BufReader::new(std::io::stdin().lock()), streaming, false, args.stall_s),
    }
}

/// The `--set` list as a TOML table: each value parsed as TOML, or taken as a string.
fn set_params(set: &[String]) -> Result<toml::Value> {
    let mut t = toml::Table::new();
    for kv in set {
        let Some((k, v)) = kv.split_once('=') else {
            return Err(Error::new(
                ErrorKind::InvalidParameter,
                format!("--set {kv:?}: expected KEY=VALUE"),
            ));
        };
        let value = toml::from_str::<toml::Table>(&format!("v = {v}"))
            .ok()
            .and_then(|mut t| t.remove("v"))
            .unwrap_or_else(|| toml::Value::String(v.to_string()));
        t.insert(k.trim().to_string(), value);
    }
    Ok(toml::Value::Table(t))
}

/// Sleeps until sample `i` is due at `speed` × the capture rate (not at all at speed 0).
struct Pace {
    start: Instant,
    period_s: f64,
}

impl Pace {
    fn new(rate_hz: f64, speed: f64) -> Self {
        Pace {
            start: Instant::now(),
            period_s: if speed > 0.0 { 1.0 / (rate_hz * speed) } else { 0.0 },
        }
    }
    fn wait(&self, i: usize) {
        if self.period_s > 0.0 {
            let due = self.start + Duration::from_secs_f64(i as f64 * self.period_s);
            let now = Instant::now();
            if due > now {
                std::thread::sleep(due - now);
            }
        }
    }
}

/// Durations in buckets of 0.1 µs up to 10 ms: constant memory for a stream of any length.
struct Histogram {
    counts: Vec<u32>,
    over: u64,
}

const BUCKETS: usize = 100_000;

impl Histogram {
    fn new() -> Self {
        Histogram { counts: vec![0; BUCKETS], over: 0 }
    }
    fn add(&mut self, d: Duration) {
        match usize::try_from(d.as_nanos() / 100).ok().filter(|&b| b < BUCKETS) {
            Some(b) => self.counts[b] += 1,
            None => self.over += 1,
        }
    }
    fn len(&self) -> u64 {
        self.counts.iter().map(|&c| c as u64).sum::<u64>() + self.over
    }
    /// The `q` quantile in µs (the bucket's middle; ∞ past 10 ms; NaN when empty).
    fn quantile_us(&self, q: f64) -> f64 {
        let n = self.len();
        if n == 0 {
            return f64::NAN;
        }
        let target = ((n as f64) * q).ceil().max(1.0) as u64;
        let mut acc = 0;
        for (b, &c) in self.counts.iter().enumerate() {
            acc += c as u64;
            if acc >= target {
                return (b as f64 + 0.5) / 10.0;
            }
        }
        f64::INFINITY
    }
}

/// A session and what it has printed, with the time each sample and each line took.
struct Live {
    session: Box<dyn SegmenterSession>,
    rate_hz: f64,
    decided: Vec<Decision>,
    printed: usize,
    /// The segmenter's time per sample.
    cost: Histogram,
    /// The time per line read: parsing, the segmenter and printing (live input only).
    line_cost: Histogram,
}

impl Live {
    fn start(session: Box<dyn SegmenterSession>, rate_hz: f64) -> Self {
        Live {
            session,
            rate_hz,
            decided: Vec::new(),
            printed: 0,
            cost: Histogram::new(),
            line_cost: Histogram::new(),
        }
    }

    /// Pushes one sample and prints what it decided.
    fn push(&mut self, sample: &[f64]) -> Result<()> {
        let t = Instant::now();
        let r = self.session.push_sample(sample, &mut self.decided);
        self.cost.add(t.elapsed());
        self.print()?;
        r
    }

    fn end(&mut self) -> Result<()> {
        self.session.finish(&mut self.decided)?;
        self.print()
    }

    fn print(&mut self) -> Result<()> {
        if self.printed == self.decided.len() {
            return Ok(());
        }
        let mut out = std::io::stdout().lock();
        for d in &self.decided[self.printed..] {
            let line = serde_json::json!({
                "boundary": d.boundary,
                "decided_at": d.decided_at,
                "boundary_s": d.boundary as f64 / self.rate_hz,
                "delay_s": d.decided_at.saturating_sub(d.boundary) as f64 / self.rate_hz,
            });
            writeln!(out, "{line}")
                .map_err(|e| Error::new(ErrorKind::Io, format!("stdout: {e}")))?;
        }
        out.flush().map_err(|e| Error::new(ErrorKind::Io, format!("stdout: {e}")))?;
        self.printed = self.decided.len();
        Ok(())
    }

    fn summary(&self) {
        let (median, p90) = (self.cost.quantile_us(0.5), self.cost.quantile_us(0.9));
        let lines = if self.line_cost.len() > 0 {
            format!(
                "; per line read (parsing and printing included) median {:.1} µs, p90 {:.1} µs",
                self.line_cost.quantile_us(0.5),
                self.line_cost.quantile_us(0.9)
            )
        } else {
            String::new()
        };
        eprintln!(
            "live: {} samples, {} boundaries; segmenter per sample median {median:.1} µs, p90 {p90:.1} µs{lines} (one thread)",
            self.session.samples_seen(),
            self.decided.len()
        );
    }
}

/// Reads the line protocol from `input` into a session of `streaming`.
fn serve(
    mut input: impl BufRead,
    streaming: &dyn motionlab_core::StreamingSegmenter,
    socket: bool,
    stall_s: f64,
) -> Result<ExitCode> {
    let source = if socket { "the connection" } else { "standard input" };
    let mut line_no = 0usize;
    let mut buf = Vec::new();
    let mut live: Option<Live> = None;
    let mut width = 0;
    loop {
        buf.clear();
        let mut stalled = false;
        // One line, across read timeouts (a stall is said once, then waited out).
        let status = loop {
            match input.read_until(b'\n', &mut buf) {
                Ok(0) => break Status::Closed,
                Ok(_) if buf.ends_with(b"\n") => break Status::Line,
                Ok(_) => break Status::Line, // the last line, without its newline
                Err(e)
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                    ) =>
                {
                    if !stalled {
                        eprintln!(
                            "live: stall — no complete line for {stall_s} s after line {line_no}; waiting"
                        );
                        stalled = true;
                    }
                }
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => break Status::Failed(e.to_string()),
            }
        };
        if let Status::Line = status {
            line_no += 1;
            let text = String::from_utf8_lossy(&buf);
            let text = text.trim();
            if text.is_empty() {
                continue;
            }
            if live.is_none() {
                let (layout, s) = header(text, line_no, streaming)?;
                width = layout.width();
                live = Some(Live::start(s, layout.rate.hz()));
                continue;
            }
            let Some(l) = live.as_mut() else { continue };
            let started = Instant::now();
            match sample_lines(text, width) {
                Ok(Line::End) => {
                    l.end()?;
                    l.summary();
                    return Ok(ExitCode::SUCCESS);
                }
                Ok(Line::Samples(rows)) => {
                    for row in rows.chunks_exact(width) {
                        if let Err(e) = l.push(row) {
                            let n = l.session.samples_seen();
                            eprintln!("live: line {line_no}: {e}; counted as missing sample {n}");
                            l.push(&vec![f64::NAN; width])?;
                        }
                    }
                }
                Err(why) => {
                    let n = l.session.samples_seen();
                    eprintln!("live: line {line_no}: {why}; counted as missing sample {n}");
                    l.push(&vec![f64::NAN; width])?;
                }
            }
            l.line_cost.add(started.elapsed());
            continue;
        }
        // The input ended or failed before an end line.
        let Some(l) = live.as_mut() else {
            return Err(Error::new(
                ErrorKind::EmptySequence,
                format!(
                    "{source} ended before its header line (`{{\"rate_hz\": …, \"points\" or \"channels\": […]}}`)"
                ),
            ));
        };
        if !socket && matches!(status, Status::Closed) {
            l.end()?;
            l.summary();
            return Ok(ExitCode::SUCCESS);
        }
        let why = match status {
            Status::Failed(e) => format!("failed ({e})"),
            _ => "closed".to_string(),
        };
        eprintln!(
            "live: {source} {why} after {} samples, before an {{\"end\": true}} line: the {} boundaries decided so far stand",
            l.session.samples_seen(),
            l.decided.len()
        );
        l.summary();
        return Ok(ExitCode::from(2));
    }
}

enum Status {
    Line,
    Closed,
    Failed(String),
}

enum Line {
    Samples(Vec<f64>),
    End,
}

/// The header line: the stream's layout, and a session of `streaming` on it.
fn header(
    text: &str,
    line_no: usize,
    streaming: &dyn motionlab_core::StreamingSegmenter,
) -> Result<(StreamLayout, Box<dyn SegmenterSession>)> {
    #[derive(serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    struct Header {
        rate_hz: f64,
        #[serde(default)]
        points: Option<Vec<String>>,
        #[serde(default)]
        channels: Option<Vec<String>>,
        #[serde(default)]
        up_axis: Option<Axis>,
        #[serde(default)]
        #[allow(dead_code)]
        name: Option<String>,
    }
    let at =
        |msg: String| Error::new(ErrorKind::Syntax, format!("line {line_no} (the header): {msg}"));
    let h: Header = serde_json::from_str(text).map_err(|e| {
        at(format!("{e}; expected {{\"rate_hz\": 120, \"points\": [\"LFHD\", …], \"up_axis\": \"z\"}} or {{\"rate_hz\": 100, \"channels\": [\"a\", …]}}"))
    })?;
    let rate = FrameRate::new(h.rate_hz).map_err(|e| at(format!("rate_hz: {e}")))?;
    let layout = match (h.points, h.channels) {
        (Some(p), None) if !p.is_empty() => {
            StreamLayout::points(p, rate, h.up_axis.unwrap_or(Axis::Y))
        }
        (None, Some(c)) if !c.is_empty() => StreamLayout::channels(c, rate),
        _ => {
            return Err(at(
                "expected exactly one non-empty list, \"points\" or \"channels\"".into()
            ));
        }
    };
    if layout.kind != streaming.consumes() {
        return Err(at(format!(
            "the stream carries {}, and the segmenter reads {}",
            layout.kind.describe(),
            streaming.consumes().describe()
        )));
    }
    let session = streaming.start(&layout).map_err(|e| at(e.to_string()))?;
    Ok((layout, session))
}

/// A sample line: one sample, a block of samples, or the end.
fn sample_lines(text: &str, width: usize) -> std::result::Result<Line, String> {
    let v: serde_json::Value = serde_json::from_str(text).map_err(|e| format!("not JSON ({e})"))?;
    let number = |x: &serde_json::Value| -> std::result::Result<f64, String> {
        match x {
            serde_json::Value::Null => Ok(f64::NAN),
            serde_json::Value::Number(n) => {
                n.as_f64().ok_or_else(|| format!("{n} is not a number"))
            }
            other => Err(format!("{other} is not a number or null")),
        }
    };
    match v {
        serde_json::Value::Object(o) if o.get("end") == Some(&serde_json::Value::Bool(true)) => {
            Ok(Line::End)
        }
        serde_json::Value::Array(a) if a.first().is_some_and(|x| x.is_array()) => {
            let mut out = Vec::with_capacity(a.len() * width);
            for (i, row) in a.iter().enumerate() {
                let row = row.as_array().ok_or_else(|| format!("block row {i} is not an array"))?;
                if row.len() != width {
                    return Err(format!("block row {i} has {} values, expected {width}", row.len()));
                }
                for x in row {
                    out.push(number(x)?);
                }
            }
            Ok(Line::Samples(out))
        }
        serde_json::Value::Array(a) => {
            if a.len() != width {
                return Err(format!("{} values, expected {width}", a.len()));
            }
            a.iter().map(number).collect::<std::result::Result<Vec<_>, _>>().map(Line::Samples)
        }
        _ => Err("expected an array of numbers (a sample), an array of arrays (a block) or {\"end\": true}".into()),
    }
}

/// Sends a motion's samples to a live listener over the line protocol, paced.
fn send(
    addr: &str,
    motion: &Motion,
    layout: &StreamLayout,
    samples: &[f64],
    speed: f64,
) -> Result<ExitCode> {
    let io = |e: std::io::Error| Error::new(ErrorKind::Io, format!("sending to {addr}: {e}"));
    let mut stream = TcpStream::connect(addr).map_err(io)?;
    let _ = stream.set_nodelay(true);
    let names = match layout.kind {
        DataKind::Points => {
            serde_json::json!({"rate_hz": layout.rate.hz(), "points": layout.names, "up_axis": layout.up_axis, "name": motion.name})
        }
        DataKind::Channels => {
            serde_json::json!({"rate_hz": layout.rate.hz(), "channels": layout.names, "name": motion.name})
        }
    };
    writeln!(stream, "{names}").map_err(io)?;
    let pace = Pace::new(layout.rate.hz(), speed);
    let mut line = String::new();
    for (i, s) in samples.chunks_exact(layout.width().max(1)).enumerate() {
        line.clear();
        sample_json(s, &mut line);
        pace.wait(i);
        stream.write_all(line.as_bytes()).map_err(io)?;
    }
    writeln!(stream, "{{\"end\": true}}").map_err(io)?;
    stream.flush().map_err(io)?;
    // Wait for the listener to close its side: everything sent has been read.
    let mut sink = [0u8; 64];
    let _ = stream.read(&mut sink);
    Ok(ExitCode::SUCCESS)
}

/// One sample as a JSON line (NaN as null; shortest round-trip decimals, so the listener reads
/// back the very values).
pub(crate) fn sample_json(s: &[f64], out: &mut String) {
    use std::fmt::Write as _;
    out.push('[');
    for (i, v) in s.iter().enumerate() {
        if i > 0 {
            out.push(',');
        }
        if v.is_finite() {
            let _ = write!(out, "{v:?}");
        } else {
            out.push_str("null");
        }
    }
    out.push_str("]\n");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sample_lines_read_samples_blocks_nulls_and_the_end() {
        let Ok(Line::Samples(v)) = sample_lines("[1, null, 2.5]", 3) else { panic!() };
        assert!(v[0] == 1.0 && v[1].is_nan() && v[2] == 2.5);
        let Ok(Line::Samples(v)) = sample_lines("[[1, 2], [3, 4]]", 2) else { panic!() };
        assert_eq!(v, vec![1.0, 2.0, 3.0, 4.0]);
        assert!(matches!(sample_lines("{\"end\": true}", 2), Ok(Line::End)));
        let e = sample_lines("[1, 2", 2).err().unwrap();
        assert!(e.starts_with("not JSON"), "{e}");
        assert_eq!(sample_lines("[1]", 2).err().unwrap(), "1 values, expected 2");
        assert!(sample_lines("[\"a\", 1]", 2).err().unwrap().contains("not a number"));
        let mut s = String::new();
        sample_json(&[0.1, f64::NAN, -3.0], &mut s);
        assert_eq!(s, "[0.1,null,-3.0]\n");
    }

    #[test]
    fn set_values_are_toml_or_strings() {
        let t = set_params(&["a=5".into(), "b={ frames = 3 }".into(), "c=root".into()]).unwrap();
        assert_eq!(t["a"].as_integer(), Some(5));
        assert_eq!(t["b"]["frames"].as_integer(), Some(3));
        assert_eq!(t["c"].as_str(), Some("root"));
        assert!(set_params(&["nokey".into()]).is_err());
    }
}
