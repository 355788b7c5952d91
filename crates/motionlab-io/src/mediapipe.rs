//! The MediaPipe pose-landmark loader plugin `mediapipe`: BlazePose landmarks written as
//! protobuf text (`.pbtxt`, MediaPipe's own `LandmarksDetectionResult` /
//! `NormalizedLandmarkList`), read into a 2-D motion.
//!
//! The protobuf text format is read by a small hand-written parser: the messages are flat
//! (`landmark { x: … y: … }`), and a protobuf runtime would be a large dependency for them.

use std::path::Path;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{Dimensionality, Error, ErrorKind, LoadNotes, Loader, Motion, Result};

use crate::pose::{self, BLAZEPOSE_33, PersonRule};

/// Reads MediaPipe pose landmarks in protobuf text format (`.pbtxt`) into a 2-D motion.
///
/// Each top-level `landmarks { landmark { x: … y: … z: … visibility: … presence: … } … }`
/// block (MediaPipe's `LandmarksDetectionResult`; a bare list of `landmark { … }` blocks, a
/// `NormalizedLandmarkList`, is one block) is one frame; several blocks, as a video's results
/// written one after another, are consecutive frames. 33 landmarks are named as BlazePose's
/// (`nose` … `right_foot_index`), another count `kp0`, `kp1`, …. `world_landmarks` blocks
/// (metres) are not read, nor `z` (relative depth, not a coordinate).
///
/// x and y are normalised to the image (0–1); with `image_width_px` and `image_height_px`
/// they become pixels, else they stay normalised (the load notes say so, and speeds are then
/// in image widths/heights per second). A landmark's confidence is its `visibility` (or
/// `presence` when visibility is absent; 1 when neither is written). **Missing samples**: a
/// landmark with confidence 0 or below `min_confidence`, or without x or y.
///
/// The files carry no frame rate: `rate_hz` is required. Errors name the file and line: an
/// unclosed block, a field without a value, a value that is not a number, no landmark.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MediaPipeParams {
    /// Frames per second of the video (the files do not store it).
    #[serde(default)]
    #[schemars(extend("x-default" = "none: loading a file asks for it"))]
    pub rate_hz: Option<f64>,
    /// The image's width in pixels, to turn normalised x into pixels.
    #[serde(default)]
    #[schemars(extend("x-default" = "none: x stays normalised"))]
    pub image_width_px: Option<f64>,
    /// The image's height in pixels, to turn normalised y into pixels.
    #[serde(default)]
    #[schemars(extend("x-default" = "none: y stays normalised"))]
    pub image_height_px: Option<f64>,
    /// Landmarks whose visibility is below this (0–1) are missing samples.
    #[serde(default)]
    pub min_confidence: f64,
}

/// The validated loader.
#[derive(Clone, Debug)]
pub struct MediaPipeLoader {
    rate_hz: Option<f64>,
    scale: Option<(f64, f64)>,
    min_confidence: f64,
}

impl ParamGuard for MediaPipeParams {
    type Checked = MediaPipeLoader;
    fn check(self) -> Result<MediaPipeLoader> {
        if let Some(hz) = self.rate_hz {
            motionlab_core::FrameRate::new(hz).map_err(|e| e.with_field("rate_hz"))?;
        }
        let positive = |v: f64, key: &str| {
            if v.is_finite() && v > 0.0 {
                Ok(v)
            } else {
                Err(Error::new(ErrorKind::OutOfRange, format!("{key} = {v}; expected pixels > 0"))
                    .with_field(key))
            }
        };
        let scale = match (self.image_width_px, self.image_height_px) {
            (None, None) => None,
            (Some(w), Some(h)) => {
                Some((positive(w, "image_width_px")?, positive(h, "image_height_px")?))
            }
            (Some(_), None) | (None, Some(_)) => {
                return Err(Error::new(
                    ErrorKind::MissingKey,
                    "image_width_px and image_height_px go together (x and y are normalised separately)",
                )
                .with_field(if self.image_width_px.is_some() {
                    "image_height_px"
                } else {
                    "image_width_px"
                }));
            }
        };
        Ok(MediaPipeLoader {
            rate_hz: self.rate_hz,
            scale,
            min_confidence: pose::check_min_confidence(self.min_confidence)?,
        })
    }
}

