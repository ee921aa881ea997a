//! Arithmetic written once for one particle and for four particles side by side.
//!
//! The per-particle formulas of the transfers (the 1D weights, the terms of a node, a particle's
//! sums, the stress update) are generic over [`Real`]: `f64` runs them for one particle, and
//! [`F64x4`] (x86-64 with AVX2 and FMA) for four, one per lane of a 4-wide vector, and `F64x8`
//! (AVX-512) for eight. Every operation of the trait is one IEEE operation per lane with the
//! scalar operation's rounding (`+ − × ÷`, `√`, `|·|`, `max`/`min` written as the comparisons
//! `a > b`, `a < b`, and [`Real::mul_add`], a fused multiply-add rounded once, as
//! `f64::mul_add`), and `ln` is the scalar `f64::ln` of each lane, so a formula gives the same
//! bits in either form: the vectorised kernels equal the scalar ones to the last bit by
//! construction (`tests/simd.rs`). Fused multiply-adds appear only where a formula calls
//! `mul_add` (Rust does not contract `a·b + c` on its own): the sums of the grid-to-particle
//! gathers and the terms of the particle-to-grid scatter.
//!
//! The vector builds of a kernel are chosen at run time ([`avx2`], the [`dispatch!`] macro): the
//! baseline build runs the scalar form, and either gives the same results on any machine and
//! for any thread count (`tests/simd.rs`), for runs without NaN (a NaN's payload bits are not
//! specified by the compiler in either build).

use std::ops::{Add, Div, Mul, Neg, Sub};
use std::sync::atomic::{AtomicUsize, Ordering};

static LANES: AtomicUsize = AtomicUsize::new(8);

/// Chooses the scalar build of the transfers (`true`) or the widest vector build the CPU has
/// (`false`, the default) for the whole process. The results are the same bits either way: this
/// changes speed only (for benchmarks: `mpm bench --scalar-kernels`).
pub fn set_scalar_kernels(scalar: bool) {
    set_kernel_lanes(if scalar { 1 } else { 8 });
}

/// Sets the most particles the kernels take side by side for the whole process: 1 (the scalar
/// build), 4 (AVX2) or 8 (AVX-512, the default); the CPU may allow fewer. The results are the
/// same bits for every width.
pub fn set_kernel_lanes(lanes: usize) {
    LANES.store(lanes, Ordering::Relaxed);
}

/// The most particles side by side that the CPU and [`set_kernel_lanes`] allow: 8 with AVX-512F
/// and AVX-512VL (the four-lane kernels of that build then have 32 vector registers), 4 with
/// AVX2 and FMA, 1 otherwise.
pub fn kernel_lanes() -> usize {
    lanes_available()
}

/// [`kernel_lanes`], for the dispatch.
#[inline]
pub(crate) fn lanes_available() -> usize {
    let wanted = LANES.load(Ordering::Relaxed);
    #[cfg(target_arch = "x86_64")]
    {
        if wanted >= 8
            && std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("avx512vl")
        {
            return 8;
        }
        if wanted >= 4 && std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
            return 4;
        }
    }
    let _ = wanted;
    1
}

