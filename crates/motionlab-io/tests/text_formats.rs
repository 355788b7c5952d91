//! Real-data tests of the text formats: BVH (`data/cmu131`), ASF/AMC (`data/cmu86`,
//! `data/mocap6`), the BVH writer, the ground-truth readers, and their error cases (each names its file and line).
//!
//! Each shipped motion is loaded once per test binary (forward kinematics of a 4600-frame AMC
//! takes seconds in an unoptimised build).

use std::path::Path;
use std::sync::LazyLock;

use motionlab_core::registry::{build_ground_truth, build_loader, default_params, find};
use motionlab_core::{Axis, ErrorKind, FrameRate, LengthUnit, Motion, Result};
use motionlab_io::asf_amc::{AsfSkeleton, parse_amc, parse_asf};
use motionlab_io::bvh::{BvhOptions, parse_bvh, parse_bvh_channels, rest_pose_height, write_bvh};
use motionlab_io::read::read_text;
use motionlab_testkit::data_path;

const MM_PER_CMU_UNIT: f64 = 25.4 / 0.45;

fn load(loader: &str, params: &str, file: &str) -> Result<Motion> {
    let params: toml::Value = toml::from_str(params).expect("test params are valid TOML");
    build_loader(loader, &params)?.load(&data_path(file))
}

static BVH_131_01: LazyLock<Motion> =
    LazyLock::new(|| load("bvh", "", "cmu131/131_01.bvh.gz").unwrap());
static AMC_86_01: LazyLock<Motion> =
    LazyLock::new(|| load("asf_amc", "", "cmu86/86_01.amc.gz").unwrap());
static ASF_86: LazyLock<AsfSkeleton> = LazyLock::new(|| {
    let p = data_path("cmu86/86.asf");
    parse_asf(&read_text(&p).unwrap(), &p).unwrap()
});

/// The three mocap6 AMC files: an explicit relative skeleton path for one, auto-discovery
/// (`../asf/13.asf`) for the others; (file, params, frames as counted by `grep -c '^[0-9]*$'`).
const MOCAP6: [(&str, &str, usize); 3] = [
    ("mocap6/amc/13_29.amc.gz", "skeleton = \"../asf/13.asf\"", 4592),
    ("mocap6/amc/13_30.amc.gz", "", 2465),
    ("mocap6/amc/13_31.amc.gz", "frame_rate_hz = 120.0", 3017),
];
static MOCAP6_MOTIONS: LazyLock<Vec<Motion>> = LazyLock::new(|| {
    MOCAP6.iter().map(|(file, params, _)| load("asf_amc", params, file).unwrap()).collect()
});

fn text_of(file: &str) -> String {
    read_text(&data_path(file)).unwrap()
}

/// Every bone (joint–parent and end site–joint) keeps its rest length (the offset's norm) in
/// every frame, to `rel` relative; zero-length bones stay at zero. Returns how many were checked.
fn assert_bone_lengths_constant(m: &Motion, rel: f64) -> usize {
    let sk = &m.skeleton.as_ref().expect("skeleton motion").skeleton;
    let norm = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    let mut rest: Vec<f64> =
        sk.joints.iter().filter(|j| j.parent.is_some()).map(|j| norm(j.offset)).collect();
    rest.extend(sk.joints.iter().flat_map(|j| j.end_sites.iter().map(|e| norm(*e))));
    let bones = sk.bones();
    assert_eq!(bones.len(), rest.len());
    for f in 0..m.n_frames() {
        let p = m.frame(f);
        for (&(a, b), &len) in bones.iter().zip(&rest) {
            let d = norm([p[a][0] - p[b][0], p[a][1] - p[b][1], p[a][2] - p[b][2]]);
            let ok = if len == 0.0 { d < 1e-9 } else { (d - len).abs() <= rel * len };
            assert!(
                ok,
                "frame {f}: bone {}–{} is {d} mm, rest length {len} mm",
                m.point_names()[a],
                m.point_names()[b]
            );
        }
    }
    bones.len()
}

// ---------------------------------------------------------------------------------------------
// Independent rotation matrices for hand-checks (plain arrays, column vectors).
// ---------------------------------------------------------------------------------------------

type M3 = [[f64; 3]; 3];

fn rot(axis: usize, deg: f64) -> M3 {
    let (s, c) = deg.to_radians().sin_cos();
    match axis {
        0 => [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]],
        1 => [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]],
        _ => [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]],
    }
}
fn mul(a: M3, b: M3) -> M3 {
    let mut o = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            o[i][j] = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    o
}
fn transpose(a: M3) -> M3 {
    let mut o = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            o[i][j] = a[j][i];
        }
    }
    o
}
fn apply(a: M3, v: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|i| a[i][0] * v[0] + a[i][1] * v[1] + a[i][2] * v[2])
}
fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    a.map(|c| c * s)
}
/// `Rz(z)·Ry(y)·Rx(x)` — CMU's Euler convention (x applied first).
fn zyx(x: f64, y: f64, z: f64) -> M3 {
    mul(rot(2, z), mul(rot(1, y), rot(0, x)))
}
fn assert_close(a: [f64; 3], b: [f64; 3], tol: f64, what: &str) {
    let d = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
    assert!(d <= tol, "{what}: {a:?} vs {b:?} ({d} mm apart)");
}

