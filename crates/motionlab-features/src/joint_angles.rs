//! Joint angles: Cardan angles of ISB anatomical frames built from skin markers, and the
//! rotation channels of skeleton motions (BVH, ASF/AMC) — the input of Osafune et al. §2.2.
//!
//! ## Written by hand
//!
//! The frames and the Cardan decomposition are a few dozen lines of vector algebra on top of
//! `nalgebra` (already in the workspace for forward kinematics). No crate implements the ISB
//! marker-to-segment definitions for this marker set; `nalgebra`'s own `euler_angles` covers a
//! single sequence (Z-Y-X) and is used in the tests as the independent reference for it.
//!
//! ## Conventions
//!
//! Every segment frame is right-handed with **X anterior, Y superior (proximal), Z to the
//! subject's right** — the ISB convention (Wu et al. 2002, 2005) — on *both* sides, so left and
//! right frames coincide in a neutral standing pose. Matrices hold the frame's axes as columns
//! in lab coordinates. The rotation of a distal segment relative to its proximal segment is
//! `R = R_proximalᵀ · R_distal`, decomposed as `R = R_a1(θ1) · R_a2(θ2) · R_a3(θ3)` for the
//! chosen sequence (intrinsic: first about the proximal axis `a1`, last about the distal axis
//! `a3`). With the default sequence Z-X-Y this is the joint coordinate system of Grood & Suntay
//! (1983) that the ISB recommends for hip, knee and ankle: flexion about the proximal Z,
//! ab/adduction about the floating X, axial rotation about the distal Y.

use std::sync::Arc;

use nalgebra::{Matrix3, Vector3};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::AngleCurves;
use motionlab_core::registry::ParamGuard;
use motionlab_core::{
    ChannelKind, Error, ErrorKind, FeatureCache, FeatureExtractor, FeatureSet, FrameRate, Location,
    Motion, Result, SkeletonMotion, Trace,
};

// ---------------------------------------------------------------------------------------------
// Cardan angles
// ---------------------------------------------------------------------------------------------

/// A Cardan (Tait–Bryan) sequence of three distinct axes, rotations composed intrinsically:
/// `zxy` means `R = Rz(θ1) · Rx(θ2) · Ry(θ3)`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum CardanSequence {
    /// Flexion (Z), ab/adduction (X), axial rotation (Y): ISB / Grood–Suntay.
    #[default]
    Zxy,
    Zyx,
    Xyz,
    Xzy,
    Yxz,
    Yzx,
}

impl CardanSequence {
    pub const ALL: [CardanSequence; 6] = [
        CardanSequence::Zxy,
        CardanSequence::Zyx,
        CardanSequence::Xyz,
        CardanSequence::Xzy,
        CardanSequence::Yxz,
        CardanSequence::Yzx,
    ];

    /// Axis indices (0 = X, 1 = Y, 2 = Z) in composition order.
    pub fn axes(self) -> [usize; 3] {
        match self {
            CardanSequence::Zxy => [2, 0, 1],
            CardanSequence::Zyx => [2, 1, 0],
            CardanSequence::Xyz => [0, 1, 2],
            CardanSequence::Xzy => [0, 2, 1],
            CardanSequence::Yxz => [1, 0, 2],
            CardanSequence::Yzx => [1, 2, 0],
        }
    }

    /// +1 when the axes are a cyclic (even) permutation of X, Y, Z.
    fn parity(self) -> f64 {
        let [i, j, _] = self.axes();
        if (i + 1) % 3 == j { 1.0 } else { -1.0 }
    }
}

fn elementary(axis: usize, radians: f64) -> Matrix3<f64> {
    let (s, c) = radians.sin_cos();
    match axis {
        0 => Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c),
        1 => Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c),
        _ => Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0),
    }
}

/// `R = R_a1(θ1) · R_a2(θ2) · R_a3(θ3)` from angles in degrees, in sequence order.
pub fn rotation_from_cardan(sequence: CardanSequence, angles_deg: [f64; 3]) -> Matrix3<f64> {
    let [a, b, c] = sequence.axes();
    elementary(a, angles_deg[0].to_radians())
        * elementary(b, angles_deg[1].to_radians())
        * elementary(c, angles_deg[2].to_radians())
}

/// Below this `|cos θ2|` the first and third axes are aligned (gimbal lock): only `θ1 ± θ3` is
/// defined, and the decomposition reports `θ3 = 0`.
pub const GIMBAL_LOCK_COS: f64 = 1e-12;

/// Angles (degrees, in sequence order) with `R = R_a1(θ1) · R_a2(θ2) · R_a3(θ3)`;
/// `θ2 ∈ [−90°, 90°]`, `θ1, θ3 ∈ (−180°, 180°]`. At gimbal lock (`|cos θ2| <` [`GIMBAL_LOCK_COS`])
/// `θ3 = 0` and `θ1` carries the whole rotation about the aligned axes.
///
/// With `(i, j, k)` the axes and `ε = ±1` their parity: `θ2 = atan2(ε·r_ik, √(r_ii² + r_ij²))`,
/// `θ1 = atan2(−ε·r_jk, r_kk)`, `θ3 = atan2(−ε·r_ij, r_ii)`.
pub fn cardan_angles(r: &Matrix3<f64>, sequence: CardanSequence) -> [f64; 3] {
    let [i, j, k] = sequence.axes();
    let e = sequence.parity();
    let cos2 = (r[(i, i)] * r[(i, i)] + r[(i, j)] * r[(i, j)]).sqrt();
    let t2 = (e * r[(i, k)]).atan2(cos2);
    let (t1, t3) = if cos2 < GIMBAL_LOCK_COS {
        ((e * r[(k, j)]).atan2(r[(j, j)]), 0.0)
    } else {
        ((-e * r[(j, k)]).atan2(r[(k, k)]), (-e * r[(i, j)]).atan2(r[(i, i)]))
    };
    [t1.to_degrees(), t2.to_degrees(), t3.to_degrees()]
}

/// The Cardan angles re-ordered by axis: `[about Z, about X, about Y]` in degrees, whatever
/// the sequence (so "flexion" is always the Z angle).
fn angles_by_axis(r: &Matrix3<f64>, sequence: CardanSequence) -> [f64; 3] {
    let t = cardan_angles(r, sequence);
    let mut by_axis = [0.0; 3]; // X, Y, Z
    for (angle, axis) in t.into_iter().zip(sequence.axes()) {
        by_axis[axis] = angle;
    }
    [by_axis[2], by_axis[0], by_axis[1]]
}

// ---------------------------------------------------------------------------------------------
// Segment frames from markers
// ---------------------------------------------------------------------------------------------

type V3 = Vector3<f64>;

/// Two directions closer to parallel than this (|a × b| < ε |a| |b|) do not define a plane.
const DEGENERATE_SIN: f64 = 1e-6;

fn unit(v: V3) -> Option<V3> {
    let n = v.norm();
    (n.is_finite() && n > 0.0).then(|| v / n)
}

fn unit_cross(a: &V3, b: &V3) -> Option<V3> {
    let c = a.cross(b);
    let scale = a.norm() * b.norm();
    (c.norm() > DEGENERATE_SIN * scale).then(|| c / c.norm())
}

/// Frame with the long axis `Y` along `y_dir` and `Z` in the plane of `y_dir` and `z_hint`
/// (pointing to the same side as `z_hint`): `Y = ŷ`, `X = Y × ẑ_hint / |…|`, `Z = X × Y`.
pub fn frame_from_y_z(y_dir: V3, z_hint: V3) -> Option<Matrix3<f64>> {
    let y = unit(y_dir)?;
    let x = unit_cross(&y, &z_hint)?;
    Some(Matrix3::from_columns(&[x, y, x.cross(&y)]))
}

/// Frame with `Z` along `z_dir` and `X` in the plane of `z_dir` and `x_hint`:
/// `Z = ẑ`, `Y = Z × x_hint / |…|`, `X = Y × Z`.
pub fn frame_from_z_x(z_dir: V3, x_hint: V3) -> Option<Matrix3<f64>> {
    let z = unit(z_dir)?;
    let y = unit_cross(&z, &x_hint)?;
    Some(Matrix3::from_columns(&[y.cross(&z), y, z]))
}

/// Frame with `X` along `x_dir` and `Z` in the plane of `x_dir` and `z_hint`:
/// `X = x̂`, `Y = z_hint × X / |…|`, `Z = X × Y`.
pub fn frame_from_x_z(x_dir: V3, z_hint: V3) -> Option<Matrix3<f64>> {
    let x = unit(x_dir)?;
    let y = unit_cross(&z_hint, &x)?;
    Some(Matrix3::from_columns(&[x, y, x.cross(&y)]))
}

