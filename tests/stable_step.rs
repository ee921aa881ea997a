//! The stable step holds until the next estimate: a random particle layout falling into a walled
//! box at 0.9 of the reported stable step runs 2,000 steps with bounded energy for every mass
//! (linear and quadratic B-spline functions); the singularity policies carry a one-particle-
//! per-cell two-disk impact to its end; series:32 and blends run the two disks at the default
//! Courant number. Every run uses the default mass options but the scheme (and the policy).

use sparse_mpm::bench::{falling_block, BenchSpec};
use sparse_mpm::mass::MassScheme;
use sparse_mpm::scene::Scene;
use sparse_mpm::simulation::{TimeStep, Transfer, UpdateScheme, DEFAULT_STABILITY_INTERVAL};
use sparse_mpm::ShapeFunction;

/// Particles of the falling block: 12 × 12 cells, the block 6 × 6 cells, 4 per cell.
const PARTICLES: usize = 144;

/// The largest rise of the total energy allowed over the run, relative to its initial value
/// (kinetic plus gravitational). Unstable runs gain 50% to 560% or invert a particle
/// (docs/simulation.md); stable ones stay within 11%.
const ENERGY_RISE: f64 = 0.2;

/// The falling block at Courant number 0.9 of the reported stable step for 2,000 steps: the
/// largest relative rise of the total energy, or the error that stopped it.
fn falling_block_rise(shape: ShapeFunction, mass: MassScheme) -> Result<f64, String> {
    falling_block_rise_of(PARTICLES, shape, mass)
}

/// [`falling_block_rise`] with `particles` particles.
fn falling_block_rise_of(particles: usize, shape: ShapeFunction, mass: MassScheme) -> Result<f64, String> {
    falling_block_rise_seeded(particles, BenchSpec::default().seed, 2000, shape, mass)
}

/// [`falling_block_rise_of`] with the positions drawn from `seed`, for `steps` steps.
fn falling_block_rise_seeded(
    particles: usize,
    seed: u64,
    steps: usize,
    shape: ShapeFunction,
    mass: MassScheme,
) -> Result<f64, String> {
    let spec = BenchSpec {
        shape,
        mass,
        transfer: Transfer::Flip,
        update: UpdateScheme::Musl,
        seed,
        ..BenchSpec::default()
    };
    let courant = TimeStep::Cfl { number: 0.9 };
    let mut sim = falling_block(particles, &spec, courant, DEFAULT_STABILITY_INTERVAL).map_err(|e| e.to_string())?;
    let mut first = None;
    let mut rise = 0.0f64;
    for _ in 0..steps {
        let r = sim.step().map_err(|e| format!("step {}: {e}", sim.steps()))?;
        let e0: f64 = *first.get_or_insert(r.total_energy);
        rise = rise.max((r.total_energy - e0) / e0.abs());
        if !r.total_energy.is_finite() || r.max_speed > 1e3 {
            return Err(format!("step {}: run-away (speed {})", r.step, r.max_speed));
        }
    }
    Ok(rise)
}

fn check_falling_block(shape: ShapeFunction) {
    let masses = [
        MassScheme::Lumped,
        MassScheme::Consistent,
        "cg".parse().unwrap(),
        MassScheme::TruncatedSeries { k: 8 },
        MassScheme::TruncatedSeries { k: 32 },
    ];
    let mut failures = Vec::new();
    for mass in masses {
        match falling_block_rise(shape, mass) {
            Ok(rise) => {
                println!("{shape} {mass}: largest energy rise {:+.2}%", 100.0 * rise);
                if rise > ENERGY_RISE {
                    failures.push(format!("{mass}: energy rose by {:.1}%", 100.0 * rise));
                }
            }
            Err(e) => failures.push(format!("{mass}: {e}")),
        }
    }
    assert!(failures.is_empty(), "{shape} at 0.9 of the stable step: {failures:?}");
}

#[test]
fn a_random_block_falling_into_a_box_at_0_9_of_the_stable_step_stays_bounded_linear() {
    check_falling_block(ShapeFunction::Linear);
}

#[test]
fn a_random_block_falling_into_a_box_at_0_9_of_the_stable_step_stays_bounded_quadratic() {
    check_falling_block(ShapeFunction::QuadraticBSpline);
}

