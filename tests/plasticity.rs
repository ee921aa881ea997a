//! The elastoplastic models at one material point: von Mises in uniaxial stress against the
//! closed form of linear hardening, a shear path on the yield surface, Drucker–Prager's cone
//! and apex returns, the continuity of the elastic–plastic switch, non-negative dissipation,
//! and the consistent tangents against central differences of the updates.

use sparse_mpm::material::{Cone, DruckerPrager, Material, PlaneCondition, PlasticState, Regime, VonMises};

const E: f64 = 2.0e5;

fn von_mises(plane: PlaneCondition, hardening: f64) -> VonMises {
    VonMises {
        youngs_modulus: E,
        poisson_ratio: 0.3,
        yield_stress: 250.0,
        hardening_modulus: hardening,
        plane,
    }
}

fn drucker_prager(cohesion: f64, dilatancy: f64) -> DruckerPrager {
    DruckerPrager {
        youngs_modulus: E,
        poisson_ratio: 0.3,
        friction_angle: 30.0,
        cohesion,
        dilatancy_angle: dilatancy,
    }
}

/// One step of a material point: `f = I + h` with `h_yy` (and `h_zz` through the plane
/// condition) found by Newton so that `P̃_yy = 0` (free lateral faces), the state committed.
fn uniaxial_step(cone: &Cone, state: &PlasticState, hxx: f64, j_n: f64) -> (PlasticState, f64, f64) {
    let mut hyy = -0.3 * hxx;
    for _ in 0..50 {
        let (p, a) = cone.relative_stress(state, [hxx, 0.0, 0.0, hyy], j_n);
        if p[3].abs() < 1e-12 * E {
            break;
        }
        hyy -= p[3] / a[3][3];
    }
    let up = cone.update(state, [1.0 + hxx, 0.0, 0.0, 1.0 + hyy]);
    (up.state, up.kirchhoff[0], up.kirchhoff[1])
}

/// J2 with linear hardening in uniaxial stress (plane stress, the lateral face free): beyond
/// yield the Kirchhoff stress follows `σ_y + E H/(E + H) (ε − σ_y/E)` in the log strain
/// `ε = ln λ`, exact for Hencky elasticity with coaxial plastic flow.
#[test]
fn von_mises_in_uniaxial_stress_follows_linear_hardening() {
    for hardening in [0.0, 1.0e4, 5.0e4] {
        let m = von_mises(PlaneCondition::Stress, hardening);
        let cone = m.cone();
        let mut state = PlasticState::default();
        let mut stretch = 1.0f64;
        let mut yielded = 0;
        for _ in 0..400 {
            // ε̇ Δt = 2.5e-5 per step: yield (1.25e-3) at step 50, 1% strain at 400.
            let hxx = 2.5e-5;
            // P̃_yy = 0 is τ_yy = 0 whatever J_n.
            let (next, txx, tyy) = uniaxial_step(&cone, &state, hxx, 1.0);
            state = next;
            stretch *= 1.0 + hxx;
            let eps = stretch.ln();
            let (sy, h) = (m.yield_stress, hardening);
            let expected = if E * eps <= sy {
                E * eps
            } else {
                yielded += 1;
                sy + E * h / (E + h) * (eps - sy / E)
            };
            assert!(
                (txx - expected).abs() <= 1e-6 * expected.abs(),
                "H = {hardening}, ε = {eps}: τxx {txx} against {expected}"
            );
            assert!(tyy.abs() <= 1e-9 * sy, "τyy {tyy}");
            let plastic = if E * eps > sy {
                (eps - sy / E) * E / (E + h)
            } else {
                0.0
            };
            assert!((state.plastic_strain - plastic).abs() <= 1e-6 * plastic.max(1e-3));
        }
        assert!(
            yielded > 300,
            "the path goes well beyond yield ({yielded} plastic steps)"
        );
    }
}

/// A pure shear path `h = diag(γ, −γ)` in plane strain stays on the yield surface after it
/// first reaches it (`f = 0` to round-off), the equivalent stress growing with `H ε̄ᵖ`.
#[test]
fn a_pure_shear_path_stays_on_the_yield_surface() {
    let m = von_mises(PlaneCondition::Strain, 2.0e4);
    let cone = m.cone();
    let mut state = PlasticState::default();
    let mut on_surface = 0;
    for step in 0..300 {
        let g = 1e-5;
        let up = cone.update(&state, [1.0 + g, 0.0, 0.0, 1.0 / (1.0 + g)]);
        let tau = up.returned.stress;
        let f = cone.yield_function(tau, up.state.plastic_strain);
        if up.returned.regime == Regime::Cone {
            on_surface += 1;
            assert!(f.abs() <= 1e-10 * m.yield_stress, "step {step}: f = {f}");
            let q = {
                let p = (tau[0] + tau[1] + tau[2]) / 3.0;
                tau.iter().map(|t| (t - p) * (t - p)).sum::<f64>().sqrt()
            };
            let expected = (2.0f64 / 3.0).sqrt() * (m.yield_stress + m.hardening_modulus * up.state.plastic_strain);
            assert!((q - expected).abs() <= 1e-10 * expected);
        } else {
            assert!(f <= 0.0);
        }
        assert!(up.dissipation_density >= 0.0);
        state = up.state;
    }
    assert!(on_surface > 100, "{on_surface} steps on the surface");
}

