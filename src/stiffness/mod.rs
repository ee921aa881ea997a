//! The grid stiffness matrix assembled from Gx and Gy, and the critical explicit time step of
//! each mass scheme.
//!
//! With degrees of freedom ordered `[u_x at nodes 0..n, u_y at nodes 0..n]`, the linear-elastic
//! stiffness of the particles is `K = Bᵀ D B` with the strain `(εxx, εyy, γxy) = (Gxᵀ u_x,
//! Gyᵀ u_y, Gyᵀ u_x + Gxᵀ u_y)` and `D = V ∘ [[C11, C12, 0], [C12, C11, 0], [0, 0, G]]`:
//!
//! ```text
//! K_xx = Gx diag(V C11) Gxᵀ + Gy diag(V G) Gyᵀ      K_xy = Gx diag(V C12) Gyᵀ + Gy diag(V G) Gxᵀ
//! K_yx = K_xyᵀ                                      K_yy = Gy diag(V C11) Gyᵀ + Gx diag(V G) Gxᵀ
//! ```
//!
//! `K u` is also `−f_int(σ(u))`: the internal force of the stress the displacement `u` causes,
//! which [`apply_stiffness`] computes without forming K.

use nalgebra_sparse::{CooMatrix, CscMatrix};

use crate::error::Result;
use crate::mass::{GridMass, MassScheme, Role};
use crate::material::LinearElastic;
use crate::operators::weighted_product;
use crate::operators::{Operator, Operators};
use crate::shape::ShapeFunction;
use crate::spectral::{lanczos_extremes, lanczos_max, lobpcg_max, start_sequence, start_vector, DEFAULT_LANCZOS_STEPS};
use crate::transfer::VectorField;

mod bound;
pub use bound::BAND_STEPS;
pub(crate) use bound::{component_node_top, mpm_update_bound_estimate, BoundRun, BoundWork, ParticleStiffness};

/// The grid stiffness `K = Bᵀ D B` (2n × 2n, x degrees of freedom first), from four weighted
/// products per block as in the [module docs](self).
///
/// # Panics
/// If `volume.len()` is not the particle count.
pub fn stiffness_matrix(ops: &Operators, volume: &[f64], material: &LinearElastic) -> CscMatrix<f64> {
    let (c11, c12) = material.normal_stiffness();
    let g = material.shear_modulus();
    let scaled = |c: f64| volume.iter().map(|v| v * c).collect::<Vec<_>>();
    let (v11, v12, vg) = (scaled(c11), scaled(c12), scaled(g));
    let (gx, gy) = (Operator::Gx, Operator::Gy);
    let n = ops.num_nodes();
    let blocks = [
        (
            0,
            0,
            weighted_product(ops, gx, gx, &v11),
            weighted_product(ops, gy, gy, &vg),
        ),
        (
            0,
            n,
            weighted_product(ops, gx, gy, &v12),
            weighted_product(ops, gy, gx, &vg),
        ),
        (
            n,
            0,
            weighted_product(ops, gy, gx, &v12),
            weighted_product(ops, gx, gy, &vg),
        ),
        (
            n,
            n,
            weighted_product(ops, gy, gy, &v11),
            weighted_product(ops, gx, gx, &vg),
        ),
    ];
    let mut coo = CooMatrix::new(2 * n, 2 * n);
    for (r0, c0, a, b) in &blocks {
        for m in [a, b] {
            for (i, j, v) in m.triplet_iter() {
                coo.push(r0 + i, c0 + j, *v);
            }
        }
    }
    CscMatrix::from(&coo)
}

/// `K u` without forming K: the negative internal force of the stress `D B u`,
///
/// ```text
/// K u = −f_int(σ),   σ = C : ε(u),   ε(u) = sym [Gxᵀ u, Gyᵀ u]      (2 × n)
/// ```
///
/// # Panics
/// If `u` does not have one entry per node or `volume` one per particle.
pub fn apply_stiffness(ops: &Operators, volume: &[f64], material: &LinearElastic, u: &VectorField) -> VectorField {
    let (c11, c12) = material.normal_stiffness();
    let tangent = vec![[c11, c12, material.shear_modulus()]; ops.num_particles()];
    apply_tangent_stiffness(ops, volume, &tangent, u)
}

