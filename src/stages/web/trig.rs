//! Fast sine and cosine for the fibre integration (eq 13 needs cos θ, sin θ at
//! every node: 1.5e8 of them for a paper-size web).
//!
//! Cody-Waite reduction by π/2 (three-part constant, exact for |q| < 2²⁰) and the
//! fdlibm kernel polynomials on [−π/4, π/4]: error below 2e-16 absolute for
//! |x| ≤ 8e5 rad, falling back to `f64::sin_cos` beyond. Deterministic (no FMA
//! contraction in Rust), so results are identical on every run and thread count.

#![allow(clippy::excessive_precision)] // fdlibm's constants, digit for digit

const TWO_OVER_PI: f64 = std::f64::consts::FRAC_2_PI;
const PIO2_1: f64 = 1.570_796_326_734_125_614_17e+00; // first 33 bits of π/2
const PIO2_2: f64 = 6.077_100_506_303_965_976_60e-11; // next 33 bits
const PIO2_3: f64 = 2.022_266_248_711_166_455_80e-21; // π/2 − PIO2_1 − PIO2_2

const S1: f64 = -1.666_666_666_666_663_243_48e-01;
const S2: f64 = 8.333_333_333_322_489_461_24e-03;
const S3: f64 = -1.984_126_982_985_794_931_34e-04;
const S4: f64 = 2.755_731_370_707_006_767_89e-06;
const S5: f64 = -2.505_076_025_340_686_341_95e-08;
const S6: f64 = 1.589_690_995_211_550_102_21e-10;
const C1: f64 = 4.166_666_666_666_660_190_37e-02;
const C2: f64 = -1.388_888_888_887_410_957_49e-03;
const C3: f64 = 2.480_158_728_947_672_941_78e-05;
const C4: f64 = -2.755_731_435_139_066_330_35e-07;
const C5: f64 = 2.087_572_321_298_174_827_90e-09;
const C6: f64 = -1.135_964_755_778_819_482_65e-11;

/// Largest |x| the fast kernel accepts (|q| < 2²⁰ keeps q·PIO2_1 exact).
pub const FAST_LIMIT: f64 = 8.0e5;
/// 1.5·2⁵²: adding it rounds to an integer held in the low mantissa bits.
const MAGIC: f64 = 6_755_399_441_055_744.0;

/// Branch-free kernel for |x| ≤ [`FAST_LIMIT`] (vectorisable in loops).
#[inline(always)]
pub(crate) fn kernel(x: f64) -> (f64, f64) {
    let t = x * TWO_OVER_PI + MAGIC;
    let bits = t.to_bits(); // low bits hold q mod 4 (two's complement for q < 0)
    let q = t - MAGIC;
    let r = ((x - q * PIO2_1) - q * PIO2_2) - q * PIO2_3;
    let z = r * r;
    let s = r + r * z * (S1 + z * (S2 + z * (S3 + z * (S4 + z * (S5 + z * S6)))));
    let c = 1.0 - 0.5 * z + z * z * (C1 + z * (C2 + z * (C3 + z * (C4 + z * (C5 + z * C6)))));
    // Quadrant q: (sin, cos) = (s, c), (c, −s), (−s, −c), (−c, s).
    let swap = (bits & 1).wrapping_neg();
    let (sb, cb) = (s.to_bits(), c.to_bits());
    let sin_bits = (sb & !swap) | (cb & swap);
    let cos_bits = (cb & !swap) | (sb & swap);
    let sin_sign = (bits & 2) << 62;
    let cos_sign = (bits.wrapping_add(1) & 2) << 62;
    (f64::from_bits(sin_bits ^ sin_sign), f64::from_bits(cos_bits ^ cos_sign))
}

/// (sin x, cos x) for |x| ≤ π/4: the kernel's polynomials without its range reduction,
/// evaluated in fused multiply-adds (within 1 ulp of `f64::sin_cos`, tested; not the
/// kernel's bits). For the rotation of a tangent by a small angle increment; not for
/// |x| > π/4. Fast only where FMA is an instruction (see [`widest_isa`]).
#[inline(always)]
pub(crate) fn small_sin_cos(x: f64) -> (f64, f64) {
    // Estrin's scheme: three short chains instead of Horner's one long one (the SDE's
    // step waits on this polynomial).
    let z = x * x;
    let z2 = z * z;
    let s = z2.mul_add(z2.mul_add(z.mul_add(S6, S5), z.mul_add(S4, S3)), z.mul_add(S2, S1));
    let c = z2.mul_add(z2.mul_add(z.mul_add(C6, C5), z.mul_add(C4, C3)), z.mul_add(C2, C1));
    ((x * z).mul_add(s, x), z2.mul_add(c, (-0.5f64).mul_add(z, 1.0)))
}

/// Largest |x| for [`tiny_sin_cos`].
pub(crate) const TINY_ANGLE: f64 = 0.125;

/// (sin x, cos x) for |x| ≤ [`TINY_ANGLE`]: Taylor polynomials to x⁹ and x¹⁰ in fused
/// multiply-adds (the first terms left out are below 2e-18 relative there; within 1 ulp
/// of `f64::sin_cos`, tested). Half the work of [`small_sin_cos`].
#[inline(always)]
pub(crate) fn tiny_sin_cos(x: f64) -> (f64, f64) {
    let z = x * x;
    let z2 = z * z;
    let s = z2.mul_add(z.mul_add(1.0 / 362_880.0, -1.0 / 5040.0), z.mul_add(1.0 / 120.0, -1.0 / 6.0));
    let c = z2.mul_add(z.mul_add(-1.0 / 3_628_800.0, 1.0 / 40_320.0), z.mul_add(-1.0 / 720.0, 1.0 / 24.0));
    ((x * z).mul_add(s, x), z2.mul_add(c, (-0.5f64).mul_add(z, 1.0)))
}

