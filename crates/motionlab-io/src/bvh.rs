//! BVH (Biovision hierarchy): loader plugin `bvh`, [`parse_bvh`] and [`write_bvh`].
//!
//! A BVH file is a joint hierarchy (`HIERARCHY`: `ROOT`/`JOINT` blocks with an `OFFSET`, a
//! `CHANNELS` line and optional `End Site`s) followed by `MOTION`: `Frames:`, `Frame Time:` and
//! one line of channel values per frame. It maps one-to-one onto the core skeleton model
//! (`motionlab_core::skeleton`) with an identity axis rotation per joint and rotations composed
//! in the order the channels are listed.
//!
//! Written by hand: no maintained BVH crate exists (bvh_anim is abandoned), and the frame
//! section needs the allocation-free number scanner of `text.rs` to reach the throughput in
//! `benches/README.md`.

use std::fmt::Write as _;
use std::io::Write;
use std::path::Path;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::skeleton::ChannelKind;
use motionlab_core::{
    Axis, Error, ErrorKind, FrameRate, Joint, LengthUnit, Loader, Location, Motion, PointKind,
    Result, Skeleton, SkeletonMotion,
};

use crate::text::{NumberLines, Token, Tokens, parse_f64, strip_bom};

/// How the loader decides the unit of OFFSET and position-channel values.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum LengthUnitSetting {
    /// Infer the unit from the skeleton's rest-pose standing height (see the loader's docs).
    #[default]
    Auto,
    Millimetre,
    Centimetre,
    Metre,
    Inch,
    /// 1 unit = 1/0.45 inch = 56.444 mm (CMU data and its BVH conversions).
    CmuUnit,
}

impl LengthUnitSetting {
    /// The explicit unit, or `None` for `auto`.
    pub fn unit(self) -> Option<LengthUnit> {
        match self {
            LengthUnitSetting::Auto => None,
            LengthUnitSetting::Millimetre => Some(LengthUnit::Millimetre),
            LengthUnitSetting::Centimetre => Some(LengthUnit::Centimetre),
            LengthUnitSetting::Metre => Some(LengthUnit::Metre),
            LengthUnitSetting::Inch => Some(LengthUnit::Inch),
            LengthUnitSetting::CmuUnit => Some(LengthUnit::CmuUnit),
        }
    }
}

/// How a joint's position channels combine with its OFFSET.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum PositionChannels {
    /// A position channel is the joint's translation from its parent along its axis; the
    /// OFFSET keeps only the axes without one (the rest pose). How Blender, bvhio and the
    /// exporters people use read and write BVH.
    #[default]
    Replace,
    /// Translation = OFFSET + position channels, the reading of some older tools.
    Add,
}

/// Loads a BVH motion: the joint hierarchy, every frame's channel values, and the world
/// positions of every joint and end site by forward kinematics.
///
/// Points are the joints in file order, then one `<joint>_end` per `End Site`; positions are in
/// mm with `up_axis` up. The skeleton (offsets in mm) and the channel values (positions in mm,
/// rotations in degrees) are kept in `motion.skeleton`.
///
/// Channels: any number per joint (usually 3 or 6), any order of `Xposition Yposition
/// Zposition Xrotation Yrotation Zrotation`; rotations compose in the listed order
/// (`Zrotation Xrotation Yrotation` ⇒ `L = Rz·Rx·Ry`, matrices acting on column vectors).
/// Position channels replace the OFFSET along their axes (`position_channels = "replace"`,
/// as Blender and bvhio read them: a root whose OFFSET is its rest position and whose
/// position channels its motion stands where the channels put it) or add to it (`"add"`).
/// Forward kinematics: `G_j = G_parent·L_j`, `p_j = p_parent + G_parent·t_j`, with `t_j` the
/// translation so formed. Files whose joints with position channels have a zero OFFSET (the
/// CMU conversions: only the root has them) read the same either way. With `replace` the
/// stored skeleton holds 0 for the replaced OFFSET axes, so forward kinematics and the BVH
/// writer see the translation the file means.
///
/// Frame rate: `1 / Frame Time`, except that a frame time within 1e-4 (relative) of `1/n` for a
/// whole number n is taken as exactly n Hz (files round the frame time: `.0083333` → 120 Hz).
///
/// Length unit, `auto`: a standing height h is compared with the height of a 1.2–2.2 m human
/// in each unit: 1.2–2.2 → metres, 21.26–38.98 → CMU units (1/0.45 inch), 47.24–86.61 →
/// inches, 120–220 → centimetres, 1200–2200 → millimetres (the ranges do not overlap). h is,
/// in this order until one falls in a range: the rest pose's extent along `up_axis` (every
/// rotation 0, every joint at its OFFSET; CMU's BVH conversions stand 24.3 units = 1.37 m
/// there, legs splayed 20°), the first frame's extent along `up_axis`, and the rest pose's
/// extent along the axis it is longest on (a skeleton modelled lying along +X). The evidence
/// used is said (`motionlab inspect`); none in range (a child, an animal, a prop, a wrong
/// `up_axis`) is an error giving all three and asking for an explicit `length_unit`.
///
/// Missing samples: BVH has none — every channel of every frame must be a finite number. A frame
/// line with the wrong number of values, a value that is not a number, NaN/inf, fewer frame lines
/// than `Frames:` (or more), or a `Frame Time` ≤ 0 is an error naming the file and line. Empty
/// lines between frames are skipped; CRLF and LF line endings and a UTF-8 BOM load alike.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct BvhParams {
    /// Unit of OFFSET and position-channel values: `"auto"` or one of
    /// `"millimetre"`, `"centimetre"`, `"metre"`, `"inch"`, `"cmu_unit"`.
    #[serde(default)]
    pub length_unit: LengthUnitSetting,
    /// The axis pointing up in the file (the default is the BVH convention).
    #[serde(default = "default_up_axis")]
    pub up_axis: Axis,
    /// How position channels combine with the OFFSET: `"replace"` (Blender, bvhio) or
    /// `"add"`.
    #[serde(default)]
    pub position_channels: PositionChannels,
}

fn default_up_axis() -> Axis {
    Axis::Y
}

/// Options of [`parse_bvh`] (the validated [`BvhParams`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BvhOptions {
    /// `None` = infer from a standing height (see the loader docs).
    pub length_unit: Option<LengthUnit>,
    pub up_axis: Axis,
    pub position_channels: PositionChannels,
}

impl Default for BvhOptions {
    fn default() -> Self {
        BvhOptions {
            length_unit: None,
            up_axis: Axis::Y,
            position_channels: PositionChannels::Replace,
        }
    }
}

/// The validated loader.
#[derive(Clone, Debug)]
pub struct BvhLoader {
    options: BvhOptions,
}

impl ParamGuard for BvhParams {
    type Checked = BvhLoader;
    fn check(self) -> Result<BvhLoader> {
        Ok(BvhLoader {
            options: BvhOptions {
                length_unit: self.length_unit.unit(),
                up_axis: self.up_axis,
                position_channels: self.position_channels,
            },
        })
    }
}

impl Loader for BvhLoader {
    fn extensions(&self) -> &'static [&'static str] {
        &["bvh"]
    }
    fn load(&self, path: &Path) -> Result<Motion> {
        let text = crate::read::read_text(path)?;
        parse_bvh(&text, path, &self.options)
    }
}

motionlab_core::register_plugin!(Loader, BvhParams, "bvh");

/// A parsed BVH file before forward kinematics.
#[derive(Clone, Debug)]
pub struct BvhData {
    /// Skeleton in mm and channel values (positions mm, rotations degrees).
    pub motion: SkeletonMotion,
    pub frame_rate: FrameRate,
    /// The `Frame Time:` value as written, seconds.
    pub frame_time_s: f64,
    /// The unit the file's lengths were read in (given or inferred).
    pub length_unit: LengthUnit,
    /// How `length_unit` was known: the loader's setting, or the evidence `auto` used.
    pub length_unit_from: String,
}

