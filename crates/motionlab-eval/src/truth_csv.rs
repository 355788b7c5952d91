//! Ground-truth reader `boundaries_csv`: the user's own boundaries or segments, from a CSV.

use std::path::Path;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{
    Error, ErrorKind, FrameRate, GroundTruthReader, Location, Motion, Result, Segmentation,
};
use motionlab_io::labels::annotations::EndRule;
use motionlab_io::labels::boundaries_csv::{CsvAnnotations, CsvUnit, parse_boundaries_csv};

use crate::consensus::ConsensusParams;
use crate::truth_annotators::Annotators;

/// Reads boundaries a user annotated, from a CSV with one row per boundary or one row per
/// segment, optionally several sequences and several annotators in one file.
///
/// **Format** (header row first; names case-insensitive; `#` comment lines; `,` or `;` or tab):
///
/// ```text
/// sequence,start_s,end_s,label,annotator
/// dance1,2.10,3.05,step,ana
/// dance1,3.05,3.90,turn,ana
/// ```
///
/// - `sequence` (optional): the motion file's stem (`dance1` for `dance1.c3d`); without the
///   column every row belongs to the motion read (one file per motion: `file = "{stem}.csv"`).
/// - one row per **boundary**: `frame` or `time_s` (or both: then `frame` is the boundary
///   and `time_s` must agree with it to within half a frame at the motion's rate — the files
///   the viewer pages and `motionlab export` write carry both); or one row per **segment**:
///   `start_frame` + `end_frame` or `start_s` + `end_s`, plus an optional `label`. Points and
///   segments, and frames and seconds of segments, do not mix (such a header is an error).
/// - `annotator` (optional): who marked the row.
///
/// **Boundaries**: each point row is one; segment rows give their starts plus the end of the
/// annotator's last segment. Frames may be fractional: every instant is converted to a motion
/// frame (`time_s × rate`, or `(frame − first_frame) × rate / frame_rate_hz`) and rounded to
/// the nearest frame, halves away from zero. Instants on the motion's first or last frame are
/// its edges, not boundaries; one past the last frame is accepted as a segment's end (an
/// exclusive end), anything later is an error. Segments keep their labels (for the
/// `transitions` evaluator). No transition windows.
///
/// **Annotators**: with one annotator (or no `annotator` column) its marks are the truth; with
/// several, `annotator = "…"` evaluates one of them (sweep it for per-annotator results) and
/// `consensus = { … }` combines them all (`motionlab describe` of the consensus rule: marks
/// chained within `tolerance`, one vote per annotator, kept with ≥ `min_votes`; the truth then
/// carries each point's spread as its window, and every annotator's own marks for
/// `boundary_metrics`' TCPDBench F1 and covering).
///
/// **Errors** (one line naming the file, the line and the column): no header or an unknown,
/// repeated, missing or mixed time column; a `time_s` more than half a frame from its row's
/// `frame` (another rate?); a non-numeric, negative or non-finite cell; a
/// segment whose start is after its end; a row with the wrong number of cells; an empty
/// `sequence` or `annotator` cell; an instant past the motion's end; **a loaded sequence with
/// no rows** (the message lists the sequences the file has); **a row naming no loaded
/// sequence** — a reader sees one motion at a time, so what is checked is that every
/// `sequence` in the file names a motion file of the same format in the folder of the motion
/// being read (`86_01` → `86_01.amc[.gz]`); set `check_sequences = false` when one CSV covers
/// motions in several folders. Missing samples in the motion do not matter: only its frame
/// count and rate are used.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct BoundariesCsvParams {
    /// The sequence whose rows to read.
    #[serde(default)]
    #[schemars(extend("x-default" = "the motion file's stem (its name when it was not loaded from a file)"))]
    pub sequence: Option<String>,
    /// Evaluate this annotator's rows only.
    #[serde(default)]
    #[schemars(extend("x-default" = "the file's only annotator"))]
    pub annotator: Option<String>,
    /// Combine every annotator's marks by consensus (k of N within a tolerance).
    #[serde(default)]
    pub consensus: Option<ConsensusParams>,
    /// Rate of the `frame` / `start_frame` / `end_frame` numbers, Hz.
    #[serde(default)]
    #[schemars(extend("x-default" = "the motion's own rate (frames are motion frames)"))]
    pub frame_rate_hz: Option<f64>,
    /// The number the file gives the motion's first frame (frames): 1 for tools that count
    /// from 1.
    #[serde(default)]
    pub first_frame: u32,
    /// Check that every `sequence` in the file names a motion file beside the one read.
    #[serde(default = "default_true")]
    pub check_sequences: bool,
}