/// (sin x, cos x).
#[inline]
pub fn sin_cos(x: f64) -> (f64, f64) {
    if x.abs() <= FAST_LIMIT {
        kernel(x)
    } else {
        x.sin_cos()
    }
}

/// True where [`sin_cos`] leaves the kernel for `f64::sin_cos`: |x| > [`FAST_LIMIT`] or NaN.
#[inline(always)]
#[allow(clippy::neg_cmp_op_on_partial_ord)] // NaN must count as beyond
pub(crate) fn beyond_fast_range(x: f64) -> bool {
    !(x.abs() <= FAST_LIMIT)
}

pub(crate) use crate::simd::widest_isa;

/// sin and cos of every angle (the slices must have equal lengths). Uses AVX-512F or
/// AVX2 when the CPU has it: the same IEEE operations on wider registers (no FMA), so
/// the results are bit-identical to the SSE2 path and to [`sin_cos`].
pub fn sin_cos_slices(angles: &[f64], sin: &mut [f64], cos: &mut [f64]) {
    assert!(sin.len() == angles.len() && cos.len() == angles.len());
    let largest = angles.iter().fold(0.0f64, |m, a| m.max(a.abs()));
    if largest <= FAST_LIMIT {
        widest_isa!(generic: kernel_slices(angles, sin, cos), avx2: kernel_slices_avx2(angles, sin, cos), avx512: kernel_slices_avx512(angles, sin, cos));
    } else {
        for ((a, s), c) in angles.iter().zip(sin.iter_mut()).zip(cos.iter_mut()) {
            (*s, *c) = a.sin_cos();
        }
    }
}

#[inline(always)]
fn kernel_slices(angles: &[f64], sin: &mut [f64], cos: &mut [f64]) {
    for ((a, s), c) in angles.iter().zip(sin.iter_mut()).zip(cos.iter_mut()) {
        (*s, *c) = kernel(*a);
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn kernel_slices_avx512(angles: &[f64], sin: &mut [f64], cos: &mut [f64]) {
    kernel_slices(angles, sin, cos)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn kernel_slices_avx2(angles: &[f64], sin: &mut [f64], cos: &mut [f64]) {
    kernel_slices(angles, sin, cos)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    #[test]
    fn matches_std_to_round_off() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let mut worst: f64 = 0.0;
        for i in 0..200_000 {
            let scale = [1.0, 10.0, 1e3, 1e5, 7e5][i % 5];
            let x = (rng.random::<f64>() * 2.0 - 1.0) * scale;
            let (s, c) = sin_cos(x);
            let (s0, c0) = x.sin_cos();
            worst = worst.max((s - s0).abs()).max((c - c0).abs());
        }
        assert!(worst < 3e-16, "worst {worst}");
        let xs: Vec<f64> = (0..1000).map(|i| (i as f64 - 500.0) * 0.37).collect();
        let (mut s, mut c) = (vec![0.0; 1000], vec![0.0; 1000]);
        sin_cos_slices(&xs, &mut s, &mut c);
        let (mut s2, mut c2) = (vec![0.0; 1000], vec![0.0; 1000]);
        kernel_slices(&xs, &mut s2, &mut c2);
        for i in 0..1000 {
            assert_eq!((s[i], c[i]), sin_cos(xs[i]));
            assert_eq!((s2[i], c2[i]), sin_cos(xs[i]));
        }
        #[cfg(target_arch = "x86_64")]
        for (name, has) in [("avx2", std::arch::is_x86_feature_detected!("avx2")), ("avx512f", std::arch::is_x86_feature_detected!("avx512f"))] {
            if has {
                let (mut s3, mut c3) = (vec![0.0; 1000], vec![0.0; 1000]);
                match name {
                    "avx2" => unsafe { kernel_slices_avx2(&xs, &mut s3, &mut c3) },
                    _ => unsafe { kernel_slices_avx512(&xs, &mut s3, &mut c3) },
                }
                for i in 0..1000 {
                    assert_eq!((s3[i], c3[i]), sin_cos(xs[i]), "{name}");
                }
            }
        }
        assert_eq!(sin_cos(0.0), (0.0, 1.0));
        // The small- and tiny-angle forms within 1 ulp of libm on their ranges.
        let ulps = |got: (f64, f64), x: f64| {
            let (s, c) = x.sin_cos();
            let ulp = |v: f64| (v.abs() * f64::EPSILON).max(f64::MIN_POSITIVE);
            ((got.0 - s).abs() / ulp(s)).max((got.1 - c).abs() / ulp(c))
        };
        let (mut small, mut tiny) = (0.0f64, 0.0f64);
        for i in 0..200_000 {
            let u = rng.random::<f64>() * 2.0 - 1.0;
            let scale = if i % 2 == 0 { 1.0 } else { 1e-3 };
            let x = u * std::f64::consts::FRAC_PI_4 * scale;
            small = small.max(ulps(small_sin_cos(x), x));
            let x = u * TINY_ANGLE * scale;
            tiny = tiny.max(ulps(tiny_sin_cos(x), x));
        }
        small = small.max(ulps(small_sin_cos(std::f64::consts::FRAC_PI_4), std::f64::consts::FRAC_PI_4));
        assert!(small <= 1.0 && tiny <= 1.0, "small_sin_cos {small} ulp, tiny_sin_cos {tiny} ulp");
        let big = 1e7_f64;
        assert_eq!(sin_cos(big), big.sin_cos());
    }
}
