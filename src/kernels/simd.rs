//! The transfers' explicit SIMD: an AVX2 build of the per-particle sums of [`super::p2g`] and
//! [`super::g2p`], chosen at run time.
//!
//! Each particle's sums over its stencil are vectorised across the fields a node carries: a
//! gather reads a node's packed velocities `[w, v]` and `[v*, u]` as two 4-wide vectors and
//! forms `N w`, `N v`, `N v*`, the velocity gradient, `∇N w` and APIC's `N w (x_I − x_p)` in
//! five vector products; a scatter forms a node's `[m, q_x, q_y, f_x]` in one vector (and
//! `f_y` beside it). The baseline build runs the scalar loops.
//!
//! **The same bits.** The AVX2 code performs, lane by lane, the scalar code's multiplications
//! and additions in the scalar code's order (no fused multiply-add: Rust never contracts
//! `a·b + c` unless asked, and the intrinsics used are plain `mul`/`add`), and a node's
//! contributions still arrive in particle order: the two builds give identical results on any
//! machine and for any thread count (`tests/simd.rs`), for runs without NaN (a NaN's payload
//! bits are not specified by the compiler in either build).

use std::sync::atomic::{AtomicBool, Ordering};

static SCALAR: AtomicBool = AtomicBool::new(false);

/// Chooses the scalar build of the transfers (`true`) or the AVX2 build where the CPU has it
/// (`false`, the default) for the whole process. The results are the same bits either way: this
/// changes speed only (for benchmarks: `mpm bench --scalar-kernels`).
pub fn set_scalar_kernels(scalar: bool) {
    SCALAR.store(scalar, Ordering::Relaxed);
}

/// Whether the vectorised build may run ([`set_scalar_kernels`]).
#[inline]
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
pub(crate) fn vectorised() -> bool {
    !SCALAR.load(Ordering::Relaxed)
}

