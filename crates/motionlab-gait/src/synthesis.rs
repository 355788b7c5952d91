//! Walk synthesis by feature-channel control (Osafune et al. §4): scale the DC and amplitude of
//! the feature channels of a normal walk by their mean change rates, then play the whole walk
//! at the changed frequency.
//!
//! Written by hand: an affine map per channel and a one-dimensional resampling (linear or
//! Catmull–Rom) — smaller than any interpolation crate's API surface, and the exactness the
//! tests require (all rates 0 → the input, bit for bit) is easiest to guarantee here.

use std::collections::BTreeMap;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::{WalkChanges, WalkSynthesizer};
use motionlab_core::registry::ParamGuard;
use motionlab_core::{ChannelKind, Error, ErrorKind, FrameRate, Result, Skeleton, SkeletonMotion};
use motionlab_features::waveform::{channel_dc, check_cycles};
use motionlab_features::{AngleCurves, GaitCycle};

/// How the walk is resampled in time.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Interpolation {
    /// Straight line between neighbouring frames.
    #[default]
    Linear,
    /// Catmull–Rom cubic through the four neighbouring frames (ends clamped).
    Cubic,
}

/// Synthesises a changed walk from a normal one by controlling only the feature channels
/// (Osafune et al. §4).
///
/// For each channel `c` listed in the changes, with `D_c` its DC over the walk's gait cycles
/// (the mean of the per-cycle means, as `waveform_parameters` measures it; the mean of all
/// frames when no cycle is given), every frame becomes
/// `y(t) = (1 + μ_DC/100)·D_c + (1 + μ_A/100)·(x(t) − D_c)`: the amplitude scaled about the DC,
/// the DC scaled (a rate missing for one component counts as 0). Unlisted channels are
/// unchanged. Then the whole walk is resampled in time so that it plays at
/// `s = 1 + μ_f/100` times the original frequency: output frame `k` (same frame rate) is the
/// input at time `k·s` frames, `k = 0 … ⌊(F−1)/s⌋` (interpolated per `interpolation`). A gait
/// cycle `start..end` of the input therefore spans `start/s .. end/s` in the output.
///
/// Angles that wrap (a jump of more than 180° between frames, e.g. a BVH root yaw) are
/// unwrapped before the change and the interpolation and wrapped back into (−180°, 180°]
/// afterwards; other channels are never touched by that arithmetic, so with every rate 0 the
/// output equals the input exactly.
///
/// `channel_map` translates the changes' channel names (marker-derived: `knee_l.flexion`) to
/// the walk's (BVH: `LeftLeg.Xrotation`): with a map, only mapped channels are changed and the
/// others are dropped; without one, every changed channel must exist in the walk.
///
/// Missing samples: NaN stays NaN (and makes interpolated neighbours NaN); a changed channel
/// whose DC is undefined (no complete cycle) is an error naming it.
#[derive(Clone, Debug, Default, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FeatureChannelControlParams {
    /// `"linear"` or `"cubic"` (Catmull–Rom).
    #[serde(default)]
    pub interpolation: Interpolation,
    /// Change-rate channel → walk channel (e.g. `"knee_l.flexion" = "LeftLeg.Xrotation"`).
    #[serde(default)]
    #[schemars(extend("x-default" = "the walk's own names"))]
    pub channel_map: BTreeMap<String, String>,
}

/// The validated stage.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FeatureChannelControl {
    pub interpolation: Interpolation,
    pub channel_map: BTreeMap<String, String>,
}

impl ParamGuard for FeatureChannelControlParams {
    type Checked = FeatureChannelControl;
    fn check(self) -> Result<FeatureChannelControl> {
        let mut targets = std::collections::HashSet::new();
        for (from, to) in &self.channel_map {
            if from.trim().is_empty() || to.trim().is_empty() {
                return Err(Error::new(
                    ErrorKind::InvalidParameter,
                    "channel names must not be empty",
                )
                .with_field(format!("channel_map.{from}")));
            }
            if !targets.insert(to.as_str()) {
                return Err(Error::new(
                    ErrorKind::InvalidParameter,
                    format!("two channels map to {to:?}"),
                )
                .with_field(format!("channel_map.{from}")));
            }
        }
        Ok(FeatureChannelControl {
            interpolation: self.interpolation,
            channel_map: self.channel_map,
        })
    }
}

