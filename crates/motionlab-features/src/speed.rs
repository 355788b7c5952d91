//! Marker speeds and the fastest-marker speed `V` (Sonoda et al. §2.1).
//!
//! `v[i][k] = |p[i+1][k] − p[i][k]| · fps` (mm/s) for `i < F−1`; `V[i] = max_k v[i][k]`.
//! The last frame has no successor, so `v[F−1][k]` is NaN.
//!
//! **Missing samples:** a marker missing at `i` or `i+1` has `v[i][k] = NaN` and is skipped
//! when taking the maximum; `V[i]` is NaN only when no marker is valid at both frames.

use motionlab_core::registry::ParamGuard;
use motionlab_core::{
    FeatureCache, FeatureExtractor, FeatureSet, LabelTrace, Motion, Result, TimeSpan, Trace,
};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::smoothing::moving_average_positions;

/// Per-marker speeds of a motion, frame-major like its positions.
#[derive(Clone, Debug, PartialEq)]
pub struct MarkerSpeeds {
    pub n_points: usize,
    /// `speeds[i * M + k]` = `v[i][k]` in mm/s (NaN where undefined).
    pub speeds: Vec<f64>,
    /// `V[i]`, mm/s.
    pub fastest: Vec<f64>,
    /// The marker giving `V[i]` (None where `V[i]` is NaN).
    pub fastest_marker: Vec<Option<usize>>,
}

impl MarkerSpeeds {
    pub fn n_frames(&self) -> usize {
        self.fastest.len()
    }
    /// `v[i][k]`.
    pub fn speed(&self, frame: usize, point: usize) -> f64 {
        self.speeds[frame * self.n_points + point]
    }
    /// One marker's speed over all frames.
    pub fn marker_speed(&self, point: usize) -> Vec<f64> {
        (0..self.n_frames()).map(|i| self.speed(i, point)).collect()
    }
}

/// Computes `v` and `V` from positions smoothed by a centred moving average of
/// `smoothing_frames` frames (≤ 1 = no smoothing).
pub fn marker_speeds(motion: &Motion, smoothing_frames: usize) -> MarkerSpeeds {
    let f = motion.n_frames();
    let m = motion.n_points();
    let fps = motion.frame_rate().hz();
    let smoothed;
    let positions = if smoothing_frames > 1 {
        smoothed = moving_average_positions(motion, smoothing_frames);
        &smoothed[..]
    } else {
        motion.positions()
    };
    let flat = positions.as_flattened();
    // NaN where the kernel writes nothing: the last frame, which has no successor.
    let mut speeds = vec![f64::NAN; f * m];
    let mut fastest = vec![f64::NAN; f];
    let mut fastest_marker = vec![None; f];
    let simd = crate::simd::available();
    for (i, row) in speeds.chunks_exact_mut(m.max(1)).take(f.saturating_sub(1)).enumerate() {
        let (a, b) = (&flat[3 * m * i..3 * m * (i + 1)], &flat[3 * m * (i + 1)..3 * m * (i + 2)]);
        let top = speed_row_dispatch(simd, a, b, fps, row);
        // The first marker at the top speed, as a sequential `>` scan would pick (NaN = missing
        // never equals it; no valid marker: top = −∞, matched by none).
        if let Some(k) = row.iter().position(|&v| v == top) {
            (fastest[i], fastest_marker[i]) = (top, Some(k));
        }
    }
    MarkerSpeeds { n_points: m, speeds, fastest, fastest_marker }
}

/// One step of [`marker_speeds`], for streams that get one frame at a time: `row[k]` = the
/// speed of marker `k` from frame `a` to frame `b` (flat x, y, z per marker, mm; NaN =
/// missing) in mm/s, with the same operations (and bits) as the whole-motion computation.
/// Returns the fastest marker (the first at the top speed) and its speed, None when no marker
/// is valid at both frames.
pub fn step_speeds(a: &[f64], b: &[f64], fps: f64, row: &mut [f64]) -> Option<(usize, f64)> {
    let top = speed_row_dispatch(crate::simd::available(), a, b, fps, row);
    row.iter().position(|&v| v == top).map(|k| (k, top))
}

