//! Labeller `multistream_dp`: which segments of a take are the same motion, by the two-stage
//! multistream DP of Yabe & Tanaka between every pair of segments.

use std::ops::Range;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{DataKind, Error, ErrorKind, Labeller, Motion, Result, StateLabels};
use motionlab_features::clustering::{average_linkage, cut_at_distance, cut_to_k, k_by_silhouette};

use crate::dp::Trajectory3;
use crate::input::trajectories;
use crate::multistream::two_stage;

/// Multistream-DP state labelling for mocap: segments compared pairwise by the matching
/// paper's two-stage DP over all markers (speed-invariant), clustered agglomeratively.
///
/// 1. Each segment's trajectories of `points` (every point by default), sampled every
///    `round(motion rate / rate_hz)` frames, with each frame's centroid of those points
///    subtracted (**choice**: the same exercise done at another place in the room is the same
///    state; the facing direction is kept).
/// 2. For every pair (A, B): the two-stage DP of A as the model against B as the target
///    (`multistream_two_stage`: A matched in full to the best stretch of B, every marker over
///    the same stretch), `H(A→B) / (frames of A × points)`, and the same with the roles swapped;
///    the distance is the mean of the two (mm per sampled frame and point).
/// 3. Average-linkage clustering (UPGMA) of those distances; the states are the clusters after
///    every merge at or below `threshold_mm`, or — without a threshold — the silhouette rule
///    of `segment_clusters`: each segment its own state with one or two segments, else the
///    `k` in `2 ..= min(max_states, segments − 1)` with the largest silhouette.
///
/// **Choosing `threshold_mm` (the protocol):** leave-one-take-out on the five shipped labelled
/// mocap6 takes with the truth's own segments — for each take held out, the threshold with the
/// best mean AMI on the other four (candidates: every merge distance there, and 0; the
/// smallest on ties), scored on the held-out take
/// (`crates/motionlab-workflows/examples/multistream_dp_threshold.rs`). It chooses 0 — every
/// segment its own state — on every fold: within one mocap6 take an exercise rarely recurs
/// (one repeat in 30 segments), so never merging is nearly perfect there, and it is exactly
/// its own chance baseline. That choice says nothing about telling motions apart, so no
/// threshold is set unless the experiment sets one: the silhouette rule decides.
///
/// The result keeps the merge history and the distance matrix (mm). Cost: one DP per ordered
/// pair of segments, each `frames(A) × frames(B) × points` cells at the sampled rate.
///
/// Missing samples: **refused** (as the matcher: a missing sample has no distance to anything);
/// fill gaps first or choose `points`.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MultistreamDpParams {
    /// The markers or joints compared.
    #[serde(default)]
    #[schemars(extend("x-default" = "every point of the motion"))]
    pub points: Option<Vec<String>>,
    /// The rate the segments are sampled at before matching (Hz, > 0; the DP's cost grows with
    /// its square); the default keeps the motion of an exercise repetition (~1 s) in 20 samples.
    #[serde(default = "default_rate_hz")]
    pub rate_hz: f64,
    /// Segments at most this far apart (mm per sampled frame and point) join one state.
    #[serde(default)]
    #[schemars(extend("x-default" = "the silhouette rule"))]
    pub threshold_mm: Option<f64>,
    /// The largest number of states the silhouette rule may choose (≥ 2).
    #[serde(default = "default_max_states")]
    pub max_states: usize,
}

fn default_rate_hz() -> f64 {
    20.0
}

fn default_max_states() -> usize {
    12
}

/// The validated labeller.
#[derive(Clone, Debug)]
pub struct MultistreamDp {
    points: Option<Vec<String>>,
    rate_hz: f64,
    threshold_mm: Option<f64>,
    max_states: usize,
}

impl ParamGuard for MultistreamDpParams {
    type Checked = MultistreamDp;
    fn check(self) -> Result<MultistreamDp> {
        if !(self.rate_hz.is_finite() && self.rate_hz > 0.0) {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                format!("is {}; expected a rate above 0 Hz", self.rate_hz),
            )
            .with_field("rate_hz"));
        }
        if let Some(t) = self.threshold_mm.filter(|t| !(t.is_finite() && *t >= 0.0)) {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                format!("is {t}; expected a distance of at least 0 mm"),
            )
            .with_field("threshold_mm"));
        }
        if self.max_states < 2 {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                format!("is {}; expected at least 2", self.max_states),
            )
            .with_field("max_states"));
        }
        Ok(MultistreamDp {
            points: self.points,
            rate_hz: self.rate_hz,
            threshold_mm: self.threshold_mm,
            max_states: self.max_states,
        })
    }
}