/// The shipped two-disk scene with `mass` in both solves, `particles_per_cell` per axis and the
/// singularity policy `policy`, run to its end at the scene's Courant number: the largest
/// `|E(t) − E(0)| / KE(0)`, and whether a solve substituted another mass.
fn two_disks(mass: &str, particles_per_cell: usize, policy: &str) -> (f64, bool) {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/two_disks.toml")).unwrap();
    let text = text
        .replace(
            "mass = { velocity = \"lumped\", acceleration = \"lumped\" }",
            &format!("mass = {{ velocity = \"{mass}\", acceleration = \"{mass}\", singularity = \"{policy}\" }}"),
        )
        .replace(
            "particles_per_cell = 2",
            &format!("particles_per_cell = {particles_per_cell}"),
        );
    let scene = Scene::from_toml_str(&text).unwrap();
    let mut sim = scene.build().unwrap();
    let (mut first, mut worst, mut substituted) = (None, 0.0f64, false);
    sim.run_until(scene.time.end, |_, r| {
        let (e0, k0) = *first.get_or_insert((r.total_energy, r.kinetic_energy));
        worst = worst.max((r.total_energy - e0).abs() / k0);
        substituted |= [&r.velocity_solve, &r.acceleration_solve]
            .iter()
            .any(|s| s.outcome != sparse_mpm::mass::SolveOutcome::Solved);
        Ok(())
    })
    .unwrap_or_else(|e| panic!("{mass}, {particles_per_cell} × {particles_per_cell} per cell, {policy}: {e}"));
    assert!(
        (sim.time() - scene.time.end).abs() < 1e-9,
        "{mass}: stopped at {}",
        sim.time()
    );
    (worst, substituted)
}

/// One particle per cell: the consistent mass is singular at times and nearly singular
/// (`NEARLY_SINGULAR_RATIO`) at others; each policy carries the two disks to the end, and the
/// energy moves by less than 2.5 times what the lumped mass moves on the same particles (the
/// lumped mass loses energy in the impact, the consistent one gains). Measured: fallback 12.9%,
/// regularize:0.1 6.8%, lumped 6.3%. The figure is sensitive to round-off in this nearly
/// singular case: before the kernels formed fused multiply-adds, 10.6% and 9.5% (lumped 6.3%);
/// before the policies acted on a nearly singular mass, 6.6% and 6.6%, in 12,000 steps against
/// the lumped mass's 247; the same scenes by `mpm run`, whose steps land on the snapshot times:
/// 5.75% and 6.62% (lumped 6.36%). A run-away grows without bound.
#[test]
fn one_particle_per_cell_runs_the_two_disks_to_the_end_under_each_singularity_policy() {
    let (lumped, _) = two_disks("lumped", 1, "error");
    for policy in ["fallback_to_lumped", "regularize:0.1"] {
        let (worst, substituted) = two_disks("consistent", 1, policy);
        println!(
            "{policy}: largest |ΔE| / KE0 {:.2}% (lumped {:.2}%), substituted {substituted}",
            100.0 * worst,
            100.0 * lumped
        );
        assert!(
            substituted,
            "{policy}: the policy never acted, so the test does not test it"
        );
        assert!(
            worst <= 2.5 * lumped,
            "{policy}: the energy moved by {:.2}% of KE0, the lumped mass's by {:.2}%",
            100.0 * worst,
            100.0 * lumped
        );
    }
}

#[test]
fn series_32_and_blends_run_the_two_disks_at_the_default_courant_number() {
    for mass in ["series:32", "blended:0.5", "blended:0.9"] {
        let (worst, _) = two_disks(mass, 2, "error");
        println!("{mass}: largest |ΔE| / KE0 {:.2}%", 100.0 * worst);
        assert!(worst < 0.1, "{mass}: the energy moved by {:.1}% of KE0", 100.0 * worst);
    }
}

#[test]
fn the_singular_mass_message_names_the_scene_keys_and_the_kernel() {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/two_disks.toml")).unwrap();
    for (shape, word, not) in [
        ("linear", "bilinear cell", "B-spline"),
        ("quadratic_bspline", "quadratic B-spline", "bilinear"),
    ] {
        let text = text
            .replace("shape = \"linear\"", &format!("shape = \"{shape}\""))
            .replace("origin = [0.0, 0.0]", "origin = [-0.1, -0.1]")
            .replace("cells = [20, 20]", "cells = [24, 24]")
            .replace(
                "mass = { velocity = \"lumped\", acceleration = \"lumped\" }",
                "mass = { velocity = \"consistent\", acceleration = \"consistent\", stabilization = \"none\" }",
            )
            .replace("particles_per_cell = 2", "particles_per_cell = 1");
        let scene = Scene::from_toml_str(&text).unwrap();
        let message = match scene.build().and_then(|mut s| s.step().map(|_| ())) {
            Err(e) => e.to_string(),
            Ok(()) => panic!("{shape}: one particle per cell with the plain consistent mass must be singular"),
        };
        for key in [
            "schemes.mass.singularity = \"fallback_to_lumped\"",
            "{ regularize = { epsilon = 0.1 } }",
            word,
        ] {
            assert!(message.contains(key), "{shape}: `{key}` missing from: {message}");
        }
        assert!(!message.contains(not), "{shape}: `{not}` in: {message}");
        assert!(
            !message.contains("FallbackToLumped or"),
            "{shape}: Rust names as the remedy: {message}"
        );
    }
}

