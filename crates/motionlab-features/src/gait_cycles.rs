//! Gait cycles: same-side foot strike to the next foot strike (Osafune et al. analyse walks one
//! gait cycle at a time; the cycle duration gives the frequency).
//!
//! Two detectors: `c3d_events` reads the Foot Strike events stored in the file (Vicon writes
//! them from force plates or by hand), `heel_height` finds foot strikes in the heel marker's
//! vertical trajectory when a file has no events (BVH, AMC, TSV). Both are small enough that no
//! crate is warranted (the only gait-event crates are Python: gaitpy, pyomeca).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::{GaitCycle, GaitCycleDetector};
use motionlab_core::registry::ParamGuard;
use motionlab_core::{Error, ErrorKind, Location, Motion, Result, TimeSpan};

use crate::signal::percentile;

/// Which foot's cycles to return.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum CycleSide {
    Left,
    Right,
    /// Both feet's cycles, sorted by start frame.
    #[default]
    Both,
}

impl CycleSide {
    fn sides(self) -> &'static [(&'static str, usize)] {
        match self {
            CycleSide::Left => &[("Left", 0)],
            CycleSide::Right => &[("Right", 1)],
            CycleSide::Both => &[("Left", 0), ("Right", 1)],
        }
    }
}

/// Cycles from consecutive strike instants (fractional frames) of one side; strikes are
/// rounded to the nearest frame.
fn cycles_from_strikes(strikes: &mut [f64], side: &str) -> Vec<GaitCycle> {
    strikes.sort_by(f64::total_cmp);
    strikes
        .windows(2)
        .filter_map(|w| {
            let (start, end) = (w[0].round() as usize, w[1].round() as usize);
            (end > start).then(|| GaitCycle { start, end, side: side.to_string() })
        })
        .collect()
}

fn sort_cycles(cycles: &mut [GaitCycle]) {
    cycles.sort_by(|a, b| a.start.cmp(&b.start).then(a.side.cmp(&b.side)));
}

fn location_of(motion: &Motion) -> Location {
    motion.source.as_ref().map(Location::file).unwrap_or_default()
}

// ---------------------------------------------------------------------------------------------
// From the C3D events
// ---------------------------------------------------------------------------------------------

/// Gait cycles from the foot-strike events stored in the file (C3D `EVENT` group): each cycle
/// runs from a Foot Strike to the next Foot Strike of the same foot, `start..end` in frames
/// (the event's fractional frame rounded to the nearest frame; `end` is the next cycle's start).
///
/// An event is a foot strike when its label, trimmed, equals `strike_label` (case-insensitive)
/// or is `strike_label` followed by digits only (this dataset's Vicon export numbers them:
/// `Foot Strike1`, `Foot Strike2`); its side comes from its context (`left_context` /
/// `right_context`). Events that do not round to a recorded frame are ignored. With `side = "both"` a
/// foot with fewer than two strikes contributes no cycle; the stage fails only when no cycle
/// is found at all (then use `heel_height`). Missing marker samples play no part.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct C3dEventsParams {
    /// Which foot's cycles: `"left"`, `"right"` or `"both"`.
    #[serde(default)]
    pub side: CycleSide,
    /// Label of the foot-strike events.
    #[serde(default = "default_strike_label")]
    pub strike_label: String,
    /// Event context of the left foot.
    #[serde(default = "default_left_context")]
    pub left_context: String,
    /// Event context of the right foot.
    #[serde(default = "default_right_context")]
    pub right_context: String,
}

fn default_strike_label() -> String {
    "Foot Strike".into()
}
fn default_left_context() -> String {
    "Left".into()
}
fn default_right_context() -> String {
    "Right".into()
}

impl Default for C3dEventsParams {
    fn default() -> Self {
        C3dEventsParams {
            side: CycleSide::Both,
            strike_label: default_strike_label(),
            left_context: default_left_context(),
            right_context: default_right_context(),
        }
    }
}

