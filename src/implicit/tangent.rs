//! The internal force of the particles as a function of a grid displacement, and its exact
//! tangent, both products of the operators.
//!
//! Within a step the grid is fixed at the particles' positions at the step's start, `t_n`. A
//! grid displacement `u = (u_x, u_y)` (2n values, x first) moves particle `p` by
//! `Σ_I N_I(x_p) u_I` and deforms it by `F_inc = I + ∇u_p`, with the displacement gradient
//!
//! ```text
//! (∇u_p)_ab = Σ_I u_{aI} ∂_b N_I(x_p)      ∇u = 𝔾 u,   𝔾 = [[Gxᵀ, 0], [Gyᵀ, 0], [0, Gxᵀ], [0, Gyᵀ]]
//! ```
//!
//! (rows `4p + 2a + b`: `xx, xy, yx, yy`). The internal force is the divergence of the stress
//! measured in the step-start configuration, `P̃ = J_inc σ F_inc^{-T}` (the first
//! Piola–Kirchhoff stress relative to `t_n`), on the step-start volumes `V_n`:
//!
//! ```text
//! f_int(u) = −𝔾ᵀ s(u),   s_p = V_n,p P̃_p(F_inc,p)            (f_{aI} = −Σ_p V_p Σ_b P̃_ab ∂_b N_I)
//! K(u) = −∂f_int/∂u = 𝔾ᵀ 𝔻 𝔾,   𝔻 = blockdiag_p(V_n,p 𝔸_p),   𝔸_abcd = ∂P̃_ab/∂(∇u)_cd
//! ```
//!
//! At `u = 0` the force is the explicit step's `−Σ_p V_p σ_p ∇N_I`. The materials:
//!
//! ```text
//! linear elastic:  P̃ = σ_n + C : sym ∇u           (the rate form σ ← σ + C : ε̇ Δt over one step)
//!                  𝔸: xx,xx = yy,yy = C11;  xx,yy = yy,xx = C12;  {xy, yx} × {xy, yx} = G
//! neo-Hookean:     F = F_inc F_n,  P(F) = μ F + (λ ln J − μ) F^{-T},   P̃ = P F_nᵀ / J_n
//!                  𝔸_abce = (1/J_n) Σ_{B,D} A_aBcD (F_n)_bB (F_n)_eD,
//!                  A_aBcD = ∂P_aB/∂F_cD = μ δ_ac δ_BD + λ F⁻¹_Ba F⁻¹_Dc + (μ − λ ln J) F⁻¹_Bc F⁻¹_Da
//! elastoplastic:   P̃ = τ F_inc^{-T} / J_n,  τ the Kirchhoff stress of the return map from the
//!                  step-start state (crate::material::hencky, with its exact derivative)
//! ```
//!
//! All tangents are exact derivatives of their forces (`tests/implicit.rs` compares them with
//! central differences for every kernel) and symmetric: the hyperelastic `A` has major symmetry.

use nalgebra_sparse::{CooMatrix, CscMatrix};

use crate::error::{MpmError, Result};
use crate::fields::mat2_mul;
use crate::material::Material;
use crate::operators::Operators;
use crate::particles::Particles;

/// The displacement-gradient operator 𝔾 (4P × 2n) of the [module docs](self).
pub fn gradient_operator(ops: &Operators) -> CscMatrix<f64> {
    let (n, np) = (ops.num_nodes(), ops.num_particles());
    let mut coo = CooMatrix::new(4 * np, 2 * n);
    for p in 0..np {
        for (node, _, dx, dy) in ops.column(p) {
            for (a, offset) in [(0, 0), (1, n)] {
                coo.push(4 * p + 2 * a, offset + node, dx);
                coo.push(4 * p + 2 * a + 1, offset + node, dy);
            }
        }
    }
    CscMatrix::from(&coo)
}

/// The displacement gradients `∇u_p` (`[xx, xy, yx, yy]` per particle) of the grid displacement
/// `u` (x values then y values): `𝔾 u`.
///
/// # Panics
/// If `u.len() != 2 · nodes`.
pub fn displacement_gradients(ops: &Operators, u: &[f64]) -> Vec<[f64; 4]> {
    let n = ops.num_nodes();
    assert_eq!(u.len(), 2 * n, "a displacement has 2 values per node");
    (0..ops.num_particles())
        .map(|p| {
            let mut g = [0.0; 4];
            for (node, _, dx, dy) in ops.column(p) {
                g[0] += u[node] * dx;
                g[1] += u[node] * dy;
                g[2] += u[n + node] * dx;
                g[3] += u[n + node] * dy;
            }
            g
        })
        .collect()
}

