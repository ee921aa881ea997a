//! FLIP, XPIC(k) and FMPM(k) on Nairn's two-disk impact: energy lost against k and cell size.
//!
//! ```text
//! cargo run --release --example fmpm_disks                    # 20, 40 and 80 cells (a few minutes)
//! cargo run --release --example fmpm_disks -- --cells 20,40   # fewer resolutions
//! ```
//!
//! Nairn's variant of the two-disk problem (FMPM technical note, ch. 3): two neo-Hookean disks
//! (E = 1000, ν = 0.33, ρ = 1000, plane strain) of diameter 0.4 with a gap of 0.02 (5% of the
//! diameter) approach each other at 1% of the P-wave speed, touch through the grid, and bounce
//! apart. uGIMP shape functions (the closest of ours to his CPDI), 2 × 2 particles per cell, USL
//! (his USL−, the scheme his headline figures use), Courant number 0.2 of each transfer's stable
//! step, to t = 6. Reported: the total energy lost by then, as a percentage of the initial.
//!
//! Nairn reports, at his finest comparison (disk diameter 40 cells), FLIP 3.23%, FMPM(8) 2.23%,
//! FMPM(16) 1.86%, FMPM(k) losing more than FLIP for k < 4 and less for k ≥ 4, and the losses
//! falling about linearly with the cell size.

use sparse_mpm::scene::Scene;
use sparse_mpm::simulation::Transfer;

const END: f64 = 6.0;
const CFL: f64 = 0.2;
/// Speed of each disk: half of 1% of the P-wave speed √(C11/ρ) = 1.217.
const SPEED: f64 = 0.0061;

fn scene(cells: usize, transfer: &str) -> Scene {
    let h = 1.0 / cells as f64;
    let body = |name: &str, x: f64, v: f64| {
        format!(
            "[[bodies]]\nname = \"{name}\"\nmaterial = {{ model = \"neo_hookean\", youngs_modulus = 1000.0, \
             poisson_ratio = 0.33 }}\ndensity = 1000.0\nparticles_per_cell = 2\nvelocity = [{v}, 0.0]\n\
             geometry = {{ disk = {{ center = [{x}, 0.5], radius = 0.2 }} }}\n"
        )
    };
    let text = format!(
        "[grid]\ncell_size = [{h}, {h}]\ncells = [{cells}, {cells}]\n\
         [schemes]\nshape = {{ gimp = {{ half_width = 0.25 }} }}\nupdate = \"usl\"\ntransfer = {transfer}\n\
         [time]\nend = {END}\ncfl = {CFL}\n{}{}",
        body("left", 0.29, SPEED),
        body("right", 0.71, -SPEED)
    );
    Scene::from_toml_str(&text).expect("a valid scene")
}

/// Energy lost by the end, % of the initial total energy, and the steps taken.
fn energy_loss(cells: usize, transfer: &str) -> Result<(f64, usize), sparse_mpm::MpmError> {
    let mut sim = scene(cells, transfer).build()?;
    let mut first = None;
    let mut last = 0.0;
    sim.run_until(END, |_, r| {
        first.get_or_insert(r.total_energy);
        last = r.total_energy;
        Ok(())
    })?;
    let e0 = first.expect("at least one step");
    Ok((100.0 * (e0 - last) / e0, sim.steps()))
}

fn main() {
    let cells: Vec<usize> = std::env::args()
        .skip_while(|a| a != "--cells")
        .nth(1)
        .map(|list| {
            list.split(',')
                .map(|c| c.parse().expect("--cells takes numbers"))
                .collect()
        })
        .unwrap_or_else(|| vec![20, 40, 80]);
    let transfers = [
        ("FLIP", "\"flip\""),
        ("PIC", "\"pic\""),
        ("FMPM(1)", "{ fmpm = { k = 1 } }"),
        ("FMPM(2)", "{ fmpm = { k = 2 } }"),
        ("FMPM(4)", "{ fmpm = { k = 4 } }"),
        ("FMPM(8)", "{ fmpm = { k = 8 } }"),
        ("FMPM(16)", "{ fmpm = { k = 16 } }"),
        ("XPIC(4)", "{ xpic = { k = 4 } }"),
        ("XPIC(8)", "{ xpic = { k = 8 } }"),
    ];
    debug_assert!(matches!(
        scene(20, transfers[5].1).options().transfer,
        Transfer::Fmpm { k: 8 }
    ));
    println!("two neo-Hookean disks approaching at 1% of the wave speed; uGIMP, USL, CFL {CFL}, t = {END}");
    println!("energy lost by the end (% of the initial total energy), steps in brackets:\n");
    print!("{:<10}", "transfer");
    for c in &cells {
        print!(" {:>22}", format!("{c} cells ({} per disk)", (0.4 * *c as f64).round()));
    }
    println!();
    for (label, transfer) in transfers {
        print!("{label:<10}");
        for &c in &cells {
            match energy_loss(c, transfer) {
                Ok((loss, steps)) => print!(" {:>22}", format!("{loss:.3}% ({steps})")),
                Err(e) => print!(
                    " {:>22}",
                    format!("failed: {}", e.to_string().chars().take(12).collect::<String>())
                ),
            }
        }
        println!();
    }
}
