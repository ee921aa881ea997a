//! Contact against closed forms ([`sparse_mpm::contact`]).
//!
//! A block, and a disk, on a floor under gravity tilted by θ: a rigid body at rest, an elastic
//! slab held at its base, or the grid's bottom edge as a slip wall with friction, each meeting
//! the body through its own grid field. The block's centre of mass follows
//! `x(t) = ½ g (sin θ − μ cos θ) t²` when `tan θ > μ` and stays put otherwise; a solid disk
//! rolls at `⅔ g sin θ` when `μ ≥ tan θ / 3` and slides at `g (sin θ − μ cos θ)` below. (With 5
//! cells across its radius, as in the table, the rolling disk is 4 to 7% slow; with 10 or more
//! it is within 2%: `-- rolling`, docs/verification.md.)
//!
//! `cargo run --release --example verify_contact` (both masses and shapes; `-- consistent
//! linear` for one of each), `-- rolling` (the rolling disk with 5, 10 and 20 cells across its
//! radius), `-- disks` (the two disks of `scenes/two_disks_contact.toml` with each mass).

use sparse_mpm::scene::Scene;

const G: f64 = 9.81;
const END: f64 = 0.4;

/// The block (0.1 × 0.05 m, E = 1 MPa, ρ = 1000), or a disk of radius 0.05 m, on a floor under
/// gravity tilted by `theta` degrees (reaching its full value over `ramp` seconds), on square
/// cells of side `cell`.
#[allow(clippy::too_many_arguments)]
fn slope_scene(theta: f64, mu: f64, shape: &str, mass: &str, body: &str, ramp: f64, floor: Floor, cell: f64) -> String {
    let (s, c) = theta.to_radians().sin_cos();
    let pad = if shape == "linear" { 0.0 } else { 2.0 * cell };
    let cells = |l: f64| ((l + 2.0 * pad) / cell).round() as usize;
    let geometry = if body == "disk" {
        "{ disk = { center = [0.1, 0.1], radius = 0.05 } }"
    } else {
        "{ rectangle = { min = [0.05, 0.05], max = [0.15, 0.1] } }"
    };
    // On a wall, the grid's bottom edge is a slip wall with friction at y = 0.05: its innermost
    // node line (the second with quadratic B-splines, whose line beyond it the kernel reaches).
    let below = if shape == "linear" { 0.0 } else { cell };
    let (origin_y, ny) = match floor {
        Floor::Wall => (0.05 - below, ((0.15 + below + pad) / cell).round() as usize),
        Floor::Rigid | Floor::Held => (-pad, cells(0.2)),
    };
    let rest = match floor {
        Floor::Wall => format!("[[boundaries]]\nedge = \"bottom\"\ncondition = \"slip\"\nfriction = {mu}\n"),
        Floor::Rigid | Floor::Held => {
            let (held, pair) = match floor {
                Floor::Held => (
                    "[[boundaries]]\nedge = \"bottom\"\ncondition = \"fixed\"\n".to_string(),
                    // The ramp's surface gives the normal: the block's corners would turn the
                    // average.
                    format!("[[contact.pairs]]\nbodies = [\"{body}\", \"floor\"]\nnormal = \"floor\""),
                ),
                _ => (String::new(), "rigid = [\"floor\"]".to_string()),
            };
            format!(
                r#"[[bodies]]
name = "floor"
material = {{ model = "linear_elastic", youngs_modulus = 1e7, poisson_ratio = 0.3, plane = "strain" }}
density = 1000.0
geometry = {{ rectangle = {{ min = [0.0, 0.0], max = [0.6, 0.05] }} }}
{held}[contact]
friction = {mu}
{pair}
"#
            )
        }
    };
    format!(
        r#"
[grid]
origin = [{o}, {origin_y}]
cell_size = [{cell}, {cell}]
cells = [{nx}, {ny}]
[schemes]
shape = "{shape}"
update = "musl"
transfer = "flip"
mass = {{ velocity = "{mass}", acceleration = "{mass}" }}
[time]
end = {END}
cfl = 0.4
[loads]
gravity = [{gx}, {gy}]
gravity_ramp = {ramp}
[[bodies]]
name = "{body}"
material = {{ model = "linear_elastic", youngs_modulus = 1e6, poisson_ratio = 0.3, plane = "strain" }}
density = 1000.0
geometry = {geometry}
{rest}"#,
        o = -pad,
        nx = cells(0.6),
        gx = G * s,
        gy = -G * c,
    )
}

/// The floor: a rigid body, an elastic slab (E = 10 MPa) held at its base whose surface gives
/// the contact normal, or a slip wall with friction.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Floor {
    Rigid,
    Held,
    /// No floor body: the grid's bottom edge a slip wall with friction.
    Wall,
}

