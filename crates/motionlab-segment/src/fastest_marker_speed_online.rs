//! `fastest_marker_speed_online`: Sonoda et al.'s fastest-marker tracker (§2.1) deciding
//! while the frames arrive.

use std::collections::VecDeque;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{
    DataKind, Decision, Error, ErrorKind, Point3, Result, SegmenterSession, StreamLayout, Streamed,
    StreamingSegmenter, TimeSpan,
};
use motionlab_features::speed::step_speeds;

use crate::stream_frames::{frame_points, require_points};

/// The fastest-marker tracker of `fastest_marker_speed` (Sonoda et al. §2.1: from each local
/// maximum of V ≥ `v_high_mm_per_s`, follow its marker k to its own next local minimum j; j is
/// a candidate when V[j] ≤ `v_low_mm_per_s`), run causally on a stream of frames: the same
/// steps, taken as soon as the frames they read have arrived, so its candidates are exactly
/// `fastest_marker_speed`'s with these thresholds in mm/s and this smoothing.
///
/// **Lag, stated:** candidate j is decided when frame j + 2 + h arrives, h = ⌊w/2⌋ for a
/// smoothing window of w > 1 frames (h = 0 without smoothing): V[j] is the speed from frame j
/// to j + 1, a local minimum needs the next speed too (frame j + 2), and a centred average
/// needs h frames past its centre. At the end of a stream the last h smoothed frames are
/// averaged over what there is (as offline), and candidates found then are decided at the end.
///
/// **Thresholds in mm/s only.** `fastest_marker_speed`'s default thresholds are fractions of
/// the take's 90th-percentile speed, which only the whole take gives; a stream needs them in
/// mm/s.
///
/// **Memory**: the last 2h + 1 frames and three frames of speeds: constant however long the
/// stream. **Missing samples**: as `fastest_marker_speed` — a marker missing at either frame of
/// a step has no speed and is skipped for V; a missing speed of the followed marker is never a
/// local minimum; the centred average skips missing samples and leaves a missing one missing.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FastestMarkerSpeedOnlineParams {
    /// A local maximum of V starts a followed stretch when V ≥ this, mm/s.
    pub v_high_mm_per_s: f64,
    /// The followed marker's minimum j is a candidate when V[j] ≤ this, mm/s (below
    /// `v_high_mm_per_s`).
    pub v_low_mm_per_s: f64,
    /// Centred moving-average window on positions before differentiating (`{ frames = 5 }` or
    /// `{ seconds = 0.05 }`); adds half the window to the lag.
    #[serde(default)]
    #[schemars(extend("x-default" = "raw positions"))]
    pub smoothing: Option<TimeSpan>,
}

/// The validated stage.
#[derive(Clone, Debug, PartialEq)]
pub struct FastestMarkerSpeedOnline {
    pub v_high_mm_per_s: f64,
    pub v_low_mm_per_s: f64,
    pub smoothing: Option<TimeSpan>,
}

impl ParamGuard for FastestMarkerSpeedOnlineParams {
    type Checked = Streamed<FastestMarkerSpeedOnline>;
    fn check(self) -> Result<Streamed<FastestMarkerSpeedOnline>> {
        for (field, v) in
            [("v_high_mm_per_s", self.v_high_mm_per_s), ("v_low_mm_per_s", self.v_low_mm_per_s)]
        {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::new(
                    ErrorKind::OutOfRange,
                    format!("{field} is {v}, expected a speed > 0 mm/s"),
                )
                .with_field(field));
            }
        }
        if self.v_low_mm_per_s >= self.v_high_mm_per_s {
            return Err(Error::new(
                ErrorKind::InvalidParameter,
                format!(
                    "v_low_mm_per_s ({}) must be below v_high_mm_per_s ({})",
                    self.v_low_mm_per_s, self.v_high_mm_per_s
                ),
            )
            .with_field("v_low_mm_per_s"));
        }
        let smoothing = self.smoothing.map(|s| s.check("smoothing", false)).transpose()?;
        Ok(Streamed(FastestMarkerSpeedOnline {
            v_high_mm_per_s: self.v_high_mm_per_s,
            v_low_mm_per_s: self.v_low_mm_per_s,
            smoothing,
        }))
    }
}

