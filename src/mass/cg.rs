//! The conjugate gradient of the iterative scheme, written once: preconditioned by the lumped
//! mass, on `M_FF x = b` for the free nodes `F`, in the vector layout of the matrix form at
//! hand ([`CgLayout`]: the padded grid-line layout of the stencil form, or node numbering for a
//! compressed-column matrix such as the ghost-penalty-stabilised `M`).
//!
//! ```text
//! r₀ = b − M x₀,  z₀ = M_L⁻¹ r₀,  p₀ = z₀
//! α = (r·z) / (p·M p),  x += α p,  r −= α M p,  z = M_L⁻¹ r,  β = (r·z)_new / (r·z),  p = z + β p
//! ```
//!
//! until `‖r‖ ≤ tolerance · scale`. Every sum runs in eight lanes added in a fixed order, so a
//! solve gives the same bits on every run and any number of threads.

use std::ops::Range;

use nalgebra_sparse::CscMatrix;

use super::matrices::MassOperator;
use super::options::MassScheme;
use super::{GridMass, Role};
use crate::fields::VectorField;

/// The vector layout a matrix form applies itself in.
pub(crate) trait CgLayout {
    /// Length of a work vector.
    fn layout_len(&self) -> usize;
    /// The runs of positions that can hold values, ascending.
    fn segments(&self) -> Vec<Range<usize>>;
    /// The position of node `i`.
    fn position(&self, i: usize) -> usize;
    /// `out = mask ∘ M x` on the segments (elsewhere left as it was), with `mask` zero where
    /// the product is to be dropped; returns `x · out`.
    fn apply(&self, x: &[f64], out: &mut [f64], mask: &[f64]) -> f64;
}

impl CgLayout for CscMatrix<f64> {
    fn layout_len(&self) -> usize {
        self.nrows()
    }
    fn segments(&self) -> Vec<Range<usize>> {
        std::iter::once(0..self.nrows()).collect()
    }
    fn position(&self, i: usize) -> usize {
        i
    }
    fn apply(&self, x: &[f64], out: &mut [f64], mask: &[f64]) -> f64 {
        let y = super::matrices::csc_times(self, x);
        let mut dot = [0.0; 8];
        for (k, ((o, y), (m, x))) in out.iter_mut().zip(&y).zip(mask.iter().zip(x)).enumerate() {
            *o = if *m == 0.0 { 0.0 } else { *y };
            dot[k % 8] += *o * x;
        }
        lanes_sum(&dot)
    }
}

impl GridMass {
    /// The conjugate gradient's warm-start vectors, one per (role, component): the last
    /// solution over all nodes (NaN where a node was not free), empty before the first solve.
    /// The next solves start from them, so they are part of a checkpoint.
    pub(crate) fn warm_start(&self) -> [Vec<f64>; 4] {
        let mut warm = self.cg.warm.clone();
        if let Some(y) = &self.component_y {
            // The y component's vectors are its own grid mass's.
            for k in [1, 3] {
                warm[k].clone_from(&y.cg.warm[k]);
            }
        }
        warm
    }

    /// Makes `w` the start of the next warm velocity solve, on the active nodes (the lumped
    /// solution elsewhere): the updated grid velocity of a step is the next step's projection
    /// but for the particles' motion.
    pub(crate) fn set_velocity_warm_start(&mut self, w: &crate::fields::VectorField) {
        if let Some(y) = &mut self.component_y {
            y.set_velocity_warm_start(w);
        }
        let state = &mut self.cg;
        if state.warm[0].is_empty() {
            return;
        }
        for (c, values) in [&w.x, &w.y].into_iter().enumerate() {
            let last = &mut state.warm[2 * (Role::Velocity as usize) + c];
            last.clear();
            last.extend(
                values
                    .iter()
                    .zip(&self.is_active)
                    .map(|(v, &a)| if a { *v } else { f64::NAN }),
            );
        }
    }

    /// Sets the warm-start vectors of [`GridMass::warm_start`] (resuming from a checkpoint).
    pub(crate) fn set_warm_start(&mut self, warm: [Vec<f64>; 4]) {
        if let Some(y) = &mut self.component_y {
            y.cg.warm.clone_from(&warm);
        }
        self.cg.warm = warm;
    }