/// Frame with `Y` along `y_dir` and `X` in the plane of `y_dir` and `x_hint`:
/// `Y = ŷ`, `Z = x_hint × Y / |…|`, `X = Y × Z`.
pub fn frame_from_y_x(y_dir: V3, x_hint: V3) -> Option<Matrix3<f64>> {
    let y = unit(y_dir)?;
    let z = unit_cross(&x_hint, &y)?;
    Some(Matrix3::from_columns(&[y.cross(&z), y, z]))
}

fn mid(a: V3, b: V3) -> V3 {
    (a + b) * 0.5
}

// ---------------------------------------------------------------------------------------------
// The plugin
// ---------------------------------------------------------------------------------------------

/// A joint (or a segment relative to the lab) whose three Cardan angles are reported.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum JointName {
    /// Pelvis relative to the progression frame: `pelvis.tilt`, `pelvis.obliquity`, `pelvis.rotation`.
    Pelvis,
    /// Thorax relative to the progression frame: `thorax.tilt`, `thorax.obliquity`, `thorax.rotation`.
    Thorax,
    /// Thorax relative to the pelvis: `lumbar.flexion`, `lumbar.lateral_bending`, `lumbar.rotation`.
    Lumbar,
    /// Thigh relative to pelvis, both sides: `hip_l.flexion`, `hip_l.abduction`, `hip_l.rotation`, `hip_r.*`.
    Hip,
    /// Shank relative to thigh: `knee_l.flexion`, `knee_l.abduction`, `knee_l.rotation`, `knee_r.*`.
    Knee,
    /// Foot relative to shank: `ankle_l.flexion`, `ankle_l.inversion`, `ankle_l.rotation`, `ankle_r.*`.
    Ankle,
    /// Upper arm relative to thorax: `shoulder_l.flexion`, `shoulder_l.abduction`, `shoulder_l.rotation`, `shoulder_r.*`.
    Shoulder,
    /// Forearm relative to upper arm: `elbow_l.flexion`, `elbow_l.abduction`, `elbow_l.pronation`, `elbow_r.*`.
    Elbow,
    /// Hand relative to forearm: `wrist_l.flexion`, `wrist_l.abduction`, `wrist_l.rotation`, `wrist_r.*`.
    Wrist,
}

impl JointName {
    pub const ALL: [JointName; 9] = [
        JointName::Pelvis,
        JointName::Thorax,
        JointName::Lumbar,
        JointName::Hip,
        JointName::Knee,
        JointName::Ankle,
        JointName::Shoulder,
        JointName::Elbow,
        JointName::Wrist,
    ];
}

/// Hip joint centre regression from the pelvis markers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum HipCentre {
    /// Harrington et al. (2007), J Biomech 40:595: from the mid-ASIS point, in the pelvis frame,
    /// `x = −0.24·PD − 9.9`, `y = −0.30·PW − 10.9`, `z = ±(0.33·PW + 7.3)` mm, with PW the
    /// inter-ASIS distance and PD the distance between the ASIS and PSIS midpoints.
    #[default]
    Harrington2007,
    /// Bell et al. (1990), Hum Mov Sci 9:3: `x = −0.19·PW`, `y = −0.30·PW`, `z = ±0.36·PW`.
    Bell1990,
}

/// Joint angles in degrees from the ISB skin markers of Schreiber & Moissenet (2019)
/// (52 markers: `L_IAS` … `R_HM5`), as Cardan angles of each distal segment relative to its
/// proximal one — the joint-rotation channels of Osafune et al. §2.2.
///
/// Every frame is right-handed, X anterior, Y superior/proximal, Z to the subject's right, on
/// both sides (ISB, Wu et al. 2002/2005). `s` is `L_`/`R_`; `±` is `+` on the right and `−` on
/// the left so that Z points right on both sides; `mid(a, b)` is the midpoint.
///
/// | segment | long axis / primary | plane / helper | markers |
/// |---|---|---|---|
/// | pelvis | Z = R_IAS − L_IAS | X in the plane, from mid(IPS) towards mid(IAS) | L/R_IAS, L/R_IPS |
/// | thigh | Y = HJC − KJC, KJC = mid(sFLE, sFME) | Z in the plane of Y and ±(sFLE − sFME) | pelvis + sFLE, sFME |
/// | shank | Y = KJC − AJC, AJC = mid(sFAL, sTAM) | Z in the plane of Y and ±(sFAL − sTAM) | sFLE, sFME, sFAL, sTAM |
/// | foot | X = sFM2 − sFCC | Z in the plane of X and ±(sFM5 − sFM1) | sFCC, sFM1, sFM2, sFM5 |
/// | thorax | Y = mid(SJN, CV7) − mid(SXS, TV10) | X in the plane of Y and SJN − CV7 | CV7, TV10, SXS, SJN |
/// | upper arm | Y = GH − EC, EC = mid(sHLE, sHME) | Z in the plane of Y and ±(sHLE − sHME) | thorax + L/R_SAE, sHLE, sHME |
/// | forearm | Y = EC − sUHE | Z in the plane of Y and ±(sRSP − sUHE) | sHLE, sHME, sRSP, sUHE |
/// | hand | Y = mid(sRSP, sUHE) − mid(sHM2, sHM5) | Z in the plane of Y and ±(sHM2 − sHM5) | sRSP, sUHE, sHM2, sHM5 |
///
/// "Y along v, Z in the plane of Y and h" means `Y = v̂`, `X = Y × ĥ` (normalised), `Z = X × Y`.
/// HJC (hip joint centre) comes from the `hip_centre` regression; GH (shoulder centre) is the
/// acromion marker sSAE moved down the thorax Y axis by `shoulder_centre_drop` × the distance
/// between L_SAE and R_SAE (Rab et al. 2002). Markers not used: sFTC, sFAX, sTTC, sSIA, sSRS,
/// sSAA, sUOA. The lab ("progression") frame: Y = up axis of the motion, X = horizontal
/// direction from the first to the last frame's centroid of all present markers (the lab's
/// first horizontal axis when that displacement is under 200 mm, e.g. on a treadmill), Z = X × Y.
///
/// Angles: `R = R_proximalᵀ · R_distal = R_a1(θ1) R_a2(θ2) R_a3(θ3)` for `sequence` (`zxy`:
/// flexion about the proximal Z, ab/adduction about the floating X, axial rotation about
/// the distal Y — Grood & Suntay / ISB), then reported per axis with anatomical signs (`α`
/// about Z, `β` about X, `γ` about Y; left-side `β` and `γ` are negated so a positive value
/// means the same motion on both sides):
///
/// | joint | channels (positive =) | from |
/// |---|---|---|
/// | pelvis / thorax (vs lab) | `tilt` (anterior tilt / forward lean), `obliquity` (rolled to the right), `rotation` (turned left) | −α, β, γ |
/// | lumbar (thorax vs pelvis) | `flexion`, `lateral_bending` (to the right), `rotation` (thorax turned left) | −α, β, γ |
/// | hip, shoulder | `flexion`, `abduction`, `rotation` (internal) | α, ∓β, ±γ |
/// | knee | `flexion`, `abduction` (valgus), `rotation` (internal) | −α, ∓β, ±γ |
/// | ankle | `flexion` (dorsiflexion), `inversion`, `rotation` (internal, toe in) | α, ±β, ±γ |
/// | elbow | `flexion`, `abduction`, `pronation` | α, ∓β, ±γ |
/// | wrist | `flexion` (palmar), `abduction` (radial deviation), `rotation` | α, ∓β, ±γ |
///
/// One sequence serves every joint: the ISB's Y-X-Y for the shoulder is singular with the arms
/// hanging (elevation 0°), which is how they are while walking. Zero is the anatomical pose
/// (palms forward): forearms hanging in the usual half-pronated way read ~90–130° pronation.
///
/// Channels are named `<joint>.<axis>` (`knee_l.flexion`); the feature traces add the unit,
/// `knee_l.flexion_deg` ([`angle_curves_from_features`] turns them back into curves).
///
/// Missing samples: a segment frame is undefined at a frame where any of its markers is
/// missing (or its markers are collinear), and every angle that uses it is NaN at that frame;
/// other frames and joints are unaffected (no interpolation — fill gaps first if wanted). A
/// marker label absent from the whole file is an error naming it and its joint (leave the joint
/// out of `joints`), or — with `absent_markers = "nan"` — makes every channel that needs it NaN
/// throughout (two of the 18 Schreiber & Moissenet subjects, 2015026 and 2015032, were recorded
/// without the medial knee and ankle markers FME and TAM: their hip, knee and ankle channels).
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct IsbJointAnglesParams {
    /// Joints to compute; bilateral joints give both sides (all nine joints: 45 channels).
    #[serde(default = "all_joints")]
    pub joints: Vec<JointName>,
    /// Cardan sequence of the decomposition (intrinsic, proximal axis first).
    #[serde(default)]
    pub sequence: CardanSequence,
    /// Hip joint centre regression.
    #[serde(default)]
    pub hip_centre: HipCentre,
    /// Shoulder centre below the acromion marker SAE, as a fraction of the distance between
    /// the two SAE markers (dimensionless; the default is Rab et al. 2002's).
    #[serde(default = "default_shoulder_drop")]
    pub shoulder_centre_drop: f64,
    /// Label prefix of the left-side markers.
    #[serde(default = "default_left_prefix")]
    pub left_prefix: String,
    /// Label prefix of the right-side markers.
    #[serde(default = "default_right_prefix")]
    pub right_prefix: String,
    /// A marker label absent from the file: `"error"` or `"nan"` (the channels that need it are
    /// NaN).
    #[serde(default)]
    pub absent_markers: AbsentMarkers,
}