/// Parses BVH text into a [`Motion`] with joint positions (mm) and its skeleton.
///
/// `origin` names the file in error messages and becomes `motion.source`; the motion's name is
/// its stem. This is what the `bvh` loader calls after reading (and decompressing) the file.
pub fn parse_bvh(text: &str, origin: &Path, options: &BvhOptions) -> Result<Motion> {
    let data = parse_bvh_channels(text, origin, options)?;
    bvh_motion(data, origin, options.up_axis)
}

/// Turns parsed channels into a [`Motion`] by forward kinematics (the second half of
/// [`parse_bvh`], separate so its cost can be measured on its own).
pub fn bvh_motion(data: BvhData, origin: &Path, up_axis: Axis) -> Result<Motion> {
    let positions = data.motion.positions();
    let names = data.motion.skeleton.point_names();
    let mut motion = Motion::new(
        crate::read::stem(origin),
        data.frame_rate,
        up_axis,
        PointKind::Joint,
        names,
        positions,
    )
    .map_err(|e| e.in_file(origin))?
    .with_source(origin, "bvh");
    motion.skeleton = Some(data.motion);
    motion.load_notes.length_unit = Some(data.length_unit);
    motion.load_notes.length_unit_from = data.length_unit_from;
    Ok(motion)
}

/// Parses BVH text into its skeleton and channel values, without forward kinematics.
pub fn parse_bvh_channels(text: &str, origin: &Path, options: &BvhOptions) -> Result<BvhData> {
    let text = strip_bom(text);
    let header = parse_header(text, origin)?;
    let Header { mut skeleton, n_frames, frame_time, frame_rate, data_pos, data_line } = header;
    let is_translation: Vec<bool> = skeleton
        .joints
        .iter()
        .flat_map(|j| j.channels.iter())
        .map(|c| matches!(c, ChannelKind::Translation(_)))
        .collect();
    let read =
        |scale: &[f64]| read_frames(text.as_bytes(), data_pos, data_line, n_frames, scale, origin);

    // The unit, and the frames when inferring it needed them (read in file units).
    let (length_unit, length_unit_from, file_unit_values) = match options.length_unit {
        Some(u) => {
            (u, format!("length_unit = \"{}\" (loader setting)", unit_setting_name(u)), None)
        }
        None => {
            let rest = UnitEvidence::RestPoseHeight(
                options.up_axis,
                rest_pose_height(&skeleton, options.up_axis),
            );
            match rest.unit() {
                Some(u) => (u, format!("inferred from {rest}"), None),
                None => {
                    let values = read(&vec![1.0; is_translation.len()])?;
                    let posed =
                        with_position_convention(skeleton.clone(), options.position_channels);
                    let first = UnitEvidence::FirstFrameHeight(
                        options.up_axis,
                        first_frame_height(&posed, &values, options.up_axis),
                    );
                    let (axis, extent) = rest_pose_longest_extent(&skeleton);
                    let lying = UnitEvidence::RestPoseExtent(axis, extent);
                    match [first, lying].into_iter().find_map(|e| e.unit().map(|u| (u, e))) {
                        Some((u, e)) => (
                            u,
                            format!(
                                "inferred from {e} (rest pose: {} units tall along {})",
                                fmt_units(rest.height()),
                                options.up_axis
                            ),
                            Some(values),
                        ),
                        None => {
                            return Err(cannot_infer(&[rest, first, lying])
                                .with_location(Location::file(origin)));
                        }
                    }
                }
            }
        }
    };
    let mm = length_unit.millimetres_per_unit();
    for j in &mut skeleton.joints {
        j.offset = j.offset.map(|c| c * mm);
        for e in &mut j.end_sites {
            *e = e.map(|c| c * mm);
        }
    }
    let skeleton = with_position_convention(skeleton, options.position_channels);
    let values = match file_unit_values {
        // `v × 1.0 × mm` is `v × mm` exactly: the same bits as scaling while reading.
        Some(mut values) => {
            let c = is_translation.len();
            for (k, v) in values.iter_mut().enumerate() {
                if is_translation[k % c] {
                    *v *= mm;
                }
            }
            values
        }
        None => {
            read(&is_translation.iter().map(|t| if *t { mm } else { 1.0 }).collect::<Vec<f64>>())?
        }
    };
    let n_channels = is_translation.len();
    let motion = SkeletonMotion::new(skeleton, values).map_err(|e| e.in_file(origin))?;
    debug_assert_eq!(motion.n_channels(), n_channels);
    Ok(BvhData { motion, frame_rate, frame_time_s: frame_time, length_unit, length_unit_from })
}

/// With `Replace`, zeroes each OFFSET axis that a position channel of the same joint drives:
/// forward kinematics (`offset + translation`) then gives the channel value alone there.
fn with_position_convention(mut skeleton: Skeleton, convention: PositionChannels) -> Skeleton {
    if convention == PositionChannels::Replace {
        for j in &mut skeleton.joints {
            for c in &j.channels {
                if let ChannelKind::Translation(a) = c {
                    j.offset[a.index()] = 0.0;
                }
            }
        }
    }
    skeleton
}

/// The extent along `up` of the first frame's joints and end sites.
fn first_frame_height(skeleton: &Skeleton, values: &[f64], up: Axis) -> f64 {
    let n = skeleton.n_channels();
    let (points, _) = skeleton.forward_kinematics(values.get(..n).unwrap_or(&[]));
    extent(&points, up.index())
}

fn extent(points: &[[f64; 3]], axis: usize) -> f64 {
    let (lo, hi) = points
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| (lo.min(p[axis]), hi.max(p[axis])));
    hi - lo
}

/// The axis the rest pose extends most along, and that extent.
fn rest_pose_longest_extent(skeleton: &Skeleton) -> (Axis, f64) {
    let (points, _) = skeleton.forward_kinematics(&vec![0.0; skeleton.n_channels()]);
    [Axis::X, Axis::Y, Axis::Z]
        .into_iter()
        .map(|a| (a, extent(&points, a.index())))
        .fold((Axis::Y, f64::NEG_INFINITY), |best, e| if e.1 > best.1 { e } else { best })
}

/// A standing height `auto` can infer the length unit from, in file units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum UnitEvidence {
    /// The rest pose's extent along the up axis.
    RestPoseHeight(Axis, f64),
    /// The first frame's extent along the up axis.
    FirstFrameHeight(Axis, f64),
    /// The rest pose's extent along the axis it is longest on.
    RestPoseExtent(Axis, f64),
}

impl UnitEvidence {
    pub fn height(self) -> f64 {
        match self {
            UnitEvidence::RestPoseHeight(_, h)
            | UnitEvidence::FirstFrameHeight(_, h)
            | UnitEvidence::RestPoseExtent(_, h) => h,
        }
    }
    /// The unit in whose human height range the height lies.
    pub fn unit(self) -> Option<LengthUnit> {
        let h = self.height();
        INFERABLE_UNITS.iter().copied().find(|u| {
            let (lo, hi) = human_height_range(*u);
            (lo..=hi).contains(&h)
        })
    }
}

impl std::fmt::Display for UnitEvidence {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            UnitEvidence::RestPoseHeight(a, h) => {
                write!(f, "the rest pose: {} units tall along {a}", fmt_units(*h))
            }
            UnitEvidence::FirstFrameHeight(a, h) => {
                write!(f, "the first frame: {} units tall along {a}", fmt_units(*h))
            }
            UnitEvidence::RestPoseExtent(a, h) => {
                write!(f, "the rest pose's longest extent: {} units along {a}", fmt_units(*h))
            }
        }
    }
}

fn fmt_units(h: f64) -> String {
    format!("{h:.4}").trim_end_matches('0').trim_end_matches('.').to_string()
}