/// [`apply_stiffness`] with a tangent `[C11, C12, G]` per particle (see
/// [`crate::material::Material::tangent`]):
///
/// ```text
/// K u = −f_int(σ),   σ_p = C_p : ε_p(u),   ε(u) = sym [Gxᵀ u, Gyᵀ u]
/// ```
///
/// # Panics
/// If `u` does not have one entry per node, or `volume` and `tangent` one per particle.
pub fn apply_tangent_stiffness(ops: &Operators, volume: &[f64], tangent: &[[f64; 3]], u: &VectorField) -> VectorField {
    let np = ops.num_particles();
    assert_eq!(tangent.len(), np, "one tangent per particle");
    assert_eq!(volume.len(), np, "one volume per particle");
    assert_eq!(u.len(), ops.num_nodes(), "one displacement per node");
    let mut f = VectorField::zeros(ops.num_nodes());
    let tangent_of = |p: usize| tangent[p];
    crate::with_support!(ops, tangent_columns::<S>(ops, volume, &tangent_of, u, &mut f));
    // f holds f_int(σ); K u is its negation (exact).
    for v in f.x.iter_mut().chain(f.y.iter_mut()) {
        *v = -*v;
    }
    f
}

/// [`apply_tangent_stiffness`] into `f` (one entry per node, zero outside the operators' node
/// span, as this leaves it): `f` is cleared over the span only, so that a field reused across
/// products touches no page outside it.
pub(crate) fn apply_tangent_stiffness_into(
    ops: &Operators,
    volume: &[f64],
    tangent: &impl Fn(usize) -> [f64; 3],
    u: &VectorField,
    f: &mut VectorField,
) {
    let span = ops.node_span();
    assert!(
        u.len() == ops.num_nodes() && f.len() == ops.num_nodes(),
        "one value per node"
    );
    f.x[span.clone()].fill(0.0);
    f.y[span.clone()].fill(0.0);
    crate::with_support!(ops, tangent_columns::<S>(ops, volume, tangent, u, f));
    // f holds f_int(σ); K u is its negation (exact).
    for v in f.x[span.clone()].iter_mut().chain(f.y[span].iter_mut()) {
        *v = -*v;
    }
}

/// The free degrees of freedom of a grid field (`d < n`: x of node `d`; `d ≥ n`: y of node
/// `d − n`), and the maps between a field and the vector of its free entries.
pub(crate) struct FreeDofs {
    n: usize,
    /// The nodes whose x component is free, then those whose y component is, each ascending
    /// (32-bit: the operators number fewer than 2³² nodes): the free degrees of freedom in
    /// order.
    nodes: [Vec<u32>; 2],
}

impl FreeDofs {
    fn new(free: &[bool]) -> FreeDofs {
        let n = free.len() / 2;
        let of = |c: usize| (0..n).filter(|&i| free[c * n + i]).map(|i| i as u32).collect();
        FreeDofs {
            n,
            nodes: [of(0), of(1)],
        }
    }

    /// Every free degree of freedom as (component, node), in order.
    fn each(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        (0..2).flat_map(move |c| self.nodes[c].iter().map(move |&i| (c, i as usize)))
    }

    /// The free entries of `field`.
    fn compress(&self, field: &VectorField) -> Vec<f64> {
        let f = [&field.x, &field.y];
        self.each().map(|(c, i)| f[c][i]).collect()
    }

    /// [`start_vector`] of all `2n` degrees of freedom on the free ones, at the free ones (the
    /// same pseudo-random sequence, without the full vector).
    fn start_vector(&self) -> Vec<f64> {
        let n = self.n;
        let mut next = self.each().map(|(c, i)| c * n + i).peekable();
        let mut out = Vec::new();
        start_sequence(2 * n, |d, value| {
            if next.peek() == Some(&d) {
                next.next();
                out.push(value);
            }
        });
        out
    }

    /// `x_d ← x_d · inv(node of d)` for each free entry `x_d`: the lumped solve `r · (1/m_L)`.
    fn scale(&self, x: &mut [f64], inv: &[f64]) {
        for ((_, i), v) in self.each().zip(x) {
            *v *= inv[i];
        }
    }