/// The consistent mass's estimate must find a new top mode wherever it appears: with 256
/// particles the linear block ran at 0.9 of an estimate started from the previous estimate's
/// mode until a particle inverted at step 1914 (measured); with the cold start it rises by
/// +2.5% (docs/simulation.md).
#[test]
fn the_consistent_mass_estimate_finds_new_modes_on_a_larger_random_block() {
    for mass in [MassScheme::Consistent, "cg".parse().unwrap()] {
        let rise = falling_block_rise_of(256, ShapeFunction::Linear, mass).unwrap();
        println!(
            "linear {mass}, 256 particles: largest energy rise {:+.2}%",
            100.0 * rise
        );
        assert!(rise <= ENERGY_RISE, "{mass}: energy rose by {:.1}%", 100.0 * rise);
    }
}

/// The guard between two estimates of the update bound runs at every step, however little the
/// particles moved: a node that a particle barely reaches stiffens as `1/ε` with the particle's
/// distance `ε` from the grid line, so the smallest moves raise the top frequency most. With a
/// guard only after 0.01 cell widths of travel, the 256-particle block of these seeds inverted a
/// particle at 0.9 of the stable step (steps 955 and 310; measured); with it each stays within
/// +0.6% of its energy.
#[test]
fn the_guard_catches_a_node_stiffening_between_estimates() {
    for seed in [6, 11] {
        let rise = falling_block_rise_seeded(256, seed, 1000, ShapeFunction::Linear, MassScheme::Consistent)
            .unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        println!(
            "linear consistent, 256 particles, seed {seed}: largest energy rise {:+.2}%",
            100.0 * rise
        );
        assert!(rise <= ENERGY_RISE, "seed {seed}: energy rose by {:.1}%", 100.0 * rise);
    }
}

/// The masses estimated by the update bound (consistent, cg) and by Lanczos (series, blends)
/// at 0.9 of the reported step on random blocks of `sizes` particles, seeds `seeds`, both
/// shapes: the failures (a run-away, an inverted particle, or an energy rise above
/// [`ENERGY_RISE`]).
fn random_blocks(sizes: &[usize], seeds: std::ops::Range<u64>, masses: &[&str]) -> Vec<String> {
    let mut failures = Vec::new();
    for shape in [ShapeFunction::Linear, ShapeFunction::QuadraticBSpline] {
        for mass in masses {
            let scheme: MassScheme = mass.parse().unwrap();
            for &n in sizes {
                let mut worst = 0.0f64;
                for seed in seeds.clone() {
                    match falling_block_rise_seeded(n, seed, 2000, shape, scheme) {
                        Ok(rise) if rise <= ENERGY_RISE => worst = worst.max(rise),
                        Ok(rise) => failures.push(format!(
                            "{shape} {mass} {n} seed {seed}: energy rose by {:.1}%",
                            100.0 * rise
                        )),
                        Err(e) => failures.push(format!("{shape} {mass} {n} seed {seed}: {e}")),
                    }
                }
                println!(
                    "{shape} {mass} {n} particles: largest energy rise {:+.2}%",
                    100.0 * worst
                );
            }
        }
    }
    failures
}

/// Three seeds of the 256-particle block for the masses the 144-particle tests above do not run
/// (the full set of 16 seeds, 256 and 1,024 particles and every mass is the ignored test below).
#[test]
fn cg_and_a_blend_hold_on_random_blocks_of_256_particles() {
    let failures = random_blocks(&[256], 0..3, &["cg", "blended:0.5"]);
    assert!(failures.is_empty(), "{failures:?}");
}

/// 16 seeds of the random block with 256 and 1,024 particles, linear and quadratic B-splines,
/// the consistent mass, cg, series:8, series:32 and blended:0.5, each at 0.9 of its reported
/// step for 2,000 steps: no run-away, no inverted particle, an energy rise under 20%
/// (docs/simulation.md, "The time step", quotes the largest rises). About 25 minutes on one
/// core in release:
///
/// ```text
/// cargo test --release --test stable_step -- --ignored
/// ```
#[test]
#[ignore = "about 25 minutes in release; run with --ignored"]
fn sixteen_random_blocks_of_256_and_1024_particles_hold_for_every_non_lumped_mass() {
    let masses = ["consistent", "cg", "series:8", "series:32", "blended:0.5"];
    let failures = random_blocks(&[256, 1024], 0..16, &masses);
    assert!(failures.is_empty(), "{failures:?}");
}