/// The stress `P̃` (`[xx, xy, yx, yy]`) of particle `p` of `particles` at the incremental
/// displacement gradient `h = ∇u`, and its tangent `𝔸` (row `ab`, column `cd`), as in the
/// [module docs](self).
///
/// # Errors
/// [`MpmError::InvalidParticleValue`] (`det F`) when `F_inc` or `F` is not invertible with a
/// positive determinant.
pub fn particle_stress(
    material: &Material,
    particles: &Particles,
    p: usize,
    h: [f64; 4],
) -> Result<([f64; 4], [[f64; 4]; 4])> {
    let f_inc = [1.0 + h[0], h[1], h[2], 1.0 + h[3]];
    let j_inc = f_inc[0] * f_inc[3] - f_inc[1] * f_inc[2];
    if j_inc.is_nan() || j_inc <= 0.0 {
        return Err(MpmError::InvalidParticleValue {
            particle: p,
            field: "det F",
            value: j_inc,
            reason: "the step's displacement inverts the particle (det(I + ∇u) ≤ 0)",
        });
    }
    match material {
        Material::LinearElastic(m) => {
            let [dxx, dyy, dxy] = m.stress_increment(h[0], h[3], 0.5 * (h[1] + h[2]));
            let sxy = particles.sxy[p] + dxy;
            let sigma = [particles.sxx[p] + dxx, sxy, sxy, particles.syy[p] + dyy];
            Ok((sigma, m.stiffness_tensor()))
        }
        Material::NeoHookean(m) => {
            let fn_ = [particles.fxx[p], particles.fxy[p], particles.fyx[p], particles.fyy[p]];
            let j_n = fn_[0] * fn_[3] - fn_[1] * fn_[2];
            // F = F_inc F_n (row-major [xx, xy, yx, yy]).
            let f = mat2_mul(f_inc, fn_);
            let j = f[0] * f[3] - f[1] * f[2];
            if !(j > 0.0 && j_n > 0.0) {
                return Err(MpmError::InvalidParticleValue {
                    particle: p,
                    field: "det F",
                    value: j.min(j_n),
                    reason: "the deformation gradient must have a positive determinant",
                });
            }
            let (big_p, big_a) = m.first_piola_kirchhoff(f);
            // P̃ = P F_nᵀ / J_n;  𝔸_abce = (1/J_n) Σ_{B,D} A_aBcD (F_n)_bB (F_n)_eD.
            let fnm = |r: usize, c: usize| fn_[2 * r + c];
            let mut stress = [0.0; 4];
            let mut tangent = [[0.0; 4]; 4];
            for a in 0..2 {
                for b in 0..2 {
                    stress[2 * a + b] = (0..2).map(|bb| big_p[2 * a + bb] * fnm(b, bb)).sum::<f64>() / j_n;
                    for c in 0..2 {
                        for e in 0..2 {
                            let mut sum = 0.0;
                            for bb in 0..2 {
                                for d in 0..2 {
                                    sum += big_a[2 * a + bb][2 * c + d] * fnm(b, bb) * fnm(e, d);
                                }
                            }
                            tangent[2 * a + b][2 * c + e] = sum / j_n;
                        }
                    }
                }
            }
            Ok((stress, tangent))
        }
        Material::VonMises(_) | Material::DruckerPrager(_) => {
            let cone = material.cone().expect("an elastoplastic model has a cone");
            let j_n = particles.fxx[p] * particles.fyy[p] - particles.fxy[p] * particles.fyx[p];
            Ok(cone.relative_stress(&particles.plastic_state(p), h, j_n))
        }
    }
}

/// The internal force `f_int(u) = −𝔾ᵀ s(u)` (2n values, x first) and the tangent
/// `K(u) = 𝔾ᵀ 𝔻(u) 𝔾` of the [module docs](self), for the particles of `particles` (volumes,
/// stresses and deformation gradients of the step's start, materials by body) and the
/// operators `ops` of their positions. `gradient` is [`gradient_operator`]`(ops)`.
///
/// # Errors
/// The errors of [`particle_stress`].
pub fn internal_force_and_tangent(
    ops: &Operators,
    gradient: &CscMatrix<f64>,
    particles: &Particles,
    materials: &[Material],
    u: &[f64],
) -> Result<(Vec<f64>, CscMatrix<f64>)> {
    let np = ops.num_particles();
    let h = displacement_gradients(ops, u);
    let mut s = vec![0.0; 4 * np];
    let mut d = CooMatrix::new(4 * np, 4 * np);
    for p in 0..np {
        let (stress, tangent) = particle_stress(&materials[particles.body[p]], particles, p, h[p])?;
        let v = particles.volume[p];
        for r in 0..4 {
            s[4 * p + r] = v * stress[r];
            for c in 0..4 {
                if tangent[r][c] != 0.0 {
                    d.push(4 * p + r, 4 * p + c, v * tangent[r][c]);
                }
            }
        }
    }
    let d = CscMatrix::from(&d);
    let gt = gradient.transpose();
    let k = &gt * &(&d * gradient);
    let mut force = vec![0.0; gradient.ncols()];
    for (row, col, &v) in gradient.triplet_iter() {
        force[col] -= v * s[row];
    }
    Ok((force, k))
}

/// The internal force alone ([`internal_force_and_tangent`] without the tangent).
///
/// # Errors
/// The errors of [`particle_stress`].
pub fn internal_force(
    ops: &Operators,
    gradient: &CscMatrix<f64>,
    particles: &Particles,
    materials: &[Material],
    u: &[f64],
) -> Result<Vec<f64>> {
    let h = displacement_gradients(ops, u);
    let mut force = vec![0.0; gradient.ncols()];
    let mut s = vec![0.0; 4 * ops.num_particles()];
    for (p, hp) in h.iter().enumerate() {
        let (stress, _) = particle_stress(&materials[particles.body[p]], particles, p, *hp)?;
        for r in 0..4 {
            s[4 * p + r] = particles.volume[p] * stress[r];
        }
    }
    for (row, col, &v) in gradient.triplet_iter() {
        force[col] -= v * s[row];
    }
    Ok(force)
}