// ---------------------------------------------------------------------------------------------
// BVH on real data
// ---------------------------------------------------------------------------------------------

#[test]
fn bvh_131_01_has_994_frames_at_120_fps_in_cmu_units() {
    let m = &*BVH_131_01;
    assert_eq!(m.n_frames(), 994);
    assert_eq!(m.frame_rate().hz(), 120.0);
    assert_eq!((m.format.as_str(), m.name.as_str(), m.up_axis()), ("bvh", "131_01", Axis::Y));
    let sk = m.skeleton.as_ref().unwrap();
    assert_eq!(sk.n_frames(), 994);
    assert_eq!(m.point_names(), sk.skeleton.point_names());
    assert_eq!(&m.point_names()[..3], ["Hips", "LHipJoint", "LeftHip"]);
    assert!(m.point_names().contains(&"Head_end".to_string()));
    assert_eq!(m.missing_count(), 0);
    // Auto unit = CMU units; the first frame line starts 5.2300 16.9002 -33.8986 -5.4029 …
    let text = text_of("cmu131/131_01.bvh.gz");
    let d = parse_bvh_channels(&text, Path::new("131_01.bvh"), &BvhOptions::default()).unwrap();
    assert_eq!(d.length_unit, LengthUnit::CmuUnit);
    assert_eq!(d.frame_time_s, 0.0083333);
    let v = sk.frame_values(0);
    let expect = [
        5.2300 * MM_PER_CMU_UNIT,
        16.9002 * MM_PER_CMU_UNIT,
        -33.8986 * MM_PER_CMU_UNIT,
        -5.4029,
        9.8098,
        10.4956,
    ];
    for (a, b) in v.iter().zip(expect) {
        assert!((a - b).abs() < 1e-9, "{v:?}");
    }
    // LeftHip's OFFSET 1.24777 -1.64261 0.71711, in mm.
    let lh = &sk.skeleton.joints[2];
    assert_eq!(lh.offset, [1.24777, -1.64261, 0.71711].map(|c| c * MM_PER_CMU_UNIT));
    // Rest pose 24.27 units tall (legs splayed); the capture's standing pose is 1.3–1.6 m.
    let h = rest_pose_height(&d.motion.skeleton, Axis::Y) / MM_PER_CMU_UNIT;
    assert!((h - 24.27).abs() < 0.01, "{h}");
    let ys: Vec<f64> = m.frame(0).iter().map(|p| p[1]).collect();
    let stand =
        ys.iter().cloned().fold(f64::MIN, f64::max) - ys.iter().cloned().fold(f64::MAX, f64::min);
    assert!((1300.0..1600.0).contains(&stand), "{stand}");
}

#[test]
fn bvh_131_01_bone_lengths_are_constant_over_every_frame() {
    let n = assert_bone_lengths_constant(&BVH_131_01, 1e-6);
    assert!(n > 30, "{n}");
}

#[test]
fn bvh_fk_matches_an_independent_computation_on_the_left_arm() {
    // Chain Hips → lowerback → Chest → Chest2 → LeftCollar → LeftShoulder → LeftElbow: the
    // arm joints list `Zrotation Xrotation Yrotation` (the spine `Z Y X`), so this checks
    // per-joint channel order. Computed here with plain matrices at frame 500.
    let m = &*BVH_131_01;
    let sm = m.skeleton.as_ref().unwrap();
    let sk = &sm.skeleton;
    let f = 500;
    let values = sm.frame_values(f);
    let mut first = Vec::new();
    let mut at = 0;
    for j in &sk.joints {
        first.push(at);
        at += j.channels.len();
    }
    let idx = |n: &str| sk.joint_index(n).unwrap();
    let chain = ["Hips", "lowerback", "Chest", "Chest2", "LeftCollar", "LeftShoulder", "LeftElbow"];
    let mut g = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let hips = idx("Hips");
    let mut p = add(sk.joints[hips].offset, [values[0], values[1], values[2]]);
    for (k, name) in chain.iter().enumerate() {
        let j = idx(name);
        if k > 0 {
            p = add(p, apply(g, sk.joints[j].offset));
            assert_close(m.position(f, j), p, 1e-9, name);
        }
        // Local rotation: product of the rotation channels in listed order.
        let mut local = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        for (c, v) in sk.joints[j].channels.iter().zip(&values[first[j]..]) {
            if let motionlab_core::ChannelKind::Rotation(a) = c {
                local = mul(local, rot(a.index(), *v));
            }
        }
        g = mul(g, local);
    }
    assert_eq!(
        sk.joints[idx("LeftElbow")].channels.iter().map(|c| c.bvh_name()).collect::<Vec<_>>(),
        ["Zrotation", "Xrotation", "Yrotation"]
    );
}

