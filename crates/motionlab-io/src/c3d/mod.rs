//! The C3D loader plugin `c3d`: marker trajectories, point rate, labels and gait events.
//!
//! ## Why a reader of our own
//!
//! The maintained crate, c3dio 0.8, reads the markers of the shipped files (and gives the
//! same positions: `tests/binary_formats.rs` checks every sample of every shipped C3D), but
//! (a) returns every event time as 0.0 — it takes row 0 of the 2 × N `EVENT:TIMES` array,
//! the minutes — so no stride time can be computed; (b) loads a file cut off inside its data
//! section without an error; (c) panics on some corrupt headers (on 4 of 500 random
//! single-byte corruptions of `walk1.c3d`'s header and parameters). Every parser here is
//! fuzzed for panics and gives an exact error kind and byte offset for every malformed case,
//! which needs control of every read, so the whole reader is here: [`raw`]
//! (header, parameter section, the Intel/DEC/MIPS number formats, data layout) and this file
//! (markers, units, labels, events). c3dio stays a dev-dependency, as the independent reader
//! of the cross-check and in a test that pins (a)–(c).
//!
//! ## Missing samples
//!
//! C3D marks a sample invalid by a negative residual word (the 4th word of each point; in
//! float files a float holding the word's value). The MoCap Toolbox files (`data/mct`) write −1
//! and leave stale coordinates in X, Y, Z, so the residual, not the coordinates, decides. Such
//! samples are flagged in the motion's missing mask and stored as NaN — never dropped, never
//! zero-filled. A few old writers marked gaps as X = Y = Z = 0 instead; none of the shipped
//! files does (checked: no all-zero point in any of them), so exact zeros are data unless
//! `zero_means_missing = true`.

pub mod analog;
pub mod raw;

use std::path::Path;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::units::{Axis, FrameRate, LengthUnit, Seconds};
use motionlab_core::{
    DataKind, Error, ErrorKind, Event, LoadNotes, Loader, Motion, PointKind, Result,
};

use raw::{C3dFile, DataLayout, Param, Processor, Repairs, header_offset};

