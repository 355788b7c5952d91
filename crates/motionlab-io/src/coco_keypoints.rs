//! The COCO keypoint loader plugin `coco_keypoints`: a COCO person-keypoint annotation file
//! (`{images, annotations, categories}`) or a results file (a list of detections), read into
//! one 2-D motion, one frame per image.

use std::path::Path;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use serde_json::Value;

use motionlab_core::registry::ParamGuard;
use motionlab_core::{
    Dimensionality, Error, ErrorKind, LoadNotes, Loader, Location, Motion, Result,
};

use crate::openpose::{kind_of, line_of_nth, parse_json, triples};
use crate::pose::{self, COCO_17, Person, PersonRule};

/// Reads COCO keypoint JSON (`.json`) into a 2-D motion: one frame per image, keypoint
/// positions in pixels, the third value of each keypoint as its confidence.
///
/// Two layouts, told apart by the top level: an **annotation file** (an object with `images`,
/// `annotations` and `categories`; frames are the `images` in file order, keypoint names the
/// `person` category's `keypoints`) and a **results file** (a list of detections `{image_id,
/// keypoints, score}`; frames are the image ids in order of first appearance, keypoints the
/// COCO 17 when there are 17, else `kp0`, `kp1`, …). Keypoints are flat `[x, y, v, …]`; in
/// annotations v is 0 (not labelled), 1 (labelled, not visible) or 2 (visible), in results a
/// detector's confidence.
///
/// **People**: an image may hold several; `person` chooses one per image (rank by the mean of
/// the third values). **Missing samples**: a keypoint whose third value is 0 (unlabelled,
/// whatever filler coordinates it carries) or below `min_confidence`, and every keypoint of
/// an image without annotations. Only `category_id` 1 (person) is read from a results file.
///
/// The files carry no frame rate: `rate_hz` is required (for a video's frames, its frames per
/// second). Errors name the file, the line and the field (`annotations[3].keypoints`): not
/// JSON, keypoints not a multiple of 3 or not numbers, an annotation of an image the file does
/// not list, counts that differ between annotations.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CocoKeypointsParams {
    /// Frames (images) per second (COCO files do not store one).
    #[serde(default)]
    #[schemars(extend("x-default" = "none: loading a file asks for it"))]
    pub rate_hz: Option<f64>,
    /// Which person of an image with several becomes the motion's.
    #[serde(default)]
    pub person: PersonRule,
    /// Keypoints whose third value is below this are missing samples (v = 0 always is); 0 keeps
    /// every labelled keypoint, visible or not.
    #[serde(default)]
    pub min_confidence: f64,
}

/// The validated loader.
#[derive(Clone, Debug)]
pub struct CocoKeypointsLoader {
    rate_hz: Option<f64>,
    person: PersonRule,
    min_confidence: f64,
}

impl ParamGuard for CocoKeypointsParams {
    type Checked = CocoKeypointsLoader;
    fn check(self) -> Result<CocoKeypointsLoader> {
        if let Some(hz) = self.rate_hz {
            motionlab_core::FrameRate::new(hz).map_err(|e| e.with_field("rate_hz"))?;
        }
        Ok(CocoKeypointsLoader {
            rate_hz: self.rate_hz,
            person: self.person,
            min_confidence: pose::check_min_confidence(self.min_confidence)?,
        })
    }
}

impl Loader for CocoKeypointsLoader {
    fn extensions(&self) -> &'static [&'static str] {
        &["json"]
    }
    fn dimensionality(&self) -> Dimensionality {
        Dimensionality::Two
    }
    fn load(&self, path: &Path) -> Result<Motion> {
        let text = crate::read::read_text(path)?;
        let coco = parse_coco(&text, path)?;
        let rate = pose::rate_of(self.rate_hz, "COCO keypoint").map_err(|e| e.in_file(path))?;
        let notes = LoadNotes {
            length_unit: None,
            length_unit_from: format!(
                "pixels (2-D image coordinates); COCO {} file",
                if coco.results { "results" } else { "annotation" }
            ),
            repairs: Vec::new(),
        };
        let (motion, _) = pose::motion_of_people(
            crate::read::stem(path),
            &coco.frames,
            coco.names,
            self.person,
            self.min_confidence,
            rate,
            notes,
        )
        .map_err(|e| e.in_file(path))?;
        Ok(motion.with_source(path, "coco_keypoints"))
    }
}

motionlab_core::register_plugin!(Loader, CocoKeypointsParams, "coco_keypoints");

/// A COCO keypoint file as read.
#[derive(Clone, Debug)]
pub struct CocoFile {
    /// A results file (a list of detections), not an annotation file.
    pub results: bool,
    /// Image ids, one per frame.
    pub image_ids: Vec<i64>,
    /// Each image's people (annotations or detections), in file order.
    pub frames: Vec<Vec<Person>>,
    /// Keypoint names.
    pub names: Vec<String>,
}

fn at(origin: &Path, line: usize, field: impl Into<String>, kind: ErrorKind, msg: String) -> Error {
    Error::new(kind, msg).with_location(Location::file(origin).line(line).field(field))
}

