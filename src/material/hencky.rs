//! The finite-strain update of the elastoplastic models ([`super::plastic`]): the elastic
//! state is the logarithmic strain of the elastic left Cauchy–Green tensor,
//! `ε_e = ½ ln b_e`, `b_e = F_e F_eᵀ` (its in-plane components `xx, yy, xy` and the
//! out-of-plane `zz`, a principal direction), with the equivalent plastic strain `ε̄ᵖ`.
//! Over a step with the relative deformation gradient `f = I + h` (`h = Δt L`, or `∇u` of an
//! implicit step):
//!
//! ```text
//! b_e^tr = f exp(2 ε_e,n) fᵀ,   b_e,zz^tr = exp(2 ε_e,zz,n)   (plane strain: f_zz = 1)
//! ε^tr   = ½ ln b_e^tr = Σᵢ ε^tr_i nᵢ⊗nᵢ      (principal, in the plane; the third is zz)
//! (τᵢ, εᵢ, Δε̄ᵖ) = return(ε^tr, ε̄ᵖ_n)         (super::plastic)
//! ε_e = Σᵢ εᵢ nᵢ⊗nᵢ,   τ = Σᵢ τᵢ nᵢ⊗nᵢ,   σ = τ / J,   J = det F
//! ```
//!
//! (J. C. Simo, Comput. Methods Appl. Mech. Engrg. 99 (1992), Box 1: the exponential
//! update of `b_e` with the spatial return on its logarithm). In plane stress the zz strain
//! is the one that makes `τ_zz = 0` and `σ = τ / det F` is the stress per unit of the
//! reference thickness. The strain energy is `V₀ W(ε_e)`; the plastic dissipation of the step
//! is the plastic work of the returned stress on the plastic strain increment,
//! `V₀ τ : (ε^tr − ε_e) ≥ 0` (`≥ 0` for both models with `ψ ≤ φ`; the elastic energy the
//! return removes, `W(ε^tr) − W(ε_e)`, is larger by `½ Δεᵖ : C : Δεᵖ`, the second-order
//! part of the trial's energy that no stress did work for: counted, it made the dissipation of a
//! granular collapse four times the potential energy released).
//!
//! The implicit integrators take the stress relative to the step's start
//! `P̃ = τ f⁻ᵀ / J_n` and its exact derivative with respect to `h`
//! (`crate::implicit::particle_stress`):
//!
//! ```text
//! dP̃ = (dτ f⁻ᵀ − τ f⁻ᵀ dhᵀ f⁻ᵀ) / J_n,   db^tr = dh b_n fᵀ + f b_n dhᵀ
//! in the principal frame of b^tr (λᵢ its eigenvalues):
//!   dε̂ᵢᵢ = d b̂ᵢᵢ / (2λᵢ),   dε̂₁₂ = d b̂₁₂ (ε₁^tr − ε₂^tr)/(λ₁ − λ₂)
//!   dτ̂ᵢᵢ = Σⱼ Dᵢⱼ dε̂ⱼⱼ,     dτ̂₁₂ = dε̂₁₂ (τ₁ − τ₂)/(ε₁^tr − ε₂^tr)
//! ```
//!
//! with `D` the return's algorithmic tangent (condensed in plane stress) and the quotients'
//! limits `1/(2λ)` and `D₁₁ − D₁₂` at equal eigenvalues.

use super::plastic::{Cone, Returned};
use crate::fields::mat2_mul;

/// One particle's plastic state: the elastic log strain `[xx, yy, xy, zz]` and `ε̄ᵖ`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PlasticState {
    /// `ε_e` as `[xx, yy, xy, zz]` (tensor shear).
    pub elastic_strain: [f64; 4],
    /// The equivalent plastic strain `ε̄ᵖ`.
    pub plastic_strain: f64,
}

/// What the update of one particle gives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Updated {
    /// The new state.
    pub state: PlasticState,
    /// The Kirchhoff stress `[τxx, τyy, τxy]` (divide by `det F` for the Cauchy stress).
    pub kirchhoff: [f64; 3],
    /// The out-of-plane Kirchhoff stress `τ_zz` (0 in plane stress).
    pub kirchhoff_zz: f64,
    /// `W(ε_e)` per unit reference volume.
    pub energy_density: f64,
    /// `τ : (ε^tr − ε_e) ≥ 0` per unit reference volume: this step's plastic dissipation.
    pub dissipation_density: f64,
    /// The return's result in the principal frame.
    pub returned: Returned,
    /// The principal frame of `b^tr`: its first eigenvector `(cos a, sin a)`.
    frame: [f64; 2],
    /// The trial strains' principal values.
    trial: [f64; 3],
    /// The eigenvalues of `b^tr` in the plane.
    stretch: [f64; 2],
}

