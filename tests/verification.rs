//! Verification problems with known answers, at sizes that run in seconds: convergence orders
//! fitted from three or more resolutions, the sign and order of the frequency error under
//! lumped and consistent mass, the energy behaviour of PIC and FLIP, the single material point.

use sparse_mpm::mass::{MassOptions, MassScheme};
use sparse_mpm::simulation::{Transfer, UpdateScheme};
use sparse_mpm::ShapeFunction;
use sparse_mpm_study::verification::bar::{Bar, Ends};
use sparse_mpm_study::verification::manufactured::{self, AxisAlignedMms, GeneralisedVortex};
use sparse_mpm_study::verification::{cantilever, fitted_order, single_point, Choices};

/// The bar at a small amplitude, so that particles stay within a fraction of a cell of their
/// start and the grid-crossing error of bilinear functions does not mix in.
fn small_bar(ends: Ends) -> Bar {
    Bar {
        amplitude: 1e-3,
        ..Bar::new(ends)
    }
}

fn choices(mass: MassScheme, transfer: Transfer) -> Choices {
    Choices {
        mass: MassOptions::both(mass),
        transfer,
        cfl: 0.2,
        ..Choices::default()
    }
}

#[test]
fn the_bar_period_error_is_positive_for_lumped_and_negative_for_consistent_mass_and_second_order() {
    for ends in [Ends::FixedFree, Ends::FixedFixed] {
        let bar = small_bar(ends);
        for (mass, sign) in [(MassScheme::Lumped, 1.0), (MassScheme::Consistent, -1.0)] {
            let errors: Vec<(f64, f64)> = [8, 16, 32]
                .iter()
                .map(|&cells| {
                    let o = bar.run(cells, &choices(mass, Transfer::Flip)).unwrap();
                    (o.cell_size, o.metric("period_error").unwrap())
                })
                .collect();
            assert!(
                errors.iter().all(|&(_, e)| e * sign > 0.0),
                "{} {:#}: period errors {errors:?}",
                bar.name(),
                mass
            );
            let magnitudes: Vec<(f64, f64)> = errors.iter().map(|&(h, e)| (h, e.abs())).collect();
            let order = fitted_order(&magnitudes).unwrap();
            assert!(
                (1.6..2.4).contains(&order),
                "{} {:#}: order {order} from {errors:?}",
                bar.name(),
                mass
            );
        }
    }
}

#[test]
fn pic_with_lumped_mass_damps_the_bar_strongly_and_flip_far_less() {
    let bar = small_bar(Ends::FixedFixed);
    let change = |mass, transfer| {
        bar.run(16, &choices(mass, transfer))
            .unwrap()
            .metric("energy_change")
            .unwrap()
    };
    let pic = change(MassScheme::Lumped, Transfer::Pic);
    let flip = change(MassScheme::Lumped, Transfer::Flip);
    let pic_consistent = change(MassScheme::Consistent, Transfer::Pic);
    assert!(pic < -0.3, "PIC with lumped mass loses {pic}");
    assert!(flip.abs() < 0.03, "FLIP changes the energy by {flip}");
    // PIC with the consistent mass is an L2 projection: it keeps what the grid represents.
    assert!(
        pic_consistent.abs() < 0.03,
        "PIC with consistent mass: {pic_consistent}"
    );
}

#[test]
fn the_single_material_point_follows_its_exact_solution() {
    for update in [UpdateScheme::Usf, UpdateScheme::Musl] {
        let o = single_point::run(
            0.01,
            &Choices {
                update,
                ..Choices::default()
            },
        )
        .unwrap();
        let (v, x) = (o.metric("velocity_error").unwrap(), o.metric("position_error").unwrap());
        assert!(v < 5e-3, "{update:?}: velocity error {v}");
        assert!(x < 3e-2, "{update:?}: position error {x}");
    }
    // Bardenhagen (2002): one order of the updates conserves the energy of this problem, the
    // other dissipates it.
    let drift = |update| {
        single_point::run(
            0.01,
            &Choices {
                update,
                ..Choices::default()
            },
        )
        .unwrap()
        .metric("energy_drift")
        .unwrap()
    };
    assert!(drift(UpdateScheme::Usl) > 10.0 * drift(UpdateScheme::Usf));
}

