//! `mpm bench`: the peers' benchmark problem timed over whole steps.

use clap::Args;

use super::*;

#[derive(Args, Debug)]
pub(crate) struct BenchArgs {
    /// Shape functions: linear, gimp (or gimp:half_width), quadratic_bspline (quadratic), cubic_bspline (cubic).
    #[arg(long, default_value = "quadratic")]
    shape: ShapeFunction,
    /// Mass scheme: lumped, consistent, blended:γ, series:k, cg, cg:tolerance or
    /// cg:tolerance:max_iterations.
    #[arg(long, default_value = "lumped")]
    mass: MassScheme,
    /// Stabilisation of the consistent mass: linear_extension, linear_extension:γ,
    /// linear_extension:γ:θ, partial_lumping, partial_lumping:θ, ghost_penalty, ghost_penalty:γ,
    /// none.
    #[arg(long, default_value = "linear_extension")]
    stabilization: Stabilization,
    /// Velocity transfer: pic, flip, apic, blend:α, xpic:k, fmpm:k [default: apic with the
    /// lumped mass, flip with any other (APIC pairs with a lumped velocity projection only)].
    #[arg(long)]
    transfer: Option<Transfer>,
    /// Update scheme: usf, usl, musl.
    #[arg(long, default_value = "usl")]
    update: UpdateScheme,
    /// Particle counts, comma-separated (16 to 1e9; `1e6` and `1_000_000` are accepted)
    /// [default: 8192,65536,262144,1048576].
    #[arg(long, value_name = "N[,N…]", value_delimiter = ',', value_parser = particle_count)]
    particles: Option<Vec<usize>>,
    /// Worker threads (results are bit-identical for any count).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u64).range(1..=sparse_mpm::parallel::MAX_THREADS as u64))]
    threads: u64,
    /// Timed steps per repetition [default: max(20, min(2000, 2e7/N))].
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..))]
    steps: Option<u64>,
    /// Repetitions; the median is reported.
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u64).range(1..))]
    reps: u64,
    /// A fixed time step instead of the problem's.
    #[arg(long, value_parser = positive, conflicts_with = "cfl")]
    dt: Option<f64>,
    /// Run any mass at this Courant number of the stable step the time loop reports
    /// (estimates and guards included in the timing), instead of the peers' fixed step, so that
    /// masses are compared at their own safe steps.
    #[arg(long, value_parser = positive)]
    cfl: Option<f64>,
    /// Integrate with Newmark's rule (β = ¼, γ = ½, Newton to 1e-10; docs/implicit.md), which
    /// has no stable step, at the fixed step (`--dt`, or the peers' step) instead of the
    /// explicit update.
    #[arg(long, conflicts_with = "cfl")]
    newmark: bool,
    /// Print the share of each phase of the step.
    #[arg(long)]
    profile: bool,
    /// Run the transfers particle by particle instead of in lanes (the same results, to the
    /// bit; for comparing their speed). The same as `--lanes 1`.
    #[arg(long)]
    scalar_kernels: bool,
    /// The most particles the transfers take side by side: 1 (scalar), 4 (AVX2) or 8
    /// (AVX-512; the CPU may allow fewer). The same results, to the bit, for every width.
    #[arg(long, default_value_t = 8, value_parser = lanes)]
    lanes: usize,
    /// Run the explicit step's fused pass (the grid-to-particle pass with the next step's
    /// assembly and particle-to-grid scatter) instead of the separate passes: the same results,
    /// to the bit; for comparing their speed.
    #[arg(long)]
    fused_passes: bool,
}

