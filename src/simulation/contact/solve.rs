//! Contact through each body's mass (consistent, blended, cg, series): the impulses of every
//! pair in contact solved together, so that the node-wise contact law holds for the velocities
//! they give through the bodies' masses.
//!
//! With `Λ_e` the impulse body `a` of pair `e` receives at its node `i_e` (body `b` receives
//! `−Λ_e`), the stage's velocities are
//!
//! ```text
//! u_b(Λ) = u*_b + M_b⁻¹ J_b(Λ),    J_b = Σ_{e: a_e = b} Λ_e δ_{i_e} − Σ_{e: b_e = b} Λ_e δ_{i_e}
//! ```
//!
//! with `M_b` the mass of the solve the stage corrects (the velocity projection's, or the
//! acceleration solve's for the updated velocities: an impulse over the step is a force). At
//! the solution every pair obeys the node-wise law of [`crate::contact::pair_correction`] on
//! the *accumulated* impulse: `Λ_n = Λ_e · n ≤ 0` (a push) with the relative normal velocity
//! zero, or `Λ_n = 0` and the pair separating; `|Λ_t| ≤ μ |Λ_n|`, the pair sticking inside the
//! bound and its impulse opposing the slip on it (the strain stage's pairs are held together,
//! `Λ_n` of either sign). The iteration is the projected gradient one of the lumped correction,
//! accelerated (Nesterov, restarted when its step grows),
//!
//! ```text
//! Λ ← P(y + ω m̃_e (u_b(y) − u_a(y))(i_e)),   y = Λ_k + β_k (Λ_k − Λ_{k−1}),   ω = 1/λ_max(m̃ W)
//! ```
//!
//! `m̃_e` the pair's reduced lumped mass, `W = Σ_b C_b M_b⁻¹ C_bᵀ` the pairs' coupling through
//! the masses (its largest eigenvalue by a power iteration), `P` the projection onto the law's
//! bounds. With the lumped mass `m̃ W = I` and one step is [`super::correct::correct`]'s
//! correction. Frictionless, the solution is the `M`-metric projection of `u*` onto the
//! velocities that do not approach: the bodies' kinetic energy `½ Σ_b uᵀ M_b u` cannot grow,
//! and each iterate lowers it (`f(Λ) = ½ Λᵀ W Λ − Λᵀ g*` is its change). The pair's momentum is
//! exact at every iterate (`J` sums to zero over the pair).

use super::correct::{Candidate, Context, Decide, Stage, Tally, Touching, WALL};
use super::{walls, Layer};
use crate::error::Result;
use crate::fields::VectorField;
use crate::operators::Operators;

/// The relative change of the impulses at which the iteration stops.
const TOLERANCE: f64 = 1e-9;
/// The iteration limit (the momentum is exact at any iterate; the law then holds to what the
/// iteration reached).
const MAX_ITERATIONS: usize = 400;
/// Power iterations for `λ_max(m̃ W)`.
const POWER_ITERATIONS: usize = 12;
/// The margin on the estimated `λ_max`.
const MARGIN: f64 = 1.1;
/// The number of pairs up to which their coupling `W` is formed (two solves per pair and
/// body) and the law solved on it by projected Gauss–Seidel; the accelerated iteration beyond.
const DENSE_PAIRS: usize = 32;
/// The sweep limit of the projected Gauss–Seidel.
const MAX_SWEEPS: usize = 1000;

/// One pair that may be in contact at one node: its candidate, its reduced lumped mass, and
/// whether it is held together (the strain stage).
struct Entry {
    c: Candidate,
    reduced: f64,
    held: bool,
}

