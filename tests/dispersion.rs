//! The dispersion relation (src/verification/dispersion.rs): the reference values for bilinear
//! functions, the closed forms, the small-θ coefficients of docs/mass.md for the B-splines, an
//! independent eigenvalue computation on a periodic bar, and the vibrating bar's measured period.
#![allow(clippy::approx_constant)] // the reference values are printed to three digits (0.318 is 1/π)

use std::f64::consts::PI;

use sparse_mpm::mass::MassScheme;
use sparse_mpm::ShapeFunction;
use sparse_mpm_study::verification::dispersion::{dispersion, Symbols};

const LUMPED: MassScheme = MassScheme::Lumped;
const CONSISTENT: MassScheme = MassScheme::Consistent;

fn ratio(shape: ShapeFunction, v: MassScheme, a: MassScheme, k: usize, theta: f64) -> f64 {
    Symbols::new(shape, k).unwrap().c_ratio(v, a, theta)
}

#[test]
fn bilinear_two_particles_per_cell_matches_the_reference_values() {
    let blend = MassScheme::Blended { gamma: 13.0 / 18.0 };
    let cases: [(MassScheme, MassScheme, [f64; 3]); 5] = [
        (LUMPED, LUMPED, [0.919, 0.712, 0.318]),
        (CONSISTENT, CONSISTENT, [1.033, 1.139, 1.273]),
        (CONSISTENT, LUMPED, [0.975, 0.900, 0.637]),
        (LUMPED, CONSISTENT, [0.975, 0.900, 0.637]),
        (blend, blend, [0.999, 0.976, 0.695]),
    ];
    for (v, a, expected) in cases {
        for (theta, want) in [PI / 4.0, PI / 2.0, PI].into_iter().zip(expected) {
            let got = ratio(ShapeFunction::Linear, v, a, 2, theta);
            println!("{v}/{a} θ = {theta:.4}: {got:.5} (reference {want})");
            assert!(
                (got - want).abs() < 1e-3,
                "{v}/{a} at θ = {theta}: {got} against {want}"
            );
        }
    }
}

#[test]
fn bilinear_two_particles_per_cell_matches_the_closed_forms_and_brackets_one() {
    for j in 1..=200 {
        let theta = PI * j as f64 / 200.0;
        let s = 2.0 * (theta / 2.0).sin() / theta;
        let m = ((10.0 + 6.0 * theta.cos()) / 16.0).sqrt();
        let lumped = ratio(ShapeFunction::Linear, LUMPED, LUMPED, 2, theta);
        let consistent = ratio(ShapeFunction::Linear, CONSISTENT, CONSISTENT, 2, theta);
        let mixed = ratio(ShapeFunction::Linear, CONSISTENT, LUMPED, 2, theta);
        assert!((lumped - s * m).abs() < 1e-12, "θ = {theta}: lumped {lumped}");
        assert!(
            (consistent - s / m).abs() < 1e-12,
            "θ = {theta}: consistent {consistent}"
        );
        assert!((mixed - s).abs() < 1e-12, "θ = {theta}: mixed {mixed}");
        // lumped waves are slow and consistent ones fast over the whole spectrum, for any
        // number of particles per cell
        for k in 1..=4 {
            let l = ratio(ShapeFunction::Linear, LUMPED, LUMPED, k, theta);
            let c = ratio(ShapeFunction::Linear, CONSISTENT, CONSISTENT, k, theta);
            // (one particle per cell at the centre: the consistent mass is singular at θ = π)
            let singular = k == 1 && j == 200;
            assert!(
                l < 1.0 && (c > 1.0 || (singular && c.is_nan())),
                "k = {k}, θ = {theta}: lumped {l}, consistent {c}"
            );
        }
    }
}

/// `1 − c_h/c = c θ²/96 + O(θ⁴)`: the period-error coefficients of docs/mass.md.
#[test]
fn small_wavenumbers_give_the_period_error_coefficients_of_every_kernel() {
    let cases = [
        (ShapeFunction::Linear, LUMPED, 13.0),
        (ShapeFunction::Linear, CONSISTENT, -5.0),
        (ShapeFunction::QuadraticBSpline, LUMPED, 25.0),
        (ShapeFunction::QuadraticBSpline, CONSISTENT, 1.0),
        (ShapeFunction::CubicBSpline, LUMPED, 32.0),
        (ShapeFunction::CubicBSpline, CONSISTENT, 0.0),
    ];
    let theta = 1e-3;
    for (shape, mass, coefficient) in cases {
        let got = (1.0 - ratio(shape, mass, mass, 2, theta)) * 96.0 / (theta * theta);
        println!("{shape} {mass}: {got:.5} (docs {coefficient})");
        assert!(
            (got - coefficient).abs() < 1e-2,
            "{shape} {mass}: {got} against {coefficient}"
        );
    }
}