#[test]
fn bvh_other_shipped_files_load() {
    for (file, frames) in [("cmu131/131_02.bvh.gz", 1247), ("cmu131/131_03.bvh.gz", 1102)] {
        let text = text_of(file);
        let d = parse_bvh_channels(&text, &data_path(file), &BvhOptions::default()).unwrap();
        assert_eq!(
            (d.motion.n_frames(), d.frame_rate.hz(), d.length_unit),
            (frames, 120.0, LengthUnit::CmuUnit),
            "{file}"
        );
    }
}

#[test]
fn bvh_explicit_length_unit_and_up_axis_are_used() {
    let text = text_of("cmu131/131_01.bvh.gz");
    let opts = BvhOptions {
        length_unit: Some(LengthUnit::Inch),
        up_axis: Axis::Z,
        ..BvhOptions::default()
    };
    let d = parse_bvh_channels(&text, Path::new("x.bvh"), &opts).unwrap();
    assert_eq!(d.length_unit, LengthUnit::Inch);
    assert_eq!(d.motion.skeleton.joints[2].offset[0], 1.24777 * 25.4);
    // Rotations are not lengths: unchanged.
    assert_eq!(d.motion.frame_values(0)[3], -5.4029);
    let e = load("bvh", "length_unit = \"furlong\"", "cmu131/131_01.bvh.gz").err().unwrap();
    assert_eq!(e.kind(), ErrorKind::WrongType);
}

// ---------------------------------------------------------------------------------------------
// Line endings and BOM
// ---------------------------------------------------------------------------------------------

#[test]
fn crlf_lf_and_bom_load_identically() {
    // 131_01 mixes CRLF and LF lines; 86_01.amc and 86.asf are CRLF throughout.
    let bvh = text_of("cmu131/131_01.bvh.gz");
    assert!(bvh.contains("\r\n") && bvh.contains("0000\n"));
    let lf = bvh.replace("\r\n", "\n");
    let crlf = lf.replace('\n', "\r\n");
    let bom = format!("\u{feff}{crlf}");
    let opts = BvhOptions::default();
    let base = parse_bvh_channels(&bvh, Path::new("a.bvh"), &opts).unwrap();
    for variant in [&lf, &crlf, &bom] {
        let d = parse_bvh_channels(variant, Path::new("a.bvh"), &opts).unwrap();
        assert_eq!(d.motion.skeleton, base.motion.skeleton);
        assert_eq!(d.motion.channel_values(), base.motion.channel_values());
    }
    // Positions are a function of skeleton and channels; check one variant end to end anyway.
    let short = |t: &str| {
        let cut: Vec<&str> = t.split_inclusive('\n').collect();
        let header_end = cut.iter().position(|l| l.starts_with("Frame Time")).unwrap() + 1;
        cut[..header_end].concat().replace("Frames: 994", "Frames: 20")
            + &cut[header_end..header_end + 20].concat()
    };
    let a = parse_bvh(&short(&lf), Path::new("a.bvh"), &opts).unwrap();
    let b = parse_bvh(&short(&bom), Path::new("a.bvh"), &opts).unwrap();
    assert_eq!(a.positions(), b.positions());

    let asf = text_of("cmu86/86.asf");
    let amc = text_of("cmu86/86_01.amc.gz");
    assert!(asf.contains("\r\n") && amc.contains("\r\n"));
    let asf_lf = parse_asf(&asf.replace("\r\n", "\n"), Path::new("86.asf")).unwrap();
    let asf_bom = parse_asf(&format!("\u{feff}{asf}"), Path::new("86.asf")).unwrap();
    assert_eq!(asf_lf.skeleton, ASF_86.skeleton);
    assert_eq!(asf_bom.skeleton, ASF_86.skeleton);
    let base = parse_amc(&amc, Path::new("86_01.amc"), &ASF_86).unwrap();
    let lf = parse_amc(&amc.replace("\r\n", "\n"), Path::new("86_01.amc"), &asf_lf).unwrap();
    let bom = parse_amc(&format!("\u{feff}{amc}"), Path::new("86_01.amc"), &ASF_86).unwrap();
    assert_eq!(lf.channel_values(), base.channel_values());
    assert_eq!(bom.channel_values(), base.channel_values());
}

// ---------------------------------------------------------------------------------------------
// BVH writer
// ---------------------------------------------------------------------------------------------

#[test]
fn bvh_round_trip_keeps_channels_and_positions() {
    let m = &*BVH_131_01;
    let sm = m.skeleton.as_ref().unwrap();
    let mut out = Vec::new();
    write_bvh(sm, m.frame_rate(), LengthUnit::CmuUnit, &mut out).unwrap();
    let text = String::from_utf8(out).unwrap();
    assert!(
        text.starts_with("HIERARCHY\nROOT Hips\n{\n\tOFFSET 0.000000 0.000000 0.000000\n"),
        "{}",
        &text[..200]
    );
    let back = parse_bvh(&text, Path::new("rt.bvh"), &BvhOptions::default()).unwrap();
    let bs = back.skeleton.as_ref().unwrap();
    assert_eq!(back.frame_rate(), m.frame_rate());
    assert_eq!(back.point_names(), m.point_names());
    assert_eq!(bs.skeleton.channel_names(), sm.skeleton.channel_names());
    // Six decimals: within 0.5e-6 of a unit (translations, mm = × 56.4) or a degree.
    for (k, (a, b)) in bs.channel_values().iter().zip(sm.channel_values()).enumerate() {
        assert!((a - b).abs() <= 0.5e-6 * MM_PER_CMU_UNIT + 1e-9, "value {k}: {a} vs {b}");
    }
    for (a, b) in back.positions().iter().zip(m.positions()) {
        assert_close(*a, *b, 1e-6 * MM_PER_CMU_UNIT, "position");
    }
}

