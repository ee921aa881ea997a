//! Timings of the whole time loop: `Simulation::step` on the block-in-box scene
//! (`scenes/block_in_box.toml`) refined so the block holds about 1e5 and 1e6 particles, with
//! bilinear and quadratic B-spline shape functions, and, measured in the same run for context,
//! `Operators::reassemble` alone on the same particles.
//!
//! ```text
//! cargo bench --bench engine               # P ≈ 1e5 and P ≈ 1e6
//! cargo bench --bench engine -- --quick    # P ≈ 1e4 and P ≈ 1e5, fewer repeats
//! cargo bench --bench engine -- --sizes 1e5,3e5
//! ```
//!
//! The scene keeps its 1 × 1 box, its block (0.3 × 0.3, 2 × 2 particles per cell), its materials,
//! boundaries and schemes (MUSL, APIC, lumped mass, CFL time step, re-sort every 50 steps); only
//! the grid is refined by a whole factor r (cell size 0.025 / r, 40 r × 40 r cells), so the block
//! stays aligned with the cells and holds 576 r² particles; r is the factor whose count is nearest
//! the size asked for. `--sizes 576` is the shipped scene itself.
//!
//! For each size and shape, several repeats; each repeat builds the simulation anew, takes a few
//! untimed warm-up steps, then times N consecutive steps, each step on its own, and its figure is
//! the mean of the N. Every repeat thus times the same steps of the same motion (the block falling
//! freely, before it reaches the floor), and the spread of the repeats is the machine's. N is a
//! multiple of the sort interval when that keeps a repeat under about 4 s (then every repeat
//! contains exactly one re-sorting step, as a long run does), otherwise the smallest count of at
//! least 3 steps that lasts a second; at most 100 either way. After each repeat, one sample of
//! `Operators::reassemble` on the simulation's current particle positions is taken (the harness of
//! `benches/common`: calls shorter than 20 ms are repeated within the sample), so the step and the
//! assembly are timed interleaved under the same load.

mod common;
use common::*;

use std::path::Path;
use std::time::{Duration, Instant};

use faer::Par;
use sparse_mpm::scene::{Geometry, Scene};
use sparse_mpm::simulation::Simulation;
use sparse_mpm::{Operators, ShapeFunction};

/// The shipped scene, found from the crate root.
const SCENE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/block_in_box.toml");

/// Untimed steps before the repeats (the first step sorts the particles and sizes the buffers).
const WARM_UP_STEPS: usize = 3;
/// A repeat lasts at least this long.
const MIN_REPEAT: Duration = Duration::from_secs(1);
/// A repeat spanning whole sort intervals may last up to this long.
const MAX_ALIGNED_REPEAT: Duration = Duration::from_secs(4);
/// Fewest steps in a repeat.
const MIN_STEPS: usize = 3;
/// Most steps in a repeat. Every repeat starts from a new simulation, so the timed steps are
/// always among its first `WARM_UP_STEPS + MAX_STEPS`: the block is falling freely and has not
/// yet reached the floor at any size. It also keeps them clear of a growth seen with bilinear
/// functions and APIC: a freely falling block's strain energy grows from round-off until a
/// particle inverts after about 230–250 steps (at r = 1 and r = 4).
const MAX_STEPS: usize = 100;

fn median(mut v: Vec<f64>) -> f64 {
    assert!(!v.is_empty());
    v.sort_by(f64::total_cmp);
    let k = v.len();
    if k % 2 == 1 {
        v[k / 2]
    } else {
        0.5 * (v[k / 2 - 1] + v[k / 2])
    }
}

/// Resident set size of this process in MiB (current, and the peak so far), read from
/// `/proc/self/status`; `None` where that file does not exist.
fn memory_mib() -> Option<(f64, f64)> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let field = |name: &str| -> Option<f64> {
        let line = status.lines().find(|l| l.starts_with(name))?;
        let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
        Some(kib / 1024.0)
    };
    Some((field("VmRSS:")?, field("VmHWM:")?))
}

fn memory_note() -> String {
    match memory_mib() {
        Some((rss, peak)) => format!("resident memory {rss:.0} MiB (peak so far {peak:.0} MiB)"),
        None => "resident memory not available on this system".into(),
    }
}