/// Runs the benchmark of `args` and prints its rows, the memory peak, the estimates and the
/// profile.
pub(crate) fn bench(args: &BenchArgs) -> Result<(), String> {
    sparse_mpm::kernels::set_kernel_lanes(if args.scalar_kernels { 1 } else { args.lanes });
    let defaults = sparse_mpm::bench::BenchSpec::default();
    let spec = sparse_mpm::bench::BenchSpec {
        shape: args.shape,
        mass: args.mass,
        stabilization: args.stabilization,
        transfer: args.transfer.unwrap_or(if args.mass == MassScheme::Lumped {
            Transfer::Apic
        } else {
            Transfer::Flip
        }),
        update: args.update,
        particles: args.particles.clone().unwrap_or(defaults.particles.clone()),
        threads: args.threads as usize,
        fused_passes: args.fused_passes,
        steps: args.steps.map(|s| s as usize),
        reps: args.reps as usize,
        profile: args.profile,
        dt: args.dt,
        cfl: args.cfl,
        integrator: if args.newmark {
            sparse_mpm::simulation::Integrator::Newmark(Default::default())
        } else {
            sparse_mpm::simulation::Integrator::Explicit
        },
        ..defaults
    };
    println!(
        "# sparse-mpm {}: shape {:#}, mass {:#}, transfer {:#}, update {}, {} thread(s), f64, transfers {} particle(s) side by side, {} passes",
        env!("CARGO_PKG_VERSION"),
        spec.shape,
        spec.mass,
        spec.transfer,
        spec.update,
        spec.threads,
        sparse_mpm::kernels::kernel_lanes(),
        if spec.fused_passes { "fused" } else { "separate" }
    );
    println!("particles,n_grid,steps,dt,reps,setup_s,min_psps,median_psps,max_psps,peak_bytes_per_particle,median_ms_per_step,median_s_per_simulated_s");
    let rows = sparse_mpm_cli::bench::run(&spec, |row| {
        let [min, med, max] = row.rate_summary();
        println!(
            "{},{},{},{:.4e},{},{:.3},{min:.4e},{med:.4e},{max:.4e},{},{:.4},{:.4e}",
            row.particles,
            row.n_grid,
            row.steps,
            row.dt,
            row.seconds.len(),
            row.setup_seconds,
            row.peak_bytes_per_particle.map_or("".into(), |b| format!("{b:.0}")),
            1e3 * row.seconds_per_step(),
            row.seconds_per_simulated_second()
        );
        let _ = std::io::stdout().flush();
    })
    .map_err(|e| e.to_string())?;
    for row in &rows {
        let [_, med, _] = row.rate_summary();
        println!("N = {}: particle-steps/s: {med:.4e}", row.particles);
        let rule = match (spec.dt, spec.cfl) {
            (Some(_), _) if args.newmark => "the fixed --dt, Newmark".to_string(),
            (None, _) if args.newmark => "the peers' step, Newmark".to_string(),
            (Some(_), _) => "the fixed --dt".to_string(),
            (None, Some(c)) => format!("{c} of the stable step the time loop reports"),
            (None, None) => format!(
                "the peers' {:.4e} unchecked, or {} of the stable step where that is shorter",
                sparse_mpm::bench::peers_time_step(row.particles),
                sparse_mpm::bench::BENCH_COURANT
            ),
        };
        let [shortest, longest] = row.dt_range;
        println!(
            "N = {}: timed steps {shortest:.4e} to {longest:.4e} ({rule})",
            row.particles
        );
        match row.peak_bytes_per_particle {
            Some(b) => println!("N = {}: peak bytes/particle: {b:.0}", row.particles),
            None => println!(
                "N = {}: peak bytes/particle: not measured on this system",
                row.particles
            ),
        }
        println!(
            "N = {}: {:.3} ms per step, {:.4e} wall s per simulated s (medians)",
            row.particles,
            1e3 * row.seconds_per_step(),
            row.seconds_per_simulated_second()
        );
        let c = row.counts;
        let each = |total: usize, count: usize| {
            if count > 0 {
                format!("{:.1}", total as f64 / count as f64)
            } else {
                "-".into()
            }
        };
        println!(
            "N = {}: stable step in the timed steps: {} estimates in {} steps ({} Lanczos/LOBPCG steps each), {} guards ({} LOBPCG steps each, {} raised the frequency)",
            row.particles,
            c.estimates,
            row.steps * row.seconds.len(),
            each(c.estimate_steps, c.estimates),
            c.guards,
            each(c.guard_steps, c.guards),
            c.raised
        );
        // The update bound estimates at most every BOUND_INTERVAL steps: a shorter window holds
        // one estimate or none, so its cost per step is not a long run's.
        let bound = sparse_mpm::simulation::BOUND_INTERVAL;
        if c.guards > 0 && row.steps < bound {
            println!(
                "N = {}: note: a long run makes an estimate at least every {bound} steps; a window of {} steps holds one or none, not its share: `--steps {bound}` or more gives a long run's cost per step",
                row.particles, row.steps
            );
        }
        if let Some(profile) = &row.profile {
            let total = profile.total();
            let steps = profile.steps().max(1) as f64;
            println!(
                "N = {}: profile over {} steps ({:.3} ms per step):",
                row.particles,
                profile.steps(),
                1e3 * total / steps
            );
            for (phase, seconds) in profile.rows() {
                println!(
                    "    {:<42} {:>8.3} ms  {:>5.1}%",
                    phase.label(),
                    1e3 * seconds / steps,
                    100.0 * seconds / total
                );
            }
        }
    }
    Ok(())
}
