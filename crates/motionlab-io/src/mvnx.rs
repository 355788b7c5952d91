//! The Xsens MVNX loader plugin `mvnx`: an inertial suit's XML export (MVN Analyze / MVN
//! Animate, MVNX versions 3 and 4), written from Xsens's published schema (the MVN user
//! manual's "MVNX file format" section); no redistributable MVNX file exists, so the tests
//! write their own small files.
//!
//! Parsed with `roxmltree` (a read-only XML tree with line positions).

use std::path::Path;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::units::{Axis, FrameRate, LengthUnit, Seconds};
use motionlab_core::{
    Channels, Error, ErrorKind, Event, LoadNotes, Loader, Location, Motion, PointKind, Result,
};

/// Reads Xsens MVNX files (`.mvnx`): the segments' positions as points (metres in the file,
/// mm here), their orientations and the joint angles as channels, foot contacts as events.
///
/// Layout (MVNX 3/4): `<mvnx><subject frameRate="…">` holds `<segments>` (one `<segment
/// label="…">` each, in the order of the frame data), `<joints>` (one `<joint label="…">` each),
/// an optional `<footContactDefinition>` (`<contactDefinition index="…" label="LeftFoot_Heel"/>`)
/// and `<frames>`, whose `<frame type="normal">` elements are the recording (the calibration
/// frames `identity`, `tpose`, `tpose-isb` are skipped). Per frame, read: `<position>` (x y z per
/// segment, m), `<orientation>` (q0 q1 q2 q3 per segment, a unit quaternion), `<jointAngle>`
/// (x y z per joint, degrees: ZXY Euler angles as MVN defines them) and `<footContacts>` (one 0/1
/// per contact point); other elements (velocities, sensors, centre of mass) are not read.
///
/// The motion: points = the segments (Xsens's lab frame is Z-up); channels `<segment>_q0`…`_q3`
/// and `<joint>_x_deg`, `_y_deg`, `_z_deg`; events `Foot Strike` / `Foot Off` with context
/// `Left` / `Right` where a foot's first contact point touches down after none did, or its last
/// lifts off (contact labels starting `Left`/`Right`); the rate is `frameRate`.
///
/// **Missing samples**: MVN writes none (an inertial suit sees every segment); a value that is
/// not a number is an error. Errors name the file and line: not XML, no `<subject>` or
/// `frameRate`, a frame whose `<position>` or `<jointAngle>` holds the wrong number of values
/// (naming the element), no normal frame.
#[derive(Clone, Debug, Default, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MvnxParams {}

/// The validated loader.
#[derive(Clone, Debug)]
pub struct MvnxLoader;

impl ParamGuard for MvnxParams {
    type Checked = MvnxLoader;
    fn check(self) -> Result<MvnxLoader> {
        Ok(MvnxLoader)
    }
}

impl Loader for MvnxLoader {
    fn extensions(&self) -> &'static [&'static str] {
        &["mvnx"]
    }
    fn load(&self, path: &Path) -> Result<Motion> {
        let text = crate::read::read_text(path)?;
        parse_mvnx(&text, path)?.into_motion(path)
    }
}

motionlab_core::register_plugin!(Loader, MvnxParams, "mvnx");

/// An MVNX file as read: values in the file's units.
#[derive(Clone, Debug, Default)]
pub struct MvnxFile {
    pub frame_rate_hz: f64,
    pub segments: Vec<String>,
    pub joints: Vec<String>,
    pub contacts: Vec<String>,
    /// Per normal frame: segment positions (m).
    pub positions: Vec<Vec<[f64; 3]>>,
    /// Per normal frame: segment orientations (q0 q1 q2 q3).
    pub orientations: Vec<Vec<[f64; 4]>>,
    /// Per normal frame: joint angles (degrees), empty when the file has none.
    pub joint_angles: Vec<Vec<[f64; 3]>>,
    /// Per normal frame: foot contacts, empty when the file has none.
    pub foot_contacts: Vec<Vec<bool>>,
}

