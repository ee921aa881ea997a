//! The truncated series of the full-mass inverse, written once for both of its uses: the
//! [`MassScheme::TruncatedSeries`](super::MassScheme::TruncatedSeries) solve (on the assembled
//! or stencil `M`) and the XPIC(k) / FMPM(k) transfers (by particle–grid products, `M` never
//! formed):
//!
//! ```text
//! v(k) = Σ_{ℓ=0}^{k−1} Δv_ℓ,   Δv_0 = u,   Δv_ℓ = Π (Δv_{ℓ−1} − M_L⁻¹ M Δv_{ℓ−1})
//! ```
//!
//! which is `Σ_{ℓ<k} (I − M_L⁻¹M)^ℓ u`; with `u = M_L⁻¹ r` it is the first `k` terms of
//! `M⁻¹ r = Σ_ℓ (I − M_L⁻¹ M)^ℓ M_L⁻¹ r`.

use super::options::MassScheme;
use super::GridMass;
use crate::fields::VectorField;
use crate::operators::{Operator, Operators};

/// Work arrays of the series, kept between calls so that it allocates nothing once they have
/// grown to size.
#[derive(Debug, Clone, Default)]
pub struct SeriesScratch {
    increment: VectorField,
    product: VectorField,
    at_particles: VectorField,
}

/// `out = Σ_{ℓ<k} (I − M_L⁻¹M)^ℓ u` (module docs), with `M` applied by `apply_m(x, M x)`,
/// `inv_m` holding `1/m_L,I` on active nodes and 0 elsewhere, and `constrain` (`Π`) zeroing
/// the components each increment must not have. `k = 1` returns `u`.
///
/// # Panics
/// On length mismatch, or `k = 0`.
pub(crate) fn series_into(
    k: usize,
    inv_m: &[f64],
    u: &VectorField,
    apply_m: &mut dyn FnMut(&VectorField, &mut VectorField, &mut VectorField),
    constrain: &dyn Fn(&mut VectorField),
    out: &mut VectorField,
    scratch: &mut SeriesScratch,
) {
    assert!(k >= 1, "the series needs at least one term");
    let n = inv_m.len();
    assert_eq!(u.len(), n, "one velocity and one inverse mass per node");
    let SeriesScratch {
        increment: dv,
        product: q,
        at_particles,
    } = scratch;
    for field in [&mut *out, &mut *dv, &mut *q] {
        field.x.resize(n, 0.0);
        field.y.resize(n, 0.0);
    }
    out.x.copy_from_slice(&u.x);
    out.y.copy_from_slice(&u.y);
    dv.x.copy_from_slice(&u.x);
    dv.y.copy_from_slice(&u.y);
    for _ in 1..k {
        apply_m(dv, q, at_particles);
        for i in 0..n {
            dv.x[i] -= q.x[i] * inv_m[i];
            dv.y[i] -= q.y[i] * inv_m[i];
        }
        constrain(dv);
        for i in 0..n {
            out.x[i] += dv.x[i];
            out.y[i] += dv.y[i];
        }
    }
}

/// The operator of [`series_velocity_into`]: `M = N diag(m) Nᵀ` applied through the operators
/// (never assembled), `M_L⁻¹` as `inv_m`, and `Π₀`, which zeroes the prescribed components of a
/// field.
#[derive(Clone, Copy)]
pub struct SeriesOperator<'a> {
    /// The operators (`N`).
    pub ops: &'a Operators,
    /// Particle masses `m`.
    pub m: &'a [f64],
    /// `1/m_L,I` on active nodes, 0 elsewhere.
    pub inv_m: &'a [f64],
    /// `Π₀`: zeroes the prescribed components of a field.
    pub constrain: &'a dyn Fn(&mut VectorField),
    /// Walls folded on the grid (slip walls under the mirror rule): `(v, true)` folds a grid
    /// field onto the interior, `v ← Cᵀ v`, `(v, false)` unfolds it, `v ← C v`; the product
    /// is then `Cᵀ N (m ∘ Nᵀ C x)`. `None` without such walls.
    pub walls: Option<crate::fields::GridFold<'a>>,
}

