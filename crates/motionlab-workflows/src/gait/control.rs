//! The control of a skeleton walk (`[gait.control]`): the trial channels' change rates applied
//! through `channel_map`, the synthesised BVH, its tables and its channel figures.

use std::path::Path;

use serde::Serialize;

use motionlab_core::registry;
use motionlab_core::{
    ChannelKind, Error, ErrorKind, LengthUnit, Location, Motion, PointKind, Result, SkeletonMotion,
    Table,
};
use motionlab_experiment::Datasets;
use motionlab_experiment::workflow::{Output, sanitize};
use motionlab_features::{AngleCurves, GaitCycle, WaveformParameters};
use motionlab_figure::{Chart, Figure, Series};
use motionlab_gait::change_rates::StudyChanges;
use motionlab_gait::{WalkChanges, WalkSynthesizer};

use super::{BuiltControl, ControlSection, GaitWorkflow, WalkRecord};

#[derive(Serialize)]
struct ControlChangeRow {
    walk_channel: String,
    trial_channel: String,
    /// μ of the DC change (%); NaN when the trial channel's DC is no feature (unchanged).
    mu_dc_pct: f64,
    mu_amplitude_pct: f64,
    offset_deg: f64,
    recorded_dc_deg: f64,
    synthesised_dc_deg: f64,
    recorded_amplitude_deg: f64,
    synthesised_amplitude_deg: f64,
}

#[derive(Serialize)]
struct ControlWalkRow {
    sequence: String,
    condition: String,
    frequency_change_pct: f64,
    time_factor: f64,
    n_frames_recorded: usize,
    n_frames_synthesised: usize,
    n_cycles: usize,
    recorded_frequency_hz: f64,
    synthesised_frequency_hz: f64,
    bvh_file: String,
}

#[derive(Serialize)]
struct CurveRow {
    channel: String,
    frame: usize,
    time_s: f64,
    synthesised_deg: f64,
}

/// The skeleton's channels in storage order, each with the names it may carry as an angle
/// channel (BVH and ASF spelling) and whether it is a rotation.
fn skeleton_channels(sk: &SkeletonMotion) -> Vec<([String; 2], bool)> {
    sk.skeleton
        .joints
        .iter()
        .flat_map(|j| {
            j.channels.iter().map(move |c| {
                (
                    [
                        format!("{}.{}", j.name, c.bvh_name()),
                        format!("{}.{}", j.name, c.short_name()),
                    ],
                    matches!(c, ChannelKind::Rotation(_)),
                )
            })
        })
        .collect()
}

/// Cycles of a walk played `s` times faster: bounds divided by `s`, rounded, inside the new walk.
fn scaled_cycles(cycles: &[GaitCycle], s: f64, n_frames: usize) -> Vec<GaitCycle> {
    cycles
        .iter()
        .filter_map(|c| {
            let start = (c.start as f64 / s).round() as usize;
            let end = ((c.end as f64 / s).round() as usize).min(n_frames.saturating_sub(1));
            (end > start).then(|| GaitCycle { start, end, side: c.side.clone() })
        })
        .collect()
}

/// The control walk synthesised, and what it measures.
struct Synthesis {
    /// Every channel the synthesizer returned: the walk's angle channels (offsets restored) and
    /// its translation channels.
    curves: AngleCurves,
    /// The skeleton driven by `curves`.
    motion: SkeletonMotion,
    /// The walk is played `1 + μ_f / 100` times faster.
    time_factor: f64,
    /// The walk's gait cycles, scaled to the synthesised walk.
    cycles: Vec<GaitCycle>,
    /// The waveform parameters of the synthesised walk, over `cycles`.
    measured: WaveformParameters,
    /// Its BVH file's name under `files/`.
    bvh_name: String,
}

impl Synthesis {
    fn n_frames(&self) -> usize {
        self.curves.n_frames()
    }
}

/// The angle channels of `curves`: all but the `translations`.
fn angle_channels(curves: &AngleCurves, translations: &[String]) -> AngleCurves {
    AngleCurves {
        frame_rate: curves.frame_rate,
        channels: curves.channels.iter().filter(|c| !translations.contains(c)).cloned().collect(),
        values: curves
            .channels
            .iter()
            .zip(&curves.values)
            .filter(|(c, _)| !translations.contains(c))
            .map(|(_, v)| v.clone())
            .collect(),
    }
}

