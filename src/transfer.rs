//! Particle ↔ grid transfers written as products with N, Gx, Gy, and the explicit updates.
//!
//! Every function here is one line of the formulation (docs/formulation.md); nodal and
//! particle vector quantities are [`VectorField`]s (an x and a y component vector).

pub use crate::fields::{deformation_increment, StrainRate, VectorField, VelocityGradient};
pub use crate::kernels::{extend_to_inactive_nodes, ExtensionScratch};
pub use crate::mass::{series_velocity_into, SeriesScratch};
use nalgebra_sparse::{CooMatrix, CscMatrix};

use crate::operators::{Operator, Operators};

/// Grid momentum (the numerator of the seed's 4(A)):
///
/// ```text
/// q = N (m ∘ v)      (two n-vectors: qx = N (m ∘ vx), qy = N (m ∘ vy))
/// ```
///
/// # Panics
/// If an input's length is not the particle count.
pub fn momentum(ops: &Operators, m: &[f64], vx: &[f64], vy: &[f64]) -> VectorField {
    let mut q = VectorField::zeros(ops.num_nodes());
    ops.scatter_scaled(Operator::N, Some(m), [vx, vy], [&mut q.x, &mut q.y]);
    q
}

/// External grid force from body forces per unit mass (seed 3(A)):
///
/// ```text
/// f_ext = N (m ∘ b)  (two n-vectors)
/// ```
///
/// # Panics
/// If an input's length is not the particle count.
pub fn external_force(ops: &Operators, m: &[f64], bx: &[f64], by: &[f64]) -> VectorField {
    let mut f = VectorField::zeros(ops.num_nodes());
    ops.scatter_scaled(Operator::N, Some(m), [bx, by], [&mut f.x, &mut f.y]);
    f
}

/// Internal grid force, the divergence of stress (seed 3(B)):
///
/// ```text
/// f_int,x = −( Gx (V ∘ σxx) + Gy (V ∘ σxy) )
/// f_int,y = −( Gx (V ∘ σxy) + Gy (V ∘ σyy) )      (two n-vectors; V, σ are P-vectors)
/// ```
///
/// Computed in one pass over the shared pattern of Gx and Gy ([`crate::kernels::add_internal_force`]).
///
/// # Panics
/// If an input's length is not the particle count.
pub fn internal_force(ops: &Operators, volume: &[f64], sxx: &[f64], syy: &[f64], sxy: &[f64]) -> VectorField {
    let mut f = VectorField::zeros(ops.num_nodes());
    crate::kernels::add_internal_force(ops, volume, sxx, syy, sxy, &mut f);
    f
}

/// Grid → particle interpolation of a nodal vector field:
///
/// ```text
/// u_p = Nᵀ u_grid    (two P-vectors)
/// ```
///
/// # Panics
/// If `u` does not have one entry per node.
pub fn interpolate(ops: &Operators, u: &VectorField) -> VectorField {
    let mut out = VectorField::zeros(ops.num_particles());
    ops.gather(Operator::N, [&u.x, &u.y], [&mut out.x, &mut out.y]);
    out
}

/// The velocity gradient at the particles, `L = ∇v`:
///
/// ```text
/// Lxx = Gxᵀ v̄x   Lxy = Gyᵀ v̄x   Lyx = Gxᵀ v̄y   Lyy = Gyᵀ v̄y      (P-vectors)
/// ```
///
/// with `Lab = ∂v_a/∂x_b`.
///
/// # Panics
/// If `v` does not have one entry per node.
pub fn velocity_gradient(ops: &Operators, v: &VectorField) -> VelocityGradient {
    let np = ops.num_particles();
    let mut l = VelocityGradient {
        xx: vec![0.0; np],
        xy: vec![0.0; np],
        yx: vec![0.0; np],
        yy: vec![0.0; np],
    };
    ops.gather(Operator::Gx, [&v.x, &v.y], [&mut l.xx, &mut l.yx]);
    ops.gather(Operator::Gy, [&v.x, &v.y], [&mut l.xy, &mut l.yy]);
    l
}

/// Strain rate, the symmetric part of the velocity gradient (seed 4(E)):
///
/// ```text
/// ε̇xx = Lxx,   ε̇yy = Lyy,   ε̇xy = ½ (Lxy + Lyx) = ½ (Gyᵀ v̄x + Gxᵀ v̄y)
/// ```
pub fn strain_rate(l: &VelocityGradient) -> StrainRate {
    StrainRate {
        xx: l.xx.clone(),
        yy: l.yy.clone(),
        xy: l.xy.iter().zip(&l.yx).map(|(a, b)| 0.5 * (a + b)).collect(),
    }
}

/// Standard MPM position update with the updated grid velocity (seed 4(C), standard form):
///
/// ```text
/// x_p ← x_p + Δt Nᵀ v̄
/// ```
///
/// # Panics
/// On length mismatch.
pub fn update_positions(ops: &Operators, x: &mut [f64], y: &mut [f64], v_grid: &VectorField, dt: f64) {
    let v = interpolate(ops, v_grid);
    axpy(x, dt, &v.x);
    axpy(y, dt, &v.y);
}

