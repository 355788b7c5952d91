//! `motionlab inspect`: ffprobe for mocap files.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use serde::Serialize;

use motionlab_core::registry::{self, Build, StageKind};
use motionlab_core::{Error, ErrorKind, Loader, Motion, Result};

#[derive(Serialize)]
struct Report {
    file: String,
    format: String,
    frames: usize,
    frame_rate_hz: f64,
    duration_s: f64,
    point_kind: motionlab_core::PointKind,
    up_axis: String,
    points: Vec<String>,
    missing_samples: usize,
    missing_percent: f64,
    skeleton_joints: Option<usize>,
    skeleton_channels: Option<usize>,
    events: Vec<EventRow>,
}

#[derive(Serialize)]
struct EventRow {
    label: String,
    context: String,
    time_s: f64,
    frame: f64,
}

/// The loader registered for a file's extension, at its default parameters.
pub(crate) fn loader_for(path: &Path) -> Result<(&'static str, Box<dyn Loader>)> {
    let ext = motionlab_core::paths::format_extension(path).unwrap_or_default();
    let mut known = Vec::new();
    for p in registry::plugins().into_iter().filter(|p| p.kind == StageKind::Loader) {
        if let Build::Loader(build) = p.build {
            let loader = build(&registry::default_params())?;
            if loader.extensions().contains(&ext.as_str()) {
                return Ok((p.name, loader));
            }
            known.extend(loader.extensions().iter().map(|e| e.to_string()));
        }
    }
    Err(Error::new(ErrorKind::UnknownPlugin, format!("no loader reads .{ext} files (known: {})", known.join(", ")))
        .with_location(motionlab_core::Location::file(path)))
}

fn report(path: &Path) -> Result<Report> {
    let (name, loader) = loader_for(path)?;
    let m: Motion = loader.load(path).map_err(|e| e.in_file(path))?;
    let total = m.n_frames() * m.n_points();
    Ok(Report {
        file: path.display().to_string(),
        format: name.to_string(),
        frames: m.n_frames(),
        frame_rate_hz: m.frame_rate().hz(),
        duration_s: m.duration().value(),
        point_kind: m.point_kind(),
        up_axis: m.up_axis().to_string(),
        points: m.point_names().to_vec(),
        missing_samples: m.missing_count(),
        missing_percent: if total == 0 { 0.0 } else { 100.0 * m.missing_count() as f64 / total as f64 },
        skeleton_joints: m.skeleton.as_ref().map(|s| s.skeleton.joints.len()),
        skeleton_channels: m.skeleton.as_ref().map(|s| s.n_channels()),
        events: m.events.iter().map(|e| EventRow { label: e.label.clone(), context: e.context.clone(), time_s: e.time.value(), frame: e.frame }).collect(),
    })
}

fn text(r: &Report) -> String {
    let mut s = format!("{}\n", r.file);
    s += &format!("  format    {}\n", r.format);
    s += &format!("  frames    {} at {} Hz ({:.3} s)\n", r.frames, r.frame_rate_hz, r.duration_s);
    let kind = match r.point_kind {
        motionlab_core::PointKind::Marker => "markers",
        motionlab_core::PointKind::Joint => "joints",
    };
    s += &format!("  {kind:<9} {}: {}\n", r.points.len(), r.points.join(" "));
    s += &format!("  missing   {} samples ({:.2} %)\n", r.missing_samples, r.missing_percent);
    s += &format!("  up axis   {}\n", r.up_axis);
    if let (Some(j), Some(c)) = (r.skeleton_joints, r.skeleton_channels) {
        s += &format!("  skeleton  {j} joints, {c} channels\n");
    }
    if r.events.is_empty() {
        s += "  events    none\n";
    } else {
        s += &format!("  events    {}\n", r.events.len());
        for e in &r.events {
            s += &format!("            {:>8.3} s  frame {:>8.2}  {} ({})\n", e.time_s, e.frame, e.label, e.context);
        }
    }
    s
}

/// Inspects every file; a bad file prints its one-line error and makes the exit code non-zero,
/// but the other files are still described.
pub fn inspect(files: &[PathBuf], json: bool) -> Result<ExitCode> {
    if files.is_empty() {
        return Err(Error::new(ErrorKind::MissingKey, "inspect needs at least one file"));
    }
    let mut ok = true;
    let mut reports = Vec::new();
    for f in files {
        match report(f) {
            Ok(r) => {
                if !json {
                    print!("{}", text(&r));
                }
                reports.push(r);
            }
            Err(e) => {
                eprintln!("error: {e}");
                ok = false;
            }
        }
    }
    if json {
        println!("{}", serde_json::to_string_pretty(&reports).unwrap_or_default());
    }
    Ok(if ok { ExitCode::SUCCESS } else { ExitCode::from(1) })
}
