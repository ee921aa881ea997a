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
pub(super) fn fill_local_avx2(block: &LocalBlock, firsts: &mut [[u32; 2]], t: [&mut [f64]; 2]) -> BlockSpan {
    fill_local_body::<4>(block, firsts, t)
}

/// [`fill_local_body`] compiled for AVX-512F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl")]
pub(super) fn fill_local_avx512(block: &LocalBlock, firsts: &mut [[u32; 2]], t: [&mut [f64]; 2]) -> BlockSpan {
    fill_local_body::<8>(block, firsts, t)
}

/// One block of [`Operators::fill_local`]: `V` particles at a time (eight in the AVX-512 build,
/// four in the AVX2 build; [`AxisFrame::locate_lanes`], the same numbers as the scalar
/// [`AxisFrame::locate`]), then one at a time; the lowest and highest first node and index
/// along the lines, whether a stencil is shifted, whether a weight may be zero.
#[inline(always)]
pub(super) fn fill_local_body<const V: usize>(
    block: &LocalBlock,
    firsts: &mut [[u32; 2]],
    [tx, ty]: [&mut [f64]; 2],
) -> BlockSpan {
    let n = firsts.len();
    let mut acc = LocalSums {
        lo: f64::INFINITY,
        hi: 0.0,
        along: [f64::INFINITY, 0.0],
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
    BlockSpan {
        lo: acc.lo as usize,
        hi: acc.hi as usize,
        along: [acc.along[0] as usize, acc.along[1] as usize],
        shifted: acc.shifted,
        zero: acc.zero,
    }
}

/// What the assembly found over a block of particles: the lowest and highest first node, the
/// lowest and highest first node's index along the grid lines, whether a stencil is shifted
/// and whether a weight may be zero.
#[derive(Debug, Clone, Copy)]
pub(super) struct BlockSpan {
    pub(super) lo: usize,
    pub(super) hi: usize,
    pub(super) along: [usize; 2],
    pub(super) shifted: bool,
    pub(super) zero: bool,
}

impl Default for BlockSpan {
    /// Nothing found: the identity of [`BlockSpan::join`].
    fn default() -> Self {
        BlockSpan {
            lo: usize::MAX,
            hi: 0,
            along: [usize::MAX, 0],
            shifted: false,
            zero: false,
        }
    }
}

impl BlockSpan {
    /// One stencil's, from its first node's grid indices `i`, `j` and the node strides.
    pub(super) fn of_first(i: usize, j: usize, [sx, sy]: [usize; 2]) -> BlockSpan {
        let (node, along) = (i * sx + j * sy, if sx == 1 { i } else { j });
        BlockSpan {
            lo: node,
            hi: node,
            along: [along, along],
            shifted: false,
            zero: false,
        }
    }

    /// What two blocks found together.
    pub(super) fn join(self, other: BlockSpan) -> BlockSpan {
        BlockSpan {
            lo: self.lo.min(other.lo),
            hi: self.hi.max(other.hi),
            along: [self.along[0].min(other.along[0]), self.along[1].max(other.along[1])],
            shifted: self.shifted | other.shifted,
            zero: self.zero | other.zero,
        }
    }
}

/// What [`fill_local_body`] gathers over a block.
struct LocalSums {
    lo: f64,
    hi: f64,
    along: [f64; 2],
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
    // The index along the lines: along x when x has the unit stride.
    let along = if block.strides[0] == 1.0 { fx } else { fy };
    for l in 0..R::LANES {
        (acc.lo, acc.hi) = (acc.lo.min(node[l]), acc.hi.max(node[l]));
        acc.along = [acc.along[0].min(along[l]), acc.along[1].max(along[l])];
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
