//! Cost of one step's mass treatment for each mass scheme: `GridMass::update` on a grid mass
//! already built once (the symbolic Cholesky analysis is reused: the steady state), then the
//! two solves of a step, `v̄ = M⁻¹ q` (`Role::Velocity`) and `a = M⁻¹ f` (`Role::Acceleration`).
//! Also, for the consistent mass: the first build (`GridMass::new`, with symbolic analysis)
//! against the steady-state update, and the assembly of `M = N diag(m) Nᵀ` alone.
//!
//! ```text
//! cargo bench --bench mass_schemes               # P = 1e5 and P = 1e6
//! cargo bench --bench mass_schemes -- --quick    # P = 1e5 only
//! cargo bench --bench mass_schemes -- --sizes 1e5,3e5
//! ```
//!
//! The same small harness as `benches/operators.rs` (no criterion): one warm-up call, then up to
//! 11 timed samples; calls shorter than 20 ms are repeated inside a sample and the sample is
//! divided by the repetition count; calls longer than 0.25 s get 5 samples, longer than 1 s get 3.
//! The kernels of one table are timed round-robin (one sample of each in turn), so load from
//! other processes on a shared host falls on all of them alike, and every ratio compares medians
//! measured in this same run.

mod common;
use common::*;

use std::hint::black_box;
use std::time::Instant;

use faer::Par;
use sparse_mpm::mass::{self, Constraints, GridMass, MassOptions, MassScheme, Role, SolveOutcome, SolveReport};
use sparse_mpm::transfer::{self, VectorField};
use sparse_mpm::{Grid, Operators, Particles, ShapeFunction};

/// A kernel to time: returns nothing, passes its results through `black_box` itself.
type Kernel<'a> = Box<dyn FnMut() + 'a>;

/// Times several kernels round-robin: one warm-up call each, then rounds in which every kernel
/// that still needs samples takes one. Slow kernels (3 or 5 samples) are thus interleaved with
/// the first samples of the fast ones.
fn measure_round_robin(kernels: &mut [Kernel<'_>]) -> Vec<Stats> {
    let plans: Vec<Plan> = kernels.iter_mut().map(warm_up).collect();
    let rounds = plans.iter().map(|p| p.samples).max().unwrap_or(0);
    let mut times: Vec<Vec<f64>> = plans.iter().map(|p| Vec::with_capacity(p.samples)).collect();
    for round in 0..rounds {
        for ((kernel, plan), t) in kernels.iter_mut().zip(&plans).zip(&mut times) {
            if round < plan.samples {
                t.push(sample(kernel, plan.calls));
            }
        }
    }
    times
        .into_iter()
        .zip(&plans)
        .map(|(t, p)| summarize(t, p.calls))
        .collect()
}

/// `a / b` of the medians, formatted.
fn ratio(a: Stats, b: Stats) -> String {
    let r = a.median_ms / b.median_ms;
    if r >= 10.0 {
        format!("{r:.0}")
    } else {
        format!("{r:.2}")
    }
}

fn fmt_residual(r: f64) -> String {
    if r == 0.0 {
        "0".into()
    } else {
        format!("{r:.1e}")
    }
}

/// The benchmark problem: `nc × nc` unit cells filled with 2 × 2 particles each at the regular
/// positions (¼, ¾), inside a grid with [`MARGIN`] empty cells on every side; particles in
/// cell-sorted order; uniform masses (density 1).
struct Problem {
    grid: Grid,
    cells_per_side: usize,
    particles: Particles,
    vx: Vec<f64>,
    vy: Vec<f64>,
    bx: Vec<f64>,
    by: Vec<f64>,
}

impl Problem {
    fn new(target_particles: usize) -> Problem {
        let (grid, x, y) = block(target_particles);
        let np = x.len();
        let nc = grid.cells()[0] - 2 * MARGIN;
        let field = |f: &dyn Fn(f64, f64) -> f64| -> Vec<f64> { x.iter().zip(&y).map(|(&a, &b)| f(a, b)).collect() };
        // Smooth velocity field and body force per unit mass (gravity plus a smooth variation).
        let vx = field(&|a, b| (0.01 * a).sin() + 0.5 * (0.013 * b).cos());
        let vy = field(&|a, b| (0.017 * b).cos() - 0.25 * (0.011 * a).sin());
        let bx = field(&|a, b| 0.3 * (0.02 * a + 0.01 * b).sin());
        let by = field(&|a, b| -9.81 + 0.5 * (0.015 * a).cos() * (0.007 * b).sin());
        let particles = Particles::new(x, y, vec![0.25; np], vec![0.25; np]).expect("valid particles");
        Problem {
            grid,
            cells_per_side: nc,
            particles,
            vx,
            vy,
            bx,
            by,
        }
    }
}

/// The schemes compared, the first being the reference of the ratios.
fn schemes() -> Vec<MassScheme> {
    vec![
        MassScheme::Lumped,
        MassScheme::Consistent,
        MassScheme::Blended { gamma: 0.5 },
        MassScheme::TruncatedSeries { k: 2 },
        MassScheme::TruncatedSeries { k: 8 },
        MassScheme::Iterative {
            tolerance: 1e-8,
            max_iterations: 1000,
        },
    ]
}

/// Everything one step's mass treatment needs, shared by all schemes.
struct StepInput<'a> {
    ops: &'a Operators,
    m: &'a [f64],
    q: &'a VectorField,
    f: &'a VectorField,
    constraints: &'a Constraints,
}

