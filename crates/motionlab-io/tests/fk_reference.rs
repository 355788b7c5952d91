//! Forward kinematics stays bit for bit what it was: the loaders' positions are compared with a
//! verbatim copy of the original implementation (nalgebra `Rotation3` products, one per-frame
//! `Vec` per joint list) on every shipped BVH and AMC take.
//!
//! The production FK (`motionlab_core::skeleton::ForwardKinematics`) skips products with
//! identity matrices and multiplies out only the non-zero entries of the axis rotations, which
//! is exact for every non-zero result; this test pins that it is exact on real data, down to
//! the sign of zero (`f64::to_bits`), so the runs of record stay byte-identical.

use std::path::Path;

use motionlab_core::registry::{build_loader, default_params};
use motionlab_core::skeleton::{ChannelKind, axis_rotation};
use motionlab_core::{Motion, Point3, Skeleton};
use motionlab_testkit::data_path;
use nalgebra::{Rotation3, Vector3};

/// The original `Skeleton::forward_kinematics` (2026-11-23), verbatim (points only); its local
/// rotations come from `Skeleton::local_rotation`, which is still the original nalgebra code.
fn reference_forward_kinematics(skeleton: &Skeleton, values: &[f64]) -> Vec<Point3> {
    let n = skeleton.joints.len();
    let mut pos: Vec<Vector3<f64>> = Vec::with_capacity(n);
    let mut rot: Vec<Rotation3<f64>> = Vec::with_capacity(n);
    let mut at = 0;
    for (j, joint) in skeleton.joints.iter().enumerate() {
        let vals = &values[at..at + joint.channels.len()];
        at += joint.channels.len();
        let mut translation = Vector3::zeros();
        for (c, v) in joint.channels.iter().zip(vals) {
            if let ChannelKind::Translation(a) = c {
                translation[a.index()] += *v;
            }
        }
        let local = skeleton.local_rotation(j, vals);
        let offset = Vector3::from(joint.offset);
        let (p, g) = match joint.parent {
            None => (offset + translation, local),
            Some(pi) => (pos[pi] + rot[pi] * (offset + translation), rot[pi] * local),
        };
        pos.push(p);
        rot.push(g);
    }
    let mut points: Vec<Point3> = pos.iter().map(|p| [p.x, p.y, p.z]).collect();
    for (j, joint) in skeleton.joints.iter().enumerate() {
        for e in &joint.end_sites {
            let p = pos[j] + rot[j] * Vector3::from(*e);
            points.push([p.x, p.y, p.z]);
        }
    }
    points
}

/// Loads `file` and checks every coordinate of every frame against the reference, bit for bit.
fn assert_loader_matches_reference(loader: &str, file: &str) {
    let motion: Motion =
        build_loader(loader, &default_params()).unwrap().load(&data_path(file)).unwrap();
    let sm = motion.skeleton.as_ref().expect("a skeleton motion");
    let m = motion.n_points();
    assert!(motion.n_frames() > 100, "{file}");
    for f in 0..motion.n_frames() {
        let expected = reference_forward_kinematics(&sm.skeleton, sm.frame_values(f));
        assert_eq!(expected.len(), m);
        for (k, (got, want)) in motion.frame(f).iter().zip(&expected).enumerate() {
            let same = got.iter().zip(want).all(|(a, b)| a.to_bits() == b.to_bits());
            assert!(
                same,
                "{file} frame {f} point {}: {got:?} vs reference {want:?}",
                motion.point_names()[k]
            );
        }
    }
}

#[test]
fn amc_86_01_positions_are_bit_identical_to_the_reference() {
    assert_loader_matches_reference("asf_amc", "cmu86/86_01.amc.gz");
}

#[test]
fn bvh_131_01_positions_are_bit_identical_to_the_reference() {
    assert_loader_matches_reference("bvh", "cmu131/131_01.bvh.gz");
}

