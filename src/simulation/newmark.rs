//! The implicit step: Newmark's rule on the grid, Newton iterations on the grid displacement,
//! the particles updated from the converged solution by the explicit step's grid-to-particle
//! pass (docs/implicit.md).
//!
//! ```text
//! (1)–(5)  operators, grid mass, momentum and force at the particles' positions (as explicit)
//! (6)      v_n = M_v⁻¹ N m v_p                       (the velocity projection of the mass scheme)
//! (7)      a_n = M⁻¹ (f_ext + f_int(σ_n))             (the acceleration solve of the mass scheme)
//! (8)      Newton on the free degrees of freedom from u = Δt v_n + ½ Δt² a_n
//!          (crate::implicit::newton): f_ext + f_int(u) = M (u − Δt v_n − Δt² (½ − β) a_n)/(β Δt²)
//! (9)      a_{n+1} = a(u),  v_{n+1} = v_n + Δt ((1 − γ) a_n + γ a_{n+1})
//! (10)     the grid-to-particle pass with w = v_{n+1}, v = v_n and the motion field u/Δt:
//!          x += Nᵀ u,  F ← (I + ∇u) F,  V ← det(I + ∇u) V,  σ from ∇u (linear) or F,
//!          v_p ← v_p + Nᵀ (v_{n+1} − v_n) (FLIP), Nᵀ v_{n+1} (PIC), or a blend
//! ```
//!
//! `M` is the matrix the acceleration solve of (7) stands for (`GridMass::solved_matrix`):
//! `diag(m_L)` (lumped, or after a fall-back to lumped), the consistent mass with its
//! stabilisation (consistent, conjugate gradient), the plain one (truncated series), or
//! `g M_s + (1 − g) diag(m_L)` (blended, and after a regularisation), so that `a_n` of (7) and
//! the Newmark residual use one mass. The free degrees of freedom are the components of the
//! active nodes and of the nodes without mass in a particle's support (which follow the active
//! ones as the explicit step's extension (8b) has it), less the prescribed components, where
//! `u = Δt v̄` (`a = 0`). The Newton iterations and the relative residual are reported in the
//! acceleration solve's columns of the step report.

use super::motion::{move_by, stacked};
use super::phases::{finish_step, prepare_grid, project_velocity, solve_acceleration};
use super::plan::StepPlan;
use super::{Cache, Simulation, StepReport};
use crate::error::Result;
use crate::implicit::newton::{Converged, Freedom, NewtonMass, NewtonSystem};
use crate::implicit::Newmark;
use crate::mass::{Role, SolveReport};

