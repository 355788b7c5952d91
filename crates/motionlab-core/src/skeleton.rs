//! Skeletons (BVH hierarchies, ASF bone trees), their per-frame channel values and forward
//! kinematics.
//!
//! One representation serves both formats. A joint sits at the *start* of its segment; its
//! rotation turns everything below it. The local rotation of joint `j` at a frame is
//!
//! ```text
//! L_j = C_j · R_{o1}(θ_{o1}) · R_{o2}(θ_{o2}) · R_{o3}(θ_{o3}) · C_j⁻¹
//! ```
//!
//! where `C_j` is a fixed axis rotation (ASF `axis`; identity for BVH) and `o1 o2 o3` is the
//! joint's `rotation_order` (BVH: the order the rotation channels are listed; ASF: Z, Y, X —
//! the CMU convention `M = Rz·Ry·Rx` whatever order the `dof` line lists). Matrices act on
//! column vectors. Forward kinematics:
//!
//! ```text
//! G_root = L_root,            p_root = offset_root + translation
//! G_j    = G_parent · L_j,    p_j    = p_parent + G_parent · offset_j
//! end site e of j:            p_e    = p_j + G_j · e
//! ```

use nalgebra::{Matrix3, Rotation3, Vector3};

use crate::motion::Point3;
use crate::units::Axis;
use crate::{Error, ErrorKind, Result};

/// What one channel of a joint drives.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ChannelKind {
    /// A translation along an axis, stored in **mm** after loading.
    Translation(Axis),
    /// A rotation about an axis, stored in **degrees**.
    Rotation(Axis),
}

impl ChannelKind {
    /// BVH spelling (`Xposition`, `Zrotation`, …).
    pub fn bvh_name(self) -> &'static str {
        match self {
            ChannelKind::Translation(Axis::X) => "Xposition",
            ChannelKind::Translation(Axis::Y) => "Yposition",
            ChannelKind::Translation(Axis::Z) => "Zposition",
            ChannelKind::Rotation(Axis::X) => "Xrotation",
            ChannelKind::Rotation(Axis::Y) => "Yrotation",
            ChannelKind::Rotation(Axis::Z) => "Zrotation",
        }
    }
    /// Short spelling used in channel names (`tx`, `rz`, …), as ASF `dof` lines write them.
    pub fn short_name(self) -> &'static str {
        match self {
            ChannelKind::Translation(Axis::X) => "tx",
            ChannelKind::Translation(Axis::Y) => "ty",
            ChannelKind::Translation(Axis::Z) => "tz",
            ChannelKind::Rotation(Axis::X) => "rx",
            ChannelKind::Rotation(Axis::Y) => "ry",
            ChannelKind::Rotation(Axis::Z) => "rz",
        }
    }
}

/// One joint of a skeleton.
#[derive(Clone, Debug, PartialEq)]
pub struct Joint {
    pub name: String,
    /// Index of the parent joint; always smaller than this joint's index (topological order).
    pub parent: Option<usize>,
    /// Position relative to the parent joint, in the parent's rest frame, mm.
    pub offset: Point3,
    /// The channels stored for this joint, in file order.
    pub channels: Vec<ChannelKind>,
    /// Order in which rotations compose (see module docs). Axes without a channel are 0°.
    pub rotation_order: Vec<Axis>,
    /// The fixed axis rotation `C` (ASF `axis`); identity for BVH.
    pub axis: Rotation3<f64>,
    /// End sites (BVH `End Site`, ASF leaf bone tips) relative to this joint, in its frame, mm.
    pub end_sites: Vec<Point3>,
}

impl Joint {
    /// A BVH-style joint (no axis rotation; rotations compose in channel order).
    pub fn new(
        name: impl Into<String>,
        parent: Option<usize>,
        offset: Point3,
        channels: Vec<ChannelKind>,
    ) -> Self {
        let rotation_order = channels
            .iter()
            .filter_map(|c| match c {
                ChannelKind::Rotation(a) => Some(*a),
                ChannelKind::Translation(_) => None,
            })
            .collect();
        Joint {
            name: name.into(),
            parent,
            offset,
            channels,
            rotation_order,
            axis: Rotation3::identity(),
            end_sites: Vec::new(),
        }
    }
}

