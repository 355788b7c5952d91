//! Labeller `segment_clusters`: the classical baseline of state detection — each segment
//! summarised by a few numbers, the segments clustered.

use std::ops::Range;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{Error, ErrorKind, Labeller, Motion, Result, StateLabels};
use motionlab_features::clustering::{average_linkage, cut_to_k, k_by_silhouette};

/// Segment-feature clustering: states by clustering the segments' summary statistics.
///
/// Each segment is described by the mean and the standard deviation (population) of every
/// channel over its samples; each of these features is standardised across the sequence's
/// segments (z-score; a feature equal on every segment is left out), and the segments are
/// clustered by average linkage (UPGMA, as scipy's `linkage(…, "average")`) on the Euclidean
/// distance between their standardised features.
///
/// **How many states (the written rule):** `states` when given; otherwise, with one or two
/// segments, each segment is its own state (adjacent segments were cut apart because they
/// differ); with more, the `k` in `2 ..= min(max_states, segments − 1)` whose cut has the
/// largest silhouette (scikit-learn's `silhouette_score` on the same distances), the smaller
/// `k` on ties. The silhouette cannot choose one state: a sequence of one repeated motion gets
/// two.
///
/// Reads channels (a channel file's; on mocap takes give it `input = { features = … }`, as a
/// channel segmenter). The result keeps the merge history and the segment-by-segment distances
/// (standardised units). Missing samples (NaN) are left out of a segment's statistics; a
/// segment with no defined sample of a channel takes that feature's mean over the other
/// segments (z = 0).
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SegmentClustersParams {
    /// The largest number of states the silhouette rule may choose (≥ 2); the default is the
    /// number of exercises of the largest labelled mocap routine shipped (mocap6, 12).
    #[serde(default = "default_max_states")]
    pub max_states: usize,
    /// A fixed number of states (≥ 1) instead of the silhouette rule (more than the segments
    /// gives one state per segment).
    #[serde(default)]
    #[schemars(extend("x-default" = "chosen by the silhouette rule"))]
    pub states: Option<usize>,
}

fn default_max_states() -> usize {
    12
}

/// The validated labeller.
#[derive(Clone, Debug)]
pub struct SegmentClusters {
    max_states: usize,
    states: Option<usize>,
}

impl ParamGuard for SegmentClustersParams {
    type Checked = SegmentClusters;
    fn check(self) -> Result<SegmentClusters> {
        if self.max_states < 2 {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                format!(
                    "is {}; expected at least 2 (the silhouette compares 2 states or more)",
                    self.max_states
                ),
            )
            .with_field("max_states"));
        }
        if self.states == Some(0) {
            return Err(Error::new(ErrorKind::OutOfRange, "is 0; expected at least 1 state")
                .with_field("states"));
        }
        Ok(SegmentClusters { max_states: self.max_states, states: self.states })
    }
}

/// The standardised features of each segment (rows) — means then standard deviations per
/// channel, constant features dropped.
pub fn segment_features(motion: &Motion, segments: &[Range<usize>]) -> Result<Vec<Vec<f64>>> {
    let ch = motion.require_channels("segment_clusters")?;
    let (d, n) = (ch.n_channels(), ch.n_samples());
    if let Some(s) = segments.iter().find(|s| s.end > n || s.start >= s.end) {
        return Err(Error::new(
            ErrorKind::OutOfRange,
            format!(
                "segment {}..{} is empty or outside the {n} samples of {}",
                s.start, s.end, motion.name
            ),
        ));
    }
    let values = ch.values();
    let mut raw: Vec<Vec<f64>> = Vec::with_capacity(segments.len());
    for s in segments {
        let mut row = vec![f64::NAN; 2 * d];
        for c in 0..d {
            let vals: Vec<f64> =
                (s.start..s.end).map(|i| values[i * d + c]).filter(|v| v.is_finite()).collect();
            if vals.is_empty() {
                continue;
            }
            let mean = vals.iter().sum::<f64>() / vals.len() as f64;
            let var = vals.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / vals.len() as f64;
            row[c] = mean;
            row[d + c] = var.sqrt();
        }
        raw.push(row);
    }
    let mut out: Vec<Vec<f64>> = vec![Vec::new(); segments.len()];
    for f in 0..2 * d {
        let col: Vec<f64> = raw.iter().map(|r| r[f]).filter(|v| v.is_finite()).collect();
        if col.is_empty() {
            continue;
        }
        let mean = col.iter().sum::<f64>() / col.len() as f64;
        let sd =
            (col.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / col.len() as f64).sqrt();
        if sd <= f64::EPSILON * mean.abs().max(1.0) {
            continue; // equal on every segment: tells no segment from another
        }
        for (o, r) in out.iter_mut().zip(&raw) {
            o.push(if r[f].is_finite() { (r[f] - mean) / sd } else { 0.0 });
        }
    }
    Ok(out)
}