impl Simulation {
    /// One Newmark step of at most `max_dt` (the steps of the [module docs](self)).
    pub(super) fn newmark_phases(&mut self, newmark: Newmark, max_dt: f64) -> Result<StepReport> {
        let plan = StepPlan::of(&self.setup, &self.options, self.state.time);
        let (input, mut out) = self.split(&plan);
        prepare_grid(input, out.reborrow())?; // (1)–(5)
        let (setup, options) = (input.setup, input.options);
        let dt = newmark.time_step(options.time_step, out.state.time, out.state.steps, max_dt)?;
        let step = out.state.steps + 1;
        let state = &*out.state;
        let (Cache { ops, mass, nodes, .. }, scratch) = (&mut *out.cache, &mut *out.scratch);
        let velocity_solve = project_velocity(setup, ops, mass, &nodes.momentum, &mut nodes.projected)?; // (6)
        let prescribed = &setup.prescribed;
        let base_solve = solve_acceleration(prescribed, ops, mass, &nodes.force, &mut nodes.acceleration)?; // (7)
        let fields = &mut [&mut nodes.projected, &mut nodes.acceleration];
        super::walls::unfold(&prescribed.slip, &setup.grid, fields);
        let n = ops.num_nodes();
        let (vn, an) = (stacked(&nodes.projected), stacked(&nodes.acceleration));
        let is_active = mass.is_active();
        let fallbacks: [&dyn Fn(usize) -> f64; 2] = [&|k| dt * vn[k], &|_| 0.0];
        let predictor = |k: usize| dt * vn[k] + 0.5 * dt * dt * an[k];
        let mut freedom = Freedom::of(
            ops,
            is_active,
            prescribed,
            dt,
            &predictor,
            &fallbacks,
            &mut scratch.extension,
        );
        let (free, start) = (std::mem::take(&mut freedom.free), std::mem::take(&mut freedom.start));
        let on_free =
            |f: &dyn Fn(usize) -> f64| -> Vec<f64> { (0..2 * n).map(|k| if free[k] { f(k) } else { 0.0 }).collect() };
        let beta = newmark.beta;
        let (materials, force) = (setup.bodies.iter().map(|b| b.material).collect(), stacked(&nodes.force));
        let system = NewtonSystem {
            predicted: on_free(&|k| dt * vn[k] + dt * dt * (0.5 - beta) * an[k]),
            inertia: 1.0 / (beta * dt * dt),
            tolerance: newmark.tolerance,
            max_iterations: newmark.max_iterations,
            key: "newmark",
            singularity: options.mass.singularity,
            ..NewtonSystem::new(ops, &state.particles, materials, mass.lumped(), force, freedom, step)
        };
        let (matrix, outcome) = (mass.solved_matrix(Role::Acceleration), base_solve.outcome);
        let matrix_y = mass.component_y_solved_matrix(Role::Acceleration);
        let mut solver = std::mem::take(&mut scratch.newton);
        let solved = system.solve(
            start,
            Some(NewtonMass {
                matrix,
                matrix_y,
                outcome,
            }),
            &mut solver,
            &mut scratch.newton_residuals,
        );
        scratch.newton = solver;
        let Converged {
            u,
            iterations,
            relative,
            mass,
        } = solved?;
        let newton_mass = mass.expect("Newmark solves with a mass");
        // (9) Nodes without mass carry no acceleration; their velocity is their displacement rate.
        let gamma = newmark.gamma;
        let mut v1: Vec<f64> = (0..2 * n)
            .map(|k| match (free[k], is_active[k % n]) {
                (true, true) => {
                    let a1 = (u[k] - system.predicted[k]) / (beta * dt * dt);
                    vn[k] + dt * ((1.0 - gamma) * an[k] + gamma * a1)
                }
                (true, false) => u[k] / dt,
                (false, _) => 0.0,
            })
            .collect();
        for (c, i, v) in prescribed.each() {
            v1[c * n + i] = v;
        }
        let mut w1 = crate::fields::VectorField {
            x: v1[..n].to_vec(),
            y: v1[n..].to_vec(),
        };
        super::walls::unfold(&prescribed.slip, &setup.grid, &mut [&mut w1]);
        let v1 = stacked(&w1);
        move_by(input, out.reborrow(), &u, Some(&v1), dt, step)?; // (10)
                                                                  // The kinetic energies of the grid, ½ vᵀ M v, in the report's balance: the integrator's
                                                                  // share apart from the transfers' (the trapezoidal rule keeps the grid's energy).
        let kinetic = &mut out.scratch.particle.kinetic;
        (kinetic.projected, kinetic.updated) = (grid_kinetic(&newton_mass, &vn), grid_kinetic(&newton_mass, &v1));
        let newton = SolveReport {
            scheme: base_solve.scheme,
            outcome: newton_mass.outcome,
            iterations,
            relative_residual: relative,
        };
        finish_step(input, out, dt, f64::INFINITY, [velocity_solve, newton])
    }
}

/// `½ vᵀ M v` for both components of `v` (stacked).
fn grid_kinetic(m: &NewtonMass, v: &[f64]) -> f64 {
    0.5 * v.iter().zip(m.times(v)).map(|(a, b)| a * b).sum::<f64>()
}
