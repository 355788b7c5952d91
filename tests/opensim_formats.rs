//! OpenSim's exchange formats end to end through the command: `motionlab convert` round trips
//! (TRC → TRC in another unit, C3D/BVH/ASF-AMC → TRC, → CSV, MOT → CSV) read back to the same
//! values within text rounding, `inspect` says what the TRC/MOT loaders repaired, and
//! `motionlab new` + `run` work on a folder of TRC files with a truth CSV as on C3D.

use std::path::Path;

use motionlab_core::Motion;
use motionlab_core::registry::{build_loader, default_params};

use crate::own_annotations::{motionlab_ok, read_table, run_dir};

fn repo(p: &str) -> String {
    motionlab_testkit::repo_root().join(p).to_str().unwrap().to_string()
}

fn load(loader: &str, path: &Path) -> Motion {
    build_loader(loader, &default_params()).unwrap().load(path).unwrap_or_else(|e| panic!("{e}"))
}

/// Positions equal to within `rel` relative (text rounding), missing at the same samples.
fn assert_close(a: &Motion, b: &Motion, rel: f64, what: &str) {
    assert_eq!(a.point_names(), b.point_names(), "{what}");
    assert_eq!(a.n_frames(), b.n_frames(), "{what}");
    assert_eq!(a.missing_mask(), b.missing_mask(), "{what}");
    assert!((a.frame_rate().hz() - b.frame_rate().hz()).abs() <= 1e-12 * b.frame_rate().hz());
    for (p, q) in a.positions().iter().zip(b.positions()) {
        for k in 0..3 {
            assert!(
                (p[k].is_nan() && q[k].is_nan())
                    || (p[k] - q[k]).abs() <= rel * q[k].abs().max(1.0),
                "{what}: {p:?} vs {q:?}"
            );
        }
    }
}

#[test]
fn convert_to_trc_reads_back_to_the_same_values() {
    let tmp = tempfile::tempdir().unwrap();
    let cases = [
        ("data/formats/opensim-core/dataWithBlanksForMissingMarkers.trc", "trc", "m"),
        ("data/formats/opensim-core/dataWithEformat.trc", "trc", "mm"),
        ("data/mct/walk1.c3d.gz", "c3d", "mm"),
        ("data/cmu131/131_03.bvh.gz", "bvh", "cm"),
        ("data/mocap6/amc/13_29.amc.gz", "asf_amc", "m"),
    ];
    for (k, (input, loader, unit)) in cases.iter().enumerate() {
        let out = tmp.path().join(format!("{k}.trc"));
        let said = motionlab_ok(&["convert", "--units", unit, &repo(input), out.to_str().unwrap()]);
        assert!(said.starts_with(&format!("wrote {}", out.display())), "{said}");
        let original = load(loader, Path::new(&repo(input)));
        let back = load("trc", &out);
        // Shortest round-trip decimals, scaled once to the unit and back: a few ulps.
        assert_close(&back, &original, 1e-12, input);
        assert_eq!(back.load_notes.length_unit_from, format!("Units {unit:?} (line 3)"));
    }
    // The missing samples survive as empty cells (walk1 has 27; the Mokka file many).
    let walk1 = load("trc", &tmp.path().join("2.trc"));
    assert_eq!(walk1.missing_count(), 27);
}