fn numbers(
    node: roxmltree::Node<'_, '_>,
    line: usize,
    origin: &Path,
    expected: usize,
    what: &str,
) -> Result<Vec<f64>> {
    let text = node.text().unwrap_or("");
    let values: Vec<f64> = text
        .split_whitespace()
        .enumerate()
        .map(|(i, v)| {
            fast_float2::parse::<f64, _>(v).ok().filter(|x: &f64| x.is_finite()).ok_or_else(|| {
                Error::new(
                    ErrorKind::Syntax,
                    format!("value {} is {v:?}; expected a number", i + 1),
                )
                .with_location(Location::file(origin).line(line).field(node.tag_name().name()))
            })
        })
        .collect::<Result<_>>()?;
    if values.len() != expected {
        return Err(Error::new(
            ErrorKind::WrongValueCount,
            format!("holds {} values; expected {expected} ({what})", values.len()),
        )
        .with_location(Location::file(origin).line(line).field(node.tag_name().name())));
    }
    Ok(values)
}

/// Parses an MVNX text; `origin` names it in errors.
pub fn parse_mvnx(text: &str, origin: &Path) -> Result<MvnxFile> {
    let text = crate::text::strip_bom(text);
    let doc = roxmltree::Document::parse(text).map_err(|e| {
        let row = match e {
            roxmltree::Error::UnclosedRootNode | roxmltree::Error::UnexpectedEndOfStream => {
                text.trim_end().lines().count().max(1)
            }
            _ => e.pos().row as usize,
        };
        let kind = match e {
            roxmltree::Error::UnclosedRootNode | roxmltree::Error::UnexpectedEndOfStream => {
                ErrorKind::Truncated
            }
            _ => ErrorKind::Syntax,
        };
        Error::at_line(kind, origin, row, format!("not well-formed XML: {e}"))
    })?;
    let line_of = |n: roxmltree::Node| doc.text_pos_at(n.range().start).row as usize;
    let root = doc.root_element();
    if root.tag_name().name() != "mvnx" {
        return Err(Error::at_line(
            ErrorKind::Syntax,
            origin,
            line_of(root),
            format!("the root element is <{}>; expected <mvnx>", root.tag_name().name()),
        ));
    }
    fn child<'a, 'i>(n: roxmltree::Node<'a, 'i>, name: &str) -> Option<roxmltree::Node<'a, 'i>> {
        n.children().find(|c| c.is_element() && c.tag_name().name() == name)
    }
    let subject = child(root, "subject").ok_or_else(|| {
        Error::at_line(
            ErrorKind::MissingKey,
            origin,
            line_of(root),
            "<mvnx> holds no <subject>".to_string(),
        )
        .with_field("subject")
    })?;
    let rate_text = subject.attribute("frameRate").ok_or_else(|| {
        Error::at_line(
            ErrorKind::MissingKey,
            origin,
            line_of(subject),
            "<subject> has no frameRate".to_string(),
        )
        .with_field("frameRate")
    })?;
    let frame_rate_hz: f64 =
        rate_text.trim().parse().ok().filter(|r: &f64| r.is_finite() && *r > 0.0).ok_or_else(
            || {
                Error::at_line(
                    ErrorKind::OutOfRange,
                    origin,
                    line_of(subject),
                    format!("frameRate is {rate_text:?}; expected frames per second > 0"),
                )
                .with_field("frameRate")
            },
        )?;
    let labels = |parent: &str, item: &str| -> Vec<String> {
        child(subject, parent)
            .map(|p| {
                p.children()
                    .filter(|c| c.is_element() && c.tag_name().name() == item)
                    .map(|c| c.attribute("label").unwrap_or_default().to_string())
                    .collect()
            })
            .unwrap_or_default()
    };
    let segments = labels("segments", "segment");
    let joints = labels("joints", "joint");
    let contacts = labels("footContactDefinition", "contactDefinition");
    if segments.is_empty() {
        return Err(Error::at_line(
            ErrorKind::EmptySequence,
            origin,
            line_of(subject),
            "<subject> lists no <segments><segment label=…>".to_string(),
        )
        .with_field("segments"));
    }
    let frames = child(subject, "frames").ok_or_else(|| {
        Error::at_line(
            ErrorKind::MissingKey,
            origin,
            line_of(subject),
            "<subject> holds no <frames>".to_string(),
        )
        .with_field("frames")
    })?;
    let (s, j) = (segments.len(), joints.len());
    let mut out = MvnxFile { frame_rate_hz, segments, joints, contacts, ..Default::default() };
    for frame in frames.children().filter(|c| c.is_element() && c.tag_name().name() == "frame") {
        if frame.attribute("type").unwrap_or("normal") != "normal" {
            continue;
        }
        let mut pos = None;
        let mut ori = None;
        let mut ang = None;
        let mut feet = None;
        for e in frame.children().filter(|c| c.is_element()) {
            let line = line_of(e);
            match e.tag_name().name() {
                "position" => {
                    pos = Some(numbers(
                        e,
                        line,
                        origin,
                        3 * s,
                        &format!("x y z for each of {s} segments"),
                    )?)
                }
                "orientation" => {
                    ori = Some(numbers(
                        e,
                        line,
                        origin,
                        4 * s,
                        &format!("q0 q1 q2 q3 for each of {s} segments"),
                    )?)
                }
                "jointAngle" if j > 0 => {
                    ang = Some(numbers(
                        e,
                        line,
                        origin,
                        3 * j,
                        &format!("x y z for each of {j} joints"),
                    )?)
                }
                "footContacts" if !out.contacts.is_empty() => {
                    let c = out.contacts.len();
                    feet = Some(numbers(
                        e,
                        line,
                        origin,
                        c,
                        &format!("one 0/1 for each of {c} contact points"),
                    )?)
                }
                _ => {}
            }
        }
        let Some(pos) = pos else {
            return Err(Error::at_line(
                ErrorKind::MissingKey,
                origin,
                line_of(frame),
                "a normal <frame> without <position>".to_string(),
            )
            .with_field("position"));
        };
        out.positions.push(pos.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect());
        let ori = ori.unwrap_or_else(|| vec![f64::NAN; 4 * s]);
        out.orientations.push(ori.chunks_exact(4).map(|c| [c[0], c[1], c[2], c[3]]).collect());
        if let Some(a) = ang {
            out.joint_angles.push(a.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect());
        }
        if let Some(f) = feet {
            out.foot_contacts.push(f.iter().map(|v| *v != 0.0).collect());
        }
    }
    if out.positions.is_empty() {
        return Err(Error::at_line(
            ErrorKind::EmptySequence,
            origin,
            line_of(frames),
            "<frames> holds no frame of type \"normal\" (only calibration frames)".to_string(),
        ));
    }
    let n = out.positions.len();
    if !out.joint_angles.is_empty() && out.joint_angles.len() != n {
        return Err(Error::at_line(
            ErrorKind::WrongValueCount,
            origin,
            line_of(frames),
            format!(
                "{} of {n} normal frames have <jointAngle>; expected all or none",
                out.joint_angles.len()
            ),
        ));
    }
    if !out.foot_contacts.is_empty() && out.foot_contacts.len() != n {
        return Err(Error::at_line(
            ErrorKind::WrongValueCount,
            origin,
            line_of(frames),
            format!(
                "{} of {n} normal frames have <footContacts>; expected all or none",
                out.foot_contacts.len()
            ),
        ));
    }
    Ok(out)
}

