//! `F64x8`: eight `f64` lanes in an AVX-512 register.

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
    fn first_nodes(firsts: &[[u32; 2]], k: usize, strides: [usize; 2]) -> ([F64x8; 2], [usize; 8]) {
        let v = &firsts[k..k + 8];
        let mut nodes = [0usize; 8];
        // SAFETY: `v` holds 8 pairs of u32 (64 bytes); AVX-512 as above.
        let (i, j) = unsafe {
            let raw = _mm512_loadu_si512(v.as_ptr().cast());
            let order = _mm512_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14, 1, 3, 5, 7, 9, 11, 13, 15);
            let split = _mm512_permutexvar_epi32(order, raw);
            let (i, j) = (_mm512_castsi512_si256(split), _mm512_extracti64x4_epi64::<1>(split));
            if super::strides_fit(strides) {
                let [sx, sy] = strides.map(|s| _mm512_set1_epi64(s as i64));
                let (i64, j64) = (_mm512_cvtepu32_epi64(i), _mm512_cvtepu32_epi64(j));
                let n = _mm512_add_epi64(_mm512_mul_epu32(i64, sx), _mm512_mul_epu32(j64, sy));
                _mm512_storeu_si512(nodes.as_mut_ptr().cast(), n);
            } else {
                nodes = super::first_nodes_by_lane(firsts, k, strides, 8);
            }
            (_mm512_cvtepu32_pd(i), _mm512_cvtepu32_pd(j))
        };
        ([F64x8(i), F64x8(j)], nodes)
    }
    #[inline(always)]
    fn store_pairs(i: F64x8, j: F64x8, pairs: &mut [[u32; 2]], k: usize) {
        let v = &mut pairs[k..k + 8];
        // SAFETY: `v` holds 8 pairs of u32 (64 bytes); AVX-512F as above. As F64x4's.
        unsafe {
            let two52 = _mm512_set1_pd(4_503_599_627_370_496.0);
            let low = |x: __m512d| _mm512_castpd_si512(_mm512_add_pd(x, two52));
            let mask = _mm512_set1_epi64(0xffff_ffff);
            let both = _mm512_or_si512(_mm512_and_si512(low(i.0), mask), _mm512_slli_epi64::<32>(low(j.0)));
            _mm512_storeu_si512(v.as_mut_ptr().cast(), both);
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
