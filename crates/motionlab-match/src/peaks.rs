//! Point detector `velocity_peaks`: one point per repetition at the peak of a marker's
//! velocity function, and a window cut around it (Yabe & Tanaka §3.1.1).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::{PointDetection, PointDetector};
use motionlab_core::registry::ParamGuard;
use motionlab_core::{Error, ErrorKind, Motion, Result, TimeSpan, Trace};
use motionlab_features::smoothing::moving_average_positions;

use crate::input::{check_names, trajectories};

/// One point per repetition at the velocity peaks of one marker, a window around each (§3.1.1).
///
/// Finds the N repetitions in a continuous take from the velocity function of one marker, and
/// cuts a window around each (Yabe & Tanaka §3.1.1).
///
/// Velocity function (mm per frame): `v(i) = |s_i − s_{i+1}|` for `i = 0..F−2`
/// (the trace's last frame is NaN: no successor). One repetition shows as one "mountain".
///
/// Threshold: starting at `max v` and lowering it, the regions where `v ≥ θ` (maximal runs of
/// consecutive frames) appear, grow, and merge. The threshold is the **highest** `θ` at which
/// there are exactly `count` separate regions. The sweep is exact: it visits every distinct
/// value of `v` in decreasing order (the region set only changes there), not a fixed step, so
/// two peaks a hair apart in height are still told apart. Each region's maximum (its earliest
/// frame among equal values) is a point. If no threshold gives exactly `count` regions the
/// stage fails and the error lists the counts that occurred; smoothing usually helps when a
/// mountain has several summits.
///
/// Window: frames `point − before ..= point + after`, clipped to the take (`before`/`after`
/// rounded to whole frames at the take's rate).
///
/// Missing samples: **refused** for the chosen marker (an error names the first missing frame;
/// fill gaps first with the `fill_gaps` preprocessor); other markers are not read.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct VelocityPeaksParams {
    /// Marker (or joint) whose velocity function is used (the paper: the swinging hand).
    /// Required.
    pub marker: String,
    /// `N`: number of repetitions in the take, i.e. of peaks to find. Required, ≥ 1.
    pub count: usize,
    /// Window length before each point (`{ seconds = 1.0 }` or `{ frames = 120 }`).
    #[serde(default = "default_span")]
    pub before: TimeSpan,
    /// Window length after each point.
    #[serde(default = "default_span")]
    pub after: TimeSpan,
    /// Centred moving-average window applied to the marker's positions before the velocity is
    /// taken (**choice**; the paper does not smooth).
    #[serde(default)]
    pub smoothing: Option<TimeSpan>,
}

fn default_span() -> TimeSpan {
    TimeSpan::Seconds(1.0)
}

/// The validated stage.
#[derive(Clone, Debug)]
pub struct VelocityPeaks {
    marker: String,
    count: usize,
    before: TimeSpan,
    after: TimeSpan,
    smoothing: Option<TimeSpan>,
}

impl ParamGuard for VelocityPeaksParams {
    type Checked = VelocityPeaks;
    fn check(self) -> Result<VelocityPeaks> {
        check_names(std::slice::from_ref(&self.marker), "marker")?;
        if self.count == 0 {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                "expected at least one repetition (count >= 1), found 0",
            )
            .with_field("count"));
        }
        Ok(VelocityPeaks {
            marker: self.marker,
            count: self.count,
            before: self.before.check("before", false)?,
            after: self.after.check("after", false)?,
            smoothing: self.smoothing.map(|s| s.check("smoothing", false)).transpose()?,
        })
    }
}

/// The regions where `v ≥ threshold`, as inclusive frame ranges, when exactly `count` occur.
#[derive(Clone, Debug, PartialEq)]
pub struct PeakRegions {
    pub threshold: f64,
    pub regions: Vec<(usize, usize)>,
}

/// The number of regions `v ≥ θ` at every distinct finite value `θ` of `v`, in decreasing `θ`
/// (an incremental sweep: O(F log F)). NaN samples never belong to a region.
pub fn region_counts(v: &[f64]) -> Vec<(f64, usize)> {
    let mut order: Vec<usize> = (0..v.len()).filter(|&i| !v[i].is_nan()).collect();
    order.sort_by(|&a, &b| v[b].total_cmp(&v[a]));
    let mut active = vec![false; v.len()];
    let mut count = 0usize;
    let mut out: Vec<(f64, usize)> = Vec::new();
    let mut k = 0;
    while k < order.len() {
        let theta = v[order[k]];
        // Activate every sample of this value before counting: equal neighbours join one region.
        while k < order.len() && v[order[k]] == theta {
            let i = order[k];
            let left = i > 0 && active[i - 1];
            let right = i + 1 < v.len() && active[i + 1];
            match (left, right) {
                (false, false) => count += 1,
                (true, true) => count -= 1,
                _ => {}
            }
            active[i] = true;
            k += 1;
        }
        out.push((theta, count));
    }
    out
}

