//! `mpm`: run scene files, export the matrices of a scene, print the worked problem, run the
//! verification study and the benchmark. `mpm help` and `mpm <command> --help` describe each
//! command.

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

use clap::{Args, Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};

use sparse_mpm::limits;
use sparse_mpm::mass::{MassScheme, Stabilization};
use sparse_mpm::numbers::human;
use sparse_mpm::scene::Scene;
use sparse_mpm::simulation::{Transfer, UpdateScheme};
use sparse_mpm::ShapeFunction;
use sparse_mpm_cli::run::{
    prepare_output, run_scene_with, write_matrices, OutputPolicy, Progress, RunLimits, RunOptions,
};

/// The scene `mpm run` uses when none is given.
mod bench;
mod study;
mod view;

use bench::{bench, BenchArgs};
use study::{study, StudyArgs};
use view::{plot, render, PlotArgs, RenderArgs};

const DEFAULT_SCENE: (&str, &str) = ("two_disks", include_str!("../../../../scenes/two_disks.toml"));

/// The 2D material point method in sparse-matrix form.
#[derive(Parser, Debug)]
#[command(name = "mpm", version, about, long_about = None, arg_required_else_help = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Run a scene: particle snapshots for ParaView, a report row per step, the scene as read.
    ///
    /// Writes DIR/particles_*.vtp, DIR/particles.pvd (open it in ParaView), DIR/report.csv
    /// (one row per step) and DIR/scene.toml (reruns the same scene from DIR). Without a scene,
    /// runs the built-in two-disk impact (scenes/two_disks.toml).
    Run(RunArgs),
    /// Continue a run from a checkpoint written by `mpm run --checkpoint-every`.
    ///
    /// The continued run's report rows and snapshots are bit-identical to an uninterrupted
    /// run's. Writes into the checkpoint's run folder (the folder above `checkpoints/`) unless
    /// --out says otherwise.
    Resume(ResumeArgs),
    /// Write N, Gx, Gy, M (consistent mass) and mL (lumped mass) of a scene's initial
    /// configuration as Matrix Market files, with nodes.csv and particles.csv.
    Matrices(MatricesArgs),
    /// Print a scene with every default filled in (and any --set applied), as TOML that reads
    /// back to the same scene: what `run` would run.
    Scene(SceneArgs),
    /// Read and validate a scene exactly as `run` does (limits and the stable time step
    /// included) and print its size and stable time step.
    Check(CheckArgs),
    /// One explicit MPM step worked by hand: bilinear shape functions on a 6-node grid with 4
    /// particles, consistent and lumped mass, grid forces, accelerations, the step; every
    /// quantity printed (docs/homework.md).
    Homework {
        /// Print the answers as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Run the verification problems over a matrix of choices and write a report with plots.
    ///
    /// Writes DIR/report.md with its PNG plots and DIR/runs.csv (every run). Parts: dispersion,
    /// frequency, bar_energy, convergence, energy, time_step, cantilever, single_point,
    /// time_order, waves, stabilization, implicit. With a subcommand the study is split across processes
    /// or machines: `plan` writes the runs, `run DIR --shard K/N` runs a share, `merge DIR`
    /// writes the report (docs/study.md).
    Study(StudyArgs),
    /// Time the peers' benchmark problem (a random block falling into a walled unit box,
    /// neo-Hookean, about 4 particles per cell; docs/performance.md) over whole steps.
    ///
    /// Prints a CSV row per particle count (min/median/max), then `particle-steps/s: <median>`
    /// and `peak bytes/particle: <value>`.
    Bench(BenchArgs),
    /// Print the discrete dispersion relation of the explicit update as CSV: the wave speed
    /// c_h/c of a Fourier mode against θ = kh over (0, π] (docs/mass.md, "Dispersion").
    ///
    /// Columns `theta,c_ratio`: one row per θ = π j / samples, or with --cells N per wavenumber
    /// of a periodic bar of N cells (θ = 2π j / N, j = 1 … N/2).
    Dispersion(DispersionArgs),
    /// Draw a run's particles coloured by a field: PNG frames and an animated GIF.
    ///
    /// Reads RUN_DIR/particles.pvd and its snapshots (and RUN_DIR/scene.toml for the grid);
    /// writes OUT/frames_FIELD/frame_NNNNNN.png and OUT/FIELD.gif (OUT: RUN_DIR unless --out).
    Render(RenderArgs),
    /// Plot the energies and momenta of a run's report.csv against time into a PNG
    /// (RUN_DIR/report.png unless --out).
    Plot(PlotArgs),
}

