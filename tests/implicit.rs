//! Implicit integration: the tangent of the internal force against central differences for
//! every kernel and material.

use sparse_mpm::implicit::{gradient_operator, internal_force, internal_force_and_tangent};
use sparse_mpm::material::{LinearElastic, Material, NeoHookean, PlaneCondition};
use sparse_mpm::particles::lattice;
use sparse_mpm::{Grid, Operators, Particles, ShapeFunction};

const SHAPES: [ShapeFunction; 4] = [
    ShapeFunction::Linear,
    ShapeFunction::Gimp { half_width: 0.25 },
    ShapeFunction::QuadraticBSpline,
    ShapeFunction::CubicBSpline,
];

fn materials() -> [Material; 2] {
    [
        Material::LinearElastic(LinearElastic::new(1000.0, 0.3, PlaneCondition::Strain).unwrap()),
        Material::NeoHookean(NeoHookean {
            youngs_modulus: 1000.0,
            poisson_ratio: 0.3,
        }),
    ]
}

/// A small deterministic sequence in [−1, 1].
fn noise(k: usize) -> f64 {
    let x = ((k as f64 + 1.0) * 12.9898).sin() * 43758.5453;
    2.0 * (x - x.floor()) - 1.0
}

/// A block of pre-deformed, pre-stressed particles inside an 8 × 8 grid of h = 0.25.
fn setup(shape: ShapeFunction, material: &Material) -> (Operators, Particles) {
    let grid = Grid::new([0.0, 0.0], [0.25, 0.25], [8, 8]).unwrap();
    let (x, y, volume) = lattice(&grid, 2, |px, py| (0.6..1.4).contains(&px) && (0.6..1.4).contains(&py));
    let n = x.len();
    let mut p = Particles::new(x, y, vec![volume; n], vec![volume; n]).unwrap();
    for k in 0..n {
        // F_n near the identity, different per particle; the stress the material gives it
        // (neo-Hookean) or any stress (linear: the rate form starts from any σ_n).
        let f = [
            1.0 + 0.05 * noise(4 * k),
            0.03 * noise(4 * k + 1),
            0.03 * noise(4 * k + 2),
            1.0 + 0.05 * noise(4 * k + 3),
        ];
        p.fxx[k] = f[0];
        p.fxy[k] = f[1];
        p.fyx[k] = f[2];
        p.fyy[k] = f[3];
        let [sxx, syy, sxy] = match material {
            Material::NeoHookean(m) => m.stress(f),
            Material::LinearElastic(_) => [10.0 * noise(7 * k), 10.0 * noise(7 * k + 1), 5.0 * noise(7 * k + 2)],
        };
        p.sxx[k] = sxx;
        p.syy[k] = syy;
        p.sxy[k] = sxy;
        p.volume[k] *= f[0] * f[3] - f[1] * f[2];
    }
    let ops = Operators::assemble(&grid, shape, &p).unwrap();
    (ops, p)
}

#[test]
fn the_tangent_is_the_central_difference_jacobian_of_the_internal_force_for_every_kernel_and_material() {
    for shape in SHAPES {
        for material in materials() {
            let (ops, p) = setup(shape, &material);
            let mats = [material];
            let g = gradient_operator(&ops);
            let dofs = 2 * ops.num_nodes();
            let u: Vec<f64> = (0..dofs).map(|k| 2e-3 * noise(1000 + k)).collect();
            let (f0, k) = internal_force_and_tangent(&ops, &g, &p, &mats, &u).unwrap();
            assert_eq!(f0, internal_force(&ops, &g, &p, &mats, &u).unwrap());
            let dense = k.clone();
            let mut scale = 0.0f64;
            for (_, _, v) in dense.triplet_iter() {
                scale = scale.max(v.abs());
            }
            let eps = 1e-6;
            let mut worst = 0.0f64;
            for j in 0..dofs {
                let (mut up, mut down) = (u.clone(), u.clone());
                up[j] += eps;
                down[j] -= eps;
                let (fp, fm) = (
                    internal_force(&ops, &g, &p, &mats, &up).unwrap(),
                    internal_force(&ops, &g, &p, &mats, &down).unwrap(),
                );
                let col = k.col(j);
                let mut kcol = vec![0.0; dofs];
                for (&i, &v) in col.row_indices().iter().zip(col.values()) {
                    kcol[i] = v;
                }
                for i in 0..dofs {
                    let fd = -(fp[i] - fm[i]) / (2.0 * eps);
                    worst = worst.max((fd - kcol[i]).abs());
                }
            }
            assert!(
                worst <= 1e-6 * scale,
                "{shape:?} {material:?}: |K − K_fd| = {worst:.3e} against max |K| = {scale:.3e}"
            );
            // Symmetric (the hyperelastic tangent has major symmetry).
            let kt = k.transpose();
            let mut asym = 0.0f64;
            for (i, j, v) in k.triplet_iter() {
                let t = kt.get_entry(i, j).map_or(0.0, |e| e.into_value());
                asym = asym.max((v - t).abs());
            }
            assert!(asym <= 1e-12 * scale, "{shape:?} {material:?}: asymmetry {asym:.3e}");
        }
    }
}

#[test]
fn at_zero_displacement_the_force_is_the_explicit_internal_force_and_the_linear_tangent_is_the_stiffness() {
    for shape in SHAPES {
        let material = materials()[0];
        let (ops, p) = setup(shape, &material);
        let g = gradient_operator(&ops);
        let n = ops.num_nodes();
        let (f, k) = internal_force_and_tangent(&ops, &g, &p, &[material], &vec![0.0; 2 * n]).unwrap();
        // −Σ_p V_p σ_p ∇N_I, summed independently.
        let mut expect = vec![0.0; 2 * n];
        for q in 0..p.len() {
            for (node, _, dx, dy) in ops.column(q) {
                expect[node] -= p.volume[q] * (p.sxx[q] * dx + p.sxy[q] * dy);
                expect[n + node] -= p.volume[q] * (p.sxy[q] * dx + p.syy[q] * dy);
            }
        }
        let err = f.iter().zip(&expect).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!(
            err < 1e-12 * expect.iter().fold(0.0f64, |m, v| m.max(v.abs())),
            "{shape:?}: {err}"
        );
        let Material::LinearElastic(le) = material else {
            unreachable!()
        };
        let stiffness = sparse_mpm::stiffness::stiffness_matrix(&ops, &p.volume, &le);
        let mut worst = 0.0f64;
        let mut scale = 0.0f64;
        for (i, j, v) in stiffness.triplet_iter() {
            scale = scale.max(v.abs());
            worst = worst.max((v - k.get_entry(i, j).map_or(0.0, |e| e.into_value())).abs());
        }
        assert!(
            worst <= 1e-12 * scale,
            "{shape:?}: K differs from stiffness_matrix by {worst:.3e}"
        );
    }
}