/// The DC and amplitude factors applied to one channel of the walk.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AppliedChange {
    /// The channel in the walk.
    pub channel: String,
    /// The change-rate channel it came from (the same name without a map).
    pub source: String,
    pub dc_factor: f64,
    pub amplitude_factor: f64,
}

fn factor(field: &str, channel: &str, pct: f64) -> Result<f64> {
    let f = 1.0 + pct / 100.0;
    if pct.is_finite() && f > 0.0 {
        Ok(f)
    } else {
        Err(Error::new(
            ErrorKind::OutOfRange,
            format!("a change of {pct} % would make the factor 1 + μ/100 = {f}; it must be > 0"),
        )
        .with_field(format!("{field}.{channel}")))
    }
}

/// The time factor `s = 1 + μ_f/100` (> 0).
pub fn speed_factor(changes: &WalkChanges) -> Result<f64> {
    factor("frequency_percent", "walk", changes.frequency_percent)
}

/// Unwraps jumps larger than 180° (returns None when there is none, so the channel is left
/// untouched).
fn unwrap_degrees(x: &[f64]) -> Option<Vec<f64>> {
    let mut out = x.to_vec();
    let mut offset = 0.0;
    let mut prev: Option<f64> = None;
    let mut any = false;
    for v in out.iter_mut() {
        if !v.is_finite() {
            continue;
        }
        let raw = *v;
        if let Some(p) = prev {
            let jump = raw - p;
            if jump.abs() > 180.0 {
                offset -= 360.0 * (jump / 360.0).round();
                any = true;
            }
        }
        prev = Some(raw);
        *v = raw + offset;
    }
    any.then_some(out)
}

fn wrap_degrees(v: f64) -> f64 {
    let w = v - 360.0 * (v / 360.0).round();
    if w <= -180.0 { w + 360.0 } else { w }
}

/// `x` resampled at instants `k·s` (frames), `k = 0 … ⌊(len−1)/s⌋`. Integer instants return the
/// sample itself.
pub fn resample(x: &[f64], s: f64, interpolation: Interpolation) -> Vec<f64> {
    if x.is_empty() {
        return Vec::new();
    }
    let last = x.len() - 1;
    let n_out = ((last as f64) / s).floor() as usize + 1;
    (0..n_out)
        .map(|k| {
            let t = (k as f64 * s).min(last as f64);
            let i = t.floor() as usize;
            let w = t - i as f64;
            if w == 0.0 {
                return x[i];
            }
            match interpolation {
                Interpolation::Linear => x[i] + (x[i + 1] - x[i]) * w,
                Interpolation::Cubic => {
                    let (p0, p1, p2) = (x[i.saturating_sub(1)], x[i], x[i + 1]);
                    let p3 = x[(i + 2).min(last)];
                    0.5 * (2.0 * p1
                        + (p2 - p0) * w
                        + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * w * w
                        + (3.0 * (p1 - p2) + p3 - p0) * w * w * w)
                }
            }
        })
        .collect()
}

/// DC of a channel as `waveform_parameters` measures it ([`channel_dc`]); the mean of all
/// finite frames when no cycle is given.
fn walk_dc(values: &[f64], cycles: &[GaitCycle]) -> f64 {
    if cycles.is_empty() {
        let finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
        return if finite.is_empty() {
            f64::NAN
        } else {
            finite.iter().sum::<f64>() / finite.len() as f64
        };
    }
    channel_dc(values, cycles)
}

