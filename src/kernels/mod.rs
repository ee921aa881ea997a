//! The fused particle ↔ grid kernels: tier 2 of the products with N, Gx, Gy.
//!
//! Tier 1 ([`crate::transfer`], [`crate::mass`]) writes one product per call, as the equations
//! read: `m_L = N m`, `q = N (m ∘ v)`, `L = [Gxᵀ v, Gyᵀ v]` … The time loop makes the same products
//! in fewer passes over the shared pattern of N, Gx, Gy: these kernels, each a named phase with
//! its inputs by `&` and its outputs by `&mut`. Together with [`crate::operators`] this is the
//! one place that indexes the compressed-column arrays; `tests/kernels.rs` holds the two tiers
//! equal to round-off for every shape function, transfer and update scheme.
//!
//! | kernel | equations (docs/formulation.md) |
//! |---|---|
//! | [`p2g`] | (2)–(5): `m_L = N m`, `q = N (m ∘ v) [+ APIC]`, `f = N (m ∘ b) + m_L g − G (V σ)` |
//! | [`add_internal_force`] | (5) alone: `f −= [Gx (V∘σxx) + Gy (V∘σxy); Gx (V∘σxy) + Gy (V∘σyy)]` |
//! | [`reproject_momentum`] | MUSL's `q' = N (m ∘ v_p) [+ APIC]` |
//! | [`velocity_gradient_into`] | `L = [Gxᵀ u, Gyᵀ u]` |
//! | [`velocity_gradient_layered`] | the same with one grid velocity per body (contact) |
//! | [`g2p`] | (9)–(11): new particle velocities, APIC moments, position increments, `L` |
//! | [`extend_to_inactive_nodes`] | (8b): massless support nodes take their particles' mean velocity |
//! | `update_lumped_grid` | (6)–(8) with the lumped mass in both solves, in one pass over the nodes |
//! | `g2p` with `Fused` | USL's (9)–(13) and the report's particle sums in one sweep |
//!
//! Each per-particle formula is written once, generic over `lanes::Real`, and runs for one
//! particle, four side by side (AVX2) or eight (AVX-512), the widest the CPU has
//! ([`set_kernel_lanes`]), with the same bits (`tests/simd.rs`).

mod columns;
mod extend;
mod fused;
mod g2p;
mod gather;
mod gradient;
mod grid;
mod p2g;
mod particle;
mod scatter;
mod stiffness;

pub use crate::lanes::{kernel_lanes, set_kernel_lanes, set_scalar_kernels};
pub use extend::{extend_to_inactive_nodes, ExtensionScratch};
pub(crate) use fused::{g2p_then_p2g, NextTerms, Velocities};
pub use g2p::{g2p, G2pRule};
pub(crate) use g2p::{g2p_packed, pack_layers, pack_velocities, Fused, G2pBlock, Packed};
pub use gradient::{velocity_gradient_into, velocity_gradient_layered};
pub(crate) use grid::update_lumped_grid;
pub(crate) use p2g::subtract_particle_force;
pub use p2g::{add_internal_force, p2g, reproject_momentum};
pub(crate) use p2g::{p2g_prepared, p2g_with, NodeWrites};
pub(crate) use particle::{update_stress, StressInput, StressOutput, SumInput};
pub use particle::{Partials, ParticleSums, StressPartials, StressSums, SumPartials};
pub(crate) use stiffness::subtract_tangent_forces;

use crate::fields::VectorField;
use crate::grid::Grid;
use crate::operators::Operators;
use crate::particles::Particles;

/// Which grid velocity a phase reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GridField {
    /// `v`: projected from the particles, (6).
    Projected,
    /// `w = v + Δt a`: updated, (8).
    Updated,
    /// `v*`: the series velocity of XPIC and FMPM.
    Series,
    /// `u/Δt`: the implicit step's converged grid displacement over the step, which moves and
    /// strains the particles.
    Motion,
}

