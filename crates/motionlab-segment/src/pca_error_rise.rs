//! Baseline change-point detector: the PCA reconstruction-error rise of Barbič et al.,
//! "Segmenting Motion Capture Data into Distinct Behaviors", Graphics Interface 2004 — the
//! method Sonoda et al. cite as [4] and set aside as costly. It exists to show that a published
//! segmenter is one file here.

use nalgebra::{DMatrix, DVector};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{
    Error, ErrorKind, FeatureCache, Motion, Result, Segmenter, SegmenterOutput, TimeSpan, Trace,
};

/// Frame vectors: every point's position minus the frame's centroid (translation removed),
/// `3M` values per frame; None for frames with any missing sample.
fn centred_frames(motion: &Motion) -> Vec<Option<Vec<f64>>> {
    (0..motion.n_frames())
        .map(|i| {
            if motion.frame_missing(i).iter().any(|m| *m) {
                return None;
            }
            let f = motion.frame(i);
            let n = f.len() as f64;
            let c = [0, 1, 2].map(|k| f.iter().map(|p| p[k]).sum::<f64>() / n);
            Some(f.iter().flat_map(|p| [p[0] - c[0], p[1] - c[1], p[2] - c[2]]).collect())
        })
        .collect()
}

/// Running first and second moments of the frames of the current segment.
struct Moments {
    n: f64,
    sum: DVector<f64>,
    outer: DMatrix<f64>,
}

impl Moments {
    fn new(d: usize) -> Self {
        Moments { n: 0.0, sum: DVector::zeros(d), outer: DMatrix::zeros(d, d) }
    }
    fn add(&mut self, x: &[f64]) {
        let x = DVector::from_column_slice(x);
        self.n += 1.0;
        self.sum += &x;
        self.outer.syger(1.0, &x, &x, 1.0);
    }
    /// Eigenvalues of the scatter matrix Σ (x − x̄)(x − x̄)ᵀ, largest first.
    fn scatter_eigenvalues(&self) -> Vec<f64> {
        if self.n < 1.0 {
            return Vec::new();
        }
        let mean = &self.sum / self.n;
        let mut s = self.outer.clone();
        s.syger(-self.n, &mean, &mean, 1.0);
        // syger fills the lower triangle only; symmetric_eigenvalues reads the lower triangle.
        let mut ev: Vec<f64> = s.symmetric_eigenvalues().iter().map(|v| v.max(0.0)).collect();
        ev.sort_by(|a, b| b.total_cmp(a));
        ev
    }
}

/// Settings of [`pca_error_rise`], in frames.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PcaErrorRiseFrames {
    pub initial: usize,
    pub lag: usize,
    pub step: usize,
    pub variance_kept: f64,
    pub k_sigma: f64,
}

/// Cut frames, and the reconstruction error `e` (mm², NaN where not evaluated) per frame.
pub fn pca_error_rise(motion: &Motion, p: PcaErrorRiseFrames) -> (Vec<usize>, Vec<f64>) {
    let frames = centred_frames(motion);
    let n = frames.len();
    let d = 3 * motion.n_points();
    let mut error = vec![f64::NAN; n];
    let mut cuts = Vec::new();
    let mut start = 0;
    'segments: while start + p.initial + p.lag < n {
        // r: fewest principal components keeping `variance_kept` of the first window's variance.
        let mut m = Moments::new(d);
        for x in frames[start..start + p.initial].iter().flatten() {
            m.add(x);
        }
        let ev = m.scatter_eigenvalues();
        let total: f64 = ev.iter().sum();
        let mut r = 0;
        let mut kept = 0.0;
        while r < ev.len() && kept < p.variance_kept * total {
            kept += ev[r];
            r += 1;
        }
        // e_i = Σ_{j > r} λ_j over frames start..=i: the squared error of projecting them onto
        // their own r-dimensional principal subspace. Evaluated every `step` frames.
        let mut e_at: Vec<(usize, f64)> = Vec::new();
        let mut rises: Vec<f64> = Vec::new();
        let mut next = start + p.initial;
        for i in start + p.initial..n {
            if let Some(x) = &frames[i] {
                m.add(x);
            }
            if i != next {
                continue;
            }
            next += p.step;
            let ev = m.scatter_eigenvalues();
            // Scaled to the frames spanned, so frames left out (missing samples) do not slow the
            // error's growth and fake a rise when they end.
            let spanned = (i + 1 - start) as f64;
            let e: f64 =
                if m.n > 0.0 { ev.iter().skip(r).sum::<f64>() * spanned / m.n } else { 0.0 };
            error[i] = e;
            e_at.push((i, e));
            // d_i = e_i − e_{i−ℓ}; a cut when it exceeds the mean of the earlier d by k_σ s.d.
            let back = p.lag / p.step;
            if e_at.len() > back {
                let rise = e - e_at[e_at.len() - 1 - back].1;
                // Mean and s.d. need a lag's worth of earlier rises to mean anything.
                if rises.len() >= back.max(2) {
                    let mean = rises.iter().sum::<f64>() / rises.len() as f64;
                    let var =
                        rises.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / rises.len() as f64;
                    if rise > mean + p.k_sigma * var.sqrt() {
                        cuts.push(i);
                        start = i;
                        continue 'segments;
                    }
                }
                rises.push(rise);
            }
        }
        break;
    }
    (cuts, error)
}

