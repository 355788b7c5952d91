//! Acclaim ASF (skeleton) + AMC (motion): loader plugin `asf_amc`, [`parse_asf`], [`parse_amc`].
//!
//! Written by hand: no maintained Rust crate reads ASF/AMC, and the AMC frame section is large
//! (3.6 MB for the 38-second CMU trial 86_01), so it uses the allocation-free number scanner of
//! `text.rs`.
//!
//! ## Mapping onto the core skeleton model
//!
//! A joint sits at the *start* of its segment (see `motionlab_core::skeleton`). An ASF bone
//! starts where its parent bone ends, so:
//!
//! - the ASF `root` becomes joint `root` (offset = `:root position`, no segment of its own);
//! - bone `b` becomes joint `b` whose offset from its parent joint is the *parent's*
//!   `direction × length` (zero when the parent is the root);
//! - a leaf bone (no children in `:hierarchy`) gets an end site `b_end` at its own
//!   `direction × length`;
//! - the bone's `axis a b c ORD` is the joint's axis rotation `C` (composed in the order `ORD`
//!   names, first letter applied first: `XYZ` ⇒ `C = Rz(c)·Ry(b)·Rx(a)`), the root's
//!   `orientation` likewise with the root's `axis` order;
//! - rotation channels compose in the CMU convention `M = Rz·Ry·Rx` whatever order the `dof`
//!   (or root `order`) line lists them in, so the local rotation is `C·Rz·Ry·Rx·C⁻¹`; axes a
//!   bone has no dof for are 0°.
//!
//! The `dof`/`order` lines give the order of the values on the AMC lines, which is the order
//! the channels are stored in.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use nalgebra::Rotation3;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::{ParamGuard, closest_names};
use motionlab_core::skeleton::{ChannelKind, axis_rotation};
use motionlab_core::{
    Axis, Error, ErrorKind, FrameRate, Joint, LengthUnit, Loader, Location, Motion, PointKind,
    Result, Skeleton, SkeletonMotion,
};

use crate::text::{LineWord, NumberLines, read_plain_line, strip_bom};

/// Loads a CMU/Acclaim AMC motion with its ASF skeleton: every frame's bone rotations and the
/// world positions of every joint (bone start) and leaf-bone tip (`<bone>_end`) by forward
/// kinematics, in mm with Y up.
///
/// ASF: `:units` (`length L` means 1 unit = 1/L inch, so CMU's `length 0.45` is 56.444 mm;
/// `angle deg|rad`; `mass` ignored; defaults length 1, angle deg), `:root` (`order` = the AMC
/// value order of the root, `axis`, `position`, `orientation`), `:bonedata` (`name`,
/// `direction`, `length`, `axis a b c XYZ`, `dof` in any order; `id`, `limits`, `bodymass`,
/// `cofmass` and other keys are ignored), `:hierarchy`. A joint sits at the start of its bone:
/// bone b's offset from its parent is the parent's `direction × length`, leaf bones get an end
/// site at their own `direction × length`, the bone `axis` is the fixed rotation C, and
/// rotations compose as CMU's `M = Rz·Ry·Rx` whatever order `dof` lists, so the local rotation
/// is `C·M·C⁻¹` (ASF/AMC "Acclaim" convention, as in the CMU viewer). Bone translation or
/// length dofs (`tx`, `l`) are refused.
///
/// AMC: optional `#` comments and `:FULLY-SPECIFIED`, `:DEGREES`/`:RADIANS` (without them: the
/// ASF's angle unit), then for each frame a frame-number line followed by one `bone v1 v2 …`
/// line per bone with dofs (values in the bone's `dof` order; root translations in ASF length
/// units, converted to mm). Frame numbers must count up by one. CRLF and LF files load alike.
///
/// Missing samples: AMC has none — every bone with dofs must appear exactly once in every frame
/// with one finite value per dof. A bone absent from the ASF, a wrong number of values, a value
/// that is not a number, NaN/inf, or a bone missing from a frame is an error naming the file
/// and line.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct AsfAmcParams {
    /// Path of the ASF skeleton, relative to the AMC file's folder (an absolute path also
    /// works). Unset, it is discovered: `<subject>.asf` in the AMC's folder, then in `../asf/`
    /// (also `.asf.gz`), where the subject is the AMC file name up to its first `_`
    /// (`86_01.amc` → `86.asf`).
    #[serde(default)]
    #[schemars(extend("x-default" = "discovered beside the AMC file (see above)"))]
    pub skeleton: Option<String>,
    /// Frame rate in Hz (frames per second): AMC files do not store one; the default is the
    /// rate of the CMU motion-capture database.
    #[serde(default = "default_frame_rate_hz")]
    pub frame_rate_hz: f64,
}

fn default_frame_rate_hz() -> f64 {
    120.0
}

/// The validated loader.
#[derive(Clone, Debug)]
pub struct AsfAmcLoader {
    skeleton: Option<PathBuf>,
    frame_rate: FrameRate,
}

impl ParamGuard for AsfAmcParams {
    type Checked = AsfAmcLoader;
    fn check(self) -> Result<AsfAmcLoader> {
        let frame_rate =
            FrameRate::new(self.frame_rate_hz).map_err(|e| e.with_field("frame_rate_hz"))?;
        let skeleton = match self.skeleton {
            Some(s) if s.trim().is_empty() => {
                return Err(Error::new(
                    ErrorKind::InvalidParameter,
                    "is empty; expected a path to an .asf file or no key at all",
                )
                .with_field("skeleton"));
            }
            s => s.map(PathBuf::from),
        };
        Ok(AsfAmcLoader { skeleton, frame_rate })
    }
}

impl Loader for AsfAmcLoader {
    fn extensions(&self) -> &'static [&'static str] {
        &["amc"]
    }
    fn load(&self, path: &Path) -> Result<Motion> {
        let asf_path = match &self.skeleton {
            Some(p) => resolve_relative(path, p),
            None => discover_asf(path)?,
        };
        let asf = parse_asf(&crate::read::read_text(&asf_path)?, &asf_path)?;
        let amc = crate::read::read_text(path)?;
        let channels = parse_amc(&amc, path, &asf)?;
        let mut motion = amc_motion(channels, path, self.frame_rate)?;
        motion.load_notes.length_unit = asf.length_unit;
        motion.load_notes.length_unit_from =
            format!("the ASF's :units length ({} mm per unit)", asf.mm_per_unit);
        Ok(motion)
    }
}

motionlab_core::register_plugin!(Loader, AsfAmcParams, "asf_amc");

/// `p` relative to the folder of `amc` (absolute paths unchanged).
fn resolve_relative(amc: &Path, p: &Path) -> PathBuf {
    if p.is_absolute() { p.to_path_buf() } else { amc.parent().unwrap_or(Path::new("")).join(p) }
}

/// The ASF candidates for an AMC file, in the order they are tried (see [`AsfAmcParams`]).
pub fn asf_candidates(amc: &Path) -> Vec<PathBuf> {
    let stem = crate::read::stem(amc);
    let subject = stem.split('_').next().filter(|s| !s.is_empty()).unwrap_or(&stem).to_string();
    let dir = amc.parent().unwrap_or(Path::new("")).to_path_buf();
    let mut out = Vec::new();
    for folder in [dir.clone(), dir.join("..").join("asf")] {
        out.push(folder.join(format!("{subject}.asf")));
        out.push(folder.join(format!("{subject}.asf.gz")));
    }
    out
}

