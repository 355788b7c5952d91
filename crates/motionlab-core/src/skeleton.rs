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

use nalgebra::{Rotation3, Vector3};

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
    pub fn new(name: impl Into<String>, parent: Option<usize>, offset: Point3, channels: Vec<ChannelKind>) -> Self {
        let rotation_order = channels
            .iter()
            .filter_map(|c| match c {
                ChannelKind::Rotation(a) => Some(*a),
                ChannelKind::Translation(_) => None,
            })
            .collect();
        Joint { name: name.into(), parent, offset, channels, rotation_order, axis: Rotation3::identity(), end_sites: Vec::new() }
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
                return Err(Error::new(ErrorKind::DuplicateName, format!("joint {:?} is declared twice", j.name)));
            }
            if let Some(p) = j.parent
                && p >= i
            {
                return Err(Error::new(ErrorKind::Syntax, format!("joint {:?} comes before its parent", j.name)));
            }
            if !j.offset.iter().chain(j.end_sites.iter().flatten()).all(|c| c.is_finite()) {
                return Err(Error::new(ErrorKind::NonFinite, format!("joint {:?} has a non-finite offset", j.name)));
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
                names.push(if e == 0 { format!("{}_end", j.name) } else { format!("{}_end{}", j.name, e + 1) });
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
    /// and each joint's global rotation.
    pub fn forward_kinematics(&self, values: &[f64]) -> (Vec<Point3>, Vec<Rotation3<f64>>) {
        let n = self.joints.len();
        let mut pos: Vec<Vector3<f64>> = Vec::with_capacity(n);
        let mut rot: Vec<Rotation3<f64>> = Vec::with_capacity(n);
        let mut at = 0;
        for (j, joint) in self.joints.iter().enumerate() {
            let vals = &values[at..at + joint.channels.len()];
            at += joint.channels.len();
            let mut translation = Vector3::zeros();
            for (c, v) in joint.channels.iter().zip(vals) {
                if let ChannelKind::Translation(a) = c {
                    translation[a.index()] += *v;
                }
            }
            let local = self.local_rotation(j, vals);
            let offset = Vector3::from(joint.offset);
            let (p, g) = match joint.parent {
                None => (offset + translation, local),
                Some(pi) => (pos[pi] + rot[pi] * (offset + translation), rot[pi] * local),
            };
            pos.push(p);
            rot.push(g);
        }
        let mut points: Vec<Point3> = pos.iter().map(|p| [p.x, p.y, p.z]).collect();
        for (j, joint) in self.joints.iter().enumerate() {
            for e in &joint.end_sites {
                let p = pos[j] + rot[j] * Vector3::from(*e);
                points.push([p.x, p.y, p.z]);
            }
        }
        (points, rot)
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
                format!("{} channel values is not a whole number of frames of {c} channels", channel_values.len()),
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
        (0..self.n_frames).flat_map(|f| self.skeleton.forward_kinematics(self.frame_values(f)).0).collect()
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
        let mut elbow = Joint::new("elbow", Some(0), [100.0, 0.0, 0.0], vec![ChannelKind::Rotation(Axis::Z)]);
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
    fn channel_count_mismatch_is_an_error() {
        let e = SkeletonMotion::new(arm(), vec![0.0; 7]).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::WrongValueCount);
        let m = SkeletonMotion::new(arm(), vec![0.0; 10]).unwrap();
        assert_eq!(m.n_frames(), 2);
        assert_eq!(m.channel(3), vec![0.0, 0.0]);
    }
}
