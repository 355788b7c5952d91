//! Zero-phase Butterworth low-pass filtering: the preprocessor `butterworth`, as scipy's
//! `signal.butter` + `signal.filtfilt` (and MATLAB's `butter` + `filtfilt`, which the MoCap
//! Toolbox's filtering functions call).
//!
//! Written here rather than taken from a crate: `sci-rs` (the one crate that mirrors scipy's
//! Butterworth design and forward-backward filtering) filters second-order sections
//! (`sosfiltfilt`), whose padding and rounding differ from `filtfilt` of the transfer function,
//! and pulls in ndarray 0.15, an older nalgebra (0.32 beside the workspace's 0.35), lstsq,
//! kalmanfilt and rustfft; the audio biquad crates design single second-order sections from a
//! Q factor. None filters around gaps. What is needed is scipy's exact recipe — analogue
//! prototype, bilinear transform with prewarping, `lfilter_zi` initial conditions, odd
//! extension — ~100 lines here, so the numbers equal scipy's: `bench/butterworth_vs_scipy.py`
//! checks them on real data (run by CI, `.ci/run`; 1e-14 relative for orders 2 and 4).
//! Orders are limited to 8: the transfer-function form (as scipy's `filtfilt(b, a)`) loses
//! precision at high orders with low cutoffs.

use nalgebra::{Complex, DMatrix, DVector};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{Error, ErrorKind, Motion, Preprocessor, Result};

/// Zero-phase Butterworth low-pass filter of every marker coordinate (forward and backward,
/// like MATLAB/scipy `filtfilt`, the filtering of MoCap Toolbox `mcfilter`).
///
/// Design: scipy's `butter(order, cutoff_hz / (rate / 2))` — analogue Butterworth prototype,
/// cutoff prewarped (`ω = 4·tan(π·Wn/2)`), bilinear transform. Filtering: scipy's
/// `filtfilt(b, a, x)` with its defaults — the run extended at both ends by an **odd**
/// reflection of `3·(order + 1)` samples, the forward pass started in the steady state of the
/// first sample (`lfilter_zi`), the backward pass likewise from the last output, the extension
/// cut off again. Running the filter twice cancels its phase (no lag: boundaries found on the
/// filtered motion stay where they are) and squares its gain: the result is of order
/// `2·order`, −6 dB (not −3 dB) at the cutoff.
///
/// Why the defaults (`motionlab describe butterworth` lists them): marker data of human
/// movement hold little beyond 6 Hz (Winter, *Biomechanics and Motor Control of Human
/// Movement*: 6 Hz for walking markers; 6–10 Hz is the usual range, higher for fast hand
/// movement); the noise of raw positions is broadband, and it is what makes speed minima appear
/// a frame after every peak at 120 Hz. Order 2 forward and backward is the common 4th-order
/// zero-phase filter of biomechanics.
///
/// Missing samples (gap-aware): each coordinate of each marker is filtered **per contiguous
/// run of present samples**, separately — a gap is never bridged and stays missing (NaN); a
/// run of at most `3·(order + 1)` samples (too short for filtfilt's padding; scipy refuses
/// it) is left **unfiltered**, as captured. The skeleton, when the motion has one, is
/// dropped: the filtered positions no longer follow from its joint rotations.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ButterworthParams {
    /// Order of the designed filter (1–8); the forward-backward result has twice this order.
    #[serde(default = "default_order")]
    pub order: usize,
    /// Cutoff frequency in Hz (−3 dB of one pass, −6 dB of the zero-phase result); must be
    /// below half the motion's frame rate.
    #[serde(default = "default_cutoff_hz")]
    pub cutoff_hz: f64,
}

fn default_order() -> usize {
    2
}

fn default_cutoff_hz() -> f64 {
    6.0
}

/// The validated stage.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Butterworth {
    pub order: usize,
    pub cutoff_hz: f64,
}

impl ParamGuard for ButterworthParams {
    type Checked = Butterworth;
    fn check(self) -> Result<Butterworth> {
        if !(1..=8).contains(&self.order) {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                format!("must be 1 to 8, found {}", self.order),
            )
            .with_field("order"));
        }
        if !(self.cutoff_hz.is_finite() && self.cutoff_hz > 0.0) {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                format!("must be a finite frequency > 0 Hz, found {}", self.cutoff_hz),
            )
            .with_field("cutoff_hz"));
        }
        Ok(Butterworth { order: self.order, cutoff_hz: self.cutoff_hz })
    }
}

