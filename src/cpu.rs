//! The processor's vector width, chosen at run time for the kernels whose
//! loops run over arrays: the sweep's forward kinematics (four poses in
//! lock-step), the operator's sums over the rows and the datasheet kernels
//! (arrays of poses). [`wide`]
//! runs a closure compiled for AVX2 (four doubles a register) when the
//! processor has it, and for the baseline x86-64 (SSE2, two) otherwise.
//! Only AVX2 is enabled, not FMA: a multiply and an add stay two roundings,
//! each lane does what the baseline does in the same order, and the results
//! are the same bits on every x86-64 processor (tested: the tests run the
//! kernels both ways and compare the bits).

/// Does this processor run the AVX2 copies?
#[inline]
pub fn has_avx2() -> bool {
    #[cfg(test)]
    if BASELINE.with(|b| b.get()) {
        return false;
    }
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// `f()`, compiled for AVX2 when the processor has it. The closure should
/// be `#[inline(always)]`, and so should every function it calls whose
/// loops are to be compiled into the AVX2 copy.
#[inline(always)]
pub fn wide<R>(f: impl FnOnce() -> R) -> R {
    #[cfg(target_arch = "x86_64")]
    if has_avx2() {
        // SAFETY: the processor has AVX2, checked just above.
        return unsafe { avx2(f) };
    }
    f()
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn avx2<R>(f: impl FnOnce() -> R) -> R {
    f()
}

#[cfg(test)]
thread_local! {
    static BASELINE: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// `f()` with every kernel on its baseline copy (on this thread), for the
/// tests that hold the AVX2 copies to the baseline's bits.
#[cfg(test)]
pub fn baseline<R>(f: impl FnOnce() -> R) -> R {
    BASELINE.with(|b| b.set(true));
    let r = f();
    BASELINE.with(|b| b.set(false));
    r
}
