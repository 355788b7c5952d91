//! `motionlab inspect`: ffprobe for mocap files.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use serde::Serialize;

use motionlab_core::{Error, ErrorKind, LengthUnit, Motion, Result};

#[derive(Serialize)]
struct Report {
    file: String,
    format: String,
    frames: usize,
    /// `None`: the file does not say (a channel file without a time column).
    frame_rate_hz: Option<f64>,
    duration_s: Option<f64>,
    point_kind: motionlab_core::PointKind,
    /// `3d` (world positions, mm) or `2d` (image positions, px: video pose estimation).
    dimensionality: motionlab_core::Dimensionality,
    /// Whether the loader gave a per-sample confidence (pose estimation).
    confidence: bool,
    up_axis: String,
    points: Vec<String>,
    missing_samples: usize,
    missing_percent: f64,
    /// The file's length unit as the loader read or inferred it (`None`: not stated).
    length_unit: Option<LengthUnit>,
    length_unit_from: String,
    /// The extent of the figure along the up axis in the first frame with a sample.
    height_mm: Option<f64>,
    height_frame: Option<usize>,
    /// What the loader repaired to read the file (see the loader's documentation).
    repairs: Vec<String>,
    skeleton_joints: Option<usize>,
    skeleton_channels: Option<usize>,
    events: Vec<EventRow>,
    /// The motion's channels (a channel file's columns, an analog-only C3D's analog
    /// channels), at `frame_rate_hz`; empty for a marker or skeleton file.
    channels: Vec<ChannelRow>,
    /// A marker C3D's analog channels, at their own rate (what the `c3d` loader gives with
    /// `analog = true`); absent for other files.
    #[serde(skip_serializing_if = "Option::is_none")]
    analog: Option<AnalogReport>,
    /// Where `--npy` wrote the positions.
    #[serde(skip_serializing_if = "Option::is_none")]
    positions_npy: Option<String>,
    /// Where `--npy` wrote the channels (samples × channels), when there are any.
    #[serde(skip_serializing_if = "Option::is_none")]
    channels_npy: Option<String>,
}

#[derive(Serialize)]
struct ChannelRow {
    name: String,
    unit: String,
}

#[derive(Serialize)]
struct AnalogReport {
    rate_hz: f64,
    samples: usize,
    channels: Vec<ChannelRow>,
    /// Where `--npy` wrote them (samples × channels).
    #[serde(skip_serializing_if = "Option::is_none")]
    npy: Option<String>,
}

#[derive(Serialize)]
struct EventRow {
    label: String,
    context: String,
    time_s: f64,
    frame: f64,
}

/// The loader a file's extension picks (shared with the Python package's `load`).
pub use motionlab_engine::front::loader_for;

/// The extent along the up axis of the first frame holding any sample, and that frame.
fn first_height(m: &Motion) -> Option<(f64, usize)> {
    let up = m.up_axis().index();
    (0..m.n_frames()).find_map(|f| {
        let heights = m
            .frame(f)
            .iter()
            .zip(m.frame_missing(f))
            .filter(|(_, gone)| !**gone)
            .map(|(p, _)| p[up]);
        let (lo, hi) =
            heights.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), h| (lo.min(h), hi.max(h)));
        (lo <= hi).then_some((hi - lo, f))
    })
}

fn channel_rows(c: &motionlab_core::Channels) -> Vec<ChannelRow> {
    c.names()
        .iter()
        .zip(c.units())
        .map(|(name, unit)| ChannelRow { name: name.clone(), unit: unit.clone() })
        .collect()
}

/// Writes a motion's channels to `out` as samples × channels.
fn write_channels(out: &Path, c: &motionlab_core::Channels) -> Result<String> {
    let io = |e: std::io::Error| Error::io(out, e);
    let mut w = std::io::BufWriter::new(std::fs::File::create(out).map_err(io)?);
    motionlab_external::npy::write_matrix(&mut w, c.values(), c.n_samples(), c.n_channels())
        .map_err(io)?;
    std::io::Write::flush(&mut w).map_err(io)?;
    Ok(out.display().to_string())
}

/// A marker C3D's analog channels (the `c3d` loader with `analog = true`); `None` for other
/// formats and for a C3D without analog channels.
fn analog_of(
    format: &str,
    m: &Motion,
    path: &Path,
    npy: Option<&Path>,
) -> Result<Option<AnalogReport>> {
    if format != "c3d" || m.n_points() == 0 {
        return Ok(None);
    }
    let params = toml::from_str("analog = true").map_err(|e| {
        Error::new(ErrorKind::InvalidParameter, format!("analog loader parameters: {e}"))
    })?;
    let Ok(a) = motionlab_core::registry::build_loader("c3d", &params)?.load(path) else {
        return Ok(None);
    };
    let npy = match npy {
        Some(out) => Some(write_channels(&out.with_extension("analog.npy"), a.channels())?),
        None => None,
    };
    Ok(Some(AnalogReport {
        rate_hz: a.frame_rate().hz(),
        samples: a.n_frames(),
        channels: channel_rows(a.channels()),
        npy,
    }))
}

