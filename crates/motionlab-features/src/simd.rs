//! Run-time choice between the AVX2 + FMA kernels (hull certification, marker speeds) and their
//! portable loops, which give the same decisions and values.

#[cfg(test)]
thread_local! {
    /// Set by a test: this thread takes the portable paths even on an AVX2 CPU.
    pub(crate) static FORCE_PORTABLE: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// May the AVX2 + FMA kernels run? True when the CPU has both (detected at run time, cached by
/// the standard library); tests can force the portable code on their thread.
#[inline]
pub(crate) fn available() -> bool {
    #[cfg(test)]
    if FORCE_PORTABLE.with(|f| f.get()) {
        return false;
    }
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}