/// The grid fields of one step, one entry per node (the lumped mass, its inverse and the
/// active set are the grid mass's: [`crate::mass::GridMass`]).
#[derive(Debug, Clone, Default)]
pub struct GridState {
    /// Momentum `q`.
    pub momentum: VectorField,
    /// Force `f = f_ext + f_int`.
    pub force: VectorField,
    /// Projected velocity `v`.
    pub projected: VectorField,
    /// Acceleration `a`.
    pub acceleration: VectorField,
    /// Updated velocity `w`.
    pub updated: VectorField,
    /// XPIC's or FMPM's series velocity `v*`.
    pub series: VectorField,
    /// The implicit step's grid displacement over the step, `u/Δt`.
    pub motion: VectorField,
    /// The grid's origin and cell size: node coordinates are formed from them where needed,
    /// not stored ([`Grid::node_position`]).
    frame: ([f64; 2], [f64; 2]),
    /// `Σ_I x_I × q_I` of the last [`p2g`].
    pub angular_momentum: f64,
    /// Nodes outside this range hold zero mass, momentum and force ([`Operators::node_span`]
    /// at the last [`p2g`]).
    pub span: std::ops::Range<usize>,
    /// Within `span`, nodes whose index along their line lies outside this range hold zero
    /// mass, momentum and force too ([`Operators::column_span`] at the last [`p2g`], or the
    /// whole line), and their entries of the accumulator are not read.
    columns: std::ops::Range<usize>,
    /// Per node of the lines of `span`, what [`p2g`] accumulates, `[m_L, q_x, q_y, f_x, f_y]`
    /// (`f` without gravity), interleaved so that one particle's contributions to a node land
    /// together; from node `base`.
    accumulator: Vec<[f64; 5]>,
    base: usize,
    /// The nodes whose updated velocity the last lumped grid pass wrote
    /// ([`update_lumped_grid`]; all of them at first).
    lumped_span: std::ops::Range<usize>,
    /// The columns of `lumped_span` it wrote.
    lumped_columns: std::ops::Range<usize>,
    /// Nodes per grid line ([`Operators::line_length`]).
    line_len: usize,
    /// The angular momentum of each block of nodes of the last [`p2g`].
    angular_blocks: Vec<f64>,
    /// The next step's particle terms, scattered by the fused pass ([`fused`]).
    next: fused::NextScatter,
}

impl GridState {
    /// Zeroed fields for the nodes of `grid`.
    pub fn new(grid: &Grid) -> GridState {
        let n = grid.num_nodes();
        // Each field zeroed on its own (pages the step never writes stay untouched).
        GridState {
            momentum: VectorField::zeros(n),
            force: VectorField::zeros(n),
            projected: VectorField::zeros(n),
            acceleration: VectorField::zeros(n),
            updated: VectorField::zeros(n),
            series: VectorField::zeros(n),
            motion: VectorField::zeros(n),
            frame: (grid.origin(), grid.cell_size()),
            angular_momentum: 0.0,
            span: 0..n,
            columns: 0..usize::MAX,
            // Reserved for the whole grid (address space only: pages are touched as the span
            // needs them), so that a growing span never reallocates.
            accumulator: Vec::with_capacity(n),
            base: 0,
            lumped_span: 0..n,
            lumped_columns: 0..usize::MAX,
            line_len: {
                let [sx, sy] = grid.strides();
                sx.max(sy).max(1)
            },
            angular_blocks: Vec::new(),
            next: fused::NextScatter::with_capacity(n),
        }
    }

    /// Whether the fused pass of the last step left this step's particle terms
    /// ([`fused::g2p_then_p2g`]).
    pub(crate) fn next_ready(&self) -> bool {
        self.next.ready
    }

    /// Forgets the particle terms the fused pass left (the particles changed since).
    pub(crate) fn discard_next(&mut self) {
        self.next.ready = false;
    }

    /// Takes the particle terms the fused pass left as this step's accumulator.
    fn take_next(&mut self) {
        assert!(self.next.ready, "the fused pass left this step's terms");
        std::mem::swap(&mut self.accumulator, &mut self.next.acc);
        self.base = self.next.base;
        self.next.ready = false;
    }

    /// The velocity field `field`.
    pub fn field(&self, field: GridField) -> &VectorField {
        match field {
            GridField::Projected => &self.projected,
            GridField::Updated => &self.updated,
            GridField::Series => &self.series,
            GridField::Motion => &self.motion,
        }
    }

    /// The velocity field `source` to read and the series field to write, at once.
    ///
    /// # Panics
    /// If `source` is the series field itself.
    pub fn source_and_series(&mut self, source: GridField) -> (&VectorField, &mut VectorField) {
        match source {
            GridField::Projected => (&self.projected, &mut self.series),
            GridField::Updated => (&self.updated, &mut self.series),
            GridField::Series | GridField::Motion => {
                panic!("the series is taken of a projected or updated velocity")
            }
        }
    }

    /// The velocity field `field`, to write.
    pub fn field_mut(&mut self, field: GridField) -> &mut VectorField {
        match field {
            GridField::Projected => &mut self.projected,
            GridField::Updated => &mut self.updated,
            GridField::Series => &mut self.series,
            GridField::Motion => &mut self.motion,
        }
    }
}

/// Kinetic energies measured at the particles by [`g2p`]:
/// `K(u) = ½ Σ_p m_p |(Nᵀu)_p|²`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct KineticEnergies {
    /// The particles' own, before the update.
    pub before: f64,
    /// `K(v)`, of the projected velocity.
    pub projected: f64,
    /// `K(w)`, of the updated velocity.
    pub updated: f64,
}

