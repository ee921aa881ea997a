//! (9)–(11): the grid-to-particle pass, and the velocity gradient `L = [Gxᵀ u, Gyᵀ u]` alone.

use super::simd::dispatch;
use super::{ApicInertia, GridField, GridState, KineticEnergies, ParticleScratch};
use crate::fields::VectorField;
use crate::operators::Operators;
use crate::parallel::{Splittable, Workers};
use crate::particles::Particles;
use crate::schemes::{PositionUpdate, Transfer};

/// The velocity gradient of the grid velocity `u` at every particle, into `l`:
///
/// ```text
/// Lxx = Gxᵀ ux,  Lxy = Gyᵀ ux,  Lyx = Gxᵀ uy,  Lyy = Gyᵀ uy
/// ```
///
/// # Panics
/// If `u` does not have one entry per node.
pub fn velocity_gradient_into(ops: &Operators, u: &VectorField, l: &mut [Vec<f64>; 4], workers: &Workers) {
    let np = ops.num_particles();
    assert_eq!(u.len(), ops.num_nodes(), "one velocity per node");
    for c in l.iter_mut() {
        c.resize(np, 0.0);
    }
    let mut none: Vec<()> = Vec::new();
    workers.split_blocks(l.each_mut().map(|c| &mut c[..]), &mut none, |first, out| {
        crate::with_support!(ops, gradient_block::<S>(ops, u, first, out))
    });
}

/// `L += [∂N/∂x u_x, ∂N/∂y u_x; ∂N/∂x u_y, ∂N/∂y u_y]` for one node: the one definition of
/// a node's term of `L = [Gxᵀ u, Gyᵀ u]` (row-major `[xx, xy, yx, yy]`).
#[inline(always)]
fn add_gradient(l: &mut [f64; 4], gx: f64, gy: f64, ux: f64, uy: f64) {
    l[0] += gx * ux;
    l[1] += gy * ux;
    l[2] += gx * uy;
    l[3] += gy * uy;
}

fn gradient_block<const S: usize>(ops: &Operators, u: &VectorField, first: usize, l: [&mut [f64]; 4]) {
    for j in 0..l[0].len() {
        let mut g = [0.0; 4];
        let st = ops.stencil::<S>(first + j);
        for b in 0..S {
            let (start, _, gx, gy) = st.row(b);
            let (ux, uy) = (&u.x[start..start + S], &u.y[start..start + S]);
            for a in 0..S {
                add_gradient(&mut g, gx[a], gy[a], ux[a], uy[a]);
            }
        }
        for c in 0..4 {
            l[c][j] = g[c];
        }
    }
}

/// What [`g2p`] does with the grid velocities.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct G2pRule {
    /// The particle velocity update.
    pub transfer: Transfer,
    /// The position update (XPIC and FMPM use their own).
    pub position: PositionUpdate,
    /// How APIC keeps its moments (read only under [`Transfer::Apic`]; with bilinear kernels,
    /// [`ApicInertia::StoredC`], the particle stores `C_p` itself).
    pub inertia: ApicInertia,
    /// The grid velocity whose gradient to write into the scratch (USL), if any.
    pub gradient: Option<GridField>,
}

