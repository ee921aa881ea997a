//! Adding the particle-to-grid terms of a group of particles to the grid's accumulator, lane
//! after lane so that every node receives its terms in particle order ([`super::p2g`]).

use super::columns::Columns;
#[cfg(target_arch = "x86_64")]
use crate::lanes::F64x4;
use crate::lanes::Real;

/// Adding a group's terms to the grid.
pub(super) trait Scatter: Real {
    /// Adds each lane's terms of run `b` (from [`Group::run`]) to its nodes, lane after lane.
    fn scatter_run<const S: usize>(
        terms: &[[Self; 5]; S],
        cols: &Columns<Self, S>,
        b: usize,
        acc: &mut [[f64; 5]],
        base: usize,
    );
    /// Adds each lane's terms of every run to its nodes, lane after lane (particle order).
    fn scatter_lanes<const S: usize>(
        terms: &[[[Self; 5]; S]; S],
        cols: &Columns<Self, S>,
        acc: &mut [[f64; 5]],
        base: usize,
    );
}

impl Scatter for f64 {
    #[inline(always)]
    fn scatter_run<const S: usize>(
        terms: &[[f64; 5]; S],
        cols: &Columns<f64, S>,
        b: usize,
        acc: &mut [[f64; 5]],
        base: usize,
    ) {
        let start = cols.run_start(0, b) - base;
        let r = &mut acc[start..start + S];
        for a in 0..S {
            for c in 0..5 {
                r[a][c] += terms[a][c];
            }
        }
    }

    #[inline(always)]
    fn scatter_lanes<const S: usize>(
        terms: &[[[f64; 5]; S]; S],
        cols: &Columns<f64, S>,
        acc: &mut [[f64; 5]],
        base: usize,
    ) {
        for b in 0..S {
            f64::scatter_run(&terms[b], cols, b, acc, base);
        }
    }
}

#[cfg(target_arch = "x86_64")]
impl F64x4 {
    /// Lane `l`'s `[m, q_x, q_y, f_x]` at each node of a run, one vector per node (a 4 × 4
    /// transpose), and its `f_y`.
    #[inline(always)]
    pub(super) fn lane_terms<const S: usize>(
        terms: &[[F64x4; 5]; S],
    ) -> ([[std::arch::x86_64::__m256d; 4]; S], [[f64; 4]; S]) {
        let mut quads = [[F64x4::splat(0.0).0; 4]; S];
        let mut fy = [[0.0; 4]; S];
        for a in 0..S {
            let t = &terms[a];
            quads[a] = transpose([t[0].0, t[1].0, t[2].0, t[3].0]);
            let l = t[4].lanes();
            fy[a] = [l[0], l[1], l[2], l[3]];
        }
        (quads, fy)
    }

    /// Adds lane `l`'s terms to the nodes of run `b` from node `start` (relative to `base`).
    #[inline(always)]
    pub(super) fn add_run<const S: usize>(
        quads: &[[std::arch::x86_64::__m256d; 4]; S],
        fy: &[[f64; 4]; S],
        l: usize,
        start: usize,
        acc: &mut [[f64; 5]],
    ) {
        use std::arch::x86_64::*;
        let r = &mut acc[start..start + S];
        for a in 0..S {
            let node = &mut r[a];
            // SAFETY: a node's accumulator holds 5 values; the load and store take the first
            // 4. F64x4 runs only where the CPU has AVX2.
            unsafe {
                let sum = _mm256_add_pd(_mm256_loadu_pd(node.as_ptr()), quads[a][l]);
                _mm256_storeu_pd(node.as_mut_ptr(), sum);
            }
            node[4] += fy[a][l];
        }
    }
}

#[cfg(target_arch = "x86_64")]
impl Scatter for F64x4 {
    #[inline(always)]
    fn scatter_run<const S: usize>(
        terms: &[[F64x4; 5]; S],
        cols: &Columns<F64x4, S>,
        b: usize,
        acc: &mut [[f64; 5]],
        base: usize,
    ) {
        let (quads, fy) = F64x4::lane_terms(terms);
        for l in 0..4 {
            F64x4::add_run(&quads, &fy, l, cols.run_start(l, b) - base, acc);
        }
    }

    #[inline(always)]
    fn scatter_lanes<const S: usize>(
        terms: &[[[F64x4; 5]; S]; S],
        cols: &Columns<F64x4, S>,
        acc: &mut [[f64; 5]],
        base: usize,
    ) {
        let at = [cols.first[0], cols.first[1], cols.first[2], cols.first[3]];
        F64x4::scatter_lanes_at(terms, at, cols.run_stride, acc, base);
    }
}

#[cfg(target_arch = "x86_64")]
impl F64x4 {
    /// [`Scatter::scatter_lanes`] for lanes whose stencils start at nodes `first`, runs
    /// `run_stride` nodes apart.
    #[inline(always)]
    pub(super) fn scatter_lanes_at<const S: usize>(
        terms: &[[[F64x4; 5]; S]; S],
        first: [usize; 4],
        run_stride: usize,
        acc: &mut [[f64; 5]],
        base: usize,
    ) {
        let mut quads = [[[F64x4::splat(0.0).0; 4]; S]; S];
        let mut fy = [[[0.0; 4]; S]; S];
        for b in 0..S {
            (quads[b], fy[b]) = F64x4::lane_terms(&terms[b]);
        }
        for l in 0..4 {
            for b in 0..S {
                F64x4::add_run(&quads[b], &fy[b], l, first[l] + b * run_stride - base, acc);
            }
        }
    }
}

/// `[r0, r1, r2, r3]` (rows) to its columns: lane `l` of column `c` is lane `c` of row `l`.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(super) fn transpose(r: [std::arch::x86_64::__m256d; 4]) -> [std::arch::x86_64::__m256d; 4] {
    use std::arch::x86_64::*;
    // SAFETY: called only from the AVX2 build (F64x4).
    unsafe {
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
}
