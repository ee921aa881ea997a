//! (9)–(11): the grid-to-particle pass, and the velocity gradient `L = [Gxᵀ u, Gyᵀ u]` alone.
//!
//! Both are written once for one particle and for four side by side ([`Real`]): the AVX2 build
//! runs four particles per 4-wide vector (their grid velocities gathered node by node and
//! transposed into lanes), with the same bits as the scalar build.

use super::columns::Columns;
use super::fused::{relocate_and_scatter, NextBand, FUSED_BATCH};
use super::gather::{gather_sums, Gather, Wanted};
use super::particle::{update_stress, Partials, StressInput, StressOutput, StressPartials, SumInput, SumPartials};
use super::{ApicInertia, GridField, GridState, KineticEnergies, ParticleScratch};
use crate::lanes::{dispatch, Real};
#[cfg(target_arch = "x86_64")]
use crate::lanes::{F64x4, F64x8};
use crate::operators::{ColumnView, Layout, Operators};
use crate::parallel::{Splittable, Workers};
use crate::particles::Particles;
use crate::schemes::{PositionUpdate, Transfer};

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
    /// The grid field `u` that moves the particles, `Δx_p = Δt Nᵀ u`, in place of the position
    /// update (the implicit step: its converged displacement over `Δt`, [`GridField::Motion`]).
    pub motion: Option<GridField>,
}

impl G2pRule {
    /// Values per node of the packed grid velocities the pass reads: 4 (`[w, v]`) when the
    /// transfer's target and the gradient field are `w`, 8 (`[w, v, v*, u]`, with the motion
    /// field in place of `v*` when the rule has one) otherwise.
    pub(crate) fn packed_width(&self) -> usize {
        let plain_target = self.transfer.series_terms().is_none() && self.motion.is_none();
        let plain_gradient = matches!(self.gradient, None | Some(GridField::Updated));
        if plain_target && plain_gradient {
            4
        } else {
            8
        }
    }
}

/// What the pass also does for each particle after its velocity update, in the same sweep.
#[derive(Clone, Copy)]
pub(crate) struct Fused<'a> {
    /// (12)–(13) with `L` of the rule's gradient field (USL): each body's material.
    pub stress: Option<&'a [crate::material::Prepared]>,
    /// (9) `x_p ← x_p + Δx_p` and the report's particle sums under this gravity (instead of
    /// the position increments into the scratch).
    pub moves: Option<[f64; 2]>,
    /// Every particle's body force is +0: zeros stand in for it, not read.
    pub zero_body_force: bool,
}

/// What a fused pass returns per block of particles.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct G2pBlock {
    /// `K_p` before, `K(v)`, `K(w)`.
    pub kinetic: [Partials; 3],
    pub stress: StressPartials,
    pub sums: SumPartials,
}

/// (9)–(11) in one pass over N, Gx, Gy. With `v_pic = Nᵀ w` and the increment
/// `Δv = Nᵀ (w − v)` (the one FLIP rule, docs/formulation.md):
///
/// ```text
/// PIC, APIC:  v_p ← v_pic        (APIC: B_p ← Σ_I N_I w_I (x_I − x_p)ᵀ; bilinear: C_p ← Gᵀ w)
/// FLIP:       v_p ← v_p + Δv     blend α: α (v_p + Δv) + (1 − α) v_pic
/// XPIC, FMPM: v_p ← Nᵀ v*
/// Δx_p = Δt Nᵀ w   (trapezoidal: (Δt/2)(v_p,old + Nᵀ w); FMPM: (Δt/2)(v_p,old + v_p,new);
///                   XPIC: Δt (Nᵀ v + ½ (v_p,new − v_p,old)); a motion field u: Δt Nᵀ u)
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
    let mut packed = std::mem::take(&mut scratch.packed);
    pack_velocities(ops, grid, rule, &mut packed);
    let fused = Fused {
        stress: None,
        moves: None,
        zero_body_force: false,
    };
    let mut blocks = std::mem::take(&mut scratch.blocks);
    let width = rule.packed_width();
    let view = Packed {
        values: &packed,
        stride: width,
        layer: 0,
    };
    g2p_packed(ops, view, rule, dt, &fused, p, scratch, workers, &mut blocks);
    scratch.kinetic = KineticEnergies::total(&blocks);
    scratch.packed = packed;
    scratch.blocks = blocks;
}

