//! An elastic block dropped onto a slip floor keeps its total energy (kinetic, strain and
//! gravitational above the floor) with the consistent mass and its default stabilisation: the
//! linear-extension penalty fades in as a node enters a particle's support (its onset ψ₀), so
//! the stabilised mass does not pump energy into a body bouncing and settling on the floor
//! (docs/mass.md, "Energy on a floor").

use sparse_mpm::scene::Scene;

/// The dropped block: a 0.3 m square of neo-Hookean rubber (E = 1 MPa, ν = 0.3, 1,000 kg/m³),
/// 2 × 2 particles per cell of 0.025 m, released from rest 0.55 m above the floor of a box with
/// slip walls; MUSL, FLIP, the Courant number 0.5, 1.5 s. `shape`, `transfer` and the masses of
/// the velocity and acceleration solves are the parameters.
fn dropped_block(shape: &str, transfer: &str, velocity: &str, acceleration: &str) -> String {
    format!(
        r#"
[grid]
origin = [0.0, 0.0]
cell_size = [0.025, 0.025]
cells = [40, 40]

[schemes]
shape = "{shape}"
update = "musl"
transfer = "{transfer}"
mass = {{ velocity = "{velocity}", acceleration = "{acceleration}" }}

[time]
end = 1.5
cfl = 0.5

[loads]
gravity = [0.0, -9.81]

[[bodies]]
name = "block"
material = {{ model = "neo_hookean", youngs_modulus = 1.0e6, poisson_ratio = 0.3 }}
density = 1000.0
particles_per_cell = 2
velocity = [0.0, 0.0]
geometry = {{ rectangle = {{ min = [0.3, 0.55], max = [0.6, 0.85] }} }}

[[boundaries]]
edge = "bottom"
condition = "slip"

[[boundaries]]
edge = "left"
condition = "slip"

[[boundaries]]
edge = "right"
condition = "slip"
"#
    )
}

/// The largest rise and the largest change of the total energy over the run, relative to its
/// value at the first step.
fn energy_changes(text: &str) -> (f64, f64) {
    let scene = Scene::from_toml_str(text).unwrap();
    let mut sim = scene.build().unwrap();
    let (mut first, mut rise, mut change) = (None, 0.0f64, 0.0f64);
    sim.run_until(scene.time.end, |_, r| {
        let e0: f64 = *first.get_or_insert(r.total_energy);
        rise = rise.max((r.total_energy - e0) / e0);
        change = change.max(((r.total_energy - e0) / e0).abs());
        Ok(())
    })
    .unwrap();
    assert!((sim.time() - scene.time.end).abs() < 1e-9, "stopped at {}", sim.time());
    (rise, change)
}

/// Quadratic B-splines, FLIP, MUSL, the Courant number 0.5, the default stabilisation: within
/// 3% of the starting energy over 1.5 s. Measured: 1.1% (the lumped mass 3.6%); before the
/// penalty's onset the consistent mass gained 17% and kept gaining.
#[test]
fn a_block_dropped_on_a_floor_keeps_its_energy_with_the_consistent_mass() {
    let (_, change) = energy_changes(&dropped_block("quadratic_bspline", "flip", "consistent", "consistent"));
    let (_, lumped) = energy_changes(&dropped_block("quadratic_bspline", "flip", "lumped", "lumped"));
    println!(
        "quadratic: largest |ΔE|/E0 consistent {:.2}%, lumped {:.2}%",
        100.0 * change,
        100.0 * lumped
    );
    assert!(change <= 0.03, "the energy moved by {:.2}%", 100.0 * change);
    assert!(change <= lumped, "consistent {change}, lumped {lumped}");
}

/// Linear shape functions move energy on the same block with either mass as particles cross
/// cells (FLIP): the consistent mass no more than the lumped one (measured: 3.2% and 15.5%);
/// and APIC, which pairs with a lumped velocity projection, with the consistent mass in the
/// acceleration solve loses energy (it ends 35–45% down) after a rise within 3% (measured
/// 2.7% linear). About a minute in release.
#[test]
#[ignore = "about a minute in release; run with --ignored"]
fn the_consistent_mass_moves_no_more_energy_than_the_lumped_with_linear_shapes_or_apic() {
    let (_, consistent) = energy_changes(&dropped_block("linear", "flip", "consistent", "consistent"));
    let (_, lumped) = energy_changes(&dropped_block("linear", "flip", "lumped", "lumped"));
    println!(
        "linear: largest |ΔE|/E0 consistent {:.2}%, lumped {:.2}%",
        100.0 * consistent,
        100.0 * lumped
    );
    assert!(consistent <= lumped, "consistent {consistent}, lumped {lumped}");
    for shape in ["linear", "quadratic_bspline"] {
        let (rise, _) = energy_changes(&dropped_block(shape, "apic", "lumped", "consistent"));
        println!(
            "{shape}, APIC, consistent acceleration: largest rise {:.2}%",
            100.0 * rise
        );
        assert!(rise <= 0.03, "{shape}, APIC: the energy rose by {:.2}%", 100.0 * rise);
    }
}

