//! faer's dense kernels (through `pulp` and `gemm`) run in AVX and AVX-512
//! registers and can return with the registers' upper halves dirty. The
//! rest of uvpin is compiled for baseline x86-64, whose SSE-encoded vector
//! instructions then pay a transition penalty on Intel cores until the
//! upper halves are cleared (docs/decisions.md). [`after_faer`] clears
//! them; every call into faer is followed by it.

/// Clears the upper halves of the vector registers (`vzeroupper`) where the
/// CPU has AVX; nothing elsewhere.
#[inline]
pub fn after_faer() {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx") {
        // SAFETY: the CPU supports AVX (checked just above).
        unsafe { zero_upper() }
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn zero_upper() {
    std::arch::x86_64::_mm256_zeroupper();
}
