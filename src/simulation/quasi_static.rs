//! The quasi-static step: one load increment brought to static equilibrium by Newton
//! iterations on the grid displacement (docs/implicit.md), no mass:
//!
//! ```text
//! (1)–(5)  operators, lumped mass (the active set), force at the particles' positions
//! (8)      Newton on the free degrees of freedom from u = 0 (prescribed: u = Δt v̄)
//!          (crate::implicit::newton):  λ_k f_ext + f_int(u) = 0,   λ_k = min(k / load_steps, 1)
//! (10)     the grid-to-particle pass with the motion field u/Δt: x += Nᵀ u,  F ← (I + ∇u) F,
//!          V ← det(I + ∇u) V,  σ from ∇u (linear) or F;  v_p = 0
//! ```
//!
//! Each increment starts from the configuration the last one converged to (updated
//! Lagrangian): the operators are assembled there, the stress of the particles is the last
//! increment's, and the internal force is `f_int(u)` of the Newmark step. No mass matrix
//! enters, whatever `schemes.mass` says; the particles are at rest after every increment.

use super::phases::StepPlan;
use super::{Cache, Simulation, StepReport};
use crate::error::{MpmError, Result};
use crate::fields::VectorField;
use crate::implicit::newton::{follow, reduction, start, Converged, NewtonSystem};
use crate::implicit::QuasiStatic;
use crate::mass::{Role, SolveReport};
use crate::material::Material;
use crate::transfer::{extension_matrix, interpolate};

impl Simulation {
    /// One load increment of at most `max_dt` (the steps of the [module docs](self)).
    pub(super) fn quasi_static_phases(&mut self, quasi_static: QuasiStatic, max_dt: f64) -> Result<StepReport> {
        let plan = StepPlan::of(&self.setup, &self.options);
        self.prepare_grid(&plan)?; // (1)–(5)
        let super::TimeStep::Fixed { dt } = self.options.time_step else {
            return Err(MpmError::InvalidOption {
                option: "integrator",
                reason: "the quasi-static integrator takes a fixed step (a scene's time.end / load_steps)".into(),
            });
        };
        let dt = dt.min(max_dt);
        let step = self.state.steps + 1;
        let Simulation {
            setup,
            options,
            state,
            cache: Cache { ops, mass, nodes },
            scratch,
            ..
        } = self;
        let n = ops.num_nodes();
        let is_active = mass.is_active();
        let extension = extension_matrix(ops, is_active);
        let (free, mut u) = start(is_active, &extension, &setup.prescribed, dt, |_| 0.0);
        follow(ops, is_active, &free, &mut u, &mut scratch.extension);
        let (dofs, reduction) = reduction(&extension, &free, is_active);
        let materials: Vec<Material> = setup.bodies.iter().map(|b| b.material).collect();
        let system = NewtonSystem {
            ops,
            particles: &state.particles,
            materials: &materials,
            lumped: mass.lumped(),
            force: [&nodes.force.x[..], &nodes.force.y[..]].concat(),
            predicted: vec![0.0; 2 * n],
            inertia: 0.0,
            load: quasi_static.load_factor(step),
            dofs,
            reduction,
            tolerance: quasi_static.tolerance,
            max_iterations: quasi_static.max_iterations,
            key: "quasi_static",
            step,
            singularity: options.mass.singularity,
        };
        let mut solver = std::mem::take(&mut scratch.newton);
        let solved = system.solve(u, None, &mut solver, &mut scratch.newton_residuals);
        scratch.newton = solver;
        let Converged {
            u,
            iterations,
            relative,
            ..
        } = solved?;
        // (10), after checking that every particle stays where the shape functions accept it.
        let motion = VectorField {
            x: u[..n].iter().map(|u| u / dt).collect(),
            y: u[n..].iter().map(|u| u / dt).collect(),
        };
        super::newmark::inside(options, setup, state, &interpolate(ops, &motion), dt, step)?;
        nodes.motion = motion;
        for field in [&mut nodes.projected, &mut nodes.updated] {
            field.x.iter_mut().chain(field.y.iter_mut()).for_each(|v| *v = 0.0);
        }
        let velocity = mass.lumped_report(Role::Velocity);
        let newton = SolveReport {
            iterations,
            relative_residual: relative,
            ..mass.lumped_report(Role::Acceleration)
        };
        self.particle_phases(&plan, dt)?;
        self.finish_step(dt, f64::INFINITY, [velocity, newton])
    }
}