/// Whether the AVX2 build of the kernels runs: the CPU has AVX2 and it is not switched off.
#[inline]
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
pub(crate) fn avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        vectorised() && std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Declares `$name`, which runs `$body::<S, true>` from a copy compiled for AVX2 when [`avx2`]
/// says so and `$body::<S, false>` from the baseline build otherwise (see the note on bits).
macro_rules! dispatch {
    ($(#[$doc:meta])* fn $name:ident / $avx:ident = $body:ident ( $($arg:ident : $ty:ty),* ) -> $ret:ty) => {
        $(#[$doc])*
        fn $name<const S: usize>($($arg: $ty),*) -> $ret {
            #[cfg(target_arch = "x86_64")]
            if $crate::kernels::simd::avx2() {
                // SAFETY: the CPU has AVX2, checked at run time just above.
                return unsafe { $avx::<S>($($arg),*) };
            }
            $body::<S, false>($($arg),*)
        }

        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2")]
        unsafe fn $avx<const S: usize>($($arg: $ty),*) -> $ret {
            $body::<S, true>($($arg),*)
        }
    };
}
pub(crate) use dispatch;

/// Four particles side by side, one per lane of a 4-wide vector: the transposed factored
/// columns, the offsets to their nodes and their first nodes, for the across-particle forms of
/// the transfers.
#[cfg(target_arch = "x86_64")]
pub(crate) mod four {
    use crate::operators::Operators;
    use std::arch::x86_64::*;

    /// Particles `k … k + 3`, for a support of `S ≤ 4` nodes per axis.
    pub(crate) struct Four {
        /// `wx[a]`, `w′x[a]`, `wy[a]`, `w′y[a]` with one particle per lane.
        pub wx: [__m256d; 4],
        pub dwx: [__m256d; 4],
        pub wy: [__m256d; 4],
        pub dwy: [__m256d; 4],
        /// `x_{i0+a} − x_p` and `y_{j0+a} − y_p` per lane (as `Stencil::offsets`).
        pub dx: [__m256d; 4],
        pub dy: [__m256d; 4],
        /// Each lane's first node.
        pub first: [usize; 4],
        /// Node-number distance between runs, and whether runs go along x.
        pub run_stride: usize,
        pub runs_along_x: bool,
    }

    /// `[r0, r1, r2, r3]` (rows) to its columns: lane `l` of column `c` is lane `c` of row `l`.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) fn transpose(r: [__m256d; 4]) -> [__m256d; 4] {
        let t0 = _mm256_unpacklo_pd(r[0], r[1]);
        let t1 = _mm256_unpackhi_pd(r[0], r[1]);
        let t2 = _mm256_unpacklo_pd(r[2], r[3]);
        let t3 = _mm256_unpackhi_pd(r[2], r[3]);
        [
            _mm256_permute2f128_pd::<0x20>(t0, t2),
            _mm256_permute2f128_pd::<0x20>(t1, t3),
            _mm256_permute2f128_pd::<0x31>(t0, t2),
            _mm256_permute2f128_pd::<0x31>(t1, t3),
        ]
    }

    /// Four consecutive values from `values[k]` in one vector.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) fn load(values: &[f64], k: usize) -> __m256d {
        let v = &values[k..k + 4];
        // SAFETY: `v` holds 4 values.
        unsafe { _mm256_loadu_pd(v.as_ptr()) }
    }

    /// A vector's lanes.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) fn lanes(v: __m256d) -> [f64; 4] {
        let mut out = [0.0; 4];
        // SAFETY: `out` holds 4 values.
        unsafe { _mm256_storeu_pd(out.as_mut_ptr(), v) };
        out
    }

    /// Particles `k … k + 3` of `ops` at positions `x`, `y`.
    ///
    /// # Panics
    /// If `k + 4` exceeds the particle count or `S` is not the support (or exceeds 4).
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) fn four<const S: usize>(ops: &Operators, x: &[f64], y: &[f64], k: usize) -> Four {
        let st = ops.stencil::<S>(k);
        let f = ops.factors_block(k, 4);
        let per = 4 * S;
        // Column c of the transposed block is factor c of each lane.
        let mut cols = [_mm256_setzero_pd(); 16];
        for c in 0..S {
            let rows: [__m256d; 4] = std::array::from_fn(|l| {
                let r = &f[l * per + 4 * c..l * per + 4 * c + 4];
                // SAFETY: `r` holds 4 values.
                unsafe { _mm256_loadu_pd(r.as_ptr()) }
            });
            let t = transpose(rows);
            cols[4 * c..4 * c + 4].copy_from_slice(&t);
        }
        let pick = |offset: usize| -> [__m256d; 4] {
            std::array::from_fn(|a| if a < S { cols[offset + a] } else { _mm256_setzero_pd() })
        };
        let firsts = &ops.first_nodes()[k..k + 4];
        let [sx, sy] = ops.strides();
        let ([ox, oy], [hx, hy]) = (st.origin, st.cell_size);
        let (xp, yp) = (load(x, k), load(y, k));
        let at = |origin: f64, h: f64, axis: usize, a: usize, p: __m256d| {
            let i = |l: usize| (firsts[l][axis] as usize + a) as f64;
            let node = _mm256_add_pd(
                _mm256_set1_pd(origin),
                _mm256_mul_pd(_mm256_setr_pd(i(0), i(1), i(2), i(3)), _mm256_set1_pd(h)),
            );
            _mm256_sub_pd(node, p)
        };
        Four {
            wx: pick(0),
            dwx: pick(S),
            wy: pick(2 * S),
            dwy: pick(3 * S),
            dx: std::array::from_fn(|a| at(ox, hx, 0, a, xp)),
            dy: std::array::from_fn(|a| at(oy, hy, 1, a, yp)),
            first: std::array::from_fn(|l| firsts[l][0] as usize * sx + firsts[l][1] as usize * sy),
            run_stride: st.run_stride,
            runs_along_x: st.runs_along_x,
        }
    }
}
