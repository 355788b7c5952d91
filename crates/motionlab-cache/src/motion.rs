//! The cached form of a loaded motion (and its ground truth): a MessagePack header with names,
//! skeleton, events and truth, then the positions and channel values as raw little-endian f64
//! — every number's bits exactly as loaded (NaN included), and decoded without a per-number
//! parse.
//!
//! Payload: `u64` header length (LE), the MessagePack header, `n_frames × n_points × 3` f64
//! positions, then the skeleton's `n_frames × n_channels` channel values when it has one, then
//! the motion's own channels (`n_frames × channels`, sample-major) when it has any.

use std::path::PathBuf;

use nalgebra::{Matrix3, Rotation3};
use serde::{Deserialize, Serialize};

use motionlab_core::skeleton::{ChannelKind, Joint, Skeleton, SkeletonMotion};
use motionlab_core::{
    Axis, Boundary, Channels, Dimensionality, Error, ErrorKind, Event, FrameRate, LoadNotes,
    Motion, PointKind, Result, Seconds, Segment, Segmentation,
};

#[derive(Serialize, Deserialize)]
struct Header {
    name: String,
    source: Option<PathBuf>,
    format: String,
    frame_rate_hz: f64,
    up_axis: Axis,
    joints_not_markers: bool,
    point_names: Vec<String>,
    n_frames: u64,
    skeleton: Option<Vec<JointRecord>>,
    events: Vec<(String, String, f64, f64)>,
    truth: Option<TruthRecord>,
    /// The motion's channels' names and units (values after the skeleton's).
    #[serde(default)]
    channels: Option<(Vec<String>, Vec<String>)>,
    /// The loader's length unit and repairs, for `inspect` and the run's provenance.
    #[serde(default)]
    load_notes: LoadNotes,
    /// 3-D world or 2-D image positions (video pose estimation).
    #[serde(default)]
    dimensionality: Dimensionality,
    /// The per-sample confidence, when the loader gave one (frame-major).
    #[serde(default)]
    confidence: Option<Vec<f32>>,
}

/// A ground truth as cached.
#[derive(Serialize, Deserialize)]
struct TruthRecord {
    frame_rate_hz: f64,
    boundaries: Vec<Boundary>,
    segments: Vec<Segment>,
    /// Each annotator's own boundary frames (empty for one annotator).
    annotators: Vec<Vec<usize>>,
    /// Their names, in the same order.
    annotator_names: Vec<String>,
}

#[derive(Serialize, Deserialize)]
struct JointRecord {
    name: String,
    parent: Option<usize>,
    offset: [f64; 3],
    /// (translation?, axis) per channel.
    channels: Vec<(bool, Axis)>,
    rotation_order: Vec<Axis>,
    /// The axis rotation's matrix, column-major.
    axis: [f64; 9],
    end_sites: Vec<[f64; 3]>,
}

fn bad(msg: impl Into<String>) -> Error {
    Error::new(ErrorKind::Mismatch, format!("cached motion: {}", msg.into()))
}

