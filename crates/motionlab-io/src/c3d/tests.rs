//! Unit tests on hand-made C3D files (see `testfile.rs`); real-data tests are in
//! `tests/binary_formats.rs`.

use std::path::Path;

use motionlab_core::registry::{build_loader, parse_params};
use motionlab_core::{Axis, ErrorKind};

use super::raw::{BLOCK, C3dFile, Processor};
use super::testfile::C3dSpec;
use super::*;

const ORIGIN: &str = "hand/made.c3d";

fn parse(bytes: &[u8]) -> Result<Motion> {
    parse_c3d(bytes, Path::new(ORIGIN), &C3dOptions::default())
}

fn err(bytes: &[u8]) -> motionlab_core::Error {
    match parse(bytes) {
        Ok(m) => panic!("expected an error, loaded {} frames", m.n_frames()),
        Err(e) => {
            assert!(e.to_string().contains(ORIGIN), "message must name the file: {e}");
            assert!(!e.to_string().contains('\n'), "one line: {e}");
            e
        }
    }
}

/// The error of a strict reading (every repair refused).
fn strict_err(bytes: &[u8]) -> motionlab_core::Error {
    let strict = C3dOptions { strict: true, ..C3dOptions::default() };
    match parse_c3d(bytes, Path::new(ORIGIN), &strict) {
        Ok(m) => panic!("strict reading loaded {} frames; notes {:?}", m.n_frames(), m.load_notes),
        Err(e) => {
            assert!(e.to_string().contains(ORIGIN) && !e.to_string().contains('\n'), "{e}");
            e
        }
    }
}

fn close(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
    a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol)
}

#[test]
fn float_storage_reads_positions_labels_rate_and_missing() {
    let m = parse(&C3dSpec::small().build()).unwrap();
    assert_eq!((m.n_frames(), m.n_points()), (3, 2));
    assert_eq!(m.point_names(), ["a", "b"]);
    assert_eq!(m.frame_rate().hz(), 100.0);
    assert_eq!(m.up_axis(), Axis::Z);
    assert_eq!(m.name, "made");
    assert_eq!(m.format, "c3d");
    // f32 values widened exactly.
    assert_eq!(m.position(1, 0), [1.5, 2.5, 3.5]);
    assert_eq!(m.position(2, 1), [12.0, 22.0, 32.0]);
    // Residual −1 at (frame 1, b): missing and NaN although the file holds 11, 21, 31.
    assert!(m.is_missing(1, 1) && m.position(1, 1)[0].is_nan());
    // Residual 0 (frame 1, a) is a valid, interpolated sample in C3D.
    assert!(!m.is_missing(1, 0));
    assert_eq!(m.missing_count(), 1);
}

#[test]
fn integer_storage_multiplies_by_the_scale_and_skips_analog_words() {
    let mut spec = C3dSpec::small();
    spec.scale = 0.5;
    spec.analog_per_frame = 3;
    let m = parse(&spec.build()).unwrap();
    // 1.5 / 0.5 = 3 stored → 1.5 mm; every frame is exact at 0.5 mm resolution.
    assert_eq!(m.position(1, 0), [1.5, 2.5, 3.5]);
    assert_eq!(m.position(2, 0), [2.0, 3.0, 4.0]);
    assert_eq!(m.position(2, 1), [12.0, 22.0, 32.0]);
    assert!(m.is_missing(1, 1));
    assert_eq!(m.missing_count(), 1);
    // The analog filler (9999 / 32000) never leaks into positions.
    assert!(m.positions().iter().flatten().all(|v| v.is_nan() || v.abs() < 100.0));
}

#[test]
fn float_storage_also_skips_analog_words() {
    let mut spec = C3dSpec::small();
    spec.analog_per_frame = 5;
    let m = parse(&spec.build()).unwrap();
    assert_eq!(m.position(2, 1), [12.0, 22.0, 32.0]);
}

#[test]
fn dec_mips_and_intel_files_with_the_same_content_load_identically() {
    let intel = parse(&C3dSpec::small().build()).unwrap();
    for processor in [Processor::Dec, Processor::Mips] {
        for scale in [-0.1, 0.5] {
            let mut spec = C3dSpec::small();
            spec.processor = processor;
            spec.scale = scale;
            spec.events = vec![("Foot Strike", "Left", 0.0, 0.02)];
            let m = parse(&spec.build()).unwrap();
            assert_eq!(m.frame_rate().hz(), 100.0, "{processor:?}");
            for f in 0..3 {
                for p in 0..2 {
                    let (a, b) = (intel.position(f, p), m.position(f, p));
                    assert!(
                        a == b || (a[0].is_nan() && b[0].is_nan()),
                        "{processor:?} {scale} ({f},{p}): {a:?} vs {b:?}"
                    );
                }
            }
            assert!((m.events[0].time.0 - 0.02).abs() < 1e-7, "{processor:?}");
        }
    }
    // The processor byte really differs (the test is not reading three Intel files).
    let mut dec = C3dSpec::small();
    dec.processor = Processor::Dec;
    let bytes = dec.build();
    assert_eq!(C3dFile::parse(&bytes, Path::new(ORIGIN)).unwrap().processor, Processor::Dec);
    assert_eq!(bytes[BLOCK + 3], 85);
}

