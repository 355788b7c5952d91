//! Run-time choice of the instruction set for the multistream kernels ([`crate::lanes`]): one
//! detection for the crate, and a test switch that forces a lower level on the test's thread.
//!
//! Every level computes the same IEEE operations in the same order (no fused multiply-add, an
//! exactly rounded square root), so the results are bit-for-bit equal; only the speed differs.

/// An instruction set the kernels are compiled for, from the most portable up.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Level {
    /// Plain Rust on the baseline target (SSE2 on x86-64): runs everywhere.
    Portable,
    /// The portable code compiled with AVX2 enabled (two 256-bit registers per eight lanes).
    Avx2,
    /// AVX-512F intrinsics: one 512-bit register per eight lanes, and a square root from
    /// `vrsqrt14pd` refined to the exactly rounded value (checked per lane, see `lanes`).
    Avx512,
}

#[cfg(test)]
thread_local! {
    /// Set by a test: this thread uses at most this level even when the CPU offers more.
    pub(crate) static CAP: std::cell::Cell<Level> = const { std::cell::Cell::new(Level::Avx512) };
}

/// The best level this CPU runs (detected at run time, cached by the standard library),
/// capped by a test's switch.
#[inline]
pub fn level() -> Level {
    let detected = detected();
    #[cfg(test)]
    {
        detected.min(CAP.with(|c| c.get()))
    }
    #[cfg(not(test))]
    {
        detected
    }
}

fn detected() -> Level {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            return Level::Avx512;
        }
        if std::arch::is_x86_feature_detected!("avx2") {
            return Level::Avx2;
        }
    }
    Level::Portable
}

/// Runs `f` with the kernels capped at `cap` on this thread (tests only).
#[cfg(test)]
pub(crate) fn with_cap<T>(cap: Level, f: impl FnOnce() -> T) -> T {
    let before = CAP.with(|c| c.replace(cap));
    let out = f();
    CAP.with(|c| c.set(before));
    out
}

/// The levels this CPU can run, most portable first (tests only).
#[cfg(test)]
pub(crate) fn available() -> Vec<Level> {
    [Level::Portable, Level::Avx2, Level::Avx512].into_iter().filter(|&l| l <= detected()).collect()
}