/// The `length_unit` setting that names `unit`.
fn unit_setting_name(unit: LengthUnit) -> &'static str {
    match unit {
        LengthUnit::Millimetre => "millimetre",
        LengthUnit::Centimetre => "centimetre",
        LengthUnit::Metre => "metre",
        LengthUnit::Inch => "inch",
        LengthUnit::CmuUnit => "cmu_unit",
    }
}

fn cannot_infer(evidence: &[UnitEvidence]) -> Error {
    let ranges: Vec<String> = INFERABLE_UNITS
        .iter()
        .map(|u| {
            let (lo, hi) = human_height_range(*u);
            format!("{u:?} {lo:.4}–{hi:.4}")
        })
        .collect();
    let seen: Vec<String> = evidence.iter().map(ToString::to_string).collect();
    Error::new(
        ErrorKind::OutOfRange,
        format!(
            "cannot infer the length unit: {}; none is within the range of a 1.2–2.2 m human in any unit ({}); set length_unit explicitly",
            seen.join(", "),
            ranges.join(", ")
        ),
    )
    .with_field("length_unit")
}

/// Reads `n_frames` lines of `scale.len()` values each, starting at byte `pos` (line `line`).
fn read_frames(
    bytes: &[u8],
    pos: usize,
    line: usize,
    n_frames: usize,
    scale: &[f64],
    origin: &Path,
) -> Result<Vec<f64>> {
    let c = scale.len();
    // Every value takes at least two bytes (a digit and a separator), so a `Frames:` count the
    // rest of the file cannot hold is not allocated up front: it fails as truncated below.
    let fits = (bytes.len().saturating_sub(pos) / (2 * c)).saturating_add(1);
    let mut values: Vec<f64> = Vec::with_capacity(n_frames.min(fits) * c);
    let mut cursor = NumberLines::new(bytes, pos, line, origin);
    for f in 0..n_frames {
        if !cursor.skip_empty_lines() {
            return Err(Error::at_line(
                ErrorKind::Truncated,
                origin,
                cursor.line(),
                format!("file ends after {f} frame lines; MOTION declares Frames: {n_frames}"),
            ));
        }
        let start = values.len();
        values.resize(start + c, 0.0);
        let got = cursor.read_line(&mut values[start..], scale, || format!("frame {}", f + 1))?;
        if got.count != c {
            return Err(Error::at_line(
                ErrorKind::WrongValueCount,
                origin,
                got.line,
                format!(
                    "frame {}: found {} values, expected {c} (one per channel of the hierarchy)",
                    f + 1,
                    got.count
                ),
            ));
        }
    }
    if cursor.skip_empty_lines() {
        return Err(Error::at_line(
            ErrorKind::WrongValueCount,
            origin,
            cursor.line(),
            format!("more frame lines than the {n_frames} that MOTION declares in Frames:"),
        ));
    }
    Ok(values)
}

struct Header {
    /// Offsets and end sites in file units.
    skeleton: Skeleton,
    n_frames: usize,
    frame_time: f64,
    frame_rate: FrameRate,
    data_pos: usize,
    data_line: usize,
}

fn syntax(origin: &Path, line: usize, msg: impl Into<String>) -> Error {
    Error::at_line(ErrorKind::Syntax, origin, line, msg)
}

/// Where the header scanner is, for "file ends inside …" messages.
fn truncated(origin: &Path, toks: &Tokens<'_>, inside: &str, expected: &str) -> Error {
    Error::at_line(
        ErrorKind::Truncated,
        origin,
        toks.line(),
        format!("file ends inside {inside}; expected {expected}"),
    )
}

fn parse_header(text: &str, origin: &Path) -> Result<Header> {
    let mut toks = Tokens::new(text, false);
    match toks.next_token() {
        Some(t) if t.text.eq_ignore_ascii_case("HIERARCHY") => {}
        Some(t) => {
            return Err(syntax(
                origin,
                t.line,
                format!("expected HIERARCHY at the start of a BVH file, found {:?}", t.text),
            ));
        }
        None => {
            return Err(Error::at_line(
                ErrorKind::Truncated,
                origin,
                1,
                "empty file; expected a BVH HIERARCHY",
            ));
        }
    }
    let mut joints: Vec<Joint> = Vec::new();
    let mut declared: std::collections::HashMap<String, usize> = std::collections::HashMap::new();
    loop {
        let Some(t) = toks.next_token() else {
            return Err(truncated(origin, &toks, "HIERARCHY", "ROOT or MOTION"));
        };
        if t.text.eq_ignore_ascii_case("ROOT") {
            parse_joint_tree(&mut toks, t, origin, &mut joints, &mut declared)?;
        } else if t.text.eq_ignore_ascii_case("MOTION") {
            break;
        } else {
            return Err(syntax(
                origin,
                t.line,
                format!("expected ROOT or MOTION, found {:?}", t.text),
            ));
        }
    }
    if joints.is_empty() {
        return Err(syntax(origin, toks.line(), "HIERARCHY declares no ROOT joint"));
    }
    let skeleton = Skeleton { joints };
    if skeleton.n_channels() == 0 {
        return Err(syntax(
            origin,
            toks.line(),
            "HIERARCHY declares no CHANNELS; expected at least one channel",
        ));
    }

    // Frames: N
    let t =
        toks.next_token().ok_or_else(|| truncated(origin, &toks, "MOTION", "Frames: <count>"))?;
    let count_tok = keyword_value(&mut toks, t, "Frames:", origin)?;
    let n_frames: usize = count_tok.text.parse().map_err(|_| {
        syntax(
            origin,
            count_tok.line,
            format!("Frames: is {:?}, expected a whole number of frames", count_tok.text),
        )
    })?;
    if n_frames == 0 {
        return Err(Error::at_line(
            ErrorKind::EmptySequence,
            origin,
            count_tok.line,
            "Frames: 0; expected at least one frame",
        ));
    }
    // Frame Time: t
    let t = toks
        .next_token()
        .ok_or_else(|| truncated(origin, &toks, "MOTION", "Frame Time: <seconds>"))?;
    if !t.text.eq_ignore_ascii_case("Frame") {
        return Err(syntax(
            origin,
            t.line,
            format!("expected \"Frame Time:\", found {:?}", t.text),
        ));
    }
    let t = toks
        .next_token()
        .ok_or_else(|| truncated(origin, &toks, "MOTION", "Frame Time: <seconds>"))?;
    let time_tok = keyword_value(&mut toks, t, "Time:", origin)?;
    let frame_time = parse_f64(time_tok, origin, "Frame Time")?;
    let frame_rate = frame_rate_from_time(frame_time)
        .map_err(|e| e.with_location(Location::file(origin).line(time_tok.line)))?;
    let extra = toks.rest_of_line();
    if let Some(x) = extra.first() {
        return Err(syntax(
            origin,
            x.line,
            format!("unexpected {:?} after Frame Time; expected the end of the line", x.text),
        ));
    }
    Ok(Header {
        skeleton,
        n_frames,
        frame_time,
        frame_rate,
        data_pos: toks.pos(),
        data_line: toks.line(),
    })
}

/// `Frames: 994` or `Frames:994` (and `Time: 0.008` likewise): returns the value token.
fn keyword_value<'a>(
    toks: &mut Tokens<'a>,
    t: Token<'a>,
    keyword: &str,
    origin: &Path,
) -> Result<Token<'a>> {
    let k = keyword.len();
    // Byte comparison: the first k bytes matching an ASCII keyword makes k a char boundary.
    if t.text.len() >= k && t.text.as_bytes()[..k].eq_ignore_ascii_case(keyword.as_bytes()) {
        if t.text.len() > k {
            return Ok(Token { text: &t.text[k..], line: t.line });
        }
        return toks
            .next_token()
            .ok_or_else(|| truncated(origin, toks, "MOTION", &format!("a value after {keyword}")));
    }
    Err(syntax(origin, t.line, format!("expected {keyword:?}, found {:?}", t.text)))
}

