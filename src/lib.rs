//! # sparse-mpm
//!
//! The two-dimensional Material Point Method in sparse-matrix form. The shape functions and
//! their gradients at the particles are sparse matrices N, Gx, Gy (nodes × particles); mass,
//! momentum, forces and the maps back to the particles are products with them, and the grid
//! solve can use the lumped mass or the consistent mass matrix `M = N diag(m) Nᵀ` (sparse
//! Cholesky with faer).
//!
//! ```
//! use sparse_mpm::{Grid, Operators, Particles, ShapeFunction, mass};
//!
//! // A 2 × 1 grid of unit cells and four particles (the seed assignment's).
//! let grid = Grid::new([0.0, 0.0], [1.0, 1.0], [2, 1])?;
//! let particles = Particles::new(
//!     vec![1.2, 1.7, 1.3, 1.8],
//!     vec![0.75, 0.81, 0.26, 0.24],
//!     vec![1.0; 4],
//!     vec![2.0; 4],
//! )?;
//! let ops = Operators::assemble(&grid, ShapeFunction::Linear, &particles)?;
//! let n = ops.n_matrix();                                     // nalgebra-sparse CscMatrix, 6 × 4
//! let m_c = mass::consistent_mass(&ops, &particles.mass);     // N diag(m) Nᵀ, 6 × 6
//! let m_l = mass::lumped_mass(&ops, &particles.mass);         // N m
//! for i in 0..6 {
//!     let row_sum: f64 = (0..6).map(|j| m_c.get_entry(i, j).unwrap().into_value()).sum();
//!     assert!((row_sum - m_l[i]).abs() < 1e-12);              // lumped = row sums of consistent
//! }
//! assert_eq!(n.nnz(), 16);                                    // 4 nodes per particle
//! # Ok::<(), sparse_mpm::MpmError>(())
//! ```
//!
//! ## One explicit step, as equations
//!
//! [`step::explicit_step`] runs these lines, one call each (numbers as in
//! docs/formulation.md):
//!
//! ```text
//! (1)  N, Gx, Gy  at the particle positions                       Operators::assemble
//! (2)  m_L = N m;  active nodes A;  M = N diag(m) Nᵀ              mass::GridMass::new
//! (3)  q = N (m ∘ v)                                               transfer::momentum
//! (4)  f_ext = N (m ∘ b)                                           transfer::external_force
//! (5)  f_int = −[Gx (V∘σxx) + Gy (V∘σxy);  Gx (V∘σxy) + Gy (V∘σyy)]  transfer::internal_force
//! (6)  v̄  = M⁻¹ q                    (lumped or consistent, on A) mass::GridMass::solve
//! (7)  a  = M⁻¹ (f_ext + f_int)                                    mass::GridMass::solve
//! (8)  v̄′ = v̄ + Δt a                                               transfer::VectorField::add_scaled
//! (8b) massless support nodes take the particles' mean velocity    transfer::extend_to_massless_nodes
//! (9)  x ← x + Δt Nᵀ v̄′                                            transfer::update_positions
//! (10) v ← v + Δt Nᵀ a                                             transfer::update_velocities
//! (11) L = [Gxᵀ v̄′, Gyᵀ v̄′],  ε̇ = sym L                            transfer::velocity_gradient, strain_rate
//! (12) σ ← σ + C : (ε̇ Δt)                                          material::LinearElastic::update_stress
//! (13) V ← V det(I + Δt L)                                         transfer::update_volumes
//! ```
//!
//! ## A whole simulation
//!
//! [`simulation::Simulation`] runs the time loop on the same operators, with every choice an
//! independent axis of [`simulation::Options`]: shape function ([`ShapeFunction`]: linear,
//! uGIMP, quadratic and cubic B-splines), update scheme (USF, USL, MUSL), transfer (PIC, FLIP,
//! blend, APIC), mass scheme of each solve ([`mass::MassOptions`]), time step (fixed or CFL),
//! gravity and boundary conditions ([`boundary`]); bodies carry their own
//! [`material::Material`] (linear elastic or neo-Hookean). Each step returns a
//! [`simulation::StepReport`] of energies, momenta and solver outcomes. [`scene::Scene`] reads
//! and writes the same description as TOML. The applications are crates of their own in the
//! same workspace: `sparse-mpm-cli` (the `mpm` program: a scene run to a folder of VTK
//! snapshots, a ParaView time series and a CSV report; docs/simulation.md) and
//! `sparse-mpm-study` (the verification problems and the study of consistent against lumped
//! mass; docs/verification.md).
//!
//! ```
//! use sparse_mpm::scene::Scene;
//!
//! let scene = Scene::from_toml_str(r#"
//!     [grid]
//!     cell_size = [0.1, 0.1]
//!     cells = [10, 10]
//!     [time]
//!     end = 0.05
//!     [loads]
//!     gravity = [0.0, -9.81]
//!     [[bodies]]
//!     name = "block"
//!     material = { model = "neo_hookean", youngs_modulus = 1.0e5, poisson_ratio = 0.3 }
//!     density = 1000.0
//!     geometry = { rectangle = { min = [0.3, 0.3], max = [0.7, 0.7] } }
//! "#)?;
//! let mut sim = scene.build()?;
//! sim.run_until(scene.time.end, |_, _| Ok(()))?;
//! let t = sim.time();
//! let vy = sim.particles().momentum()[1] / sim.particles().total_mass();
//! assert!((vy - (-9.81 * t)).abs() < 1e-9);                  // free fall: v = g t
//! # Ok::<(), sparse_mpm::MpmError>(())
//! ```
//!
//! ## Symbols and functions
//!
//! | symbol | function | shape |
//! |---|---|---|
//! | `S_I(x)`, `∇S_I(x)` | [`shape()`], [`dshape`], [`shape::evaluate`] | scalar |
//! | N, Gx, Gy | [`Operators::n_matrix`], [`Operators::gx_matrix`], [`Operators::gy_matrix`]; faer views [`Operators::n_faer`] … | n × P |
//! | `N X`, `Nᵀ Y` (K fields per pass) | [`Operators::scatter`], [`Operators::scatter_scaled`], [`Operators::gather`] | |
//! | `m_L = N m` | [`mass::lumped_mass`] | n |
//! | `M = N diag(m) Nᵀ` | [`mass::consistent_mass`] | n × n |
//! | `M_AA⁻¹` | [`mass::ConsistentMassSolver`] | |
//! | `q`, `f_ext`, `f_int` | [`transfer::momentum`], [`transfer::external_force`], [`transfer::internal_force`] | 2 × n |
//! | `L`, `ε̇` | [`transfer::velocity_gradient`], [`transfer::strain_rate`] | P |
//! | `σ(F)`, `W(F)` | [`material::NeoHookean::stress`], [`material::NeoHookean::strain_energy_density`] | per particle |
//! | `Δt_stable` | [`simulation::Simulation::stable_time_step`] | |
//!
//! Node numbering, cells and the gradient on grid lines are documented in [`grid`] and
//! [`shape::linear`]. Errors are one enum, [`MpmError`], naming the particle, node, field or
//! value at fault; user data never causes a panic.
#![deny(missing_docs)]

pub mod bench;
pub mod boundary;
pub mod contact;
pub mod damping;
pub mod error;
mod fields;
pub mod grid;
pub mod implicit;
pub mod io;
pub mod kernels;
mod lanes;
pub mod limits;
pub mod mass;
pub mod material;
pub mod names;
pub mod numbers;
pub mod operators;
mod pairs;
pub mod parallel;
pub mod particles;
pub mod scene;
mod schemes;
pub mod shape;
pub mod simulation;
pub mod spectral;
pub mod step;
pub mod stiffness;
pub mod transfer;

pub use error::{MpmError, Result};
pub use grid::{Grid, NodeOrder};
pub use operators::{Operator, Operators};
pub use particles::Particles;
pub use shape::{dshape, shape, ShapeFunction};