/// The motion as the loader reads it at its defaults, and whether its rate is known. A file
/// that stores no rate (a channel file without a time column; OpenPose, COCO and MediaPipe
/// keypoints) makes its loader ask for `rate_hz`: it is read at 1 Hz to describe its samples,
/// points and channels, with the rate unknown.
fn load_described(
    name: &str,
    loader: &dyn motionlab_core::Loader,
    path: &Path,
) -> Result<(Motion, bool)> {
    match loader.load(path) {
        Ok(m) => Ok((m, true)),
        Err(e)
            if e.kind() == ErrorKind::MissingKey
                && e.location().field.as_deref() == Some("rate_hz") =>
        {
            let mut params = toml::Table::new();
            params.insert("rate_hz".into(), toml::Value::Float(1.0));
            let loader = motionlab_core::registry::build_loader(name, &toml::Value::Table(params))?;
            Ok((loader.load(path).map_err(|e| e.in_file(path))?, false))
        }
        Err(e) => Err(e.in_file(path)),
    }
}

fn report(path: &Path, npy: Option<&Path>) -> Result<Report> {
    let (name, loader) = loader_for(path)?;
    let (m, rate_known) = load_described(name, &*loader, path)?;
    // A channel file's missing samples are its channels' (it has no points).
    let channel_file = m.n_points() == 0 && m.channels().n_channels() > 0;
    let (total, missing) = if channel_file {
        (m.n_frames() * m.channels().n_channels(), m.channels().missing_count())
    } else {
        (m.n_frames() * m.n_points(), m.missing_count())
    };
    let analog = analog_of(name, &m, path, npy)?;
    let channels_npy = match npy {
        Some(out) if !m.channels().is_empty() => {
            Some(write_channels(&out.with_extension("channels.npy"), m.channels())?)
        }
        _ => None,
    };
    let height = first_height(&m);
    let positions_npy = match npy {
        Some(out) => {
            let io = |e: std::io::Error| Error::io(out, e);
            let mut w = std::io::BufWriter::new(std::fs::File::create(out).map_err(io)?);
            motionlab_external::npy::write_positions(
                &mut w,
                m.positions(),
                m.n_frames(),
                m.n_points(),
            )
            .map_err(io)?;
            std::io::Write::flush(&mut w).map_err(io)?;
            Some(out.display().to_string())
        }
        None => None,
    };
    Ok(Report {
        file: path.display().to_string(),
        format: name.to_string(),
        frames: m.n_frames(),
        frame_rate_hz: rate_known.then(|| m.frame_rate().hz()),
        duration_s: rate_known.then(|| m.duration().value()),
        point_kind: m.point_kind(),
        dimensionality: m.dimensionality(),
        confidence: m.confidence().is_some(),
        up_axis: m.up_axis().to_string(),
        points: m.point_names().to_vec(),
        missing_samples: missing,
        missing_percent: if total == 0 { 0.0 } else { 100.0 * missing as f64 / total as f64 },
        length_unit: m.load_notes.length_unit,
        length_unit_from: m.load_notes.length_unit_from.clone(),
        height_mm: height.map(|h| h.0),
        height_frame: height.map(|h| h.1),
        repairs: m.load_notes.repairs.clone(),
        skeleton_joints: m.skeleton.as_ref().map(|s| s.skeleton.joints.len()),
        skeleton_channels: m.skeleton.as_ref().map(|s| s.n_channels()),
        events: m
            .events
            .iter()
            .map(|e| EventRow {
                label: e.label.clone(),
                context: e.context.clone(),
                time_s: e.time.value(),
                frame: e.frame,
            })
            .collect(),
        channels: channel_rows(m.channels()),
        analog,
        positions_npy,
        channels_npy,
    })
}

/// A rate to the 7 significant digits a file can mean: C3D stores rates as 32-bit floats
/// (`25.000001907…` is 25 Hz), BVH a frame time of a few decimals.
pub(crate) fn rate_text(hz: f64) -> String {
    if !hz.is_finite() || hz <= 0.0 {
        return hz.to_string();
    }
    let decimals = (6 - hz.log10().floor() as i32).max(0) as usize;
    let s = format!("{hz:.decimals$}");
    if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.').to_string() } else { s }
}

fn unit_text(unit: LengthUnit) -> &'static str {
    match unit {
        LengthUnit::Millimetre => "mm",
        LengthUnit::Centimetre => "cm",
        LengthUnit::Metre => "m",
        LengthUnit::Inch => "in",
        LengthUnit::CmuUnit => "CMU unit, 1/0.45 in",
    }
}

/// `EMG1 (V), Fz1 (N), …`; a channel without a unit is its name alone.
fn channel_list(rows: &[ChannelRow]) -> String {
    let each: Vec<String> = rows
        .iter()
        .map(
            |c| if c.unit.is_empty() { c.name.clone() } else { format!("{} ({})", c.name, c.unit) },
        )
        .collect();
    each.join(", ")
}

