//! Matcher `multistream_two_stage`: the two-stage DP over every marker (Yabe & Tanaka §3.1.3).

use std::ops::Range;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::{Alignment, Matcher};
use motionlab_core::registry::ParamGuard;
use motionlab_core::{Error, ErrorKind, Motion, Result};

use crate::dp::{Trajectory3, argmin_first};
use crate::input::{check_names, trajectories};
use crate::lanes::{self, Cell8, LANES, MarkerBlocks, Step8};
use crate::simd::{self, Level};

/// Two-stage DP matching over all markers with one common stretch `[a, b]` (Yabe & Tanaka §3.1.3).
///
/// Matches a model motion against a stretch of a target motion, every marker aligned over the
/// same stretch.
///
/// 1. Forward pass per marker `l` (the paper's subsequence DP, §3.1.2, free start and end,
///    `d(i, j) = |s_i − t_j|` in mm): `h_l(j) = g(n−1, j)`.
/// 2. `G(j) = Σ_l h_l(j)`; the common end is `b = argmin_j G(j)`.
/// 3. Backward pass per marker anchored at `b` (both sequences reversed from `b`, first row
///    cumulative): the cost of matching the whole model to `T[a..=b]` for every start `a`.
///    The common start `a` minimises the sum of those costs over the markers.
/// 4. `h_l` = marker `l`'s backward cost at `a` (mm, summed along its path); `H = Σ_l h_l`.
/// 5. Per-marker warping paths from `(0, a)` to `(n−1, b)` (model frame, target frame).
///
/// Ties (**choice**; the paper is silent) resolve towards the tightest stretch: `b` is the
/// earliest of equal minima of `G`, `a` the latest of equal minima of the summed backward cost
/// (a user standing still before or after the motion matches the model's still end frames at
/// equal cost; the tightest stretch is where the motion is). Path ties: diagonal step first,
/// then the model step, then the target step.
///
/// Frame indices are 0-based into the target given to the matcher (a cut window); the points
/// are matched by name, so model and target may list them in different orders.
///
/// Memory: the forward pass keeps one rolling row (O(m)) for each block of eight markers in
/// turn, plus `G` (O(m)); the backward pass one rolling row per block (each marker's cost per
/// start, O(L·b)) and, when paths are kept, two bytes of path decisions per cell and block
/// (O(n·b·L/8) bytes).
///
/// Missing samples: **refused**. A missing sample has no distance to anything, so the run stops
/// with an error naming the marker and the first missing frame; fill gaps first (preprocessor
/// `fill_gaps`) or leave the marker out with `points`.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MultistreamTwoStageParams {
    /// Names of the markers (or joints) to match, in the order of the per-marker distances and
    /// paths in the result.
    #[serde(default)]
    #[schemars(extend("x-default" = "every point of the model, in the model's order"))]
    pub points: Option<Vec<String>>,
    /// Keep each marker's warping path (needed by the `synchronisation` stage; costs
    /// O(n·(b−a+1)) memory per marker while it is computed).
    #[serde(default = "default_keep_paths")]
    pub keep_paths: bool,
}

fn default_keep_paths() -> bool {
    true
}

/// The validated stage.
#[derive(Clone, Debug)]
pub struct MultistreamTwoStage {
    points: Option<Vec<String>>,
    keep_paths: bool,
}

impl ParamGuard for MultistreamTwoStageParams {
    type Checked = MultistreamTwoStage;
    fn check(self) -> Result<MultistreamTwoStage> {
        if let Some(p) = &self.points {
            check_names(p, "points")?;
        }
        Ok(MultistreamTwoStage { points: self.points, keep_paths: self.keep_paths })
    }
}

/// Everything the two stages compute, for figures and diagnostics beyond the [`Alignment`].
#[derive(Clone, Debug, PartialEq)]
pub struct TwoStageMatch {
    /// `G(j) = Σ_l h_l(j)` for every target frame (mm).
    pub end_costs: Vec<f64>,
    /// Summed backward cost of every start `a ≤ b` (mm); its minimum is `H`.
    pub start_costs: Vec<f64>,
    pub alignment: Alignment,
}

