//! Arithmetic written once for one particle and for four particles side by side.
//!
//! The per-particle formulas of the transfers (the 1D weights, the terms of a node, a particle's
//! sums, the stress update) are generic over [`Real`]: `f64` runs them for one particle, and
//! [`F64x4`] (x86-64 with AVX2) for four, one per lane of a 4-wide vector. Every operation of
//! the trait is one IEEE operation per lane with the scalar operation's rounding (`+ − × ÷`,
//! `√`, `|·|`, and `max`/`min` written as the comparisons `a > b`, `a < b`), and `ln` is the
//! scalar `f64::ln` of each lane, so a formula gives the same bits in either form: the
//! vectorised kernels equal the scalar ones to the last bit by construction (`tests/simd.rs`).
//! No fused multiply-add is formed (Rust does not contract `a·b + c`).
//!
//! The AVX2 build of a kernel is chosen at run time ([`avx2`], the [`dispatch!`] macro): the
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

/// The most particles side by side that the CPU and [`set_kernel_lanes`] allow: 8 with AVX-512F,
/// 4 with AVX2, 1 otherwise.
pub fn kernel_lanes() -> usize {
    lanes_available()
}

/// [`kernel_lanes`], for the dispatch.
#[inline]
pub(crate) fn lanes_available() -> usize {
    let wanted = LANES.load(Ordering::Relaxed);
    #[cfg(target_arch = "x86_64")]
    {
        if wanted >= 8 && std::arch::is_x86_feature_detected!("avx512f") {
            return 8;
        }
        if wanted >= 4 && std::arch::is_x86_feature_detected!("avx2") {
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
    ($(#[$doc:meta])* fn $name:ident $(<const $c:ident : usize>)? / $avx2:ident, $avx512:ident = $body:ident ( $($arg:ident : $ty:ty),* ) -> $ret:ty) => {
        $(#[$doc])*
        fn $name<const S: usize $(, const $c: usize)?>($($arg: $ty),*) -> $ret {
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
        #[target_feature(enable = "avx2")]
        unsafe fn $avx2<const S: usize $(, const $c: usize)?>($($arg: $ty),*) -> $ret {
            $body::<S $(, $c)?, 4>($($arg),*)
        }

        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx512f")]
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
    /// `ln x`, lane by lane (the scalar `f64::ln`).
    fn ln(self) -> Self;
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
    fn ln(self) -> f64 {
        f64::ln(self)
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
        fn ln(self) -> F64x4 {
            let l = self.lanes();
            F64x4::from_fn(|i| l[i].ln())
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
    /// `#[target_feature(enable = "avx512f")]` that run after a run-time check of the CPU
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
        fn ln(self) -> F64x8 {
            let l = self.lanes();
            F64x8::from_fn(|i| l[i].ln())
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
    }

    impl F64x8 {
        /// Lanes 0–3 and 4–7 as two four-lane vectors.
        #[inline(always)]
        pub(crate) fn halves(self) -> [super::F64x4; 2] {
            // SAFETY: as above.
            unsafe {
                [
                    super::F64x4(_mm512_castpd512_pd256(self.0)),
                    super::F64x4(_mm512_extractf64x4_pd::<1>(self.0)),
                ]
            }
        }

        /// The vector of lanes `lo` then `hi`.
        #[inline(always)]
        pub(crate) fn join(lo: super::F64x4, hi: super::F64x4) -> F64x8 {
            // SAFETY: as above.
            F64x8(unsafe { _mm512_insertf64x4::<1>(_mm512_castpd256_pd512(lo.0), hi.0) })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Real;

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

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn four_lanes_give_the_scalar_bits() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            return;
        }
        let a = [1.5, -0.0, f64::NAN, 3.0e-310];
        let b = [-2.25, 0.0, 1.0, f64::INFINITY];
        // SAFETY: the CPU has AVX2 (checked above).
        let (s, m, n, d, x, y, q, r) = unsafe { check(a, b) };
        for l in 0..4 {
            let same = |v: f64, w: f64| v.to_bits() == w.to_bits() || (v.is_nan() && w.is_nan());
            assert!(same(s[l], a[l] + b[l]));
            assert!(same(m[l], a[l] * b[l]));
            assert!(same(n[l], -a[l]));
            assert!(same(d[l], a[l] / b[l]));
            assert!(same(x[l], Real::max(a[l], b[l])));
            assert!(same(y[l], Real::min(a[l], b[l])));
            assert!(same(q[l], a[l].abs().sqrt()));
            assert!(same(r[l], a[l].abs().ln()));
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[allow(clippy::type_complexity)]
    fn check(a: [f64; 4], b: [f64; 4]) -> ([f64; 4], [f64; 4], [f64; 4], [f64; 4], [f64; 4], [f64; 4], [f64; 4], [f64; 4]) {
        use super::F64x4;
        let (va, vb) = (F64x4::load(&a, 0), F64x4::load(&b, 0));
        (
            (va + vb).lanes(),
            (va * vb).lanes(),
            (-va).lanes(),
            (va / vb).lanes(),
            va.max(vb).lanes(),
            va.min(vb).lanes(),
            va.abs().sqrt().lanes(),
            va.abs().ln().lanes(),
        )
    }
}