impl Loader for MediaPipeLoader {
    fn extensions(&self) -> &'static [&'static str] {
        &["pbtxt"]
    }
    fn dimensionality(&self) -> Dimensionality {
        Dimensionality::Two
    }
    fn load(&self, path: &Path) -> Result<Motion> {
        let text = crate::read::read_text(path)?;
        let frames = parse_pbtxt(&text, path)?;
        let n = frames[0].len();
        if let Some((k, f)) = frames.iter().enumerate().find(|(_, f)| f.len() != n) {
            return Err(Error::new(
                ErrorKind::WrongValueCount,
                format!("frame {k} has {} landmarks; frame 0 has {n}", f.len()),
            )
            .with_location(motionlab_core::Location::file(path).field("landmarks")));
        }
        let (sx, sy) = self.scale.unwrap_or((1.0, 1.0));
        let people: Vec<Vec<pose::Person>> = frames
            .iter()
            .map(|f| vec![f.iter().map(|l| [l.x * sx, l.y * sy, l.confidence]).collect()])
            .collect();
        let names = if n == BLAZEPOSE_33.len() {
            BLAZEPOSE_33.iter().map(|s| s.to_string()).collect()
        } else {
            (0..n).map(|k| format!("kp{k}")).collect()
        };
        let notes = LoadNotes {
            length_unit: None,
            length_unit_from: match self.scale {
                Some((w, h)) => format!("pixels: normalised x, y times {w} × {h} px"),
                None => "normalised image coordinates (0–1; no image_width_px/image_height_px given): not pixels".into(),
            },
            repairs: Vec::new(),
        };
        let rate =
            pose::rate_of(self.rate_hz, "MediaPipe landmark").map_err(|e| e.in_file(path))?;
        let (motion, _) = pose::motion_of_people(
            crate::read::stem(path),
            &people,
            names,
            PersonRule::HighestMeanConfidence,
            self.min_confidence,
            rate,
            notes,
        )
        .map_err(|e| e.in_file(path))?;
        Ok(motion.with_source(path, "mediapipe"))
    }
}

motionlab_core::register_plugin!(Loader, MediaPipeParams, "mediapipe");

/// One landmark as written.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Landmark {
    pub x: f64,
    pub y: f64,
    /// Relative depth (same scale as x), as written; NaN when absent.
    pub z: f64,
    /// `visibility`, else `presence`, else 1.
    pub confidence: f64,
}

/// A token of the text format with its line.
#[derive(Debug, PartialEq)]
enum Token<'a> {
    Word(&'a str),
    Colon,
    Open,
    Close,
}

fn tokens<'a>(text: &'a str, origin: &Path) -> Result<Vec<(Token<'a>, usize)>> {
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line_no = i + 1;
        let line = line.split('#').next().unwrap_or("");
        let mut rest = line;
        while let Some(c) = rest.chars().next() {
            match c {
                c if c.is_whitespace() || c == ',' || c == ';' => rest = &rest[c.len_utf8()..],
                ':' => {
                    out.push((Token::Colon, line_no));
                    rest = &rest[1..];
                }
                '{' | '<' => {
                    out.push((Token::Open, line_no));
                    rest = &rest[1..];
                }
                '}' | '>' => {
                    out.push((Token::Close, line_no));
                    rest = &rest[1..];
                }
                '"' | '\'' => {
                    return Err(Error::at_line(
                        ErrorKind::Syntax,
                        origin,
                        line_no,
                        "a string value; MediaPipe landmarks hold only numbers".to_string(),
                    ));
                }
                _ => {
                    let end = rest
                        .find(|c: char| c.is_whitespace() || ":{}<>,;#".contains(c))
                        .unwrap_or(rest.len());
                    out.push((Token::Word(&rest[..end]), line_no));
                    rest = &rest[end..];
                }
            }
        }
    }
    Ok(out)
}

