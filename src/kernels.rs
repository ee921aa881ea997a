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
//! | [`g2p`] | (9)–(11): new particle velocities, APIC moments, position increments, `L` |
//! | [`extend_to_inactive_nodes`] | (8b): massless support nodes take their particles' mean velocity |

use crate::fields::VectorField;
use crate::grid::Grid;
use crate::operators::Operators;
use crate::parallel::Workers;
use crate::particles::Particles;
use crate::schemes::PositionUpdate;
use crate::schemes::Transfer;
use crate::shape::ShapeFunction;

/// Which grid velocity a phase reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GridField {
    /// `v`: projected from the particles, (6).
    Projected,
    /// `w = v + Δt a`: updated, (8).
    Updated,
    /// `v*`: the series velocity of XPIC and FMPM.
    Series,
}

/// The grid fields of one step, one entry per node.
#[derive(Debug, Clone, Default)]
pub struct GridState {
    /// Lumped mass `m_L = N m`.
    pub mass: Vec<f64>,
    /// `1/m_L` on active nodes, 0 elsewhere.
    pub inverse_mass: Vec<f64>,
    /// Whether each node is active (carries mass above the tolerance).
    pub active: Vec<bool>,
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
    /// Node coordinates.
    pub node_x: Vec<f64>,
    /// Node coordinates.
    pub node_y: Vec<f64>,
    /// `Σ_I x_I × q_I` of the last [`p2g`].
    pub angular_momentum: f64,
    /// Nodes outside this range hold zero mass, momentum and force ([`Operators::node_span`]
    /// at the last [`p2g`]).
    pub span: std::ops::Range<usize>,
    /// Per node of `span`, what [`p2g`] accumulates, `[m_L, q_x, q_y, f_x, f_y]`, interleaved so
    /// that one particle's contributions to a node land in one cache line.
    accumulator: Vec<[f64; 5]>,
}

impl GridState {
    /// Zeroed fields for the nodes of `grid`.
    pub fn new(grid: &Grid) -> GridState {
        let n = grid.num_nodes();
        let zero = VectorField::zeros(n);
        GridState {
            mass: vec![0.0; n],
            inverse_mass: vec![0.0; n],
            active: vec![false; n],
            momentum: zero.clone(),
            force: zero.clone(),
            projected: zero.clone(),
            acceleration: zero.clone(),
            updated: zero.clone(),
            series: zero,
            node_x: grid.node_x(),
            node_y: grid.node_y(),
            angular_momentum: 0.0,
            span: 0..n,
            // Reserved for the whole grid (address space only: pages are touched as the span
            // needs them), so that a growing span never reallocates.
            accumulator: Vec::with_capacity(n),
        }
    }

    /// The velocity field `field`.
    pub fn field(&self, field: GridField) -> &VectorField {
        match field {
            GridField::Projected => &self.projected,
            GridField::Updated => &self.updated,
            GridField::Series => &self.series,
        }
    }