/// `1 / frame_time`, snapped to a whole rate when within 1e-4 relative (see the loader docs).
pub fn frame_rate_from_time(frame_time: f64) -> Result<FrameRate> {
    if frame_time.is_nan() || frame_time <= 0.0 || frame_time.is_infinite() {
        return Err(Error::new(
            ErrorKind::OutOfRange,
            format!("Frame Time is {frame_time}; expected a time > 0 s"),
        ));
    }
    let rate = 1.0 / frame_time;
    let whole = rate.round();
    if whole >= 1.0 && (frame_time * whole - 1.0).abs() <= 1e-4 {
        FrameRate::new(whole)
    } else {
        FrameRate::new(rate)
    }
}

/// Parses one `ROOT name { … }` tree (the ROOT token already consumed), appending joints in
/// file order. Iterative so a deeply nested (or malicious) file cannot overflow the stack.
fn parse_joint_tree<'a>(
    toks: &mut Tokens<'a>,
    root_tok: Token<'a>,
    origin: &Path,
    joints: &mut Vec<Joint>,
    declared: &mut std::collections::HashMap<String, usize>,
) -> Result<()> {
    // Open joints: (index, line of its name, whether OFFSET was seen).
    let mut stack: Vec<(usize, usize, bool)> = Vec::new();
    open_joint(toks, root_tok, None, origin, joints, declared, &mut stack)?;
    while let Some(&(top, opened_at, _)) = stack.last() {
        let inside = || format!("joint {:?} (opened at line {opened_at})", joints[top].name);
        let Some(t) = toks.next_token() else {
            return Err(truncated(
                origin,
                toks,
                &inside(),
                "OFFSET, CHANNELS, JOINT, End Site or '}'",
            ));
        };
        let word = t.text;
        if word.eq_ignore_ascii_case("OFFSET") {
            joints[top].offset = read_offset(toks, origin, &inside())?;
            if let Some(s) = stack.last_mut() {
                s.2 = true;
            }
        } else if word.eq_ignore_ascii_case("CHANNELS") {
            let channels = read_channels(toks, origin, &inside())?;
            let name = joints[top].name.clone();
            let parent = joints[top].parent;
            let offset = joints[top].offset;
            let end_sites = std::mem::take(&mut joints[top].end_sites);
            joints[top] = Joint::new(name, parent, offset, channels);
            joints[top].end_sites = end_sites;
        } else if word.eq_ignore_ascii_case("JOINT") {
            open_joint(toks, t, Some(top), origin, joints, declared, &mut stack)?;
        } else if word.eq_ignore_ascii_case("End") || word.eq_ignore_ascii_case("EndSite") {
            if word.eq_ignore_ascii_case("End") {
                match toks.next_token() {
                    Some(s) if s.text.eq_ignore_ascii_case("Site") => {}
                    Some(s) => {
                        return Err(syntax(
                            origin,
                            s.line,
                            format!("expected \"End Site\", found \"End {}\"", s.text),
                        ));
                    }
                    None => return Err(truncated(origin, toks, &inside(), "End Site")),
                }
            }
            let site = format!("the End Site of {}", inside());
            expect_brace(toks, "{", origin, &site)?;
            match toks.next_token() {
                Some(o) if o.text.eq_ignore_ascii_case("OFFSET") => {}
                Some(o) => {
                    return Err(syntax(
                        origin,
                        o.line,
                        format!("expected OFFSET in {site}, found {:?}", o.text),
                    ));
                }
                None => return Err(truncated(origin, toks, &site, "OFFSET")),
            }
            let e = read_offset(toks, origin, &site)?;
            joints[top].end_sites.push(e);
            expect_brace(toks, "}", origin, &site)?;
        } else if word == "}" {
            if !stack.last().is_some_and(|s| s.2) {
                return Err(syntax(
                    origin,
                    t.line,
                    format!("{} has no OFFSET; expected OFFSET x y z", inside()),
                ));
            }
            stack.pop();
        } else {
            return Err(syntax(
                origin,
                t.line,
                format!(
                    "expected OFFSET, CHANNELS, JOINT, End Site or '}}' in {}, found {:?}",
                    inside(),
                    word
                ),
            ));
        }
    }
    Ok(())
}

fn expect_brace(toks: &mut Tokens<'_>, brace: &str, origin: &Path, inside: &str) -> Result<()> {
    match toks.next_token() {
        Some(b) if b.text == brace => Ok(()),
        Some(b) => Err(syntax(
            origin,
            b.line,
            format!("expected '{brace}' in {inside}, found {:?}", b.text),
        )),
        None => Err(truncated(origin, toks, inside, &format!("'{brace}'"))),
    }
}

/// Reads `name [{]` after ROOT/JOINT and pushes the new joint. The name is the rest of the line
/// (names with spaces occur in the wild); a `{` on the same line opens the block.
fn open_joint<'a>(
    toks: &mut Tokens<'a>,
    keyword: Token<'a>,
    parent: Option<usize>,
    origin: &Path,
    joints: &mut Vec<Joint>,
    declared: &mut std::collections::HashMap<String, usize>,
    stack: &mut Vec<(usize, usize, bool)>,
) -> Result<()> {
    let mut words = toks.rest_of_line();
    let brace_on_line = words.last().is_some_and(|w| w.text == "{");
    if brace_on_line {
        words.pop();
    }
    if words.is_empty() {
        return Err(syntax(
            origin,
            keyword.line,
            format!("{} without a name; expected {} <name>", keyword.text, keyword.text),
        ));
    }
    let name = words.iter().map(|w| w.text).collect::<Vec<_>>().join(" ");
    if let Some(first) = declared.get(&name) {
        return Err(Error::at_line(
            ErrorKind::DuplicateName,
            origin,
            keyword.line,
            format!(
                "joint {name:?} is already declared at line {first}; joint names must be unique"
            ),
        ));
    }
    if !brace_on_line {
        expect_brace(toks, "{", origin, &format!("joint {name:?}"))?;
    }
    declared.insert(name.clone(), keyword.line);
    joints.push(Joint::new(name, parent, [0.0; 3], Vec::new()));
    stack.push((joints.len() - 1, keyword.line, false));
    Ok(())
}

fn read_offset(toks: &mut Tokens<'_>, origin: &Path, inside: &str) -> Result<[f64; 3]> {
    let mut out = [0.0; 3];
    for (k, slot) in out.iter_mut().enumerate() {
        let t = toks
            .next_token()
            .ok_or_else(|| truncated(origin, toks, inside, "three OFFSET values"))?;
        *slot = parse_f64(t, origin, &format!("OFFSET value {} of {inside}", k + 1))?;
    }
    Ok(out)
}

fn read_channels(toks: &mut Tokens<'_>, origin: &Path, inside: &str) -> Result<Vec<ChannelKind>> {
    let n_tok = toks
        .next_token()
        .ok_or_else(|| truncated(origin, toks, inside, "a channel count after CHANNELS"))?;
    let n: usize = n_tok.text.parse().ok().filter(|n| *n <= 6).ok_or_else(|| {
        syntax(origin, n_tok.line, format!("CHANNELS count is {:?}, expected 0 to 6", n_tok.text))
    })?;
    let mut channels = Vec::with_capacity(n);
    for _ in 0..n {
        let t = toks
            .next_token()
            .ok_or_else(|| truncated(origin, toks, inside, &format!("{n} channel names")))?;
        let kind = channel_kind(t.text).ok_or_else(|| {
            syntax(origin, t.line, format!("channel {:?} in {inside}; expected one of Xposition Yposition Zposition Xrotation Yrotation Zrotation", t.text))
        })?;
        if channels.contains(&kind) {
            return Err(Error::at_line(
                ErrorKind::DuplicateName,
                origin,
                t.line,
                format!("channel {} is listed twice in {inside}", kind.bvh_name()),
            ));
        }
        channels.push(kind);
    }
    Ok(channels)
}

