//! The Newton stage of the implicit integrators: the grid displacement `u` of one step on the
//! free degrees of freedom (docs/implicit.md). Newmark's step and a quasi-static increment
//! (no mass, the load factor `λ`):
//!
//! ```text
//! a(u) = (u − c) / (β Δt²),   c = Δt v_n + Δt² (½ − β) a_n
//! r(u) = λ f_ext + f_int(u) − M a(u)                           (quasi-static: no M a(u))
//! Tᵀ (K(u) + M / (β Δt²)) T δũ = Tᵀ r(u),   u ← u + T δũ      (faer sparse LU)
//! ```
//!
//! each step halved until no particle inverts. `T` eliminates the free nodes without mass: their
//! displacement follows the nodes with mass as the explicit step's extension has it
//! ([`crate::transfer::extension_matrix`]), so that a rigid motion stays rigid at the particles
//! whose support reaches past the body.

use nalgebra_sparse::{CooMatrix, CscMatrix, CsrMatrix};

use super::{displacement_gradients, gradient_operator, internal_force, internal_force_and_tangent, SparseLu};
use crate::boundary::Prescribed;
use crate::error::{MpmError, Result};
use crate::fields::VectorField;
use crate::kernels::{extend_to_inactive_nodes, ExtensionScratch};
use crate::mass::{csc_times, lumped_matrix, SingularityPolicy, SolveOutcome};
use crate::material::Material;
use crate::operators::Operators;
use crate::particles::Particles;

/// One step's equations on the grid: what the Newton iterations read. Vectors over the
/// degrees of freedom hold the x components of every node, then the y components.
pub(crate) struct NewtonSystem<'a> {
    /// The operators at the particles' positions at the start of the step.
    pub ops: &'a Operators,
    /// The particles at the start of the step.
    pub particles: &'a Particles,
    /// Each body's material.
    pub materials: Vec<Material>,
    /// The lumped mass (the singularity policy's fall-back).
    pub lumped: &'a [f64],
    /// The grid force `f = f_ext + f_int(σ_n)`.
    pub force: Vec<f64>,
    /// `c = Δt v_n + Δt² (½ − β) a_n` on the free degrees of freedom, 0 elsewhere (Newmark).
    pub predicted: Vec<f64>,
    /// `1/(β Δt²)` (Newmark), 0 without inertia (quasi-static).
    pub inertia: f64,
    /// `λ`, the factor of `f_ext` (1 for Newmark).
    pub load: f64,
    /// The free degrees of freedom, ascending.
    pub dofs: Vec<usize>,
    /// `T` (free degrees of freedom × free components of nodes with mass), `None` for `T = I`.
    pub reduction: Option<CscMatrix<f64>>,
    /// The relative tolerance and the iterations allowed.
    pub tolerance: f64,
    /// Newton iterations allowed.
    pub max_iterations: usize,
    /// The integrator's key in `schemes.integrator` (`newmark`, `quasi_static`), for advice.
    pub key: &'static str,
    /// The step's number, for the errors.
    pub step: usize,
    /// What a singular Newton matrix calls for.
    pub singularity: SingularityPolicy,
}

impl<'a> NewtonSystem<'a> {
    /// The equations of step `step` at the operators `ops`, the particles `particles` of
    /// bodies of `materials`, the lumped mass and the grid force: the free degrees of freedom of
    /// `freedom`; no inertia, the full load, the default controls of the quasi-static
    /// integrator (the caller sets what differs).
    pub(crate) fn new(
        ops: &'a Operators,
        particles: &'a Particles,
        materials: Vec<Material>,
        lumped: &'a [f64],
        force: Vec<f64>,
        freedom: Freedom,
        step: usize,
    ) -> NewtonSystem<'a> {
        let defaults = super::QuasiStatic::default();
        NewtonSystem {
            predicted: vec![0.0; force.len()],
            ops,
            particles,
            materials,
            lumped,
            force,
            inertia: 0.0,
            load: 1.0,
            dofs: freedom.dofs,
            reduction: freedom.reduction,
            tolerance: defaults.tolerance,
            max_iterations: defaults.max_iterations,
            key: "quasi_static",
            step,
            singularity: SingularityPolicy::Error,
        }
    }
}

