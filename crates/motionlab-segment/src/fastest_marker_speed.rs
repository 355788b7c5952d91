//! Sonoda et al. §2.1: candidates where the whole body stops, found by following the fastest
//! marker from each burst of speed down to its own next minimum.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{
    Error, ErrorKind, FeatureCache, Motion, Result, Segmenter, SegmenterOutput, Threshold,
    TimeSpan, Trace,
};
use motionlab_features::signal::is_local_max;
use motionlab_features::speed::{MarkerSpeeds, cached_marker_speeds};

use crate::thresholds::SpeedThreshold;

/// What the tracker found.
#[derive(Clone, Debug, PartialEq)]
pub struct Tracking {
    /// Candidate frames `j` (sorted).
    pub candidates: Vec<usize>,
    /// At each frame `i..=j` of each followed stretch, the followed marker's own speed
    /// `v[f][k]` (mm/s); NaN where no marker was being followed.
    pub tracked_speed: Vec<f64>,
    /// The followed marker at each frame (None where none was).
    pub tracked_marker: Vec<Option<usize>>,
}

/// The tracking algorithm of Sonoda et al. §2.1, steps 1–3, on precomputed speeds:
///
/// 1. scanning forward from `s`, find the next frame `i` that is a local maximum of V with
///    `V[i] ≥ v_high`; let `k` be the marker giving `V[i]`;
/// 2. find the nearest `j > i` that is a local minimum of `v[·][k]` (that marker's own speed);
/// 3. if `V[j] ≤ v_low`, `j` is a candidate and scanning resumes at `j + 1`; otherwise the
///    motion goes on and scanning resumes at `j` (the next qualifying maximum at or after `j`).
///
/// Local extrema are strict, and false where a neighbour is NaN, so missing samples never
/// produce one.
pub fn track_fastest_marker(speeds: &MarkerSpeeds, v_high: f64, v_low: f64) -> Tracking {
    let v = &speeds.fastest;
    let n = v.len();
    let mut out = Tracking {
        candidates: Vec::new(),
        tracked_speed: vec![f64::NAN; n],
        tracked_marker: vec![None; n],
    };
    let mut s = 1;
    while s + 1 < n {
        let Some(i) = (s..n - 1).find(|&i| v[i] >= v_high && is_local_max(v, i)) else { break };
        // A finite local maximum always has a fastest marker.
        let Some(k) = speeds.fastest_marker[i] else {
            s = i + 1;
            continue;
        };
        let vk = |f: usize| speeds.speed(f, k);
        let is_min = |f: usize| {
            let (a, b, c) = (vk(f - 1), vk(f), vk(f + 1));
            a > b && b < c
        };
        let j = (i + 1..n - 1).find(|&f| is_min(f));
        let end = j.unwrap_or(n - 1);
        for f in i..=end {
            out.tracked_speed[f] = vk(f);
            out.tracked_marker[f] = Some(k);
        }
        let Some(j) = j else { break };
        if v[j] <= v_low {
            out.candidates.push(j);
            s = j + 1;
        } else {
            s = j;
        }
    }
    out
}

