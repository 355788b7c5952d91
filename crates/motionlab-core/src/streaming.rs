//! Streaming segmenters: boundaries decided while the samples arrive.
//!
//! A [`StreamingSegmenter`] starts a [`SegmenterSession`] on a stream of a known layout
//! ([`StreamLayout`]: channel rows, or frames of marker positions) and is pushed samples one
//! at a time or in blocks. Each boundary comes out as a [`Decision`] naming the boundary
//! sample and the sample whose arrival decided it, so the detection delay is
//! `decided_at − boundary` samples. A session keeps a bounded history — the method's window —
//! so a stream of any length runs in constant memory; each plugin states its bound and its lag.
//!
//! **Offline too, through one adapter.** A streaming plugin registers as an ordinary
//! [`Segmenter`] wrapped in [`Streamed`]: fed the whole series in one block, it answers wherever
//! a segmenter is accepted (segmentation, the benchmark, `input = { features = … }`, Python),
//! and [`Segmenter::streaming`] hands the streaming form to whoever can run it live (the
//! `live` command). The offline output is by construction what the stream decided: the same
//! code runs both ways.

use serde::{Deserialize, Serialize};

use crate::motion::Motion;
use crate::stage::{DataKind, FeatureCache, Segmenter, SegmenterOutput, Trace};
use crate::units::{Axis, FrameRate};
use crate::{Error, ErrorKind, Result};

/// One boundary a streaming segmenter decided.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Decision {
    /// The boundary, a sample index counted from the stream's first sample (0), in the
    /// method's own convention (its doc comment says which sample of the change it names).
    pub boundary: usize,
    /// The index of the sample whose arrival decided it (`n_samples` for a decision only the
    /// end of the stream could make). Detection delay = `decided_at − boundary` samples.
    pub decided_at: usize,
}

/// What each sample of a stream holds.
#[derive(Clone, Debug, PartialEq)]
pub struct StreamLayout {
    /// Channels (one value per name) or points (x, y, z in mm per name; NaN = missing).
    pub kind: DataKind,
    /// Channel or point names, in sample order.
    pub names: Vec<String>,
    /// Samples per second.
    pub rate: FrameRate,
    /// The vertical axis of point positions (Y for channels, which have none).
    pub up_axis: Axis,
}

impl StreamLayout {
    /// A stream of channel rows.
    pub fn channels(names: Vec<String>, rate: FrameRate) -> Self {
        StreamLayout { kind: DataKind::Channels, names, rate, up_axis: Axis::Y }
    }
    /// A stream of frames of point positions (mm) with `up_axis` vertical.
    pub fn points(names: Vec<String>, rate: FrameRate, up_axis: Axis) -> Self {
        StreamLayout { kind: DataKind::Points, names, rate, up_axis }
    }
    /// The index of a named channel or point; the error lists the closest names.
    pub fn index(&self, name: &str, stage: &str) -> Result<usize> {
        self.names.iter().position(|n| n == name).ok_or_else(|| {
            let close = crate::registry::closest_names(name, self.names.iter().map(String::as_str));
            let hint = if close.is_empty() {
                String::new()
            } else {
                format!(" (closest: {})", close.join(", "))
            };
            Error::new(
                ErrorKind::UnknownName,
                format!("{stage}: the stream has no {} named {name:?}{hint}", self.kind_noun()),
            )
        })
    }
    fn kind_noun(&self) -> &'static str {
        match self.kind {
            DataKind::Channels => "channel",
            DataKind::Points => "marker or joint",
        }
    }
    /// Values per sample: one per channel, three per point.
    pub fn width(&self) -> usize {
        match self.kind {
            DataKind::Channels => self.names.len(),
            DataKind::Points => 3 * self.names.len(),
        }
    }
    /// The layout of `motion` read as `kind`, and its samples, sample-major: its channels, or
    /// its positions frame by frame.
    pub fn of_motion<'a>(
        motion: &'a Motion,
        kind: DataKind,
        stage: &str,
    ) -> Result<(Self, &'a [f64])> {
        match kind {
            DataKind::Channels => {
                let c = motion.require_channels(stage)?;
                Ok((StreamLayout::channels(c.names().to_vec(), motion.frame_rate()), c.values()))
            }
            DataKind::Points => {
                motion.require_points(stage)?;
                Ok((
                    StreamLayout::points(
                        motion.point_names().to_vec(),
                        motion.frame_rate(),
                        motion.up_axis(),
                    ),
                    motion.positions().as_flattened(),
                ))
            }
        }
    }
}