/// Transfer-function coefficients `b` (numerator) and `a` (denominator, `a[0] = 1`).
#[derive(Clone, Debug, PartialEq)]
pub struct TransferFunction {
    pub b: Vec<f64>,
    pub a: Vec<f64>,
}

/// scipy `butter(order, wn)` low-pass, `wn` the cutoff as a fraction of Nyquist (0 < wn < 1).
pub fn butter_lowpass(order: usize, wn: f64) -> TransferFunction {
    let n = order as f64;
    // Analogue prototype poles: −exp(iπm/(2N)), m = −N+1, −N+3, …, N−1 (scipy buttap).
    let warped = 4.0 * (std::f64::consts::PI * wn / 2.0).tan();
    let poles: Vec<Complex<f64>> = (0..order)
        .map(|i| {
            let m = -(n - 1.0) + 2.0 * i as f64;
            -Complex::from_polar(1.0, std::f64::consts::PI * m / (2.0 * n)) * warped
        })
        .collect();
    // Bilinear transform at fs = 2 (scipy's normalisation): p → (4 + p)/(4 − p), zeros at −1.
    let four = Complex::new(4.0, 0.0);
    let digital: Vec<Complex<f64>> = poles.iter().map(|&p| (four + p) / (four - p)).collect();
    let denominator: Complex<f64> = poles.iter().map(|&p| four - p).product();
    let gain = warped.powi(order as i32) * (Complex::new(1.0, 0.0) / denominator).re;
    let b: Vec<f64> =
        poly(&vec![Complex::new(-1.0, 0.0); order]).iter().map(|c| gain * c.re).collect();
    let a: Vec<f64> = poly(&digital).iter().map(|c| c.re).collect();
    TransferFunction { b, a }
}

/// Polynomial coefficients (highest power first) with the given roots, as numpy `poly`.
fn poly(roots: &[Complex<f64>]) -> Vec<Complex<f64>> {
    let mut c = vec![Complex::new(1.0, 0.0)];
    for &r in roots {
        let mut next = c.clone();
        next.push(Complex::new(0.0, 0.0));
        for (i, &ci) in c.iter().enumerate() {
            next[i + 1] -= r * ci;
        }
        c = next;
    }
    c
}

/// scipy `lfilter_zi`: the initial state of the step response's steady state.
fn lfilter_zi(tf: &TransferFunction) -> Vec<f64> {
    let n = tf.a.len().max(tf.b.len());
    let (a, b) = (&tf.a, &tf.b);
    // I − companion(a)ᵀ, companion's first row −a[1:] and ones below the diagonal.
    let m = DMatrix::from_fn(n - 1, n - 1, |i, j| {
        let companion_t = if j == 0 {
            -a[i + 1]
        } else if i + 1 == j {
            1.0
        } else {
            0.0
        };
        f64::from(u8::from(i == j)) - companion_t
    });
    let rhs = DVector::from_fn(n - 1, |i, _| b[i + 1] - a[i + 1] * b[0]);
    // The matrix is regular for any stable filter (all poles inside the unit circle).
    m.lu().solve(&rhs).map(|v| v.iter().copied().collect()).unwrap_or_else(|| vec![0.0; n - 1])
}

/// Direct form II transposed (scipy `lfilter`) with initial state `zi`, in place.
fn lfilter(tf: &TransferFunction, x: &mut [f64], zi: &[f64]) {
    let (b, a) = (&tf.b, &tf.a);
    let mut z = zi.to_vec();
    let k = z.len();
    for v in x.iter_mut() {
        let xin = *v;
        let y = b[0] * xin + z.first().copied().unwrap_or(0.0);
        for i in 0..k {
            let next = if i + 1 < k { z[i + 1] } else { 0.0 };
            z[i] = b[i + 1] * xin + next - a[i + 1] * y;
        }
        *v = y;
    }
}

/// scipy `filtfilt(b, a, x)` with `padtype='odd'`, `padlen = 3·max(len(a), len(b))`; None
/// when `x` is not longer than `padlen`.
pub fn filtfilt(tf: &TransferFunction, x: &[f64]) -> Option<Vec<f64>> {
    let pad = 3 * tf.a.len().max(tf.b.len());
    let n = x.len();
    if n <= pad {
        return None;
    }
    let mut ext = Vec::with_capacity(n + 2 * pad);
    ext.extend((1..=pad).rev().map(|i| 2.0 * x[0] - x[i]));
    ext.extend_from_slice(x);
    ext.extend((1..=pad).map(|i| 2.0 * x[n - 1] - x[n - 1 - i]));
    let zi = lfilter_zi(tf);
    let start: Vec<f64> = zi.iter().map(|z| z * ext[0]).collect();
    lfilter(tf, &mut ext, &start);
    ext.reverse();
    let start: Vec<f64> = zi.iter().map(|z| z * ext[0]).collect();
    lfilter(tf, &mut ext, &start);
    ext.reverse();
    Some(ext[pad..pad + n].to_vec())
}