/// Candidates where the whole body has stopped, found by tracking the fastest marker
/// (Sonoda et al. §2.1, steps 1–3 — not plain minima of V; compare `speed_minima`).
///
/// `v[i][k] = |p[i+1][k] − p[i][k]| · fps` (mm/s), `V[i] = max_k v[i][k]`.
/// 1. Scanning forward, find the next local maximum `i` of V with `V[i] ≥ v_high`; let `k` be
///    the marker giving it. 2. Find the nearest `j > i` that is a local minimum of `v[·][k]`.
/// 3. If `V[j] ≤ v_low`, `j` is a candidate (the followed marker has stopped and so has every
///    other); continue after `j`. Otherwise the motion goes on: continue from `j`.
///
/// Because the followed marker stays fixed until its own minimum, frames where the fastest
/// marker merely changes hands (V dips while one part slows and another speeds up) are not
/// candidates — the spurious candidates that plain V minima produce.
///
/// Outputs traces `V_mm_per_s` and `tracked_speed_mm_per_s` (the followed marker's own speed,
/// NaN where nothing is followed: the paper's Fig. 2/3) and thresholds `v_high`, `v_low`.
///
/// Missing samples: a marker missing at frame `i` or `i+1` has no speed there and is skipped
/// when V is taken; a followed marker's missing speed is never a local minimum, so the search
/// for `j` continues past the gap. Nothing is interpolated.
///
/// **Defaults, and the protocol that chose them**: the defaults of `v_high`, `v_low` and
/// `smoothing` (their values are in the parameter list, from the one serde source) were chosen
/// from the grid
/// `v_low` ∈ {0.1, 0.2, 0.3, 0.4, 0.45} × `v_high` ∈ {0.5, 0.75, 1.0} (fractions of p90) ×
/// `smoothing` ∈ {0, 0.1, 0.2} s; 6 of the 7 folds chose the same. Held out: pooled F1 0.22
/// against 0.18 for as many random frames (p ≈ 0.08, not above chance at α = 0.05). Table 1's
/// values, which the paper-reproduction experiments pin: `v_low` 0.15, no smoothing.
///
#[doc = include_str!("sonoda_protocol.md")]
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
#[schemars(extend("x-defaults-tuned-on" = crate::SONODA_DEFAULTS_TUNED_ON))]
pub struct FastestMarkerSpeedParams {
    /// A local maximum of V starts a followed stretch when V ≥ this ("sufficiently large").
    /// `{ fraction_of_p90 = 0.5 }` is half the speed the body exceeds only 10 % of the time,
    /// i.e. a real movement whatever the dancer's overall tempo.
    #[serde(default = "default_v_high")]
    pub v_high: SpeedThreshold,
    /// The followed marker's minimum `j` is a candidate when V[j] ≤ this ("sufficiently small").
    /// The default is chosen by the protocol above.
    #[serde(default = "default_v_low")]
    pub v_low: SpeedThreshold,
    /// Centred moving-average window on positions before differentiating (`{ seconds = 0.0 }`:
    /// none; the default is chosen by the protocol above).
    #[serde(default = "default_smoothing")]
    pub smoothing: Option<TimeSpan>,
}

fn default_v_high() -> SpeedThreshold {
    SpeedThreshold::FractionOfP90(0.5)
}
fn default_v_low() -> SpeedThreshold {
    SpeedThreshold::FractionOfP90(0.45)
}
fn default_smoothing() -> Option<TimeSpan> {
    Some(TimeSpan::Seconds(0.2))
}

/// The validated stage.
#[derive(Clone, Debug)]
pub struct FastestMarkerSpeed {
    v_high: SpeedThreshold,
    v_low: SpeedThreshold,
    smoothing: Option<TimeSpan>,
}

impl ParamGuard for FastestMarkerSpeedParams {
    type Checked = FastestMarkerSpeed;
    fn check(self) -> Result<FastestMarkerSpeed> {
        let (v_high, v_low) = (self.v_high.check("v_high")?, self.v_low.check("v_low")?);
        let inverted = match (v_low, v_high) {
            (SpeedThreshold::MmPerS(lo), SpeedThreshold::MmPerS(hi))
            | (SpeedThreshold::FractionOfP90(lo), SpeedThreshold::FractionOfP90(hi)) => lo >= hi,
            _ => false, // mixed kinds are compared once resolved, in `segment`
        };
        if inverted {
            return Err(Error::new(
                ErrorKind::InvalidParameter,
                format!("v_low ({v_low:?}) must be below v_high ({v_high:?})"),
            )
            .with_field("v_low"));
        }
        let smoothing = self.smoothing.map(|s| s.check("smoothing", false)).transpose()?;
        Ok(FastestMarkerSpeed { v_high, v_low, smoothing })
    }
}