/// Row-major Euclidean distances between feature rows.
pub fn euclidean_distances(rows: &[Vec<f64>]) -> Vec<f64> {
    let n = rows.len();
    let mut d = vec![0.0; n * n];
    for i in 0..n {
        for j in i + 1..n {
            let v =
                rows[i].iter().zip(&rows[j]).map(|(a, b)| (a - b) * (a - b)).sum::<f64>().sqrt();
            d[i * n + j] = v;
            d[j * n + i] = v;
        }
    }
    d
}

impl Labeller for SegmentClusters {
    fn label(&self, motion: &Motion, segments: &[Range<usize>]) -> Result<StateLabels> {
        let rows = segment_features(motion, segments)?;
        let n = rows.len();
        let distances = euclidean_distances(&rows);
        let merges = average_linkage(&distances, n)?;
        let k = match self.states {
            Some(k) => k,
            None => k_by_silhouette(&distances, n, &merges, self.max_states)?,
        };
        Ok(StateLabels { segment_states: cut_to_k(&merges, n, k), merges, distances })
    }
}

motionlab_core::register_plugin!(Labeller, SegmentClustersParams, "segment_clusters");

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_core::{Channels, FrameRate, registry, segments_of};

    /// Three motions, A B A C B A on one channel: A a slow sine around 0, B a level of 10, C a
    /// fast sine of amplitude 5 around 0. The labeller must give A, B, C one state each.
    #[test]
    fn known_answer_on_repeated_motions() {
        let kinds = [0, 1, 0, 2, 1, 0];
        let mut values = Vec::new();
        for &k in &kinds {
            for i in 0..100 {
                let t = i as f64;
                values.push(match k {
                    0 => (t / 10.0).sin(),
                    1 => 10.0 + 0.01 * (t / 7.0).cos(),
                    _ => 5.0 * (t * 1.3).sin(),
                });
            }
        }
        let ch = Channels::new(vec!["x".into()], vec![String::new()], values).unwrap();
        let m = Motion::from_channels("abc", FrameRate::new(100.0).unwrap(), ch).unwrap();
        let segments = segments_of(&[100, 200, 300, 400, 500], 600);
        let labeller =
            registry::build_labeller("segment_clusters", &toml::Value::Table(Default::default()))
                .unwrap();
        let s = labeller.label(&m, &segments).unwrap();
        assert_eq!(s.segment_states, vec![0, 1, 0, 2, 1, 0]);
        assert_eq!(s.merges.len(), 5);
        assert_eq!(s.distances.len(), 36);
        let per = s.per_sample(&segments).unwrap();
        assert_eq!((per[0], per[150], per[350], per[599]), (0, 1, 2, 0));
        // A fixed number of states: 2 puts C with one of the others.
        let two = SegmentClustersParams { max_states: 12, states: Some(2) }.check().unwrap();
        let s2 = two.label(&m, &segments).unwrap();
        assert_eq!(s2.segment_states.iter().max(), Some(&1));
    }

    #[test]
    fn bad_parameters_name_their_field() {
        let e = SegmentClustersParams { max_states: 1, states: None }.check().unwrap_err();
        assert!(e.to_string().contains("max_states"), "{e}");
        let e = SegmentClustersParams { max_states: 5, states: Some(0) }.check().unwrap_err();
        assert!(e.to_string().contains("states"), "{e}");
    }
}