/// (9)–(11) in one pass over N, Gx, Gy. With `v_pic = Nᵀ w` and the increment
/// `Δv = Nᵀ (w − v)` (the one FLIP rule, docs/formulation.md):
///
/// ```text
/// PIC, APIC:  v_p ← v_pic        (APIC: B_p ← Σ_I N_I w_I (x_I − x_p)ᵀ; bilinear: C_p ← Gᵀ w)
/// FLIP:       v_p ← v_p + Δv     blend α: α (v_p + Δv) + (1 − α) v_pic
/// XPIC, FMPM: v_p ← Nᵀ v*
/// Δx_p = Δt Nᵀ w   (trapezoidal: (Δt/2)(v_p,old + Nᵀ w); FMPM: (Δt/2)(v_p,old + v_p,new);
///                   XPIC: Δt (Nᵀ v + ½ (v_p,new − v_p,old)))
/// L = [Gxᵀ u, Gyᵀ u]   for u = rule.gradient
/// ```
///
/// The position increments go to `scratch.displacement` (applied after the stress update), the
/// kinetic energies `K_p`, `K(v)`, `K(w)` to `scratch.kinetic`.
pub fn g2p(
    ops: &Operators,
    grid: &GridState,
    rule: &G2pRule,
    dt: f64,
    p: &mut Particles,
    scratch: &mut ParticleScratch,
    workers: &Workers,
) {
    scratch.resize(p.len());
    let span = ops.node_span();
    let transfer = rule.transfer;
    let (w, v) = (&grid.updated, &grid.projected);
    let target = if transfer.series_terms().is_some() {
        &grid.series
    } else {
        w
    };
    let gradient = grid.field(rule.gradient.unwrap_or(GridField::Updated));
    let mut packed = std::mem::take(&mut scratch.packed);
    if packed.capacity() < grid.momentum.len() {
        // Address space for the whole grid, so that a growing span never reallocates.
        packed.reserve_exact(grid.momentum.len() - packed.len());
    }
    packed.clear();
    packed.extend(span.clone().map(|i| {
        [
            w.x[i],
            w.y[i],
            v.x[i],
            v.y[i],
            target.x[i],
            target.y[i],
            gradient.x[i],
            gradient.y[i],
        ]
    }));
    let input = G2pInput {
        ops,
        packed: &packed,
        lo: span.start,
        rule,
        dt,
        x: &p.x,
        y: &p.y,
        mass: &p.mass,
    };
    let out = G2pOutput {
        velocity: [&mut p.vx[..], &mut p.vy[..]],
        affine: [
            &mut p.affine_xx[..],
            &mut p.affine_xy[..],
            &mut p.affine_yx[..],
            &mut p.affine_yy[..],
        ],
        gradient: scratch.velocity_gradient.each_mut().map(|v| &mut v[..]),
        displacement: [&mut scratch.displacement.x[..], &mut scratch.displacement.y[..]],
    };
    let mut blocks = std::mem::take(&mut scratch.kinetic_blocks);
    workers.split_blocks(out, &mut blocks, |first, out| {
        crate::with_support!(ops, g2p_block::<S>(&input, first, out))
    });
    let mut kinetic = KineticEnergies::default();
    for b in &blocks {
        kinetic.before += b.before;
        kinetic.projected += b.projected;
        kinetic.updated += b.updated;
    }
    scratch.kinetic = kinetic;
    scratch.kinetic_blocks = blocks;
    scratch.packed = packed;
}

/// What every block of [`g2p`] reads.
struct G2pInput<'a> {
    ops: &'a Operators,
    /// Grid velocities packed per node from node `lo`.
    packed: &'a [[f64; 8]],
    lo: usize,
    rule: &'a G2pRule,
    dt: f64,
    x: &'a [f64],
    y: &'a [f64],
    mass: &'a [f64],
}