/// Reads C3D motion-capture files (Vicon, Qualisys, Motion Analysis, …): marker positions,
/// point rate, marker labels and the events of the `EVENT` group.
///
/// What is read: the header (parameter block, point count, first/last frame, scale factor,
/// data start, analog values per frame, frame rate) and every parameter; Intel, DEC (VAX
/// floats) and MIPS (big-endian) files; float storage (scale < 0) and 16-bit integer storage
/// (scale > 0, coordinates × scale). Analog data is skipped when the points are read (its
/// words still set the stride between frames; below: reading them).
/// Rate: `POINT:RATE`, else the header's. Frames: `TRIAL:ACTUAL_START_FIELD`
/// … `ACTUAL_END_FIELD` when present, else header words 4–5. Units: `POINT:UNITS` (`mm`, `cm`,
/// `m`, `in`) converted to mm; absent or blank means mm. Names: `POINT:LABELS`, `LABELS2`,
/// … in order, trimmed; labels beyond the point count are ignored, a blank label becomes
/// `P<n>` (1-based point number), fewer labels than points is an error; a Vicon subject
/// prefix (`Subject:`) is removed unless `strip_subject_prefix = false`.
///
/// The data section's size is checked against the file: the header's account of it (points,
/// analog words per frame, first block: header words 2, 3 and 9) and the parameters'
/// (`POINT:USED`, `ANALOG:USED` × `ANALOG:RATE` / `POINT:RATE`, `POINT:DATA_START`) must hold
/// the frames; when the two differ, the one whose frames end in the file's last 512-byte
/// block is read, and when neither does the file is refused (reading either would shift or
/// cut the frames without a word).
///
/// Read leniently, as ezc3d and py-c3d read them, and always said (each repair is a line of
/// `motionlab inspect` and of the run's provenance): the header's and the parameters'
/// accounts disagreeing (resolved by the file size, above); a label written twice (the later
/// points become `RKNE#2`, `RKNE#3`, …); no `POINT:LABELS` at all (points `P1`…`Pn`); group or
/// parameter names with spaces (`Splines Fitted`); a parameter defined twice (the first is
/// kept); a last parameter record whose next-record offset points past the parameter
/// section (SGI/MIPS writers: read as the last record); a `POINT:UNITS` cut short (`mete`
/// is metres); bytes after the last frame beyond one block's padding (not read). With
/// `strict = true` each of these is an error instead. A processor type other than 84, 85 or
/// 86 (0 in files whose writer never set it) is refused, as ezc3d and py-c3d refuse it.
///
/// Events: `EVENT:LABELS`, `EVENT:CONTEXTS` and `EVENT:TIMES`, a 2 × N array of (minutes,
/// seconds): time = 60·minutes + seconds from the start of the capture, where time 0 is frame
/// number 1. The event's fractional frame index into the loaded frames is therefore
/// `time × rate + 1 − first_frame` (verified on the Schreiber & Moissenet 2019 files: force
/// plate loading starts on average 0.6 frame after a Foot Strike, over 72 plate strikes; an
/// off-by-one convention would give −0.4 or 1.6). Events outside the stored
/// frames are kept, with frame < 0 or ≥ the frame count.
///
/// Missing samples: a negative residual word marks a sample missing (the C3D convention; the
/// stale coordinates such files keep are discarded); it is flagged in the missing mask and
/// stored as NaN, never dropped or zero-filled. A NaN coordinate in a float file (how some
/// writers mark a gap) is missing likewise; an infinite one is an error (`NonFinite`, naming
/// the byte offset, frame and marker). X = Y = Z = 0 is missing only with
/// `zero_means_missing`.
///
/// Errors name the file, the byte offset and the parameter (`POINT:SCALE`): a wrong key byte
/// or parameter block pointer, a file shorter than its frames need (`Truncated`), a data
/// section that fits neither account, a zero or NaN scale factor or rate, last frame < first
/// frame, too few labels, non-UTF-8 labels.
///
/// Analog channels (EMG, force plates, accelerometers, dynamometers): a file with no 3-D
/// point and `ANALOG:USED` > 0 (an EMG system's export) loads as a motion of channels at the
/// analog rate, and with `analog = true` any file does (a marker file's analog channels then
/// feed channel segmenters and the benchmark like a channel file). Names: `ANALOG:LABELS`,
/// `LABELS2`, … (blank → `A<n>`, a repeated label → `EMG#2`, noted); units: `ANALOG:UNITS`,
/// `UNITS2`, …; rate: `ANALOG:RATE`, which must equal the samples per frame × the point rate
/// (when it does not, the data's count wins, noted); values
/// `(word − ANALOG:OFFSET) × ANALOG:SCALE × ANALOG:GEN_SCALE`, words and offsets unsigned when
/// `ANALOG:FORMAT` is `UNSIGNED` (the C3D User Guide's reading, py-c3d's; ezc3d's where the
/// offsets are ≥ 0 and the words signed — every real file shipped). Events keep their times;
/// their frame indices count analog samples.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct C3dParams {
    /// The axis of the file's lab frame that points up (Vicon and Qualisys labs, including
    /// every shipped C3D, are Z-up).
    #[serde(default = "default_up_axis")]
    pub up_axis: Axis,
    /// Treat a point whose X, Y and Z are all exactly 0 as missing (a convention of some old
    /// writers); off, a marker at the lab origin is data.
    #[serde(default)]
    pub zero_means_missing: bool,
    /// Drop a subject prefix from marker labels: Vicon writes `Subject:Marker`, and the subject
    /// name changes between sessions (`vsk2:LFWT` in one file, `vsk:LFWT` in the next), so
    /// one experiment can address markers by their plain names across files. Everything up
    /// to the last `:` is removed; two labels that become equal (two subjects in one file) is
    /// an error naming both — set `false` to keep the prefixes then. No shipped C3D has a
    /// prefix, so their names are unchanged either way.
    #[serde(default = "default_strip_subject_prefix")]
    pub strip_subject_prefix: bool,
    /// Refuse every departure from the C3D letter that is read leniently by default (the
    /// repairs listed above), each with the error naming the file, byte and parameter.
    #[serde(default)]
    pub strict: bool,
    /// Load the analog channels (at the analog rate) instead of the 3-D points, so that a
    /// marker file's EMG or force plates feed channel segmenters and the benchmark. A file
    /// without points loads its analog channels whatever this says.
    #[serde(default)]
    pub analog: bool,
    /// With `analog = true`: the channels to keep, by label, in this order.
    #[serde(default)]
    #[schemars(extend("x-default" = "every analog channel"))]
    pub analog_channels: Option<Vec<String>>,
}

