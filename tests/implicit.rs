//! Implicit integration: the tangent of the internal force against central differences for
//! every kernel and material.

use sparse_mpm::implicit::{gradient_operator, internal_force, internal_force_and_tangent};
use sparse_mpm::material::{DruckerPrager, LinearElastic, Material, NeoHookean, PlaneCondition, VonMises};
use sparse_mpm::particles::lattice;
use sparse_mpm::{Grid, Operators, Particles, ShapeFunction};

const SHAPES: [ShapeFunction; 4] = [
    ShapeFunction::Linear,
    ShapeFunction::Gimp { half_width: 0.25 },
    ShapeFunction::QuadraticBSpline,
    ShapeFunction::CubicBSpline,
];

fn materials() -> [Material; 4] {
    [
        Material::LinearElastic(LinearElastic::new(1000.0, 0.3, PlaneCondition::Strain).unwrap()),
        Material::NeoHookean(NeoHookean {
            youngs_modulus: 1000.0,
            poisson_ratio: 0.3,
        }),
        // Yield near the states of `setup`: some particles return, some do not.
        Material::VonMises(VonMises {
            youngs_modulus: 1000.0,
            poisson_ratio: 0.3,
            yield_stress: 2.0,
            hardening_modulus: 50.0,
            plane: PlaneCondition::Strain,
        }),
        Material::DruckerPrager(DruckerPrager {
            youngs_modulus: 1000.0,
            poisson_ratio: 0.3,
            friction_angle: 30.0,
            cohesion: 1.0,
            dilatancy_angle: 10.0,
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
            // An elastic strain and a plastic strain per particle, and their stress τ/J.
            Material::VonMises(_) | Material::DruckerPrager(_) => {
                p.with_plastic_state();
                let e = [
                    -4e-3 + 2e-3 * noise(11 * k),
                    -2e-3 + 2e-3 * noise(11 * k + 1),
                    1e-3 * noise(11 * k + 2),
                    5e-4 * noise(11 * k + 3),
                ];
                [p.elastic_xx[k], p.elastic_yy[k], p.elastic_xy[k], p.elastic_zz[k]] = e;
                p.plastic_strain[k] = 0.01 * noise(11 * k + 4).abs();
                let cone = material.cone().unwrap();
                let tau = cone.update(&p.plastic_state(k), [1.0, 0.0, 0.0, 1.0]).kirchhoff;
                let j = f[0] * f[3] - f[1] * f[2];
                tau.map(|t| t / j)
            }
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
            // Small enough that no particle's state crosses a yield surface or the apex within it.
            let eps = 1e-7;
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
            // Symmetric (the hyperelastic tangent has major symmetry, and so has the return map's
            // with associated flow).
            let kt = k.transpose();
            let mut asym = 0.0f64;
            for (i, j, v) in k.triplet_iter() {
                let t = kt.get_entry(i, j).map_or(0.0, |e| e.into_value());
                asym = asym.max((v - t).abs());
            }
            // Non-associated flow (ψ ≠ φ) has no symmetric tangent; the rest must.
            let associated = !matches!(material, Material::DruckerPrager(m) if m.dilatancy_angle != m.friction_angle);
            if associated {
                assert!(asym <= 1e-12 * scale, "{shape:?} {material:?}: asymmetry {asym:.3e}");
            } else {
                assert!(
                    asym > 1e-9 * scale,
                    "{shape:?}: a non-associated tangent is not symmetric"
                );
            }
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

/// The Newmark integrator on the verification problems.
mod newmark {
    use sparse_mpm::mass::{MassOptions, MassScheme};
    use sparse_mpm::simulation::{Integrator, Newmark, Simulation, TimeStep};
    use sparse_mpm_study::verification::bar::{newmark_period, Bar, Ends};
    use sparse_mpm_study::verification::{cantilever, disks, Choices};

    fn choices(scheme: MassScheme) -> Choices {
        Choices {
            mass: MassOptions::both(scheme),
            cfl: 0.1,
            ..Choices::default()
        }
    }

    /// `sim` switched to the average-acceleration rule at `factor` times its explicit stable step.
    fn implicit(mut sim: Simulation, factor: f64) -> Simulation {
        let dt = factor * sim.stable_time_step();
        sim.set_integrator(Integrator::Newmark(Newmark::default()), TimeStep::Fixed { dt })
            .unwrap();
        sim
    }

    #[test]
    fn the_bar_period_follows_the_discrete_newmark_theory_at_five_times_the_stable_step() {
        let mut spatial = Vec::new();
        for scheme in [MassScheme::Lumped, MassScheme::Consistent] {
            let cells = 32;
            let explicit = Bar {
                amplitude: 1e-3,
                ..Bar::new(Ends::FixedFixed)
            };
            // The space-discrete period T_h in closed form (two particles per cell), checked
            // against an explicit run in the_closed_form_space_discrete_period_is_….
            let t = explicit.period();
            let t_h = explicit
                .discrete_period(cells, 2, scheme == MassScheme::Consistent)
                .unwrap();
            let bar = Bar {
                newmark: Some((Newmark::default(), 5.0)),
                periods: 10.0,
                ..explicit
            };
            let i = bar.run(cells, &choices(scheme)).unwrap();
            let dt = i.metric("dt").unwrap();
            let measured = t * (1.0 + i.metric("period_error").unwrap());
            let predicted = newmark_period(t_h, dt);
            let off = measured / predicted - 1.0;
            assert!(
                off.abs() < 1e-3,
                "{scheme:?}: period {measured} against the discrete Newmark period {predicted} ({off:.2e})"
            );
            // Energy over ten periods: the integrator's share (the total change less the
            // transfers' loss) within 1%; the transfers' share reported apart.
            let change = i.metric("energy_change").unwrap();
            let transfers = i.metric("transfer_loss").unwrap();
            assert!(
                (change + transfers).abs() < 0.01 && i.metric("energy_drift").unwrap() < 0.05,
                "{scheme:?}: energy change {change:.3e}, of which the transfers {transfers:.3e}"
            );
            eprintln!(
                "{scheme:?}: period / Newmark theory − 1 = {off:.2e}; energy change over 10 periods {change:.3e}, \
                 transfers' share {transfers:.3e}; space-discrete period error {:.3e}",
                i.metric("spatial_period_error").unwrap()
            );
            spatial.push(i.metric("spatial_period_error").unwrap().abs());
        }
        assert!(
            spatial[1] < spatial[0],
            "consistent {} against lumped {}",
            spatial[1],
            spatial[0]
        );
    }

    #[test]
    fn newton_converges_quadratically_on_the_cantilever() {
        for scheme in [MassScheme::Lumped, MassScheme::Consistent] {
            let scene = cantilever::scene(8, &choices(scheme)).unwrap();
            let mut sim = implicit(scene.build().unwrap(), 5.0);
            let mut shown = Vec::new();
            for _ in 0..10 {
                let report = sim.step().unwrap();
                let r = sim.newton_residuals().to_vec();
                assert!(report.acceleration_solve.iterations >= 2, "{scheme:?}: {r:?}");
                assert!(*r.last().unwrap() <= Newmark::default().tolerance, "{scheme:?}: {r:?}");
                // r_{k+1} ≤ C r_k², above round-off.
                for w in r.windows(2).filter(|w| w[1] > 1e-12) {
                    let ratio = w[1] / (w[0] * w[0]);
                    assert!(ratio < 10.0, "{scheme:?}: residuals {r:?}, r_k+1 / r_k² = {ratio:.2e}");
                }
                shown.push(r);
            }
            eprintln!("{scheme:?}: Newton residuals of the first steps {:?}", &shown[..3]);
        }
    }

    #[test]
    fn the_two_disks_run_to_the_end_with_the_implicit_integrator_and_each_mass() {
        for scheme in [
            MassScheme::Lumped,
            MassScheme::Consistent,
            MassScheme::Blended { gamma: 13.0 / 18.0 },
        ] {
            let c = choices(scheme);
            let scene = disks::scene(20, &c).unwrap();
            let mut sim = implicit(scene.build().unwrap(), 5.0);
            let e0 = sim.particles().kinetic_energy();
            let mut last = None;
            sim.run_until(scene.time.end, |_, r| {
                last = Some(r.clone());
                Ok(())
            })
            .unwrap();
            let last = last.unwrap();
            assert!((last.time - scene.time.end).abs() < 1e-9);
            let (total, transfers) = (last.total_energy / e0, last.transfer_loss / e0);
            assert!(
                total.is_finite() && total < 1.01 && (total + transfers - 1.0).abs() < 0.05,
                "{scheme:?}: E/E0 {total}, transfers {transfers}"
            );
            eprintln!(
                "{scheme:?}: {} steps, E_end/E0 = {total:.4}, transfers' loss {transfers:.4}",
                sim.steps()
            );
        }
    }

    #[test]
    fn an_implicit_run_resumes_from_a_checkpoint_bit_for_bit() {
        let scene = cantilever::scene(8, &choices(MassScheme::Consistent)).unwrap();
        let mut whole = implicit(scene.build().unwrap(), 5.0);
        let mut cut = implicit(scene.build().unwrap(), 5.0);
        for _ in 0..6 {
            whole.step().unwrap();
        }
        for _ in 0..3 {
            cut.step().unwrap();
        }
        let dir = std::env::temp_dir().join(format!("sparse_mpm_implicit_ckpt_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("sim.ckpt");
        cut.write_checkpoint(&path).unwrap();
        let mut resumed = Simulation::read_checkpoint(&path).unwrap();
        assert_eq!(resumed.options().integrator, whole.options().integrator);
        for _ in 0..3 {
            resumed.step().unwrap();
        }
        let (a, b) = (whole.particles(), resumed.particles());
        for (x, y) in [(&a.x, &b.x), (&a.vx, &b.vx), (&a.sxx, &b.sxx), (&a.fxy, &b.fxy)] {
            assert!(x.iter().zip(y.iter()).all(|(u, v)| u.to_bits() == v.to_bits()));
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn the_newton_matrix_keeps_its_symbolic_analysis_and_a_step_that_does_not_converge_is_an_error() {
        let scene = cantilever::scene(8, &choices(MassScheme::Consistent)).unwrap();
        let mut sim = implicit(scene.build().unwrap(), 5.0);
        let mut iterations = 0;
        for _ in 0..10 {
            iterations += sim.step().unwrap().acceleration_solve.iterations;
        }
        let analyses = sim.newton_symbolic_analyses();
        assert!(
            (1..10).contains(&analyses) && analyses < iterations,
            "{analyses} analyses for {iterations} Newton iterations in 10 steps"
        );
        // One iteration allowed, a tolerance no iterate meets: an error naming the step.
        let strict = Newmark {
            max_iterations: 1,
            tolerance: 1e-14,
            ..Newmark::default()
        };
        let mut sim = scene.build().unwrap();
        let dt = 5.0 * sim.stable_time_step();
        sim.set_integrator(Integrator::Newmark(strict), TimeStep::Fixed { dt })
            .unwrap();
        let err = sim.step().unwrap_err().to_string();
        assert!(
            err.contains("step 1:") && err.contains("did not converge") && err.contains("time.dt"),
            "{err}"
        );
    }

    #[test]
    fn newmark_is_refused_with_a_cfl_step_or_apic_naming_the_option() {
        let scene = cantilever::scene(8, &choices(MassScheme::Lumped)).unwrap();
        let mut sim = scene.build().unwrap();
        let err = sim
            .set_integrator(Integrator::Newmark(Newmark::default()), TimeStep::Cfl { number: 0.5 })
            .unwrap_err();
        assert!(err.to_string().contains("fixed time step"), "{err}");
        let bad = Newmark {
            beta: 0.0,
            ..Newmark::default()
        };
        let err = sim
            .set_integrator(Integrator::Newmark(bad), TimeStep::Fixed { dt: 1e-3 })
            .unwrap_err();
        assert!(err.to_string().contains("beta"), "{err}");
        // The simulation is unchanged and steps explicitly.
        assert_eq!(sim.options().integrator, Integrator::Explicit);
        sim.step().unwrap();
    }
}

#[test]
fn a_scene_selects_newmark_and_a_cfl_step_is_refused_naming_the_key() {
    use sparse_mpm::scene::Scene;
    let base = include_str!("../scenes/two_disks.toml").replace(
        "[schemes]",
        "[schemes]\nintegrator = { newmark = { beta = 0.25, gamma = 0.5, max_iterations = 10 } }",
    );
    let refused = Scene::from_toml_str(&base).unwrap_err().to_string();
    assert!(
        refused.contains("schemes.integrator") && refused.contains("fixed time step"),
        "{refused}"
    );
    let scene = Scene::from_toml_str(&base.replace("cfl = 0.5", "dt = 0.05")).unwrap();
    let mut sim = scene.build().unwrap();
    let report = sim.step().unwrap();
    assert_eq!(
        report.dt, 0.05,
        "a fixed step above the explicit stable step is taken as it is"
    );
    // Linear elastic disks moving apart at rest stresses: the predictor, or one Newton step.
    assert!(
        report.acceleration_solve.iterations <= 1,
        "{:?}",
        sim.newton_residuals()
    );
    assert!(
        report.acceleration_solve.relative_residual <= 1e-10,
        "{:?}",
        sim.newton_residuals()
    );
    let bad = base
        .replace("cfl = 0.5", "dt = 0.05")
        .replace("beta = 0.25", "beta = 0.75");
    let err = Scene::from_toml_str(&bad).unwrap_err().to_string();
    assert!(err.contains("beta"), "{err}");
}

#[test]
fn the_closed_form_space_discrete_period_is_the_one_the_explicit_bar_measures() {
    use sparse_mpm::mass::{MassOptions, MassScheme};
    use sparse_mpm_study::verification::bar::{Bar, Ends};
    use sparse_mpm_study::verification::Choices;
    let bar = Bar {
        amplitude: 1e-3,
        ..Bar::new(Ends::FixedFixed)
    };
    for (scheme, consistent) in [(MassScheme::Lumped, false), (MassScheme::Consistent, true)] {
        for cells in [16, 32] {
            let choices = Choices {
                mass: MassOptions::both(scheme),
                cfl: 0.1,
                ..Choices::default()
            };
            let e = bar.run(cells, &choices).unwrap();
            let measured = bar.period() * (1.0 + e.metric("spatial_period_error").unwrap());
            let closed = bar.discrete_period(cells, 2, consistent).unwrap();
            assert!(
                (measured / closed - 1.0).abs() < 1e-4,
                "{scheme:?} {cells}: measured {measured}, closed form {closed}"
            );
        }
    }
}

/// The two-disk scene with the Newmark integrator at `dt`, `particles_per_cell` per cell axis
/// and the mass table `mass` (TOML inline table).
fn disks_newmark(dt: f64, particles_per_cell: usize, mass: &str, end: f64) -> sparse_mpm::scene::Scene {
    sparse_mpm::scene::Scene::from_toml_str(&disks_newmark_text(dt, particles_per_cell, mass, end)).unwrap()
}

/// The text of [`disks_newmark`]'s scene.
fn disks_newmark_text(dt: f64, particles_per_cell: usize, mass: &str, end: f64) -> String {
    include_str!("../scenes/two_disks.toml")
        .replace(
            "mass = { velocity = \"lumped\", acceleration = \"lumped\" }",
            &format!("mass = {mass}\nintegrator = {{ newmark = {{}} }}"),
        )
        .replace("end = 3.5\ncfl = 0.5", &format!("end = {end}\ndt = {dt}"))
        .replace(
            "particles_per_cell = 2",
            &format!("particles_per_cell = {particles_per_cell}"),
        )
}

#[test]
fn only_newmark_parameters_stable_for_every_step_and_usable_steps_are_accepted() {
    use sparse_mpm::simulation::Newmark;
    for (beta, gamma) in [(0.25, 0.9), (0.1, 0.5), (0.3, 0.7)] {
        let err = Newmark {
            beta,
            gamma,
            ..Newmark::default()
        }
        .validate()
        .unwrap_err()
        .to_string();
        assert!(
            err.contains("beta") && err.contains("2β ≥ γ"),
            "β = {beta}, γ = {gamma}: {err}"
        );
    }
    for (beta, gamma) in [(0.25, 0.5), (0.3025, 0.6), (0.5, 1.0)] {
        Newmark {
            beta,
            gamma,
            ..Newmark::default()
        }
        .validate()
        .unwrap();
    }
    let err = Newmark {
        tolerance: 1e-300,
        ..Newmark::default()
    }
    .validate()
    .unwrap_err()
    .to_string();
    assert!(err.contains("tolerance"), "{err}");
    let text = include_str!("../scenes/two_disks.toml")
        .replace("[schemes]", "[schemes]\nintegrator = { newmark = {} }")
        .replace("cfl = 0.5", "dt = 1e-300");
    let err = sparse_mpm::scene::Scene::from_toml_str(&text)
        .and_then(|s| s.build().map(|_| ()))
        .unwrap_err()
        .to_string();
    assert!(err.contains("time.dt"), "{err}");
}

#[test]
fn an_iterate_that_runs_away_is_an_error_never_a_step() {
    // One particle per cell, consistent mass falling back to lumped, Δt = 25 explicit steps:
    // the Newton iterate runs away; every step taken keeps its energy, and the one that does
    // not converge is an error (before: strain energy 3.8e23, reported as converged).
    let scene = disks_newmark(
        0.05,
        1,
        "{ velocity = \"consistent\", acceleration = \"consistent\", singularity = \"fallback_to_lumped\" }",
        0.3,
    );
    let mut sim = scene.build().unwrap();
    let initial = sim.particles().kinetic_energy();
    for _ in 0..6 {
        match sim.step() {
            Ok(report) => assert!(
                report.total_energy <= 1.1 * initial && report.total_energy.is_finite(),
                "step {}: total energy {} from {initial}",
                report.step,
                report.total_energy
            ),
            Err(e) => {
                let e = e.to_string();
                assert!(e.contains("did not converge") && e.contains("time.dt"), "{e}");
                return;
            }
        }
    }
}

#[test]
fn the_singularity_policy_holds_for_the_newton_matrix() {
    use sparse_mpm::mass::SolveOutcome;
    // The plain consistent mass, one particle per cell: K and M share null vectors and the
    // Newton matrix is singular at some steps; the policy falls back to the lumped mass there
    // (before: "the Newton matrix is singular" at step 626).
    let scene = disks_newmark(
        0.002,
        1,
        "{ velocity = \"consistent\", acceleration = \"consistent\", singularity = \"fallback_to_lumped\", \
         stabilization = \"none\" }",
        1.5,
    );
    let mut sim = scene.build().unwrap();
    let initial = sim.particles().kinetic_energy();
    let mut fell_back = 0;
    let mut last = None;
    while sim.time() < 1.5 - 1e-9 {
        let report = sim.step().unwrap();
        fell_back += usize::from(matches!(
            report.acceleration_solve.outcome,
            SolveOutcome::FellBackToLumped { .. }
        ));
        last = Some(report);
    }
    let last = last.unwrap();
    assert!(
        fell_back > 0,
        "the fall-back is reported in the step's acceleration outcome"
    );
    assert!(
        (last.total_energy / initial - 1.0).abs() < 0.05,
        "energy {} from {initial}",
        last.total_energy
    );
    assert!(last.momentum[0].abs() < 1e-10 && last.momentum[1].abs() < 1e-10);
}

#[test]
fn a_rigid_translation_of_particles_on_grid_lines_is_exact() {
    use sparse_mpm::mass::{MassOptions, MassScheme};
    use sparse_mpm::material::{LinearElastic, Material, PlaneCondition};
    use sparse_mpm::simulation::{Body, Integrator, Newmark, Options, Simulation, TimeStep};
    // Particles on the vertical grid lines x = 0.5 + i h/2: the node beyond the block's right
    // edge has no mass but a gradient at the particles there (N = 0, ∇N ≠ 0).
    let grid = Grid::new([0.0, 0.0], [0.0625, 0.0625], [32, 32]).unwrap();
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for i in 0..=16 {
        for j in 0..8 {
            x.push(0.5 + i as f64 * 0.03125);
            y.push(0.5 + (j as f64 + 0.5) * 0.03125);
        }
    }
    let n = x.len();
    let v = 0.03125 * 0.03125;
    let mut p = Particles::new(x, y, vec![v; n], vec![v; n]).unwrap();
    p.vx.iter_mut().for_each(|u| *u = 0.1);
    for mass in [MassScheme::Lumped, MassScheme::Consistent] {
        let options = Options {
            shape: ShapeFunction::Linear,
            mass: MassOptions::both(mass),
            integrator: Integrator::Newmark(Newmark::default()),
            time_step: TimeStep::Fixed { dt: 0.001 },
            ..Options::default()
        };
        let material = Material::LinearElastic(LinearElastic::new(1000.0, 0.3, PlaneCondition::Stress).unwrap());
        let body = Body {
            name: "block".into(),
            material,
        };
        let mut sim = Simulation::new(grid.clone(), p.clone(), vec![body], options).unwrap();
        let report = sim.step().unwrap();
        assert!(
            report.strain_energy < 1e-25,
            "{mass:?}: strain energy {}",
            report.strain_energy
        );
        let momentum = 0.1 * v * n as f64;
        assert!(
            (report.momentum[0] - momentum).abs() < 1e-14 * momentum,
            "{mass:?}: momentum {} against {momentum}",
            report.momentum[0]
        );
    }
}

#[test]
fn a_step_that_carries_particles_off_the_grid_is_an_error_naming_the_step() {
    let text = include_str!("../scenes/seed_problem.toml")
        .replace("[schemes]", "[schemes]\nintegrator = { newmark = {} }")
        .replace("end = 0.001\ndt = 0.001", "end = 1.0\ndt = 1.0");
    let mut scene = sparse_mpm::scene::Scene::from_toml_str(&text).unwrap();
    scene.base_dir = Some(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes"));
    let mut sim = scene.build().unwrap();
    let before = sim.particles().x.clone();
    let err = sim.step().unwrap_err().to_string();
    assert!(
        err.contains("step 1:") && err.contains("outside the region") && err.contains("time.dt"),
        "{err}"
    );
    assert_eq!(sim.particles().x, before, "the particles are not moved");
}

/// The shipped vibrating bar with the Newmark integrator at `dt` for 20 steps and the mass
/// table `mass`: the total energy after each step.
fn bar_newmark_energies(mass: &str, dt: f64) -> Vec<f64> {
    let text = include_str!("../scenes/vibrating_bar.toml");
    let start = text.find("mass = {").unwrap();
    let end = start + text[start..].find('\n').unwrap();
    let mut text = format!(
        "{}mass = {mass}\nintegrator = {{ newmark = {{}} }}{}",
        &text[..start],
        &text[end..]
    );
    let time = text.find("[time]").unwrap();
    let next = time + text[time..].find("\n\n").unwrap();
    text.replace_range(time..next, &format!("[time]\nend = {}\ndt = {dt}", 20.0 * dt));
    let mut scene = sparse_mpm::scene::Scene::from_toml_str(&text).unwrap();
    scene.base_dir = Some(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes"));
    let mut sim = scene.build().unwrap();
    (0..20).map(|_| sim.step().unwrap().total_energy).collect()
}

#[test]
fn newmark_with_the_conjugate_gradient_is_newmark_with_the_consistent_mass() {
    // The conjugate gradient stands for the consistent mass in the Newmark residual too (it
    // once fell back to the lumped diagonal there, and the bar's energy grew 500-fold).
    let cg = bar_newmark_energies("{ velocity = \"cg\", acceleration = \"cg\" }", 0.4);
    let consistent = bar_newmark_energies("{ velocity = \"consistent\", acceleration = \"consistent\" }", 0.4);
    for (k, (a, b)) in cg.iter().zip(&consistent).enumerate() {
        assert!((a / b - 1.0).abs() < 1e-5, "step {}: cg {a}, consistent {b}", k + 1);
    }
    assert!((cg[19] / cg[0] - 1.0).abs() < 1e-2, "{cg:?}");
}

#[test]
fn particles_on_nodes_and_grid_lines_step_and_stay_unstrained_in_a_translation() {
    use sparse_mpm::mass::{MassOptions, MassScheme};
    use sparse_mpm::material::{LinearElastic, Material, PlaneCondition};
    use sparse_mpm::simulation::{Body, Integrator, Newmark, Options, Simulation, TimeStep};
    let grid = Grid::new([0.0, 0.0], [0.0625, 0.0625], [32, 32]).unwrap();
    let layouts: [(&str, Vec<(f64, f64)>); 3] = [
        ("one particle on a node", vec![(0.5, 0.5)]),
        ("one particle on a vertical line", vec![(0.5, 0.53125)]),
        (
            "a 9 × 9 block on the nodes",
            (0..9)
                .flat_map(|i| (0..9).map(move |j| (0.25 + i as f64 * 0.0625, 0.25 + j as f64 * 0.0625)))
                .collect(),
        ),
    ];
    for (name, points) in layouts {
        let n = points.len();
        let v = 0.0625 * 0.0625;
        let (x, y): (Vec<f64>, Vec<f64>) = points.into_iter().unzip();
        let mut p = Particles::new(x, y, vec![v; n], vec![v; n]).unwrap();
        p.vx.iter_mut().for_each(|u| *u = 0.1);
        for mass in [MassScheme::Lumped, MassScheme::Consistent] {
            let options = Options {
                shape: ShapeFunction::Linear,
                mass: MassOptions {
                    singularity: sparse_mpm::mass::SingularityPolicy::FallbackToLumped,
                    ..MassOptions::both(mass)
                },
                integrator: Integrator::Newmark(Newmark::default()),
                time_step: TimeStep::Fixed { dt: 0.001 },
                ..Options::default()
            };
            let body = Body {
                name: "b".into(),
                material: Material::LinearElastic(LinearElastic::new(1000.0, 0.3, PlaneCondition::Stress).unwrap()),
            };
            let mut sim = Simulation::new(grid.clone(), p.clone(), vec![body], options).unwrap();
            for _ in 0..10 {
                let report = sim.step().unwrap_or_else(|e| panic!("{name}, {mass:?}: {e}"));
                let momentum = 0.1 * v * n as f64;
                assert!(
                    report.strain_energy < 1e-20,
                    "{name}, {mass:?}: strain {}",
                    report.strain_energy
                );
                assert!(
                    (report.momentum[0] / momentum - 1.0).abs() < 1e-12,
                    "{name}, {mass:?}: momentum {}",
                    report.momentum[0]
                );
            }
        }
    }
}

#[test]
fn the_truncated_series_is_refused_in_the_acceleration_solve_of_newmark() {
    // Its a_n is not M⁻¹ f of any mass the residual can use (GIMP, series:2 once gained energy
    // 890-fold in a step); in the velocity projection it stays allowed.
    let refused = disks_newmark_text(0.05, 2, "{ velocity = \"lumped\", acceleration = \"series:2\" }", 3.5);
    let err = sparse_mpm::scene::Scene::from_toml_str(&refused)
        .and_then(|s| s.build().map(|_| ()))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("schemes.integrator") && err.contains("series:2") && err.contains("schemes.mass.acceleration"),
        "{err}"
    );
    let allowed = disks_newmark_text(
        0.05,
        2,
        "{ velocity = \"series:8\", acceleration = \"consistent\" }",
        3.5,
    );
    let mut sim = sparse_mpm::scene::Scene::from_toml_str(&allowed)
        .unwrap()
        .build()
        .unwrap();
    let initial = sim.particles().kinetic_energy();
    for _ in 0..5 {
        let report = sim.step().unwrap();
        assert!(
            (report.total_energy / initial - 1.0).abs() < 1e-2,
            "{}",
            report.total_energy
        );
    }
}

#[test]
fn a_refused_or_unconverged_implicit_step_changes_nothing_and_the_run_goes_on() {
    let scene = disks_newmark(0.05, 2, "{ velocity = \"lumped\", acceleration = \"lumped\" }", 3.5);
    let mut sim = scene.build().unwrap();
    sim.step().unwrap();
    let (time, steps, x) = (sim.time(), sim.steps(), sim.particles().x.clone());
    // A step the clock cannot resolve at t = 0.05: refused, nothing changed (it once wrote NaN
    // into the particles and left the simulation unusable).
    for tiny in [1e-20, 1e-300, 5e-324] {
        let err = sim.step_capped(tiny).unwrap_err().to_string();
        assert!(err.contains("too short") && err.contains("step 2:"), "{err}");
        assert_eq!((sim.time(), sim.steps()), (time, steps));
        assert_eq!(sim.particles().x, x);
    }
    let report = sim.step().unwrap();
    assert_eq!(report.step, steps + 1);
    assert!(sim.particles().x.iter().all(|v| v.is_finite()));
}