/// Baseline change-point detector: PCA reconstruction-error rise (Barbič, Safonova, Pan,
/// Faloutsos, Hodgins, Pollard, "Segmenting Motion Capture Data into Distinct Behaviors",
/// Graphics Interface 2004, §4.1 "PCA approach"; cited by Sonoda et al. as [4]).
///
/// A simple motion's frames lie close to a low-dimensional subspace. Starting a segment at
/// frame s, the number of components `r` is the fewest that keep `variance_kept` of the variance
/// of the first `initial` frames. For each later frame i, `e_i` = squared error (mm²) of
/// projecting frames s..=i onto their own r-dimensional principal subspace (the sum of the
/// scatter matrix's eigenvalues beyond the r largest); `d_i = e_i − e_{i−lag}`. A cut is declared
/// at the first i where `d_i > mean(d) + k_sigma · sd(d)` over the earlier d of the segment (at
/// least a lag's worth of them), and a new segment starts there.
///
/// Frame vectors are every marker's position minus the frame's centroid (Barbič et al. used
/// joint-angle quaternions; positions work for marker and skeleton data alike). Cost is one
/// eigen-decomposition of a 3M × 3M matrix per evaluated frame, hence `step`.
///
/// Outputs trace `pca_error_mm2` (NaN where not evaluated). Missing samples: frames with any
/// missing sample are left out of the moments, and `e_i` is scaled by (frames spanned) / (frames
/// used) so a stretch with gaps does not make the error grow more slowly and fake a rise where
/// it ends; gap-fill first to use those frames.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PcaErrorRiseParams {
    /// Frames used to choose r at the start of each segment (the default is Barbič et al.'s
    /// 240 frames at 120 fps).
    #[serde(default = "default_initial")]
    pub initial: TimeSpan,
    /// The lag ℓ of the error derivative `d_i = e_i − e_{i−ℓ}`.
    #[serde(default = "default_lag")]
    pub lag: TimeSpan,
    /// Evaluate e every this many frames (rounded; 1 = every frame as in the paper, slowest).
    #[serde(default = "default_step")]
    pub step: TimeSpan,
    /// Fraction of the variance the r components keep (Barbič et al.'s τ).
    #[serde(default = "default_variance_kept")]
    pub variance_kept: f64,
    /// Cut when the derivative exceeds its running mean by this many standard deviations
    /// (Barbič et al.'s k_σ).
    #[serde(default = "default_k_sigma")]
    pub k_sigma: f64,
}

fn default_initial() -> TimeSpan {
    TimeSpan::Seconds(2.0)
}
fn default_lag() -> TimeSpan {
    TimeSpan::Seconds(0.5)
}
fn default_step() -> TimeSpan {
    TimeSpan::Seconds(0.05)
}
fn default_variance_kept() -> f64 {
    0.9
}
fn default_k_sigma() -> f64 {
    3.0
}

/// The validated stage.
#[derive(Clone, Debug)]
pub struct PcaErrorRise {
    initial: TimeSpan,
    lag: TimeSpan,
    step: TimeSpan,
    variance_kept: f64,
    k_sigma: f64,
}

