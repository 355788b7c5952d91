//! Posture (DC), size (amplitude) and speed (frequency) of joint-angle waveforms over gait
//! cycles (Osafune et al. §2.2), and the time normalisation of a cycle shared with the walk
//! synthesis and its evaluation.
//!
//! Written by hand: a mean, a linear resampling and one DFT bin — a signal-processing crate
//! would add a dependency for three loops.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::{AngleCurves, GaitCycle, WaveformAnalyzer, WaveformParameters};
use motionlab_core::registry::ParamGuard;
use motionlab_core::{Error, ErrorKind, Result};

/// How the amplitude of a channel is measured on its mean gait cycle.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum AmplitudeDefinition {
    /// `A = (max − min) / 2` of the mean gait cycle.
    #[default]
    HalfPeakToPeak,
    /// `A = 2·|X₁| / P`, `X₁ = Σ_k m_k e^{−2πik/P}` over the `P = points − 1` samples of one period
    /// of the mean gait cycle `m` (the last point repeats the first and is left out).
    FirstHarmonic,
}

/// Posture, size and speed of each angle channel of a walk (Osafune et al. §2.2), averaged
/// over the walk's gait cycles.
///
/// For a cycle `start..end` (frames; `end` = the next same-side strike) of `N = end − start`
/// frames:
/// - **DC** (posture): `(1/N) Σ_{n=start}^{end−1} f(n)` per cycle, averaged over the cycles.
/// - **Amplitude** (size): each cycle is time-normalised to `points` samples (linear
///   interpolation at `start + k·N/(points−1)`, frame `end` included); cycles starting at the
///   same foot are averaged point by point into that foot's *mean gait cycle*, whose amplitude
///   is measured per `amplitude` (half peak-to-peak or first harmonic); the channel's amplitude
///   is the mean over feet. Cycles of different feet are never averaged together: they are half
///   a period apart and would cancel.
/// - **Frequency** (speed, common to all channels): `fps / mean N` (Hz), i.e. 1 / the mean cycle
///   duration.
///
/// Missing samples: a cycle in which a channel has any NaN sample (frames `start..=end`) is
/// left out for that channel only; a channel without any complete cycle gets NaN DC and
/// amplitude (the change-rate evaluator then excludes it, flagged). A cycle that ends after the
/// last frame is an error.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct WaveformParametersParams {
    /// `"half_peak_to_peak"` or `"first_harmonic"`.
    #[serde(default)]
    pub amplitude: AmplitudeDefinition,
    /// Samples of the time-normalised gait cycle (0 % … 100 %, both ends).
    #[serde(default = "default_points")]
    pub points: usize,
}

fn default_points() -> usize {
    101
}

impl Default for WaveformParametersParams {
    fn default() -> Self {
        WaveformParametersParams {
            amplitude: AmplitudeDefinition::default(),
            points: default_points(),
        }
    }
}

/// The validated stage.
#[derive(Clone, Debug, PartialEq)]
pub struct WaveformParametersStage {
    pub amplitude: AmplitudeDefinition,
    pub points: usize,
}

impl ParamGuard for WaveformParametersParams {
    type Checked = WaveformParametersStage;
    fn check(self) -> Result<WaveformParametersStage> {
        if !(3..=100_000).contains(&self.points) {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                format!("must be between 3 and 100000 samples, found {}", self.points),
            )
            .with_field("points"));
        }
        Ok(WaveformParametersStage { amplitude: self.amplitude, points: self.points })
    }
}

/// `values` resampled at `points` equally spaced instants from `start` to `end` (fractional
/// frames, both included) by linear interpolation. `None` when the span leaves `0..=len−1`,
/// is empty, or touches a non-finite sample.
pub fn time_normalise(values: &[f64], start: f64, end: f64, points: usize) -> Option<Vec<f64>> {
    let last = values.len().checked_sub(1)? as f64;
    if !(start >= 0.0 && end > start && end <= last && points >= 2) {
        return None;
    }
    let step = (end - start) / (points - 1) as f64;
    let mut out = Vec::with_capacity(points);
    for k in 0..points {
        let t = if k + 1 == points { end } else { start + k as f64 * step };
        let i = (t.floor() as usize).min(values.len() - 1);
        let w = t - i as f64;
        let v = if w == 0.0 { values[i] } else { values[i] + (values[i + 1] - values[i]) * w };
        if !v.is_finite() {
            return None;
        }
        out.push(v);
    }
    Some(out)
}

