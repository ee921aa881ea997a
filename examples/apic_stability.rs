//! How many steps a stiff, rigidly translating block survives under APIC, for each shape
//! function and Courant number.
//!
//! ```text
//! cargo run --release --example apic_stability
//! ```
//!
//! In exact arithmetic the block translates forever. APIC gives each particle an affine velocity
//! with inertia `m_p D_p`; for linear kernels `D_p` vanishes as a particle approaches a grid line,
//! the highest frequency is unbounded, and round-off grows until a particle inverts
//! (docs/simulation.md). GIMP and B-splines keep `D_p` bounded below.

use sparse_mpm::material::{LinearElastic, Material, PlaneCondition};
use sparse_mpm::simulation::{Body, Options, Simulation, TimeStep, Transfer};
use sparse_mpm::{Grid, Particles, ShapeFunction};

const STEPS: usize = 2000;
const H: f64 = 0.025;
const E: f64 = 2.0e5;
const RHO: f64 = 1000.0;

fn main() {
    let material = LinearElastic {
        youngs_modulus: E,
        poisson_ratio: 0.3,
        plane: PlaneCondition::Strain,
    };
    let c = material.wave_speed(RHO);
    println!("24 x 24 particles (2 x 2 per cell), h = {H}, E = {E}, rho = {RHO}, c = {c:.2}, v = (0.5, 0), MUSL, APIC");
    println!("steps survived out of {STEPS} at fixed steps dt = Courant number * h / c:");
    let courants = [0.066, 0.25, 0.5];
    print!("{:<22}", "shape");
    for k in courants {
        print!(" {:>10}", format!("C = {k}"));
    }
    println!();
    for shape in [
        ShapeFunction::Linear,
        ShapeFunction::Gimp { half_width: 0.25 },
        ShapeFunction::QuadraticBSpline,
        ShapeFunction::CubicBSpline,
    ] {
        print!("{:<22}", shape.name());
        for courant in courants {
            let dt = courant * H / c;
            let mut sim = block(shape, Material::LinearElastic(material), dt);
            let survived = (0..STEPS).take_while(|_| sim.step().is_ok()).count();
            let text = if survived == STEPS {
                "all".to_string()
            } else {
                survived.to_string()
            };
            print!(" {text:>10}");
        }
        println!();
    }
}

fn block(shape: ShapeFunction, material: Material, dt: f64) -> Simulation {
    // A 1.25 × 1 grid: the block (x from 0.1 to 0.4) travels at most 0.5 × 2000 × 7.6e-4 = 0.76.
    let grid = Grid::new([0.0, 0.0], [H, H], [50, 40]).expect("valid grid");
    let d = H / 2.0;
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for j in 0..24 {
        for i in 0..24 {
            x.push(0.1 + (i as f64 + 0.5) * d);
            y.push(0.4 + (j as f64 + 0.5) * d);
        }
    }
    let n = x.len();
    let particles = Particles::new(x, y, vec![RHO * d * d; n], vec![d * d; n])
        .and_then(|p| p.with_velocity(vec![0.5; n], vec![0.0; n]))
        .expect("valid particles");
    let options = Options {
        shape,
        transfer: Transfer::Apic,
        time_step: TimeStep::Fixed { dt },
        ..Options::default()
    };
    let bodies = vec![Body {
        name: "block".into(),
        material,
    }];
    Simulation::new(grid, particles, bodies, options).expect("valid simulation")
}
