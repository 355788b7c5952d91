//! The files motionlab hands an external program and the JSON it reads back (protocol 1; the
//! crate docs describe it for program authors).

use std::io::{BufWriter, Write};
use std::path::Path;

use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};

use motionlab_core::{
    Axis, ErrorKind, FeatureSet, LabelTrace, Motion, PointKind, SegmenterOutput, Threshold, Trace,
};

/// The protocol version written to `meta.json` (`"protocol": 1`).
pub const PROTOCOL_VERSION: u32 = 1;
/// The positions file's name inside the exchange folder.
pub const POSITIONS_FILE: &str = "positions.npy";
/// The metadata file's name inside the exchange folder.
pub const META_FILE: &str = "meta.json";

/// A problem with what the program returned: its kind and a message (the caller adds the
/// plugin and the command).
pub type ReplyError = (ErrorKind, String);

/// `meta.json`.
#[derive(Debug, Serialize)]
pub struct Meta<'a> {
    pub protocol: u32,
    /// The plugin that runs the program (`external`, `external_features`).
    pub plugin: &'a str,
    /// What the program must return: `segmenter` or `feature_extractor`.
    pub expects: &'a str,
    pub command: &'a [String],
    pub motion: MotionMeta<'a>,
    pub positions: PositionsMeta,
    /// The stage's `params` table, unchanged.
    pub params: &'a Map<String, Value>,
}

/// What a program needs to know about the motion besides its positions.
#[derive(Debug, Serialize)]
pub struct MotionMeta<'a> {
    pub name: &'a str,
    /// The file it was loaded from, when it was.
    pub source: Option<String>,
    /// The loader that read it (`asf_amc`, `qualisys_tsv`, …).
    pub format: &'a str,
    pub rate_hz: f64,
    pub n_frames: usize,
    pub n_points: usize,
    pub point_names: &'a [String],
    pub point_kind: PointKind,
    pub up_axis: Axis,
    pub n_missing_samples: usize,
}

/// How `positions.npy` is laid out.
#[derive(Debug, Serialize)]
pub struct PositionsMeta {
    pub file: &'static str,
    pub dtype: &'static str,
    pub shape: [usize; 3],
    pub unit: &'static str,
    pub missing: &'static str,
}

impl<'a> Meta<'a> {
    pub fn new(
        plugin: &'a str,
        expects: &'a str,
        command: &'a [String],
        params: &'a Map<String, Value>,
        motion: &'a Motion,
    ) -> Self {
        let (f, m) = (motion.n_frames(), motion.n_points());
        Meta {
            protocol: PROTOCOL_VERSION,
            plugin,
            expects,
            command,
            motion: MotionMeta {
                name: &motion.name,
                source: motion.source.as_ref().map(|p| p.display().to_string()),
                format: &motion.format,
                rate_hz: motion.frame_rate().hz(),
                n_frames: f,
                n_points: m,
                point_names: motion.point_names(),
                point_kind: motion.point_kind(),
                up_axis: motion.up_axis(),
                n_missing_samples: motion.missing_count(),
            },
            positions: PositionsMeta {
                file: POSITIONS_FILE,
                dtype: "<f8",
                shape: [f, m, 3],
                unit: "mm",
                missing: "a missing sample is NaN in all three coordinates; no other value is NaN",
            },
            params,
        }
    }
}

/// Writes `positions.npy` and `meta.json` into `dir`.
pub fn write_exchange(dir: &Path, meta: &Meta<'_>, motion: &Motion) -> std::io::Result<()> {
    let mut npy = BufWriter::new(std::fs::File::create(dir.join(POSITIONS_FILE))?);
    crate::npy::write_positions(
        &mut npy,
        motion.positions(),
        motion.n_frames(),
        motion.n_points(),
    )?;
    npy.flush()?;
    let json = serde_json::to_vec_pretty(meta).map_err(std::io::Error::other)?;
    std::fs::write(dir.join(META_FILE), json)
}

/// One returned trace: `values` has one number per frame, `null` for NaN.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TraceReply {
    pub name: String,
    #[serde(default)]
    pub unit: String,
    pub values: Vec<Option<f64>>,
}

/// One returned threshold, drawn on the trace it names.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ThresholdReply {
    pub name: String,
    pub trace: String,
    pub value: f64,
}

/// One returned label trace: one string per frame.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LabelReply {
    pub name: String,
    pub values: Vec<String>,
}

/// A segmenter's stdout.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SegmenterReply {
    pub candidates: Vec<usize>,
    #[serde(default)]
    pub traces: Vec<TraceReply>,
    #[serde(default)]
    pub thresholds: Vec<ThresholdReply>,
    #[serde(default)]
    pub flagged_frames: Vec<usize>,
}

/// A feature extractor's stdout.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FeaturesReply {
    #[serde(default)]
    pub traces: Vec<TraceReply>,
    #[serde(default)]
    pub labels: Vec<LabelReply>,
}