/// The scene refined by the whole factor `r`: same box, cell size divided by `r`.
fn refined(base: &Scene, r: usize, shape: ShapeFunction) -> Scene {
    let mut scene = base.clone();
    scene.grid.cell_size = base.grid.cell_size.map(|h| h / r as f64);
    scene.grid.cells = base.grid.cells.map(|c| c * r);
    scene.schemes.shape = shape;
    scene
}

/// The refinement factor whose particle count `base_count · r²` is nearest `target`.
fn refinement(base_count: usize, target: usize) -> usize {
    let r = ((target as f64 / base_count as f64).sqrt()).max(1.0);
    let (lo, hi) = ((r.floor() as usize).max(1), r.ceil() as usize);
    let count = |r: usize| base_count * r * r;
    if count(hi).abs_diff(target) < count(lo).abs_diff(target) {
        hi
    } else {
        lo
    }
}

/// Checks the refined block lies on cell boundaries, so the count scales exactly with r².
fn check_aligned(scene: &Scene) {
    let [ox, oy] = scene.grid.origin;
    let [hx, hy] = scene.grid.cell_size;
    let on_lines = |v: f64, o: f64, h: f64| {
        let c = (v - o) / h;
        (c - c.round()).abs() < 1e-6
    };
    for body in &scene.bodies {
        if let Geometry::Rectangle { min, max } = &body.geometry {
            assert!(
                on_lines(min[0], ox, hx)
                    && on_lines(max[0], ox, hx)
                    && on_lines(min[1], oy, hy)
                    && on_lines(max[1], oy, hy),
                "the block of body {:?} does not lie on the grid lines",
                body.name
            );
        }
    }
}

fn shape_label(shape: ShapeFunction) -> &'static str {
    match shape {
        ShapeFunction::Linear => "linear",
        ShapeFunction::QuadraticBSpline => "quadratic B-spline",
        _ => "other",
    }
}

/// One measured configuration.
struct Outcome {
    particles: usize,
    shape: ShapeFunction,
    /// Mean step time of each repeat, ms.
    repeat_ms: Vec<f64>,
    steps_per_repeat: usize,
    /// Single-step times of the steps that re-sorted the particles / of the others, ms.
    sorting_ms: Vec<f64>,
    plain_ms: Vec<f64>,
    reassemble: Stats,
}

impl Outcome {
    fn step_ms(&self) -> f64 {
        median(self.repeat_ms.clone())
    }
    fn range_ms(&self) -> (f64, f64) {
        let lo = self.repeat_ms.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = self.repeat_ms.iter().copied().fold(0.0, f64::max);
        (lo, hi)
    }
    fn particle_steps_per_second(&self) -> f64 {
        self.particles as f64 / (self.step_ms() * 1e-3)
    }
}

/// Steps `sim` once, checking the step succeeded and its state is finite; returns the time, whether
/// the step re-sorted the particles, and the step's strain energy.
fn timed_step(sim: &mut Simulation) -> (f64, bool, f64) {
    let interval = sim.options().sort_interval;
    let sorts = interval > 0 && sim.steps().is_multiple_of(interval);
    let start = Instant::now();
    let report = sim.step().expect("the step succeeds");
    let ms = start.elapsed().as_secs_f64() * 1e3;
    assert!(
        report.total_energy.is_finite() && report.max_speed.is_finite(),
        "step {}: non-finite state",
        report.step
    );
    (ms, sorts, report.strain_energy)
}

/// A freshly built simulation after the warm-up steps, the time of the build in seconds and of
/// the warm-up steps in ms.
fn fresh(scene: &Scene) -> (Simulation, f64, Vec<f64>) {
    let start = Instant::now();
    let mut sim = scene.build().expect("the refined scene builds");
    let build_s = start.elapsed().as_secs_f64();
    let warm = (0..WARM_UP_STEPS).map(|_| timed_step(&mut sim).0).collect();
    (sim, build_s, warm)
}

/// Steps per repeat for a step of `per_step` seconds (see the module docs).
fn steps_per_repeat(per_step: f64, interval: usize) -> usize {
    let min = MIN_REPEAT.as_secs_f64();
    if interval > 0 && interval <= MAX_STEPS && interval as f64 * per_step <= MAX_ALIGNED_REPEAT.as_secs_f64() {
        let k = (min / (interval as f64 * per_step)).ceil() as usize;
        interval * k.clamp(1, MAX_STEPS / interval)
    } else {
        ((min / per_step).ceil() as usize).clamp(MIN_STEPS, MAX_STEPS)
    }
}