fn channel_kind(word: &str) -> Option<ChannelKind> {
    let w = word.to_ascii_lowercase();
    let axis = match w.as_bytes().first()? {
        b'x' => Axis::X,
        b'y' => Axis::Y,
        b'z' => Axis::Z,
        _ => return None,
    };
    match &w[1..] {
        "position" => Some(ChannelKind::Translation(axis)),
        "rotation" => Some(ChannelKind::Rotation(axis)),
        _ => None,
    }
}

/// Standing height of a skeleton's rest pose (every channel 0), in its own units: the extent
/// along `up` of all rest-pose points (joints and end sites), from the lowest (a toe) to the
/// highest (the top of the head).
pub fn rest_pose_height(skeleton: &Skeleton, up: Axis) -> f64 {
    let zeros = vec![0.0; skeleton.n_channels()];
    let (points, _) = skeleton.forward_kinematics(&zeros);
    extent(&points, up.index())
}

/// Human standing heights `auto` accepts: 1.2 m to 2.2 m.
pub const HUMAN_HEIGHT_MM: (f64, f64) = (1200.0, 2200.0);

/// The units `auto` can infer, in increasing size of their height range in file units; the
/// ranges (`HUMAN_HEIGHT_MM` expressed in each unit) do not overlap.
pub const INFERABLE_UNITS: [LengthUnit; 5] = [
    LengthUnit::Metre,
    LengthUnit::CmuUnit,
    LengthUnit::Inch,
    LengthUnit::Centimetre,
    LengthUnit::Millimetre,
];

/// The rest-pose height range of a human in `unit` (file units).
pub fn human_height_range(unit: LengthUnit) -> (f64, f64) {
    let mm = unit.millimetres_per_unit();
    (HUMAN_HEIGHT_MM.0 / mm, HUMAN_HEIGHT_MM.1 / mm)
}

/// Infers the length unit from [`rest_pose_height`] alone (see the loader docs for the
/// ranges; the loader also tries the first frame and the rest pose's longest extent).
pub fn infer_length_unit(skeleton: &Skeleton, up: Axis) -> Result<LengthUnit> {
    let rest = UnitEvidence::RestPoseHeight(up, rest_pose_height(skeleton, up));
    rest.unit().ok_or_else(|| cannot_infer(&[rest]))
}

// ---------------------------------------------------------------------------------------------
// Writer
// ---------------------------------------------------------------------------------------------

/// How one joint's channels are written.
enum WritePlan {
    /// Channels as stored, rotations permuted into `rotation_order` (exact).
    Direct { translations: Vec<(usize, ChannelKind)>, rotations: Vec<(usize, ChannelKind)> },
    /// A joint with an axis rotation C (ASF): its local rotation `C·R·C⁻¹` is written as
    /// `Zrotation Yrotation Xrotation` Euler angles.
    Baked { translations: Vec<(usize, ChannelKind)>, first_channel: usize },
}

/// Writes a skeleton motion as BVH: lengths in `length_unit`, rotations in degrees, values with
/// six decimals (1e-6 of a unit / degree), `Frame Time` = 1 / `frame_rate` in full precision.
///
/// Joints are written depth-first (children in index order) with their end sites as `End
/// Site`s, so re-reading gives the same points. A joint without an axis rotation keeps its
/// channels; its rotation channels are listed in its rotation order (BVH composes in listed
/// order), which is exact. A joint with an axis rotation C (from ASF) has no BVH equivalent
/// channel-for-channel; its local rotation `C·R·C⁻¹` is written as `Zrotation Yrotation
/// Xrotation`, which reproduces the same positions. Non-finite values are refused
/// (`NonFinite`).
pub fn write_bvh(
    motion: &SkeletonMotion,
    frame_rate: FrameRate,
    length_unit: LengthUnit,
    out: &mut impl Write,
) -> Result<()> {
    let skeleton = &motion.skeleton;
    skeleton.validate()?;
    let per_mm = 1.0 / length_unit.millimetres_per_unit();
    let n = skeleton.joints.len();
    let mut children: Vec<Vec<usize>> = vec![Vec::new(); n];
    for (i, j) in skeleton.joints.iter().enumerate() {
        if let Some(p) = j.parent {
            children[p].push(i);
        }
    }
    let mut first_channel = Vec::with_capacity(n);
    let mut at = 0;
    for j in &skeleton.joints {
        first_channel.push(at);
        at += j.channels.len();
    }
    let plans: Vec<WritePlan> = skeleton
        .joints
        .iter()
        .enumerate()
        .map(|(i, j)| {
            let translations: Vec<(usize, ChannelKind)> = j
                .channels
                .iter()
                .enumerate()
                .filter(|(_, c)| matches!(c, ChannelKind::Translation(_)))
                .map(|(k, c)| (first_channel[i] + k, *c))
                .collect();
            let has_rotation = j.channels.iter().any(|c| matches!(c, ChannelKind::Rotation(_)));
            if has_rotation && j.axis.angle() != 0.0 {
                WritePlan::Baked { translations, first_channel: first_channel[i] }
            } else {
                let rotations = j
                    .rotation_order
                    .iter()
                    .filter_map(|a| {
                        j.channels
                            .iter()
                            .position(|c| *c == ChannelKind::Rotation(*a))
                            .map(|k| (first_channel[i] + k, ChannelKind::Rotation(*a)))
                    })
                    .collect();
                WritePlan::Direct { translations, rotations }
            }
        })
        .collect();

    let mut head = String::from("HIERARCHY\n");
    // Depth-first order of the joints as written (frame values follow it).
    let mut order = Vec::with_capacity(n);
    for root in (0..n).filter(|&i| skeleton.joints[i].parent.is_none()) {
        // Stack of (joint, next child to visit).
        let mut stack: Vec<(usize, usize)> = vec![(root, 0)];
        write_joint_open(&mut head, skeleton, root, &plans[root], 0, per_mm);
        order.push(root);
        while let Some(&mut (j, ref mut next)) = stack.last_mut() {
            if let Some(&c) = children[j].get(*next) {
                *next += 1;
                write_joint_open(&mut head, skeleton, c, &plans[c], stack.len(), per_mm);
                order.push(c);
                stack.push((c, 0));
            } else {
                let depth = stack.len() - 1;
                let indent = "\t".repeat(depth);
                for e in &skeleton.joints[j].end_sites {
                    let _ = writeln!(head, "{indent}\tEnd Site\n{indent}\t{{");
                    let _ = writeln!(
                        head,
                        "{indent}\t\tOFFSET {:.6} {:.6} {:.6}",
                        e[0] * per_mm,
                        e[1] * per_mm,
                        e[2] * per_mm
                    );
                    let _ = writeln!(head, "{indent}\t}}");
                }
                let _ = writeln!(head, "{indent}}}");
                stack.pop();
            }
        }
    }
    let _ = writeln!(
        head,
        "MOTION\nFrames: {}\nFrame Time: {}",
        motion.n_frames(),
        frame_rate.frame_period().value()
    );
    let io = |e: std::io::Error| Error::new(ErrorKind::Io, format!("cannot write BVH: {e}"));
    out.write_all(head.as_bytes()).map_err(io)?;

    let names = skeleton.channel_names();
    let mut line = String::with_capacity(16 * skeleton.n_channels());
    for f in 0..motion.n_frames() {
        line.clear();
        let values = motion.frame_values(f);
        for &j in &order {
            let mut put = |v: f64, k: Option<usize>| -> Result<()> {
                if !v.is_finite() {
                    let what =
                        k.map_or_else(|| skeleton.joints[j].name.clone(), |k| names[k].clone());
                    return Err(Error::new(
                        ErrorKind::NonFinite,
                        format!("frame {f}: {what} is {v}; BVH needs finite values"),
                    )
                    .with_field(what));
                }
                if !line.is_empty() {
                    line.push(' ');
                }
                let _ = write!(line, "{v:.6}");
                Ok(())
            };
            match &plans[j] {
                WritePlan::Direct { translations, rotations } => {
                    for &(k, _) in translations {
                        put(values[k] * per_mm, Some(k))?;
                    }
                    for &(k, _) in rotations {
                        put(values[k], Some(k))?;
                    }
                }
                WritePlan::Baked { translations, first_channel } => {
                    for &(k, _) in translations {
                        put(values[k] * per_mm, Some(k))?;
                    }
                    let nc = skeleton.joints[j].channels.len();
                    let local =
                        skeleton.local_rotation(j, &values[*first_channel..*first_channel + nc]);
                    // nalgebra: euler_angles() = (roll, pitch, yaw) with R = Rz(yaw)·Ry(pitch)·Rx(roll).
                    let (x, y, z) = local.euler_angles();
                    put(z.to_degrees(), None)?;
                    put(y.to_degrees(), None)?;
                    put(x.to_degrees(), None)?;
                }
            }
        }
        line.push('\n');
        out.write_all(line.as_bytes()).map_err(io)?;
    }
    out.flush().map_err(io)
}

