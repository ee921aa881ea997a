//! Extreme eigenvalues by the Lanczos method, for the mass and stiffness diagnostics.

/// Default number of Lanczos steps: enough for the extreme eigenvalues of the grid operators to
/// converge to a fraction of a percent on grids of up to millions of nodes.
pub const DEFAULT_LANCZOS_STEPS: usize = 80;

/// Estimates the smallest and largest eigenvalues of an operator `T` that is self-adjoint in the
/// inner product `⟨x, y⟩ = xᵀ B y` (`B` symmetric positive semi-definite), by `steps` Lanczos
/// steps with full reorthogonalization from the start vector `start`:
///
/// ```text
/// T v_j = β_{j−1} v_{j−1} + α_j v_j + β_j v_{j+1},   ⟨v_i, v_j⟩ = δ_ij;   eig(tridiag(β, α, β)) → eig(T)
/// ```
///
/// The extreme Ritz values converge from inside the spectrum: the largest is a lower bound on
/// `λ_max`, the smallest an upper bound on `λ_min` (of the part of the spectrum reachable from
/// `start`). Returns `None` when `start` has zero `B`-norm.
pub fn lanczos_extremes(
    start: &[f64],
    steps: usize,
    mut apply_t: impl FnMut(&[f64]) -> Vec<f64>,
    mut apply_b: impl FnMut(&[f64]) -> Vec<f64>,
) -> Option<(f64, f64)> {
    let (v, bv) = normalized(start, &mut apply_b)?;
    let (mut basis, mut b_basis) = (vec![v], vec![bv]);
    let (mut alpha, mut beta): (Vec<f64>, Vec<f64>) = (Vec::new(), Vec::new());
    for j in 0..steps {
        let mut w = apply_t(&basis[j]);
        let a = dot(&w, &b_basis[j]);
        alpha.push(a);
        // Full reorthogonalization (twice is enough) against every basis vector.
        for _ in 0..2 {
            for (q, bq) in basis.iter().zip(&b_basis) {
                let c = dot(&w, bq);
                w.iter_mut().zip(q).for_each(|(x, y)| *x -= c * y);
            }
        }
        let bw = apply_b(&w);
        let b = dot(&w, &bw).max(0.0).sqrt();
        let scale = alpha.iter().map(|x| x.abs()).fold(0.0, f64::max).max(f64::MIN_POSITIVE);
        if j + 1 == steps || b <= 1e-12 * scale || !b.is_finite() {
            break;
        }
        beta.push(b);
        basis.push(w.iter().map(|x| x / b).collect());
        b_basis.push(bw.iter().map(|x| x / b).collect());
    }
    let eig = tridiagonal_eigenvalues(&alpha, &beta);
    Some((eig.min(), eig.max()))
}

/// `x ⋅ y`.
fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// `start` and `B start` scaled to unit `B`-norm, or `None` when that norm is zero or not finite.
fn normalized(start: &[f64], apply_b: &mut impl FnMut(&[f64]) -> Vec<f64>) -> Option<(Vec<f64>, Vec<f64>)> {
    let mut v = start.to_vec();
    let mut bv = apply_b(&v);
    let norm = dot(&v, &bv).max(0.0).sqrt();
    if norm == 0.0 || !norm.is_finite() {
        return None;
    }
    v.iter_mut().for_each(|x| *x /= norm);
    bv.iter_mut().for_each(|x| *x /= norm);
    Some((v, bv))
}

/// A deterministic start vector with entries in (0.5, 1.5) on the given positions, 0 elsewhere
/// (positive so that it is not orthogonal to the smooth modes).
pub fn start_vector(len: usize, support: impl Fn(usize) -> bool) -> Vec<f64> {
    let mut out = Vec::with_capacity(len);
    start_sequence(len, |i, value| out.push(if support(i) { value } else { 0.0 }));
    out
}

/// The values of [`start_vector`] at every position `0..len`, in order, to `f(i, value)`.
pub(crate) fn start_sequence(len: usize, mut f: impl FnMut(usize, f64)) {
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    for i in 0..len {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        f(i, 0.5 + (state >> 11) as f64 / (1u64 << 53) as f64);
    }
}