fn run_config(base: &Scene, r: usize, shape: ShapeFunction, repeats: usize) -> Outcome {
    let scene = refined(base, r, shape);
    check_aligned(&scene);
    let grid = scene.grid().expect("a valid grid");

    // The first build's later warm-up steps set the number of steps per repeat.
    let (mut sim, build_s, warm) = fresh(&scene);
    let np = sim.particles().len();
    let mass0: f64 = sim.particles().mass.iter().sum();
    let per_step = median(warm[1..].to_vec()).max(1e-3) * 1e-3;
    let steps = steps_per_repeat(per_step, sim.options().sort_interval);

    // A separate `Operators` on the simulation's particles, for the assembly alone.
    let mut ops = Operators::default();
    let plan = {
        let p = sim.particles();
        ops.reassemble(&grid, shape, &p.x, &p.y).expect("inside the grid");
        warm_up(&mut || ops.reassemble(&grid, shape, &p.x, &p.y).expect("inside the grid"))
    };

    let (mut repeat_ms, mut sorting_ms, mut plain_ms, mut assembly) = (vec![], vec![], vec![], vec![]);
    let mut strain_max = 0.0f64;
    for repeat in 0..repeats {
        if repeat > 0 {
            // Every repeat times the same steps of a new simulation (drop the old one first).
            drop(sim);
            sim = fresh(&scene).0;
        }
        let mut total = 0.0;
        for _ in 0..steps {
            let (ms, sorted, strain) = timed_step(&mut sim);
            total += ms;
            strain_max = strain_max.max(strain);
            if sorted {
                sorting_ms.push(ms);
            } else {
                plain_ms.push(ms);
            }
        }
        repeat_ms.push(total / steps as f64);
        let p = sim.particles();
        assembly.push(sample(
            &mut || ops.reassemble(&grid, shape, &p.x, &p.y).expect("inside the grid"),
            plan.calls,
        ));
        let mass: f64 = p.mass.iter().sum();
        assert!((mass - mass0).abs() <= 1e-12 * mass0, "mass changed: {mass0} -> {mass}");
    }
    assert_eq!(
        ops.nnz(),
        sim.operators().nnz(),
        "the same pattern size as the step's operators"
    );

    // What the last simulation looks like after its steps.
    let p = sim.particles();
    let lowest = p.y.iter().copied().fold(f64::INFINITY, f64::min);
    let speed = (0..p.len()).map(|k| p.vx[k].hypot(p.vy[k])).fold(0.0, f64::max);
    let [cx, cy] = grid.cells();
    let [h, _] = grid.cell_size();
    println!();
    println!(
        "### P = {np}, {} (grid {cx} × {cy} cells of {h:.3e}, n = {} nodes, {} stored entries per operator)",
        shape_label(shape),
        grid.num_nodes(),
        ops.nnz(),
    );
    println!();
    println!(
        "Each repeat: build ({build_s:.2} s the first time), {WARM_UP_STEPS} warm-up steps, {steps} timed steps; \
         {repeats} repeats. After the last: step {}, t = {:.3e} s (mean dt {:.3e} s), lowest particle y = \
         {lowest:.4}, max speed {speed:.3} m/s, largest strain energy of a timed step {strain_max:.2e} J, mass \
         conserved; {}.",
        sim.steps(),
        sim.time(),
        sim.time() / sim.steps() as f64,
        memory_note(),
    );
    let stats = summarize(assembly, plan.calls);
    Outcome {
        particles: np,
        shape,
        repeat_ms,
        steps_per_repeat: steps,
        sorting_ms,
        plain_ms,
        reassemble: stats,
    }
}

