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

use super::motion::{move_by, stacked};
use super::phases::{finish_step, prepare_grid};
use super::plan::StepPlan;
use super::{Cache, Simulation, StepReport};
use crate::error::{MpmError, Result};
use crate::implicit::newton::{Converged, Freedom, NewtonSystem};
use crate::implicit::QuasiStatic;
use crate::mass::{Role, SolveReport};

impl Simulation {
    /// One load increment of at most `max_dt` (the steps of the [module docs](self)).
    pub(super) fn quasi_static_phases(&mut self, quasi_static: QuasiStatic, max_dt: f64) -> Result<StepReport> {
        let plan = StepPlan::of(&self.setup, &self.options, self.state.time);
        let (input, mut out) = self.split(&plan);
        prepare_grid(input, out.reborrow())?; // (1)–(5)
        let super::TimeStep::Fixed { dt } = input.options.time_step else {
            return Err(MpmError::InvalidOption {
                option: "integrator",
                reason: "the quasi-static integrator takes a fixed step (a scene's time.end / load_steps)".into(),
            });
        };
        let dt = dt.min(max_dt);
        let step = out.state.steps + 1;
        let (setup, state) = (input.setup, &*out.state);
        let (Cache { ops, mass, nodes, .. }, scratch) = (&mut *out.cache, &mut *out.scratch);
        let zero = |_: usize| 0.0;
        let mut freedom = Freedom::of(
            ops,
            mass.is_active(),
            &setup.prescribed,
            dt,
            &zero,
            &[],
            &mut scratch.extension,
        );
        let (materials, force) = (setup.bodies.iter().map(|b| b.material).collect(), stacked(&nodes.force));
        let start = std::mem::take(&mut freedom.start);
        let system = NewtonSystem {
            load: quasi_static.load_factor(step),
            tolerance: quasi_static.tolerance,
            max_iterations: quasi_static.max_iterations,
            ..NewtonSystem::new(ops, &state.particles, materials, mass.lumped(), force, freedom, step)
        };
        let mut solver = std::mem::take(&mut scratch.newton);
        let solved = system.solve(start, None, &mut solver, &mut scratch.newton_residuals);
        scratch.newton = solver;
        let Converged {
            u,
            iterations,
            relative,
            ..
        } = solved?;
        let velocity = mass.lumped_report(Role::Velocity);
        let newton = SolveReport {
            iterations,
            relative_residual: relative,
            ..mass.lumped_report(Role::Acceleration)
        };
        move_by(input, out.reborrow(), &u, None, dt, step)?; // (10)
        finish_step(input, out, dt, f64::INFINITY, [velocity, newton])
    }
}
