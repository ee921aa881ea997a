//! The discrete dispersion relation of the explicit update over the whole spectrum: the wave
//! speed `c_h/c` of a Fourier mode `e^{iθx/h}` against `θ = kh`, for each pair of mass schemes
//! and each kernel, with `K` particles per cell at the centres of `K` equal sub-cells.
//!
//! With FLIP the particle velocities stay `Nᵀ W` for a grid field `W` and MUSL's grid velocity
//! is `M_v⁻¹ M W`; for small motions the grid displacement obeys
//!
//! ```text
//! Ü = −M_v⁻¹ M M_a⁻¹ K U       (ω² the eigenvalues of M_v⁻¹ M M_a⁻¹ K, those of M_a⁻¹ K M_v⁻¹ M)
//! ```
//!
//! On a uniform periodic bar every operator is circulant, so each Fourier mode is an
//! eigenvector and the eigenvalue is the product of the symbols (one node per cell, `h = 1`,
//! `ρ = E = 1`, particle mass and volume `1/K`, `S_j`, `S'_j` the kernel's weights and
//! derivatives at the particle, `j` the node offsets):
//!
//! ```text
//! M̂(θ) = Σ_p m_p |Σ_j S_j(x_p) e^{iθj}|²,     K̂(θ) = Σ_p V_p |Σ_j S'_j(x_p) e^{iθj}|²,     m̂_L = Σ_p m_p = 1
//! λ(θ) = K̂ · P_a(θ) · P_v(θ) · M̂,            c_h/c = √λ / θ
//! ```
//!
//! with the symbol `P` of each inverse: lumped `1/m̂_L`; consistent and conjugate gradient
//! `1/M̂`; blended γ `1/((1 − γ) m̂_L + γ M̂)`; series(k) `(1/m̂_L) Σ_{ℓ<k} (1 − M̂/m̂_L)^ℓ`. The
//! fringe stabilisation does not act in the interior of a uniform bar. The weights are the
//! library's own ([`ShapeFunction::axis_weights`]).
//!
//! For bilinear functions with 2 particles per cell (at the quarter points), in closed form:
//! lumped `c_h/c = 2 sin(θ/2) √((10 + 6 cos θ)/16) / θ`, consistent
//! `2 sin(θ/2) / (θ √((10 + 6 cos θ)/16))`, either mixed pair `2 sin(θ/2)/θ`.

use sparse_mpm::error::{MpmError, Result};
use sparse_mpm::grid::Grid;
use sparse_mpm::mass::MassScheme;
use sparse_mpm::shape::ShapeFunction;

/// One point of a dispersion curve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DispersionPoint {
    /// `θ = kh`, in `(0, π]`.
    pub theta: f64,
    /// `c_h/c = ω_h/(c k)`; NaN where a mass symbol vanishes (no finite frequency).
    pub c_ratio: f64,
}

/// One particle of the cell: its mass (= volume) and, per supporting node, the node's offset
/// `j`, the weight `S_j` and the derivative `S'_j`.
type CellParticle = (f64, Vec<(f64, f64, f64)>);

/// The symbols of one kernel and particle layout: `M̂(θ)`, `K̂(θ)` and `m̂_L`.
#[derive(Debug, Clone)]
pub struct Symbols {
    /// The particles of one cell.
    particles: Vec<CellParticle>,
}

impl Symbols {
    /// The symbols of `shape` with `particles_per_cell` particles per cell at the centres of
    /// equal sub-cells.
    ///
    /// # Errors
    /// [`MpmError::InvalidParameter`] when `particles_per_cell` is 0 or above 64, or the
    /// kernel's parameters are invalid.
    pub fn new(shape: ShapeFunction, particles_per_cell: usize) -> Result<Symbols> {
        if !(1..=64).contains(&particles_per_cell) {
            return Err(MpmError::InvalidParameter {
                name: "particles_per_cell",
                value: particles_per_cell as f64,
                reason: "the particles per cell must lie in 1..=64",
            });
        }
        shape.validate()?;
        // A grid wide enough that the middle cell's particles see interior weights.
        let cells = 16;
        let grid = Grid::new([0.0, 0.0], [1.0, 1.0], [cells, cells])?;
        let centre = (cells / 2) as f64;
        let k = particles_per_cell as f64;
        let particles = (0..particles_per_cell)
            .map(|a| {
                let x = centre + (a as f64 + 0.5) / k;
                let w = shape
                    .axis_weights(&grid, 0, x)
                    .expect("the middle of a 16-cell grid is inside every kernel's margin");
                let nodes = (0..w.len)
                    .map(|j| ((w.first + j) as f64 - centre, w.value[j], w.derivative[j]))
                    .collect();
                (1.0 / k, nodes)
            })
            .collect();
        Ok(Symbols { particles })
    }