/// What a block of [`g2p`] writes, for its particles: velocities, APIC moments, velocity
/// gradients, position increments.
struct G2pOutput<'a> {
    /// `v_p` (x, y).
    velocity: [&'a mut [f64]; 2],
    /// APIC's `B_p` (or `C_p` for linear kernels), row-major.
    affine: [&'a mut [f64]; 4],
    /// `L_p`, row-major.
    gradient: [&'a mut [f64]; 4],
    /// `Δx_p` (x, y).
    displacement: [&'a mut [f64]; 2],
}

impl Splittable for G2pOutput<'_> {
    fn len(&self) -> usize {
        self.velocity[0].len()
    }
    fn split_at(self, mid: usize) -> (Self, Self) {
        let (v0, v1) = Splittable::split_at(self.velocity, mid);
        let (a0, a1) = Splittable::split_at(self.affine, mid);
        let (g0, g1) = Splittable::split_at(self.gradient, mid);
        let (d0, d1) = Splittable::split_at(self.displacement, mid);
        (
            G2pOutput {
                velocity: v0,
                affine: a0,
                gradient: g0,
                displacement: d0,
            },
            G2pOutput {
                velocity: v1,
                affine: a1,
                gradient: g1,
                displacement: d1,
            },
        )
    }
}

/// What one particle gathers over its stencil: `Nᵀ w`, `Nᵀ v*`, `Nᵀ v`, `L` of the gradient
/// field, `L` of `w` and APIC's `B_p` (the last three when asked for).
#[derive(Clone, Copy, Default)]
struct Gathered {
    w: [f64; 2],
    t: [f64; 2],
    r: [f64; 2],
    l: [f64; 4],
    lw: [f64; 4],
    b: [f64; 4],
}

/// Which of the optional sums of [`Gathered`] a pass forms.
#[derive(Clone, Copy)]
struct Wanted {
    /// `L` of the gradient field (USL).
    l: bool,
    /// `L` of `w` and `B_p`.
    apic: bool,
}

/// Particle `k`'s sums, node by node in stencil order.
#[inline(always)]
fn gather_one<const S: usize>(input: &G2pInput, k: usize, wanted: Wanted) -> Gathered {
    let mut g = Gathered::default();
    let st = input.ops.stencil::<S>(k);
    let offsets = st.offsets(input.x[k], input.y[k]);
    for row in 0..S {
        let (start, n, gxv, gyv) = st.row(row);
        let nodes = &input.packed[start - input.lo..start - input.lo + S];
        let (dxs, dys) = st.run_offsets(&offsets, row);
        for a in 0..S {
            let [wx, wy, v_x, v_y, t_x, t_y, gx, gy] = nodes[a];
            g.w[0] += n[a] * wx;
            g.w[1] += n[a] * wy;
            g.t[0] += n[a] * t_x;
            g.t[1] += n[a] * t_y;
            g.r[0] += n[a] * v_x;
            g.r[1] += n[a] * v_y;
            if wanted.l {
                add_gradient(&mut g.l, gxv[a], gyv[a], gx, gy);
            }
            if wanted.apic {
                add_gradient(&mut g.lw, gxv[a], gyv[a], wx, wy);
                let (dx, dy) = (dxs[a], dys[a]);
                g.b[0] += n[a] * wx * dx;
                g.b[1] += n[a] * wx * dy;
                g.b[2] += n[a] * wy * dx;
                g.b[3] += n[a] * wy * dy;
            }
        }
    }
    g
}

/// [`gather_one`] with the node's fields in 4-wide vectors: the same products and sums, lane by
/// lane, in the same order (so the same bits; see [`super::simd`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn gather_one_avx2<const S: usize>(input: &G2pInput, k: usize, wanted: Wanted) -> Gathered {
    use std::arch::x86_64::*;
    let st = input.ops.stencil::<S>(k);
    let offsets = st.offsets(input.x[k], input.y[k]);
    let z = _mm256_setzero_pd();
    // [w_x, w_y, v_x, v_y], [v*_x, v*_y, ·, ·], L, L of w, B.
    let (mut wv, mut tu, mut l, mut lw, mut b) = (z, z, z, z, z);
    for row in 0..S {
        let (start, n, gxv, gyv) = st.row(row);
        let nodes = &input.packed[start - input.lo..start - input.lo + S];
        let (dxs, dys) = st.run_offsets(&offsets, row);
        for a in 0..S {
            let node = &nodes[a];
            // SAFETY: a node holds 8 values; both loads are in bounds.
            let (lo, hi) = unsafe { (_mm256_loadu_pd(node.as_ptr()), _mm256_loadu_pd(node.as_ptr().add(4))) };
            let nn = _mm256_set1_pd(n[a]);
            wv = _mm256_add_pd(wv, _mm256_mul_pd(nn, lo));
            tu = _mm256_add_pd(tu, _mm256_mul_pd(nn, hi));
            if wanted.l || wanted.apic {
                let gv = _mm256_setr_pd(gxv[a], gyv[a], gxv[a], gyv[a]);
                if wanted.l {
                    // [u_x, u_x, u_y, u_y] of the gradient field.
                    let uu = _mm256_permute4x64_pd::<0b11_11_10_10>(hi);
                    l = _mm256_add_pd(l, _mm256_mul_pd(gv, uu));
                }
                if wanted.apic {
                    let ww = _mm256_permute4x64_pd::<0b01_01_00_00>(lo); // [w_x, w_x, w_y, w_y]
                    lw = _mm256_add_pd(lw, _mm256_mul_pd(gv, ww));
                    let d = _mm256_setr_pd(dxs[a], dys[a], dxs[a], dys[a]);
                    b = _mm256_add_pd(b, _mm256_mul_pd(_mm256_mul_pd(nn, ww), d));
                }
            }
        }
    }
    let mut out = [[0.0; 4]; 5];
    for (slot, v) in out.iter_mut().zip([wv, tu, l, lw, b]) {
        // SAFETY: each slot holds 4 values.
        unsafe { _mm256_storeu_pd(slot.as_mut_ptr(), v) };
    }
    let [wv, tu, l, lw, b] = out;
    Gathered {
        w: [wv[0], wv[1]],
        r: [wv[2], wv[3]],
        t: [tu[0], tu[1]],
        l,
        lw,
        b,
    }
}

dispatch! {
    /// The particle loop of [`g2p`] for the particles from `first` (a block), for a support of
    /// `S` nodes per axis; the block's kinetic energies.
    fn g2p_block / g2p_block_avx2 = g2p_block_body(input: &G2pInput, first: usize, out: G2pOutput) -> KineticEnergies
}

/// What a block of [`g2p`] writes, with the rule's flags: the per-particle update from a
/// particle's sums.
struct Finish<'a> {
    out: G2pOutput<'a>,
    mass: &'a [f64],
    first: usize,
    transfer: Transfer,
    apic: bool,
    linear_apic: bool,
    with_gradient: bool,
    trapezoidal: bool,
    dt: f64,
    kinetic: KineticEnergies,
}