fn discover_asf(amc: &Path) -> Result<PathBuf> {
    let candidates = asf_candidates(amc);
    candidates.iter().find(|c| c.is_file()).cloned().ok_or_else(|| {
        let tried: Vec<String> = candidates.iter().map(|c| c.display().to_string()).collect();
        Error::new(
            ErrorKind::Io,
            format!("no ASF skeleton found for this AMC (tried {}); set `skeleton = \"path/to/file.asf\"`", tried.join(", ")),
        )
        .with_location(Location::file(amc).field("skeleton"))
    })
}

/// A parsed ASF skeleton, ready to read AMC files against.
#[derive(Clone, Debug)]
pub struct AsfSkeleton {
    /// The `:name` line (empty when absent).
    pub name: String,
    /// The skeleton in mm (joint `root`, then bones depth-first in `:hierarchy` order).
    pub skeleton: Skeleton,
    /// Millimetres per ASF length unit (`25.4 / L` for `:units length L`).
    pub mm_per_unit: f64,
    /// `LengthUnit::CmuUnit` when `length 0.45`, `Inch` when `length 1`; otherwise none of the
    /// named units (see `mm_per_unit`).
    pub length_unit: Option<LengthUnit>,
    /// Whether `:units angle` is `rad` (AMC values then default to radians).
    pub angles_in_radians: bool,
    /// The file it came from (errors about the skeleton name it).
    pub origin: PathBuf,
}

/// ASF line reader: strips `#` comments and blanks, remembers line numbers.
struct AsfLines<'a> {
    lines: Vec<(usize, Vec<&'a str>)>,
    at: usize,
}

impl<'a> AsfLines<'a> {
    fn new(text: &'a str) -> Self {
        let lines = text
            .split('\n')
            .enumerate()
            .filter_map(|(i, l)| {
                let l = l.split('#').next().unwrap_or("");
                let words: Vec<&str> = l.split_ascii_whitespace().collect();
                (!words.is_empty()).then_some((i + 1, words))
            })
            .collect();
        AsfLines { lines, at: 0 }
    }
    fn peek(&self) -> Option<&(usize, Vec<&'a str>)> {
        self.lines.get(self.at)
    }
    fn next_line(&mut self) -> Option<(usize, Vec<&'a str>)> {
        let l = self.lines.get(self.at).cloned();
        self.at += 1;
        l
    }
    fn last_line(&self) -> usize {
        self.lines.last().map_or(1, |l| l.0)
    }
}

/// One `:bonedata` entry as written.
struct AsfBone<'a> {
    name: &'a str,
    line: usize,
    direction: [f64; 3],
    length: f64,
    /// C in the ASF's angle unit, with its order.
    axis: ([f64; 3], &'a str),
    dof: Vec<ChannelKind>,
}

fn num(word: &str, origin: &Path, line: usize, what: &str) -> Result<f64> {
    match fast_float2::parse::<f64, _>(word) {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(Error::at_line(
            ErrorKind::NonFinite,
            origin,
            line,
            format!("{what} is {word:?}, expected a finite number"),
        )),
        Err(_) => Err(Error::at_line(
            ErrorKind::Syntax,
            origin,
            line,
            format!("{what} is {word:?}, expected a number"),
        )),
    }
}

fn nums3(words: &[&str], origin: &Path, line: usize, what: &str) -> Result<[f64; 3]> {
    if words.len() < 4 {
        return Err(Error::at_line(
            ErrorKind::WrongValueCount,
            origin,
            line,
            format!("{what} has {} values, expected 3", words.len().saturating_sub(1)),
        ));
    }
    Ok([
        num(words[1], origin, line, &format!("{what} x"))?,
        num(words[2], origin, line, &format!("{what} y"))?,
        num(words[3], origin, line, &format!("{what} z"))?,
    ])
}

/// Parses an axis-order token (`XYZ`, `zyx`, …).
fn axis_order(word: &str, origin: &Path, line: usize) -> Result<[Axis; 3]> {
    let mut out = [Axis::X; 3];
    let w = word.to_ascii_uppercase();
    let ok = w.len() == 3
        && w.chars().enumerate().all(|(i, c)| {
            out[i] = match c {
                'X' => Axis::X,
                'Y' => Axis::Y,
                'Z' => Axis::Z,
                _ => return false,
            };
            true
        })
        && out[0] != out[1]
        && out[1] != out[2]
        && out[0] != out[2];
    if ok {
        Ok(out)
    } else {
        Err(Error::at_line(
            ErrorKind::Syntax,
            origin,
            line,
            format!("axis order {word:?}; expected a permutation of XYZ"),
        ))
    }
}

/// `C` from three angles (in `order`, first applied first): `XYZ` ⇒ `Rz·Ry·Rx`.
fn axis_matrix(angles_deg: [f64; 3], order: [Axis; 3]) -> Rotation3<f64> {
    let mut c = Rotation3::identity();
    for a in order {
        c = axis_rotation(a, angles_deg[a.index()].to_radians()) * c;
    }
    c
}

fn dof_kind(word: &str) -> Option<ChannelKind> {
    match word.to_ascii_lowercase().as_str() {
        "rx" => Some(ChannelKind::Rotation(Axis::X)),
        "ry" => Some(ChannelKind::Rotation(Axis::Y)),
        "rz" => Some(ChannelKind::Rotation(Axis::Z)),
        "tx" => Some(ChannelKind::Translation(Axis::X)),
        "ty" => Some(ChannelKind::Translation(Axis::Y)),
        "tz" => Some(ChannelKind::Translation(Axis::Z)),
        _ => None,
    }
}

const CMU_ROTATION_ORDER: [Axis; 3] = [Axis::Z, Axis::Y, Axis::X];

