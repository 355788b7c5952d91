//! `direction_change_online`: Sonoda et al.'s direction-change candidates (§2.2) decided while
//! the frames arrive.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{
    Axis, DataKind, Decision, Error, ErrorKind, Point3, Result, SegmenterSession, StreamLayout,
    Streamed, StreamingSegmenter, TimeSpan,
};
use motionlab_features::curvature::{CurvatureSpec, k_cosine_at};

use crate::stream_frames::{frame_points, require_points};

/// The turns of the root's floor-plane path (`direction_change`, Sonoda et al. §2.2), decided
/// on a stream of frames: with q the root's floor-plane position and L the lag,
/// `C[i] = a·b / (|a||b|)`, `a = q[i−L] − q[i]`, `b = q[i+L] − q[i]` (undefined when a leg is
/// shorter than `min_leg_mm` or a position is missing); candidate i when
/// `C[i−1] < C[i] > C[i+1]` and `C[i] ≥ c_min` — exactly `direction_change`'s candidates with
/// these parameters.
///
/// **Lag, stated:** candidate i is decided when frame i + L + 1 arrives: C[i+1] needs
/// q[i+1+L]. With the default lag of 0.5 s that is half a second and a frame.
///
/// **Memory**: the last 2L + 2 root positions and three values of C. **Missing samples**: a
/// missing root makes C undefined at the three samples that read it; an undefined C is never a
/// candidate nor the neighbour of one (nothing is interpolated).
///
/// The defaults are `direction_change`'s, chosen by the protocol its documentation gives
/// (`motionlab describe direction_change`).
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
#[schemars(extend("x-defaults-tuned-on" = crate::SONODA_DEFAULTS_TUNED_ON))]
pub struct DirectionChangeOnlineParams {
    /// Root marker or joint, by its name in the stream.
    #[serde(default = "default_root")]
    pub root: String,
    /// The lag L (frames or seconds); also the decision delay, plus one frame.
    #[serde(default = "default_lag")]
    pub lag: TimeSpan,
    /// The paper's T, mm: C is undefined when either leg is shorter.
    #[serde(default = "default_min_leg_mm")]
    pub min_leg_mm: f64,
    /// A local maximum of C counts when C ≥ this (dimensionless, −1 … 1).
    #[serde(default = "default_c_min")]
    pub c_min: f64,
    /// Up axis to drop for the floor plane (`"x"`, `"y"`, `"z"`).
    #[serde(default)]
    #[schemars(extend("x-default" = "the stream's up axis"))]
    pub up_axis: Option<Axis>,
}

fn default_root() -> String {
    "root".into()
}
fn default_lag() -> TimeSpan {
    TimeSpan::Seconds(0.5)
}
fn default_c_min() -> f64 {
    0.25
}
fn default_min_leg_mm() -> f64 {
    100.0
}

/// The validated stage.
#[derive(Clone, Debug, PartialEq)]
pub struct DirectionChangeOnline {
    pub curvature: CurvatureSpec,
    pub c_min: f64,
}

impl ParamGuard for DirectionChangeOnlineParams {
    type Checked = Streamed<DirectionChangeOnline>;
    fn check(self) -> Result<Streamed<DirectionChangeOnline>> {
        if !(self.c_min.is_finite() && (-1.0..=1.0).contains(&self.c_min)) {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                format!("must be a cosine in [-1, 1], found {}", self.c_min),
            )
            .with_field("c_min"));
        }
        let curvature = CurvatureSpec::new(self.root, self.lag, self.min_leg_mm, self.up_axis)?;
        Ok(Streamed(DirectionChangeOnline { curvature, c_min: self.c_min }))
    }
}

impl DirectionChangeOnline {
    /// L in whole frames at `rate` (at least 1), as `direction_change` takes it.
    pub fn lag_frames(&self, rate: motionlab_core::FrameRate) -> usize {
        self.curvature.lag.whole_frames_at(rate).max(1)
    }
}

impl StreamingSegmenter for DirectionChangeOnline {
    fn consumes(&self) -> DataKind {
        DataKind::Points
    }
    fn start(&self, layout: &StreamLayout) -> Result<Box<dyn SegmenterSession>> {
        let m = require_points(layout, "direction_change_online")?;
        let root = layout
            .index(&self.curvature.root, "direction_change_online")
            .map_err(|e| e.with_field("root"))?;
        let up = self.curvature.up_axis.unwrap_or(layout.up_axis);
        let lag = self.lag_frames(layout.rate);
        Ok(Box::new(DirectionSession {
            m,
            root,
            plane: up.others(),
            lag,
            min_leg_mm: self.curvature.min_leg_mm,
            c_min: self.c_min,
            seen: 0,
            path: vec![[f64::NAN; 2]; 2 * lag + 1],
            c: [f64::NAN; 3],
            scratch: Vec::with_capacity(m),
        }))
    }
}

