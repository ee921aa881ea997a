//! Why the mass changes the deflection of a cantilever one cell thick: the linearised MPM update
//! of the clamped beam of `tests/thin_cantilever.rs` (8 × 1, E = 10⁹, ν = 0.3, ρ = 1050, g = 10,
//! quadratic B-splines, 2 × 2 particles per cell, MUSL, FLIP, mirrored clamp), for each mass.
//!
//! With FLIP the particle velocities stay `Nᵀ W` for a grid field `W`, so the grid velocity of
//! MUSL is `v = M_v⁻¹ N (m ∘ Nᵀ W) = M_v⁻¹ M W` (M the plain consistent mass) and the grid
//! displacement `U` obeys, for small motions,
//!
//! ```text
//! Ü = A (f − K U),   A = M_v⁻¹ M M_a⁻¹        (M_v = M_a = M_L lumped, = M_s stabilised consistent)
//! ```
//!
//! with K = Bᵀ D B from the particles (`stiffness::stiffness_matrix`). When K is nonsingular on
//! the free degrees of freedom every mass has the static `U = K⁻¹ f`. A body one cell thick with
//! quadratic B-splines has two particle rows on four node rows, and K has zero-energy modes
//! there: the static then lies in the range of A, which depends on the mass. The example prints
//! the free degrees of freedom, the rank of M (the dimension of the range of A), the number of
//! zero-energy modes, the static tip deflection and the first peak of the modal
//! solution `U(t) = Σ_k c_k (1 − cos ω_k t)` for each mass, one, two, four and eight cells thick.
//!
//! ```text
//! cargo run --release --example thin_beam_statics
//! ```

use nalgebra::{DMatrix, DVector, SymmetricEigen};
use nalgebra_sparse::CscMatrix;
use sparse_mpm::material::{LinearElastic, PlaneCondition};
use sparse_mpm::scene::Scene;
use sparse_mpm::stiffness::stiffness_matrix;

use sparse_mpm_study::verification::cantilever::thin_beam::{
    self, GRAVITY as G, LENGTH, POISSON_RATIO as NU, YOUNGS_MODULUS as E,
};

fn dense(m: &CscMatrix<f64>) -> DMatrix<f64> {
    let mut d = DMatrix::zeros(m.nrows(), m.ncols());
    for (i, j, v) in m.triplet_iter() {
        d[(i, j)] += *v;
    }
    d
}

/// The symmetric square root of a positive semi-definite matrix (eigenvalues below 1e-12 of the
/// largest set to zero).
fn sqrt_psd(a: &DMatrix<f64>) -> DMatrix<f64> {
    let e = SymmetricEigen::new(a.clone());
    let largest = e.eigenvalues.max();
    let d = e.eigenvalues.map(|v| if v > 1e-12 * largest { v.sqrt() } else { 0.0 });
    &e.eigenvectors * DMatrix::from_diagonal(&d) * e.eigenvectors.transpose()
}

/// The scene of the beam `cells_thick` cells thick with `mass` in both solves.
fn scene(cells_thick: usize, mass: &str) -> Scene {
    thin_beam::scene(cells_thick, mass).expect("the beam scene is valid")
}