impl GaitWorkflow {
    /// `[gait.control]`: the condition's mean change rates applied to the control walk through
    /// `channel_map`; its BVH file, tables and (when drawing) figures into `out`.
    pub(super) fn control_walk(
        &self,
        c: &BuiltControl,
        walk: &WalkRecord,
        analysis: &StudyChanges,
        data: &Datasets,
        draw: bool,
        out: &mut Output,
    ) -> Result<()> {
        let spec = &c.spec;
        let fail = |e: Error| e.under_field("gait.control");
        let synthesizer = self
            .synthesizer
            .as_deref()
            .ok_or_else(|| fail(Error::new(ErrorKind::MissingKey, "needs a synthesizer")))?;
        let loaded = data.load(c.dataset, 0)?;
        let motion = &loaded.motion;
        let file = data.datasets[c.dataset].files[0].clone();
        let Some(sk) = &motion.skeleton else {
            return Err(fail(
                Error::new(
                    ErrorKind::MissingData,
                    "the control walk has no skeleton; expected a BVH or ASF/AMC motion",
                )
                .with_location(Location::file(&file)),
            ));
        };
        let changes = analysis.condition(&spec.condition).map_err(fail)?.walk_changes();
        let applied = self.changes_on_walk(spec, walk, &changes)?;
        let (curves, translations, synthesised) =
            synthesise(spec, synthesizer, walk, sk, &applied, &file)?;
        let mut bvh = Vec::new();
        motionlab_io::bvh::write_bvh(
            &synthesised,
            motion.frame_rate(),
            LengthUnit::Millimetre,
            &mut bvh,
        )
        .map_err(fail)?;
        let suffix =
            if self.combo_index == 0 { String::new() } else { format!("_c{}", self.combo_index) };
        let bvh_name =
            format!("{}_{}{suffix}.bvh", sanitize(&walk.sequence), sanitize(&spec.condition));
        out.files.push((bvh_name.clone(), bvh));

        // What was applied, and what the synthesised walk measures (over the scaled cycles).
        let time_factor = 1.0 + applied.frequency_percent / 100.0;
        let cycles = scaled_cycles(&walk.cycles, time_factor, curves.n_frames());
        let measured = self
            .analyzer
            .parameters(&angle_channels(&curves, &translations), &cycles)
            .map_err(|e| e.under_field("gait.waveform"))?;
        let synth =
            Synthesis { curves, motion: synthesised, time_factor, cycles, measured, bvh_name };
        out.tables.extend(control_tables(
            spec,
            walk,
            &analysis.normal_condition,
            &changes,
            &applied,
            &synth,
        )?);
        if draw {
            out.figures.extend(self.control_figures(c, walk, motion, &applied, &synth, analysis)?);
        }
        Ok(())
    }

    /// The trial channels' μ renamed to the walk's channels through `channel_map` (each target
    /// checked to be a channel of the walk).
    fn changes_on_walk(
        &self,
        spec: &ControlSection,
        walk: &WalkRecord,
        changes: &WalkChanges,
    ) -> Result<WalkChanges> {
        let mut applied =
            WalkChanges { frequency_percent: changes.frequency_percent, ..Default::default() };
        for (from, to) in &spec.channel_map {
            if walk.curves.channel_index(to).is_err() {
                let close =
                    registry::closest_names(to, walk.curves.channels.iter().map(String::as_str));
                return Err(self.config_error(
                    "gait.control.channel_map",
                    Error::new(ErrorKind::UnknownName, format!("{from:?} maps to {to:?}, which is not a channel of the control walk (closest: {})", close.join(", "))),
                ));
            }
            if let Some(v) = changes.dc_percent.get(from) {
                applied.dc_percent.insert(to.clone(), *v);
            }
            if let Some(v) = changes.amplitude_percent.get(from) {
                applied.amplitude_percent.insert(to.clone(), *v);
            }
        }
        Ok(applied)
    }