/// The grid velocities [`g2p`] reads, packed node by node over the operators' node span:
/// `[w, v]`, or `[w, v, v*, u]` ([`G2pRule::packed_width`]), two components each.
pub(crate) fn pack_velocities(ops: &Operators, grid: &GridState, rule: &G2pRule, packed: &mut Vec<f64>) {
    pack_layers(ops, &[grid], rule, packed);
}

/// [`pack_velocities`] of one grid state per body, one after the other (contact,
/// [`crate::contact`]); returns the values per body ([`Packed::layer`]).
pub(crate) fn pack_layers(ops: &Operators, grids: &[&GridState], rule: &G2pRule, packed: &mut Vec<f64>) -> usize {
    let span = ops.node_span();
    let width = rule.packed_width();
    let len = grids.first().map_or(0, |g| g.updated.len());
    reserve_packed(packed, width * len * grids.len());
    packed.clear();
    for grid in grids {
        let (w, v) = (&grid.updated, &grid.projected);
        let target = match rule.motion {
            Some(motion) => grid.field(motion),
            None if rule.transfer.series_terms().is_some() => &grid.series,
            None => w,
        };
        let gradient = grid.field(rule.gradient.unwrap_or(GridField::Updated));
        for i in span.clone() {
            packed.extend_from_slice(&[w.x[i], w.y[i], v.x[i], v.y[i]]);
            if width == 8 {
                packed.extend_from_slice(&[target.x[i], target.y[i], gradient.x[i], gradient.y[i]]);
            }
        }
    }
    width * span.len()
}

/// Address space for `len` packed values (pages are touched as the span needs them), so that a
/// growing span never reallocates.
pub(crate) fn reserve_packed(packed: &mut Vec<f64>, len: usize) {
    if packed.capacity() < len {
        packed.reserve_exact(len - packed.len());
    }
}

/// [`g2p`] from packed grid velocities (of [`pack_velocities`], or the lumped grid pass), with
/// what `fused` adds; the results of each block of particles into `blocks`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn g2p_packed(
    ops: &Operators,
    packed: Packed,
    rule: &G2pRule,
    dt: f64,
    fused: &Fused,
    p: &mut Particles,
    scratch: &mut ParticleScratch,
    workers: &Workers,
    blocks: &mut Vec<G2pBlock>,
) {
    let view = BlockColumns::Shared(ops.view());
    let lo = ops.node_span().start;
    let (input, out) = split_pass(view, ops.support(), lo, packed, rule, dt, fused, p, scratch);
    let width = rule.packed_width();
    workers.split_blocks(out, blocks, |first, out| match width {
        4 => crate::with_support!(ops, g2p_block::<S, 4>(&input, first, out)),
        _ => crate::with_support!(ops, g2p_block::<S, 8>(&input, first, out)),
    });
}