/// The impulses of the stage's pairs through the bodies' masses ([module docs](self)); the
/// stage's field of every body corrected, the prescribed components kept.
pub(super) fn correct_through_mass(
    cx: &Context,
    ops: &Operators,
    bodies: &mut [Layer],
    span: std::ops::Range<usize>,
    decide: Decide,
) -> Result<Tally> {
    cx.set_rigid(bodies, span.clone());
    let mut entries = Vec::new();
    let mut record = None;
    match decide {
        Decide::Known(touching) => {
            for t in touching {
                if let Some(c) = cx.candidate(bodies, t.node, t.bodies, true, 0.0) {
                    entries.extend(entry(c, true));
                }
            }
        }
        Decide::Approach(touching) => {
            cx.each_pair(bodies, span, touching, |bodies, i, pair, centre| {
                if let Some(c) = cx.candidate(bodies, i, pair, false, centre) {
                    entries.extend(entry(c, false));
                }
                false
            });
            record = Some(touching);
        }
    }
    let mut tally = Tally::default();
    if !entries.is_empty() {
        let solver = Solver::new(cx, ops, bodies, &entries);
        let impulses = if entries.len() <= DENSE_PAIRS {
            solver.solve_dense()?
        } else {
            solver.solve()?
        };
        let velocities = solver.velocities(&impulses)?;
        for (e, lambda) in entries.iter().zip(&impulses) {
            if lambda[0] == 0.0 && lambda[1] == 0.0 {
                continue;
            }
            let n = e.c.normal;
            let normal = lambda[0] * n[0] + lambda[1] * n[1];
            tally.normal_impulse += normal.abs();
            if cx.stage == Stage::Force {
                // Friction's work over the step: its impulse against the slip that remains.
                let t = [lambda[0] - normal * n[0], lambda[1] - normal * n[1]];
                let [ua, ub] = solver.pair_velocities(&velocities, e, false);
                tally.friction -= t[0] * (ua[0] - ub[0]) + t[1] * (ua[1] - ub[1]);
            }
            if let Some(touching) = record.as_deref_mut() {
                touching.push(Touching {
                    node: e.c.node,
                    bodies: e.c.bodies,
                });
            }
        }
        let involved = solver.involved;
        for (k, u) in involved.into_iter().zip(velocities) {
            *cx.stage.field(&mut bodies[k].nodes) = u;
        }
    }
    for layer in bodies.iter_mut() {
        let u = cx.stage.field(&mut layer.nodes);
        cx.setup.prescribed.apply_velocity(&mut u.x, &mut u.y);
    }
    Ok(tally)
}

/// The entry of candidate `c`, none where both bodies are rigid or the reduced mass is zero.
fn entry(c: Candidate, held: bool) -> Option<Entry> {
    let reduced = match (c.a.rigid, c.b.rigid) {
        (true, true) => return None,
        (false, true) => c.a.mass,
        (true, false) => c.b.mass,
        (false, false) => c.a.mass * c.b.mass / (c.a.mass + c.b.mass),
    };
    (reduced > 0.0 && reduced.is_finite()).then_some(Entry { c, reduced, held })
}

/// The bodies' masses and starting velocities for one stage's solve.
struct Solver<'a> {
    cx: &'a Context<'a>,
    ops: &'a Operators,
    bodies: &'a [Layer],
    entries: &'a [Entry],
    /// The bodies that move with the impulses (not rigid), ascending.
    involved: Vec<usize>,
    /// `u*_b` of each involved body.
    start: Vec<VectorField>,
}