impl KineticEnergies {
    /// The energies of the blocks of a pass, added in order.
    pub(crate) fn total(blocks: &[G2pBlock]) -> KineticEnergies {
        let mut t = KineticEnergies::default();
        for b in blocks {
            t.before += b.kinetic[0].sum();
            t.projected += b.kinetic[1].sum();
            t.updated += b.kinetic[2].sum();
        }
        t
    }
}

/// Per-particle fields of one step.
#[derive(Debug, Clone, Default)]
pub struct ParticleScratch {
    /// `L = [[Lxx, Lxy], [Lyx, Lyy]]` as `[Lxx, Lxy, Lyx, Lyy]`, one vector each.
    pub velocity_gradient: [Vec<f64>; 4],
    /// Position increments of [`g2p`].
    pub displacement: VectorField,
    /// Kinetic energies of the last [`g2p`].
    pub kinetic: KineticEnergies,
    /// The grid velocities [`g2p`] reads, packed node by node over the operators' node span
    /// ([`pack_velocities`]).
    packed: Vec<f64>,
    /// What each block of particles of the last [`g2p`] returned.
    blocks: Vec<G2pBlock>,
}

pub use crate::shape::ApicInertia;

/// What a particle-to-grid pass ([`p2g`]) adds beside `m_L = N m` and `q = N (m ∘ v)`: the
/// APIC affine momentum, gravity, and whether the internal force.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct P2gTerms {
    /// The kernel's APIC inertia when the transfer is APIC (`q` gains
    /// `Σ_p N_Ip m_p C_p (x_I − x_p)`), `None` otherwise.
    pub apic: Option<ApicInertia>,
    /// Gravity `g`: the force gains `m_L g`.
    pub gravity: [f64; 2],
    /// Whether the force includes `f_int`.
    pub stress: Stress,
}

/// Whether [`p2g`] adds the internal force (USF adds it after its stress update instead).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stress {
    /// `f` includes `f_int`.
    Include,
    /// `f` is the external force only.
    Omit,
}

/// The APIC affine velocity matrix of one particle, `C_p`.
#[derive(Clone, Copy)]
struct Affine {
    c: [f64; 4],
}

impl Affine {
    /// `C_p (x_I − x_p)` at a node `(dx, dy) = x_I − x_p` away, weighted by `n`.
    #[inline(always)]
    fn velocity(&self, dx: f64, dy: f64, n: f64) -> [f64; 2] {
        [
            n * (self.c[0] * dx + self.c[1] * dy),
            n * (self.c[2] * dx + self.c[3] * dy),
        ]
    }
}

/// Particle `k`'s APIC affine velocity matrix at its current position: `C_p = B_p D_p⁻¹` with
/// `D_p = diag(Σ_I N_I dx², Σ_I N_I dy²)` (the off-diagonal part vanishes for tensor-product
/// kernels). Linear kernels store `C_p = Σ_I w_I ∇N_Iᵀ` itself (`∇N_I = D_p⁻¹ N_I (x_I − x_p)` at
/// the old position).
#[inline(always)]
fn apic_affine(p: &Particles, k: usize, ops: &Operators, kind: ApicInertia) -> Affine {
    let b = [p.affine_xx[k], p.affine_xy[k], p.affine_yx[k], p.affine_yy[k]];
    let at = [p.x[k], p.y[k]];
    let [dxx, dyy] = match kind {
        ApicInertia::StoredC => return Affine { c: b },
        ApicInertia::Constant(d) => d,
        ApicInertia::Column => crate::with_support!(ops, column_inertia::<S>(ops, k, at)),
    };
    Affine {
        c: [b[0] / dxx, b[1] / dyy, b[2] / dxx, b[3] / dyy],
    }
}

/// `D_p = diag(Σ_I N_I dx², Σ_I N_I dy²)` over particle `k`'s column (GIMP), `dx = x_I − x_p`.
fn column_inertia<const S: usize>(ops: &Operators, k: usize, at: [f64; 2]) -> [f64; 2] {
    let st = ops.stencil::<S>(k);
    let offsets = st.offsets(at[0], at[1]);
    let (mut dxx, mut dyy) = (0.0, 0.0);
    for b in 0..S {
        let (_, n) = st.n_row(b);
        let (dxs, dys) = st.run_offsets(&offsets, b);
        for a in 0..S {
            let (dx, dy) = (dxs[a], dys[a]);
            dxx += n[a] * dx * dx;
            dyy += n[a] * dy * dy;
        }
    }
    // D_p > 0 for GIMP: its weights always spread over more than one node.
    [dxx, dyy]
}