fn default_true() -> bool {
    true
}

/// The validated reader.
#[derive(Clone, Debug)]
pub struct BoundariesCsv {
    sequence: Option<String>,
    annotators: Annotators,
    frame_rate: Option<FrameRate>,
    first_frame: f64,
    check_sequences: bool,
}

impl ParamGuard for BoundariesCsvParams {
    type Checked = BoundariesCsv;
    fn check(self) -> Result<BoundariesCsv> {
        let annotators = Annotators::from_params(self.annotator, self.consensus, "annotator")?;
        let frame_rate = self
            .frame_rate_hz
            .map(|hz| FrameRate::new(hz).map_err(|e| e.with_field("frame_rate_hz")))
            .transpose()?;
        if self.sequence.as_ref().is_some_and(|s| s.trim().is_empty()) {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                "is empty; expected a sequence named in the file",
            )
            .with_field("sequence"));
        }
        Ok(BoundariesCsv {
            sequence: self.sequence,
            annotators,
            frame_rate,
            first_frame: f64::from(self.first_frame),
            check_sequences: self.check_sequences,
        })
    }
}

/// The sequence a motion is: its file's stem, else its name (without a dataset prefix).
pub(crate) fn sequence_of(motion: &Motion) -> String {
    match &motion.source {
        Some(p) => motionlab_core::paths::stem(p),
        None => motion.name.rsplit('/').next().unwrap_or(&motion.name).to_string(),
    }
}

/// Every `sequence` of the file must name a motion file of the motion's format in its folder
/// (a motion read from a folder, OpenPose's frames: a folder beside it).
fn check_sequences_exist(csv: &CsvAnnotations, origin: &Path, motion: &Motion) -> Result<()> {
    let Some(source) = &motion.source else { return Ok(()) };
    let ext = motionlab_core::paths::format_extension(source);
    let folders = source.is_dir();
    let dir = source.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let Ok(entries) = std::fs::read_dir(dir) else { return Ok(()) };
    let mut stems: Vec<String> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            if folders {
                p.is_dir()
            } else {
                p.is_file() && motionlab_core::paths::format_extension(p) == ext
            }
        })
        .map(|p| motionlab_core::paths::stem(&p))
        .collect();
    stems.sort();
    for s in csv.sequences() {
        if !stems.iter().any(|t| t == s) {
            let line = csv.first_line_of(s).unwrap_or(csv.header_line);
            let shown: Vec<&str> = stems.iter().take(12).map(String::as_str).collect();
            return Err(Error::at_line(
                ErrorKind::UnknownName,
                origin,
                line,
                format!(
                    "sequence {s:?} names no loaded sequence: no {s}.{} beside {} (motion files there: {}{}); set check_sequences = false if it lives elsewhere",
                    ext.as_deref().unwrap_or("?"),
                    source.display(),
                    shown.join(", "),
                    if stems.len() > shown.len() { ", …" } else { "" }
                ),
            )
            .with_field("sequence"));
        }
    }
    Ok(())
}

