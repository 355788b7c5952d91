//! TRC and MOT/STO conformance on the shipped OpenSim exchange files (`data/formats/`, see its
//! README): one test per file. Each loads through the registered loader, and its frames, rate,
//! units, point (column) count, labels and first values equal the file's row of
//! `references.csv` — read by OpenSim 4.6's Python API (`TimeSeriesTableVec3` for TRC,
//! `TimeSeriesTable`/`Storage` for MOT/STO), not by this project's code. CI compares with
//! OpenSim itself as well (`bench/opensim_crosscheck.py`).
//!
//! The quirks each file has (README: NumFrames ≠ rows, Frame# from 185, blank cells, E
//! notation, duplicate labels, wrong header counts, no `inDegrees`) are asserted to be said in
//! the motion's load notes.

use std::path::{Path, PathBuf};

use motionlab_core::registry::{build_loader, default_params};
use motionlab_core::{LengthUnit, Motion};
use motionlab_io::mot::{StorageFile, parse_storage};
use motionlab_io::read::read_text;
use motionlab_io::trc::{TrcFile, parse_trc};
use motionlab_testkit::data_path;

/// A row of a folder's `references.csv`.
struct Reference {
    frames: usize,
    rate: String,
    units: String,
    n_points: usize,
    first: [f64; 3],
    notes: String,
}

fn reference(file: &str) -> Reference {
    let (folder, name) = file.split_once('/').unwrap();
    let path = data_path(&format!("formats/{folder}/references.csv"));
    let mut reader = csv::Reader::from_path(&path).unwrap();
    for row in reader.records() {
        let row = row.unwrap();
        if row[0] == *name {
            let first: Vec<f64> = row[6]
                .split_whitespace()
                .map(|v| if v == "nan" { f64::NAN } else { v.parse().unwrap() })
                .collect();
            return Reference {
                frames: row[2].parse().unwrap(),
                rate: row[3].to_string(),
                units: row[4].to_string(),
                n_points: row[5].parse().unwrap(),
                first: [first[0], first[1], first[2]],
                notes: row[7].to_string(),
            };
        }
    }
    panic!("{file} has no row in {}", path.display());
}

/// The labels a note lists after `key=` (`a|b|c`).
fn labels_in(notes: &str, key: &str) -> Vec<String> {
    let start = notes.find(key).unwrap_or_else(|| panic!("no {key} in {notes}")) + key.len();
    notes[start..].split(';').next().unwrap().trim().split('|').map(str::to_string).collect()
}

fn same(a: f64, b: f64) -> bool {
    (a.is_nan() && b.is_nan()) || a == b
}

fn path(file: &str) -> PathBuf {
    data_path(&format!("formats/{file}"))
}

fn load(loader: &str, file: &str) -> Motion {
    build_loader(loader, &default_params())
        .unwrap()
        .load(&path(file))
        .unwrap_or_else(|e| panic!("{e}"))
}

/// Checks a TRC file against its reference; returns what was read and the loaded motion.
fn check_trc(file: &str) -> (TrcFile, Motion) {
    let r = reference(file);
    let trc = parse_trc(&read_text(&path(file)).unwrap(), Path::new(file)).unwrap();
    let motion = load("trc", file);
    assert_eq!(trc.n_frames(), r.frames, "frames");
    assert_eq!(motion.n_frames(), r.frames, "frames");
    assert_eq!(trc.rate_hz, r.rate.parse::<f64>().unwrap(), "rate");
    assert_eq!(motion.frame_rate().hz(), trc.rate_hz);
    assert_eq!(trc.units, r.units, "units");
    let mm = trc.unit.millimetres_per_unit();
    assert_eq!(motion.load_notes.length_unit, Some(trc.unit));
    assert_eq!(motion.n_points(), r.n_points, "points");
    assert_eq!(motion.point_names(), labels_in(&r.notes, "marker_labels="), "labels");
    for k in 0..3 {
        assert!(same(trc.positions[0][k], r.first[k]), "{:?} vs {:?}", trc.positions[0], r.first);
        let back = motion.position(0, 0)[k] / mm;
        assert!(
            (r.first[k].is_nan() && back.is_nan())
                || (back - r.first[k]).abs() <= 1e-12 * r.first[k].abs(),
            "{back} vs {}",
            r.first[k]
        );
    }
    assert_eq!(motion.is_missing(0, 0), r.first[0].is_nan());
    (trc, motion)
}