    /// The velocity field `field`, to write.
    pub fn field_mut(&mut self, field: GridField) -> &mut VectorField {
        match field {
            GridField::Projected => &mut self.projected,
            GridField::Updated => &mut self.updated,
            GridField::Series => &mut self.series,
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

/// Per-particle fields of one step.
#[derive(Debug, Clone, Default)]
pub struct ParticleScratch {
    /// `L = [[Lxx, Lxy], [Lyx, Lyy]]` as `[Lxx, Lxy, Lyx, Lyy]`, one vector each.
    pub velocity_gradient: [Vec<f64>; 4],
    /// Position increments of [`g2p`].
    pub displacement: VectorField,
    /// Kinetic energies of the last [`g2p`].
    pub kinetic: KineticEnergies,
    /// The grid velocities [`g2p`] reads, packed node by node over the operators' node span:
    /// `[w, v, target, gradient field]`, two components each.
    packed: Vec<[f64; 8]>,
    /// Kinetic energies of each block of particles of the last [`g2p`].
    kinetic_blocks: Vec<KineticEnergies>,
}

impl ParticleScratch {
    fn resize(&mut self, np: usize) {
        for l in self.velocity_gradient.iter_mut() {
            l.resize(np, 0.0);
        }
        self.displacement.x.resize(np, 0.0);
        self.displacement.y.resize(np, 0.0);
    }
}

/// How a kernel's APIC inertia `D_p` is obtained.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ApicInertia {
    /// Linear kernels: the particle stores `C_p` itself (their `D_p` vanishes on grid lines).
    StoredC,
    /// B-splines: `D_p = diag(dxx, dyy)`, the same for every particle.
    Constant([f64; 2]),
    /// GIMP: summed over the particle's column.
    Column,
}

impl ApicInertia {
    /// The inertia of `shape` on `grid` (`h²/4` quadratic, `h²/3` cubic B-splines).
    pub fn of(shape: ShapeFunction, grid: &Grid) -> ApicInertia {
        let [hx, hy] = grid.cell_size();
        match shape {
            ShapeFunction::Linear => ApicInertia::StoredC,
            ShapeFunction::QuadraticBSpline => ApicInertia::Constant([hx * hx / 4.0, hy * hy / 4.0]),
            ShapeFunction::CubicBSpline => ApicInertia::Constant([hx * hx / 3.0, hy * hy / 3.0]),
            ShapeFunction::Gimp { .. } => ApicInertia::Column,
        }
    }
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

/// (2)–(5) in one pass over the shared pattern of N, Gx, Gy, into `grid.mass`,
/// `grid.momentum`, `grid.force` and `grid.angular_momentum`:
///
/// ```text
/// m_L = N m,   q = N (m ∘ v) [+ APIC: Σ_p N_Ip m_p C_p (x_I − x_p)],
/// f = N (m ∘ b) + m_L g − [Gx (V∘σxx) + Gy (V∘σxy); Gx (V∘σxy) + Gy (V∘σyy)]   (Stress::Include)
/// ```
///
/// # Panics
/// If `grid` does not have one entry per node of the operators.
pub fn p2g(
    ops: &Operators,
    p: &Particles,
    apic: Option<ApicInertia>,
    gravity: [f64; 2],
    stress: Stress,
    grid: &mut GridState,
    workers: &Workers,
) {
    let n = ops.num_nodes();
    assert_eq!(grid.mass.len(), n, "grid state sized for the operators' nodes");
    let span = ops.node_span();
    // Zero what the last p2g left outside the new span.
    let old = grid.span.clone();
    let below = old.start..old.end.min(span.start);
    let above = old.start.max(span.end)..old.end;
    for range in [below, above].into_iter().filter(|r| r.start < r.end) {
        grid.mass[range.clone()].fill(0.0);
        for field in [&mut grid.momentum, &mut grid.force] {
            field.x[range.clone()].fill(0.0);
            field.y[range.clone()].fill(0.0);
        }
    }
    let internal = if stress == Stress::Include { 1.0 } else { 0.0 };
    let (acc, base) = scatter_bands(ops, &mut grid.accumulator, workers, |acc, base, lines| {
        crate::with_support!(ops, p2g_columns::<S>(ops, p, apic, internal, acc, base, lines))
    });
    let [gx, gy] = gravity;
    let mut angular = 0.0;
    for i in span.clone() {
        let r = acc[i - base];
        grid.mass[i] = r[0];
        grid.momentum.x[i] = r[1];
        grid.momentum.y[i] = r[2];
        grid.force.x[i] = r[3] + r[0] * gx;
        grid.force.y[i] = r[4] + r[0] * gy;
        angular += grid.node_x[i] * r[2] - grid.node_y[i] * r[1];
    }
    grid.angular_momentum = angular;
    grid.span = span;
}

/// A deterministic scatter into the interleaved accumulator: zeroes it over the operators'
/// whole lines ([`Operators::line_span`]), cuts it into one band of lines per worker and runs
/// `fill(band, first node of the band, lines of the band)` on each (see [`crate::parallel`]).
/// Returns the accumulator and the node number of its first entry.
fn scatter_bands<'a>(
    ops: &Operators,
    acc: &'a mut Vec<[f64; 5]>,
    workers: &Workers,
    fill: impl Fn(&mut [[f64; 5]], usize, std::ops::Range<usize>) + Sync,
) -> (&'a [[f64; 5]], usize) {
    let (line_len, lines) = (ops.line_length(), ops.line_span());
    acc.clear();
    acc.resize(lines.len() * line_len, [0.0; 5]);
    let per_band = lines.len().div_ceil(workers.threads()).max(1);
    workers.chunks(acc, per_band * line_len, |t, band| {
        let first = lines.start + t * per_band;
        fill(band, first * line_len, first..(first + per_band).min(lines.end));
    });
    (acc, lines.start * line_len)
}

/// The particle loop of [`p2g`] for a support of `S` nodes per axis, into the interleaved
/// accumulator of the nodes from `lo`.
fn p2g_columns<const S: usize>(
    ops: &Operators,
    p: &Particles,
    apic: Option<ApicInertia>,
    internal: f64,
    acc: &mut [[f64; 5]],
    base: usize,
    lines: std::ops::Range<usize>,
) {
    for k in 0..p.len() {
        let l0 = ops.first_line(k);
        if l0 + S <= lines.start || l0 >= lines.end {
            continue;
        }
        let m = p.mass[k];
        let (mvx, mvy) = (m * p.vx[k], m * p.vy[k]);
        let (mbx, mby) = (m * p.bx[k], m * p.by[k]);
        let v = internal * p.volume[k];
        let (vsxx, vsyy, vsxy) = (v * p.sxx[k], v * p.syy[k], v * p.sxy[k]);
        let affine = apic.map(|kind| apic_affine(p, k, ops, kind));
        let st = ops.stencil::<S>(k);
        let offsets = st.offsets(p.x[k], p.y[k]);
        for b in 0..S {
            if !lines.contains(&(l0 + b)) {
                continue;
            }
            let (start, n, gx, gy) = st.row(b);
            let (dx, dy) = st.run_offsets(&offsets, b);
            let r = &mut acc[start - base..start - base + S];
            for a in 0..S {
                let [ax, ay] = affine.map_or([0.0, 0.0], |af| af.velocity(dx[a], dy[a], n[a]));
                let r = &mut r[a];
                r[0] += n[a] * m;
                r[1] += n[a] * mvx + m * ax;
                r[2] += n[a] * mvy + m * ay;
                r[3] += n[a] * mbx - (gx[a] * vsxx + gy[a] * vsxy);
                r[4] += n[a] * mby - (gx[a] * vsxy + gy[a] * vsyy);
            }
        }
    }
}

/// (5) added to `f`:
///
/// ```text
/// f_x −= Gx (V∘σxx) + Gy (V∘σxy),   f_y −= Gx (V∘σxy) + Gy (V∘σyy)
/// ```
///
/// # Panics
/// If `f` does not have one entry per node.
pub fn add_internal_force(ops: &Operators, volume: &[f64], sxx: &[f64], syy: &[f64], sxy: &[f64], f: &mut VectorField) {
    let np = ops.num_particles();
    for field in [volume, sxx, syy, sxy] {
        assert_eq!(field.len(), np, "particle field length must equal the particle count");
    }
    assert_eq!(f.len(), ops.num_nodes(), "one force per node");
    crate::with_support!(ops, internal_force_columns::<S>(ops, [volume, sxx, syy, sxy], f));
}

fn internal_force_columns<const S: usize>(ops: &Operators, [volume, sxx, syy, sxy]: [&[f64]; 4], f: &mut VectorField) {
    for k in 0..ops.num_particles() {
        let (txx, tyy, txy) = (volume[k] * sxx[k], volume[k] * syy[k], volume[k] * sxy[k]);
        let st = ops.stencil::<S>(k);
        for b in 0..S {
            let (start, _, gx, gy) = st.row(b);
            let (fx, fy) = (&mut f.x[start..start + S], &mut f.y[start..start + S]);
            for a in 0..S {
                fx[a] -= gx[a] * txx + gy[a] * txy;
                fy[a] -= gx[a] * txy + gy[a] * tyy;
            }
        }
    }
}

/// MUSL's re-projection of the updated particle velocities into `grid.momentum`, with the
/// operators and positions of the start of the step:
///
/// ```text
/// q' = N (m ∘ v_p) [+ APIC: Σ_p N_Ip m_p C_p (x_I − x_p)]
/// ```
pub fn reproject_momentum(
    ops: &Operators,
    p: &Particles,
    apic: Option<ApicInertia>,
    grid: &mut GridState,
    workers: &Workers,
) {
    let span = ops.node_span();
    assert!(
        span.end <= grid.momentum.len() && grid.span == span,
        "reproject_momentum follows a p2g with the same operators"
    );
    let (acc, base) = scatter_bands(ops, &mut grid.accumulator, workers, |acc, base, lines| {
        crate::with_support!(ops, reproject_columns::<S>(ops, p, apic, acc, base, lines))
    });
    for i in span {
        grid.momentum.x[i] = acc[i - base][1];
        grid.momentum.y[i] = acc[i - base][2];
    }
}

fn reproject_columns<const S: usize>(
    ops: &Operators,
    p: &Particles,
    apic: Option<ApicInertia>,
    acc: &mut [[f64; 5]],
    base: usize,
    lines: std::ops::Range<usize>,
) {
    for k in 0..p.len() {
        let l0 = ops.first_line(k);
        if l0 + S <= lines.start || l0 >= lines.end {
            continue;
        }
        let m = p.mass[k];
        let affine = apic.map(|kind| apic_affine(p, k, ops, kind));
        let st = ops.stencil::<S>(k);
        let offsets = st.offsets(p.x[k], p.y[k]);
        for b in 0..S {
            if !lines.contains(&(l0 + b)) {
                continue;
            }
            let (start, n) = st.n_row(b);
            let (dx, dy) = st.run_offsets(&offsets, b);
            let r = &mut acc[start - base..start - base + S];
            for a in 0..S {
                let [ax, ay] = affine.map_or([0.0, 0.0], |af| af.velocity(dx[a], dy[a], n[a]));
                r[a][1] += n[a] * m * p.vx[k] + m * ax;
                r[a][2] += n[a] * m * p.vy[k] + m * ay;
            }
        }
    }
}

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

fn gradient_block<const S: usize>(ops: &Operators, u: &VectorField, first: usize, l: [&mut [f64]; 4]) {
    for j in 0..l[0].len() {
        let mut g = [0.0; 4];
        let st = ops.stencil::<S>(first + j);
        for b in 0..S {
            let (start, _, gx, gy) = st.row(b);
            let (ux, uy) = (&u.x[start..start + S], &u.y[start..start + S]);
            for a in 0..S {
                g[0] += gx[a] * ux[a];
                g[1] += gy[a] * ux[a];
                g[2] += gx[a] * uy[a];
                g[3] += gy[a] * uy[a];
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
    if packed.capacity() < grid.mass.len() {
        // Address space for the whole grid, so that a growing span never reallocates.
        packed.reserve_exact(grid.mass.len() - packed.len());
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
    let out = (
        [&mut p.vx[..], &mut p.vy[..]],
        (
            [
                &mut p.affine_xx[..],
                &mut p.affine_xy[..],
                &mut p.affine_yx[..],
                &mut p.affine_yy[..],
            ],
            (
                scratch.velocity_gradient.each_mut().map(|v| &mut v[..]),
                [&mut scratch.displacement.x[..], &mut scratch.displacement.y[..]],
            ),
        ),
    );
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
type G2pOutput<'a> = (
    [&'a mut [f64]; 2],
    ([&'a mut [f64]; 4], ([&'a mut [f64]; 4], [&'a mut [f64]; 2])),
);

/// The particle loop of [`g2p`] for the particles from `first` (a block), for a support of
/// `S` nodes per axis; the block's kinetic energies.
fn g2p_block<const S: usize>(input: &G2pInput, first: usize, out: G2pOutput) -> KineticEnergies {
    let ([vel_x, vel_y], (affine, (grad, [disp_x, disp_y]))) = out;
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
                    l[0] += gxv[a] * gx;
                    l[1] += gyv[a] * gx;
                    l[2] += gxv[a] * gy;
                    l[3] += gyv[a] * gy;
                }
                if apic {
                    lw[0] += gxv[a] * wx;
                    lw[1] += gyv[a] * wx;
                    lw[2] += gxv[a] * wy;
                    lw[3] += gyv[a] * wy;
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
            _ if trapezoidal => (0.5 * (old_x + vx), 0.5 * (old_y + vy)),
            _ => (vx, vy),
        };
        disp_x[j] = dt * ux;
        disp_y[j] = dt * uy;
    }
    kinetic
}

/// Work arrays of [`extend_to_inactive_nodes`], kept between calls so that it allocates
/// nothing once they have grown to the node count.
#[derive(Debug, Clone, Default)]
pub struct ExtensionScratch {
    sum: VectorField,
    count: Vec<u32>,
}

impl ExtensionScratch {
    /// Work arrays already sized for `num_nodes` nodes.
    pub fn new(num_nodes: usize) -> ExtensionScratch {
        ExtensionScratch {
            sum: VectorField::zeros(num_nodes),
            count: vec![0; num_nodes],
        }
    }
}

/// Gives the inactive nodes in some particle's support the mean interpolated velocity of those
/// particles ([`crate::transfer::extend_to_massless_nodes`]), with the active nodes as a mask
/// (`is_active[I]`) and reused work arrays:
///
/// ```text
/// v_I = (1/|P_I|) Σ_{p ∈ P_I} (Nᵀ v)_p     for inactive I,   P_I = {p : I in the support of p}
/// ```
///
/// Only the columns of particles that touch an inactive node are visited; returns whether any
/// node was changed.
///
/// # Panics
/// If `v` or `is_active` does not have one entry per node.
pub fn extend_to_inactive_nodes(
    ops: &Operators,
    is_active: &[bool],
    v: &mut VectorField,
    scratch: &mut ExtensionScratch,
) -> bool {
    let n = ops.num_nodes();
    assert!(
        v.len() == n && is_active.len() == n,
        "one velocity and one flag per node"
    );
    let any = crate::with_support!(ops, extend_columns::<S>(ops, is_active, v, scratch));
    if any {
        for i in 0..n {
            if scratch.count[i] > 0 {
                let c = scratch.count[i] as f64;
                v.x[i] = scratch.sum.x[i] / c;
                v.y[i] = scratch.sum.y[i] / c;
            }
        }
    }
    any
}

/// The particle loop of [`extend_to_inactive_nodes`]: sums and counts into the scratch; whether
/// any particle touches an inactive node.
fn extend_columns<const S: usize>(
    ops: &Operators,
    is_active: &[bool],
    v: &VectorField,
    scratch: &mut ExtensionScratch,
) -> bool {
    let n = ops.num_nodes();
    let mut any = false;
    for p in 0..ops.num_particles() {
        let st = ops.stencil::<S>(p);
        let all_active = (0..S).all(|b| {
            let (start, _) = st.n_row(b);
            is_active[start..start + S].iter().all(|&x| x)
        });
        if all_active {
            continue;
        }
        if !any {
            scratch.sum.x.clear();
            scratch.sum.x.resize(n, 0.0);
            scratch.sum.y.clear();
            scratch.sum.y.resize(n, 0.0);
            scratch.count.clear();
            scratch.count.resize(n, 0);
            any = true;
        }
        let (mut vx, mut vy) = (0.0, 0.0);
        for b in 0..S {
            let (start, nv) = st.n_row(b);
            for a in 0..S {
                vx += nv[a] * v.x[start + a];
                vy += nv[a] * v.y[start + a];
            }
        }
        for b in 0..S {
            let (start, _) = st.n_row(b);
            for a in 0..S {
                let i = start + a;
                if !is_active[i] {
                    scratch.sum.x[i] += vx;
                    scratch.sum.y[i] += vy;
                    scratch.count[i] += 1;
                }
            }
        }
    }
    any
}
