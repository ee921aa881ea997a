//! Timings of the operator kernels: assembly of N, Gx, Gy, scatter (particle → grid), gather
//! (grid → particle), internal force, lumped and consistent mass, the consistent-mass Cholesky,
//! reference sparse × dense products from nalgebra-sparse and faer measured in the same run, and
//! particles in shuffled memory order.
//!
//! ```text
//! cargo bench --bench operators               # P = 1e5 and P = 1e6
//! cargo bench --bench operators -- --quick    # P = 1e5 only
//! cargo bench --bench operators -- --sizes 1e5,3e5
//! ```
//!
//! A small harness (no criterion): one warm-up call, then up to 11 timed samples; the output is a
//! Markdown table of the median and minimum per call. Calls shorter than 20 ms are
//! repeated inside a sample and the sample is divided by the repetition count; calls longer than
//! 0.25 s get 5 samples, longer than 1 s get 3. Every ratio (ours / reference, one pass / several,
//! shuffled / sorted) comes from the two kernels timed with their samples interleaved, so load from
//! other processes on a shared host falls on both alike.

mod common;
use common::*;

use std::time::Instant;

use faer::sparse::linalg::matmul::sparse_dense_matmul;
use faer::{Accum, Mat, MatRef, Par};
use nalgebra::DMatrix;
use nalgebra_sparse::ops::serial::spmm_csc_dense;
use nalgebra_sparse::ops::Op;
use sparse_mpm::mass::{self, ConsistentMassSolver, ConsistentSolveOptions, DEFAULT_ACTIVE_MASS_TOLERANCE};
use sparse_mpm::transfer;
use sparse_mpm::{Grid, Operator, Operators, Particles, ShapeFunction};

/// Times `f`: one warm-up call, then the planned samples.
fn measure<R>(mut f: impl FnMut() -> R) -> Stats {
    let plan = warm_up(&mut f);
    let times = (0..plan.samples).map(|_| sample(&mut f, plan.calls)).collect();
    summarize(times, plan.calls)
}

/// Times `f` and `g` with their samples interleaved (f, g, f, g, ...), so that load from other
/// processes on the host falls on both alike; used for every ratio.
fn measure_pair<R, S>(mut f: impl FnMut() -> R, mut g: impl FnMut() -> S) -> (Stats, Stats) {
    let (pf, pg) = (warm_up(&mut f), warm_up(&mut g));
    let samples = pf.samples.min(pg.samples);
    let (mut tf, mut tg) = (Vec::with_capacity(samples), Vec::with_capacity(samples));
    for _ in 0..samples {
        tf.push(sample(&mut f, pf.calls));
        tg.push(sample(&mut g, pg.calls));
    }
    (summarize(tf, pf.calls), summarize(tg, pg.calls))
}

/// Prints table rows as they are measured.
struct Table {
    p: usize,
}

impl Table {
    fn header() {
        println!("| operation | P | median ms | min ms | samples × calls | ratio / notes |");
        println!("|---|---:|---:|---:|---:|---|");
    }

    fn row(&self, operation: &str, s: Stats, notes: &str) -> Stats {
        println!(
            "| {operation} | {} | {} | {} | {} × {} | {notes} |",
            self.p,
            common::fmt_ms(s.median_ms),
            common::fmt_ms(s.min_ms),
            s.samples,
            s.calls_per_sample
        );
        s
    }
}

/// `a / b` of the medians, formatted.
fn ratio(a: Stats, b: Stats) -> String {
    format!("{:.2}", a.median_ms / b.median_ms)
}

/// A deterministic 64-bit linear congruential generator (Knuth's MMIX constants).
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        self.0
    }
    /// Uniform-ish integer in `0..n` from the high bits.
    fn below(&mut self, n: usize) -> usize {
        (((self.next() >> 32) as u128 * n as u128) >> 32) as usize
    }
}