/// Checks the per-marker trajectories and regroups them eight markers to a block.
pub(crate) fn marker_blocks(
    model: &[Trajectory3],
    target: &[Trajectory3],
) -> Result<(MarkerBlocks, MarkerBlocks)> {
    let (Some(s0), Some(t0)) = (model.first(), target.first()) else {
        return Err(Error::new(
            ErrorKind::EmptySequence,
            "two-stage matching needs at least one marker",
        ));
    };
    let (n, m) = (s0.len(), t0.len());
    if model.len() != target.len()
        || model.iter().any(|s| s.len() != n)
        || target.iter().any(|t| t.len() != m)
    {
        return Err(Error::new(
            ErrorKind::WrongValueCount,
            format!(
                "two-stage matching needs the same markers on both sides ({} model, {} target trajectories), \
                 all model trajectories {n} frames long and all target trajectories {m} frames long",
                model.len(),
                target.len()
            ),
        ));
    }
    if n == 0 || m == 0 {
        let which = if n == 0 { "the model" } else { "the target" };
        return Err(Error::new(
            ErrorKind::EmptySequence,
            format!(
                "DP matching needs at least one frame in each sequence, but {which} has none (model {n}, target {m} frames)"
            ),
        ));
    }
    let gather = |t: &[Trajectory3]| {
        MarkerBlocks::gather(t).ok_or_else(|| {
            Error::new(ErrorKind::WrongValueCount, "marker trajectories of unequal lengths")
        })
    };
    Ok((gather(model)?, gather(target)?))
}

/// Stage 1 over marker blocks: `G(j) = Σ_l h_l(j)`, markers added in order, for the target's
/// frames `frames` (index 0 of the result is frame `frames.start`).
pub(crate) fn summed_end_costs(
    level: Level,
    model: &MarkerBlocks,
    target: &MarkerBlocks,
    frames: Range<usize>,
    cells: &mut Vec<Cell8>,
) -> Vec<f64> {
    let mut end_costs = vec![0.0; frames.len()];
    for k in 0..model.block_count() {
        lanes::forward(level, model.block(k), &target.block(k)[frames.clone()], cells);
        let used = model.used(k);
        for (g, h) in end_costs.iter_mut().zip(cells.iter()) {
            for v in &h.0[..used] {
                *g += v;
            }
        }
    }
    end_costs
}

/// Stage 1 alone: `G(j)` for every target frame (mm), O(m) memory.
pub fn end_costs(model: &[Trajectory3], target: &[Trajectory3]) -> Result<Vec<f64>> {
    let (s, t) = marker_blocks(model, target)?;
    Ok(summed_end_costs(simd::level(), &s, &t, 0..t.frames(), &mut Vec::new()))
}

/// The two-stage match of per-marker model trajectories against the same markers' target
/// trajectories (`model[l]` pairs with `target[l]`). Samples must be finite.
///
/// The two cost passes run eight markers at a time in the SIMD lanes of one DP cell, and the
/// backward pass records each cell's path decision, so the paths need no third DP (see
/// [`crate::lanes`]); the numbers and paths are bit-for-bit those of one marker at a time with
/// [`crate::dp`]'s kernels.
pub fn two_stage(
    model: &[Trajectory3],
    target: &[Trajectory3],
    keep_paths: bool,
) -> Result<TwoStageMatch> {
    let (s, t) = marker_blocks(model, target)?;
    two_stage_at(simd::level(), &s, &t, 0..t.frames(), keep_paths)
}

/// [`two_stage`] at a chosen instruction-set level (capped at what the CPU runs), to compare
/// the levels' speed; every level gives the same numbers.
pub fn two_stage_at_level(
    level: Level,
    model: &[Trajectory3],
    target: &[Trajectory3],
    keep_paths: bool,
) -> Result<TwoStageMatch> {
    let (s, t) = marker_blocks(model, target)?;
    two_stage_at(level.min(simd::level()), &s, &t, 0..t.frames(), keep_paths)
}

