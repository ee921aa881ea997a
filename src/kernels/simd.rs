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
    ($(#[$doc:meta])* fn $name:ident $(<const $c:ident : usize>)? / $avx:ident = $body:ident ( $($arg:ident : $ty:ty),* ) -> $ret:ty) => {
        $(#[$doc])*
        fn $name<const S: usize $(, const $c: usize)?>($($arg: $ty),*) -> $ret {
            #[cfg(target_arch = "x86_64")]
            if $crate::kernels::simd::avx2() {
                // SAFETY: the CPU has AVX2, checked at run time just above.
                return unsafe { $avx::<S $(, $c)?>($($arg),*) };
            }
            $body::<S $(, $c)?, false>($($arg),*)
        }

        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2")]
        unsafe fn $avx<const S: usize $(, const $c: usize)?>($($arg: $ty),*) -> $ret {
            $body::<S $(, $c)?, true>($($arg),*)
        }
    };
}
pub(crate) use dispatch;