/// The largest eigenvalue of an operator `T` self-adjoint in `⟨x, y⟩ = xᵀ B y` (`B` symmetric
/// positive semi-definite), by plain Lanczos (three-term recurrence, no stored basis, so memory
/// is a few vectors whatever the step count) from `start`:
///
/// ```text
/// T v_j = β_{j−1} v_{j−1} + α_j v_j + β_j v_{j+1};   λ_max ≈ max eig(tridiag(β, α, β))
/// ```
///
/// Stops after `max_steps`, on breakdown, or once the estimate has changed by less than
/// `tolerance` (relative) over five consecutive steps. The estimate converges from below (it is
/// a Ritz value); loss of orthogonality only duplicates converged values. Returns the estimate
/// and the steps taken, or `None` when `start` has zero `B`-norm.
pub fn lanczos_max(
    start: &[f64],
    max_steps: usize,
    tolerance: f64,
    mut apply_t: impl FnMut(&[f64]) -> Vec<f64>,
    mut apply_b: impl FnMut(&[f64]) -> Vec<f64>,
) -> Option<(f64, usize)> {
    let (mut v, mut bv) = normalized(start, &mut apply_b)?;
    let (mut v_prev, mut bv_prev) = (vec![0.0; v.len()], vec![0.0; v.len()]);
    let (mut alpha, mut beta): (Vec<f64>, Vec<f64>) = (Vec::new(), Vec::new());
    let mut history: Vec<f64> = Vec::new();
    for j in 0..max_steps.max(1) {
        let mut w = apply_t(&v);
        let a = dot(&w, &bv);
        alpha.push(a);
        let b_prev = beta.last().copied().unwrap_or(0.0);
        for k in 0..w.len() {
            w[k] -= a * v[k] + b_prev * v_prev[k];
        }
        // One local re-orthogonalisation against the last two vectors.
        let (c, c_prev) = (dot(&w, &bv), dot(&w, &bv_prev));
        for k in 0..w.len() {
            w[k] -= c * v[k] + c_prev * v_prev[k];
        }
        let top = tridiagonal_eigenvalues(&alpha, &beta).max();
        history.push(top);
        let settled = history.len() > 5 && {
            let old = history[history.len() - 6];
            (top - old).abs() <= tolerance * top.abs()
        };
        let bw = apply_b(&w);
        let b = dot(&w, &bw).max(0.0).sqrt();
        let scale = alpha.iter().map(|x| x.abs()).fold(0.0, f64::max).max(f64::MIN_POSITIVE);
        if settled || j + 1 >= max_steps || b <= 1e-12 * scale || !b.is_finite() {
            return Some((top, j + 1));
        }
        beta.push(b);
        let (mut w, mut bw) = (w, bw);
        w.iter_mut().chain(bw.iter_mut()).for_each(|x| *x /= b);
        v_prev = std::mem::replace(&mut v, w);
        bv_prev = std::mem::replace(&mut bv, bw);
    }
    unreachable!("the loop returns at its last step")
}

/// The eigenvalues of the symmetric tridiagonal matrix with diagonal `alpha` and off-diagonal
/// `beta` (`beta.len() ≥ alpha.len() − 1`; extra entries are ignored).
fn tridiagonal_eigenvalues(alpha: &[f64], beta: &[f64]) -> nalgebra::DVector<f64> {
    let m = alpha.len();
    let t = nalgebra::DMatrix::from_fn(m, m, |i, j| {
        if i == j {
            alpha[i]
        } else if i + 1 == j {
            beta[i]
        } else if j + 1 == i {
            beta[j]
        } else {
            0.0
        }
    });
    nalgebra::SymmetricEigen::new(t).eigenvalues
}