impl StepInput<'_> {
    /// One step's mass treatment: update, then the velocity and acceleration solves.
    fn step(&self, mass: &mut GridMass, options: &MassOptions) -> (SolveReport, SolveReport) {
        mass.update(self.ops, self.m, options, self.constraints)
            .expect("the mass matrix is regular");
        let (v, rv) = mass
            .solve(Role::Velocity, self.q, None, self.ops)
            .expect("velocity solve");
        let (a, ra) = mass
            .solve(Role::Acceleration, self.f, None, self.ops)
            .expect("acceleration solve");
        black_box((&v, &a));
        (rv, ra)
    }
}

fn run_size(target: usize) {
    let prob = Problem::new(target);
    let np = prob.particles.len();
    let grid = &prob.grid;
    let n = grid.num_nodes();
    let m = &prob.particles.mass;
    let ops = Operators::assemble(grid, ShapeFunction::Linear, &prob.particles).expect("particles inside the grid");
    let q = transfer::momentum(&ops, m, &prob.vx, &prob.vy);
    let f = transfer::external_force(&ops, m, &prob.bx, &prob.by);
    let constraints = Constraints::none();
    let input = StepInput {
        ops: &ops,
        m,
        q: &q,
        f: &f,
        constraints: &constraints,
    };

    // Build each scheme's grid mass once (symbolic analysis), outside the timings.
    let schemes = schemes();
    let options: Vec<MassOptions> = schemes.iter().map(|&s| MassOptions::both(s)).collect();
    let mut masses: Vec<GridMass> = options
        .iter()
        .map(|o| GridMass::new(&ops, m, o, &constraints).expect("the mass matrix is regular"))
        .collect();
    let (active, nnz_m) = {
        let c = &masses[1];
        (c.active_nodes().len(), c.consistent_matrix().map_or(0, |mm| mm.nnz()))
    };

    println!();
    println!(
        "### P = {np} ({0} × {0} cells with 2 × 2 particles each, grid {1} × {1} cells, n = {n} nodes, \
         {active} active, {nnz_m} stored entries in M)",
        prob.cells_per_side,
        grid.cells()[0],
    );
    println!();

    // 1. One step's mass treatment per scheme, round-robin.
    let mut reports: Vec<Option<(SolveReport, SolveReport)>> = vec![None; schemes.len()];
    let stats = {
        let mut kernels: Vec<Kernel<'_>> = masses
            .iter_mut()
            .zip(&options)
            .zip(reports.iter_mut())
            .map(|((mass, opts), report)| {
                let input = &input;
                Box::new(move || *report = Some(input.step(mass, opts))) as Kernel<'_>
            })
            .collect();
        measure_round_robin(&mut kernels)
    };
    println!("| scheme | P | median ms | min ms | ratio to lumped | iterations | residual |");
    println!("|---|---:|---:|---:|---:|---:|---:|");
    for ((scheme, s), report) in schemes.iter().zip(&stats).zip(&reports) {
        let (rv, ra) = report.as_ref().expect("measured at least once");
        for r in [rv, ra] {
            assert_eq!(r.outcome, SolveOutcome::Solved, "{:#}: {:?}", scheme, r.outcome);
        }
        let iterations = match scheme {
            MassScheme::Iterative { .. } => format!("v {} / a {}", rv.iterations, ra.iterations),
            _ => "–".into(),
        };
        let residual = match scheme {
            MassScheme::Lumped => "–".into(),
            _ => format!(
                "v {} / a {}",
                fmt_residual(rv.relative_residual),
                fmt_residual(ra.relative_residual)
            ),
        };
        println!(
            "| {:#} | {np} | {} | {} | {} | {iterations} | {residual} |",
            scheme,
            common::fmt_ms(s.median_ms),
            common::fmt_ms(s.min_ms),
            ratio(*s, stats[0])
        );
    }
    println!();
    println!(
        "Samples × calls per sample: {}.",
        schemes
            .iter()
            .zip(&stats)
            .map(|(sc, s)| format!("{sc:#} {} × {}", s.samples, s.calls_per_sample))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let cons = &masses[1];
    println!(
        "Symbolic analyses after all steps (consistent): velocity {}, acceleration {} (x and y summed; \
         1 each means the steady-state update reused the first analysis).",
        cons.symbolic_analyses(Role::Velocity),
        cons.symbolic_analyses(Role::Acceleration)
    );

    // 2. The consistent mass in detail: first build vs steady-state update vs assembly alone, and
    //    an update that factorizes for the velocity solve only.
    let consistent = MassOptions::both(MassScheme::Consistent);
    let velocity_only = MassOptions {
        acceleration: MassScheme::Lumped,
        ..consistent
    };
    let mut steady = GridMass::new(&ops, m, &consistent, &constraints).expect("regular");
    let mut single = GridMass::new(&ops, m, &velocity_only, &constraints).expect("regular");
    let detail = {
        let mut kernels: Vec<Kernel<'_>> = vec![
            Box::new(|| {
                black_box(GridMass::new(&ops, m, &consistent, &constraints).expect("regular"));
            }),
            Box::new(|| steady.update(&ops, m, &consistent, &constraints).expect("regular")),
            Box::new(|| {
                black_box(mass::consistent_mass(&ops, m));
            }),
            Box::new(|| single.update(&ops, m, &velocity_only, &constraints).expect("regular")),
        ];
        measure_round_robin(&mut kernels)
    };
    let rows = [
        "consistent: first build `GridMass::new` (assembly + symbolic + numeric)",
        "consistent: steady-state `GridMass::update` (assembly + numeric, symbolic reused)",
        "consistent: assembly of M alone `mass::consistent_mass`",
        "velocity consistent, acceleration lumped: steady-state `update` (one factorization)",
    ];
    println!();
    println!("| operation | P | median ms | min ms | samples × calls | ratio to steady-state update |");
    println!("|---|---:|---:|---:|---:|---:|");
    for (row, s) in rows.iter().zip(&detail) {
        println!(
            "| {row} | {np} | {} | {} | {} × {} | {} |",
            common::fmt_ms(s.median_ms),
            common::fmt_ms(s.min_ms),
            s.samples,
            s.calls_per_sample,
            ratio(*s, detail[1])
        );
    }
    println!(
        "Symbolic analyses (consistent, steady state): velocity {}, acceleration {}.",
        steady.symbolic_analyses(Role::Velocity),
        steady.symbolic_analyses(Role::Acceleration)
    );
}