/// A state outside the Drucker–Prager cone returns onto it (compression with shear); one in
/// tension beyond the apex returns to the apex `p = A/B`, `s = 0`; the cohesionless apex is
/// stress-free.
#[test]
fn drucker_prager_returns_onto_the_cone_and_to_the_apex() {
    for (cohesion, dilatancy) in [(0.0, 0.0), (50.0, 0.0), (50.0, 10.0), (0.0, 30.0)] {
        let cone = drucker_prager(cohesion, dilatancy).cone();
        // Compression with shear: ε = (−3e-3, 1e-3, 0) is far outside a 30° cone.
        let r = cone.principal_return([-3e-3, 1e-3, 0.0], 0.0);
        assert_eq!(r.regime, Regime::Cone, "c = {cohesion}, ψ = {dilatancy}");
        let f = cone.yield_function(r.stress, 0.0);
        assert!(f.abs() <= 1e-9 * E * 1e-3, "f = {f} after the cone return");
        let p_before: f64 = cone.elastic_stress([-3e-3, 1e-3, 0.0]).iter().sum::<f64>() / 3.0;
        let p_after = r.stress.iter().sum::<f64>() / 3.0;
        // Dilatancy lowers the pressure's magnitude... in tension-positive p: p rises by K B_ψ Δγ less.
        if dilatancy == 0.0 {
            assert!((p_after - p_before).abs() <= 1e-9 * p_before.abs(), "ψ = 0 keeps p");
        } else {
            assert!(p_after < p_before, "dilatancy lowers p (more compression)");
        }
        // Tension: equal principal stretches of 1e-3 are beyond the apex.
        let r = cone.principal_return([1e-3, 1e-3, 1e-3], 0.0);
        assert_eq!(r.regime, Regime::Apex);
        let apex = cone.apex();
        for t in r.stress {
            assert!((t - apex).abs() <= 1e-12 * E, "τ {t} against the apex {apex}");
        }
        if cohesion == 0.0 {
            assert_eq!(r.stress, [0.0; 3]);
        }
    }
}

/// The elastic–plastic switch is continuous: along a ray of trial strains the returned stress
/// changes by no more than the ray's step times the elastic modulus, across the yield point.
#[test]
fn the_elastic_plastic_switch_is_continuous() {
    let models = [
        von_mises(PlaneCondition::Strain, 1.0e4).cone(),
        drucker_prager(20.0, 5.0).cone(),
        drucker_prager(0.0, 0.0).cone(),
    ];
    for cone in models {
        let direction = [-1.0, 0.4, 0.1];
        let stress_at = |t: f64| cone.principal_return(direction.map(|d| d * t), 0.0);
        // Find the yield point by bisection on the regime, then compare both sides.
        let (mut lo, mut hi) = (0.0, 1e-1);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if stress_at(mid).regime == Regime::Elastic {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let (a, b) = (stress_at(lo), stress_at(hi));
        assert_eq!(a.regime, Regime::Elastic);
        assert_ne!(b.regime, Regime::Elastic);
        for i in 0..3 {
            assert!(
                (a.stress[i] - b.stress[i]).abs() <= 1e-9 * E * hi.max(1e-6),
                "τ{i}: {} against {}",
                a.stress[i],
                b.stress[i]
            );
        }
    }
}

/// Random trial states: the return's dissipation `W(ε^tr) − W(ε)` is non-negative, and the
/// returned state is on or inside the yield surface.
#[test]
fn the_plastic_dissipation_is_never_negative() {
    let models = [
        von_mises(PlaneCondition::Strain, 1.0e4).cone(),
        von_mises(PlaneCondition::Stress, 0.0).cone(),
        drucker_prager(0.0, 0.0).cone(),
        drucker_prager(30.0, 15.0).cone(),
    ];
    let mut seed = 12345u64;
    let mut next = || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    };
    for cone in models {
        for _ in 0..2000 {
            let state = PlasticState {
                elastic_strain: [2e-3 * next(), 2e-3 * next(), 1e-3 * next(), 0.0],
                plastic_strain: 0.01 * next().abs(),
            };
            let f = [1.0 + 5e-3 * next(), 5e-3 * next(), 5e-3 * next(), 1.0 + 5e-3 * next()];
            let up = cone.update(&state, f);
            assert!(
                up.dissipation_density >= -1e-12 * E * 1e-6,
                "dissipation {}",
                up.dissipation_density
            );
            let f_after = cone.yield_function(up.returned.stress, up.state.plastic_strain);
            assert!(f_after <= 1e-8 * E * 1e-3, "f = {f_after} after the return");
            assert!(up.state.plastic_strain >= state.plastic_strain);
        }
    }
}