/// Parses a COCO annotation or results text; `origin` names it in errors.
pub fn parse_coco(text: &str, origin: &Path) -> Result<CocoFile> {
    let value = parse_json(text, origin)?;
    match &value {
        Value::Array(list) => parse_results(list, text, origin),
        Value::Object(_) => parse_annotations(&value, text, origin),
        other => Err(at(
            origin,
            1,
            "",
            ErrorKind::WrongType,
            format!("is {}; expected a COCO annotation object or a results list", kind_of(other)),
        )),
    }
}

fn image_id(v: Option<&Value>, origin: &Path, line: usize, field: String) -> Result<i64> {
    match v {
        Some(v) => v.as_i64().ok_or_else(|| {
            at(
                origin,
                line,
                field,
                ErrorKind::WrongType,
                format!("is {}; expected an integer image id", kind_of(v)),
            )
        }),
        None => Err(at(
            origin,
            line,
            field,
            ErrorKind::MissingKey,
            "is absent; expected the image id".into(),
        )),
    }
}

fn same_count(
    count: &mut Option<usize>,
    n: usize,
    origin: &Path,
    line: usize,
    field: &str,
) -> Result<()> {
    match *count {
        None => *count = Some(n),
        Some(c) if c != n => {
            return Err(at(
                origin,
                line,
                field,
                ErrorKind::WrongValueCount,
                format!("{n} keypoints; expected {c}, as the first annotation has"),
            ));
        }
        Some(_) => {}
    }
    Ok(())
}

fn parse_results(list: &[Value], text: &str, origin: &Path) -> Result<CocoFile> {
    let mut image_ids: Vec<i64> = Vec::new();
    let mut frames: Vec<Vec<Person>> = Vec::new();
    let mut count = None;
    for (i, d) in list.iter().enumerate() {
        let line = line_of_nth(text, "\"keypoints\"", i);
        let Some(obj) = d.as_object() else {
            return Err(at(
                origin,
                line,
                format!("[{i}]"),
                ErrorKind::WrongType,
                format!("is {}; expected a detection object", kind_of(d)),
            ));
        };
        if obj.get("category_id").and_then(Value::as_i64).is_some_and(|c| c != 1) {
            continue;
        }
        let id = image_id(obj.get("image_id"), origin, line, format!("[{i}].image_id"))?;
        let field = format!("[{i}].keypoints");
        let kp = obj.get("keypoints").ok_or_else(|| {
            at(
                origin,
                line,
                field.clone(),
                ErrorKind::MissingKey,
                "is absent; expected flat [x, y, v, …] keypoints".into(),
            )
        })?;
        let kp = triples(kp, origin, line, &field)?;
        same_count(&mut count, kp.len(), origin, line, &field)?;
        let k = match image_ids.iter().position(|&x| x == id) {
            Some(k) => k,
            None => {
                image_ids.push(id);
                frames.push(Vec::new());
                frames.len() - 1
            }
        };
        frames[k].push(kp);
    }
    let n = count.unwrap_or(0);
    if frames.is_empty() {
        return Err(at(
            origin,
            1,
            "",
            ErrorKind::EmptySequence,
            "holds no person detection".into(),
        ));
    }
    let names = if n == COCO_17.len() {
        COCO_17.iter().map(|s| s.to_string()).collect()
    } else {
        (0..n).map(|k| format!("kp{k}")).collect()
    };
    Ok(CocoFile { results: true, image_ids, frames, names })
}

/// The top-level list `key` of an annotation file.
fn top_list<'a>(value: &'a Value, key: &str, text: &str, origin: &Path) -> Result<&'a Vec<Value>> {
    match value.get(key) {
        Some(Value::Array(a)) => Ok(a),
        Some(other) => Err(at(
            origin,
            line_of_nth(text, &format!("\"{key}\""), 0),
            key,
            ErrorKind::WrongType,
            format!("is {}; expected a list", kind_of(other)),
        )),
        None => Err(at(
            origin,
            1,
            key,
            ErrorKind::MissingKey,
            "is absent; a COCO annotation file has `images`, `annotations` and `categories`".into(),
        )),
    }
}

