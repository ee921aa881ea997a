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
use crate::mass::{weighted_product, GridMass, Role};
use crate::material::LinearElastic;
use crate::operators::{Operator, Operators};
use crate::spectral::{lanczos_extremes, start_vector, DEFAULT_LANCZOS_STEPS};
use crate::transfer::{internal_force, velocity_gradient, VectorField};

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
    let l = velocity_gradient(ops, u);
    let np = ops.num_particles();
    let (mut sxx, mut syy, mut sxy) = (vec![0.0; np], vec![0.0; np], vec![0.0; np]);
    for p in 0..np {
        [sxx[p], syy[p], sxy[p]] = material.stress_increment(l.xx[p], l.yy[p], 0.5 * (l.xy[p] + l.yx[p]));
    }
    let f = internal_force(ops, volume, &sxx, &syy, &sxy);
    VectorField {
        x: f.x.iter().map(|v| -v).collect(),
        y: f.y.iter().map(|v| -v).collect(),
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
    let (fx, fy) = mass.free_dofs();
    let mut is_free = vec![false; 2 * n];
    fx.iter().for_each(|&i| is_free[i] = true);
    fy.iter().for_each(|&i| is_free[n + i] = true);
    let split = |v: &[f64]| VectorField {
        x: v[..n].to_vec(),
        y: v[n..].to_vec(),
    };
    let join = |f: VectorField| [f.x, f.y].concat();
    let k = |v: &[f64]| {
        let mut kv = join(apply_stiffness(ops, volume, material, &split(v)));
        kv.iter_mut()
            .zip(&is_free)
            .for_each(|(x, free)| *x = if *free { *x } else { 0.0 });
        kv
    };
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