impl ParamGuard for C3dEventsParams {
    type Checked = C3dEventsParams;
    fn check(self) -> Result<Self> {
        for (field, v) in [
            ("strike_label", &self.strike_label),
            ("left_context", &self.left_context),
            ("right_context", &self.right_context),
        ] {
            if v.trim().is_empty() {
                return Err(
                    Error::new(ErrorKind::InvalidParameter, "must not be empty").with_field(field)
                );
            }
        }
        if self.left_context.trim().eq_ignore_ascii_case(self.right_context.trim()) {
            return Err(Error::new(
                ErrorKind::InvalidParameter,
                "left and right contexts must differ",
            )
            .with_field("right_context"));
        }
        Ok(self)
    }
}

impl C3dEventsParams {
    fn is_strike(&self, label: &str) -> bool {
        let label = label.trim();
        let want = self.strike_label.trim();
        label.len() >= want.len()
            && label.is_char_boundary(want.len())
            && label[..want.len()].eq_ignore_ascii_case(want)
            && label[want.len()..].chars().all(|c| c.is_ascii_digit())
    }
}

impl GaitCycleDetector for C3dEventsParams {
    fn cycles(&self, motion: &Motion) -> Result<Vec<GaitCycle>> {
        let last = motion.n_frames().saturating_sub(1) as f64;
        let contexts = [self.left_context.trim(), self.right_context.trim()];
        let mut cycles = Vec::new();
        for &(side, k) in self.side.sides() {
            let mut strikes: Vec<f64> = motion
                .events
                .iter()
                .filter(|e| {
                    self.is_strike(&e.label) && e.context.trim().eq_ignore_ascii_case(contexts[k])
                })
                .map(|e| e.frame)
                // Rounded to a recorded frame, so a cycle never ends after the last frame.
                .filter(|f| f.is_finite() && f.round() >= 0.0 && f.round() <= last)
                .collect();
            cycles.extend(cycles_from_strikes(&mut strikes, side));
        }
        if cycles.is_empty() {
            let found: Vec<String> = motion
                .events
                .iter()
                .map(|e| format!("{}/{}", e.label.trim(), e.context.trim()))
                .collect();
            return Err(Error::new(
                ErrorKind::MissingData,
                format!(
                    "{}: no two {:?} events of the same foot ({}); events present: [{}]. Use the `heel_height` detector for files without events",
                    motion.name,
                    self.strike_label,
                    match self.side {
                        CycleSide::Both => "either foot".to_string(),
                        s => format!("side {s:?}"),
                    },
                    found.join(", ")
                ),
            )
            .with_location(location_of(motion).field("EVENT")));
        }
        sort_cycles(&mut cycles);
        Ok(cycles)
    }
}

motionlab_core::register_custom_plugin!(
    crate::GaitCycleDetector,
    C3dEventsParams,
    "c3d_events",
    kind = "gait_cycle_detector"
);

// ---------------------------------------------------------------------------------------------
// From the heel marker's height
// ---------------------------------------------------------------------------------------------

/// How a foot strike is placed once the heel has come down.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum StrikeRule {
    /// The instant the heel height falls through the contact level.
    Height,
    /// After that, the first instant the heel's horizontal speed falls to `strike_speed_mm_per_s`
    /// (in terminal swing the heel skims the floor while still moving forward).
    #[default]
    HeightThenSpeed,
}

