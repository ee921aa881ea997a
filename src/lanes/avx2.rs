//! [`F64x4`]: four `f64` lanes in an AVX register (AVX2 and FMA).

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
    fn first_nodes(firsts: &[[u32; 2]], k: usize, strides: [usize; 2]) -> ([F64x4; 2], [usize; 8]) {
        let v = &firsts[k..k + 4];
        let mut nodes = [0usize; 8];
        // SAFETY: `v` holds 4 pairs of u32 (32 bytes); AVX2 as above. u32 to f64 exactly:
        // 2⁵² + x holds x in its mantissa.
        let (i, j) = unsafe {
            let raw = _mm256_loadu_si256(v.as_ptr().cast());
            let split = _mm256_permutevar8x32_epi32(raw, _mm256_setr_epi32(0, 2, 4, 6, 1, 3, 5, 7));
            let i = _mm256_cvtepu32_epi64(_mm256_castsi256_si128(split));
            let j = _mm256_cvtepu32_epi64(_mm256_extracti128_si256::<1>(split));
            if super::strides_fit(strides) {
                let [sx, sy] = strides.map(|s| _mm256_set1_epi64x(s as i64));
                let n = _mm256_add_epi64(_mm256_mul_epu32(i, sx), _mm256_mul_epu32(j, sy));
                _mm256_storeu_si256(nodes.as_mut_ptr().cast(), n);
            } else {
                nodes = super::first_nodes_by_lane(firsts, k, strides, 4);
            }
            let (magic, two52) = (
                _mm256_set1_epi64x(super::TWO_52 as i64),
                _mm256_set1_pd(4_503_599_627_370_496.0),
            );
            let exact = |x: __m256i| _mm256_sub_pd(_mm256_castsi256_pd(_mm256_or_si256(x, magic)), two52);
            (exact(i), exact(j))
        };
        ([F64x4(i), F64x4(j)], nodes)
    }
    #[inline(always)]
    fn store_pairs(i: F64x4, j: F64x4, pairs: &mut [[u32; 2]], k: usize) {
        let v = &mut pairs[k..k + 4];
        // SAFETY: `v` holds 4 pairs of u32 (32 bytes); AVX2 as above. For an integer x in
        // [0, 2³²), the bits of 2⁵² + x end in x: lane l's 64 bits become [i_l, j_l].
        unsafe {
            let two52 = _mm256_set1_pd(4_503_599_627_370_496.0);
            let low = |x: __m256d| _mm256_castpd_si256(_mm256_add_pd(x, two52));
            let mask = _mm256_set1_epi64x(0xffff_ffff);
            let both = _mm256_or_si256(_mm256_and_si256(low(i.0), mask), _mm256_slli_epi64::<32>(low(j.0)));
            _mm256_storeu_si256(v.as_mut_ptr().cast(), both);
        }
    }
}