    /// The paper's Fig 5 and, for each mapped channel the control changed, its recorded and
    /// synthesised curves over time.
    fn control_figures(
        &self,
        c: &BuiltControl,
        walk: &WalkRecord,
        recorded: &Motion,
        applied: &WalkChanges,
        synth: &Synthesis,
        analysis: &StudyChanges,
    ) -> Result<Vec<Figure>> {
        let spec = &c.spec;
        let names = synth.motion.skeleton.point_names();
        let positions = synth.motion.positions();
        let synth_motion = Motion::new(
            format!("{} ({})", walk.sequence, spec.condition),
            recorded.frame_rate(),
            recorded.up_axis(),
            PointKind::Joint,
            names,
            positions,
        )?;
        let mut figures = vec![self.fig5(
            c,
            walk,
            recorded,
            &synth_motion,
            &walk.curves,
            &synth.curves,
            &synth.cycles,
            analysis,
        )?];
        let rate = synth.curves.frame_rate.hz();
        for (to, k) in spec
            .channel_map
            .values()
            .filter_map(|to| walk.curves.channel_index(to).ok().map(|k| (to, k)))
        {
            let changed =
                applied.dc_percent.contains_key(to) || applied.amplitude_percent.contains_key(to);
            let (Ok(ks), true) = (synth.curves.channel_index(to), changed) else { continue };
            let t = |n: usize| (0..n).map(|f| f as f64 / rate).collect::<Vec<f64>>();
            figures.push(Figure::chart(
                format!("control_{}", sanitize(to)),
                Chart {
                    title: format!(
                        "{} — {to}: recorded {} vs synthesised {}",
                        walk.sequence, analysis.normal_condition, spec.condition
                    ),
                    x_label: "time (s)".into(),
                    y_label: format!("{to} (deg)"),
                    lines: vec![
                        Series::new(
                            format!("recorded {}", analysis.normal_condition),
                            t(walk.curves.n_frames()),
                            walk.curves.values[k].clone(),
                        ),
                        Series::new(
                            format!("synthesised {}", spec.condition),
                            t(synth.n_frames()),
                            synth.curves.values[ks].clone(),
                        ),
                    ],
                    ..Default::default()
                },
            ));
        }
        Ok(figures)
    }
}

/// The walk's angle channels (offsets removed) plus its translation channels — passed through
/// the synthesizer unchanged, so they are retimed exactly like the angles — synthesised with
/// the `applied` changes, offsets restored: the synthesised curves, the names of the
/// translation channels among them and the skeleton motion they drive. `file` is the walk's,
/// for the synthesizer's errors.
fn synthesise(
    spec: &ControlSection,
    synthesizer: &dyn WalkSynthesizer,
    walk: &WalkRecord,
    sk: &SkeletonMotion,
    applied: &WalkChanges,
    file: &Path,
) -> Result<(AngleCurves, Vec<String>, SkeletonMotion)> {
    let fail = |e: Error| e.under_field("gait.control");
    let channels = skeleton_channels(sk);
    let mut curves = walk.curves.clone();
    if curves.n_frames() != sk.n_frames() {
        return Err(fail(Error::new(
            ErrorKind::Mismatch,
            format!(
                "the walk's angles have {} frames, its skeleton {}",
                curves.n_frames(),
                sk.n_frames()
            ),
        )));
    }
    for (ch, o) in &spec.offset_deg {
        let k = curves.channel_index(ch).map_err(fail)?;
        curves.values[k].iter_mut().for_each(|v| *v -= o);
    }
    let mut translations = Vec::new();
    for (index, (names, rotation)) in channels.iter().enumerate() {
        if !rotation {
            curves.channels.push(names[0].clone());
            curves.values.push(sk.channel(index));
            translations.push(names[0].clone());
        }
    }
    let mut synth = synthesizer
        .synthesize(&curves, &walk.cycles, applied)
        .map_err(|e| e.in_file(file).under_field("gait.synthesizer"))?;
    for (ch, o) in &spec.offset_deg {
        let k = synth.channel_index(ch).map_err(fail)?;
        synth.values[k].iter_mut().for_each(|v| *v += o);
    }
    let n_out = synth.n_frames();
    let mut columns: Vec<&Vec<f64>> = Vec::with_capacity(channels.len());
    for (names, _) in &channels {
        let k = synth.channels.iter().position(|c| names.contains(c)).ok_or_else(|| {
            fail(Error::new(
                ErrorKind::UnknownName,
                format!("the walk's angle source gives no channel {:?}; expected the skeleton's rotation channels (use skeleton_joint_angles)", names[0]),
            ))
        })?;
        columns.push(&synth.values[k]);
    }
    let frame_major: Vec<f64> =
        (0..n_out).flat_map(|f| columns.iter().map(move |c| c[f])).collect();
    let motion = SkeletonMotion::new(sk.skeleton.clone(), frame_major).map_err(fail)?;
    Ok((synth, translations, motion))
}