#[test]
fn the_vortex_converges_with_gimp_and_b_splines() {
    let vortex = GeneralisedVortex {
        amplitude: 0.05,
        ..GeneralisedVortex::default()
    };
    for (shape, least) in [
        (ShapeFunction::Gimp { half_width: 0.25 }, 1.2),
        (ShapeFunction::QuadraticBSpline, 1.2),
    ] {
        let c = Choices {
            shape,
            cfl: 0.2,
            ..Choices::default()
        };
        let errors: Vec<(f64, f64)> = [16, 32, 64]
            .iter()
            .map(|&cells| {
                let o = manufactured::run(&vortex, cells, &c).unwrap();
                (o.cell_size, o.metric("displacement_error_l2").unwrap())
            })
            .collect();
        let order = fitted_order(&errors).unwrap();
        assert!(order > least, "{}: order {order} from {errors:?}", shape.name());
    }
}

/// The vortex with the smooth profile `g = (1 − ξ²)³` (the shear stress's gradient vanishes at
/// the free surfaces too): second order between the two finest grids with GIMP and both
/// B-splines, with APIC at A = 0.05 and with FLIP at A = 0.01 (FLIP's error at 0.05 includes a
/// finite-amplitude part that grows with GIMP on fine grids; docs/verification.md).
#[test]
fn the_smooth_vortex_converges_at_second_order_with_gimp_and_b_splines() {
    use sparse_mpm::simulation::Transfer;
    for (transfer, amplitude) in [(Transfer::Apic, 0.05), (Transfer::Flip, 0.01)] {
        let vortex = GeneralisedVortex::smooth(amplitude);
        for shape in [
            ShapeFunction::Gimp { half_width: 0.25 },
            ShapeFunction::QuadraticBSpline,
            ShapeFunction::CubicBSpline,
        ] {
            let c = Choices {
                shape,
                transfer,
                cfl: 0.2,
                ..Choices::default()
            };
            let errors: Vec<f64> = [32, 64, 128]
                .iter()
                .map(|&cells| {
                    manufactured::run(&vortex, cells, &c)
                        .unwrap()
                        .metric("displacement_error_l2")
                        .unwrap()
                })
                .collect();
            let local = (errors[1] / errors[2]).log2();
            println!("{transfer} A = {amplitude} {shape}: {errors:?}, order 64→128 {local:.3}");
            assert!(local >= 1.8, "{transfer} {shape}: local order {local} from {errors:?}");
        }
    }
}

/// The axis-aligned manufactured solution (B5) on its roller walls, mirrored: second order with
/// GIMP and both B-splines (at the small amplitude 10⁻³, where the particles stay within a
/// fraction of a cell; at Uintah's 0.05 they cross cells and the quadrature at moved particles
/// takes over, docs/verification.md). Held, the walls made it first order (at Uintah's
/// amplitude, quadratic B-splines: orders 1.20, 1.13, 1.35 from 8 to 64 cells).
#[test]
fn the_axis_aligned_manufactured_solution_converges_at_second_order_on_mirrored_rollers() {
    let problem = AxisAlignedMms {
        amplitude: 1e-3,
        ..AxisAlignedMms::default()
    };
    for shape in [
        ShapeFunction::QuadraticBSpline,
        ShapeFunction::CubicBSpline,
        ShapeFunction::Gimp { half_width: 0.25 },
    ] {
        let c = Choices {
            shape,
            cfl: 0.2,
            ..Choices::default()
        };
        let errors: Vec<f64> = [32, 64]
            .iter()
            .map(|&cells| {
                let o = manufactured::run(&problem, cells, &c).unwrap();
                o.metric("displacement_error_l2").unwrap()
            })
            .collect();
        let order = (errors[0] / errors[1]).log2();
        println!("{shape}: {errors:?}, order {order:.3}");
        assert!(order >= 1.9, "{shape}: order {order} from {errors:?}");
    }
}

#[test]
fn richardson_extrapolation_recovers_a_known_limit_and_order() {
    // f(h) = 2 + 3 h²: values on h = 1, 1/2, 1/4.
    let f = [5.0, 2.75, 2.1875];
    let (limit, order) = cantilever::extrapolate(f, 2.0).unwrap();
    assert!((limit - 2.0).abs() < 1e-12 && (order - 2.0).abs() < 1e-12);
    assert!(
        cantilever::extrapolate([1.0, 2.0, 1.5], 2.0).is_none(),
        "non-monotone differences"
    );
}

