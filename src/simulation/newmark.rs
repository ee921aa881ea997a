//! The implicit step: Newmark's rule on the grid, Newton iterations on the grid displacement,
//! the particles updated from the converged solution (docs/implicit.md).
//!
//! ```text
//! (1)–(5)  operators, grid mass, momentum and force at the particles' positions (as explicit)
//! (6)      v_n = M_v⁻¹ N m v_p                       (the velocity projection of the mass scheme)
//! (7)      a_n = M⁻¹ (f_ext + f_int(σ_n))             (the acceleration solve of the mass scheme)
//! (8)      Newton on the free degrees of freedom, from u = Δt v_n + ½ Δt² a_n:
//!            a(u) = (u − Δt v_n − Δt² (½ − β) a_n) / (β Δt²)
//!            r(u) = f_ext + f_int(u) − M a(u)
//!            (K(u) + M / (β Δt²)) δu = r(u),   u ← u + δu        (faer sparse LU)
//! (9)      a_{n+1} = a(u),  v_{n+1} = v_n + Δt ((1 − γ) a_n + γ a_{n+1})
//! (10)     particles: x += Nᵀ u,  F ← (I + ∇u) F,  V ← det(I + ∇u) V,  σ from ∇u (linear) or F,
//!          v_p ← v_p + Nᵀ (v_{n+1} − v_n) (FLIP), Nᵀ v_{n+1} (PIC), or a blend
//! ```
//!
//! `M` is the matrix the acceleration solve of (7) stands for (`GridMass::solved_matrix`):
//! `diag(m_L)` (lumped, or after a fall-back to lumped), the consistent mass with its
//! stabilisation (consistent, conjugate gradient), the plain one (truncated series), or
//! `g M_s + (1 − g) diag(m_L)` (blended, and after a regularisation), so that `a_n` of (7) and
//! the Newmark residual use one mass. The free degrees of freedom are the nodes of positive lumped
//! mass less the prescribed components, where `u = Δt v̄` (`a = 0`). The Newton iterations and the
//! relative residual are reported in the acceleration solve's columns of the step report.

use nalgebra_sparse::{CooMatrix, CscMatrix};

use super::phases::{project_velocity, solve_acceleration, StepPlan};
use super::{Cache, Simulation, StepReport, TimeStep, Transfer};
use crate::error::{MpmError, Result};
use crate::implicit::{displacement_gradients, gradient_operator, internal_force_and_tangent, Newmark};
use crate::kernels::KineticEnergies;
use crate::mass::{lumped_matrix, Role, SingularityPolicy, SolveOutcome, SolveReport};
use crate::material::Material;

/// The nodes without mass in a particle's support, each following the nodes with mass as the
/// mean of its particles' interpolated values (the explicit step's extension,
/// `transfer::extend_to_massless_nodes`, applied to the displacement):
///
/// ```text
/// u_I = (1/|P_I|) Σ_{p ∈ P_I} Σ_J N_Jp u_J     P_I = {p : I in the support of p}
/// ```
///
/// so that a rigid motion stays rigid at the particles whose support reaches past the body. In
/// the Newton iterations they are eliminated: `u = T ũ`, the system `Tᵀ J T δũ = Tᵀ r`.
struct MasslessFollow {
    /// For each node without mass in some support, `(node, weight)` of the nodes it follows.
    weights: std::collections::BTreeMap<usize, Vec<(usize, f64)>>,
}

impl MasslessFollow {
    fn new(ops: &crate::operators::Operators, lumped: &[f64]) -> Self {
        let mut sums: std::collections::BTreeMap<usize, (usize, std::collections::BTreeMap<usize, f64>)> =
            Default::default();
        for q in 0..ops.num_particles() {
            for (node, _, _, _) in ops.column(q) {
                if lumped[node] > 0.0 {
                    continue;
                }
                let (count, acc) = sums.entry(node).or_default();
                *count += 1;
                for (j, w, _, _) in ops.column(q) {
                    if w != 0.0 {
                        *acc.entry(j).or_default() += w;
                    }
                }
            }
        }
        let weights = sums
            .into_iter()
            .map(|(node, (count, acc))| (node, acc.into_iter().map(|(j, w)| (j, w / count as f64)).collect()))
            .collect();
        MasslessFollow { weights }
    }