/// Parses ASF text (see [`AsfAmcParams`] for what is read). `origin` names the file in errors.
pub fn parse_asf(text: &str, origin: &Path) -> Result<AsfSkeleton> {
    let text = strip_bom(text);
    let mut lines = AsfLines::new(text);
    let mut name = String::new();
    let mut length_per_inch = 1.0f64;
    let mut radians = false;
    let mut root_order: Vec<ChannelKind> = Vec::new();
    let mut root_axis: [Axis; 3] = [Axis::X, Axis::Y, Axis::Z];
    let mut root_position = [0.0; 3];
    let mut root_orientation = [0.0; 3];
    let mut saw_root = false;
    let mut bones: Vec<AsfBone<'_>> = Vec::new();
    let mut bone_index: HashMap<&str, usize> = HashMap::new();
    // children[parent] in :hierarchy order; parent None = root.
    let mut root_children: Vec<usize> = Vec::new();
    let mut children: Vec<Vec<usize>> = Vec::new();
    let mut parent_line: Vec<Option<usize>> = Vec::new();
    let mut saw_hierarchy = false;

    while let Some((line, words)) = lines.next_line() {
        let keyword = words[0];
        if !keyword.starts_with(':') {
            return Err(Error::at_line(
                ErrorKind::Syntax,
                origin,
                line,
                format!(
                    "{keyword:?} outside any section; expected a :keyword such as :root or :bonedata"
                ),
            ));
        }
        match keyword.to_ascii_lowercase().as_str() {
            ":name" => name = words[1..].join(" "),
            ":units" => {
                while let Some((l, w)) =
                    lines.peek().cloned().filter(|(_, w)| !w[0].starts_with(':'))
                {
                    lines.next_line();
                    match w[0].to_ascii_lowercase().as_str() {
                        "length" => {
                            let v =
                                num(w.get(1).copied().unwrap_or(""), origin, l, ":units length")?;
                            if v <= 0.0 {
                                return Err(Error::at_line(
                                    ErrorKind::OutOfRange,
                                    origin,
                                    l,
                                    format!(":units length is {v}; expected > 0"),
                                ));
                            }
                            length_per_inch = v;
                        }
                        "angle" => match w.get(1).map(|a| a.to_ascii_lowercase()).as_deref() {
                            Some("deg") => radians = false,
                            Some("rad") => radians = true,
                            other => {
                                return Err(Error::at_line(
                                    ErrorKind::Syntax,
                                    origin,
                                    l,
                                    format!(
                                        ":units angle is {:?}; expected deg or rad",
                                        other.unwrap_or("")
                                    ),
                                ));
                            }
                        },
                        _ => {} // mass and vendor keys do not affect positions
                    }
                }
            }
            ":root" => {
                saw_root = true;
                while let Some((l, w)) =
                    lines.peek().cloned().filter(|(_, w)| !w[0].starts_with(':'))
                {
                    lines.next_line();
                    match w[0].to_ascii_lowercase().as_str() {
                        "order" => {
                            root_order.clear();
                            for t in &w[1..] {
                                let kind = dof_kind(t).ok_or_else(|| {
                                    Error::at_line(
                                        ErrorKind::Syntax,
                                        origin,
                                        l,
                                        format!(
                                            ":root order lists {t:?}; expected TX TY TZ RX RY RZ"
                                        ),
                                    )
                                })?;
                                if root_order.contains(&kind) {
                                    return Err(Error::at_line(
                                        ErrorKind::DuplicateName,
                                        origin,
                                        l,
                                        format!(":root order lists {t} twice"),
                                    ));
                                }
                                root_order.push(kind);
                            }
                        }
                        "axis" => {
                            root_axis = axis_order(w.get(1).copied().unwrap_or(""), origin, l)?
                        }
                        "position" => root_position = nums3(&w, origin, l, ":root position")?,
                        "orientation" => {
                            root_orientation = nums3(&w, origin, l, ":root orientation")?
                        }
                        other => {
                            return Err(Error::at_line(
                                ErrorKind::Syntax,
                                origin,
                                l,
                                format!(
                                    "{other:?} in :root; expected order, axis, position or orientation"
                                ),
                            ));
                        }
                    }
                }
            }
            ":bonedata" => parse_bonedata(&mut lines, origin, &mut bones, &mut bone_index)?,
            ":hierarchy" => {
                saw_hierarchy = true;
                children.resize(bones.len(), Vec::new());
                parent_line.resize(bones.len(), None);
                parse_hierarchy(
                    &mut lines,
                    origin,
                    &bones,
                    &bone_index,
                    &mut root_children,
                    &mut children,
                    &mut parent_line,
                )?;
            }
            // :version, :documentation (free text) and vendor sections: skip to the next section.
            _ => {
                while lines.peek().is_some_and(|(_, w)| !w[0].starts_with(':')) {
                    lines.next_line();
                }
            }
        }
    }
    if !saw_root {
        return Err(Error::at_line(
            ErrorKind::Syntax,
            origin,
            lines.last_line(),
            "no :root section; expected :root with order, axis, position, orientation",
        ));
    }
    if !saw_hierarchy {
        return Err(Error::at_line(
            ErrorKind::Syntax,
            origin,
            lines.last_line(),
            "no :hierarchy section; expected one after :bonedata",
        ));
    }
    // Bones declared after :hierarchy were never attached either.
    children.resize(bones.len(), Vec::new());
    parent_line.resize(bones.len(), None);
    if let Some(bone) = bones.iter().zip(&parent_line).find(|(_, p)| p.is_none()).map(|(b, _)| b) {
        return Err(Error::at_line(
            ErrorKind::Syntax,
            origin,
            bone.line,
            format!("bone {:?} is declared but never attached in :hierarchy", bone.name),
        ));
    }

    let mm = if length_per_inch == 0.45 {
        LengthUnit::CmuUnit.millimetres_per_unit()
    } else {
        25.4 / length_per_inch
    };
    let length_unit = if length_per_inch == 0.45 {
        Some(LengthUnit::CmuUnit)
    } else if length_per_inch == 1.0 {
        Some(LengthUnit::Inch)
    } else {
        None
    };
    let to_deg = |v: f64| if radians { v.to_degrees() } else { v };

    let mut root = Joint::new("root", None, root_position.map(|c| c * mm), root_order);
    root.rotation_order = CMU_ROTATION_ORDER.to_vec();
    root.axis = axis_matrix(root_orientation.map(to_deg), root_axis);
    let mut joints = vec![root];
    // Depth-first from the root, children in :hierarchy order; (bone, parent joint).
    let mut stack: Vec<(usize, usize)> = root_children.iter().rev().map(|&b| (b, 0)).collect();
    let mut visited = vec![false; bones.len()];
    let mut segment_of_joint: Vec<[f64; 3]> = vec![[0.0; 3]]; // root has no segment
    while let Some((b, parent_joint)) = stack.pop() {
        if std::mem::replace(&mut visited[b], true) {
            continue;
        }
        let bone = &bones[b];
        let segment = bone.direction.map(|c| c * bone.length * mm);
        let mut joint = Joint::new(
            bone.name,
            Some(parent_joint),
            segment_of_joint[parent_joint],
            bone.dof.clone(),
        );
        joint.rotation_order = CMU_ROTATION_ORDER.to_vec();
        joint.axis =
            axis_matrix(bone.axis.0.map(to_deg), axis_order(bone.axis.1, origin, bone.line)?);
        if children[b].is_empty() {
            joint.end_sites.push(segment);
        }
        joints.push(joint);
        segment_of_joint.push(segment);
        let me = joints.len() - 1;
        stack.extend(children[b].iter().rev().map(|&c| (c, me)));
    }
    if let Some(b) = visited.iter().position(|v| !v) {
        // Every bone has a parent, so an unvisited one sits on a parent cycle.
        return Err(Error::at_line(
            ErrorKind::Syntax,
            origin,
            parent_line[b].unwrap_or(bones[b].line),
            format!(
                "bone {:?} is not connected to root (its :hierarchy parents form a cycle)",
                bones[b].name
            ),
        ));
    }
    let skeleton = Skeleton { joints };
    skeleton.validate().map_err(|e| e.in_file(origin))?;
    Ok(AsfSkeleton {
        name,
        skeleton,
        mm_per_unit: mm,
        length_unit,
        angles_in_radians: radians,
        origin: origin.to_path_buf(),
    })
}