/// Encodes a motion and its truth.
pub fn encode(motion: &Motion, truth: Option<&Segmentation>) -> Result<Vec<u8>> {
    let skeleton = motion.skeleton.as_ref().map(|s| {
        s.skeleton
            .joints
            .iter()
            .map(|j| JointRecord {
                name: j.name.clone(),
                parent: j.parent,
                offset: j.offset,
                channels: j
                    .channels
                    .iter()
                    .map(|c| match c {
                        ChannelKind::Translation(a) => (true, *a),
                        ChannelKind::Rotation(a) => (false, *a),
                    })
                    .collect(),
                rotation_order: j.rotation_order.clone(),
                axis: {
                    let m = j.axis.matrix();
                    let mut a = [0.0; 9];
                    a.copy_from_slice(m.as_slice());
                    a
                },
                end_sites: j.end_sites.clone(),
            })
            .collect()
    });
    let header = Header {
        name: motion.name.clone(),
        source: motion.source.clone(),
        format: motion.format.clone(),
        frame_rate_hz: motion.frame_rate().hz(),
        up_axis: motion.up_axis(),
        joints_not_markers: motion.point_kind() == PointKind::Joint,
        point_names: motion.point_names().to_vec(),
        n_frames: motion.n_frames() as u64,
        skeleton,
        events: motion
            .events
            .iter()
            .map(|e| (e.label.clone(), e.context.clone(), e.time.value(), e.frame))
            .collect(),
        truth: truth.map(|t| TruthRecord {
            frame_rate_hz: t.frame_rate.hz(),
            boundaries: t.boundaries.clone(),
            segments: t.segments.clone(),
            annotators: t.annotators.clone(),
            annotator_names: t.annotator_names.clone(),
        }),
        channels: (!motion.channels().is_empty())
            .then(|| (motion.channels().names().to_vec(), motion.channels().units().to_vec())),
        load_notes: motion.load_notes.clone(),
        dimensionality: motion.dimensionality(),
        confidence: motion.confidence().map(<[f32]>::to_vec),
    };
    let head = rmp_serde::to_vec(&header).map_err(|e| bad(format!("cannot encode: {e}")))?;
    let values = motion.skeleton.as_ref().map_or(&[][..], |s| s.channel_values());
    let mut out =
        Vec::with_capacity(8 + head.len() + (motion.positions().len() * 3 + values.len()) * 8);
    out.extend_from_slice(&(head.len() as u64).to_le_bytes());
    out.extend_from_slice(&head);
    for p in motion.positions() {
        for c in p {
            out.extend_from_slice(&c.to_le_bytes());
        }
    }
    for v in values.iter().chain(motion.channels().values()) {
        out.extend_from_slice(&v.to_le_bytes());
    }
    Ok(out)
}

fn f64s(bytes: &[u8]) -> impl Iterator<Item = f64> + '_ {
    bytes.chunks_exact(8).map(|c| {
        let mut b = [0u8; 8];
        b.copy_from_slice(c);
        f64::from_le_bytes(b)
    })
}

