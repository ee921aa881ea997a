//! `mpm`: run scene files, export the matrices of a scene, print the worked problem.
//!
//! ```text
//! mpm run [SCENE.toml] [--out DIR] [--end-time T] [--steps N] [--quiet]
//! mpm matrices SCENE.toml [--out DIR]
//! mpm check SCENE.toml
//! mpm homework [--json]
//! mpm study [--out DIR] [--spec STUDY.toml] [--parts a,b] [--quick]
//! mpm bench [--shape S] [--mass M] [--transfer T] [--update U] [--particles N[,N…]]
//!           [--threads T] [--steps S] [--reps R] [--profile]
//! ```

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use sparse_mpm::bench::names;
use sparse_mpm::run::{run_scene, write_matrices, Progress, RunLimits};
use sparse_mpm::scene::Scene;

/// The scene `mpm run` uses when none is given.
const DEFAULT_SCENE: (&str, &str) = ("two_disks", include_str!("../../scenes/two_disks.toml"));

const USAGE: &str = "\
mpm: the 2D material point method in sparse-matrix form

USAGE:
    mpm run [SCENE.toml] [--out DIR] [--end-time T] [--steps N] [--quiet]
        Run a scene (default: the built-in two-disk impact, scenes/two_disks.toml).
        Writes DIR/particles_*.vtp, DIR/particles.pvd (open it in ParaView),
        DIR/report.csv (one row per step) and DIR/scene.toml.
        DIR defaults to out/<scene name>.
    mpm matrices SCENE.toml [--out DIR]
        Write N, Gx, Gy, M (consistent mass) and mL (lumped mass) of the initial
        configuration as Matrix Market files, with nodes.csv and particles.csv.
        DIR defaults to out/<scene name>/matrices.
    mpm check SCENE.toml
        Read and validate a scene; print its size and stable time step.
    mpm homework [--json]
        Print the answers of the worked problem (the seed assignment).
    mpm study [--out DIR] [--spec STUDY.toml] [--parts a,b] [--quick]
        Run the verification problems over a matrix of choices (mass schemes,
        transfers, shape functions, resolutions) and write DIR/report.md with its
        PNG plots and DIR/runs.csv (every run). DIR defaults to out/study.
        Parts: frequency, bar_energy, convergence, energy, time_step, cantilever,
        single_point (default: all). --quick: smaller grids, a few seconds.
        A STUDY.toml sets any of the study's keys (docs/verification.md).
    mpm bench [--shape S] [--mass M] [--transfer T] [--update U] [--particles N[,N...]]
              [--threads T] [--steps S] [--reps R] [--profile]
        Time the peers' benchmark problem (random block falling into a walled unit
        box, neo-Hookean, about 4 particles per cell; docs/performance.md) over whole
        explicit steps, set-up excluded. Defaults: quadratic, lumped, apic, usl,
        8192,65536,262144,1048576 particles, 1 thread, max(20, min(2000, 2e7/N))
        steps, 5 repetitions. Prints min/median/max per particle count, then
        `particle-steps/s: <median>` and `peak bytes/particle: <value>`.
        Shapes: linear, gimp[:half_width], quadratic, cubic. Masses: lumped,
        consistent, blended:g, series:k, cg[:tol]. Transfers: pic, flip, apic,
        blend:a, xpic:k, fmpm:k. Updates: usf, usl, musl. --profile: the share of
        each phase of the step.
    mpm help
        This text.
";

struct Args {
    positional: Vec<String>,
    out: Option<PathBuf>,
    end_time: Option<f64>,
    steps: Option<usize>,
    quiet: bool,
    json: bool,
    spec: Option<PathBuf>,
    parts: Option<String>,
    quick: bool,
    bench: sparse_mpm::bench::BenchSpec,
}