/// What to do when a marker label a joint needs is not in the file at all.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum AbsentMarkers {
    /// Refuse, naming the marker and the joint.
    #[default]
    Error,
    /// Leave the channels of every joint that needs it NaN.
    Nan,
}

fn all_joints() -> Vec<JointName> {
    JointName::ALL.to_vec()
}
fn default_shoulder_drop() -> f64 {
    0.17
}
fn default_left_prefix() -> String {
    "L_".into()
}
fn default_right_prefix() -> String {
    "R_".into()
}

impl Default for IsbJointAnglesParams {
    fn default() -> Self {
        IsbJointAnglesParams {
            joints: all_joints(),
            sequence: CardanSequence::default(),
            hip_centre: HipCentre::default(),
            shoulder_centre_drop: default_shoulder_drop(),
            left_prefix: default_left_prefix(),
            right_prefix: default_right_prefix(),
            absent_markers: AbsentMarkers::default(),
        }
    }
}

/// The validated stage.
#[derive(Clone, Debug)]
pub struct IsbJointAngles {
    joints: Vec<JointName>,
    sequence: CardanSequence,
    hip_centre: HipCentre,
    shoulder_centre_drop: f64,
    prefixes: [String; 2],
    absent_markers: AbsentMarkers,
}

impl ParamGuard for IsbJointAnglesParams {
    type Checked = IsbJointAngles;
    fn check(self) -> Result<IsbJointAngles> {
        if self.joints.is_empty() {
            return Err(Error::new(ErrorKind::InvalidParameter, "needs at least one joint")
                .with_field("joints"));
        }
        let mut joints = Vec::new();
        for j in self.joints {
            if joints.contains(&j) {
                return Err(Error::new(
                    ErrorKind::InvalidParameter,
                    format!("joint {j:?} is listed twice"),
                )
                .with_field("joints"));
            }
            joints.push(j);
        }
        if !(self.shoulder_centre_drop.is_finite()
            && (0.0..=1.0).contains(&self.shoulder_centre_drop))
        {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                format!("must be a fraction in [0, 1], found {}", self.shoulder_centre_drop),
            )
            .with_field("shoulder_centre_drop"));
        }
        if self.left_prefix == self.right_prefix {
            return Err(Error::new(
                ErrorKind::InvalidParameter,
                "left and right prefixes must differ",
            )
            .with_field("right_prefix"));
        }
        Ok(IsbJointAngles {
            joints,
            sequence: self.sequence,
            hip_centre: self.hip_centre,
            shoulder_centre_drop: self.shoulder_centre_drop,
            prefixes: [self.left_prefix, self.right_prefix],
            absent_markers: self.absent_markers,
        })
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Side {
    Left,
    Right,
}

impl Side {
    fn suffix(self) -> &'static str {
        match self {
            Side::Left => "_l",
            Side::Right => "_r",
        }
    }
    /// +1 on the right, −1 on the left: makes "lateral" hints point to the subject's right.
    fn sign(self) -> f64 {
        match self {
            Side::Left => -1.0,
            Side::Right => 1.0,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Segment {
    Lab,
    Pelvis,
    Thorax,
    Thigh(Side),
    Shank(Side),
    Foot(Side),
    UpperArm(Side),
    Forearm(Side),
    Hand(Side),
}

/// The markers the segment frames read (without side prefix).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mk {
    Ias,
    Ips,
    Fle,
    Fme,
    Fal,
    Tam,
    Fcc,
    Fm1,
    Fm2,
    Fm5,
    Cv7,
    Tv10,
    Sxs,
    Sjn,
    Sae,
    Hle,
    Hme,
    Rsp,
    Uhe,
    Hm2,
    Hm5,
}

impl Mk {
    const COUNT: usize = 21;
    fn label(self) -> &'static str {
        match self {
            Mk::Ias => "IAS",
            Mk::Ips => "IPS",
            Mk::Fle => "FLE",
            Mk::Fme => "FME",
            Mk::Fal => "FAL",
            Mk::Tam => "TAM",
            Mk::Fcc => "FCC",
            Mk::Fm1 => "FM1",
            Mk::Fm2 => "FM2",
            Mk::Fm5 => "FM5",
            Mk::Cv7 => "CV7",
            Mk::Tv10 => "TV10",
            Mk::Sxs => "SXS",
            Mk::Sjn => "SJN",
            Mk::Sae => "SAE",
            Mk::Hle => "HLE",
            Mk::Hme => "HME",
            Mk::Rsp => "RSP",
            Mk::Uhe => "UHE",
            Mk::Hm2 => "HM2",
            Mk::Hm5 => "HM5",
        }
    }
    /// Slot in a dense (marker, side) table: no hashing in the per-frame loop.
    fn slot(self, side: Option<Side>) -> usize {
        self as usize * 3
            + match side {
                None => 0,
                Some(Side::Left) => 1,
                Some(Side::Right) => 2,
            }
    }
}

impl Segment {
    const COUNT: usize = 15;
    fn id(self) -> usize {
        let side = |s: Side| usize::from(s == Side::Right);
        match self {
            Segment::Lab => 0,
            Segment::Pelvis => 1,
            Segment::Thorax => 2,
            Segment::Thigh(s) => 3 + side(s),
            Segment::Shank(s) => 5 + side(s),
            Segment::Foot(s) => 7 + side(s),
            Segment::UpperArm(s) => 9 + side(s),
            Segment::Forearm(s) => 11 + side(s),
            Segment::Hand(s) => 13 + side(s),
        }
    }
}

/// Marker labels (without side prefix) a segment frame reads: `(name, sided)`.
fn segment_markers(seg: Segment) -> Vec<(Mk, Option<Side>)> {
    let pelvis = vec![
        (Mk::Ias, Some(Side::Left)),
        (Mk::Ias, Some(Side::Right)),
        (Mk::Ips, Some(Side::Left)),
        (Mk::Ips, Some(Side::Right)),
    ];
    let thorax = vec![(Mk::Cv7, None), (Mk::Tv10, None), (Mk::Sxs, None), (Mk::Sjn, None)];
    let sided = |s: Side, names: &[Mk]| names.iter().map(|n| (*n, Some(s))).collect::<Vec<_>>();
    match seg {
        Segment::Lab => Vec::new(),
        Segment::Pelvis => pelvis,
        Segment::Thorax => thorax,
        Segment::Thigh(s) => [pelvis, sided(s, &[Mk::Fle, Mk::Fme])].concat(),
        Segment::Shank(s) => sided(s, &[Mk::Fle, Mk::Fme, Mk::Fal, Mk::Tam]),
        Segment::Foot(s) => sided(s, &[Mk::Fcc, Mk::Fm1, Mk::Fm2, Mk::Fm5]),
        Segment::UpperArm(s) => [
            thorax,
            vec![(Mk::Sae, Some(Side::Left)), (Mk::Sae, Some(Side::Right))],
            sided(s, &[Mk::Hle, Mk::Hme]),
        ]
        .concat(),
        Segment::Forearm(s) => sided(s, &[Mk::Hle, Mk::Hme, Mk::Rsp, Mk::Uhe]),
        Segment::Hand(s) => sided(s, &[Mk::Rsp, Mk::Uhe, Mk::Hm2, Mk::Hm5]),
    }
}