/// The mass of the Newmark residual, and what the acceleration solve did to it.
pub(crate) struct NewtonMass {
    /// `M` (nodes × nodes), of the x component and, when `matrix_y` is `None`, of both.
    pub matrix: CscMatrix<f64>,
    /// The y component's own `M`, when the components have masses of their own (slip walls
    /// under the mirror rule: `crate::mass::GridMass::has_component_masses`).
    pub matrix_y: Option<CscMatrix<f64>>,
    /// Solved as it is, regularised or fallen back to the lumped mass.
    pub outcome: SolveOutcome,
}

impl NewtonMass {
    /// `M` of component `c` (0: x, 1: y).
    pub(crate) fn component(&self, c: usize) -> &CscMatrix<f64> {
        match (c, &self.matrix_y) {
            (1, Some(y)) => y,
            _ => &self.matrix,
        }
    }

    /// `y = M x` for both components stacked.
    pub(crate) fn times(&self, x: &[f64]) -> Vec<f64> {
        let n = self.matrix.nrows();
        [
            csc_times(self.component(0), &x[..n]),
            csc_times(self.component(1), &x[n..]),
        ]
        .concat()
    }
}

/// The converged displacement and how it was reached.
pub(crate) struct Converged {
    /// `u` on every degree of freedom.
    pub u: Vec<f64>,
    /// Newton iterations taken.
    pub iterations: usize,
    /// The last relative residual.
    pub relative: f64,
    /// The mass the residual used at the end (a singular Newton matrix may have replaced it).
    pub mass: Option<NewtonMass>,
}

/// The degrees of freedom of one step and the start of its Newton iterations.
pub(crate) struct Freedom {
    /// Which components are free (x components of every node, then y).
    pub free: Vec<bool>,
    /// The start of `u`.
    pub start: Vec<f64>,
    /// The free degrees of freedom, ascending.
    pub dofs: Vec<usize>,
    /// `T` ([`reduction`]).
    pub reduction: Option<CscMatrix<f64>>,
}

impl Freedom {
    /// The free components: those of the active nodes and of the inactive nodes the extension
    /// reaches (a particle on the edge of a node's support, where `N = 0` but `∇N ≠ 0`), less
    /// the prescribed ones. The start: `u = Δt v̄` on the prescribed components, `initial(k)` on
    /// the free ones, or the first of `fallbacks` that inverts no particle when `initial` does
    /// (a large step into contact); then the free inactive nodes follow the active ones by the
    /// explicit step's extension.
    pub(crate) fn of(
        ops: &Operators,
        is_active: &[bool],
        prescribed: &Prescribed,
        dt: f64,
        initial: &dyn Fn(usize) -> f64,
        fallbacks: &[&dyn Fn(usize) -> f64],
        scratch: &mut ExtensionScratch,
    ) -> Freedom {
        let n = is_active.len();
        let e = crate::transfer::extension_matrix(ops, is_active);
        let mut follows = vec![false; n];
        e.triplet_iter().for_each(|(i, _, _)| follows[i] = true);
        let mut free: Vec<bool> = (0..2 * n).map(|k| is_active[k % n] || follows[k % n]).collect();
        for (c, i, _) in prescribed.each() {
            free[c * n + i] = false;
        }
        // The ghosts of slip walls under the mirror rule: free, their mirrors' values times the
        // wall's sign for the component (stacked degrees of freedom).
        let mirrored = mirrored_dofs(ops, prescribed);
        for &(g, _, _) in &mirrored {
            free[g] = true;
        }
        let reflect = |u: &mut [f64]| mirrored.iter().for_each(|&(g, m, s)| u[g] = s * u[m]);
        let mut start: Vec<f64> = (0..2 * n).map(|k| if free[k] { initial(k) } else { 0.0 }).collect();
        for (c, i, v) in prescribed.each() {
            start[c * n + i] = dt * v;
        }
        reflect(&mut start);
        for fallback in fallbacks {
            if admissible(ops, &start) {
                break;
            }
            (0..2 * n).filter(|&k| free[k]).for_each(|k| start[k] = fallback(k));
            reflect(&mut start);
        }
        follow(ops, is_active, &free, &mut start, scratch);
        reflect(&mut start);
        let (dofs, reduction) = reduction(&e, &free, is_active, &mirrored);
        Freedom {
            free,
            start,
            dofs,
            reduction,
        }
    }
}