impl GroundTruthReader for BoundariesCsv {
    fn read(&self, path: &Path, motion: &Motion) -> Result<Segmentation> {
        let text = motionlab_io::read::read_text(path)?;
        let csv = parse_boundaries_csv(&text, path)?;
        if self.check_sequences && csv.has_sequence {
            check_sequences_exist(&csv, path, motion)?;
        }
        let sequence = self.sequence.clone().unwrap_or_else(|| sequence_of(motion));
        let tracks = csv.tracks(&sequence);
        if tracks.is_empty() {
            let message = if csv.has_sequence {
                format!(
                    "no row for sequence {sequence:?} (motion {}); the file has rows for {}",
                    motion.name,
                    csv.sequences().join(", ")
                )
            } else {
                format!("no rows; expected one per boundary or segment of {}", motion.name)
            };
            return Err(Error::new(ErrorKind::EmptySequence, message)
                .with_location(Location::file(path).line(csv.header_line).field("sequence")));
        }
        let rate = motion.frame_rate().hz();
        let first = self.first_frame;
        let scale = self.frame_rate.map_or(1.0, |r| rate / r.hz());
        let rule = EndRule::LastEndOnly;
        let where_ = format!("sequence {sequence:?}");
        if csv.unit == CsvUnit::Frames {
            check_times_agree_with_frames(&csv, &sequence, path, rate, move |f| {
                (f - first) * scale
            })?;
        }
        match csv.unit {
            CsvUnit::Seconds => self.annotators.truth(
                &tracks,
                move |s| s * rate,
                rule,
                path,
                motion,
                "annotator",
                &where_,
            ),
            CsvUnit::Frames => self.annotators.truth(
                &tracks,
                move |f| (f - first) * scale,
                rule,
                path,
                motion,
                "annotator",
                &where_,
            ),
        }
    }
}

/// A row giving both `frame` and `time_s` must name one instant: the two, as motion frames,
/// within half a frame of each other.
fn check_times_agree_with_frames(
    csv: &CsvAnnotations,
    sequence: &str,
    origin: &Path,
    rate: f64,
    to_frame: impl Fn(f64) -> f64,
) -> Result<()> {
    let rows =
        csv.rows.iter().filter(|r| !csv.has_sequence || r.sequence.as_deref() == Some(sequence));
    for r in rows {
        let Some(t) = r.time_s else { continue };
        let (by_frame, by_time) = (to_frame(r.item.start), t * rate);
        if (by_frame - by_time).abs() > 0.5 {
            return Err(Error::at_line(
                ErrorKind::Mismatch,
                origin,
                r.item.line,
                format!(
                    "time_s {t} is motion frame {by_time:.2} at {rate} Hz, but frame {} is motion frame {by_frame:.2}; the file's frames and times disagree (written at another rate? set frame_rate_hz)",
                    r.item.start
                ),
            )
            .with_field("time_s"));
        }
    }
    Ok(())
}