/// A joint hierarchy. Joints are stored parents-first.
#[derive(Clone, Debug, PartialEq)]
pub struct Skeleton {
    pub joints: Vec<Joint>,
}

impl Skeleton {
    /// Checks the structural invariants loaders must uphold: parents precede children, names are
    /// unique, offsets are finite.
    pub fn validate(&self) -> Result<()> {
        let mut seen = std::collections::HashSet::new();
        for (i, j) in self.joints.iter().enumerate() {
            if !seen.insert(j.name.as_str()) {
                return Err(Error::new(
                    ErrorKind::DuplicateName,
                    format!("joint {:?} is declared twice", j.name),
                ));
            }
            if let Some(p) = j.parent
                && p >= i
            {
                return Err(Error::new(
                    ErrorKind::Syntax,
                    format!("joint {:?} comes before its parent", j.name),
                ));
            }
            if !j.offset.iter().chain(j.end_sites.iter().flatten()).all(|c| c.is_finite()) {
                return Err(Error::new(
                    ErrorKind::NonFinite,
                    format!("joint {:?} has a non-finite offset", j.name),
                ));
            }
        }
        Ok(())
    }
    pub fn n_channels(&self) -> usize {
        self.joints.iter().map(|j| j.channels.len()).sum()
    }
    pub fn joint_index(&self, name: &str) -> Option<usize> {
        self.joints.iter().position(|j| j.name == name)
    }
    /// `joint.rx`-style names of every channel, in storage order.
    pub fn channel_names(&self) -> Vec<String> {
        self.joints
            .iter()
            .flat_map(|j| j.channels.iter().map(move |c| format!("{}.{}", j.name, c.short_name())))
            .collect()
    }
    /// Names of the points forward kinematics produces: every joint, then every end site as
    /// `<joint>_end` (`<joint>_end2`, … when a joint has several).
    pub fn point_names(&self) -> Vec<String> {
        let mut names: Vec<String> = self.joints.iter().map(|j| j.name.clone()).collect();
        for j in &self.joints {
            for (e, _) in j.end_sites.iter().enumerate() {
                names.push(if e == 0 {
                    format!("{}_end", j.name)
                } else {
                    format!("{}_end{}", j.name, e + 1)
                });
            }
        }
        names
    }
    /// Pairs of point indices (into [`Skeleton::point_names`]) joined by a bone, for stick figures.
    pub fn bones(&self) -> Vec<(usize, usize)> {
        let mut bones: Vec<(usize, usize)> =
            self.joints.iter().enumerate().filter_map(|(i, j)| j.parent.map(|p| (p, i))).collect();
        let mut next = self.joints.len();
        for (i, j) in self.joints.iter().enumerate() {
            for _ in &j.end_sites {
                bones.push((i, next));
                next += 1;
            }
        }
        bones
    }
    /// Local rotation `C · R(order) · C⁻¹` of joint `j` from its channel values (degrees).
    ///
    /// Plain nalgebra products, kept as written: `motionlab-io`'s `tests/fk_reference.rs` uses it
    /// as the reference the compiled [`ForwardKinematics`] must match bit for bit.
    pub fn local_rotation(&self, j: usize, values: &[f64]) -> Rotation3<f64> {
        let joint = &self.joints[j];
        let mut angle = [0.0f64; 3];
        for (c, v) in joint.channels.iter().zip(values) {
            if let ChannelKind::Rotation(a) = c {
                angle[a.index()] = *v;
            }
        }
        let mut m = Rotation3::identity();
        for a in &joint.rotation_order {
            m *= axis_rotation(*a, angle[a.index()].to_radians());
        }
        joint.axis * m * joint.axis.inverse()
    }
    /// Forward kinematics of one frame: `values` holds every channel (translations in mm,
    /// rotations in degrees) in storage order. Returns points in [`Skeleton::point_names`] order
    /// and each joint's global rotation. For many frames, [`ForwardKinematics::positions`]
    /// resolves the skeleton once.
    pub fn forward_kinematics(&self, values: &[f64]) -> (Vec<Point3>, Vec<Rotation3<f64>>) {
        let fk = ForwardKinematics::new(self);
        let mut points = vec![[0.0; 3]; fk.n_points()];
        let mut rot = vec![IDENTITY; self.joints.len()];
        fk.frame::<Portable>(values, &mut points, &mut rot);
        let rot = rot
            .iter()
            .map(|g| Rotation3::from_matrix_unchecked(Matrix3::from_fn(|i, j| g[i][j])))
            .collect();
        (points, rot)
    }
}