fn default_strip_subject_prefix() -> bool {
    true
}

fn default_up_axis() -> Axis {
    Axis::Z
}

/// Options of [`parse_c3d`] (the checked [`C3dParams`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct C3dOptions {
    pub up_axis: Axis,
    pub zero_means_missing: bool,
    pub strip_subject_prefix: bool,
    pub strict: bool,
    /// Load the analog channels instead of the points.
    pub analog: bool,
}

impl Default for C3dOptions {
    fn default() -> Self {
        C3dOptions {
            up_axis: Axis::Z,
            zero_means_missing: false,
            strip_subject_prefix: true,
            strict: false,
            analog: false,
        }
    }
}

/// The validated loader.
#[derive(Clone, Debug)]
pub struct C3dLoader {
    options: C3dOptions,
    analog_channels: Option<Vec<String>>,
}

impl ParamGuard for C3dParams {
    type Checked = C3dLoader;
    fn check(self) -> Result<C3dLoader> {
        if self.analog_channels.is_some() && !self.analog {
            return Err(Error::new(
                ErrorKind::InvalidParameter,
                "analog_channels picks analog channels, and analog is false: set analog = true",
            )
            .with_field("analog_channels"));
        }
        if self.analog_channels.as_ref().is_some_and(Vec::is_empty) {
            return Err(Error::new(
                ErrorKind::EmptySequence,
                "analog_channels is empty; expected at least one channel label",
            )
            .with_field("analog_channels"));
        }
        Ok(C3dLoader {
            options: C3dOptions {
                up_axis: self.up_axis,
                zero_means_missing: self.zero_means_missing,
                strip_subject_prefix: self.strip_subject_prefix,
                strict: self.strict,
                analog: self.analog,
            },
            analog_channels: self.analog_channels,
        })
    }
}

impl Loader for C3dLoader {
    fn gives(&self) -> DataKind {
        if self.options.analog { DataKind::Channels } else { DataKind::Points }
    }
    fn extensions(&self) -> &'static [&'static str] {
        &["c3d"]
    }
    fn load(&self, path: &Path) -> Result<Motion> {
        let bytes = crate::read::read_bytes(path)?;
        let motion = parse_c3d(&bytes, path, &self.options)?;
        let Some(names) = &self.analog_channels else { return Ok(motion) };
        let kept = motion
            .channels()
            .select(names)
            .map_err(|e| e.in_file(path).under_field("analog_channels"))?;
        let mut out = Motion::from_channels(motion.name.clone(), motion.frame_rate(), kept)?
            .with_source(path, "c3d");
        out.events = motion.events;
        out.load_notes = motion.load_notes;
        Ok(out)
    }
}

motionlab_core::register_plugin!(Loader, C3dParams, "c3d");

/// Parses a whole C3D file held in memory; `origin` names it in errors and in the motion.
pub fn parse_c3d(bytes: &[u8], origin: &Path, options: &C3dOptions) -> Result<Motion> {
    let file = C3dFile::parse_with(bytes, origin, Repairs::new(options.strict))?;
    let layout = file.data_layout()?;
    let mut repairs = file.repairs.clone();
    repairs.notes.extend(layout.repairs.iter().cloned());
    if layout.points == 0 || options.analog {
        return analog_motion(&file, &layout, origin, repairs);
    }
    let rate = frame_rate(&file)?;
    let (unit, unit_from) = units(&file, &mut repairs)?;
    let names = point_names(&file, layout.points, options.strip_subject_prefix, &mut repairs)?;
    let positions = decode_points(
        &file,
        &layout,
        unit.millimetres_per_unit(),
        options.zero_means_missing,
        &names,
    )?;
    let events = events(&file, &layout, rate)?;
    let mut motion = Motion::new(
        crate::read::stem(origin),
        rate,
        options.up_axis,
        PointKind::Marker,
        names,
        positions,
    )
    .map_err(|e| e.in_file(origin))?
    .with_source(origin, "c3d");
    motion.events = events;
    motion.load_notes =
        LoadNotes { length_unit: Some(unit), length_unit_from: unit_from, repairs: repairs.notes };
    Ok(motion)
}

