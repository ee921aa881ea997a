//! One explicit MPM step, written as the equations of docs/formulation.md.
//!
//! The sequence is the seed assignment's (questions 3 and 4), an update-stress-last (USL) step
//! with a FLIP velocity update:
//!
//! | eq. | quantity | code |
//! |---|---|---|
//! | (1) | N, Gx, Gy | [`Operators::assemble`] |
//! | (2) | `m_L = N m`, active nodes, `M = N diag(m) Nᵀ`, factorizations | [`GridMass::new`] |
//! | (3) | `q = N (m ∘ v)` | [`momentum`] |
//! | (4) | `f_ext = N (m ∘ b)` | [`external_force`] |
//! | (5) | `f_int = −(Gx (V∘σxx) + Gy (V∘σxy), Gx (V∘σxy) + Gy (V∘σyy))` | [`internal_force`] |
//! | (6) | `v̄ = M⁻¹ q` | [`GridMass::solve`] |
//! | (7) | `a = M⁻¹ (f_ext + f_int)` | [`GridMass::solve`] |
//! | (8) | `v̄' = v̄ + Δt a` | [`VectorField::add_scaled`] |
//! | (8b) | massless nodes in a particle's support take the mean particle velocity | [`extend_to_massless_nodes`] |
//! | (9) | `x ← x + Δt Nᵀ v̄'` (or the trapezoidal rule) | [`update_positions`] |
//! | (10) | `v ← v + Δt Nᵀ a` (the change of the grid velocity, `a` zero on constrained components) | [`update_velocities`] |
//! | (11) | `L = (Gxᵀ v̄', Gyᵀ v̄')`, `ε̇ = sym L` | [`velocity_gradient`], [`strain_rate`] |
//! | (12) | `σ ← σ + C : (ε̇ Δt)` | [`LinearElastic::update_stress`] |
//! | (13) | `V ← V det(I + Δt L)` | [`update_volumes`] |

use crate::error::{MpmError, Result};
use crate::grid::Grid;
use crate::mass::{Constraints, GridMass, MassOptions, Role, SolveReport};
use crate::material::LinearElastic;
use crate::operators::Operators;
use crate::particles::Particles;
use crate::shape::ShapeFunction;
use crate::transfer::{
    extend_to_massless_nodes, external_force, internal_force, momentum, strain_rate, update_positions,
    update_positions_trapezoidal, update_velocities, update_volumes, velocity_gradient, StrainRate, VectorField,
    VelocityGradient,
};

pub use crate::schemes::PositionUpdate;

/// The choices of one explicit step.
#[derive(Debug, Clone, PartialEq)]
pub struct StepOptions {
    /// Time step `Δt` (> 0).
    pub dt: f64,
    /// Shape-function family.
    pub shape: ShapeFunction,
    /// Mass schemes of the velocity projection (6) and the acceleration solve (7), the
    /// singularity policy and tolerances.
    pub mass: MassOptions,
    /// Grid degrees of freedom held at zero velocity (fixed and roller nodes).
    pub constraints: Constraints,
    /// Position update rule, (9).
    pub position_update: PositionUpdate,
}

impl Default for StepOptions {
    fn default() -> Self {
        StepOptions {
            dt: 1e-3,
            shape: ShapeFunction::Linear,
            mass: MassOptions::default(),
            constraints: Constraints::none(),
            position_update: PositionUpdate::GridVelocity,
        }
    }
}

/// Every intermediate quantity of one step, for inspection. Particle quantities after the
/// step are in the [`Particles`] the step updated.
#[derive(Debug)]
pub struct StepRecord {
    /// (1) N, Gx, Gy at the start of the step.
    pub operators: Operators,
    /// (2) Lumped mass, active nodes and (when a scheme needs it) the consistent mass.
    pub mass: GridMass,
    /// (7) What the acceleration solve did.
    pub acceleration_report: SolveReport,
    /// (6) What the velocity projection did.
    pub velocity_report: SolveReport,
    /// (3) Grid momentum `q`.
    pub momentum: VectorField,
    /// (4) External grid force.
    pub external_force: VectorField,
    /// (5) Internal grid force.
    pub internal_force: VectorField,
    /// (7) Grid acceleration.
    pub acceleration: VectorField,
    /// (6) Grid velocity from the particles' momentum, before the update.
    pub grid_velocity: VectorField,
    /// (8) Updated grid velocity.
    pub updated_grid_velocity: VectorField,
    /// (11) Velocity gradient at the particles.
    pub velocity_gradient: VelocityGradient,
    /// (11) Strain rate at the particles.
    pub strain_rate: StrainRate,
}