    /// Whether node `i` (without mass) is in a particle's support.
    fn follows(&self, i: usize) -> bool {
        self.weights.contains_key(&i)
    }

    /// Sets `u` of the free components of the nodes without mass from the nodes they follow.
    fn apply(&self, u: &mut [f64], free: &[bool]) {
        let n = u.len() / 2;
        for (&i, list) in &self.weights {
            for c in 0..2 {
                if free[c * n + i] {
                    u[c * n + i] = list.iter().map(|&(j, w)| w * u[c * n + j]).sum();
                }
            }
        }
    }

    /// `T` (free degrees of freedom × free components of nodes with mass), `None` when no node
    /// without mass is free (then `T = I`).
    fn reduction(&self, dofs: &[usize], free: &[bool], n: usize) -> Option<CscMatrix<f64>> {
        if !dofs.iter().any(|&k| self.follows(k % n)) {
            return None;
        }
        let mut column = vec![usize::MAX; 2 * n];
        let mut columns = 0;
        for &k in dofs {
            if !self.follows(k % n) {
                column[k] = columns;
                columns += 1;
            }
        }
        let mut coo = CooMatrix::new(dofs.len(), columns);
        for (row, &k) in dofs.iter().enumerate() {
            match self.weights.get(&(k % n)) {
                None => coo.push(row, column[k], 1.0),
                Some(list) => {
                    let c = k / n;
                    for &(j, w) in list {
                        if free[c * n + j] && column[c * n + j] != usize::MAX {
                            coo.push(row, column[c * n + j], w);
                        }
                    }
                }
            }
        }
        Some(CscMatrix::from(&coo))
    }
}

/// `T x`.
fn times(t: &CscMatrix<f64>, x: &[f64]) -> Vec<f64> {
    let mut y = vec![0.0; t.nrows()];
    for (i, j, &v) in t.triplet_iter() {
        y[i] += v * x[j];
    }
    y
}

/// `Tᵀ x`.
fn transpose_times(t: &CscMatrix<f64>, x: &[f64]) -> Vec<f64> {
    let mut y = vec![0.0; t.ncols()];
    for (i, j, &v) in t.triplet_iter() {
        y[j] += v * x[i];
    }
    y
}

/// `y = M x` for both components stacked (x values, then y values).
fn mass_times(m: &CscMatrix<f64>, x: &[f64]) -> Vec<f64> {
    let n = m.nrows();
    let mut y = vec![0.0; 2 * n];
    for (i, j, &v) in m.triplet_iter() {
        y[i] += v * x[j];
        y[n + i] += v * x[n + j];
    }
    y
}

/// Whether the grid displacement `u` keeps every particle's `det(I + ∇u) > 0`.
fn admissible(ops: &crate::operators::Operators, u: &[f64]) -> bool {
    displacement_gradients(ops, u)
        .iter()
        .all(|h| (1.0 + h[0]) * (1.0 + h[3]) - h[1] * h[2] > 0.0)
}

/// What to change when the Newton iterations of a step do not converge, from their relative
/// residuals (`small_increment`: the last increment was below the tolerance).
fn newton_advice(residuals: &[f64], small_increment: bool) -> String {
    let last = residuals.last().copied().unwrap_or(f64::INFINITY);
    let earlier = residuals.len().checked_sub(4).map(|i| residuals[i]);
    let stagnant = earlier.is_some_and(|e| last > 0.1 * e);
    if small_increment {
        "the increments vanish while the residual does not (the iterate ran away, or the Newton matrix is \
         nearly singular: a singular mass with `schemes.mass.singularity`?): take a smaller time.dt"
            .into()
    } else if stagnant && last < 1e-6 {
        format!(
            "the residual stalls near {last:.1e}, the round-off of this problem: raise \
             schemes.integrator.newmark.tolerance above it"
        )
    } else {
        "take a smaller time.dt, or raise schemes.integrator.newmark.max_iterations".into()
    }
}

fn norm(v: impl Iterator<Item = f64>) -> f64 {
    v.map(|x| x * x).sum::<f64>().sqrt()
}

