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
    /// The first nodes `firsts[k …]` (one `[i, j]` per lane): `[i, j]` as values, and the node
    /// numbers `i s_x + j s_y` (with `strides = [s_x, s_y]`; entries past [`Real::LANES`] are
    /// 0). Exact: every index is an integer below 2³².
    fn first_nodes(firsts: &[[u32; 2]], k: usize, strides: [usize; 2]) -> ([Self; 2], [usize; 8]);
    /// Writes `[i, j]` of each lane to `pairs[k …]` as `u32`: the inverse of
    /// [`Real::first_nodes`]'s values, for lanes holding integers in `[0, 2³²)`.
    fn store_pairs(i: Self, j: Self, pairs: &mut [[u32; 2]], k: usize);
}

/// [`Real::first_nodes`] one lane at a time, for `lanes` lanes.
#[inline(always)]
fn first_nodes_by_lane(firsts: &[[u32; 2]], k: usize, [sx, sy]: [usize; 2], lanes: usize) -> [usize; 8] {
    let mut n = [0; 8];
    for (l, n) in n.iter_mut().enumerate().take(lanes) {
        let [i, j] = firsts[k + l];
        *n = i as usize * sx + j as usize * sy;
    }
    n
}

/// Whether both node-number strides fit in 32 bits (the vector builds' 32 × 32-bit products).
#[inline(always)]
fn strides_fit(strides: [usize; 2]) -> bool {
    strides.iter().all(|&s| u32::try_from(s).is_ok())
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
    fn first_nodes(firsts: &[[u32; 2]], k: usize, strides: [usize; 2]) -> ([f64; 2], [usize; 8]) {
        let [i, j] = firsts[k];
        ([f64::from(i), f64::from(j)], first_nodes_by_lane(firsts, k, strides, 1))
    }
    #[inline(always)]
    fn store_pairs(i: f64, j: f64, pairs: &mut [[u32; 2]], k: usize) {
        pairs[k] = [i as u32, j as u32];
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
mod avx2;

#[cfg(target_arch = "x86_64")]
pub(crate) use avx512::F64x8;

#[cfg(target_arch = "x86_64")]
mod avx512;

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

    /// The vector builds' first nodes (their index values and node numbers) are the scalar
    /// ones, for indices up to 2³² − 1 and for strides that do not fit in 32 bits.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn first_nodes_of_four_and_eight_lanes_are_the_scalar_ones() {
        let firsts: Vec<[u32; 2]> = (0..16u32)
            .map(|l| [l.wrapping_mul(0x9e37_79b9) | (l % 2) << 31, u32::MAX - 7 * l])
            .collect();
        let small: Vec<[u32; 2]> = (0..16u32).map(|l| [3 * l + 1, 1000 - l]).collect();
        let cases = [(&firsts, [1, 1025]), (&firsts, [2049, 1]), (&small, [1, 1 << 33])];
        for (firsts, strides) in cases {
            for k in 0..8 {
                let mut widths = vec![];
                if std::arch::is_x86_feature_detected!("avx2") {
                    // SAFETY: the CPU has AVX2 (checked above).
                    widths.push((4, unsafe { nodes_four(firsts, k, strides) }));
                }
                if std::arch::is_x86_feature_detected!("avx512f") && std::arch::is_x86_feature_detected!("avx512vl") {
                    // SAFETY: the CPU has AVX-512F and VL (checked above).
                    widths.push((8, unsafe { nodes_eight(firsts, k, strides) }));
                }
                for (lanes, ([i, j], nodes)) in widths.clone() {
                    // Written back as pairs, the values give the same entries.
                    let mut back = firsts.clone();
                    back[k..k + lanes].fill([0, 0]);
                    // SAFETY: as above (the width was only measured where the CPU has it).
                    unsafe { store_back(&mut back, k, lanes, i, j) };
                    assert_eq!(
                        &back[k..k + lanes],
                        &firsts[k..k + lanes],
                        "{lanes} lanes stored back, k {k}"
                    );
                    for l in 0..8 {
                        let ([ei, ej], en) = f64::first_nodes(firsts, k + l, strides);
                        let expected = if l < lanes { (ei, ej, en[0]) } else { (0.0, 0.0, 0) };
                        assert_eq!(
                            (i[l], j[l], nodes[l]),
                            expected,
                            "{lanes} lanes, {strides:?}, k {k}, lane {l}"
                        );
                    }
                }
            }
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn nodes_four(firsts: &[[u32; 2]], k: usize, strides: [usize; 2]) -> ([[f64; 8]; 2], [usize; 8]) {
        let ([i, j], nodes) = super::F64x4::first_nodes(firsts, k, strides);
        ([i.lanes(), j.lanes()], nodes)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512vl")]
    fn nodes_eight(firsts: &[[u32; 2]], k: usize, strides: [usize; 2]) -> ([[f64; 8]; 2], [usize; 8]) {
        let ([i, j], nodes) = super::F64x8::first_nodes(firsts, k, strides);
        ([i.lanes(), j.lanes()], nodes)
    }

    /// [`Real::store_pairs`] of `lanes` (4 or 8) lanes from the values `i`, `j`.
    #[cfg(target_arch = "x86_64")]
    unsafe fn store_back(pairs: &mut [[u32; 2]], k: usize, lanes: usize, i: [f64; 8], j: [f64; 8]) {
        if lanes == 4 {
            store_back_four(pairs, k, i, j)
        } else {
            store_back_eight(pairs, k, i, j)
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn store_back_four(pairs: &mut [[u32; 2]], k: usize, i: [f64; 8], j: [f64; 8]) {
        super::F64x4::store_pairs(super::F64x4::load(&i, 0), super::F64x4::load(&j, 0), pairs, k);
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512vl")]
    fn store_back_eight(pairs: &mut [[u32; 2]], k: usize, i: [f64; 8], j: [f64; 8]) {
        super::F64x8::store_pairs(super::F64x8::load(&i, 0), super::F64x8::load(&j, 0), pairs, k);
    }
}