/// The file's analog channels as a motion of channels at the analog rate (no points).
fn analog_motion(
    file: &C3dFile<'_>,
    layout: &DataLayout,
    origin: &Path,
    mut repairs: Repairs,
) -> Result<Motion> {
    let ctx = file.ctx;
    let point_rate = frame_rate(file)?;
    let Some(a) = analog::read(file, layout, point_rate, &mut repairs)? else {
        let what = if layout.points == 0 {
            "no 3-D points and no analog channels"
        } else {
            "no analog channels (analog = true)"
        };
        return Err(ctx
            .err(
                ErrorKind::EmptySequence,
                header_offset::ANALOG_PER_FRAME,
                format!("the file holds {what}; expected at least one marker or ANALOG:USED > 0"),
            )
            .with_field("ANALOG:USED"));
    };
    let events = analog::events_in_samples(events(file, layout, point_rate)?, a.per_frame);
    let mut motion = Motion::from_channels(crate::read::stem(origin), a.rate, a.channels)
        .map_err(|e| e.in_file(origin))?
        .with_source(origin, "c3d");
    motion.events = events;
    motion.load_notes =
        LoadNotes { length_unit: None, length_unit_from: String::new(), repairs: repairs.notes };
    Ok(motion)
}

fn frame_rate(file: &C3dFile<'_>) -> Result<FrameRate> {
    let ctx = file.ctx;
    match file.param("POINT", "RATE") {
        Some(p) => {
            let hz = p.first_float(ctx)?;
            FrameRate::new(hz).map_err(|_| {
                ctx.param_err(ErrorKind::OutOfRange, p, format!("point rate is {hz} Hz; expected a finite rate > 0"))
            })
        }
        None => FrameRate::new(file.header.frame_rate).map_err(|_| {
            ctx.err(
                ErrorKind::OutOfRange,
                header_offset::FRAME_RATE,
                format!("header frame rate is {} Hz and there is no POINT:RATE; expected a finite rate > 0", file.header.frame_rate),
            )
            .with_field("header.frame_rate")
        }),
    }
}

/// The unit of `POINT:UNITS` and how it was read. A name cut short by its writer (`mete`,
/// 4 characters of `metre`) is the unit it begins, noted as a repair.
fn units(file: &C3dFile<'_>, repairs: &mut Repairs) -> Result<(LengthUnit, String)> {
    let Some(p) = file.param("POINT", "UNITS") else {
        return Ok((LengthUnit::Millimetre, "no POINT:UNITS: the C3D default".into()));
    };
    let label = p.strings(file.ctx)?.into_iter().next().unwrap_or_default();
    if label.is_empty() {
        return Ok((LengthUnit::Millimetre, "POINT:UNITS is blank: the C3D default".into()));
    }
    if let Some(unit) = LengthUnit::from_label(&label) {
        return Ok((unit, format!("POINT:UNITS {label:?}")));
    }
    let Some((unit, full)) = unit_by_prefix(&label) else {
        return Err(file.ctx.param_err(
            ErrorKind::OutOfRange,
            p,
            format!("unknown length unit {label:?}; expected mm, cm, m or in"),
        ));
    };
    repairs.make(format!("POINT:UNITS {label:?} read as {full:?} (a unit name cut short)"), || {
        file.ctx.param_err(ErrorKind::OutOfRange, p, format!("length unit {label:?} is a cut-short {full:?}; expected mm, cm, m or in (strict reading)"))
    })?;
    Ok((unit, format!("POINT:UNITS {label:?}, read as {full:?}")))
}

/// The unit whose spelled-out name begins with `label` (at least two letters, and every
/// name it begins naming the same unit).
fn unit_by_prefix(label: &str) -> Option<(LengthUnit, &'static str)> {
    const NAMES: [(&str, LengthUnit); 7] = [
        ("millimetre", LengthUnit::Millimetre),
        ("millimeter", LengthUnit::Millimetre),
        ("centimetre", LengthUnit::Centimetre),
        ("centimeter", LengthUnit::Centimetre),
        ("metre", LengthUnit::Metre),
        ("meter", LengthUnit::Metre),
        ("inches", LengthUnit::Inch),
    ];
    let label = label.trim().to_ascii_lowercase();
    if label.len() < 2 {
        return None;
    }
    let mut hits = NAMES.iter().filter(|(name, _)| name.starts_with(&label));
    let (name, unit) = hits.next()?;
    hits.all(|(_, u)| u == unit).then_some((*unit, *name))
}