impl Finish<'_> {
    /// Particle `first + j`'s new velocity, APIC moment, velocity gradient, position increment
    /// and kinetic energies from its sums `g`.
    #[inline(always)]
    fn apply(&mut self, j: usize, g: &Gathered) {
        let ([vx, vy], [tx, ty], [rx, ry]) = (g.w, g.t, g.r);
        let out = &mut self.out;
        if self.with_gradient {
            for c in 0..4 {
                out.gradient[c][j] = g.l[c];
            }
        }
        let (old_x, old_y) = (out.velocity[0][j], out.velocity[1][j]);
        let half_m = 0.5 * self.mass[self.first + j];
        self.kinetic.before += half_m * (old_x * old_x + old_y * old_y);
        self.kinetic.projected += half_m * (rx * rx + ry * ry);
        self.kinetic.updated += half_m * (vx * vx + vy * vy);
        let (dvx, dvy) = (vx - rx, vy - ry);
        let (new_x, new_y) = match self.transfer {
            Transfer::Pic | Transfer::Apic => (vx, vy),
            Transfer::Xpic { .. } | Transfer::Fmpm { .. } => (tx, ty),
            Transfer::Flip => (old_x + dvx, old_y + dvy),
            Transfer::Blend { flip } => (
                flip * (old_x + dvx) + (1.0 - flip) * vx,
                flip * (old_y + dvy) + (1.0 - flip) * vy,
            ),
        };
        out.velocity[0][j] = new_x;
        out.velocity[1][j] = new_y;
        if self.apic {
            let b = if self.linear_apic { g.lw } else { g.b };
            for c in 0..4 {
                out.affine[c][j] = b[c];
            }
        }
        let (ux, uy) = match self.transfer {
            Transfer::Xpic { .. } => (rx + 0.5 * (new_x - old_x), ry + 0.5 * (new_y - old_y)),
            Transfer::Fmpm { .. } => (0.5 * (old_x + new_x), 0.5 * (old_y + new_y)),
            Transfer::Pic | Transfer::Flip | Transfer::Blend { .. } | Transfer::Apic if self.trapezoidal => {
                (0.5 * (old_x + vx), 0.5 * (old_y + vy))
            }
            Transfer::Pic | Transfer::Flip | Transfer::Blend { .. } | Transfer::Apic => (vx, vy),
        };
        out.displacement[0][j] = self.dt * ux;
        out.displacement[1][j] = self.dt * uy;
    }
}

/// The body of [`g2p_block`]: each particle's sums ([`gather_one`], or its AVX2 form), then its
/// update from them.
#[inline(always)]
fn g2p_block_body<const S: usize, const AVX2: bool>(input: &G2pInput, first: usize, out: G2pOutput) -> KineticEnergies {
    let G2pInput { rule, dt, .. } = *input;
    let transfer = rule.transfer;
    let apic = transfer == Transfer::Apic;
    let with_gradient = rule.gradient.is_some();
    let wanted = Wanted { l: with_gradient, apic };
    let np = out.len();
    let mut finish = Finish {
        out,
        mass: input.mass,
        first,
        transfer,
        apic,
        linear_apic: apic && rule.inertia == ApicInertia::StoredC,
        with_gradient,
        trapezoidal: rule.position == PositionUpdate::Trapezoidal,
        dt,
        kinetic: KineticEnergies::default(),
    };
    #[cfg(target_arch = "x86_64")]
    debug_assert!(!AVX2 || std::arch::is_x86_feature_detected!("avx2"));
    for j in 0..np {
        let g = if AVX2 {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: the AVX2 instance runs only where the CPU has AVX2 (`dispatch!`).
            unsafe {
                gather_one_avx2::<S>(input, first + j, wanted)
            }
            #[cfg(not(target_arch = "x86_64"))]
            gather_one::<S>(input, first + j, wanted)
        } else {
            gather_one::<S>(input, first + j, wanted)
        };
        finish.apply(j, &g);
    }
    finish.kinetic
}