    /// Writes the free entries `v` into `field`, whose other entries stay as they are (zero
    /// for the fields of an estimate).
    fn expand(&self, v: &[f64], field: &mut VectorField) {
        let (vx, vy) = v.split_at(self.nodes[0].len());
        for (&i, &x) in self.nodes[0].iter().zip(vx) {
            field.x[i as usize] = x;
        }
        for (&i, &y) in self.nodes[1].iter().zip(vy) {
            field.y[i as usize] = y;
        }
    }
}

/// The particle loop of [`apply_tangent_stiffness`]: per particle its `L = [Gxᵀ u, Gyᵀ u]`,
/// `σ = C : sym L` and its part of `f_int`, in one sweep over its stencil (no per-particle
/// arrays; the sums in the order of `transfer::velocity_gradient` and
/// `kernels::add_internal_force`, so the same bits as those products in turn).
fn tangent_columns<const S: usize>(
    ops: &Operators,
    volume: &[f64],
    tangent: &impl Fn(usize) -> [f64; 3],
    u: &VectorField,
    f: &mut VectorField,
) {
    for p in 0..ops.num_particles() {
        let st = ops.stencil::<S>(p);
        let (mut lxx, mut lxy, mut lyx, mut lyy) = (0.0, 0.0, 0.0, 0.0);
        for b in 0..S {
            let (start, _, gx, gy) = st.row(b);
            let (ux, uy) = (&u.x[start..start + S], &u.y[start..start + S]);
            for a in 0..S {
                lxx += gx[a] * ux[a];
                lyx += gx[a] * uy[a];
                lxy += gy[a] * ux[a];
                lyy += gy[a] * uy[a];
            }
        }
        let [c11, c12, g] = tangent(p);
        let (sxx, syy, sxy) = (c11 * lxx + c12 * lyy, c12 * lxx + c11 * lyy, g * (lxy + lyx));
        let t = [volume[p] * sxx, volume[p] * syy, volume[p] * sxy];
        crate::kernels::subtract_particle_force(&st, t, f);
    }
}

/// `K u` on the padded layout of a stencil mass (node `i` at `i + shift`, wrapping), masked
/// by `mask` (0: dropped), in lanes ([`crate::kernels::subtract_tangent_forces`]):
///
/// ```text
/// f = mask ∘ K u,   K u = −f_int(σ),   σ_p = C_p : sym L_p(u)
/// ```
pub(crate) fn apply_tangent_stiffness_shifted(
    ops: &Operators,
    volume: &[f64],
    tangents: &[[f64; 3]],
    u: [&[f64]; 2],
    f: [&mut [f64]; 2],
    shift: usize,
    mask: [&[f64]; 2],
) {
    let [fx, fy] = f;
    fx.fill(0.0);
    fy.fill(0.0);
    crate::kernels::subtract_tangent_forces(ops, volume, tangents, u, [&mut *fx, &mut *fy], shift);
    for (f, m) in [(fx, mask[0]), (fy, mask[1])] {
        for (v, &m) in f.iter_mut().zip(m) {
            *v = if m == 0.0 { 0.0 } else { -*v };
        }
    }
}

/// The largest eigenvalue of `M⁻¹ K` on the free degrees of freedom, with `M⁻¹` the solve of
/// the mass scheme of `role` (whatever it is: lumped, consistent, blended, truncated series,
/// iterative), estimated by Lanczos in the `K` inner product:
///
/// ```text
/// ω²_max = λ_max(M⁻¹ K)
/// ```
///
/// # Errors
/// Those of [`GridMass::solve`].
pub fn max_frequency_squared(
    ops: &Operators,
    volume: &[f64],
    material: &LinearElastic,
    mass: &GridMass,
    role: Role,
) -> Result<f64> {
    let n = ops.num_nodes();
    let [fx, fy] = mass.free_dofs();
    let mut is_free = vec![false; 2 * n];
    fx.iter().for_each(|&i| is_free[i] = true);
    fy.iter().for_each(|&i| is_free[n + i] = true);
    let k = |v: &[f64]| on_free(join(apply_stiffness(ops, volume, material, &split(v))), &is_free);
    let mut failure = None;
    let start = start_vector(2 * n, |i| is_free[i]);
    let result = lanczos_extremes(
        &start,
        DEFAULT_LANCZOS_STEPS,
        |v| match mass.solve(role, &split(&k(v)), None, ops) {
            Ok((u, _)) => join(u),
            Err(e) => {
                failure.get_or_insert(e);
                vec![0.0; 2 * n]
            }
        },
        k,
    );
    if let Some(e) = failure {
        return Err(e);
    }
    Ok(result.map_or(0.0, |(_, max)| max.max(0.0)))
}