#[test]
fn units_are_converted_to_millimetres() {
    let mut spec = C3dSpec::small();
    spec.units = Some("m");
    let m = parse(&spec.build()).unwrap();
    assert!(close(m.position(0, 1), [10_000.0, 20_000.0, 30_000.0], 1e-9));
    spec.units = Some("cm");
    assert!(close(parse(&spec.build()).unwrap().position(0, 0), [10.0, 20.0, 30.0], 1e-9));
    spec.units = None;
    assert_eq!(parse(&spec.build()).unwrap().position(0, 0), [1.0, 2.0, 3.0]);
    spec.units = Some("furlong");
    let e = err(&spec.build());
    assert_eq!(
        (e.kind(), e.location().field.as_deref()),
        (ErrorKind::OutOfRange, Some("POINT:UNITS"))
    );
}

#[test]
fn events_combine_minutes_and_seconds_and_are_sorted_with_frame_offsets() {
    let mut spec = C3dSpec::small();
    spec.first_frame = 11;
    spec.events = vec![
        ("Foot Off", "Right", 1.0, 2.5),
        ("Foot Strike", "Left", 0.0, 0.13),
        ("Event", "General", 0.0, 0.1),
    ];
    let m = parse(&spec.build()).unwrap();
    let got: Vec<(&str, &str)> =
        m.events.iter().map(|e| (e.label.as_str(), e.context.as_str())).collect();
    assert_eq!(got, [("Event", "General"), ("Foot Strike", "Left"), ("Foot Off", "Right")]);
    let f32_time = |t: f32| f64::from(t);
    assert_eq!(m.events[0].time.0, f32_time(0.1));
    assert_eq!(m.events[2].time.0, 60.0 + 2.5);
    // time 0 is frame number 1; the first stored frame is number 11 → index = t·rate + 1 − 11.
    assert!((m.events[1].frame - (13.0 + 1.0 - 11.0)).abs() < 1e-4, "{}", m.events[1].frame);
    assert!((m.events[0].frame - 0.0).abs() < 1e-4);
    assert!((m.events[2].frame - (6250.0 - 10.0)).abs() < 1e-3);
}

#[test]
fn events_outside_the_stored_frames_are_kept_with_their_frame_index() {
    let mut spec = C3dSpec::small();
    spec.events = vec![("Before", "General", 0.0, -0.05), ("After", "General", 0.0, 0.5)];
    let m = parse(&spec.build()).unwrap();
    assert_eq!(m.events.len(), 2);
    assert!((m.events[0].frame + 5.0).abs() < 1e-4 && (m.events[1].frame - 50.0).abs() < 1e-4);
    // Slicing the motion drops them, as it drops any event outside the slice.
    assert!(m.slice_frames(0, 3).unwrap().events.is_empty());
}

#[test]
fn trial_start_field_overrides_the_header_first_frame() {
    let mut spec = C3dSpec::small();
    spec.events = vec![("Foot Strike", "Left", 0.0, 0.5)];
    // Header says frame 1 first; TRIAL says 70001 … 70003 (two words: 70001 = 4465 + 65536).
    spec.extra = vec![
        spec.raw_ints("TRIAL", "ACTUAL_START_FIELD", &[4465, 1]),
        spec.raw_ints("TRIAL", "ACTUAL_END_FIELD", &[4467, 1]),
    ];
    let m = parse(&spec.build()).unwrap();
    assert_eq!(m.n_frames(), 3);
    assert!((m.events[0].frame - (50.0 + 1.0 - 70001.0)).abs() < 1e-6);
}

#[test]
fn labels_continue_in_labels2_are_trimmed_and_blank_ones_numbered() {
    let mut spec = C3dSpec::small();
    spec.frames = vec![vec![[1.0, 1.0, 1.0, 0.0]; 4]; 2];
    spec.labels = vec![];
    spec.extra = vec![
        C3dSpec::raw_chars("POINT", "LABELS", 6, &["  LASI", "    "]),
        C3dSpec::raw_chars("POINT", "LABELS2", 6, &["RASI\0\0", "extra1", "extra2"]),
    ];
    let m = parse(&spec.build()).unwrap();
    assert_eq!(m.point_names(), ["LASI", "P2", "RASI", "extra1"]);
}

#[test]
fn zero_means_missing_is_opt_in() {
    let mut spec = C3dSpec::small();
    spec.frames[0][0] = [0.0, 0.0, 0.0, 1.0];
    assert!(!parse(&spec.build()).unwrap().is_missing(0, 0));
    let options = C3dOptions { zero_means_missing: true, ..C3dOptions::default() };
    let m = parse_c3d(&spec.build(), Path::new(ORIGIN), &options).unwrap();
    assert!(m.is_missing(0, 0));
    assert_eq!(m.missing_count(), 2);
}

