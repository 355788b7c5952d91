//! `cmu86_labels`: the CMU subject-86 segment labels (`data/cmu86/mocap.txt`).

use std::path::Path;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{
    Boundary, Error, ErrorKind, FrameRate, GroundTruthReader, Motion, Result, Segment, Segmentation,
};

/// Reads the CMU subject-86 action labels of Zhou, De la Torre & Hodgins (HACA, FG 2008 /
/// TPAMI 2013) for one trial into boundaries and labelled segments.
///
/// File format: blocks separated by blank lines; a block starts with `86 01` (subject, trial)
/// and lists one `action a b c` line per segment, where `b` is the segment's end frame
/// (1-based, at 120 fps) and `a`..`c` the annotated transition window; the last line gives the
/// trial length (its `b`) and labels the final segment. Trailing spaces, CRLF/LF mixtures and
/// a missing final newline are accepted.
///
/// Result: boundary k at frame `b_k − 1` (0-based) with window `[a_k − 1, c_k − 1]`; where the
/// annotation puts `a` after `b` or `c` before `b` (trials 86_05 and 86_06 do), the window is
/// widened to include `b`, so a window always contains its boundary. Segment k spans
/// `b_{k−1} − 1 .. b_k − 1` (the first starts at 0, the last ends at the trial length) and is
/// labelled with its action. When the motion's rate differs from `label_rate_hz`, every frame
/// is rescaled to the motion's rate and rounded.
///
/// Errors: a trial absent from the file (the message lists the trials present), boundaries
/// that do not increase, or labels running past the motion's last frame. Frames after the
/// trial length (a motion longer than labelled) belong to no segment. Missing samples in the
/// motion do not matter: only its frame count and rate are used.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Cmu86LabelsParams {
    /// The trial to read, as `"86_01"` or `"86 01"`.
    #[serde(default)]
    #[schemars(extend("x-default" = "the motion's name (the AMC file stem, e.g. `86_01`)"))]
    pub trial: Option<String>,
    /// Frame rate of the frame numbers in the file, Hz (the default is the CMU capture rate).
    #[serde(default = "default_label_rate_hz")]
    pub label_rate_hz: f64,
}

fn default_label_rate_hz() -> f64 {
    120.0
}

/// The validated reader.
#[derive(Clone, Debug)]
pub struct Cmu86Labels {
    trial: Option<(u32, u32)>,
    label_rate: FrameRate,
}

impl ParamGuard for Cmu86LabelsParams {
    type Checked = Cmu86Labels;
    fn check(self) -> Result<Cmu86Labels> {
        let label_rate =
            FrameRate::new(self.label_rate_hz).map_err(|e| e.with_field("label_rate_hz"))?;
        let trial = match &self.trial {
            None => None,
            Some(t) => Some(trial_id(t).ok_or_else(|| {
                Error::new(
                    ErrorKind::InvalidParameter,
                    format!("{t:?} is not a trial; expected subject and trial like \"86_01\""),
                )
                .with_field("trial")
            })?),
        };
        Ok(Cmu86Labels { trial, label_rate })
    }
}

/// `"86_01"`, `"86 01"`, `"86-1"` → (86, 1).
fn trial_id(s: &str) -> Option<(u32, u32)> {
    let mut parts =
        s.split(|c: char| c == '_' || c == '-' || c.is_whitespace()).filter(|p| !p.is_empty());
    let subject = parts.next()?.parse().ok()?;
    let trial = parts.next()?.parse().ok()?;
    parts.next().is_none().then_some((subject, trial))
}

/// One `action a b c` line.
#[derive(Clone, Debug, PartialEq)]
pub struct LabelLine {
    pub action: String,
    pub a: usize,
    pub b: usize,
    pub c: usize,
    /// 1-based line in the file.
    pub line: usize,
}

/// One trial's block.
#[derive(Clone, Debug, PartialEq)]
pub struct TrialLabels {
    /// (subject, trial) as written in the block header.
    pub trial: (u32, u32),
    pub header_line: usize,
    pub lines: Vec<LabelLine>,
}