/// A segmenter that decides boundaries as samples arrive.
pub trait StreamingSegmenter: Send + Sync {
    /// What a stream's samples hold: channels (the default) or point positions.
    fn consumes(&self) -> DataKind {
        DataKind::Channels
    }
    /// A fresh session on a stream of this layout; fails when the layout cannot be read (no
    /// channel, a rate the parameters cannot use).
    fn start(&self, layout: &StreamLayout) -> Result<Box<dyn SegmenterSession>>;
}

/// One stream being segmented.
pub trait SegmenterSession: Send {
    /// Values per sample (the layout's width).
    fn width(&self) -> usize;
    /// Samples pushed so far.
    fn samples_seen(&self) -> usize;
    /// Takes the next sample (`width` values) and appends the boundaries its arrival decided.
    fn push_sample(&mut self, sample: &[f64], decided: &mut Vec<Decision>) -> Result<()>;
    /// The stream has ended: appends what only the end decides (`decided_at = samples_seen`).
    fn finish(&mut self, decided: &mut Vec<Decision>) -> Result<()> {
        let _ = decided;
        Ok(())
    }
    /// Takes a block of whole samples (sample-major) and appends the boundaries decided on it.
    fn push(&mut self, samples: &[f64], decided: &mut Vec<Decision>) -> Result<()> {
        let w = self.width();
        if w == 0 || !samples.len().is_multiple_of(w) {
            return Err(Error::new(
                ErrorKind::WrongValueCount,
                format!(
                    "{} values do not make whole samples of {w} values each (sample-major)",
                    samples.len()
                ),
            ));
        }
        for s in samples.chunks_exact(w) {
            self.push_sample(s, decided)?;
        }
        Ok(())
    }
}

/// Checks a sample's width and values: `width` values, none infinite (NaN = missing is each
/// plugin's to treat). What every session's `push_sample` calls first, so a bad sample is one
/// clear error naming the sample.
pub fn check_sample(sample: &[f64], width: usize, index: usize, stage: &str) -> Result<()> {
    if sample.len() != width {
        return Err(Error::new(
            ErrorKind::WrongValueCount,
            format!("{stage}: sample {index} has {} values, expected {width}", sample.len()),
        ));
    }
    if let Some(k) = sample.iter().position(|v| v.is_infinite()) {
        return Err(Error::new(
            ErrorKind::NonFinite,
            format!(
                "{stage}: value {k} of sample {index} is {}, expected a finite number or NaN (missing)",
                sample[k]
            ),
        ));
    }
    Ok(())
}

/// Every decision of `segmenter` on the whole of `samples` (sample-major), pushed as one block
/// and then ended: the offline run of a streaming segmenter.
pub fn run_offline(
    segmenter: &dyn StreamingSegmenter,
    layout: &StreamLayout,
    samples: &[f64],
) -> Result<Vec<Decision>> {
    let mut session = segmenter.start(layout)?;
    let mut decided = Vec::new();
    session.push(samples, &mut decided)?;
    session.finish(&mut decided)?;
    Ok(decided)
}

/// A [`SegmenterOutput`] of decisions on `n_samples` samples: the candidates are the boundaries
/// strictly inside the series (sorted, unique), and the trace `decision_delay_samples` holds,
/// at each candidate, how many samples after it it was decided (NaN elsewhere).
pub fn decisions_output(decided: &[Decision], n_samples: usize) -> SegmenterOutput {
    let mut delay = vec![f64::NAN; n_samples];
    let mut candidates = Vec::new();
    for d in decided.iter().filter(|d| d.boundary > 0 && d.boundary < n_samples) {
        candidates.push(d.boundary);
        let slot = &mut delay[d.boundary];
        let lag = d.decided_at.saturating_sub(d.boundary) as f64;
        // The first decision of a boundary decided twice is when it was known.
        if slot.is_nan() {
            *slot = lag;
        }
    }
    candidates.sort_unstable();
    candidates.dedup();
    SegmenterOutput {
        candidates,
        traces: vec![Trace::new("decision_delay_samples", "samples", delay)],
        ..Default::default()
    }
}

/// The one adapter that makes a streaming segmenter an offline [`Segmenter`]: the whole motion
/// (its channels, or its positions) pushed as one block. Plugins register `Streamed<Stage>` as
/// their checked type, so every streaming plugin is also a segmenter, and
/// [`Segmenter::streaming`] gives back the streaming form.
#[derive(Clone, Debug, PartialEq)]
pub struct Streamed<S>(pub S);

