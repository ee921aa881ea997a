//! Two energy observations, measured (docs/verification.md): the two-disk impact's dip with a
//! linear-elastic and a neo-Hookean material at three speeds, and a block in a box of fixed
//! walls under USL, MUSL and the consistent mass.
//!
//! ```text
//! cargo run --release --example energy_observations
//! ```

use sparse_mpm::scene::Scene;
use sparse_mpm::MpmError;

/// Runs a scene to its end: (largest dip 1 − min E/E₀, E_end/E₀ − 1).
fn energy(text: &str) -> Result<(f64, f64), MpmError> {
    let scene = Scene::from_toml_str(text)?;
    let mut sim = scene.build()?;
    let (mut first, mut lowest, mut last) = (None, f64::INFINITY, 0.0);
    sim.run_until(scene.time.end, |_, r| {
        first.get_or_insert(r.total_energy);
        lowest = lowest.min(r.total_energy);
        last = r.total_energy;
        Ok(())
    })?;
    let e0 = first.expect("a step");
    Ok((1.0 - lowest / e0, last / e0 - 1.0))
}

fn main() -> Result<(), MpmError> {
    let disks = include_str!("../scenes/two_disks.toml");
    println!("two disks (FLIP, MUSL, lumped, 20 cells, to t = 0.3 / speed): energy dip during the impact / change by the end");
    for speed in [0.1, 0.05, 0.02] {
        let scaled = disks
            .replace("[0.1, 0.1]", &format!("[{speed}, {speed}]"))
            .replace("[-0.1, -0.1]", &format!("[-{speed}, -{speed}]"))
            .replace("end = 3.5", &format!("end = {}", 3.0 * 0.1 / speed));
        let neo = scaled.replace(
            "model = \"linear_elastic\", youngs_modulus = 1000.0, poisson_ratio = 0.3, plane = \"strain\"",
            "model = \"neo_hookean\", youngs_modulus = 1000.0, poisson_ratio = 0.3",
        );
        let (le, nh) = (energy(&scaled)?, energy(&neo)?);
        println!(
            "  speed {speed:<5} linear elastic {:5.2}% / {:+.2}%   neo-Hookean {:5.2}% / {:+.2}%",
            100.0 * le.0,
            100.0 * le.1,
            100.0 * nh.0,
            100.0 * nh.1
        );
    }
    let block = |update: &str, mass: &str, dt: f64| {
        format!(
            "[grid]\ncell_size = [1.0, 1.0]\ncells = [24, 24]\n[schemes]\nupdate = \"{update}\"\ntransfer = \"flip\"\n\
             mass = {{ velocity = \"{mass}\", acceleration = \"{mass}\" }}\n[time]\nend = 100.0\ndt = {dt}\n\
             [[bodies]]\nname = \"block\"\nmaterial = {{ model = \"linear_elastic\", youngs_modulus = 100.0, \
             poisson_ratio = 0.3, plane = \"strain\" }}\ndensity = 1.0\nvelocity = [0.01, 0.0]\n\
             geometry = {{ rectangle = {{ min = [0.0, 0.0], max = [24.0, 24.0] }} }}\n{}",
            ["left", "right", "bottom", "top"]
                .map(|e| format!("[[boundaries]]\nedge = \"{e}\"\ncondition = \"fixed\"\n"))
                .concat()
        )
    };
    println!(
        "\n24 x 24 block in a box of fixed walls, uniform velocity 0.01, FLIP, to t = 100: energy lost by the end"
    );
    for (update, mass, dt) in [
        ("usl", "lumped", 0.03),
        ("usl", "lumped", 0.015),
        ("usl", "lumped", 0.0075),
        ("musl", "lumped", 0.03),
        ("usl", "consistent", 0.03),
        ("musl", "consistent", 0.03),
    ] {
        let (_, change) = energy(&block(update, mass, dt))?;
        println!("  {update:<5} {mass:<11} dt = {dt:<7} {:6.2}%", -100.0 * change);
    }
    Ok(())
}
