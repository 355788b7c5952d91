//! Reader conformance on real files other software wrote (`tests/fixtures/conformance/`, see
//! its SOURCE.txt): one test per file. Each loads with positions equal, to 1e-9 relative, to
//! the reader that reads it right — ezc3d where it does, else the raw reading or py-c3d (C3D),
//! a NumPy forward kinematics with position channels replacing the OFFSET (BVH) — through the
//! per-point checksums `bench/conformance_crosscheck.py reference` wrote into
//! `reference.json`; or, where no reader can, refuses it with one clear error. Each repair the
//! lenient reading makes is asserted, and that `strict = true` refuses it.
//!
//! Also: every shipped C3D reads strictly (nothing repaired), and every shipped BVH gives the
//! same positions bit for bit whether position channels replace or add to the OFFSET.

use std::path::PathBuf;
use std::sync::LazyLock;

use motionlab_core::registry::{build_loader, default_params};
use motionlab_core::{Axis, ErrorKind, LengthUnit, Motion};
use motionlab_io::bvh::{BvhOptions, PositionChannels, parse_bvh};
use motionlab_io::c3d::{C3dOptions, parse_c3d};
use motionlab_io::read::{read_bytes, read_text};
use motionlab_testkit::{data_path, repo_root};
use serde_json::Value;

fn fixture(kind: &str, name: &str) -> PathBuf {
    repo_root().join("tests/fixtures/conformance").join(kind).join(name)
}

static REFERENCE: LazyLock<Value> = LazyLock::new(|| {
    let text =
        std::fs::read_to_string(repo_root().join("tests/fixtures/conformance/reference.json"))
            .unwrap();
    serde_json::from_str(&text).unwrap()
});

fn reference(kind: &str, name: &str) -> &'static Value {
    &REFERENCE[kind][name]
}