impl FeatureChannelControl {
    /// Which walk channels change and by what factors; fails on an unknown channel (without a
    /// map) or a factor ≤ 0.
    pub fn plan(
        &self,
        walk_channels: &[String],
        changes: &WalkChanges,
    ) -> Result<Vec<AppliedChange>> {
        let mut planned: BTreeMap<String, AppliedChange> = BTreeMap::new();
        let listed = changes.dc_percent.keys().chain(changes.amplitude_percent.keys());
        for source in listed {
            let target = if self.channel_map.is_empty() {
                source.clone()
            } else {
                match self.channel_map.get(source) {
                    Some(t) => t.clone(),
                    None => continue, // the map selects what to apply
                }
            };
            if !walk_channels.contains(&target) {
                let what = if self.channel_map.is_empty() {
                    "changed channel"
                } else {
                    "channel_map target"
                };
                return Err(Error::new(
                    ErrorKind::UnknownName,
                    format!("{what} {target:?} is not a channel of the walk"),
                )
                .with_field(if self.channel_map.is_empty() {
                    target.clone()
                } else {
                    format!("channel_map.{source}")
                }));
            }
            if planned.contains_key(&target) {
                continue;
            }
            let dc = changes.dc_percent.get(source).copied().unwrap_or(0.0);
            let amplitude = changes.amplitude_percent.get(source).copied().unwrap_or(0.0);
            planned.insert(
                target.clone(),
                AppliedChange {
                    channel: target,
                    source: source.clone(),
                    dc_factor: factor("dc_percent", source, dc)?,
                    amplitude_factor: factor("amplitude_percent", source, amplitude)?,
                },
            );
        }
        Ok(planned.into_values().collect())
    }

    /// Applies the DC/amplitude change (if any) and the time factor to one channel.
    fn channel(
        &self,
        values: &[f64],
        change: Option<&AppliedChange>,
        cycles: &[GaitCycle],
        s: f64,
    ) -> Result<Vec<f64>> {
        let unwrapped = unwrap_degrees(values);
        let x = unwrapped.as_deref().unwrap_or(values);
        let changed: Option<Vec<f64>> = match change {
            Some(c) if c.dc_factor != 1.0 || c.amplitude_factor != 1.0 => {
                let d = walk_dc(x, cycles);
                if !d.is_finite() {
                    return Err(Error::new(
                        ErrorKind::MissingData,
                        format!("cannot change channel {:?}: its DC is undefined (no gait cycle without missing samples)", c.channel),
                    )
                    .with_field(c.channel.clone()));
                }
                Some(x.iter().map(|v| c.dc_factor * d + c.amplitude_factor * (v - d)).collect())
            }
            _ => None,
        };
        let base = changed.as_deref().unwrap_or(x);
        let mut out = if s == 1.0 { base.to_vec() } else { resample(base, s, self.interpolation) };
        if unwrapped.is_some() {
            out.iter_mut().for_each(|v| *v = wrap_degrees(*v));
        }
        Ok(out)
    }

    /// A skeleton motion (BVH/AMC) changed likewise: rotation channels named `joint.Xrotation`
    /// (BVH spelling) take the changes; every channel, translations included, is resampled in
    /// time (translations without any angle unwrapping). Returns the new motion.
    pub fn synthesize_skeleton(
        &self,
        motion: &SkeletonMotion,
        frame_rate: FrameRate,
        cycles: &[GaitCycle],
        changes: &WalkChanges,
    ) -> Result<SkeletonMotion> {
        let names = bvh_channel_names(&motion.skeleton);
        let plan = self.plan(&skeleton_rotation_channels(&motion.skeleton), changes)?;
        let s = speed_factor(changes)?;
        if !cycles.is_empty() {
            check_cycles(cycles, motion.n_frames())?;
        }
        let _ = frame_rate; // the output keeps the input's frame rate
        let mut columns = Vec::with_capacity(names.len());
        for (index, (name, rotation)) in names.iter().enumerate() {
            let values = motion.channel(index);
            let column = if *rotation {
                self.channel(&values, plan.iter().find(|p| p.channel == *name), cycles, s)?
            } else if s == 1.0 {
                values
            } else {
                resample(&values, s, self.interpolation)
            };
            columns.push(column);
        }
        let n_out = columns.first().map(Vec::len).unwrap_or(0);
        let frame_major: Vec<f64> =
            (0..n_out).flat_map(|f| columns.iter().map(move |c| c[f])).collect();
        SkeletonMotion::new(motion.skeleton.clone(), frame_major)
    }
}