/// The eigen-decomposition of a symmetric `2 × 2` `[[a, b], [b, d]]`: eigenvalues (larger
/// first) and the first eigenvector `(cos θ, sin θ)`, `θ = ½ atan2(2b, a − d)`.
pub(crate) fn principal([a, d, b]: [f64; 3]) -> ([f64; 2], [f64; 2]) {
    let m = 0.5 * (a + d);
    let r = (0.5 * (a - d)).hypot(b);
    let theta = 0.5 * (2.0 * b).atan2(a - d);
    ([m + r, m - r], [theta.cos(), theta.sin()])
}

/// `Σᵢ vᵢ nᵢ⊗nᵢ` as `[xx, yy, xy]` for the frame `n₁ = (c, s)`, `n₂ = (−s, c)`.
fn compose([c, s]: [f64; 2], v: [f64; 2]) -> [f64; 3] {
    [
        v[0] * c * c + v[1] * s * s,
        v[0] * s * s + v[1] * c * c,
        (v[0] - v[1]) * c * s,
    ]
}

/// `ln(λ₁/λ₂) / (λ₁ − λ₂)` without cancellation (→ `1/λ` as `λ₁ → λ₂`).
fn log_quotient(l1: f64, l2: f64) -> f64 {
    let x = (l1 - l2) / l2;
    if x == 0.0 {
        1.0 / l2
    } else {
        x.ln_1p() / x / l2
    }
}

/// `f b fᵀ` for `f` row-major and `b` as `[xx, yy, xy]`.
fn push_forward(f: [f64; 4], b: [f64; 3]) -> [f64; 3] {
    let [bxx, byy, bxy] = b;
    // f b, row-major.
    let fb = [
        f[0] * bxx + f[1] * bxy,
        f[0] * bxy + f[1] * byy,
        f[2] * bxx + f[3] * bxy,
        f[2] * bxy + f[3] * byy,
    ];
    [
        fb[0] * f[0] + fb[1] * f[1],
        fb[2] * f[2] + fb[3] * f[3],
        fb[0] * f[2] + fb[1] * f[3],
    ]
}

/// `b_n = exp(2 ε_e,n)` in the plane, `[xx, yy, xy]`.
fn exponential(strain: [f64; 4]) -> [f64; 3] {
    let (values, frame) = principal([strain[0], strain[1], strain[2]]);
    compose(frame, values.map(|v| (2.0 * v).exp()))
}

impl Cone {
    /// The update of the [module docs](self) of a particle in state `state` over a step with
    /// relative deformation gradient `f` (row-major `[xx, xy, yx, yy]`, `det f > 0`).
    pub fn update(&self, state: &PlasticState, f: [f64; 4]) -> Updated {
        let b = push_forward(f, exponential(state.elastic_strain));
        let (stretch, frame) = principal(b);
        let trial = [0.5 * stretch[0].ln(), 0.5 * stretch[1].ln(), state.elastic_strain[3]];
        let returned = self.plane_return(trial, state.plastic_strain);
        let strain = compose(frame, [returned.strain[0], returned.strain[1]]);
        let kirchhoff = compose(frame, [returned.stress[0], returned.stress[1]]);
        let energy_density = self.energy_density(returned.strain);
        // τ : Δεᵖ with the returned stress (principal, coaxial with the trial).
        let dissipation_density = (0..3)
            .map(|i| returned.stress[i] * (returned.trial[i] - returned.strain[i]))
            .sum::<f64>();
        Updated {
            state: PlasticState {
                elastic_strain: [strain[0], strain[1], strain[2], returned.strain[2]],
                plastic_strain: state.plastic_strain + returned.plastic_strain,
            },
            kirchhoff,
            kirchhoff_zz: returned.stress[2],
            energy_density,
            dissipation_density,
            returned,
            frame,
            trial: returned.trial,
            stretch,
        }
    }