/// [`speed_row_avx2`] when `simd` (from `simd::available`), else [`speed_row`].
#[inline]
fn speed_row_dispatch(simd: bool, a: &[f64], b: &[f64], fps: f64, row: &mut [f64]) -> f64 {
    #[cfg(target_arch = "x86_64")]
    if simd {
        // SAFETY: the CPU supports AVX2 (`simd` comes from `simd::available`), the only
        // requirement of the `target_feature` function.
        return unsafe { speed_row_avx2(a, b, fps, row) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = simd;
    speed_row(a, b, fps, row)
}

/// One frame step: `row[k] = √((dx² + dy²) + dz²) · fps` for the flat coordinates `a` (frame
/// `i`) and `b` (frame `i+1`), in exactly this order of operations (no FMA), so the AVX2 kernel
/// gives the same bits. Returns the largest speed (−∞ when every marker is missing; a NaN never
/// wins the `>` comparison).
fn speed_row(a: &[f64], b: &[f64], fps: f64, row: &mut [f64]) -> f64 {
    let mut top = f64::NEG_INFINITY;
    for ((v, a), b) in row.iter_mut().zip(a.chunks_exact(3)).zip(b.chunks_exact(3)) {
        let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        *v = ((d[0] * d[0] + d[1] * d[1]) + d[2] * d[2]).sqrt() * fps; // NaN when missing
        top = if *v > top { *v } else { top };
    }
    top
}

/// [`speed_row`] with AVX2, four markers per register: the 12 coordinates of markers
/// `4j..4j+4` are three loads (`x0 y0 z0 x1 | y1 z1 x2 y2 | z2 x3 y3 z3`), differenced and
/// squared, then de-interleaved by blends and permutes into `x², y², z²` of the four markers.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn speed_row_avx2(a: &[f64], b: &[f64], fps: f64, row: &mut [f64]) -> f64 {
    use std::arch::x86_64::*;
    let quads = row.len() / 4;
    let rate = _mm256_set1_pd(fps);
    let mut top4 = _mm256_set1_pd(f64::NEG_INFINITY);
    for j in 0..quads {
        let (a, b) = (&a[12 * j..12 * j + 12], &b[12 * j..12 * j + 12]);
        // SAFETY: `a` and `b` have 12 elements: three unaligned 32-byte loads each.
        let sq = |k: usize| unsafe {
            let d = _mm256_sub_pd(
                _mm256_loadu_pd(b[4 * k..].as_ptr()),
                _mm256_loadu_pd(a[4 * k..].as_ptr()),
            );
            _mm256_mul_pd(d, d)
        };
        let (s0, s1, s2) = (sq(0), sq(1), sq(2));
        // s0 = x0 y0 z0 x1, s1 = y1 z1 x2 y2, s2 = z2 x3 y3 z3 (squares).
        let x = _mm256_permute4x64_pd::<0b01_10_11_00>(_mm256_blend_pd::<0b0010>(
            _mm256_blend_pd::<0b0100>(s0, s1),
            s2,
        ));
        let y = _mm256_permute_pd::<0b0101>(_mm256_blend_pd::<0b0100>(
            _mm256_blend_pd::<0b1001>(s0, s1),
            s2,
        ));
        let z = _mm256_permute4x64_pd::<0b11_00_01_10>(_mm256_blend_pd::<0b1001>(
            _mm256_blend_pd::<0b0010>(s0, s1),
            s2,
        ));
        let v = _mm256_mul_pd(_mm256_sqrt_pd(_mm256_add_pd(_mm256_add_pd(x, y), z)), rate);
        // SAFETY: `row[4j..4j+4]` exists (unaligned 32-byte store).
        unsafe { _mm256_storeu_pd(row[4 * j..4 * j + 4].as_mut_ptr(), v) };
        // vmaxpd returns the second operand when either is NaN: a missing marker never wins.
        top4 = _mm256_max_pd(v, top4);
    }
    let mut lanes = [0.0; 4];
    // SAFETY: `lanes` is 4 × f64 = 32 bytes, the width of the unaligned store.
    unsafe { _mm256_storeu_pd(lanes.as_mut_ptr(), top4) };
    let top = lanes.into_iter().fold(f64::NEG_INFINITY, |t, v| if v > t { v } else { t });
    let rest = 4 * quads;
    let top_rest = speed_row(&a[3 * rest..], &b[3 * rest..], fps, &mut row[rest..]);
    if top_rest > top { top_rest } else { top }
}

/// Cached [`marker_speeds`]: the speed segmenters and the feature extractor share one computation.
pub fn cached_marker_speeds(
    motion: &Motion,
    cache: &FeatureCache,
    smoothing_frames: usize,
) -> Result<std::sync::Arc<MarkerSpeeds>> {
    cache.get_or_compute(&format!("marker_speeds/smooth={smoothing_frames}"), || {
        Ok(marker_speeds(motion, smoothing_frames))
    })
}

/// Per-frame speed of every marker and the fastest-marker speed V (mm/s), with the name of the
/// fastest marker at each frame (Sonoda et al. §2.1). On 2-D image positions (video pose
/// estimation) the speeds are px/s and the traces are named `V_px_per_s`, `v_<marker>_px_per_s`.
///
/// `v[i][k] = |p[i+1][k] − p[i][k]| · fps`; `V[i] = max_k v[i][k]`. The last frame is NaN
/// (no successor). Missing samples: a marker missing at either frame is skipped; V is NaN only
/// when no marker is valid.
#[derive(Clone, Debug, Default, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MarkerSpeedParams {
    /// Centred moving-average window applied to positions before differentiating
    /// (`{ frames = 5 }` or `{ seconds = 0.05 }`).
    #[serde(default)]
    #[schemars(extend("x-default" = "raw positions"))]
    pub smoothing: Option<TimeSpan>,
    /// Also output every marker's own speed as `v_<marker>_mm_per_s`.
    #[serde(default)]
    pub per_marker: bool,
}