/// Gait cycles from foot strikes found in the heel marker's trajectory — the fallback for files
/// without gait events (BVH/AMC: give a foot or ankle joint as the "heel").
///
/// Rule, per foot: `h` = the heel's height along the motion's up axis, optionally smoothed
/// (centred moving average). `floor` and `top` are the 5th and 95th percentiles of `h`;
/// `contact = floor + contact_fraction·(top − floor)`, `swing = floor + swing_fraction·(top − floor)`.
/// The heel comes down when `h` falls through `contact` (`h[i−1] > contact ≥ h[i]`) after having
/// risen above `swing` since the previous strike — or, before the first strike, when the
/// recording starts with the heel above `contact`. With `rule = "height"` that instant (linearly
/// interpolated) is the strike. With `rule = "height_then_speed"` the strike is the
/// first instant at or after it at which the heel's horizontal speed `v` (central difference
/// of the floor-plane position, mm/s) falls to `strike_speed_mm_per_s` (interpolated between
/// frames); a recording that starts with the heel already low but still moving faster than that
/// counts as having come down at frame 0. Cycles run from a strike to the next strike of the
/// same foot, rounded to the nearest frame, when the heel swung exactly once in between (two
/// swings mean a strike was missed: no cycle is made across it).
///
/// Measured on the 36 Schreiber & Moissenet trials against their Foot Strike events (which
/// coincide with force-plate loading): the height rule alone fires about 10 frames early (the
/// heel skims the floor in terminal swing) and misses the first strike of most trials; the
/// speed gate of 500 mm/s (chosen on these data) lands within ±2 frames of the event for most
/// strikes — `tests/schreiber2019.rs` in motionlab-gait asserts and prints the counts.
///
/// Missing samples: a missing heel sample is skipped (it never starts or ends a crossing; a
/// crossing inside a gap is missed, and the two cycles around it are dropped; the speed at a
/// frame next to a gap is undefined and does not end the wait). Fails when the heel never rises
/// `min_rise_mm` above its floor or no cycle is found.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct HeelHeightParams {
    /// Left heel marker (or joint); the default is the ISB calcaneus marker.
    #[serde(default = "default_left_heel")]
    pub left_heel: String,
    /// Right heel marker (or joint).
    #[serde(default = "default_right_heel")]
    pub right_heel: String,
    /// Which foot's cycles: `"left"`, `"right"` or `"both"`.
    #[serde(default)]
    pub side: CycleSide,
    /// Contact level as a fraction of the heel's height range (dimensionless).
    #[serde(default = "default_contact_fraction")]
    pub contact_fraction: f64,
    /// Swing level (the heel must rise above it between strikes), fraction of the range.
    #[serde(default = "default_swing_fraction")]
    pub swing_fraction: f64,
    /// The heel must rise at least this far above its floor (mm), else the motion is not a
    /// walk for this foot.
    #[serde(default = "default_min_rise_mm")]
    pub min_rise_mm: f64,
    /// Centred moving average on the heel height and horizontal speed before detection
    /// (`{ frames = 3 }` or `{ seconds = 0.03 }`).
    #[serde(default)]
    pub smoothing: Option<TimeSpan>,
    /// `"height_then_speed"` or `"height"` (see above).
    #[serde(default)]
    pub rule: StrikeRule,
    /// Horizontal heel speed (mm/s) at which the heel has landed (rule `height_then_speed`).
    #[serde(default = "default_strike_speed")]
    pub strike_speed_mm_per_s: f64,
}

fn default_left_heel() -> String {
    "L_FCC".into()
}
fn default_right_heel() -> String {
    "R_FCC".into()
}
fn default_contact_fraction() -> f64 {
    0.05
}
fn default_swing_fraction() -> f64 {
    0.5
}
fn default_min_rise_mm() -> f64 {
    30.0
}
fn default_strike_speed() -> f64 {
    500.0
}

impl Default for HeelHeightParams {
    fn default() -> Self {
        HeelHeightParams {
            left_heel: default_left_heel(),
            right_heel: default_right_heel(),
            side: CycleSide::Both,
            contact_fraction: default_contact_fraction(),
            swing_fraction: default_swing_fraction(),
            min_rise_mm: default_min_rise_mm(),
            smoothing: None,
            rule: StrikeRule::default(),
            strike_speed_mm_per_s: default_strike_speed(),
        }
    }
}