/// A block of 12 × 12 particles, one per cell, released at rest on the floor (linear shape
/// functions) or a cell above it (quadratic B-splines, whose walls hold two node layers), with
/// the consistent mass under the singularity policy `policy`, or the lumped mass: the largest
/// `|ΔE|/E0`, the steps, and whether a solve substituted another mass.
fn resting_block(shape: &str, mass: &str, policy: &str) -> (f64, usize, bool) {
    let bottom = if shape == "linear" { 0.0 } else { 0.05 };
    let text = dropped_block(shape, "flip", mass, mass)
        .replace(
            &format!("acceleration = \"{mass}\" }}"),
            &format!("acceleration = \"{mass}\", singularity = \"{policy}\" }}"),
        )
        .replace("particles_per_cell = 2", "particles_per_cell = 1")
        .replace(
            "min = [0.3, 0.55], max = [0.6, 0.85]",
            &format!("min = [0.3, {bottom}], max = [0.6, {}]", bottom + 0.3),
        );
    let scene = Scene::from_toml_str(&text).unwrap();
    let mut sim = scene.build().unwrap();
    let (mut first, mut change, mut steps, mut substituted) = (None, 0.0f64, 0, false);
    sim.run_until(scene.time.end, |_, r| {
        let e0: f64 = *first.get_or_insert(r.total_energy);
        change = change.max(((r.total_energy - e0) / e0).abs());
        steps += 1;
        substituted |= [&r.velocity_solve, &r.acceleration_solve]
            .iter()
            .any(|s| s.outcome != sparse_mpm::mass::SolveOutcome::Solved);
        Ok(())
    })
    .unwrap_or_else(|e| panic!("{shape}, {mass}, {policy}: {e}"));
    assert!((sim.time() - 1.5).abs() < 1e-9, "stopped at {}", sim.time());
    (change, steps, substituted)
}

/// The resting block under `policy` against the lumped mass: to the end, the policy acting,
/// the energy within 0.1% of E0 of the lumped mass's change.
fn check_resting_block(shape: &str, policy: &str) {
    let (lumped, lumped_steps, _) = resting_block(shape, "lumped", "error");
    let (change, steps, substituted) = resting_block(shape, "consistent", policy);
    println!(
        "{shape}, {policy}: largest |ΔE|/E0 {:.4}% in {steps} steps (lumped {:.4}% in {lumped_steps})",
        100.0 * change,
        100.0 * lumped
    );
    assert!(substituted, "{shape}, {policy}: the policy never acted");
    assert!(
        change <= lumped + 1e-3,
        "{shape}, {policy}: the energy moved by {:.3}%, the lumped mass's by {:.3}%",
        100.0 * change,
        100.0 * lumped
    );
}

/// One particle per cell at rest on a floor, linear and quadratic, `fallback_to_lumped`: the
/// consistent mass is singular or nearly singular (its top frequency 10⁵ times any single
/// node's) at most steps, and the fallback keeps the lumped mass's energy. Measured: linear
/// 0.0029% (lumped 0.0029%), quadratic 1.10% (lumped 1.40%). Before the fallback acted on a
/// nearly singular mass, the step fell to 10⁻⁶ of the lumped one and a particle inverted
/// (docs/simulation.md, "The time step").
#[test]
fn a_block_at_rest_on_a_floor_with_one_particle_per_cell_keeps_its_energy_under_the_fallback() {
    for shape in ["linear", "quadratic_bspline"] {
        check_resting_block(shape, "fallback_to_lumped");
    }
}

/// [`a_block_at_rest_on_a_floor_with_one_particle_per_cell_keeps_its_energy_under_the_fallback`]
/// under `regularize:0.1`, whose stable step comes from the solves themselves. Measured:
/// linear 0.0015%, quadratic 0.48%. About a minute in release.
#[test]
#[ignore = "about a minute in release; run with --ignored"]
fn a_block_at_rest_on_a_floor_with_one_particle_per_cell_keeps_its_energy_when_regularized() {
    for shape in ["linear", "quadratic_bspline"] {
        check_resting_block(shape, "regularize:0.1");
    }
}