/// Parses protobuf text holding `landmarks { landmark { … } … }` blocks (or bare `landmark`
/// blocks: one frame); returns each frame's landmarks. `origin` names it in errors.
pub fn parse_pbtxt(text: &str, origin: &Path) -> Result<Vec<Vec<Landmark>>> {
    let toks = tokens(text, origin)?;
    let last_line = text.lines().count().max(1);
    let mut frames: Vec<Vec<Landmark>> = Vec::new();
    let mut bare: Vec<Landmark> = Vec::new();
    let mut i = 0;
    // Skips a field's value or a whole block (unknown fields such as `world_landmarks`).
    fn skip(toks: &[(Token<'_>, usize)], mut i: usize) -> Option<usize> {
        let mut depth = 0usize;
        loop {
            match toks.get(i)?.0 {
                Token::Open => depth += 1,
                Token::Close => {
                    depth = depth.checked_sub(1)?;
                    if depth == 0 {
                        return Some(i + 1);
                    }
                }
                Token::Word(_) if depth == 0 => return Some(i + 1),
                _ => {}
            }
            i += 1;
        }
    }
    let unclosed = |line: usize| {
        Error::at_line(
            ErrorKind::Truncated,
            origin,
            last_line,
            format!("the block opened on line {line} is not closed (`}}` expected)"),
        )
    };
    // Reads one `landmark { … }` body starting after its `{`; returns it and the next index.
    let landmark = |mut i: usize, open_line: usize| -> Result<(Landmark, usize)> {
        let (mut x, mut y, mut z, mut vis, mut pres) = (None, None, f64::NAN, None, None);
        loop {
            match toks.get(i) {
                None => return Err(unclosed(open_line)),
                Some((Token::Close, _)) => break,
                Some((Token::Word(key), line)) => {
                    let line = *line;
                    if !matches!(toks.get(i + 1), Some((Token::Colon, _))) {
                        return Err(Error::at_line(
                            ErrorKind::Syntax,
                            origin,
                            line,
                            format!("field {key:?} has no `: value`"),
                        ));
                    }
                    let Some((Token::Word(v), _)) = toks.get(i + 2) else {
                        return Err(Error::at_line(
                            ErrorKind::Syntax,
                            origin,
                            line,
                            format!("field {key:?} has no value"),
                        ));
                    };
                    let v: f64 = fast_float2::parse(v)
                        .ok()
                        .filter(|v: &f64| v.is_finite())
                        .ok_or_else(|| {
                            Error::new(ErrorKind::Syntax, format!("{v:?} is not a number"))
                                .with_location(
                                    motionlab_core::Location::file(origin).line(line).field(*key),
                                )
                        })?;
                    match *key {
                        "x" => x = Some(v),
                        "y" => y = Some(v),
                        "z" => z = v,
                        "visibility" => vis = Some(v),
                        "presence" => pres = Some(v),
                        _ => {}
                    }
                    i += 3;
                }
                Some((_, line)) => {
                    return Err(Error::at_line(
                        ErrorKind::Syntax,
                        origin,
                        *line,
                        "expected a field name".to_string(),
                    ));
                }
            }
        }
        let confidence = vis.or(pres).unwrap_or(1.0);
        let lm = match (x, y) {
            (Some(x), Some(y)) => Landmark { x, y, z, confidence },
            _ => Landmark { x: f64::NAN, y: f64::NAN, z, confidence: 0.0 },
        };
        Ok((lm, i + 1))
    };
    while i < toks.len() {
        match &toks[i] {
            (Token::Word("landmarks"), line) => {
                let line = *line;
                let mut j = i + 1;
                if matches!(toks.get(j), Some((Token::Colon, _))) {
                    j += 1;
                }
                if !matches!(toks.get(j), Some((Token::Open, _))) {
                    return Err(Error::at_line(
                        ErrorKind::Syntax,
                        origin,
                        line,
                        "`landmarks` without `{`".to_string(),
                    ));
                }
                j += 1;
                let mut frame = Vec::new();
                loop {
                    match toks.get(j) {
                        None => return Err(unclosed(line)),
                        Some((Token::Close, _)) => {
                            j += 1;
                            break;
                        }
                        Some((Token::Word("landmark"), l)) => {
                            let l = *l;
                            let mut k = j + 1;
                            if matches!(toks.get(k), Some((Token::Colon, _))) {
                                k += 1;
                            }
                            if !matches!(toks.get(k), Some((Token::Open, _))) {
                                return Err(Error::at_line(
                                    ErrorKind::Syntax,
                                    origin,
                                    l,
                                    "`landmark` without `{`".to_string(),
                                ));
                            }
                            let (lm, next) = landmark(k + 1, l)?;
                            frame.push(lm);
                            j = next;
                        }
                        Some((Token::Word(_), l)) => {
                            let l = *l;
                            j = skip(&toks, j + 1).ok_or_else(|| unclosed(l))?;
                        }
                        Some((_, l)) => {
                            return Err(Error::at_line(
                                ErrorKind::Syntax,
                                origin,
                                *l,
                                "expected `landmark { … }`".to_string(),
                            ));
                        }
                    }
                }
                frames.push(frame);
                i = j;
            }
            (Token::Word("landmark"), line) => {
                let line = *line;
                let mut k = i + 1;
                if matches!(toks.get(k), Some((Token::Colon, _))) {
                    k += 1;
                }
                if !matches!(toks.get(k), Some((Token::Open, _))) {
                    return Err(Error::at_line(
                        ErrorKind::Syntax,
                        origin,
                        line,
                        "`landmark` without `{`".to_string(),
                    ));
                }
                let (lm, next) = landmark(k + 1, line)?;
                bare.push(lm);
                i = next;
            }
            (Token::Word(_), line) => {
                let line = *line;
                i = skip(&toks, i + 1).ok_or_else(|| unclosed(line))?;
            }
            (_, line) => {
                return Err(Error::at_line(
                    ErrorKind::Syntax,
                    origin,
                    *line,
                    "unbalanced `{`/`}`".to_string(),
                ));
            }
        }
    }
    if !bare.is_empty() {
        frames.push(bare);
    }
    frames.retain(|f| !f.is_empty());
    if frames.is_empty() {
        return Err(Error::at_line(
            ErrorKind::EmptySequence,
            origin,
            1,
            "holds no `landmark { … }`; expected MediaPipe pose landmarks in protobuf text"
                .to_string(),
        ));
    }
    Ok(frames)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_frames_of_two_landmarks_and_a_skipped_block() {
        let text = "# proto-message: LandmarksDetectionResult\nlandmarks {\n  landmark { x: 0.5 y: 0.25 z: -0.1 visibility: 0.9 presence: 0.8 }\n  landmark { x: 1e-1 y: 0.2 presence: 0.7 }\n}\nworld_landmarks { landmark { x: 3 y: 4 } }\nlandmarks { landmark { x: 0.4 y: 0.3 visibility: 0.0 } landmark { x: 0.1 y: 0.1 } }\n";
        let f = parse_pbtxt(text, Path::new("p.pbtxt")).unwrap();
        assert_eq!(f.len(), 2);
        assert_eq!(f[0][0], Landmark { x: 0.5, y: 0.25, z: -0.1, confidence: 0.9 });
        assert_eq!(f[0][1].confidence, 0.7, "presence when visibility is absent");
        assert_eq!(f[1][1].confidence, 1.0, "neither written");
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("p.pbtxt");
        std::fs::write(&p, text).unwrap();
        let params: toml::Value =
            toml::from_str("rate_hz = 30.0\nimage_width_px = 640.0\nimage_height_px = 480.0")
                .unwrap();
        let m =
            motionlab_core::registry::build_loader("mediapipe", &params).unwrap().load(&p).unwrap();
        assert_eq!(m.position(0, 0), [320.0, 120.0, 0.0]);
        assert!(m.is_missing(1, 0), "visibility 0");
        assert_eq!(m.point_names(), ["kp0", "kp1"]);
    }

    #[test]
    fn malformed_text_names_the_line() {
        let p = Path::new("p.pbtxt");
        let e = parse_pbtxt("landmarks {\n landmark {\n x: 0.5\n", p).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::Truncated);
        let e = parse_pbtxt("landmarks {\n landmark {\n x: abc\n } }", p).unwrap_err();
        assert_eq!((e.location().line, e.location().field.as_deref()), (Some(3), Some("x")));
        let e = parse_pbtxt("landmarks {\n landmark {\n x \n } }", p).unwrap_err();
        assert_eq!(e.location().line, Some(3));
        assert!(parse_pbtxt("# nothing\n", p).is_err());
        assert!(parse_pbtxt("}", p).is_err());
    }
}
