//! The OpenPose loader plugin `openpose`: a folder of per-frame JSON files, as OpenPose's
//! `--write_json` (and Pose2Sim, which reads them) writes them, read into one 2-D motion.

use std::path::{Path, PathBuf};

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use serde_json::Value;

use motionlab_core::registry::ParamGuard;
use motionlab_core::{Dimensionality, Error, ErrorKind, LoadNotes, Loader, Motion, Result};

use crate::pose::{self, BODY_25, BODY_25B, COCO_18, Person, PersonRule};

/// Reads a folder of OpenPose JSON files (one per video frame) into a 2-D motion: keypoint
/// positions in pixels (x right, y down) with OpenPose's confidence per keypoint.
///
/// Frames are the folder's `.json` files in name order (OpenPose numbers them with zero-padded
/// frame numbers: `<video>_000000000012_keypoints.json`, Pose2Sim's `cam01.0012.json`); other
/// files are ignored. Each file is `{"version": …, "people": [{"pose_keypoints_2d": [x, y, c,
/// …]}, …]}`; hand, face and 3-D arrays are not read. The keypoint layout is `model`, or by
/// count: 18 keypoints are OpenPose's COCO model, 25 its default BODY_25 (BODY_25B, which
/// Pose2Sim uses, has 25 keypoints in another order: say `model = "body_25b"`); another count
/// names them `kp0`, `kp1`, ….
///
/// **People**: a frame may hold several; `person` chooses one per frame (`highest_mean_confidence`
/// or `nearest_previous`, see `motionlab describe openpose`). A person written as `{}` or with
/// an empty keypoint list is not a person. **Missing samples**: a keypoint written `0,0,0`
/// (undetected), with confidence 0, or below `min_confidence` is missing, and so is every
/// keypoint of a frame without people; the load notes count each kind.
///
/// The files carry no frame rate: `rate_hz` is required (the video's frames per second).
/// Errors name the file and the field: a file that is not JSON (with its line), no `people`
/// list, keypoints that are not numbers or not a multiple of 3, a person with a keypoint count
/// other than the folder's or the model's, an empty folder.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct OpenPoseParams {
    /// Frames per second of the video the keypoints were estimated from (the JSON files do
    /// not store it).
    #[serde(default)]
    #[schemars(extend("x-default" = "none: loading a file asks for it"))]
    pub rate_hz: Option<f64>,
    /// The keypoint layout: `"auto"` (by count: 18 = COCO, 25 = BODY_25), `"body_25"`,
    /// `"body_25b"`, `"coco_18"`.
    #[serde(default)]
    pub model: OpenPoseModel,
    /// Which person of a frame with several becomes the motion's.
    #[serde(default)]
    pub person: PersonRule,
    /// Keypoints with a confidence below this (0–1) are missing samples. The default is
    /// OpenPose's own `--render_threshold`, below which it does not draw a keypoint.
    #[serde(default = "default_min_confidence")]
    pub min_confidence: f64,
}

fn default_min_confidence() -> f64 {
    0.05
}

/// OpenPose's body models.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum OpenPoseModel {
    /// By keypoint count (18: COCO, 25: BODY_25).
    #[default]
    Auto,
    #[serde(rename = "body_25")]
    Body25,
    #[serde(rename = "body_25b")]
    Body25b,
    #[serde(rename = "coco_18")]
    Coco18,
}

impl OpenPoseModel {
    fn names(self, count: usize) -> (Vec<String>, String) {
        let own = |n: &[&str]| n.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        match (self, count) {
            (OpenPoseModel::Body25, _) => (own(&BODY_25), "model = \"body_25\"".into()),
            (OpenPoseModel::Body25b, _) => (own(&BODY_25B), "model = \"body_25b\"".into()),
            (OpenPoseModel::Coco18, _) => (own(&COCO_18), "model = \"coco_18\"".into()),
            (OpenPoseModel::Auto, 25) => (
                own(&BODY_25),
                "25 keypoints: BODY_25, OpenPose's default (give model = \"body_25b\" for BODY_25B)"
                    .into(),
            ),
            (OpenPoseModel::Auto, 18) => (own(&COCO_18), "18 keypoints: OpenPose's COCO model".into()),
            (OpenPoseModel::Auto, n) => (
                (0..n).map(|k| format!("kp{k}")).collect(),
                format!("{n} keypoints, no known OpenPose model: named kp0…kp{}", n.saturating_sub(1)),
            ),
        }
    }
}