fn load_c3d(name: &str) -> Motion {
    let path = fixture("c3d", name);
    build_loader("c3d", &default_params()).unwrap().load(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// The error of a strict reading; it names the file.
fn strict_c3d_error(name: &str) -> motionlab_core::Error {
    let path = fixture("c3d", name);
    let strict = C3dOptions { strict: true, ..C3dOptions::default() };
    let e = parse_c3d(&read_bytes(&path).unwrap(), &path, &strict)
        .err()
        .unwrap_or_else(|| panic!("{name}: strict reading loaded"));
    assert!(e.to_string().contains(name) && !e.to_string().contains('\n'), "{e}");
    e
}

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"))
}

/// `a` within 1e-9 of `b`, relative to `scale` (the sum of magnitudes `b` was summed from).
fn assert_close(a: f64, b: f64, scale: f64, what: &str) {
    assert!((a - b).abs() <= 1e-9 * scale.max(1e-300), "{what}: {a} vs {b} (scale {scale})");
}

/// Compares a motion's positions (mm) with the reference's checksums, whose positions are in
/// file units of `mm_per_unit` mm. Returns how many samples the checksums cover.
fn assert_matches_reference(m: &Motion, r: &Value, mm_per_unit: f64) -> usize {
    let (n, points) = (m.n_frames(), m.n_points());
    assert_eq!(
        (n as u64, points as u64),
        (r["n_frames"].as_u64().unwrap(), r["n_points"].as_u64().unwrap())
    );
    let mut covered = 0;
    for p in 0..points {
        let what = |s: &str| format!("{} point {p} ({}) {s}", m.name, m.point_names()[p]);
        let valid: Vec<usize> = (0..n).filter(|&k| !m.is_missing(k, p)).collect();
        assert_eq!(
            valid.len() as u64,
            r["valid"][p].as_u64().unwrap(),
            "{}",
            what("valid samples")
        );
        let missing_sum: u64 = (0..n).filter(|&k| m.is_missing(k, p)).map(|k| k as u64).sum();
        assert_eq!(
            missing_sum,
            r["missing_frame_sum"][p].as_u64().unwrap(),
            "{}",
            what("missing frames")
        );
        covered += valid.len();
        for axis in 0..3 {
            let c = |k: usize| m.position(k, p)[axis] / mm_per_unit;
            let sum: f64 = valid.iter().map(|&k| c(k)).sum();
            let abs: f64 = valid.iter().map(|&k| c(k).abs()).sum();
            let weighted: f64 = valid.iter().map(|&k| (k + 1) as f64 * c(k)).sum();
            let square: f64 = valid.iter().map(|&k| c(k) * c(k)).sum();
            assert_close(abs, f(&r["abs_sum"][p][axis]), abs, &what("sum of |x|"));
            assert_close(sum, f(&r["sum"][p][axis]), abs, &what("sum"));
            assert_close(
                weighted,
                f(&r["weighted_sum"][p][axis]),
                abs * n as f64,
                &what("frame-weighted sum"),
            );
            assert_close(square, f(&r["square_sum"][p][axis]), square, &what("sum of squares"));
        }
    }
    for (frame, row) in r["frames"].as_object().unwrap() {
        let k: usize = frame.parse().unwrap();
        for (p, point) in row.as_array().unwrap().iter().enumerate() {
            match point.as_array() {
                None => {
                    assert!(m.is_missing(k, p), "{} frame {k} point {p} should be missing", m.name)
                }
                Some(xyz) => {
                    let ours = m.position(k, p);
                    for axis in 0..3 {
                        let want = f(&xyz[axis]);
                        assert_close(
                            ours[axis] / mm_per_unit,
                            want,
                            want.abs(),
                            &format!("{} frame {k} point {p}", m.name),
                        );
                    }
                }
            }
        }
    }
    covered
}

/// Every coordinate's bits, for bit-for-bit comparisons (NaN included).
fn bits(m: &Motion) -> Vec<u64> {
    m.positions().iter().flat_map(|p| p.map(f64::to_bits)).collect()
}

/// The reference's labels, blank ones as `P<n>` (the loader's documented naming).
fn reference_names(r: &Value) -> Vec<String> {
    r["labels"]
        .as_array()
        .unwrap()
        .iter()
        .enumerate()
        .map(|(i, l)| match l.as_str().unwrap() {
            "" => format!("P{}", i + 1),
            s => s.to_string(),
        })
        .collect()
}

/// A C3D fixture that loads: positions equal to its reference, names and rate as it has them.
fn c3d_matches_reference(name: &str) -> Motion {
    let m = load_c3d(name);
    let r = reference("c3d", name);
    let covered = assert_matches_reference(&m, r, 1.0);
    assert!(covered > 0, "{name}");
    assert_eq!(m.frame_rate().hz(), f(&r["rate_hz"]), "{name}");
    m
}

#[test]
fn processor_type_0_is_refused_as_every_reader_refuses_it() {
    assert!(reference("c3d", "examples_simple.c3d")["reference"].is_null());
    let path = fixture("c3d", "examples_simple.c3d");
    let e = build_loader("c3d", &default_params()).unwrap().load(&path).unwrap_err();
    assert_eq!(
        (e.kind(), e.location().byte_offset, e.location().field.as_deref()),
        (ErrorKind::Syntax, Some(515), Some("parameters.processor"))
    );
    assert!(
        e.to_string().contains("examples_simple.c3d (byte 515)")
            && e.to_string().contains("processor type is 0 (never set"),
        "{e}"
    );
}

#[test]
fn motion_analysis_walk1_repeated_labels_are_made_unique() {
    let name = "sample_00_Motion_Analysis_Corporation_Walk1.c3d";
    let m = c3d_matches_reference(name);
    let theirs = reference_names(reference("c3d", name));
    assert_eq!((theirs[14].as_str(), theirs[25].as_str()), ("RKNE", "RKNE"));
    assert_eq!((m.point_names()[14].as_str(), m.point_names()[25].as_str()), ("RKNE", "RKNE#2"));
    assert_eq!(
        (m.point_names()[29].as_str(), m.point_names()[41].as_str(), m.point_names()[42].as_str()),
        ("VMID", "VMID#2", "VMID#3")
    );
    // Every other name is as written.
    for (ours, written) in m.point_names().iter().zip(&theirs) {
        assert!(ours == written || ours.starts_with(&format!("{written}#")), "{ours} vs {written}");
    }
    assert_eq!(m.load_notes.repairs.len(), 1);
    assert!(
        m.load_notes.repairs[0].starts_with(
            r#"duplicate point labels made unique: "RKNE" (points 15, 26) → RKNE, RKNE#2; "#
        ),
        "{:?}",
        m.load_notes
    );
    assert_eq!(strict_c3d_error(name).kind(), ErrorKind::DuplicateName);
}

#[test]
fn pc_int_reads_as_ezc3d_with_nothing_repaired() {
    let m = c3d_matches_reference("sample_02_pc_int.c3d");
    assert_eq!(m.point_names(), reference_names(reference("c3d", "sample_02_pc_int.c3d")));
    assert!(m.load_notes.repairs.is_empty(), "{:?}", m.load_notes);
    assert_eq!(m.load_notes.length_unit, Some(LengthUnit::Millimetre));
}

/// The SGI versions hold pc_int's recording: the integer one bit for bit, the float one within
/// one step of the integer files' storage (POINT:SCALE 0.2812 mm).
#[test]
fn sgi_int_reads_like_pc_int_bit_for_bit() {
    let name = "sample_02_sgi_int.c3d";
    let m = c3d_matches_reference(name);
    let pc = load_c3d("sample_02_pc_int.c3d");
    assert_eq!(m.point_names(), pc.point_names());
    assert_eq!(m.missing_mask(), pc.missing_mask());
    assert_eq!(bits(&m), bits(&pc));
    assert_eq!(m.load_notes.repairs.len(), 1);
    assert!(m.load_notes.repairs[0].contains("LABELS's offset to the next record (16129) points to byte 21558, past the parameter section's end at byte 6144"), "{:?}", m.load_notes);
    let e = strict_c3d_error(name);
    assert_eq!((e.kind(), e.location().byte_offset), (ErrorKind::Syntax, Some(21558 - 16129)));
}

#[test]
fn sgi_real_reads_like_pc_int_within_one_integer_step() {
    let name = "sample_02_sgi_real.c3d";
    let m = c3d_matches_reference(name);
    let pc = load_c3d("sample_02_pc_int.c3d");
    assert_eq!(m.missing_mask(), pc.missing_mask());
    let step = 0.281_181_87;
    let mut worst = 0.0f64;
    for (a, b) in m.positions().iter().zip(pc.positions()).filter(|(a, _)| !a[0].is_nan()) {
        for k in 0..3 {
            worst = worst.max((a[k] - b[k]).abs());
        }
    }
    assert!(worst > 0.0 && worst <= step * 1.0001, "largest difference {worst} mm");
    assert_eq!(m.load_notes.repairs.len(), 1, "{:?}", m.load_notes);
    assert_eq!(strict_c3d_error(name).kind(), ErrorKind::Syntax);
}

#[test]
fn a_parameter_name_with_a_space_is_read() {
    let name = "sample_11_2198928.c3d";
    let m = c3d_matches_reference(name);
    assert_eq!(m.point_names(), reference_names(reference("c3d", name)));
    assert_eq!(
        m.load_notes.repairs,
        [r#"group or parameter names with spaces accepted: "Splines Fitted""#]
    );
    let e = strict_c3d_error(name);
    assert_eq!((e.kind(), e.location().byte_offset), (ErrorKind::Syntax, Some(20003)));
    assert!(e.message().contains(r#""Splines Fitted" has a space"#), "{e}");
}

/// The header is right here (17 analog samples per frame) and ezc3d, which reads 16, is not.
#[test]
fn evart_reads_with_the_header_stride() {
    let name = "sample_11_evart.c3d";
    assert_eq!(reference("c3d", name)["reference"], "raw");
    let m = c3d_matches_reference(name);
    assert_eq!(m.point_names(), reference_names(reference("c3d", name)));
    assert_eq!(
        m.load_notes.repairs,
        [
            "ANALOG:RATE 1000 Hz is not a whole multiple of POINT:RATE 60 Hz, so the parameters give no analog word count; the header's 476 words per frame are used"
        ]
    );
    assert_eq!(strict_c3d_error(name).location().field.as_deref(), Some("ANALOG:RATE"));
}

#[test]
fn a_unit_string_cut_short_is_read_as_its_unit() {
    let name = "sample_15_FP1.C3D";
    let m = c3d_matches_reference(name);
    assert_eq!(m.load_notes.length_unit, Some(LengthUnit::Metre));
    assert_eq!(
        m.load_notes.repairs,
        [r#"POINT:UNITS "mete" read as "meter" (a unit name cut short)"#]
    );
    // Metres: the markers span about a metre.
    assert!(
        (500.0..3000.0).contains(&(m.frame(0).iter().map(|p| p[2]).fold(f64::MIN, f64::max))),
        "{:?}",
        m.frame(0)
    );
    assert_eq!(
        (strict_c3d_error(name).kind(), strict_c3d_error(name).location().field.as_deref()),
        (ErrorKind::OutOfRange, Some("POINT:UNITS"))
    );
}

#[test]
fn a_file_without_parameters_is_read_by_its_header_with_numbered_points() {
    let name = "sample_20_phasespace_sample.c3d";
    let m = c3d_matches_reference(name);
    assert_eq!(m.n_points(), 40);
    assert_eq!(m.point_names().first().map(String::as_str), Some("P1"));
    assert_eq!(m.point_names().last().map(String::as_str), Some("P40"));
    assert_eq!(m.frame_rate().hz(), 30.0);
    assert_eq!(m.load_notes.repairs, ["no POINT:LABELS: the 40 points are named P1…P40"]);
    assert_eq!(strict_c3d_error(name).kind(), ErrorKind::MissingKey);
}

/// The silent wrong-number case: trusting the header's 16 analog words read 194,560 of the
/// file's 517,120 bytes, 36 % of the samples missing and coordinates up to 128 m.
#[test]
fn motion_monitor_reads_every_sample_with_the_parameters_stride() {
    let name = "sample_24_MotionMonitorC3D.c3d";
    let m = c3d_matches_reference(name);
    assert_eq!(m.missing_count(), 0);
    let largest = m.positions().iter().flatten().fold(0.0f64, |a, c| a.max(c.abs()));
    assert!(largest < 2000.0, "{largest} mm");
    assert_eq!(
        m.load_notes.repairs,
        [
            "the header says 16 analog words per frame but ANALOG:USED 16 × 7 samples = 112: the parameters' account fits the file (517120 bytes) and is used"
        ]
    );
    assert_eq!(m.point_names()[0], "P1");
    assert_eq!(strict_c3d_error(name).location().field.as_deref(), Some("ANALOG:USED"));
}

/// POINT:USED says 12, the header 11; the header's frames fill the file (ezc3d reads 12 points
/// and 145 frames, cutting the recording short).
#[test]
fn kyowadengyo_point_count_is_resolved_by_the_file_size() {
    let name = "sample_27_kyowadengyo.c3d";
    let m = c3d_matches_reference(name);
    assert_eq!((m.n_points(), m.n_frames()), (11, 152));
    assert_eq!(m.point_names(), reference_names(reference("c3d", name)));
    assert_eq!(
        m.load_notes.repairs,
        [
            "POINT:USED is 12 but the header says 11 points per frame: the header's account fits the file (31232 bytes) and is used"
        ]
    );
    assert_eq!(strict_c3d_error(name).location().field.as_deref(), Some("POINT:USED"));
}

/// ANALOG:USED 6 without ANALOG:RATE: the header's 6 words per frame stand (ezc3d drops them
/// and reads every frame short). py-c3d reads it as motionlab does.
#[test]
fn type1_reads_with_the_header_stride_as_py_c3d_does() {
    let name = "sample_28_type1.C3D";
    assert_eq!(reference("c3d", name)["reference"], "pyc3d");
    let m = c3d_matches_reference(name);
    assert_eq!(m.point_names(), reference_names(reference("c3d", name)));
    assert!(m.load_notes.repairs.is_empty(), "{:?}", m.load_notes);
}

#[test]
fn parameters_defined_twice_keep_the_first() {
    let name = "sample_33_bigparlove.c3d";
    let m = c3d_matches_reference(name);
    assert_eq!(m.point_names(), reference_names(reference("c3d", name)));
    assert_eq!(m.load_notes.repairs.len(), 1);
    assert!(m.load_notes.repairs[0].starts_with("2764 parameters defined twice, the first definition of each kept: PROCESSING:MARKERDIAMETER"), "{:?}", m.load_notes);
    let e = strict_c3d_error(name);
    assert_eq!(
        (e.kind(), e.location().field.as_deref()),
        (ErrorKind::DuplicateName, Some("PROCESSING:MARKERDIAMETER"))
    );
}

/// The PyMO walk: a root OFFSET of (11.3, 35.4, −54.3) inches under its position channels.
/// Replacing the OFFSET stands the figure on the floor, as Blender and bvhio show it; adding
/// both floats it 0.9 m up.
#[test]
fn pymo_walk_position_channels_replace_the_offset() {
    let name = "pymo_AV_8Walk_Meredith_HVHA_Rep1.bvh";
    let path = fixture("bvh", name);
    let m = build_loader("bvh", &default_params()).unwrap().load(&path).unwrap();
    assert_eq!(m.load_notes.length_unit, Some(LengthUnit::Inch));
    assert_eq!(
        m.load_notes.length_unit_from,
        "inferred from the rest pose: 60.5578 units tall along y"
    );
    let covered = assert_matches_reference(&m, reference("bvh", name), 25.4);
    assert_eq!(covered, 1064 * 30);
    let lowest = |m: &Motion| m.positions().iter().map(|p| p[1]).fold(f64::INFINITY, f64::min);
    assert!(lowest(&m).abs() < 10.0, "feet {} mm from the floor", lowest(&m));
    let add = parse_bvh(
        &read_text(&path).unwrap(),
        &path,
        &BvhOptions { position_channels: PositionChannels::Add, ..BvhOptions::default() },
    )
    .unwrap();
    assert!((lowest(&add) - 35.419 * 25.4).abs() < 10.0, "{}", lowest(&add));
}

#[test]
fn every_shipped_bvh_reads_the_same_under_both_position_conventions() {
    let files: Vec<PathBuf> = ["131_01", "131_02", "131_03"]
        .iter()
        .map(|t| data_path(&format!("cmu131/{t}.bvh.gz")))
        .collect();
    for path in &files {
        let text = read_text(path).unwrap();
        let replace = parse_bvh(&text, path, &BvhOptions::default()).unwrap();
        let add = parse_bvh(
            &text,
            path,
            &BvhOptions { position_channels: PositionChannels::Add, ..BvhOptions::default() },
        )
        .unwrap();
        // Only the root has position channels, and its OFFSET is zero: nothing to replace.
        let sk = &add.skeleton.as_ref().unwrap().skeleton;
        let translated: Vec<&str> = sk
            .joints
            .iter()
            .filter(|j| {
                j.channels.iter().any(|c| matches!(c, motionlab_core::ChannelKind::Translation(_)))
            })
            .map(|j| j.name.as_str())
            .collect();
        assert_eq!(translated, ["Hips"], "{}", path.display());
        assert_eq!(sk.joints[0].offset, [0.0; 3], "{}", path.display());
        assert_eq!(bits(&replace), bits(&add), "{}", path.display());
        let (r, a) = (replace.skeleton.as_ref().unwrap(), add.skeleton.as_ref().unwrap());
        assert_eq!((&r.skeleton, r.channel_values()), (&a.skeleton, a.channel_values()));
        assert_eq!(replace.load_notes.length_unit, Some(LengthUnit::CmuUnit));
    }
}

#[test]
fn every_shipped_c3d_reads_strictly_with_nothing_repaired() {
    let mut files: Vec<PathBuf> = ["dance1", "dance2", "walk1", "walk2"]
        .iter()
        .map(|n| data_path(&format!("mct/{n}.c3d.gz")))
        .collect();
    for subject in std::fs::read_dir(data_path("schreiber2019")).unwrap() {
        if let Ok(entries) = std::fs::read_dir(subject.unwrap().path().join("dynamic")) {
            files.extend(entries.map(|e| e.unwrap().path()));
        }
    }
    assert_eq!(files.len(), 40);
    let strict = C3dOptions { strict: true, ..C3dOptions::default() };
    for path in &files {
        let bytes = read_bytes(path).unwrap();
        let lenient = parse_c3d(&bytes, path, &C3dOptions::default()).unwrap();
        assert!(
            lenient.load_notes.repairs.is_empty(),
            "{}: {:?}",
            path.display(),
            lenient.load_notes
        );
        let m = parse_c3d(&bytes, path, &strict).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(m.positions().len(), lenient.positions().len());
        assert_eq!(
            (m.up_axis(), m.load_notes.length_unit),
            (Axis::Z, Some(LengthUnit::Millimetre))
        );
    }
}

#[test]
fn fixtures_are_the_corpus_byte_for_byte_with_licences_and_source() {
    let dir = repo_root().join("tests/fixtures/conformance");
    let source = std::fs::read_to_string(dir.join("SOURCE.txt")).unwrap();
    let mut n = 0;
    for kind in ["c3d", "bvh"] {
        for e in std::fs::read_dir(dir.join(kind)).unwrap() {
            let name = e.unwrap().file_name().to_string_lossy().into_owned();
            if name.starts_with("LICENSE") {
                continue;
            }
            // Listed in SOURCE.txt with its SHA-256, and a test of this file names it.
            let bytes = std::fs::read(dir.join(kind).join(&name)).unwrap();
            let line = source
                .lines()
                .find(|l| l.contains(&format!("{kind}/{name}")))
                .unwrap_or_else(|| panic!("{name} not in SOURCE.txt"));
            assert!(
                line.contains(&motionlab_cache::hex(&motionlab_cache::sha256(&bytes))),
                "{name}: {line}"
            );
            assert!(
                include_str!("conformance.rs").contains(&format!("\"{name}\"")),
                "no test names {name}"
            );
            n += 1;
        }
        assert!(
            dir.join(kind).read_dir().unwrap().any(|e| e
                .unwrap()
                .file_name()
                .to_string_lossy()
                .starts_with("LICENSE")),
            "{kind}: no licence"
        );
    }
    assert_eq!(n, 14);
}
