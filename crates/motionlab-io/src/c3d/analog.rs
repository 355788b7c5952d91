//! A C3D file's analog channels (EMG, force plates, accelerometers, dynamometers) as
//! [`Channels`] at their own rate: what the `c3d` loader gives for a file without 3-D points,
//! and for any file with `analog = true`.

use motionlab_core::units::FrameRate;
use motionlab_core::{Channels, ErrorKind, Event, Result};

use super::raw::{C3dFile, DataLayout, Repairs, header_offset};

/// The analog channels of a file: rate, samples per point frame and the scaled values.
pub struct Analog {
    /// `ANALOG:RATE` (or the point rate × samples per frame when the two disagree).
    pub rate: FrameRate,
    /// Analog samples per point frame.
    pub per_frame: usize,
    pub channels: Channels,
}

/// Reads every analog channel: names from `ANALOG:LABELS`, `LABELS2`, … (blank → `A<n>`, a
/// label written twice → `EMG#2`, noted), units from `ANALOG:UNITS`, `UNITS2`, … (absent →
/// empty), values scaled by [`C3dFile::analog_channel`]. `None` when the file has no analog
/// channel (`ANALOG:USED` absent or 0, or no analog word per frame).
pub fn read(
    file: &C3dFile<'_>,
    layout: &DataLayout,
    point_rate: FrameRate,
    repairs: &mut Repairs,
) -> Result<Option<Analog>> {
    let ctx = file.ctx;
    let used = match file.param("ANALOG", "USED") {
        Some(p) => p.first_unsigned(ctx)? as usize,
        None => 0,
    };
    if used == 0 || layout.analog_words == 0 {
        return Ok(None);
    }
    if !layout.analog_words.is_multiple_of(used) {
        return Err(ctx
            .err(
                ErrorKind::WrongValueCount,
                header_offset::ANALOG_PER_FRAME,
                format!(
                    "{} analog words per frame for ANALOG:USED {used} channels; expected a whole number of samples of every channel",
                    layout.analog_words
                ),
            )
            .with_field("ANALOG:USED"));
    }
    let per_frame = layout.analog_words / used;
    let from_layout = point_rate.hz() * per_frame as f64;
    let rate_hz = match file.param("ANALOG", "RATE") {
        Some(p) => {
            let hz = p.first_float(ctx)?;
            // C3D stores rates as float32: 1500.0001 Hz is the layout's 1500 Hz.
            if (hz - from_layout).abs() > 1e-4 * from_layout {
                repairs.make(
                    format!(
                        "ANALOG:RATE is {hz} Hz but the data hold {per_frame} analog samples per {} Hz frame: the channels are read at {from_layout} Hz",
                        point_rate.hz()
                    ),
                    || {
                        ctx.param_err(
                            ErrorKind::OutOfRange,
                            p,
                            format!("{hz} Hz; expected {per_frame} × POINT:RATE = {from_layout} Hz (strict reading)"),
                        )
                    },
                )?;
                from_layout
            } else {
                hz
            }
        }
        None => from_layout,
    };
    let rate = FrameRate::new(rate_hz).map_err(|_| {
        ctx.err(
            ErrorKind::OutOfRange,
            header_offset::ANALOG_PER_FRAME,
            format!("analog rate is {rate_hz} Hz; expected a finite rate > 0"),
        )
        .with_field("ANALOG:RATE")
    })?;
    let names = labels(file, used, repairs)?;
    let units = continued(file, "UNITS")?
        .into_iter()
        .chain(std::iter::repeat(String::new()))
        .take(used)
        .collect();
    let columns = (0..used).map(|k| file.analog_channel(layout, k)).collect::<Result<Vec<_>>>()?;
    let n_samples = columns.first().map_or(0, Vec::len);
    let mut values = Vec::with_capacity(n_samples * used);
    for s in 0..n_samples {
        values.extend(columns.iter().map(|c| c[s]));
    }
    let channels = Channels::new(names, units, values)
        .map_err(|e| e.in_file(ctx.origin).with_field("ANALOG"))?;
    Ok(Some(Analog { rate, per_frame, channels }))
}

/// The strings of `ANALOG:NAME`, `NAME2`, `NAME3`, … concatenated (empty when absent).
fn continued(file: &C3dFile<'_>, name: &str) -> Result<Vec<String>> {
    let mut out = Vec::new();
    if let Some(p) = file.param("ANALOG", name) {
        out.extend(p.strings(file.ctx)?);
        let mut k = 2;
        while let Some(p) = file.param("ANALOG", &format!("{name}{k}")) {
            out.extend(p.strings(file.ctx)?);
            k += 1;
        }
    }
    Ok(out)
}

/// One unique, non-empty name per channel.
fn labels(file: &C3dFile<'_>, used: usize, repairs: &mut Repairs) -> Result<Vec<String>> {
    let mut labels = continued(file, "LABELS")?;
    labels.resize(used, String::new());
    let mut seen = std::collections::HashSet::with_capacity(used);
    let mut renamed = Vec::new();
    for (i, l) in labels.iter_mut().enumerate() {
        if l.is_empty() {
            *l = format!("A{}", i + 1);
        }
        if !seen.insert(l.clone()) {
            let unique = (2..).map(|k| format!("{l}#{k}")).find(|c| !seen.contains(c));
            let unique = unique.unwrap_or_default();
            renamed.push(format!("{l:?} (channel {}) → {unique}", i + 1));
            seen.insert(unique.clone());
            *l = unique;
        }
    }
    if !renamed.is_empty() {
        let ctx = file.ctx;
        repairs.make(
            format!("duplicate analog labels made unique: {}", renamed.join("; ")),
            || {
                ctx.err(
                    ErrorKind::DuplicateName,
                    header_offset::ANALOG_PER_FRAME,
                    format!("analog labels repeat ({}) (strict reading)", renamed.join("; ")),
                )
                .with_field("ANALOG:LABELS")
            },
        )?;
    }
    Ok(labels)
}

/// The events' fractional frame indices moved from point frames to analog samples.
pub fn events_in_samples(events: Vec<Event>, per_frame: usize) -> Vec<Event> {
    events.into_iter().map(|e| Event { frame: e.frame * per_frame as f64, ..e }).collect()
}