/// Parses the whole label file into its trial blocks.
pub fn parse_cmu86_labels(text: &str, origin: &Path) -> Result<Vec<TrialLabels>> {
    let text = crate::text::strip_bom(text);
    let mut trials: Vec<TrialLabels> = Vec::new();
    for (i, raw) in text.split('\n').enumerate() {
        let line = i + 1;
        let words: Vec<&str> = raw.split_ascii_whitespace().collect();
        match words.len() {
            0 => continue,
            2 => {
                let id = (words[0].parse().ok(), words[1].parse().ok());
                let (Some(s), Some(t)) = id else {
                    return Err(Error::at_line(
                        ErrorKind::Syntax,
                        origin,
                        line,
                        format!("{:?}; expected a trial header like \"86 01\"", raw.trim()),
                    ));
                };
                if let Some(prev) = trials.iter().find(|b| b.trial == (s, t)) {
                    return Err(Error::at_line(
                        ErrorKind::DuplicateName,
                        origin,
                        line,
                        format!(
                            "trial {s} {t:02} is listed twice (first at line {})",
                            prev.header_line
                        ),
                    ));
                }
                trials.push(TrialLabels { trial: (s, t), header_line: line, lines: Vec::new() });
            }
            4 => {
                let Some(block) = trials.last_mut() else {
                    return Err(Error::at_line(
                        ErrorKind::Syntax,
                        origin,
                        line,
                        "label line before any trial header; expected \"86 01\" first",
                    ));
                };
                let mut n = [0usize; 3];
                for (k, w) in words[1..].iter().enumerate() {
                    n[k] = w.parse().ok().filter(|v| *v >= 1).ok_or_else(|| {
                        Error::at_line(
                            ErrorKind::Syntax,
                            origin,
                            line,
                            format!("{w:?} in {:?}; expected a frame number ≥ 1", raw.trim()),
                        )
                    })?;
                }
                block.lines.push(LabelLine {
                    action: words[0].to_string(),
                    a: n[0],
                    b: n[1],
                    c: n[2],
                    line,
                });
            }
            _ => {
                return Err(Error::at_line(
                    ErrorKind::Syntax,
                    origin,
                    line,
                    format!(
                        "{:?} has {} words; expected \"subject trial\" or \"action a b c\"",
                        raw.trim(),
                        words.len()
                    ),
                ));
            }
        }
    }
    Ok(trials)
}

/// Builds the segmentation of one trial (see [`Cmu86LabelsParams`]) at `motion_rate`, for a
/// motion of `n_frames` frames.
pub fn trial_segmentation(
    block: &TrialLabels,
    origin: &Path,
    label_rate: FrameRate,
    motion_rate: FrameRate,
    n_frames: usize,
) -> Result<Segmentation> {
    let (s, t) = block.trial;
    let Some(last) = block.lines.last() else {
        return Err(Error::at_line(
            ErrorKind::EmptySequence,
            origin,
            block.header_line,
            format!("trial {s} {t:02} has no label lines"),
        ));
    };
    let ratio = motion_rate.hz() / label_rate.hz();
    // Label frame (0-based at the label rate) → motion frame.
    let at_rate =
        |f: usize| -> usize { if ratio == 1.0 { f } else { (f as f64 * ratio).round() as usize } };
    let length = at_rate(last.b);
    if length > n_frames {
        return Err(Error::at_line(
            ErrorKind::OutOfRange,
            origin,
            last.line,
            format!(
                "trial {s} {t:02} is labelled up to frame {} but the motion has {n_frames} frames (at {}); wrong trial or motion?",
                last.b, motion_rate
            ),
        ));
    }
    let mut boundaries = Vec::new();
    let mut segments = Vec::new();
    let mut start = 0usize;
    for (k, l) in block.lines.iter().enumerate() {
        let is_last = k + 1 == block.lines.len();
        let end = if is_last { length } else { at_rate(l.b - 1) };
        if end <= start || end > length || (!is_last && end >= length) {
            return Err(Error::at_line(
                ErrorKind::OutOfRange,
                origin,
                l.line,
                format!(
                    "segment {:?} ends at frame {} (1-based), not after the previous boundary and before the trial length {}",
                    l.action, l.b, last.b
                ),
            ));
        }
        if !is_last {
            let lo = at_rate(l.a.min(l.b) - 1);
            let hi = at_rate(l.c.max(l.b) - 1);
            boundaries.push(Boundary { frame: end, window: Some((lo, hi)) });
        }
        segments.push(Segment { start, end, label: l.action.clone() });
        start = end;
    }
    Ok(Segmentation {
        frame_rate: motion_rate,
        boundaries,
        segments,
        annotators: Vec::new(),
        annotator_names: Vec::new(),
    })
}