impl WalkSynthesizer for FeatureChannelControl {
    fn synthesize(
        &self,
        walk: &AngleCurves,
        cycles: &[GaitCycle],
        changes: &WalkChanges,
    ) -> Result<AngleCurves> {
        let n = walk.n_frames();
        if n == 0 {
            return Err(Error::new(ErrorKind::EmptySequence, "the walk to change has no frames"));
        }
        if let Some((c, v)) = walk.channels.iter().zip(&walk.values).find(|(_, v)| v.len() != n) {
            return Err(Error::new(
                ErrorKind::WrongValueCount,
                format!("channel {c:?} has {} frames, the first channel {n}", v.len()),
            ));
        }
        if !cycles.is_empty() {
            check_cycles(cycles, n)?;
        }
        let plan = self.plan(&walk.channels, changes)?;
        let s = speed_factor(changes)?;
        let values = walk
            .channels
            .iter()
            .zip(&walk.values)
            .map(|(name, v)| self.channel(v, plan.iter().find(|p| p.channel == *name), cycles, s))
            .collect::<Result<Vec<_>>>()?;
        Ok(AngleCurves { frame_rate: walk.frame_rate, channels: walk.channels.clone(), values })
    }
}

motionlab_core::register_custom_plugin!(
    crate::WalkSynthesizer,
    FeatureChannelControlParams,
    "feature_channel_control",
    kind = "walk_synthesizer"
);

/// Every channel of a skeleton in BVH spelling, with whether it is a rotation.
fn bvh_channel_names(skeleton: &Skeleton) -> Vec<(String, bool)> {
    skeleton
        .joints
        .iter()
        .flat_map(|j| {
            j.channels.iter().map(move |c| {
                (format!("{}.{}", j.name, c.bvh_name()), matches!(c, ChannelKind::Rotation(_)))
            })
        })
        .collect()
}