impl ParamGuard for HeelHeightParams {
    type Checked = HeelHeightParams;
    fn check(self) -> Result<Self> {
        let fraction = |field: &str, v: f64| {
            if v.is_finite() && v > 0.0 && v < 1.0 {
                Ok(())
            } else {
                Err(Error::new(
                    ErrorKind::OutOfRange,
                    format!("must be a fraction in (0, 1), found {v}"),
                )
                .with_field(field))
            }
        };
        fraction("contact_fraction", self.contact_fraction)?;
        fraction("swing_fraction", self.swing_fraction)?;
        if self.contact_fraction >= self.swing_fraction {
            return Err(Error::new(
                ErrorKind::InvalidParameter,
                format!(
                    "contact_fraction ({}) must be below swing_fraction ({})",
                    self.contact_fraction, self.swing_fraction
                ),
            )
            .with_field("contact_fraction"));
        }
        if !(self.min_rise_mm.is_finite() && self.min_rise_mm >= 0.0) {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                format!("must be >= 0 mm, found {}", self.min_rise_mm),
            )
            .with_field("min_rise_mm"));
        }
        if !(self.strike_speed_mm_per_s.is_finite() && self.strike_speed_mm_per_s > 0.0) {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                format!("must be > 0 mm/s, found {}", self.strike_speed_mm_per_s),
            )
            .with_field("strike_speed_mm_per_s"));
        }
        if let Some(s) = self.smoothing {
            s.check("smoothing", false)?;
        }
        Ok(self)
    }
}

/// Centred moving average over `window` frames (shrunk at the ends), skipping NaN.
fn moving_average(x: &[f64], window: usize) -> Vec<f64> {
    if window <= 1 {
        return x.to_vec();
    }
    let half = window / 2;
    (0..x.len())
        .map(|i| {
            if x[i].is_nan() {
                return f64::NAN;
            }
            let (lo, hi) = (i.saturating_sub(half), (i + half + 1).min(x.len()));
            let (sum, n) = x[lo..hi]
                .iter()
                .filter(|v| v.is_finite())
                .fold((0.0, 0.0), |(s, n), v| (s + v, n + 1.0));
            sum / n
        })
        .collect()
}

/// A foot strike found in a heel-height series.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeelStrike {
    /// Fractional frame of the crossing of the contact level.
    pub frame: f64,
    /// Swings (rises above the swing level) since the previous strike: exactly 1 when the two
    /// strikes bound one gait cycle; more when a strike was missed (e.g. in a marker gap).
    pub swings_since_previous: usize,
}

/// The levels and rule of [`HeelHeightParams`], for [`heel_strikes`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StrikeLevels {
    pub contact_fraction: f64,
    pub swing_fraction: f64,
    pub min_rise_mm: f64,
    /// `Some(v)`: rule `height_then_speed` with threshold `v` mm/s; `None`: rule `height`.
    pub strike_speed_mm_per_s: Option<f64>,
}

/// Foot strikes in a heel trajectory by the rule of [`HeelHeightParams`]: `height[i]` (mm) and
/// the horizontal speed `speed[i]` (mm/s, NaN where undefined; only read with a speed rule).
/// `None` when the heel never rises `min_rise_mm` above its floor.
pub fn heel_strikes(
    height: &[f64],
    speed: &[f64],
    levels: &StrikeLevels,
) -> Option<Vec<HeelStrike>> {
    let floor = percentile(height, 5.0)?;
    let top = percentile(height, 95.0)?;
    if top - floor < levels.min_rise_mm || top <= floor {
        return None;
    }
    let contact = floor + levels.contact_fraction * (top - floor);
    let swing = floor + levels.swing_fraction * (top - floor);
    let start = height.iter().position(|v| v.is_finite())?;
    let fast = |i: usize, gate: f64| speed.get(i).is_some_and(|v| *v > gate);
    // Came down (waiting for the speed to drop) / armed (waiting for the height crossing).
    let mut landing = false;
    let mut swings = 0;
    if height[start] > contact {
        swings = 1; // the recording starts mid-descent: that counts as one swing
    } else if let Some(gate) = levels.strike_speed_mm_per_s
        && fast(start, gate)
    {
        swings = 1;
        landing = true;
    }
    let mut above_swing = height[start] > swing;
    let mut strikes = Vec::new();
    for i in start + 1..height.len() {
        let (a, b) = (height[i - 1], height[i]);
        if b.is_finite() {
            if b > swing && !above_swing {
                swings += 1;
            }
            above_swing = b > swing;
        }
        if !landing && swings > 0 && a > contact && contact >= b {
            match levels.strike_speed_mm_per_s {
                None => {
                    strikes.push(HeelStrike {
                        frame: (i - 1) as f64 + (a - contact) / (a - b),
                        swings_since_previous: swings,
                    });
                    swings = 0;
                    continue;
                }
                Some(_) => landing = true,
            }
        }
        if landing
            && let Some(gate) = levels.strike_speed_mm_per_s
            && speed[i] <= gate
        {
            let prev = speed[i - 1];
            let frame = if prev.is_finite() && prev > gate {
                (i - 1) as f64 + (prev - gate) / (prev - speed[i])
            } else {
                i as f64
            };
            strikes.push(HeelStrike { frame, swings_since_previous: swings });
            swings = 0;
            landing = false;
        }
    }
    Some(strikes)
}