fn parse_annotations(value: &Value, text: &str, origin: &Path) -> Result<CocoFile> {
    let images = top_list(value, "images", text, origin)?;
    let annotations = top_list(value, "annotations", text, origin)?;
    let categories = top_list(value, "categories", text, origin)?;
    let mut image_ids = Vec::with_capacity(images.len());
    for (i, im) in images.iter().enumerate() {
        image_ids.push(image_id(
            im.get("id"),
            origin,
            line_of_nth(text, "\"file_name\"", i),
            format!("images[{i}].id"),
        )?);
    }
    let person = categories
        .iter()
        .find(|c| c.get("name").and_then(Value::as_str) == Some("person"))
        .or_else(|| categories.iter().find(|c| c.get("keypoints").is_some()));
    let person_id = person.and_then(|c| c.get("id")).and_then(Value::as_i64);
    let mut names: Option<Vec<String>> = person
        .and_then(|c| c.get("keypoints"))
        .and_then(Value::as_array)
        .map(|k| k.iter().map(|n| n.as_str().unwrap_or_default().to_string()).collect());
    let mut frames: Vec<Vec<Person>> = vec![Vec::new(); image_ids.len()];
    let mut count = names.as_ref().map(Vec::len);
    let after = text.find("\"annotations\"").unwrap_or(0);
    for (i, a) in annotations.iter().enumerate() {
        let line = after_line(text, after, "\"keypoints\"", i);
        if let (Some(want), Some(c)) = (person_id, a.get("category_id").and_then(Value::as_i64))
            && c != want
        {
            continue;
        }
        let field = format!("annotations[{i}].keypoints");
        let Some(kp) = a.get("keypoints") else {
            return Err(at(
                origin,
                line,
                field,
                ErrorKind::MissingKey,
                "is absent; expected flat [x, y, v, …] keypoints".into(),
            ));
        };
        let kp = triples(kp, origin, line, &field)?;
        same_count(&mut count, kp.len(), origin, line, &field)?;
        let id = image_id(a.get("image_id"), origin, line, format!("annotations[{i}].image_id"))?;
        let Some(k) = image_ids.iter().position(|&x| x == id) else {
            return Err(at(
                origin,
                line,
                format!("annotations[{i}].image_id"),
                ErrorKind::UnknownName,
                format!("is {id}, an image `images` does not list"),
            ));
        };
        frames[k].push(kp);
    }
    if image_ids.is_empty() {
        return Err(at(origin, 1, "images", ErrorKind::EmptySequence, "lists no image".into()));
    }
    let n = count.unwrap_or(0);
    if names.is_none() {
        names = Some((0..n).map(|k| format!("kp{k}")).collect());
    }
    Ok(CocoFile { results: false, image_ids, frames, names: names.unwrap_or_default() })
}

/// The line of the `n`-th `needle` after byte `from`.
fn after_line(text: &str, from: usize, needle: &str, n: usize) -> usize {
    let before = text[..from].bytes().filter(|b| *b == b'\n').count();
    before + line_of_nth(&text[from..], needle, n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn annotations_one_frame_per_image_in_file_order_v0_missing() {
        let text = r#"{"images":[{"id":7,"file_name":"a.jpg"},{"id":3,"file_name":"b.jpg"},{"id":9,"file_name":"c.jpg"}],
"annotations":[
{"image_id":3,"category_id":1,"keypoints":[10,20,2,30,40,1]},
{"image_id":3,"category_id":1,"keypoints":[11,21,1,0,0,0]},
{"image_id":7,"category_id":1,"keypoints":[1,2,2,5,5,0]}],
"categories":[{"id":1,"name":"person","keypoints":["a","b"]}]}"#;
        let c = parse_coco(text, Path::new("t.json")).unwrap();
        assert!(!c.results);
        assert_eq!(c.image_ids, vec![7, 3, 9]);
        assert_eq!(c.frames.iter().map(Vec::len).collect::<Vec<_>>(), vec![1, 2, 0]);
        let (m, chosen) = pose::motion_of_people(
            "t".into(),
            &c.frames,
            c.names.clone(),
            PersonRule::HighestMeanConfidence,
            0.0,
            motionlab_core::FrameRate::new(1.0).unwrap(),
            LoadNotes::default(),
        )
        .unwrap();
        assert_eq!(chosen, vec![Some(0), Some(0), None]);
        assert_eq!(m.point_names(), ["a", "b"]);
        assert_eq!(m.position(0, 0), [1.0, 2.0, 0.0]);
        assert!(m.is_missing(0, 1), "v = 0 with filler coordinates is missing");
        assert_eq!(m.position(1, 1), [30.0, 40.0, 0.0], "v = 1 (labelled, not visible) is kept");
        assert!(m.is_missing(2, 0) && m.is_missing(2, 1), "an image without people");
    }

    #[test]
    fn malformed_files_name_the_line_and_field() {
        let p = Path::new("t.json");
        let bad = "{\"images\":[{\"id\":1}],\n\"annotations\":[\n{\"image_id\":1,\"keypoints\":[1,2]}],\"categories\":[]}";
        let e = parse_coco(bad, p).unwrap_err();
        assert_eq!(e.location().line, Some(3));
        assert_eq!(e.location().field.as_deref(), Some("annotations[0].keypoints"));
        let orphan = "{\"images\":[{\"id\":1}],\"annotations\":[{\"image_id\":2,\"keypoints\":[1,2,2]}],\"categories\":[]}";
        assert!(
            parse_coco(orphan, p)
                .unwrap_err()
                .to_string()
                .contains("an image `images` does not list")
        );
        let e = parse_coco("{\"images\":[]}", p).unwrap_err();
        assert_eq!(e.location().field.as_deref(), Some("annotations"));
        let e = parse_coco(
            "[{\"image_id\":1,\"keypoints\":[1,2,2]},{\"image_id\":1,\"keypoints\":[1,2,2,3,4,2]}]",
            p,
        )
        .unwrap_err();
        assert!(e.to_string().contains("2 keypoints; expected 1"), "{e}");
        assert!(parse_coco("3", p).is_err());
    }
}