impl Segmenter for FastestMarkerSpeed {
    /// On 2-D image positions V is px/s (absolute thresholds are then read as px/s).
    fn accepts_2d(&self) -> bool {
        true
    }
    fn segment(&self, motion: &Motion, cache: &FeatureCache) -> Result<SegmenterOutput> {
        motion.require_frames(3, "fastest_marker_speed")?;
        let smoothing = self.smoothing.map(|s| s.whole_frames_at(motion.frame_rate())).unwrap_or(0);
        let speeds = cached_marker_speeds(motion, cache, smoothing)?;
        let v = &speeds.fastest;
        let (v_high, v_low) = SpeedThreshold::resolve_pair(self.v_high, self.v_low, v)?;
        if v_low >= v_high {
            return Err(Error::new(
                ErrorKind::InvalidParameter,
                format!(
                    "on {} v_low resolves to {v_low:.1} {u}/s, not below v_high = {v_high:.1} {u}/s",
                    motion.name,
                    u = motion.length_unit()
                ),
            )
            .with_field("v_low"));
        }
        let t = track_fastest_marker(&speeds, v_high, v_low);
        let u = motion.length_unit();
        let trace = format!("V_{u}_per_s");
        Ok(SegmenterOutput {
            candidates: t.candidates,
            traces: vec![
                Trace::new(trace.clone(), format!("{u}/s"), v.clone()),
                Trace::new(format!("tracked_speed_{u}_per_s"), format!("{u}/s"), t.tracked_speed),
            ],
            thresholds: vec![
                Threshold { name: "v_high".into(), trace: trace.clone(), value: v_high },
                Threshold { name: "v_low".into(), trace, value: v_low },
            ],
            flagged_frames: Vec::new(),
            penalty_path: Vec::new(),
        })
    }
}

motionlab_core::register_plugin!(Segmenter, FastestMarkerSpeedParams, "fastest_marker_speed");

#[cfg(test)]
mod tests {
    use super::*;
    use crate::speed_minima::SpeedMinimaParams;
    use motionlab_core::registry::build_segmenter;
    use motionlab_features::signal::is_local_min;
    use motionlab_features::speed::marker_speeds;
    use motionlab_testkit::motion_from_fn;

    /// Two markers at 100 Hz whose speeds are prescribed (mm/s): marker A (0) moves along x,
    /// B (1) along y. A bursts at frames 60 and 230; B bursts at 100, overlapping A's
    /// deceleration so the fastest marker changes hands at frame ~76 with V dipping to ~36 mm/s;
    /// A's own speed has its next minimum at ~85, where B is fast. Both slow to 5 mm/s together
    /// at frames 160 and 280: the two real stops.
    fn stop_go() -> Motion {
        let bump = |t: f64, c: f64, w: f64| (-((t - c) / w).powi(2)).exp();
        let base =
            |t: f64| 5.0 + 10.0 * (1.0 - (2.0 * std::f64::consts::PI * (t - 160.0) / 120.0).cos());
        let speed = |k: usize, t: f64| {
            if k == 0 {
                1000.0 * bump(t, 60.0, 8.0)
                    + 100.0 * bump(t, 97.0, 4.0)
                    + 1000.0 * bump(t, 230.0, 12.0)
                    + base(t)
            } else {
                1000.0 * bump(t, 100.0, 12.0) + base(t)
            }
        };
        let fps = 100.0;
        let mut pos = [0.0f64; 2];
        let mut traj = vec![[[0.0; 3]; 2]; 320];
        for (i, frame) in traj.iter_mut().enumerate() {
            *frame = [[pos[0], 0.0, 0.0], [0.0, pos[1], 0.0]];
            for (k, p) in pos.iter_mut().enumerate() {
                *p += speed(k, i as f64) / fps;
            }
        }
        motion_from_fn(320, fps, 2, |i, k| traj[i][k])
    }