/// The kernel `S(ξ)` and `S'(ξ)` from the 1D formulas of src/shape (not the weights the
/// operators use).
fn kernel(shape: ShapeFunction, xi: f64) -> (f64, f64) {
    use sparse_mpm::shape::{bspline, gimp, linear};
    match shape {
        ShapeFunction::Linear => (linear::tent(xi), linear::tent_derivative(xi)),
        ShapeFunction::Gimp { half_width } => gimp::kernel(xi, half_width),
        ShapeFunction::QuadraticBSpline => (bspline::quadratic(xi), bspline::quadratic_derivative(xi)),
        ShapeFunction::CubicBSpline => (bspline::cubic(xi), bspline::cubic_derivative(xi)),
    }
}

/// The eigenvalues of `M_a⁻¹ K M_v⁻¹ M` on a periodic bar of `n` cells, assembled densely from
/// the 1D kernels, against the symbols at `θ = 2πj/n`.
#[test]
fn the_symbols_are_the_eigenvalues_of_a_periodic_bar() {
    use nalgebra::DMatrix;
    let n = 12;
    let shapes = [
        ShapeFunction::Linear,
        ShapeFunction::Gimp { half_width: 0.25 },
        ShapeFunction::QuadraticBSpline,
        ShapeFunction::CubicBSpline,
    ];
    let schemes = [
        (LUMPED, LUMPED),
        (CONSISTENT, CONSISTENT),
        (LUMPED, CONSISTENT),
        (MassScheme::Blended { gamma: 0.5 }, MassScheme::Blended { gamma: 0.5 }),
        (
            MassScheme::TruncatedSeries { k: 3 },
            MassScheme::TruncatedSeries { k: 3 },
        ),
    ];
    for shape in shapes {
        for k in [1, 2, 3] {
            let (mut m, mut kk, mut ml) = (DMatrix::zeros(n, n), DMatrix::zeros(n, n), DMatrix::zeros(n, n));
            for cell in 0..n {
                for a in 0..k {
                    let x = cell as f64 + (a as f64 + 0.5) / k as f64;
                    let w: Vec<(usize, f64, f64)> = (0..n)
                        .flat_map(|i| (-2i64..=2).map(move |wrap| (i, i as f64 + (wrap * n as i64) as f64)))
                        .map(|(i, xi)| {
                            let (s, ds) = kernel(shape, x - xi);
                            (i, s, -ds)
                        })
                        .filter(|w| w.1 != 0.0 || w.2 != 0.0)
                        .collect();
                    let mp = 1.0 / k as f64;
                    for &(i, si, di) in &w {
                        ml[(i, i)] += mp * si;
                        for &(j, sj, dj) in &w {
                            m[(i, j)] += mp * si * sj;
                            kk[(i, j)] += mp * di * dj;
                        }
                    }
                }
            }
            let inverse = |scheme: MassScheme| -> DMatrix<f64> {
                let mli = ml.clone().try_inverse().unwrap();
                match scheme {
                    MassScheme::Lumped => mli,
                    MassScheme::Consistent => m.clone().try_inverse().unwrap(),
                    MassScheme::Blended { gamma } => (&ml * (1.0 - gamma) + &m * gamma).try_inverse().unwrap(),
                    MassScheme::TruncatedSeries { k } => {
                        let r = DMatrix::identity(n, n) - &mli * &m;
                        let mut term = DMatrix::identity(n, n);
                        let mut sum = DMatrix::zeros(n, n);
                        for _ in 0..k {
                            sum += &term;
                            term = &r * &term;
                        }
                        sum * mli
                    }
                    _ => unreachable!(),
                }
            };
            let symbols = Symbols::new(shape, k).unwrap();
            for (v, a) in schemes {
                // One particle per cell at the centre has symmetric weights, so the consistent
                // mass symbol vanishes at θ = π (the matrix is singular), as the symbols say.
                let singular = (0..n).any(|j| symbols.mass(2.0 * PI * j as f64 / n as f64) < 1e-12);
                if singular
                    && [v, a]
                        .iter()
                        .any(|s| !matches!(s, MassScheme::Lumped | MassScheme::TruncatedSeries { .. }))
                {
                    assert_eq!(k, 1, "{shape}: singular mass with {k} particles per cell");
                    continue;
                }
                let op = inverse(a) * &kk * inverse(v) * &m;
                let mut got: Vec<f64> = op.complex_eigenvalues().iter().map(|z| z.re).collect();
                got.sort_by(f64::total_cmp);
                let mut want: Vec<f64> = (0..n)
                    .map(|j| {
                        let theta = 2.0 * PI * j as f64 / n as f64;
                        symbols.stiffness(theta)
                            * symbols.inverse(a, theta)
                            * symbols.inverse(v, theta)
                            * symbols.mass(theta)
                    })
                    .collect();
                want.sort_by(f64::total_cmp);
                for (g, w) in got.iter().zip(&want) {
                    assert!(
                        (g - w).abs() < 1e-9 * want[n - 1],
                        "{shape} k = {k} {v}/{a}: {got:?} against {want:?}"
                    );
                }
            }
        }
    }
}

