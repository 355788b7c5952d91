//! Runs the walk analysis of Osafune et al. on the 36 Schreiber & Moissenet (2019) trials and
//! writes its tables as CSV, for `bench/osafune_check.py` (until the engine exports them) and
//! for a look at the numbers:
//!
//! ```text
//! cargo run --release -p motionlab-gait --example osafune_export -- [OUT_DIR]
//! ```
//!
//! OUT_DIR (default `target/osafune`) receives `gait_parameters.csv`, `change_rates.csv`,
//! `change_rate_summary.csv`, `frequency_changes.csv` (the `change_rates` evaluator's tables),
//! `loso_subjects.csv`, `loso_channels.csv`, `loso_channel_means.csv` (leave-one-subject-out),
//! and `131_01_fast.bvh`: CMU 131_01 with the fast-walking change rates applied to its leg
//! joints (marker-derived K mapped to BVH channels).

use std::io::Write;
use std::path::{Path, PathBuf};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{ColumnValues, Evaluator, Table};
use motionlab_features::gait_cycles::{C3dEventsParams, HeelHeightParams};
use motionlab_features::joint_angles::{AbsentMarkers, IsbJointAnglesParams};
use motionlab_features::waveform::WaveformParametersParams;
use motionlab_features::{GaitCycleDetector, WaveformAnalyzer};
use motionlab_gait::change_rates::ChangeRatesParams;
use motionlab_gait::loso::leave_one_subject_out;
use motionlab_gait::study::{AnalysedWalk, SubjectWalk, Walk, study_of};
use motionlab_gait::synthesis::{
    FeatureChannelControl, FeatureChannelControlParams, skeleton_rotation_channels,
};

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// Writes a table as CSV; floats with Rust's shortest round-trip formatting (`NaN` for NaN).
fn write_csv(table: &Table, dir: &Path) -> std::io::Result<PathBuf> {
    let path = dir.join(format!("{}.csv", table.name));
    let mut out = std::io::BufWriter::new(std::fs::File::create(&path)?);
    writeln!(
        out,
        "{}",
        table.columns.iter().map(|c| csv_field(&c.name)).collect::<Vec<_>>().join(",")
    )?;
    for row in 0..table.n_rows() {
        let cells: Vec<String> = table
            .columns
            .iter()
            .map(|c| match &c.values {
                ColumnValues::F64(v) => format!("{}", v[row]),
                other => csv_field(&other.cell(row)),
            })
            .collect();
        writeln!(out, "{}", cells.join(","))?;
    }
    Ok(path)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out_dir = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| motionlab_testkit::repo_root().join("target/osafune"));
    std::fs::create_dir_all(&out_dir)?;

    let angles = IsbJointAnglesParams { absent_markers: AbsentMarkers::Nan, ..Default::default() }
        .check()?;
    let analyzer = WaveformParametersParams::default().check()?;
    let detector = C3dEventsParams::default().check()?;
    let root = motionlab_testkit::data_path("schreiber2019");
    let mut paths: Vec<PathBuf> = std::fs::read_dir(&root)?
        .filter_map(|d| std::fs::read_dir(d.ok()?.path().join("dynamic")).ok())
        .flatten()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.to_string_lossy().ends_with(".c3d.gz"))
        .collect();
    paths.sort();
    let mut walks = Vec::new();
    for p in &paths {
        let bytes = motionlab_io::read::read_bytes(p)?;
        let motion =
            motionlab_io::c3d::parse_c3d(&bytes, p, &motionlab_io::c3d::C3dOptions::default())?;
        let mut parts = motion.name.split('_');
        let (subject, condition) = (
            parts.next().unwrap_or_default().to_string(),
            parts.next().unwrap_or_default().to_string(),
        );
        let curves = angles.angle_curves(&motion)?;
        let cycles = detector.cycles(&motion)?;
        let parameters = analyzer.parameters(&curves, &cycles)?;
        walks.push(SubjectWalk {
            subject,
            condition,
            analysed: AnalysedWalk { walk: Walk { curves, cycles }, parameters },
        });
    }
    let study = study_of("C4", &walks);
    let rates = ChangeRatesParams::default().check()?;
    for table in rates.evaluate(motionlab_core::EvalInput::new(&study))? {
        println!("wrote {}", write_csv(&table, &out_dir)?.display());
    }

    let analysis = rates.analyse(&study)?;
    let fast = analysis.condition("C5")?;
    println!(
        "\nFast vs normal (C5 vs C4), {} subjects; frequency K: μ {:.1} %, σ {:.1} %, CV {:.1} %",
        fast.subjects.len(),
        fast.frequency_mean_pct,
        fast.frequency_sd_pct,
        fast.frequency_cv_pct
    );
    for component in ["dc", "amplitude"] {
        println!("{component}: feature channels (|CV| <= {} %)", rates.max_abs_cv_pct);
        for s in fast.summary.iter().filter(|s| s.feature && s.component.name() == component) {
            println!(
                "  {:24} mean {:7.1} %  sd {:7.1} %  CV {:7.1} %  (n = {}, excluded {})",
                s.channel, s.mean_pct, s.sd_pct, s.cv_pct, s.n_subjects, s.n_excluded
            );
        }
    }

    let loso =
        leave_one_subject_out(&walks, "C4", "C5", &rates, &FeatureChannelControl::default(), 101)?;
    for table in loso.tables()? {
        println!("wrote {}", write_csv(&table, &out_dir)?.display());
    }
    let m = &loso.mean;
    println!(
        "\nLeave-one-subject-out, mean over {} subjects: RMS synthesised {:.2}° vs unchanged {:.2}° (controlled channels {:.2}° vs {:.2}°); \
         DTW {:.2}° vs {:.2}°; frequency {:.3} Hz synthesised, {:.3} recorded, {:.3} unchanged",
        loso.subjects.len(),
        m.rms_synth_deg,
        m.rms_normal_deg,
        m.rms_synth_controlled_deg,
        m.rms_normal_controlled_deg,
        m.dtw_synth_deg,
        m.dtw_normal_deg,
        m.frequency_synth_hz,
        m.frequency_recorded_hz,
        m.frequency_normal_hz
    );

    // Control of a skeleton walk: CMU 131_01 with the fast change rates on its leg joints.
    let bvh = motionlab_testkit::data_path("cmu131/131_01.bvh.gz");
    let text = motionlab_io::read::read_text(&bvh)?;
    let data = motionlab_io::bvh::parse_bvh_channels(
        &text,
        &bvh,
        &motionlab_io::bvh::BvhOptions::default(),
    )?;
    let motion = motionlab_io::bvh::bvh_motion(data.clone(), &bvh, motionlab_core::Axis::Y)?;
    let cycles = HeelHeightParams {
        left_heel: "LeftAnkle".into(),
        right_heel: "RightAnkle".into(),
        ..Default::default()
    }
    .check()?
    .cycles(&motion)?;
    let map = [
        ("hip_l.flexion", "LeftHip.Xrotation"),
        ("hip_r.flexion", "RightHip.Xrotation"),
        ("knee_l.flexion", "LeftKnee.Xrotation"),
        ("knee_r.flexion", "RightKnee.Xrotation"),
        ("ankle_l.flexion", "LeftAnkle.Xrotation"),
        ("ankle_r.flexion", "RightAnkle.Xrotation"),
    ];
    let control = FeatureChannelControlParams {
        channel_map: map.iter().map(|(a, b)| (a.to_string(), b.to_string())).collect(),
        ..Default::default()
    }
    .check()?;
    let changes = fast.walk_changes();
    for p in control.plan(&skeleton_rotation_channels(&data.motion.skeleton), &changes)? {
        println!(
            "131_01: {} ← {}: DC × {:.3}, amplitude × {:.3}",
            p.channel, p.source, p.dc_factor, p.amplitude_factor
        );
    }
    let synthesized =
        control.synthesize_skeleton(&data.motion, data.frame_rate, &cycles, &changes)?;
    let out = out_dir.join("131_01_fast.bvh");
    let mut file = std::io::BufWriter::new(std::fs::File::create(&out)?);
    motionlab_io::bvh::write_bvh(&synthesized, data.frame_rate, data.length_unit, &mut file)?;
    println!(
        "wrote {} ({} → {} frames, frequency × {:.3})",
        out.display(),
        data.motion.n_frames(),
        synthesized.n_frames(),
        1.0 + changes.frequency_percent / 100.0
    );
    Ok(())
}
