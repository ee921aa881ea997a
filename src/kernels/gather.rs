//! The gathers of the grid-to-particle pass: each particle's sums over its stencil of the
//! packed grid velocities, for one particle or several side by side ([`Real`]).

use super::columns::Columns;
use super::g2p::Packed;
use crate::lanes::Real;
#[cfg(target_arch = "x86_64")]
use crate::lanes::{F64x4, F64x8};

/// What the particles of a group gather over their stencils: `Nᵀ w`, `Nᵀ v*`, `Nᵀ v`, `L` of the
/// gradient field, `L` of `w` and APIC's `B_p` (the last three when asked for).
#[derive(Clone, Copy)]
pub(super) struct Gathered<R> {
    pub(super) w: [R; 2],
    pub(super) t: [R; 2],
    pub(super) r: [R; 2],
    pub(super) l: [R; 4],
    pub(super) lw: [R; 4],
    pub(super) b: [R; 4],
}

/// Which of the optional sums of [`Gathered`] a pass forms.
#[derive(Clone, Copy)]
pub(super) struct Wanted {
    /// `L` of the gradient field.
    pub(super) l: bool,
    /// `L` of `w` and `B_p`.
    pub(super) apic: bool,
}

/// Reading a node's packed velocities for every lane.
pub(super) trait Gather: Real {
    /// `packed[at_l + c]` for `c < W` in lane `l`.
    ///
    /// # Safety
    /// `at_l + W ≤ packed.len()` for every lane `l < LANES`.
    unsafe fn gather<const W: usize>(packed: &[f64], at: [usize; 8]) -> [Self; W];
}

impl Gather for f64 {
    #[inline(always)]
    unsafe fn gather<const W: usize>(packed: &[f64], at: [usize; 8]) -> [f64; W] {
        let mut out = [0.0; W];
        for (c, o) in out.iter_mut().enumerate() {
            // SAFETY: in bounds by the caller's contract.
            *o = unsafe { *packed.get_unchecked(at[0] + c) };
        }
        out
    }
}

#[cfg(target_arch = "x86_64")]
impl Gather for F64x4 {
    /// Each lane's node as 4-wide rows (one or two per node), transposed into lanes.
    #[inline(always)]
    unsafe fn gather<const W: usize>(packed: &[f64], at: [usize; 8]) -> [F64x4; W] {
        use std::arch::x86_64::*;
        let mut out = [F64x4::splat(0.0); W];
        let base = packed.as_ptr();
        for half in 0..W / 4 {
            // SAFETY: each row is in bounds by the caller's contract; F64x4 runs only where the
            // CPU has AVX2.
            let row = |l: usize| unsafe { _mm256_loadu_pd(base.add(at[l] + 4 * half)) };
            let t = super::scatter::transpose([row(0), row(1), row(2), row(3)]);
            for c in 0..4 {
                out[4 * half + c] = F64x4(t[c]);
            }
        }
        out
    }
}

#[cfg(target_arch = "x86_64")]
impl Gather for F64x8 {
    /// Four values at a time ([`gather_four`]; a node holds 4 or 8).
    #[inline(always)]
    unsafe fn gather<const W: usize>(packed: &[f64], at: [usize; 8]) -> [F64x8; W] {
        debug_assert!(W.is_multiple_of(4), "packed nodes hold 4 or 8 values");
        let mut out = [F64x8::splat(0.0); W];
        for half in 0..W / 4 {
            let mut from = at;
            for a in from.iter_mut() {
                *a += 4 * half;
            }
            // SAFETY: the caller's contract covers every lane's W values.
            let four = unsafe { gather_four(packed, from) };
            out[4 * half..4 * half + 4].copy_from_slice(&four);
        }
        out
    }
}