impl ParamGuard for PcaErrorRiseParams {
    type Checked = PcaErrorRise;
    fn check(self) -> Result<PcaErrorRise> {
        if !(self.variance_kept > 0.0 && self.variance_kept <= 1.0) {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                format!("must be in (0, 1], found {}", self.variance_kept),
            )
            .with_field("variance_kept"));
        }
        if !(self.k_sigma.is_finite() && self.k_sigma >= 0.0) {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                format!("must be finite and >= 0, found {}", self.k_sigma),
            )
            .with_field("k_sigma"));
        }
        Ok(PcaErrorRise {
            initial: self.initial.check("initial", true)?,
            lag: self.lag.check("lag", true)?,
            step: self.step.check("step", true)?,
            variance_kept: self.variance_kept,
            k_sigma: self.k_sigma,
        })
    }
}

impl PcaErrorRise {
    fn frames(&self, motion: &Motion) -> PcaErrorRiseFrames {
        let rate = motion.frame_rate();
        let step = self.step.whole_frames_at(rate).max(1);
        // The lag is a whole number of steps so e_{i−ℓ} was evaluated.
        let lag = self.lag.whole_frames_at(rate).max(1).div_ceil(step) * step;
        PcaErrorRiseFrames {
            initial: self.initial.whole_frames_at(rate).max(2),
            lag,
            step,
            variance_kept: self.variance_kept,
            k_sigma: self.k_sigma,
        }
    }
}

impl Segmenter for PcaErrorRise {
    /// PCA of image positions is as defined as of world positions (the error is then px²).
    fn accepts_2d(&self) -> bool {
        true
    }
    fn segment(&self, motion: &Motion, _cache: &FeatureCache) -> Result<SegmenterOutput> {
        let p = self.frames(motion);
        motion.require_frames(p.initial + p.lag + 1, "pca_error_rise")?;
        let (candidates, error) = pca_error_rise(motion, p);
        Ok(SegmenterOutput {
            candidates,
            traces: vec![Trace::new(
                format!("pca_error_{}2", motion.length_unit()),
                format!("{}²", motion.length_unit()),
                error,
            )],
            thresholds: Vec::new(),
            flagged_frames: Vec::new(),
            penalty_path: Vec::new(),
        })
    }
}