/// Zero-energy modes of K, the static tip deflection and the first peak of the linearised update.
fn response(cells_thick: usize, mass: &str) -> (usize, usize, usize, f64, f64) {
    let sim = scene(cells_thick, mass).build().expect("the beam builds");
    let ops = sim.operators();
    let p = sim.particles();
    let n = ops.num_nodes();
    let nm = dense(&ops.n_matrix());
    let plain = &nm * DMatrix::from_diagonal(&DVector::from_column_slice(&p.mass)) * nm.transpose();
    let lumped = sim.lumped_mass();
    let grid_mass = sim.grid_mass();
    let material = LinearElastic::new(E, NU, PlaneCondition::Strain).expect("valid material");
    let k = dense(&stiffness_matrix(ops, &p.volume, &material));
    let [free_x, free_y] = grid_mass.free_dofs();
    let dofs: Vec<usize> = free_x.iter().copied().chain(free_y.iter().map(|i| i + n)).collect();
    let nd = dofs.len();
    let component = |a: &DMatrix<f64>| {
        DMatrix::from_fn(nd, nd, |i, j| {
            if (dofs[i] < n) == (dofs[j] < n) {
                a[(dofs[i] % n, dofs[j] % n)]
            } else {
                0.0
            }
        })
    };
    let kf = DMatrix::from_fn(nd, nd, |i, j| k[(dofs[i], dofs[j])]);
    let mf = component(&plain);
    let mass_matrix = match grid_mass.stabilized_matrix() {
        Some(m) => component(&dense(m)),
        None => DMatrix::from_fn(nd, nd, |i, j| if i == j { lumped[dofs[i] % n] } else { 0.0 }),
    };
    let inverse = mass_matrix.try_inverse().expect("the mass is nonsingular");
    let a = &inverse * &mf * &inverse;
    let a = (&a + a.transpose()) * 0.5;
    let force = DVector::from_fn(nd, |i, _| if dofs[i] >= n { -G * lumped[dofs[i] - n] } else { 0.0 });
    let tip = (0..p.len())
        .min_by(|&a, &b| {
            let d = |q: usize| (p.x[q] - LENGTH).hypot(p.y[q] - 0.5);
            d(a).total_cmp(&d(b))
        })
        .expect("the beam has particles");
    let probe = DVector::from_fn(nd, |i, _| if dofs[i] >= n { nm[(dofs[i] - n, tip)] } else { 0.0 });
    let k_eigen = SymmetricEigen::new(kf.clone()).eigenvalues;
    let zero_modes = k_eigen.iter().filter(|&&v| v < 1e-9 * k_eigen.max()).count();
    let m_eigen = SymmetricEigen::new(mf.clone()).eigenvalues;
    let rank = m_eigen.iter().filter(|&&v| v > 1e-10 * m_eigen.max()).count();
    // U = R z with R = A^½: z̈ = R f − (R K R) z, modes of the symmetric R K R.
    let r = sqrt_psd(&a);
    let s = &r * &kf * &r;
    let modes = SymmetricEigen::new((&s + s.transpose()) * 0.5);
    let (rf, rt) = (&r * &force, &r * &probe);
    let largest = modes.eigenvalues.max();
    let terms: Vec<(f64, f64)> = (0..nd)
        .filter(|&q| modes.eigenvalues[q] > 1e-12 * largest)
        .map(|q| {
            let phi = modes.eigenvectors.column(q);
            let l = modes.eigenvalues[q];
            (l.sqrt(), phi.dot(&rt) * phi.dot(&rf) / l)
        })
        .collect();
    let static_tip: f64 = -terms.iter().map(|t| t.1).sum::<f64>();
    let dominant = terms
        .iter()
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
        .expect("a mode carries the load");
    let period = 2.0 * std::f64::consts::PI / dominant.0;
    let peak = (0..4000)
        .map(|q| {
            let t = period * q as f64 / 4000.0;
            -terms.iter().map(|(w, c)| c * (1.0 - (w * t).cos())).sum::<f64>()
        })
        .fold(0.0, f64::max);
    (nd, rank, zero_modes, static_tip, peak)
}

fn main() {
    let eb = 0.5 * thin_beam::euler_bernoulli_first_swing();
    println!(
        "Euler–Bernoulli static tip deflection {eb:.5} (first swing {:.5})",
        2.0 * eb
    );
    println!("| cells thick | free dofs | rank of M | zero-energy modes of K | static, lumped | static, consistent | first peak, lumped | first peak, consistent |");
    println!("|---|---|---|---|---|---|---|---|");
    for cells_thick in [1, 2, 4, 8] {
        let (dofs, rank, zero, sl, pl) = response(cells_thick, "lumped");
        let (_, _, _, sc, pc) = response(cells_thick, "consistent");
        println!("| {cells_thick} | {dofs} | {rank} | {zero} | {sl:.5} | {sc:.5} | {pl:.5} | {pc:.5} |");
    }
}