impl MultistreamDp {
    /// The segment-by-segment distances (row-major, mm per sampled frame and point).
    pub fn distances(&self, motion: &Motion, segments: &[Range<usize>]) -> Result<Vec<f64>> {
        motion.require_points("multistream_dp")?;
        let names = self.points.clone().unwrap_or_else(|| motion.point_names().to_vec());
        let all = trajectories(motion, &names, "take", "multistream_dp")?;
        let n_frames = motion.n_frames();
        let step = ((motion.frame_rate().hz() / self.rate_hz).round() as usize).max(1);
        let mut pieces: Vec<Vec<Trajectory3>> = Vec::with_capacity(segments.len());
        for s in segments {
            if s.start >= s.end || s.end > n_frames {
                return Err(Error::new(
                    ErrorKind::OutOfRange,
                    format!(
                        "segment {}..{} is empty or outside the {n_frames} frames of {}",
                        s.start, s.end, motion.name
                    ),
                ));
            }
            let frames: Vec<usize> = (s.start..s.end).step_by(step).collect();
            let mut out: Vec<Trajectory3> =
                all.iter().map(|_| Trajectory3::with_capacity(frames.len())).collect();
            for &f in &frames {
                let mut c = [0.0; 3];
                for t in &all {
                    for (ca, pa) in c.iter_mut().zip(t.point(f)) {
                        *ca += pa / all.len() as f64;
                    }
                }
                for (o, t) in out.iter_mut().zip(&all) {
                    let p = t.point(f);
                    o.push([p[0] - c[0], p[1] - c[1], p[2] - c[2]]);
                }
            }
            pieces.push(out);
        }
        let n = segments.len();
        let per = |a: usize, b: usize| -> Result<f64> {
            let m = two_stage(&pieces[a], &pieces[b], false)?;
            Ok(m.alignment.total_distance / (pieces[a][0].len() * names.len()) as f64)
        };
        let mut d = vec![0.0; n * n];
        for a in 0..n {
            for b in a + 1..n {
                let v = 0.5 * (per(a, b)? + per(b, a)?);
                d[a * n + b] = v;
                d[b * n + a] = v;
            }
        }
        Ok(d)
    }
}

impl Labeller for MultistreamDp {
    fn consumes(&self) -> DataKind {
        DataKind::Points
    }
    fn label(&self, motion: &Motion, segments: &[Range<usize>]) -> Result<StateLabels> {
        let distances = self.distances(motion, segments)?;
        let n = segments.len();
        let merges = average_linkage(&distances, n)?;
        let segment_states = match self.threshold_mm {
            Some(t) => cut_at_distance(&merges, n, t),
            None => cut_to_k(&merges, n, k_by_silhouette(&distances, n, &merges, self.max_states)?),
        };
        Ok(StateLabels { segment_states, merges, distances })
    }
}

motionlab_core::register_plugin!(Labeller, MultistreamDpParams, "multistream_dp");

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_core::segments_of;
    use motionlab_testkit::motion_from_fn;

    /// Two motions of three markers at 100 Hz: A circles in the horizontal plane (each marker
    /// on its own radius, so the motion survives the centroid's removal), B bobs up and down
    /// (each marker at its own frequency); A B A B A, the third A at half speed and the second B somewhere else in the
    /// room. The DP is speed-invariant and the centroid removes the place: two states.
    #[test]
    fn same_motion_at_another_speed_or_place_is_one_state() {
        let lens = [200, 200, 400, 200, 200];
        let kinds = [0, 1, 0, 1, 0];
        let speeds = [1.0, 1.0, 0.5, 1.0, 1.0];
        let offsets = [0.0, 0.0, 0.0, 3000.0, 0.0];
        let mut starts = vec![0];
        for l in lens {
            starts.push(starts.last().unwrap() + l);
        }
        let n = *starts.last().unwrap();
        let m = motion_from_fn(n, 100.0, 3, |i, k| {
            let seg = starts.iter().rposition(|&s| s <= i).unwrap().min(4);
            let t = (i - starts[seg]) as f64 / 100.0 * speeds[seg];
            let base = [k as f64 * 100.0 + offsets[seg], 0.0, 1000.0];
            let w = 2.0 * std::f64::consts::PI * t;
            match kinds[seg] {
                0 => {
                    let r = 150.0 * (k as f64 + 1.0);
                    [base[0] + r * w.cos(), base[1] + r * w.sin(), base[2]]
                }
                _ => [base[0], base[1], base[2] + 300.0 * (w * (k as f64 + 1.0)).sin()],
            }
        });
        let segments = segments_of(&starts[1..5], n);
        let labeller =
            MultistreamDpParams { points: None, rate_hz: 20.0, threshold_mm: None, max_states: 12 }
                .check()
                .unwrap();
        let s = labeller.label(&m, &segments).unwrap();
        assert_eq!(s.segment_states, vec![0, 1, 0, 1, 0], "{:?}", s.distances);
        // The distances: small within a state, large across.
        let d = |a: usize, b: usize| s.distances[a * 5 + b];
        assert!(d(0, 2) < d(0, 1) / 5.0 && d(1, 3) < d(1, 2) / 5.0, "{:?}", s.distances);
        // A threshold of 1 µm: only the copies (the same motion at the same speed, here or
        // 3 m away) join; the slow A is its own state.
        let strict = MultistreamDpParams {
            points: None,
            rate_hz: 20.0,
            threshold_mm: Some(1e-3),
            max_states: 12,
        }
        .check()
        .unwrap();
        assert_eq!(strict.label(&m, &segments).unwrap().segment_states, vec![0, 1, 2, 1, 0]);
    }

    #[test]
    fn bad_parameters_name_their_field() {
        let p = |rate_hz, threshold_mm, max_states| MultistreamDpParams {
            points: None,
            rate_hz,
            threshold_mm,
            max_states,
        };
        for (params, field) in [
            (p(0.0, None, 12), "rate_hz"),
            (p(20.0, Some(-1.0), 12), "threshold_mm"),
            (p(20.0, None, 1), "max_states"),
        ] {
            let e = params.check().unwrap_err();
            assert!(e.to_string().contains(field), "{e}");
        }
    }
}