/// `POINT:LABELS`, `LABELS2`, `LABELS3`, … concatenated, cut to the point count.
///
/// Repairs (noted; refused when strict): no `POINT:LABELS` at all names the points `P1`…`Pn`;
/// a label written twice becomes unique with `#2`, `#3`, … on its later points (`RKNE`,
/// `RKNE#2`), as several writers' files need (Motion Analysis repeats labels). Two labels
/// that only become equal once subject prefixes are stripped stay an error: renaming them
/// would mix two subjects' markers.
fn point_names(
    file: &C3dFile<'_>,
    n_points: usize,
    strip_subject_prefix: bool,
    repairs: &mut Repairs,
) -> Result<Vec<String>> {
    let ctx = file.ctx;
    let Some(first) = file.param("POINT", "LABELS") else {
        let refuse = || {
            ctx.err(
                ErrorKind::MissingKey,
                header_offset::POINT_COUNT,
                format!("no POINT:LABELS parameter; expected {n_points} marker names"),
            )
            .with_field("POINT:LABELS")
        };
        repairs.make(
            format!("no POINT:LABELS: the {n_points} points are named P1…P{n_points}"),
            refuse,
        )?;
        return Ok((1..=n_points).map(|i| format!("P{i}")).collect());
    };
    let mut labels = first.strings(ctx)?;
    let mut k = 2;
    while labels.len() < n_points {
        match file.param("POINT", &format!("LABELS{k}")) {
            Some(p) => labels.extend(p.strings(ctx)?),
            None => break,
        }
        k += 1;
    }
    if labels.len() < n_points {
        return Err(ctx.param_err(
            ErrorKind::WrongValueCount,
            first,
            format!(
                "{} labels (with LABELS2, …) for {n_points} points; expected one label per point",
                labels.len()
            ),
        ));
    }
    labels.truncate(n_points);
    for (i, l) in labels.iter_mut().enumerate() {
        if l.is_empty() {
            *l = format!("P{}", i + 1);
        }
    }
    let written = labels.clone();
    if strip_subject_prefix {
        for l in labels.iter_mut() {
            if let Some((_, plain)) = l.rsplit_once(':')
                && !plain.trim().is_empty()
            {
                *l = plain.trim().to_string();
            }
        }
    }
    let taken: std::collections::HashSet<String> = labels.iter().cloned().collect();
    let mut first_use: std::collections::HashMap<String, usize> =
        std::collections::HashMap::with_capacity(n_points);
    // label → (its points, 1-based, and the names they got), in the order first repeated.
    let mut renamed: Vec<(String, Vec<(usize, String)>)> = Vec::new();
    let mut used: std::collections::HashSet<String> =
        std::collections::HashSet::with_capacity(n_points);
    for i in 0..n_points {
        let l = labels[i].clone();
        let Some(&j) = first_use.get(&l) else {
            first_use.insert(l.clone(), i);
            used.insert(l);
            continue;
        };
        let duplicate = |hint: String| {
            ctx.param_err(
                ErrorKind::DuplicateName,
                first,
                format!(
                    "label {l:?} names points {} and {}{hint}; expected unique marker names",
                    j + 1,
                    i + 1
                ),
            )
        };
        if written[i] != written[j] {
            return Err(duplicate(format!(
                " once subject prefixes are stripped (written {:?} and {:?}); set strip_subject_prefix = false",
                written[j], written[i]
            )));
        }
        if repairs.is_strict() {
            return Err(duplicate(" (strict reading)".into()));
        }
        let unique = (2..)
            .map(|k| format!("{l}#{k}"))
            .find(|c| !taken.contains(c) && !used.contains(c))
            .unwrap_or_default();
        used.insert(unique.clone());
        match renamed.iter_mut().find(|(name, _)| *name == l) {
            Some((_, points)) => points.push((i + 1, unique.clone())),
            None => renamed.push((l.clone(), vec![(j + 1, l.clone()), (i + 1, unique.clone())])),
        }
        labels[i] = unique;
    }
    if !renamed.is_empty() {
        let each: Vec<String> = renamed
            .iter()
            .map(|(l, points)| {
                let numbers: Vec<String> = points.iter().map(|(p, _)| p.to_string()).collect();
                let names: Vec<&str> = points.iter().map(|(_, n)| n.as_str()).collect();
                format!("{l:?} (points {}) → {}", numbers.join(", "), names.join(", "))
            })
            .collect();
        repairs.notes.push(format!("duplicate point labels made unique: {}", each.join("; ")));
    }
    Ok(labels)
}