impl<S: StreamingSegmenter + 'static> Segmenter for Streamed<S> {
    fn consumes(&self) -> DataKind {
        self.0.consumes()
    }
    fn segment(&self, motion: &Motion, _cache: &FeatureCache) -> Result<SegmenterOutput> {
        let (layout, samples) = StreamLayout::of_motion(motion, self.0.consumes(), &motion.name)?;
        let n = samples.len() / layout.width().max(1);
        let decided = run_offline(&self.0, &layout, samples)?;
        Ok(decisions_output(&decided, n))
    }
    fn streaming(&self) -> Option<&dyn StreamingSegmenter> {
        Some(&self.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Channels;

    /// Decides a boundary at every sample whose first value jumps by more than 1 from the
    /// previous one, one sample late (it waits for the next sample to confirm the level).
    struct Jumps;
    struct JumpSession {
        seen: usize,
        last: Vec<f64>,
        pending: Option<usize>,
    }
    impl StreamingSegmenter for Jumps {
        fn start(&self, layout: &StreamLayout) -> Result<Box<dyn SegmenterSession>> {
            assert_eq!(layout.width(), 1);
            Ok(Box::new(JumpSession { seen: 0, last: Vec::new(), pending: None }))
        }
    }
    impl SegmenterSession for JumpSession {
        fn width(&self) -> usize {
            1
        }
        fn samples_seen(&self) -> usize {
            self.seen
        }
        fn push_sample(&mut self, sample: &[f64], decided: &mut Vec<Decision>) -> Result<()> {
            check_sample(sample, 1, self.seen, "jumps")?;
            if let Some(b) = self.pending.take() {
                decided.push(Decision { boundary: b, decided_at: self.seen });
            }
            if let Some(&prev) = self.last.last()
                && (sample[0] - prev).abs() > 1.0
            {
                self.pending = Some(self.seen);
            }
            self.last = sample.to_vec();
            self.seen += 1;
            Ok(())
        }
        fn finish(&mut self, decided: &mut Vec<Decision>) -> Result<()> {
            if let Some(b) = self.pending.take() {
                decided.push(Decision { boundary: b, decided_at: self.seen });
            }
            Ok(())
        }
    }

    #[test]
    fn offline_is_the_stream_fed_at_once_and_delays_are_kept() {
        let x = [0.0, 0.0, 5.0, 5.0, 5.0, 0.0];
        let rate = FrameRate::new(10.0).unwrap();
        let layout = StreamLayout::channels(vec!["x".into()], rate);
        // One sample at a time and one block give the same decisions.
        let mut s = Jumps.start(&layout).unwrap();
        let mut one_by_one = Vec::new();
        for v in x {
            s.push(&[v], &mut one_by_one).unwrap();
        }
        s.finish(&mut one_by_one).unwrap();
        let block = run_offline(&Jumps, &layout, &x).unwrap();
        assert_eq!(one_by_one, block);
        assert_eq!(
            block,
            [Decision { boundary: 2, decided_at: 3 }, Decision { boundary: 5, decided_at: 6 }]
        );
        // Through the adapter, as any segmenter runs.
        let c = Channels::new(vec!["x".into()], vec![String::new()], x.to_vec()).unwrap();
        let m = Motion::from_channels("m", rate, c).unwrap();
        let seg = Streamed(Jumps);
        let out = seg.segment(&m, &FeatureCache::new()).unwrap();
        assert_eq!(out.candidates, vec![2, 5]);
        let delay = &out.traces[0].values;
        assert_eq!((delay[2], delay[5]), (1.0, 1.0));
        assert!(delay[0].is_nan() && delay[3].is_nan());
        assert!(seg.streaming().is_some());
        // A block that is not whole samples, and an infinite value, are one clear error each.
        let mut s = Jumps.start(&layout).unwrap();
        let mut d = Vec::new();
        assert!(s.push(&[], &mut d).is_ok());
        let e = s.push_sample(&[f64::INFINITY], &mut d).unwrap_err();
        assert!(e.to_string().contains("value 0 of sample 0"), "{e}");
        let e = check_sample(&[1.0, 2.0], 1, 7, "jumps").unwrap_err();
        assert!(e.to_string().contains("sample 7 has 2 values, expected 1"), "{e}");
    }

    #[test]
    fn boundaries_at_the_ends_are_not_candidates() {
        let d = [
            Decision { boundary: 0, decided_at: 1 },
            Decision { boundary: 3, decided_at: 5 },
            Decision { boundary: 3, decided_at: 7 },
            Decision { boundary: 9, decided_at: 9 },
        ];
        let out = decisions_output(&d, 9);
        assert_eq!(out.candidates, vec![3]);
        assert_eq!(out.traces[0].values[3], 2.0);
    }
}