fn text(r: &Report) -> String {
    let mut s = format!("{}\n", r.file);
    s += &format!("  format    {}\n", r.format);
    s += &match (r.frame_rate_hz, r.duration_s) {
        (Some(hz), Some(d)) => {
            format!("  frames    {} at {} Hz ({d:.3} s)\n", r.frames, rate_text(hz))
        }
        _ if r.format == "channels" => format!(
            "  frames    {} at an unknown rate (no time_s column; give the channels loader rate_hz)\n",
            r.frames
        ),
        _ => format!(
            "  frames    {} at an unknown rate (the {} format stores none; give the loader rate_hz)\n",
            r.frames, r.format
        ),
    };
    if !r.channels.is_empty() && r.points.is_empty() {
        // A channel file: its channels and their missing samples; no figure to describe.
        let names: Vec<&str> = r.channels.iter().map(|c| c.name.as_str()).collect();
        s += &format!("  channels  {}: {}\n", r.channels.len(), names.join(" "));
        if r.channels.iter().any(|c| !c.unit.is_empty()) {
            s += &format!("  units     {}\n", channel_list(&r.channels));
        }
        s += &format!("  missing   {} samples ({:.2} %)\n", r.missing_samples, r.missing_percent);
        if !r.length_unit_from.is_empty() {
            s += &format!("  unit      {}\n", r.length_unit_from);
        }
        for repair in &r.repairs {
            s += &format!("  repaired  {repair}\n");
        }
        return s;
    }
    let kind = match r.point_kind {
        motionlab_core::PointKind::Marker => "markers",
        motionlab_core::PointKind::Joint => "joints",
    };
    s += &format!("  {kind:<9} {}: {}\n", r.points.len(), r.points.join(" "));
    if r.dimensionality == motionlab_core::Dimensionality::Two {
        s += &format!(
            "  space     2-D image positions (px, x right, y down){}\n",
            if r.confidence { ", with a confidence per sample" } else { "" }
        );
    }
    s += &format!("  missing   {} samples ({:.2} %)\n", r.missing_samples, r.missing_percent);
    s += &format!("  up axis   {}\n", r.up_axis);
    s += &match r.length_unit {
        Some(u) => format!("  unit      {} — {}\n", unit_text(u), r.length_unit_from),
        None if !r.length_unit_from.is_empty() => format!("  unit      {}\n", r.length_unit_from),
        None => "  unit      not stated by the loader (positions are mm)\n".to_string(),
    };
    s += &match (r.height_mm, r.height_frame) {
        (Some(h), Some(f)) => format!(
            "  height    {h:.0} {} along {} in frame {} (the figure's extent)\n",
            r.dimensionality.length_unit(),
            r.up_axis,
            f + 1
        ),
        _ => "  height    none (no sample in any frame)\n".to_string(),
    };
    for repair in &r.repairs {
        s += &format!("  repaired  {repair}\n");
    }
    if !r.channels.is_empty() {
        s += &format!(
            "  channels  {} at {} Hz: {}\n",
            r.channels.len(),
            r.frame_rate_hz.map(rate_text).unwrap_or_else(|| "an unknown rate".into()),
            channel_list(&r.channels)
        );
    }
    if let Some(a) = &r.analog {
        s += &format!(
            "  analog    {} channels, {} samples at {} Hz (loader c3d, analog = true): {}\n",
            a.channels.len(),
            a.samples,
            rate_text(a.rate_hz),
            channel_list(&a.channels)
        );
    }
    if let (Some(j), Some(c)) = (r.skeleton_joints, r.skeleton_channels) {
        s += &format!("  skeleton  {j} joints, {c} channels\n");
    }
    if r.events.is_empty() {
        s += "  events    none\n";
    } else {
        s += &format!("  events    {}\n", r.events.len());
        for e in &r.events {
            s += &format!(
                "            {:>8.3} s  frame {:>8.2}  {} ({})\n",
                e.time_s, e.frame, e.label, e.context
            );
        }
    }
    s
}

/// Inspects every file; a bad file prints its one-line error and makes the exit code non-zero,
/// but the other files are still described. With `npy`, file k's positions go to `npy/k.npy`.
pub fn inspect(files: &[PathBuf], json: bool, npy: Option<&Path>) -> Result<ExitCode> {
    if files.is_empty() {
        return Err(Error::new(ErrorKind::MissingKey, "inspect needs at least one file"));
    }
    if let Some(dir) = npy {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    }
    let mut ok = true;
    let mut reports = Vec::new();
    for (k, f) in files.iter().enumerate() {
        let out = npy.map(|dir| dir.join(format!("{k}.npy")));
        match report(f, out.as_deref()) {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rates_print_to_what_the_file_can_mean() {
        assert_eq!(rate_text(f64::from(25.000_002_f32)), "25");
        assert_eq!(rate_text(120.0), "120");
        assert_eq!(rate_text(1.0 / 0.0081), "123.4568");
        assert_eq!(rate_text(59.940_059_94), "59.94006");
        assert_eq!(rate_text(0.5), "0.5");
        assert_eq!(rate_text(1500.0), "1500");
    }
}