#[test]
fn multi_dimensional_char_arrays_and_all_numeric_types_parse() {
    let mut spec = C3dSpec::small();
    let mut chars3 =
        C3dSpec::raw_chars("SUBJECT", "GRID", 2, &["ab", "cd", "ef", "gh", "ij", "kl"]);
    chars3.dims = vec![2, 3, 2];
    let bytes_param = super::testfile::RawParam {
        group: "SUBJECT",
        name: "FLAGS".into(),
        type_byte: 1,
        dims: vec![3],
        data: vec![1, 200, 7],
    };
    let mut empty = C3dSpec::raw_chars("SUBJECT", "NOTES", 1, &[""]);
    empty.dims = vec![0, 4];
    empty.data.clear();
    spec.extra = vec![
        chars3,
        bytes_param,
        empty,
        spec.raw_floats("SUBJECT", "MASS", vec![2], &[70.5, -1.25]),
    ];
    let bytes = spec.build();
    let file = C3dFile::parse(&bytes, Path::new(ORIGIN)).unwrap();
    let ctx = file.ctx;
    assert_eq!(
        file.param("subject", "grid").unwrap().strings(ctx).unwrap(),
        ["ab", "cd", "ef", "gh", "ij", "kl"]
    );
    assert_eq!(file.param("SUBJECT", "FLAGS").unwrap().unsigned(ctx).unwrap(), [1, 200, 7]);
    assert_eq!(file.param("SUBJECT", "NOTES").unwrap().strings(ctx).unwrap(), ["", "", "", ""]);
    assert_eq!(file.param("SUBJECT", "MASS").unwrap().floats(ctx).unwrap(), [70.5, -1.25]);
    assert!(file.param("SUBJECT", "MASS").unwrap().strings(ctx).is_err());
}

// ---- malformed files: exact kind, file and byte offset / parameter -------------------------

#[test]
fn wrong_key_byte_is_a_syntax_error_at_byte_1() {
    let mut bytes = C3dSpec::small().build();
    bytes[1] = 0x51;
    let e = err(&bytes);
    assert_eq!((e.kind(), e.location().byte_offset), (ErrorKind::Syntax, Some(1)));
    assert!(e.message().contains("0x50"), "{e}");
}

#[test]
fn parameter_block_pointer_out_of_range_is_an_error_at_byte_0() {
    for pointer in [0u8, 1, 200] {
        let mut bytes = C3dSpec::small().build();
        bytes[0] = pointer;
        let e = err(&bytes);
        assert_eq!(
            (e.kind(), e.location().byte_offset),
            (ErrorKind::OutOfRange, Some(0)),
            "{pointer}: {e}"
        );
        assert!(e.message().contains(&format!("pointer is {pointer}")), "{e}");
    }
}

#[test]
fn unknown_processor_byte_is_a_syntax_error() {
    let mut bytes = C3dSpec::small().build();
    bytes[BLOCK + 3] = 99;
    let e = err(&bytes);
    assert_eq!((e.kind(), e.location().byte_offset), (ErrorKind::Syntax, Some(BLOCK as u64 + 3)));
}

#[test]
fn file_shorter_than_its_frames_is_truncated_at_the_first_incomplete_frame() {
    let bytes = C3dSpec::small().build();
    let frame_bytes = 2 * 16;
    let data_start = bytes.len() - 3 * frame_bytes;
    let cut = &bytes[..bytes.len() - 5];
    let e = err(cut);
    assert_eq!(e.kind(), ErrorKind::Truncated);
    assert_eq!(e.location().byte_offset, Some((data_start + 2 * frame_bytes) as u64));
    assert!(e.message().contains("frame 3 of 3"), "{e}");
    // Cut inside the header block.
    let e = err(&bytes[..100]);
    assert_eq!((e.kind(), e.location().byte_offset), (ErrorKind::Truncated, Some(100)));
}

#[test]
fn zero_or_nan_scale_factor_is_out_of_range_naming_point_scale() {
    for scale in [0.0f32, f32::NAN] {
        let mut spec = C3dSpec::small();
        spec.scale = scale;
        let e = err(&spec.build());
        assert_eq!(
            (e.kind(), e.location().field.as_deref()),
            (ErrorKind::OutOfRange, Some("POINT:SCALE")),
            "{e}"
        );
        assert!(e.location().byte_offset.is_some());
    }
    // Without POINT:SCALE the header's word 7–8 is used and named.
    let mut spec = C3dSpec::small();
    spec.scale = 0.0;
    spec.omit = vec!["POINT:SCALE"];
    let e = err(&spec.build());
    assert_eq!((e.kind(), e.location().byte_offset), (ErrorKind::OutOfRange, Some(12)));
}