    fn run(params: &str, m: &Motion) -> SegmenterOutput {
        let v: toml::Value = toml::from_str(params).unwrap();
        build_segmenter("fastest_marker_speed", &v)
            .unwrap()
            .segment(m, &FeatureCache::new())
            .unwrap()
    }

    /// Without the default smoothing: the rule itself on the hand-made speeds.
    fn run_unsmoothed(params: &str, m: &Motion) -> SegmenterOutput {
        run(&format!("smoothing = {{ seconds = 0.0 }}\n{params}"), m)
    }

    #[test]
    fn finds_exactly_the_stops_and_not_the_fastest_marker_switch() {
        let m = stop_go();
        let thresholds = "v_high = { mm_per_s = 500.0 }\nv_low = { mm_per_s = 100.0 }";
        let out = run_unsmoothed(thresholds, &m);
        assert_eq!(out.candidates, vec![160, 280]);

        // The plain rule does fire at the switch: V has a local minimum under v_low at 76, where
        // the fastest marker changes from A to B.
        let s = marker_speeds(&m, 0);
        assert!(
            is_local_min(&s.fastest, 76) && s.fastest[76] <= 100.0,
            "V[76] = {}",
            s.fastest[76]
        );
        assert_eq!((s.fastest_marker[76], s.fastest_marker[77]), (Some(0), Some(1)));
        let plain = SpeedMinimaParams { v_low: SpeedThreshold::MmPerS(100.0), smoothing: None }
            .check()
            .unwrap();
        let plain = plain.segment(&m, &FeatureCache::new()).unwrap();
        assert!(plain.candidates.contains(&76), "{:?}", plain.candidates);
        assert!(plain.candidates.contains(&160) && plain.candidates.contains(&280));

        // The followed marker's trace: A from its peak at 60 to its own minimum (~85, not a
        // candidate: B is fast there), B from 100 to the stop at 160, A from 230 to 280.
        let t = track_fastest_marker(&s, 500.0, 100.0);
        assert_eq!(t.tracked_marker[60], Some(0));
        assert_eq!(t.tracked_marker[120], Some(1));
        assert_eq!(t.tracked_marker[250], Some(0));
        assert!(t.tracked_speed[10].is_nan() && t.tracked_speed[200].is_nan());
        assert_eq!(t.tracked_speed[120], s.speed(120, 1));
        let a_min = (61..100).find(|&f| t.tracked_marker[f + 1] != Some(0)).unwrap();
        assert!(
            is_local_min(&s.marker_speed(0), a_min) && s.fastest[a_min] > 100.0,
            "A's minimum at {a_min}"
        );
        // Outputs carry V, the followed speed and both thresholds.
        assert_eq!(out.traces[1].name, "tracked_speed_mm_per_s");
        assert_eq!(out.thresholds.iter().map(|t| t.value).collect::<Vec<_>>(), vec![500.0, 100.0]);
    }

    #[test]
    fn a_gap_in_the_followed_marker_is_skipped_not_a_stop() {
        // Marker B missing around its minimum at 160: its speed is NaN there, so no minimum is
        // found in the gap and the search runs on to the next minimum of B (the one at 280).
        let m = stop_go();
        let mut pos = m.positions().to_vec();
        for f in 158..=162 {
            pos[f * 2 + 1] = [f64::NAN; 3];
        }
        let gappy = motion_from_fn(320, 100.0, 2, |i, k| pos[i * 2 + k]);
        let out =
            run_unsmoothed("v_high = { mm_per_s = 500.0 }\nv_low = { mm_per_s = 100.0 }", &gappy);
        assert!(!out.candidates.iter().any(|c| (157..=163).contains(c)), "{:?}", out.candidates);
        assert!(out.candidates.contains(&280));
    }

