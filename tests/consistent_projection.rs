//! What the consistent mass is for, kept by its default stabilisation: the L2 projection of a
//! field in the span of the shape functions (translation, rigid rotation, uniform strain rate)
//! is exact at every node with mass, for every kernel and body shape, including bodies one cell
//! thick and random layouts; a disk in rigid rotation keeps its angular momentum; APIC with a
//! consistent velocity projection is refused naming both keys.

use std::f64::consts::PI;

use sparse_mpm::mass::{Constraints, GridMass, MassOptions, MassScheme, Role, Stabilization};
use sparse_mpm::material::{Material, NeoHookean};
use sparse_mpm::scene::Scene;
use sparse_mpm::simulation::{Body, Options, Simulation, TimeStep, Transfer, UpdateScheme};
use sparse_mpm::transfer::VectorField;
use sparse_mpm::Operator;
use sparse_mpm::{Grid, Operators, Particles, ShapeFunction};

const SHAPES: [ShapeFunction; 4] = [
    ShapeFunction::Linear,
    ShapeFunction::Gimp { half_width: 0.25 },
    ShapeFunction::QuadraticBSpline,
    ShapeFunction::CubicBSpline,
];

/// Relative round-off allowance of a solve on a few hundred nodes.
const ROUND_OFF: f64 = 1e-9;

struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Particle positions of the bodies the projection is tried on, on a 16 × 16 grid of unit
/// cells: a disk whose edge particles sit just past grid lines, a strip one cell thick (two
/// particles across), and a block of particles at random positions (about 4 per cell).
fn bodies() -> Vec<(&'static str, Vec<f64>, Vec<f64>)> {
    let (mut dx, mut dy) = (Vec::new(), Vec::new());
    for j in 0..32 {
        for i in 0..32 {
            let (px, py) = ((i as f64 + 0.5) / 2.0, (j as f64 + 0.5) / 2.0);
            if (px - 8.0f64).hypot(py - 8.0) < 4.5 {
                dx.push(px + 0.27);
                dy.push(py + 0.11);
            }
        }
    }
    let (mut sx, mut sy) = (Vec::new(), Vec::new());
    for i in 0..20 {
        for j in 0..2 {
            sx.push(4.0 + (i as f64 + 0.5) / 2.0);
            sy.push(7.0 + (j as f64 + 0.5) / 2.0);
        }
    }
    let mut rng = Lcg(3);
    let (mut rx, mut ry) = (Vec::new(), Vec::new());
    for _ in 0..144 {
        rx.push(5.0 + 6.0 * rng.next());
        ry.push(5.0 + 6.0 * rng.next());
    }
    vec![
        ("disk", dx, dy),
        ("strip one cell thick", sx, sy),
        ("random block", rx, ry),
    ]
}

/// The velocity fields the grid represents exactly: a rigid rotation about (8, 8) with a
/// translation, a uniform strain rate (stretch and shear) with a translation, and a bilinear
/// field (linear along each axis; every kernel here reproduces it).
type Field = fn(f64, f64) -> [f64; 2];

fn fields() -> Vec<(&'static str, Field)> {
    vec![
        ("rigid rotation", |x, y| [0.3 - 0.7 * (y - 8.0), -0.2 + 0.7 * (x - 8.0)]),
        ("uniform strain rate", |x, y| {
            [0.1 + 0.5 * x - 0.25 * y, 0.05 - 0.25 * x - 0.3 * y]
        }),
        ("bilinear field", |x, y| {
            [0.02 * (x - 8.0) * (y - 7.0), -0.03 * (x - 6.0) * (y - 9.0)]
        }),
    ]
}

/// The largest difference, over nodes with mass, between the consistent projection of the
/// particle values of `v` and `v` at the nodes, relative to the largest |v| there.
fn projection_error(
    shape: ShapeFunction,
    x: &[f64],
    y: &[f64],
    v: fn(f64, f64) -> [f64; 2],
    stab: Stabilization,
) -> f64 {
    let grid = Grid::new([0.0, 0.0], [1.0, 1.0], [16, 16]).unwrap();
    let n = x.len();
    let particles = Particles::new(x.to_vec(), y.to_vec(), vec![0.25; n], vec![0.25; n]).unwrap();
    let ops = Operators::assemble(&grid, shape, &particles).unwrap();
    let mut options = MassOptions::both(MassScheme::Consistent);
    options.stabilization = stab;
    let mass = GridMass::new(&ops, &particles.mass, &options, &Constraints::none()).unwrap();
    // r = N (m ∘ v_p)
    let (px, py): (Vec<f64>, Vec<f64>) = (0..n)
        .map(|p| {
            let [a, b] = v(x[p], y[p]);
            (0.25 * a, 0.25 * b)
        })
        .unzip();
    let mut rhs = VectorField::zeros(ops.num_nodes());
    ops.scatter(Operator::N, [&px, &py], [&mut rhs.x, &mut rhs.y]);
    let (u, _) = mass.solve(Role::Velocity, &rhs, None, &ops).unwrap();
    let (mut worst, mut scale) = (0.0f64, 0.0f64);
    for i in mass.active_nodes() {
        let [gx, gy] = grid.node_position(i);
        let exact = v(gx, gy);
        scale = scale.max(exact[0].abs()).max(exact[1].abs());
        worst = worst.max((u.x[i] - exact[0]).abs()).max((u.y[i] - exact[1]).abs());
    }
    worst / scale
}