#[test]
fn zero_or_nan_rate_is_out_of_range_naming_point_rate() {
    for rate in [0.0f32, f32::NAN, -60.0] {
        let mut spec = C3dSpec::small();
        spec.rate = rate;
        let e = err(&spec.build());
        assert_eq!(
            (e.kind(), e.location().field.as_deref()),
            (ErrorKind::OutOfRange, Some("POINT:RATE")),
            "{e}"
        );
    }
    let mut spec = C3dSpec::small();
    spec.rate = 0.0;
    spec.omit = vec!["POINT:RATE"];
    let e = err(&spec.build());
    assert_eq!((e.kind(), e.location().byte_offset), (ErrorKind::OutOfRange, Some(20)));
}

#[test]
fn last_frame_before_first_is_a_negative_frame_count() {
    let mut spec = C3dSpec::small();
    spec.extra = vec![
        spec.raw_ints("TRIAL", "ACTUAL_START_FIELD", &[10, 0]),
        spec.raw_ints("TRIAL", "ACTUAL_END_FIELD", &[5, 0]),
    ];
    let e = err(&spec.build());
    assert_eq!(
        (e.kind(), e.location().field.as_deref()),
        (ErrorKind::OutOfRange, Some("TRIAL:ACTUAL_END_FIELD"))
    );
    assert!(e.message().contains("negative frame count"), "{e}");
    // Same through the header when there is no TRIAL group.
    let mut spec = C3dSpec::small();
    spec.omit = vec!["TRIAL:ACTUAL_START_FIELD", "TRIAL:ACTUAL_END_FIELD"];
    let mut bytes = spec.build();
    bytes[6..8].copy_from_slice(&9u16.to_le_bytes());
    let e = err(&bytes);
    assert_eq!((e.kind(), e.location().byte_offset), (ErrorKind::OutOfRange, Some(8)));
}

#[test]
fn fewer_labels_than_points_is_an_error_naming_point_labels() {
    let mut spec = C3dSpec::small();
    spec.labels = vec!["only_one".into()];
    let e = err(&spec.build());
    assert_eq!(
        (e.kind(), e.location().field.as_deref()),
        (ErrorKind::WrongValueCount, Some("POINT:LABELS"))
    );
    assert!(e.message().contains("1 labels") && e.message().contains("2 points"), "{e}");
}

#[test]
fn no_point_labels_names_the_points_p1_to_pn_and_says_so() {
    let mut spec = C3dSpec::small();
    spec.omit = vec!["POINT:LABELS"];
    let m = parse(&spec.build()).unwrap();
    assert_eq!(m.point_names(), ["P1", "P2"]);
    assert_eq!(m.load_notes.repairs, ["no POINT:LABELS: the 2 points are named P1…P2"]);
    assert_eq!(strict_err(&spec.build()).kind(), ErrorKind::MissingKey);
}