/// The body's centre-of-mass displacement along the slope at each step, with the times.
fn slide_path(scene: &str) -> sparse_mpm::error::Result<Vec<(f64, f64)>> {
    let scene = Scene::from_toml_str(scene)?;
    let mut sim = scene.build()?;
    let centre = |sim: &sparse_mpm::simulation::Simulation| {
        let p = sim.particles();
        let (mut m, mut mx) = (0.0, 0.0);
        for k in 0..p.len() {
            if p.body[k] == 0 {
                m += p.mass[k];
                mx += p.mass[k] * p.x[k];
            }
        }
        mx / m
    };
    let x0 = centre(&sim);
    let mut out = vec![(0.0, 0.0)];
    sim.run_until(END, |sim, _| {
        out.push((sim.time(), centre(sim) - x0));
        Ok(())
    })?;
    Ok(out)
}

/// The disk of [`slope_scene`] on a rigid floor (θ = 30°, μ = 0.3: it rolls) with 5, 10 and 20
/// cells across its radius, lumped mass.
fn rolling_against_resolution() -> sparse_mpm::error::Result<()> {
    let exact = 2.0 / 3.0 * G * 30f64.to_radians().sin();
    println!("a disk rolling (θ = 30°, μ = 0.3, rigid floor, lumped, to t = {END} s): ⅔ g sin θ = {exact:.4}");
    println!(
        "{:>18} {:>14} {:>10} {:>9}",
        "shape", "cells/radius", "a fitted", "error"
    );
    for shape in ["linear", "quadratic_bspline"] {
        for per_radius in [5.0, 10.0, 20.0] {
            let scene = slope_scene(
                30.0,
                0.3,
                shape,
                "lumped",
                "disk",
                1e-9,
                Floor::Rigid,
                0.05 / per_radius,
            );
            let fitted = fit_acceleration(&slide_path(&scene)?);
            println!(
                "{shape:>18} {per_radius:>14} {fitted:>10.4} {:>8.1}%",
                100.0 * (fitted / exact - 1.0)
            );
        }
    }
    Ok(())
}

/// The two disks of `scenes/two_disks_contact.toml` (frictionless) with each mass and each
/// body's own stabilisation: their energy when they part, its least value, at the end, and the
/// largest momentum component of the pair.
fn disks_with_each_mass() -> sparse_mpm::error::Result<()> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/two_disks_contact.toml");
    let text = std::fs::read_to_string(path).expect("the shipped scene");
    println!("the two disks in frictionless contact: energy against the start");
    println!(
        "{:>12} {:>16} {:>9} {:>9} {:>9} {:>10}",
        "mass", "stabilization", "parting", "least", "end", "momentum"
    );
    for (mass, stabilization) in [
        ("lumped", "partial_lumping"),
        ("consistent", "partial_lumping"),
        ("consistent", "ghost_penalty"),
        ("consistent", "linear_extension"),
        ("cg", "partial_lumping"),
        ("blended:0.5", "partial_lumping"),
        ("series:8", "partial_lumping"),
    ] {
        let scene = text
            .replace(
                "mass = { velocity = \"lumped\", acceleration = \"lumped\" }",
                &format!("mass = {{ velocity = \"{mass}\", acceleration = \"{mass}\" }}"),
            )
            .replace(
                "friction = 0.0",
                &format!("friction = 0.0\nstabilization = \"{stabilization}\""),
            );
        let mut scene = Scene::from_toml_str(&scene)?;
        scene.output = Default::default();
        let mut sim = scene.build()?;
        let (mut history, mut momentum) = (Vec::new(), 0.0_f64);
        sim.run_until(scene.time.end, |_, r| {
            history.push((r.contact_force, r.total_energy));
            momentum = momentum.max(r.momentum[0].abs()).max(r.momentum[1].abs());
            Ok(())
        })?;
        // Parting: the first report after the last one with a contact force.
        let e0 = history[0].1;
        let after = history
            .iter()
            .rposition(|(f, _)| *f > 0.0)
            .map_or(history.len(), |k| k + 1);
        let parted = history.get(after).map_or(f64::NAN, |(_, e)| e / e0);
        let least = history.iter().map(|(_, e)| e / e0).fold(f64::INFINITY, f64::min);
        let last = history.last().map_or(f64::NAN, |(_, e)| e / e0);
        println!("{mass:>12} {stabilization:>16} {parted:>9.4} {least:>9.4} {last:>9.4} {momentum:>10.1e}");
    }
    Ok(())
}