/// One reported joint: proximal and distal segment, channel names, and the signs applied to
/// (α about Z, β about X, γ about Y).
struct JointDef {
    proximal: Segment,
    distal: Segment,
    channels: [String; 3],
    signs: [f64; 3],
}

fn joint_defs(joint: JointName) -> Vec<JointDef> {
    let midline = |name: &str, axes: [&str; 3], signs: [f64; 3], proximal, distal| JointDef {
        proximal,
        distal,
        channels: axes.map(|a| format!("{name}.{a}")),
        signs,
    };
    let bilateral = |name: &str,
                     axes: [&str; 3],
                     sign_z: f64,
                     sign_x_right: f64,
                     sign_y_right: f64,
                     seg: fn(Side) -> (Segment, Segment)| {
        [Side::Left, Side::Right]
            .into_iter()
            .map(|s| {
                let (proximal, distal) = seg(s);
                JointDef {
                    proximal,
                    distal,
                    channels: axes.map(|a| format!("{name}{}.{a}", s.suffix())),
                    // Left-side β and γ are negated: the mirror image of the same motion.
                    signs: [sign_z, sign_x_right * s.sign(), sign_y_right * s.sign()],
                }
            })
            .collect::<Vec<_>>()
    };
    match joint {
        JointName::Pelvis => vec![midline(
            "pelvis",
            ["tilt", "obliquity", "rotation"],
            [-1.0, 1.0, 1.0],
            Segment::Lab,
            Segment::Pelvis,
        )],
        JointName::Thorax => vec![midline(
            "thorax",
            ["tilt", "obliquity", "rotation"],
            [-1.0, 1.0, 1.0],
            Segment::Lab,
            Segment::Thorax,
        )],
        JointName::Lumbar => {
            vec![midline(
                "lumbar",
                ["flexion", "lateral_bending", "rotation"],
                [-1.0, 1.0, 1.0],
                Segment::Pelvis,
                Segment::Thorax,
            )]
        }
        JointName::Hip => {
            bilateral("hip", ["flexion", "abduction", "rotation"], 1.0, -1.0, 1.0, |s| {
                (Segment::Pelvis, Segment::Thigh(s))
            })
        }
        JointName::Knee => {
            bilateral("knee", ["flexion", "abduction", "rotation"], -1.0, -1.0, 1.0, |s| {
                (Segment::Thigh(s), Segment::Shank(s))
            })
        }
        JointName::Ankle => {
            bilateral("ankle", ["flexion", "inversion", "rotation"], 1.0, 1.0, 1.0, |s| {
                (Segment::Shank(s), Segment::Foot(s))
            })
        }
        JointName::Shoulder => {
            bilateral("shoulder", ["flexion", "abduction", "rotation"], 1.0, -1.0, 1.0, |s| {
                (Segment::Thorax, Segment::UpperArm(s))
            })
        }
        JointName::Elbow => {
            bilateral("elbow", ["flexion", "abduction", "pronation"], 1.0, -1.0, 1.0, |s| {
                (Segment::UpperArm(s), Segment::Forearm(s))
            })
        }
        JointName::Wrist => {
            bilateral("wrist", ["flexion", "abduction", "rotation"], 1.0, -1.0, 1.0, |s| {
                (Segment::Forearm(s), Segment::Hand(s))
            })
        }
    }
}

/// Marker positions of one frame, looked up by (name, side); None when missing.
struct FrameMarkers<'a> {
    positions: &'a [[f64; 3]],
    missing: &'a [bool],
    /// Point index of each (marker, side) slot ([`Mk::slot`]); None when not in the file.
    index: &'a [Option<usize>],
}

impl FrameMarkers<'_> {
    fn get(&self, name: Mk, side: Option<Side>) -> Option<V3> {
        let k = self.index[name.slot(side)]?;
        (!self.missing[k]).then(|| V3::from(self.positions[k]))
    }
    fn s(&self, side: Side, name: Mk) -> Option<V3> {
        self.get(name, Some(side))
    }
}

impl IsbJointAngles {
    /// Channel names in output order.
    pub fn channel_names(&self) -> Vec<String> {
        self.joints.iter().flat_map(|j| joint_defs(*j)).flat_map(|d| d.channels).collect()
    }

    fn label(&self, name: Mk, side: Option<Side>) -> String {
        let name = name.label();
        match side {
            None => name.to_string(),
            Some(Side::Left) => format!("{}{name}", self.prefixes[0]),
            Some(Side::Right) => format!("{}{name}", self.prefixes[1]),
        }
    }

    /// The joint angles of a marker motion as curves (degrees, NaN where undefined).
    pub fn angle_curves(&self, motion: &Motion) -> Result<AngleCurves> {
        motion.require_frames(1, "isb_joint_angles")?;
        let defs: Vec<JointDef> = self.joints.iter().flat_map(|j| joint_defs(*j)).collect();
        // Resolve every label the requested joints need, naming the joint when one is absent.
        let mut index: Vec<Option<usize>> = vec![None; Mk::COUNT * 3];
        for (joint, def) in
            self.joints.iter().flat_map(|j| joint_defs(*j).into_iter().map(move |d| (*j, d)))
        {
            for seg in [def.proximal, def.distal] {
                for (name, side) in segment_markers(seg) {
                    if index[name.slot(side)].is_some() {
                        continue;
                    }
                    let label = self.label(name, side);
                    if self.absent_markers == AbsentMarkers::Nan
                        && !motion.point_names().contains(&label)
                    {
                        continue; // every frame that needs it is then undefined
                    }
                    let k = motion.point_index(&label).map_err(|e| {
                        let loc = motion.source.as_ref().map(Location::file).unwrap_or_default();
                        Error::new(
                            ErrorKind::UnknownName,
                            format!("{}; joint {joint:?} needs marker {label:?} (leave {joint:?} out of `joints` to skip it)", e.message()),
                        )
                        .with_location(loc.field(label.clone()))
                    })?;
                    index[name.slot(side)] = Some(k);
                }
            }
        }
        let lab = progression_frame(motion);
        let n = motion.n_frames();
        let mut values = vec![vec![f64::NAN; n]; defs.len() * 3];
        // The output is channel-major; the loop runs over frames and writes one column of it.
        #[allow(clippy::needless_range_loop)]
        for f in 0..n {
            let markers = FrameMarkers {
                positions: motion.frame(f),
                missing: motion.frame_missing(f),
                index: &index,
            };
            // Each segment frame is built once per frame, whatever number of joints use it.
            let mut cache: [Option<Option<Matrix3<f64>>>; Segment::COUNT] = [None; Segment::COUNT];
            for (d, def) in defs.iter().enumerate() {
                let mut frame_of = |seg: Segment| -> Option<Matrix3<f64>> {
                    *cache[seg.id()].get_or_insert_with(|| {
                        if seg == Segment::Lab {
                            Some(lab)
                        } else {
                            self.segment_frame(seg, &markers)
                        }
                    })
                };
                let (Some(p), Some(q)) = (frame_of(def.proximal), frame_of(def.distal)) else {
                    continue;
                };
                let angles = angles_by_axis(&(p.transpose() * q), self.sequence);
                for a in 0..3 {
                    values[d * 3 + a][f] = def.signs[a] * angles[a];
                }
            }
        }
        Ok(AngleCurves { frame_rate: motion.frame_rate(), channels: self.channel_names(), values })
    }

    fn pelvis(&self, m: &FrameMarkers) -> Option<(Matrix3<f64>, V3, f64, f64)> {
        let (lias, rias) = (m.s(Side::Left, Mk::Ias)?, m.s(Side::Right, Mk::Ias)?);
        let (lips, rips) = (m.s(Side::Left, Mk::Ips)?, m.s(Side::Right, Mk::Ips)?);
        let (mid_ias, mid_ips) = (mid(lias, rias), mid(lips, rips));
        let r = frame_from_z_x(rias - lias, mid_ias - mid_ips)?;
        Some((r, mid_ias, (rias - lias).norm(), (mid_ias - mid_ips).norm()))
    }

    fn hip_centre(&self, m: &FrameMarkers, side: Side) -> Option<V3> {
        let (r, origin, pw, pd) = self.pelvis(m)?;
        let local = match self.hip_centre {
            HipCentre::Harrington2007 => {
                V3::new(-0.24 * pd - 9.9, -0.30 * pw - 10.9, side.sign() * (0.33 * pw + 7.3))
            }
            HipCentre::Bell1990 => V3::new(-0.19 * pw, -0.30 * pw, side.sign() * 0.36 * pw),
        };
        Some(origin + r * local)
    }