    /// The stress relative to the step's start `P̃ = τ f⁻ᵀ / J_n` (row-major) at `f = I + h`,
    /// and its derivative `𝔸[ab][cd] = ∂P̃_ab/∂h_cd` (the [module docs](self)).
    pub fn relative_stress(&self, state: &PlasticState, h: [f64; 4], j_n: f64) -> ([f64; 4], [[f64; 4]; 4]) {
        let f = [1.0 + h[0], h[1], h[2], 1.0 + h[3]];
        let up = self.update(state, f);
        let det = f[0] * f[3] - f[1] * f[2];
        // f⁻ᵀ row-major: (f⁻¹)ᵀ.
        let f_inv_t = [f[3] / det, -f[2] / det, -f[1] / det, f[0] / det];
        let [txx, tyy, txy] = up.kirchhoff;
        let tau = [txx, txy, txy, tyy];
        let p = mat2_mul(tau, f_inv_t).map(|v| v / j_n);
        let b_n = exponential(state.elastic_strain);
        let [c, s] = up.frame;
        let (l1, l2) = (up.stretch[0], up.stretch[1]);
        let (e1, e2) = (up.trial[0], up.trial[1]);
        let d = up.returned.tangent;
        let [t1, t2] = [up.returned.stress[0], up.returned.stress[1]];
        let shear_ratio = if (e1 - e2).abs() > 1e-9 {
            (t1 - t2) / (e1 - e2)
        } else {
            d[0][0] - d[0][1]
        };
        let b_n_m = [b_n[0], b_n[2], b_n[2], b_n[1]];
        let mut a = [[0.0; 4]; 4];
        for (col, unit) in (0..4).map(|k| (k, std::array::from_fn::<f64, 4, _>(|i| f64::from(u8::from(i == k))))) {
            // db = dh b fᵀ + f b dhᵀ, row-major, symmetric.
            let x = mat2_mul(mat2_mul(unit, b_n_m), transpose(f));
            let db = [2.0 * x[0], 2.0 * x[3], x[1] + x[2]];
            // In the frame n₁ = (c, s), n₂ = (−s, c).
            let hat11 = c * c * db[0] + s * s * db[1] + 2.0 * c * s * db[2];
            let hat22 = s * s * db[0] + c * c * db[1] - 2.0 * c * s * db[2];
            let hat12 = -c * s * db[0] + c * s * db[1] + (c * c - s * s) * db[2];
            let de = [hat11 / (2.0 * l1), hat22 / (2.0 * l2)];
            let de12 = 0.5 * hat12 * log_quotient(l1, l2);
            let dt = [d[0][0] * de[0] + d[0][1] * de[1], d[1][0] * de[0] + d[1][1] * de[1]];
            let dt12 = shear_ratio * de12;
            // Back to x, y: dτ = Σ dτ̂ᵢⱼ nᵢ⊗nⱼ.
            let diag = compose([c, s], dt);
            let dtau = [
                diag[0] - 2.0 * c * s * dt12,
                diag[2] + (c * c - s * s) * dt12,
                diag[2] + (c * c - s * s) * dt12,
                diag[1] + 2.0 * c * s * dt12,
            ];
            let first = mat2_mul(dtau, f_inv_t);
            let second = mat2_mul(mat2_mul(mat2_mul(tau, f_inv_t), transpose(unit)), f_inv_t);
            for row in 0..4 {
                a[row][col] = (first[row] - second[row]) / j_n;
            }
        }
        (p, a)
    }
}

/// `Aᵀ` stored row-major.
fn transpose(a: [f64; 4]) -> [f64; 4] {
    [a[0], a[2], a[1], a[3]]
}

impl Cone {
    /// The elastic log strain `[xx, yy, xy, zz]` of the in-plane Kirchhoff stress
    /// `τ = [τxx, τyy, τxy]`, Hencky's law inverted, with `τ_zz = ν (τ₁ + τ₂)` in plane strain
    /// (no out-of-plane elastic strain) and `τ_zz = 0` in plane stress:
    ///
    /// ```text
    /// εᵢ = p / (3K) + (τᵢ − p) / (2μ),   p = (τ₁ + τ₂ + τ₃) / 3
    /// ```
    pub fn strain_of_stress(&self, tau: [f64; 3]) -> [f64; 4] {
        let (values, frame) = principal(tau);
        let nu = (3.0 * self.bulk - 2.0 * self.shear) / (2.0 * (3.0 * self.bulk + self.shear));
        let t3 = match self.plane {
            super::PlaneCondition::Strain => nu * (values[0] + values[1]),
            super::PlaneCondition::Stress => 0.0,
        };
        let e = self.strain_of([values[0], values[1], t3]);
        let [xx, yy, xy] = compose(frame, [e[0], e[1]]);
        [xx, yy, xy, e[2]]
    }
}