    #[test]
    fn defaults_are_fractions_of_p90_and_inverted_thresholds_are_rejected() {
        let m = stop_go();
        let out = run("", &m);
        // Default smoothing 0.2 s: the thresholds scale the smoothed V.
        let smoothing = TimeSpan::Seconds(0.2).whole_frames_at(m.frame_rate());
        assert!(smoothing > 0);
        let p90 =
            motionlab_features::signal::percentile(&marker_speeds(&m, smoothing).fastest, 90.0)
                .unwrap();
        assert!((out.thresholds[0].value - 0.5 * p90).abs() < 1e-9);
        assert!((out.thresholds[1].value - 0.45 * p90).abs() < 1e-9);
        let bad: toml::Value =
            toml::from_str("v_high = { mm_per_s = 50.0 }\nv_low = { mm_per_s = 100.0 }").unwrap();
        let e = build_segmenter("fastest_marker_speed", &bad).err().unwrap();
        assert_eq!(
            (e.kind(), e.location().field.as_deref()),
            (ErrorKind::InvalidParameter, Some("v_low"))
        );
        // Mixed kinds are compared once resolved.
        let mixed: toml::Value =
            toml::from_str("v_high = { mm_per_s = 1.0 }\nv_low = { fraction_of_p90 = 0.15 }")
                .unwrap();
        let e = build_segmenter("fastest_marker_speed", &mixed)
            .unwrap()
            .segment(&m, &FeatureCache::new())
            .unwrap_err();
        assert_eq!(e.location().field.as_deref(), Some("v_low"));
    }

    #[test]
    fn real_walk_with_missing_samples_obeys_the_rule() {
        // walk1: Head_FR missing at 199–209, Shoulder_R at 304–319. Thresholds low enough for a
        // steady walk to produce candidates (the defaults find none in it: nobody stops).
        let m = crate::test_data::walk1();
        let s = marker_speeds(&m, 0);
        let head = m.point_index("Head_FR").unwrap();
        assert!(s.speed(200, head).is_nan() && s.fastest[200].is_finite());
        let p90 = motionlab_features::signal::percentile(&s.fastest, 90.0).unwrap();
        let (hi, lo) = (0.6 * p90, 0.45 * p90);
        let t = track_fastest_marker(&s, hi, lo);
        assert!(!t.candidates.is_empty());
        for &j in &t.candidates {
            let k = t.tracked_marker[j].expect("a candidate ends a followed stretch");
            let vk = s.marker_speed(k);
            assert!(s.fastest[j] <= lo && is_local_min(&vk, j), "frame {j}");
            assert!(!m.is_missing(j, k) && !m.is_missing(j + 1, k));
        }
        // Through the plugin with the same thresholds in mm/s: the same frames.
        let out = run_unsmoothed(
            &format!("v_high = {{ mm_per_s = {hi} }}\nv_low = {{ mm_per_s = {lo} }}"),
            &m,
        );
        assert_eq!(out.candidates, t.candidates);
    }

    #[test]
    fn on_cmu_86_01_tracking_removes_most_plain_minima() {
        // The paper's argument on real data: at the same v_low, plain minima of V fire on every
        // wobble of a slow stretch; the tracker keeps only ends of followed movements.
        let m = crate::test_data::load("cmu86/86_01.amc.gz");
        let cache = FeatureCache::new();
        let same: toml::Value =
            toml::from_str("v_low = { fraction_of_p90 = 0.15 }\nsmoothing = { seconds = 0.0 }")
                .unwrap();
        let tracked =
            build_segmenter("fastest_marker_speed", &same).unwrap().segment(&m, &cache).unwrap();
        let plain =
            SpeedMinimaParams { v_low: SpeedThreshold::FractionOfP90(0.15), smoothing: None }
                .check()
                .unwrap()
                .segment(&m, &cache)
                .unwrap();
        assert_eq!(tracked.thresholds[1].value, plain.thresholds[0].value);
        assert!(!tracked.candidates.is_empty());
        assert!(
            tracked.candidates.len() * 10 < plain.candidates.len(),
            "{} vs {}",
            tracked.candidates.len(),
            plain.candidates.len()
        );
    }
}