#[test]
fn every_other_shipped_take_is_bit_identical_to_the_reference() {
    for file in ["cmu131/131_02.bvh.gz", "cmu131/131_03.bvh.gz"] {
        assert_loader_matches_reference("bvh", file);
    }
    for file in ["mocap6/amc/13_29.amc.gz", "mocap6/amc/13_30.amc.gz", "mocap6/amc/13_31.amc.gz"] {
        assert_loader_matches_reference("asf_amc", file);
    }
}

/// Hand-made skeletons that hit the corners the real takes may not: repeated and missing
/// rotation axes, angles of exactly ±0, 90° and 180°, several end sites, translations on
/// non-root joints, axis rotations with exact zeros.
#[test]
fn synthetic_corner_cases_are_bit_identical_to_the_reference() {
    use motionlab_core::{Axis, Joint, SkeletonMotion};
    let t = |a| ChannelKind::Translation(a);
    let r = |a| ChannelKind::Rotation(a);
    let mut root = Joint::new(
        "root",
        None,
        [1.0, -0.0, 2.5],
        vec![t(Axis::X), t(Axis::Y), t(Axis::Z), r(Axis::Z), r(Axis::X), r(Axis::Y)],
    );
    root.axis = axis_rotation(Axis::Y, 0.3) * axis_rotation(Axis::X, -1.2);
    let mut a =
        Joint::new("a", Some(0), [0.0, 10.0, 0.0], vec![r(Axis::X), r(Axis::X), r(Axis::Z)]);
    a.end_sites = vec![[0.0, 0.0, 3.0], [-0.0, 1.0, 0.0]];
    let mut b = Joint::new("b", Some(1), [5.0, 0.0, -0.0], vec![t(Axis::Y), r(Axis::Y)]);
    b.rotation_order = vec![Axis::Z, Axis::Y, Axis::X];
    b.axis = axis_rotation(Axis::Z, std::f64::consts::FRAC_PI_2);
    let c = Joint::new("c", Some(0), [-3.0, 0.0, 0.0], vec![]);
    let mut d = Joint::new("d", Some(3), [0.0, -4.0, 0.0], vec![r(Axis::Y), r(Axis::Z)]);
    d.end_sites = vec![[1.0, 2.0, 3.0]];
    let skeleton = Skeleton { joints: vec![root, a, b, c, d] };
    let angles = [0.0, -0.0, 90.0, -90.0, 180.0, -180.0, 1e-300, 33.3, 720.5];
    let mut values = Vec::new();
    let mut n_frames = 0;
    for (i, &x) in angles.iter().enumerate() {
        for &y in &angles {
            let z = angles[(i * 7 + 3) % angles.len()];
            values.extend([x * 0.5, -0.0, y, x, y, z, y, z, x, -0.0, z, y, x]);
            n_frames += 1;
        }
    }
    let sm = SkeletonMotion::new(skeleton, values).unwrap();
    let positions = sm.positions();
    let m = sm.skeleton.point_names().len();
    assert_eq!(positions.len(), n_frames * m);
    for f in 0..n_frames {
        let expected = reference_forward_kinematics(&sm.skeleton, sm.frame_values(f));
        for (k, (got, want)) in positions[f * m..(f + 1) * m].iter().zip(&expected).enumerate() {
            let same = got.iter().zip(want).all(|(a, b)| a.to_bits() == b.to_bits());
            assert!(same, "frame {f} point {k}: {got:?} vs reference {want:?}");
        }
    }
}

#[test]
fn reference_is_not_trivially_equal() {
    // The comparison above must be able to fail: a one-ulp change of one channel moves a point.
    let p = data_path("cmu131/131_01.bvh.gz");
    let text = motionlab_io::read::read_text(&p).unwrap();
    let d =
        motionlab_io::bvh::parse_bvh_channels(&text, Path::new("131_01.bvh"), &Default::default())
            .unwrap();
    let mut v = d.motion.frame_values(0).to_vec();
    let before = reference_forward_kinematics(&d.motion.skeleton, &v);
    v[5] = f64::from_bits(v[5].to_bits() + 1);
    let after = reference_forward_kinematics(&d.motion.skeleton, &v);
    assert_ne!(before, after);
}