impl ParamGuard for MarkerSpeedParams {
    type Checked = MarkerSpeedParams;
    fn check(self) -> Result<Self> {
        if let Some(s) = self.smoothing {
            s.check("smoothing", false)?;
        }
        Ok(self)
    }
}

impl FeatureExtractor for MarkerSpeedParams {
    /// Speeds of image positions are px/s (trace names say `px_per_s`).
    fn accepts_2d(&self) -> bool {
        true
    }
    fn extract(&self, motion: &Motion, cache: &FeatureCache) -> Result<FeatureSet> {
        motion.require_frames(2, "marker_speed")?;
        let smoothing = self.smoothing.map(|s| s.whole_frames_at(motion.frame_rate())).unwrap_or(0);
        let s = cached_marker_speeds(motion, cache, smoothing)?;
        let names = motion.point_names();
        // mm/s on 3-D positions, px/s on 2-D image positions.
        let u = motion.length_unit();
        let mut traces =
            vec![Trace::new(format!("V_{u}_per_s"), format!("{u}/s"), s.fastest.clone())];
        if self.per_marker {
            for (k, n) in names.iter().enumerate() {
                traces.push(Trace::new(
                    format!("v_{n}_{u}_per_s"),
                    format!("{u}/s"),
                    s.marker_speed(k),
                ));
            }
        }
        let labels = vec![LabelTrace {
            name: "fastest_marker".into(),
            values: s
                .fastest_marker
                .iter()
                .map(|k| k.map(|k| names[k].clone()).unwrap_or_default())
                .collect(),
        }];
        Ok(FeatureSet { traces, labels })
    }
}