fn parse_bonedata<'a>(
    lines: &mut AsfLines<'a>,
    origin: &Path,
    bones: &mut Vec<AsfBone<'a>>,
    bone_index: &mut HashMap<&'a str, usize>,
) -> Result<()> {
    while let Some((begin_line, w)) = lines.peek().cloned().filter(|(_, w)| !w[0].starts_with(':'))
    {
        lines.next_line();
        if !w[0].eq_ignore_ascii_case("begin") {
            return Err(Error::at_line(
                ErrorKind::Syntax,
                origin,
                begin_line,
                format!("{:?} in :bonedata; expected begin", w[0]),
            ));
        }
        let mut name = None;
        let mut direction = None;
        let mut length = None;
        let mut axis = ([0.0; 3], "XYZ");
        let mut dof = Vec::new();
        loop {
            let Some((l, w)) = lines.next_line() else {
                return Err(Error::at_line(
                    ErrorKind::Truncated,
                    origin,
                    lines.last_line(),
                    format!(
                        "file ends inside the bone that begins at line {begin_line}; expected end"
                    ),
                ));
            };
            let key = w[0].to_ascii_lowercase();
            match key.as_str() {
                "end" => break,
                "name" => name = Some((w.get(1).copied().unwrap_or(""), l)),
                "direction" => direction = Some(nums3(&w, origin, l, "direction")?),
                "length" => {
                    length = Some(num(w.get(1).copied().unwrap_or(""), origin, l, "length")?)
                }
                "axis" => {
                    let a = nums3(&w, origin, l, "axis")?;
                    let order = w.get(4).copied().unwrap_or("XYZ");
                    axis_order(order, origin, l)?;
                    axis = (a, order);
                }
                "dof" => {
                    for t in &w[1..] {
                        let kind = dof_kind(t).ok_or_else(|| {
                            let hint = if t.eq_ignore_ascii_case("l") {
                                " (bone stretching is not supported)"
                            } else {
                                ""
                            };
                            Error::at_line(
                                ErrorKind::Syntax,
                                origin,
                                l,
                                format!("dof {t:?}{hint}; expected rx, ry or rz"),
                            )
                        })?;
                        if let ChannelKind::Translation(_) = kind {
                            return Err(Error::at_line(
                                ErrorKind::Syntax,
                                origin,
                                l,
                                format!(
                                    "dof {t:?}: bone translations are not supported; expected rx, ry or rz"
                                ),
                            ));
                        }
                        if dof.contains(&kind) {
                            return Err(Error::at_line(
                                ErrorKind::DuplicateName,
                                origin,
                                l,
                                format!("dof {t} is listed twice"),
                            ));
                        }
                        dof.push(kind);
                    }
                }
                k if k.starts_with(':') => {
                    return Err(Error::at_line(
                        ErrorKind::Truncated,
                        origin,
                        l,
                        format!(
                            "section {} starts inside the bone that begins at line {begin_line}; expected end",
                            w[0]
                        ),
                    ));
                }
                _ => {} // id, limits and their continuation lines, bodymass, cofmass
            }
        }
        let (name, name_line) = name.filter(|(n, _)| !n.is_empty()).ok_or_else(|| {
            Error::at_line(
                ErrorKind::Syntax,
                origin,
                begin_line,
                "bone without a name; expected name <bone>",
            )
        })?;
        let missing = |what: &str| {
            Error::at_line(
                ErrorKind::Syntax,
                origin,
                begin_line,
                format!("bone {name:?} has no {what}; expected {what} …"),
            )
        };
        let direction = direction.ok_or_else(|| missing("direction"))?;
        let length = length.ok_or_else(|| missing("length"))?;
        if name.eq_ignore_ascii_case("root") {
            return Err(Error::at_line(
                ErrorKind::DuplicateName,
                origin,
                name_line,
                "a bone is named root; that name is the :root's",
            ));
        }
        if let Some(&first) = bone_index.get(name) {
            return Err(Error::at_line(
                ErrorKind::DuplicateName,
                origin,
                name_line,
                format!(
                    "bone {name:?} is already declared at line {}; bone names must be unique",
                    bones[first].line
                ),
            ));
        }
        bone_index.insert(name, bones.len());
        bones.push(AsfBone { name, line: name_line, direction, length, axis, dof });
    }
    Ok(())
}

fn parse_hierarchy(
    lines: &mut AsfLines<'_>,
    origin: &Path,
    bones: &[AsfBone<'_>],
    bone_index: &HashMap<&str, usize>,
    root_children: &mut Vec<usize>,
    children: &mut [Vec<usize>],
    parent_line: &mut [Option<usize>],
) -> Result<()> {
    let unknown = |name: &str, line: usize| {
        let close = closest_names(name, bones.iter().map(|b| b.name).chain(["root"]));
        let hint = if close.is_empty() {
            String::new()
        } else {
            format!(" (closest: {})", close.join(", "))
        };
        Error::at_line(
            ErrorKind::UnknownName,
            origin,
            line,
            format!("bone {name:?} in :hierarchy is not declared in :bonedata{hint}"),
        )
    };
    while let Some((l, w)) = lines.peek().cloned().filter(|(_, w)| !w[0].starts_with(':')) {
        lines.next_line();
        if w[0].eq_ignore_ascii_case("begin") || w[0].eq_ignore_ascii_case("end") {
            continue;
        }
        let parent = if w[0] == "root" {
            None
        } else {
            Some(*bone_index.get(w[0]).ok_or_else(|| unknown(w[0], l))?)
        };
        for child in &w[1..] {
            let c = *bone_index.get(child).ok_or_else(|| unknown(child, l))?;
            if let Some(first) = parent_line[c] {
                return Err(Error::at_line(
                    ErrorKind::DuplicateName,
                    origin,
                    l,
                    format!(
                        "bone {child:?} is given a second parent; it is already attached at line {first}"
                    ),
                ));
            }
            parent_line[c] = Some(l);
            match parent {
                None => root_children.push(c),
                Some(p) => children[p].push(c),
            }
        }
    }
    Ok(())
}

/// Where one bone's values go in a frame.
#[derive(Clone, Copy)]
struct Slot {
    first: usize,
    n: usize,
}

/// The bone-line fast path of [`parse_amc`]: from the second frame on, bone lines are expected
/// in the previous frame's order, and each that is the usual `bone v1 v2 …` line is read in one
/// pass by [`read_plain_line`]. Kept out of line so its loop has the registers to itself.
struct FastBoneLines<'a> {
    /// Joint of each bone line of the first frame, in file order.
    order: &'a [usize],
    words: &'a [Option<LineWord>],
    slots: &'a [Slot],
    scale: &'a [f64],
}

impl FastBoneLines<'_> {
    /// Reads consecutive bone lines that follow `order` from `order_pos` on into `frame_values`
    /// (one frame's channels), marking each joint seen in frame `frame`; stops at the first
    /// line that is not such a line (left unread, for the general path) and returns how many it
    /// read. A joint already seen in this frame also stops it, so the general path reports the
    /// duplicate.
    #[inline(never)]
    fn read(
        &self,
        cursor: &mut NumberLines<'_>,
        order_pos: usize,
        frame_values: &mut [f64],
        seen: &mut [usize],
        frame: usize,
    ) -> usize {
        let mut read = 0;
        for &j in &self.order[order_pos.min(self.order.len())..] {
            if !cursor.skip_empty_lines() || seen[j] == frame {
                break;
            }
            let (Some(window), Some(word)) = (cursor.window(), &self.words[j]) else { break };
            let slot = self.slots[j];
            let Some(used) = read_plain_line(
                window,
                Some(word),
                &mut frame_values[slot.first..slot.first + slot.n],
                &self.scale[slot.first..slot.first + slot.n],
            ) else {
                break;
            };
            seen[j] = frame;
            cursor.skip_read_line(used);
            read += 1;
        }
        read
    }
}