impl Butterworth {
    /// The coefficients at a frame rate; an error naming `cutoff_hz` when it is not below
    /// Nyquist.
    pub fn design(&self, rate_hz: f64) -> Result<TransferFunction> {
        let nyquist = rate_hz / 2.0;
        if self.cutoff_hz >= nyquist {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                format!(
                    "must be below half the frame rate ({nyquist} Hz at {rate_hz} Hz), found {} Hz",
                    self.cutoff_hz
                ),
            )
            .with_field("cutoff_hz"));
        }
        Ok(butter_lowpass(self.order, self.cutoff_hz / nyquist))
    }
}

impl Preprocessor for Butterworth {
    fn apply(&self, mut motion: Motion) -> Result<Motion> {
        let tf = self.design(motion.frame_rate().hz())?;
        let (f, m) = (motion.n_frames(), motion.n_points());
        let missing: Vec<bool> = (0..f)
            .flat_map(|i| (0..m).map(move |k| (i, k)))
            .map(|(i, k)| motion.is_missing(i, k))
            .collect();
        let positions = motion.positions_mut();
        for k in 0..m {
            let mut i = 0;
            while i < f {
                if missing[i * m + k] {
                    i += 1;
                    continue;
                }
                let start = i;
                while i < f && !missing[i * m + k] {
                    i += 1;
                }
                // Short runs (None) stay as captured (documented).
                let filtered: [Option<Vec<f64>>; 3] = std::array::from_fn(|c| {
                    let series: Vec<f64> = (start..i).map(|j| positions[j * m + k][c]).collect();
                    filtfilt(&tf, &series)
                });
                for (c, y) in filtered.iter().enumerate() {
                    let Some(y) = y else { continue };
                    for (j, &v) in (start..i).zip(y) {
                        positions[j * m + k][c] = v;
                    }
                }
            }
        }
        motion.refresh_missing();
        motion.skeleton = None;
        Ok(motion)
    }
}