/// Mean of `values[start..end]`; `None` when the range is empty, out of bounds or holds NaN.
pub fn cycle_mean(values: &[f64], start: usize, end: usize) -> Option<f64> {
    let slice = values.get(start..end).filter(|s| !s.is_empty())?;
    let mean = slice.iter().sum::<f64>() / slice.len() as f64;
    mean.is_finite().then_some(mean)
}

/// Amplitude of one period of a mean cycle (`points` samples, last = first of the next period).
pub fn cycle_amplitude(mean_cycle: &[f64], definition: AmplitudeDefinition) -> f64 {
    match definition {
        AmplitudeDefinition::HalfPeakToPeak => {
            let (lo, hi) = mean_cycle
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(*v), hi.max(*v)));
            (hi - lo) / 2.0
        }
        AmplitudeDefinition::FirstHarmonic => {
            let p = mean_cycle.len().saturating_sub(1);
            if p == 0 {
                return f64::NAN;
            }
            let (mut re, mut im) = (0.0, 0.0);
            for (k, v) in mean_cycle[..p].iter().enumerate() {
                let phase = std::f64::consts::TAU * k as f64 / p as f64;
                re += v * phase.cos();
                im -= v * phase.sin();
            }
            2.0 * re.hypot(im) / p as f64
        }
    }
}

/// Point-by-point mean of the time-normalised spans `(start, end)` (fractional frames) that are
/// complete (no NaN); `None` when none is.
pub fn mean_cycle_between(values: &[f64], spans: &[(f64, f64)], points: usize) -> Option<Vec<f64>> {
    let normalised: Vec<Vec<f64>> =
        spans.iter().filter_map(|&(a, b)| time_normalise(values, a, b, points)).collect();
    let n = normalised.len();
    (n > 0).then(|| {
        (0..points).map(|k| normalised.iter().map(|c| c[k]).sum::<f64>() / n as f64).collect()
    })
}

/// Point-by-point mean of the time-normalised cycles (all complete) of one side; `None` when
/// no cycle is complete.
pub fn mean_gait_cycle(values: &[f64], cycles: &[&GaitCycle], points: usize) -> Option<Vec<f64>> {
    let spans: Vec<(f64, f64)> = cycles.iter().map(|c| (c.start as f64, c.end as f64)).collect();
    mean_cycle_between(values, &spans, points)
}

/// DC of a channel: the mean over its complete cycles (no NaN in frames `start..=end`) of the
/// per-cycle mean of frames `start..end`; NaN when no cycle is complete.
pub fn channel_dc(values: &[f64], cycles: &[GaitCycle]) -> f64 {
    let dcs: Vec<f64> = cycles
        .iter()
        .filter(|c| values.get(c.start..=c.end).is_some_and(|s| s.iter().all(|v| v.is_finite())))
        .filter_map(|c| cycle_mean(values, c.start, c.end))
        .collect();
    if dcs.is_empty() { f64::NAN } else { dcs.iter().sum::<f64>() / dcs.len() as f64 }
}

/// The cycles grouped by side, in order of first appearance.
pub fn cycles_by_side(cycles: &[GaitCycle]) -> Vec<(&str, Vec<&GaitCycle>)> {
    let mut groups: Vec<(&str, Vec<&GaitCycle>)> = Vec::new();
    for c in cycles {
        match groups.iter_mut().find(|(s, _)| *s == c.side) {
            Some((_, g)) => g.push(c),
            None => groups.push((c.side.as_str(), vec![c])),
        }
    }
    groups
}

/// Checks cycles against a walk of `n_frames` frames.
pub fn check_cycles(cycles: &[GaitCycle], n_frames: usize) -> Result<()> {
    if cycles.is_empty() {
        return Err(Error::new(
            ErrorKind::EmptySequence,
            "no gait cycle to analyse; expected at least one from a gait-cycle detector",
        ));
    }
    for (i, c) in cycles.iter().enumerate() {
        if c.end <= c.start || c.end >= n_frames {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                format!(
                    "gait cycle {i} ({} frames {}..{}) must have start < end <= {} (the last frame of the walk)",
                    c.side,
                    c.start,
                    c.end,
                    n_frames.saturating_sub(1)
                ),
            ));
        }
    }
    Ok(())
}