/// Reads X, Y, Z and the residual word of every point of every frame; a negative residual
/// (or, with `zero_means_missing`, X = Y = Z = 0, or a NaN coordinate in float storage) gives
/// a NaN sample. An infinite coordinate in a sample the residual calls valid is an error.
fn decode_points(
    file: &C3dFile<'_>,
    layout: &DataLayout,
    mm_per_unit: f64,
    zero_means_missing: bool,
    names: &[String],
) -> Result<Vec<[f64; 3]>> {
    // One monomorphised loop per storage (float/integer × byte order): the per-value match on
    // the processor, taken inside the loop, kept the decoder out of line and cost 3–4× the
    // decode time of dance1 (perf: 82 % of the load in the closure and its caller).
    let scale = layout.scale;
    let words = |point: &[u8], i: usize| {
        [point[4 * i], point[4 * i + 1], point[4 * i + 2], point[4 * i + 3]]
    };
    let halves = |point: &[u8], i: usize| [point[2 * i], point[2 * i + 1]];
    // `!(r >= 0)` also treats a NaN residual as missing.
    match (layout.float, file.processor) {
        (true, Processor::Intel) => {
            decode_points_with(file, layout, mm_per_unit, zero_means_missing, names, 4, |p| {
                let v = |i| f64::from(f32::from_le_bytes(words(p, i)));
                ([v(0), v(1), v(2)], v(3) >= 0.0)
            })
        }
        (true, Processor::Mips) => {
            decode_points_with(file, layout, mm_per_unit, zero_means_missing, names, 4, |p| {
                let v = |i| f64::from(f32::from_be_bytes(words(p, i)));
                ([v(0), v(1), v(2)], v(3) >= 0.0)
            })
        }
        (true, Processor::Dec) => {
            decode_points_with(file, layout, mm_per_unit, zero_means_missing, names, 4, |p| {
                let v = |i| raw::dec_f32(words(p, i));
                ([v(0), v(1), v(2)], v(3) >= 0.0)
            })
        }
        (false, Processor::Mips) => {
            decode_points_with(file, layout, mm_per_unit, zero_means_missing, names, 2, |p| {
                let v = |i| i16::from_be_bytes(halves(p, i));
                (
                    [f64::from(v(0)) * scale, f64::from(v(1)) * scale, f64::from(v(2)) * scale],
                    v(3) >= 0,
                )
            })
        }
        (false, Processor::Intel | Processor::Dec) => {
            decode_points_with(file, layout, mm_per_unit, zero_means_missing, names, 2, |p| {
                let v = |i| i16::from_le_bytes(halves(p, i));
                (
                    [f64::from(v(0)) * scale, f64::from(v(1)) * scale, f64::from(v(2)) * scale],
                    v(3) >= 0,
                )
            })
        }
    }
}

/// The frame loop of [`decode_points`] for one storage: `read_point` decodes one point's four
/// words (`word` bytes each) into its coordinates in file units and whether it is valid.
#[inline(always)]
fn decode_points_with(
    file: &C3dFile<'_>,
    layout: &DataLayout,
    mm_per_unit: f64,
    zero_means_missing: bool,
    names: &[String],
    word: usize,
    read_point: impl Fn(&[u8]) -> ([f64; 3], bool),
) -> Result<Vec<[f64; 3]>> {
    let bytes = file.bytes;
    // `data_layout` checked that every frame fits in `bytes`, so `get` never fails here; it
    // keeps the loop panic-free all the same.
    let out_of_file =
        |at: usize| file.ctx.err(ErrorKind::Truncated, at, "point data past the end of the file");
    let mut positions = Vec::with_capacity(layout.n_frames * layout.points);
    for frame in 0..layout.n_frames {
        let frame_start = layout.start + frame * layout.frame_bytes;
        let frame_bytes = bytes
            .get(frame_start..frame_start + 4 * layout.points * word)
            .ok_or_else(|| out_of_file(frame_start))?;
        for (k, point) in frame_bytes.chunks_exact(4 * word).enumerate() {
            let (xyz, valid) = read_point(point);
            // Only float storage can hold ±inf. No writer's missing-data convention uses it
            // (NaN is sometimes written for missing and becomes a missing sample below), so it
            // is corruption, refused rather than silently dropped.
            if valid && let Some(axis) = xyz.iter().position(|c| c.is_infinite()) {
                let at = frame_start + k * 4 * word + axis * word;
                let label = names.get(k).map_or("?", String::as_str);
                return Err(file
                    .ctx
                    .err(
                        ErrorKind::NonFinite,
                        at,
                        format!(
                            "frame {} marker {label:?}: {} is {}; expected a finite coordinate (a missing sample has a negative residual)",
                            frame + 1,
                            ["X", "Y", "Z"][axis],
                            xyz[axis]
                        ),
                    )
                    .with_field(label.to_string()));
            }
            let zero = zero_means_missing && xyz == [0.0; 3];
            positions.push(if valid && !zero {
                [xyz[0] * mm_per_unit, xyz[1] * mm_per_unit, xyz[2] * mm_per_unit]
            } else {
                [f64::NAN; 3]
            });
        }
    }
    Ok(positions)
}