/// The rotation channels of a skeleton in BVH spelling (`LeftKnee.Xrotation`): the names
/// [`FeatureChannelControl::synthesize_skeleton`] changes (and `channel_map` targets).
pub fn skeleton_rotation_channels(skeleton: &Skeleton) -> Vec<String> {
    bvh_channel_names(skeleton).into_iter().filter(|(_, r)| *r).map(|(n, _)| n).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::build_walk_synthesizer;
    use motionlab_core::{Axis, Joint};
    use motionlab_features::WaveformAnalyzer;
    use motionlab_features::waveform::{AmplitudeDefinition, WaveformParametersParams};
    use std::f64::consts::TAU;

    fn walk(period: usize, cycles: usize, rate: f64) -> AngleCurves {
        let n = period * cycles + 1;
        let ch = |dc: f64, a: f64, phase: f64| {
            (0..n)
                .map(|i| dc + a * (TAU * i as f64 / period as f64 + phase).sin())
                .collect::<Vec<_>>()
        };
        AngleCurves {
            frame_rate: FrameRate::new(rate).unwrap(),
            channels: vec![
                "knee_l.flexion".into(),
                "hip_l.flexion".into(),
                "pelvis.rotation".into(),
            ],
            values: vec![ch(20.0, 30.0, 0.0), ch(10.0, 25.0, 1.0), ch(-3.0, 4.0, 2.0)],
        }
    }

    fn cycles(period: usize, count: usize) -> Vec<GaitCycle> {
        (0..count)
            .map(|k| GaitCycle { start: k * period, end: (k + 1) * period, side: "Left".into() })
            .collect()
    }

    fn changes(dc: &[(&str, f64)], amplitude: &[(&str, f64)], f: f64) -> WalkChanges {
        WalkChanges {
            dc_percent: dc.iter().map(|(k, v)| (k.to_string(), *v)).collect(),
            amplitude_percent: amplitude.iter().map(|(k, v)| (k.to_string(), *v)).collect(),
            frequency_percent: f,
        }
    }

    #[test]
    fn all_rates_zero_returns_the_input_exactly() {
        let mut w = walk(100, 3, 100.0);
        // A wrapping channel and a missing sample must survive too.
        w.channels.push("Hips.Yrotation".into());
        w.values
            .push((0..301).map(|i| ((i as f64 * 3.0 + 170.0 + 180.0) % 360.0) - 180.0).collect());
        w.values[1][7] = f64::NAN;
        let z = changes(
            &[("knee_l.flexion", 0.0), ("Hips.Yrotation", 0.0)],
            &[("hip_l.flexion", 0.0)],
            0.0,
        );
        for interpolation in [Interpolation::Linear, Interpolation::Cubic] {
            let stage = FeatureChannelControl { interpolation, ..Default::default() };
            let out = stage.synthesize(&w, &cycles(100, 3), &z).unwrap();
            assert_eq!(out.channels, w.channels);
            for (a, b) in out.values.iter().zip(&w.values) {
                assert_eq!(a.len(), b.len());
                for (x, y) in a.iter().zip(b) {
                    assert!(x.to_bits() == y.to_bits(), "{x} != {y}");
                }
            }
        }
    }

    #[test]
    fn a_sinusoid_changes_by_the_requested_rates() {
        // 120 frames per cycle at 120 Hz; +100 % frequency → 60 frames per cycle, every output
        // frame an input frame, so the measured rates are exact.
        let w = walk(120, 3, 120.0);
        let c = changes(
            &[("knee_l.flexion", 25.0)],
            &[("knee_l.flexion", -40.0), ("hip_l.flexion", 10.0)],
            100.0,
        );
        let out = FeatureChannelControl::default().synthesize(&w, &cycles(120, 3), &c).unwrap();
        assert_eq!(out.n_frames(), 181);
        let rate = |a: f64, b: f64| (b - a) / a * 100.0;
        for def in [AmplitudeDefinition::HalfPeakToPeak, AmplitudeDefinition::FirstHarmonic] {
            let analyzer = WaveformParametersParams { amplitude: def, points: 61 }.check().unwrap();
            let before = analyzer.parameters(&w, &cycles(120, 3)).unwrap();
            let after = analyzer.parameters(&out, &cycles(60, 3)).unwrap();
            assert!(
                (rate(before.dc[0], after.dc[0]) - 25.0).abs() < 1e-9,
                "{def:?} {} -> {}",
                before.dc[0],
                after.dc[0]
            );
            assert!((rate(before.amplitude[0], after.amplitude[0]) + 40.0).abs() < 1e-9, "{def:?}");
            assert!(rate(before.dc[1], after.dc[1]).abs() < 1e-9);
            assert!((rate(before.amplitude[1], after.amplitude[1]) - 10.0).abs() < 1e-9);
            // The unlisted channel is only resampled.
            assert!(
                (after.dc[2] - before.dc[2]).abs() < 1e-12
                    && (after.amplitude[2] - before.amplitude[2]).abs() < 1e-12
            );
            assert!((rate(before.frequency_hz, after.frequency_hz) - 100.0).abs() < 1e-12);
        }
        // A non-integer factor (+50 %) keeps the DC exact (linear interpolation of a full period
        // of a sinusoid averages to its mean) and the frequency exact.
        let c = changes(&[("knee_l.flexion", 25.0)], &[], 50.0);
        let out = FeatureChannelControl::default().synthesize(&w, &cycles(120, 3), &c).unwrap();
        let analyzer = WaveformParametersParams::default().check().unwrap();
        let after = analyzer.parameters(&out, &cycles(80, 3)).unwrap();
        assert!((after.dc[0] - 25.0).abs() < 1e-9 && (after.frequency_hz - 1.5).abs() < 1e-12);
    }

    #[test]
    fn resampling_hits_input_frames_and_interpolates_between() {
        let x = [0.0, 10.0, 20.0, 30.0, 40.0];
        assert_eq!(resample(&x, 2.0, Interpolation::Linear), vec![0.0, 20.0, 40.0]);
        assert_eq!(
            resample(&x, 0.5, Interpolation::Linear),
            vec![0.0, 5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0, 40.0]
        );
        // Catmull–Rom reproduces a straight line (away from the clamped ends) and a cubic's samples.
        let c = resample(&x, 0.5, Interpolation::Cubic);
        assert!((c[3] - 15.0).abs() < 1e-12 && (c[5] - 25.0).abs() < 1e-12);
    }

    #[test]
    fn wrapped_angles_are_interpolated_the_short_way() {
        let w = AngleCurves {
            frame_rate: FrameRate::new(10.0).unwrap(),
            channels: vec!["yaw".into()],
            values: vec![vec![170.0, 178.0, -174.0, -166.0]],
        };
        let out = FeatureChannelControl::default()
            .synthesize(&w, &[], &changes(&[], &[], -50.0))
            .unwrap();
        // s = 0.5: midpoints. 178 → −174 crosses ±180 by 8°: the midpoint is −178, not 2.
        assert_eq!(out.values[0].len(), 7);
        assert!((out.values[0][3] + 178.0).abs() < 1e-12, "{:?}", out.values[0]);
    }

    #[test]
    fn maps_select_channels_and_bad_changes_are_errors() {
        let w = walk(100, 2, 100.0);
        let stage = FeatureChannelControl::default();
        let e = stage
            .synthesize(&w, &cycles(100, 2), &changes(&[("ankle_l.flexion", 5.0)], &[], 0.0))
            .unwrap_err();
        assert_eq!(e.kind(), ErrorKind::UnknownName);
        let e = stage
            .synthesize(&w, &cycles(100, 2), &changes(&[], &[("knee_l.flexion", -100.0)], 0.0))
            .unwrap_err();
        assert_eq!(e.kind(), ErrorKind::OutOfRange);
        assert_eq!(e.location().field.as_deref(), Some("amplitude_percent.knee_l.flexion"));
        assert!(stage.synthesize(&w, &cycles(100, 2), &changes(&[], &[], -100.0)).is_err());
        // With a map, only mapped channels change; unmapped changes are dropped.
        let t: toml::Value =
            toml::from_str("[channel_map]\n\"knee_marker\" = \"knee_l.flexion\"").unwrap();
        let mapped = build_walk_synthesizer("feature_channel_control", &t).unwrap();
        let out = mapped
            .synthesize(
                &w,
                &cycles(100, 2),
                &changes(&[("knee_marker", 10.0), ("elsewhere", 50.0)], &[], 0.0),
            )
            .unwrap();
        assert!((out.values[0][0] - (w.values[0][0] + 0.1 * 20.0)).abs() < 1e-9); // DC 20 → 22
        assert_eq!(out.values[1], w.values[1]);
        let t: toml::Value = toml::from_str("[channel_map]\na = \"x\"\nb = \"x\"").unwrap();
        assert!(build_walk_synthesizer("feature_channel_control", &t).is_err());
    }

    #[test]
    fn skeleton_motion_is_changed_and_resampled() {
        use motionlab_core::ChannelKind::{Rotation, Translation};
        let root = Joint::new(
            "Hips",
            None,
            [0.0; 3],
            vec![
                Translation(Axis::X),
                Translation(Axis::Y),
                Translation(Axis::Z),
                Rotation(Axis::Z),
                Rotation(Axis::X),
                Rotation(Axis::Y),
            ],
        );
        let knee = Joint::new(
            "LeftLeg",
            Some(0),
            [0.0, -400.0, 0.0],
            vec![Rotation(Axis::Z), Rotation(Axis::X), Rotation(Axis::Y)],
        );
        let skeleton = motionlab_core::Skeleton { joints: vec![root, knee] };
        let n = 201;
        let values: Vec<f64> = (0..n)
            .flat_map(|i| {
                let t = i as f64;
                [
                    10.0 * t,
                    900.0,
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                    20.0 + 30.0 * (TAU * t / 100.0).sin(),
                    0.0,
                ]
            })
            .collect();
        let sk = SkeletonMotion::new(skeleton, values).unwrap();
        let stage = FeatureChannelControlParams {
            channel_map: [("knee_l.flexion".to_string(), "LeftLeg.Xrotation".to_string())].into(),
            ..Default::default()
        }
        .check()
        .unwrap();
        let out = stage
            .synthesize_skeleton(
                &sk,
                FrameRate::new(100.0).unwrap(),
                &cycles(100, 2),
                &changes(&[("knee_l.flexion", 50.0)], &[], 100.0),
            )
            .unwrap();
        assert_eq!(out.n_frames(), 101);
        // Root x advances 20 mm per output frame (twice as fast); the knee's DC moved 20 → 30.
        assert_eq!(out.channel(0)[10], 200.0);
        let knee = out.channel(7);
        let dc = knee[..50].iter().sum::<f64>() / 50.0;
        assert!((dc - 30.0).abs() < 1e-9, "{dc}");
    }
}