impl MvnxFile {
    /// Foot Strike / Foot Off events: per side (contact labels starting `Left`/`Right`), a
    /// strike where some contact point of that foot is down and none was in the frame before,
    /// an off where none is down and some was.
    pub fn events(&self) -> Vec<Event> {
        let mut events = Vec::new();
        for side in ["Left", "Right"] {
            let points: Vec<usize> =
                (0..self.contacts.len()).filter(|&k| self.contacts[k].starts_with(side)).collect();
            if points.is_empty() {
                continue;
            }
            let down = |f: usize| points.iter().any(|&k| self.foot_contacts[f][k]);
            for f in 1..self.foot_contacts.len() {
                let label = match (down(f - 1), down(f)) {
                    (false, true) => "Foot Strike",
                    (true, false) => "Foot Off",
                    _ => continue,
                };
                events.push(Event {
                    label: label.into(),
                    context: side.into(),
                    time: Seconds(f as f64 / self.frame_rate_hz),
                    frame: f as f64,
                });
            }
        }
        events.sort_by(|a, b| a.frame.total_cmp(&b.frame));
        events
    }

    /// The motion: positions in mm, orientations and joint angles as channels, contacts as events.
    pub fn into_motion(self, origin: &Path) -> Result<Motion> {
        let rate = FrameRate::new(self.frame_rate_hz).map_err(|e| e.in_file(origin))?;
        let mm = LengthUnit::Metre.millimetres_per_unit();
        let positions: Vec<[f64; 3]> =
            self.positions.iter().flatten().map(|p| [p[0] * mm, p[1] * mm, p[2] * mm]).collect();
        let mut names = Vec::new();
        let mut units = Vec::new();
        for s in &self.segments {
            for q in ["q0", "q1", "q2", "q3"] {
                names.push(format!("{s}_{q}"));
                units.push(String::new());
            }
        }
        if !self.joint_angles.is_empty() {
            for j in &self.joints {
                for a in ["x", "y", "z"] {
                    names.push(format!("{j}_{a}_deg"));
                    units.push("deg".into());
                }
            }
        }
        let mut values = Vec::with_capacity(self.positions.len() * names.len());
        for f in 0..self.positions.len() {
            values.extend(self.orientations[f].iter().flatten());
            if let Some(a) = self.joint_angles.get(f) {
                values.extend(a.iter().flatten());
            }
        }
        let events = if self.foot_contacts.is_empty() { Vec::new() } else { self.events() };
        let channels = Channels::new(names, units, values).map_err(|e| e.in_file(origin))?;
        let mut motion = Motion::new(
            crate::read::stem(origin),
            rate,
            Axis::Z,
            PointKind::Joint,
            self.segments,
            positions,
        )
        .map_err(|e| e.in_file(origin))?
        .with_channels(channels)
        .map_err(|e| e.in_file(origin))?
        .with_source(origin, "mvnx");
        motion.events = events;
        motion.load_notes = LoadNotes {
            length_unit: Some(LengthUnit::Metre),
            length_unit_from: "MVNX positions are metres (Xsens's schema)".into(),
            repairs: Vec::new(),
        };
        Ok(motion)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A two-segment, one-joint MVNX 4 file with a calibration frame and three normal frames
    /// (the left heel lands on frame 1 and lifts on frame 2), as the schema lays it out.
    const FILE: &str = r##"<?xml version="1.0" encoding="UTF-8"?>
<mvnx version="4">
<mvn version="2022.0.0" build="x"/>
<subject label="s" torsoColor="#ea6852" frameRate="60" segmentCount="2" recDate="" originalFilename="">
<segments>
<segment label="Pelvis" id="1"><points/></segment>
<segment label="L5" id="2"><points/></segment>
</segments>
<joints>
<joint label="jL5S1"><connector1>Pelvis/jL5S1</connector1><connector2>L5/jL5S1</connector2></joint>
</joints>
<footContactDefinition>
<contactDefinition index="0" label="LeftFoot_Heel"/>
<contactDefinition index="1" label="LeftFoot_Toe"/>
<contactDefinition index="2" label="RightFoot_Heel"/>
</footContactDefinition>
<frames segmentCount="2" sensorCount="0" jointCount="1">
<frame time="0" index="" tc="" ms="" type="tpose">
<orientation>1 0 0 0 1 0 0 0</orientation>
<position>0 0 1 0 0 1.1</position>
</frame>
<frame time="0" index="0" tc="00:00:00:00" ms="0" type="normal">
<orientation>1 0 0 0 0.7071068 0 0 0.7071068</orientation>
<position>0.1 0.2 0.95 0.1 0.2 1.05</position>
<velocity>0 0 0 0 0 0</velocity>
<jointAngle>1.5 -2 3</jointAngle>
<footContacts>0 0 1</footContacts>
</frame>
<frame time="17" index="1" tc="00:00:00:01" ms="17" type="normal">
<orientation>1 0 0 0 1 0 0 0</orientation>
<position>0.11 0.2 0.95 0.11 0.2 1.05</position>
<jointAngle>1.6 -2 3</jointAngle>
<footContacts>1 0 1</footContacts>
</frame>
<frame time="33" index="2" tc="00:00:00:02" ms="33" type="normal">
<orientation>1 0 0 0 1 0 0 0</orientation>
<position>0.12 0.2 0.95 0.12 0.2 1.05</position>
<jointAngle>1.7 -2 3</jointAngle>
<footContacts>0 0 0</footContacts>
</frame>
</frames>
</subject>
</mvnx>
"##;

    #[test]
    fn segments_joint_angles_orientations_and_foot_contacts() {
        let p = Path::new("walk.mvnx");
        let f = parse_mvnx(FILE, p).unwrap();
        assert_eq!(f.segments, ["Pelvis", "L5"]);
        assert_eq!(f.positions.len(), 3, "the tpose frame is skipped");
        let m = f.into_motion(p).unwrap();
        assert_eq!((m.n_frames(), m.n_points(), m.frame_rate().hz()), (3, 2, 60.0));
        assert_eq!(m.up_axis(), Axis::Z);
        assert!((m.position(0, 1)[2] - 1050.0).abs() < 1e-9, "metres to mm");
        let c = m.channels();
        assert_eq!(c.names()[4..8], ["L5_q0", "L5_q1", "L5_q2", "L5_q3"]);
        assert_eq!(c.names()[8..], ["jL5S1_x_deg", "jL5S1_y_deg", "jL5S1_z_deg"]);
        assert_eq!(c.values()[11 + 8], 1.6, "frame 1's jL5S1 x");
        // The file's text, not the constant 1/√2 it approximates.
        assert_eq!(c.values()[7].to_string(), "0.7071068");
        let ev: Vec<(&str, &str, f64)> =
            m.events.iter().map(|e| (e.label.as_str(), e.context.as_str(), e.frame)).collect();
        assert_eq!(
            ev,
            [("Foot Strike", "Left", 1.0), ("Foot Off", "Left", 2.0), ("Foot Off", "Right", 2.0)]
        );
        assert!((m.events[0].time.value() - 1.0 / 60.0).abs() < 1e-12);
    }

    #[test]
    fn malformed_files_name_the_line_and_element() {
        let p = Path::new("bad.mvnx");
        let short = FILE.replace(
            "<position>0.11 0.2 0.95 0.11 0.2 1.05</position>",
            "<position>0.11 0.2 0.95 0.11 0.2</position>",
        );
        let e = parse_mvnx(&short, p).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::WrongValueCount);
        assert_eq!(
            (e.location().line, e.location().field.as_deref()),
            (Some(31), Some("position"))
        );
        assert!(e.to_string().contains("holds 5 values; expected 6"), "{e}");
        let nan =
            FILE.replace("<jointAngle>1.7 -2 3</jointAngle>", "<jointAngle>1.7 x 3</jointAngle>");
        let e = parse_mvnx(&nan, p).unwrap_err();
        assert_eq!(e.location().line, Some(38));
        assert!(e.to_string().contains("value 2 is \"x\""), "{e}");
        let e = parse_mvnx(&FILE.replace(" frameRate=\"60\"", ""), p).unwrap_err();
        assert_eq!(e.location().field.as_deref(), Some("frameRate"));
        let e = parse_mvnx(&FILE[..FILE.len() / 2], p).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::Truncated);
        assert!(parse_mvnx("<bvh/>", p).is_err());
    }
}