/// A 3×3 matrix, row-major (`m[row][column]`), acting on column vectors. Rows are padded to
/// four lanes (the fourth is never read) so a row is two SSE2 or one AVX register.
type Mat3 = [[f64; 4]; 3];

const IDENTITY: Mat3 = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]];

/// `a · b`, each entry summed as `(a_i0·b_0j + a_i1·b_1j) + a_i2·b_2j`: the order of nalgebra's
/// `gemm` for fixed-size matrices (one axpy per column of `a`), so the result is bit for bit
/// that of the `Rotation3` product the reference implementation computes. Written row by row
/// (row i of the result = Σ_k a_ik · row k of b) so it vectorises across the row's lanes.
#[inline(always)]
fn mat_mul(a: &Mat3, b: &Mat3) -> Mat3 {
    let mut out = [[0.0; 4]; 3];
    for i in 0..3 {
        for j in 0..4 {
            out[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
        }
    }
    out
}

/// The dense products of the per-frame hot path ([`ForwardKinematics::frame`]), in a portable
/// and an AVX build with the same per-entry arithmetic.
trait DenseProduct {
    fn mul(a: &Mat3, b: &Mat3) -> Mat3;
}

/// [`mat_mul`] as the compiler vectorises it for the build's baseline (SSE2 on x86-64).
struct Portable;

impl DenseProduct for Portable {
    #[inline(always)]
    fn mul(a: &Mat3, b: &Mat3) -> Mat3 {
        mat_mul(a, b)
    }
}

/// [`mat_mul`] with a row in one 256-bit register: row i = (a_i0·B₀ + a_i1·B₁) + a_i2·B₂,
/// lane by lane the same products and sums (no FMA), so bit-identical.
#[cfg(target_arch = "x86_64")]
struct Avx;

#[cfg(target_arch = "x86_64")]
impl DenseProduct for Avx {
    #[inline(always)]
    fn mul(a: &Mat3, b: &Mat3) -> Mat3 {
        // SAFETY: `Avx` is only used by `ForwardKinematics::frames_avx2`, which runs only after
        // AVX2 (which implies AVX) was detected.
        unsafe { mat_mul_avx(a, b) }
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
fn mat_mul_avx(a: &Mat3, b: &Mat3) -> Mat3 {
    use std::arch::x86_64::{
        _mm256_add_pd, _mm256_loadu_pd, _mm256_mul_pd, _mm256_set1_pd, _mm256_storeu_pd,
    };
    let mut out = [[0.0; 4]; 3];
    // SAFETY: every pointer is to a whole `[f64; 4]` row (four readable/writable f64s).
    unsafe {
        let (b0, b1, b2) = (
            _mm256_loadu_pd(b[0].as_ptr()),
            _mm256_loadu_pd(b[1].as_ptr()),
            _mm256_loadu_pd(b[2].as_ptr()),
        );
        for (row, a) in out.iter_mut().zip(a) {
            let sum = _mm256_add_pd(
                _mm256_add_pd(
                    _mm256_mul_pd(_mm256_set1_pd(a[0]), b0),
                    _mm256_mul_pd(_mm256_set1_pd(a[1]), b1),
                ),
                _mm256_mul_pd(_mm256_set1_pd(a[2]), b2),
            );
            _mm256_storeu_pd(row.as_mut_ptr(), sum);
        }
    }
    out
}

/// `a · v`, in the same summation order as [`mat_mul`].
#[inline(always)]
fn mat_vec(a: &Mat3, v: [f64; 3]) -> [f64; 3] {
    [
        a[0][0] * v[0] + a[0][1] * v[1] + a[0][2] * v[2],
        a[1][0] * v[0] + a[1][1] * v[1] + a[1][2] * v[2],
        a[2][0] * v[0] + a[2][1] * v[1] + a[2][2] * v[2],
    ]
}

#[inline(always)]
fn add3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// Whether any entry is −0. Multiplying by the identity turns such an entry into +0 (unless its
/// whole row is ≤ −0), so skipping an identity product is exact only without them.
#[inline(always)]
fn has_negative_zero(m: &Mat3) -> bool {
    m.iter().flat_map(|r| &r[..3]).any(|x| x.to_bits() == (-0.0f64).to_bits())
}

/// `m · I`, skipped when that is exactly `m` (see [`has_negative_zero`]).
#[inline(always)]
fn times_identity(m: Mat3) -> Mat3 {
    if has_negative_zero(&m) { mat_mul(&m, &IDENTITY) } else { m }
}

/// The rotation with sine `s` and cosine `c` about `axis` with exactly the entries of
/// nalgebra's `Rotation3::from_axis_angle` for a unit coordinate axis and an angle ≠ 0: `1`,
/// `cos`, `±sin` and +0 elsewhere (its `0·(1−cos) ∓ 0·sin` terms are +0 for every angle).
#[inline(always)]
fn axis_matrix(axis: usize, s: f64, c: f64) -> Mat3 {
    match axis {
        0 => [[1.0, 0.0, 0.0, 0.0], [0.0, c, -s, 0.0], [0.0, s, c, 0.0]],
        1 => [[c, 0.0, s, 0.0], [0.0, 1.0, 0.0, 0.0], [-s, 0.0, c, 0.0]],
        _ => [[c, -s, 0.0, 0.0], [s, c, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]],
    }
}

/// `m · R` for the rotation `R` about `axis` with sine `s`, cosine `c`, multiplying out only
/// R's non-zero entries: column `axis` is m's, the other two are two products each, summed in
/// the full product's order. This equals [`mat_mul`]`(m, R)` bit for bit whenever m has no −0
/// entry and every computed entry is non-zero (a dropped term is ±0, and `x + ±0 = x` for
/// x ≠ 0; an exact cancellation gives +0 either way). Returns `None` when a computed entry is
/// zero, where the sign of that zero could differ — the caller then redoes the joint the long
/// way. The result then has no −0 entry either, so the products chain.
#[inline(always)]
fn times_axis_rotation(m: &Mat3, axis: usize, s: f64, c: f64) -> Option<Mat3> {
    // Each row is built whole (`[x, y, z, 0]`) rather than patched entry by entry in memory,
    // so the dense product that reads it next gets it from registers or from one full-width
    // store (a row loaded across several narrower stores stalls store-to-load forwarding).
    // Per axis, the rotated columns (p, q) and R's entries for them:
    //   Rx: (1, 2), R11 = c, R21 = s, R12 = −s, R22 = c
    //   Ry: (0, 2), R00 = c, R20 = −s, R02 = s, R22 = c
    //   Rz: (0, 1), R00 = c, R10 = s, R01 = −s, R11 = c
    // and each new entry is `m_p · R_pp' + m_q · R_qp'`, as in the full product.
    let mut out = [[0.0; 4]; 3];
    let mut zero = false;
    match axis {
        0 => {
            for (o, row) in out.iter_mut().zip(m) {
                let a = row[1] * c + row[2] * s;
                let b = row[1] * -s + row[2] * c;
                zero |= a == 0.0 || b == 0.0;
                *o = [row[0], a, b, 0.0];
            }
        }
        1 => {
            for (o, row) in out.iter_mut().zip(m) {
                let a = row[0] * c + row[2] * -s;
                let b = row[0] * s + row[2] * c;
                zero |= a == 0.0 || b == 0.0;
                *o = [a, row[1], b, 0.0];
            }
        }
        _ => {
            for (o, row) in out.iter_mut().zip(m) {
                let a = row[0] * c + row[1] * s;
                let b = row[0] * -s + row[1] * c;
                zero |= a == 0.0 || b == 0.0;
                *o = [a, b, row[2], 0.0];
            }
        }
    }
    (!zero).then_some(out)
}

/// One joint of a [`ForwardKinematics`], with everything that does not change between frames
/// resolved once.
#[derive(Clone, Debug)]
struct FkJoint {
    parent: Option<usize>,
    offset: [f64; 3],
    /// (channel index in the frame, axis) of each translation channel, in channel order.
    translations: Vec<(usize, usize)>,
    /// Per rotation in composition order ([`Joint::rotation_order`]): its axis and the channel
    /// index holding its angle (the last rotation channel about that axis, as
    /// [`Skeleton::local_rotation`] reads them; `None` = 0°).
    rotations: Vec<(usize, Option<usize>)>,
    /// `(C, Cᵀ)`, or `None` when `C` is exactly the identity.
    axis: Option<(Mat3, Mat3)>,
    /// `C · I · Cᵀ` as the reference computes it when every angle is 0 (not exactly `I`).
    rest_local: Mat3,
}

/// Forward kinematics compiled for one skeleton: the same arithmetic as
/// [`Skeleton::local_rotation`] and the recurrences in the module docs, with per-joint
/// constants (channel slots, axis matrices, their transposes) resolved once, no allocation per
/// frame, products with an exact identity skipped (rotations by 0°, `C = I`) and the Euler
/// product multiplied out over the rotations' non-zero entries only — each shortcut taken only
/// where it is exact (see [`times_axis_rotation`]), so every position is bit-identical to the
/// original nalgebra implementation: `tests/fk_reference.rs` in `motionlab-io` compares the
/// two on every shipped take and on hand-made corner cases.
#[derive(Clone, Debug)]
pub struct ForwardKinematics {
    joints: Vec<FkJoint>,
    /// (joint, offset) of every end site, in [`Skeleton::point_names`] order.
    end_sites: Vec<(usize, [f64; 3])>,
    n_channels: usize,
}

impl ForwardKinematics {
    /// Resolves the per-joint constants of `skeleton` (a validated one: parents before
    /// children). Cheap (one pass over the joints); build it once per take, not per frame.
    pub fn new(skeleton: &Skeleton) -> Self {
        let mut joints = Vec::with_capacity(skeleton.joints.len());
        let mut at = 0;
        for joint in &skeleton.joints {
            let mut translations = Vec::new();
            let mut angle_channel = [None; 3];
            for (k, c) in joint.channels.iter().enumerate() {
                match c {
                    ChannelKind::Translation(a) => translations.push((at + k, a.index())),
                    ChannelKind::Rotation(a) => angle_channel[a.index()] = Some(at + k),
                }
            }
            at += joint.channels.len();
            let c: Mat3 = std::array::from_fn(|i| {
                std::array::from_fn(|j| if j < 3 { joint.axis.matrix()[(i, j)] } else { 0.0 })
            });
            let ct: Mat3 =
                std::array::from_fn(|i| std::array::from_fn(|j| if j < 3 { c[j][i] } else { 0.0 }));
            let rest_local = mat_mul(&mat_mul(&c, &IDENTITY), &ct);
            let axis = (c != IDENTITY || has_negative_zero(&c)).then_some((c, ct));
            joints.push(FkJoint {
                parent: joint.parent,
                offset: joint.offset,
                translations,
                rotations: joint
                    .rotation_order
                    .iter()
                    .map(|a| (a.index(), angle_channel[a.index()]))
                    .collect(),
                axis,
                rest_local,
            });
        }
        let end_sites = skeleton
            .joints
            .iter()
            .enumerate()
            .flat_map(|(j, joint)| joint.end_sites.iter().map(move |e| (j, *e)))
            .collect();
        ForwardKinematics { joints, end_sites, n_channels: at }
    }

    /// Points per frame: every joint, then every end site.
    pub fn n_points(&self) -> usize {
        self.joints.len() + self.end_sites.len()
    }

    /// Channel values per frame.
    pub fn n_channels(&self) -> usize {
        self.n_channels
    }

    /// `M = R_o1 · R_o2 · R_o3` of a joint, `None` when it is exactly the identity. Angles of
    /// exactly 0 are skipped (`from_axis_angle` gives the identity for them, and `I · R = R`,
    /// `M · I = M` exactly while M has no −0 entry).
    #[inline(always)]
    fn euler(joint: &FkJoint, values: &[f64]) -> Option<Mat3> {
        let mut m: Option<Mat3> = None;
        for &(a, k) in &joint.rotations {
            let radians = k.map_or(0.0, |k| values[k]).to_radians();
            if radians == 0.0 {
                continue;
            }
            let (s, c) = radians.sin_cos();
            m = Some(match m {
                None => axis_matrix(a, s, c),
                Some(m) => match times_axis_rotation(&m, a, s, c) {
                    Some(next) => next,
                    None => return Self::euler_reference(joint, values),
                },
            });
        }
        m
    }

    /// [`Self::euler`] the long way: every product in full, identities included — the
    /// reference's arithmetic, for the rare joint where a shortcut could flip the sign of a zero.
    #[cold]
    fn euler_reference(joint: &FkJoint, values: &[f64]) -> Option<Mat3> {
        let mut m = IDENTITY;
        for &(a, k) in &joint.rotations {
            let radians = k.map_or(0.0, |k| values[k]).to_radians();
            let r = if radians == 0.0 {
                IDENTITY
            } else {
                let (s, c) = radians.sin_cos();
                axis_matrix(a, s, c)
            };
            m = mat_mul(&m, &r);
        }
        Some(m)
    }

    /// The local rotation `C · M · Cᵀ` of a joint, `None` when it is exactly the identity.
    #[inline(always)]
    fn local<P: DenseProduct>(joint: &FkJoint, values: &[f64]) -> Option<Mat3> {
        match (&joint.axis, Self::euler(joint, values)) {
            (None, None) => None,
            // (I · M) · Iᵀ
            (None, Some(m)) => Some(if has_negative_zero(&m) {
                mat_mul(&mat_mul(&IDENTITY, &m), &IDENTITY)
            } else {
                m
            }),
            (Some(_), None) => Some(joint.rest_local),
            (Some((c, ct)), Some(m)) => Some(P::mul(&P::mul(c, &m), ct)),
        }
    }

    /// Forward kinematics of one frame into `points` ([`Self::n_points`] long) and each
    /// joint's global rotation into `rot` (one per joint). `values` holds the frame's channels.
    #[inline(always)]
    fn frame<P: DenseProduct>(&self, values: &[f64], points: &mut [Point3], rot: &mut [Mat3]) {
        let values = &values[..self.n_channels];
        let (joint_points, end_points) = points.split_at_mut(self.joints.len());
        for (j, joint) in self.joints.iter().enumerate() {
            let mut translation = [0.0f64; 3];
            for &(k, a) in &joint.translations {
                translation[a] += values[k];
            }
            let local = Self::local::<P>(joint, values);
            let v = add3(joint.offset, translation);
            match joint.parent {
                None => {
                    joint_points[j] = v;
                    rot[j] = local.unwrap_or(IDENTITY);
                }
                Some(pi) => {
                    let gp = rot[pi];
                    joint_points[j] = add3(joint_points[pi], mat_vec(&gp, v));
                    rot[j] = match local {
                        Some(l) => P::mul(&gp, &l),
                        None => times_identity(gp),
                    };
                }
            }
        }
        for (out, &(j, e)) in end_points.iter_mut().zip(&self.end_sites) {
            *out = add3(joint_points[j], mat_vec(&rot[j], e));
        }
    }

    /// Forward kinematics of every frame of `channel_values` (frame-major,
    /// [`Self::n_channels`] per frame): frame-major points.
    pub fn positions(&self, channel_values: &[f64]) -> Vec<Point3> {
        let m = self.n_points();
        let n_frames = channel_values.len().checked_div(self.n_channels).unwrap_or(0);
        let mut points = vec![[0.0; 3]; n_frames * m];
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, the one requirement of the `target_feature` function.
            unsafe { self.frames_avx2(channel_values, &mut points) };
            return points;
        }
        self.frames(channel_values, &mut points);
        points
    }

    /// Every frame, portable build (SSE2 on x86-64).
    fn frames(&self, channel_values: &[f64], points: &mut [Point3]) {
        self.frames_inline::<Portable>(channel_values, points);
    }

    /// Every frame, compiled for AVX2: the same code and the same IEEE operations (no FMA, so
    /// bit-identical results), with a matrix row in one 256-bit register.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn frames_avx2(&self, channel_values: &[f64], points: &mut [Point3]) {
        self.frames_inline::<Avx>(channel_values, points);
    }

    #[inline(always)]
    fn frames_inline<P: DenseProduct>(&self, channel_values: &[f64], points: &mut [Point3]) {
        let m = self.n_points();
        let mut rot = vec![IDENTITY; self.joints.len()];
        for (values, out) in channel_values
            .chunks_exact(self.n_channels.max(1))
            .zip(points.chunks_exact_mut(m.max(1)))
        {
            self.frame::<P>(values, out, &mut rot);
        }
    }
}

/// Rotation by `radians` about a coordinate axis.
pub fn axis_rotation(axis: Axis, radians: f64) -> Rotation3<f64> {
    let v = match axis {
        Axis::X => Vector3::x_axis(),
        Axis::Y => Vector3::y_axis(),
        Axis::Z => Vector3::z_axis(),
    };
    Rotation3::from_axis_angle(&v, radians)
}

/// A skeleton with its channel values for every frame.
#[derive(Clone, Debug)]
pub struct SkeletonMotion {
    pub skeleton: Skeleton,
    /// Frame-major channel values (`F × n_channels`): translations in mm, rotations in degrees.
    channel_values: Vec<f64>,
    n_frames: usize,
}

impl SkeletonMotion {
    pub fn new(skeleton: Skeleton, channel_values: Vec<f64>) -> Result<Self> {
        skeleton.validate()?;
        let c = skeleton.n_channels();
        let n_frames = channel_values.len().checked_div(c).unwrap_or(0);
        if c == 0 || !channel_values.len().is_multiple_of(c) {
            return Err(Error::new(
                ErrorKind::WrongValueCount,
                format!(
                    "{} channel values is not a whole number of frames of {c} channels",
                    channel_values.len()
                ),
            ));
        }
        Ok(SkeletonMotion { skeleton, channel_values, n_frames })
    }
    pub fn n_frames(&self) -> usize {
        self.n_frames
    }
    pub fn n_channels(&self) -> usize {
        self.skeleton.n_channels()
    }
    /// Channel values of one frame.
    pub fn frame_values(&self, frame: usize) -> &[f64] {
        let c = self.n_channels();
        &self.channel_values[frame * c..(frame + 1) * c]
    }
    /// All channel values, frame-major.
    pub fn channel_values(&self) -> &[f64] {
        &self.channel_values
    }
    /// One channel over all frames.
    pub fn channel(&self, index: usize) -> Vec<f64> {
        let c = self.n_channels();
        (0..self.n_frames).map(|f| self.channel_values[f * c + index]).collect()
    }
    /// Local rotation of joint `j` at `frame`.
    pub fn local_rotation(&self, frame: usize, j: usize) -> Rotation3<f64> {
        let start: usize = self.skeleton.joints[..j].iter().map(|jt| jt.channels.len()).sum();
        let n = self.skeleton.joints[j].channels.len();
        self.skeleton.local_rotation(j, &self.frame_values(frame)[start..start + n])
    }
    /// Forward kinematics of every frame, frame-major points in [`Skeleton::point_names`] order.
    pub fn positions(&self) -> Vec<Point3> {
        ForwardKinematics::new(&self.skeleton).positions(&self.channel_values)
    }
    pub fn slice_frames(&self, start: usize, end: usize) -> SkeletonMotion {
        let c = self.n_channels();
        SkeletonMotion {
            skeleton: self.skeleton.clone(),
            channel_values: self.channel_values[start * c..end * c].to_vec(),
            n_frames: end - start,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    fn arm() -> Skeleton {
        let root = Joint::new(
            "root",
            None,
            [0.0; 3],
            vec![
                ChannelKind::Translation(Axis::X),
                ChannelKind::Translation(Axis::Y),
                ChannelKind::Translation(Axis::Z),
                ChannelKind::Rotation(Axis::Z),
            ],
        );
        let mut elbow =
            Joint::new("elbow", Some(0), [100.0, 0.0, 0.0], vec![ChannelKind::Rotation(Axis::Z)]);
        elbow.end_sites.push([50.0, 0.0, 0.0]);
        Skeleton { joints: vec![root, elbow] }
    }

    #[test]
    fn forward_kinematics_of_a_two_link_arm() {
        let s = arm();
        // Root at (10,0,0) turned 90° about z, elbow bent another 90°.
        let (p, _) = s.forward_kinematics(&[10.0, 0.0, 0.0, 90.0, 90.0]);
        let expect = [[10.0, 0.0, 0.0], [10.0, 100.0, 0.0], [-40.0, 100.0, 0.0]];
        for (a, b) in p.iter().zip(expect) {
            for k in 0..3 {
                assert!((a[k] - b[k]).abs() < 1e-9, "{p:?}");
            }
        }
        assert_eq!(s.point_names(), vec!["root", "elbow", "elbow_end"]);
        assert_eq!(s.bones(), vec![(0, 1), (1, 2)]);
    }

    #[test]
    fn axis_rotation_conjugates_the_channel_rotation() {
        // With C = 90° about x, a rotation "about local z" is a rotation about global -y.
        let mut s = arm();
        s.joints[1].axis = axis_rotation(Axis::X, FRAC_PI_2);
        let (p, _) = s.forward_kinematics(&[0.0, 0.0, 0.0, 0.0, 90.0]);
        // elbow_end = elbow + Ry(-90°)·(50,0,0) = (100,0,0) + (0,0,50)
        assert!((p[2][0] - 100.0).abs() < 1e-9 && (p[2][2] - 50.0).abs() < 1e-9, "{p:?}");
    }

    #[test]
    fn portable_and_avx2_forward_kinematics_agree_bit_for_bit() {
        // A 3-joint chain with an axis rotation, every angle non-zero and varying per frame.
        let mut s = arm();
        s.joints[1].axis = axis_rotation(Axis::Y, 0.7) * axis_rotation(Axis::Z, -0.2);
        s.joints[1].channels = vec![
            ChannelKind::Rotation(Axis::X),
            ChannelKind::Rotation(Axis::Y),
            ChannelKind::Rotation(Axis::Z),
        ];
        s.joints[1].rotation_order = vec![Axis::Z, Axis::Y, Axis::X];
        let fk = ForwardKinematics::new(&s);
        let values: Vec<f64> =
            (0..7 * 200).map(|i| ((i * 37 % 101) as f64 - 50.0) * 1.37).collect();
        let mut portable = vec![[0.0; 3]; 200 * fk.n_points()];
        fk.frames(&values, &mut portable);
        let bits = |p: &[Point3]| p.iter().flatten().map(|c| c.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&portable), bits(&fk.positions(&values)));
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            let mut wide = vec![[0.0; 3]; 200 * fk.n_points()];
            // SAFETY: AVX2 was just detected.
            unsafe { fk.frames_avx2(&values, &mut wide) };
            assert_eq!(bits(&portable), bits(&wide));
        }
    }

    #[test]
    fn channel_count_mismatch_is_an_error() {
        let e = SkeletonMotion::new(arm(), vec![0.0; 7]).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::WrongValueCount);
        let m = SkeletonMotion::new(arm(), vec![0.0; 10]).unwrap();
        assert_eq!(m.n_frames(), 2);
        assert_eq!(m.channel(3), vec![0.0, 0.0]);
    }
}
