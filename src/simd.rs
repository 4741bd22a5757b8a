//! Runtime dispatch to the widest vector extension the CPU has, for the kernels that
//! vectorise over nodes or fibres (the web generators, the rod's drag). The crate is built
//! for baseline x86-64; a kernel compiled again under `#[target_feature]` gets AVX2 or
//! AVX-512 registers, and [`widest_isa`] picks the copy this CPU can run.

/// Evaluates the expression compiled for the widest vector extension this CPU has: the
/// `avx512` one with AVX-512F, the `avx2` one with AVX2 and FMA, else the `generic` one.
/// The three are the same code under `#[target_feature]` (the same IEEE operations: Rust
/// contracts nothing to FMA, and a written-out `mul_add` is one correctly rounded
/// operation everywhere, a libm call in the generic code), so the choice changes the
/// speed, never the bits. The `avx*` expressions call `unsafe`
/// target-feature functions; the detection just before makes them sound.
macro_rules! widest_isa {
    (generic: $generic:expr, avx2: $avx2:expr, avx512: $avx512:expr $(,)?) => {{
        #[cfg(target_arch = "x86_64")]
        let value = if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU supports AVX-512F (checked just above).
            #[allow(unused_unsafe)]
            unsafe {
                $avx512
            }
        } else if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
            // SAFETY: the CPU supports AVX2 and FMA (checked just above).
            #[allow(unused_unsafe)]
            unsafe {
                $avx2
            }
        } else {
            $generic
        };
        #[cfg(not(target_arch = "x86_64"))]
        let value = $generic;
        value
    }};
}
pub(crate) use widest_isa;