#[test]
fn asf_amc_written_as_bvh_reproduces_the_positions() {
    // ASF joints have an axis rotation C, which BVH lacks: the writer bakes C·M·C⁻¹ into
    // Z-Y-X Euler angles. 240 frames keep the test quick.
    let m = AMC_86_01.slice_frames(0, 240).unwrap();
    let sm = m.skeleton.as_ref().unwrap();
    let mut out = Vec::new();
    write_bvh(sm, m.frame_rate(), LengthUnit::CmuUnit, &mut out).unwrap();
    let text = String::from_utf8(out).unwrap();
    let back = parse_bvh(&text, Path::new("86_01.bvh"), &BvhOptions::default()).unwrap();
    assert_eq!(back.point_names(), m.point_names());
    assert_eq!(back.frame_rate().hz(), 120.0);
    // Euler angles printed to 1e-6°: a chain of ~10 joints 2 m long moves < 1e-3 mm.
    let mut worst = 0.0f64;
    for (a, b) in back.positions().iter().zip(m.positions()) {
        let d = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
        worst = worst.max(d);
    }
    assert!(worst < 1e-3, "worst {worst} mm");
}

// ---------------------------------------------------------------------------------------------
// ASF/AMC on real data
// ---------------------------------------------------------------------------------------------

#[test]
fn amc_86_01_has_4579_frames_and_a_plausible_height() {
    let m = &*AMC_86_01;
    assert_eq!(m.n_frames(), 4579);
    assert_eq!(m.frame_rate().hz(), 120.0);
    assert_eq!((m.format.as_str(), m.name.as_str(), m.up_axis()), ("asf_amc", "86_01", Axis::Y));
    let sk = &m.skeleton.as_ref().unwrap().skeleton;
    // root + 30 bones; leaf bones: ltoes rtoes head lfingers lthumb rfingers rthumb.
    assert_eq!(sk.joints.len(), 31);
    assert_eq!(m.n_points(), 38);
    assert_eq!(sk.n_channels(), 62);
    assert_eq!(ASF_86.length_unit, Some(LengthUnit::CmuUnit));
    assert!((ASF_86.mm_per_unit - 56.444_444).abs() < 1e-5);
    // Standing height (max − min joint height) in the first frame, and in the rest pose.
    let ys: Vec<f64> = m.frame(0).iter().map(|p| p[1]).collect();
    let h =
        ys.iter().cloned().fold(f64::MIN, f64::max) - ys.iter().cloned().fold(f64::MAX, f64::min);
    assert!((1500.0..2000.0).contains(&h), "first frame {h} mm");
    let rest = rest_pose_height(sk, Axis::Y);
    assert!((1500.0..2000.0).contains(&rest), "rest pose {rest} mm");
    // First frame's root: 17.3866 18.0959 0.17894 units.
    let root = m.position(0, 0);
    assert_close(root, [17.3866, 18.0959, 0.17894].map(|c| c * MM_PER_CMU_UNIT), 1e-9, "root");
}

#[test]
fn amc_86_01_bone_lengths_are_constant_over_every_frame() {
    let n = assert_bone_lengths_constant(&AMC_86_01, 1e-6);
    assert_eq!(n, 37);
}

#[test]
fn asf_rest_pose_equals_the_sums_of_direction_times_length() {
    // Numbers copied from data/cmu86/86.asf (lhipjoint, lfemur, ltibia, lfoot, ltoes).
    let bones = [
        ([0.561145, -0.797705, 0.220866], 2.46425),
        ([0.34202, -0.939693, 0.0], 7.95556),
        ([0.34202, -0.939693, 0.0], 7.9832),
        ([0.0723927, -0.198897, 0.977343], 2.23085),
        ([1.53826e-011, -4.21988e-011, 1.0], 1.12127),
    ];
    let sk = &ASF_86.skeleton;
    let (rest, _) = sk.forward_kinematics(&vec![0.0; sk.n_channels()]);
    let names = sk.point_names();
    let at = |n: &str| rest[names.iter().position(|x| x == n).unwrap()];
    // A joint sits at the start of its bone: lfemur starts where lhipjoint ends, …
    let mut sum = [0.0; 3];
    assert_close(at("lhipjoint"), sum, 1e-12, "lhipjoint");
    for (name, (d, l)) in ["lfemur", "ltibia", "lfoot", "ltoes", "ltoes_end"].iter().zip(bones) {
        sum = add(sum, scale(d, l * MM_PER_CMU_UNIT));
        assert_close(at(name), sum, 1e-9, name);
    }
}