/// The critical time step of explicit central differences with the mass scheme of `role`:
///
/// ```text
/// Δt_crit = 2 / ω_max,   ω²_max = λ_max(M⁻¹ K)
/// ```
///
/// `f64::INFINITY` when there is no stiffness (no free degree of freedom).
///
/// # Errors
/// Those of [`GridMass::solve`].
pub fn critical_time_step(
    ops: &Operators,
    volume: &[f64],
    material: &LinearElastic,
    mass: &GridMass,
    role: Role,
) -> Result<f64> {
    let w2 = max_frequency_squared(ops, volume, material, mass, role)?;
    Ok(if w2 > 0.0 { 2.0 / w2.sqrt() } else { f64::INFINITY })
}

/// Safety factor of [`mpm_critical_time_step`] on the exact limit: the Lanczos estimate of `ω²_max`
/// converges from below, and this covers what is left of its error when it stops (its
/// tolerance is [`FREQUENCY_TOLERANCE`]), so that the step stays on the safe side of the
/// exact limit while within a few per cent of it (tests/time_step.rs).
pub const TIME_STEP_SAFETY: f64 = 0.98;

/// Relative change of the Lanczos estimate of `ω²_max` over five steps at which
/// [`mpm_max_frequency_squared`] stops.
pub const FREQUENCY_TOLERANCE: f64 = 1e-3;

/// Most Lanczos steps of one frequency estimate.
pub const FREQUENCY_MAX_STEPS: usize = 150;

/// The inverse of a grid mass, `u = M_s⁻¹ r`, with zero on the nodes and components that are
/// not free (inactive or prescribed).
pub type MassInverse<'a> = dyn FnMut(&VectorField) -> Result<VectorField> + 'a;

/// The largest squared frequency of the explicit MPM update, and how it was found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrequencyEstimate {
    /// `ω²_max` (0 when there is no stiffness).
    pub omega_squared: f64,
    /// Lanczos steps taken (summed over the two runs of a mixed pair), or LOBPCG steps for
    /// [`mpm_mass_bound_frequency_squared`].
    pub lanczos_steps: usize,
}

/// `ω²_max` of one explicit MPM step with the mass `M_v` in the velocity projection and `M_a`
/// in the acceleration solve (update-stress-first or modified update-stress-last):
///
/// ```text
/// v_p ← v_p − Δt Nᵀ M_a⁻¹ G (V σ),   σ ← σ + Δt C Gᵀ M_v⁻¹ N (m ∘ v_p)
///   ⇒  ω²_max = λ_max(M_a⁻¹ K M_v⁻¹ M),   K = G diag(V C) Gᵀ,   M = N diag(m) Nᵀ
/// ```
///
/// With FLIP the particle update is a leapfrog pair, stable for `Δt ≤ 2/ω_max` (PIC-type
/// transfers: see [`mpm_critical_time_step`]). Here `M` is always the
/// particles' own consistent mass, whatever masses the solves use, so the lumped mass gives
/// `λ_max(M_L⁻¹ K M_L⁻¹ M)`, which stays bounded where a node's support empties. With
/// `M_a = M_v = M_s` the operator `M_s⁻¹ M M_s⁻¹ K` is self-adjoint in the `K` inner product and
/// Lanczos estimates its top eigenvalue; for a mixed pair the estimate is the bound
/// `ω²_max ≤ √(λ_max(M_v⁻¹ M M_v⁻¹ K) λ_max(M_a⁻¹ M M_a⁻¹ K))` (the norms of the two halves of
/// the update in the energy norms). `free[d]` marks the free degrees of freedom (`d < n`: x
/// component of node `d`, then y). Lanczos starts from a fixed pseudo-random vector.
///
/// # Errors
/// Those of the mass inverses.
///
/// # Panics
/// On length mismatch.
pub fn mpm_max_frequency_squared(
    ops: &Operators,
    mass: &[f64],
    volume: &[f64],
    tangent: &[[f64; 3]],
    free: &[bool],
    inverse_velocity: &mut MassInverse<'_>,
    inverse_acceleration: Option<&mut MassInverse<'_>>,
) -> Result<FrequencyEstimate> {
    let tangent_of = |p: usize| tangent[p];
    let velocity = Inverse::Solve(inverse_velocity);
    let acceleration = inverse_acceleration.map(Inverse::Solve);
    let space = FreeSpace { free, walls: None };
    max_frequency_squared_with(ops, mass, volume, &tangent_of, space, velocity, acceleration)
}

