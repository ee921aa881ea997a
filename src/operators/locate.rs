//! Locating particles in the grid for [`Operators::fill_local`](super::Operators): each
//! particle's first node and kernel coordinate along x and y, a block of particles at a time
//! (eight or four lanes where the CPU has them, the same numbers as the scalar path).

use crate::lanes::Real;
use crate::shape::AxisFrame;

/// What [`Operators::fill_local`] reads for one block of particles.
pub(super) struct LocalBlock<'a> {
    pub(super) frames: [AxisFrame; 2],
    /// Node-number strides along x and y, as floats (exact).
    pub(super) strides: [f64; 2],
    pub(super) x: &'a [f64],
    pub(super) y: &'a [f64],
}

/// [`fill_local_body`] compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub(super) fn fill_local_avx2(
    block: &LocalBlock,
    firsts: &mut [[u32; 2]],
    t: [&mut [f64]; 2],
) -> (usize, usize, bool, bool) {
    fill_local_body::<4>(block, firsts, t)
}

/// [`fill_local_body`] compiled for AVX-512F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl")]
pub(super) fn fill_local_avx512(
    block: &LocalBlock,
    firsts: &mut [[u32; 2]],
    t: [&mut [f64]; 2],
) -> (usize, usize, bool, bool) {
    fill_local_body::<8>(block, firsts, t)
}

/// One block of [`Operators::fill_local`]: `V` particles at a time (eight in the AVX-512 build,
/// four in the AVX2 build; [`AxisFrame::locate_lanes`], the same numbers as the scalar
/// [`AxisFrame::locate`]), then one at a time; the lowest and highest first node, whether a
/// stencil is shifted, whether a weight may be zero.
#[inline(always)]
pub(super) fn fill_local_body<const V: usize>(
    block: &LocalBlock,
    firsts: &mut [[u32; 2]],
    [tx, ty]: [&mut [f64]; 2],
) -> (usize, usize, bool, bool) {
    let n = firsts.len();
    let mut acc = LocalSums {
        lo: f64::INFINITY,
        hi: 0.0,
        shifted: false,
        zero: false,
    };
    let mut j = 0;
    #[cfg(target_arch = "x86_64")]
    {
        while V >= 8 && j + 8 <= n {
            locate_into::<crate::lanes::F64x8>(block, j, firsts, [&mut *tx, &mut *ty], &mut acc);
            j += 8;
        }
        while V >= 4 && j + 4 <= n {
            locate_into::<crate::lanes::F64x4>(block, j, firsts, [&mut *tx, &mut *ty], &mut acc);
            j += 4;
        }
    }
    while j < n {
        locate_into::<f64>(block, j, firsts, [&mut *tx, &mut *ty], &mut acc);
        j += 1;
    }
    (acc.lo as usize, acc.hi as usize, acc.shifted, acc.zero)
}

/// What [`fill_local_body`] gathers over a block.
struct LocalSums {
    lo: f64,
    hi: f64,
    shifted: bool,
    zero: bool,
}

/// Particles `j …` of a block: their first nodes and `t` written, the sums updated.
#[inline(always)]
fn locate_into<R: Real>(
    block: &LocalBlock,
    j: usize,
    firsts: &mut [[u32; 2]],
    [tx, ty]: [&mut [f64]; 2],
    acc: &mut LocalSums,
) {
    let (f, t, shifted, zero) = locate_group::<R>(block, j);
    let node = (f[0] * R::splat(block.strides[0]) + f[1] * R::splat(block.strides[1])).lanes();
    let (fx, fy) = (f[0].lanes(), f[1].lanes());
    for l in 0..R::LANES {
        (acc.lo, acc.hi) = (acc.lo.min(node[l]), acc.hi.max(node[l]));
        firsts[j + l] = [fx[l] as u32, fy[l] as u32];
    }
    (acc.shifted, acc.zero) = (acc.shifted | shifted, acc.zero | zero);
    t[0].store(tx, j);
    t[1].store(ty, j);
}

/// Particles `j …` of a block: first node and `t` along x and y, shifted, zero weight.
#[inline(always)]
fn locate_group<R: crate::lanes::Real>(block: &LocalBlock, j: usize) -> ([R; 2], [R; 2], bool, bool) {
    let [fx, fy] = &block.frames;
    let (_, first_x, t_x, shifted_x, zero_x) = fx.locate_lanes(R::load(block.x, j));
    let (_, first_y, t_y, shifted_y, zero_y) = fy.locate_lanes(R::load(block.y, j));
    ([first_x, first_y], [t_x, t_y], shifted_x | shifted_y, zero_x | zero_y)
}