/// The sums of the particles of `cols` over their stencils, factored along the runs: with `α`
/// the axis along a run and `β` across, node `(a, b)` has `N = wα_a wβ_b`, and each sum over the
/// stencil is a sum over the runs of a sum along each run,
///
/// ```text
/// Nᵀu = Σ_b wβ_b (Σ_a wα_a u_ab),    (∂N/∂α)ᵀu = Σ_b wβ_b (Σ_a w′α_a u_ab),
/// (∂N/∂β)ᵀu = Σ_b w′β_b (Σ_a wα_a u_ab),
/// Σ N u dα = Σ_b wβ_b (Σ_a wα_a dα_a u_ab),    Σ N u dβ = Σ_b wβ_b dβ_b (Σ_a wα_a u_ab)
/// ```
///
/// (`dα`, `dβ` the offsets `x_I − x_p`), in stencil order.
#[inline(always)]
pub(super) fn gather_sums<R: Gather, const S: usize, const W: usize>(
    cols: &Columns<R, S>,
    packed: Packed,
    lo: usize,
    layers: [usize; 8],
    wanted: Wanted,
) -> Gathered<R> {
    let Packed {
        values: packed, stride, ..
    } = packed;
    debug_assert!(stride >= W, "a node holds the values read");
    let z = R::splat(0.0);
    let (wa, dwa, da, wb, dwb, db) = (&cols.wa, &cols.dwa, &cols.da, &cols.wb, &cols.dwb, &cols.db);
    let gradient_of_w = wanted.apic || (W == 4 && wanted.l);
    let mut wda = [z; S];
    if wanted.apic {
        for a in 0..S {
            wda[a] = wa[a] * da[a];
        }
    }
    // Each lane's first packed value, and the stencil's reach from there, checked once.
    let mut at = [0; 8];
    for (l, at) in at.iter_mut().enumerate().take(R::LANES) {
        *at = layers[l] + stride * (cols.first[l] - lo);
    }
    let reach = stride * ((S - 1) * cols.run_stride + S - 1) + W;
    assert!(
        at[..R::LANES].iter().all(|&a| a + reach <= packed.len()),
        "a stencil reaches past the packed grid velocities"
    );
    // Nᵀw, Nᵀv, Nᵀv*; ∂/∂α and ∂/∂β of w and of the gradient field; Σ N w dα, Σ N w dβ.
    let (mut w, mut r, mut t) = ([z; 2], [z; 2], [z; 2]);
    let (mut lw_a, mut lw_b, mut lg_a, mut lg_b, mut b_a, mut b_b) = ([z; 2], [z; 2], [z; 2], [z; 2], [z; 2], [z; 2]);
    for b in 0..S {
        // Sums along run b: wα u for w, v, v*, u; w′α u for w and u; wα dα w.
        let (mut aw, mut av, mut at_, mut ag) = ([z; 2], [z; 2], [z; 2], [z; 2]);
        let (mut dw, mut dg, mut xw) = ([z; 2], [z; 2], [z; 2]);
        for a in 0..S {
            let offset = stride * (b * cols.run_stride + a);
            // SAFETY: every lane's node of the stencil is in bounds (checked above).
            let mut node = at;
            for n in node.iter_mut().take(R::LANES) {
                *n += offset;
            }
            let u = unsafe { R::gather::<W>(packed, node) };
            for c in 0..2 {
                aw[c] = wa[a].mul_add(u[c], aw[c]);
                av[c] = wa[a].mul_add(u[2 + c], av[c]);
                if W == 8 {
                    at_[c] = wa[a].mul_add(u[4 + c], at_[c]);
                    if wanted.l {
                        ag[c] = wa[a].mul_add(u[6 + c], ag[c]);
                        dg[c] = dwa[a].mul_add(u[6 + c], dg[c]);
                    }
                }
                if gradient_of_w {
                    dw[c] = dwa[a].mul_add(u[c], dw[c]);
                }
                if wanted.apic {
                    xw[c] = wda[a].mul_add(u[c], xw[c]);
                }
            }
        }
        let wdb = wb[b] * db[b];
        for c in 0..2 {
            w[c] = wb[b].mul_add(aw[c], w[c]);
            r[c] = wb[b].mul_add(av[c], r[c]);
            if W == 8 {
                t[c] = wb[b].mul_add(at_[c], t[c]);
                if wanted.l {
                    lg_a[c] = wb[b].mul_add(dg[c], lg_a[c]);
                    lg_b[c] = dwb[b].mul_add(ag[c], lg_b[c]);
                }
            }
            if gradient_of_w {
                lw_a[c] = wb[b].mul_add(dw[c], lw_a[c]);
                lw_b[c] = dwb[b].mul_add(aw[c], lw_b[c]);
            }
            if wanted.apic {
                b_a[c] = wb[b].mul_add(xw[c], b_a[c]);
                b_b[c] = wdb.mul_add(aw[c], b_b[c]);
            }
        }
    }
    // Rows of L (`[∂/∂x, ∂/∂y]` of each component) and of B (`[dx, dy]`) from (α, β).
    let xy = |along: [R; 2], across: [R; 2]| {
        let (x, y) = cols.xy(along, across);
        [x[0], y[0], x[1], y[1]]
    };
    let lw = xy(lw_a, lw_b);
    if W == 4 {
        // The target and the gradient field are w itself.
        t = w;
    }
    Gathered {
        w,
        t,
        r,
        l: if W == 4 { lw } else { xy(lg_a, lg_b) },
        lw,
        b: xy(b_a, b_b),
    }
}

/// The four values from each lane's `packed[at_l ..]` in lanes, with 512-bit shuffles: rows
/// `l` and `l + 4` side by side in one register, pairs interleaved within each 128-bit part,
/// then each value's eight lanes picked from two registers.
///
/// # Safety
/// `at_l + 4 ≤ packed.len()` for every lane; the CPU has AVX-512F.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn gather_four(packed: &[f64], at: [usize; 8]) -> [F64x8; 4] {
    use std::arch::x86_64::*;
    let base = packed.as_ptr();
    // SAFETY: every row is in bounds by the caller's contract; AVX-512F as the caller says.
    unsafe {
        let row = |l: usize| _mm256_loadu_pd(base.add(at[l]));
        let pair = |l: usize| _mm512_insertf64x4::<1>(_mm512_castpd256_pd512(row(l)), row(l + 4));
        let (z0, z1, z2, z3) = (pair(0), pair(1), pair(2), pair(3));
        // [r0.0, r1.0, r0.2, r1.2 | r4.0, r5.0, r4.2, r5.2] and the like.
        let (t0, t1) = (_mm512_unpacklo_pd(z0, z1), _mm512_unpackhi_pd(z0, z1));
        let (t2, t3) = (_mm512_unpacklo_pd(z2, z3), _mm512_unpackhi_pd(z2, z3));
        // Lanes 0–7 of values 0 and 2 from (t0, t2), of values 1 and 3 from (t1, t3).
        let even = _mm512_setr_epi64(0, 1, 8, 9, 4, 5, 12, 13);
        let odd = _mm512_setr_epi64(2, 3, 10, 11, 6, 7, 14, 15);
        [
            F64x8(_mm512_permutex2var_pd(t0, even, t2)),
            F64x8(_mm512_permutex2var_pd(t1, even, t3)),
            F64x8(_mm512_permutex2var_pd(t0, odd, t2)),
            F64x8(_mm512_permutex2var_pd(t1, odd, t3)),
        ]
    }
}