fn write_joint_open(
    head: &mut String,
    skeleton: &Skeleton,
    j: usize,
    plan: &WritePlan,
    depth: usize,
    per_mm: f64,
) {
    let joint = &skeleton.joints[j];
    let indent = "\t".repeat(depth);
    let keyword = if joint.parent.is_none() { "ROOT" } else { "JOINT" };
    let o = joint.offset;
    let _ = writeln!(head, "{indent}{keyword} {}\n{indent}{{", joint.name);
    let _ = writeln!(
        head,
        "{indent}\tOFFSET {:.6} {:.6} {:.6}",
        o[0] * per_mm,
        o[1] * per_mm,
        o[2] * per_mm
    );
    let names: Vec<&str> = match plan {
        WritePlan::Direct { translations, rotations } => {
            translations.iter().chain(rotations.iter()).map(|(_, c)| c.bvh_name()).collect()
        }
        WritePlan::Baked { translations, .. } => translations
            .iter()
            .map(|(_, c)| c.bvh_name())
            .chain(["Zrotation", "Yrotation", "Xrotation"])
            .collect(),
    };
    let _ = write!(head, "{indent}\tCHANNELS {}", names.len());
    for n in names {
        let _ = write!(head, " {n}");
    }
    head.push('\n');
}

#[cfg(test)]
mod tests {
    use super::*;

    const ARM: &str = "HIERARCHY\nROOT hip\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n  JOINT knee\n  {\n    OFFSET 0 -10 0\n    CHANNELS 3 Xrotation Yrotation Zrotation\n    End Site\n    {\n      OFFSET 0 -10 0\n    }\n  }\n}\nMOTION\nFrames: 2\nFrame Time: 0.1\n1 2 3 0 0 0 0 0 0\n0 0 0 90 0 0 90 0 0\n";

    fn opts_mm() -> BvhOptions {
        BvhOptions {
            length_unit: Some(LengthUnit::Millimetre),
            up_axis: Axis::Y,
            ..BvhOptions::default()
        }
    }

