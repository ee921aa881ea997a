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
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    (0..len)
        .map(|i| {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            if support(i) {
                0.5 + (state >> 11) as f64 / (1u64 << 53) as f64
            } else {
                0.0
            }
        })
        .collect()
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
        v_prev = std::mem::replace(&mut v, w.iter().map(|x| x / b).collect());
        bv_prev = std::mem::replace(&mut bv, bw.iter().map(|x| x / b).collect());
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