#[derive(Args, Debug)]
struct DispersionArgs {
    /// Shape functions: linear, gimp (or gimp:half_width), quadratic_bspline (quadratic), cubic_bspline (cubic).
    #[arg(long, default_value = "linear")]
    shape: ShapeFunction,
    /// Mass scheme of the velocity projection (and of the acceleration solve unless
    /// --acceleration-mass is given): lumped, consistent, blended:γ, series:k, cg.
    #[arg(long, default_value = "lumped")]
    mass: MassScheme,
    /// Mass scheme of the acceleration solve [default: --mass].
    #[arg(long)]
    acceleration_mass: Option<MassScheme>,
    /// Particles per cell along the bar, at the centres of equal sub-cells (1–64).
    #[arg(long, default_value_t = 2)]
    particles_per_cell: usize,
    /// Points of the curve, θ = π j / samples.
    #[arg(long, default_value_t = 64)]
    samples: usize,
    /// Sample the wavenumbers of a periodic bar of N cells instead.
    #[arg(long, value_name = "N")]
    cells: Option<usize>,
}

/// Where output goes and what may be replaced there.
#[derive(Args, Debug)]
struct OutputArgs {
    /// Output folder [default: out/SCENE, SCENE the scene file name without .toml].
    #[arg(long, short = 'o', value_name = "DIR")]
    out: Option<PathBuf>,
    /// Replace the output of an earlier run in DIR (its snapshots, report, scene and
    /// checkpoints are removed first); without it a folder holding files is refused.
    #[arg(long)]
    overwrite: bool,
}

/// How long a run goes and what it writes besides its output: shared by `run` and `resume`.
#[derive(Args, Debug)]
struct StepArgs {
    /// Stop at this time instead of the scene's `time.end`.
    #[arg(long, value_name = "T", value_parser = positive)]
    end_time: Option<f64>,
    /// Stop after this many steps in all (counted from the start of the run).
    #[arg(long, value_name = "N")]
    steps: Option<usize>,
    /// Write a checkpoint every K steps under DIR/checkpoints (resume with `mpm resume`).
    #[arg(long, value_name = "K", value_parser = clap::value_parser!(u64).range(1..))]
    checkpoint_every: Option<u64>,
    /// Accept a run whose estimated memory or output exceeds the limits of docs/reliability.md.
    #[arg(long)]
    allow_large: bool,
    /// Print only the final throughput line.
    #[arg(long, short = 'q')]
    quiet: bool,
    /// Worker threads [default: the scene's execution.threads, or the checkpoint's]; the
    /// results are the same bits for any count.
    #[arg(long, value_name = "T", value_parser = clap::value_parser!(u64).range(1..=sparse_mpm::parallel::MAX_THREADS as u64))]
    threads: Option<u64>,
}

impl StepArgs {
    fn options(&self, output: OutputPolicy) -> RunOptions {
        RunOptions {
            limits: RunLimits {
                end_time: self.end_time,
                max_steps: self.steps,
            },
            output,
            checkpoint_every: self.checkpoint_every.map(|k| k as usize),
            allow_large: self.allow_large,
            threads: self.threads.map(|t| t as usize),
        }
    }
}

#[derive(Args, Debug)]
struct RunArgs {
    /// The scene file [default: the built-in two-disk impact].
    scene: Option<PathBuf>,
    /// Change a key of the scene, as an edit of the file would (repeatable):
    /// `--set time.end=2 --set bodies[0].material.youngs_modulus=2e7`; an empty value removes
    /// the key (`--set time.cfl= --set time.dt=1e-4`).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    sets: Vec<String>,
    #[command(flatten)]
    output: OutputArgs,
    #[command(flatten)]
    run: StepArgs,
}

#[derive(Args, Debug)]
struct ResumeArgs {
    /// A checkpoint folder (`checkpoints/step_NNNNNNNN`) written by `mpm run --checkpoint-every`.
    checkpoint: PathBuf,
    /// Output folder [default: the checkpoint's run folder].
    #[arg(long, short = 'o', value_name = "DIR")]
    out: Option<PathBuf>,
    #[command(flatten)]
    run: StepArgs,
}

#[derive(Args, Debug)]
struct MatricesArgs {
    /// The scene file.
    scene: PathBuf,
    /// Change a key of the scene, as an edit of the file would (repeatable):
    /// `--set time.end=2 --set bodies[0].material.youngs_modulus=2e7`; an empty value removes
    /// the key (`--set time.cfl= --set time.dt=1e-4`).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    sets: Vec<String>,
    /// Output folder [default: out/SCENE/matrices].
    #[arg(long, short = 'o', value_name = "DIR")]
    out: Option<PathBuf>,
    /// Replace matrix files already in DIR.
    #[arg(long)]
    overwrite: bool,
    /// Accept a scene whose estimated memory exceeds the limits.
    #[arg(long)]
    allow_large: bool,
}