motionlab_core::register_plugin!(GroundTruth, BoundariesCsvParams, "boundaries_csv");

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_core::registry::build_ground_truth;
    use motionlab_testkit::motion_from_fn;

    fn read(params: &str, csv: &str, motion: &Motion) -> Result<Segmentation> {
        let dir = std::env::temp_dir().join(format!("motionlab-truth-csv-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(format!("{:x}.csv", csv.len() * 31 + params.len()));
        std::fs::write(&path, csv).unwrap();
        build_ground_truth("boundaries_csv", &toml::from_str(params).unwrap())?.read(&path, motion)
    }

    fn motion(name: &str) -> Motion {
        let mut m = motion_from_fn(1000, 100.0, 1, |_, _| [0.0; 3]);
        m.name = name.into();
        m
    }

    #[test]
    fn units_rates_and_sequences() {
        let m = motion("d1");
        let csv = "sequence,time_s\nd1,2.004\nd1,5.5\nd2,1\n";
        assert_eq!(read("", csv, &m).unwrap().frames(), vec![200, 550]);
        // Frames at 50 Hz numbered from 1: (11 − 1) × 2 = 20, (20.25 − 1) × 2 = 38.5 → 39.
        let s = read("frame_rate_hz = 50.0\nfirst_frame = 1", "frame\n11\n20.25\n", &m).unwrap();
        assert_eq!(s.frames(), vec![20, 39]);
        // Another sequence by parameter; a missing one is an error listing those present.
        assert_eq!(read("sequence = \"d2\"", csv, &m).unwrap().frames(), vec![100]);
        let e = read("", csv, &motion("d3")).unwrap_err();
        assert_eq!(
            (e.kind(), e.location().line, e.location().field.as_deref()),
            (ErrorKind::EmptySequence, Some(1), Some("sequence"))
        );
        assert!(e.to_string().contains("the file has rows for d1, d2"), "{e}");
        // Frames with their times (as the viewer writes them): the frames are the boundaries,
        // and times more than half a frame off are refused — here frames of a 50 Hz file read
        // as 100 Hz motion frames.
        let both = "sequence,frame,time_s,label,annotator\nd1,200,2,walk,ana\nd1,551,5.51,,ana\n";
        assert_eq!(read("", both, &m).unwrap().frames(), vec![200, 551]);
        let e = read("", "frame,time_s\n200,2.004\n100,2\n", &m).unwrap_err();
        assert_eq!(
            (e.kind(), e.location().line, e.location().field.as_deref()),
            (ErrorKind::Mismatch, Some(3), Some("time_s"))
        );
        assert_eq!(
            read("frame_rate_hz = 50.0", "frame,time_s\n100,2\n", &m).unwrap().frames(),
            vec![200]
        );
    }

    #[test]
    fn segments_give_starts_and_the_last_end_with_labels() {
        let m = motion("d1");
        let csv = "start_frame,end_frame,label\n100,250,step\n250,400.5,turn\n500,600,step\n";
        let s = read("", csv, &m).unwrap();
        assert_eq!(s.frames(), vec![100, 250, 500, 600]);
        assert_eq!(
            s.transitions().iter().map(|t| t.to.as_str()).collect::<Vec<_>>(),
            vec!["turn", "step"]
        );
        assert_eq!(s.segments[1].end, 401);
    }

    #[test]
    fn several_annotators_need_a_choice() {
        let m = motion("d1");
        let csv = "sequence,frame,annotator\nd1,100,ana\nd1,300,ana\nd1,104,ben\n";
        let e = read("", csv, &m).unwrap_err();
        assert_eq!(e.location().field.as_deref(), Some("annotator"));
        assert_eq!(read("annotator = \"ana\"", csv, &m).unwrap().frames(), vec![100, 300]);
        let s = read("consensus = { tolerance = { frames = 5 }, min_votes = 2 }", csv, &m).unwrap();
        assert_eq!(
            s.boundaries,
            vec![motionlab_core::Boundary { frame: 102, window: Some((100, 104)) }]
        );
        let e = build_ground_truth(
            "boundaries_csv",
            &toml::from_str("annotator = \"a\"\nconsensus = {}").unwrap(),
        )
        .err()
        .unwrap();
        assert_eq!(e.location().field.as_deref(), Some("consensus"));
    }

    #[test]
    fn rows_must_name_motion_files_beside_the_motion() {
        let dir =
            std::env::temp_dir().join(format!("motionlab-truth-csv-seq-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for f in ["take1.c3d", "take2.c3d", "notes.txt"] {
            std::fs::write(dir.join(f), b"").unwrap();
        }
        let mut m = motion("take1");
        m.source = Some(dir.join("take1.c3d"));
        let csv = "sequence,frame\ntake1,10\ntake2,20\ntake3,30\n";
        let e = read("", csv, &m).unwrap_err();
        assert_eq!(
            (e.kind(), e.location().line, e.location().field.as_deref()),
            (ErrorKind::UnknownName, Some(4), Some("sequence"))
        );
        assert!(e.to_string().contains("take1, take2"), "{e}");
        assert_eq!(read("check_sequences = false", csv, &m).unwrap().frames(), vec![10]);
    }
}