    /// The conjugate gradient on each component (`cg.rs`) from the lumped solution, or with
    /// `warm` from the previous warm solution of the same role and component (the lumped
    /// solution on nodes that were not free then), which this one then replaces: the
    /// solution, the iterations and the largest relative residual; or the failing component,
    /// the iterations before it, and the reason.
    pub(super) fn solve_cg(
        &self,
        role: Role,
        state: &mut CgState,
        warm_start: bool,
        rhs: &VectorField,
        [tolerance, norm_r]: [f64; 2],
        max_iterations: usize,
    ) -> std::result::Result<(VectorField, usize, f64), CgFailure> {
        let m = self
            .matrices
            .operator(MassScheme::Consistent)
            .expect("assembled for the iterative scheme");
        let mut x = VectorField::default();
        self.solve_lumped(rhs, None, &mut x);
        let (mut iterations, mut worst) = (0, 0.0f64);
        let CgState { warm, work } = state;
        for (c, dofs) in self.dofs.iter().enumerate() {
            let (b, xc) = if c == 0 { (&rhs.x, &mut x.x) } else { (&rhs.y, &mut x.y) };
            let last = &mut warm[2 * (role as usize) + c];
            if warm_start && last.len() == self.lumped.len() {
                for &i in dofs.free.iter().filter(|&&i| last[i].is_finite()) {
                    xc[i] = last[i];
                }
            }
            // With prescribed values the right-hand side is r − M_FD u_D: never below its own norm.
            let own = dofs.free.iter().map(|&i| b[i] * b[i]).sum::<f64>().sqrt();
            let scale = norm_r.max(own);
            let preconditioner = self.matrices.preconditioner.as_deref().unwrap_or(&self.lumped);
            let stop = CgStop {
                tolerance,
                max_iterations,
                scale,
            };
            let free = &dofs.free[..];
            let solved = match m {
                MassOperator::Stencil(s) => pcg(s, free, preconditioner, b, xc, stop, work),
                MassOperator::Csc(s) => pcg(s, free, preconditioner, b, xc, stop, work),
            };
            let (its, residual) = solved.map_err(|reason| CgFailure {
                component: c,
                iterations,
                reason,
            })?;
            iterations += its;
            worst = worst.max(residual);
            if !warm_start {
                continue;
            }
            last.clear();
            last.resize(self.lumped.len(), f64::NAN);
            for &i in &dofs.free {
                last[i] = xc[i];
            }
        }
        Ok((x, iterations, worst))
    }
}

/// A conjugate gradient that did not converge: the component (0 for x, 1 for y), the
/// iterations of the components before it, and why.
#[derive(Debug)]
pub(super) struct CgFailure {
    pub(super) component: usize,
    pub(super) iterations: usize,
    pub(super) reason: String,
}

/// What the conjugate gradient keeps between solves.
#[derive(Debug, Default)]
pub(crate) struct CgState {
    /// The last solution per (role, component) over all nodes (NaN where a node was not free).
    pub(crate) warm: [Vec<f64>; 4],
    pub(crate) work: CgWork,
}

/// Work vectors of [`pcg`], kept between solves.
#[derive(Debug, Default)]
pub(crate) struct CgWork([Vec<f64>; 7]);

/// When [`pcg`] stops: at the relative residual `tolerance` of `scale`, or after
/// `max_iterations`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct CgStop {
    /// The relative residual to reach.
    pub(crate) tolerance: f64,
    /// The most iterations.
    pub(crate) max_iterations: usize,
    /// What the residual is relative to.
    pub(crate) scale: f64,
}

/// Preconditioned conjugate gradient on `M_FF x = b` for the free nodes `free` (ascending),
/// with the diagonal preconditioner `lumped` and the initial guess `x` (`b`, `x` and `lumped`
/// over all nodes; only `F` is read and written), to the residual `‖b − M_FF x‖ ≤ tolerance ·
/// scale` (the recurrence's residual; `scale` is `‖b_F‖` or the norm of the whole vector
/// problem `b` is a component of). Returns the iterations and `‖b − M_FF x‖ / scale`, or the
/// reason for failure.
pub(crate) fn pcg(
    m: &impl CgLayout,
    free: &[usize],
    lumped: &[f64],
    b: &[f64],
    x: &mut [f64],
    stop: CgStop,
    work: &mut CgWork,
) -> std::result::Result<(usize, f64), String> {
    let CgStop {
        tolerance,
        max_iterations,
        scale,
    } = stop;
    if free.is_empty() || free.iter().all(|&i| b[i] == 0.0) {
        free.iter().for_each(|&i| x[i] = 0.0);
        return Ok((0, 0.0));
    }
    // Work vectors in the layout, zero outside F. They are zero outside the segments between
    // solves (each solve clears what it wrote), so only a change of length needs a fill.
    let len = m.layout_len();
    for v in work.0.iter_mut() {
        if v.len() != len {
            v.clear();
            v.resize(len, 0.0);
        }
    }
    let segments = m.segments();
    let problem = Problem {
        m,
        free,
        segments: &segments,
        tolerance,
        max_iterations,
        norm_b: scale,
    };
    let result = problem.iterate(lumped, b, x, &mut work.0);
    for v in work.0.iter_mut() {
        for g in &segments {
            v[g.clone()].fill(0.0);
        }
    }
    result
}