impl FastestMarkerSpeedOnline {
    /// Half the smoothing window at `rate` (0 without smoothing): frames of lag it adds.
    pub fn smoothing_half(&self, rate: motionlab_core::FrameRate) -> (usize, usize) {
        let w = self.smoothing.map(|s| s.whole_frames_at(rate)).unwrap_or(0);
        (w, if w > 1 { w / 2 } else { 0 })
    }
    /// The stated lag in frames at `rate`: 2 + ⌊w/2⌋.
    pub fn lag_frames(&self, rate: motionlab_core::FrameRate) -> usize {
        2 + self.smoothing_half(rate).1
    }
}

impl StreamingSegmenter for FastestMarkerSpeedOnline {
    fn consumes(&self) -> DataKind {
        DataKind::Points
    }
    fn start(&self, layout: &StreamLayout) -> Result<Box<dyn SegmenterSession>> {
        let m = require_points(layout, "fastest_marker_speed_online")?;
        let (w, half) = self.smoothing_half(layout.rate);
        Ok(Box::new(SpeedSession {
            m,
            fps: layout.rate.hz(),
            smooth: w > 1,
            half,
            v_high: self.v_high_mm_per_s,
            v_low: self.v_low_mm_per_s,
            seen: 0,
            raw: VecDeque::with_capacity(2 * half + 2),
            smoothed_count: 0,
            prev: None,
            rows: VecDeque::with_capacity(4),
            state: Track::Seek { s: 1 },
            scratch: Vec::with_capacity(m),
        }))
    }
}

/// One step's speeds: V, the marker giving it, every marker's speed (mm/s).
struct SpeedRow {
    fastest: f64,
    fastest_marker: Option<usize>,
    speeds: Vec<f64>,
}

/// Where the tracker is (the offline loop's variables).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Track {
    /// Looking for a qualifying maximum of V at or after `s`.
    Seek { s: usize },
    /// Following marker `k` from the maximum at `i` to its own next minimum.
    Follow { i: usize, k: usize },
}

struct SpeedSession {
    m: usize,
    fps: f64,
    smooth: bool,
    half: usize,
    v_high: f64,
    v_low: f64,
    /// Raw frames pushed.
    seen: usize,
    /// The last 2·half + 1 raw frames (the back is frame `seen − 1`).
    raw: VecDeque<Vec<Point3>>,
    /// Smoothed frames produced (the next one's index).
    smoothed_count: usize,
    /// The last smoothed frame, flat.
    prev: Option<Vec<f64>>,
    /// The last three speed rows (the back is row `smoothed_count − 2`).
    rows: VecDeque<SpeedRow>,
    state: Track,
    scratch: Vec<Point3>,
}

impl SpeedSession {
    /// Smoothed frame `f` over raw frames `f − half .. hi` (all held in `raw`), with
    /// `moving_average_positions`' operations in its order.
    fn smoothed(&self, f: usize, hi: usize) -> Vec<f64> {
        let front = self.seen - self.raw.len();
        let at = |j: usize| &self.raw[j - front];
        if !self.smooth {
            return at(f).as_flattened().to_vec();
        }
        let lo = f.saturating_sub(self.half);
        let mut out = Vec::with_capacity(3 * self.m);
        for k in 0..self.m {
            let p = at(f)[k];
            if p[0].is_nan() {
                out.extend_from_slice(&p);
                continue;
            }
            let mut acc = [0.0; 3];
            let mut n = 0.0;
            for j in lo..hi {
                let p = at(j)[k];
                if !p[0].is_nan() {
                    acc = [acc[0] + p[0], acc[1] + p[1], acc[2] + p[2]];
                    n += 1.0;
                }
            }
            out.extend_from_slice(&[acc[0] / n, acc[1] / n, acc[2] / n]);
        }
        out
    }

