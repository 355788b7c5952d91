//! The malformed-input corpus: `tests/fixtures/malformed/`, generated from the real
//! files in `data/` by `make.py` beside them (plus a few hand-written older cases).
//!
//! Every defect asserts the exact [`ErrorKind`] and that the error names the file and the line
//! (text formats), the byte offset (C3D) or the key path (experiment TOML) — both in
//! [`Location`](motionlab_core::Location) and in the one-line message the user sees. Quirks
//! that are valid by design (one frame, CRLF, a BOM, a zero-length offset, a marker missing in
//! every frame, events outside the frames) assert the documented behaviour instead, mostly by
//! equality with the plain variant of the same file or with an independent reader.
//!
//! Loaders and ground-truth readers are built through the plugin registry (as an experiment
//! builds them); experiments go through `motionlab_engine::plan`.

use std::path::{Path, PathBuf};

use motionlab_core::registry;
use motionlab_core::{Error, ErrorKind, Motion, Result};

// Link the plugin crates so the registry holds their loaders and readers.
use motionlab_eval as _;
use motionlab_features as _;
use motionlab_gait as _;
use motionlab_io as _;
use motionlab_match as _;
use motionlab_segment as _;
use motionlab_workflows as _;

fn fixture(name: &str) -> PathBuf {
    motionlab_testkit::repo_root().join("tests/fixtures/malformed").join(name)
}

/// Loads a fixture with a loader plugin at its default parameters.
fn load(loader: &str, name: &str) -> Result<Motion> {
    let empty = toml::Value::Table(toml::Table::new());
    registry::build_loader(loader, &empty).expect("loader builds").load(&fixture(name))
}

/// Loads a fixture with a loader plugin at the parameters of a TOML table.
fn load_with(loader: &str, params: &str, name: &str) -> Result<Motion> {
    let params: toml::Value = toml::from_str(params).expect("parameters parse");
    registry::build_loader(loader, &params).expect("loader builds").load(&fixture(name))
}

fn load_ok(loader: &str, name: &str) -> Motion {
    load(loader, name).unwrap_or_else(|e| panic!("{name} should load: {e}"))
}