#[test]
fn amc_fk_matches_an_independent_computation_of_the_left_leg() {
    // The CMU viewer's algorithm, written out with numbers copied from 86.asf and from frame 1
    // of 86_01.amc: a bone's end = its parent's end + length · (M_parent · C · E · C⁻¹) · direction,
    // E = Rz·Ry·Rx of its dof values, C = Rz·Ry·Rx of its axis angles.
    let root_t = [17.3866, 18.0959, 0.17894];
    let m_root = zyx(-88.1261, -87.8338, 101.641);
    // (direction, length, axis angles, dof values as (rx, ry, rz))
    type Bone = ([f64; 3], f64, [f64; 3], [f64; 3]);
    let bones: [Bone; 5] = [
        ([0.561145, -0.797705, 0.220866], 2.46425, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]), // lhipjoint: no dof
        ([0.34202, -0.939693, 0.0], 7.95556, [0.0, 0.0, 20.0], [-29.1974, 1.82053, -23.3363]), // lfemur rx ry rz
        ([0.34202, -0.939693, 0.0], 7.9832, [0.0, 0.0, 20.0], [40.0149, 0.0, 0.0]), // ltibia rx
        (
            [0.0723927, -0.198897, 0.977343],
            2.23085,
            [-90.0, 7.62852e-016, 20.0],
            [-22.863, 0.0, 0.874378],
        ), // lfoot rx rz
        (
            [1.53826e-011, -4.21988e-011, 1.0],
            1.12127,
            [-90.0, 7.62852e-016, 20.0],
            [-5.96403, 0.0, 0.0],
        ), // ltoes rx
    ];
    let names = ["ltibia", "lfoot", "ltoes", "ltoes_end"];
    let mut m = m_root;
    let mut end = root_t;
    let mut expected = Vec::new();
    for (d, l, axis, dof) in bones {
        let c = zyx(axis[0], axis[1], axis[2]);
        m = mul(m, mul(c, mul(zyx(dof[0], dof[1], dof[2]), transpose(c))));
        end = add(end, scale(apply(m, d), l));
        expected.push(end);
    }
    let motion = &*AMC_86_01;
    for (name, e) in names.iter().zip(&expected[1..]) {
        let k = motion.point_index(name).unwrap();
        assert_close(motion.position(0, k), scale(*e, MM_PER_CMU_UNIT), 1e-6, name);
    }
}

#[test]
fn mocap6_amc_files_load_with_the_13_skeleton() {
    let p13 = data_path("mocap6/asf/13.asf");
    let asf = parse_asf(&read_text(&p13).unwrap(), &p13).unwrap();
    for ((file, _, frames), m) in MOCAP6.iter().zip(MOCAP6_MOTIONS.iter()) {
        assert_eq!(m.n_frames(), *frames, "{file}");
        assert_eq!(m.frame_rate().hz(), 120.0);
        // The loader found (or was given) 13.asf: same skeleton as parsed here.
        assert_eq!(m.skeleton.as_ref().unwrap().skeleton, asf.skeleton, "{file}");
        let ys: Vec<f64> = m.frame(0).iter().map(|p| p[1]).collect();
        let h = ys.iter().cloned().fold(f64::MIN, f64::max)
            - ys.iter().cloned().fold(f64::MAX, f64::min);
        assert!((1300.0..2000.0).contains(&h), "{file}: {h} mm");
    }
    assert_bone_lengths_constant(&MOCAP6_MOTIONS[1], 1e-6);
}