/// Checks a MOT/STO file against its reference.
fn check_storage(file: &str) -> (StorageFile, Motion) {
    let r = reference(file);
    let s = parse_storage(&read_text(&path(file)).unwrap(), Path::new(file)).unwrap();
    let motion = load("mot", file);
    assert_eq!(s.n_rows(), r.frames, "frames");
    assert_eq!(motion.n_frames(), r.frames, "frames");
    // The reference's rate is 1 / (first time step) to 4 significant digits; the loader's is
    // the mean step's, which the uneven steps of few-decimal times make differ from it.
    let reference_hz: f64 = r.rate.split_whitespace().next().unwrap().parse().unwrap();
    let first_step_hz = 1.0 / (s.times[1] - s.times[0]);
    let half_digit = 0.5 * 10f64.powi(reference_hz.log10().floor() as i32 - 3);
    assert!((first_step_hz - reference_hz).abs() <= half_digit, "{first_step_hz} vs {}", r.rate);
    let n = s.n_rows();
    let mean_hz = (n - 1) as f64 / (s.times[n - 1] - s.times[0]);
    assert!((motion.frame_rate().hz() - mean_hz).abs() < 1e-9 * mean_hz);
    let unit = match s.in_degrees {
        None => "not stated (OpenSim Storage assumes degrees)",
        Some(true) => "degrees (inDegrees=yes)",
        Some(false) => "radians (inDegrees=no)",
    };
    assert_eq!(unit, r.units, "units");
    assert!(motion.load_notes.length_unit_from.contains(s.angle_unit()));
    assert_eq!(motion.channels().n_channels(), r.n_points, "columns");
    let labels = labels_in(&r.notes, "column_labels=");
    assert_eq!(labels[0], s.time_label);
    // Repeated labels are renamed `label#k`; the names before `#` are the file's.
    let stripped: Vec<&str> =
        motion.channels().names().iter().map(|n| n.split('#').next().unwrap()).collect();
    assert_eq!(stripped, labels[1..], "labels");
    for k in 0..3 {
        assert!(same(motion.channels().values()[k], r.first[k]), "{k}");
    }
    (s, motion)
}

fn said(m: &Motion, phrase: &str) {
    let notes = m.load_notes.repairs.join("\n");
    assert!(notes.contains(phrase), "{phrase:?} not in the load notes:\n{notes}");
}

#[test]
fn marker_trajectories_trc() {
    let (_, m) = check_trc("opensim-core/marker_trajectories.trc");
    said(&m, "data rows end with empty cells (trailing TABs)");
    assert_eq!(m.missing_count(), 0);
}

#[test]
fn walk_free_01_trc_numframes_900_for_73_rows_from_frame_185() {
    let (trc, m) = check_trc("opensim-core/walk_free_01.trc");
    assert_eq!(trc.header_value("NumFrames"), Some("900"));
    assert_eq!((trc.frame_numbers[0], trc.times[0]), (185.0, 3.067));
    said(&m, "NumFrames says 900; 73 rows are present");
    said(&m, "Frame# 185 at 3.067 s");
}

#[test]
fn data_with_blanks_trc_written_by_mokka() {
    let (trc, m) = check_trc("opensim-core/dataWithBlanksForMissingMarkers.trc");
    // The reference's note gives the first sample present when row 1 is empty.
    let r = reference("opensim-core/dataWithBlanksForMissingMarkers.trc");
    assert!(r.notes.contains("OrigNumFrames=1103"));
    assert!(m.missing_count() > 0);
    assert!(m.frame_missing(0).iter().all(|g| *g), "row 1 is blank for every marker");
    said(&m, "samples are empty cells: read as missing");
    // No empty cell reads as zero.
    assert!(
        trc.positions
            .iter()
            .all(|p| p.iter().all(|c| c.is_nan()) || p.iter().all(|c| c.is_finite()))
    );
}

