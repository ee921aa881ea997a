//! The mass schemes compared on a problem with an exact solution: the vibrating bar with both
//! ends fixed (notes benchmark B2, Tielen et al. 2017 sec. 4.1).
//!
//! ```text
//! cargo run --release --example mass_study [-- --out DIR]      # CSV to DIR (default target/mass_study)
//! ```
//!
//! E = 100, ρ = 1, L = 25, ν = 0 (plane stress), v(x, 0) = v0 sin(πx/L), v0 = 0.1. The
//! centre-of-mass velocity is exactly
//!
//! ```text
//! v_cm(t) = (2 v0/π) cos(ω t),   ω = π c/L,   c = √(E/ρ),   T = 2π/ω = 5
//! ```
//!
//! The bar is a one-cell-high strip: 25 × 1 cells of h = 1, 2×2 particles per cell, x fixed at
//! x = 0 and x = L, y fixed everywhere (rollers). Explicit steps (USL, FLIP) with Δt = 0.1 h/c
//! to t = 2T, for seven (velocity projection, acceleration solve) mass-scheme pairs. Reported:
//! the RMS error of v_cm over the run (relative to 2v0/π), the period from the zero crossings
//! of v_cm, and the drift of the total energy
//!
//! ```text
//! E = ½ Σ_p m_p |v_p|² + ½ Σ_p V_p σ_p : ε_p,    ε_p = Σ_steps ε̇_p Δt   (ε̇ from StepRecord.strain_rate)
//! ```

use std::f64::consts::PI;
use std::fmt::Write as _;
use std::path::PathBuf;

use sparse_mpm::mass::{Constraints, MassOptions, MassScheme, SolveOutcome};
use sparse_mpm::material::{LinearElastic, PlaneCondition};
use sparse_mpm::step::{explicit_step, StepOptions};
use sparse_mpm::{Grid, Particles};

// Constants (notes B2).
const E: f64 = 100.0;
const RHO: f64 = 1.0;
const L: f64 = 25.0;
const V0: f64 = 0.1;
const H: f64 = 1.0;
const CFL: f64 = 0.1;
const PERIODS: f64 = 2.0;

const LUMPED: MassScheme = MassScheme::Lumped;
const CONSISTENT: MassScheme = MassScheme::Consistent;
/// (velocity projection v̄ = M⁻¹q, acceleration solve a = M⁻¹f).
const PAIRS: [(MassScheme, MassScheme); 7] = [
    (LUMPED, LUMPED),
    (CONSISTENT, CONSISTENT),
    (LUMPED, CONSISTENT),
    (CONSISTENT, LUMPED),
    (MassScheme::Blended { gamma: 0.5 }, MassScheme::Blended { gamma: 0.5 }),
    (
        MassScheme::TruncatedSeries { k: 2 },
        MassScheme::TruncatedSeries { k: 2 },
    ),
    (
        MassScheme::TruncatedSeries { k: 8 },
        MassScheme::TruncatedSeries { k: 8 },
    ),
];

/// One run: v_cm and total energy at t = 0, Δt, 2Δt, …
struct Run {
    v_cm: Vec<f64>,
    energy: Vec<f64>,
    kinetic_final: f64,
    not_solved: usize,
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out_dir = out_dir_from_args();
    let c = (E / RHO).sqrt();
    let omega = PI * c / L;
    let period = 2.0 * PI / omega;
    let dt = CFL * H / c;
    let steps = (PERIODS * period / dt).round() as usize;
    let v_cm_exact = |t: f64| 2.0 * V0 / PI * (omega * t).cos();

    // Setup: the strip, its particles and the roller constraints.
    let cells = (L / H).round() as usize;
    let grid = Grid::new([0.0, 0.0], [H, H], [cells, 1])?;
    let particles = bar_particles(cells)?;
    let material = LinearElastic::new(E, 0.0, PlaneCondition::Stress)?;
    let ends: Vec<usize> = (0..2)
        .flat_map(|j| [grid.node_index(0, j), grid.node_index(cells, j)])
        .collect();
    let constraints = Constraints {
        fixed_x: ends,
        fixed_y: (0..grid.num_nodes()).collect(),
    };