/// `control_changes` (μ applied per mapped channel, DC and amplitude before and after),
/// `control_walk` (time factor, frame counts, frequencies) and `control_curves` (the
/// synthesised curves of the mapped channels).
fn control_tables(
    spec: &ControlSection,
    walk: &WalkRecord,
    normal: &str,
    changes: &WalkChanges,
    applied: &WalkChanges,
    synth: &Synthesis,
) -> Result<Vec<Table>> {
    let get = |p: &WaveformParameters, ch: &str| {
        p.channels
            .iter()
            .position(|c| c == ch)
            .map(|i| (p.dc[i], p.amplitude[i]))
            .unwrap_or((f64::NAN, f64::NAN))
    };
    let rows: Vec<ControlChangeRow> = spec
        .channel_map
        .iter()
        .map(|(from, to)| {
            let (d0, a0) = get(&walk.parameters, to);
            let (d1, a1) = get(&synth.measured, to);
            ControlChangeRow {
                walk_channel: to.clone(),
                trial_channel: from.clone(),
                mu_dc_pct: changes.dc_percent.get(from).copied().unwrap_or(f64::NAN),
                mu_amplitude_pct: changes.amplitude_percent.get(from).copied().unwrap_or(f64::NAN),
                offset_deg: spec.offset_deg.get(to).copied().unwrap_or(0.0),
                recorded_dc_deg: d0,
                synthesised_dc_deg: d1,
                recorded_amplitude_deg: a0,
                synthesised_amplitude_deg: a1,
            }
        })
        .collect();
    let changes_table = Table::from_records(
        "control_changes",
        format!(
            "Control of {}: μ applied per mapped channel ({} vs {normal}; NaN = not a feature, unchanged) and the DC/amplitude measured before and after",
            walk.sequence, spec.condition
        ),
        &rows,
    )?;
    let walk_table = Table::from_records(
        "control_walk",
        format!(
            "Control of {}: the whole walk played at (1 + μ_f/100) times its frequency",
            walk.sequence
        ),
        &[ControlWalkRow {
            sequence: walk.sequence.clone(),
            condition: spec.condition.clone(),
            frequency_change_pct: applied.frequency_percent,
            time_factor: synth.time_factor,
            n_frames_recorded: walk.n_frames,
            n_frames_synthesised: synth.n_frames(),
            n_cycles: walk.cycles.len(),
            recorded_frequency_hz: walk.parameters.frequency_hz,
            synthesised_frequency_hz: synth.measured.frequency_hz,
            bvh_file: format!("files/{}", synth.bvh_name),
        }],
    )?;
    let rate = synth.curves.frame_rate.hz();
    let curves = &synth.curves;
    let curve_rows: Vec<CurveRow> = spec
        .channel_map
        .values()
        .filter_map(|to| curves.channel_index(to).ok().map(|k| (to, k)))
        .flat_map(|(to, k)| {
            curves.values[k].iter().enumerate().map(move |(f, v)| CurveRow {
                channel: to.clone(),
                frame: f,
                time_s: f as f64 / rate,
                synthesised_deg: *v,
            })
        })
        .collect();
    let curves_table = Table::from_records(
        "control_curves",
        format!(
            "Synthesised {} angle curves of {} (mapped channels)",
            spec.condition, walk.sequence
        ),
        &curve_rows,
    )?;
    Ok(vec![changes_table, walk_table, curves_table])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scaled_cycles_stay_inside_the_faster_walk() {
        let cycles = vec![
            GaitCycle { start: 10, end: 110, side: "Left".into() },
            GaitCycle { start: 110, end: 219, side: "Left".into() },
        ];
        // 220 frames at s = 1.25 → 176 frames (0..=175).
        let out = scaled_cycles(&cycles, 1.25, 176);
        assert_eq!(out[0], GaitCycle { start: 8, end: 88, side: "Left".into() });
        assert_eq!(out[1].start, 88);
        assert_eq!(out[1].end, 175); // 219 / 1.25 = 175.2
    }
    #[test]
    fn skeleton_channels_carry_both_spellings_in_storage_order() {
        use motionlab_core::{Axis, Joint, Skeleton};
        let root = Joint::new(
            "Hips",
            None,
            [0.0; 3],
            vec![ChannelKind::Translation(Axis::X), ChannelKind::Rotation(Axis::Z)],
        );
        let knee = Joint::new(
            "LeftKnee",
            Some(0),
            [0.0, -400.0, 0.0],
            vec![ChannelKind::Rotation(Axis::X)],
        );
        let sk = SkeletonMotion::new(Skeleton { joints: vec![root, knee] }, vec![0.0; 6]).unwrap();
        let ch = skeleton_channels(&sk);
        assert_eq!(ch.len(), 3);
        assert_eq!(ch[0], (["Hips.Xposition".to_string(), "Hips.tx".to_string()], false));
        assert_eq!(ch[2], (["LeftKnee.Xrotation".to_string(), "LeftKnee.rx".to_string()], true));
    }
}