/// Parses AMC text against an ASF skeleton into channel values (root translations in mm,
/// rotations in degrees, in the skeleton's channel order). `origin` names the AMC in errors.
pub fn parse_amc(text: &str, origin: &Path, asf: &AsfSkeleton) -> Result<SkeletonMotion> {
    parse_amc_with(text, origin, asf, true).map(|(motion, _)| motion)
}

/// [`parse_amc`], with the bone-line fast path ([`FastBoneLines`]) switched off when
/// `fast_path` is false — for the test that the two read every shipped take bit for bit alike.
/// Also returns how many bone lines the fast path read.
fn parse_amc_with(
    text: &str,
    origin: &Path,
    asf: &AsfSkeleton,
    fast_path: bool,
) -> Result<(SkeletonMotion, usize)> {
    let bytes = strip_bom(text).as_bytes();
    let mut reader = AmcReader::new(asf, origin, bytes.len());
    let mut cursor = NumberLines::new(bytes, 0, 1, origin);
    while cursor.skip_empty_lines() {
        // The usual bone line — the bone the previous frame had at this place, then its
        // values — in one pass; anything else (and any error) goes the general way below.
        if fast_path && reader.read_predicted_bone_lines(&mut cursor) {
            continue;
        }
        let word = cursor.peek_word();
        let line = cursor.line();
        match word.first() {
            Some(b'#') => cursor.skip_line(),
            Some(b':') => reader.keyword_line(&mut cursor, word, line)?,
            Some(b) if b.is_ascii_digit() => reader.frame_number_line(&mut cursor, word, line)?,
            _ => reader.bone_line(&mut cursor, word, line)?,
        }
    }
    reader.finish(cursor.line())
}

/// An AMC read in progress: where each bone's values go in a frame, the values read so far and
/// which bones the current frame has had.
struct AmcReader<'a> {
    asf: &'a AsfSkeleton,
    origin: &'a Path,
    n_channels: usize,
    slots: Vec<Slot>,
    by_name: HashMap<&'a str, usize>,
    /// Each joint's name as the bone-line fast path matches it.
    line_words: Vec<Option<LineWord>>,
    radians: bool,
    /// Frame-major channel values, scaled (mm, degrees).
    values: Vec<f64>,
    /// Per joint: the frame index it was last seen in (usize::MAX = never).
    seen: Vec<usize>,
    /// Per channel: the factor from the file's units to mm or degrees (set at the first frame).
    scale: Vec<f64>,
    n_frames: usize,
    frame_number: u64,
    frame_line: usize,
    /// The bone order of the first frame, to skip the hash lookup on the usual repeat.
    order: Vec<usize>,
    /// The place in `order` of the current frame's next bone line.
    order_pos: usize,
    first_order_done: bool,
    /// Bone lines read by the fast path.
    fast_lines: usize,
}

impl<'a> AmcReader<'a> {
    fn new(asf: &'a AsfSkeleton, origin: &'a Path, text_len: usize) -> Self {
        let skeleton = &asf.skeleton;
        let n_channels = skeleton.n_channels();
        let mut slots: Vec<Slot> = Vec::with_capacity(skeleton.joints.len());
        let mut by_name: HashMap<&str, usize> = HashMap::with_capacity(skeleton.joints.len());
        let mut at = 0;
        for (j, joint) in skeleton.joints.iter().enumerate() {
            slots.push(Slot { first: at, n: joint.channels.len() });
            by_name.insert(joint.name.as_str(), j);
            at += joint.channels.len();
        }
        AmcReader {
            asf,
            origin,
            n_channels,
            slots,
            by_name,
            line_words: skeleton.joints.iter().map(|j| LineWord::new(j.name.as_bytes())).collect(),
            radians: asf.angles_in_radians,
            values: Vec::with_capacity(n_channels * (text_len / 600 + 1)),
            seen: vec![usize::MAX; skeleton.joints.len()],
            scale: Vec::new(),
            n_frames: 0,
            frame_number: 0,
            frame_line: 0,
            order: Vec::with_capacity(skeleton.joints.len()),
            order_pos: 0,
            first_order_done: false,
            fast_lines: 0,
        }
    }

    /// From the second frame on: the bone lines that follow the first frame's order, read by
    /// [`FastBoneLines`]; whether it read any.
    fn read_predicted_bone_lines(&mut self, cursor: &mut NumberLines<'_>) -> bool {
        if !(self.first_order_done && self.order_pos < self.order.len()) {
            return false;
        }
        let frame = self.n_frames - 1;
        let n = self.n_channels;
        let fast = FastBoneLines {
            order: &self.order,
            words: &self.line_words,
            slots: &self.slots,
            scale: &self.scale,
        };
        let read = fast.read(
            cursor,
            self.order_pos,
            &mut self.values[frame * n..(frame + 1) * n],
            &mut self.seen,
            frame,
        );
        self.order_pos += read;
        self.fast_lines += read;
        read > 0
    }

    /// `:DEGREES`, `:RADIANS` and other keyword lines, allowed before the first frame only.
    fn keyword_line(
        &mut self,
        cursor: &mut NumberLines<'_>,
        word: &[u8],
        line: usize,
    ) -> Result<()> {
        if self.n_frames > 0 {
            return Err(Error::at_line(
                ErrorKind::Syntax,
                self.origin,
                line,
                format!(
                    "{:?} after the first frame; expected a frame number or a bone line",
                    String::from_utf8_lossy(word)
                ),
            ));
        }
        if word.eq_ignore_ascii_case(b":DEGREES") {
            self.radians = false;
        } else if word.eq_ignore_ascii_case(b":RADIANS") {
            self.radians = true;
        }
        cursor.skip_line();
        Ok(())
    }

    /// A frame number line: the previous frame checked complete, the next number checked, a
    /// new frame of values started.
    fn frame_number_line(
        &mut self,
        cursor: &mut NumberLines<'_>,
        word: &[u8],
        line: usize,
    ) -> Result<()> {
        let number = std::str::from_utf8(word)
            .ok()
            .and_then(|w| w.parse::<u64>().ok())
            .ok_or_else(|| {
                Error::at_line(
                    ErrorKind::Syntax,
                    self.origin,
                    line,
                    format!(
                        "{:?}; expected a frame number or a bone name",
                        String::from_utf8_lossy(word)
                    ),
                )
            })?;
        self.check_frame_complete()?;
        if self.n_frames > 0 && number != self.frame_number + 1 {
            return Err(Error::at_line(
                ErrorKind::Syntax,
                self.origin,
                line,
                format!(
                    "frame number {number} follows frame {}; expected {}",
                    self.frame_number,
                    self.frame_number + 1
                ),
            ));
        }
        if self.n_frames == 0 {
            self.scale = self.channel_scale();
        } else if !self.first_order_done {
            self.first_order_done = true;
        }
        self.frame_number = number;
        self.frame_line = line;
        self.n_frames += 1;
        self.values.resize(self.n_frames * self.n_channels, 0.0);
        self.order_pos = 0;
        cursor.skip_word(word);
        let rest = cursor.read_line(&mut [], &[], || format!("frame number line {number}"))?;
        if rest.count != 0 {
            return Err(Error::at_line(
                ErrorKind::Syntax,
                self.origin,
                line,
                format!(
                    "frame number {number} is followed by values; expected it alone on its line"
                ),
            ));
        }
        Ok(())
    }