impl GroundTruthReader for Cmu86Labels {
    fn read(&self, path: &Path, motion: &Motion) -> Result<Segmentation> {
        let text = crate::read::read_text(path)?;
        let trials = parse_cmu86_labels(&text, path)?;
        let wanted = match self.trial {
            Some(t) => t,
            None => trial_id(&motion.name).ok_or_else(|| {
                Error::new(
                    ErrorKind::InvalidParameter,
                    format!(
                        "the motion's name {:?} is no trial like \"86_01\"; set `trial`",
                        motion.name
                    ),
                )
                .with_field("trial")
            })?,
        };
        let Some(block) = trials.iter().find(|b| b.trial == wanted) else {
            let present: Vec<String> =
                trials.iter().map(|b| format!("{}_{:02}", b.trial.0, b.trial.1)).collect();
            return Err(Error::new(
                ErrorKind::UnknownName,
                format!(
                    "trial {}_{:02} is not in the label file; it has {}",
                    wanted.0,
                    wanted.1,
                    present.join(", ")
                ),
            )
            .with_location(motionlab_core::Location::file(path).field("trial")));
        };
        trial_segmentation(block, path, self.label_rate, motion.frame_rate(), motion.n_frames())
    }
}

motionlab_core::register_plugin!(GroundTruth, Cmu86LabelsParams, "cmu86_labels");

#[cfg(test)]
mod tests {
    use super::*;

    const FILE: &str = "86 01\r\nwalk 10 20 30 \r\njump 40 38 60\r\npunch 100 100 100\n\n86 02\nrun 5 6 7\nrun 9 9 9";

    #[test]
    fn boundaries_windows_and_segments_of_a_small_file() {
        let trials = parse_cmu86_labels(FILE, Path::new("m.txt")).unwrap();
        assert_eq!(trials.len(), 2);
        let r = FrameRate::new(120.0).unwrap();
        let s = trial_segmentation(&trials[0], Path::new("m.txt"), r, r, 100).unwrap();
        assert_eq!(s.frames(), vec![19, 37]);
        assert_eq!(s.boundaries[0].window, Some((9, 29)));
        // a = 40 > b = 38: the window is widened to include the boundary.
        assert_eq!(s.boundaries[1].window, Some((37, 59)));
        let spans: Vec<(usize, usize, &str)> =
            s.segments.iter().map(|g| (g.start, g.end, g.label.as_str())).collect();
        assert_eq!(spans, vec![(0, 19, "walk"), (19, 37, "jump"), (37, 100, "punch")]);
    }

    #[test]
    fn rescales_to_the_motion_rate_and_refuses_labels_past_the_end() {
        let trials = parse_cmu86_labels(FILE, Path::new("m.txt")).unwrap();
        let (r120, r60) = (FrameRate::new(120.0).unwrap(), FrameRate::new(60.0).unwrap());
        let s = trial_segmentation(&trials[0], Path::new("m.txt"), r120, r60, 50).unwrap();
        assert_eq!(s.frames(), vec![10, 19]); // 19 × 0.5 = 9.5 → 10, 37 × 0.5 = 18.5 → 19
        assert_eq!(s.segments.last().map(|g| g.end), Some(50));
        let e = trial_segmentation(&trials[0], Path::new("m.txt"), r120, r120, 99).unwrap_err();
        assert_eq!((e.kind(), e.location().line), (ErrorKind::OutOfRange, Some(4)));
    }

    #[test]
    fn malformed_lines_name_their_line() {
        let e = parse_cmu86_labels("86 01\nwalk 10 x 30\n", Path::new("m.txt")).unwrap_err();
        assert_eq!((e.kind(), e.location().line), (ErrorKind::Syntax, Some(2)));
        let e = parse_cmu86_labels("walk 1 2 3\n", Path::new("m.txt")).unwrap_err();
        assert_eq!((e.kind(), e.location().line), (ErrorKind::Syntax, Some(1)));
        let trials = parse_cmu86_labels(
            "86 01\nwalk 50 50 50\nrun 40 40 40\nx 60 60 60\n",
            Path::new("m.txt"),
        )
        .unwrap();
        let r = FrameRate::new(120.0).unwrap();
        let e = trial_segmentation(&trials[0], Path::new("m.txt"), r, r, 60).unwrap_err();
        assert_eq!((e.kind(), e.location().line), (ErrorKind::OutOfRange, Some(3)));
    }

    #[test]
    fn trial_names_parse_in_both_spellings() {
        assert_eq!(trial_id("86_01"), Some((86, 1)));
        assert_eq!(trial_id("86 01"), Some((86, 1)));
        assert_eq!(trial_id("walk"), None);
        assert_eq!(trial_id("86_01_x"), None);
        let bad: toml::Value = toml::from_str("trial = \"eighty-six\"").unwrap();
        let e = motionlab_core::registry::build_ground_truth("cmu86_labels", &bad).err().unwrap();
        assert_eq!(e.location().field.as_deref(), Some("trial"));
    }
}