impl WaveformParametersStage {
    /// DC and amplitude of one channel over the cycles (NaN when no cycle is complete).
    pub fn channel_parameters(&self, values: &[f64], cycles: &[GaitCycle]) -> (f64, f64) {
        let dc = channel_dc(values, cycles);
        let amplitudes: Vec<f64> = cycles_by_side(cycles)
            .iter()
            .filter_map(|(_, group)| mean_gait_cycle(values, group, self.points))
            .map(|m| cycle_amplitude(&m, self.amplitude))
            .collect();
        let amplitude = if amplitudes.is_empty() {
            f64::NAN
        } else {
            amplitudes.iter().sum::<f64>() / amplitudes.len() as f64
        };
        (dc, amplitude)
    }
}

impl WaveformAnalyzer for WaveformParametersStage {
    fn parameters(&self, curves: &AngleCurves, cycles: &[GaitCycle]) -> Result<WaveformParameters> {
        let n = curves.n_frames();
        if let Some((c, v)) = curves.channels.iter().zip(&curves.values).find(|(_, v)| v.len() != n)
        {
            return Err(Error::new(
                ErrorKind::WrongValueCount,
                format!("channel {c:?} has {} frames, the first channel {n}", v.len()),
            ));
        }
        check_cycles(cycles, n)?;
        let mean_frames =
            cycles.iter().map(|c| (c.end - c.start) as f64).sum::<f64>() / cycles.len() as f64;
        let (dc, amplitude) =
            curves.values.iter().map(|v| self.channel_parameters(v, cycles)).unzip();
        Ok(WaveformParameters {
            channels: curves.channels.clone(),
            dc,
            amplitude,
            frequency_hz: curves.frame_rate.hz() / mean_frames,
        })
    }
}