/// Where an error must point.
#[derive(Debug)]
enum At<'a> {
    Line(usize),
    Byte(u64),
    Field(&'a str),
    LineField(usize, &'a str),
    ByteField(u64, &'a str),
}

/// Asserts kind, file and place of an error, in its location and in its message.
fn assert_error<T>(
    result: Result<T>,
    file: &str,
    kind: ErrorKind,
    at: At<'_>,
    says: &str,
) -> Error {
    let e = match result {
        Ok(_) => panic!("{file}: loaded, expected a {kind:?} error"),
        Err(e) => e,
    };
    let text = e.to_string();
    assert_eq!(e.kind(), kind, "{file}: {text}");
    assert!(!text.contains('\n'), "{file}: multi-line message {text:?}");
    let loc = e.location();
    assert_eq!(
        loc.file.as_deref().and_then(Path::file_name).and_then(|f| f.to_str()),
        Some(file),
        "{text}"
    );
    assert!(text.contains(file), "message does not name {file}: {text}");
    let (line, byte, field) = match at {
        At::Line(l) => (Some(l), None, None),
        At::Byte(b) => (None, Some(b), None),
        At::Field(f) => (None, None, Some(f)),
        At::LineField(l, f) => (Some(l), None, Some(f)),
        At::ByteField(b, f) => (None, Some(b), Some(f)),
    };
    if let Some(l) = line {
        assert_eq!(loc.line, Some(l), "{text}");
        assert!(text.contains(&format!("{file}:{l}")), "message does not name line {l}: {text}");
    }
    if let Some(b) = byte {
        assert_eq!(loc.byte_offset, Some(b), "{text}");
        assert!(text.contains(&format!("(byte {b})")), "message does not name byte {b}: {text}");
    }
    if let Some(f) = field {
        assert_eq!(loc.field.as_deref(), Some(f), "{text}");
        assert!(text.contains(f), "message does not name field {f}: {text}");
    }
    assert!(text.contains(says), "expected {says:?} in: {text}");
    e
}

/// Every position of two motions equal within `tol` mm, missing where the other is missing.
fn assert_same_positions(a: &Motion, b: &Motion, tol: f64, what: &str) {
    assert_eq!((a.n_frames(), a.n_points()), (b.n_frames(), b.n_points()), "{what}");
    assert_eq!(a.point_names(), b.point_names(), "{what}");
    assert_eq!(a.missing_mask(), b.missing_mask(), "{what}");
    for (k, (p, q)) in a.positions().iter().zip(b.positions()).enumerate() {
        if a.missing_mask()[k] {
            continue;
        }
        for c in 0..3 {
            assert!(
                (p[c] - q[c]).abs() <= tol,
                "{what}: sample {k} axis {c}: {} vs {}",
                p[c],
                q[c]
            );
        }
    }
}

// ---------------------------------------------------------------------------------------------
// BVH (131_01 cut to 8 frames: `Frames:` on line 186, `Frame Time:` 187, frames 188–195)
// ---------------------------------------------------------------------------------------------

#[test]
fn bvh_defects_name_kind_and_line() {
    let cases: &[(&str, ErrorKind, usize, &str)] = &[
        ("bvh_empty.bvh", ErrorKind::Truncated, 1, "empty file"),
        (
            "bvh_header_only.bvh",
            ErrorKind::Truncated,
            188,
            "file ends after 0 frame lines; MOTION declares Frames: 8",
        ),
        ("bvh_zero_frames.bvh", ErrorKind::EmptySequence, 186, "Frames: 0"),
        ("bvh_nan.bvh", ErrorKind::NonFinite, 190, "frame 3: value 5 is \"nan\""),
        ("bvh_inf.bvh", ErrorKind::NonFinite, 189, "frame 2: value 1 is \"inf\""),
        ("bvh_neg_inf.bvh", ErrorKind::NonFinite, 195, "frame 8: value 96 is \"-inf\""),
        ("bvh_frame_time_zero.bvh", ErrorKind::OutOfRange, 187, "Frame Time is 0"),
        (
            "bvh_duplicate_joint.bvh",
            ErrorKind::DuplicateName,
            39,
            "joint \"LeftHip\" is already declared at line 10",
        ),
        (
            "bvh_duplicate_channel.bvh",
            ErrorKind::DuplicateName,
            9,
            "channel Zrotation is listed twice",
        ),
        ("bvh_non_utf8.bvh", ErrorKind::Syntax, 191, "invalid UTF-8"),
        (
            "bvh_long_line.bvh",
            ErrorKind::WrongValueCount,
            192,
            "frame 5: found 30096 values, expected 96",
        ),
        // Older hand-written cases (also run through the CLI in tests/cli.rs).
        ("truncated.bvh", ErrorKind::Truncated, 198, "Frames: 994"),
        ("wrong_value_count.bvh", ErrorKind::WrongValueCount, 191, "found 95 values, expected 96"),
        ("cut_in_hierarchy.bvh", ErrorKind::Truncated, 41, "RightHip"),
    ];
    for (file, kind, line, says) in cases {
        assert_error(load("bvh", file), file, *kind, At::Line(*line), says);
    }
}

#[test]
fn bvh_line_endings_and_bom_load_identically() {
    let lf = load_ok("bvh", "bvh_lf.bvh");
    assert_eq!((lf.n_frames(), lf.n_points()), (8, 38));
    for other in ["bvh_crlf.bvh", "bvh_bom.bvh"] {
        assert_same_positions(&load_ok("bvh", other), &lf, 0.0, other);
    }
    // One frame: the first frame of the 8.
    let one = load_ok("bvh", "bvh_one_frame.bvh");
    assert_eq!(one.n_frames(), 1);
    assert_eq!(one.frame(0), lf.frame(0));
}

#[test]
fn bvh_zero_length_offset_puts_the_joint_on_its_parent() {
    let lf = load_ok("bvh", "bvh_lf.bvh");
    let same_place = |m: &Motion, joint: &str, parent: &str| {
        let (j, p) = (m.point_index(joint).unwrap(), m.point_index(parent).unwrap());
        (0..m.n_frames()).all(|f| m.position(f, j) == m.position(f, p))
    };
    // The real file already has zero-length offsets (LHipJoint on Hips, LThumb on lhand).
    assert!(same_place(&lf, "LHipJoint", "Hips") && same_place(&lf, "LThumb", "lhand"));
    // LeftToe's offset zeroed: it moves onto LeftAnkle, where it was a bone length away.
    let m = load_ok("bvh", "bvh_zero_offset.bvh");
    assert!(same_place(&m, "LeftToe", "LeftAnkle"));
    assert!(!same_place(&lf, "LeftToe", "LeftAnkle"));
    // Every point outside the toe's subtree is unchanged.
    for (k, name) in m.point_names().iter().enumerate() {
        if !["LeftToe", "LeftToe_end"].contains(&name.as_str()) {
            assert!((0..8).all(|f| m.position(f, k) == lf.position(f, k)), "{name}");
        }
    }
}

// ---------------------------------------------------------------------------------------------
// ASF / AMC (86_01 cut to 4 frames; frame k's number line is 4 + 30·(k − 1))
// ---------------------------------------------------------------------------------------------

fn parse_asf_fixture(name: &str) -> Result<motionlab_io::asf_amc::AsfSkeleton> {
    let path = fixture(name);
    let text = motionlab_io::read::read_text(&path)?;
    motionlab_io::asf_amc::parse_asf(&text, &path)
}

/// 1-based line of the `n`-th (1-based) line of `file` that contains `needle`.
fn line_containing(file: &str, needle: &str, n: usize) -> usize {
    let text = std::fs::read_to_string(fixture(file)).unwrap();
    text.lines()
        .enumerate()
        .filter(|(_, l)| l.contains(needle))
        .nth(n - 1)
        .map(|(i, _)| i + 1)
        .unwrap()
}

#[test]
fn asf_defects_name_kind_and_line() {
    let dup_line = line_containing("asf_duplicate_bone.asf", "name rfemur", 2);
    assert_error(
        parse_asf_fixture("asf_duplicate_bone.asf"),
        "asf_duplicate_bone.asf",
        ErrorKind::DuplicateName,
        At::Line(dup_line),
        "rfemur",
    );
    let len_line = line_containing("asf_negative_length.asf", "length -0.45", 1);
    assert_error(
        parse_asf_fixture("asf_negative_length.asf"),
        "asf_negative_length.asf",
        ErrorKind::OutOfRange,
        At::Line(len_line),
        ":units length is -0.45; expected > 0",
    );
    assert_error(
        parse_asf_fixture("asf_empty.asf"),
        "asf_empty.asf",
        ErrorKind::Syntax,
        At::Line(1),
        "no :root section",
    );
    // The fixtures' 86.asf is the shipped one with LF line ends: the same skeleton.
    let lf = parse_asf_fixture("86.asf").unwrap();
    let crlf = motionlab_io::asf_amc::parse_asf(
        &motionlab_io::read::read_text(&motionlab_testkit::data_path("cmu86/86.asf")).unwrap(),
        Path::new("86.asf"),
    )
    .unwrap();
    assert_eq!(lf.skeleton, crlf.skeleton);
}

#[test]
fn amc_defects_name_kind_and_line() {
    let cases: &[(&str, ErrorKind, usize, &str)] = &[
        ("86_header_only.amc", ErrorKind::EmptySequence, 4, "no frames"),
        ("86_nan.amc", ErrorKind::NonFinite, 35, "\"NaN\""),
        ("86_missing_bone.amc", ErrorKind::WrongValueCount, 64, "lfemur"),
        ("86_duplicate_bone.amc", ErrorKind::DuplicateName, 64, "rtibia"),
        ("86_frame_gap.amc", ErrorKind::Syntax, 64, "4"),
        ("86_unknown_bone.amc", ErrorKind::UnknownName, 60, "\"lfemurx\""),
    ];
    for (file, kind, line, says) in cases {
        assert_error(load("asf_amc", file), file, *kind, At::Line(*line), says);
    }
}

#[test]
fn amc_line_endings_and_one_frame_load_identically() {
    let lf = load_ok("asf_amc", "86_lf.amc");
    assert_eq!(lf.n_frames(), 4);
    assert_same_positions(&load_ok("asf_amc", "86_crlf.amc"), &lf, 0.0, "86_crlf.amc");
    let one = load_ok("asf_amc", "86_one_frame.amc");
    assert_eq!(one.n_frames(), 1);
    assert_eq!(one.frame(0), lf.frame(0));
    // The same 4 frames as the shipped CRLF file.
    let real = registry::build_loader("asf_amc", &toml::Value::Table(toml::Table::new()))
        .unwrap()
        .load(&motionlab_testkit::data_path("cmu86/86_01.amc.gz"))
        .unwrap()
        .slice_frames(0, 4)
        .unwrap();
    assert_same_positions(&lf, &real, 0.0, "86_lf.amc vs data/cmu86/86_01.amc.gz");
}

// ---------------------------------------------------------------------------------------------
// C3D (walk1.c3d cut to 10 frames: 28 markers, float storage, data from byte 3072)
// ---------------------------------------------------------------------------------------------

const C3D_DATA_START: u64 = 3072;
const C3D_FRAME_BYTES: u64 = 28 * 16;

#[test]
fn c3d_defects_name_kind_byte_offset_and_parameter() {
    assert_error(
        load("c3d", "c3d_empty.c3d"),
        "c3d_empty.c3d",
        ErrorKind::Truncated,
        At::Byte(0),
        "file is 0 bytes",
    );
    assert_error(
        load("c3d", "c3d_header_only.c3d"),
        "c3d_header_only.c3d",
        ErrorKind::OutOfRange,
        At::ByteField(0, "header.parameter_block"),
        "parameter block pointer is 2, but the file is 512 bytes and ends after its header block",
    );
    assert_error(
        load("c3d", "c3d_zero_frames.c3d"),
        "c3d_zero_frames.c3d",
        ErrorKind::EmptySequence,
        At::Field("TRIAL:ACTUAL_END_FIELD"),
        "no frames",
    );
    assert_error(
        load("c3d", "c3d_truncated.c3d"),
        "c3d_truncated.c3d",
        ErrorKind::Truncated,
        At::Byte(C3D_DATA_START + 9 * C3D_FRAME_BYTES),
        "inside frame 10 of 10",
    );
    // The integer file with its scale factor made negative reads as floats: twice the bytes.
    assert_error(
        load("c3d", "c3d_negative_scale.c3d"),
        "c3d_negative_scale.c3d",
        ErrorKind::Truncated,
        At::Byte(C3D_DATA_START + 5 * C3D_FRAME_BYTES),
        "frames",
    );
    assert_error(
        load("c3d", "c3d_zero_scale.c3d"),
        "c3d_zero_scale.c3d",
        ErrorKind::OutOfRange,
        At::Field("POINT:SCALE"),
        "point scale factor is 0",
    );
    // A repeated label is read (renamed, below) unless the reading is strict.
    assert_error(
        load_with("c3d", "strict = true", "c3d_duplicate_label.c3d"),
        "c3d_duplicate_label.c3d",
        ErrorKind::DuplicateName,
        At::Field("POINT:LABELS"),
        "names points 1 and 2",
    );
    // POINT:USED 29 against the header's 28, and 600 bytes more than the header's frames:
    // neither account of the data section fits the file.
    assert_error(
        load("c3d", "c3d_neither_account_fits.c3d"),
        "c3d_neither_account_fits.c3d",
        ErrorKind::WrongValueCount,
        At::ByteField(C3D_DATA_START, "POINT:USED"),
        "POINT:USED is 29 but the header says 28 points per frame, and the data section fits neither account",
    );
    assert_error(
        load_with("c3d", "strict = true", "c3d_parameters_account_fits.c3d"),
        "c3d_parameters_account_fits.c3d",
        ErrorKind::WrongValueCount,
        At::ByteField(C3D_DATA_START, "ANALOG:USED"),
        "the header says 0 analog words per frame but ANALOG:USED 4 × 1 samples = 4",
    );
    // +inf at frame 4, marker 3 (Head_BL), Y.
    assert_error(
        load("c3d", "c3d_inf.c3d"),
        "c3d_inf.c3d",
        ErrorKind::NonFinite,
        At::ByteField(C3D_DATA_START + 3 * C3D_FRAME_BYTES + 2 * 16 + 4, "Head_BL"),
        "frame 4 marker \"Head_BL\": Y is inf",
    );
    assert_error(
        load("c3d", "corrupt_header.c3d"),
        "corrupt_header.c3d",
        ErrorKind::Syntax,
        At::Byte(1),
        "expected 0x50",
    );
}

#[test]
fn c3d_float_and_integer_storage_give_the_real_positions() {
    let float = load_ok("c3d", "c3d_float_storage.c3d");
    assert_eq!((float.n_frames(), float.n_points()), (10, 28));
    // Independent reader of the same recording: the Qualisys TSV export (3 decimals).
    let tsv = registry::build_loader("qualisys_tsv", &toml::Value::Table(toml::Table::new()))
        .unwrap()
        .load(&motionlab_testkit::data_path("mct/walk1.tsv.gz"))
        .unwrap()
        .slice_frames(0, 10)
        .unwrap();
    assert_same_positions(&float, &tsv, 1e-3, "c3d float storage vs walk1.tsv");
    // Integer storage at 0.1 mm per bit: within half a bit of the float file, plus the float32
    // rounding of the stored scale factor (0.1 is 0.100000001490116…: 7e-6 mm at 4 m).
    let int = load_ok("c3d", "c3d_int_storage.c3d");
    assert_same_positions(&int, &float, 0.05 + 1e-5, "c3d integer storage vs float storage");
    let one = load_ok("c3d", "c3d_one_frame.c3d");
    assert_eq!(one.n_frames(), 1);
    assert_eq!(one.frame(0), float.frame(0));
}

#[test]
fn c3d_repairs_read_the_real_positions_and_say_so() {
    let float = load_ok("c3d", "c3d_float_storage.c3d");
    assert!(float.load_notes.repairs.is_empty());
    // Head_FL written twice: the second is Head_FL#2, the positions untouched.
    let dup = load_ok("c3d", "c3d_duplicate_label.c3d");
    assert_eq!(&dup.point_names()[..3], ["Head_FL", "Head_FL#2", "Head_BL"]);
    assert_eq!(dup.positions(), float.positions());
    assert_eq!(
        dup.load_notes.repairs,
        [r#"duplicate point labels made unique: "Head_FL" (points 1, 2) → Head_FL, Head_FL#2"#]
    );
    // Four analog words the header does not count: read with the parameters' stride, every
    // frame is the float file's (read with the header's, frame 2 would start in frame 1's
    // analog words).
    let stride = load_ok("c3d", "c3d_parameters_account_fits.c3d");
    assert_eq!(stride.positions(), float.positions());
    assert_eq!(stride.load_notes.repairs.len(), 1);
    assert!(
        stride.load_notes.repairs[0]
            .ends_with("the parameters' account fits the file (7712 bytes) and is used"),
        "{:?}",
        stride.load_notes
    );
}

#[test]
fn c3d_missing_marker_nan_coordinate_and_events_outside_the_frames() {
    let base = load_ok("c3d", "c3d_float_storage.c3d");
    assert_eq!(base.missing_count(), 0);
    // Residual −1 for Spine (marker 7) in every frame: it loads, with 10 missing samples.
    let m = load_ok("c3d", "c3d_marker_missing_every_frame.c3d");
    let spine = m.point_index("Spine").unwrap();
    assert_eq!(m.missing_count(), 10);
    assert!(
        (0..10).all(|f| m.is_missing(f, spine) && m.position(f, spine).iter().all(|c| c.is_nan()))
    );
    // A NaN coordinate with a valid residual: that one sample is missing, nothing else changes.
    let n = load_ok("c3d", "c3d_nan.c3d");
    assert_eq!(n.missing_count(), 1);
    assert!(n.is_missing(4, 3));
    // Events outside the stored frames are kept (frame ≥ frame count), as documented.
    let cut = load_ok("c3d", "c3d_events_outside.c3d");
    let full = registry::build_loader("c3d", &toml::Value::Table(toml::Table::new()))
        .unwrap()
        .load(&motionlab_testkit::data_path("schreiber2019/2014001/dynamic/2014001_C4_05.c3d.gz"))
        .unwrap();
    assert_eq!(cut.n_frames(), 10);
    assert_eq!(cut.events.len(), full.events.len());
    for (c, f) in cut.events.iter().zip(&full.events) {
        assert_eq!((&c.label, c.time, c.frame), (&f.label, f.time, f.frame));
    }
    let outside = cut.events.iter().filter(|e| e.frame >= 10.0).count();
    assert!(
        outside >= 4 && outside < cut.events.len(),
        "{outside} of {} events after the cut",
        cut.events.len()
    );
}

// ---------------------------------------------------------------------------------------------
// Qualisys TSV (walk1: MARKER_NAMES on line 10, rows from line 11)
// ---------------------------------------------------------------------------------------------

#[test]
fn tsv_defects_name_kind_line_and_column() {
    let cases: &[(&str, ErrorKind, usize, Option<&str>, &str)] = &[
        ("tsv_empty.tsv", ErrorKind::MissingKey, 1, Some("MARKER_NAMES"), "no MARKER_NAMES line"),
        ("tsv_header_only.tsv", ErrorKind::Truncated, 11, None, "file ends after 0 data rows"),
        ("tsv_zero_frames.tsv", ErrorKind::EmptySequence, 11, None, "no data rows"),
        ("tsv_inf.tsv", ErrorKind::NonFinite, 14, Some("Head_FR Y"), "\"inf\""),
        ("tsv_neg_inf.tsv", ErrorKind::NonFinite, 20, Some("BigToe_R Z"), "\"-Infinity\""),
        (
            "tsv_duplicate_marker.tsv",
            ErrorKind::DuplicateName,
            10,
            Some("Spine"),
            "named twice (columns 8 and 9)",
        ),
        ("tsv_non_utf8.tsv", ErrorKind::Syntax, 15, None, "invalid UTF-8"),
        (
            "tsv_long_line.tsv",
            ErrorKind::WrongValueCount,
            17,
            None,
            "found 30084 values, expected 3 × 28 markers = 84",
        ),
        ("short_row.tsv", ErrorKind::WrongValueCount, 13, None, "expected 3 × 28 markers = 84"),
    ];
    for (file, kind, line, field, says) in cases {
        let at = match field {
            Some(f) => At::LineField(*line, f),
            None => At::Line(*line),
        };
        assert_error(load("qualisys_tsv", file), file, *kind, at, says);
    }
}

#[test]
fn tsv_quirks_load_as_documented() {
    let lf = load_ok("qualisys_tsv", "tsv_lf.tsv");
    assert_eq!((lf.n_frames(), lf.n_points()), (10, 28));
    for other in ["tsv_crlf.tsv", "tsv_bom.tsv"] {
        assert_same_positions(&load_ok("qualisys_tsv", other), &lf, 0.0, other);
    }
    let one = load_ok("qualisys_tsv", "tsv_one_frame.tsv");
    assert_eq!(one.n_frames(), 1);
    assert_eq!(one.frame(0), lf.frame(0));
    // Sternum NaN in every row: loads, that marker missing throughout, nothing else.
    let m = load_ok("qualisys_tsv", "tsv_marker_missing_every_frame.tsv");
    let sternum = m.point_index("Sternum").unwrap();
    assert_eq!(m.missing_count(), 10);
    assert!((0..10).all(|f| m.is_missing(f, sternum)));
    // walk1's real gaps: all 27 missing samples of the file are in these 130 rows.
    let gap = load_ok("qualisys_tsv", "tsv_walk1_gap_rows.tsv");
    assert_eq!((gap.n_frames(), gap.missing_count()), (130, 27));
    // Events before the first and after the last frame are kept, at frame = time × rate.
    let e = load_ok("qualisys_tsv", "tsv_events_outside.tsv");
    let frames: Vec<(&str, f64)> = e.events.iter().map(|x| (x.label.as_str(), x.frame)).collect();
    assert_eq!(frames.len(), 2);
    assert_eq!(frames[0].0, "before");
    assert!((frames[0].1 - -6.0).abs() < 1e-9, "{frames:?}");
    assert_eq!(frames[1].0, "after");
    assert!((frames[1].1 - 498.0).abs() < 1e-9, "{frames:?}");
}

// ---------------------------------------------------------------------------------------------
// Ground-truth label files
// ---------------------------------------------------------------------------------------------

fn read_labels(reader: &str, file: &str, motion: &Motion) -> Result<motionlab_core::Segmentation> {
    registry::build_ground_truth(reader, &toml::Value::Table(toml::Table::new()))
        .unwrap()
        .read(&fixture(file), motion)
}

fn motion_named(name: &str, n_frames: usize) -> Motion {
    let mut m = motionlab_testkit::motion_from_fn(n_frames, 120.0, 1, |_, _| [0.0; 3]);
    m.name = name.into();
    m
}

#[test]
fn label_defects_name_kind_and_line() {
    let m86 = motion_named("86_01", 4579);
    assert_error(
        read_labels("cmu86_labels", "cmu86_beyond_motion.txt", &m86),
        "cmu86_beyond_motion.txt",
        ErrorKind::OutOfRange,
        At::Line(8),
        "labelled up to frame 99999",
    );
    assert_error(
        read_labels("cmu86_labels", "cmu86_zero_frame.txt", &m86),
        "cmu86_zero_frame.txt",
        ErrorKind::Syntax,
        At::Line(3),
        "expected a frame number ≥ 1",
    );
    assert_error(
        read_labels("cmu86_labels", "cmu86_duplicate_trial.txt", &m86),
        "cmu86_duplicate_trial.txt",
        ErrorKind::DuplicateName,
        At::Line(10),
        "trial 86 01 is listed twice",
    );
    let m13 = motion_named("13_29", 3000);
    assert_error(
        read_labels("mocap6_labels", "mocap6_label_13.txt", &m13),
        "mocap6_label_13.txt",
        ErrorKind::OutOfRange,
        At::Line(1),
        "label 5 is \"13\"",
    );
    assert_error(
        read_labels("mocap6_labels", "mocap6_label_text.txt", &m13),
        "mocap6_label_text.txt",
        ErrorKind::Syntax,
        At::Line(1),
        "label 4 is \"jog\"",
    );
}

/// The users' annotation readers (`boundaries_csv`, `elan_eaf`) on fixtures made from 86_01's
/// labels (make.py `annotation_cases`); the motion stands in for data/cmu86/86_01.amc.gz (4579
/// frames at 120 Hz, in the folder the CSV's sequences are checked against).
#[test]
fn annotation_defects_name_kind_line_and_column() {
    let mut m86 = motion_named("86_01", 4579);
    m86.source = Some(motionlab_testkit::data_path("cmu86/86_01.amc.gz"));
    let csv: &[(&str, ErrorKind, At<'_>, &str)] = &[
        (
            "csv_no_rows_for_sequence.csv",
            ErrorKind::EmptySequence,
            At::LineField(2, "sequence"),
            "no row for sequence \"86_01\"",
        ),
        (
            "csv_unknown_sequence.csv",
            ErrorKind::UnknownName,
            At::LineField(6, "sequence"),
            "sequence \"86_99\" names no loaded sequence",
        ),
        (
            "csv_non_numeric.csv",
            ErrorKind::Syntax,
            At::LineField(5, "end_frame"),
            "\"1979f\" is not a number",
        ),
        (
            "csv_start_after_end.csv",
            ErrorKind::OutOfRange,
            At::LineField(4, "end_frame"),
            "ends at 549, before its start 1149",
        ),
        (
            "csv_mixed_formats.csv",
            ErrorKind::InvalidParameter,
            At::LineField(2, "start_frame"),
            "mixed formats: columns frame, start_frame, end_frame",
        ),
        (
            "csv_missing_end_column.csv",
            ErrorKind::MissingKey,
            At::LineField(2, "end_frame"),
            "\"start_frame\" needs \"end_frame\"",
        ),
        (
            "csv_past_end.csv",
            ErrorKind::OutOfRange,
            At::LineField(9, "end_frame"),
            "9579 is motion frame 9579, outside the motion's frames 0..=4579",
        ),
    ];
    for (file, kind, at, says) in csv {
        let at = match at {
            At::LineField(l, f) => At::LineField(*l, f),
            _ => unreachable!(),
        };
        assert_error(read_labels("boundaries_csv", file, &m86), file, *kind, at, says);
    }
    let eaf: &[(&str, ErrorKind, usize, Option<&str>, &str)] = &[
        (
            "eaf_unaligned_slot.eaf",
            ErrorKind::MissingData,
            27,
            Some("TIME_SLOT_REF2"),
            "time slot \"ts4\" (line 9) has no TIME_VALUE",
        ),
        (
            "eaf_undeclared_slot.eaf",
            ErrorKind::UnknownName,
            32,
            Some("TIME_SLOT_REF2"),
            "time slot \"ts50\" is not declared",
        ),
        (
            "eaf_end_before_start.eaf",
            ErrorKind::OutOfRange,
            22,
            Some("TIME_SLOT_REF2"),
            "ends at 4000, before its start 4575",
        ),
        (
            "eaf_time_text.eaf",
            ErrorKind::Syntax,
            10,
            Some("TIME_VALUE"),
            "\"20.8s\" is not a number",
        ),
        (
            "eaf_truncated.eaf",
            ErrorKind::Syntax,
            50,
            None,
            "the root node was opened but never closed",
        ),
    ];
    for (file, kind, line, field, says) in eaf {
        let at = match field {
            Some(f) => At::LineField(*line, f),
            None => At::Line(*line),
        };
        assert_error(read_labels("elan_eaf", file, &m86), file, *kind, at, says);
    }
    // The intact sources read: 86_01's six boundaries, as cmu86_labels gives them.
    let dir = motionlab_testkit::repo_root().join("tests/fixtures/annotations");
    let empty = toml::Value::Table(toml::Table::new());
    let with = |params: &str| -> toml::Value { toml::from_str(params).unwrap() };
    let from_csv = registry::build_ground_truth("boundaries_csv", &with("check_sequences = false"))
        .unwrap()
        .read(&dir.join("cmu86_mocap6_segments.csv"), &m86)
        .unwrap();
    let from_eaf = registry::build_ground_truth("elan_eaf", &empty)
        .unwrap()
        .read(&dir.join("86_01.eaf"), &m86)
        .unwrap();
    assert_eq!(from_csv.frames(), vec![549, 1149, 1979, 2499, 3199, 4064]);
    assert_eq!(from_eaf.frames(), from_csv.frames());
}

// ---------------------------------------------------------------------------------------------
// Experiment TOML, validated by motionlab_engine::plan
// ---------------------------------------------------------------------------------------------

#[test]
fn experiment_defects_name_kind_key_path_and_line() {
    let cases: &[(&str, ErrorKind, usize, Option<&str>, &str)] = &[
        ("toml_syntax_error.toml", ErrorKind::Syntax, 4, None, "unclosed array table"),
        (
            "toml_wrong_type_tolerance.toml",
            ErrorKind::WrongType,
            15,
            Some("evaluate[0].tolerance"),
            "expected `frames` or `seconds`",
        ),
        (
            "toml_negative_tolerance.toml",
            ErrorKind::OutOfRange,
            15,
            Some("evaluate[0].tolerance"),
            "must be a finite time span >= 0, found -0.5 s",
        ),
        (
            "toml_lag_zero.toml",
            ErrorKind::OutOfRange,
            12,
            Some("segmentation.segmenter[0].lag"),
            "must be a finite time span > 0, found 0 frames",
        ),
        (
            "toml_missing_files.toml",
            ErrorKind::MissingKey,
            4,
            Some("dataset[0]"),
            "missing field `files`",
        ),
        ("toml_bad_name.toml", ErrorKind::OutOfRange, 2, Some("experiment.name"), "\"two words\""),
        (
            "toml_sweep_too_large.toml",
            ErrorKind::OutOfRange,
            13,
            Some("sweep"),
            "the sweep has 200000 combinations; expected at most 10000",
        ),
        (
            "toml_fill_gaps_negative.toml",
            ErrorKind::OutOfRange,
            7,
            Some("dataset[0].preprocess[0].max_gap"),
            "-3",
        ),
        (
            "unknown_key.toml",
            ErrorKind::UnknownKey,
            7,
            Some("dataset[0].frame_rate"),
            "unknown field `frame_rate`",
        ),
        (
            "unknown_section.toml",
            ErrorKind::UnknownKey,
            9,
            Some("segmentaton"),
            // The list of workflow sections is the binary's (a scaffolded workflow joins it), so
            // the message is checked from its fixed part on.
            "[segmentation]) or one of experiment, dataset, preprocess, evaluate, sweep, published; did you mean `segmentation`?",
        ),
        (
            "unknown_param.toml",
            ErrorKind::UnknownKey,
            9,
            Some("features.extractors[0].per_markers"),
            "unknown field `per_markers`",
        ),
        (
            "unknown_plugin.toml",
            ErrorKind::UnknownPlugin,
            10,
            Some("segmentation.segmenter[0].type"),
            "fastest_marker_sped",
        ),
        (
            "wrong_type.toml",
            ErrorKind::WrongType,
            11,
            Some("segmentation.segmenter[0].v_low"),
            "expected `mm_per_s` or `fraction_of_p90`",
        ),
    ];
    for (file, kind, line, field, says) in cases {
        let at = match field {
            Some(f) => At::LineField(*line, f),
            None => At::Line(*line),
        };
        assert_error(
            motionlab_engine::plan(&fixture(file), &[]).map(|_| ()),
            file,
            *kind,
            at,
            says,
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Fuzzer findings (tests/fixtures/fuzz/: the minimised inputs, see fuzz/README.md)
// ---------------------------------------------------------------------------------------------

fn fuzz_fixture(name: &str) -> PathBuf {
    motionlab_testkit::repo_root().join("tests/fixtures/fuzz").join(name)
}

#[test]
fn fuzz_finding_a_malformed_sweep_key_is_located_at_the_sweep() {
    // experiment_toml: a grid key that is no key path (`"et["`) was reported without file or line.
    let file = "experiment_sweep_bad_key.toml";
    assert_error(
        motionlab_engine::plan(&fuzz_fixture(file), &[]).map(|_| ()),
        file,
        ErrorKind::Syntax,
        At::LineField(9, "sweep"),
        "bad key path \"et[\": unclosed [",
    );
    // The same class through overrides: a bad override names the experiment file (it is not
    // written in the file, so there is no line) and, when it cannot be set, its key path.
    let quickstart = motionlab_testkit::repo_root().join("experiments/quickstart.toml");
    for (o, kind, field) in [
        ("et[=1", ErrorKind::Syntax, None),
        ("experiment.name[0]=1", ErrorKind::UnknownKey, Some("experiment.name[0]")),
    ] {
        let e = motionlab_engine::plan(&quickstart, &[o.to_string()]).map(|_| ()).unwrap_err();
        assert_eq!(e.kind(), kind, "{o}: {e}");
        assert_eq!(e.location().file.as_deref(), Some(quickstart.as_path()), "{o}: {e}");
        assert_eq!(e.location().field.as_deref(), field, "{o}: {e}");
        assert!(e.to_string().contains("quickstart.toml"), "{e}");
    }
}

#[test]
fn the_corpus_has_at_least_thirty_cases_and_make_py_lists_them_all() {
    let dir = motionlab_testkit::repo_root().join("tests/fixtures/malformed");
    let fixtures: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| !n.ends_with(".py"))
        .collect();
    assert!(fixtures.len() >= 30, "{} fixtures", fixtures.len());
    // Every fixture is named in this file, so none sits there untested.
    let this = include_str!("malformed.rs");
    let untested: Vec<&String> =
        fixtures.iter().filter(|f| *f != "86.asf" && !this.contains(&format!("\"{f}\""))).collect();
    assert!(untested.is_empty(), "fixtures no test names: {untested:?}");
    let fuzz_dir = motionlab_testkit::repo_root().join("tests/fixtures/fuzz");
    for e in std::fs::read_dir(&fuzz_dir).unwrap() {
        let f = e.unwrap().file_name().to_string_lossy().into_owned();
        assert!(this.contains(&format!("\"{f}\"")), "fuzz fixture {f} has no test");
    }
}

// ---------------------------------------------------------------------------------------------
// No panics on input: every unwrap/expect left in library code is listed and justified
// ---------------------------------------------------------------------------------------------

#[test]
fn every_remaining_unwrap_in_library_code_is_documented() {
    // The scan lives in Python so it can be run by hand too; CI machines have python3 (the
    // browser and benchmark scripts need it). A missing interpreter fails loudly here rather
    // than letting the audit silently lapse.
    let root = motionlab_testkit::repo_root();
    let out = std::process::Command::new("python3")
        .arg(root.join("tests/unwrap_audit.py"))
        .output()
        .expect("python3 is needed for the unwrap audit (tests/unwrap_audit.py)");
    assert!(
        out.status.success(),
        "undocumented unwrap/expect/panic sites (add a reason to docs/unwrap-audit.md or return an Error):\n{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

// ---------------------------------------------------------------------------------------------
// TRC (opensim-core dataWithEformat.trc: header lines 1–5, rows 6–10) and MOT/STO
// (referenceCoordinates.sto cut to 8 rows: `endheader` on line 5, labels 6, rows 7–14)
// ---------------------------------------------------------------------------------------------

#[test]
fn trc_defects_name_kind_line_and_column() {
    let cases: &[(&str, ErrorKind, At<'_>, &str)] = &[
        (
            "trc_truncated_header.trc",
            ErrorKind::Truncated,
            At::Line(3),
            "the header ends after 3 lines; expected 5",
        ),
        ("trc_header_only.trc", ErrorKind::EmptySequence, At::Line(5), "no data rows"),
        (
            "trc_too_many_cells.trc",
            ErrorKind::WrongValueCount,
            At::Line(8),
            "found 45 cells, a value in cell 45; expected 2 + 3 × 14 markers = 44",
        ),
        (
            "trc_short_row.trc",
            ErrorKind::WrongValueCount,
            At::Line(7),
            "found 40 cells; expected 2 + 3 × 14 markers = 44",
        ),
        (
            "trc_not_a_number.trc",
            ErrorKind::Syntax,
            At::LineField(9, "RUA1 Y"),
            "\"2,45E-01\" in column 7",
        ),
        (
            "trc_no_units.trc",
            ErrorKind::MissingKey,
            At::LineField(3, "Units"),
            "no Units in the header",
        ),
    ];
    for (file, kind, at, says) in cases {
        let at = match at {
            At::Line(l) => At::Line(*l),
            At::LineField(l, f) => At::LineField(*l, f),
            _ => unreachable!(),
        };
        assert_error(load("trc", file), file, *kind, at, says);
    }
}

#[test]
fn trc_crlf_loads_as_lf() {
    let lf = load_ok("trc", "trc_lf.trc");
    assert_eq!((lf.n_frames(), lf.n_points()), (5, 14));
    assert_same_positions(&load_ok("trc", "trc_crlf.trc"), &lf, 0.0, "trc_crlf.trc");
}

#[test]
fn sto_defects_name_kind_line_and_column() {
    let cases: &[(&str, ErrorKind, usize, Option<&str>, &str)] = &[
        ("sto_no_endheader.sto", ErrorKind::Truncated, 4, None, "no `endheader` line"),
        (
            "sto_too_many_cells.sto",
            ErrorKind::WrongValueCount,
            9,
            None,
            "found 12 values; expected 11 (time and 10 columns, as labelled on line 6)",
        ),
        (
            "sto_not_a_number.sto",
            ErrorKind::Syntax,
            11,
            Some("/jointset/groundPelvis/pelvis_ty/value"),
            "\"0.88x\" in column 4",
        ),
        ("sto_time_backwards.sto", ErrorKind::OutOfRange, 13, None, "expected increasing times"),
    ];
    for (file, kind, line, field, says) in cases {
        let at = match field {
            Some(f) => At::LineField(*line, f),
            None => At::Line(*line),
        };
        assert_error(load("mot", file), file, *kind, at, says);
    }
}

#[test]
fn sto_crlf_loads_as_lf() {
    let lf = load_ok("mot", "sto_lf.sto");
    let crlf = load_ok("mot", "sto_crlf.sto");
    assert_eq!((lf.n_frames(), lf.channels().n_channels()), (8, 10));
    assert_eq!(lf.channels(), crlf.channels());
    assert_eq!(lf.frame_rate().hz(), crlf.frame_rate().hz());
}

// ---------------------------------------------------------------------------------------------
// Video pose estimation: OpenPose frame folders (each case a folder holding a frame file named
// after it), COCO keypoint JSON, MediaPipe landmarks (see make.py's `pose_cases`)
// ---------------------------------------------------------------------------------------------

#[test]
fn openpose_defects_name_kind_file_line_and_field() {
    let cases: &[(&str, &str, ErrorKind, At<'_>, &str)] = &[
        (
            "openpose_no_people",
            "openpose_no_people.json",
            ErrorKind::MissingKey,
            At::LineField(1, "people"),
            "has no `people` list",
        ),
        (
            "openpose_not_multiple_of_3",
            "openpose_not_multiple_of_3.json",
            ErrorKind::WrongValueCount,
            At::LineField(1, "people[0].pose_keypoints_2d"),
            "holds 74 numbers, not a multiple of 3",
        ),
        (
            "openpose_truncated",
            "openpose_truncated.json",
            ErrorKind::Truncated,
            At::Line(1),
            "not valid JSON",
        ),
        (
            "openpose_count_differs",
            "openpose_count_differs.json",
            ErrorKind::WrongValueCount,
            At::LineField(1, "people[0].pose_keypoints_2d"),
            "18 keypoints; expected 25",
        ),
    ];
    for (folder, file, kind, at, says) in cases {
        let at = match at {
            At::Line(l) => At::Line(*l),
            At::LineField(l, f) => At::LineField(*l, f),
            _ => unreachable!(),
        };
        assert_error(load_with("openpose", "rate_hz = 60.0", folder), file, *kind, at, says);
    }
    let e = load_with("openpose", "rate_hz = 60.0", "openpose_empty").unwrap_err();
    assert_eq!(e.kind(), ErrorKind::EmptySequence, "{e}");
    assert!(
        e.to_string().contains("openpose_empty") && e.to_string().contains("no .json file"),
        "{e}"
    );
}

#[test]
fn coco_and_mediapipe_defects_name_kind_line_and_field() {
    let coco_line = line_containing("coco_not_multiple_of_3.json", "\"keypoints\": [", 2);
    assert_error(
        load_with("coco_keypoints", "rate_hz = 1.0", "coco_not_multiple_of_3.json"),
        "coco_not_multiple_of_3.json",
        ErrorKind::WrongValueCount,
        At::LineField(coco_line, "annotations[0].keypoints"),
        "holds 50 numbers, not a multiple of 3",
    );
    assert_error(
        load_with("coco_keypoints", "rate_hz = 1.0", "coco_unknown_image.json"),
        "coco_unknown_image.json",
        ErrorKind::UnknownName,
        At::LineField(coco_line, "annotations[0].image_id"),
        "is 999999, an image `images` does not list",
    );
    assert_error(
        load_with("mediapipe", "rate_hz = 30.0", "mediapipe_not_a_number.pbtxt"),
        "mediapipe_not_a_number.pbtxt",
        ErrorKind::Syntax,
        At::LineField(5, "x"),
        "\"0.465O7242\" is not a number",
    );
    assert_error(
        load_with("mediapipe", "rate_hz = 30.0", "mediapipe_truncated.pbtxt"),
        "mediapipe_truncated.pbtxt",
        ErrorKind::Truncated,
        At::Line(12),
        "the block opened on line 11 is not closed",
    );
}