#[derive(Args, Debug)]
struct SceneArgs {
    /// The scene file [default: the built-in two-disk impact].
    scene: Option<PathBuf>,
    /// Print the scene as TOML with every default filled in (the default action).
    #[arg(long)]
    print: bool,
    /// Change a key of the scene, as an edit of the file would (repeatable):
    /// `--set time.end=2 --set bodies[0].material.youngs_modulus=2e7`; an empty value removes
    /// the key (`--set time.cfl= --set time.dt=1e-4`).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    sets: Vec<String>,
}

#[derive(Args, Debug)]
struct CheckArgs {
    /// The scene file.
    scene: PathBuf,
    /// Change a key of the scene, as an edit of the file would (repeatable):
    /// `--set time.end=2 --set bodies[0].material.youngs_modulus=2e7`; an empty value removes
    /// the key (`--set time.cfl= --set time.dt=1e-4`).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    sets: Vec<String>,
    /// Check against raised limits, as `mpm run --allow-large` would run.
    #[arg(long)]
    allow_large: bool,
}

/// A kernel width: 1, 4 or 8.
fn lanes(text: &str) -> Result<usize, String> {
    match text {
        "1" => Ok(1),
        "4" => Ok(4),
        "8" => Ok(8),
        _ => Err(format!("{text:?}: the transfers take 1, 4 or 8 particles side by side")),
    }
}

/// A finite positive number.
fn positive(text: &str) -> Result<f64, String> {
    text.parse::<f64>()
        .ok()
        .filter(|v| v.is_finite() && *v > 0.0)
        .ok_or_else(|| format!("`{text}` is not a positive number"))
}

/// A particle count between 16 and 1e9, written as an integer, with `_` separators, or in
/// exponent form.
fn particle_count(text: &str) -> Result<usize, String> {
    let cleaned = text.trim().replace('_', "");
    cleaned
        .parse::<f64>()
        .ok()
        .filter(|x| x.fract() == 0.0 && (16.0..=1e9).contains(x))
        .map(|x| x as usize)
        .ok_or_else(|| format!("`{text}` is not a count between 16 and 1e9"))
}

/// The scene at `path`, or the built-in default; and its name.
fn load_scene(path: Option<&Path>, sets: &[String]) -> Result<(Scene, String), String> {
    match path {
        Some(path) => {
            let scene = Scene::load_with(path, sets).map_err(|e| e.to_string())?;
            let name = path
                .file_stem()
                .map_or("scene".into(), |s| s.to_string_lossy().into_owned());
            Ok((scene, name))
        }
        None => {
            let text = sparse_mpm::scene::apply_overrides(DEFAULT_SCENE.1, sets)
                .map_err(|e| format!("built-in scene: {e}"))?;
            let scene = Scene::from_toml_str(&text).map_err(|e| format!("built-in scene: {e}"))?;
            Ok((scene, DEFAULT_SCENE.0.to_string()))
        }
    }
}

/// A progress bar over simulated time on stderr (hidden when stderr is not a terminal or with
/// `--quiet`), and a one-time warning when a fixed step runs above the stable step.
struct RunDisplay {
    bar: ProgressBar,
    warned: bool,
}

impl RunDisplay {
    fn new(quiet: bool) -> RunDisplay {
        let bar = if quiet || !std::io::stderr().is_terminal() {
            ProgressBar::hidden()
        } else {
            ProgressBar::new(1000)
        };
        bar.set_style(
            ProgressStyle::with_template("[{bar:30}] {percent:>3}%  {msg}  eta {eta}")
                .expect("a valid template")
                .progress_chars("#>-"),
        );
        bar.enable_steady_tick(Duration::from_millis(200));
        RunDisplay { bar, warned: false }
    }

    fn update(&mut self, p: &Progress) {
        if p.dt > p.stable_time_step && !self.warned {
            self.warned = true;
            self.bar.suspend(|| {
                eprintln!(
                    "warning: step {}: the fixed time step {} exceeds the stable step {} ({:.1}% over); the run goes \
                     on because `allow_unstable = true`",
                    p.steps,
                    human(p.dt),
                    human(p.stable_time_step),
                    100.0 * (p.dt / p.stable_time_step - 1.0)
                )
            });
        }
        let fraction = (p.time / p.end_time).clamp(0.0, 1.0);
        self.bar.set_position((1000.0 * fraction) as u64);
        self.bar.set_message(format!(
            "t = {} / {}  step {}",
            human(p.time),
            human(p.end_time),
            p.steps
        ));
    }

    fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

fn print_summary(summary: &sparse_mpm_cli::run::RunSummary, out: &Path, quiet: bool) {
    if !quiet {
        println!(
            "{} particles, {} steps to t = {} in {:.2} s ({:.2} s stepping)",
            summary.particles,
            summary.steps,
            human(summary.time),
            summary.total.as_secs_f64(),
            summary.stepping.as_secs_f64()
        );
        if let Some(r) = &summary.last {
            println!(
                "final: kinetic energy {}, strain energy {}, total {}, momentum ({}, {})",
                human(r.kinetic_energy),
                human(r.strain_energy),
                human(r.total_energy),
                human(r.momentum[0]),
                human(r.momentum[1])
            );
        }
        if let Some((step, time)) = summary.settled {
            println!(
                "settled at step {step}, t = {} (the kinetic energy of the particles' motion fell below \
                 loads.damping.settled of its largest)",
                human(time)
            );
        }
        println!(
            "output: {} ({} snapshots; open {} in ParaView), {} (one row per step)",
            out.display(),
            summary.snapshots.len(),
            summary.pvd.display(),
            summary.report.display()
        );
        if !summary.checkpoints.is_empty() {
            println!(
                "checkpoints: {} (last {})",
                summary.checkpoints.len(),
                summary
                    .checkpoints
                    .last()
                    .map_or(String::new(), |c| c.display().to_string())
            );
        }
    }
    println!(
        "particle-steps per second: {}",
        human(summary.particle_steps_per_second)
    );
}

/// What to say about a failed run: the error, and where its output is when the run had
/// started writing (a failed step; not a refused scene or output folder).
fn failure(error: sparse_mpm::MpmError, out: &Path) -> String {
    use sparse_mpm::MpmError;
    let before_output = matches!(
        error,
        MpmError::OutputExists { .. }
            | MpmError::OutputInUse { .. }
            | MpmError::OutputNotOwned { .. }
            | MpmError::InvalidScene { .. }
            | MpmError::InvalidOption { .. }
    );
    let written = out.join("report.csv").exists();
    if written && !before_output {
        format!("{error}\n(output written before the failure is in {})", out.display())
    } else {
        error.to_string()
    }
}

fn run(args: &RunArgs) -> Result<(), String> {
    let (scene, name) = load_scene(args.scene.as_deref(), &args.sets)?;
    let limits = if args.run.allow_large {
        limits::Limits::raised()
    } else {
        limits::Limits::default()
    };
    for warning in limits::scene_warnings(&scene, &limits) {
        eprintln!("warning: {warning}");
    }
    let out = args.output.out.clone().unwrap_or_else(|| Path::new("out").join(&name));
    let title = scene.title.clone().unwrap_or_else(|| name.clone());
    if !args.run.quiet {
        println!("scene: {title}");
    }
    let options = args.run.options(if args.output.overwrite {
        OutputPolicy::Overwrite
    } else {
        OutputPolicy::RefuseNonEmpty
    });
    let mut display = RunDisplay::new(args.run.quiet);
    let result = run_scene_with(&scene, &out, &options, |p| display.update(p));
    display.finish();
    let summary = result.map_err(|e| failure(e, &out))?;
    print_summary(&summary, &out, args.run.quiet);
    Ok(())
}

fn resume(args: &ResumeArgs) -> Result<(), String> {
    let options = args.run.options(OutputPolicy::Continue);
    let mut display = RunDisplay::new(args.run.quiet);
    let result =
        sparse_mpm_cli::run::resume_run(&args.checkpoint, args.out.as_deref(), &options, |p| display.update(p));
    display.finish();
    let (summary, out) = result.map_err(|e| e.to_string())?;
    print_summary(&summary, &out, args.run.quiet);
    Ok(())
}

fn matrices(args: &MatricesArgs) -> Result<(), String> {
    let (scene, name) = load_scene(Some(&args.scene), &args.sets)?;
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| Path::new("out").join(&name).join("matrices"));
    if !args.allow_large {
        let estimate = limits::estimate_scene(&scene);
        limits::check(&estimate, &limits::Limits::default(), &scene).map_err(|e| e.to_string())?;
    }
    if !args.overwrite {
        prepare_output(&out, OutputPolicy::RefuseNonEmpty).map_err(|e| e.to_string())?;
    }
    let files = write_matrices(&scene, &out).map_err(|e| e.to_string())?;
    for f in files {
        println!("{}", f.display());
    }
    Ok(())
}