#[test]
fn asf_discovery_failure_lists_the_paths_tried() {
    let dir = std::env::temp_dir().join(format!("mlab-asf-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let amc = dir.join("99_01.amc");
    std::fs::write(&amc, "1\nroot 0 0 0 0 0 0\n").unwrap();
    let e = build_loader("asf_amc", &default_params()).unwrap().load(&amc).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::Io);
    assert!(e.to_string().contains("99.asf") && e.to_string().contains("skeleton"), "{e}");
    // An absolute skeleton path is used as given.
    let asf = dir.join("other.asf");
    std::fs::write(&asf, ":root\n order TX TY TZ RX RY RZ\n axis XYZ\n position 0 0 0\n orientation 0 0 0\n:bonedata\n:hierarchy\n").unwrap();
    let params: toml::Value =
        toml::Value::Table(toml::toml! { skeleton = (asf.display().to_string()) });
    let m = build_loader("asf_amc", &params).unwrap().load(&amc).unwrap();
    assert_eq!((m.n_frames(), m.n_points()), (1, 1));
    std::fs::remove_dir_all(&dir).ok();
}

// ---------------------------------------------------------------------------------------------
// Errors: kind, file and line
// ---------------------------------------------------------------------------------------------

fn assert_error_at(e: &motionlab_core::Error, kind: ErrorKind, file: &str, line: usize) {
    assert_eq!(e.kind(), kind, "{e}");
    assert_eq!(e.location().line, Some(line), "{e}");
    let shown = e.to_string();
    assert!(shown.starts_with(&format!("{file}:{line}: ")), "{shown}");
    assert!(!shown.contains('\n'), "{shown}");
}

/// 131_01 with LF endings; line numbers below refer to it.
fn bvh_lf() -> String {
    text_of("cmu131/131_01.bvh.gz").replace("\r\n", "\n")
}

fn motion_line(text: &str) -> usize {
    text.lines().position(|l| l.starts_with("Frame Time")).unwrap() + 1
}

fn replace_line(text: &str, line: usize, new: &str) -> String {
    let mut lines: Vec<&str> = text.split('\n').collect();
    lines[line - 1] = new;
    lines.join("\n")
}

#[test]
fn truncated_bvh_frames_and_hierarchy_are_errors() {
    let text = bvh_lf();
    let ft = motion_line(&text);
    // Keep 500 of 994 frame lines.
    let cut: String = text.split_inclusive('\n').take(ft + 500).collect();
    let e = parse_bvh(&cut, Path::new("cut.bvh"), &BvhOptions::default()).unwrap_err();
    assert_error_at(&e, ErrorKind::Truncated, "cut.bvh", ft + 501);
    assert!(e.message().contains("500 frame lines") && e.message().contains("994"), "{e}");
    // Cut inside HIERARCHY (in the middle of the left arm).
    for keep in [110, 120] {
        let cut: String = text.split_inclusive('\n').take(keep).collect();
        let e = parse_bvh(&cut, Path::new("cut.bvh"), &BvhOptions::default()).unwrap_err();
        assert_error_at(&e, ErrorKind::Truncated, "cut.bvh", keep + 1);
        assert!(
            e.message().contains("file ends inside") && e.message().contains("joint \"L"),
            "{e}"
        );
    }
    // Through the loader: the error names the real file.
    let dir = std::env::temp_dir().join(format!("mlab-bvh-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let f = dir.join("short.bvh");
    std::fs::write(&f, text.split_inclusive('\n').take(ft + 3).collect::<String>()).unwrap();
    let e = build_loader("bvh", &default_params()).unwrap().load(&f).unwrap_err();
    assert_error_at(&e, ErrorKind::Truncated, &f.display().to_string(), ft + 4);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bvh_frame_line_with_the_wrong_number_of_values() {
    let text = bvh_lf();
    let line = motion_line(&text) + 10;
    let values: Vec<&str> = text.lines().nth(line - 1).unwrap().split_whitespace().collect();
    let n = values.len();
    let short = replace_line(&text, line, &values[..n - 1].join(" "));
    let e = parse_bvh(&short, Path::new("w.bvh"), &BvhOptions::default()).unwrap_err();
    assert_error_at(&e, ErrorKind::WrongValueCount, "w.bvh", line);
    assert!(e.message().contains(&format!("found {} values, expected {n}", n - 1)), "{e}");
    let long = replace_line(&text, line, &format!("{} 1.0", values.join(" ")));
    let e = parse_bvh(&long, Path::new("w.bvh"), &BvhOptions::default()).unwrap_err();
    assert_error_at(&e, ErrorKind::WrongValueCount, "w.bvh", line);
    assert!(e.message().contains(&format!("found {} values, expected {n}", n + 1)), "{e}");
}

#[test]
fn bvh_non_numeric_and_non_finite_values() {
    let text = bvh_lf();
    let line = motion_line(&text) + 3;
    let orig = text.lines().nth(line - 1).unwrap();
    for (bad, kind) in [
        ("1.2.3", ErrorKind::Syntax),
        ("abc", ErrorKind::Syntax),
        ("nan", ErrorKind::NonFinite),
        ("-inf", ErrorKind::NonFinite),
    ] {
        let t = replace_line(&text, line, &orig.replacen("0.0000", bad, 1));
        let e = parse_bvh(&t, Path::new("n.bvh"), &BvhOptions::default()).unwrap_err();
        assert_error_at(&e, kind, "n.bvh", line);
        assert!(e.message().contains(bad), "{e}");
    }
    // A NaN OFFSET in the hierarchy (line 4: the root's OFFSET).
    let t = replace_line(&text, 4, "\tOFFSET 0 NaN 0");
    let e = parse_bvh(&t, Path::new("n.bvh"), &BvhOptions::default()).unwrap_err();
    assert_error_at(&e, ErrorKind::NonFinite, "n.bvh", 4);
}

#[test]
fn bvh_frame_time_must_be_positive() {
    let text = bvh_lf();
    let line = motion_line(&text);
    for bad in ["0", "-0.0083333"] {
        let t = replace_line(&text, line, &format!("Frame Time: {bad}"));
        let e = parse_bvh(&t, Path::new("t.bvh"), &BvhOptions::default()).unwrap_err();
        assert_error_at(&e, ErrorKind::OutOfRange, "t.bvh", line);
    }
}

#[test]
fn bvh_duplicate_joint_names_are_refused() {
    let text = bvh_lf();
    // Rename RHipJoint (line 35) to LHipJoint (line 6).
    assert_eq!(text.lines().nth(34).unwrap().trim(), "JOINT RHipJoint");
    let t = replace_line(&text, 35, "\tJOINT LHipJoint");
    let e = parse_bvh(&t, Path::new("d.bvh"), &BvhOptions::default()).unwrap_err();
    assert_error_at(&e, ErrorKind::DuplicateName, "d.bvh", 35);
    assert!(e.message().contains("LHipJoint") && e.message().contains("line 6"), "{e}");
}

#[test]
fn amc_bone_absent_from_the_asf_names_the_bone_line_and_close_names() {
    let amc = text_of("cmu86/86_01.amc.gz").replace("\r\n", "\n");
    // Frame 2's lfemur line.
    let line =
        amc.lines().enumerate().filter(|(_, l)| l.starts_with("lfemur ")).nth(1).unwrap().0 + 1;
    let orig = amc.lines().nth(line - 1).unwrap().to_string();
    let t = replace_line(&amc, line, &orig.replace("lfemur", "lfemr"));
    let e = parse_amc(&t, Path::new("86_01.amc"), &ASF_86).unwrap_err();
    assert_error_at(&e, ErrorKind::UnknownName, "86_01.amc", line);
    assert!(
        e.message().contains("\"lfemr\"")
            && e.message().contains("lfemur")
            && e.message().contains("86.asf"),
        "{e}"
    );
}

#[test]
fn amc_bone_line_with_the_wrong_number_of_values() {
    let amc = text_of("cmu86/86_01.amc.gz").replace("\r\n", "\n");
    let line = amc.lines().position(|l| l.starts_with("lfoot ")).unwrap() + 1;
    let t = replace_line(&amc, line, "lfoot -22.863");
    let e = parse_amc(&t, Path::new("86_01.amc"), &ASF_86).unwrap_err();
    assert_error_at(&e, ErrorKind::WrongValueCount, "86_01.amc", line);
    assert!(e.message().contains("found 1 values, expected 2 (dof rx rz)"), "{e}");
    // NaN in an AMC value.
    let t = replace_line(&amc, line, "lfoot nan 0.8");
    let e = parse_amc(&t, Path::new("86_01.amc"), &ASF_86).unwrap_err();
    assert_error_at(&e, ErrorKind::NonFinite, "86_01.amc", line);
    // A bone left out of a frame.
    let t = replace_line(&amc, line, "");
    let e = parse_amc(&t, Path::new("86_01.amc"), &ASF_86).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::WrongValueCount, "{e}");
    assert!(e.message().contains("lfoot"), "{e}");
}

#[test]
fn asf_hierarchy_naming_an_undeclared_bone() {
    let asf = text_of("cmu86/86.asf").replace("\r\n", "\n");
    let line = asf.lines().position(|l| l.trim() == "lfemur ltibia").unwrap() + 1;
    let t = replace_line(&asf, line, "    lfemur ltibia lknee");
    let e = parse_asf(&t, Path::new("86.asf")).unwrap_err();
    assert_error_at(&e, ErrorKind::UnknownName, "86.asf", line);
    assert!(e.message().contains("lknee"), "{e}");
    // A duplicate bone name.
    let line = asf.lines().position(|l| l.trim() == "name rfemur").unwrap() + 1;
    let t = replace_line(&asf, line, "     name lfemur");
    let e = parse_asf(&t, Path::new("86.asf")).unwrap_err();
    assert_error_at(&e, ErrorKind::DuplicateName, "86.asf", line);
}

// ---------------------------------------------------------------------------------------------
// Ground truth on real data
// ---------------------------------------------------------------------------------------------

#[test]
fn cmu86_labels_of_86_01() {
    let reader = build_ground_truth("cmu86_labels", &default_params()).unwrap();
    let s = reader.read(&data_path("cmu86/mocap.txt"), &AMC_86_01).unwrap();
    // mocap.txt, trial 86 01: b = 550 1150 1980 2500 3200 4065, length 4579.
    assert_eq!(s.frames(), vec![549, 1149, 1979, 2499, 3199, 4064]);
    let windows: Vec<_> = s.boundaries.iter().map(|b| b.window.unwrap()).collect();
    assert_eq!(
        windows,
        vec![(499, 599), (1099, 1199), (1929, 2029), (2449, 2549), (3149, 3249), (4014, 4114)]
    );
    let labels: Vec<&str> = s.segments.iter().map(|g| g.label.as_str()).collect();
    assert_eq!(labels, ["walk", "jump", "walk", "punch", "walk", "leg_kick", "punch"]);
    assert_eq!((s.segments[0].start, s.segments[6].end), (0, 4579));
    assert_eq!(s.transitions().len(), 6);
}

#[test]
fn cmu86_labels_every_trial_parses_and_windows_contain_their_boundary() {
    let p = data_path("cmu86/mocap.txt");
    let trials =
        motionlab_io::labels::cmu86::parse_cmu86_labels(&read_text(&p).unwrap(), &p).unwrap();
    assert_eq!(trials.len(), 14);
    let r = FrameRate::new(120.0).unwrap();
    for t in &trials {
        let length = t.lines.last().unwrap().b;
        let s = motionlab_io::labels::cmu86::trial_segmentation(t, &p, r, r, length).unwrap();
        assert_eq!(s.segments.len(), t.lines.len());
        for b in &s.boundaries {
            let (lo, hi) = b.window.unwrap();
            assert!(lo <= b.frame && b.frame <= hi, "{:?}: {b:?}", t.trial);
        }
    }
    // 86_05's jump is annotated "3881 3840 4000": the window is widened to include b.
    let t5 = trials.iter().find(|t| t.trial == (86, 5)).unwrap();
    let s = motionlab_io::labels::cmu86::trial_segmentation(t5, &p, r, r, 8340).unwrap();
    let b = s.boundaries.iter().find(|b| b.frame == 3839).unwrap();
    assert_eq!(b.window, Some((3839, 3999)));
}

#[test]
fn cmu86_labels_errors_name_what_is_wrong() {
    let p = data_path("cmu86/mocap.txt");
    let absent: toml::Value = toml::from_str("trial = \"86_15\"").unwrap();
    let e = build_ground_truth("cmu86_labels", &absent).unwrap().read(&p, &AMC_86_01).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::UnknownName);
    assert!(
        e.message().contains("86_15")
            && e.message().contains("86_01")
            && e.message().contains("86_14"),
        "{e}"
    );
    // Trial 86_02 runs to frame 10617, past the end of 86_01's 4579 frames.
    let other: toml::Value = toml::from_str("trial = \"86 02\"").unwrap();
    let e = build_ground_truth("cmu86_labels", &other).unwrap().read(&p, &AMC_86_01).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::OutOfRange);
    assert!(e.to_string().contains("mocap.txt:20:"), "{e}");
}

#[test]
fn mocap6_labels_of_the_three_shipped_sequences() {
    // Expected runs computed independently from truelabels/*.txt (block i → frames 12(i−1)…).
    let cases: [(&str, &[usize], &[&str]); 3] = [
        (
            "13_29",
            &[468, 1212, 1920, 2700, 3804],
            &["JumpJack", "Twist", "ArmCircle", "ToeTouchOneHand", "KneeRaise", "Squat"],
        ),
        ("13_30", &[216, 804, 1416, 1932], &["JumpJack", "Twist", "KneeRaise", "Squat", "Jog"]),
        (
            "13_31",
            &[396, 984, 1392, 1608, 2052, 2724],
            &["Twist", "KneeRaise", "ToeTouchOneHand", "Twist", "Jog", "ArmCircle", "JumpJack"],
        ),
    ];
    let reader = build_ground_truth("mocap6_labels", &default_params()).unwrap();
    for ((trial, bounds, labels), m) in cases.into_iter().zip(MOCAP6_MOTIONS.iter()) {
        let labels_file = data_path(&format!("mocap6/truelabels/{trial}.txt"));
        let s = reader.read(&labels_file, m).unwrap();
        assert_eq!(s.frames(), bounds, "{trial}");
        assert_eq!(
            s.segments.iter().map(|g| g.label.as_str()).collect::<Vec<_>>(),
            labels,
            "{trial}"
        );
        // ceil(F / 12) labels: the last block is partial and cut at the motion's end.
        let n_labels = read_text(&labels_file).unwrap().split_whitespace().count();
        assert_eq!(n_labels, m.n_frames().div_ceil(12), "{trial}");
        assert_ne!(m.n_frames() % 12, 0, "{trial}");
        assert_eq!(s.segments.last().unwrap().end, m.n_frames(), "{trial}");
        if trial == "13_29" {
            // A motion cut before the labels end is refused; a longer one leaves its tail
            // unlabelled (13_30's 206 labels on 13_29's 4592 frames end at 2472).
            let short = m.slice_frames(0, 4000).unwrap();
            let e = reader.read(&labels_file, &short).unwrap_err();
            assert_eq!(e.kind(), ErrorKind::OutOfRange, "{e}");
            assert!(e.to_string().contains("13_29.txt:1:"), "{e}");
            let s = reader.read(&data_path("mocap6/truelabels/13_30.txt"), m).unwrap();
            assert_eq!(s.segments.last().unwrap().end, 2472);
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Registry
// ---------------------------------------------------------------------------------------------

#[test]
fn plugins_are_registered_documented_and_valid() {
    for (name, ext) in [
        ("bvh", Some("bvh")),
        ("asf_amc", Some("amc")),
        ("cmu86_labels", None),
        ("mocap6_labels", None),
    ] {
        let p = find(name).unwrap();
        assert!(p.doc().contains("Missing samples"), "{name}: {}", p.doc());
        if let Some(ext) = ext {
            assert_eq!(build_loader(name, &default_params()).unwrap().extensions(), [ext]);
        }
    }
    let problems: Vec<String> = motionlab_core::registry::check_registry()
        .into_iter()
        .filter(|p| {
            ["bvh", "asf_amc", "cmu86_labels", "mocap6_labels"]
                .iter()
                .any(|n| p.contains(&format!("\"{n}\"")))
        })
        .collect();
    assert!(problems.is_empty(), "{problems:?}");
    let describe: Vec<String> =
        find("bvh").unwrap().params().iter().map(|p| p.name.to_string()).collect();
    assert_eq!(describe, ["length_unit", "up_axis", "position_channels"]);
}