    /// Takes smoothed frame `smoothed_count`; decisions made now are `decided_at`.
    fn take_smoothed(&mut self, frame: Vec<f64>, decided_at: usize, decided: &mut Vec<Decision>) {
        self.smoothed_count += 1;
        let Some(prev) = self.prev.replace(frame) else { return };
        let cur = self.prev.as_deref().unwrap_or_default();
        let mut speeds = vec![f64::NAN; self.m];
        let top = step_speeds(&prev, cur, self.fps, &mut speeds);
        if self.rows.len() == 3 {
            self.rows.pop_front();
        }
        self.rows.push_back(SpeedRow {
            fastest: top.map_or(f64::NAN, |t| t.1),
            fastest_marker: top.map(|t| t.0),
            speeds,
        });
        // The newest row is q = smoothed_count − 2; the step examines centre c = q − 1.
        let q = self.smoothed_count - 2;
        if q < 2 {
            return;
        }
        let c = q - 1;
        let v = |r: usize| self.rows[r].fastest; // rows[0] = c − 1, rows[1] = c, rows[2] = c + 1
        loop {
            match self.state {
                Track::Seek { s } => {
                    if c >= s && v(1) >= self.v_high && v(0) < v(1) && v(1) > v(2) {
                        self.state = match self.rows[1].fastest_marker {
                            Some(k) => Track::Follow { i: c, k },
                            None => Track::Seek { s: c + 1 },
                        };
                    }
                    break;
                }
                Track::Follow { i, k } => {
                    let vk = |r: usize| self.rows[r].speeds[k];
                    if c > i && vk(0) > vk(1) && vk(1) < vk(2) {
                        if v(1) <= self.v_low {
                            decided.push(Decision { boundary: c, decided_at });
                            self.state = Track::Seek { s: c + 1 };
                            break;
                        }
                        // The motion goes on: the next maximum may be at this very frame.
                        self.state = Track::Seek { s: c };
                        continue;
                    }
                    break;
                }
            }
        }
    }
}

impl SegmenterSession for SpeedSession {
    fn width(&self) -> usize {
        3 * self.m
    }
    fn samples_seen(&self) -> usize {
        self.seen
    }
    fn push_sample(&mut self, sample: &[f64], decided: &mut Vec<Decision>) -> Result<()> {
        let r = self.seen;
        let mut points = std::mem::take(&mut self.scratch);
        frame_points(sample, self.m, r, "fastest_marker_speed_online", &mut points)?;
        let keep = 2 * self.half + 1;
        let frame = if self.raw.len() == keep {
            // Reuse the oldest frame's buffer.
            let mut old = self.raw.pop_front().unwrap_or_default();
            old.clear();
            old.extend_from_slice(&points);
            old
        } else {
            points.clone()
        };
        self.scratch = points;
        self.raw.push_back(frame);
        self.seen += 1;
        if r >= self.half {
            let f = r - self.half;
            let s = self.smoothed(f, r + 1);
            self.take_smoothed(s, r, decided);
        }
        Ok(())
    }
    fn finish(&mut self, decided: &mut Vec<Decision>) -> Result<()> {
        // The last frames' averages, over the frames there are (as offline at the end).
        let n = self.seen;
        while self.smoothed_count < n {
            let s = self.smoothed(self.smoothed_count, n);
            self.take_smoothed(s, n, decided);
        }
        Ok(())
    }
}