/// What the blocks of a grid-to-particle pass read and write: the particles `p` and the scratch
/// split into [`G2pInput`] and [`G2pOutput`], with the columns `columns` (of a support of
/// `support` nodes per axis) and the grid velocities `packed` from node `lo`.
#[allow(clippy::too_many_arguments)]
pub(super) fn split_pass<'a>(
    columns: BlockColumns<'a>,
    support: usize,
    lo: usize,
    packed: Packed<'a>,
    rule: &'a G2pRule,
    dt: f64,
    fused: &Fused<'a>,
    p: &'a mut Particles,
    scratch: &'a mut ParticleScratch,
) -> (G2pInput<'a>, G2pOutput<'a>) {
    let np = p.len();
    let with_gradient = rule.gradient.is_some() && fused.stress.is_none();
    if with_gradient {
        for l in scratch.velocity_gradient.iter_mut() {
            l.resize(np, 0.0);
        }
    }
    if fused.moves.is_none() {
        scratch.displacement.x.resize(np, 0.0);
        scratch.displacement.y.resize(np, 0.0);
    }
    // The stress and volume: written by the pass (USL), or read by the fused scatter.
    let (held, stress) = if fused.stress.is_some() {
        let out = StressOutput {
            f: [&mut p.fxx[..], &mut p.fxy[..], &mut p.fyx[..], &mut p.fyy[..]],
            sigma: [&mut p.sxx[..], &mut p.syy[..], &mut p.sxy[..]],
            volume: &mut p.volume[..],
        };
        (None, Some(out))
    } else {
        (Some(([&p.sxx[..], &p.syy[..], &p.sxy[..]], &p.volume[..])), None)
    };
    let input = G2pInput {
        support,
        packed,
        lo,
        rule,
        dt,
        mass: &p.mass,
        body: &p.body,
        force: (!fused.zero_body_force).then_some([&p.bx, &p.by]),
        stress: fused.stress,
        gravity: fused.moves,
        held,
    };
    let moves = fused.moves.is_some();
    let out = G2pOutput {
        columns,
        position: [&mut p.x[..], &mut p.y[..]],
        moves,
        velocity: [&mut p.vx[..], &mut p.vy[..]],
        affine: [
            &mut p.affine_xx[..],
            &mut p.affine_xy[..],
            &mut p.affine_yx[..],
            &mut p.affine_yy[..],
        ],
        gradient: with_gradient.then(|| scratch.velocity_gradient.each_mut().map(|v| &mut v[..])),
        displacement: (!moves).then(|| [&mut scratch.displacement.x[..], &mut scratch.displacement.y[..]]),
        stress,
    };
    (input, out)
}

/// The grid velocities a grid-to-particle pass reads: node `lo + i` holds `W` values (`[w, v]`,
/// or `[w, v, v*, u]`) from `values[stride · i]`; with one field per body (contact,
/// [`crate::contact`]), body `b`'s from `values[b · layer + stride · i]`.
#[derive(Clone, Copy)]
pub(crate) struct Packed<'a> {
    pub values: &'a [f64],
    pub stride: usize,
    /// Values per body's field (0: one field for every particle).
    pub layer: usize,
}