/// The `EVENT` group as [`Event`]s sorted by time; none when the group is absent.
fn events(file: &C3dFile<'_>, layout: &DataLayout, rate: FrameRate) -> Result<Vec<Event>> {
    let ctx = file.ctx;
    let used =
        file.param("EVENT", "USED").map(|p| p.first_unsigned(ctx)).transpose()?.map(|n| n as usize);
    let Some(times_param) = file.param("EVENT", "TIMES") else {
        return match used {
            Some(n) if n > 0 => Err(ctx
                .err(
                    ErrorKind::MissingKey,
                    0,
                    format!("EVENT:USED is {n} but there is no EVENT:TIMES"),
                )
                .with_field("EVENT:TIMES")),
            _ => Ok(Vec::new()),
        };
    };
    if times_param.dims.first() != Some(&2) && !times_param.is_empty() {
        return Err(ctx.param_err(
            ErrorKind::WrongValueCount,
            times_param,
            format!("dimensions are {:?}; expected 2 × N (minutes, seconds)", times_param.dims),
        ));
    }
    let times = times_param.floats(ctx)?;
    let n = used.unwrap_or(times.len() / 2);
    let have = |p: Option<&Param<'_>>, what: &str| -> Result<Vec<String>> {
        match p {
            Some(p) => {
                let v = p.strings(ctx)?;
                if v.len() < n {
                    return Err(ctx.param_err(
                        ErrorKind::WrongValueCount,
                        p,
                        format!("{} {what} for {n} events (EVENT:USED)", v.len()),
                    ));
                }
                Ok(v)
            }
            None if what == "contexts" => Ok(vec![String::new(); n]),
            None => Err(ctx
                .err(ErrorKind::MissingKey, 0, format!("{n} events but no EVENT:LABELS"))
                .with_field("EVENT:LABELS")),
        }
    };
    if times.len() / 2 < n {
        return Err(ctx.param_err(
            ErrorKind::WrongValueCount,
            times_param,
            format!("{} times for {n} events (EVENT:USED)", times.len() / 2),
        ));
    }
    let labels = have(file.param("EVENT", "LABELS"), "labels")?;
    let contexts = have(file.param("EVENT", "CONTEXTS"), "contexts")?;
    let mut events = Vec::with_capacity(n);
    for i in 0..n {
        let (minutes, seconds) = (times[2 * i], times[2 * i + 1]);
        let t = 60.0 * minutes + seconds;
        if !t.is_finite() {
            return Err(ctx
                .err(
                    ErrorKind::NonFinite,
                    times_param.data_offset + 8 * i,
                    format!(
                        "event {} time is {minutes} min {seconds} s; expected finite numbers",
                        i + 1
                    ),
                )
                .with_field(times_param.key()));
        }
        events.push(Event {
            label: labels[i].clone(),
            context: contexts[i].clone(),
            time: Seconds(t),
            // Time 0 is frame number 1; frame numbers of the stored frames start at first_frame.
            frame: rate.seconds_to_frames(Seconds(t)) + 1.0 - layout.first_frame as f64,
        });
    }
    events.sort_by(|a, b| a.time.0.total_cmp(&b.time.0));
    Ok(events)
}

#[cfg(test)]
mod testfile;

#[cfg(test)]
mod tests;