motionlab_core::register_plugin!(Segmenter, PcaErrorRiseParams, "pca_error_rise");

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_core::registry::build_segmenter;
    use motionlab_testkit::{Rng, motion_from_fn};

    /// Six markers: frames 0..300 one rigid oscillation along x (a 1-D motion), frames 300..600 a
    /// different one along y and z (new directions the first subspace cannot represent).
    fn two_behaviours() -> Motion {
        let mut rng = Rng::new(9);
        let offsets: Vec<[f64; 3]> = (0..6)
            .map(|_| [rng.normal() * 200.0, rng.normal() * 200.0, rng.normal() * 200.0])
            .collect();
        let noise: Vec<f64> = (0..600 * 6 * 3).map(|_| rng.normal() * 0.5).collect();
        motion_from_fn(600, 100.0, 6, |i, k| {
            let t = i as f64 / 100.0;
            let o = offsets[k];
            let (dx, dy, dz) = if i < 300 {
                (if k % 2 == 0 { 80.0 } else { -80.0 } * (3.0 * t).sin(), 0.0, 0.0)
            } else {
                (
                    0.0,
                    90.0 * (2.0 * t).sin() * (k as f64 - 2.5),
                    70.0 * (5.0 * t).cos() * if k < 3 { 1.0 } else { -1.0 },
                )
            };
            let n = &noise[(i * 6 + k) * 3..];
            [o[0] + dx + n[0], o[1] + dy + n[1], o[2] + dz + n[2]]
        })
    }

    #[test]
    fn detects_the_change_of_behaviour_and_nothing_before_it() {
        let m = two_behaviours();
        let seg =
            build_segmenter("pca_error_rise", &toml::Value::Table(Default::default())).unwrap();
        let out = seg.segment(&m, &FeatureCache::new()).unwrap();
        let first = *out.candidates.first().expect("a cut");
        // The change is at 300; the error derivative over a 0.5 s lag rises within it.
        assert!((300..=330).contains(&first), "{:?}", out.candidates);
        // Before the change the motion is one behaviour: the error stays at the noise level.
        let e = &out.traces[0].values;
        let before = e[200..300].iter().copied().filter(|v| v.is_finite()).fold(0.0, f64::max);
        assert!(before < 300.0 * 6.0 * 3.0 * 0.5f64.powi(2) * 2.0, "noise-level error {before}");
    }

    #[test]
    fn eigenvalue_sum_equals_an_independent_projection_error() {
        // Σ_{j>r} λ_j of the scatter matrix = Σ_frames |x − x̄ − P(x − x̄)|² computed from an SVD.
        let m = two_behaviours();
        let frames: Vec<Vec<f64>> = centred_frames(&m).into_iter().take(350).flatten().collect();
        let mut mo = Moments::new(18);
        for x in &frames {
            mo.add(x);
        }
        let ev = mo.scatter_eigenvalues();
        let r = 2;
        let e_eig: f64 = ev.iter().skip(r).sum();
        let mean = frames.iter().fold(vec![0.0; 18], |a, x| {
            a.iter().zip(x).map(|(a, b)| a + b / frames.len() as f64).collect()
        });
        let x = DMatrix::from_fn(frames.len(), 18, |i, j| frames[i][j] - mean[j]);
        let svd = x.clone().svd(false, true);
        let mut order: Vec<usize> = (0..svd.singular_values.len()).collect();
        order.sort_by(|&a, &b| svd.singular_values[b].total_cmp(&svd.singular_values[a]));
        let vt = svd.v_t.unwrap();
        let basis = DMatrix::from_fn(18, r, |i, j| vt[(order[j], i)]);
        let resid = &x - &x * &basis * basis.transpose();
        let e_svd = resid.norm_squared();
        assert!((e_eig - e_svd).abs() <= 1e-9 * e_svd, "{e_eig} vs {e_svd}");
    }

    #[test]
    fn missing_frames_are_left_out_and_parameters_checked() {
        let m = two_behaviours();
        let mut pos = m.positions().to_vec();
        // Marker 2 missing at every 7th frame throughout (as occlusions scatter in real takes).
        for f in (3..600).step_by(7) {
            pos[f * 6 + 2] = [f64::NAN; 3];
        }
        let gappy = motion_from_fn(600, 100.0, 6, |i, k| pos[i * 6 + k]);
        let seg =
            build_segmenter("pca_error_rise", &toml::Value::Table(Default::default())).unwrap();
        let out = seg.segment(&gappy, &FeatureCache::new()).unwrap();
        assert!(
            (300..=330).contains(out.candidates.first().expect("a cut")),
            "{:?}",
            out.candidates
        );
        for (text, field) in [
            ("variance_kept = 1.5", "variance_kept"),
            ("k_sigma = -1.0", "k_sigma"),
            ("step = { frames = 0 }", "step"),
        ] {
            let v: toml::Value = toml::from_str(text).unwrap();
            assert_eq!(
                build_segmenter("pca_error_rise", &v).err().unwrap().location().field.as_deref(),
                Some(field)
            );
        }
    }

    #[test]
    fn real_cmu_86_01_cuts_near_every_labelled_boundary() {
        // 86_01: walk, jump, walk, punch, walk, kick, punch. Every labelled boundary has a cut
        // within 2 s, and there are not many more cuts than boundaries.
        let m = crate::test_data::load("cmu86/86_01.amc.gz");
        // A coarse step keeps this debug-build test short (one eigen-decomposition per step).
        let p: toml::Value = toml::from_str("step = { seconds = 0.25 }").unwrap();
        let out = build_segmenter("pca_error_rise", &p)
            .unwrap()
            .segment(&m, &FeatureCache::new())
            .unwrap();
        let truth = crate::test_data::cmu86_01_boundaries();
        assert_eq!(truth, vec![549, 1149, 1979, 2499, 3199, 4064]);
        for b in &truth {
            assert!(
                out.candidates.iter().any(|c| c.abs_diff(*b) <= 240),
                "boundary {b}: cuts {:?}",
                out.candidates
            );
        }
        assert!(out.candidates.len() <= 2 * truth.len(), "{:?}", out.candidates);
    }

    #[test]
    fn real_steady_walk_with_missing_samples_is_one_behaviour() {
        // walk1 (27 missing samples, left out): one steady walk, so no cut.
        let m = crate::test_data::walk1();
        let out = build_segmenter("pca_error_rise", &toml::Value::Table(Default::default()))
            .unwrap()
            .segment(&m, &FeatureCache::new())
            .unwrap();
        assert!(out.candidates.is_empty(), "{:?}", out.candidates);
        assert!(out.traces[0].values.iter().filter(|v| v.is_finite()).count() > 20);
    }
}