motionlab_core::register_plugin!(FeatureExtractor, MarkerSpeedParams, "marker_speed");

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_testkit::motion_from_fn;

    #[test]
    fn speed_of_uniform_motion_is_distance_times_rate() {
        // Marker 0 moves 2 mm per frame along x at 50 Hz = 100 mm/s; marker 1 is still.
        let m =
            motion_from_fn(
                5,
                50.0,
                2,
                |i, k| if k == 0 { [2.0 * i as f64, 0.0, 0.0] } else { [0.0; 3] },
            );
        let s = marker_speeds(&m, 0);
        for i in 0..4 {
            assert!((s.fastest[i] - 100.0).abs() < 1e-12);
            assert_eq!(s.fastest_marker[i], Some(0));
            assert_eq!(s.speed(i, 1), 0.0);
        }
        assert!(s.fastest[4].is_nan());
    }

    #[test]
    fn missing_samples_are_skipped_not_counted() {
        let m = motion_from_fn(3, 10.0, 2, |i, k| match (i, k) {
            (1, 0) => [f64::NAN; 3],
            (_, 0) => [100.0 * i as f64, 0.0, 0.0],
            _ => [0.0, i as f64, 0.0],
        });
        let s = marker_speeds(&m, 0);
        // Marker 0 is missing at frame 1, so only marker 1 (1 mm/frame = 10 mm/s) counts.
        assert_eq!(s.fastest[0], 10.0);
        assert_eq!(s.fastest_marker[0], Some(1));
        assert!(s.speed(0, 0).is_nan());
    }

    #[test]
    fn fastest_marker_is_the_first_of_the_fastest_and_skips_missing_ones() {
        // 9 markers (two groups of four and a remainder): marker k moves `step(i, k)` mm per
        // frame along x; ties, missing samples and the fastest in every position occur.
        let step = |i: usize, k: usize| [1.0, 3.0, 2.0, 3.0, 0.5, 3.0, 1.0, 2.5, 3.0][(k + i) % 9];
        let m = motion_from_fn(12, 1.0, 9, |i, k| {
            if (i + 2 * k) % 7 == 0 && k != 0 {
                [f64::NAN; 3]
            } else {
                [(0..i).map(|j| step(j, k)).sum::<f64>(), 0.0, 0.0]
            }
        });
        let s = marker_speeds(&m, 0);
        for i in 0..11 {
            // Sequential scan: the first valid marker with the largest speed.
            let mut want: Option<(usize, f64)> = None;
            for k in 0..9 {
                let v = s.speed(i, k);
                if !v.is_nan() && want.is_none_or(|(_, b)| v > b) {
                    want = Some((k, v));
                }
            }
            assert_eq!(s.fastest_marker[i], want.map(|w| w.0), "frame {i}");
            assert_eq!(s.fastest[i], want.unwrap().1);
        }
    }

    use crate::simd::FORCE_PORTABLE;

    #[test]
    fn simd_and_portable_speeds_are_bitwise_equal_on_a_real_take() {
        let path = motionlab_testkit::data_path("cmu86/86_01.amc.gz");
        let asf = motionlab_testkit::data_path("cmu86/86.asf");
        let m = motionlab_io::asf_amc::load_asf_amc(
            &path,
            &asf,
            motionlab_core::FrameRate::new(120.0).unwrap(),
        )
        .unwrap();
        // 38 joints: nine groups of four and a remainder of two; with a missing sample.
        let mut positions = m.positions().to_vec();
        positions[100 * 38 + 5] = [f64::NAN; 3];
        let m = Motion::new(
            m.name.clone(),
            m.frame_rate(),
            m.up_axis(),
            m.point_kind(),
            m.point_names().to_vec(),
            positions,
        )
        .unwrap();
        let fast = marker_speeds(&m, 0);
        FORCE_PORTABLE.with(|f| f.set(true));
        let slow = marker_speeds(&m, 0);
        FORCE_PORTABLE.with(|f| f.set(false));
        assert!(fast.speeds.iter().zip(&slow.speeds).all(|(a, b)| a.to_bits() == b.to_bits()));
        assert_eq!(fast.fastest_marker, slow.fastest_marker);
        assert!(fast.speeds[100 * 38 + 5].is_nan() && fast.speeds[99 * 38 + 5].is_nan());
    }
}