#[test]
fn a_periodic_bar_samples_its_own_wavenumbers_and_bad_input_names_the_parameter() {
    let curve = dispersion(ShapeFunction::Linear, LUMPED, LUMPED, 2, 0, Some(8)).unwrap();
    let thetas: Vec<f64> = curve.iter().map(|p| p.theta).collect();
    assert_eq!(thetas.len(), 4);
    for (j, t) in thetas.iter().enumerate() {
        assert!((t - 2.0 * PI * (j + 1) as f64 / 8.0).abs() < 1e-15);
    }
    let curve = dispersion(ShapeFunction::QuadraticBSpline, CONSISTENT, CONSISTENT, 2, 64, None).unwrap();
    assert_eq!(curve.len(), 64);
    assert!((curve[63].theta - PI).abs() < 1e-15);
    for (args, name) in [
        ((0usize, 64usize, None), "particles_per_cell"),
        ((2, 0, None), "samples"),
        ((2, 0, Some(1)), "cells"),
    ] {
        let e = dispersion(ShapeFunction::Linear, LUMPED, LUMPED, args.0, args.1, args.2).unwrap_err();
        assert!(e.to_string().contains(name), "{e}");
    }
    let e = dispersion(
        ShapeFunction::Linear,
        MassScheme::Blended { gamma: 2.0 },
        LUMPED,
        2,
        8,
        None,
    )
    .unwrap_err();
    assert!(e.to_string().contains("gamma"), "{e}");
}

/// The vibrating bar (mirrored walls, 2 × 2 particles per cell) measures the same dispersion
/// at its own wavenumber: its spatial period error is `c/c_h(βh) − 1`.
#[test]
fn the_vibrating_bar_measures_the_dispersion_at_its_wavenumber() {
    use sparse_mpm::mass::MassOptions;
    use sparse_mpm_study::verification::bar::{Bar, Ends};
    use sparse_mpm_study::verification::Choices;
    let cells = 32;
    for shape in [
        ShapeFunction::Linear,
        ShapeFunction::QuadraticBSpline,
        ShapeFunction::CubicBSpline,
    ] {
        for mass in [LUMPED, CONSISTENT] {
            let bar = Bar {
                amplitude: 1e-3,
                ..Bar::new(Ends::FixedFixed)
            };
            let choices = Choices {
                shape,
                mass: MassOptions::both(mass),
                cfl: 0.2,
                ..Choices::default()
            };
            let measured = bar
                .run(cells, &choices)
                .unwrap()
                .metric("spatial_period_error")
                .unwrap();
            let theta = bar.wavenumber() * bar.length / cells as f64;
            let predicted = 1.0 / ratio(shape, mass, mass, 2, theta) - 1.0;
            println!("{shape} {mass}: measured {measured:+.4e}, dispersion {predicted:+.4e}");
            assert!(
                (measured - predicted).abs() <= 0.02 * predicted.abs() + 2e-6,
                "{shape} {mass}: measured {measured}, dispersion {predicted}"
            );
        }
    }
}

/// One particle per cell at the centre: the consistent mass is singular at θ = π (symmetric
/// weights) for every kernel, and the curve says NaN there rather than a round-off number.
#[test]
fn a_singular_consistent_mass_gives_nan_not_round_off() {
    for shape in [
        ShapeFunction::Linear,
        ShapeFunction::QuadraticBSpline,
        ShapeFunction::CubicBSpline,
    ] {
        let curve = dispersion(shape, CONSISTENT, CONSISTENT, 1, 4, None).unwrap();
        assert!(curve[3].c_ratio.is_nan(), "{shape}: {:?}", curve[3]);
        assert!(curve[..3].iter().all(|p| p.c_ratio.is_finite()), "{shape}: {curve:?}");
        let lumped = dispersion(shape, LUMPED, LUMPED, 1, 4, None).unwrap();
        assert!(lumped.iter().all(|p| p.c_ratio.is_finite()));
    }
}