/// Parses the program's stdout as one JSON object of type `T`.
pub fn parse_reply<T: serde::de::DeserializeOwned>(stdout: &[u8]) -> Result<T, ReplyError> {
    let text = String::from_utf8_lossy(stdout);
    if text.trim().is_empty() {
        return Err((
            ErrorKind::Syntax,
            "printed nothing on stdout; expected one JSON object (protocol 1)".into(),
        ));
    }
    serde_json::from_str(&text).map_err(|e| {
        use serde_json::error::Category;
        let (kind, hint) = match e.classify() {
            Category::Data => (ErrorKind::WrongType, ""),
            _ if text.contains("NaN") || text.contains("Infinity") => {
                (ErrorKind::Syntax, " (JSON has no NaN or Infinity: write null for a missing value, e.g. None in Python)")
            }
            _ if !text.trim_start().starts_with('{') => (ErrorKind::Syntax, " (stdout must hold only the JSON object: print anything else to stderr)"),
            _ => (ErrorKind::Syntax, ""),
        };
        (kind, format!("stdout is not the expected JSON: {e}{hint}"))
    })
}

/// Checks a segmenter's reply against a motion of `n_frames` frames and converts it.
pub fn segmenter_output(
    reply: SegmenterReply,
    n_frames: usize,
) -> Result<SegmenterOutput, ReplyError> {
    check_frames("candidates", &reply.candidates, n_frames)?;
    check_frames("flagged_frames", &reply.flagged_frames, n_frames)?;
    let traces = traces(reply.traces, n_frames)?;
    let mut thresholds = Vec::with_capacity(reply.thresholds.len());
    for t in reply.thresholds {
        if !t.value.is_finite() {
            return Err((
                ErrorKind::NonFinite,
                format!("threshold {:?} has value {}, expected a finite number", t.name, t.value),
            ));
        }
        if !traces.iter().any(|tr| tr.name == t.trace) {
            let names: Vec<&str> = traces.iter().map(|tr| tr.name.as_str()).collect();
            return Err((
                ErrorKind::UnknownName,
                format!(
                    "threshold {:?} names trace {:?}, but the returned traces are {names:?}",
                    t.name, t.trace
                ),
            ));
        }
        thresholds.push(Threshold { name: t.name, trace: t.trace, value: t.value });
    }
    Ok(SegmenterOutput {
        candidates: reply.candidates,
        traces,
        thresholds,
        flagged_frames: reply.flagged_frames,
        penalty_path: Vec::new(),
    })
}

/// Checks a feature extractor's reply against a motion of `n_frames` frames and converts it.
pub fn feature_set(reply: FeaturesReply, n_frames: usize) -> Result<FeatureSet, ReplyError> {
    if reply.traces.is_empty() && reply.labels.is_empty() {
        return Err((
            ErrorKind::EmptySequence,
            "returned no trace and no label; expected at least one".into(),
        ));
    }
    let traces = traces(reply.traces, n_frames)?;
    let mut labels: Vec<LabelTrace> = Vec::with_capacity(reply.labels.len());
    for l in reply.labels {
        check_name(
            "label",
            &l.name,
            labels.iter().map(|x| x.name.as_str()).chain(traces.iter().map(|t| t.name.as_str())),
        )?;
        if l.values.len() != n_frames {
            return Err((
                ErrorKind::WrongValueCount,
                format!(
                    "label {:?} has {} values, expected one per frame ({n_frames})",
                    l.name,
                    l.values.len()
                ),
            ));
        }
        labels.push(LabelTrace { name: l.name, values: l.values });
    }
    Ok(FeatureSet { traces, labels })
}

/// Frames must lie in `0..n_frames`, strictly ascending.
fn check_frames(what: &str, frames: &[usize], n_frames: usize) -> Result<(), ReplyError> {
    if let Some((i, &f)) = frames.iter().enumerate().find(|&(_, &f)| f >= n_frames) {
        let last = n_frames.saturating_sub(1);
        return Err((
            ErrorKind::OutOfRange,
            format!(
                "{what}[{i}] = {f} is out of range: the motion has {n_frames} frames (0–{last})"
            ),
        ));
    }
    if let Some(i) = frames.windows(2).position(|w| w[0] >= w[1]) {
        let (a, b) = (frames[i], frames[i + 1]);
        let why = if a == b { "repeated" } else { "not ascending" };
        return Err((
            ErrorKind::OutOfRange,
            format!(
                "{what} must be ascending without repeats: {what}[{}] = {b} follows {a} ({why})",
                i + 1
            ),
        ));
    }
    Ok(())
}

