//! Optional position smoothing before differentiation (a **choice** the papers leave open;
//! off by default everywhere).

use motionlab_core::{Motion, Point3};

/// Centred moving average of each marker's trajectory over `window` frames (shrunk at the
/// ends). Missing samples are left missing and are not averaged into their neighbours.
pub fn moving_average_positions(motion: &Motion, window: usize) -> Vec<Point3> {
    let f = motion.n_frames();
    let m = motion.n_points();
    let half = window / 2;
    let src = motion.positions();
    let mut out = src.to_vec();
    for k in 0..m {
        for i in 0..f {
            if motion.is_missing(i, k) {
                continue;
            }
            let (lo, hi) = (i.saturating_sub(half), (i + half + 1).min(f));
            let mut acc = [0.0; 3];
            let mut n = 0.0;
            for j in lo..hi {
                if !motion.is_missing(j, k) {
                    let p = src[j * m + k];
                    acc = [acc[0] + p[0], acc[1] + p[1], acc[2] + p[2]];
                    n += 1.0;
                }
            }
            out[i * m + k] = [acc[0] / n, acc[1] / n, acc[2] / n];
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_testkit::motion_from_fn;

    #[test]
    fn moving_average_keeps_a_line_and_skips_gaps() {
        let m =
            motion_from_fn(
                5,
                10.0,
                1,
                |i, _| if i == 2 { [f64::NAN; 3] } else { [i as f64, 0.0, 0.0] },
            );
        let s = moving_average_positions(&m, 3);
        assert_eq!(s[0][0], 0.5); // (0 + 1) / 2 at the edge
        assert_eq!(s[1][0], 0.5); // frame 2 is missing: (0 + 1) / 2
        assert!(s[2][0].is_nan());
        assert_eq!(s[3][0], 3.5);
    }
}