/// Advances `particles` by one explicit step (the table in the [module docs](self)) and
/// returns every intermediate quantity.
///
/// # Errors
/// [`MpmError::InvalidParameter`] for a non-positive or non-finite `dt`; the errors of
/// [`Particles::validate`] and [`LinearElastic::validate`]; [`MpmError::ParticleOutsideGrid`];
/// [`MpmError::SingularMassMatrix`] with consistent mass. On error the particles are unchanged.
pub fn explicit_step(
    grid: &Grid,
    particles: &mut Particles,
    material: &LinearElastic,
    options: &StepOptions,
) -> Result<StepRecord> {
    check_inputs(particles, material, options)?;
    let (p, dt) = (particles, options.dt);
    let ops = Operators::assemble(grid, options.shape, p)?; //                                          (1)
    let mass = GridMass::new(&ops, &p.mass, &options.mass, &options.constraints)?; //                     (2)
    let q = momentum(&ops, &p.mass, &p.vx, &p.vy); //                                                    (3)
    let f_ext = external_force(&ops, &p.mass, &p.bx, &p.by); //                                          (4)
    let f_int = internal_force(&ops, &p.volume, &p.sxx, &p.syy, &p.sxy); //                               (5)
    let (v, v_report) = mass.solve(Role::Velocity, &q, None, &ops)?; //                                  (6)
    let (a, a_report) = mass.solve(Role::Acceleration, &f_ext.add_scaled(1.0, &f_int), None, &ops)?; //  (7)
    let mut v_new = v.add_scaled(dt, &a); //                                                             (8)
    extend_to_massless_nodes(&ops, mass.is_active(), &mut v_new); //                                        (8b)
    move_particles(&ops, p, &v_new, dt, options.position_update); //                                     (9)
    update_velocities(&ops, &mut p.vx, &mut p.vy, &a, dt); //                                           (10)
    let l = velocity_gradient(&ops, &v_new); //                                                         (11)
    let rate = strain_rate(&l); //                                                                      (11)
    material.update_stress(&mut p.sxx, &mut p.syy, &mut p.sxy, &rate, dt); //                           (12)
    update_volumes(&mut p.volume, &l, dt); //                                                           (13)
    Ok(StepRecord {
        operators: ops,
        mass,
        acceleration_report: a_report,
        velocity_report: v_report,
        momentum: q,
        external_force: f_ext,
        internal_force: f_int,
        acceleration: a,
        grid_velocity: v,
        updated_grid_velocity: v_new,
        velocity_gradient: l,
        strain_rate: rate,
    })
}

/// Step (9) with the chosen rule.
fn move_particles(ops: &Operators, p: &mut Particles, v_grid: &VectorField, dt: f64, rule: PositionUpdate) {
    match rule {
        PositionUpdate::GridVelocity => update_positions(ops, &mut p.x, &mut p.y, v_grid, dt),
        PositionUpdate::Trapezoidal => update_positions_trapezoidal(ops, &mut p.x, &mut p.y, &p.vx, &p.vy, v_grid, dt),
    }
}

fn check_inputs(particles: &Particles, material: &LinearElastic, options: &StepOptions) -> Result<()> {
    if !(options.dt.is_finite() && options.dt > 0.0) {
        return Err(MpmError::InvalidParameter {
            name: "dt",
            value: options.dt,
            reason: "the time step must be a positive finite number",
        });
    }
    particles.validate()?;
    material.validate()
}