/// The algorithmic tangent `∂τ/∂ε^tr` of the principal return, and the tangent `∂P̃/∂h` of
/// the finite-strain update, equal central differences to 1e-6 of the elastic modulus: elastic,
/// on the cone (associated and not), and von Mises in plane stress.
#[test]
fn the_consistent_tangents_equal_central_differences() {
    let models = [
        (
            "von Mises, plane strain",
            von_mises(PlaneCondition::Strain, 1.0e4).cone(),
        ),
        (
            "von Mises, plane stress",
            von_mises(PlaneCondition::Stress, 1.0e4).cone(),
        ),
        ("Drucker-Prager c = 0, ψ = 0", drucker_prager(0.0, 0.0).cone()),
        ("Drucker-Prager c = 40, ψ = 12", drucker_prager(40.0, 12.0).cone()),
    ];
    let scale = E;
    let states = [
        PlasticState::default(),
        PlasticState {
            elastic_strain: [-1.2e-3, 4e-4, 3e-4, -2e-4],
            plastic_strain: 0.02,
        },
    ];
    let steps = [
        [1e-5, 0.0, 0.0, -0.5e-5],       // elastic
        [-4e-3, 2e-3, 1e-3, 1.5e-3],     // plastic
        [-2e-3, -1.5e-3, 0.5e-3, -3e-3], // plastic, compressive
    ];
    let mut seen = std::collections::BTreeSet::new();
    for (name, cone) in models {
        // Principal return.
        for e in [[-3e-3, 1e-3, 2e-4], [-1e-3, -2e-3, -5e-4], [2e-4, -1e-4, 0.0]] {
            let r = cone.principal_return(e, 0.01);
            seen.insert(format!("{name} {:?}", r.regime));
            if cone.c11() > 0.0 && r.regime == Regime::Apex {
                continue;
            }
            let d = 1e-8;
            for j in 0..3 {
                let mut ep = e;
                ep[j] += d;
                let mut em = e;
                em[j] -= d;
                let (tp, tm) = (cone.principal_return(ep, 0.01), cone.principal_return(em, 0.01));
                for i in 0..3 {
                    let fd = (tp.stress[i] - tm.stress[i]) / (2.0 * d);
                    assert!(
                        (fd - r.tangent[i][j]).abs() <= 1e-6 * scale,
                        "{name}: D[{i}][{j}] {} against {fd}",
                        r.tangent[i][j]
                    );
                }
            }
        }
        // The finite-strain update.
        for state in &states {
            for h in steps {
                let j_n = 1.05;
                let (p, a) = cone.relative_stress(state, h, j_n);
                assert!(p.iter().all(|v| v.is_finite()));
                let d = 1e-8;
                for c in 0..4 {
                    let mut hp = h;
                    hp[c] += d;
                    let mut hm = h;
                    hm[c] -= d;
                    let (pp, _) = cone.relative_stress(state, hp, j_n);
                    let (pm, _) = cone.relative_stress(state, hm, j_n);
                    for r in 0..4 {
                        let fd = (pp[r] - pm[r]) / (2.0 * d);
                        assert!(
                            (fd - a[r][c]).abs() <= 1e-6 * scale,
                            "{name}, h = {h:?}: A[{r}][{c}] {} against {fd}",
                            a[r][c]
                        );
                    }
                }
            }
        }
    }
    for regime in ["Elastic", "Cone"] {
        assert!(
            seen.iter().any(|s| s.ends_with(regime)),
            "the cases reach the {regime} branch: {seen:?}"
        );
    }
}