/// Decodes what [`encode`] wrote. Any inconsistency is an error (the caller then recomputes).
pub fn decode(bytes: &[u8]) -> Result<(Motion, Option<Segmentation>)> {
    let len_bytes: [u8; 8] =
        bytes.get(..8).and_then(|s| s.try_into().ok()).ok_or_else(|| bad("too short"))?;
    let head_len =
        usize::try_from(u64::from_le_bytes(len_bytes)).map_err(|_| bad("header length"))?;
    let head =
        bytes.get(8..8usize.saturating_add(head_len)).ok_or_else(|| bad("header past the end"))?;
    let h: Header = rmp_serde::from_slice(head).map_err(|e| bad(format!("header: {e}")))?;
    let body = &bytes[8 + head_len..];
    let n_frames = usize::try_from(h.n_frames).map_err(|_| bad("frame count"))?;
    let n_pos = n_frames
        .checked_mul(h.point_names.len())
        .and_then(|n| n.checked_mul(3))
        .ok_or_else(|| bad("size"))?;
    let pos_bytes = body.get(..n_pos * 8).ok_or_else(|| bad("positions past the end"))?;
    let flat: Vec<f64> = f64s(pos_bytes).collect();
    let positions: Vec<[f64; 3]> = flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    let kind = if h.joints_not_markers { PointKind::Joint } else { PointKind::Marker };
    let mut rest = &body[n_pos * 8..];
    // The motion's own channels are the last values.
    let channels = match h.channels {
        None => None,
        Some((names, units)) => {
            let n = n_frames
                .checked_mul(names.len())
                .and_then(|n| n.checked_mul(8))
                .ok_or_else(|| bad("size"))?;
            let at = rest.len().checked_sub(n).ok_or_else(|| bad("channels past the end"))?;
            let values = f64s(&rest[at..]).collect();
            rest = &rest[..at];
            Some(Channels::new(names, units, values)?)
        }
    };
    let rate = FrameRate::new(h.frame_rate_hz)?;
    let mut motion = match (h.point_names.is_empty(), channels) {
        (true, Some(c)) => Motion::from_channels(h.name, rate, c)?,
        (_, c) => {
            let m = Motion::new(h.name, rate, h.up_axis, kind, h.point_names, positions)?;
            match c {
                Some(c) => m.with_channels(c)?,
                None => m,
            }
        }
    };
    if motion.n_frames() != n_frames {
        return Err(bad("frame count differs"));
    }
    motion.source = h.source;
    motion.format = h.format;
    motion.events = h
        .events
        .into_iter()
        .map(|(label, context, t, frame)| Event { label, context, time: Seconds(t), frame })
        .collect();
    motion.load_notes = h.load_notes;
    if h.dimensionality == Dimensionality::Two {
        motion = motion.into_image_2d();
    }
    if let Some(c) = h.confidence {
        motion = motion.with_confidence(c)?;
    }
    match h.skeleton {
        Some(joints) => {
            let joints: Vec<Joint> =
                joints
                    .into_iter()
                    .map(|j| Joint {
                        name: j.name,
                        parent: j.parent,
                        offset: j.offset,
                        channels: j
                            .channels
                            .into_iter()
                            .map(|(t, a)| {
                                if t {
                                    ChannelKind::Translation(a)
                                } else {
                                    ChannelKind::Rotation(a)
                                }
                            })
                            .collect(),
                        rotation_order: j.rotation_order,
                        axis: Rotation3::from_matrix_unchecked(Matrix3::from_column_slice(&j.axis)),
                        end_sites: j.end_sites,
                    })
                    .collect();
            let skeleton = Skeleton { joints };
            let expected =
                n_frames.checked_mul(skeleton.n_channels()).ok_or_else(|| bad("size"))?;
            if rest.len() != expected * 8 {
                return Err(bad("channel values have the wrong length"));
            }
            motion.skeleton = Some(SkeletonMotion::new(skeleton, f64s(rest).collect())?);
        }
        None if !rest.is_empty() => return Err(bad("trailing bytes")),
        None => {}
    }
    let truth = match h.truth {
        Some(t) => Some(Segmentation {
            frame_rate: FrameRate::new(t.frame_rate_hz)?,
            boundaries: t.boundaries,
            segments: t.segments,
            annotators: t.annotators,
            annotator_names: t.annotator_names,
        }),
        None => None,
    };
    Ok((motion, truth))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_2d_motion_with_confidence_comes_back_2d_with_its_confidence() {
        let rate = FrameRate::new(60.0).unwrap();
        let pos = vec![[505.232, 431.63, 0.0], [f64::NAN; 3]];
        let m =
            Motion::new("cam", rate, Axis::Y, PointKind::Marker, vec!["a".into(), "b".into()], pos)
                .unwrap()
                .into_image_2d()
                .with_confidence(vec![0.664216, 0.0])
                .unwrap();
        let (back, _) = decode(&encode(&m, None).unwrap()).unwrap();
        assert_eq!(back.dimensionality(), Dimensionality::Two);
        assert_eq!(back.confidence(), Some(&[0.664216_f32, 0.0][..]));
        assert_eq!(back.position(0, 0), [505.232, 431.63, 0.0]);
        assert!(back.is_missing(0, 1));
        let (plain, _) = decode(
            &encode(
                &Motion::new(
                    "p",
                    rate,
                    Axis::Y,
                    PointKind::Marker,
                    vec!["a".into()],
                    vec![[1.0, 2.0, 3.0]],
                )
                .unwrap(),
                None,
            )
            .unwrap(),
        )
        .unwrap();
        assert_eq!((plain.dimensionality(), plain.confidence()), (Dimensionality::Three, None));
    }

    #[test]
    fn round_trip_keeps_every_bit() {
        let rate = FrameRate::new(120.0).unwrap();
        let pos = vec![
            [1.5, -0.0, 1e-300],
            [f64::NAN, f64::NAN, f64::NAN],
            [3.0, 4.0, 5.0],
            [0.1, 0.2, 0.3],
        ];
        let mut m =
            Motion::new("take", rate, Axis::Y, PointKind::Joint, vec!["a".into(), "b".into()], pos)
                .unwrap()
                .with_source("/x/take.amc", "asf_amc");
        let mut root = Joint::new(
            "a",
            None,
            [0.0, 0.0, 0.0],
            vec![ChannelKind::Translation(Axis::X), ChannelKind::Rotation(Axis::Z)],
        );
        root.axis = Rotation3::from_axis_angle(&nalgebra::Vector3::x_axis(), 0.3);
        let child =
            Joint::new("b", Some(0), [0.0, 10.0, 0.0], vec![ChannelKind::Rotation(Axis::X)]);
        m.skeleton = Some(
            SkeletonMotion::new(
                Skeleton { joints: vec![root, child] },
                vec![1.0, 2.0, 3.0, 4.0, 5.0, 0.1],
            )
            .unwrap(),
        );
        m.events.push(Event {
            label: "Foot Strike".into(),
            context: "Left".into(),
            time: Seconds(0.5),
            frame: 1.25,
        });
        m.load_notes.length_unit = Some(motionlab_core::LengthUnit::CmuUnit);
        m.load_notes.length_unit_from = "ASF :units length 0.45".into();
        m.load_notes.repairs = vec!["duplicate label \"a\" renamed".into()];
        let bytes = encode(&m, None).unwrap();
        let (back, truth) = decode(&bytes).unwrap();
        assert!(truth.is_none());
        let bits =
            |m: &Motion| m.positions().iter().flat_map(|p| p.map(f64::to_bits)).collect::<Vec<_>>();
        assert_eq!(bits(&back), bits(&m));
        assert_eq!(back.missing_mask(), m.missing_mask());
        assert_eq!(back.point_names(), m.point_names());
        assert_eq!(
            (back.name.as_str(), back.format.as_str(), back.source.clone()),
            (m.name.as_str(), m.format.as_str(), m.source.clone())
        );
        let (s0, s1) = (m.skeleton.as_ref().unwrap(), back.skeleton.as_ref().unwrap());
        assert_eq!(s0.skeleton, s1.skeleton);
        assert_eq!(s0.channel_values(), s1.channel_values());
        assert_eq!(back.events, m.events);
        assert_eq!(back.load_notes, m.load_notes);
        // Damaged payloads are errors, never a different motion.
        assert!(decode(&bytes[..bytes.len() - 8]).is_err());
        assert!(decode(&bytes[..5]).is_err());
    }

    #[test]
    fn channels_round_trip_with_and_without_points() {
        let rate = FrameRate::new(1.0).unwrap();
        let c = Channels::new(
            vec!["value".into(), "b".into()],
            vec![String::new(), "mm/s".into()],
            vec![1.0, f64::NAN, -2.5, 1e-300],
        )
        .unwrap();
        let series = Motion::from_channels("Adiac", rate, c.clone())
            .unwrap()
            .with_source("/x/Adiac.txt", "channels");
        let (back, _) = decode(&encode(&series, None).unwrap()).unwrap();
        assert_eq!((back.n_points(), back.n_frames()), (0, 2));
        let bits = |c: &Channels| c.values().iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(back.channels()), bits(&c));
        assert_eq!((back.channels().names(), back.channels().units()), (c.names(), c.units()));
        let take = Motion::new(
            "t",
            rate,
            Axis::Y,
            PointKind::Marker,
            vec!["a".into()],
            vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]],
        )
        .unwrap()
        .with_channels(c.clone())
        .unwrap();
        let bytes = encode(&take, None).unwrap();
        let (back, _) = decode(&bytes).unwrap();
        assert_eq!((back.positions(), bits(back.channels())), (take.positions(), bits(&c)));
        assert!(decode(&bytes[..bytes.len() - 8]).is_err());
    }
}