#[test]
fn the_default_consistent_projection_of_linear_fields_is_exact_at_every_node_with_mass() {
    for shape in SHAPES {
        for (body, x, y) in bodies() {
            for (field, v) in fields() {
                let error = projection_error(shape, &x, &y, v, Stabilization::default());
                assert!(
                    error <= ROUND_OFF,
                    "{shape}, {body}, {field}: the projection is off by {error:.3e} of the field"
                );
            }
        }
    }
}

#[test]
fn partial_lumping_breaks_the_exact_projection_at_a_fringe_so_the_check_can_fail() {
    let (_, x, y) = bodies().remove(0);
    let lumping: Stabilization = "partial_lumping:0.5".parse().unwrap();
    for shape in [ShapeFunction::Linear, ShapeFunction::QuadraticBSpline] {
        let error = projection_error(shape, &x, &y, fields()[0].1, lumping);
        assert!(error > 1e-4, "{shape}: partial lumping error {error:.3e}");
    }
}

/// A neo-Hookean disk (radius 0.3, 2 × 2 particles per cell on 0.05 cells) spinning at 1 rad/s
/// about its centre for one revolution with FLIP and the consistent mass in both solves: the
/// relative change of its angular momentum about the centre.
fn spinning_disk_angular_momentum_change(shape: ShapeFunction) -> f64 {
    let pad = shape.recommended_padding() as f64;
    let h = 0.05;
    let cells = 20 + 2 * pad as usize;
    let grid = Grid::new([-pad * h, -pad * h], [h, h], [cells, cells]).unwrap();
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for j in 0..40 {
        for i in 0..40 {
            let (px, py) = ((i as f64 + 0.5) * 0.025, (j as f64 + 0.5) * 0.025);
            if (px - 0.5f64).hypot(py - 0.5) < 0.3 {
                x.push(px);
                y.push(py);
            }
        }
    }
    let n = x.len();
    let vx: Vec<f64> = y.iter().map(|y| -(y - 0.5)).collect();
    let vy: Vec<f64> = x.iter().map(|x| x - 0.5).collect();
    let vol = 0.025 * 0.025;
    let particles = Particles::new(x, y, vec![1000.0 * vol; n], vec![vol; n])
        .and_then(|p| p.with_velocity(vx, vy))
        .unwrap();
    let options = Options {
        shape,
        mass: MassOptions::both(MassScheme::Consistent),
        transfer: Transfer::Flip,
        update: UpdateScheme::Musl,
        time_step: TimeStep::Cfl { number: 0.5 },
        ..Options::default()
    };
    let bodies = vec![Body {
        name: "disk".into(),
        material: Material::NeoHookean(NeoHookean {
            youngs_modulus: 1.0e4,
            poisson_ratio: 0.3,
        }),
    }];
    let mut sim = Simulation::new(grid, particles, bodies, options).unwrap();
    let angular = |s: &Simulation| {
        let p = s.particles();
        (0..p.len())
            .map(|k| p.mass[k] * ((p.x[k] - 0.5) * p.vy[k] - (p.y[k] - 0.5) * p.vx[k]))
            .sum::<f64>()
    };
    let start = angular(&sim);
    sim.run_until(2.0 * PI, |_, _| Ok(())).unwrap();
    (angular(&sim) - start).abs() / start
}

#[test]
fn a_disk_in_rigid_rotation_keeps_its_angular_momentum_with_the_consistent_mass() {
    for shape in [ShapeFunction::Linear, ShapeFunction::QuadraticBSpline] {
        let change = spinning_disk_angular_momentum_change(shape);
        assert!(
            change < 0.01,
            "{shape}: angular momentum changed by {:.2}% over one revolution",
            100.0 * change
        );
    }
}

#[test]
fn apic_with_a_consistent_velocity_projection_is_refused_naming_both_keys() {
    let grid = Grid::new([0.0, 0.0], [1.0, 1.0], [8, 8]).unwrap();
    let particles = Particles::new(vec![4.2, 4.7], vec![4.3, 4.6], vec![1.0; 2], vec![1.0; 2]).unwrap();
    let bodies = || {
        vec![Body {
            name: "b".into(),
            material: Material::NeoHookean(NeoHookean {
                youngs_modulus: 1.0,
                poisson_ratio: 0.3,
            }),
        }]
    };
    for velocity in ["consistent", "blended:0.5", "series:4", "cg"] {
        let options = Options {
            transfer: Transfer::Apic,
            mass: MassOptions {
                velocity: velocity.parse().unwrap(),
                ..MassOptions::both(MassScheme::Lumped)
            },
            ..Options::default()
        };
        let err = options.validate().unwrap_err().to_string();
        assert!(
            err.contains("schemes.transfer") && err.contains("schemes.mass.velocity") && err.contains("lumped"),
            "{velocity}: {err}"
        );
        assert!(Simulation::new(grid.clone(), particles.clone(), bodies(), options).is_err());
    }
    // Lumped velocity with any acceleration mass is accepted.
    let options = Options {
        transfer: Transfer::Apic,
        mass: MassOptions {
            acceleration: MassScheme::Consistent,
            ..MassOptions::both(MassScheme::Lumped)
        },
        ..Options::default()
    };
    assert!(options.validate().is_ok());
    // A scene says it at its keys.
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/block_in_box.toml"))
        .unwrap()
        .replace(
            "mass = { velocity = \"lumped\", acceleration = \"lumped\" }",
            "mass = { velocity = \"consistent\", acceleration = \"consistent\" }",
        );
    let err = Scene::from_toml_str(&text)
        .and_then(|scene| scene.build())
        .expect_err("refused")
        .to_string();
    assert!(
        err.contains("schemes.transfer") && err.contains("schemes.mass.velocity"),
        "{err}"
    );
}