motionlab_core::register_custom_plugin!(
    crate::WaveformAnalyzer,
    WaveformParametersParams,
    "waveform_parameters",
    kind = "waveform_analyzer"
);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::build_waveform_analyzer;
    use motionlab_core::FrameRate;
    use std::f64::consts::TAU;

    fn curves(rate: f64, channels: Vec<Vec<f64>>) -> AngleCurves {
        AngleCurves {
            frame_rate: FrameRate::new(rate).unwrap(),
            channels: (0..channels.len()).map(|k| format!("c{k}")).collect(),
            values: channels,
        }
    }

    fn cycle(start: usize, end: usize, side: &str) -> GaitCycle {
        GaitCycle { start, end, side: side.into() }
    }

    #[test]
    fn sinusoid_parameters_are_exact_with_both_amplitude_definitions() {
        // 100 frames per cycle at 100 Hz: f = 1 Hz; DC 12.5°, amplitude 30°. Frames fall on the
        // peak (25) and trough (75), so half peak-to-peak is exact too.
        let x: Vec<f64> = (0..301).map(|n| 12.5 + 30.0 * (TAU * n as f64 / 100.0).sin()).collect();
        let c = curves(100.0, vec![x]);
        let cycles = [
            cycle(0, 100, "Left"),
            cycle(100, 200, "Left"),
            cycle(50, 150, "Right"),
            cycle(150, 250, "Right"),
        ];
        for def in [AmplitudeDefinition::HalfPeakToPeak, AmplitudeDefinition::FirstHarmonic] {
            let p = WaveformParametersParams { amplitude: def, points: 101 }
                .check()
                .unwrap()
                .parameters(&c, &cycles)
                .unwrap();
            assert!((p.dc[0] - 12.5).abs() < 1e-12, "{def:?} {}", p.dc[0]);
            assert!((p.amplitude[0] - 30.0).abs() < 1e-12, "{def:?} {}", p.amplitude[0]);
            assert!((p.frequency_hz - 1.0).abs() < 1e-15);
        }
    }

    #[test]
    fn first_harmonic_ignores_the_second_harmonic_that_half_peak_to_peak_sees() {
        let x: Vec<f64> = (0..201)
            .map(|n| {
                5.0 + 20.0 * (TAU * n as f64 / 100.0).cos()
                    + 8.0 * (2.0 * TAU * n as f64 / 100.0).cos()
            })
            .collect();
        let c = curves(50.0, vec![x]);
        let cycles = [cycle(0, 100, "Left"), cycle(100, 200, "Left")];
        let fh =
            WaveformParametersParams { amplitude: AmplitudeDefinition::FirstHarmonic, points: 101 }
                .check()
                .unwrap();
        let p = fh.parameters(&c, &cycles).unwrap();
        assert!((p.amplitude[0] - 20.0).abs() < 1e-12);
        assert!((p.frequency_hz - 0.5).abs() < 1e-15);
        // Half peak-to-peak of 20cos θ + 8cos 2θ = 16c² + 20c − 8 (c = cos θ): max 28 at c = 1,
        // min −14.25 at c = −0.625 (between samples) → (28 + 14.25) / 2 = 21.125.
        let hp =
            WaveformParametersParams::default().check().unwrap().parameters(&c, &cycles).unwrap();
        assert!((hp.amplitude[0] - 21.125).abs() < 0.01, "{}", hp.amplitude[0]);
    }

    #[test]
    fn dc_is_the_paper_mean_over_the_cycle_frames() {
        // Independent: the plain mean of frames start..end, averaged over cycles, by hand.
        let x: Vec<f64> = vec![1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0];
        let c = curves(10.0, vec![x]);
        let p = WaveformParametersParams::default()
            .check()
            .unwrap()
            .parameters(&c, &[cycle(0, 3, "Left"), cycle(3, 6, "Left")])
            .unwrap();
        assert_eq!(p.dc[0], ((1.0 + 2.0 + 4.0) / 3.0 + (8.0 + 16.0 + 32.0) / 3.0) / 2.0);
        assert!((p.frequency_hz - 10.0 / 3.0).abs() < 1e-15);
    }

    #[test]
    fn a_cycle_with_missing_samples_is_left_out_for_that_channel_only() {
        let mut x: Vec<f64> =
            (0..201).map(|n| 3.0 + 10.0 * (TAU * n as f64 / 100.0).sin()).collect();
        let y = x.clone();
        x[130] = f64::NAN;
        let c = curves(100.0, vec![x, y]);
        let stage = WaveformParametersParams::default().check().unwrap();
        let cycles = [cycle(0, 100, "Left"), cycle(100, 200, "Left")];
        let p = stage.parameters(&c, &cycles).unwrap();
        assert!((p.dc[0] - 3.0).abs() < 1e-12 && (p.amplitude[0] - 10.0).abs() < 1e-12);
        // Only the first cycle is complete for channel 0: a NaN there as well leaves nothing.
        let mut z = c.values[0].clone();
        z[10] = f64::NAN;
        let p = stage.parameters(&curves(100.0, vec![z]), &cycles).unwrap();
        assert!(p.dc[0].is_nan() && p.amplitude[0].is_nan());
        assert!(p.frequency_hz.is_finite());
    }

    #[test]
    fn bad_cycles_and_params_are_errors() {
        let c = curves(100.0, vec![vec![0.0; 50]]);
        let stage = WaveformParametersParams::default().check().unwrap();
        assert_eq!(stage.parameters(&c, &[]).unwrap_err().kind(), ErrorKind::EmptySequence);
        assert_eq!(
            stage.parameters(&c, &[cycle(10, 50, "Left")]).unwrap_err().kind(),
            ErrorKind::OutOfRange
        );
        let t: toml::Value = toml::from_str("points = 2").unwrap();
        assert_eq!(
            build_waveform_analyzer("waveform_parameters", &t)
                .err()
                .unwrap()
                .location()
                .field
                .as_deref(),
            Some("points")
        );
        let t: toml::Value = toml::from_str("amplitude = \"first_harmonic\"").unwrap();
        assert!(build_waveform_analyzer("waveform_parameters", &t).is_ok());
    }

    #[test]
    fn time_normalise_interpolates_and_refuses_gaps() {
        let x = [0.0, 10.0, 20.0, f64::NAN, 40.0];
        assert_eq!(time_normalise(&x, 0.0, 2.0, 5).unwrap(), vec![0.0, 5.0, 10.0, 15.0, 20.0]);
        assert_eq!(time_normalise(&x, 0.5, 1.5, 3).unwrap(), vec![5.0, 10.0, 15.0]);
        assert!(time_normalise(&x, 1.0, 4.0, 4).is_none());
        assert!(time_normalise(&x, 0.0, 4.5, 4).is_none());
    }
}