/// A pseudo-random permutation of `0..n` (Fisher–Yates driven by [`Lcg`]).
fn permutation(n: usize, seed: u64) -> Vec<usize> {
    let mut perm: Vec<usize> = (0..n).collect();
    let mut rng = Lcg(seed);
    for i in (1..n).rev() {
        let j = rng.below(i + 1);
        perm.swap(i, j);
    }
    perm
}

fn permute(values: &[f64], perm: &[usize]) -> Vec<f64> {
    perm.iter().map(|&p| values[p]).collect()
}

fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
}

fn max_abs(a: &[f64]) -> f64 {
    a.iter().map(|x| x.abs()).fold(0.0, f64::max)
}

/// Asserts that two results agree to rounding, so compared timings compute the same thing.
fn check_same(what: &str, a: &[f64], b: &[f64]) {
    let scale = max_abs(a).max(max_abs(b)).max(1e-300);
    let err = max_abs_diff(a, b) / scale;
    assert!(err < 1e-12, "{what}: results differ (relative {err:e})");
}

/// The benchmark problem: `nc × nc` cells of size 1 filled with 2 × 2 particles each, inside a
/// grid with [`MARGIN`] empty cells on every side; particles in cell-sorted order (cells in the
/// grid's x-fastest order, then the 2 × 2 particles of each cell).
struct Problem {
    grid: Grid,
    x: Vec<f64>,
    y: Vec<f64>,
    m: Vec<f64>,
    volume: Vec<f64>,
    vx: Vec<f64>,
    vy: Vec<f64>,
    sxx: Vec<f64>,
    syy: Vec<f64>,
    sxy: Vec<f64>,
}

impl Problem {
    fn new(target_particles: usize) -> Problem {
        let (grid, x, y) = block(target_particles);
        let np = x.len();
        let field = |f: &dyn Fn(f64, f64) -> f64| -> Vec<f64> { x.iter().zip(&y).map(|(&a, &b)| f(a, b)).collect() };
        let vx = field(&|a, b| (0.01 * a).sin() + 0.5 * (0.013 * b).cos());
        let vy = field(&|a, b| (0.017 * b).cos() - 0.25 * (0.011 * a).sin());
        let sxx = field(&|a, b| 1.0e3 * (0.02 * a + 0.01 * b).sin());
        let syy = field(&|a, b| -2.0e3 + 10.0 * b - 3.0 * a);
        let sxy = field(&|a, b| 5.0e2 * (0.015 * a).cos() * (0.007 * b).sin());
        Problem {
            grid,
            m: vec![0.25; np],
            volume: vec![0.25; np],
            x,
            y,
            vx,
            vy,
            sxx,
            syy,
            sxy,
        }
    }

    fn len(&self) -> usize {
        self.x.len()
    }

    /// The same particles stored in the memory order `perm` (particle `k` is old particle `perm[k]`).
    fn permuted(&self, perm: &[usize]) -> Problem {
        Problem {
            grid: self.grid.clone(),
            x: permute(&self.x, perm),
            y: permute(&self.y, perm),
            m: permute(&self.m, perm),
            volume: permute(&self.volume, perm),
            vx: permute(&self.vx, perm),
            vy: permute(&self.vy, perm),
            sxx: permute(&self.sxx, perm),
            syy: permute(&self.syy, perm),
            sxy: permute(&self.sxy, perm),
        }
    }

    fn particles(&self) -> Particles {
        Particles::new(self.x.clone(), self.y.clone(), self.m.clone(), self.volume.clone()).expect("valid particles")
    }
}

/// Note for a reference row: our kernel's median over the interleaved samples and the ratio.
fn versus(ours: &str, ours_stats: Stats, theirs: Stats) -> String {
    format!(
        "ours ({ours}, {} ms interleaved) / this = **{}**",
        common::fmt_ms(ours_stats.median_ms),
        ratio(ours_stats, theirs)
    )
}