#[test]
fn convert_to_csv_writes_positions_or_channels() {
    let tmp = tempfile::tempdir().unwrap();
    let csv = tmp.path().join("walk.csv");
    let trc = repo("data/formats/opensim-core/walk_free_01.trc");
    motionlab_ok(&["convert", &trc, csv.to_str().unwrap()]);
    let rows = read_table(&csv);
    let m = load("trc", Path::new(&trc));
    assert_eq!(rows.len(), m.n_frames());
    assert_eq!(rows[0]["R.ASIS_x_mm"].parse::<f64>().unwrap(), m.position(0, 0)[0]);
    assert_eq!(rows[0]["R.ASIS_x_mm"], "596.88123");
    // MOT joint angles: one column per channel, repeated labels renamed.
    let mot = repo("data/formats/opensim-core/subject01_walk1_ik.mot");
    let out = tmp.path().join("ik.csv");
    let said = motionlab_ok(&["convert", &mot, out.to_str().unwrap()]);
    assert!(said.contains("73 frames, 164 channels"), "{said}");
    let text = std::fs::read_to_string(&out).unwrap();
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    assert_eq!(&header[..3], ["time_s", "pelvis_tx", "pelvis_ty"]);
    assert!(header.contains(&"ground_force_vx#2"));
    let first: Vec<&str> = text.lines().nth(1).unwrap().split(',').collect();
    assert_eq!(&first[1..4], ["0.60175322", "1.04544757", "-0.02167535"]);
    // TRC needs positions: a channel motion is refused with one clear line.
    let refused = crate::motionlab_command()
        .args(["convert", &mot, tmp.path().join("x.trc").to_str().unwrap()])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(!refused.status.success() && err.contains("holds channels and no marker"), "{err}");
}

#[test]
fn inspect_says_what_the_trc_and_mot_loaders_repaired() {
    let said = motionlab_ok(&[
        "inspect",
        &repo("data/formats/opensim-core/walk_free_01.trc"),
        &repo("data/formats/opensim-core/subject01_walk1_ik.mot"),
    ]);
    for expected in [
        "format    trc",
        "frames    73 at 60 Hz",
        "unit      mm — Units \"mm\" (line 3)",
        "repaired  NumFrames says 900; 73 rows are present: read 73",
        "repaired  the first row is Frame# 185 at 3.067 s",
        "format    mot",
        "channels  164: pelvis_tx pelvis_ty",
        "unit      angles in degrees: no inDegrees in the header, OpenSim's Storage assumes degrees",
        "repaired  column label \"ground_force_vx\" repeats",
    ] {
        assert!(said.contains(expected), "{expected:?} not in:\n{said}");
    }
}

/// `motionlab new` on a folder of TRC files with a truth CSV writes an experiment that
/// validates and runs, as on C3D: the `trc` loader, a root from the hip markers, the
/// precision/recall table for each annotated take.
#[test]
fn new_and_run_on_a_folder_of_trc_files() {
    let tmp = tempfile::tempdir().unwrap();
    let folder = tmp.path().join("trials");
    std::fs::create_dir(&folder).unwrap();
    for f in [
        "data/formats/opencap-processing/walk.trc",
        "data/formats/pose2sim/S00_P00_T01_BalancingTrial_0-100_filt_butterworth.trc",
    ] {
        let src = motionlab_testkit::repo_root().join(f);
        std::fs::copy(&src, folder.join(src.file_name().unwrap())).unwrap();
    }
    std::fs::write(
        folder.join("truth.csv"),
        "sequence,time_s,label,annotator\nwalk,1.2,step,a\nwalk,2.4,step,a\n\
         S00_P00_T01_BalancingTrial_0-100_filt_butterworth,0.8,shift,a\n",
    )
    .unwrap();
    let toml = tmp.path().join("trials.toml");
    let said = motionlab_ok(&[
        "new",
        folder.to_str().unwrap(),
        "--truth",
        folder.join("truth.csv").to_str().unwrap(),
        "-o",
        toml.to_str().unwrap(),
    ]);
    assert!(said.contains("(valid)"), "{said}");
    let text = std::fs::read_to_string(&toml).unwrap();
    assert!(text.contains("loader = { type = \"trc\" }"), "{text}");
    let reports = tmp.path().join("reports");
    motionlab_ok(&[
        "run",
        toml.to_str().unwrap(),
        "--reports",
        reports.to_str().unwrap(),
        "--quiet",
    ]);
    let name = toml::from_str::<toml::Table>(&text).unwrap()["experiment"]["name"]
        .as_str()
        .unwrap()
        .to_string();
    let rows = read_table(&run_dir(&reports, &name).join("tables/table1_precision_recall.csv"));
    let mut sequences: Vec<&str> =
        rows.iter().filter(|r| r["method"] == "fused").map(|r| r["sequence"].as_str()).collect();
    sequences.sort();
    assert_eq!(sequences, ["S00_P00_T01_BalancingTrial_0-100_filt_butterworth", "pooled", "walk"]);
}