fn parse(args: &[String]) -> Result<Args, String> {
    let mut a = Args {
        positional: Vec::new(),
        out: None,
        end_time: None,
        steps: None,
        quiet: false,
        json: false,
        spec: None,
        parts: None,
        quick: false,
        bench: sparse_mpm::bench::BenchSpec::default(),
    };
    let mut it = args.iter();
    while let Some(arg) = it.next() {
        let mut value = |name: &str| it.next().cloned().ok_or_else(|| format!("{name} needs a value"));
        match arg.as_str() {
            "--out" | "-o" => a.out = Some(PathBuf::from(value("--out")?)),
            "--end-time" => {
                let v = value("--end-time")?;
                a.end_time = Some(
                    v.parse::<f64>()
                        .ok()
                        .filter(|t| t.is_finite() && *t > 0.0)
                        .ok_or_else(|| format!("--end-time {v}: expected a positive number"))?,
                );
            }
            "--steps" => {
                let v = value("--steps")?;
                a.steps = Some(v.parse().map_err(|_| format!("--steps {v}: expected a whole number"))?);
            }
            "--quiet" | "-q" => a.quiet = true,
            "--json" => a.json = true,
            "--spec" => a.spec = Some(PathBuf::from(value("--spec")?)),
            "--parts" => a.parts = Some(value("--parts")?),
            "--quick" => a.quick = true,
            "--profile" => a.bench.profile = true,
            "--shape" => a.bench.shape = names::shape(&value("--shape")?).map_err(|e| format!("--shape: {e}"))?,
            "--mass" => a.bench.mass = names::mass(&value("--mass")?).map_err(|e| format!("--mass: {e}"))?,
            "--transfer" => {
                a.bench.transfer = names::transfer(&value("--transfer")?).map_err(|e| format!("--transfer: {e}"))?
            }
            "--update" => a.bench.update = names::update(&value("--update")?).map_err(|e| format!("--update: {e}"))?,
            "--particles" => {
                let v = value("--particles")?;
                a.bench.particles = v
                    .split(',')
                    .map(|n| {
                        let n = n.trim().replace('_', "");
                        n.parse::<f64>()
                            .ok()
                            .filter(|x| x.fract() == 0.0 && *x >= 16.0 && *x <= 1e9)
                            .map(|x| x as usize)
                            .ok_or_else(|| format!("--particles {v}: `{n}` is not a count between 16 and 1e9"))
                    })
                    .collect::<Result<_, _>>()?;
            }
            "--threads" => {
                let v = value("--threads")?;
                a.bench.threads = v
                    .parse()
                    .ok()
                    .filter(|t| *t >= 1)
                    .ok_or_else(|| format!("--threads {v}: expected a whole number of at least 1"))?;
            }
            "--dt" => {
                let v = value("--dt")?;
                a.bench.dt = Some(
                    v.parse()
                        .ok()
                        .filter(|d: &f64| d.is_finite() && *d > 0.0)
                        .ok_or_else(|| format!("--dt {v}: expected a positive number"))?,
                );
            }
            "--reps" => {
                let v = value("--reps")?;
                a.bench.reps = v
                    .parse()
                    .ok()
                    .filter(|r| *r >= 1)
                    .ok_or_else(|| format!("--reps {v}: expected a whole number of at least 1"))?;
            }
            s if s.starts_with('-') => return Err(format!("unknown option `{s}`")),
            s => a.positional.push(s.to_string()),
        }
    }
    Ok(a)
}

/// The scene named on the command line, or the built-in default; and its name.
fn load_scene(args: &Args, allow_default: bool) -> Result<(Scene, String), String> {
    match args.positional.first() {
        Some(path) => {
            let path = Path::new(path);
            let scene = Scene::load(path).map_err(|e| e.to_string())?;
            let name = path
                .file_stem()
                .map_or("scene".into(), |s| s.to_string_lossy().into_owned());
            Ok((scene, name))
        }
        None if allow_default => {
            let scene = Scene::from_toml_str(DEFAULT_SCENE.1).map_err(|e| format!("built-in scene: {e}"))?;
            Ok((scene, DEFAULT_SCENE.0.to_string()))
        }
        None => Err("a scene file is required".into()),
    }
}

/// A one-line progress bar on stderr, redrawn at most every 0.2 s, shown once a run has taken
/// more than a second.
struct Bar {
    enabled: bool,
    last: Option<Instant>,
}

impl Bar {
    fn update(&mut self, p: &Progress) {
        if !self.enabled || p.elapsed < Duration::from_secs(1) {
            return;
        }
        if self.last.is_some_and(|t| t.elapsed() < Duration::from_millis(200)) {
            return;
        }
        self.last = Some(Instant::now());
        let fraction = (p.time / p.end_time).clamp(0.0, 1.0);
        let width = 30;
        let filled = (fraction * width as f64).round() as usize;
        let eta = if fraction > 0.0 {
            p.elapsed.as_secs_f64() * (1.0 - fraction) / fraction
        } else {
            0.0
        };
        eprint!(
            "\r[{}{}] {:5.1}%  t = {:.4e} / {:.4e}  step {}  eta {:.0} s   ",
            "#".repeat(filled),
            " ".repeat(width - filled),
            100.0 * fraction,
            p.time,
            p.end_time,
            p.steps,
            eta
        );
    }