impl Simulation {
    /// One Newmark step of at most `max_dt` (the steps of the [module docs](self)).
    pub(super) fn newmark_phases(&mut self, newmark: Newmark, max_dt: f64) -> Result<StepReport> {
        let plan = StepPlan::of(&self.setup, &self.options);
        self.prepare_grid(&plan)?; // (1)–(5)
        let TimeStep::Fixed { dt } = self.options.time_step else {
            return Err(MpmError::InvalidOption {
                option: "integrator",
                reason: "the Newmark integrator takes a fixed time step".into(),
            });
        };
        let dt = dt.min(max_dt);
        // The step's number as report.csv and the other step errors count (from 1).
        let step = self.state.steps + 1;
        // A step the clock cannot resolve, or too short for 1/(β Δt²) to be a number.
        let inertia = 1.0 / (newmark.beta * dt * dt);
        if !(dt > 0.0 && self.state.time + dt > self.state.time && inertia.is_normal()) {
            return Err(MpmError::StepRejected {
                step,
                reason: format!(
                    "a step of {dt:e} at t = {} is too short for the Newmark integrator (the time does not \
                     advance, or 1/(β Δt²) is not a number): give a longer step",
                    self.state.time
                ),
            });
        }
        let Simulation {
            setup,
            options,
            state,
            cache: Cache { ops, mass, nodes },
            scratch,
            ..
        } = self;
        let velocity_solve = project_velocity(setup, ops, mass, &nodes.momentum, &mut nodes.projected)?; // (6)
        let prescribed = &setup.prescribed;
        let base_solve = solve_acceleration(prescribed, ops, mass, &nodes.force, &mut nodes.acceleration)?; // (7)
        let n = ops.num_nodes();
        let materials: Vec<Material> = setup.bodies.iter().map(|b| b.material).collect();
        let g = gradient_operator(ops);
        let stack = |x: &[f64], y: &[f64]| -> Vec<f64> { x.iter().chain(y).copied().collect() };
        let (vn, an) = (
            stack(&nodes.projected.x, &nodes.projected.y),
            stack(&nodes.acceleration.x, &nodes.acceleration.y),
        );
        let p = &state.particles;
        let (f_int0, _) = internal_force_and_tangent(ops, &g, p, &materials, &vec![0.0; 2 * n])?;
        let force = stack(&nodes.force.x, &nodes.force.y);
        let f_ext: Vec<f64> = force.iter().zip(&f_int0).map(|(f, i)| f - i).collect();
        let mut m = mass.solved_matrix(Role::Acceleration);
        let mut outcome = base_solve.outcome;
        // Free degrees of freedom: nodes with mass, and the nodes without mass in a particle's
        // support (a particle on the edge of the node's support: N = 0, ∇N ≠ 0), which the
        // particles' strain sees; less the prescribed components. A node without mass follows
        // the nodes with mass (`follow`, below), as the explicit step's extension has it.
        let massless = |k: usize| mass.lumped()[k % n] <= 0.0;
        let follow = MasslessFollow::new(ops, mass.lumped());
        let mut free = vec![false; 2 * n];
        for i in 0..n {
            let node_free = !massless(i) || follow.follows(i);
            free[i] = node_free;
            free[n + i] = node_free;
        }
        let mut u = vec![0.0; 2 * n];
        let (beta, gamma) = (newmark.beta, newmark.gamma);
        for k in 0..2 * n {
            if free[k] {
                u[k] = dt * vn[k] + 0.5 * dt * dt * an[k];
            }
        }
        for (c, i, v) in prescribed.each() {
            free[c * n + i] = false;
            u[c * n + i] = dt * v;
        }
        // A predictor that inverts a particle (a large step into contact) gives way to
        // `u = Δt v_n`, then to no motion of the free nodes.
        for fallback in [1.0, 0.0] {
            if admissible(ops, &u) {
                break;
            }
            for k in 0..2 * n {
                if free[k] {
                    u[k] = fallback * dt * vn[k];
                }
            }
        }
        follow.apply(&mut u, &free);
        let dofs: Vec<usize> = (0..2 * n).filter(|&k| free[k]).collect();
        // u = T ũ on the free degrees of freedom: ũ the free components of nodes with mass.
        let reduction = follow.reduction(&dofs, &free, n);
        let predicted: Vec<f64> = (0..2 * n)
            .map(|k| {
                if free[k] {
                    dt * vn[k] + dt * dt * (0.5 - beta) * an[k]
                } else {
                    0.0
                }
            })
            .collect();
        let mut local = vec![usize::MAX; 2 * n];
        for (l, &k) in dofs.iter().enumerate() {
            local[k] = l;
        }
        let accel = |u: &[f64]| -> Vec<f64> {
            (0..2 * n)
                .map(|k| {
                    if free[k] {
                        (u[k] - dt * vn[k] - dt * dt * (0.5 - beta) * an[k]) / (beta * dt * dt)
                    } else {
                        0.0
                    }
                })
                .collect()
        };
        let start = u.clone();
        let mut iterations = 0;
        let mut relative = f64::INFINITY;
        let mut solver = std::mem::take(&mut scratch.newton);
        let mut small_increment = false;
        scratch.newton_residuals.clear();
        loop {
            let (f_int, k) = internal_force_and_tangent(ops, &g, p, &materials, &u).map_err(|e| match e {
                MpmError::InvalidParticleValue { particle, value, .. } => MpmError::NewtonFailed {
                    step,
                    iterations,
                    residual: relative,
                    reason: format!(
                        "particle {particle} inverts in the Newton iterate (det F = {value:.3e}); take a smaller \
                         time.dt"
                    ),
                },
                other => other,
            })?;
            // M a(u) = (M u − M c) / (β Δt²), c = Δt v_n + Δt² (½ − β) a_n: each term's size is the
            // residual's scale, so that a converged step reads near round-off even where the
            // forces and accelerations vanish.
            let free_u: Vec<f64> = (0..2 * n).map(|k| if free[k] { u[k] } else { 0.0 }).collect();
            let (mu, mc) = (mass_times(&m, &free_u), mass_times(&m, &predicted));
            let inertia = 1.0 / (beta * dt * dt);
            let r: Vec<f64> = dofs
                .iter()
                .map(|&k| f_ext[k] + f_int[k] - inertia * (mu[k] - mc[k]))
                .collect();
            let scale = norm(
                dofs.iter()
                    .map(|&k| f_ext[k].abs() + f_int[k].abs() + inertia * (mu[k].abs() + mc[k].abs())),
            );
            let (r, scale) = match &reduction {
                None => (r, scale),
                Some(t) => {
                    // Tᵀ r, and the scale carried the same way (T's weights are positive).
                    let terms: Vec<f64> = dofs
                        .iter()
                        .map(|&k| f_ext[k].abs() + f_int[k].abs() + inertia * (mu[k].abs() + mc[k].abs()))
                        .collect();
                    (transpose_times(t, &r), norm(transpose_times(t, &terms).into_iter()))
                }
            };
            relative = if scale > 0.0 {
                norm(r.iter().copied()) / scale
            } else {
                0.0
            };
            scratch.newton_residuals.push(relative);
            if !relative.is_finite() || !u.iter().all(|x| x.is_finite()) {
                scratch.newton = solver;
                return Err(MpmError::NewtonFailed {
                    step,
                    iterations,
                    residual: relative,
                    reason: "the iterate is not finite: take a smaller time.dt".into(),
                });
            }
            // A small increment ends the iterations only with a residual within √tolerance:
            // one held up by round-off, not an iterate that ran away (where every increment is
            // small beside a huge `u`).
            let stalled = small_increment && relative <= newmark.tolerance.sqrt();
            if relative <= newmark.tolerance || stalled || dofs.is_empty() {
                break;
            }
            if small_increment || iterations >= newmark.max_iterations {
                scratch.newton = solver;
                return Err(MpmError::NewtonFailed {
                    step,
                    iterations,
                    residual: relative,
                    reason: newton_advice(&scratch.newton_residuals, small_increment),
                });
            }
            // (K + M / (β Δt²)) on the free degrees of freedom.
            let mut coo = CooMatrix::new(dofs.len(), dofs.len());
            for (i, j, &v) in k.triplet_iter() {
                if local[i] != usize::MAX && local[j] != usize::MAX {
                    coo.push(local[i], local[j], v);
                }
            }
            let shift = 1.0 / (beta * dt * dt);
            for (i, j, &v) in m.triplet_iter() {
                for c in [0, n] {
                    if local[c + i] != usize::MAX && local[c + j] != usize::MAX {
                        coo.push(local[c + i], local[c + j], shift * v);
                    }
                }
            }
            let mut jacobian = CscMatrix::from(&coo);
            if let Some(t) = &reduction {
                jacobian = &(&t.transpose() * &jacobian) * t;
            }
            let mut delta = r;
            let solved = solver.solve(&jacobian, &mut delta);
            if let (Ok(()), Some(t)) = (&solved, &reduction) {
                delta = times(t, &delta);
            }
            if let Err(reason) = solved {
                // K and M share a null vector (a consistent mass without stabilisation and
                // stiffness without its zero-energy modes held): the mass's singularity policy
                // applies to the Newton matrix too, and the step starts again.
                let substitute = match (options.mass.singularity, &outcome) {
                    (_, SolveOutcome::FellBackToLumped { .. }) => None,
                    (SingularityPolicy::FallbackToLumped, _) => Some((
                        lumped_matrix(mass.lumped(), 1.0),
                        SolveOutcome::FellBackToLumped {
                            node: None,
                            relative_pivot: f64::NAN,
                        },
                    )),
                    (SingularityPolicy::Regularize { epsilon }, SolveOutcome::Solved) => Some((
                        &(&m * (1.0 - epsilon)) + &lumped_matrix(mass.lumped(), epsilon),
                        SolveOutcome::Regularized { node: None, epsilon },
                    )),
                    _ => None,
                };
                if let Some((replacement, substituted)) = substitute {
                    m = replacement;
                    outcome = substituted;
                    u.clone_from(&start);
                    iterations = 0;
                    relative = f64::INFINITY;
                    small_increment = false;
                    scratch.newton_residuals.clear();
                    continue;
                }
                scratch.newton = solver;
                let advice = if matches!(outcome, SolveOutcome::Solved)
                    && options.mass.singularity == SingularityPolicy::Error
                {
                    " (a consistent mass without schemes.mass.stabilization and few particles per cell?); give \
                     schemes.mass.singularity = \"fallback_to_lumped\" or { regularize = { epsilon = 0.1 } }, or a \
                     stabilisation"
                } else {
                    "; take a smaller time.dt"
                };
                return Err(MpmError::StepRejected {
                    step,
                    reason: format!("{reason}: the Newton matrix K + M/(β Δt²) is singular{advice}"),
                });
            }
            // Backtracking: the Newton step halved until no particle inverts.
            let mut step_length = 1.0;
            let mut trial = u.clone();
            for _ in 0..30 {
                for (l, &k) in dofs.iter().enumerate() {
                    trial[k] = u[k] + step_length * delta[l];
                }
                if admissible(ops, &trial) {
                    break;
                }
                step_length *= 0.5;
            }
            if step_length < 1.0 {
                delta.iter_mut().for_each(|d| *d *= step_length);
            }
            u = trial;
            iterations += 1;
            // Converged by the increment: the residual of the new iterate is evaluated for the
            // report, then the loop ends.
            small_increment = norm(delta.iter().copied()) <= newmark.tolerance * norm(u.iter().copied());
        }
        scratch.newton = solver;
        // (9)
        // Nodes without mass carry no acceleration; their velocity is their displacement rate.
        let a1 = accel(&u);
        let mut v1: Vec<f64> = (0..2 * n)
            .map(|k| match (free[k], massless(k)) {
                (true, false) => vn[k] + dt * ((1.0 - gamma) * an[k] + gamma * a1[k]),
                (true, true) => u[k] / dt,
                (false, _) => 0.0,
            })
            .collect();
        for (c, i, v) in prescribed.each() {
            v1[c * n + i] = v;
        }
        let energy = |v: &[f64]| 0.5 * v.iter().zip(mass_times(&m, v)).map(|(a, b)| a * b).sum::<f64>();
        let kinetic_before = p.kinetic_energy();
        let (k_projected, k_updated) = (energy(&vn), energy(&v1));
        // (10), after checking that every particle stays where the shape functions accept it.
        let allowed = options.shape.allowed_region(&setup.grid);
        for q in 0..p.len() {
            let mut moved = [p.x[q], p.y[q]];
            for (node, w, _, _) in ops.column(q) {
                moved[0] += w * u[node];
                moved[1] += w * u[n + node];
            }
            let inside =
                moved[0] >= allowed[0] && moved[0] <= allowed[1] && moved[1] >= allowed[2] && moved[1] <= allowed[3];
            if !inside {
                return Err(MpmError::StepRejected {
                    step,
                    reason: format!(
                        "the converged step moves particle {q} from ({:.6}, {:.6}) to ({:.6}, {:.6}), outside the \
                         region [{}, {}] x [{}, {}] where the {} shape functions accept particles: take a smaller \
                         time.dt",
                        p.x[q],
                        p.y[q],
                        moved[0],
                        moved[1],
                        allowed[0],
                        allowed[1],
                        allowed[2],
                        allowed[3],
                        options.shape.name()
                    ),
                });
            }
        }
        let h = displacement_gradients(ops, &u);
        let transfer = options.transfer;
        let p = &mut state.particles;
        let mut strain_energy = 0.0;
        for q in 0..p.len() {
            let (mut du, mut dv, mut v_new) = ([0.0; 2], [0.0; 2], [0.0; 2]);
            for (node, w, _, _) in ops.column(q) {
                for c in 0..2 {
                    du[c] += w * u[c * n + node];
                    dv[c] += w * (v1[c * n + node] - vn[c * n + node]);
                    v_new[c] += w * v1[c * n + node];
                }
            }
            let flip = [p.vx[q] + dv[0], p.vy[q] + dv[1]];
            let [vx, vy] = match transfer {
                Transfer::Pic => v_new,
                Transfer::Blend { flip: alpha } => [
                    alpha * flip[0] + (1.0 - alpha) * v_new[0],
                    alpha * flip[1] + (1.0 - alpha) * v_new[1],
                ],
                _ => flip,
            };
            p.vx[q] = vx;
            p.vy[q] = vy;
            p.x[q] += du[0];
            p.y[q] += du[1];
            let hq = h[q];
            let (fxx, fxy, fyx, fyy) = (p.fxx[q], p.fxy[q], p.fyx[q], p.fyy[q]);
            p.fxx[q] = (1.0 + hq[0]) * fxx + hq[1] * fyx;
            p.fxy[q] = (1.0 + hq[0]) * fxy + hq[1] * fyy;
            p.fyx[q] = hq[2] * fxx + (1.0 + hq[3]) * fyx;
            p.fyy[q] = hq[2] * fxy + (1.0 + hq[3]) * fyy;
            let j_inc = (1.0 + hq[0]) * (1.0 + hq[3]) - hq[1] * hq[2];
            p.volume[q] *= j_inc;
            let material = &materials[p.body[q]];
            let f = [p.fxx[q], p.fxy[q], p.fyx[q], p.fyy[q]];
            let sigma = match material {
                Material::LinearElastic(le) => {
                    let d = le.stress_increment(hq[0], hq[3], 0.5 * (hq[1] + hq[2]));
                    [p.sxx[q] + d[0], p.syy[q] + d[1], p.sxy[q] + d[2]]
                }
                Material::NeoHookean(nh) => nh.stress(f),
            };
            [p.sxx[q], p.syy[q], p.sxy[q]] = sigma;
            strain_energy += material.strain_energy(p.volume[q], sigma, f);
        }
        state.strain_energy = strain_energy;
        nodes.updated.x[..n].copy_from_slice(&v1[..n]);
        nodes.updated.y[..n].copy_from_slice(&v1[n..]);
        scratch.particle.kinetic = KineticEnergies {
            before: kinetic_before,
            projected: k_projected,
            updated: k_updated,
        };
        scratch.sums = None;
        let newton = SolveReport {
            scheme: base_solve.scheme,
            outcome,
            iterations,
            relative_residual: relative,
        };
        self.finish_step(dt, f64::INFINITY, [velocity_solve, newton])
    }
}