/// The free degrees of freedom and the reduction `T` for the free flags `free` (every
/// component of the nodes with mass and of the nodes the extension `e` reaches, less the
/// prescribed ones): `T` maps the free components of nodes with mass to every free degree of
/// freedom, a follower's row holding its extension weights.
///
/// The ghost degrees of freedom of slip walls under the mirror rule, `mirrored` as
/// `(ghost, mirror, sign)`, hold their mirror's row times the sign, so that `Tᵀ K T` and
/// `Tᵀ M T` are the folded `Cᵀ K C` and `Cᵀ M C` (simulation/walls.rs).
pub(crate) fn reduction(
    e: &CscMatrix<f64>,
    free: &[bool],
    is_active: &[bool],
    mirrored: &[(usize, usize, f64)],
) -> (Vec<usize>, Option<CscMatrix<f64>>) {
    let n = is_active.len();
    let dofs: Vec<usize> = (0..2 * n).filter(|&k| free[k]).collect();
    if dofs.iter().all(|&k| is_active[k % n]) {
        return (dofs, None);
    }
    let mut mirror_of = vec![None; 2 * n];
    for &(g, m, s) in mirrored {
        mirror_of[g] = Some((m, s));
    }
    let mut column = vec![usize::MAX; 2 * n];
    let mut columns = 0;
    for &k in &dofs {
        if is_active[k % n] {
            column[k] = columns;
            columns += 1;
        }
    }
    let rows = CsrMatrix::from(e);
    let mut coo = CooMatrix::new(dofs.len(), columns);
    for (row, &dof) in dofs.iter().enumerate() {
        let (k, sign) = mirror_of[dof].unwrap_or((dof, 1.0));
        let (c, i) = (k / n, k % n);
        if !free[k] {
            continue; // a prescribed mirror (the ghost follows nothing)
        }
        if is_active[i] {
            coo.push(row, column[k], sign);
            continue;
        }
        let weights = rows.row(i);
        for (&j, &w) in weights.col_indices().iter().zip(weights.values()) {
            if w != 0.0 && column[c * n + j] != usize::MAX {
                coo.push(row, column[c * n + j], sign * w);
            }
        }
    }
    (dofs, Some(CscMatrix::from(&coo)))
}

/// The ghost degrees of freedom of the slip walls under the mirror rule as
/// `(ghost, mirror, sign)` (stacked: x components of every node, then y).
fn mirrored_dofs(ops: &Operators, prescribed: &Prescribed) -> Vec<(usize, usize, f64)> {
    let Some(grid) = ops.grid().filter(|_| !prescribed.slip.is_empty()) else {
        return Vec::new();
    };
    let n = grid.num_nodes();
    (0..2)
        .flat_map(|c| {
            let walls = prescribed.slip.component(c);
            walls
                .ghost_map(grid)
                .into_iter()
                .map(move |(g, m, s)| (c * n + g, c * n + m, s))
        })
        .collect()
}

/// (8b) for the displacement `u` (stacked): the free components of the inactive nodes in a
/// particle's support follow the particles' mean interpolated displacement.
fn follow(ops: &Operators, is_active: &[bool], free: &[bool], u: &mut [f64], s: &mut ExtensionScratch) {
    let n = is_active.len();
    let mut field = VectorField {
        x: u[..n].to_vec(),
        y: u[n..].to_vec(),
    };
    extend_to_inactive_nodes(ops, is_active, &mut field, s);
    for i in (0..n).filter(|&i| !is_active[i]) {
        for (c, value) in [field.x[i], field.y[i]].into_iter().enumerate() {
            if free[c * n + i] {
                u[c * n + i] = value;
            }
        }
    }
}

/// Whether the grid displacement `u` keeps every particle's `det(I + ∇u) > 0`.
pub(crate) fn admissible(ops: &Operators, u: &[f64]) -> bool {
    displacement_gradients(ops, u)
        .iter()
        .all(|h| (1.0 + h[0]) * (1.0 + h[3]) - h[1] * h[2] > 0.0)
}