/// Trace names become table columns: non-empty, letters, digits and `_`, unique.
fn check_name<'a>(
    what: &str,
    name: &str,
    taken: impl IntoIterator<Item = &'a str>,
) -> Result<(), ReplyError> {
    if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
        return Err((
            ErrorKind::Syntax,
            format!(
                "{what} name {name:?} must be non-empty ASCII letters, digits and _ (it becomes a table column)"
            ),
        ));
    }
    if taken.into_iter().any(|t| t == name) {
        return Err((ErrorKind::DuplicateName, format!("{what} name {name:?} is returned twice")));
    }
    Ok(())
}

fn traces(replies: Vec<TraceReply>, n_frames: usize) -> Result<Vec<Trace>, ReplyError> {
    let mut out: Vec<Trace> = Vec::with_capacity(replies.len());
    for t in replies {
        check_name("trace", &t.name, out.iter().map(|x| x.name.as_str()))?;
        if t.values.len() != n_frames {
            return Err((
                ErrorKind::WrongValueCount,
                format!(
                    "trace {:?} has {} values, expected one per frame ({n_frames})",
                    t.name,
                    t.values.len()
                ),
            ));
        }
        let values = t.values.into_iter().map(|v| v.unwrap_or(f64::NAN)).collect();
        out.push(Trace::new(t.name, t.unit, values));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn seg(json: &str, n: usize) -> Result<SegmenterOutput, ReplyError> {
        segmenter_output(parse_reply(json.as_bytes())?, n)
    }

    #[test]
    fn a_valid_reply_converts_with_null_as_nan() {
        let out = seg(r#"{"candidates": [1, 3], "traces": [{"name": "V", "unit": "mm/s", "values": [1.5, null, 2, 0]}],
            "thresholds": [{"name": "v_low", "trace": "V", "value": 1.75}]}"#, 4)
        .unwrap();
        assert_eq!(out.candidates, vec![1, 3]);
        assert_eq!(out.traces[0].values[0], 1.5);
        assert!(out.traces[0].values[1].is_nan());
        assert_eq!(out.thresholds[0].value, 1.75);
    }

    #[test]
    fn each_bad_reply_is_one_error_of_its_kind() {
        let cases: [(&str, ErrorKind, &str); 10] = [
            ("", ErrorKind::Syntax, "printed nothing"),
            ("hello\n{\"candidates\": []}", ErrorKind::Syntax, "only the JSON object"),
            (r#"{"candidates": [1, 2"#, ErrorKind::Syntax, "line 1 column"),
            (r#"{"candidates": [1.5]}"#, ErrorKind::WrongType, "floating point `1.5`"),
            (r#"{"candidates": [-1]}"#, ErrorKind::WrongType, "integer `-1`"),
            (
                r#"{"candidates": [4]}"#,
                ErrorKind::OutOfRange,
                "candidates[0] = 4 is out of range: the motion has 4 frames (0–3)",
            ),
            (r#"{"candidates": [2, 1]}"#, ErrorKind::OutOfRange, "not ascending"),
            (r#"{"candidates": [2, 2]}"#, ErrorKind::OutOfRange, "repeated"),
            (
                r#"{"candidates": [], "traces": [{"name": "V", "values": [NaN, 1, 2, 3]}]}"#,
                ErrorKind::Syntax,
                "write null",
            ),
            (r#"{"candidate": [1]}"#, ErrorKind::WrongType, "unknown field `candidate`"),
        ];
        for (json, kind, needle) in cases {
            let (k, msg) = seg(json, 4).unwrap_err();
            assert_eq!(k, kind, "{json}: {msg}");
            assert!(msg.contains(needle), "{json}: {msg}");
        }
        let (k, msg) = seg(r#"{"candidates": [], "traces": [{"name": "V", "values": [1, 2]}]}"#, 4)
            .unwrap_err();
        assert_eq!(
            (k, msg.as_str()),
            (ErrorKind::WrongValueCount, "trace \"V\" has 2 values, expected one per frame (4)")
        );
        let (k, _) = seg(
            r#"{"candidates": [], "thresholds": [{"name": "t", "trace": "W", "value": 1}]}"#,
            4,
        )
        .unwrap_err();
        assert_eq!(k, ErrorKind::UnknownName);
    }

    #[test]
    fn feature_replies_need_one_trace_or_label_of_full_length() {
        let ok = feature_set(
            parse_reply(br#"{"labels": [{"name": "side", "values": ["l", "r"]}]}"#).unwrap(),
            2,
        )
        .unwrap();
        assert_eq!(ok.labels[0].values, vec!["l", "r"]);
        assert_eq!(
            feature_set(parse_reply(b"{}").unwrap(), 2).unwrap_err().0,
            ErrorKind::EmptySequence
        );
        let dup = br#"{"traces": [{"name": "a", "values": [1, 2]}], "labels": [{"name": "a", "values": ["x", "y"]}]}"#;
        assert_eq!(
            feature_set(parse_reply(dup).unwrap(), 2).unwrap_err().0,
            ErrorKind::DuplicateName
        );
    }
}