    // Loop: one run per (velocity, acceleration) scheme pair.
    let clock = std::time::Instant::now();
    let mut runs = Vec::new();
    for (velocity, acceleration) in PAIRS {
        let options = StepOptions {
            dt,
            mass: MassOptions {
                velocity,
                acceleration,
                ..MassOptions::both(LUMPED)
            },
            constraints: constraints.clone(),
            ..StepOptions::default()
        };
        runs.push(run(&grid, particles.clone(), &material, &options, steps)?);
    }
    let elapsed = clock.elapsed().as_secs_f64();

    // Comparison with the exact solution.
    let times: Vec<f64> = (0..=steps).map(|n| n as f64 * dt).collect();
    let amplitude = 2.0 * V0 / PI;
    println!(
        "Vibrating bar, both ends fixed: E = {E}, rho = {RHO}, L = {L}, v0 = {V0}, c = {c}, T = {period}; \
         {cells} x 1 cells, {} particles (2x2 per cell)",
        particles.len()
    );
    println!(
        "dt = {dt} (CFL {CFL}), {steps} steps to t = {} ({PERIODS} periods), {} runs in {elapsed:.2} s\n",
        steps as f64 * dt,
        PAIRS.len()
    );
    println!(
        "{:>14} {:>14} | {:>12} {:>9} {:>10} | {:>12} {:>12} {:>10}",
        "velocity", "acceleration", "RMS err v_cm", "period", "period err", "energy drift", "max |dE|/E0", "KE end/E0"
    );
    for ((velocity, acceleration), r) in PAIRS.iter().zip(&runs) {
        let rms = (times
            .iter()
            .zip(&r.v_cm)
            .map(|(&t, v)| (v - v_cm_exact(t)).powi(2))
            .sum::<f64>()
            / times.len() as f64)
            .sqrt();
        let t_num = period_from_zero_crossings(&times, &r.v_cm);
        let e0 = r.energy[0];
        let drift = (r.energy[steps] - e0) / e0;
        let max_dev = r.energy.iter().map(|e| (e - e0).abs()).fold(0.0, f64::max) / e0;
        println!(
            "{:>#14} {:>#14} | {:>11.3}% {:>9.5} {:>9.3}% | {:>11.4}% {:>11.4}% {:>10.4}",
            velocity,
            acceleration,
            100.0 * rms / amplitude,
            t_num,
            100.0 * (t_num - period) / period,
            100.0 * drift,
            100.0 * max_dev,
            r.kinetic_final / e0
        );
        if r.not_solved > 0 {
            println!("    ({} solves fell back or were regularized)", r.not_solved);
        }
    }
    println!(
        "\nRMS err: RMS over all steps of v_cm - (2 v0/pi) cos(omega t), relative to 2 v0/pi = {amplitude:.6}.\n\
         period: twice the mean spacing of the zero crossings of v_cm; exact {period}.\n\
         energy: 1/2 sum m v^2 + 1/2 sum V sigma:eps, eps integrated from StepRecord.strain_rate * dt;\n\
         drift = (E(t_end) - E0)/E0, E0 = {:.6e}. KE end/E0: the exact value is cos^2(omega t_end) = {:.4}.",
        runs[0].energy[0],
        (omega * steps as f64 * dt).cos().powi(2)
    );

    // The time series, for plotting.
    std::fs::create_dir_all(&out_dir)?;
    let path = out_dir.join("mass_study.csv");
    let mut csv = String::from("t,v_cm_exact");
    for (velocity, acceleration) in PAIRS {
        write!(csv, ",{velocity:#}/{acceleration:#}")?;
    }
    csv.push('\n');
    for (n, &t) in times.iter().enumerate() {
        write!(csv, "{t},{}", v_cm_exact(t))?;
        for r in &runs {
            write!(csv, ",{}", r.v_cm[n])?;
        }
        csv.push('\n');
    }
    std::fs::write(&path, csv)?;
    println!(
        "\nTime series (t, v_cm exact, v_cm per velocity/acceleration pair): {}",
        path.display()
    );
    Ok(())
}