impl<'a> Solver<'a> {
    fn new(cx: &'a Context<'a>, ops: &'a Operators, bodies: &'a [Layer], entries: &'a [Entry]) -> Solver<'a> {
        let mut involved: Vec<usize> = entries
            .iter()
            .flat_map(|e| e.c.bodies)
            .filter(|&b| b < WALL && cx.rigid[b].is_none())
            .collect();
        involved.sort_unstable();
        involved.dedup();
        let start = involved
            .iter()
            .map(|&b| cx.stage.field_of(&bodies[b].nodes).clone())
            .collect();
        Solver {
            cx,
            ops,
            bodies,
            entries,
            involved,
            start,
        }
    }

    /// `M_b⁻¹ J_b(Λ)` of every involved body (with the slip walls' fold), plus `u*_b` when
    /// `base`.
    fn respond(&self, impulses: &[[f64; 2]], base: bool) -> Result<Vec<VectorField>> {
        let (grid, slip) = (&self.cx.setup.grid, &self.cx.setup.prescribed.slip);
        let n = self.ops.num_nodes();
        let mut out = Vec::with_capacity(self.involved.len());
        for (slot, &k) in self.involved.iter().enumerate() {
            let mut j = VectorField::zeros(n);
            for (e, lambda) in self.entries.iter().zip(impulses) {
                let [a, b] = e.c.bodies;
                let sign = if a == k {
                    1.0
                } else if b == k {
                    -1.0
                } else {
                    continue;
                };
                j.x[e.c.node] += sign * lambda[0];
                j.y[e.c.node] += sign * lambda[1];
            }
            let mut du = VectorField::zeros(n);
            if j.x.iter().chain(&j.y).any(|&v| v != 0.0) {
                walls::fold(slip, grid, &mut j);
                let mass = &self.bodies[k].mass;
                mass.solve_into(self.cx.stage.role(), &j, None, self.ops, &mut du)?;
                walls::unfold(slip, grid, &mut [&mut du]);
            }
            if base {
                let s = &self.start[slot];
                for i in 0..n {
                    du.x[i] += s.x[i];
                    du.y[i] += s.y[i];
                }
            }
            out.push(du);
        }
        Ok(out)
    }

    /// The velocities `u_b(Λ)` of the involved bodies.
    fn velocities(&self, impulses: &[[f64; 2]]) -> Result<Vec<VectorField>> {
        if impulses.iter().all(|l| l[0] == 0.0 && l[1] == 0.0) {
            return Ok(self.start.clone());
        }
        self.respond(impulses, true)
    }

    /// The velocities of the pair `e` at its node, the involved bodies' from `fields` (a rigid
    /// body's its own, a wall at rest); or, for `response` fields (`M_b⁻¹ J_b` alone), the
    /// involved bodies' responses and 0 for the others.
    fn pair_velocities(&self, fields: &[VectorField], e: &Entry, response: bool) -> [[f64; 2]; 2] {
        let i = e.c.node;
        let of = |k: usize, own: [f64; 2]| match self.involved.binary_search(&k) {
            Ok(slot) => [fields[slot].x[i], fields[slot].y[i]],
            Err(_) if response => [0.0; 2],
            Err(_) => own,
        };
        let [a, b] = e.c.bodies;
        let ua = of(a, e.c.a.velocity);
        let ub = if b >= WALL { [0.0; 2] } else { of(b, e.c.b.velocity) };
        [ua, ub]
    }

    /// `m̃_e (u_b − u_a)(i_e)` of every pair ([`Solver::pair_velocities`]): the lumped
    /// correction the velocities `fields` still ask for.
    fn wanted(&self, fields: &[VectorField], response: bool) -> Vec<[f64; 2]> {
        self.entries
            .iter()
            .map(|e| {
                let [ua, ub] = self.pair_velocities(fields, e, response);
                [e.reduced * (ub[0] - ua[0]), e.reduced * (ub[1] - ua[1])]
            })
            .collect()
    }

    /// `λ_max(m̃ W)` by power iteration from the pairs' normals (1 with the lumped mass).
    fn largest_eigenvalue(&self) -> Result<f64> {
        let mut x: Vec<[f64; 2]> = self.entries.iter().map(|e| e.c.normal).collect();
        let norm = |v: &[[f64; 2]]| v.iter().map(|l| l[0] * l[0] + l[1] * l[1]).sum::<f64>().sqrt();
        let mut lambda = 1.0_f64;
        for _ in 0..POWER_ITERATIONS {
            let nx = norm(&x);
            if nx == 0.0 || !nx.is_finite() {
                break;
            }
            let du = self.respond(&x, false)?;
            // `m̃ W x`: the relative velocity `u_a − u_b` the impulses `x` give, times `m̃`.
            let y: Vec<[f64; 2]> = self.wanted(&du, true).into_iter().map(|w| [-w[0], -w[1]]).collect();
            let ny = norm(&y);
            lambda = ny / nx;
            if ny == 0.0 || !ny.is_finite() {
                break;
            }
            x = y.iter().map(|l| [l[0] / ny, l[1] / ny]).collect();
        }
        Ok(lambda.max(1.0))
    }

    /// The accumulated impulses `Λ` ([module docs](self)).
    fn solve(&self) -> Result<Vec<[f64; 2]>> {
        let m = self.entries.len();
        let omega = 1.0 / (MARGIN * self.largest_eigenvalue()?);
        let mut lambda = vec![[0.0; 2]; m];
        let mut previous = lambda.clone();
        let mut t = 1.0_f64;
        for _ in 0..MAX_ITERATIONS {
            let t_next = 0.5 * (1.0 + (1.0 + 4.0 * t * t).sqrt());
            let beta = (t - 1.0) / t_next;
            t = t_next;
            let y: Vec<[f64; 2]> = lambda
                .iter()
                .zip(&previous)
                .map(|(l, p)| [l[0] + beta * (l[0] - p[0]), l[1] + beta * (l[1] - p[1])])
                .collect();
            let wanted = self.wanted(&self.velocities(&y)?, false);
            let next: Vec<[f64; 2]> = self
                .entries
                .iter()
                .zip(y.iter().zip(&wanted))
                .map(|(e, (y, w))| project(e, [y[0] + omega * w[0], y[1] + omega * w[1]]))
                .collect();
            let (mut step, mut scale, mut restart) = (0.0_f64, 0.0_f64, 0.0);
            for ((n, y), l) in next.iter().zip(&y).zip(&lambda) {
                step = step.max((n[0] - y[0]).abs()).max((n[1] - y[1]).abs());
                scale = scale.max(n[0].abs()).max(n[1].abs());
                // O'Donoghue and Candès' gradient restart: the step against the momentum.
                restart += (y[0] - n[0]) * (n[0] - l[0]) + (y[1] - n[1]) * (n[1] - l[1]);
            }
            previous = std::mem::replace(&mut lambda, next);
            if restart > 0.0 {
                t = 1.0;
                previous.clone_from(&lambda);
            }
            if step <= TOLERANCE * scale || scale == 0.0 {
                break;
            }
        }
        Ok(lambda)
    }

    /// The accumulated impulses by projected Gauss–Seidel on the pairs' coupling `W`, formed
    /// column by column (the normal `n_e` and the tangent `t_e = (−n_y, n_x)` of each pair):
    /// `W_{(f,β),(e,α)} = d_β^f · (u_a − u_b)(i_f)` for the unit impulse `d_α^e` on `a_e`.
    /// Each pair in turn takes the normal impulse that stops its approach (`Λ_n ≤ 0`) and then
    /// the tangential one that stops its slip within `μ |Λ_n|`, the other pairs' relative
    /// velocities updated; the sweeps stop when no impulse changes by more than the tolerance.
    fn solve_dense(&self) -> Result<Vec<[f64; 2]>> {
        let m = self.entries.len();
        let size = 2 * m;
        let dirs: Vec<[[f64; 2]; 2]> = self
            .entries
            .iter()
            .map(|e| {
                let n = e.c.normal;
                [n, [-n[1], n[0]]]
            })
            .collect();
        let dot = |a: [f64; 2], b: [f64; 2]| a[0] * b[0] + a[1] * b[1];
        // Column-major: w[col * size + row].
        let mut w = vec![0.0; size * size];
        let mut x = vec![[0.0; 2]; m];
        for col in 0..size {
            x[col / 2] = dirs[col / 2][col % 2];
            let du = self.respond(&x, false)?;
            x[col / 2] = [0.0; 2];
            for (f, e) in self.entries.iter().enumerate() {
                let [ua, ub] = self.pair_velocities(&du, e, true);
                let rel = [ua[0] - ub[0], ua[1] - ub[1]];
                w[col * size + 2 * f] = dot(rel, dirs[f][0]);
                w[col * size + 2 * f + 1] = dot(rel, dirs[f][1]);
            }
        }
        // r = (u_b − u_a) along each direction, at Λ = 0.
        let mut r = vec![0.0; size];
        for (f, e) in self.entries.iter().enumerate() {
            let [ua, ub] = self.pair_velocities(&self.start, e, false);
            let rel = [ub[0] - ua[0], ub[1] - ua[1]];
            r[2 * f] = dot(rel, dirs[f][0]);
            r[2 * f + 1] = dot(rel, dirs[f][1]);
        }
        let mut lambda = vec![0.0; size];
        for _ in 0..MAX_SWEEPS {
            let (mut change, mut scale) = (0.0_f64, 0.0_f64);
            for (e, entry) in self.entries.iter().enumerate() {
                for k in [2 * e, 2 * e + 1] {
                    let diagonal = w[k * size + k];
                    if diagonal.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                        continue;
                    }
                    let trial = lambda[k] + r[k] / diagonal;
                    let next = if k == 2 * e {
                        if entry.held {
                            trial
                        } else {
                            trial.min(0.0)
                        }
                    } else {
                        let bound = entry.c.mu * lambda[2 * e].abs();
                        trial.clamp(-bound, bound)
                    };
                    let delta = next - lambda[k];
                    if delta != 0.0 {
                        lambda[k] = next;
                        for (rj, wj) in r.iter_mut().zip(&w[k * size..(k + 1) * size]) {
                            *rj -= wj * delta;
                        }
                    }
                    change = change.max(delta.abs());
                    scale = scale.max(next.abs());
                }
            }
            if change <= TOLERANCE * scale || scale == 0.0 {
                break;
            }
        }
        let impulses = (0..m)
            .map(|e| {
                let [n, t] = dirs[e];
                let (ln, lt) = (lambda[2 * e], lambda[2 * e + 1]);
                [ln * n[0] + lt * t[0], ln * n[1] + lt * t[1]]
            })
            .collect();
        Ok(impulses)
    }
}

/// `P`: the impulse on `a` within the law's bounds, a push along the normal (`Λ · n ≤ 0`,
/// unless the pair is held) and friction within `μ |Λ · n|`.
fn project(e: &Entry, lambda: [f64; 2]) -> [f64; 2] {
    let n = e.c.normal;
    let mut s = lambda[0] * n[0] + lambda[1] * n[1];
    let mut t = [lambda[0] - s * n[0], lambda[1] - s * n[1]];
    if !e.held {
        s = s.min(0.0);
    }
    let (length, bound) = (t[0].hypot(t[1]), e.c.mu * s.abs());
    if length > bound {
        let k = if length > 0.0 { bound / length } else { 0.0 };
        t = [k * t[0], k * t[1]];
    }
    [s * n[0] + t[0], s * n[1] + t[1]]
}