fn run_size(target: usize) {
    let prob = Problem::new(target);
    let np = prob.len();
    let grid = &prob.grid;
    let shape = ShapeFunction::Linear;
    let n = grid.num_nodes();
    let particles = prob.particles();
    let t = Table { p: np };

    let mut ops = Operators::assemble(grid, shape, &particles).expect("particles inside the grid");
    println!();
    println!(
        "### P = {np} ({0} × {0} cells with 2 × 2 particles each, grid {1} × {1} cells, n = {n} nodes, \
         {2} stored entries per operator)",
        ((np / 4) as f64).sqrt().round() as usize,
        grid.cells()[0],
        ops.nnz()
    );
    println!();
    Table::header();

    // 1. Assembly.
    t.row(
        "assemble N, Gx, Gy (first, fresh buffers)",
        measure(|| Operators::assemble(grid, shape, &particles).expect("inside")),
        "`Operators::assemble`, includes allocating the buffers",
    );
    t.row(
        "reassemble N, Gx, Gy (reused buffers)",
        measure(|| {
            ops.reassemble(grid, shape, &prob.x, &prob.y).expect("inside");
        }),
        "`Operators::reassemble`, steady state",
    );

    // 2. Scatter.
    let mut g1 = vec![0.0; n];
    t.row(
        "scatter K=1: N·m (lumped mass)",
        measure(|| ops.scatter(Operator::N, [&prob.m], [&mut g1])),
        "`scatter(N, [m])`",
    );
    let (mut qx, mut qy) = (vec![0.0; n], vec![0.0; n]);
    t.row(
        "scatter K=2: N·(m∘v) (momentum)",
        measure(|| ops.scatter_scaled(Operator::N, Some(&prob.m), [&prob.vx, &prob.vy], [&mut qx, &mut qy])),
        "`scatter_scaled(N, Some(m), [vx, vy])`",
    );
    t.row(
        "scatter K=2: N·[vx vy] (unscaled)",
        measure(|| ops.scatter(Operator::N, [&prob.vx, &prob.vy], [&mut qx, &mut qy])),
        "`scatter(N, [vx, vy])`",
    );
    let four: [&[f64]; 4] = [&prob.vx, &prob.vy, &prob.sxx, &prob.syy];
    let mut out4 = vec![vec![0.0; n]; 4];
    let mut sep4 = vec![vec![0.0; n]; 4];
    let (scatter4, separate4) = {
        let [a, b, c, d] = &mut out4[..] else { unreachable!() };
        measure_pair(
            || ops.scatter(Operator::N, four, [&mut *a, &mut *b, &mut *c, &mut *d]),
            || {
                for (field, out) in four.iter().zip(sep4.iter_mut()) {
                    ops.scatter(Operator::N, [*field], [out.as_mut_slice()]);
                }
            },
        )
    };
    for k in 0..4 {
        check_same("scatter K=4 vs K=1", &out4[k], &sep4[k]);
    }
    t.row("scatter K=4, one pass", scatter4, "`scatter(N, [4 fields])`");
    t.row(
        "scatter 4 × K=1, separate passes",
        separate4,
        &format!("one K=4 pass / four K=1 passes = **{}**", ratio(scatter4, separate4)),
    );

    // 3. Gather.
    let gfx: Vec<f64> = (0..n).map(|i| (0.001 * i as f64).sin()).collect();
    let gfy: Vec<f64> = (0..n).map(|i| (0.0007 * i as f64).cos()).collect();
    let (mut px, mut py) = (vec![0.0; np], vec![0.0; np]);
    t.row(
        "gather K=1: Nᵀ·y",
        measure(|| ops.gather(Operator::N, [&gfx], [&mut px])),
        "`gather(N, [y])`",
    );
    t.row(
        "gather K=2: Nᵀ·[yx yy]",
        measure(|| ops.gather(Operator::N, [&gfx, &gfy], [&mut px, &mut py])),
        "`gather(N, [yx, yy])`",
    );

    // 4. Internal force.
    t.row(
        "internal force (Gx, Gy, one pass)",
        measure(|| transfer::internal_force(&ops, &prob.volume, &prob.sxx, &prob.syy, &prob.sxy)),
        "`transfer::internal_force`, allocates the 2 n-vector result",
    );

    // 5. Reference products on the same matrix and vectors, each timed interleaved with ours.
    let n_csc = ops.n_matrix();
    let x_na = DMatrix::from_column_slice(np, 1, &prob.m);
    let mut c_na = DMatrix::<f64>::zeros(n, 1);
    let (ours, theirs) = measure_pair(
        || ops.scatter(Operator::N, [&prob.m], [&mut g1]),
        || spmm_csc_dense(0.0, &mut c_na, 1.0, Op::NoOp(&n_csc), Op::NoOp(&x_na)),
    );
    check_same("nalgebra-sparse N·x", c_na.as_slice(), &g1);
    t.row(
        "nalgebra-sparse `spmm_csc_dense` N·x (P×1)",
        theirs,
        &versus("scatter K=1", ours, theirs),
    );
    let y_na = DMatrix::from_column_slice(n, 1, &gfx);
    let mut d_na = DMatrix::<f64>::zeros(np, 1);
    let (ours, theirs) = measure_pair(
        || ops.gather(Operator::N, [&gfx], [&mut px]),
        || spmm_csc_dense(0.0, &mut d_na, 1.0, Op::Transpose(&n_csc), Op::NoOp(&y_na)),
    );
    check_same("nalgebra-sparse Nᵀ·y", d_na.as_slice(), &px);
    t.row(
        "nalgebra-sparse `spmm_csc_dense` Nᵀ·y (n×1)",
        theirs,
        &versus("gather K=1", ours, theirs),
    );
    let x2_na = DMatrix::from_fn(np, 2, |i, j| if j == 0 { prob.vx[i] } else { prob.vy[i] });
    let mut c2_na = DMatrix::<f64>::zeros(n, 2);
    let (ours, theirs) = measure_pair(
        || ops.scatter(Operator::N, [&prob.vx, &prob.vy], [&mut qx, &mut qy]),
        || spmm_csc_dense(0.0, &mut c2_na, 1.0, Op::NoOp(&n_csc), Op::NoOp(&x2_na)),
    );
    check_same("nalgebra-sparse N·X", &c2_na.as_slice()[..n], &qx);
    check_same("nalgebra-sparse N·X", &c2_na.as_slice()[n..], &qy);
    t.row(
        "nalgebra-sparse `spmm_csc_dense` N·X (P×2)",
        theirs,
        &versus("scatter K=2 unscaled", ours, theirs),
    );
    drop((n_csc, x_na, c_na, y_na, d_na, x2_na, c2_na));

    let n_faer = ops.n_faer();
    let x_f = MatRef::from_column_major_slice(&prob.m, np, 1);
    let mut c_f = Mat::<f64>::zeros(n, 1);
    let (ours, theirs) = measure_pair(
        || ops.scatter(Operator::N, [&prob.m], [&mut g1]),
        || sparse_dense_matmul(c_f.as_mut(), Accum::Replace, n_faer, x_f, 1.0, Par::Seq),
    );
    let c_f_col: Vec<f64> = (0..n).map(|i| c_f[(i, 0)]).collect();
    check_same("faer N·x", &c_f_col, &g1);
    t.row(
        "faer `sparse_dense_matmul` N·x (P×1)",
        theirs,
        &versus("scatter K=1", ours, theirs),
    );
    let y_f = MatRef::from_column_major_slice(&gfx, n, 1);
    let mut d_f = Mat::<f64>::zeros(np, 1);
    let (ours, theirs) = measure_pair(
        || ops.gather(Operator::N, [&gfx], [&mut px]),
        || sparse_dense_matmul(d_f.as_mut(), Accum::Replace, n_faer.transpose(), y_f, 1.0, Par::Seq),
    );
    let d_f_col: Vec<f64> = (0..np).map(|i| d_f[(i, 0)]).collect();
    check_same("faer Nᵀ·y", &d_f_col, &px);
    t.row(
        "faer `sparse_dense_matmul` Nᵀ·y (n×1)",
        theirs,
        &versus("gather K=1", ours, theirs),
    );
    let x2_f = Mat::<f64>::from_fn(np, 2, |i, j| if j == 0 { prob.vx[i] } else { prob.vy[i] });
    let mut c2_f = Mat::<f64>::zeros(n, 2);
    let (ours, theirs) = measure_pair(
        || ops.scatter(Operator::N, [&prob.vx, &prob.vy], [&mut qx, &mut qy]),
        || sparse_dense_matmul(c2_f.as_mut(), Accum::Replace, n_faer, x2_f.as_ref(), 1.0, Par::Seq),
    );
    let c2_f_col0: Vec<f64> = (0..n).map(|i| c2_f[(i, 0)]).collect();
    check_same("faer N·X", &c2_f_col0, &qx);
    let c2_f_col1: Vec<f64> = (0..n).map(|i| c2_f[(i, 1)]).collect();
    check_same("faer N·X", &c2_f_col1, &qy);
    t.row(
        "faer `sparse_dense_matmul` N·X (P×2)",
        theirs,
        &versus("scatter K=2 unscaled", ours, theirs),
    );
    drop((c_f, d_f, x2_f, c2_f));

    // 6. Mass.
    t.row(
        "lumped mass N·m",
        measure(|| mass::lumped_mass(&ops, &prob.m)),
        "`mass::lumped_mass`, allocates the n-vector",
    );
    t.row(
        "consistent mass N diag(m) Nᵀ (SpGEMM)",
        measure(|| mass::consistent_mass(&ops, &prob.m)),
        "`mass::consistent_mass`, builds Nᵀ's pattern each call",
    );
    let mm = mass::consistent_mass(&ops, &prob.m);
    let lumped = mass::lumped_mass(&ops, &prob.m);
    let active = mass::active_nodes(&lumped, DEFAULT_ACTIVE_MASS_TOLERANCE);
    let options = ConsistentSolveOptions::default();
    t.row(
        "Cholesky of M_AA (symbolic + numeric)",
        measure(|| ConsistentMassSolver::new(&mm, &active, &ops, options).expect("non-singular")),
        &format!(
            "`ConsistentMassSolver::new`, {} active nodes, {} stored entries in M",
            active.len(),
            mm.nnz()
        ),
    );
    let solver = ConsistentMassSolver::new(&mm, &active, &ops, options).expect("non-singular");
    let (rx, ry) = (mass::lumped_mass(&ops, &prob.vx), mass::lumped_mass(&ops, &prob.vy));
    let (mut bx, mut by) = (vec![0.0; n], vec![0.0; n]);
    t.row(
        "Cholesky solve, 2 right-hand sides",
        measure(|| {
            bx.copy_from_slice(&rx);
            by.copy_from_slice(&ry);
            solver.solve_in_place([&mut bx, &mut by]);
        }),
        "`solve_in_place([bx, by])`, includes copying the 2 right-hand sides in",
    );
    drop((mm, solver));

    // 7. The same particles in shuffled memory order.
    run_shuffled(&prob, &mut ops, &t);
}