/// The degrees of freedom [`max_frequency_squared_with`] iterates on: the free flags, and the
/// walls folded on the grid (slip walls under the mirror rule: `(v, true)` folds a grid field,
/// `v ← Cᵀ v`, `(v, false)` unfolds it, `v ← C v`), around whose products `K` and `M` become
/// `Cᵀ K C` and `Cᵀ M C`.
#[derive(Clone, Copy)]
pub(crate) struct FreeSpace<'a> {
    /// One flag per degree of freedom (x of every node, then y).
    pub free: &'a [bool],
    /// The fold of walls folded on the grid, if any.
    pub walls: Option<crate::fields::GridFold<'a>>,
}

/// How [`max_frequency_squared_with`] applies a mass inverse.
pub(crate) enum Inverse<'a, 'b> {
    /// A solve of grid fields.
    Solve(&'a mut MassInverse<'b>),
    /// The lumped mass: `1/m_L` per node (0 where inactive), applied to the free entries.
    Lumped(&'a [f64]),
}

/// [`mpm_max_frequency_squared`] with each particle's tangent from `tangent(p)` and each mass
/// inverse as an [`Inverse`]: the same operations (and bits) for either form of an inverse.
/// Lanczos runs on the free degrees of freedom only (every other entry of its vectors is zero,
/// and stays zero): a grid field is expanded from them and compressed back around each
/// product, so that the iteration holds a few vectors of the free count and two grid fields
/// (four with a solve), written over the node span only.
pub(crate) fn max_frequency_squared_with(
    ops: &Operators,
    mass: &[f64],
    volume: &[f64],
    tangent: &impl Fn(usize) -> [f64; 3],
    space: FreeSpace<'_>,
    velocity: Inverse<'_, '_>,
    acceleration: Option<Inverse<'_, '_>>,
) -> Result<FrequencyEstimate> {
    let (n, free) = (ops.num_nodes(), space.free);
    assert_eq!(free.len(), 2 * n, "one flag per degree of freedom");
    let dofs = FreeDofs::new(free);
    let fold = |v: &mut VectorField, to_interior: bool| {
        if let Some(walls) = space.walls {
            walls(v, to_interior);
        }
    };
    let k_into = |v: &[f64], u: &mut VectorField, f: &mut VectorField| -> Vec<f64> {
        dofs.expand(v, u);
        fold(u, false);
        apply_tangent_stiffness_into(ops, volume, tangent, u, f);
        fold(f, true);
        dofs.compress(f)
    };
    let mass_into = |u: &mut VectorField, f: &mut VectorField| {
        fold(u, false);
        ops.mass_product_into(mass, u, f);
        fold(f, true);
    };
    let start = dofs.start_vector();
    let run = |inverse: Inverse<'_, '_>| -> Result<(f64, usize)> {
        let mut failure = None;
        // Two grid fields, shared by the two products (Lanczos applies them one after the other).
        let fields = std::cell::RefCell::new((VectorField::zeros(n), VectorField::zeros(n)));
        let mut inverse = inverse;
        let mut apply = |v: &[f64]| -> Vec<f64> {
            let (u, f) = &mut *fields.borrow_mut();
            let kv = k_into(v, u, f);
            let step = match &mut inverse {
                // u = M_L⁻¹ r as GridMass::solve_lumped forms it on the free entries.
                Inverse::Lumped(inv) => {
                    let mut w = kv;
                    dofs.scale(&mut w, inv);
                    dofs.expand(&w, u);
                    mass_into(u, f);
                    let mut out = dofs.compress(f);
                    dofs.scale(&mut out, inv);
                    Ok(out)
                }
                Inverse::Solve(solve) => {
                    dofs.expand(&kv, u);
                    solve(u)
                        .and_then(|mut w| {
                            mass_into(&mut w, f);
                            solve(f)
                        })
                        .map(|w| dofs.compress(&w))
                }
            };
            match step {
                Ok(w) => w,
                Err(e) => {
                    failure.get_or_insert(e);
                    vec![0.0; v.len()]
                }
            }
        };
        let k = |v: &[f64]| {
            let (u, f) = &mut *fields.borrow_mut();
            k_into(v, u, f)
        };
        let result = lanczos_max(&start, FREQUENCY_MAX_STEPS, FREQUENCY_TOLERANCE, &mut apply, k);
        if let Some(e) = failure {
            return Err(e);
        }
        Ok(result.map_or((0.0, 0), |(top, steps)| (top.max(0.0), steps)))
    };
    let (velocity, steps_v) = run(velocity)?;
    let (omega_squared, lanczos_steps) = match acceleration {
        None => (velocity, steps_v),
        Some(inverse) => {
            let (acceleration, steps_a) = run(inverse)?;
            ((velocity * acceleration).sqrt(), steps_v + steps_a)
        }
    };
    Ok(FrequencyEstimate {
        omega_squared,
        lanczos_steps,
    })
}

/// An upper bound of [`mpm_max_frequency_squared`] that needs no mass solve, for a mass `M_s`
/// that bounds the particles' consistent mass from above (`M_s ⪰ M`) in both solves:
///
/// ```text
/// ω²_max = λ_max(M_s⁻¹ K M_s⁻¹ M) ≤ λ_max(M_s⁻¹ K) = max_x (xᵀK x)/(xᵀM_s x),   K = G diag(V C) Gᵀ
/// ```
///
/// (`M_s^{-1/2} M M_s^{-1/2} ⪯ I`, so the velocity projection can only lower the frequency;
/// equality for `M_s = M`). The largest eigenvalue of the pencil `(K_FF, M_s,FF)` on the free
/// degrees of freedom is found by [`lobpcg_max`] with products by `K` and `M_s` only,
/// preconditioned by `d⁻¹`, `d` a diagonal close to that of `M_s`; `mass_times(c, x)` is
/// `M_s x` for component `c`. Measured on the benchmark's random block (linear shape functions,
/// 65,536 particles): 6% above the exact value with the linear-extension penalty
/// (`GridMass::bounding_mass` says where the time loop uses it).
///
/// # Panics
/// On length mismatch.
pub fn mpm_mass_bound_frequency_squared(
    ops: &Operators,
    volume: &[f64],
    tangent: &[[f64; 3]],
    free: &[bool],
    mut mass_times: impl FnMut(usize, &[f64]) -> Vec<f64>,
    diagonal: &[f64],
) -> FrequencyEstimate {
    let n = ops.num_nodes();
    assert_eq!(free.len(), 2 * n, "one flag per degree of freedom");
    assert_eq!(diagonal.len(), n, "one diagonal entry per node");
    let k = |v: &[f64]| on_free(join(apply_tangent_stiffness(ops, volume, tangent, &split(v))), free);
    let b = |v: &[f64]| {
        let v = on_free(v.to_vec(), free);
        let mut out = mass_times(0, &v[..n]);
        out.extend(mass_times(1, &v[n..]));
        on_free(out, free)
    };
    let precondition = |r: &[f64]| -> Vec<f64> {
        (0..2 * n)
            .map(|d| {
                let m = diagonal[d % n];
                if free[d] && m > 0.0 {
                    r[d] / m
                } else {
                    0.0
                }
            })
            .collect()
    };
    // The top of the pencil's spectrum is oscillatory: a start alternating in sign from node to
    // node along both axes reaches it in fewer steps than a smooth one.
    let parity: Vec<bool> = match ops.grid() {
        Some(g) => (0..n)
            .map(|i| {
                let (a, b) = g.node_ij(i);
                (a + b) % 2 == 1
            })
            .collect(),
        None => vec![false; n],
    };
    let mut start = start_vector(2 * n, |d| free[d]);
    start
        .iter_mut()
        .enumerate()
        .filter(|(d, _)| parity[d % n])
        .for_each(|(_, v)| *v = -*v);
    let result = lobpcg_max(&start, FREQUENCY_MAX_STEPS, FREQUENCY_TOLERANCE, k, b, precondition);
    let (omega_squared, lanczos_steps) = result.map_or((0.0, 0), |(top, steps)| (top.max(0.0), steps));
    FrequencyEstimate {
        omega_squared,
        lanczos_steps,
    }
}

/// The stable step of the explicit MPM update:
///
/// ```text
/// Δt = TIME_STEP_SAFETY · √(2 (1 + α)) / ω_max
/// ```
///
/// with `ω²_max` from [`mpm_max_frequency_squared`] and `α` the weight with which the particle
/// velocity keeps its own value (FLIP 1, a blend its FLIP weight, PIC, APIC, XPIC and FMPM 0).
/// A PIC-type update replaces `v_p` by `Φ v_p − Δt P σ` with a filter `Φ = Nᵀ M_v⁻¹ N diag(m)`
/// whose eigenvalues `φ` lie in `[α, 1]`; on a mode with `Δt² ω² = x` the update's characteristic
/// polynomial `λ² − (1 + φ − x) λ + φ` has its roots in the unit disk exactly when
/// `x ≤ 2 (1 + φ)` (Jury), so FLIP (`φ = 1`) is stable up to `2/ω` and a pure PIC filter, whose
/// smallest `φ` sit on the same high modes, only up to `√2/ω`. `f64::INFINITY` without stiffness.
pub fn mpm_critical_time_step(estimate: &FrequencyEstimate, flip_weight: f64) -> f64 {
    if estimate.omega_squared > 0.0 {
        TIME_STEP_SAFETY * (2.0 * (1.0 + flip_weight.clamp(0.0, 1.0))).sqrt() / estimate.omega_squared.sqrt()
    } else {
        f64::INFINITY
    }
}

/// Fraction of the FLIP part of the limit kept with linear shape functions or a truncated-series
/// mass, [`crossing_margin`]: measured on the benchmark's random falling block
/// (docs/simulation.md, "The time step").
pub const FLIP_CROSSING_MARGIN: f64 = 0.5;

/// The fraction of the frozen-configuration limit [`mpm_critical_time_step`] that the time loop
/// takes as its stable step, for a shape function, the masses of the two solves and a FLIP
/// weight `α`:
///
/// ```text
/// μ = 1 − α (1 − FLIP_CROSSING_MARGIN)   linear shape functions, or a truncated series (k ≥ 2) in a solve
/// μ = 1                                  otherwise
/// ```
///
/// [`mpm_max_frequency_squared`] is the limit of the update with the operators frozen, and the
/// operators change with every step. FLIP keeps the particle velocity, and with it the modes
/// the grid does not see; where the operators change abruptly (the gradient of a linear shape
/// function jumps when a particle crosses a grid line) or the velocity projection is not a
/// projection (the truncated series, `S M ≠ I`), the changes pump energy into the particles
/// well below the frozen limit. Measured on a random layout falling into a box (estimates at
/// every step): linear, lumped mass, +200% of the initial energy at 0.6 of the frozen FLIP
/// limit, +3.8% at 0.45; quadratic B-splines, series:8, +25% at 0.9, +11% at 0.7, +1.4% at
/// 0.5. PIC (`α = 0`) and the other masses with continuous-gradient kernels stayed within 2% at
/// 0.9, so they keep the limit whole. Between, `μ` is interpolated in `α`.
pub fn crossing_margin(shape: ShapeFunction, masses: [MassScheme; 2], flip_weight: f64) -> f64 {
    let abrupt = !shape.continuous_gradient();
    let series = masses.iter().any(|m| m.series_terms().is_some_and(|k| k >= 2));
    if abrupt || series {
        1.0 - flip_weight.clamp(0.0, 1.0) * (1.0 - FLIP_CROSSING_MARGIN)
    } else {
        1.0
    }
}

/// A vector of the `2n` degrees of freedom `[u_x at nodes 0..n, u_y at nodes 0..n]` as a field.
fn split(v: &[f64]) -> VectorField {
    let n = v.len() / 2;
    VectorField {
        x: v[..n].to_vec(),
        y: v[n..].to_vec(),
    }
}

/// A field as the vector of its `2n` degrees of freedom (the inverse of [`split`]).
fn join(f: VectorField) -> Vec<f64> {
    [f.x, f.y].concat()
}

/// `v` with 0 on the degrees of freedom that are not free.
fn on_free(mut v: Vec<f64>, free: &[bool]) -> Vec<f64> {
    v.iter_mut().zip(free).for_each(|(x, f)| *x = if *f { *x } else { 0.0 });
    v
}