    /// `Σ_p c_p |Σ_j f_j e^{iθ j}|²` for the weights (`derivative = false`) or derivatives.
    fn quadratic_form(&self, theta: f64, derivative: bool) -> f64 {
        self.particles
            .iter()
            .map(|(c, nodes)| {
                let (re, im) = nodes.iter().fold((0.0, 0.0), |(re, im), &(j, s, ds)| {
                    let f = if derivative { ds } else { s };
                    (re + f * (theta * j).cos(), im + f * (theta * j).sin())
                });
                c * (re * re + im * im)
            })
            .sum()
    }

    /// The consistent mass symbol `M̂(θ) = Σ_p m_p |Σ_j S_j e^{iθj}|²`.
    pub fn mass(&self, theta: f64) -> f64 {
        self.quadratic_form(theta, false)
    }

    /// The stiffness symbol `K̂(θ) = Σ_p V_p |Σ_j S'_j e^{iθj}|²` (`E = 1`, `h = 1`).
    pub fn stiffness(&self, theta: f64) -> f64 {
        self.quadratic_form(theta, true)
    }

    /// The lumped mass `m̂_L = Σ_p m_p Σ_j S_j` (1 for every kernel: partition of unity).
    pub fn lumped(&self) -> f64 {
        self.particles
            .iter()
            .map(|(m, nodes)| m * nodes.iter().map(|n| n.1).sum::<f64>())
            .sum()
    }

    /// The symbol of a scheme's inverse mass at `θ` ([`MassScheme::inverse_symbol`]).
    pub fn inverse(&self, scheme: MassScheme, theta: f64) -> f64 {
        scheme.inverse_symbol(self.lumped(), self.mass(theta))
    }

    /// `c_h/c` at `θ` for the velocity and acceleration schemes:
    /// `√(K̂ P_a P_v M̂) / θ`.
    pub fn c_ratio(&self, velocity: MassScheme, acceleration: MassScheme, theta: f64) -> f64 {
        let lambda = self.stiffness(theta)
            * self.inverse(acceleration, theta)
            * self.inverse(velocity, theta)
            * self.mass(theta);
        if lambda.is_finite() && lambda >= 0.0 {
            lambda.sqrt() / theta
        } else {
            f64::NAN
        }
    }
}

/// The dispersion curve `c_h/c` against `θ` of the schemes (`velocity`, `acceleration`) with
/// `shape` and `particles_per_cell` (module docs), at `θ = π j / samples`, `j = 1 … samples`;
/// with `cells = Some(n)` instead at the wavenumbers of a periodic bar of `n` cells,
/// `θ = 2π j / n`, `j = 1 … ⌊n/2⌋`.
///
/// # Errors
/// Those of [`Symbols::new`], and [`MpmError::InvalidParameter`] for `samples = 0`, `cells`
/// below 2 or above 10⁶, and invalid mass schemes.
pub fn dispersion(
    shape: ShapeFunction,
    velocity: MassScheme,
    acceleration: MassScheme,
    particles_per_cell: usize,
    samples: usize,
    cells: Option<usize>,
) -> Result<Vec<DispersionPoint>> {
    velocity.validate()?;
    acceleration.validate()?;
    let symbols = Symbols::new(shape, particles_per_cell)?;
    let thetas: Vec<f64> = match cells {
        Some(n) if (2..=1_000_000).contains(&n) => (1..=n / 2)
            .map(|j| 2.0 * std::f64::consts::PI * j as f64 / n as f64)
            .collect(),
        Some(n) => {
            return Err(MpmError::InvalidParameter {
                name: "cells",
                value: n as f64,
                reason: "the cells of the periodic bar must lie in 2..=1000000",
            })
        }
        None if (1..=1_000_000).contains(&samples) => (1..=samples)
            .map(|j| std::f64::consts::PI * j as f64 / samples as f64)
            .collect(),
        None => {
            return Err(MpmError::InvalidParameter {
                name: "samples",
                value: samples as f64,
                reason: "the samples of the curve must lie in 1..=1000000",
            })
        }
    };
    Ok(thetas
        .into_iter()
        .map(|theta| DispersionPoint {
            theta,
            c_ratio: symbols.c_ratio(velocity, acceleration, theta),
        })
        .collect())
}