/// Horizontal speed (mm/s) of a trajectory by central differences (one-sided at the ends);
/// NaN where a needed sample is missing.
pub fn horizontal_speed(motion: &Motion, point: usize) -> Vec<f64> {
    let n = motion.n_frames();
    let rate = motion.frame_rate().hz();
    let xy: Vec<[f64; 2]> = motion.trajectory(point).map(|p| motion.horizontal(p)).collect();
    (0..n)
        .map(|i| {
            let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
            if a == b {
                return f64::NAN;
            }
            let d = [xy[b][0] - xy[a][0], xy[b][1] - xy[a][1]];
            (d[0] * d[0] + d[1] * d[1]).sqrt() * rate / (b - a) as f64
        })
        .collect()
}

/// Cycles between consecutive heel strikes that bound exactly one swing.
fn cycles_from_heel_strikes(strikes: &[HeelStrike], side: &str) -> Vec<GaitCycle> {
    strikes
        .windows(2)
        .filter(|w| w[1].swings_since_previous == 1)
        .filter_map(|w| {
            let (start, end) = (w[0].frame.round() as usize, w[1].frame.round() as usize);
            (end > start).then(|| GaitCycle { start, end, side: side.to_string() })
        })
        .collect()
}

impl GaitCycleDetector for HeelHeightParams {
    fn cycles(&self, motion: &Motion) -> Result<Vec<GaitCycle>> {
        motion.require_frames(3, "heel_height")?;
        let window = self.smoothing.map(|s| s.whole_frames_at(motion.frame_rate())).unwrap_or(0);
        let heels = [self.left_heel.as_str(), self.right_heel.as_str()];
        let levels = StrikeLevels {
            contact_fraction: self.contact_fraction,
            swing_fraction: self.swing_fraction,
            min_rise_mm: self.min_rise_mm,
            strike_speed_mm_per_s: (self.rule == StrikeRule::HeightThenSpeed)
                .then_some(self.strike_speed_mm_per_s),
        };
        let mut cycles = Vec::new();
        let mut flat = Vec::new();
        for &(side, k) in self.side.sides() {
            let point = motion
                .point_index(heels[k])
                .map_err(|e| e.under_field(if k == 0 { "left_heel" } else { "right_heel" }))?;
            let height: Vec<f64> = motion.trajectory(point).map(|p| motion.height(p)).collect();
            let speed = moving_average(&horizontal_speed(motion, point), window);
            match heel_strikes(&moving_average(&height, window), &speed, &levels) {
                Some(strikes) => cycles.extend(cycles_from_heel_strikes(&strikes, side)),
                None => flat.push(heels[k]),
            }
        }
        if cycles.is_empty() {
            let why = if flat.is_empty() {
                "fewer than two foot strikes per foot".to_string()
            } else {
                format!(
                    "heel {} never rises {} mm above its floor",
                    flat.join(" and "),
                    self.min_rise_mm
                )
            };
            return Err(Error::new(
                ErrorKind::MissingData,
                format!("{}: no gait cycle found ({why}); expected a walk", motion.name),
            )
            .with_location(location_of(motion)));
        }
        sort_cycles(&mut cycles);
        Ok(cycles)
    }
}