/// What every block of [`g2p`] reads.
pub(super) struct G2pInput<'a> {
    /// Nodes per axis of a stencil.
    pub(super) support: usize,
    /// Grid velocities packed per node from node `lo`.
    pub(super) packed: Packed<'a>,
    pub(super) lo: usize,
    pub(super) rule: &'a G2pRule,
    pub(super) dt: f64,
    pub(super) mass: &'a [f64],
    pub(super) body: &'a [usize],
    /// The body forces (`None`: all +0).
    pub(super) force: Option<[&'a [f64]; 2]>,
    pub(super) stress: Option<&'a [crate::material::Prepared]>,
    pub(super) gravity: Option<[f64; 2]>,
    /// `σxx, σyy, σxy` and `V` of every particle when the pass does not update them.
    pub(super) held: Option<([&'a [f64]; 3], &'a [f64])>,
}

/// What a block of [`g2p`] writes, for its particles: velocities, APIC moments, velocity
/// gradients or the stress update, position increments or the positions.
pub(super) struct G2pOutput<'a> {
    /// The columns the particles read.
    pub(super) columns: BlockColumns<'a>,
    /// `x_p` (read for the node offsets; written when the pass moves the particles).
    pub(super) position: [&'a mut [f64]; 2],
    pub(super) moves: bool,
    /// `v_p` (x, y).
    pub(super) velocity: [&'a mut [f64]; 2],
    /// APIC's `B_p` (or `C_p` for linear kernels), row-major.
    pub(super) affine: [&'a mut [f64]; 4],
    /// `L_p`, row-major, when written.
    pub(super) gradient: Option<[&'a mut [f64]; 4]>,
    /// `Δx_p` (x, y), unless the pass moves the particles.
    pub(super) displacement: Option<[&'a mut [f64]; 2]>,
    /// `F`, `σ`, `V`, when the pass updates the stress.
    pub(super) stress: Option<StressOutput<'a>>,
}

/// The columns a block of the pass reads: the operators' own, shared by every block (entry `k`
/// particle `k`'s), or the block's part of them, which the fused pass rewrites as its particles
/// move (entry `j` the block's particle `j`'s).
pub(super) enum BlockColumns<'a> {
    Shared(ColumnView<'a>),
    Own {
        layout: Layout,
        first: &'a mut [[u32; 2]],
        local: [&'a mut [f64]; 2],
    },
}

impl BlockColumns<'_> {
    /// The columns as a view (the block's own, or every particle's).
    #[inline(always)]
    pub(super) fn view(&self) -> ColumnView<'_> {
        match self {
            BlockColumns::Shared(view) => *view,
            BlockColumns::Own { layout, first, local } => ColumnView {
                layout: *layout,
                first,
                local: [&local[0][..], &local[1][..]],
                factors: None,
            },
        }
    }

    fn split_at(self, mid: usize) -> (Self, Self) {
        match self {
            BlockColumns::Shared(view) => (BlockColumns::Shared(view), BlockColumns::Shared(view)),
            BlockColumns::Own { layout, first, local } => {
                let (f0, f1) = first.split_at_mut(mid);
                let (l0, l1) = Splittable::split_at(local, mid);
                (
                    BlockColumns::Own {
                        layout,
                        first: f0,
                        local: l0,
                    },
                    BlockColumns::Own {
                        layout,
                        first: f1,
                        local: l1,
                    },
                )
            }
        }
    }
}

fn split_option<T: Splittable>(t: Option<T>, mid: usize) -> (Option<T>, Option<T>) {
    match t {
        Some(t) => {
            let (a, b) = t.split_at(mid);
            (Some(a), Some(b))
        }
        None => (None, None),
    }
}

impl Splittable for G2pOutput<'_> {
    fn len(&self) -> usize {
        self.velocity[0].len()
    }
    fn split_at(self, mid: usize) -> (Self, Self) {
        let (x0, x1) = Splittable::split_at(self.position, mid);
        let (v0, v1) = Splittable::split_at(self.velocity, mid);
        let (a0, a1) = Splittable::split_at(self.affine, mid);
        let (g0, g1) = split_option(self.gradient, mid);
        let (d0, d1) = split_option(self.displacement, mid);
        let (s0, s1) = split_option(self.stress, mid);
        let (c0, c1) = self.columns.split_at(mid);
        (
            G2pOutput {
                columns: c0,
                position: x0,
                moves: self.moves,
                velocity: v0,
                affine: a0,
                gradient: g0,
                displacement: d0,
                stress: s0,
            },
            G2pOutput {
                columns: c1,
                position: x1,
                moves: self.moves,
                velocity: v1,
                affine: a1,
                gradient: g1,
                displacement: d1,
                stress: s1,
            },
        )
    }
}

dispatch! {
    /// The particle loop of [`g2p`] for the particles from `first` (a block), for a support of
    /// `S` nodes per axis and `W` packed values per node.
    pub(super) fn g2p_block<const W: usize> / g2p_block_avx2, g2p_block_avx512 = g2p_block_plain(
        input: &G2pInput,
        first: usize,
        out: G2pOutput
    ) -> G2pBlock
}

dispatch! {
    /// [`g2p_block`] with the fused pass's relocation and scatter of the next step
    /// ([`super::fused`]).
    pub(super) fn g2p_block_next<const W: usize> / g2p_block_next_avx2, g2p_block_next_avx512 = g2p_block_fused(
        input: &G2pInput,
        first: usize,
        out: G2pOutput,
        next: &mut NextBand
    ) -> G2pBlock
}

/// [`g2p_block_body`] alone (its own code, without the fused pass's).
#[inline(always)]
fn g2p_block_plain<const S: usize, const W: usize, const V: usize>(
    input: &G2pInput,
    first: usize,
    out: G2pOutput,
) -> G2pBlock {
    g2p_block_body::<S, W, V>(input, first, out, None)
}

/// [`g2p_block_body`] with the fused pass.
#[inline(always)]
fn g2p_block_fused<const S: usize, const W: usize, const V: usize>(
    input: &G2pInput,
    first: usize,
    out: G2pOutput,
    next: &mut NextBand,
) -> G2pBlock {
    g2p_block_body::<S, W, V>(input, first, out, Some(next))
}

/// The body of [`g2p_block`]: the particles' sums `V` at a time (eight in the AVX-512 build,
/// four in the AVX2 build; then fewer for the last few of a block), then their updates; with
/// `next`, the fused pass, each group's new columns and its terms of the next step's (2)–(5)
/// right after its update ([`super::fused`]).
#[inline(always)]
fn g2p_block_body<const S: usize, const W: usize, const V: usize>(
    input: &G2pInput,
    first: usize,
    mut out: G2pOutput,
    mut next: Option<&mut NextBand>,
) -> G2pBlock {
    let np = out.len();
    let mut block = G2pBlock::default();
    // A batch of particles at a time, each phase's code in a loop of its own: their sums and
    // updates, then (USL) their stress updates from the gradients kept in `gradients` (a
    // short loop, whose particles the CPU overlaps; inside the long one their chains of
    // dependent operations would not), then (the fused pass) their relocation and scatter,
    // while they are in cache. Every particle sees the same operations as one after another.
    let mut gradients = [[0.0; FUSED_BATCH]; 4];
    let mut start = 0;
    while start < np {
        let end = (start + FUSED_BATCH).min(np);
        let mut batch = Batch {
            start,
            gradients: &mut gradients,
        };
        let mut j = start;
        #[cfg(target_arch = "x86_64")]
        {
            while V >= 8 && j + 8 <= end {
                update_group::<F64x8, S, W>(input, first, j, &mut out, &mut block, &mut batch);
                j += 8;
            }
            while V >= 4 && j + 4 <= end {
                update_group::<F64x4, S, W>(input, first, j, &mut out, &mut block, &mut batch);
                j += 4;
            }
        }
        while j < end {
            update_group::<f64, S, W>(input, first, j, &mut out, &mut block, &mut batch);
            j += 1;
        }
        if let (Some(materials), Some(stress)) = (input.stress, out.stress.as_mut()) {
            let stress_input = StressInput {
                materials,
                body: input.body,
                mass: input.mass,
                dt: input.dt,
            };
            let mut j = start;
            #[cfg(target_arch = "x86_64")]
            {
                while V >= 8 && j + 8 <= end {
                    stress_group::<F64x8>(&stress_input, first, j, &batch, stress, &mut block.stress);
                    j += 8;
                }
                while V >= 4 && j + 4 <= end {
                    stress_group::<F64x4>(&stress_input, first, j, &batch, stress, &mut block.stress);
                    j += 4;
                }
            }
            while j < end {
                stress_group::<f64>(&stress_input, first, j, &batch, stress, &mut block.stress);
                j += 1;
            }
        }
        if let Some(next) = next.as_deref_mut() {
            relocate_and_scatter::<S, V>(input, first, start..end, &mut out, next);
        }
        start = end;
    }
    block
}

/// The particles of a batch from block entry `start`: the velocity gradients of their stress
/// update (entry `j − start`).
struct Batch<'a> {
    start: usize,
    gradients: &'a mut [[f64; FUSED_BATCH]; 4],
}

/// (12)–(13) for particles `first + j …` (`R::LANES` of them) from the gradients of `batch`.
#[inline(always)]
fn stress_group<R: Real>(
    input: &StressInput,
    first: usize,
    j: usize,
    batch: &Batch,
    out: &mut StressOutput,
    sums: &mut StressPartials,
) {
    let at = j - batch.start;
    let g = &batch.gradients;
    let l = [
        R::load(&g[0], at),
        R::load(&g[1], at),
        R::load(&g[2], at),
        R::load(&g[3], at),
    ];
    update_stress(input, l, first + j, j, out, sums);
}

/// Particles `first + j …` (`R::LANES` of them): their sums, then their new velocities, APIC
/// moments, velocity gradients (into the scratch, or into `batch` for the stress update that
/// follows), position increments or positions, and their kinetic energies (and report sums),
/// added to `block` in particle order.
#[inline(always)]
fn update_group<R: Gather, const S: usize, const W: usize>(
    input: &G2pInput,
    first: usize,
    j: usize,
    out: &mut G2pOutput,
    block: &mut G2pBlock,
    batch: &mut Batch,
) {
    let k = first + j;
    let rule = input.rule;
    let transfer = rule.transfer;
    let apic = transfer == Transfer::Apic;
    let wanted = Wanted {
        l: rule.gradient.is_some(),
        apic,
    };
    let (xp, yp) = (R::load(out.position[0], j), R::load(out.position[1], j));
    let cols = match &out.columns {
        BlockColumns::Shared(view) => Columns::<R, S>::load_view(view, k, xp, yp),
        own => Columns::<R, S>::load_view(&own.view(), j, xp, yp),
    };
    // Each particle reads its own body's field when there is one per body.
    let mut layers = [0; 8];
    if input.packed.layer > 0 {
        for (l, at) in layers.iter_mut().enumerate().take(R::LANES) {
            *at = input.body[k + l] * input.packed.layer;
        }
    }
    let g = gather_sums::<R, S, W>(&cols, input.packed, input.lo, layers, wanted);
    let ([vx, vy], [tx, ty], [rx, ry]) = (g.w, g.t, g.r);
    if let Some(l) = out.gradient.as_mut() {
        for c in 0..4 {
            g.l[c].store(l[c], j);
        }
    }
    let (old_x, old_y) = (R::load(out.velocity[0], j), R::load(out.velocity[1], j));
    let c = R::splat;
    let half_m = c(0.5) * R::load(input.mass, k);
    block.kinetic[0].add(j, half_m * (old_x * old_x + old_y * old_y));
    block.kinetic[1].add(j, half_m * (rx * rx + ry * ry));
    block.kinetic[2].add(j, half_m * (vx * vx + vy * vy));
    let (dvx, dvy) = (vx - rx, vy - ry);
    let (new_x, new_y) = match transfer {
        Transfer::Pic | Transfer::Apic => (vx, vy),
        Transfer::Xpic { .. } | Transfer::Fmpm { .. } => (tx, ty),
        Transfer::Flip => (old_x + dvx, old_y + dvy),
        Transfer::Blend { flip } => (
            c(flip) * (old_x + dvx) + c(1.0 - flip) * vx,
            c(flip) * (old_y + dvy) + c(1.0 - flip) * vy,
        ),
    };
    new_x.store(out.velocity[0], j);
    new_y.store(out.velocity[1], j);
    if apic {
        let b = if rule.inertia == ApicInertia::StoredC {
            g.lw
        } else {
            g.b
        };
        for c in 0..4 {
            b[c].store(out.affine[c], j);
        }
    }
    let trapezoidal = rule.position == PositionUpdate::Trapezoidal;
    let (ux, uy) = match transfer {
        // The motion field, packed in the target's place.
        _ if rule.motion.is_some() => (tx, ty),
        Transfer::Xpic { .. } => (rx + c(0.5) * (new_x - old_x), ry + c(0.5) * (new_y - old_y)),
        Transfer::Fmpm { .. } => (c(0.5) * (old_x + new_x), c(0.5) * (old_y + new_y)),
        Transfer::Pic | Transfer::Flip | Transfer::Blend { .. } | Transfer::Apic if trapezoidal => {
            (c(0.5) * (old_x + vx), c(0.5) * (old_y + vy))
        }
        Transfer::Pic | Transfer::Flip | Transfer::Blend { .. } | Transfer::Apic => (vx, vy),
    };
    let (dx, dy) = (c(input.dt) * ux, c(input.dt) * uy);
    if out.stress.is_some() {
        for c in 0..4 {
            g.l[c].store(&mut batch.gradients[c], j - batch.start);
        }
    }
    match (out.displacement.as_mut(), input.gravity) {
        (Some(d), _) => {
            dx.store(d[0], j);
            dy.store(d[1], j);
        }
        (None, gravity) => {
            let (x, y) = (xp + dx, yp + dy);
            x.store(out.position[0], j);
            y.store(out.position[1], j);
            if let Some(gravity) = gravity {
                let sum = SumInput {
                    x: [x, y],
                    v: [new_x, new_y],
                    m: R::load(input.mass, k),
                    b: body_force(input.force, k),
                };
                block.sums.add(j, k, sum, gravity);
            }
        }
    }
}

/// Particles `k …`'s body forces, or zeros (the same operations follow on them) when `force`
/// is `None`.
#[inline(always)]
pub(super) fn body_force<R: Real>(force: Option<[&[f64]; 2]>, k: usize) -> [R; 2] {
    match force {
        Some([bx, by]) => [R::load(bx, k), R::load(by, k)],
        None => [R::splat(0.0), R::splat(0.0)],
    }
}