/// The seed's position update as read in docs/homework.md, the trapezoidal rule between the
/// particle velocity before the step and the interpolated updated grid velocity:
///
/// ```text
/// x_p ← x_p + (Δt/2) (v_p + Nᵀ v̄)
/// ```
///
/// # Panics
/// On length mismatch.
pub fn update_positions_trapezoidal(
    ops: &Operators,
    x: &mut [f64],
    y: &mut [f64],
    vx_old: &[f64],
    vy_old: &[f64],
    v_grid: &VectorField,
    dt: f64,
) {
    let v = interpolate(ops, v_grid);
    axpy(x, 0.5 * dt, vx_old);
    axpy(x, 0.5 * dt, &v.x);
    axpy(y, 0.5 * dt, vy_old);
    axpy(y, 0.5 * dt, &v.y);
}

/// FLIP particle velocity update (seed 4(D)), the library's one FLIP rule (docs/formulation.md):
///
/// ```text
/// v_p ← v_p + Δt Nᵀ a      (= v_p + Nᵀ (v̄′ − v̄), the change of the grid velocity)
/// ```
///
/// `a` is zero on prescribed components, so a boundary condition reaches the particles through
/// the motion of the free nodes only, whatever the mass scheme.
///
/// # Panics
/// On length mismatch.
pub fn update_velocities(ops: &Operators, vx: &mut [f64], vy: &mut [f64], a: &VectorField, dt: f64) {
    let da = interpolate(ops, a);
    axpy(vx, dt, &da.x);
    axpy(vy, dt, &da.y);
}

/// Volume update by the determinant of the step's deformation increment, the library's one
/// volume update (the time loop's too):
///
/// ```text
/// V_p ← V_p det(I + Δt L_p) = V_p [(1 + Δt Lxx)(1 + Δt Lyy) − Δt² Lxy Lyx]
/// ```
///
/// It is the `J` of `F ← (I + Δt L) F`, so `V = V₀ det F` holds exactly step after step; the
/// first-order `V (1 + Δt tr ε̇)` drops the `Δt²` term and drifts from `det F`.
///
/// # Panics
/// On length mismatch.
pub fn update_volumes(volume: &mut [f64], l: &VelocityGradient, dt: f64) {
    assert_eq!(volume.len(), l.xx.len(), "one volume per particle");
    for p in 0..volume.len() {
        volume[p] *= deformation_increment([l.xx[p], l.xy[p], l.yx[p], l.yy[p]], dt).1;
    }
}

fn axpy(y: &mut [f64], a: f64, x: &[f64]) {
    assert_eq!(y.len(), x.len(), "vectors must have equal length");
    for (y, x) in y.iter_mut().zip(x) {
        *y += a * x;
    }
}

/// Gives the nodes that lie in some particle's support but carry no mass (inactive nodes) the
/// mean interpolated velocity of the particles whose support contains them:
///
/// ```text
/// v_I = (1/|P_I|) Σ_{p ∈ P_I} (Nᵀ v)_p     for inactive I,   P_I = {p : I in the support of p}
/// ```
///
/// Such nodes appear when a particle sits exactly on a grid line: its weight on the nodes of
/// the far side is 0, but its gradient there is not (see [`crate::shape::linear`]). Left at
/// zero velocity they would give the particle a spurious velocity gradient even under a rigid
/// translation; with this extension a uniform velocity field stays uniform and `Gᵀv` vanishes.
/// Interpolated values `Nᵀ v` are unchanged, because these nodes have zero weight at every
/// particle touching them.
///
/// `is_active` is the active set as a mask ([`crate::mass::GridMass::is_active`]).
///
/// # Panics
/// If `v` or `is_active` does not have one entry per node.
pub fn extend_to_massless_nodes(ops: &Operators, is_active: &[bool], v: &mut VectorField) {
    let mut scratch = ExtensionScratch::default();
    extend_to_inactive_nodes(ops, is_active, v, &mut scratch);
}

/// The extension of [`extend_to_massless_nodes`] as a matrix: `E = D⁻¹ S Nᵀ` (nodes × nodes),
/// with `S` the support of the inactive nodes (`S_Ip = 1` when inactive node `I` is in the
/// support of particle `p`) and `D = diag(S 1)` the number of particles whose support holds
/// each, so that
///
/// ```text
/// E_IJ = (1/|P_I|) Σ_{p ∈ P_I} N_Jp     for inactive I in some support (other rows empty)
/// ```
///
/// and `(E v)_I` is the extended value of node `I` for the values `v` before the extension. The
/// implicit step eliminates these nodes with it (their displacement follows the nodes they read).
///
/// # Panics
/// If `is_active` does not have one entry per node.
pub fn extension_matrix(ops: &Operators, is_active: &[bool]) -> CscMatrix<f64> {
    let n = ops.num_nodes();
    assert_eq!(is_active.len(), n, "one flag per node");
    let mut count = vec![0usize; n];
    for p in 0..ops.num_particles() {
        for (i, ..) in ops.column(p) {
            count[i] += usize::from(!is_active[i]);
        }
    }
    let mut s = CooMatrix::new(n, ops.num_particles());
    for p in 0..ops.num_particles() {
        for (i, ..) in ops.column(p) {
            if !is_active[i] {
                s.push(i, p, 1.0 / count[i] as f64);
            }
        }
    }
    let n_transposed = ops.n_matrix().transpose();
    &CscMatrix::from(&s) * &n_transposed
}