/// The largest eigenvalue of the pencil `(A, B)` (`A` symmetric positive semi-definite, `B`
/// symmetric positive definite on the vectors reached), `A x = λ B x`, by the locally optimal
/// block preconditioned conjugate gradient with one vector (LOBPCG; Knyazev 2001), which needs
/// products with `A`, `B` and a preconditioner `T ≈ B⁻¹` but no solve:
///
/// ```text
/// θ = xᵀA x / xᵀB x,   r = A x − θ B x,   w = T r,
/// x ← the Ritz vector of the largest Ritz value of (A, B) on span{x, w, p},   p ← its part along {w, p}
/// ```
///
/// Each step costs one product with `A` and one with `B`. The Ritz value rises to `λ_max` from
/// below; the method stops after `max_steps`, when the residual vanishes, or once the estimate
/// has changed by less than `tolerance` (relative) over five consecutive steps, as
/// [`lanczos_max`]. Returns the estimate and the steps taken, or `None` when `start` has zero
/// `B`-norm.
pub fn lobpcg_max(
    start: &[f64],
    max_steps: usize,
    tolerance: f64,
    mut apply_a: impl FnMut(&[f64]) -> Vec<f64>,
    mut apply_b: impl FnMut(&[f64]) -> Vec<f64>,
    precondition: impl Fn(&[f64]) -> Vec<f64>,
) -> Option<(f64, usize)> {
    let (x, bx) = normalized(start, &mut apply_b)?;
    let ax = apply_a(&x);
    let mut current = [x, ax, bx];
    let mut direction: Option<[Vec<f64>; 3]> = None;
    let mut theta = dot(&current[0], &current[1]);
    let mut history = vec![theta];
    for j in 0..max_steps.max(1) {
        let [x, ax, bx] = &current;
        let r: Vec<f64> = ax.iter().zip(bx).map(|(a, b)| a - theta * b).collect();
        let w = precondition(&r);
        let (bw, aw) = (apply_b(&w), apply_a(&w));
        let mut basis: Vec<[&[f64]; 3]> = vec![[x, ax, bx], [&w, &aw, &bw]];
        if let Some([p, ap, bp]) = &direction {
            basis.push([p, ap, bp]);
        }
        let Some((value, c)) = largest_ritz(&basis) else {
            return Some((theta, j + 1));
        };
        let combine = |k: usize, from: usize| -> Vec<f64> {
            let mut out = vec![0.0; x.len()];
            for (b, coefficient) in basis.iter().zip(&c).skip(from) {
                out.iter_mut().zip(b[k]).for_each(|(o, v)| *o += coefficient * v);
            }
            out
        };
        let p = [combine(0, 1), combine(1, 1), combine(2, 1)];
        let next = [0, 1, 2].map(|k| {
            let mut v = p[k].clone();
            v.iter_mut().zip(current[k].iter()).for_each(|(o, x)| *o += c[0] * x);
            v
        });
        current = next;
        direction = Some(p);
        theta = value;
        history.push(theta);
        let settled = history.len() > 5 && {
            let old = history[history.len() - 6];
            (theta - old).abs() <= tolerance * theta.abs()
        };
        if settled || !theta.is_finite() {
            return Some((theta, j + 1));
        }
    }
    Some((theta, max_steps.max(1)))
}

/// Work vectors of [`lobpcg_top`], kept between calls so that an estimate allocates nothing
/// once they have grown to size.
#[derive(Debug, Default, Clone)]
pub struct LobpcgWork {
    /// `A x`, `B x`, `r`/`w`, `A w`, `B w`, `p`, `A p`, `B p`, and a spare.
    v: [Vec<f64>; 9],
}