/// The validated loader.
#[derive(Clone, Debug)]
pub struct OpenPoseLoader {
    rate_hz: Option<f64>,
    model: OpenPoseModel,
    person: PersonRule,
    min_confidence: f64,
}

impl ParamGuard for OpenPoseParams {
    type Checked = OpenPoseLoader;
    fn check(self) -> Result<OpenPoseLoader> {
        if let Some(hz) = self.rate_hz {
            motionlab_core::FrameRate::new(hz).map_err(|e| e.with_field("rate_hz"))?;
        }
        Ok(OpenPoseLoader {
            rate_hz: self.rate_hz,
            model: self.model,
            person: self.person,
            min_confidence: pose::check_min_confidence(self.min_confidence)?,
        })
    }
}

impl Loader for OpenPoseLoader {
    fn extensions(&self) -> &'static [&'static str] {
        &[]
    }
    fn dimensionality(&self) -> Dimensionality {
        Dimensionality::Two
    }
    fn reads_folders(&self) -> bool {
        true
    }
    fn load(&self, path: &Path) -> Result<Motion> {
        let files = frame_files(path)?;
        let mut frames = Vec::with_capacity(files.len());
        let mut count: Option<(usize, PathBuf)> = None;
        let mut empty_people = 0;
        for file in &files {
            let text = crate::read::read_text(file)?;
            let frame = parse_frame(&text, file)?;
            empty_people += frame.empty_people;
            for (i, p) in frame.people.iter().enumerate() {
                match &count {
                    None => count = Some((p.len(), file.clone())),
                    Some((n, first)) if *n != p.len() => {
                        return Err(Error::new(
                            ErrorKind::WrongValueCount,
                            format!(
                                "{} keypoints; expected {n}, as in {} (one model per folder)",
                                p.len(),
                                first.display()
                            ),
                        )
                        .with_location(
                            motionlab_core::Location::file(file)
                                .line(frame.lines[i])
                                .field(format!("people[{i}].pose_keypoints_2d")),
                        ));
                    }
                    Some(_) => {}
                }
            }
            frames.push(frame.people);
        }
        let n = count.as_ref().map_or(0, |c| c.0);
        if n == 0 {
            return Err(Error::new(
                ErrorKind::EmptySequence,
                format!("no person in any of the {} frames: no keypoint to read", files.len()),
            )
            .with_location(motionlab_core::Location::file(path)));
        }
        let (names, how) = self.model.names(n);
        if names.len() != n {
            let (_, first) = count.unwrap_or_default();
            return Err(Error::new(
                ErrorKind::WrongValueCount,
                format!("{n} keypoints per person; {how} has {}", names.len()),
            )
            .with_location(motionlab_core::Location::file(first).field("pose_keypoints_2d")));
        }
        let rate = pose::rate_of(self.rate_hz, "OpenPose JSON").map_err(|e| e.in_file(path))?;
        let mut notes = LoadNotes {
            length_unit: None,
            length_unit_from: format!("pixels (2-D image coordinates); layout: {how}"),
            repairs: Vec::new(),
        };
        if empty_people > 0 {
            notes.repairs.push(format!(
                "{empty_people} people entries without keypoints ({{}} or an empty list): not people"
            ));
        }
        let (motion, _) = pose::motion_of_people(
            crate::read::stem(path),
            &frames,
            names,
            self.person,
            self.min_confidence,
            rate,
            notes,
        )
        .map_err(|e| e.in_file(path))?;
        Ok(motion.with_source(path, "openpose"))
    }
}

motionlab_core::register_plugin!(Loader, OpenPoseParams, "openpose");

/// The `.json` files of a frame folder, in name order.
pub fn frame_files(dir: &Path) -> Result<Vec<PathBuf>> {
    if !dir.is_dir() {
        return Err(Error::new(
            ErrorKind::Io,
            "is not a folder; the openpose loader reads a folder of per-frame JSON files",
        )
        .with_location(motionlab_core::Location::file(dir)));
    }
    let entries = std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))?;
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file() && p.extension().is_some_and(|e| e.eq_ignore_ascii_case("json")))
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(Error::new(ErrorKind::EmptySequence, "holds no .json file (one per frame)")
            .with_location(motionlab_core::Location::file(dir)));
    }
    Ok(files)
}

/// One frame file as read.
#[derive(Clone, Debug, Default)]
pub struct OpenPoseFrame {
    /// Each person's `(x, y, confidence)` keypoints, in file order.
    pub people: Vec<Person>,
    /// The line each person's keypoints start on (for errors).
    pub lines: Vec<usize>,
    /// `{}` entries and entries with an empty keypoint list, skipped.
    pub empty_people: usize,
}