/// Times assembly, scatter, gather and the consistent mass with the particles stored in a
/// pseudo-random order, each interleaved with the same kernel on the cell-sorted particles.
fn run_shuffled(prob: &Problem, ops: &mut Operators, t: &Table) {
    let perm = permutation(prob.len(), 0x5eed_1234_abcd_0001);
    let sh = prob.permuted(&perm);
    let (grid, shape, n, np) = (&sh.grid, ShapeFunction::Linear, sh.grid.num_nodes(), sh.len());
    let mut ops_sh = Operators::assemble(grid, shape, &sh.particles()).expect("inside");
    let note = |sorted: Stats, shuffled: Stats| {
        format!(
            "shuffled / sorted = **{}** (sorted {} ms interleaved)",
            ratio(shuffled, sorted),
            common::fmt_ms(sorted.median_ms)
        )
    };

    let (sorted, shuffled) = measure_pair(
        || ops.reassemble(grid, shape, &prob.x, &prob.y).expect("inside"),
        || ops_sh.reassemble(grid, shape, &sh.x, &sh.y).expect("inside"),
    );
    for op in [Operator::N, Operator::Gx, Operator::Gy] {
        let (v, v_sh) = (ops.values(op), ops_sh.values(op));
        let back: Vec<f64> = (0..np).flat_map(|k| v[4 * perm[k]..4 * perm[k] + 4].to_vec()).collect();
        check_same("shuffled assembly", &back, v_sh);
    }
    t.row(
        "shuffled order: reassemble N, Gx, Gy",
        shuffled,
        &note(sorted, shuffled),
    );

    let (mut qx, mut qy) = (vec![0.0; n], vec![0.0; n]);
    let (mut sx, mut sy) = (vec![0.0; n], vec![0.0; n]);
    let (sorted, shuffled) = measure_pair(
        || ops.scatter_scaled(Operator::N, Some(&prob.m), [&prob.vx, &prob.vy], [&mut qx, &mut qy]),
        || ops_sh.scatter_scaled(Operator::N, Some(&sh.m), [&sh.vx, &sh.vy], [&mut sx, &mut sy]),
    );
    t.row(
        "shuffled order: scatter K=2 momentum",
        shuffled,
        &note(sorted, shuffled),
    );

    let gfx: Vec<f64> = (0..n).map(|i| (0.001 * i as f64).sin()).collect();
    let gfy: Vec<f64> = (0..n).map(|i| (0.0007 * i as f64).cos()).collect();
    let (mut px, mut py) = (vec![0.0; np], vec![0.0; np]);
    let (mut ux, mut uy) = (vec![0.0; np], vec![0.0; np]);
    let (sorted, shuffled) = measure_pair(
        || ops.gather(Operator::N, [&gfx, &gfy], [&mut px, &mut py]),
        || ops_sh.gather(Operator::N, [&gfx, &gfy], [&mut ux, &mut uy]),
    );
    check_same("shuffled gather", &permute(&px, &perm), &ux);
    t.row("shuffled order: gather K=2", shuffled, &note(sorted, shuffled));

    let (sorted, shuffled) = measure_pair(
        || mass::consistent_mass(ops, &prob.m),
        || mass::consistent_mass(&ops_sh, &sh.m),
    );
    let (m_sorted, m_sh) = (
        mass::consistent_mass(ops, &prob.m),
        mass::consistent_mass(&ops_sh, &sh.m),
    );
    assert_eq!(m_sorted.row_indices(), m_sh.row_indices(), "same pattern");
    check_same("shuffled consistent mass", m_sorted.values(), m_sh.values());
    t.row(
        "shuffled order: consistent mass (SpGEMM)",
        shuffled,
        &note(sorted, shuffled),
    );
}

fn main() {
    faer::set_global_parallelism(Par::Seq);
    let args = common::args(4);
    let sizes = args.sizes_or(&[100_000], &[100_000, 1_000_000]);

    println!("# sparse-mpm operator benchmark");
    println!();
    println!(
        "Machine caveat: 2 vCPUs on a shared host, which often deliver about one core in total; every kernel \
         here runs single-threaded (faer global parallelism set to `Par::Seq`). Figures are the median and \
         minimum over the samples shown (after one warm-up call); short calls are repeated within a sample and \
         reported per call. Every ratio compares medians measured in this same run, with the samples of \
         the two kernels interleaved. Bilinear shape functions, \
         2 × 2 particles per unit cell, particles in cell-sorted order unless marked shuffled."
    );
    let total = Instant::now();
    for &p in &sizes {
        run_size(p);
    }
    println!();
    println!("Total benchmark time: {:.1} s", total.elapsed().as_secs_f64());
}
