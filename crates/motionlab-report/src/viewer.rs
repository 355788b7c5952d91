//! Interactive viewer pages: a [`ViewerSpec`] → one self-contained `<name>.html`.
//!
//! The page plays the motion back as a 3-D stick figure (orbit and zoom with the mouse, floor
//! grid, root path) above time-aligned lanes (candidates, fused candidates, ground truth with
//! its tolerance, traces with thresholds, intervals), with a playhead, keyboard stepping and a
//! list of every mark with its matched / false positive / missed status. A spec with an
//! [`AnnotationSpec`] adds annotation mode (`viewer_annotate.js`, spliced into the script):
//! boundaries marked at the playhead per annotator, judged live against the candidate lanes at
//! the run's tolerance, kept in the browser's `localStorage` under the input's SHA-256 and
//! downloaded as `boundaries_csv` / ELAN `.eaf` files in the bytes `motionlab_io`'s writers
//! give (`tests/browser/check_annotate.py` drives it and reads the files back).
//!
//! It must open from the file system: Chromium blocks `fetch()` of a local file on `file://`,
//! so the data are embedded in the page. The JavaScript is hand-written (about 600 lines, no
//! library): a 2-D canvas with a small perspective projection draws ~40 points and bones, which
//! needs neither WebGL (often unavailable headless) nor three.js's 600 KB.
//!
//! ## Data encoding (measured: see `tests/browser/` and the README)
//! Every per-frame channel (each point's x, y and z, each trace) is quantised to 16 bits with
//! its own offset and step (code 0 = missing/NaN, codes 1…65535 span the channel's finite
//! range, so a position is within range/131070 — 0.03 mm over 4 m — of its value), delta-coded
//! along time (wrapping), split into a low-byte and a high-byte plane, gzip-compressed and
//! base64-encoded into a `<script>` element. Smooth motion makes the deltas tiny, so gzip
//! shrinks the planes several-fold; the browser inflates them with its native
//! `DecompressionStream`. Small metadata (names, bones, lanes, marks) is JSON beside it.

use std::io::Write;
use std::path::{Path, PathBuf};

use base64::Engine;
use serde::Serialize;

use motionlab_core::viewer::{
    AnnotationSpec, EventKind, IntervalKind, Lane, MarkStatus, ViewerSpec,
};
use motionlab_core::{Error, ErrorKind, Location, Result};

const TEMPLATE: &str = include_str!("../templates/viewer.html");
const SCRIPT: &str = include_str!("../templates/viewer.js");
const ANNOTATE_SCRIPT: &str = include_str!("../templates/viewer_annotate.js");
const NO_ANNOTATION: &str = "const ANNO = null, anno = null;\nfunction annoInit() {}\nfunction annoKey() { return false; }\nfunction annoDrawNearest() {}\n";

/// How one channel's 16-bit codes map back to values: `value = offset + (code − 1) · step`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
struct Quant {
    offset: f64,
    step: f64,
}

/// Quantises one channel to codes, delta-coded, appended to the low- and high-byte planes.
fn encode_channel(
    values: &mut dyn Iterator<Item = f64>,
    lo: &mut Vec<u8>,
    hi: &mut Vec<u8>,
) -> Quant {
    let values: Vec<f64> = values.collect();
    let (mut min, mut max) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.iter().copied().filter(|v| v.is_finite()) {
        min = min.min(v);
        max = max.max(v);
    }
    let q = if min.is_finite() {
        Quant { offset: min, step: if max > min { (max - min) / 65534.0 } else { 1.0 } }
    } else {
        Quant { offset: 0.0, step: 1.0 }
    };
    let mut prev: u16 = 0;
    for v in values {
        let code: u16 = if v.is_finite() {
            1 + ((v - q.offset) / q.step).round().clamp(0.0, 65534.0) as u16
        } else {
            0
        };
        let d = code.wrapping_sub(prev);
        prev = code;
        lo.push(d as u8);
        hi.push((d >> 8) as u8);
    }
    q
}

#[derive(Serialize)]
struct MetaMark<'a> {
    frame: usize,
    label: &'a str,
    status: Option<MarkStatus>,
}