motionlab_core::register_plugin!(
    Segmenter,
    FastestMarkerSpeedOnlineParams,
    "fastest_marker_speed_online"
);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fastest_marker_speed::track_fastest_marker;
    use motionlab_core::streaming::run_offline;
    use motionlab_core::{FeatureCache, Motion, Segmenter};
    use motionlab_features::speed::marker_speeds;
    use motionlab_testkit::motion_from_fn;

    fn online(text: &str) -> FastestMarkerSpeedOnline {
        toml::from_str::<FastestMarkerSpeedOnlineParams>(text).unwrap().check().unwrap().0
    }

    /// Two markers along x and y whose speeds (mm/s at 100 Hz) burst and stop: A at 60 and
    /// 230, B at 100 (overlapping A's slowing), both slow together near 160 and 280.
    fn stop_go(gap: bool) -> Motion {
        let bump = |t: f64, c: f64, w: f64| (-((t - c) / w).powi(2)).exp();
        let base =
            |t: f64| 5.0 + 10.0 * (1.0 - (2.0 * std::f64::consts::PI * (t - 160.0) / 120.0).cos());
        let speed = |k: usize, t: f64| {
            if k == 0 {
                1000.0 * bump(t, 60.0, 8.0) + 1000.0 * bump(t, 230.0, 12.0) + base(t)
            } else {
                1000.0 * bump(t, 100.0, 12.0) + base(t)
            }
        };
        let mut pos = [0.0f64; 2];
        let mut traj = vec![[[0.0; 3]; 2]; 320];
        for (i, frame) in traj.iter_mut().enumerate() {
            *frame = [[pos[0], 0.0, 0.0], [0.0, pos[1], 0.0]];
            for (k, p) in pos.iter_mut().enumerate() {
                *p += speed(k, i as f64) / 100.0;
            }
        }
        motion_from_fn(320, 100.0, 2, |i, k| {
            if gap && k == 1 && (120..126).contains(&i) { [f64::NAN; 3] } else { traj[i][k] }
        })
    }

    fn offline(m: &Motion, on: &FastestMarkerSpeedOnline) -> Vec<usize> {
        let (w, _) = on.smoothing_half(m.frame_rate());
        track_fastest_marker(&marker_speeds(m, w), on.v_high_mm_per_s, on.v_low_mm_per_s).candidates
    }

    fn stream(m: &Motion, on: &FastestMarkerSpeedOnline) -> Vec<Decision> {
        let (layout, samples) = StreamLayout::of_motion(m, DataKind::Points, "t").unwrap();
        // Frame by frame, as a live capture gives them.
        let mut s = on.start(&layout).unwrap();
        let mut decided = Vec::new();
        for f in samples.chunks(layout.width()) {
            s.push_sample(f, &mut decided).unwrap();
        }
        s.finish(&mut decided).unwrap();
        assert_eq!(decided, run_offline(on, &layout, samples).unwrap());
        decided
    }

    #[test]
    fn the_stream_finds_the_two_stops_two_frames_after_each() {
        let m = stop_go(false);
        let on = online("v_high_mm_per_s = 500.0\nv_low_mm_per_s = 40.0");
        let decided = stream(&m, &on);
        let boundaries: Vec<usize> = decided.iter().map(|d| d.boundary).collect();
        // The two real stops (both markers slow), not the hand-over near 76 where only A slows.
        assert_eq!(boundaries.len(), 2, "{decided:?}");
        assert!((150..=170).contains(&boundaries[0]) && (270..=290).contains(&boundaries[1]));
        assert_eq!(boundaries, offline(&m, &on));
        assert!(decided.iter().all(|d| d.decided_at == d.boundary + 2), "{decided:?}");
        assert_eq!(on.lag_frames(m.frame_rate()), 2);
    }

    #[test]
    fn smoothed_and_gappy_streams_equal_the_offline_tracker_within_the_stated_lag() {
        for (gap, smoothing) in [(false, 5), (true, 9), (true, 0), (false, 2)] {
            let m = stop_go(gap);
            let text = format!(
                "v_high_mm_per_s = 400.0\nv_low_mm_per_s = 40.0\nsmoothing = {{ frames = {smoothing} }}"
            );
            let on = online(&text);
            let decided = stream(&m, &on);
            let boundaries: Vec<usize> = decided.iter().map(|d| d.boundary).collect();
            assert!(!boundaries.is_empty());
            assert_eq!(boundaries, offline(&m, &on), "gap {gap}, smoothing {smoothing}");
            let lag = on.lag_frames(m.frame_rate());
            assert_eq!(lag, 2 + if smoothing > 1 { smoothing / 2 } else { 0 });
            for d in &decided {
                // Exactly the lag, or at the end of the stream for a stop near it.
                assert!(
                    d.decided_at == d.boundary + lag || d.decided_at == m.n_frames(),
                    "{d:?}, lag {lag}"
                );
            }
            // The offline adapter gives the same candidates, as `fastest_marker_speed` would.
            let out = Streamed(on).segment(&m, &FeatureCache::new()).unwrap();
            assert_eq!(out.candidates, boundaries);
        }
    }

    #[test]
    fn thresholds_must_be_mm_per_s_in_order_and_samples_whole_frames() {
        let bad = |t: &str| {
            toml::from_str::<FastestMarkerSpeedOnlineParams>(t)
                .map_err(|e| e.to_string())
                .and_then(|p| p.check().map_err(|e| e.location().field.clone().unwrap_or_default()))
                .err()
                .unwrap()
        };
        assert_eq!(bad("v_high_mm_per_s = 100.0\nv_low_mm_per_s = 200.0"), "v_low_mm_per_s");
        assert_eq!(bad("v_high_mm_per_s = -1.0\nv_low_mm_per_s = 0.5"), "v_high_mm_per_s");
        assert!(bad("v_high = { fraction_of_p90 = 0.5 }").contains("unknown field"));
        let on = online("v_high_mm_per_s = 500.0\nv_low_mm_per_s = 40.0");
        let rate = motionlab_core::FrameRate::new(100.0).unwrap();
        let layout =
            StreamLayout::points(vec!["a".into(), "b".into()], rate, motionlab_core::Axis::Y);
        let mut s = on.start(&layout).unwrap();
        let mut d = Vec::new();
        let e = s.push_sample(&[0.0; 5], &mut d).unwrap_err();
        assert!(e.to_string().contains("sample 0 has 5 values, expected 6"), "{e}");
        let channels = StreamLayout::channels(vec!["x".into()], rate);
        assert!(on.start(&channels).is_err());
    }
}