    fn finish(&self) {
        if self.last.is_some() {
            eprintln!();
        }
    }
}

fn run(args: &Args) -> Result<(), String> {
    let (scene, name) = load_scene(args, true)?;
    let out = args.out.clone().unwrap_or_else(|| Path::new("out").join(&name));
    let title = scene.title.clone().unwrap_or_else(|| name.clone());
    if !args.quiet {
        println!("scene: {title}");
    }
    let mut bar = Bar {
        enabled: !args.quiet && std::io::stderr().is_terminal(),
        last: None,
    };
    let limits = RunLimits {
        end_time: args.end_time,
        max_steps: args.steps,
    };
    let mut warned = false;
    let result = run_scene(&scene, &out, limits, |p| {
        if p.dt > p.stable_time_step && !warned {
            warned = true;
            bar.finish();
            eprintln!(
                "warning: step {}: the fixed time step {:e} exceeds the stable step {:e} ({:.1}% over); the run \
                 goes on because `allow_unstable = true`",
                p.steps,
                p.dt,
                p.stable_time_step,
                100.0 * (p.dt / p.stable_time_step - 1.0)
            );
        }
        bar.update(p)
    });
    bar.finish();
    let summary = result.map_err(|e| format!("{e}\n(output written so far is in {})", out.display()))?;
    if !args.quiet {
        println!(
            "{} particles, {} steps to t = {:.6e} in {:.2} s ({:.2} s stepping)",
            summary.particles,
            summary.steps,
            summary.time,
            summary.total.as_secs_f64(),
            summary.stepping.as_secs_f64()
        );
        if let Some(r) = &summary.last {
            println!(
                "final: kinetic {:.6e}, strain {:.6e}, total {:.6e}, momentum ({:.6e}, {:.6e})",
                r.kinetic_energy, r.strain_energy, r.total_energy, r.momentum[0], r.momentum[1]
            );
        }
        println!(
            "output: {} ({} snapshots; open {} in ParaView), {} (one row per step)",
            out.display(),
            summary.snapshots.len(),
            summary.pvd.display(),
            summary.report.display()
        );
    }
    println!("particle-steps per second: {:.4e}", summary.particle_steps_per_second);
    Ok(())
}

fn matrices(args: &Args) -> Result<(), String> {
    let (scene, name) = load_scene(args, false)?;
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| Path::new("out").join(&name).join("matrices"));
    let files = write_matrices(&scene, &out).map_err(|e| e.to_string())?;
    for f in files {
        println!("{}", f.display());
    }
    Ok(())
}

fn check(args: &Args) -> Result<(), String> {
    let (scene, name) = load_scene(args, false)?;
    let sim = scene.build().map_err(|e| e.to_string())?;
    let g = sim.grid();
    println!("{name}: {}", scene.title.as_deref().unwrap_or(""));
    println!(
        "grid {} x {} cells ({} nodes), {} particles in {} bodies",
        g.cells()[0],
        g.cells()[1],
        g.num_nodes(),
        sim.particles().len(),
        sim.bodies().len()
    );
    println!(
        "shape {}, update {:?}, transfer {:?}, mass velocity {} / acceleration {}",
        scene.schemes.shape.name(),
        scene.schemes.update,
        scene.schemes.transfer,
        scene.schemes.mass.velocity.label(),
        scene.schemes.mass.acceleration.label()
    );
    println!("stable time step at t = 0: {:.6e}", sim.stable_time_step());
    Ok(())
}