fn print_outcome(o: &Outcome) {
    let (lo, hi) = o.range_ms();
    println!();
    println!("| quantity | value |");
    println!("|---|---:|");
    println!(
        "| step, median of the repeat means (ms) | **{}** |",
        common::fmt_ms(o.step_ms())
    );
    println!(
        "| particle-steps per second | **{:.3e}** |",
        o.particle_steps_per_second()
    );
    println!(
        "| range of the repeat means (ms), {} repeats × {} steps | {}–{} ({:+.0}% / {:+.0}% of the median) |",
        o.repeat_ms.len(),
        o.steps_per_repeat,
        common::fmt_ms(lo),
        common::fmt_ms(hi),
        100.0 * (lo / o.step_ms() - 1.0),
        100.0 * (hi / o.step_ms() - 1.0)
    );
    println!(
        "| single steps without re-sorting: median (ms), count | {}, {} |",
        common::fmt_ms(median(o.plain_ms.clone())),
        o.plain_ms.len()
    );
    if o.sorting_ms.is_empty() {
        println!("| steps that re-sorted the particles | none in the timed steps |");
    } else {
        println!(
            "| steps that re-sorted the particles: median (ms), count | {}, {} |",
            common::fmt_ms(median(o.sorting_ms.clone())),
            o.sorting_ms.len()
        );
    }
    println!(
        "| `Operators::reassemble` alone: median (min) ms, samples × calls | {} ({}), {} × {} |",
        common::fmt_ms(o.reassemble.median_ms),
        common::fmt_ms(o.reassemble.min_ms),
        o.reassemble.samples,
        o.reassemble.calls_per_sample
    );
    println!(
        "| reassembly / step | **{:.0}%** |",
        100.0 * o.reassemble.median_ms / o.step_ms()
    );
}

fn main() {
    faer::set_global_parallelism(Par::Seq);
    let args = common::args(1);
    let sizes = args.sizes_or(&[10_000, 100_000], &[100_000, 1_000_000]);
    let repeats = if args.quick { 3 } else { 5 };

    let base = Scene::load(Path::new(SCENE)).expect("the block-in-box scene loads");
    let base_count = base.particles().expect("the scene has particles").len();
    let s = &base.schemes;
    println!("# sparse-mpm time-loop benchmark: `Simulation::step` on the block-in-box scene");
    println!();
    println!(
        "Scene `scenes/block_in_box.toml` ({base_count} particles as shipped), grid refined by a whole factor r \
         (same 1 × 1 box and 0.3 × 0.3 block, 2 × 2 particles per cell, 576 r² particles); schemes as in the \
         scene apart from the shape function: {:?}, {:?}, mass {:#} / {:#}, CFL time step, re-sort every {} steps. \
         Step time = wall time of `Simulation::step` (everything in it, the step report included); each repeat \
         builds the simulation anew, takes 3 untimed steps and times N consecutive steps; the figure is the \
         median over the repeats of the mean step time. \
         Particle-steps per second = P / median step time. `Operators::reassemble` is timed alone on the \
         simulation's current particles with a separate `Operators`, one sample after each repeat. \
         Single-threaded (faer global parallelism `Par::Seq`; the crate's kernels are sequential) on 2 vCPUs \
         of a shared host.",
        s.update, s.transfer, s.mass.velocity, s.mass.acceleration, s.sort_interval
    );
    let total = Instant::now();
    let mut outcomes = Vec::new();
    for &target in &sizes {
        let r = refinement(base_count, target);
        for shape in [ShapeFunction::Linear, ShapeFunction::QuadraticBSpline] {
            let o = run_config(&base, r, shape, repeats);
            print_outcome(&o);
            outcomes.push(o);
        }
    }

    println!();
    println!("## Summary");
    println!();
    println!(
        "| P | shape | step ms (median) | range of repeats ms | particle-steps/s | reassemble ms | reassembly / step |"
    );
    println!("|---:|---|---:|---:|---:|---:|---:|");
    for o in &outcomes {
        let (lo, hi) = o.range_ms();
        println!(
            "| {} | {} | {} | {}–{} | {:.3e} | {} | {:.0}% |",
            o.particles,
            shape_label(o.shape),
            common::fmt_ms(o.step_ms()),
            common::fmt_ms(lo),
            common::fmt_ms(hi),
            o.particle_steps_per_second(),
            common::fmt_ms(o.reassemble.median_ms),
            100.0 * o.reassemble.median_ms / o.step_ms()
        );
    }
    println!();
    println!(
        "Total benchmark time: {:.1} s; {}.",
        total.elapsed().as_secs_f64(),
        memory_note()
    );
}