struct DirectionSession {
    m: usize,
    root: usize,
    plane: [usize; 2],
    lag: usize,
    min_leg_mm: f64,
    c_min: f64,
    seen: usize,
    /// The last 2L + 1 floor-plane positions, a ring indexed by frame modulo its length.
    path: Vec<[f64; 2]>,
    /// C at the last three centres computed (oldest first).
    c: [f64; 3],
    scratch: Vec<Point3>,
}

impl SegmenterSession for DirectionSession {
    fn width(&self) -> usize {
        3 * self.m
    }
    fn samples_seen(&self) -> usize {
        self.seen
    }
    fn push_sample(&mut self, sample: &[f64], decided: &mut Vec<Decision>) -> Result<()> {
        let r = self.seen;
        frame_points(sample, self.m, r, "direction_change_online", &mut self.scratch)?;
        let p = self.scratch[self.root];
        let len = self.path.len();
        self.path[r % len] = [p[self.plane[0]], p[self.plane[1]]];
        self.seen += 1;
        let l = self.lag;
        if r < 2 * l {
            return Ok(());
        }
        // C at the centre i = r − L, from q[i − L], q[i] and q[i + L] = the newest.
        let i = r - l;
        let ci = k_cosine_at(
            self.path[(i - l) % len],
            self.path[i % len],
            self.path[r % len],
            self.min_leg_mm,
        );
        self.c = [self.c[1], self.c[2], ci];
        // Centre i − 1 (C before L is undefined, as offline: the NaN the window starts with).
        let [a, b, c] = self.c;
        if i >= 1 && b >= self.c_min && a < b && b > c {
            decided.push(Decision { boundary: i - 1, decided_at: r });
        }
        Ok(())
    }
}

motionlab_core::register_plugin!(Segmenter, DirectionChangeOnlineParams, "direction_change_online");

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_core::registry::build_segmenter;
    use motionlab_core::{FeatureCache, Segmenter};
    use motionlab_testkit::motion_from_fn;

    #[test]
    fn a_square_walk_turns_at_its_corners_with_the_stated_lag_as_offline() {
        // The root walks a square of side 1000 mm at 10 mm/frame (Y up: the floor is x–z),
        // corners at frames 100, 200 and 300; a gap of 4 frames on the second leg.
        let corner = |i: usize| -> [f64; 3] {
            let t = i as f64 * 10.0;
            match i {
                0..100 => [t, 900.0, 0.0],
                100..200 => [1000.0, 900.0, t - 1000.0],
                200..300 => [3000.0 - t, 900.0, 1000.0],
                _ => [0.0, 900.0, 4000.0 - t],
            }
        };
        let m = motion_from_fn(400, 100.0, 1, |i, _| {
            if (150..154).contains(&i) { [f64::NAN; 3] } else { corner(i) }
        });
        let m = {
            let names = vec!["root".to_string()];
            motionlab_core::Motion::new(
                "square",
                m.frame_rate(),
                Axis::Y,
                motionlab_core::PointKind::Marker,
                names,
                m.positions().to_vec(),
            )
            .unwrap()
        };
        let params: toml::Value = toml::from_str("lag = { frames = 15 }\nc_min = -0.5").unwrap();
        let offline = build_segmenter("direction_change", &params)
            .unwrap()
            .segment(&m, &FeatureCache::new())
            .unwrap()
            .candidates;
        assert_eq!(offline, vec![100, 200, 300]);
        let on =
            toml::from_str::<DirectionChangeOnlineParams>("lag = { frames = 15 }\nc_min = -0.5")
                .unwrap()
                .check()
                .unwrap();
        let (layout, samples) = StreamLayout::of_motion(&m, DataKind::Points, "t").unwrap();
        let decided = motionlab_core::streaming::run_offline(&on.0, &layout, samples).unwrap();
        assert_eq!(decided.iter().map(|d| d.boundary).collect::<Vec<_>>(), offline);
        assert!(decided.iter().all(|d| d.decided_at == d.boundary + 16), "{decided:?}");
        assert_eq!(on.segment(&m, &FeatureCache::new()).unwrap().candidates, offline);
        // A stream without the root is refused, naming it.
        let other = StreamLayout::points(vec!["rooot".into()], m.frame_rate(), Axis::Y);
        let e = on.0.start(&other).err().unwrap();
        assert!(e.to_string().contains("closest: rooot"), "{e}");
    }
}