    /// Per channel, the factor from the file's units: the ASF's length unit to mm for
    /// translations, radians (when the file says so) to degrees for rotations.
    fn channel_scale(&self) -> Vec<f64> {
        let rotation = if self.radians { 180.0 / std::f64::consts::PI } else { 1.0 };
        self.asf
            .skeleton
            .joints
            .iter()
            .flat_map(|j| j.channels.iter())
            .map(|c| match c {
                ChannelKind::Translation(_) => self.asf.mm_per_unit,
                ChannelKind::Rotation(_) => rotation,
            })
            .collect()
    }

    /// A bone line the fast path did not read: its bone predicted from the first frame's
    /// order, else looked up by name; its values into the current frame.
    fn bone_line(&mut self, cursor: &mut NumberLines<'_>, word: &[u8], line: usize) -> Result<()> {
        let skeleton = &self.asf.skeleton;
        if self.n_frames == 0 {
            return Err(Error::at_line(
                ErrorKind::Syntax,
                self.origin,
                line,
                format!(
                    "{:?} before the first frame number; expected a frame number",
                    String::from_utf8_lossy(word)
                ),
            ));
        }
        let j = match self.order.get(self.order_pos) {
            Some(&j) if self.first_order_done && skeleton.joints[j].name.as_bytes() == word => j,
            _ => self.bone_by_name(word, line)?,
        };
        if !self.first_order_done {
            self.order.push(j);
        }
        self.order_pos += 1;
        if self.seen[j] == self.n_frames - 1 {
            return Err(Error::at_line(
                ErrorKind::DuplicateName,
                self.origin,
                line,
                format!(
                    "bone {:?} appears twice in frame {}",
                    skeleton.joints[j].name, self.frame_number
                ),
            ));
        }
        self.seen[j] = self.n_frames - 1;
        cursor.skip_word(word);
        let slot = self.slots[j];
        let base = (self.n_frames - 1) * self.n_channels + slot.first;
        let got = cursor.read_line(
            &mut self.values[base..base + slot.n],
            &self.scale[slot.first..slot.first + slot.n],
            || format!("bone {}", skeleton.joints[j].name),
        )?;
        if got.count != slot.n {
            let dofs: Vec<&str> =
                skeleton.joints[j].channels.iter().map(|c| c.short_name()).collect();
            return Err(Error::at_line(
                ErrorKind::WrongValueCount,
                self.origin,
                line,
                format!(
                    "bone {:?}: found {} values, expected {} (dof {})",
                    skeleton.joints[j].name,
                    got.count,
                    slot.n,
                    dofs.join(" ")
                ),
            ));
        }
        Ok(())
    }

    /// The joint a bone line names, or an error naming the closest bones.
    fn bone_by_name(&self, word: &[u8], line: usize) -> Result<usize> {
        let name = std::str::from_utf8(word).unwrap_or("");
        self.by_name.get(name).copied().ok_or_else(|| {
            let close =
                closest_names(name, self.asf.skeleton.joints.iter().map(|j| j.name.as_str()));
            let hint = if close.is_empty() {
                String::new()
            } else {
                format!("; closest: {}", close.join(", "))
            };
            Error::at_line(
                ErrorKind::UnknownName,
                self.origin,
                line,
                format!("bone {name:?} is not in the skeleton {}{hint}", self.asf.origin.display()),
            )
            .with_field(name.to_string())
        })
    }

    /// Every bone with dofs had a line in the current frame (if there is one).
    fn check_frame_complete(&self) -> Result<()> {
        if self.n_frames == 0 {
            return Ok(());
        }
        let joints = &self.asf.skeleton.joints;
        match joints
            .iter()
            .enumerate()
            .find(|(j, jt)| !jt.channels.is_empty() && self.seen[*j] != self.n_frames - 1)
        {
            None => Ok(()),
            Some((_, jt)) => Err(Error::at_line(
                ErrorKind::WrongValueCount,
                self.origin,
                self.frame_line,
                format!(
                    "frame {} has no line for bone {:?}; expected every bone with dofs in every frame",
                    self.frame_number, jt.name
                ),
            )),
        }
    }

    /// The channel values of every frame, once the text is read (`last_line` its last line),
    /// and how many bone lines the fast path read.
    fn finish(self, last_line: usize) -> Result<(SkeletonMotion, usize)> {
        self.check_frame_complete()?;
        if self.n_frames == 0 {
            return Err(Error::at_line(
                ErrorKind::EmptySequence,
                self.origin,
                last_line,
                "no frames; expected a frame number line then bone lines",
            ));
        }
        let origin = self.origin;
        SkeletonMotion::new(self.asf.skeleton.clone(), self.values)
            .map(|m| (m, self.fast_lines))
            .map_err(|e| e.in_file(origin))
    }
}

/// Turns AMC channel values into a [`Motion`] by forward kinematics (Y up, mm); the name is
/// the AMC's stem.
pub fn amc_motion(
    channels: SkeletonMotion,
    origin: &Path,
    frame_rate: FrameRate,
) -> Result<Motion> {
    let positions = channels.positions();
    let names = channels.skeleton.point_names();
    let mut motion = Motion::new(
        crate::read::stem(origin),
        frame_rate,
        Axis::Y,
        PointKind::Joint,
        names,
        positions,
    )
    .map_err(|e| e.in_file(origin))?
    .with_source(origin, "asf_amc");
    motion.skeleton = Some(channels);
    Ok(motion)
}

