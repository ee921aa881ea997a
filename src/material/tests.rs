//! The material models' own checks.

use super::*;

/// The time loop's per-particle update gives, to the bit, what the public accessors give.
#[test]
fn the_time_loop_update_is_the_public_stress_energy_and_tangent() {
    let (l, dt, volume) = ([0.3, -0.2, 0.1, -0.4], 1e-3, 2.5e-3);
    let f = [1.02, 0.03, -0.01, 0.97];
    let sigma = [12.0, -7.0, 3.5];
    let linear = LinearElastic::new(2.0e5, 0.3, PlaneCondition::Stress).unwrap();
    let neo = NeoHookean {
        youngs_modulus: 2.0e5,
        poisson_ratio: 0.3,
    };
    for material in [Material::LinearElastic(linear), Material::NeoHookean(neo)] {
        let (s, e, c11) = material.prepared().update_with_modulus(sigma, l, f, dt, volume);
        let expected = match material {
            Material::LinearElastic(m) => {
                let d = m.stress_increment(l[0] * dt, l[3] * dt, 0.5 * (l[1] + l[2]) * dt);
                [sigma[0] + d[0], sigma[1] + d[1], sigma[2] + d[2]]
            }
            Material::NeoHookean(m) => m.stress(f),
            Material::VonMises(_) | Material::DruckerPrager(_) => unreachable!("elastic models only"),
        };
        assert_eq!(s, expected);
        assert_eq!(e, material.strain_energy(volume, s, f));
        assert_eq!(c11, material.tangent(f)[0]);
    }
}

/// `P(F)` is the Cauchy stress pulled back (`σ = P Fᵀ / J`), `P` the derivative of `W(F)`
/// and `A` the derivative of `P`, both by central differences; the linear stiffness tensor
/// maps `∇u` to the stress increment.
#[test]
fn the_first_piola_kirchhoff_stress_and_its_tangent_are_derivatives_of_the_energy() {
    let neo = NeoHookean {
        youngs_modulus: 2.0e5,
        poisson_ratio: 0.3,
    };
    let f = [1.04, 0.07, -0.05, 0.93];
    let (p, a) = neo.first_piola_kirchhoff(f);
    let j = f[0] * f[3] - f[1] * f[2];
    let sigma = neo.stress(f);
    // σ = P Fᵀ / J, as [xx, yy, xy].
    let pulled = [
        (p[0] * f[0] + p[1] * f[1]) / j,
        (p[2] * f[2] + p[3] * f[3]) / j,
        (p[0] * f[2] + p[1] * f[3]) / j,
    ];
    for k in 0..3 {
        assert!(
            (pulled[k] - sigma[k]).abs() < 1e-10 * 2.0e5,
            "σ {k}: {} against {}",
            pulled[k],
            sigma[k]
        );
    }
    let h = 1e-6;
    let shifted = |c: usize, d: f64| {
        let mut g = f;
        g[c] += d;
        g
    };
    for c in 0..4 {
        let dw = (neo.strain_energy_density(shifted(c, h)) - neo.strain_energy_density(shifted(c, -h))) / (2.0 * h);
        assert!((dw - p[c]).abs() < 1e-6 * 2.0e5, "∂W/∂F {c}: {dw} against {}", p[c]);
        let (pp, _) = neo.first_piola_kirchhoff(shifted(c, h));
        let (pm, _) = neo.first_piola_kirchhoff(shifted(c, -h));
        for r in 0..4 {
            let dp = (pp[r] - pm[r]) / (2.0 * h);
            assert!(
                (dp - a[r][c]).abs() < 1e-5 * 2.0e5,
                "A[{r}][{c}]: {dp} against {}",
                a[r][c]
            );
        }
    }
    let linear = LinearElastic::new(2.0e5, 0.3, PlaneCondition::Strain).unwrap();
    let grad = [1e-3, 4e-4, -2e-4, -3e-4];
    let c = linear.stiffness_tensor();
    let by_tensor: Vec<f64> = (0..4).map(|r| (0..4).map(|k| c[r][k] * grad[k]).sum()).collect();
    let d = linear.stress_increment(grad[0], grad[3], 0.5 * (grad[1] + grad[2]));
    for (got, want) in [
        (by_tensor[0], d[0]),
        (by_tensor[1], d[2]),
        (by_tensor[2], d[2]),
        (by_tensor[3], d[1]),
    ] {
        assert!((got - want).abs() < 1e-12 * 2.0e5, "{got} against {want}");
    }
}