/// The truncated series applied to a lumped grid velocity `u` by particle–grid products only
/// (Nairn's FMPM loop):
///
/// ```text
/// v(k) = Σ_{ℓ<k} Δv_ℓ,   Δv_0 = u,   Δv_ℓ = Π₀ (Δv_{ℓ−1} − M_L⁻¹ N (m ∘ Nᵀ Δv_{ℓ−1}))
/// ```
///
/// which is `Σ_{ℓ<k} (I − M_L⁻¹M)^ℓ u = M_k⁻¹ M_L u`, `M_k⁻¹` the series of
/// [`crate::mass::MassScheme::TruncatedSeries`], when no component is constrained. `op.inv_m` holds
/// `1/m_L,I` on active nodes and 0 elsewhere; `op.constrain` (`Π₀`) zeroes the prescribed components
/// of each increment, so that the velocity boundary conditions `u` satisfies hold for `v(k)`
/// too. `k = 1` returns `u`.
///
/// # Panics
/// On length mismatch, or `k = 0`.
pub fn series_velocity_into(
    op: SeriesOperator<'_>,
    k: usize,
    u: &VectorField,
    out: &mut VectorField,
    scratch: &mut SeriesScratch,
) {
    let SeriesOperator {
        ops,
        m,
        inv_m,
        constrain,
        walls,
    } = op;
    assert_eq!(inv_m.len(), ops.num_nodes(), "one inverse mass per node");
    let np = ops.num_particles();
    let mut unfolded = VectorField::default();
    let mut apply_m = |x: &VectorField, mx: &mut VectorField, up: &mut VectorField| {
        up.x.resize(np, 0.0);
        up.y.resize(np, 0.0);
        let x = match walls {
            Some(walls) => {
                unfolded.clone_from(x);
                walls(&mut unfolded, false);
                &unfolded
            }
            None => x,
        };
        ops.gather(Operator::N, [&x.x, &x.y], [&mut up.x, &mut up.y]);
        ops.scatter_scaled(Operator::N, Some(m), [&up.x, &up.y], [&mut mx.x, &mut mx.y]);
        if let Some(walls) = walls {
            walls(mx, true);
        }
    };
    series_into(k, inv_m, u, &mut apply_m, constrain, out, scratch);
}

impl GridMass {
    /// The first `k` terms of `M⁻¹ rhs = Σ_l (I − M_L⁻¹ M)^l M_L⁻¹ rhs` on the free degrees of
    /// freedom (the plain `M`), 0 off F.
    pub(super) fn solve_series(&self, k: usize, rhs: &VectorField) -> VectorField {
        // k = 1 is the lumped solve: no product, and no matrix assembled.
        let m = self.matrices.operator(MassScheme::TruncatedSeries { k });
        let mut u0 = VectorField::default();
        self.solve_lumped(rhs, None, &mut u0);
        let free: [Vec<bool>; 2] = self
            .dofs
            .each_ref()
            .map(|d| d.local.iter().map(|&l| l != usize::MAX).collect());
        let constrain = |v: &mut VectorField| {
            for i in 0..v.len() {
                v.x[i] = if free[0][i] { v.x[i] } else { 0.0 };
                v.y[i] = if free[1][i] { v.y[i] } else { 0.0 };
            }
        };
        constrain(&mut u0);
        let mut apply_m = |x: &VectorField, mx: &mut VectorField, _: &mut VectorField| {
            let m = m.expect("assembled for the series of more than one term");
            mx.x = m.mul(&x.x);
            mx.y = m.mul(&x.y);
        };
        let mut out = VectorField::default();
        let mut scratch = SeriesScratch::default();
        series_into(k, &self.inverse, &u0, &mut apply_m, &constrain, &mut out, &mut scratch);
        out
    }
}