#[test]
fn the_transfer_loss_accounts_for_pic_and_vanishes_for_flip_with_the_consistent_mass() {
    let bar = small_bar(Ends::FixedFixed);
    let run = |mass, transfer| bar.run(16, &choices(mass, transfer)).unwrap();
    // PIC: the energy lost is what the transfers lost (the grid update itself conserves
    // energy to the time-integration error).
    let pic = run(MassScheme::Lumped, Transfer::Pic);
    let (lost, transfer) = (
        -pic.metric("energy_change").unwrap(),
        pic.metric("transfer_loss").unwrap(),
    );
    assert!(
        lost > 0.3 && (transfer - lost).abs() < 0.1 * lost,
        "lost {lost}, transfer loss {transfer}"
    );
    // FLIP with the consistent velocity mass: v = M⁻¹q, so the particles' kinetic energy changes
    // exactly as the grid's.
    let flip = run(MassScheme::Consistent, Transfer::Flip);
    let transfer = flip.metric("transfer_loss").unwrap();
    assert!(transfer.abs() < 1e-9, "FLIP, consistent: transfer loss {transfer}");
}

/// The time integrator's order on the single material point (v₀ = 10⁻³, where the volume change
/// is 1.6e-4 of itself): the velocity error at the report times halves with Δt for USF, USL
/// and MUSL (first order), USL's constant is about ten times the others', and MUSL's velocity
/// is a half-step quantity: against `v(t − Δt/2)` its error falls to the amplitude floor.
#[test]
fn the_single_point_measures_the_time_order_of_each_update_scheme() {
    use sparse_mpm::simulation::{Transfer, UpdateScheme};
    let v0 = 1e-3;
    let steps = [4e-3, 2e-3, 1e-3];
    let mut at_coarsest = Vec::new();
    for update in [UpdateScheme::Usf, UpdateScheme::Usl, UpdateScheme::Musl] {
        let choices = Choices {
            update,
            transfer: Transfer::Flip,
            ..Choices::default()
        };
        let outcomes: Vec<_> = steps
            .iter()
            .map(|&dt| single_point::run_with_step(v0, dt, &choices).unwrap())
            .collect();
        let errors: Vec<f64> = outcomes.iter().map(|o| o.metric("velocity_error").unwrap()).collect();
        let points: Vec<(f64, f64)> = steps.iter().copied().zip(errors.iter().copied()).collect();
        let order = fitted_order(&points).unwrap();
        println!("{update:?}: velocity errors {errors:?}, order {order:.3}");
        assert!((order - 1.0).abs() < 0.1, "{update:?}: time order {order} ({errors:?})");
        at_coarsest.push(errors[0]);
        if update == UpdateScheme::Musl {
            let h = outcomes[0].histories.iter().find(|h| h.name == "velocity").unwrap();
            let staggered = h
                .time
                .iter()
                .zip(&h.value)
                .skip(1)
                .map(|(t, v)| (v - single_point::velocity_exact(v0, t - 0.5 * steps[0])).abs())
                .fold(0.0, f64::max)
                / v0;
            println!("MUSL against v(t − Δt/2): {staggered:.3e}");
            assert!(
                staggered < errors[0] / 10.0,
                "MUSL staggered {staggered} against {}",
                errors[0]
            );
        }
    }
    assert!(
        at_coarsest[1] > 5.0 * at_coarsest[0].max(at_coarsest[2]),
        "USL {at_coarsest:?}"
    );
}

