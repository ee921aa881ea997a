//! The field types the products read and write: a 2D vector at every node or particle
//! ([`VectorField`]), and the velocity gradient and strain rate at every particle. They are
//! re-exported by [`crate::transfer`], where the products that make them live.

use crate::lanes::Real;

/// A fold of walls applied to grid fields (slip walls under the mirror rule,
/// `crate::boundary::mirror`): `(v, true)` folds `v` onto the interior nodes, `v ← Cᵀ v`;
/// `(v, false)` unfolds it, `v ← C v`.
pub type GridFold<'a> = &'a dyn Fn(&mut VectorField, bool);

/// A 2D vector quantity at every node or every particle, as two component vectors.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct VectorField {
    /// x components.
    pub x: Vec<f64>,
    /// y components.
    pub y: Vec<f64>,
}

impl VectorField {
    /// `len` zero vectors.
    pub fn zeros(len: usize) -> VectorField {
        VectorField {
            x: vec![0.0; len],
            y: vec![0.0; len],
        }
    }
    /// Number of entries.
    pub fn len(&self) -> usize {
        self.x.len()
    }
    /// Whether there are no entries.
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }
    /// `self + s · other`, entrywise.
    ///
    /// # Panics
    /// On length mismatch.
    pub fn add_scaled(&self, s: f64, other: &VectorField) -> VectorField {
        assert_eq!(self.len(), other.len(), "vector fields must have equal length");
        let f = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(a, b)| a + s * b).collect();
        VectorField {
            x: f(&self.x, &other.x),
            y: f(&self.y, &other.y),
        }
    }
    /// Sum of the components, `(Σ x, Σ y)`: total force or momentum on the grid.
    pub fn sum(&self) -> [f64; 2] {
        [self.x.iter().sum(), self.y.iter().sum()]
    }
}

/// Velocity gradient components per particle, `ab = ∂v_a/∂x_b`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct VelocityGradient {
    /// `∂vx/∂x`.
    pub xx: Vec<f64>,
    /// `∂vx/∂y`.
    pub xy: Vec<f64>,
    /// `∂vy/∂x`.
    pub yx: Vec<f64>,
    /// `∂vy/∂y`.
    pub yy: Vec<f64>,
}

/// Strain rate (tensor components) per particle.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct StrainRate {
    /// `ε̇xx`.
    pub xx: Vec<f64>,
    /// `ε̇yy`.
    pub yy: Vec<f64>,
    /// Tensor shear rate `ε̇xy` (half the engineering shear rate `γ̇xy`).
    pub xy: Vec<f64>,
}

/// The deformation increment of one particle over a step and its determinant, the one
/// definition both tiers use for (12) and (13):
///
/// ```text
/// G = I + Δt L = [1 + Δt Lxx, Δt Lxy; Δt Lyx, 1 + Δt Lyy],   J = det G = G₀₀ G₁₁ − G₀₁ G₁₀
/// ```
///
/// `l` and the returned `G` are row-major `[xx, xy, yx, yy]`.
pub fn deformation_increment(l: [f64; 4], dt: f64) -> ([f64; 4], f64) {
    deformation_increment_of(l, dt)
}

/// The product `A B` of `2 × 2` matrices stored row-major `[xx, xy, yx, yy]` (for one particle
/// or several side by side, [`Real`]): `F ← G F` of the deformation gradient's update.
#[inline(always)]
pub(crate) fn mat2_mul<R: Real>(a: [R; 4], b: [R; 4]) -> [R; 4] {
    [
        a[0] * b[0] + a[1] * b[2],
        a[0] * b[1] + a[1] * b[3],
        a[2] * b[0] + a[3] * b[2],
        a[2] * b[1] + a[3] * b[3],
    ]
}

/// [`deformation_increment`] for one particle or four side by side ([`Real`]).
#[inline(always)]
pub(crate) fn deformation_increment_of<R: Real>(l: [R; 4], dt: f64) -> ([R; 4], R) {
    let (one, dt) = (R::splat(1.0), R::splat(dt));
    let g = [one + dt * l[0], dt * l[1], dt * l[2], one + dt * l[3]];
    (g, g[0] * g[3] - g[1] * g[2])
}