fn print_scene(args: &SceneArgs) -> Result<(), String> {
    let _ = args.print;
    let (scene, _) = load_scene(args.scene.as_deref(), &args.sets)?;
    print!("{}", scene.to_toml_string().map_err(|e| e.to_string())?);
    Ok(())
}

fn check(args: &CheckArgs) -> Result<(), String> {
    let (scene, name) = load_scene(Some(&args.scene), &args.sets)?;
    let limits = if args.allow_large {
        limits::Limits::raised()
    } else {
        limits::Limits::default()
    };
    // Exactly what `mpm run` checks before its first step.
    let (sim, estimate) = limits::prepare_run(&scene, &limits).map_err(|e| e.to_string())?;
    let g = sim.grid();
    println!("{name}: {}", scene.title.as_deref().unwrap_or(""));
    println!(
        "grid {} × {} cells ({} nodes), {} particles in {} bodies",
        g.cells()[0],
        g.cells()[1],
        g.num_nodes(),
        sim.particles().len(),
        sim.bodies().len()
    );
    let schemes = &scene.schemes;
    // The Newmark step has its own order of operations: the update scheme is not used.
    let update = match schemes.integrator {
        sparse_mpm::simulation::Integrator::Explicit => schemes.update.to_string(),
        sparse_mpm::simulation::Integrator::Newmark(_) => "— (Newmark)".to_string(),
        sparse_mpm::simulation::Integrator::QuasiStatic(_) => "— (quasi-static)".to_string(),
    };
    println!(
        "shape {:#}, update {update}, transfer {:#}, mass velocity {:#} / acceleration {:#}",
        schemes.shape, schemes.transfer, schemes.mass.velocity, schemes.mass.acceleration
    );
    match schemes.integrator {
        sparse_mpm::simulation::Integrator::Explicit => {
            println!("stable time step at t = 0: {}", human(sim.stable_time_step()));
        }
        sparse_mpm::simulation::Integrator::Newmark(n) => println!(
            "integrator Newmark (β = {}, γ = {}), Newton to a relative residual of {:e} in at most {} iterations; no \
             stable-step limit; schemes.update and schemes.position_update are not used (the particles move by \
             the converged grid displacement)",
            n.beta, n.gamma, n.tolerance, n.max_iterations
        ),
        sparse_mpm::simulation::Integrator::QuasiStatic(q) => println!(
            "integrator quasi-static: the loads in {} increments, each brought to equilibrium by Newton to a \
             relative residual of {:e} in at most {} iterations; no mass enters; the particles are at rest after \
             every increment",
            q.load_steps, q.tolerance, q.max_iterations
        ),
    }
    println!("{estimate}");
    if scene.time.dt.is_none() && estimate.steps.is_some() {
        println!(
            "(steps counted with the CFL step of t = 0, {}, held to the end; the run's step follows the stable \
             step as it is re-estimated, so its count may differ)",
            human(scene.time.cfl.unwrap_or(0.5) * sim.stable_time_step())
        );
    }
    for warning in scene.warnings_for(sim.particles()) {
        eprintln!("warning: {warning}");
    }
    Ok(())
}

fn dispersion(a: &DispersionArgs) -> Result<(), String> {
    let curve = sparse_mpm_study::verification::dispersion::dispersion(
        a.shape,
        a.mass,
        a.acceleration_mass.unwrap_or(a.mass),
        a.particles_per_cell,
        a.samples,
        a.cells,
    )
    .map_err(|e| e.to_string())?;
    let mut text = String::from("theta,c_ratio\n");
    for p in curve {
        text.push_str(&format!("{},{}\n", p.theta, p.c_ratio));
    }
    let _ = std::io::stdout().lock().write_all(text.as_bytes());
    Ok(())
}

fn homework(json: bool) -> Result<(), String> {
    let answers = sparse_mpm_study::homework::solve().map_err(|e| e.to_string())?;
    let text = if json {
        serde_json::to_string_pretty(&answers.to_json()).expect("JSON values always serialize") + "\n"
    } else {
        answers.report()
    };
    let _ = std::io::stdout().lock().write_all(text.as_bytes());
    Ok(())
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Run(a) => run(a),
        Command::Resume(a) => resume(a),
        Command::Matrices(a) => matrices(a),
        Command::Check(a) => check(a),
        Command::Scene(a) => print_scene(a),
        Command::Homework { json } => homework(*json),
        Command::Study(a) => match study(a) {
            Ok(0) => Ok(()),
            Ok(status) => return ExitCode::from(status),
            Err(e) => Err(e),
        },
        Command::Bench(a) => bench(a),
        Command::Dispersion(a) => dispersion(a),
        Command::Render(a) => render(a),
        Command::Plot(a) => plot(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