/// Reads an AMC file with the skeleton of an ASF file (both may be `.gz`).
pub fn load_asf_amc(amc: &Path, asf: &Path, frame_rate: FrameRate) -> Result<Motion> {
    let skeleton = parse_asf(&crate::read::read_text(asf)?, asf)?;
    let channels = parse_amc(&crate::read::read_text(amc)?, amc, &skeleton)?;
    amc_motion(channels, amc, frame_rate)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two bones in inches and radians: `a` straight up 2 in (dof rz rx), `b` 1 in along x with
    /// axis C = 90° about z (dof rx).
    const ASF: &str = "# test\n:version 1.10\n:name T\n:units\n  mass 1.0\n  length 1\n  angle rad\n:documentation\n  free text : here\n:root\n  order TX TY TZ RX RY RZ\n  axis XYZ\n  position 0 0 0\n  orientation 0 0 0\n:bonedata\n  begin\n    id 1\n    name a\n    direction 0 1 0\n    length 2\n    axis 0 0 0 XYZ\n    dof rz rx\n    limits (-180 180)\n           (-90 90)\n  end\n  begin\n    name b\n    direction 1 0 0\n    length 1\n    axis 0 0 1.5707963267948966 XYZ\n    dof rx\n  end\n:hierarchy\n  begin\n    root a\n    a b\n  end\n";

    const HALF_PI: &str = "1.5707963267948966";

    fn asf() -> AsfSkeleton {
        parse_asf(ASF, Path::new("t.asf")).unwrap()
    }

    fn amc(header: &str, a: &str, b: &str) -> String {
        format!("{header}1\nroot 1 0 0 0 0 0\na {a}\nb {b}\n2\nroot 0 0 0 0 0 0\nb 0\na 0 0\n")
    }

    fn close(p: [f64; 3], q: [f64; 3]) -> bool {
        p.iter().zip(q).all(|(a, b)| (a - b).abs() < 1e-9)
    }

    #[test]
    fn skeleton_maps_bones_to_joints_at_their_start() {
        let s = asf();
        assert_eq!(s.name, "T");
        assert_eq!(s.mm_per_unit, 25.4);
        assert_eq!(s.length_unit, Some(LengthUnit::Inch));
        let names: Vec<&str> = s.skeleton.joints.iter().map(|j| j.name.as_str()).collect();
        assert_eq!(names, ["root", "a", "b"]);
        assert_eq!(s.skeleton.point_names(), ["root", "a", "b", "b_end"]);
        // a starts at the root; b starts at a's end; b is a leaf with its tip as end site.
        assert_eq!(s.skeleton.joints[1].offset, [0.0; 3]);
        assert_eq!(s.skeleton.joints[2].offset, [0.0, 50.8, 0.0]);
        assert_eq!(s.skeleton.joints[2].end_sites, vec![[25.4, 0.0, 0.0]]);
        assert_eq!(
            s.skeleton.joints[1].channels,
            [ChannelKind::Rotation(Axis::Z), ChannelKind::Rotation(Axis::X)]
        );
        assert_eq!(s.skeleton.joints[1].rotation_order, CMU_ROTATION_ORDER);
    }

    #[test]
    fn amc_in_radians_gives_known_positions() {
        let s = asf();
        let text = amc(":FULLY-SPECIFIED\n:RADIANS\n", &format!("{HALF_PI} 0"), HALF_PI);
        let ch = parse_amc(&text, Path::new("t.amc"), &s).unwrap();
        assert_eq!(ch.n_frames(), 2);
        // Stored in degrees, in dof order (rz, rx); root translation in mm.
        assert!(close(
            [ch.frame_values(0)[0], ch.frame_values(0)[6], ch.frame_values(0)[7]],
            [25.4, 90.0, 0.0]
        ));
        let m = amc_motion(ch, Path::new("t.amc"), FrameRate::new(120.0).unwrap()).unwrap();
        // Root at x = 1 in. a turned 90° about z: b = root + Rz(90)·(0, 2 in, 0) = (−1 in, 0, 0).
        // b's rx = 90° about its local x, which C turns onto global y: Rz(90)·Ry(90)·(1 in, 0, 0).
        assert!(close(m.position(0, 2), [-25.4, 0.0, 0.0]), "{:?}", m.position(0, 2));
        assert!(close(m.position(0, 3), [-25.4, 0.0, -25.4]), "{:?}", m.position(0, 3));
        // Frame 2 lists b before a: order does not matter; all zero = rest pose.
        assert!(close(m.position(1, 3), [25.4, 50.8, 0.0]), "{:?}", m.position(1, 3));
    }

    #[test]
    fn degrees_header_overrides_the_asf_angle_unit() {
        let text = amc(":DEGREES\n", "90 0", "90");
        let ch = parse_amc(&text, Path::new("t.amc"), &asf()).unwrap();
        assert_eq!(ch.frame_values(0)[6], 90.0);
        let no_header = parse_amc(&amc("", "1 0", "0"), Path::new("t.amc"), &asf()).unwrap();
        assert!((no_header.frame_values(0)[6] - 1f64.to_degrees()).abs() < 1e-12);
    }

    #[test]
    fn axis_orders_compose_first_letter_first() {
        let xyz = axis_matrix([90.0, 90.0, 0.0], [Axis::X, Axis::Y, Axis::Z]);
        let zyx = axis_matrix([90.0, 90.0, 0.0], [Axis::Z, Axis::Y, Axis::X]);
        // XYZ: Ry(90)·Rx(90); ZYX: Rx(90)·Ry(90). They differ on the z unit vector.
        let z = nalgebra::Vector3::z();
        let (a, b) = (xyz * z, zyx * z);
        assert!((a - nalgebra::Vector3::new(0.0, -1.0, 0.0)).norm() < 1e-12, "{a}");
        assert!((b - nalgebra::Vector3::new(1.0, 0.0, 0.0)).norm() < 1e-12, "{b}");
    }

    #[test]
    fn amc_structure_errors_name_their_line() {
        let s = asf();
        let cases = [
            ("1\nroot 0 0 0 0 0 0\na 0 0\nb 0\n3\n", ErrorKind::Syntax, 5), // frame number gap
            ("1\nroot 0 0 0 0 0 0\na 0 0\na 0 0\nb 0\n", ErrorKind::DuplicateName, 4),
            ("root 0 0 0 0 0 0\n", ErrorKind::Syntax, 1), // before any frame
            ("1\nroot 0 0 0 0 0 0\nb 0\n", ErrorKind::WrongValueCount, 1), // a missing
            ("1 2\nroot 0 0 0 0 0 0\n", ErrorKind::Syntax, 1),
            ("1\nroot 0 0 0 0 0 0\na 0 0\nb 0\n:DEGREES\n", ErrorKind::Syntax, 5),
            ("# only a comment\n:DEGREES\n", ErrorKind::EmptySequence, 3),
        ];
        for (text, kind, line) in cases {
            let e = parse_amc(text, Path::new("t.amc"), &s).unwrap_err();
            assert_eq!((e.kind(), e.location().line), (kind, Some(line)), "{text:?}: {e}");
            assert!(e.to_string().starts_with(&format!("t.amc:{line}: ")), "{e}");
        }
    }

    #[test]
    fn asf_structure_errors_name_their_line() {
        let cases = [
            (ASF.replace("    a b\n", "    a b\n    b b\n"), ErrorKind::DuplicateName),
            (ASF.replace("    a b\n", ""), ErrorKind::Syntax), // b never attached
            (ASF.replace("    dof rx\n", "    dof rx l\n"), ErrorKind::Syntax),
            (ASF.replace("    dof rx\n", "    dof tx\n"), ErrorKind::Syntax),
            (ASF.replace("    dof rx\n", "    dof rx rx\n"), ErrorKind::DuplicateName),
            (ASF.replace("name b", "name a"), ErrorKind::DuplicateName),
            (ASF.replace("length 1\n    axis", "length inf\n    axis"), ErrorKind::NonFinite),
            (ASF.replace("direction 1 0 0", "direction 1 0"), ErrorKind::WrongValueCount),
            (ASF.replace("axis 0 0 0 XYZ", "axis 0 0 0 XXZ"), ErrorKind::Syntax),
            (ASF.replace("  angle rad", "  angle grad"), ErrorKind::Syntax),
            (ASF.replace("  length 1\n", "  length 0\n"), ErrorKind::OutOfRange),
        ];
        for (text, kind) in cases {
            let e = parse_asf(&text, Path::new("t.asf")).unwrap_err();
            assert_eq!(e.kind(), kind, "{e}");
            assert!(e.to_string().starts_with("t.asf:"), "{e}");
        }
        // A self-parent makes a cycle that never reaches root.
        let cyclic = ASF.replace("    a b\n", "    b b\n");
        let e = parse_asf(&cyclic, Path::new("t.asf")).unwrap_err();
        assert!(e.message().contains("cycle"), "{e}");
        let e =
            parse_asf(&ASF.replace(":hierarchy", ":hierarchx"), Path::new("t.asf")).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::Syntax);
        let e =
            parse_asf(&ASF[..ASF.find("  end\n  begin\n    name b").unwrap()], Path::new("t.asf"))
                .unwrap_err();
        assert_eq!(e.kind(), ErrorKind::Truncated);
    }

    /// The bone-line fast path reads every shipped AMC take to the same bits as the general
    /// scanner (every channel value, via `f64::to_bits`), and reads all its bone lines but the
    /// first frame's.
    #[test]
    fn fast_path_reads_every_shipped_take_like_the_general_scanner() {
        let takes = [
            "cmu86/86_01.amc.gz",
            "cmu86/86_09.amc.gz",
            "mocap6/amc/13_29.amc.gz",
            "mocap6/amc/13_30.amc.gz",
            "mocap6/amc/13_31.amc.gz",
            "mocap6/amc/14_14.amc.gz",
            "mocap6/amc/14_20.amc.gz",
        ];
        for take in takes {
            let path = motionlab_testkit::data_path(take);
            let asf_path = discover_asf(&path).unwrap();
            let asf = parse_asf(&crate::read::read_text(&asf_path).unwrap(), &asf_path).unwrap();
            let text = crate::read::read_text(&path).unwrap();
            let (fast, fast_lines) = parse_amc_with(&text, &path, &asf, true).unwrap();
            let (general, no_lines) = parse_amc_with(&text, &path, &asf, false).unwrap();
            assert!(fast.n_frames() > 1000, "{take}");
            // Every bone line goes the fast way on these files but the first frame's (no order
            // yet) and those in the last 256 bytes (the window does not fit).
            let bones_with_dofs =
                asf.skeleton.joints.iter().filter(|j| !j.channels.is_empty()).count();
            let most = (fast.n_frames() - 1) * bones_with_dofs;
            assert!(
                fast_lines <= most && fast_lines + bones_with_dofs >= most,
                "{take}: {fast_lines} of {most}"
            );
            assert_eq!(no_lines, 0);
            let bits = |m: &SkeletonMotion| {
                m.channel_values().iter().map(|v| v.to_bits()).collect::<Vec<u64>>()
            };
            assert_eq!(bits(&fast), bits(&general), "{take}");
        }
    }

    /// Lines the fast path must leave to the general scanner still give its errors, with the
    /// same line, also after frames it read fast.
    #[test]
    fn fast_path_leaves_odd_lines_to_the_general_scanner() {
        let s = asf();
        // Enough frames that the fast path's window fits (it needs 256 bytes ahead).
        let frame = |n: usize| format!("{n}\nroot 1 0 0 0 0 0\na 0.5 -1.25\nb 2.0\n");
        let frames: String = (1..=20).map(frame).collect();
        let ok = parse_amc(&frames, Path::new("t.amc"), &s).unwrap();
        assert_eq!(
            ok.frame_values(19)[6..9],
            [0.5f64.to_degrees(), (-1.25f64).to_degrees(), 2f64.to_degrees()]
        );
        // Frame 3 is lines 9–12: its `a` line is line 11, its `b` line 12.
        let cases = [
            ("a 0.5 -1.25\n", "a 0.5 -1.25 7\n", ErrorKind::WrongValueCount, 11),
            ("a 0.5 -1.25\n", "a 0.5\n", ErrorKind::WrongValueCount, 11),
            ("a 0.5 -1.25\n", "a 0.5 -1.2x5\n", ErrorKind::Syntax, 11),
            ("a 0.5 -1.25\n", "a 0.5 nan\n", ErrorKind::NonFinite, 11),
            ("a 0.5 -1.25\n", "c 0.5 -1.25\n", ErrorKind::UnknownName, 11),
            ("a 0.5 -1.25\n", "b 0.5\n", ErrorKind::DuplicateName, 12),
        ];
        for (from, to, kind, line) in cases {
            let mut text = String::new();
            for n in 1..=20 {
                let f = frame(n);
                text.push_str(&if n == 3 { f.replacen(from, to, 1) } else { f });
            }
            let e = parse_amc(&text, Path::new("t.amc"), &s).unwrap_err();
            assert_eq!((e.kind(), e.location().line), (kind, Some(line)), "{to:?}: {e}");
        }
        // Values the fast path hands over (exponents, long mantissas, a `+`, CRLF) read alike.
        let odd = frames
            .replace("a 0.5 -1.25\n", "a 5e-1 -1.2500000000000000000001\r\n")
            .replace("b 2.0\n", "b\t+2.0 \n");
        let odd = parse_amc(&odd, Path::new("t.amc"), &s).unwrap();
        assert_eq!(odd.channel_values(), ok.channel_values());
    }

    #[test]
    fn params_are_validated() {
        let e = motionlab_core::registry::build_loader(
            "asf_amc",
            &toml::from_str("frame_rate_hz = 0.0").unwrap(),
        )
        .err()
        .unwrap();
        assert_eq!(e.location().field.as_deref(), Some("frame_rate_hz"));
        let e = motionlab_core::registry::build_loader(
            "asf_amc",
            &toml::from_str("skeleton = \" \"").unwrap(),
        )
        .err()
        .unwrap();
        assert_eq!(e.location().field.as_deref(), Some("skeleton"));
        assert_eq!(
            asf_candidates(Path::new("d/amc/86_01.amc.gz")),
            ["d/amc/86.asf", "d/amc/86.asf.gz", "d/amc/../asf/86.asf", "d/amc/../asf/86.asf.gz"]
                .map(PathBuf::from)
        );
    }

    #[test]
    fn no_truncation_or_byte_change_panics() {
        let amc_text = amc(":DEGREES\n", "90 0", "90");
        for cut in 0..ASF.len() {
            let _ = parse_asf(&ASF[..cut], Path::new("f.asf"));
        }
        for cut in 0..amc_text.len() {
            let _ = parse_amc(&amc_text[..cut], Path::new("f.amc"), &asf());
        }
        for i in 0..amc_text.len() {
            for b in ["0", "-", ":", "#", " ", "\n", "é", "nan", "a"] {
                let t = format!("{}{b}{}", &amc_text[..i], &amc_text[i + 1..]);
                let _ = parse_amc(&t, Path::new("f.amc"), &asf());
            }
        }
        for i in (0..ASF.len()).step_by(3) {
            for b in ["0", ":", "#", "\n", "é", "x"] {
                let t = format!("{}{b}{}", &ASF[..i], &ASF[i + 1..]);
                let _ = parse_asf(&t, Path::new("f.asf"));
            }
        }
    }
}