motionlab_core::register_custom_plugin!(
    crate::GaitCycleDetector,
    HeelHeightParams,
    "heel_height",
    kind = "gait_cycle_detector"
);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::build_gait_cycle_detector;
    use motionlab_core::{Event, Seconds};
    use motionlab_testkit::named_motion;

    fn event(label: &str, context: &str, frame: f64) -> Event {
        Event { label: label.into(), context: context.into(), time: Seconds(frame / 100.0), frame }
    }

    fn walk_with_events(events: Vec<Event>) -> Motion {
        let mut m = named_motion(160, 100.0, &["L_FCC", "R_FCC"], |_, _| [0.0; 3]);
        m.events = events;
        m
    }

    #[test]
    fn events_give_same_side_strike_to_strike_cycles() {
        let m = walk_with_events(vec![
            event("Foot Strike1", "Right", 3.999_997),
            event("Foot Off", "Left", 14.0),
            event("Foot Strike1", "Left", 52.0),
            event("Foot Off", "Right", 65.0),
            event("Foot Strike2", "Right", 100.2),
            event("Foot Strike2", " left ", 149.0),
            event("Foot Strike", "Left", 400.0), // after the last frame: ignored
            event("Foot Strike", "Right", 159.5), // rounds to 160, one past the last frame: ignored
        ]);
        let c = C3dEventsParams::default().cycles(&m).unwrap();
        assert_eq!(
            c,
            vec![
                GaitCycle { start: 4, end: 100, side: "Right".into() },
                GaitCycle { start: 52, end: 149, side: "Left".into() },
            ]
        );
        let left =
            C3dEventsParams { side: CycleSide::Left, ..Default::default() }.cycles(&m).unwrap();
        assert_eq!(left.len(), 1);
        assert_eq!(left[0].side, "Left");
        // "Foot Strikes" or "Foot Strike A" are other labels.
        let p = C3dEventsParams::default();
        assert!(
            p.is_strike(" foot strike12 ")
                && !p.is_strike("Foot Strikes")
                && !p.is_strike("Foot Strike A")
        );
    }

    #[test]
    fn no_events_is_an_error_that_points_to_heel_height() {
        let m = walk_with_events(vec![
            event("Foot Strike", "Left", 10.0),
            event("Foot Off", "Left", 30.0),
        ]);
        let e = C3dEventsParams::default().cycles(&m).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::MissingData);
        assert!(
            e.to_string().contains("heel_height") && e.to_string().contains("Foot Off/Left"),
            "{e}"
        );
    }

    /// Phase in [0, 1) of frame `i` for strikes every `period` frames at frames `phase + k·period`.
    fn phase_of(i: usize, period: usize, phase: usize) -> f64 {
        ((i + period - phase % period) % period) as f64 / period as f64
    }

    /// A heel that rests at 20–26 mm in stance (t < 0.6), swings up to 200 mm, and skims the
    /// floor at 21 mm for the last 5 % of the cycle while still moving forward; it moves 10 mm
    /// per frame (1000 mm/s at 100 Hz) from t = 0.6 until the strike at t = 0.
    fn heel_height(t: f64) -> f64 {
        if t < 0.6 {
            20.0 + 10.0 * t
        } else if t < 0.95 {
            26.0 + 174.0 * (std::f64::consts::PI * (t - 0.6) / 0.35).sin()
        } else {
            21.0
        }
    }

    fn heel_walk(n: usize, period: usize, phases: [usize; 2]) -> Motion {
        let x: Vec<Vec<f64>> = phases
            .iter()
            .map(|&ph| {
                let mut x = vec![0.0; n];
                for i in 1..n {
                    x[i] = x[i - 1] + if phase_of(i - 1, period, ph) >= 0.6 { 10.0 } else { 0.0 };
                }
                x
            })
            .collect();
        named_motion(n, 100.0, &["L_FCC", "R_FCC"], |i, k| {
            [x[k][i], 0.0, heel_height(phase_of(i, period, phases[k]))]
        })
    }

    #[test]
    fn heel_strike_is_where_the_heel_stops_after_coming_down() {
        let (period, n) = (100, 260);
        // Left strikes at 10, 110, 210 (the recording starts mid-descent); right at 3, 103, 203
        // (it starts while the heel skims the floor at 1000 mm/s).
        let m = heel_walk(n, period, [10, 3]);
        let c = HeelHeightParams::default().cycles(&m).unwrap();
        let expect = |side: &str, first: usize| {
            let got: Vec<(usize, usize)> =
                c.iter().filter(|c| c.side == side).map(|c| (c.start, c.end)).collect();
            assert_eq!(
                got,
                vec![(first, first + period), (first + period, first + 2 * period)],
                "{side}: {c:?}"
            );
        };
        expect("Left", 10);
        expect("Right", 3);
        // Height alone fires when the heel first reaches the skim height, before the strike,
        // found independently from the closed-form height: the last frame above the contact level.
        let h: Vec<f64> = (0..n).map(|i| heel_height(phase_of(i, period, 10))).collect();
        let (floor, top) = (percentile(&h, 5.0).unwrap(), percentile(&h, 95.0).unwrap());
        let contact = floor + 0.05 * (top - floor);
        let down = (1..n).find(|&i| h[i - 1] > contact && h[i] <= contact).unwrap();
        assert!(down + 3 < 10, "{down}");
        let height_only =
            HeelHeightParams { rule: StrikeRule::Height, ..Default::default() }.cycles(&m).unwrap();
        let left: Vec<&GaitCycle> = height_only.iter().filter(|c| c.side == "Left").collect();
        assert_eq!(left.len(), 2, "{height_only:?}");
        assert!(
            left[0].start.abs_diff(down) <= 1 && left[1].start.abs_diff(down + period) <= 1,
            "{left:?} vs {down}"
        );
        // Height alone cannot see the right foot's first strike (the heel starts low).
        assert!(
            height_only.iter().filter(|c| c.side == "Right").all(|c| c.start > 50),
            "{height_only:?}"
        );
    }

    #[test]
    fn a_strike_lost_in_a_gap_drops_its_two_cycles() {
        let (period, n) = (100, 260);
        let good = heel_walk(n, period, [10, 60]);
        let mut gap = good.clone();
        let k = gap.point_index("L_FCC").unwrap();
        for i in 100..115 {
            gap.positions_mut()[i * 2 + k] = [f64::NAN; 3];
        }
        gap.refresh_missing();
        assert_eq!(
            HeelHeightParams::default()
                .cycles(&good)
                .unwrap()
                .iter()
                .filter(|c| c.side == "Left")
                .count(),
            2
        );
        let c = HeelHeightParams::default().cycles(&gap).unwrap();
        assert!(c.iter().all(|c| c.side == "Right"), "{c:?}");
    }

    #[test]
    fn a_flat_heel_is_not_a_walk() {
        let m = named_motion(50, 100.0, &["L_FCC", "R_FCC"], |i, _| {
            [i as f64, 0.0, 20.0 + (i % 3) as f64]
        });
        let e = HeelHeightParams::default().cycles(&m).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::MissingData);
        assert!(e.to_string().contains("never rises"), "{e}");
        let e = HeelHeightParams { left_heel: "LHEE".into(), ..Default::default() }
            .cycles(&m)
            .unwrap_err();
        assert_eq!(e.kind(), ErrorKind::UnknownName);
        assert_eq!(e.location().field.as_deref(), Some("left_heel.LHEE"));
    }

    #[test]
    fn params_are_validated_and_registered() {
        let t: toml::Value = toml::from_str("contact_fraction = 0.6").unwrap();
        let e = build_gait_cycle_detector("heel_height", &t).err().unwrap();
        assert_eq!(e.location().field.as_deref(), Some("contact_fraction"));
        let t: toml::Value = toml::from_str("side = \"left\"\nsmoothing = { frames = 3 }").unwrap();
        assert!(build_gait_cycle_detector("heel_height", &t).is_ok());
        let t: toml::Value = toml::from_str("left_context = \"Right\"").unwrap();
        assert!(build_gait_cycle_detector("c3d_events", &t).is_err());
        assert!(
            build_gait_cycle_detector("c3d_events", &motionlab_core::registry::default_params())
                .is_ok()
        );
    }
}