    fn thorax(&self, m: &FrameMarkers) -> Option<Matrix3<f64>> {
        let (c7, t10, sxs, sjn) = (
            m.get(Mk::Cv7, None)?,
            m.get(Mk::Tv10, None)?,
            m.get(Mk::Sxs, None)?,
            m.get(Mk::Sjn, None)?,
        );
        frame_from_y_x(mid(sjn, c7) - mid(sxs, t10), sjn - c7)
    }

    fn segment_frame(&self, seg: Segment, m: &FrameMarkers) -> Option<Matrix3<f64>> {
        match seg {
            Segment::Lab => None,
            Segment::Pelvis => self.pelvis(m).map(|p| p.0),
            Segment::Thorax => self.thorax(m),
            Segment::Thigh(s) => {
                let (fle, fme) = (m.s(s, Mk::Fle)?, m.s(s, Mk::Fme)?);
                frame_from_y_z(self.hip_centre(m, s)? - mid(fle, fme), (fle - fme) * s.sign())
            }
            Segment::Shank(s) => {
                let (fle, fme, fal, tam) =
                    (m.s(s, Mk::Fle)?, m.s(s, Mk::Fme)?, m.s(s, Mk::Fal)?, m.s(s, Mk::Tam)?);
                frame_from_y_z(mid(fle, fme) - mid(fal, tam), (fal - tam) * s.sign())
            }
            Segment::Foot(s) => {
                let (fcc, fm1, fm2, fm5) =
                    (m.s(s, Mk::Fcc)?, m.s(s, Mk::Fm1)?, m.s(s, Mk::Fm2)?, m.s(s, Mk::Fm5)?);
                frame_from_x_z(fm2 - fcc, (fm5 - fm1) * s.sign())
            }
            Segment::UpperArm(s) => {
                let thorax = self.thorax(m)?;
                let (lsae, rsae) = (m.s(Side::Left, Mk::Sae)?, m.s(Side::Right, Mk::Sae)?);
                let sae = if s == Side::Left { lsae } else { rsae };
                let gh =
                    sae - thorax.column(1) * (self.shoulder_centre_drop * (rsae - lsae).norm());
                let (hle, hme) = (m.s(s, Mk::Hle)?, m.s(s, Mk::Hme)?);
                frame_from_y_z(gh - mid(hle, hme), (hle - hme) * s.sign())
            }
            Segment::Forearm(s) => {
                let (hle, hme, rsp, uhe) =
                    (m.s(s, Mk::Hle)?, m.s(s, Mk::Hme)?, m.s(s, Mk::Rsp)?, m.s(s, Mk::Uhe)?);
                frame_from_y_z(mid(hle, hme) - uhe, (rsp - uhe) * s.sign())
            }
            Segment::Hand(s) => {
                let (rsp, uhe, hm2, hm5) =
                    (m.s(s, Mk::Rsp)?, m.s(s, Mk::Uhe)?, m.s(s, Mk::Hm2)?, m.s(s, Mk::Hm5)?);
                frame_from_y_z(mid(rsp, uhe) - mid(hm2, hm5), (hm2 - hm5) * s.sign())
            }
        }
    }
}

/// Below this horizontal displacement (mm) over the whole motion the direction of travel is
/// not trusted and the lab's first horizontal axis is used instead.
pub const MIN_PROGRESSION_MM: f64 = 200.0;

/// The lab ("progression") frame: Y = up, X = horizontal direction of travel of the centroid of
/// the present markers from the first to the last frame that has any, Z = X × Y.
pub fn progression_frame(motion: &Motion) -> Matrix3<f64> {
    let up_index = motion.up_axis().index();
    let mut up = V3::zeros();
    up[up_index] = 1.0;
    let centroid = |f: usize| -> Option<V3> {
        let pts: Vec<V3> = motion
            .frame(f)
            .iter()
            .zip(motion.frame_missing(f))
            .filter(|(_, m)| !**m)
            .map(|(p, _)| V3::from(*p))
            .collect();
        (!pts.is_empty()).then(|| pts.iter().sum::<V3>() / pts.len() as f64)
    };
    let first = (0..motion.n_frames()).find_map(centroid);
    let last = (0..motion.n_frames()).rev().find_map(centroid);
    let fallback = {
        let mut x = V3::zeros();
        x[motion.up_axis().others()[0]] = 1.0;
        x
    };
    let forward = match (first, last) {
        (Some(a), Some(b)) => {
            let d = b - a;
            let horizontal = d - up * d.dot(&up);
            if horizontal.norm() >= MIN_PROGRESSION_MM {
                horizontal / horizontal.norm()
            } else {
                fallback
            }
        }
        _ => fallback,
    };
    Matrix3::from_columns(&[forward, up, forward.cross(&up)])
}

impl FeatureExtractor for IsbJointAngles {
    fn extract(&self, motion: &Motion, cache: &FeatureCache) -> Result<FeatureSet> {
        let key = format!(
            "isb_joint_angles/{:?}/{:?}/{:?}/{}/{}/{}/{:?}",
            self.joints,
            self.sequence,
            self.hip_centre,
            self.shoulder_centre_drop,
            self.prefixes[0],
            self.prefixes[1],
            self.absent_markers
        );
        let curves: Arc<AngleCurves> = cache.get_or_compute(&key, || self.angle_curves(motion))?;
        Ok(features_from_angle_curves(&curves))
    }
}

motionlab_core::register_plugin!(FeatureExtractor, IsbJointAnglesParams, "isb_joint_angles");

// ---------------------------------------------------------------------------------------------
// Curves <-> feature traces, and skeleton channels
// ---------------------------------------------------------------------------------------------

/// Angle curves as feature traces named `<channel>_deg` with unit `deg`.
pub fn features_from_angle_curves(curves: &AngleCurves) -> FeatureSet {
    FeatureSet {
        traces: curves
            .channels
            .iter()
            .zip(&curves.values)
            .map(|(c, v)| Trace::new(format!("{c}_deg"), "deg", v.clone()))
            .collect(),
        labels: Vec::new(),
    }
}

/// The inverse of [`features_from_angle_curves`]: every trace with unit `deg` becomes a channel
/// (its `_deg` suffix removed). Fails when there is none or their lengths differ.
pub fn angle_curves_from_features(
    features: &FeatureSet,
    frame_rate: FrameRate,
) -> Result<AngleCurves> {
    let degree: Vec<&Trace> = features.traces.iter().filter(|t| t.unit == "deg").collect();
    let Some(first) = degree.first() else {
        return Err(Error::new(
            ErrorKind::EmptySequence,
            "the feature set holds no trace in degrees (unit \"deg\"); expected joint angles",
        ));
    };
    if let Some(t) = degree.iter().find(|t| t.values.len() != first.values.len()) {
        return Err(Error::new(
            ErrorKind::WrongValueCount,
            format!(
                "angle trace {:?} has {} frames, {:?} has {}",
                t.name,
                t.values.len(),
                first.name,
                first.values.len()
            ),
        ));
    }
    Ok(AngleCurves {
        frame_rate,
        channels: degree
            .iter()
            .map(|t| t.name.strip_suffix("_deg").unwrap_or(&t.name).to_string())
            .collect(),
        values: degree.iter().map(|t| t.values.clone()).collect(),
    })
}

/// How skeleton rotation channels are named as angle channels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum ChannelNaming {
    /// `bvh` for motions loaded by the BVH loader, `short` otherwise.
    #[default]
    Auto,
    /// `LeftKnee.Xrotation` (BVH spelling).
    Bvh,
    /// `lfemur.rx` (ASF `dof` spelling).
    Short,
}

/// The rotation channels of a skeleton motion as angle curves (degrees): for BVH and AMC the
/// joint channels themselves are the angles (Osafune et al. used them directly). Translation
/// channels are left out. `naming` picks `LeftKnee.Xrotation` or `lfemur.rx` spelling.
pub fn skeleton_angle_curves(
    skeleton: &SkeletonMotion,
    frame_rate: FrameRate,
    naming: ChannelNaming,
) -> Result<AngleCurves> {
    let bvh = naming == ChannelNaming::Bvh;
    let mut channels = Vec::new();
    let mut values = Vec::new();
    let mut index = 0;
    for joint in &skeleton.skeleton.joints {
        for c in &joint.channels {
            if let ChannelKind::Rotation(_) = c {
                let spelled = if bvh { c.bvh_name() } else { c.short_name() };
                channels.push(format!("{}.{spelled}", joint.name));
                values.push(skeleton.channel(index));
            }
            index += 1;
        }
    }
    if channels.is_empty() {
        return Err(Error::new(
            ErrorKind::EmptySequence,
            "the skeleton has no rotation channel; expected joint rotations",
        ));
    }
    Ok(AngleCurves { frame_rate, channels, values })
}

