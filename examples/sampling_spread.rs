//! How much a result owes to the sampling: the colliding rings (scenes/rings.toml) run on
//! the regular lattice and on jittered and Poisson-disk samplings of several seeds, under FLIP,
//! APIC and a 99% FLIP blend: the energy at the end over the energy at the start for each.
//!
//! ```text
//! cargo run --release --example sampling_spread            # seeds 1 to 5
//! cargo run --release --example sampling_spread -- 10      # seeds 1 to 10
//! ```
//!
//! The scene is changed by the same `KEY=VALUE` overrides as `mpm run --set`.

use sparse_mpm::scene::{apply_overrides, Scene};

const SCENE: &str = include_str!("../scenes/rings.toml");

/// `E_end / E_0` of the scene with `sets` applied.
fn energy_ratio(sets: &[String]) -> sparse_mpm::error::Result<f64> {
    let scene = Scene::from_toml_str(&apply_overrides(SCENE, sets)?)?;
    let mut sim = scene.build()?;
    let mut first = None;
    let mut last = 0.0;
    sim.run_until(scene.time.end, |_, r| {
        first.get_or_insert(r.total_energy);
        last = r.total_energy;
        Ok(())
    })?;
    Ok(last / first.unwrap_or(1.0))
}

fn main() -> sparse_mpm::error::Result<()> {
    let seeds: u64 = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(5);
    println!("two rings, E_end/E_0; seeds 1 to {seeds} for the random samplings");
    println!("| transfer | regular | jittered: min, mean, max | poisson_disk: min, mean, max |");
    println!("|---|---|---|---|");
    for transfer in ["flip", "apic", "{ blend = { flip = 0.99 } }"] {
        let base = vec![format!("schemes.transfer={transfer}")];
        let show =
            |r: sparse_mpm::error::Result<f64>| r.map_or_else(|e| format!("failed ({e})"), |v| format!("{v:.4}"));
        let regular = show(energy_ratio(&base));
        let mut cells = Vec::new();
        for sampling in ["jittered", "poisson_disk"] {
            let (mut values, mut failed) = (Vec::new(), 0);
            for seed in 1..=seeds {
                let mut sets = base.clone();
                for body in 0..2 {
                    sets.push(format!("bodies[{body}].sampling={sampling}"));
                    sets.push(format!("bodies[{body}].seed={}", 2 * seed + body as u64));
                }
                match energy_ratio(&sets) {
                    Ok(v) => values.push(v),
                    Err(_) => failed += 1,
                }
            }
            let (min, max) = values
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
            let mean = values.iter().sum::<f64>() / values.len() as f64;
            let failed = if failed > 0 {
                format!(" ({failed} failed)")
            } else {
                String::new()
            };
            cells.push(format!("{min:.4}, {mean:.4}, {max:.4}{failed}"));
        }
        println!("| {transfer} | {regular} | {} | {} |", cells[0], cells[1]);
    }
    Ok(())
}
