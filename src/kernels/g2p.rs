//! (9)–(11): the grid-to-particle pass, and the velocity gradient `L = [Gxᵀ u, Gyᵀ u]` alone.

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

/// The particle loop of [`g2p`] for the particles from `first` (a block), for a support of
/// `S` nodes per axis; the block's kinetic energies.
///
/// A hot kernel, longer than the crate's functions otherwise are: every quantity of (9)–(11)
/// is gathered in one sweep over the particle's stencil, so that each node's packed velocities
/// are read once per particle and the sums stay in registers (splitting it into passes per
/// quantity costs a pass over the grid each; docs/performance.md).
fn g2p_block<const S: usize>(input: &G2pInput, first: usize, out: G2pOutput) -> KineticEnergies {
    let G2pOutput {
        velocity: [vel_x, vel_y],
        affine,
        gradient: grad,
        displacement: [disp_x, disp_y],
    } = out;
    let G2pInput {
        ops,
        packed,
        lo,
        rule,
        dt,
        ..
    } = *input;
    let transfer = rule.transfer;
    let apic = transfer == Transfer::Apic;
    let linear_apic = apic && rule.inertia == ApicInertia::StoredC;
    let with_gradient = rule.gradient.is_some();
    let need_l = with_gradient || linear_apic;
    let trapezoidal = rule.position == PositionUpdate::Trapezoidal;
    let mut kinetic = KineticEnergies::default();
    for j in 0..vel_x.len() {
        let k = first + j;
        let (mut vx, mut vy, mut tx, mut ty, mut rx, mut ry) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        let mut l = [0.0; 4];
        let mut lw = [0.0; 4];
        let mut b = [0.0; 4];
        let st = ops.stencil::<S>(k);
        let offsets = st.offsets(input.x[k], input.y[k]);
        for row in 0..S {
            let (start, n, gxv, gyv) = st.row(row);
            let nodes = &packed[start - lo..start - lo + S];
            let (dxs, dys) = st.run_offsets(&offsets, row);
            for a in 0..S {
                let [wx, wy, v_x, v_y, t_x, t_y, gx, gy] = nodes[a];
                vx += n[a] * wx;
                vy += n[a] * wy;
                tx += n[a] * t_x;
                ty += n[a] * t_y;
                rx += n[a] * v_x;
                ry += n[a] * v_y;
                if need_l {
                    add_gradient(&mut l, gxv[a], gyv[a], gx, gy);
                }
                if apic {
                    add_gradient(&mut lw, gxv[a], gyv[a], wx, wy);
                    let (dx, dy) = (dxs[a], dys[a]);
                    b[0] += n[a] * wx * dx;
                    b[1] += n[a] * wx * dy;
                    b[2] += n[a] * wy * dx;
                    b[3] += n[a] * wy * dy;
                }
            }
        }
        if with_gradient {
            for c in 0..4 {
                grad[c][j] = l[c];
            }
        }
        let (old_x, old_y) = (vel_x[j], vel_y[j]);
        let half_m = 0.5 * input.mass[k];
        kinetic.before += half_m * (old_x * old_x + old_y * old_y);
        kinetic.projected += half_m * (rx * rx + ry * ry);
        kinetic.updated += half_m * (vx * vx + vy * vy);
        let (dvx, dvy) = (vx - rx, vy - ry);
        let (new_x, new_y) = match transfer {
            Transfer::Pic | Transfer::Apic => (vx, vy),
            Transfer::Xpic { .. } | Transfer::Fmpm { .. } => (tx, ty),
            Transfer::Flip => (old_x + dvx, old_y + dvy),
            Transfer::Blend { flip } => (
                flip * (old_x + dvx) + (1.0 - flip) * vx,
                flip * (old_y + dvy) + (1.0 - flip) * vy,
            ),
        };
        vel_x[j] = new_x;
        vel_y[j] = new_y;
        if apic {
            let b = if linear_apic { lw } else { b };
            for c in 0..4 {
                affine[c][j] = b[c];
            }
        }
        let (ux, uy) = match transfer {
            Transfer::Xpic { .. } => (rx + 0.5 * (new_x - old_x), ry + 0.5 * (new_y - old_y)),
            Transfer::Fmpm { .. } => (0.5 * (old_x + new_x), 0.5 * (old_y + new_y)),
            Transfer::Pic | Transfer::Flip | Transfer::Blend { .. } | Transfer::Apic if trapezoidal => {
                (0.5 * (old_x + vx), 0.5 * (old_y + vy))
            }
            Transfer::Pic | Transfer::Flip | Transfer::Blend { .. } | Transfer::Apic => (vx, vy),
        };
        disp_x[j] = dt * ux;
        disp_y[j] = dt * uy;
    }
    kinetic
}