/// The scene keys: both models parse with their defaults and refuse bad values by name.
#[test]
fn the_models_parse_and_refuse_bad_values_by_name() {
    let m: Material =
        toml::from_str("model = \"von_mises\"\nyoungs_modulus = 2e5\npoisson_ratio = 0.3\nyield_stress = 250.0\n")
            .unwrap();
    assert_eq!(m, Material::VonMises(von_mises(PlaneCondition::Strain, 0.0)));
    m.validate().unwrap();
    let m: Material = toml::from_str(
        "model = \"drucker_prager\"\nyoungs_modulus = 2e5\npoisson_ratio = 0.3\nfriction_angle = 30.0\n",
    )
    .unwrap();
    assert_eq!(m, Material::DruckerPrager(drucker_prager(0.0, 0.0)));
    for (text, key) in [
        ("model = \"von_mises\"\nyoungs_modulus = 2e5\npoisson_ratio = 0.3\nyield_stress = -1.0\n", "yield_stress"),
        (
            "model = \"von_mises\"\nyoungs_modulus = 2e5\npoisson_ratio = 0.3\nyield_stress = 1.0\nhardening_modulus = -5.0\n",
            "hardening_modulus",
        ),
        ("model = \"drucker_prager\"\nyoungs_modulus = 2e5\npoisson_ratio = 0.3\nfriction_angle = 95.0\n", "friction_angle"),
        (
            "model = \"drucker_prager\"\nyoungs_modulus = 2e5\npoisson_ratio = 0.3\nfriction_angle = 20.0\ndilatancy_angle = 25.0\n",
            "dilatancy_angle",
        ),
        ("model = \"drucker_prager\"\nyoungs_modulus = 2e5\npoisson_ratio = 0.3\nfriction_angle = 0.0\n", "cohesion"),
    ] {
        let m: Material = toml::from_str(text).unwrap();
        let err = m.validate().unwrap_err().to_string();
        assert!(err.contains(key), "{err}");
    }
    let err = toml::from_str::<Material>(
        "model = \"drucker_prager\"\nyoungs_modulus = 2e5\npoisson_ratio = 0.3\nfriction_angle = \"steep\"\n",
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("friction_angle"), "{err}");
}

/// Drucker–Prager's cone is fitted to Mohr–Coulomb in plane strain for its own flow rule: a
/// plane-strain biaxial test (compressed along x, the confining stress `τ_yy = −p₀` held by
/// Newton on `h_yy`) flows at the Mohr–Coulomb strength, `τ_max = c cos φ − σ_m sin φ`, and
/// dilates at `ψ`, `(dε₁ + dε₂)/(dε₁ − dε₂) = sin ψ`, once the flow is steady.
#[test]
fn drucker_prager_in_plane_strain_flows_at_mohr_coulomb_and_dilates_at_psi() {
    let p0 = 100.0;
    for (phi, c, psi) in [
        (30.0, 0.0, 0.0),
        (30.0, 20.0, 10.0),
        (25.0, 10.0, 25.0),
        (40.0, 0.0, 5.0),
    ] {
        let m = DruckerPrager {
            youngs_modulus: 1.0e5,
            poisson_ratio: 0.3,
            friction_angle: phi,
            cohesion: c,
            dilatancy_angle: psi,
        };
        let cone = m.cone();
        let mut state = PlasticState {
            elastic_strain: cone.strain_of_stress([-p0, -p0, 0.0]),
            plastic_strain: 0.0,
        };
        let hxx = -2e-5;
        let (mut last, mut tau) = ((0.0, 0.0), [0.0; 3]);
        for _ in 0..4000 {
            let mut hyy = 0.0;
            for _ in 0..50 {
                let (p, a) = cone.relative_stress(&state, [hxx, 0.0, 0.0, hyy], 1.0);
                // P̃_yy = τ_yy / (1 + h_yy) = −p₀ / (1 + h_yy).
                let r = p[3] + p0 / (1.0 + hyy);
                if r.abs() < 1e-12 * p0 {
                    break;
                }
                hyy -= r / (a[3][3] - p0 / (1.0 + hyy).powi(2));
            }
            let up = cone.update(&state, [1.0 + hxx, 0.0, 0.0, 1.0 + hyy]);
            state = up.state;
            tau = up.kirchhoff;
            last = ((1.0 + hxx).ln(), (1.0 + hyy).ln());
        }
        let (s, co) = phi.to_radians().sin_cos();
        let (txx, tyy) = (tau[0], tau[1]);
        assert!((tyy + p0).abs() < 1e-9 * p0, "confinement {tyy}");
        let radius = 0.5 * (tyy - txx);
        let mean = 0.5 * (txx + tyy);
        let strength = c * co - mean * s;
        assert!(
            (radius - strength).abs() <= 1e-6 * p0,
            "φ = {phi}, c = {c}, ψ = {psi}: τ_max {radius} against Mohr–Coulomb {strength}"
        );
        let (dx, dy) = last;
        let dilation = (dx + dy) / (dy - dx);
        assert!(
            (dilation - psi.to_radians().sin()).abs() <= 1e-6,
            "φ = {phi}, ψ = {psi}: dilates at sin ψ = {dilation}"
        );
    }
}