motionlab_core::register_plugin!(Preprocessor, ButterworthParams, "butterworth");

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_core::registry::{build_preprocessor, default_params};
    use motionlab_testkit::motion_from_fn;

    /// scipy.signal.butter(2, 0.1) and butter(4, 0.25) (scipy 1.17.1, repr).
    #[test]
    fn coefficients_equal_scipy_butter() {
        let tf = butter_lowpass(2, 0.1);
        let b = [0.020083365564211232, 0.040166731128422464, 0.020083365564211232];
        let a = [1.0, -1.5610180758007182, 0.6413515380575631];
        for (x, y) in tf.b.iter().zip(b).chain(tf.a.iter().zip(a)) {
            assert!((x - y).abs() < 1e-15, "{tf:?}");
        }
        let tf = butter_lowpass(4, 0.25);
        let b = [
            0.010209480791203138,
            0.04083792316481255,
            0.061256884747218826,
            0.04083792316481255,
            0.010209480791203138,
        ];
        let a = [
            1.0,
            -1.9684277869385185,
            1.7358607092088867,
            -0.7244708295073626,
            0.12038959989624451,
        ];
        for (x, y) in tf.b.iter().zip(b).chain(tf.a.iter().zip(a)) {
            assert!((x - y).abs() < 1e-14, "{tf:?}");
        }
    }

    #[test]
    fn unit_dc_gain_keeps_constants_and_filtfilt_equals_scipy_on_a_ramp() {
        // Σb / Σa = 1: a constant passes unchanged.
        let tf = butter_lowpass(3, 0.2);
        assert!((tf.b.iter().sum::<f64>() / tf.a.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        let constant = vec![7.5; 40];
        assert!(filtfilt(&tf, &constant).unwrap().iter().all(|v| (v - 7.5).abs() < 1e-12));
        // A ramp is not kept exactly (the start state is a constant's steady state); the ends
        // bend as scipy's do: scipy.signal.filtfilt(*butter(3, 0.2), 3 + 0.5·arange(50)).
        let line: Vec<f64> = (0..50).map(|i| 3.0 + 0.5 * i as f64).collect();
        let y = filtfilt(&tf, &line).unwrap();
        for (i, want) in [(0, 3.0004953993396835), (25, 15.49998568835868), (49, 27.47635007868804)]
        {
            assert!((y[i] - want).abs() < 1e-12 * want, "{i}: {} vs {want}", y[i]);
        }
        assert_eq!(filtfilt(&tf, &line[..12]), None, "3·(order + 1) = 12 samples are too few");
        assert!(filtfilt(&tf, &line[..13]).is_some());
    }

    #[test]
    fn a_tone_above_the_cutoff_is_removed_and_one_below_kept_without_lag() {
        // 120 Hz, cutoff 6 Hz: a 1 Hz sine passes with gain ≈ 1 and no phase shift, a 30 Hz one
        // is attenuated by |H|² ≈ (1/(1+(tan(30π/120)/tan(6π/120))^4))² for order 2.
        let stage = Butterworth { order: 2, cutoff_hz: 6.0 };
        let m = motion_from_fn(1200, 120.0, 2, |i, k| {
            let t = i as f64 / 120.0;
            let f = if k == 0 { 1.0 } else { 30.0 };
            [100.0 * (2.0 * std::f64::consts::PI * f * t).sin(), 0.0, 0.0]
        });
        let out = stage.apply(m.clone()).unwrap();
        for i in 200..1000 {
            assert!((out.position(i, 0)[0] - m.position(i, 0)[0]).abs() < 0.2, "frame {i}");
        }
        let peak = (200..1000).map(|i| out.position(i, 1)[0].abs()).fold(0.0, f64::max);
        let ratio = (std::f64::consts::PI * 30.0 / 120.0).tan()
            / (std::f64::consts::PI * 6.0 / 120.0).tan();
        let expected = 100.0 / (1.0 + ratio.powi(4));
        assert!((peak - expected).abs() < 0.02 * expected, "{peak} vs {expected}");
    }

    #[test]
    fn gaps_stay_missing_and_runs_are_filtered_separately() {
        // Marker 0: a step inside run 0..40, gap 40..45, run 45..100 at another level; marker 1
        // a run of 9 samples (too short for order 2's padding of 9) then missing.
        let m = motion_from_fn(100, 100.0, 2, |i, k| match (k, i) {
            (0, 40..45) => [f64::NAN; 3],
            (0, 0..40) => [if i < 20 { 0.0 } else { 10.0 }, 0.0, 0.0],
            (0, _) => [500.0, 0.0, 0.0],
            (_, 0..9) => [i as f64 * i as f64, 1.0, 2.0],
            _ => [f64::NAN; 3],
        });
        let out =
            build_preprocessor("butterworth", &default_params()).unwrap().apply(m.clone()).unwrap();
        assert!((40..45).all(|i| out.is_missing(i, 0)) && (9..100).all(|i| out.is_missing(i, 1)));
        // The constant run after the gap is untouched by the level before it.
        assert!((45..100).all(|i| (out.position(i, 0)[0] - 500.0).abs() < 1e-9));
        // The step is smoothed; the short run is left as captured.
        assert!(out.position(20, 0)[0] > 0.5 && out.position(20, 0)[0] < 9.5);
        assert!((0..9).all(|i| out.position(i, 1) == m.position(i, 1)));
    }

    #[test]
    fn parameters_are_checked_naming_the_field() {
        let field = |t: &str| {
            let v: toml::Value = toml::from_str(t).unwrap();
            build_preprocessor("butterworth", &v)
                .err()
                .map(|e| e.location().field.clone().unwrap_or_default())
        };
        assert_eq!(field("order = 0").as_deref(), Some("order"));
        assert_eq!(field("order = 9").as_deref(), Some("order"));
        assert_eq!(field("cutoff_hz = -1.0").as_deref(), Some("cutoff_hz"));
        assert_eq!(field("cutoff_hz = 6.0\norder = 4"), None);
        // Cutoff at or above Nyquist fails when the rate is known.
        let m = motion_from_fn(100, 10.0, 1, |_, _| [0.0; 3]);
        let e = Butterworth { order: 2, cutoff_hz: 6.0 }.apply(m).unwrap_err();
        assert_eq!(
            (e.kind(), e.location().field.as_deref()),
            (ErrorKind::OutOfRange, Some("cutoff_hz"))
        );
    }
}
