//! Constitutive models: neo-Hookean identities, its small-strain limit, objectivity, and the
//! stress as the derivative of the strain energy.

use sparse_mpm::material::{LinearElastic, Material, NeoHookean, PlaneCondition};

/// Finite-difference step for derivatives of the energy.
const FD_STEP: f64 = 1e-6;

fn rubber() -> NeoHookean {
    NeoHookean {
        youngs_modulus: 3.0e6,
        poisson_ratio: 0.35,
    }
}

fn rotate(theta: f64, f: [f64; 4]) -> [f64; 4] {
    let (c, s) = (theta.cos(), theta.sin());
    [
        c * f[0] - s * f[2],
        c * f[1] - s * f[3],
        s * f[0] + c * f[2],
        s * f[1] + c * f[3],
    ]
}

#[test]
fn neo_hookean_is_stress_free_and_energy_free_at_the_identity() {
    let m = rubber();
    assert_eq!(m.stress([1.0, 0.0, 0.0, 1.0]), [0.0, 0.0, 0.0]);
    assert_eq!(m.strain_energy_density([1.0, 0.0, 0.0, 1.0]), 0.0);
}

#[test]
fn neo_hookean_reduces_to_plane_strain_linear_elasticity_for_small_strains() {
    let m = rubber();
    let linear = LinearElastic {
        youngs_modulus: m.youngs_modulus,
        poisson_ratio: m.poisson_ratio,
        plane: PlaneCondition::Strain,
    };
    let e = 1e-7;
    for (exx, eyy, exy) in [(e, 0.0, 0.0), (0.0, e, 0.0), (0.0, 0.0, e), (e, -0.5 * e, 0.3 * e)] {
        let f = [1.0 + exx, exy, exy, 1.0 + eyy];
        let s = m.stress(f);
        let expected = linear.stress_increment(exx, eyy, exy);
        for c in 0..3 {
            // Second-order terms are e² E ≈ 3e-8 relative to stresses of e E ≈ 0.3.
            assert!(
                (s[c] - expected[c]).abs() < 1e-5 * linear.youngs_modulus * e,
                "{c}: {} vs {}",
                s[c],
                expected[c]
            );
        }
    }
}

#[test]
fn neo_hookean_stress_rotates_with_the_body() {
    let m = rubber();
    let f = [1.3, 0.2, -0.1, 0.8];
    let s = m.stress(f);
    let theta = 0.7f64;
    let r = rotate(theta, f);
    let sr = m.stress(r);
    let (c, sn) = (theta.cos(), theta.sin());
    // R σ Rᵀ
    let xx = c * c * s[0] - 2.0 * c * sn * s[2] + sn * sn * s[1];
    let yy = sn * sn * s[0] + 2.0 * c * sn * s[2] + c * c * s[1];
    let xy = c * sn * (s[0] - s[1]) + (c * c - sn * sn) * s[2];
    let scale = s.iter().map(|v| v.abs()).fold(0.0, f64::max);
    for (a, b) in [(sr[0], xx), (sr[1], yy), (sr[2], xy)] {
        assert!((a - b).abs() < 1e-12 * scale, "{a} vs {b}");
    }
    assert!((m.strain_energy_density(r) - m.strain_energy_density(f)).abs() < 1e-12 * m.strain_energy_density(f));
}

#[test]
fn neo_hookean_stress_is_the_derivative_of_its_energy() {
    // Cauchy stress σ = (1/J) P Fᵀ with P = ∂W/∂F, P from central differences of W.
    let m = rubber();
    let f = [1.2, 0.15, -0.05, 0.9];
    let mut p = [0.0; 4];
    for k in 0..4 {
        let (mut up, mut down) = (f, f);
        up[k] += FD_STEP;
        down[k] -= FD_STEP;
        p[k] = (m.strain_energy_density(up) - m.strain_energy_density(down)) / (2.0 * FD_STEP);
    }
    let j = f[0] * f[3] - f[1] * f[2];
    let sxx = (p[0] * f[0] + p[1] * f[1]) / j;
    let syy = (p[2] * f[2] + p[3] * f[3]) / j;
    let sxy = (p[0] * f[2] + p[1] * f[3]) / j;
    let s = m.stress(f);
    for (a, b) in [(s[0], sxx), (s[1], syy), (s[2], sxy)] {
        assert!((a - b).abs() < 1e-6 * m.youngs_modulus, "{a} vs {b}");
    }
}

#[test]
fn linear_elastic_strain_energy_is_half_stress_times_strain() {
    for plane in [PlaneCondition::Stress, PlaneCondition::Strain] {
        let m = LinearElastic {
            youngs_modulus: 200.0,
            poisson_ratio: 0.25,
            plane,
        };
        let (exx, eyy, exy) = (1e-3, -4e-4, 2.5e-4);
        let s = m.stress_increment(exx, eyy, exy);
        let expected = 0.5 * (s[0] * exx + s[1] * eyy + 2.0 * s[2] * exy);
        let w = m.strain_energy_density(s[0], s[1], s[2]);
        assert!((w - expected).abs() < 1e-12 * expected, "{plane:?}: {w} vs {expected}");
    }
}

#[test]
fn material_wave_speeds_are_the_p_wave_speeds() {
    let rho = 1200.0;
    let nh = Material::NeoHookean(rubber());
    let (e, nu) = (rubber().youngs_modulus, rubber().poisson_ratio);
    let (mu, lambda) = (e / (2.0 * (1.0 + nu)), e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)));
    assert!((nh.wave_speed(rho) - ((lambda + 2.0 * mu) / rho).sqrt()).abs() < 1e-9);
    let le = Material::LinearElastic(LinearElastic {
        youngs_modulus: e,
        poisson_ratio: nu,
        plane: PlaneCondition::Stress,
    });
    assert!((le.wave_speed(rho) - (e / (1.0 - nu * nu) / rho).sqrt()).abs() < 1e-9);
}

#[test]
fn invalid_material_parameters_are_rejected_by_name() {
    let bad = Material::NeoHookean(NeoHookean {
        youngs_modulus: 1.0,
        poisson_ratio: 0.5,
    });
    assert!(bad.validate().unwrap_err().to_string().contains("poisson_ratio"));
    let bad = Material::LinearElastic(LinearElastic {
        youngs_modulus: -1.0,
        poisson_ratio: 0.3,
        plane: PlaneCondition::Strain,
    });
    assert!(bad.validate().unwrap_err().to_string().contains("youngs_modulus"));
}