    #[test]
    fn known_positions_of_a_two_joint_chain() {
        let m = parse_bvh(ARM, Path::new("arm.bvh"), &opts_mm()).unwrap();
        assert_eq!(m.point_names(), ["hip", "knee", "knee_end"]);
        assert_eq!(m.n_frames(), 2);
        assert_eq!(m.frame_rate().hz(), 10.0);
        let close = |a: [f64; 3], b: [f64; 3]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-9);
        // Frame 1: translated by (1,2,3), no rotation.
        assert!(close(m.position(0, 1), [1.0, -8.0, 3.0]), "{:?}", m.position(0, 1));
        // Frame 2: hip turned 90° about z moves the knee from -y to +x; the knee's 90° about x
        // then turns its (0,-10,0) segment: Rz(90)·Rx(90)·(0,-10,0) = Rz(90)·(0,0,-10) = (0,0,-10).
        assert!(close(m.position(1, 1), [10.0, 0.0, 0.0]), "{:?}", m.position(1, 1));
        assert!(close(m.position(1, 2), [10.0, 0.0, -10.0]), "{:?}", m.position(1, 2));
    }

    #[test]
    fn position_channels_replace_the_offset_by_default_and_add_on_request() {
        // Root OFFSET (5, 7, 9), its channels put it at (1, 2, 3); the knee has a Yposition
        // channel (value 4) beside its OFFSET (0, -10, 0).
        let text = ARM
            .replace("  OFFSET 0 0 0\n", "  OFFSET 5 7 9\n")
            .replace(
                "    CHANNELS 3 Xrotation Yrotation Zrotation",
                "    CHANNELS 4 Yposition Xrotation Yrotation Zrotation",
            )
            .replace("1 2 3 0 0 0 0 0 0\n", "1 2 3 0 0 0 4 0 0 0\n")
            .replace("0 0 0 90 0 0 90 0 0\n", "0 0 0 0 0 0 -10 0 0 0\n");
        let replace = parse_bvh(&text, Path::new("r.bvh"), &opts_mm()).unwrap();
        assert_eq!(replace.position(0, 0), [1.0, 2.0, 3.0]);
        // Knee: x and z keep the OFFSET's 0, y is the channel's 4.
        assert_eq!(replace.position(0, 1), [1.0, 6.0, 3.0]);
        assert_eq!(replace.position(1, 1), [0.0, -10.0, 0.0]);
        let add = parse_bvh(
            &text,
            Path::new("a.bvh"),
            &BvhOptions { position_channels: PositionChannels::Add, ..opts_mm() },
        )
        .unwrap();
        assert_eq!(add.position(0, 0), [6.0, 9.0, 12.0]);
        assert_eq!(add.position(0, 1), [6.0, 3.0, 12.0]);
        // The stored skeleton holds 0 on the replaced axes, so what the writer writes reads the
        // same under either convention.
        let sk = &replace.skeleton.as_ref().unwrap().skeleton;
        assert_eq!((sk.joints[0].offset, sk.joints[1].offset), ([0.0; 3], [0.0, 0.0, 0.0]));
        let mut out = Vec::new();
        write_bvh(
            replace.skeleton.as_ref().unwrap(),
            replace.frame_rate(),
            LengthUnit::Millimetre,
            &mut out,
        )
        .unwrap();
        let written = String::from_utf8(out).unwrap();
        for convention in [PositionChannels::Replace, PositionChannels::Add] {
            let back = parse_bvh(
                &written,
                Path::new("w.bvh"),
                &BvhOptions { position_channels: convention, ..opts_mm() },
            )
            .unwrap();
            assert_eq!(back.positions(), replace.positions(), "{convention:?}");
        }
        // A zero OFFSET under the position channels: both conventions agree bit for bit.
        let plain_add = parse_bvh(
            ARM,
            Path::new("p.bvh"),
            &BvhOptions { position_channels: PositionChannels::Add, ..opts_mm() },
        )
        .unwrap();
        assert_eq!(
            parse_bvh(ARM, Path::new("p.bvh"), &opts_mm()).unwrap().positions(),
            plain_add.positions()
        );
        let p: BvhParams = motionlab_core::registry::parse_params(
            &toml::from_str("position_channels = \"add\"").unwrap(),
        )
        .unwrap();
        assert_eq!(p.position_channels, PositionChannels::Add);
    }

    /// A 170-unit figure (cm) standing along y: hips at 100, head end at 170, feet at 0.
    const STANDING: &str = "HIERARCHY\nROOT hips\n{\n  OFFSET 0 100 0\n  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n  JOINT head\n  {\n    OFFSET 0 50 0\n    CHANNELS 3 Zrotation Xrotation Yrotation\n    End Site\n    {\n      OFFSET 0 20 0\n    }\n  }\n  JOINT leg\n  {\n    OFFSET 0 -50 0\n    CHANNELS 3 Zrotation Xrotation Yrotation\n    End Site\n    {\n      OFFSET 0 -50 0\n    }\n  }\n}\nMOTION\nFrames: 2\nFrame Time: 0.01\n0 100 0 0 0 0 0 0 0 0 0 0\n3 100 0 0 0 0 0 0 0 0 0 0\n";

    /// The Bandai-Namco layout: six channels on every joint, position values equal to the
    /// OFFSETs. Replacing reads the figure the 3-channel file describes; adding doubles every
    /// bone.
    #[test]
    fn position_channels_on_every_joint_equal_to_the_offsets_read_as_the_plain_skeleton() {
        let six = STANDING
            .replace(
                "    CHANNELS 3 Zrotation Xrotation Yrotation",
                "    CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation",
            )
            .replace("0 100 0 0 0 0 0 0 0 0 0 0\n", "0 100 0 0 0 0 0 50 0 0 0 0 0 -50 0 0 0 0\n")
            .replace("3 100 0 0 0 0 0 0 0 0 0 0\n", "3 100 0 0 0 0 0 50 0 0 0 0 0 -50 0 0 0 0\n");
        let cm = BvhOptions { length_unit: Some(LengthUnit::Centimetre), ..BvhOptions::default() };
        let plain = parse_bvh(STANDING, Path::new("p.bvh"), &cm).unwrap();
        let replace = parse_bvh(&six, Path::new("s.bvh"), &cm).unwrap();
        assert_eq!(replace.positions(), plain.positions());
        let add = parse_bvh(
            &six,
            Path::new("s.bvh"),
            &BvhOptions { position_channels: PositionChannels::Add, ..cm },
        )
        .unwrap();
        // The head end: 2 × 1 m (hips) + 2 × 0.5 m (head) + 0.2 m, instead of 1.7 m.
        assert_eq!(add.position(0, add.point_index("head_end").unwrap())[1], 3200.0);
        assert_eq!(replace.position(0, replace.point_index("head_end").unwrap())[1], 1700.0);
        // Inferred from the rest pose (every joint at its OFFSET), not from doubled bones.
        let d = parse_bvh_channels(&six, Path::new("s.bvh"), &BvhOptions::default()).unwrap();
        assert_eq!(
            (d.length_unit, d.length_unit_from.as_str()),
            (LengthUnit::Centimetre, "inferred from the rest pose: 170 units tall along y")
        );
    }

    #[test]
    fn the_length_unit_is_inferred_from_the_rest_pose_the_first_frame_or_the_longest_extent() {
        let d = parse_bvh_channels(STANDING, Path::new("s.bvh"), &BvhOptions::default()).unwrap();
        assert_eq!(d.length_unit, LengthUnit::Centimetre);
        assert_eq!(d.length_unit_from, "inferred from the rest pose: 170 units tall along y");
        // Modelled lying along +x (every OFFSET turned from y to x), standing in its frames
        // (the root turned 90° about z): the first frame says it.
        let lying = STANDING
            .replace("OFFSET 0 100 0", "OFFSET 100 0 0")
            .replace("OFFSET 0 50 0", "OFFSET 50 0 0")
            .replace("OFFSET 0 20 0", "OFFSET 20 0 0")
            .replace("OFFSET 0 -50 0", "OFFSET -50 0 0")
            .replace("0 100 0 0 0 0 0 0", "0 100 0 90 0 0 0 0")
            .replace("3 100 0 0 0 0 0 0", "3 100 0 90 0 0 0 0");
        let d = parse_bvh_channels(&lying, Path::new("l.bvh"), &BvhOptions::default()).unwrap();
        assert_eq!(d.length_unit, LengthUnit::Centimetre);
        assert_eq!(
            d.length_unit_from,
            "inferred from the first frame: 170 units tall along y (rest pose: 0 units tall along y)"
        );
        // Lying in its frames too: the rest pose's longest extent (x) says it.
        let still = lying.replace(" 90 0 0 0 0", " 0 0 0 0 0");
        let d = parse_bvh_channels(&still, Path::new("l.bvh"), &BvhOptions::default()).unwrap();
        assert_eq!(d.length_unit, LengthUnit::Centimetre);
        assert_eq!(
            d.length_unit_from,
            "inferred from the rest pose's longest extent: 170 units along x (rest pose: 0 units tall along y)"
        );
        // The frames read while inferring are scaled exactly as a one-pass read scales them.
        let explicit = parse_bvh_channels(
            &still,
            Path::new("l.bvh"),
            &BvhOptions { length_unit: Some(LengthUnit::Centimetre), ..BvhOptions::default() },
        )
        .unwrap();
        assert_eq!(explicit.motion.channel_values(), d.motion.channel_values());
        assert_eq!(explicit.length_unit_from, "length_unit = \"centimetre\" (loader setting)");
        // No evidence in range: all three are named.
        let tiny = still
            .replace("OFFSET 50 0 0", "OFFSET 5 0 0")
            .replace("OFFSET 20 0 0", "OFFSET 2 0 0")
            .replace("OFFSET -50 0 0", "OFFSET -5 0 0");
        let e = parse_bvh(&tiny, Path::new("t.bvh"), &BvhOptions::default()).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::OutOfRange);
        for said in [
            "t.bvh",
            "the rest pose: 0 units tall along y",
            "the first frame: ",
            "longest extent: 17 units along x",
            "set length_unit",
        ] {
            assert!(e.to_string().contains(said), "{said}: {e}");
        }
    }

    #[test]
    fn frame_time_snaps_to_whole_rates_only_when_close() {
        assert_eq!(frame_rate_from_time(0.0083333).unwrap().hz(), 120.0);
        assert_eq!(frame_rate_from_time(1.0 / 30.0).unwrap().hz(), 30.0);
        // 0.0081 s is 123.456… Hz: 1.2e-3 away from 1/123, so it is kept as is.
        assert!((frame_rate_from_time(0.0081).unwrap().hz() - 1.0 / 0.0081).abs() < 1e-9);
        assert_eq!(frame_rate_from_time(0.0).unwrap_err().kind(), ErrorKind::OutOfRange);
    }

    #[test]
    fn rest_pose_height_is_the_vertical_extent_and_unknown_sizes_are_refused() {
        // The ARM chain: knee_end at y = -20, hip at y = 0; a splayed leg at 45° is shorter.
        let d = parse_bvh_channels(ARM, Path::new("a.bvh"), &opts_mm()).unwrap();
        assert!((rest_pose_height(&d.motion.skeleton, Axis::Y) - 20.0).abs() < 1e-12);
        assert!((rest_pose_height(&d.motion.skeleton, Axis::Z) - 0.0).abs() < 1e-12);
        let splay = ARM.replace("OFFSET 0 -10 0\n    CHANNELS", "OFFSET 6 -8 0\n    CHANNELS");
        let d = parse_bvh_channels(&splay, Path::new("a.bvh"), &opts_mm()).unwrap();
        assert!((rest_pose_height(&d.motion.skeleton, Axis::Y) - 18.0).abs() < 1e-12);
        // 20 units tall is no human in any unit.
        let e = parse_bvh(ARM, Path::new("a.bvh"), &BvhOptions::default()).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::OutOfRange);
        assert!(e.to_string().contains("a.bvh") && e.to_string().contains("length_unit"), "{e}");
        // Scaled to 85 units (hip 0, knee_end -85: 2.16 m if inches, 85 m if metres) it is inches.
        let tall = ARM.replace("OFFSET 0 -10 0", "OFFSET 0 -42.5 0");
        let d = parse_bvh_channels(&tall, Path::new("a.bvh"), &BvhOptions::default()).unwrap();
        assert_eq!(d.length_unit, LengthUnit::Inch);
        assert!((d.motion.skeleton.joints[1].offset[1] + 42.5 * 25.4).abs() < 1e-9);
    }

    #[test]
    fn every_height_range_maps_to_its_unit_and_ranges_do_not_overlap() {
        for w in INFERABLE_UNITS.windows(2) {
            let (a, b) = (human_height_range(w[0]), human_height_range(w[1]));
            assert!(a.1 < b.0, "{w:?}: {a:?} {b:?}");
        }
        let (lo, hi) = human_height_range(LengthUnit::CmuUnit);
        assert!((lo - 21.26).abs() < 0.01 && (hi - 38.98).abs() < 0.01, "{lo} {hi}");
    }

    #[test]
    fn params_parse_and_reject_unknown_units() {
        let p: BvhParams = motionlab_core::registry::parse_params(
            &toml::from_str("length_unit = \"cmu_unit\"").unwrap(),
        )
        .unwrap();
        assert_eq!(p.length_unit.unit(), Some(LengthUnit::CmuUnit));
        assert_eq!(p.up_axis, Axis::Y);
        let e = motionlab_core::registry::parse_params::<BvhParams>(
            &toml::from_str("length_unit = \"feet\"").unwrap(),
        )
        .unwrap_err();
        assert_eq!(e.kind(), ErrorKind::WrongType);
        let e = motionlab_core::registry::parse_params::<BvhParams>(
            &toml::from_str("unit = \"mm\"").unwrap(),
        )
        .unwrap_err();
        assert_eq!(e.kind(), ErrorKind::UnknownKey);
        assert!(
            motionlab_core::registry::build_loader(
                "bvh",
                &motionlab_core::registry::default_params()
            )
            .is_ok()
        );
    }

    #[test]
    fn writer_orders_joints_depth_first_and_round_trips_positions() {
        use motionlab_core::ChannelKind::{Rotation, Translation};
        // Stored parents-first but breadth-first: r, x, y, x2 (x2 is x's child).
        let mut r = Joint::new(
            "r",
            None,
            [0.0; 3],
            vec![
                Translation(Axis::X),
                Translation(Axis::Y),
                Translation(Axis::Z),
                Rotation(Axis::Y),
            ],
        );
        r.end_sites = vec![];
        let x =
            Joint::new("x", Some(0), [100.0, 0.0, 0.0], vec![Rotation(Axis::X), Rotation(Axis::Z)]);
        let y = Joint::new("y", Some(0), [0.0, 100.0, 0.0], vec![]);
        let mut x2 = Joint::new("x2", Some(1), [0.0, 0.0, 50.0], vec![Rotation(Axis::Z)]);
        x2.end_sites = vec![[10.0, 0.0, 0.0], [0.0, 10.0, 0.0]];
        let sk = Skeleton { joints: vec![r, x, y, x2] };
        let values =
            vec![1.0, 2.0, 3.0, 30.0, 10.0, 20.0, 33.3, 2.0, 4.0, 6.0, -30.0, 45.0, 0.0, 1e-7];
        let sm = SkeletonMotion::new(sk, values).unwrap();
        let mut out = Vec::new();
        write_bvh(&sm, FrameRate::new(30.0).unwrap(), LengthUnit::Centimetre, &mut out).unwrap();
        let text = String::from_utf8(out).unwrap();
        assert!(
            text.contains(
                "\tJOINT y\n\t{\n\t\tOFFSET 0.000000 10.000000 0.000000\n\t\tCHANNELS 0\n"
            ),
            "{text}"
        );
        assert!(text.contains("Frame Time: 0.03333333333333333\n"), "{text}");
        let back = parse_bvh(
            &text,
            Path::new("w.bvh"),
            &BvhOptions {
                length_unit: Some(LengthUnit::Centimetre),
                up_axis: Axis::Y,
                ..BvhOptions::default()
            },
        )
        .unwrap();
        let names = back.point_names().to_vec();
        assert_eq!(names, ["r", "x", "x2", "y", "x2_end", "x2_end2"]);
        assert_eq!(back.frame_rate().hz(), 30.0);
        let original = sm.positions();
        let point_names = sm.skeleton.point_names();
        for f in 0..2 {
            for (k, n) in point_names.iter().enumerate() {
                let a = original[f * point_names.len() + k];
                let b = back.position(f, back.point_index(n).unwrap());
                // 1e-6 cm printed precision on lengths, 1e-6° on angles.
                assert!(
                    a.iter().zip(b).all(|(p, q)| (p - q).abs() < 1e-4),
                    "frame {f} {n}: {a:?} {b:?}"
                );
            }
        }
    }

    #[test]
    fn writer_refuses_non_finite_values() {
        let d = parse_bvh_channels(ARM, Path::new("a.bvh"), &opts_mm()).unwrap();
        let mut values = d.motion.channel_values().to_vec();
        values[7] = f64::NAN;
        let sm = SkeletonMotion::new(d.motion.skeleton.clone(), values).unwrap();
        let e = write_bvh(&sm, d.frame_rate, LengthUnit::Millimetre, &mut Vec::new()).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::NonFinite);
        assert_eq!(e.location().field.as_deref(), Some("knee.ry"));
    }

    #[test]
    fn header_quirks_are_accepted_and_errors_name_their_line() {
        // Brace on the name line, "Frames:2" glued, names with spaces, lower-case keywords.
        let quirky = ARM
            .replace("ROOT hip\n{", "root hip {")
            .replace("JOINT knee", "joint left knee")
            .replace("Frames: 2", "Frames:2");
        let m = parse_bvh(&quirky, Path::new("q.bvh"), &opts_mm()).unwrap();
        assert_eq!(m.point_names(), ["hip", "left knee", "left knee_end"]);
        let cases = [
            (ARM.replace("HIERARCHY", "HIERARCHIE"), ErrorKind::Syntax, 1),
            (
                ARM.replace("Xrotation Yrotation Zrotation", "Xrotation Wrotation Zrotation"),
                ErrorKind::Syntax,
                9,
            ),
            (
                ARM.replace("Xrotation Yrotation Zrotation", "Xrotation Xrotation Zrotation"),
                ErrorKind::DuplicateName,
                9,
            ),
            (
                ARM.replace("    OFFSET 0 -10 0\n    CHANNELS", "    CHANNELS"),
                ErrorKind::Syntax,
                13,
            ),
            (ARM.replace("Frames: 2", "Frames: two"), ErrorKind::Syntax, 17),
            (ARM.replace("Frames: 2", "Frames: 0"), ErrorKind::EmptySequence, 17),
            (ARM.replace("Frame Time: 0.1", "Frame Time: 0.1 extra"), ErrorKind::Syntax, 18),
            (ARM.replace("Frames: 2", "Frames: 1"), ErrorKind::WrongValueCount, 20),
            (ARM.replace("Frames: 2", "Frames: 3"), ErrorKind::Truncated, 21),
        ];
        for (text, kind, line) in cases {
            let e = parse_bvh(&text, Path::new("q.bvh"), &opts_mm()).unwrap_err();
            assert_eq!((e.kind(), e.location().line), (kind, Some(line)), "{e}");
            assert!(e.to_string().starts_with(&format!("q.bvh:{line}: ")), "{e}");
        }
    }

    #[test]
    fn an_absurd_frame_count_is_truncation_not_an_allocation() {
        let e = parse_bvh(
            &ARM.replace("Frames: 2", "Frames: 18446744073709551615"),
            Path::new("q.bvh"),
            &opts_mm(),
        )
        .unwrap_err();
        assert_eq!((e.kind(), e.location().line), (ErrorKind::Truncated, Some(21)), "{e}");
    }

    #[test]
    fn no_truncation_or_byte_change_panics() {
        let text = ARM; // ASCII, so every byte index is a char boundary
        for cut in 0..text.len() {
            let _ = parse_bvh(&text[..cut], Path::new("f.bvh"), &opts_mm());
        }
        for i in 0..text.len() {
            for b in ["0", "-", "}", "{", " ", "\n", "é", "nan", "9e999"] {
                let t = format!("{}{b}{}", &text[..i], &text[i + 1..]);
                if let Ok(m) = parse_bvh(&t, Path::new("f.bvh"), &opts_mm()) {
                    assert!(m.positions().iter().flatten().all(|c| c.is_finite()));
                }
            }
        }
    }
}