fn main() {
    faer::set_global_parallelism(Par::Seq);
    let args = common::args(4);
    let sizes = args.sizes_or(&[100_000], &[100_000, 1_000_000]);

    println!("# sparse-mpm mass-scheme benchmark: one step's mass treatment");
    println!();
    println!(
        "One step = `GridMass::update` on a grid mass built once before (symbolic analysis reused) + \
         `solve(Role::Velocity, q)` + `solve(Role::Acceleration, f)`, with q = N (m ∘ v) for a smooth v \
         and f = N (m ∘ b) for a smooth body force b; the same scheme for both solves, no constraints. \
         Bilinear shape functions, 2 × 2 particles per unit cell at regular positions, cell-sorted order, \
         uniform masses. Single-threaded (faer global parallelism `Par::Seq`) on 2 vCPUs of a shared host. \
         Median and minimum per call over the samples shown (after one warm-up call); the kernels of a \
         table are sampled round-robin and every ratio compares medians of this same run. \
         Iterations: conjugate-gradient iterations of the velocity (v) and acceleration (a) solve, each \
         summed over the x and y components. Residual: `SolveReport::relative_residual` \
         (‖M u − r‖ / ‖r‖ against the consistent M, γ-blended matrix for blended; max over components)."
    );
    let total = Instant::now();
    for &p in &sizes {
        run_size(p);
    }
    println!();
    println!("Total benchmark time: {:.1} s", total.elapsed().as_secs_f64());
}