#[test]
fn data_with_eformat_trc_fractional_rate_metres() {
    let (trc, m) = check_trc("opensim-core/dataWithEformat.trc");
    assert_eq!(trc.rate_hz, 119.88012);
    assert_eq!(trc.unit, LengthUnit::Metre);
    // -2.73E-01 m is -273 mm.
    assert!((m.position(0, 0)[0] + 273.0).abs() < 1e-9);
    said(&m, "Frame# 1 at 0.008342 s");
}

#[test]
fn pose2sim_trc() {
    let (trc, m) = check_trc("pose2sim/S00_P00_T01_BalancingTrial_0-100_filt_butterworth.trc");
    assert_eq!(trc.header_value("OrigDataStartFrame"), Some("0"));
    assert_eq!(trc.unit, LengthUnit::Metre);
    assert_eq!(m.missing_count(), 0);
}

#[test]
fn opencap_walk_trc_63_markers() {
    let (trc, _) = check_trc("opencap-processing/walk.trc");
    assert_eq!(trc.labels.len(), 63);
}

#[test]
fn subject01_walk1_ik_mot_hybrid_header_duplicate_labels() {
    let (s, m) = check_storage("opensim-core/subject01_walk1_ik.mot");
    assert_eq!(s.in_degrees, None);
    said(&m, "column label \"ground_force_vx\" repeats");
    said(&m, "no inDegrees in the header: angles read as degrees");
    said(&m, "time steps range from");
    assert!((m.frame_rate().hz() - 60.0).abs() < 1e-9);
}

#[test]
fn subject01_walk1_grf_mot_simm_header() {
    let (_, m) = check_storage("opensim-core/subject01_walk1_grf.mot");
    assert!((m.frame_rate().hz() - 600.0).abs() < 1e-9);
    assert!(m.channels().names().iter().all(|n| !n.starts_with(' ')), "labels are trimmed");
}

#[test]
fn reference_coordinates_sto_version_1_radians() {
    let (s, _) = check_storage("opensim-core/referenceCoordinates.sto");
    assert_eq!(s.in_degrees, Some(false));
}

#[test]
fn coordinates_sto_version_3_ncolumns_wrong() {
    let (_, m) = check_storage("opensim-core/coordinates.sto");
    said(&m, "nColumns says 40; 32 columns are present");
    assert!((m.frame_rate().hz() - 1000.0).abs() < 1e-6);
}

#[test]
fn pose2sim_ik_mot_degrees() {
    let (s, _) =
        check_storage("pose2sim/S00_P00_T01_BalancingTrial_filt_butterworth_0-100_body25b.mot");
    assert_eq!(s.in_degrees, Some(true));
}

/// Every TRC/MOT/STO shipped is one of the files tested above, and every reference row of one
/// is tested: a sample added without its test fails here.
#[test]
fn every_shipped_sample_has_its_test() {
    let tested = [
        "opensim-core/marker_trajectories.trc",
        "opensim-core/walk_free_01.trc",
        "opensim-core/dataWithBlanksForMissingMarkers.trc",
        "opensim-core/dataWithEformat.trc",
        "pose2sim/S00_P00_T01_BalancingTrial_0-100_filt_butterworth.trc",
        "opencap-processing/walk.trc",
        "opensim-core/subject01_walk1_ik.mot",
        "opensim-core/subject01_walk1_grf.mot",
        "opensim-core/referenceCoordinates.sto",
        "opensim-core/coordinates.sto",
        "pose2sim/S00_P00_T01_BalancingTrial_filt_butterworth_0-100_body25b.mot",
    ];
    let mut shipped = Vec::new();
    for folder in std::fs::read_dir(data_path("formats")).unwrap() {
        let folder = folder.unwrap().path();
        if !folder.is_dir() {
            continue;
        }
        for f in std::fs::read_dir(&folder).unwrap() {
            let f = f.unwrap().path();
            if matches!(f.extension().and_then(|e| e.to_str()), Some("trc" | "mot" | "sto")) {
                let name = format!(
                    "{}/{}",
                    folder.file_name().unwrap().to_str().unwrap(),
                    f.file_name().unwrap().to_str().unwrap()
                );
                shipped.push(name);
            }
        }
    }
    shipped.sort();
    let mut want: Vec<String> = tested.iter().map(|s| s.to_string()).collect();
    want.sort();
    assert_eq!(shipped, want);
}