/// Declares `$name`, which runs `$body::<S, …, 8>` from a copy compiled for AVX-512F,
/// `$body::<S, …, 4>` from a copy compiled for AVX2, or `$body::<S, …, 1>` from the baseline
/// build, the widest that [`lanes_available`] allows (see the note on bits).
macro_rules! dispatch {
    ($(#[$doc:meta])* $vis:vis fn $name:ident $(<const $c:ident : usize>)? / $avx2:ident, $avx512:ident = $body:ident ( $($arg:ident : $ty:ty),* ) -> $ret:ty) => {
        $(#[$doc])*
        $vis fn $name<const S: usize $(, const $c: usize)?>($($arg: $ty),*) -> $ret {
            #[cfg(target_arch = "x86_64")]
            match $crate::lanes::lanes_available() {
                // SAFETY: the CPU has AVX-512F, checked at run time just above.
                8 => return unsafe { $avx512::<S $(, $c)?>($($arg),*) },
                // SAFETY: the CPU has AVX2, checked at run time just above.
                4 => return unsafe { $avx2::<S $(, $c)?>($($arg),*) },
                _ => {}
            }
            $body::<S $(, $c)?, 1>($($arg),*)
        }

        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2,fma")]
        unsafe fn $avx2<const S: usize $(, const $c: usize)?>($($arg: $ty),*) -> $ret {
            $body::<S $(, $c)?, 4>($($arg),*)
        }

        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx512f,avx512vl,fma")]
        unsafe fn $avx512<const S: usize $(, const $c: usize)?>($($arg: $ty),*) -> $ret {
            $body::<S $(, $c)?, 8>($($arg),*)
        }
    };
}
pub(crate) use dispatch;

/// One value per lane: `f64` (one lane) or [`F64x4`] (four).
pub(crate) trait Real:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Div<Output = Self> + Neg<Output = Self>
{
    /// Lanes per value.
    const LANES: usize;
    /// `v` in every lane.
    fn splat(v: f64) -> Self;
    /// `values[k ..]`, one per lane.
    ///
    /// # Panics
    /// If `values` holds fewer than `k + LANES` values.
    fn load(values: &[f64], k: usize) -> Self;
    /// Writes the lanes to `values[k ..]`.
    ///
    /// # Panics
    /// If `values` holds fewer than `k + LANES` values.
    fn store(self, values: &mut [f64], k: usize);
    /// Lane `l` from `f(l)`.
    fn from_fn(f: impl FnMut(usize) -> f64) -> Self;
    /// The lanes (lanes past [`Real::LANES`] are 0).
    fn lanes(self) -> [f64; 8];
    /// `|x|`.
    fn abs(self) -> Self;
    /// `if self > other { self } else { other }`, lane by lane.
    fn max(self, other: Self) -> Self;
    /// `if self < other { self } else { other }`, lane by lane.
    fn min(self, other: Self) -> Self;
    /// `max(lo).min(hi)`.
    #[inline(always)]
    fn clamp(self, lo: f64, hi: f64) -> Self {
        self.max(Self::splat(lo)).min(Self::splat(hi))
    }
    /// `ln x` ([`ln_of`]: the same bits in every lane of every type).
    #[inline(always)]
    fn ln(self) -> Self {
        ln_of(self)
    }
    /// For `x` positive, normal and finite: `(m, e)` with `x = m 2^e`, `m ∈ [1/√2, √2)` (exact).
    fn split_exponent(self) -> (Self, Self);
    /// Whether `self > other` in every lane (false where either is NaN).
    fn all_gt(self, other: Self) -> bool;
    /// Whether `self >= other` in every lane (false where either is NaN).
    fn all_ge(self, other: Self) -> bool;
    /// Whether `self == other` in some lane.
    fn any_eq(self, other: Self) -> bool;
    /// `⌊x⌋` for `0 ≤ x < 2⁵²` (the truncation `x as u64`).
    fn floor_nonneg(self) -> Self;
    /// `√x`.
    fn sqrt(self) -> Self;
    /// `self · a + b` rounded once (a fused multiply-add: the same bits in every lane of every
    /// type, [`f64::mul_add`]).
    fn mul_add(self, a: Self, b: Self) -> Self;
    /// The smallest lane (of lanes holding no NaN).
    fn min_lane(self) -> f64;
    /// The largest lane (of lanes holding no NaN).
    fn max_lane(self) -> f64;
    /// `out[l] = [i_l, k_l]` for each lane `l`, of lanes holding integers in `[0, 2³¹)`.
    ///
    /// # Panics
    /// If `out` does not hold one pair per lane.
    fn store_index_pairs(i: Self, k: Self, out: &mut [[u32; 2]]);
}

impl Real for f64 {
    const LANES: usize = 1;
    #[inline(always)]
    fn splat(v: f64) -> f64 {
        v
    }
    #[inline(always)]
    fn load(values: &[f64], k: usize) -> f64 {
        values[k]
    }
    #[inline(always)]
    fn store(self, values: &mut [f64], k: usize) {
        values[k] = self;
    }
    #[inline(always)]
    fn from_fn(mut f: impl FnMut(usize) -> f64) -> f64 {
        f(0)
    }
    #[inline(always)]
    fn lanes(self) -> [f64; 8] {
        [self, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    }
    #[inline(always)]
    fn abs(self) -> f64 {
        f64::abs(self)
    }
    #[inline(always)]
    fn max(self, other: f64) -> f64 {
        if self > other {
            self
        } else {
            other
        }
    }
    #[inline(always)]
    fn min(self, other: f64) -> f64 {
        if self < other {
            self
        } else {
            other
        }
    }
    #[inline(always)]
    fn split_exponent(self) -> (f64, f64) {
        let bits = self.to_bits();
        let e = (bits >> 52) as f64 - 1023.0;
        let m = f64::from_bits((bits & MANTISSA) | ONE);
        if m > std::f64::consts::SQRT_2 {
            (m * 0.5, e + 1.0)
        } else {
            (m, e)
        }
    }
    #[inline(always)]
    fn all_gt(self, other: f64) -> bool {
        self > other
    }
    #[inline(always)]
    fn all_ge(self, other: f64) -> bool {
        self >= other
    }
    #[inline(always)]
    fn any_eq(self, other: f64) -> bool {
        self == other
    }
    #[inline(always)]
    fn floor_nonneg(self) -> f64 {
        (self as u64) as f64
    }
    #[inline(always)]
    fn sqrt(self) -> f64 {
        f64::sqrt(self)
    }
    #[inline(always)]
    fn mul_add(self, a: f64, b: f64) -> f64 {
        f64::mul_add(self, a, b)
    }
    #[inline(always)]
    fn min_lane(self) -> f64 {
        self
    }
    #[inline(always)]
    fn max_lane(self) -> f64 {
        self
    }
    #[inline(always)]
    fn store_index_pairs(i: f64, k: f64, out: &mut [[u32; 2]]) {
        assert_eq!(out.len(), 1, "one pair per lane");
        out[0] = [i as u32, k as u32];
    }
}

/// The mantissa bits of an `f64`, the exponent bits of 1.0, and the bits of 2⁵².
const MANTISSA: u64 = 0x000f_ffff_ffff_ffff;
const ONE: u64 = 0x3ff0_0000_0000_0000;
const TWO_52: u64 = 0x4330_0000_0000_0000;

/// `ln x` in one set of IEEE operations for every lane type (so that four or eight particles
/// side by side give the scalar bits): fdlibm's `log` (Sun Microsystems, 1993; error below one
/// unit in the last place) without its branches,
///
/// ```text
/// x = m 2^e, m ∈ [1/√2, √2),  f = m − 1,  s = f/(2 + f),
/// ln x = e ln2_hi − ((f²/2 − (s (f²/2 + R(s²)) + e ln2_lo)) − f),
/// R(z) = z (L1 + w (L3 + w (L5 + w L7))) + w (L2 + w (L4 + w L6)),  w = z²
/// ```
///
/// and `f64::ln` lane by lane where a lane is not positive, normal and finite (0, negative,
/// subnormal, infinite, NaN).
#[inline(always)]
pub(crate) fn ln_of<R: Real>(x: R) -> R {
    let normal = R::splat(f64::INFINITY).all_gt(x) && x.all_ge(R::splat(f64::MIN_POSITIVE));
    if !normal {
        let l = x.lanes();
        return R::from_fn(|i| {
            let v = l[i];
            if v.is_finite() && v >= f64::MIN_POSITIVE {
                ln_of(v)
            } else {
                v.ln()
            }
        });
    }
    // fdlibm's constants, bit for bit.
    const LN2_HI: f64 = f64::from_bits(0x3fe6_2e42_fee0_0000);
    const LN2_LO: f64 = f64::from_bits(0x3dea_39ef_3579_3c76);
    const L: [f64; 7] = [
        f64::from_bits(0x3fe5_5555_5555_5593),
        f64::from_bits(0x3fd9_9999_9997_fa04),
        f64::from_bits(0x3fd2_4924_9422_9359),
        f64::from_bits(0x3fcc_71c5_1d8e_78af),
        f64::from_bits(0x3fc7_4664_96cb_03de),
        f64::from_bits(0x3fc3_9a09_d078_c69f),
        f64::from_bits(0x3fc2_f112_df3e_5244),
    ];
    let c = R::splat;
    let (m, e) = x.split_exponent();
    let f = m - c(1.0);
    let s = f / (c(2.0) + f);
    let z = s * s;
    let w = z * z;
    let t1 = w * (c(L[1]) + w * (c(L[3]) + w * c(L[5])));
    let t2 = z * (c(L[0]) + w * (c(L[2]) + w * (c(L[4]) + w * c(L[6]))));
    let r = t2 + t1;
    let hfsq = c(0.5) * f * f;
    e * c(LN2_HI) - ((hfsq - (s * (hfsq + r) + e * c(LN2_LO))) - f)
}

#[cfg(target_arch = "x86_64")]
pub(crate) use avx2::F64x4;

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::Real;
    use std::arch::x86_64::*;
    use std::ops::{Add, Div, Mul, Neg, Sub};

    /// Four `f64` lanes in an AVX register.
    ///
    /// Its operations are AVX instructions: a value of this type exists only inside functions
    /// compiled with `#[target_feature(enable = "avx2")]` that run after a run-time check of the
    /// CPU (`kernels::simd`), and every method is `#[inline(always)]` so that it is compiled
    /// into them.
    #[derive(Clone, Copy, Debug)]
    pub(crate) struct F64x4(pub(crate) __m256d);

    macro_rules! binary {
        ($tr:ident, $f:ident, $intrinsic:ident) => {
            impl $tr for F64x4 {
                type Output = F64x4;
                #[inline(always)]
                fn $f(self, o: F64x4) -> F64x4 {
                    // SAFETY: F64x4 values are only made where the CPU has AVX2 (type docs).
                    F64x4(unsafe { $intrinsic(self.0, o.0) })
                }
            }
        };
    }
    binary!(Add, add, _mm256_add_pd);
    binary!(Sub, sub, _mm256_sub_pd);
    binary!(Mul, mul, _mm256_mul_pd);
    binary!(Div, div, _mm256_div_pd);

    impl Neg for F64x4 {
        type Output = F64x4;
        #[inline(always)]
        fn neg(self) -> F64x4 {
            // SAFETY: as above. −x flips the sign bit, as the scalar negation does.
            F64x4(unsafe { _mm256_xor_pd(self.0, _mm256_set1_pd(-0.0)) })
        }
    }

    impl Real for F64x4 {
        const LANES: usize = 4;
        #[inline(always)]
        fn splat(v: f64) -> F64x4 {
            // SAFETY: as above.
            F64x4(unsafe { _mm256_set1_pd(v) })
        }
        #[inline(always)]
        fn load(values: &[f64], k: usize) -> F64x4 {
            let v = &values[k..k + 4];
            // SAFETY: `v` holds 4 values; AVX as above.
            F64x4(unsafe { _mm256_loadu_pd(v.as_ptr()) })
        }
        #[inline(always)]
        fn store(self, values: &mut [f64], k: usize) {
            let v = &mut values[k..k + 4];
            // SAFETY: `v` holds 4 values; AVX as above.
            unsafe { _mm256_storeu_pd(v.as_mut_ptr(), self.0) }
        }
        #[inline(always)]
        fn from_fn(mut f: impl FnMut(usize) -> f64) -> F64x4 {
            let (a, b, c, d) = (f(0), f(1), f(2), f(3));
            // SAFETY: as above.
            F64x4(unsafe { _mm256_setr_pd(a, b, c, d) })
        }
        #[inline(always)]
        fn lanes(self) -> [f64; 8] {
            let mut out = [0.0; 8];
            // SAFETY: `out` holds at least 4 values; AVX as above.
            unsafe { _mm256_storeu_pd(out.as_mut_ptr(), self.0) };
            out
        }
        #[inline(always)]
        fn abs(self) -> F64x4 {
            // SAFETY: as above. Clears the sign bit, as f64::abs.
            F64x4(unsafe { _mm256_andnot_pd(_mm256_set1_pd(-0.0), self.0) })
        }
        #[inline(always)]
        fn max(self, other: F64x4) -> F64x4 {
            // SAFETY: as above. maxpd(a, b) is `a > b ? a : b` lane by lane.
            F64x4(unsafe { _mm256_max_pd(self.0, other.0) })
        }
        #[inline(always)]
        fn min(self, other: F64x4) -> F64x4 {
            // SAFETY: as above. minpd(a, b) is `a < b ? a : b` lane by lane.
            F64x4(unsafe { _mm256_min_pd(self.0, other.0) })
        }
        #[inline(always)]
        fn split_exponent(self) -> (F64x4, F64x4) {
            // SAFETY: as above.
            unsafe {
                let bits = _mm256_castpd_si256(self.0);
                // The biased exponent as an exact double: 2⁵² + E, less 2⁵² + 1023.
                let biased = _mm256_or_si256(_mm256_srli_epi64::<52>(bits), _mm256_set1_epi64x(super::TWO_52 as i64));
                let e = _mm256_sub_pd(
                    _mm256_castsi256_pd(biased),
                    _mm256_set1_pd(f64::from_bits(super::TWO_52) + 1023.0),
                );
                let mantissa = _mm256_and_si256(bits, _mm256_set1_epi64x(super::MANTISSA as i64));
                let m = _mm256_castsi256_pd(_mm256_or_si256(mantissa, _mm256_set1_epi64x(super::ONE as i64)));
                let big = _mm256_cmp_pd::<_CMP_GT_OQ>(m, _mm256_set1_pd(std::f64::consts::SQRT_2));
                let m = _mm256_blendv_pd(m, _mm256_mul_pd(m, _mm256_set1_pd(0.5)), big);
                let e = _mm256_blendv_pd(e, _mm256_add_pd(e, _mm256_set1_pd(1.0)), big);
                (F64x4(m), F64x4(e))
            }
        }
        #[inline(always)]
        fn all_gt(self, other: F64x4) -> bool {
            // SAFETY: as above. An ordered, non-signalling comparison: false for NaN.
            unsafe { _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_GT_OQ>(self.0, other.0)) == 0b1111 }
        }
        #[inline(always)]
        fn all_ge(self, other: F64x4) -> bool {
            // SAFETY: as above. Ordered: false for NaN.
            unsafe { _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_GE_OQ>(self.0, other.0)) == 0b1111 }
        }
        #[inline(always)]
        fn any_eq(self, other: F64x4) -> bool {
            // SAFETY: as above.
            unsafe { _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_EQ_OQ>(self.0, other.0)) != 0 }
        }
        #[inline(always)]
        fn floor_nonneg(self) -> F64x4 {
            // SAFETY: as above. Rounds toward −∞: the truncation for x ≥ 0.
            F64x4(unsafe { _mm256_floor_pd(self.0) })
        }
        #[inline(always)]
        fn sqrt(self) -> F64x4 {
            // SAFETY: as above. sqrtpd rounds as f64::sqrt.
            F64x4(unsafe { _mm256_sqrt_pd(self.0) })
        }
        #[inline(always)]
        fn mul_add(self, a: F64x4, b: F64x4) -> F64x4 {
            // SAFETY: as above (FMA comes with AVX2 here, checked by `lanes_available`, and
            // with AVX-512F). One rounding, as f64::mul_add.
            F64x4(unsafe { _mm256_fmadd_pd(self.0, a.0, b.0) })
        }
        #[inline(always)]
        fn min_lane(self) -> f64 {
            // SAFETY: AVX as above.
            unsafe {
                let a = _mm256_min_pd(self.0, _mm256_permute2f128_pd::<1>(self.0, self.0));
                let h = _mm256_castpd256_pd128(a);
                _mm_cvtsd_f64(_mm_min_pd(h, _mm_unpackhi_pd(h, h)))
            }
        }
        #[inline(always)]
        fn max_lane(self) -> f64 {
            // SAFETY: AVX as above.
            unsafe {
                let a = _mm256_max_pd(self.0, _mm256_permute2f128_pd::<1>(self.0, self.0));
                let h = _mm256_castpd256_pd128(a);
                _mm_cvtsd_f64(_mm_max_pd(h, _mm_unpackhi_pd(h, h)))
            }
        }
        #[inline(always)]
        fn store_index_pairs(i: F64x4, k: F64x4, out: &mut [[u32; 2]]) {
            assert_eq!(out.len(), 4, "one pair per lane");
            // SAFETY: `out` holds 8 u32 (checked); AVX as above. Truncation to i32 gives the
            // integer itself below 2³¹, as `as u32` does.
            unsafe {
                let (a, b) = (_mm256_cvttpd_epi32(i.0), _mm256_cvttpd_epi32(k.0));
                let p = out.as_mut_ptr().cast::<__m128i>();
                _mm_storeu_si128(p, _mm_unpacklo_epi32(a, b));
                _mm_storeu_si128(p.add(1), _mm_unpackhi_epi32(a, b));
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
pub(crate) use avx512::F64x8;

#[cfg(target_arch = "x86_64")]
mod avx512 {
    use super::Real;
    use std::arch::x86_64::*;
    use std::ops::{Add, Div, Mul, Neg, Sub};

    /// Eight `f64` lanes in an AVX-512 register.
    ///
    /// As [`super::F64x4`]: a value of this type exists only inside functions compiled with
    /// `#[target_feature(enable = "avx512f,avx512vl")]` that run after a run-time check of the CPU
    /// ([`super::lanes_available`]), and every method is `#[inline(always)]`.
    #[derive(Clone, Copy, Debug)]
    pub(crate) struct F64x8(pub(crate) __m512d);

    macro_rules! binary {
        ($tr:ident, $f:ident, $intrinsic:ident) => {
            impl $tr for F64x8 {
                type Output = F64x8;
                #[inline(always)]
                fn $f(self, o: F64x8) -> F64x8 {
                    // SAFETY: F64x8 values are only made where the CPU has AVX-512F (type docs).
                    F64x8(unsafe { $intrinsic(self.0, o.0) })
                }
            }
        };
    }
    binary!(Add, add, _mm512_add_pd);
    binary!(Sub, sub, _mm512_sub_pd);
    binary!(Mul, mul, _mm512_mul_pd);
    binary!(Div, div, _mm512_div_pd);

    /// The sign bit of every lane.
    #[inline(always)]
    fn sign() -> __m512i {
        // SAFETY: as above.
        unsafe { _mm512_set1_epi64(i64::MIN) }
    }

    impl Neg for F64x8 {
        type Output = F64x8;
        #[inline(always)]
        fn neg(self) -> F64x8 {
            // SAFETY: as above. −x flips the sign bit, as the scalar negation does.
            F64x8(unsafe { _mm512_castsi512_pd(_mm512_xor_si512(_mm512_castpd_si512(self.0), sign())) })
        }
    }

    impl Real for F64x8 {
        const LANES: usize = 8;
        #[inline(always)]
        fn splat(v: f64) -> F64x8 {
            // SAFETY: as above.
            F64x8(unsafe { _mm512_set1_pd(v) })
        }
        #[inline(always)]
        fn load(values: &[f64], k: usize) -> F64x8 {
            let v = &values[k..k + 8];
            // SAFETY: `v` holds 8 values; AVX-512F as above.
            F64x8(unsafe { _mm512_loadu_pd(v.as_ptr()) })
        }
        #[inline(always)]
        fn store(self, values: &mut [f64], k: usize) {
            let v = &mut values[k..k + 8];
            // SAFETY: `v` holds 8 values; AVX-512F as above.
            unsafe { _mm512_storeu_pd(v.as_mut_ptr(), self.0) }
        }
        #[inline(always)]
        fn from_fn(mut f: impl FnMut(usize) -> f64) -> F64x8 {
            let v = [f(0), f(1), f(2), f(3), f(4), f(5), f(6), f(7)];
            // SAFETY: `v` holds 8 values; as above.
            F64x8(unsafe { _mm512_loadu_pd(v.as_ptr()) })
        }
        #[inline(always)]
        fn lanes(self) -> [f64; 8] {
            let mut out = [0.0; 8];
            // SAFETY: `out` holds 8 values; as above.
            unsafe { _mm512_storeu_pd(out.as_mut_ptr(), self.0) };
            out
        }
        #[inline(always)]
        fn abs(self) -> F64x8 {
            // SAFETY: as above. Clears the sign bit, as f64::abs.
            F64x8(unsafe { _mm512_castsi512_pd(_mm512_andnot_si512(sign(), _mm512_castpd_si512(self.0))) })
        }
        #[inline(always)]
        fn max(self, other: F64x8) -> F64x8 {
            // SAFETY: as above. vmaxpd(a, b) is `a > b ? a : b` lane by lane.
            F64x8(unsafe { _mm512_max_pd(self.0, other.0) })
        }
        #[inline(always)]
        fn min(self, other: F64x8) -> F64x8 {
            // SAFETY: as above. vminpd(a, b) is `a < b ? a : b` lane by lane.
            F64x8(unsafe { _mm512_min_pd(self.0, other.0) })
        }
        #[inline(always)]
        fn split_exponent(self) -> (F64x8, F64x8) {
            // SAFETY: as above.
            unsafe {
                let bits = _mm512_castpd_si512(self.0);
                // The biased exponent as an exact double: 2⁵² + E, less 2⁵² + 1023.
                let biased = _mm512_or_si512(_mm512_srli_epi64::<52>(bits), _mm512_set1_epi64(super::TWO_52 as i64));
                let e = _mm512_sub_pd(
                    _mm512_castsi512_pd(biased),
                    _mm512_set1_pd(f64::from_bits(super::TWO_52) + 1023.0),
                );
                let mantissa = _mm512_and_si512(bits, _mm512_set1_epi64(super::MANTISSA as i64));
                let m = _mm512_castsi512_pd(_mm512_or_si512(mantissa, _mm512_set1_epi64(super::ONE as i64)));
                let big = _mm512_cmp_pd_mask::<_CMP_GT_OQ>(m, _mm512_set1_pd(std::f64::consts::SQRT_2));
                let m = _mm512_mask_mul_pd(m, big, m, _mm512_set1_pd(0.5));
                let e = _mm512_mask_add_pd(e, big, e, _mm512_set1_pd(1.0));
                (F64x8(m), F64x8(e))
            }
        }
        #[inline(always)]
        fn all_gt(self, other: F64x8) -> bool {
            // SAFETY: as above. Ordered, non-signalling: false for NaN.
            unsafe { _mm512_cmp_pd_mask::<_CMP_GT_OQ>(self.0, other.0) == 0xff }
        }
        #[inline(always)]
        fn all_ge(self, other: F64x8) -> bool {
            // SAFETY: as above.
            unsafe { _mm512_cmp_pd_mask::<_CMP_GE_OQ>(self.0, other.0) == 0xff }
        }
        #[inline(always)]
        fn any_eq(self, other: F64x8) -> bool {
            // SAFETY: as above.
            unsafe { _mm512_cmp_pd_mask::<_CMP_EQ_OQ>(self.0, other.0) != 0 }
        }
        #[inline(always)]
        fn floor_nonneg(self) -> F64x8 {
            // SAFETY: as above. Rounds toward −∞ (no exception): the truncation for x ≥ 0.
            F64x8(unsafe { _mm512_roundscale_pd::<{ _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC }>(self.0) })
        }
        #[inline(always)]
        fn sqrt(self) -> F64x8 {
            // SAFETY: as above. vsqrtpd rounds as f64::sqrt.
            F64x8(unsafe { _mm512_sqrt_pd(self.0) })
        }
        #[inline(always)]
        fn mul_add(self, a: F64x8, b: F64x8) -> F64x8 {
            // SAFETY: as above (FMA comes with AVX2 here, checked by `lanes_available`, and
            // with AVX-512F). One rounding, as f64::mul_add.
            F64x8(unsafe { _mm512_fmadd_pd(self.0, a.0, b.0) })
        }
        #[inline(always)]
        fn min_lane(self) -> f64 {
            // SAFETY: as above.
            unsafe { _mm512_reduce_min_pd(self.0) }
        }
        #[inline(always)]
        fn max_lane(self) -> f64 {
            // SAFETY: as above.
            unsafe { _mm512_reduce_max_pd(self.0) }
        }
        #[inline(always)]
        fn store_index_pairs(i: F64x8, k: F64x8, out: &mut [[u32; 2]]) {
            assert_eq!(out.len(), 8, "one pair per lane");
            // SAFETY: `out` holds 16 u32 (checked); AVX-512F (with AVX2) as above. Truncation
            // to i32 gives the integer itself below 2³¹, as `as u32` does.
            unsafe {
                let (a, b) = (_mm512_cvttpd_epi32(i.0), _mm512_cvttpd_epi32(k.0));
                let (lo, hi) = (_mm256_unpacklo_epi32(a, b), _mm256_unpackhi_epi32(a, b));
                let p = out.as_mut_ptr().cast::<__m256i>();
                _mm256_storeu_si256(p, _mm256_permute2x128_si256::<0x20>(lo, hi));
                _mm256_storeu_si256(p.add(1), _mm256_permute2x128_si256::<0x31>(lo, hi));
            }
        }
    }

    impl F64x8 {
        /// Lanes 0–3 and lanes 4–7.
        #[inline(always)]
        pub(crate) fn halves(self) -> (super::F64x4, super::F64x4) {
            // SAFETY: as above.
            unsafe {
                (
                    super::F64x4(_mm512_castpd512_pd256(self.0)),
                    super::F64x4(_mm512_extractf64x4_pd::<1>(self.0)),
                )
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Real;

    /// The logarithm of the kernels is within one unit in the last place of the standard
    /// library's, and takes the standard library's values where it is not positive and normal.
    #[test]
    fn the_kernels_logarithm_is_within_an_ulp_of_the_standard_one() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut worst = 0.0f64;
        for k in 0..200_000 {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            // Uniform in log scale over [1e-300, 1e300], and densely near 1.
            let u = (state >> 11) as f64 / (1u64 << 53) as f64;
            let x = if k % 2 == 0 {
                10f64.powf(600.0 * u - 300.0)
            } else {
                1.0 + (u - 0.5) * 1e-3
            };
            let (ours, std) = (super::ln_of(x), x.ln());
            let ulp = f64::from_bits(std.abs().to_bits() + 1) - std.abs();
            worst = worst.max((ours - std).abs() / ulp);
        }
        assert!(worst <= 1.0, "{worst} ulp");
        for x in [0.0, -1.0, f64::INFINITY, f64::NAN, 1e-310] {
            let (ours, std) = (super::ln_of(x), x.ln());
            assert!(
                ours.to_bits() == std.to_bits() || (ours.is_nan() && std.is_nan()),
                "{x}"
            );
        }
        assert_eq!(super::ln_of(1.0), 0.0);
    }

    /// The scalar max and min are the comparisons the vector instructions make, NaN and signed
    /// zeros included (the second operand when the comparison is false).
    #[test]
    fn scalar_max_and_min_return_the_second_operand_when_the_comparison_fails() {
        assert!(Real::max(f64::NAN, 1.0) == 1.0);
        assert!(Real::max(1.0, f64::NAN).is_nan());
        assert!(Real::max(-0.0, 0.0).is_sign_positive());
        assert!(Real::max(0.0, -0.0).is_sign_negative());
        assert!(Real::min(f64::NAN, 1.0) == 1.0);
        assert!(Real::min(0.0, -0.0).is_sign_negative());
    }

    /// Every operation of four and eight lanes gives the scalar operation's bits in each lane.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn four_and_eight_lanes_give_the_scalar_bits() {
        let a = [1.5, -0.0, f64::NAN, 3.0e-310, 7.25e12, 0.70, 1.45, -2.0];
        let b = [-2.25, 0.0, 1.0, f64::INFINITY, 3.0, 1e-300, 0.5, 2.0];
        let mut widths = vec![];
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2 (checked above).
            widths.push(unsafe { four(a, b) });
        }
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU has AVX-512F (checked above).
            widths.push(unsafe { eight(a, b) });
        }
        for (w, lanes) in widths.iter().enumerate() {
            let count = if w == 0 { 4 } else { 8 };
            for l in 0..count {
                let same = |v: f64, u: f64| v.to_bits() == u.to_bits() || (v.is_nan() && u.is_nan());
                let expected = ops::<f64>(a[l], b[l]);
                for (op, e) in expected.iter().enumerate() {
                    assert!(same(lanes[op][l], e.lanes()[0]), "operation {op}, lane {l}");
                }
            }
        }
    }

    /// `+ × − ÷ max min √|a| ln|a| ln(split)`, one value per operation.
    fn ops<R: Real>(a: R, b: R) -> [R; 9] {
        let (m, e) = (a.abs().max(R::splat(f64::MIN_POSITIVE)) + R::splat(1.0)).split_exponent();
        [
            a + b,
            a * b,
            -a,
            a / b,
            a.max(b),
            a.min(b),
            a.abs().sqrt(),
            a.abs().ln(),
            m + e,
        ]
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn four(a: [f64; 8], b: [f64; 8]) -> [[f64; 8]; 9] {
        let mut out = [[0.0; 8]; 9];
        for half in 0..2 {
            let (va, vb) = (super::F64x4::load(&a, 4 * half), super::F64x4::load(&b, 4 * half));
            for (o, v) in out.iter_mut().zip(ops(va, vb)) {
                o[4 * half..4 * half + 4].copy_from_slice(&v.lanes()[..4]);
            }
        }
        out
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn eight(a: [f64; 8], b: [f64; 8]) -> [[f64; 8]; 9] {
        let (va, vb) = (super::F64x8::load(&a, 0), super::F64x8::load(&b, 0));
        ops(va, vb).map(|v| v.lanes())
    }
}