fn main() -> sparse_mpm::error::Result<()> {
    match std::env::args().nth(1).as_deref() {
        Some("rolling") => return rolling_against_resolution(),
        Some("disks") => return disks_with_each_mass(),
        _ => {}
    }
    println!("on a floor under tilted gravity, to t = {END} s (1 cm cells, 2 × 2 particles per cell, MUSL, FLIP)");
    println!(
        "{:>6} {:>6} {:>5} {:>5} {:>18} {:>11} {:>10} {:>10} {:>10} {:>9}",
        "body", "floor", "θ", "μ", "shape", "mass", "a exact", "a fitted", "x(T) err", "max err"
    );
    // (body, θ, μ, exact acceleration, gravity ramp): the block slides at g (sin θ − μ cos θ)
    // or sticks (its load set down over 0.1 s: applied at once, the block bounces, and where
    // the normal force falls below tan θ / μ of the weight it slips); the disk rolls at ⅔ g sin θ
    // when μ ≥ tan θ / 3, and slides at g (sin θ − μ cos θ) below.
    let slide = |theta: f64, mu: f64| {
        let (s, c) = f64::to_radians(theta).sin_cos();
        (G * (s - mu * c)).max(0.0)
    };
    let roll = |theta: f64| 2.0 / 3.0 * G * f64::to_radians(theta).sin();
    let cases = [
        ("block", 30.0, 0.0, slide(30.0, 0.0), 0.0),
        ("block", 30.0, 0.3, slide(30.0, 0.3), 0.0),
        ("block", 45.0, 0.5, slide(45.0, 0.5), 0.0),
        ("block", 30.0, 0.7, 0.0, 0.1),
        ("disk", 30.0, 0.3, roll(30.0), 0.0),
        ("disk", 30.0, 0.1, slide(30.0, 0.1), 0.0),
    ];
    let runs = cases
        .iter()
        .map(|&c| (Floor::Rigid, c))
        .chain(cases[..4].iter().map(|&c| (Floor::Held, c)))
        .chain(cases.iter().map(|&c| (Floor::Wall, c)));
    // Arguments: the masses to run (lumped and consistent by default) and the shapes (both).
    let args: Vec<String> = std::env::args().skip(1).collect();
    let named: Vec<&str> = ["linear", "quadratic_bspline"]
        .into_iter()
        .filter(|s| args.iter().any(|a| a == s))
        .collect();
    let shapes = if named.is_empty() {
        vec!["linear", "quadratic_bspline"]
    } else {
        named
    };
    let masses: Vec<String> = args
        .iter()
        .filter(|a| !["linear", "quadratic_bspline"].contains(&a.as_str()))
        .cloned()
        .collect();
    let masses = if masses.is_empty() {
        vec!["lumped".to_string(), "consistent".to_string()]
    } else {
        masses
    };
    for (mass, shape) in masses.iter().flat_map(|m| shapes.iter().map(move |s| (m, *s))) {
        for (floor, (body, theta, mu, a, ramp)) in runs.clone() {
            let scene = slope_scene(theta, mu, shape, mass, body, f64::max(ramp, 1e-9), floor, 0.01);
            let path = slide_path(&scene)?;
            let (t_end, x_end) = *path.last().unwrap();
            let exact = |t: f64| if ramp > 0.0 { 0.0 } else { 0.5 * a * t * t };
            // Over the second half of the run, relative to the slide at its end (to the
            // block's length when it sticks).
            let scale = if a > 0.0 { exact(t_end) } else { 0.1 };
            let err = path
                .iter()
                .filter(|(t, _)| *t >= 0.5 * END)
                .map(|&(t, x)| (x - exact(t)).abs() / scale)
                .fold(0.0, f64::max);
            // The acceleration of a parabola through the second half: x = x0 + v0 t + ½ a t².
            let fitted = fit_acceleration(&path);
            println!(
                "{body:>6} {:>6} {theta:>5} {mu:>5} {shape:>18} {mass:>11} {a:>10.4} {fitted:>10.4} {:>10.2e} {err:>9.2e}",
                format!("{floor:?}").to_lowercase(),
                (x_end - exact(t_end)) / scale
            );
        }
    }
    Ok(())
}

/// The least-squares `a` of `x = c + v t + ½ a t²` over the second half of `path`.
fn fit_acceleration(path: &[(f64, f64)]) -> f64 {
    let pts: Vec<(f64, f64)> = path.iter().copied().filter(|(t, _)| *t >= 0.5 * END).collect();
    // Normal equations of the basis 1, t, t²/2.
    let mut a = [[0.0; 3]; 3];
    let mut b = [0.0; 3];
    for &(t, x) in &pts {
        let phi = [1.0, t, 0.5 * t * t];
        for i in 0..3 {
            for j in 0..3 {
                a[i][j] += phi[i] * phi[j];
            }
            b[i] += phi[i] * x;
        }
    }
    // Gaussian elimination (3 × 3, well conditioned over half a second).
    for i in 0..3 {
        for k in i + 1..3 {
            let f = a[k][i] / a[i][i];
            for j in 0..3 {
                a[k][j] -= f * a[i][j];
            }
            b[k] -= f * b[i];
        }
    }
    let mut x = [0.0; 3];
    for i in (0..3).rev() {
        let s: f64 = (i + 1..3).map(|j| a[i][j] * x[j]).sum();
        x[i] = (b[i] - s) / a[i][i];
    }
    x[2]
}