/// The vortex profile's derivatives against central differences, for the published and the
/// smooth exponent, and `g'' = 0` at the free surfaces of the smooth one only.
#[test]
fn the_vortex_profiles_derivatives_match_finite_differences() {
    for n in [2, 3, 4] {
        let v = GeneralisedVortex {
            exponent: n,
            ..GeneralisedVortex::default()
        };
        let eps = 1e-5;
        for k in 1..20 {
            let r = 0.75 + 0.5 * k as f64 / 20.0;
            let (_, g1, g2) = v.profile(r);
            let fd1 = (v.profile(r + eps).0 - v.profile(r - eps).0) / (2.0 * eps);
            let fd2 = (v.profile(r + eps).1 - v.profile(r - eps).1) / (2.0 * eps);
            assert!(
                (g1 - fd1).abs() < 1e-6 * (1.0 + g1.abs()),
                "n = {n}, R = {r}: g' {g1} against {fd1}"
            );
            assert!(
                (g2 - fd2).abs() < 1e-5 * (1.0 + g2.abs()),
                "n = {n}, R = {r}: g'' {g2} against {fd2}"
            );
        }
        let at_surface = v.profile(v.inner_radius).2.abs().max(v.profile(v.outer_radius).2.abs());
        if n == 2 {
            assert!(
                (at_surface - 8.0 / 0.25f64.powi(2)).abs() < 1e-9,
                "n = 2: g'' = {at_surface} at the surface"
            );
        } else {
            assert!(at_surface < 1e-12, "n = {n}: g'' = {at_surface} at the surface");
        }
    }
}

/// The expanding ring's body force is `a − Div P / ρ0`, checked against central differences of
/// the exact first Piola stress and of the exact motion (not of the formula it evaluates).
#[test]
fn the_expanding_rings_body_force_balances_its_motion_and_stress() {
    use sparse_mpm_study::verification::manufactured::{ExpandingRing, Manufactured};
    let ring = ExpandingRing {
        amplitude: 0.05,
        ..ExpandingRing::default()
    };
    let (e, tau) = (1e-5, 1e-4);
    for (k, &t) in [0.1, 0.3, 0.45].iter().enumerate() {
        for j in 0..12 {
            let angle = 0.5 * j as f64 + 0.1 * k as f64;
            let r = 0.78 + 0.44 * j as f64 / 11.0;
            let x0 = [r * angle.cos(), r * angle.sin()];
            let p = |dx: f64, dy: f64| ring.first_piola([x0[0] + dx, x0[1] + dy], t);
            let (px, mx, py, my) = (p(e, 0.0), p(-e, 0.0), p(0.0, e), p(0.0, -e));
            let div = [
                (px[0] - mx[0]) / (2.0 * e) + (py[1] - my[1]) / (2.0 * e),
                (px[2] - mx[2]) / (2.0 * e) + (py[3] - my[3]) / (2.0 * e),
            ];
            let u = |t: f64| ring.exact_displacement(x0, t);
            let (up, u0, um) = (u(t + tau), u(t), u(t - tau));
            let a = [
                (up[0] - 2.0 * u0[0] + um[0]) / (tau * tau),
                (up[1] - 2.0 * u0[1] + um[1]) / (tau * tau),
            ];
            let b = ring.body_force(x0, t);
            for c in 0..2 {
                let want = a[c] - div[c] / ring.density;
                assert!(
                    (b[c] - want).abs() < 1e-4 * (1.0 + want.abs()),
                    "t = {t}, X = {x0:?}, component {c}: {} against {want}",
                    b[c]
                );
            }
            // the λ term is active: J ≠ 1 inside the ring
            let f = ring.deformation_gradient(x0, t);
            if (0.8..1.2).contains(&r) {
                assert!((f[0] * f[3] - f[1] * f[2] - 1.0).abs() > 1e-6, "J = 1 at R = {r}");
            }
        }
    }
}

/// The expanding ring converges at second order with GIMP and B-splines (APIC, A = 0.01).
#[test]
fn the_expanding_ring_converges_at_second_order_with_gimp_and_b_splines() {
    use sparse_mpm::simulation::Transfer;
    use sparse_mpm_study::verification::manufactured::ExpandingRing;
    let ring = ExpandingRing::default();
    for shape in [
        ShapeFunction::Gimp { half_width: 0.25 },
        ShapeFunction::QuadraticBSpline,
        ShapeFunction::CubicBSpline,
    ] {
        let c = Choices {
            shape,
            transfer: Transfer::Apic,
            cfl: 0.2,
            ..Choices::default()
        };
        let errors: Vec<f64> = [32, 64, 128]
            .iter()
            .map(|&cells| {
                manufactured::run(&ring, cells, &c)
                    .unwrap()
                    .metric("displacement_error_l2")
                    .unwrap()
            })
            .collect();
        let local = (errors[1] / errors[2]).log2();
        println!("ring {shape}: {errors:?}, order 64→128 {local:.3}");
        assert!(local >= 1.8, "{shape}: local order {local} from {errors:?}");
    }
}