/// Runs `steps` explicit steps, recording v_cm and the total energy after each.
fn run(
    grid: &Grid,
    mut p: Particles,
    material: &LinearElastic,
    options: &StepOptions,
    steps: usize,
) -> sparse_mpm::Result<Run> {
    let dt = options.dt;
    let mut eps = Strain::zeros(p.len());
    let mut v_cm = vec![centre_of_mass_velocity(&p)];
    let mut energy = vec![p.kinetic_energy() + eps.energy(&p)];
    let mut not_solved = 0;
    for _ in 0..steps {
        let record = explicit_step(grid, &mut p, material, options)?;
        eps.add(&record.strain_rate, dt);
        v_cm.push(centre_of_mass_velocity(&p));
        energy.push(p.kinetic_energy() + eps.energy(&p));
        for report in [&record.velocity_report, &record.acceleration_report] {
            not_solved += usize::from(report.outcome != SolveOutcome::Solved);
        }
    }
    Ok(Run {
        v_cm,
        energy,
        kinetic_final: p.kinetic_energy(),
        not_solved,
    })
}

/// 2×2 particles per cell at offsets (0.25, 0.75) h, V = h²/4, m = ρV, v_x = v0 sin(πx/L).
fn bar_particles(cells: usize) -> sparse_mpm::Result<Particles> {
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for i in 0..cells {
        for oy in [0.25, 0.75] {
            for ox in [0.25, 0.75] {
                x.push((i as f64 + ox) * H);
                y.push(oy * H);
            }
        }
    }
    let np = x.len();
    let volume = 0.25 * H * H;
    let vx = x.iter().map(|x| V0 * (PI * x / L).sin()).collect();
    Particles::new(x, y, vec![RHO * volume; np], vec![volume; np])?.with_velocity(vx, vec![0.0; np])
}

/// Σ m_p v_x,p / Σ m_p.
fn centre_of_mass_velocity(p: &Particles) -> f64 {
    p.momentum()[0] / p.total_mass()
}

/// Small strain per particle, integrated from the strain rate.
struct Strain {
    xx: Vec<f64>,
    yy: Vec<f64>,
    xy: Vec<f64>,
}

impl Strain {
    fn zeros(np: usize) -> Strain {
        Strain {
            xx: vec![0.0; np],
            yy: vec![0.0; np],
            xy: vec![0.0; np],
        }
    }

    /// ε ← ε + ε̇ Δt.
    fn add(&mut self, rate: &sparse_mpm::transfer::StrainRate, dt: f64) {
        for q in 0..self.xx.len() {
            self.xx[q] += rate.xx[q] * dt;
            self.yy[q] += rate.yy[q] * dt;
            self.xy[q] += rate.xy[q] * dt;
        }
    }

    /// ½ Σ V (σxx εxx + σyy εyy + 2 σxy εxy).
    fn energy(&self, p: &Particles) -> f64 {
        (0..p.len())
            .map(|q| 0.5 * p.volume[q] * (p.sxx[q] * self.xx[q] + p.syy[q] * self.yy[q] + 2.0 * p.sxy[q] * self.xy[q]))
            .sum()
    }
}

/// Twice the mean spacing of the sign changes of `v` (linear interpolation between samples).
fn period_from_zero_crossings(t: &[f64], v: &[f64]) -> f64 {
    let crossings: Vec<f64> = (1..v.len())
        .filter(|&n| v[n - 1] != 0.0 && v[n - 1].signum() != v[n].signum())
        .map(|n| t[n - 1] + (t[n] - t[n - 1]) * v[n - 1] / (v[n - 1] - v[n]))
        .collect();
    match crossings.len() {
        0 | 1 => f64::NAN,
        k => 2.0 * (crossings[k - 1] - crossings[0]) / (k - 1) as f64,
    }
}

/// `--out DIR` or `--out=DIR`; default `target/mass_study`.
fn out_dir_from_args() -> PathBuf {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut dir = PathBuf::from("target/mass_study");
    for (k, a) in args.iter().enumerate() {
        if let Some(d) = a.strip_prefix("--out=") {
            dir = PathBuf::from(d);
        } else if a == "--out" {
            match args.get(k + 1) {
                Some(d) => dir = PathBuf::from(d),
                None => {
                    eprintln!("--out needs a directory");
                    std::process::exit(2);
                }
            }
        }
    }
    dir
}