/// The highest threshold giving exactly `count` regions of `v ≥ θ`, and those regions.
pub fn peak_regions(v: &[f64], count: usize) -> Result<PeakRegions> {
    let counts = region_counts(v);
    let Some(&(threshold, _)) = counts.iter().find(|&&(_, c)| c == count) else {
        let mut seen: Vec<usize> = counts.iter().map(|&(_, c)| c).collect();
        seen.dedup();
        let shown: Vec<String> = seen.iter().take(30).map(usize::to_string).collect();
        let more = if seen.len() > 30 { ", …" } else { "" };
        let max = seen.iter().max().copied().unwrap_or(0);
        return Err(Error::new(
            ErrorKind::InvalidParameter,
            format!(
                "no threshold gives exactly {count} peaks: lowering it from the maximum gave {}{more} regions (at most {max}); \
                 check `count`, or smooth the velocity (`smoothing`)",
                shown.join(", ")
            ),
        )
        .with_field("count"));
    };
    let mut regions = Vec::with_capacity(count);
    let mut run_start = None;
    for (i, &x) in v.iter().enumerate() {
        match (x >= threshold, run_start) {
            (true, None) => run_start = Some(i),
            (false, Some(s)) => {
                regions.push((s, i - 1));
                run_start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = run_start {
        regions.push((s, v.len() - 1));
    }
    Ok(PeakRegions { threshold, regions })
}

/// `v(i) = |s_i − s_{i+1}|` (mm per frame), NaN at the last frame.
pub fn velocity_function(points: &[[f64; 3]]) -> Vec<f64> {
    let mut v: Vec<f64> = points
        .windows(2)
        .map(|w| {
            ((w[0][0] - w[1][0]).powi(2)
                + (w[0][1] - w[1][1]).powi(2)
                + (w[0][2] - w[1][2]).powi(2))
            .sqrt()
        })
        .collect();
    v.push(f64::NAN);
    v
}

impl PointDetector for VelocityPeaks {
    fn detect(&self, motion: &Motion) -> Result<PointDetection> {
        motion.require_frames(2, "velocity_peaks")?;
        // Refuses missing samples of the marker (and checks it exists) before any work.
        trajectories(motion, std::slice::from_ref(&self.marker), "take", "velocity_peaks")?;
        let one = motion.select_points(std::slice::from_ref(&self.marker))?;
        let window = self.smoothing.map(|s| s.whole_frames_at(motion.frame_rate())).unwrap_or(0);
        let points = if window > 1 {
            moving_average_positions(&one, window)
        } else {
            one.positions().to_vec()
        };
        let v = velocity_function(&points);
        let found = peak_regions(&v, self.count)?;
        let peaks: Vec<usize> = found
            .regions
            .iter()
            .map(|&(s, e)| (s..=e).fold(s, |best, i| if v[i] > v[best] { i } else { best }))
            .collect();
        let f = motion.n_frames();
        let (before, after) = (
            self.before.whole_frames_at(motion.frame_rate()),
            self.after.whole_frames_at(motion.frame_rate()),
        );
        let windows =
            peaks.iter().map(|&p| (p.saturating_sub(before), (p + after + 1).min(f))).collect();
        Ok(PointDetection {
            velocity: Trace::new("v_mm_per_frame", "mm/frame", v),
            threshold: found.threshold,
            peaks,
            windows,
        })
    }
}

motionlab_core::register_custom_plugin!(
    crate::PointDetector,
    VelocityPeaksParams,
    "velocity_peaks",
    kind = "point_detector"
);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::build_point_detector;
    use motionlab_testkit::{Rng, motion_from_fn};

    /// A marker moving along x whose per-frame step is `speed(i)`: v(i) = speed(i) exactly.
    fn motion_with_speed(frames: usize, speed: impl Fn(usize) -> f64) -> Motion {
        let mut x = vec![0.0; frames];
        for i in 1..frames {
            x[i] = x[i - 1] + speed(i - 1);
        }
        motion_from_fn(frames, 100.0, 2, |i, k| [x[i], 10.0 * k as f64, 0.0])
    }

    /// Four bumps centred at 30, 80, 130, 180 with heights 9, 6, 12, 4 over a 0.5 floor.
    fn bumps(i: usize) -> f64 {
        let mut v: f64 = 0.5;
        for (c, h) in [(30.0, 9.0), (80.0, 6.0), (130.0, 12.0), (180.0, 4.0)] {
            v = v.max(h * (1.0 - ((i as f64 - c) / 12.0).powi(2)));
        }
        v
    }

    fn detector(toml_text: &str) -> Box<dyn PointDetector> {
        build_point_detector("velocity_peaks", &toml::from_str::<toml::Value>(toml_text).unwrap())
            .unwrap()
    }

    #[test]
    fn finds_n_bumps_of_different_heights_and_cuts_windows() {
        let m = motion_with_speed(210, bumps);
        let d = detector(
            "marker = \"m0\"\ncount = 4\nbefore = { frames = 20 }\nafter = { seconds = 0.25 }",
        )
        .detect(&m)
        .unwrap();
        assert_eq!(d.peaks, vec![30, 80, 130, 180]);
        // The fourth region appears when θ reaches the lowest bump's top (4).
        assert!((d.threshold - 4.0).abs() < 1e-9, "{}", d.threshold);
        // Windows: 20 frames before, 25 after (0.25 s at 100 Hz), end exclusive, clipped.
        assert_eq!(d.windows, vec![(10, 56), (60, 106), (110, 156), (160, 206)]);
        assert_eq!(d.velocity.values.len(), 210);
        assert!(d.velocity.values[209].is_nan());
        assert!((d.velocity.values[130] - 12.0).abs() < 1e-9);
        // Two repetitions: the two highest bumps.
        let d2 =
            detector("marker = \"m0\"\ncount = 2\nbefore = { frames = 40 }").detect(&m).unwrap();
        assert_eq!(d2.peaks, vec![30, 130]);
        assert_eq!(d2.windows[0], (0, 131)); // clipped at the start; 1 s = 100 frames after
    }

    #[test]
    fn the_sweep_matches_a_naive_count_at_every_distinct_value() {
        let mut rng = Rng::new(11);
        for _ in 0..50 {
            let len = 1 + (rng.next_u64() % 40) as usize;
            // Few distinct levels so plateaus and equal neighbours occur.
            let v: Vec<f64> = (0..len).map(|_| (rng.next_u64() % 6) as f64).collect();
            let mut distinct = v.clone();
            distinct.sort_by(|a, b| b.total_cmp(a));
            distinct.dedup();
            let naive: Vec<(f64, usize)> = distinct
                .iter()
                .map(|&t| {
                    let above: Vec<bool> = v.iter().map(|&x| x >= t).collect();
                    let runs = (0..len).filter(|&i| above[i] && (i == 0 || !above[i - 1])).count();
                    (t, runs)
                })
                .collect();
            assert_eq!(region_counts(&v), naive, "{v:?}");
        }
    }

    #[test]
    fn peaks_a_hair_apart_in_height_are_separated() {
        // A fixed-step sweep (e.g. 1 % of the max) would jump from 1 region straight to 3.
        let v = [0.0, 10.0, 0.0, 10.0 - 1e-12, 0.0, 10.0 - 2e-12, 0.0];
        assert_eq!(peak_regions(&v, 2).unwrap().regions, vec![(1, 1), (3, 3)]);
        assert_eq!(peak_regions(&v, 3).unwrap().threshold, 10.0 - 2e-12);
    }

    #[test]
    fn an_impossible_count_lists_the_counts_that_occurred() {
        let m = motion_with_speed(210, bumps);
        let e = detector("marker = \"m0\"\ncount = 5").detect(&m).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::InvalidParameter);
        assert!(e.to_string().contains("gave 1, 2, 3, 4, 1 regions (at most 4)"), "{e}");
    }

    #[test]
    fn smoothing_merges_a_double_summit() {
        // One mountain with a notch at its top (two summits) and one lower mountain. A 9-frame
        // average of positions averages 9 speeds, turning the notch into a box 9 frames wide
        // and 1.5/9 deep; the mountain falls faster than that per frame at the box's edges
        // (16·4.5/225), so no shoulder forms there and one summit remains.
        let speed = |i: usize| {
            let base = 8.0 * (1.0 - ((i as f64 - 40.0) / 15.0).powi(2)).max(0.0)
                + 5.0 * (1.0 - ((i as f64 - 100.0) / 15.0).powi(2)).max(0.0);
            if i == 40 { base - 1.5 } else { base }
        };
        let m = motion_with_speed(140, speed);
        assert_eq!(detector("marker = \"m0\"\ncount = 2").detect(&m).unwrap().peaks, vec![39, 41]);
        let smooth =
            detector("marker = \"m0\"\ncount = 2\nsmoothing = { frames = 9 }").detect(&m).unwrap();
        assert_eq!(smooth.peaks.len(), 2);
        assert!(
            smooth.peaks[0].abs_diff(40) <= 2 && smooth.peaks[1].abs_diff(100) <= 2,
            "{:?}",
            smooth.peaks
        );
    }

    #[test]
    fn missing_samples_and_bad_params_are_refused() {
        let m =
            motion_from_fn(
                20,
                100.0,
                1,
                |i, _| if i == 7 { [f64::NAN; 3] } else { [i as f64, 0.0, 0.0] },
            );
        let e = detector("marker = \"m0\"\ncount = 1").detect(&m).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::MissingData);
        let zero: toml::Value = toml::from_str("marker = \"m0\"\ncount = 0").unwrap();
        assert_eq!(
            build_point_detector("velocity_peaks", &zero)
                .err()
                .unwrap()
                .location()
                .field
                .as_deref(),
            Some("count")
        );
        let neg: toml::Value =
            toml::from_str("marker = \"m0\"\ncount = 1\nbefore = { seconds = -1.0 }").unwrap();
        assert_eq!(
            build_point_detector("velocity_peaks", &neg).err().unwrap().location().field.as_deref(),
            Some("before")
        );
    }
}
