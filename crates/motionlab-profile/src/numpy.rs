//! The few NumPy numerics the peers' results depend on, reproduced bit for bit: pairwise
//! summation (`np.sum`, `np.mean`, `np.std` of a contiguous float array) and the legacy
//! `RandomState` Mersenne Twister (`np.random.seed(s)`, `randint`/`choice` with replacement),
//! from which claspy draws its ensemble's temporal constraints.

/// `np.add.reduce` of a contiguous float64 array: NumPy's pairwise summation (blocks of 128,
/// eight accumulators, halves rounded down to a multiple of 8).
pub(crate) fn pairwise_sum(a: &[f64]) -> f64 {
    let n = a.len();
    if n < 8 {
        let mut res = 0.0;
        for &v in a {
            res += v;
        }
        res
    } else if n <= 128 {
        let mut r = [0.0f64; 8];
        r.copy_from_slice(&a[..8]);
        let mut i = 8;
        while i < n - (n % 8) {
            for j in 0..8 {
                r[j] += a[i + j];
            }
            i += 8;
        }
        let mut res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
        while i < n {
            res += a[i];
            i += 1;
        }
        res
    } else {
        let mut n2 = n / 2;
        n2 -= n2 % 8;
        pairwise_sum(&a[..n2]) + pairwise_sum(&a[n2..])
    }
}

/// `np.mean` of a contiguous float64 array.
pub(crate) fn mean(a: &[f64]) -> f64 {
    (0.0 + pairwise_sum(a)) / a.len() as f64
}

/// `np.std` (ddof 0) of a contiguous float64 array: the mean, then the pairwise sum of the
/// squared deviations.
pub(crate) fn std(a: &[f64]) -> f64 {
    let m = mean(a);
    let sq: Vec<f64> = a.iter().map(|&v| (v - m) * (v - m)).collect();
    ((0.0 + pairwise_sum(&sq)) / a.len() as f64).sqrt()
}

const STATE_LEN: usize = 624;

/// NumPy's legacy `RandomState` (MT19937 seeded by `init_genrand`).
pub(crate) struct LegacyRandomState {
    key: [u32; STATE_LEN],
    pos: usize,
}

impl LegacyRandomState {
    /// `np.random.seed(seed)` for an integer seed.
    pub fn new(seed: u32) -> Self {
        let mut key = [0u32; STATE_LEN];
        let mut s = seed;
        for (pos, k) in key.iter_mut().enumerate() {
            *k = s;
            s = 1_812_433_253u32.wrapping_mul(s ^ (s >> 30)).wrapping_add(pos as u32 + 1);
        }
        LegacyRandomState { key, pos: STATE_LEN }
    }

    fn generate(&mut self) {
        const N: usize = STATE_LEN;
        const M: usize = 397;
        const UPPER: u32 = 0x8000_0000;
        const LOWER: u32 = 0x7fff_ffff;
        const MATRIX_A: u32 = 0x9908_b0df;
        let mag = |y: u32| if y & 1 == 1 { MATRIX_A } else { 0 };
        for i in 0..N {
            let y = (self.key[i] & UPPER) | (self.key[(i + 1) % N] & LOWER);
            self.key[i] = self.key[(i + M) % N] ^ (y >> 1) ^ mag(y);
        }
        self.pos = 0;
    }

    /// One 32-bit output (`mt19937_next32`).
    pub fn next_u32(&mut self) -> u32 {
        if self.pos == STATE_LEN {
            self.generate();
        }
        let mut y = self.key[self.pos];
        self.pos += 1;
        y ^= y >> 11;
        y ^= (y << 7) & 0x9d2c_5680;
        y ^= (y << 15) & 0xefc6_0000;
        y ^ (y >> 18)
    }

    /// `randint(0, high)` (and `choice(high, replace=True)`): legacy masked rejection sampling
    /// on 32-bit outputs, for `1 <= high <= 2^32`.
    pub fn randint(&mut self, high: u64) -> u64 {
        let rng = high - 1;
        if rng == 0 {
            return 0;
        }
        if rng == 0xffff_ffff {
            return self.next_u32() as u64;
        }
        let mut mask = rng;
        mask |= mask >> 1;
        mask |= mask >> 2;
        mask |= mask >> 4;
        mask |= mask >> 8;
        mask |= mask >> 16;
        loop {
            let v = (self.next_u32() as u64) & mask;
            if v <= rng {
                return v;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pairwise_sum_matches_numpys_blocking() {
        // Values whose sum depends on the order: 1e16 absorbs a lone 1.0 but not a pair.
        let mut a = vec![1.0; 300];
        a[0] = 1e16;
        // NumPy 2.2: np.sum(a) - 1e16 == 290.0 (ones accumulate inside blocks before meeting 1e16).
        assert_eq!(pairwise_sum(&a) - 1e16, 290.0);
        let naive: f64 = a.iter().sum();
        assert_ne!(naive, pairwise_sum(&a));
        assert_eq!(pairwise_sum(&[1.0, 2.0, 3.0]), 6.0);
    }

    #[test]
    fn legacy_mersenne_twister_matches_numpy() {
        // np.random.seed(2357); np.random.choice(100, 2, replace=True)
        let mut r = LegacyRandomState::new(2357);
        assert_eq!([r.randint(100), r.randint(100)], NUMPY_SEED_2357);
        // np.random.seed(0); np.random.randint(0, 10**6, size=3)
        let mut r = LegacyRandomState::new(0);
        assert_eq!(
            [r.randint(1_000_000), r.randint(1_000_000), r.randint(1_000_000)],
            NUMPY_SEED_0
        );
    }

    // Printed by NumPy 2.2.6 (bench/.venv-profile) for the calls named above.
    const NUMPY_SEED_2357: [u64; 2] = [47, 35];
    const NUMPY_SEED_0: [u64; 3] = [985_772, 305_711, 435_829];
}