/// The 1-based line of the `n`-th (0-based) occurrence of `needle`, or 1.
pub(crate) fn line_of_nth(text: &str, needle: &str, n: usize) -> usize {
    text.match_indices(needle)
        .nth(n)
        .map(|(i, _)| text[..i].bytes().filter(|b| *b == b'\n').count() + 1)
        .unwrap_or(1)
}

/// A JSON text as a value; a syntax error names the line.
pub(crate) fn parse_json(text: &str, origin: &Path) -> Result<Value> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    serde_json::from_str(text).map_err(|e| {
        let kind = if e.is_eof() { ErrorKind::Truncated } else { ErrorKind::Syntax };
        Error::at_line(kind, origin, e.line().max(1), format!("not valid JSON: {e}"))
    })
}

/// A flat `[x, y, c, …]` list as keypoints; errors name `field` and say what was expected.
pub(crate) fn triples(
    value: &Value,
    origin: &Path,
    line: usize,
    field: &str,
) -> Result<Vec<[f64; 3]>> {
    let at = |kind, msg: String| {
        Error::new(kind, msg)
            .with_location(motionlab_core::Location::file(origin).line(line).field(field))
    };
    let Some(list) = value.as_array() else {
        return Err(at(
            ErrorKind::WrongType,
            format!("is {}; expected a list of numbers x, y, confidence, …", kind_of(value)),
        ));
    };
    if list.len() % 3 != 0 {
        return Err(at(
            ErrorKind::WrongValueCount,
            format!(
                "holds {} numbers, not a multiple of 3 (x, y, confidence per keypoint)",
                list.len()
            ),
        ));
    }
    let mut out = Vec::with_capacity(list.len() / 3);
    for (k, c) in list.chunks_exact(3).enumerate() {
        let mut v = [0.0; 3];
        for (j, x) in c.iter().enumerate() {
            v[j] = x.as_f64().ok_or_else(|| {
                at(
                    ErrorKind::WrongType,
                    format!(
                        "value {} (keypoint {k}, {}) is {}; expected a number",
                        3 * k + j,
                        ["x", "y", "confidence"][j],
                        kind_of(x)
                    ),
                )
            })?;
        }
        out.push(v);
    }
    Ok(out)
}

pub(crate) fn kind_of(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "a list",
        Value::Object(_) => "an object",
    }
}