/// One conjugate-gradient problem: the matrix in its layout, the free nodes and the stopping
/// rule.
struct Problem<'a, L: CgLayout> {
    m: &'a L,
    free: &'a [usize],
    segments: &'a [Range<usize>],
    tolerance: f64,
    max_iterations: usize,
    norm_b: f64,
}

impl<L: CgLayout> Problem<'_, L> {
    /// The iterations of the module docs, in the work vectors.
    fn iterate(
        &self,
        lumped: &[f64],
        b: &[f64],
        x: &mut [f64],
        work: &mut [Vec<f64>; 7],
    ) -> std::result::Result<(usize, f64), String> {
        let (m, segments) = (self.m, self.segments);
        let [inv_d, xs, r, q, z, p, scratch] = work;
        for &i in self.free {
            let at = m.position(i);
            inv_d[at] = 1.0 / lumped[i];
            xs[at] = x[i];
            r[at] = b[i];
        }
        let inv_d = &*inv_d;
        // q = M_FF v (the product, zero off F) and v·q.
        let apply = |v: &[f64], q: &mut [f64]| m.apply(v, q, inv_d);
        apply(xs, q);
        // r = b − M x0 (the update with q = M x0 and a unit step; the x it moves is scratch).
        let (rr, rz) = fused_update(segments, scratch, r, z, q, q, inv_d, 1.0);
        for g in segments {
            p[g.clone()].copy_from_slice(&z[g.clone()]);
        }
        let (mut rz, mut residual) = (rz, rr.sqrt() / self.norm_b);
        let mut it = 0;
        while residual > self.tolerance {
            if it == self.max_iterations {
                return Err(format!(
                    "conjugate gradient did not reach the relative residual {:e} in {} iterations (reached {residual:.3e})",
                    self.tolerance, self.max_iterations
                ));
            }
            let pq = apply(p, q);
            if pq.is_nan() || pq <= 0.0 {
                return Err("the mass matrix is not positive definite".into());
            }
            let alpha = rz / pq;
            let (rr, rz_new) = fused_update(segments, xs, r, z, p, q, inv_d, alpha);
            let beta = rz_new / rz;
            rz = rz_new;
            for g in segments {
                for (p, z) in p[g.clone()].iter_mut().zip(&z[g.clone()]) {
                    *p = z + beta * *p;
                }
            }
            residual = rr.sqrt() / self.norm_b;
            it += 1;
        }
        for &i in self.free {
            x[i] = xs[m.position(i)];
        }
        Ok((it, residual))
    }
}

/// Eight partial sums added in a fixed order (the same bits on every run).
pub(crate) fn lanes_sum(a: &[f64; 8]) -> f64 {
    ((a[0] + a[4]) + (a[1] + a[5])) + ((a[2] + a[6]) + (a[3] + a[7]))
}

/// One CG update over the segments: `x += α p`, `r −= α q`, `z = r ∘ d`; returns `(r·r, r·z)`
/// (each summed in eight lanes per segment position, a fixed order).
#[allow(clippy::too_many_arguments)]
fn fused_update(
    segments: &[Range<usize>],
    x: &mut [f64],
    r: &mut [f64],
    z: &mut [f64],
    p: &[f64],
    q: &[f64],
    d: &[f64],
    alpha: f64,
) -> (f64, f64) {
    let (mut rr, mut rz) = ([0.0; 8], [0.0; 8]);
    for g in segments {
        let g = g.clone();
        let (x, r, z) = (&mut x[g.clone()], &mut r[g.clone()], &mut z[g.clone()]);
        let (p, q, d) = (&p[g.clone()], &q[g.clone()], &d[g]);
        let mut chunks = x
            .chunks_exact_mut(8)
            .zip(r.chunks_exact_mut(8))
            .zip(z.chunks_exact_mut(8))
            .zip(p.chunks_exact(8).zip(q.chunks_exact(8)).zip(d.chunks_exact(8)));
        for (((x, r), z), ((p, q), d)) in &mut chunks {
            for l in 0..8 {
                x[l] += alpha * p[l];
                r[l] -= alpha * q[l];
                z[l] = r[l] * d[l];
                rr[l] += r[l] * r[l];
                rz[l] += r[l] * z[l];
            }
        }
        let done = x.len() / 8 * 8;
        for k in done..x.len() {
            x[k] += alpha * p[k];
            r[k] -= alpha * q[k];
            z[k] = r[k] * d[k];
            rr[k - done] += r[k] * r[k];
            rz[k - done] += r[k] * z[k];
        }
    }
    (lanes_sum(&rr), lanes_sum(&rz))
}