fn study(args: &Args) -> Result<(), String> {
    use sparse_mpm::study::{run_study, Part, StudySpec};
    let mut spec = match &args.spec {
        Some(path) => {
            let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
            StudySpec::from_toml_str(&text).map_err(|e| format!("{}: {e}", path.display()))?
        }
        None if args.quick => StudySpec::quick(),
        None => StudySpec::default(),
    };
    if let Some(list) = &args.parts {
        spec.parts = list
            .split(',')
            .map(|name| {
                Part::ALL
                    .into_iter()
                    .find(|p| p.name() == name.trim())
                    .ok_or_else(|| format!("--parts: unknown part `{name}`"))
            })
            .collect::<Result<_, _>>()?;
    }
    let out = args.out.clone().unwrap_or_else(|| Path::new("out").join("study"));
    let terminal = !args.quiet && std::io::stderr().is_terminal();
    let start = Instant::now();
    let summary = run_study(&spec, &out, |p| {
        if terminal {
            let width = 30;
            let filled = (width * p.done).checked_div(p.total).unwrap_or(width);
            eprint!(
                "\r[{}{}] {}/{} {:.0} s  {:<70}",
                "#".repeat(filled),
                " ".repeat(width - filled),
                p.done,
                p.total,
                start.elapsed().as_secs_f64(),
                p.current.chars().take(70).collect::<String>()
            );
            if p.done == p.total {
                eprintln!();
            }
        }
    })
    .map_err(|e| e.to_string())?;
    let failed = summary.runs.iter().filter(|r| r.outcome.is_err()).count();
    if !args.quiet {
        println!(
            "{} runs ({failed} failed) in {:.0} s; report: {}, {} plots, every run: {}",
            summary.runs.len(),
            start.elapsed().as_secs_f64(),
            summary.report.display(),
            summary.plots.len(),
            summary.csv.display()
        );
    }
    Ok(())
}

fn bench(args: &Args) -> Result<(), String> {
    let mut spec = args.bench.clone();
    spec.steps = args.steps;
    if spec.steps == Some(0) {
        return Err("--steps 0: time at least one step".into());
    }
    println!(
        "# sparse-mpm {}: shape {}, mass {}, transfer {}, update {:?}, {} thread(s), f64",
        env!("CARGO_PKG_VERSION"),
        spec.shape.name(),
        spec.mass.label(),
        spec.transfer.name(),
        spec.update,
        spec.threads
    );
    println!("particles,n_grid,steps,dt,reps,setup_s,min_psps,median_psps,max_psps,peak_bytes_per_particle");
    let rows = sparse_mpm::bench::run(&spec, |row| {
        let [min, med, max] = row.rate_summary();
        println!(
            "{},{},{},{:.4e},{},{:.3},{min:.4e},{med:.4e},{max:.4e},{}",
            row.particles,
            row.n_grid,
            row.steps,
            row.dt,
            row.seconds.len(),
            row.setup_seconds,
            row.peak_bytes_per_particle.map_or("".into(), |b| format!("{b:.0}"))
        );
        let _ = std::io::stdout().flush();
    })
    .map_err(|e| e.to_string())?;
    for row in &rows {
        let [_, med, _] = row.rate_summary();
        println!("N = {}: particle-steps/s: {med:.4e}", row.particles);
        match row.peak_bytes_per_particle {
            Some(b) => println!("N = {}: peak bytes/particle: {b:.0}", row.particles),
            None => println!(
                "N = {}: peak bytes/particle: not measured on this system",
                row.particles
            ),
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

fn homework(args: &Args) -> Result<(), String> {
    let answers = sparse_mpm::homework::solve().map_err(|e| e.to_string())?;
    let text = if args.json {
        serde_json::to_string_pretty(&answers.to_json()).expect("JSON values always serialize") + "\n"
    } else {
        answers.report()
    };
    let _ = std::io::stdout().lock().write_all(text.as_bytes());
    Ok(())
}

fn main() -> ExitCode {
    let all: Vec<String> = std::env::args().skip(1).collect();
    let Some((command, rest)) = all.split_first() else {
        eprint!("{USAGE}");
        return ExitCode::from(2);
    };
    let args = match parse(rest) {
        Ok(a) => a,
        Err(e) => {
            eprintln!("error: {e}\n\n{USAGE}");
            return ExitCode::from(2);
        }
    };
    let result = match command.as_str() {
        "run" => run(&args),
        "matrices" => matrices(&args),
        "check" => check(&args),
        "homework" => homework(&args),
        "study" => study(&args),
        "bench" => bench(&args),
        "help" | "--help" | "-h" => {
            print!("{USAGE}");
            Ok(())
        }
        other => Err(format!("unknown command `{other}`\n\n{USAGE}")),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