/// The two-stage match of the model against the target's frames `frames` (a window of a take:
/// the result's frame indices count from `frames.start`, as when the window is cut out first).
/// `frames` must be a nonempty range within the target.
pub(crate) fn two_stage_at(
    level: Level,
    s: &MarkerBlocks,
    t: &MarkerBlocks,
    frames: Range<usize>,
    keep_paths: bool,
) -> Result<TwoStageMatch> {
    if frames.is_empty() || frames.end > t.frames() {
        return Err(Error::new(
            ErrorKind::OutOfRange,
            format!(
                "frames {}..{} are not a nonempty stretch of the target's {} frames",
                frames.start,
                frames.end,
                t.frames()
            ),
        ));
    }
    let mut cells = Vec::new();
    let end_costs = summed_end_costs(level, s, t, frames.clone(), &mut cells);
    let end = argmin_first(&end_costs)
        .ok_or_else(|| Error::new(ErrorKind::NonFinite, "G(j) is NaN everywhere"))?;
    // Stage 2: backward from b; each block's cost per start is kept to read h_l at a, and its
    // path decisions to walk the paths.
    let blocks = s.block_count();
    let mut costs: Vec<Vec<Cell8>> = Vec::with_capacity(blocks);
    let mut steps: Vec<Vec<Step8>> = Vec::with_capacity(blocks);
    for k in 0..blocks {
        let (mut c, mut st) = (Vec::new(), Vec::new());
        lanes::backward(
            level,
            s.block(k),
            &t.block(k)[frames.start..=frames.start + end],
            &mut c,
            keep_paths.then_some(&mut st),
        );
        costs.push(c);
        steps.push(st);
    }
    let mut start_costs = vec![0.0; end + 1];
    for (k, c) in costs.iter().enumerate() {
        for l in 0..s.used(k) {
            for (acc, cell) in start_costs.iter_mut().zip(c) {
                *acc += cell.0[l];
            }
        }
    }
    let start = argmin_last(&start_costs)
        .ok_or_else(|| Error::new(ErrorKind::NonFinite, "the backward costs are NaN everywhere"))?;
    let markers = s.markers();
    let point_distances: Vec<f64> =
        (0..markers).map(|l| costs[l / LANES][start].0[l % LANES]).collect();
    let total_distance = point_distances.iter().sum();
    let paths = if keep_paths {
        (0..markers)
            .map(|l| lanes::walk(&steps[l / LANES], s.frames(), start, end, l % LANES))
            .collect()
    } else {
        Vec::new()
    };
    Ok(TwoStageMatch {
        end_costs,
        start_costs,
        alignment: Alignment { start, end, point_distances, total_distance, paths },
    })
}

/// Index of the least value, the latest among equal values (NaN skipped).
fn argmin_last(values: &[f64]) -> Option<usize> {
    let mut best: Option<(usize, f64)> = None;
    for (j, &v) in values.iter().enumerate() {
        if !v.is_nan() && best.is_none_or(|(_, b)| v <= b) {
            best = Some((j, v));
        }
    }
    best.map(|(j, _)| j)
}

impl MultistreamTwoStage {
    /// The point names this stage matches for a given model.
    pub fn point_names(&self, model: &Motion) -> Vec<String> {
        self.points.clone().unwrap_or_else(|| model.point_names().to_vec())
    }
    /// The full result (with `G` and the summed backward costs) for a model and a target.
    pub fn match_motions(&self, model: &Motion, target: &Motion) -> Result<TwoStageMatch> {
        let names = self.point_names(model);
        let s = trajectories(model, &names, "model", "multistream_two_stage")?;
        let t = trajectories(target, &names, "target", "multistream_two_stage")?;
        two_stage(&s, &t, self.keep_paths)
    }
}

impl Matcher for MultistreamTwoStage {
    fn align(&self, model: &Motion, target: &Motion) -> Result<Alignment> {
        Ok(self.match_motions(model, target)?.alignment)
    }
}