fn norm(v: impl Iterator<Item = f64>) -> f64 {
    v.map(|x| x * x).sum::<f64>().sqrt()
}

/// `Tᵀ x`, or `x` for `T = I`.
fn reduce(t: Option<&CscMatrix<f64>>, x: Vec<f64>) -> Vec<f64> {
    match t {
        None => x,
        Some(t) => csc_times(&t.transpose(), &x),
    }
}

impl NewtonSystem<'_> {
    /// The Newton iterations from `u` (the predictor, prescribed components set) with the mass
    /// `mass` (none: quasi-static), warm in `solver`'s symbolic analysis; each iteration's
    /// relative residual into `residuals`.
    ///
    /// # Errors
    /// [`MpmError::NewtonFailed`] when the iterations do not converge or an iterate inverts a
    /// particle; [`MpmError::StepRejected`] when the Newton matrix is singular and the singularity
    /// policy has no substitute.
    pub(crate) fn solve(
        &self,
        start: Vec<f64>,
        mut mass: Option<NewtonMass>,
        solver: &mut SparseLu,
        residuals: &mut Vec<f64>,
    ) -> Result<Converged> {
        let (ops, dofs, t, step) = (self.ops, &self.dofs, self.reduction.as_ref(), self.step);
        let n = ops.num_nodes();
        let g = gradient_operator(ops);
        // f_ext: the force less the internal force of the particles' stress.
        let f_int0 = internal_force(ops, &g, self.particles, &self.materials, &vec![0.0; 2 * n])?;
        let f_ext: Vec<f64> = self.force.iter().zip(&f_int0).map(|(f, i)| f - i).collect();
        let (inertia, load) = (self.inertia, self.load);
        let mut local = vec![usize::MAX; 2 * n];
        for (l, &k) in dofs.iter().enumerate() {
            local[k] = l;
        }
        let (mut u, mut iterations, mut relative) = (start.clone(), 0, f64::INFINITY);
        let mut small_increment = false;
        // An increment no larger than this moves no node by anything the positions resolve.
        let resolution = 1e-13 * ops.grid().map_or(1.0, |g| g.cell_size()[0].min(g.cell_size()[1]));
        let mut unresolved = false;
        residuals.clear();
        loop {
            let tangent = internal_force_and_tangent(ops, &g, self.particles, &self.materials, &u);
            let (f_int, k) = tangent.map_err(|e| match e {
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
            // M a(u) = (M u − M c) / (β Δt²): each term's size is the residual's scale, so that a
            // converged step reads near round-off even where the forces and accelerations vanish.
            let free_u: Vec<f64> = (0..2 * n)
                .map(|k| if local[k] != usize::MAX { u[k] } else { 0.0 })
                .collect();
            let (mu, mc) = match &mass {
                Some(m) => (m.times(&free_u), m.times(&self.predicted)),
                None => (vec![0.0; 2 * n], vec![0.0; 2 * n]),
            };
            let r = dofs
                .iter()
                .map(|&k| load * f_ext[k] + f_int[k] - inertia * (mu[k] - mc[k]));
            let r_now: Vec<f64> = r.clone().collect();
            let terms = dofs
                .iter()
                .map(|&k| load * f_ext[k].abs() + f_int[k].abs() + inertia * (mu[k].abs() + mc[k].abs()));
            // Tᵀ r, and the scale carried the same way (T's weights are positive), with the
            // reactions at the components that are not free: a step driven by prescribed
            // displacements alone has no other force to measure its residual by.
            let reactions = (0..2 * n)
                .filter(|&k| local[k] == usize::MAX)
                .map(|k| load * f_ext[k].abs() + f_int[k].abs());
            let free_scale = reduce(t, terms.collect());
            let (r, scale) = (reduce(t, r.collect()), norm(free_scale.into_iter().chain(reactions)));
            relative = if scale > 0.0 {
                norm(r.iter().copied()) / scale
            } else {
                0.0
            };
            residuals.push(relative);
            let failed = |reason: String| MpmError::NewtonFailed {
                step,
                iterations,
                residual: relative,
                reason,
            };
            if !relative.is_finite() || !u.iter().all(|x| x.is_finite()) {
                return Err(failed("the iterate is not finite: take a smaller time.dt".into()));
            }
            // A small increment ends the iterations only with a residual within √tolerance: one
            // held up by round-off, not an iterate that ran away. So does a residual within
            // √tolerance that no longer halves in two iterations (Newton converges quadratically
            // until round-off holds it), and an increment below what the positions resolve.
            let within = relative <= self.tolerance.sqrt();
            let stagnant = within && residuals.len() >= 3 && relative > 0.5 * residuals[residuals.len() - 3];
            let stalled = (small_increment && within) || stagnant || unresolved;
            if relative <= self.tolerance || stalled || dofs.is_empty() {
                return Ok(Converged {
                    u,
                    iterations,
                    relative,
                    mass,
                });
            }
            if small_increment || iterations >= self.max_iterations {
                return Err(failed(newton_advice(residuals, small_increment, self.key)));
            }
            // (K + M / (β Δt²)) on the free degrees of freedom.
            let mut coo = CooMatrix::new(dofs.len(), dofs.len());
            for (i, j, &v) in k.triplet_iter() {
                if local[i] != usize::MAX && local[j] != usize::MAX {
                    coo.push(local[i], local[j], v);
                }
            }
            for (component, c) in [0, n].into_iter().enumerate() {
                for (i, j, &v) in mass.iter().flat_map(|m| m.component(component).triplet_iter()) {
                    if local[c + i] != usize::MAX && local[c + j] != usize::MAX {
                        coo.push(local[c + i], local[c + j], inertia * v);
                    }
                }
            }
            let mut jacobian = CscMatrix::from(&coo);
            if let Some(t) = t {
                jacobian = &(&t.transpose() * &jacobian) * t;
            }
            let mut delta = r;
            if let Err(reason) = solver.solve(&jacobian, &mut delta) {
                // K and M share a null vector (a consistent mass without stabilisation and
                // stiffness without its zero-energy modes held): the mass's singularity policy
                // applies to the Newton matrix too, and the step starts again.
                mass = Some(self.substitute(mass, &reason)?);
                (u, iterations, relative, small_increment) = (start.clone(), 0, f64::INFINITY, false);
                unresolved = false;
                residuals.clear();
                continue;
            }
            if let Some(t) = t {
                delta = csc_times(t, &delta);
            }
            // Backtracking: the Newton step halved until no particle inverts.
            let mut step_length = 1.0;
            let mut trial = u.clone();
            let mut found = false;
            for _ in 0..31 {
                for (l, &k) in dofs.iter().enumerate() {
                    trial[k] = u[k] + step_length * delta[l];
                }
                found = admissible(ops, &trial);
                if found {
                    break;
                }
                step_length *= 0.5;
            }
            // Then halved (at most ten times) until the residual decreases: the Newton direction
            // descends |r|² with the exact tangent, and a full step that does not (a plastic
            // zone entered at the step's start, whose tangent is soft) is not taken whole. Not
            // within √tolerance, where Newton converges quadratically until round-off holds it.
            if found && !within {
                let now = norm(reduce(t, r_now).into_iter());
                let mut halvings = 0;
                while halvings < 10 {
                    let at = self.residual_norm(&g, &f_ext, mass.as_ref(), &local, &trial)?;
                    if at <= (1.0 - 1e-4 * step_length) * now || now == 0.0 {
                        break;
                    }
                    step_length *= 0.5;
                    for (l, &k) in dofs.iter().enumerate() {
                        trial[k] = u[k] + step_length * delta[l];
                    }
                    halvings += 1;
                }
            }
            if !found {
                let advice = match self.key {
                    "quasi_static" => {
                        "the increment's load is more than the bodies can carry from here (a body that cannot \
                         carry its load has no equilibrium): give more schemes.integrator.quasi_static.load_steps"
                    }
                    _ => "take a smaller time.dt",
                };
                return Err(failed(format!(
                    "every length of the Newton step down to 2⁻³⁰ of it inverts a particle: {advice}"
                )));
            }
            u = trial;
            iterations += 1;
            // Converged by the increment: the residual of the new iterate is evaluated for the
            // report, then the loop ends.
            let increment = step_length * norm(delta.iter().copied());
            small_increment = increment <= self.tolerance * norm(u.iter().copied());
            unresolved = step_length * delta.iter().fold(0.0, |m: f64, d| m.max(d.abs())) <= resolution;
        }
    }

    /// `|Tᵀ r(u)|` of the iterate `u`, the residual of [`NewtonSystem::solve`] (`f_ext` the
    /// external force less the step start's internal force); an iterate that inverts a particle
    /// has an infinite residual.
    ///
    /// # Errors
    /// None but those of the internal force other than an inversion.
    fn residual_norm(
        &self,
        g: &CscMatrix<f64>,
        f_ext: &[f64],
        mass: Option<&NewtonMass>,
        local: &[usize],
        u: &[f64],
    ) -> Result<f64> {
        let n = self.ops.num_nodes();
        let f_int = match internal_force(self.ops, g, self.particles, &self.materials, u) {
            Ok(f) => f,
            Err(MpmError::InvalidParticleValue { .. }) => return Ok(f64::INFINITY),
            Err(e) => return Err(e),
        };
        let free_u: Vec<f64> = (0..2 * n)
            .map(|k| if local[k] != usize::MAX { u[k] } else { 0.0 })
            .collect();
        let (mu, mc) = match mass {
            Some(m) => (m.times(&free_u), m.times(&self.predicted)),
            None => (vec![0.0; 2 * n], vec![0.0; 2 * n]),
        };
        let r = self
            .dofs
            .iter()
            .map(|&k| self.load * f_ext[k] + f_int[k] - self.inertia * (mu[k] - mc[k]))
            .collect();
        Ok(norm(reduce(self.reduction.as_ref(), r).into_iter()))
    }

    /// The mass the singularity policy puts in place of `mass` when the Newton matrix is
    /// singular (`reason`), or the error that the step cannot be taken.
    fn substitute(&self, mass: Option<NewtonMass>, reason: &str) -> Result<NewtonMass> {
        let Some(mass) = mass else {
            return Err(MpmError::StepRejected {
                step: self.step,
                reason: format!(
                    "{reason}: the tangent stiffness K is singular (a body free to move rigidly, or particles \
                     too few to hold a node: give the body walls that hold it, or more particles per cell)"
                ),
            });
        };
        let substitute = match (self.singularity, &mass.outcome) {
            (_, SolveOutcome::FellBackToLumped { .. }) => None,
            (SingularityPolicy::FallbackToLumped, _) => Some(NewtonMass {
                matrix: lumped_matrix(self.lumped, 1.0),
                matrix_y: None,
                outcome: SolveOutcome::FellBackToLumped {
                    node: None,
                    relative_pivot: f64::NAN,
                },
            }),
            (SingularityPolicy::Regularize { epsilon }, SolveOutcome::Solved) => Some(NewtonMass {
                matrix: &(&mass.matrix * (1.0 - epsilon)) + &lumped_matrix(self.lumped, epsilon),
                matrix_y: (mass.matrix_y.as_ref())
                    .map(|y| &(y * (1.0 - epsilon)) + &lumped_matrix(self.lumped, epsilon)),
                outcome: SolveOutcome::Regularized { node: None, epsilon },
            }),
            _ => None,
        };
        substitute.ok_or_else(|| {
            let advice = if matches!(mass.outcome, SolveOutcome::Solved) && self.singularity == SingularityPolicy::Error
            {
                " (a consistent mass without schemes.mass.stabilization and few particles per cell?); give \
                 schemes.mass.singularity = \"fallback_to_lumped\" or { regularize = { epsilon = 0.1 } }, or a \
                 stabilisation"
            } else {
                "; take a smaller time.dt"
            };
            MpmError::StepRejected {
                step: self.step,
                reason: format!("{reason}: the Newton matrix K + M/(β Δt²) is singular{advice}"),
            }
        })
    }
}

/// What to change when the Newton iterations of a step do not converge, from their relative
/// residuals (`small_increment`: the last increment was below the tolerance).
fn newton_advice(residuals: &[f64], small_increment: bool, key: &str) -> String {
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
             schemes.integrator.{key}.tolerance above it"
        )
    } else {
        format!("take a smaller time.dt (more load_steps), or raise schemes.integrator.{key}.max_iterations")
    }
}