/// [`skeleton_angle_curves`] of a loaded motion; fails when it has no skeleton.
pub fn motion_angle_curves(motion: &Motion, naming: ChannelNaming) -> Result<AngleCurves> {
    let Some(sk) = &motion.skeleton else {
        let loc = motion.source.as_ref().map(Location::file).unwrap_or_default();
        return Err(Error::new(
            ErrorKind::MissingData,
            format!("{} has no skeleton (format {:?}); joint channels need BVH or ASF/AMC, markers need `isb_joint_angles`", motion.name, motion.format),
        )
        .with_location(loc));
    };
    let naming = match naming {
        ChannelNaming::Auto if motion.format == "bvh" => ChannelNaming::Bvh,
        ChannelNaming::Auto => ChannelNaming::Short,
        other => other,
    };
    skeleton_angle_curves(sk, motion.frame_rate(), naming)
}

/// The rotation channels of a skeleton motion (BVH, ASF/AMC) as joint angles in degrees:
/// for skeleton formats the joint channels themselves are the angles (Osafune et al. §2.2).
///
/// Traces are named `<joint>.<channel>_deg`: `LeftKnee.Xrotation_deg` (BVH spelling) or
/// `lfemur.rx_deg` (ASF spelling), per `naming`. Translation channels are not angles and are
/// left out. Missing samples: skeleton channels have none (the loaders refuse non-finite
/// values); a motion without a skeleton is refused.
#[derive(Clone, Debug, Default, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SkeletonJointAnglesParams {
    /// Channel spelling: `"auto"` (BVH spelling for BVH files, ASF spelling otherwise),
    /// `"bvh"` or `"short"`.
    #[serde(default)]
    pub naming: ChannelNaming,
}

impl ParamGuard for SkeletonJointAnglesParams {
    type Checked = SkeletonJointAnglesParams;
    fn check(self) -> Result<Self> {
        Ok(self)
    }
}

impl FeatureExtractor for SkeletonJointAnglesParams {
    fn extract(&self, motion: &Motion, _cache: &FeatureCache) -> Result<FeatureSet> {
        Ok(features_from_angle_curves(&motion_angle_curves(motion, self.naming)?))
    }
}