motionlab_core::register_custom_plugin!(
    crate::Matcher,
    MultistreamTwoStageParams,
    "multistream_two_stage",
    kind = "matcher"
);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::build_matcher;
    use crate::dp::{Euclidean3, dtw_full_3d, subsequence_costs};
    use motionlab_testkit::{Rng, motion_from_fn};

    /// A smooth, non-repeating 3-D movement per marker (mm).
    fn movement(i: usize, k: usize) -> [f64; 3] {
        let t = i as f64 * 0.11;
        let k = k as f64;
        [
            300.0 * (t + k).sin() + 20.0 * k,
            200.0 * (0.7 * t + 2.0 * k).cos(),
            150.0 * (1.3 * t - k).sin() + 5.0 * t,
        ]
    }

    #[test]
    fn a_motion_against_itself_scores_zero_on_the_diagonal() {
        let m = motion_from_fn(40, 60.0, 4, movement);
        let stage = MultistreamTwoStageParams { points: None, keep_paths: true }.check().unwrap();
        let r = stage.match_motions(&m, &m).unwrap();
        let a = &r.alignment;
        assert_eq!((a.start, a.end, a.total_distance), (0, 39, 0.0));
        assert_eq!(a.point_distances, vec![0.0; 4]);
        let diagonal: Vec<(usize, usize)> = (0..40).map(|i| (i, i)).collect();
        assert_eq!(a.paths, vec![diagonal; 4]);
    }

    #[test]
    fn recovers_a_model_embedded_at_a_known_offset_in_noise() {
        // Target: 200 frames of noise around a still pose, with the model (60 frames, 5
        // markers) time-stretched by 1.25 and slightly jittered inserted at frames 70..=144.
        let mut rng = Rng::new(3);
        let (n, offset, stretched) = (60usize, 70usize, 75usize);
        let model = motion_from_fn(n, 60.0, 5, movement);
        let noise: Vec<[f64; 3]> = (0..200 * 5)
            .map(|_| [rng.normal() * 40.0, rng.normal() * 40.0, rng.normal() * 40.0])
            .collect();
        let target = motion_from_fn(200, 60.0, 5, |j, k| {
            if (offset..offset + stretched).contains(&j) {
                // Linear resampling of the model onto 75 frames, plus 1 mm jitter.
                let x = (j - offset) as f64 * (n - 1) as f64 / (stretched - 1) as f64;
                let (i0, f) = (x.floor() as usize, x.fract());
                let (p, q) = (movement(i0, k), movement((i0 + 1).min(n - 1), k));
                let e = noise[j * 5 + k];
                [
                    p[0] + f * (q[0] - p[0]) + e[0] / 40.0,
                    p[1] + f * (q[1] - p[1]) + e[1] / 40.0,
                    p[2] + f * (q[2] - p[2]) + e[2] / 40.0,
                ]
            } else {
                let e = noise[j * 5 + k];
                [e[0] + 500.0, e[1] - 400.0, e[2] + 300.0]
            }
        });
        let stage = MultistreamTwoStageParams { points: None, keep_paths: true }.check().unwrap();
        let r = stage.match_motions(&model, &target).unwrap();
        let a = &r.alignment;
        assert_eq!((a.start, a.end), (offset, offset + stretched - 1));
        // H is the sum of h_l, each the full DTW of the marker over [a, b] (independent check).
        let mut sum = 0.0;
        for k in 0..5 {
            let s: Vec<[f64; 3]> = model.trajectory(k).collect();
            let t: Vec<[f64; 3]> =
                target.trajectory(k).skip(a.start).take(a.end - a.start + 1).collect();
            let (c, p) = dtw_full_3d(&s, &t).unwrap();
            assert!((c - a.point_distances[k]).abs() < 1e-9 * c.max(1.0));
            assert!(
                (c - p.iter().map(|&(i, j)| dist(s[i], t[j])).sum::<f64>()).abs()
                    < 1e-9 * c.max(1.0)
            );
            sum += c;
            assert_eq!(a.paths[k].first(), Some(&(0, a.start)));
            assert_eq!(a.paths[k].last(), Some(&(n - 1, a.end)));
        }
        assert!((a.total_distance - sum).abs() < 1e-9 * sum);
        // G(j) is the sum of each marker's own subsequence costs.
        let h0 = subsequence_costs(&Euclidean3::new(
            &trajectories(&model, &["m0".into()], "", "").unwrap()[0],
            &trajectories(&target, &["m0".into()], "", "").unwrap()[0],
        ))
        .unwrap();
        assert!(r.end_costs.iter().zip(&h0).all(|(g, h)| g >= h));
        assert_eq!(
            r.start_costs[a.start],
            r.start_costs.iter().copied().fold(f64::INFINITY, f64::min)
        );
    }

    #[test]
    fn grouped_passes_equal_marker_by_marker_computation_exactly() {
        // Six markers: one group of four and one of two (spare lanes padded).
        let mut rng = Rng::new(17);
        let model = motion_from_fn(30, 60.0, 6, |i, k| movement(i + 3 * k, k));
        let noise: Vec<f64> = (0..90 * 6 * 3).map(|_| rng.normal()).collect();
        let target = motion_from_fn(90, 60.0, 6, |j, k| {
            let (p, e) = (movement(j, k), &noise[(j * 6 + k) * 3..]);
            [p[0] + e[0], p[1] + e[1], p[2] + e[2]]
        });
        let names: Vec<String> = model.point_names().to_vec();
        let (s, t) = (
            trajectories(&model, &names, "", "").unwrap(),
            trajectories(&target, &names, "", "").unwrap(),
        );
        let r = two_stage(&s, &t, true).unwrap();
        let mut g = vec![0.0; 90];
        for (sl, tl) in s.iter().zip(&t) {
            let h = subsequence_costs(&Euclidean3::new(sl, tl)).unwrap();
            g.iter_mut().zip(&h).for_each(|(a, b)| *a += b);
        }
        assert_eq!(r.end_costs, g);
        let a = &r.alignment;
        for (l, (sl, tl)) in s.iter().zip(&t).enumerate() {
            let back = crate::dp::anchored_costs(&Euclidean3::new(sl, tl), a.end).unwrap();
            assert_eq!(a.point_distances[l], back[a.start]);
        }
    }

    #[test]
    fn every_instruction_set_level_gives_the_scalar_kernels_results_bit_for_bit() {
        // Eleven markers (a full block of eight and one of three with spare lanes), a target
        // with a still stretch (ties between starts and ends) and the model's own first frames
        // (exact zero distances, which take the square root's fallback).
        let mut rng = Rng::new(29);
        let (n, m, markers) = (23usize, 70usize, 11usize);
        let model = motion_from_fn(n, 60.0, markers, |i, k| movement(2 * i + k, k));
        let noise: Vec<f64> = (0..m * markers * 3).map(|_| rng.normal() * 3.0).collect();
        let target = motion_from_fn(m, 60.0, markers, |j, k| match j {
            0..8 => movement(2 * j + k, k),
            8..20 => movement(2 * 8 + k, k),
            _ => {
                let (p, e) = (movement(j + 9 + k, k), &noise[(j * markers + k) * 3..]);
                [p[0] + e[0], p[1] + e[1] * 1e-7, p[2] + e[2] * 1e3]
            }
        });
        let names: Vec<String> = model.point_names().to_vec();
        let (s, t) = (
            trajectories(&model, &names, "", "").unwrap(),
            trajectories(&target, &names, "", "").unwrap(),
        );
        let mut g = vec![0.0; m];
        for (sl, tl) in s.iter().zip(&t) {
            let h = subsequence_costs(&Euclidean3::new(sl, tl)).unwrap();
            g.iter_mut().zip(&h).for_each(|(a, b)| *a += b);
        }
        let levels = crate::simd::available();
        assert!(levels.contains(&Level::Portable));
        for level in levels {
            let r = crate::simd::with_cap(level, || two_stage(&s, &t, true)).unwrap();
            assert_eq!(r.end_costs, g, "{level:?}");
            let a = &r.alignment;
            let mut start_costs = vec![0.0; a.end + 1];
            for (l, (sl, tl)) in s.iter().zip(&t).enumerate() {
                let d = Euclidean3::new(sl, tl);
                let back = crate::dp::anchored_costs(&d, a.end).unwrap();
                start_costs.iter_mut().zip(&back).for_each(|(acc, c)| *acc += c);
                assert_eq!(a.point_distances[l], back[a.start], "{level:?} marker {l}");
                let (cost, path) =
                    crate::dp::anchored_path(&d, a.start, a.end, &mut crate::dp::Workspace::new())
                        .unwrap();
                assert_eq!(
                    (cost, &path),
                    (a.point_distances[l], &a.paths[l]),
                    "{level:?} marker {l}"
                );
            }
            assert_eq!(r.start_costs, start_costs, "{level:?}");
            let without = crate::simd::with_cap(level, || two_stage(&s, &t, false)).unwrap();
            assert_eq!((without.end_costs, without.start_costs), (r.end_costs, r.start_costs));
            assert_eq!(without.alignment.point_distances, a.point_distances);
        }
    }

    fn dist(p: [f64; 3], q: [f64; 3]) -> f64 {
        ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
    }

    #[test]
    fn ties_resolve_to_the_tightest_stretch() {
        // The target holds the model's first pose for 5 frames before and its last pose for 5
        // frames after: every start in the lead-in and every end in the tail cost the same.
        let model = motion_from_fn(20, 60.0, 2, movement);
        let target = motion_from_fn(30, 60.0, 2, |j, k| movement(j.clamp(5, 24) - 5, k));
        let stage = MultistreamTwoStageParams { points: None, keep_paths: false }.check().unwrap();
        let r = stage.match_motions(&model, &target).unwrap();
        assert_eq!(r.end_costs[24..], [0.0; 6]);
        assert_eq!(r.start_costs[..6], [0.0; 6]);
        let a = &r.alignment;
        assert_eq!((a.start, a.end, a.total_distance), (5, 24, 0.0));
        assert!(a.paths.is_empty());
    }

    #[test]
    fn points_select_and_order_the_markers_by_name() {
        let model = motion_from_fn(15, 60.0, 3, movement);
        // The target lists the markers in reverse order under the same names.
        let names = ["m2", "m1", "m0"];
        let target = motionlab_testkit::named_motion(15, 60.0, &names, |i, k| movement(i, 2 - k));
        let stage = MultistreamTwoStageParams {
            points: Some(vec!["m2".into(), "m0".into()]),
            keep_paths: true,
        }
        .check()
        .unwrap();
        let a = stage.align(&model, &target).unwrap();
        assert_eq!((a.point_distances.len(), a.paths.len(), a.total_distance), (2, 2, 0.0));
    }

    #[test]
    fn missing_samples_are_refused_and_params_are_checked() {
        let model = motion_from_fn(10, 60.0, 2, movement);
        let target = motion_from_fn(30, 60.0, 2, |i, k| {
            if i == 12 && k == 1 { [f64::NAN; 3] } else { movement(i, k) }
        });
        let stage =
            build_matcher("multistream_two_stage", &motionlab_core::registry::default_params())
                .unwrap();
        let e = stage.align(&model, &target).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::MissingData);
        assert!(e.to_string().contains("fill_gaps"), "{e}");
        let bad: toml::Value = toml::from_str("points = []").unwrap();
        let e = build_matcher("multistream_two_stage", &bad).err().unwrap();
        assert_eq!(e.location().field.as_deref(), Some("points"));
        let typo: toml::Value = toml::from_str("keep_path = true").unwrap();
        assert_eq!(
            build_matcher("multistream_two_stage", &typo).err().unwrap().kind(),
            ErrorKind::UnknownKey
        );
    }
}