/// [`lobpcg_max`] in place, from the start `x`, which it leaves holding the Ritz vector of the
/// value it returns (scaled to unit `B`-norm), so that a later call can start from it (a warm
/// start):
///
/// ```text
/// θ = xᵀA x / xᵀB x,   r = A x − θ B x,   w = T r,
/// x ← the Ritz vector of the largest Ritz value of (A, B) on span{x, w, p},   p ← its part along {w, p}
/// ```
///
/// `apply_a(v, out)` and `apply_b(v, out)` write `A v` and `B v`, `precondition(r, out)` writes
/// `T r` (`T ≈ B⁻¹`); none of them allocates here. The Ritz value never falls below the
/// Rayleigh quotient of the start and rises to `λ_max` from below. Stops after `max_steps`
/// steps (at least one), when the residual vanishes, or once the estimate has changed by less
/// than `tolerance` (relative) over five consecutive steps (`tolerance = 0`: never). Returns
/// the estimate and the steps taken, or `None` when `x` has zero `B`-norm.
pub fn lobpcg_top(
    x: &mut Vec<f64>,
    max_steps: usize,
    tolerance: f64,
    mut apply_a: impl FnMut(&[f64], &mut [f64]),
    mut apply_b: impl FnMut(&[f64], &mut [f64]),
    mut precondition: impl FnMut(&[f64], &mut [f64]),
    work: &mut LobpcgWork,
) -> Option<(f64, usize)> {
    let len = x.len();
    // Every vector is written whole before it is read (the direction `p` and its images at
    // the first step without reading them), so stale values from a previous call may stay.
    for v in work.v.iter_mut() {
        v.resize(len, 0.0);
    }
    let [ax, bx, w, aw, bw, p, ap, bp, r] = &mut work.v;
    apply_b(x, bx);
    let norm = fast_dot(x, bx).max(0.0).sqrt();
    if norm == 0.0 || !norm.is_finite() {
        return None;
    }
    x.iter_mut().chain(bx.iter_mut()).for_each(|v| *v /= norm);
    apply_a(x, ax);
    let mut theta = fast_dot(x, ax);
    let mut history = vec![theta];
    let mut with_direction = false;
    for j in 0..max_steps.max(1) {
        for ((r, a), b) in r.iter_mut().zip(ax.iter()).zip(bx.iter()) {
            *r = a - theta * b;
        }
        precondition(r, w);
        apply_b(w, bw);
        apply_a(w, aw);
        let basis: Vec<[&[f64]; 3]> = if with_direction {
            vec![[x, ax, bx], [w, aw, bw], [p, ap, bp]]
        } else {
            vec![[x, ax, bx], [w, aw, bw]]
        };
        let Some((value, c)) = largest_ritz(&basis) else {
            return Some((theta, j + 1));
        };
        // p ← c₁ w + c₂ p, then x ← c₀ x + p (each with its A and B images).
        let c2 = if with_direction {
            c.get(2).copied().unwrap_or(0.0)
        } else {
            0.0
        };
        let c1 = c.get(1).copied().unwrap_or(0.0);
        let triples: [(&mut Vec<f64>, &Vec<f64>, &mut Vec<f64>); 3] = [(p, w, x), (ap, aw, ax), (bp, bw, bx)];
        for (pv, wv, xv) in triples {
            let lanes = pv.iter_mut().zip(wv.iter()).zip(xv.iter_mut());
            if with_direction {
                for ((pk, wk), xk) in lanes {
                    *pk = c1 * wk + c2 * *pk;
                    *xk = c[0] * *xk + *pk;
                }
            } else {
                // `c₂ p` is `0` at the first step whatever `p` holds (`+ 0.0`: the same bits
                // as the product with a zeroed `p`).
                for ((pk, wk), xk) in lanes {
                    *pk = c1 * wk + 0.0;
                    *xk = c[0] * *xk + *pk;
                }
            }
        }
        with_direction = true;
        theta = value;
        history.push(theta);
        let settled = tolerance > 0.0 && history.len() > 5 && {
            let old = history[history.len() - 6];
            (theta - old).abs() <= tolerance * theta.abs()
        };
        if settled || !theta.is_finite() {
            return Some((theta, j + 1));
        }
    }
    Some((theta, max_steps.max(1)))
}