#[test]
fn duplicate_labels_get_unique_names_with_a_note_and_are_refused_when_strict() {
    let mut spec = C3dSpec::small();
    spec.frames = vec![vec![[1.0, 2.0, 3.0, 0.0]; 5]; 2];
    // "b#2" is taken by a later point, so the second "b" becomes "b#3".
    spec.labels = vec!["a".into(), "b".into(), "a".into(), "b".into(), "b#2".into()];
    let m = parse(&spec.build()).unwrap();
    assert_eq!(m.point_names(), ["a", "b", "a#2", "b#3", "b#2"]);
    assert_eq!(
        m.load_notes.repairs,
        [
            r#"duplicate point labels made unique: "a" (points 1, 3) → a, a#2; "b" (points 2, 4) → b, b#3"#
        ]
    );
    let e = strict_err(&spec.build());
    assert_eq!(
        (e.kind(), e.location().field.as_deref()),
        (ErrorKind::DuplicateName, Some("POINT:LABELS"))
    );
    assert!(e.message().contains("names points 1 and 3"), "{e}");
    // A clean file has no notes, and says where its unit came from.
    let clean = parse(&C3dSpec::small().build()).unwrap();
    assert!(clean.load_notes.repairs.is_empty());
    assert_eq!(clean.load_notes.length_unit, Some(motionlab_core::LengthUnit::Millimetre));
    assert_eq!(clean.load_notes.length_unit_from, r#"POINT:UNITS "mm""#);
}

#[test]
fn labels_equal_only_once_prefixes_are_stripped_stay_an_error() {
    let mut spec = C3dSpec::small();
    spec.labels = vec!["vsk:LFWT".into(), "vsk2:LFWT".into()];
    let e = err(&spec.build());
    assert_eq!(e.kind(), ErrorKind::DuplicateName);
    assert!(e.message().contains("strip_subject_prefix = false"), "{e}");
    let keep = C3dOptions { strip_subject_prefix: false, ..C3dOptions::default() };
    assert_eq!(
        parse_c3d(&spec.build(), Path::new(ORIGIN), &keep).unwrap().point_names(),
        ["vsk:LFWT", "vsk2:LFWT"]
    );
}

#[test]
fn non_utf8_labels_are_a_syntax_error_at_the_bad_byte() {
    let mut spec = C3dSpec::small();
    spec.labels = vec!["ok".into(), "b\u{e9}".into()]; // placeholder, bytes replaced below
    let mut labels = C3dSpec::raw_chars("POINT", "LABELS", 3, &["ok", "bx"]);
    labels.data[4] = 0xE9; // Latin-1 é
    spec.extra = vec![labels];
    let bytes = spec.build();
    let e = err(&bytes);
    assert_eq!(
        (e.kind(), e.location().field.as_deref()),
        (ErrorKind::Syntax, Some("POINT:LABELS"))
    );
    let at = e.location().byte_offset.unwrap() as usize;
    assert_eq!(bytes[at], 0xE9);
}

/// Header word 3 (analog words per frame) set to `words`.
fn set_header_analog_words(bytes: &mut [u8], words: u16) {
    bytes[4..6].copy_from_slice(&words.to_le_bytes());
}

#[test]
fn point_used_disagreeing_with_the_header_is_resolved_by_the_file_size() {
    // Header: 2 points (the frames written); POINT:USED 3 would need 3 × 48 bytes more.
    let mut spec = C3dSpec::small();
    spec.extra = vec![spec.raw_ints("POINT", "USED", &[3])];
    let bytes = spec.build();
    let m = parse(&bytes).unwrap();
    assert_eq!((m.n_points(), m.position(2, 1)), (2, [12.0, 22.0, 32.0]));
    assert_eq!(
        m.load_notes.repairs,
        [format!(
            "POINT:USED is 3 but the header says 2 points per frame: the header's account fits the file ({} bytes) and is used",
            bytes.len()
        )]
    );
    let e = strict_err(&bytes);
    assert_eq!(
        (e.kind(), e.location().field.as_deref()),
        (ErrorKind::WrongValueCount, Some("POINT:USED"))
    );
    // Padded to whole blocks, both accounts end in the last block: the header's is read, and
    // that is said.
    let mut padded = bytes.clone();
    padded.resize(bytes.len().div_ceil(BLOCK) * BLOCK, 0);
    assert!(
        bytes.len() % BLOCK + 3 * 16 <= BLOCK,
        "the parameters' frames must end in the same block"
    );
    let m = parse(&padded).unwrap();
    assert_eq!(m.n_points(), 2);
    assert!(
        m.load_notes.repairs[0].ends_with(&format!(
            "both accounts fit; the header's account fits the file ({} bytes) and is used",
            padded.len()
        )),
        "{:?}",
        m.load_notes
    );
    // Unpadded, a file ending between the two accounts fits neither.
    let mut between = bytes.clone();
    between.extend([0u8; 20]);
    assert_eq!(err(&between).kind(), ErrorKind::WrongValueCount);
}

#[test]
fn the_parameters_account_is_read_when_it_alone_fits_the_file() {
    // Four analog words per frame written; the header says 2, ANALOG:USED 2 × (200 / 100 Hz) = 4.
    let mut spec = C3dSpec::small();
    spec.analog_per_frame = 4;
    spec.extra = vec![
        spec.raw_ints("ANALOG", "USED", &[2]),
        spec.raw_floats("ANALOG", "RATE", vec![], &[200.0]),
    ];
    let mut bytes = spec.build();
    set_header_analog_words(&mut bytes, 2);
    let m = parse(&bytes).unwrap();
    // Read with the header's stride, frame 2 would start inside frame 1's analog filler.
    assert_eq!(m.position(2, 1), [12.0, 22.0, 32.0]);
    assert_eq!(
        m.load_notes.repairs,
        [format!(
            "the header says 2 analog words per frame but ANALOG:USED 2 × 2 samples = 4: the parameters' account fits the file ({} bytes) and is used",
            bytes.len()
        )]
    );
    assert_eq!(strict_err(&bytes).location().field.as_deref(), Some("ANALOG:USED"));
    // The analog channels follow the layout read.
    let file = C3dFile::parse(&bytes, Path::new(ORIGIN)).unwrap();
    let layout = file.data_layout().unwrap();
    assert_eq!(layout.analog_words, 4);
    assert_eq!(
        file.analog_channel(&layout, 1).unwrap(),
        [10000.0, 10002.0, 10000.0, 10002.0, 10000.0, 10002.0]
    );
}

#[test]
fn a_data_section_that_fits_neither_account_is_refused() {
    // POINT:USED 200 needs far more than the file; the header's 2 points leave 600 bytes over.
    let mut spec = C3dSpec::small();
    spec.extra = vec![spec.raw_ints("POINT", "USED", &[200])];
    let mut bytes = spec.build();
    bytes.extend(vec![0u8; 600]);
    let e = err(&bytes);
    assert_eq!(
        (e.kind(), e.location().field.as_deref()),
        (ErrorKind::WrongValueCount, Some("POINT:USED"))
    );
    assert!(e.message().contains("fits neither account"), "{e}");
    assert!(
        e.message().contains("POINT:USED is 200 but the header says 2 points per frame"),
        "{e}"
    );
    // Both accounts longer than the file: truncated.
    let cut = &spec.build()[..spec.build().len() - 20];
    assert_eq!(err(cut).kind(), ErrorKind::Truncated);
}

#[test]
fn absurd_parameter_counts_are_checked_not_overflowed() {
    // ANALOG:RATE 1e30 Hz: 2 × 1e28 analog words per frame; POINT:USED 4e9, stored as a float.
    let mut rate = C3dSpec::small();
    rate.extra = vec![
        rate.raw_ints("ANALOG", "USED", &[2]),
        rate.raw_floats("ANALOG", "RATE", vec![], &[1e30]),
    ];
    let mut used = C3dSpec::small();
    used.extra = vec![used.raw_floats("POINT", "USED", vec![], &[4.0e9])];
    for spec in [rate, used] {
        // The header's account fits: read, the absurd parameter said.
        let m = parse(&spec.build()).unwrap();
        assert_eq!(m.position(2, 1), [12.0, 22.0, 32.0]);
        assert!(
            m.load_notes.repairs[0].contains("the header's account fits the file"),
            "{:?}",
            m.load_notes
        );
        // With bytes neither explains: refused, the impossible size said in words.
        let mut bytes = spec.build();
        bytes.extend([0u8; 600]);
        let e = err(&bytes);
        assert!(
            e.message().contains("fits neither account") && e.message().contains("bytes"),
            "{e}"
        );
    }
}

#[test]
fn bytes_after_the_last_frame_beyond_a_block_are_noted() {
    let mut bytes = C3dSpec::small().build();
    let n = bytes.len();
    bytes.extend(vec![0u8; 600]);
    let m = parse(&bytes).unwrap();
    assert_eq!(
        m.load_notes.repairs,
        [format!("600 bytes after the last frame (byte {n}) are not read")]
    );
    assert_eq!(strict_err(&bytes).kind(), ErrorKind::WrongValueCount);
    // Padding to the end of the block is no note.
    let mut padded = C3dSpec::small().build();
    padded.resize(padded.len().div_ceil(BLOCK) * BLOCK, 0);
    assert!(parse(&padded).unwrap().load_notes.repairs.is_empty());
}

#[test]
fn an_analog_rate_that_is_no_whole_multiple_keeps_the_header_and_says_so() {
    let mut spec = C3dSpec::small();
    spec.analog_per_frame = 4;
    spec.extra = vec![
        spec.raw_ints("ANALOG", "USED", &[2]),
        spec.raw_floats("ANALOG", "RATE", vec![], &[250.0]),
    ];
    let m = parse(&spec.build()).unwrap();
    assert_eq!(m.position(2, 1), [12.0, 22.0, 32.0]);
    assert_eq!(
        m.load_notes.repairs,
        [
            "ANALOG:RATE 250 Hz is not a whole multiple of POINT:RATE 100 Hz, so the parameters give no analog word count; the header's 4 words per frame are used"
        ]
    );
}

#[test]
fn a_unit_name_cut_short_is_the_unit_it_begins() {
    for (written, mm) in
        [("mete", 1000.0), ("metr", 1000.0), ("millim", 1.0), ("centi", 10.0), ("inch", 25.4)]
    {
        let mut spec = C3dSpec::small();
        spec.units = Some(written);
        let m = parse(&spec.build()).unwrap_or_else(|e| panic!("{written}: {e}"));
        assert!(close(m.position(0, 0), [mm, 2.0 * mm, 3.0 * mm], 1e-9), "{written}");
        assert!(m.load_notes.length_unit_from.contains(written), "{:?}", m.load_notes);
    }
    let mut spec = C3dSpec::small();
    spec.units = Some("mete");
    let m = parse(&spec.build()).unwrap();
    assert_eq!(
        m.load_notes.repairs,
        [r#"POINT:UNITS "mete" read as "meter" (a unit name cut short)"#]
    );
    assert_eq!(m.load_notes.length_unit, Some(motionlab_core::LengthUnit::Metre));
    let e = strict_err(&spec.build());
    assert_eq!(
        (e.kind(), e.location().field.as_deref()),
        (ErrorKind::OutOfRange, Some("POINT:UNITS"))
    );
    // Too short to say, or beginning no unit: refused as before.
    for bad in ["c", "mx", "furl"] {
        spec.units = Some(bad);
        assert_eq!(err(&spec.build()).kind(), ErrorKind::OutOfRange, "{bad}");
    }
}

/// Byte positions of every record's "offset to next" word in a hand-made file's parameter
/// section (walked independently of the reader).
fn offset_words(bytes: &[u8], processor: Processor) -> Vec<usize> {
    let mut pos = BLOCK + 4;
    let mut out = Vec::new();
    loop {
        let name_len = usize::from(bytes[pos]);
        if name_len == 0 {
            return out;
        }
        let at = pos + 2 + name_len;
        out.push(at);
        let w = [bytes[at], bytes[at + 1]];
        let next = if processor == Processor::Mips {
            i16::from_be_bytes(w)
        } else {
            i16::from_le_bytes(w)
        };
        pos = at + next as usize;
    }
}

#[test]
fn a_last_record_pointing_past_the_parameter_section_ends_it() {
    let mut spec = C3dSpec::small();
    spec.processor = Processor::Mips;
    let mut bytes = spec.build();
    let last = *offset_words(&bytes, Processor::Mips).last().unwrap();
    // SGI writers leave the last record pointing far past the section (into the data).
    bytes[last..last + 2].copy_from_slice(&30000i16.to_be_bytes());
    let m = parse(&bytes).unwrap();
    assert_eq!(m.position(2, 1), [12.0, 22.0, 32.0]);
    assert_eq!(m.load_notes.repairs.len(), 1, "{:?}", m.load_notes);
    assert!(
        m.load_notes.repairs[0]
            .contains("past the parameter section's end at byte 1024; read as the last record"),
        "{:?}",
        m.load_notes
    );
    let e = strict_err(&bytes);
    assert_eq!((e.kind(), e.location().byte_offset), (ErrorKind::Syntax, Some(last as u64)));
}

#[test]
fn names_with_spaces_and_parameters_defined_twice_are_read_with_notes() {
    let mut spec = C3dSpec::small();
    let width = spec.raw_floats("SUBJECT", "Pelvis Width", vec![], &[250.0]);
    spec.extra = vec![
        width,
        spec.raw_floats("SUBJECT", "MASS", vec![], &[70.0]),
        spec.raw_floats("SUBJECT", "MASX", vec![], &[80.0]),
    ];
    let mut bytes = spec.build();
    // MASX → MASS: SUBJECT:MASS defined twice, 70 first.
    let at = bytes.windows(4).position(|w| w == b"MASX").unwrap();
    bytes[at + 3] = b'S';
    let file = C3dFile::parse(&bytes, Path::new(ORIGIN)).unwrap();
    assert_eq!(file.param("SUBJECT", "pelvis width").unwrap().floats(file.ctx).unwrap(), [250.0]);
    assert_eq!(file.param("SUBJECT", "MASS").unwrap().floats(file.ctx).unwrap(), [70.0]);
    let m = parse(&bytes).unwrap();
    assert_eq!(
        m.load_notes.repairs,
        [
            r#"group or parameter names with spaces accepted: "Pelvis Width""#,
            "1 parameters defined twice, the first definition of each kept: SUBJECT:MASS"
        ]
    );
    let e = strict_err(&bytes);
    assert_eq!(e.kind(), ErrorKind::Syntax);
    assert!(e.message().contains("\"Pelvis Width\" has a space"), "{e}");
    // A byte that is no printable ASCII is named in the message.
    let mut bad = bytes.clone();
    let at = bad.windows(5).position(|w| w == b"Width").unwrap();
    bad[at] = 0x07;
    let e = err(&bad);
    assert_eq!((e.kind(), e.location().byte_offset), (ErrorKind::Syntax, Some(at as u64)));
    assert!(e.message().contains("byte 0x07") && !e.message().contains("space is"), "{e}");
}

#[test]
fn event_arrays_shorter_than_event_used_are_errors() {
    let mut spec = C3dSpec::small();
    spec.events = vec![("Foot Strike", "Left", 0.0, 0.01), ("Foot Off", "Left", 0.0, 0.02)];
    spec.extra = vec![spec.raw_ints("EVENT", "USED", &[3])];
    let e = err(&spec.build());
    assert_eq!(
        (e.kind(), e.location().field.as_deref()),
        (ErrorKind::WrongValueCount, Some("EVENT:TIMES"))
    );
    let mut spec = C3dSpec::small();
    spec.events = vec![("Foot Strike", "Left", 0.0, f32::INFINITY)];
    let e = err(&spec.build());
    assert_eq!(
        (e.kind(), e.location().field.as_deref()),
        (ErrorKind::NonFinite, Some("EVENT:TIMES"))
    );
}

#[test]
fn a_backward_parameter_chain_is_an_error_not_a_loop() {
    let bytes = C3dSpec::small().build();
    // First record (a group) starts at BLOCK + 4: len, id, name, then its offset word.
    let name_len = usize::from(bytes[BLOCK + 4]);
    let mut bad = bytes.clone();
    let at = BLOCK + 4 + 2 + name_len;
    bad[at..at + 2].copy_from_slice(&(-6i16).to_le_bytes());
    let e = err(&bad);
    assert_eq!((e.kind(), e.location().byte_offset), (ErrorKind::Syntax, Some(at as u64)));
}

#[test]
fn no_prefix_or_corruption_of_a_valid_file_panics() {
    let mut spec = C3dSpec::small();
    spec.events = vec![("Foot Strike", "Left", 0.0, 0.01)];
    spec.analog_per_frame = 2;
    let bytes = spec.build();
    for len in 0..bytes.len() {
        let _ = parse(&bytes[..len]);
    }
    let mut rng = motionlab_testkit::Rng::new(0xC3D);
    let mut below = |n: usize| (rng.next_u64() % n as u64) as usize;
    let mut errors = 0;
    for _ in 0..4000 {
        let mut b = bytes.clone();
        for _ in 0..1 + below(4) {
            let i = below(b.len());
            b[i] = below(256) as u8;
        }
        errors += usize::from(parse(&b).is_err());
    }
    // Many flips land in unused padding; but the header and parameters are small targets,
    // so some must have been caught.
    assert!(errors > 0);
}

#[test]
fn registered_with_defaults_and_rejects_unknown_keys() {
    let loader = build_loader("c3d", &motionlab_core::registry::default_params()).unwrap();
    assert_eq!(loader.extensions(), ["c3d"]);
    let v: toml::Value = toml::from_str("up_axis = \"y\"").unwrap();
    let p: C3dParams = parse_params(&v).unwrap();
    assert_eq!(p.up_axis, Axis::Y);
    let typo: toml::Value = toml::from_str("up = \"y\"").unwrap();
    assert_eq!(parse_params::<C3dParams>(&typo).unwrap_err().kind(), ErrorKind::UnknownKey);
    let entry = motionlab_core::registry::find("c3d").unwrap();
    assert!(entry.params().iter().all(|p| p.default.is_some() && !p.description.is_empty()));
}

/// `C3dSpec::small()` with two analog words a frame (one sample of two channels at 100 Hz).
fn with_analog(labels: &[&str], rate: f32) -> Vec<u8> {
    let mut spec = C3dSpec::small();
    spec.analog_per_frame = 2;
    let width = labels.iter().map(|l| l.len()).max().unwrap_or(1);
    spec.extra = vec![
        spec.raw_ints("ANALOG", "USED", &[2]),
        spec.raw_floats("ANALOG", "RATE", vec![], &[rate]),
        C3dSpec::raw_chars("ANALOG", "LABELS", width, labels),
    ];
    spec.build()
}

fn analog_options(strict: bool) -> C3dOptions {
    C3dOptions { analog: true, strict, ..C3dOptions::default() }
}

#[test]
fn analog_channels_load_at_their_rate_with_repeated_labels_made_unique() {
    let bytes = with_analog(&["EMG", "EMG"], 100.0);
    let m = parse_c3d(&bytes, Path::new(ORIGIN), &analog_options(false)).unwrap();
    assert_eq!(m.n_points(), 0);
    assert_eq!(m.channels().names(), ["EMG", "EMG#2"]);
    // No ANALOG:UNITS, OFFSET, SCALE or GEN_SCALE: unitless words as stored (the filler).
    assert_eq!(m.channels().units(), ["", ""]);
    assert_eq!(m.channels().values(), [9999.0, 10000.0, 9999.0, 10000.0, 9999.0, 10000.0]);
    assert_eq!(m.frame_rate().hz(), 100.0);
    assert_eq!(
        m.load_notes.repairs,
        ["duplicate analog labels made unique: \"EMG\" (channel 2) → EMG#2"]
    );
    let e = parse_c3d(&bytes, Path::new(ORIGIN), &analog_options(true)).unwrap_err();
    assert_eq!(e.location().field.as_deref(), Some("ANALOG:LABELS"));
    assert!(e.to_string().contains(ORIGIN), "{e}");
    // The points are still what the default reading gives.
    assert_eq!(parse(&bytes).unwrap().position(2, 1), [12.0, 22.0, 32.0]);
}

#[test]
fn an_analog_rate_the_data_do_not_hold_is_read_at_the_datas_rate_and_said() {
    // One sample a 100 Hz frame, while ANALOG:RATE says 150 Hz.
    let bytes = with_analog(&["Fz", ""], 150.0);
    let m = parse_c3d(&bytes, Path::new(ORIGIN), &analog_options(false)).unwrap();
    assert_eq!(m.frame_rate().hz(), 100.0);
    // A blank label is named by its channel number.
    assert_eq!(m.channels().names(), ["Fz", "A2"]);
    // The data layout's note (the parameters give no word count), then the rate's.
    assert_eq!(m.load_notes.repairs.len(), 2, "{:?}", m.load_notes);
    assert!(m.load_notes.repairs[1].starts_with("ANALOG:RATE is 150 Hz"), "{:?}", m.load_notes);
    let e = parse_c3d(&bytes, Path::new(ORIGIN), &analog_options(true)).unwrap_err();
    assert!(e.to_string().contains(ORIGIN) && e.to_string().contains("ANALOG:RATE"), "{e}");
}

#[test]
fn a_file_with_neither_points_nor_analog_is_refused_naming_analog_used() {
    let mut spec = C3dSpec::small();
    spec.labels.clear();
    spec.frames = vec![Vec::new(); 3];
    let e = err(&spec.build());
    assert_eq!(e.kind(), ErrorKind::EmptySequence);
    assert_eq!(e.location().field.as_deref(), Some("ANALOG:USED"));
    assert!(e.to_string().contains("no 3-D points and no analog channels"), "{e}");
}