#[derive(Serialize)]
#[serde(tag = "type", rename_all = "snake_case")]
enum MetaLane<'a> {
    Events {
        name: &'a str,
        kind: EventKind,
        tolerance_frames: Option<f64>,
        windows: &'a [(usize, usize)],
        judged_against: Option<&'a str>,
        marks: Vec<MetaMark<'a>>,
    },
    Trace {
        name: &'a str,
        unit: &'a str,
        /// (series name, quantisation) in data order.
        series: Vec<(&'a str, Quant)>,
        thresholds: Vec<(&'a str, f64)>,
    },
    Intervals {
        name: &'a str,
        kind: IntervalKind,
        intervals: Vec<(usize, usize, &'a str)>,
    },
}

#[derive(Serialize)]
struct Meta<'a> {
    title: &'a str,
    back_link: Option<&'a str>,
    frame_rate_hz: f64,
    n_frames: usize,
    up_axis: usize,
    point_names: &'a [String],
    bones: &'a [(usize, usize)],
    root: Option<usize>,
    /// Per point, x, y, z quantisation (point-major, as the data planes).
    positions: Vec<[Quant; 3]>,
    lanes: Vec<MetaLane<'a>>,
    annotation: Option<&'a AnnotationSpec>,
}

/// The page's metadata (JSON) and data (gzip of the byte planes, base64).
fn encode(spec: &ViewerSpec, back_link: Option<&str>) -> Result<(String, String)> {
    let m = &spec.motion;
    let (n, p) = (m.n_frames, m.n_points());
    let mut planes: Vec<u8> = Vec::with_capacity(2 * n * (3 * p + 8));
    let mut positions = Vec::with_capacity(p);
    let (mut lo, mut hi) = (Vec::with_capacity(n), Vec::with_capacity(n));
    // Point-major channels (point 0's x, y, z, then point 1's …): each a low then a high plane.
    let mut push = |values: &mut dyn Iterator<Item = f64>, planes: &mut Vec<u8>| {
        lo.clear();
        hi.clear();
        let q = encode_channel(values, &mut lo, &mut hi);
        planes.extend_from_slice(&lo);
        planes.extend_from_slice(&hi);
        q
    };
    for k in 0..p {
        let mut qs = [Quant { offset: 0.0, step: 1.0 }; 3];
        for (a, q) in qs.iter_mut().enumerate() {
            *q = push(&mut (0..n).map(|f| m.positions_mm[f * p + k][a] as f64), &mut planes);
        }
        positions.push(qs);
    }
    let mut lanes = Vec::with_capacity(spec.lanes.len());
    for lane in &spec.lanes {
        lanes.push(match lane {
            Lane::Events(l) => MetaLane::Events {
                name: &l.name,
                kind: l.kind,
                tolerance_frames: l.tolerance_frames,
                windows: &l.windows,
                judged_against: l.judged_against.as_deref(),
                marks: l
                    .marks
                    .iter()
                    .map(|k| MetaMark { frame: k.frame, label: &k.label, status: k.status })
                    .collect(),
            },
            Lane::Trace(l) => MetaLane::Trace {
                name: &l.name,
                unit: &l.unit,
                series: l
                    .series
                    .iter()
                    .map(|s| (s.name.as_str(), push(&mut s.values.iter().copied(), &mut planes)))
                    .collect(),
                thresholds: l.thresholds.iter().map(|t| (t.name.as_str(), t.value)).collect(),
            },
            Lane::Intervals(l) => MetaLane::Intervals {
                name: &l.name,
                kind: l.kind,
                intervals: l.intervals.iter().map(|i| (i.start, i.end, i.label.as_str())).collect(),
            },
        });
    }
    let meta = Meta {
        title: &spec.title,
        back_link,
        frame_rate_hz: m.frame_rate_hz,
        n_frames: n,
        up_axis: m.up_axis.index(),
        point_names: &m.point_names,
        bones: &m.bones,
        root: m.root,
        positions,
        lanes,
        annotation: spec.annotation.as_ref(),
    };
    let json = serde_json::to_string(&meta)
        .map_err(|e| Error::new(ErrorKind::Report, format!("viewer metadata: {e}")))?;
    let mut gz = flate2::write::GzEncoder::new(
        Vec::with_capacity(planes.len() / 3),
        flate2::Compression::new(6),
    );
    gz.write_all(&planes)
        .map_err(|e| Error::new(ErrorKind::Report, format!("viewer data: {e}")))?;
    let packed =
        gz.finish().map_err(|e| Error::new(ErrorKind::Report, format!("viewer data: {e}")))?;
    Ok((json, base64::engine::general_purpose::STANDARD.encode(packed)))
}

/// Text safe inside HTML element content.
fn escape_html(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
        .replace('{', "&#123;")
}

/// The whole page as text. `back_link` is a relative link shown as "run page".
pub fn render_page(spec: &ViewerSpec, back_link: Option<&str>) -> Result<String> {
    spec.validate()?;
    let (json, data) = encode(spec, back_link)?;
    // JSON inside <script>: no `<` at all, so neither `</script>` nor `<!--` (which would make
    // the parser look for a second `</script>`) can occur; `<`, `>` and `&` only occur inside
    // JSON strings, where `\u003c` is the same character to JSON.parse.
    let json = json.replace('<', "\\u003c").replace('>', "\\u003e").replace('&', "\\u0026");
    // Split at the data's place first: no text from the spec can then be taken for a placeholder.
    let (head, tail) = TEMPLATE.split_once("{{DATA}}").unwrap_or((TEMPLATE, ""));
    let head = crate::fonts::with_cjk_font(
        head.replace("{{TITLE}}", &escape_html(&spec.title)).replace("{{META}}", &json),
    );
    // Pages without annotation mode (matching, gait) get the few names the player calls.
    let annotate = if spec.annotation.is_some() { ANNOTATE_SCRIPT } else { NO_ANNOTATION };
    let script = SCRIPT.replace("/*{{ANNOTATE}}*/", annotate);
    Ok([head.as_str(), &data, &tail.replace("{{SCRIPT}}", &script)].concat())
}

/// Writes `<dir>/<spec.name>.html` (creating `dir`), linking "../index.html" as the run page.
pub fn write(dir: &Path, spec: &ViewerSpec) -> Result<PathBuf> {
    write_with_back_link(dir, spec, Some("../index.html"))
}

/// [`write`] with a chosen link back (or none).
pub fn write_with_back_link(
    dir: &Path,
    spec: &ViewerSpec,
    back_link: Option<&str>,
) -> Result<PathBuf> {
    let page = render_page(spec, back_link)?;
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let path = dir.join(format!("{}.html", motionlab_core::paths::safe_file_name(&spec.name)));
    std::fs::write(&path, page)
        .map_err(|e| Error::io(&path, e).with_location(Location::file(&path)))?;
    Ok(path)
}

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_core::Axis;
    use motionlab_core::viewer::{EventLane, TraceLane, TraceSeries, ViewerMotion};
    use std::io::Read;

    fn decode(lo: &[u8], hi: &[u8], q: Quant) -> Vec<f64> {
        let mut code: u16 = 0;
        lo.iter()
            .zip(hi)
            .map(|(l, h)| {
                code = code.wrapping_add(*l as u16 | (*h as u16) << 8);
                if code == 0 { f64::NAN } else { q.offset + (code - 1) as f64 * q.step }
            })
            .collect()
    }

    #[test]
    fn channels_round_trip_within_half_a_step_and_keep_nan() {
        let values: Vec<f64> = (0..500)
            .map(|i| if i % 97 == 5 { f64::NAN } else { 1000.0 * (i as f64 * 0.05).sin() - 300.0 })
            .collect();
        let (mut lo, mut hi) = (Vec::new(), Vec::new());
        let q = encode_channel(&mut values.iter().copied(), &mut lo, &mut hi);
        let back = decode(&lo, &hi, q);
        assert!((q.step - 2000.0 / 65534.0).abs() < 1e-3, "{q:?}");
        for (a, b) in values.iter().zip(&back) {
            assert_eq!(a.is_nan(), b.is_nan());
            if a.is_finite() {
                assert!((a - b).abs() <= q.step / 2.0 + 1e-9, "{a} vs {b}");
            }
        }
        // Constant and all-missing channels decode too.
        for vals in [vec![5.0; 4], vec![f64::NAN; 4]] {
            let (mut lo, mut hi) = (Vec::new(), Vec::new());
            let q = encode_channel(&mut vals.iter().copied(), &mut lo, &mut hi);
            let back = decode(&lo, &hi, q);
            assert!(
                vals.iter().zip(&back).all(|(a, b)| a == b || (a.is_nan() && b.is_nan())),
                "{back:?}"
            );
        }
    }

    /// A walking two-point figure of `n` frames with `points` points.
    fn spec(n: usize, points: usize) -> ViewerSpec {
        let positions_mm = (0..n)
            .flat_map(|f| {
                (0..points).map(move |k| {
                    let t = f as f32 / 120.0;
                    [
                        1000.0 * t + 30.0 * (t * 7.0 + k as f32).sin(),
                        200.0 * (k as f32 * 0.3).cos(),
                        50.0 * k as f32 + 20.0 * (t * 5.0).sin(),
                    ]
                })
            })
            .collect();
        let motion = ViewerMotion {
            frame_rate_hz: 120.0,
            up_axis: Axis::Z,
            point_names: (0..points).map(|k| format!("p{k}")).collect(),
            positions_mm,
            n_frames: n,
            bones: (1..points).map(|k| (k - 1, k)).collect(),
            root: Some(0),
        };
        let mut s = ViewerSpec::new("take", "take <1> & co", motion);
        s.lanes.push(Lane::Events(EventLane::new("fused", EventKind::Fused, &[10, n / 2])));
        s.lanes.push(Lane::Trace(TraceLane {
            name: "speed".into(),
            unit: "mm/s".into(),
            series: vec![TraceSeries {
                name: "V".into(),
                values: (0..n).map(|f| (f as f64 * 0.01).sin().abs() * 900.0).collect(),
            }],
            thresholds: vec![],
        }));
        s
    }

    #[test]
    fn page_embeds_escaped_metadata_and_data_that_inflate_to_every_channel() {
        let s = spec(300, 5);
        let page = render_page(&s, None).unwrap();
        assert!(page.contains("take &lt;1&gt; &amp; co"));
        assert!(!page.contains("http://") && !page.contains("https://"), "no network references");
        let (json, data) = encode(&s, None).unwrap();
        let meta: serde_json::Value = serde_json::from_str(&json).unwrap();
        assert_eq!(meta["lanes"][0]["marks"][1]["frame"], 150);
        assert!(meta["annotation"].is_null());
        assert!(
            !page.contains("{{ANNOTATE}}") && !page.contains("function annoEafText"),
            "no annotation script without annotation mode"
        );
        let packed = base64::engine::general_purpose::STANDARD.decode(data).unwrap();
        let mut planes = Vec::new();
        flate2::read::GzDecoder::new(&packed[..]).read_to_end(&mut planes).unwrap();
        // 5 points × 3 axes + 1 trace, two byte planes of 300 frames each.
        assert_eq!(planes.len(), (5 * 3 + 1) * 2 * 300);
        // Point 3's z (channel 3·3 + 2) decodes to the input.
        let c = 3 * 3 + 2;
        let q: Quant = Quant {
            offset: meta["positions"][3][2]["offset"].as_f64().unwrap(),
            step: meta["positions"][3][2]["step"].as_f64().unwrap(),
        };
        let back =
            decode(&planes[c * 600..c * 600 + 300], &planes[c * 600 + 300..c * 600 + 600], q);
        for f in [0, 77, 299] {
            assert!(
                (back[f] - s.motion.positions_mm[f * 5 + 3][2] as f64).abs() <= q.step,
                "frame {f}"
            );
        }
    }

    #[test]
    fn a_five_minute_take_at_120_fps_stays_under_ten_megabytes() {
        // 36 000 frames × 31 points, the size a viewer page must stay small at.
        let page = render_page(&spec(36_000, 31), None).unwrap();
        eprintln!("36 000 frames × 31 points: {} bytes", page.len());
        assert!(page.len() < 10_000_000, "{} bytes", page.len());
    }

    #[test]
    fn the_annotation_section_reaches_the_page() {
        let mut s = spec(50, 2);
        s.annotation = Some(AnnotationSpec {
            sequence: "take".into(),
            input_sha256: "0f".repeat(32),
            tolerance_frames: Some(6.0),
        });
        let (json, _) = encode(&s, None).unwrap();
        let meta: serde_json::Value = serde_json::from_str(&json).unwrap();
        assert!(
            render_page(&s, None).unwrap().contains("function annoEafText"),
            "the annotation script is spliced in"
        );
        assert_eq!(meta["annotation"]["input_sha256"], "0f".repeat(32));
        assert_eq!(meta["annotation"]["tolerance_frames"], 6.0);
        s.annotation.as_mut().unwrap().input_sha256 = "xyz".into();
        assert!(render_page(&s, None).is_err());
    }

    #[test]
    fn an_invalid_spec_is_refused() {
        let mut s = spec(10, 3);
        s.lanes.push(Lane::Events(EventLane::new("x", EventKind::Other, &[10])));
        assert!(render_page(&s, None).is_err());
    }
}