/// The largest Ritz value of `(A, B)` on the span of the vectors `basis` (each `[v, A v, B v]`)
/// and its coefficients, from the Gram matrices: the columns are scaled to unit `B`-norm and the
/// last ones dropped while the `B` Gram matrix is too ill-conditioned to factor (`None` when
/// not even the first is left).
fn largest_ritz(basis: &[[&[f64]; 3]]) -> Option<(f64, Vec<f64>)> {
    let count = basis.len();
    // Upper triangles of both Gram matrices, one lane-summed dot per entry.
    let mut a = [[0.0; 3]; 3];
    let mut b = [[0.0; 3]; 3];
    for i in 0..count {
        for j in i..count {
            a[i][j] = fast_dot(basis[i][0], basis[j][1]);
            b[i][j] = fast_dot(basis[i][0], basis[j][2]);
            (a[j][i], b[j][i]) = (a[i][j], b[i][j]);
        }
    }
    let norms: Vec<f64> = (0..count).map(|i| b[i][i].max(0.0).sqrt()).collect();
    let mut m = count;
    while m > 0 {
        if norms[..m].iter().any(|&s| s == 0.0 || !s.is_finite()) {
            m -= 1;
            continue;
        }
        let scaled = |g: &[[f64; 3]; 3]| nalgebra::DMatrix::from_fn(m, m, |i, j| g[i][j] / (norms[i] * norms[j]));
        let (ga, gb) = (scaled(&a), scaled(&b));
        let eig = nalgebra::SymmetricEigen::new(gb.clone());
        let (lo, hi) = (eig.eigenvalues.min(), eig.eigenvalues.max());
        if lo > 1e-12 * hi {
            if let Some(chol) = nalgebra::Cholesky::new(gb) {
                let l_inv = chol.l().try_inverse()?;
                let reduced = &l_inv * &ga * l_inv.transpose();
                let reduced = 0.5 * (&reduced + reduced.transpose());
                let eig = nalgebra::SymmetricEigen::new(reduced);
                let top = eig.eigenvalues.imax();
                let y = l_inv.transpose() * eig.eigenvectors.column(top);
                let c = (0..m).map(|i| y[i] / norms[i]).collect();
                return Some((eig.eigenvalues[top], c));
            }
        }
        m -= 1;
    }
    None
}

/// `x ⋅ y` summed in eight lanes added in a fixed order (the same bits on every run, and
/// vectorised).
fn fast_dot(x: &[f64], y: &[f64]) -> f64 {
    let mut lanes = [0.0; 8];
    let (xc, yc) = (x.chunks_exact(8), y.chunks_exact(8));
    let (xr, yr) = (xc.remainder(), yc.remainder());
    for (a, b) in xc.zip(yc) {
        for l in 0..8 {
            lanes[l] += a[l] * b[l];
        }
    }
    for (l, (a, b)) in xr.iter().zip(yr).enumerate() {
        lanes[l] += a * b;
    }
    ((lanes[0] + lanes[4]) + (lanes[1] + lanes[5])) + ((lanes[2] + lanes[6]) + (lanes[3] + lanes[7]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, DVector};

    /// A dense symmetric positive definite matrix of size `n` with a spread spectrum.
    fn spd(n: usize, seed: u64) -> DMatrix<f64> {
        let v = start_vector(n * n, |_| true);
        let q = DMatrix::from_fn(n, n, |i, j| v[(i * n + j + seed as usize) % (n * n)] - 1.0);
        &q * q.transpose() + DMatrix::identity(n, n) * 0.1
    }

    #[test]
    fn lobpcg_finds_the_largest_eigenvalue_of_a_pencil_without_a_solve() {
        for n in [1, 2, 5, 40] {
            let a = spd(n, 3);
            let b = spd(n, 11) + DMatrix::identity(n, n) * n as f64;
            // The exact value: the largest eigenvalue of L⁻¹ A L⁻ᵀ, B = L Lᵀ.
            let l_inv = b.clone().cholesky().unwrap().l().try_inverse().unwrap();
            let exact = nalgebra::SymmetricEigen::new(&l_inv * &a * l_inv.transpose())
                .eigenvalues
                .max();
            let times = |m: &DMatrix<f64>| {
                let m = m.clone();
                move |x: &[f64]| (&m * DVector::from_column_slice(x)).as_slice().to_vec()
            };
            let d: Vec<f64> = (0..n).map(|i| b[(i, i)]).collect();
            let precondition = |r: &[f64]| r.iter().zip(&d).map(|(r, d)| r / d).collect();
            let start = start_vector(n, |_| true);
            let (top, steps) = lobpcg_max(&start, 200, 1e-12, times(&a), times(&b), precondition).unwrap();
            assert!(
                (top - exact).abs() <= 1e-8 * exact && top <= exact * (1.0 + 1e-12),
                "n = {n}: {top} against {exact} after {steps} steps"
            );
        }
    }

    #[test]
    fn lobpcg_of_a_zero_start_is_none() {
        let id = |x: &[f64]| x.to_vec();
        assert!(lobpcg_max(&[0.0; 4], 10, 1e-6, id, id, id).is_none());
    }
}