motionlab_core::register_plugin!(
    FeatureExtractor,
    SkeletonJointAnglesParams,
    "skeleton_joint_angles"
);

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_core::registry::{build_feature_extractor, parse_params};
    use motionlab_core::{Axis, Joint, PointKind, Skeleton};
    use motionlab_testkit::{Rng, named_motion};

    fn max_abs_diff(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
        (a - b).abs().max()
    }

    #[test]
    fn cardan_angles_round_trip_for_every_sequence() {
        let mut rng = Rng::new(7);
        for seq in CardanSequence::ALL {
            for _ in 0..500 {
                let angles = [
                    rng.uniform() * 358.0 - 179.0,
                    rng.uniform() * 178.0 - 89.0,
                    rng.uniform() * 358.0 - 179.0,
                ];
                let back = cardan_angles(&rotation_from_cardan(seq, angles), seq);
                for k in 0..3 {
                    assert!((back[k] - angles[k]).abs() < 1e-9, "{seq:?} {angles:?} -> {back:?}");
                }
            }
        }
    }

    #[test]
    fn cardan_angles_near_and_at_gimbal_lock() {
        for seq in CardanSequence::ALL {
            // Near the lock the angles are still unique and recovered (to the conditioning of
            // the problem: ~1e-16 / cos θ2 radians).
            for t2 in [89.99, -89.999, 89.9999] {
                let angles = [35.0, t2, -120.0];
                let back = cardan_angles(&rotation_from_cardan(seq, angles), seq);
                for k in 0..3 {
                    assert!((back[k] - angles[k]).abs() < 1e-6, "{seq:?} {angles:?} -> {back:?}");
                }
            }
            // At the lock only θ1 ± θ3 is defined: the rotation must be reproduced with θ3 = 0.
            for t2 in [90.0, -90.0] {
                let r = rotation_from_cardan(seq, [35.0, t2, -120.0]);
                let back = cardan_angles(&r, seq);
                assert_eq!(back[2], 0.0, "{seq:?}");
                assert!((back[1] - t2).abs() < 1e-6, "{seq:?} {back:?}");
                assert!(
                    max_abs_diff(&rotation_from_cardan(seq, back), &r) < 1e-12,
                    "{seq:?} {back:?}"
                );
            }
        }
    }

    #[test]
    fn zyx_agrees_with_nalgebra_euler_angles() {
        // nalgebra's (roll, pitch, yaw) satisfy R = Rz(yaw)·Ry(pitch)·Rx(roll): our Z-Y-X
        // sequence, computed independently.
        let mut rng = Rng::new(11);
        for _ in 0..200 {
            let r = nalgebra::Rotation3::from_euler_angles(
                rng.uniform() * 6.0 - 3.0,
                rng.uniform() * 3.0 - 1.5,
                rng.uniform() * 6.0 - 3.0,
            );
            let (roll, pitch, yaw) = r.euler_angles();
            let ours = cardan_angles(r.matrix(), CardanSequence::Zyx);
            assert!((ours[0] - yaw.to_degrees()).abs() < 1e-9);
            assert!((ours[1] - pitch.to_degrees()).abs() < 1e-9);
            assert!((ours[2] - roll.to_degrees()).abs() < 1e-9);
        }
    }

    #[test]
    fn frames_from_markers_on_known_axes() {
        // Markers placed on the lab axes give the identity frame.
        let y = frame_from_y_z(V3::new(0.0, 300.0, 0.0), V3::new(0.0, 20.0, 80.0)).unwrap();
        assert!(max_abs_diff(&y, &Matrix3::identity()) < 1e-15);
        let z = frame_from_z_x(V3::new(0.0, 0.0, 250.0), V3::new(150.0, 0.0, 10.0)).unwrap();
        assert!(max_abs_diff(&z, &Matrix3::identity()) < 1e-15);
        let x = frame_from_x_z(V3::new(180.0, 0.0, 0.0), V3::new(5.0, 0.0, 60.0)).unwrap();
        assert!(max_abs_diff(&x, &Matrix3::identity()) < 1e-15);
        let yx = frame_from_y_x(V3::new(0.0, 400.0, 0.0), V3::new(120.0, 30.0, 0.0)).unwrap();
        assert!(max_abs_diff(&yx, &Matrix3::identity()) < 1e-15);
        // Collinear markers define no plane.
        assert!(frame_from_y_z(V3::new(0.0, 1.0, 0.0), V3::new(0.0, 2.0, 0.0)).is_none());
        assert!(frame_from_y_z(V3::zeros(), V3::new(0.0, 0.0, 1.0)).is_none());
    }

    /// ISB (X fwd, Y up, Z right) → lab (X fwd, Y left, Z up) for a subject facing +X.
    fn to_lab() -> Matrix3<f64> {
        Matrix3::new(1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 1.0, 0.0)
    }

    const LEG: [&str; 10] = ["FLE", "FME", "FAX", "TTC", "FAL", "TAM", "FCC", "FM1", "FM2", "FM5"];
    const ARM: [&str; 7] = ["HLE", "HME", "UOA", "RSP", "UHE", "HM2", "HM5"];

    fn isb_marker_names() -> Vec<String> {
        let mut v = Vec::new();
        for s in ["L_", "R_"] {
            for m in
                ["IAS", "IPS", "FTC", "SIA", "SRS", "SAA", "SAE"].iter().chain(&LEG).chain(&ARM)
            {
                v.push(format!("{s}{m}"));
            }
        }
        v.extend(["CV7", "TV10", "SXS", "SJN"].map(String::from));
        v
    }

    /// A pose: joint rotations (in ISB axes, relative to the proximal segment) per side
    /// (index 0 = left, 1 = right), the thorax relative to the pelvis, and the whole body.
    #[derive(Clone, Copy)]
    struct Pose {
        hip: [Matrix3<f64>; 2],
        knee: [Matrix3<f64>; 2],
        ankle: [Matrix3<f64>; 2],
        shoulder: [Matrix3<f64>; 2],
        elbow: [Matrix3<f64>; 2],
        wrist: [Matrix3<f64>; 2],
        lumbar: Matrix3<f64>,
        body: Matrix3<f64>,
    }

    fn neutral() -> Pose {
        let i = Matrix3::identity();
        Pose {
            hip: [i; 2],
            knee: [i; 2],
            ankle: [i; 2],
            shoulder: [i; 2],
            elbow: [i; 2],
            wrist: [i; 2],
            lumbar: i,
            body: i,
        }
    }

    /// Marker position (mm, ISB axes, origin mid-ASIS) of a pose in which, when neutral, every
    /// segment frame is exactly the pelvis frame (all joint angles 0).
    fn marker_isb(name: &str, pose: &Pose) -> V3 {
        let (side, base) = match name.split_once('_') {
            Some((s, b)) => (if s == "L" { -1.0 } else { 1.0 }, b),
            None => (0.0, name),
        };
        let si = usize::from(side > 0.0);
        let z = |v: f64| V3::new(0.0, 0.0, v * side);
        // Pelvis: PW = 240, PD = 160, both markers pairs level, so the pelvis frame is the identity.
        let hjc = V3::new(-0.24 * 160.0 - 9.9, -0.30 * 240.0 - 10.9, side * (0.33 * 240.0 + 7.3));
        let kjc = hjc + V3::new(0.0, -400.0, 0.0);
        let ajc = kjc + V3::new(0.0, -380.0, 0.0);
        let leg = |p: V3, level: usize| -> V3 {
            // level 1 = thigh, 2 = shank, 3 = foot: rotate about each joint centre in turn.
            let mut q = p;
            if level >= 3 {
                q = ajc + pose.ankle[si] * (q - ajc);
            }
            if level >= 2 {
                q = kjc + pose.knee[si] * (q - kjc);
            }
            hjc + pose.hip[si] * (q - hjc)
        };
        // Thorax: origin at mid(SXS, TV10) = (−50, 300, 0); arms hang from GH.
        let thorax_origin = V3::new(-50.0, 300.0, 0.0);
        let sae = V3::new(-50.0, 470.0, 190.0 * side);
        let gh = sae - V3::new(0.0, 0.17 * 380.0, 0.0);
        let ec = gh + V3::new(0.0, -300.0, 0.0);
        let uhe = ec + V3::new(0.0, -260.0, 0.0);
        let wc = uhe + z(20.0); // mid(RSP, UHE)
        let arm = |p: V3, level: usize| -> V3 {
            let mut q = p;
            if level >= 3 {
                q = wc + pose.wrist[si] * (q - wc);
            }
            if level >= 2 {
                q = ec + pose.elbow[si] * (q - ec);
            }
            gh + pose.shoulder[si] * (q - gh)
        };
        let trunk = |p: V3| thorax_origin + pose.lumbar * (p - thorax_origin);
        match base {
            "IAS" => z(120.0),
            "IPS" => V3::new(-160.0, 0.0, 45.0 * side),
            "FTC" => leg(hjc + z(70.0), 1),
            "FLE" => leg(kjc + z(50.0), 1),
            "FME" => leg(kjc - z(50.0), 1),
            "FAX" => leg(kjc + V3::new(-10.0, -50.0, 45.0 * side), 2),
            "TTC" => leg(kjc + V3::new(40.0, -60.0, 0.0), 2),
            "FAL" => leg(ajc + z(35.0), 2),
            "TAM" => leg(ajc - z(35.0), 2),
            "FCC" => leg(ajc + V3::new(-60.0, -50.0, 0.0), 3),
            "FM1" => leg(ajc + V3::new(120.0, -50.0, -25.0 * side), 3),
            "FM2" => leg(ajc + V3::new(140.0, -50.0, 0.0), 3),
            "FM5" => leg(ajc + V3::new(120.0, -50.0, 30.0 * side), 3),
            "CV7" => trunk(V3::new(-150.0, 480.0, 0.0)),
            "SJN" => trunk(V3::new(50.0, 480.0, 0.0)),
            "TV10" => trunk(V3::new(-160.0, 300.0, 0.0)),
            "SXS" => trunk(V3::new(60.0, 300.0, 0.0)),
            "SIA" => trunk(V3::new(-150.0, 280.0, 100.0 * side)),
            "SRS" => trunk(V3::new(-150.0, 380.0, 90.0 * side)),
            "SAA" => trunk(V3::new(-120.0, 460.0, 190.0 * side)),
            "SAE" => trunk(sae),
            "HLE" => trunk(arm(ec + z(30.0), 1)),
            "HME" => trunk(arm(ec - z(30.0), 1)),
            "UOA" => trunk(arm(ec + V3::new(-30.0, 10.0, 0.0), 2)),
            "UHE" => trunk(arm(uhe, 2)),
            "RSP" => trunk(arm(uhe + z(40.0), 2)),
            "HM2" => trunk(arm(uhe + V3::new(0.0, -80.0, 40.0 * side), 3)),
            "HM5" => trunk(arm(uhe + V3::new(0.0, -80.0, 0.0), 3)),
            other => panic!("no test position for {other}"),
        }
    }

    /// One frame per pose, progressing 10 mm per frame along the lab's +X.
    fn body_motion(poses: &[Pose]) -> Motion {
        let names = isb_marker_names();
        let refs: Vec<&str> = names.iter().map(String::as_str).collect();
        named_motion(poses.len(), 100.0, &refs, |f, k| {
            let q = to_lab() * poses[f].body * marker_isb(refs[k], &poses[f])
                + V3::new(10.0 * f as f64, 500.0, 900.0);
            [q.x, q.y, q.z]
        })
    }

    /// The mirror image (about the sagittal plane) of a rotation: negates its X and Y angles.
    fn mirrored(r: Matrix3<f64>) -> Matrix3<f64> {
        let m = Matrix3::from_diagonal(&V3::new(1.0, 1.0, -1.0));
        m * r * m
    }

    #[test]
    fn known_joint_rotations_are_recovered_from_markers() {
        let seq = CardanSequence::Zxy;
        let r = |a: [f64; 3]| rotation_from_cardan(seq, a); // [about Z, about X, about Y]
        let (hip, knee, ankle) = ([25.0, -8.0, 12.0], [-40.0, 3.0, -6.0], [10.0, 7.0, -4.0]);
        let (shoulder, elbow, wrist) = ([20.0, -15.0, 30.0], [60.0, 5.0, 70.0], [-20.0, 10.0, 3.0]);
        let lumbar = [-9.0, 4.0, 6.0];
        let body = [5.0, 2.0, -10.0];
        let pose = Pose {
            // The left side gets the mirror image of the right side's rotations.
            hip: [mirrored(r(hip)), r(hip)],
            knee: [mirrored(r(knee)), r(knee)],
            ankle: [mirrored(r(ankle)), r(ankle)],
            shoulder: [mirrored(r(shoulder)), r(shoulder)],
            elbow: [mirrored(r(elbow)), r(elbow)],
            wrist: [mirrored(r(wrist)), r(wrist)],
            lumbar: r(lumbar),
            body: r(body),
        };
        let stage = IsbJointAnglesParams::default().check().unwrap();
        let c = stage.angle_curves(&body_motion(&[pose; 30])).unwrap();
        let expect = |joint: &str, names: [&str; 3], signs: [f64; 3], a: [f64; 3]| {
            for k in 0..3 {
                let ch = format!("{joint}.{}", names[k]);
                let got = c.values[c.channel_index(&ch).unwrap()][7];
                assert!(
                    (got - signs[k] * a[k]).abs() < 1e-9,
                    "{ch}: {got}, expected {}",
                    signs[k] * a[k]
                );
            }
        };
        for side in ["_l", "_r"] {
            // Signs from the table in the params docs (left side mirrored, so equal to right).
            expect(
                &format!("hip{side}"),
                ["flexion", "abduction", "rotation"],
                [1.0, -1.0, 1.0],
                hip,
            );
            expect(
                &format!("knee{side}"),
                ["flexion", "abduction", "rotation"],
                [-1.0, -1.0, 1.0],
                knee,
            );
            expect(
                &format!("ankle{side}"),
                ["flexion", "inversion", "rotation"],
                [1.0, 1.0, 1.0],
                ankle,
            );
            expect(
                &format!("shoulder{side}"),
                ["flexion", "abduction", "rotation"],
                [1.0, -1.0, 1.0],
                shoulder,
            );
            expect(
                &format!("elbow{side}"),
                ["flexion", "abduction", "pronation"],
                [1.0, -1.0, 1.0],
                elbow,
            );
            expect(
                &format!("wrist{side}"),
                ["flexion", "abduction", "rotation"],
                [1.0, -1.0, 1.0],
                wrist,
            );
        }
        expect("lumbar", ["flexion", "lateral_bending", "rotation"], [-1.0, 1.0, 1.0], lumbar);
        // Segments relative to the lab see the whole-body rotation (the thorax also the lumbar one).
        expect("pelvis", ["tilt", "obliquity", "rotation"], [-1.0, 1.0, 1.0], body);
        let thorax = cardan_angles(&(r(body) * r(lumbar)), seq);
        expect("thorax", ["tilt", "obliquity", "rotation"], [-1.0, 1.0, 1.0], thorax);

        // The neutral pose gives 0 everywhere, with the hip centre from Harrington et al.
        let n = stage.angle_curves(&body_motion(&[neutral(); 30])).unwrap();
        for (ch, v) in n.channels.iter().zip(&n.values) {
            assert!(v[0].abs() < 1e-9, "{ch} = {}", v[0]);
        }
        // Bell et al.'s hip centre is 2.7 mm more anterior and 10.9 mm higher than Harrington's
        // here, so the same markers tilt the thigh back by atan(2.7 / 410.9).
        let bell = IsbJointAnglesParams { hip_centre: HipCentre::Bell1990, ..Default::default() }
            .check()
            .unwrap();
        let b = bell.angle_curves(&body_motion(&[neutral(); 30])).unwrap();
        let flexion = b.values[b.channel_index("hip_r.flexion").unwrap()][0];
        assert!((flexion + 2.7f64.atan2(410.9).to_degrees()).abs() < 1e-3, "{flexion}");
    }

    #[test]
    fn a_missing_marker_blanks_only_the_frames_and_joints_that_use_it() {
        let mut m = body_motion(&[neutral(); 30]);
        let k = m.point_index("R_FAL").unwrap();
        let n_points = m.n_points();
        m.positions_mut()[5 * n_points + k] = [f64::NAN; 3];
        m.refresh_missing();
        let c = IsbJointAnglesParams::default().check().unwrap().angle_curves(&m).unwrap();
        let at = |ch: &str, f: usize| c.values[c.channel_index(ch).unwrap()][f];
        // R_FAL feeds the right shank: knee_r and ankle_r are NaN at frame 5 only.
        for ch in ["knee_r.flexion", "knee_r.rotation", "ankle_r.flexion", "ankle_r.inversion"] {
            assert!(at(ch, 5).is_nan(), "{ch}");
            assert!(at(ch, 4).is_finite() && at(ch, 6).is_finite(), "{ch}");
        }
        for ch in
            ["hip_r.flexion", "knee_l.flexion", "ankle_l.flexion", "pelvis.tilt", "elbow_r.flexion"]
        {
            assert!(at(ch, 5).is_finite(), "{ch}");
        }
    }

    #[test]
    fn an_absent_label_is_an_error_unless_its_joint_is_skipped() {
        let names = ["L_IAS", "R_IAS", "L_IPS", "R_IPS"];
        let m = named_motion(3, 100.0, &names, |_, k| {
            [k as f64 * 10.0, (k % 2) as f64 * 30.0, 900.0 + k as f64]
        });
        let e = IsbJointAnglesParams::default().check().unwrap().angle_curves(&m).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::UnknownName);
        assert!(e.to_string().contains("CV7") || e.to_string().contains("FLE"), "{e}");
        let only_pelvis =
            IsbJointAnglesParams { joints: vec![JointName::Pelvis], ..Default::default() }
                .check()
                .unwrap();
        let c = only_pelvis.angle_curves(&m).unwrap();
        assert_eq!(c.channels, ["pelvis.tilt", "pelvis.obliquity", "pelvis.rotation"]);
        // With absent_markers = "nan" every joint is computed where it can be: only the pelvis.
        let lenient =
            IsbJointAnglesParams { absent_markers: AbsentMarkers::Nan, ..Default::default() }
                .check()
                .unwrap();
        let c = lenient.angle_curves(&m).unwrap();
        assert_eq!(c.channels.len(), 45);
        for (ch, v) in c.channels.iter().zip(&c.values) {
            assert_eq!(ch.starts_with("pelvis."), v.iter().all(|x| x.is_finite()), "{ch}: {v:?}");
        }
    }

    #[test]
    fn params_are_validated_and_registered() {
        let e = IsbJointAnglesParams { shoulder_centre_drop: 1.5, ..Default::default() }
            .check()
            .unwrap_err();
        assert_eq!(e.location().field.as_deref(), Some("shoulder_centre_drop"));
        let e = IsbJointAnglesParams {
            joints: vec![JointName::Hip, JointName::Hip],
            ..Default::default()
        }
        .check()
        .unwrap_err();
        assert_eq!(e.location().field.as_deref(), Some("joints"));
        let t: toml::Value =
            toml::from_str("joints = [\"hip\", \"knee\"]\nsequence = \"zyx\"").unwrap();
        assert!(build_feature_extractor("isb_joint_angles", &t).is_ok());
        let t: toml::Value = toml::from_str("joint = [\"hip\"]").unwrap();
        assert_eq!(
            parse_params::<IsbJointAnglesParams>(&t).unwrap_err().kind(),
            ErrorKind::UnknownKey
        );
        assert_eq!(IsbJointAnglesParams::default().check().unwrap().channel_names().len(), 45);
    }

    #[test]
    fn features_and_curves_convert_both_ways() {
        let curves = AngleCurves {
            frame_rate: FrameRate::new(100.0).unwrap(),
            channels: vec!["knee_l.flexion".into(), "hip_r.rotation".into()],
            values: vec![vec![1.0, 2.0], vec![3.0, f64::NAN]],
        };
        let f = features_from_angle_curves(&curves);
        assert_eq!(f.traces[0].name, "knee_l.flexion_deg");
        let back = angle_curves_from_features(&f, curves.frame_rate).unwrap();
        assert_eq!(back.channels, curves.channels);
        assert_eq!(back.values[0], curves.values[0]);
        assert!(back.values[1][1].is_nan());
        assert_eq!(
            angle_curves_from_features(&FeatureSet::default(), curves.frame_rate)
                .unwrap_err()
                .kind(),
            ErrorKind::EmptySequence
        );
    }

    #[test]
    fn skeleton_channels_are_the_angles() {
        use motionlab_core::ChannelKind::{Rotation, Translation};
        let root = Joint::new(
            "Hips",
            None,
            [0.0; 3],
            vec![
                Translation(Axis::X),
                Translation(Axis::Y),
                Translation(Axis::Z),
                Rotation(Axis::Z),
                Rotation(Axis::X),
                Rotation(Axis::Y),
            ],
        );
        let knee = Joint::new(
            "LeftKnee",
            Some(0),
            [0.0, -400.0, 0.0],
            vec![Rotation(Axis::Z), Rotation(Axis::X), Rotation(Axis::Y)],
        );
        let sk = SkeletonMotion::new(
            Skeleton { joints: vec![root, knee] },
            (0..18).map(|v| v as f64).collect(),
        )
        .unwrap();
        let rate = FrameRate::new(120.0).unwrap();
        let c = skeleton_angle_curves(&sk, rate, ChannelNaming::Bvh).unwrap();
        assert_eq!(
            c.channels,
            [
                "Hips.Zrotation",
                "Hips.Xrotation",
                "Hips.Yrotation",
                "LeftKnee.Zrotation",
                "LeftKnee.Xrotation",
                "LeftKnee.Yrotation"
            ]
        );
        assert_eq!(c.values[4], vec![7.0, 16.0]); // channel 7 of frames 0 and 1
        let c = skeleton_angle_curves(&sk, rate, ChannelNaming::Short).unwrap();
        assert_eq!(c.channels[3], "LeftKnee.rz");
        let mut m = Motion::new(
            "walk",
            rate,
            Axis::Y,
            PointKind::Joint,
            vec!["Hips".into(), "LeftKnee".into()],
            vec![[0.0; 3]; 4],
        )
        .unwrap();
        assert_eq!(
            motion_angle_curves(&m, ChannelNaming::Auto).unwrap_err().kind(),
            ErrorKind::MissingData
        );
        m.skeleton = Some(sk);
        m.format = "bvh".into();
        assert_eq!(
            motion_angle_curves(&m, ChannelNaming::Auto).unwrap().channels[0],
            "Hips.Zrotation"
        );
    }
}