/// Parses one OpenPose frame file; `origin` names it in errors.
pub fn parse_frame(text: &str, origin: &Path) -> Result<OpenPoseFrame> {
    let value = parse_json(text, origin)?;
    let Some(obj) = value.as_object() else {
        return Err(Error::at_line(
            ErrorKind::WrongType,
            origin,
            1,
            format!(
                "is {}; expected an OpenPose frame object {{\"version\": …, \"people\": […]}}",
                kind_of(&value)
            ),
        ));
    };
    let Some(people) = obj.get("people") else {
        return Err(Error::new(
            ErrorKind::MissingKey,
            "has no `people` list; expected an OpenPose frame {\"version\": …, \"people\": […]}",
        )
        .with_location(motionlab_core::Location::file(origin).line(1).field("people")));
    };
    let Some(people) = people.as_array() else {
        return Err(Error::new(
            ErrorKind::WrongType,
            format!("is {}; expected a list of people", kind_of(people)),
        )
        .with_location(
            motionlab_core::Location::file(origin)
                .line(line_of_nth(text, "\"people\"", 0))
                .field("people"),
        ));
    };
    let mut frame = OpenPoseFrame::default();
    let mut seen = 0;
    for (i, p) in people.iter().enumerate() {
        let field = format!("people[{i}].pose_keypoints_2d");
        let Some(person) = p.as_object() else {
            return Err(Error::new(
                ErrorKind::WrongType,
                format!("is {}; expected a person object", kind_of(p)),
            )
            .with_location(motionlab_core::Location::file(origin).field(format!("people[{i}]"))));
        };
        let Some(kp) = person.get("pose_keypoints_2d") else {
            if person.is_empty() {
                frame.empty_people += 1;
                continue;
            }
            return Err(Error::new(
                ErrorKind::MissingKey,
                "is absent; expected the person's keypoints (x, y, confidence, …)",
            )
            .with_location(motionlab_core::Location::file(origin).field(field)));
        };
        let line = line_of_nth(text, "\"pose_keypoints_2d\"", seen);
        seen += 1;
        let keypoints = triples(kp, origin, line, &field)?;
        if keypoints.is_empty() {
            frame.empty_people += 1;
            continue;
        }
        frame.people.push(keypoints);
        frame.lines.push(line);
    }
    Ok(frame)
}

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_core::registry::build_loader;

    fn write(dir: &Path, name: &str, text: &str) {
        std::fs::write(dir.join(name), text).unwrap();
    }

    fn loader(params: &str) -> Box<dyn Loader> {
        build_loader("openpose", &toml::from_str::<toml::Value>(params).unwrap()).unwrap()
    }

    #[test]
    fn two_frames_two_people_one_chosen_undetected_missing() {
        let dir = tempfile::tempdir().unwrap();
        let kp = |x: f64, c: f64| {
            (0..18)
                .flat_map(|k| if k == 3 { [0.0, 0.0, 0.0] } else { [x + k as f64, 2.0, c] })
                .map(|v| v.to_string())
                .collect::<Vec<_>>()
                .join(",")
        };
        write(
            dir.path(),
            "v_000000000000_keypoints.json",
            &format!(
                r#"{{"version":1.3,"people":[{{"pose_keypoints_2d":[{}]}},{{"pose_keypoints_2d":[{}]}}]}}"#,
                kp(10.0, 0.2),
                kp(100.0, 0.9)
            ),
        );
        write(
            dir.path(),
            "v_000000000001_keypoints.json",
            &format!(
                r#"{{"version":1.3,"people":[{{"pose_keypoints_2d":[{}]}},{{}}]}}"#,
                kp(11.0, 0.8)
            ),
        );
        write(dir.path(), "notes.txt", "ignored");
        let m = loader("rate_hz = 30.0").load(dir.path()).unwrap();
        assert_eq!((m.n_frames(), m.n_points(), m.frame_rate().hz()), (2, 18, 30.0));
        assert_eq!(m.point_names()[1], "Neck", "18 keypoints: OpenPose's COCO layout");
        assert_eq!(m.position(0, 0), [100.0, 2.0, 0.0], "the confident person");
        assert_eq!(m.position(1, 0), [11.0, 2.0, 0.0]);
        assert!(m.is_missing(0, 3) && m.is_missing(1, 3), "0,0,0 is undetected");
        assert_eq!(m.missing_count(), 2);
        assert_eq!(m.dimensionality(), Dimensionality::Two);
        assert_eq!(m.confidence().unwrap()[0], 0.9);
        let notes = m.load_notes.repairs.join("\n");
        assert!(notes.contains("1 of 2 frames hold several people"), "{notes}");
        assert!(notes.contains("1 people entries without keypoints"), "{notes}");
        // A threshold above 0.8 makes the second frame missing.
        let strict = loader("rate_hz = 30.0\nmin_confidence = 0.85").load(dir.path()).unwrap();
        assert!((0..18).all(|k| strict.is_missing(1, k)));
        // The model must fit the count.
        let e = loader("rate_hz = 30.0\nmodel = \"body_25\"").load(dir.path()).unwrap_err();
        assert!(
            e.to_string().contains("18 keypoints per person; model = \"body_25\" has 25"),
            "{e}"
        );
        // No rate: an error naming the key.
        let e = loader("").load(dir.path()).unwrap_err();
        assert_eq!(e.location().field.as_deref(), Some("rate_hz"));
    }

    #[test]
    fn malformed_frames_name_the_file_and_field() {
        let p = Path::new("f.json");
        let e = parse_frame(r#"{"version":1.3}"#, p).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::MissingKey);
        assert!(e.to_string().contains("people"), "{e}");
        let e = parse_frame("{\"people\":[\n{\"pose_keypoints_2d\":[1,2,3,4]}]}", p).unwrap_err();
        assert_eq!(e.location().line, Some(2));
        assert_eq!(e.location().field.as_deref(), Some("people[0].pose_keypoints_2d"));
        assert!(e.to_string().contains("not a multiple of 3"), "{e}");
        let e = parse_frame(r#"{"people":[{"pose_keypoints_2d":[1,"a",3]}]}"#, p).unwrap_err();
        assert!(e.to_string().contains("keypoint 0, y"), "{e}");
        let e = parse_frame("{\"people\":[\n", p).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::Truncated);
        let e = parse_frame("[1]", p).unwrap_err();
        assert!(e.to_string().contains("expected an OpenPose frame object"), "{e}");
    }
}
