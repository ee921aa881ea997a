//! (12)–(13) when a body is elastoplastic: the stress update that carries each particle's
//! plastic state (the elastic log strain and the equivalent plastic strain,
//! [`crate::material::hencky`]) and sums the plastic dissipation of the step. The particles of
//! elastic bodies in the same run take their materials' update, one particle at a time.

use super::phases::keep_stress;
use super::{Scratch, Setup, State};
use crate::error::{MpmError, Result};
use crate::fields::{deformation_increment_of, mat2_mul};
use crate::kernels::{Partials, StressOutput, StressPartials, StressSums};
use crate::material::{PlasticState, Prepared};
use crate::parallel::Splittable;
use crate::particles::Particles;

/// What the plastic stress update writes: `F`, `σ`, `V` and the plastic state
/// `[ε̄ᵖ, ε_e,xx, ε_e,yy, ε_e,xy, ε_e,zz]`.
struct PlasticOutput<'a> {
    stress: StressOutput<'a>,
    state: [&'a mut [f64]; 5],
}

impl Splittable for PlasticOutput<'_> {
    fn len(&self) -> usize {
        self.stress.len()
    }
    fn split_at(self, mid: usize) -> (Self, Self) {
        let (s0, s1) = self.stress.split_at(mid);
        let (p0, p1) = Splittable::split_at(self.state, mid);
        (
            PlasticOutput { stress: s0, state: p0 },
            PlasticOutput { stress: s1, state: p1 },
        )
    }
}

/// (12) `F ← (I + Δt L) F`, the stress and plastic state from the return map (elastoplastic
/// bodies) or the material's update (the others); (13) `V ← V det(I + Δt L)`. The strain energy
/// and wave speed go into `state` as the elastic update's do, and the step's plastic
/// dissipation `Σ_p V₀_p τ_p : Δεᵖ_p` into its energy accounts. Blocks of particles in
/// order: every thread count gives the same bits.
pub(super) fn update_stress(setup: &Setup, state: &mut State, scratch: &mut Scratch, dt: f64) -> Result<()> {
    let l = &scratch.particle.velocity_gradient;
    let p = &mut state.particles;
    p.with_plastic_state();
    let (materials, body, mass) = (&setup.materials[..], &p.body[..], &p.mass[..]);
    let out = PlasticOutput {
        stress: StressOutput {
            f: [&mut p.fxx[..], &mut p.fxy[..], &mut p.fyx[..], &mut p.fyy[..]],
            sigma: [&mut p.sxx[..], &mut p.syy[..], &mut p.sxy[..]],
            volume: &mut p.volume[..],
        },
        state: [
            &mut p.plastic_strain[..],
            &mut p.elastic_xx[..],
            &mut p.elastic_yy[..],
            &mut p.elastic_xy[..],
            &mut p.elastic_zz[..],
        ],
    };
    let mut blocks: Vec<(StressPartials, Partials)> = Vec::new();
    setup.workers.split_blocks(out, &mut blocks, |first, mut out| {
        let mut sums = StressPartials::default();
        let mut dissipation = Partials::default();
        for j in 0..out.len() {
            let k = first + j;
            let lk = [l[0][k], l[1][k], l[2][k], l[3][k]];
            if !update_one(
                &materials[body[k]],
                lk,
                dt,
                mass[k],
                k,
                j,
                &mut out,
                &mut sums,
                &mut dissipation,
            ) {
                break;
            }
        }
        (sums, dissipation)
    });
    let stress = StressSums::total(blocks.iter().map(|b| b.0));
    keep_stress(&setup.bodies, state, stress)?;
    state.relaxation.plastic_dissipation += blocks.iter().map(|b| b.1.sum()).sum::<f64>();
    Ok(())
}

/// The update of particle `k` (`j` in its block): false, with the inversion recorded in
/// `sums` and the particle left as it was, when `det(I + Δt L)` or `det F` is not positive.
#[allow(clippy::too_many_arguments)]
fn update_one(
    material: &Prepared,
    l: [f64; 4],
    dt: f64,
    mass: f64,
    k: usize,
    j: usize,
    out: &mut PlasticOutput,
    sums: &mut StressPartials,
    dissipation: &mut Partials,
) -> bool {
    let (g, j_inc) = deformation_increment_of(l, dt);
    let s = &mut out.stress;
    let old = [s.f[0][j], s.f[1][j], s.f[2][j], s.f[3][j]];
    let f = mat2_mul(g, old);
    let det_f = f[0] * f[3] - f[1] * f[2];
    if !(j_inc > 0.0 && det_f > 0.0 && det_f.is_finite()) {
        sums.inverted = Some((k, j_inc, det_f));
        return false;
    }
    let volume = s.volume[j] * j_inc;
    let sigma = [s.sigma[0][j], s.sigma[1][j], s.sigma[2][j]];
    let (stress, energy) = match material.plastic() {
        Some(cone) => {
            let st = &mut out.state;
            let before = PlasticState {
                elastic_strain: [st[1][j], st[2][j], st[3][j], st[4][j]],
                plastic_strain: st[0][j],
            };
            let up = cone.update(&before, g);
            let reference = volume / det_f;
            dissipation.add_one(j, reference * up.dissipation_density);
            st[0][j] = up.state.plastic_strain;
            for c in 0..4 {
                st[c + 1][j] = up.state.elastic_strain[c];
            }
            (up.kirchhoff.map(|t| t / det_f), reference * up.energy_density)
        }
        None => {
            let (s, e, _) = material.update_with_modulus::<f64>(sigma, l, f, dt, volume);
            (s, e)
        }
    };
    let c11 = material.tangent(f)[0];
    sums.energy.add_one(j, energy);
    sums.wave_squared.max_one(j, c11 * volume / mass);
    let s = &mut out.stress;
    for c in 0..4 {
        s.f[c][j] = f[c];
    }
    for c in 0..3 {
        s.sigma[c][j] = stress[c];
    }
    s.volume[j] = volume;
    true
}

/// The plastic state of a run's start: every particle of an elastoplastic body gets the
/// elastic strain of its stress (`Cone::strain_of_stress` of `τ = det F σ`) and no plastic
/// strain; the particles carry no state when no body is elastoplastic, and particles that
/// carry one already (those of an earlier run) keep it.
///
/// # Errors
/// [`MpmError::InvalidParticleValue`] (`stress`) for a particle of an elastoplastic body whose
/// stress needs an elastic log strain beyond [`MAX_ELASTIC_STRAIN`].
pub(super) fn initial_state(particles: &mut Particles, materials: &[Prepared]) -> Result<()> {
    if particles.has_plastic_state() || !materials.iter().any(|m| m.plastic().is_some()) {
        return Ok(());
    }
    particles.with_plastic_state();
    let p = particles;
    for k in 0..p.len() {
        let Some(cone) = materials[p.body[k]].plastic() else {
            continue;
        };
        let j = p.fxx[k] * p.fyy[k] - p.fxy[k] * p.fyx[k];
        let e = cone.strain_of_stress([p.sxx[k] * j, p.syy[k] * j, p.sxy[k] * j]);
        let largest = e.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        if largest.is_nan() || largest > MAX_ELASTIC_STRAIN {
            return Err(MpmError::InvalidParticleValue {
                particle: k,
                field: "stress",
                value: [p.sxx[k], p.syy[k], p.sxy[k]]
                    .into_iter()
                    .fold(0.0f64, |m, v| m.max(v.abs())),
                reason: "an elastoplastic body's stress needs an elastic log strain above 1 (beyond its Young's \
                         modulus): no elastic state carries it",
            });
        }
        [p.elastic_xx[k], p.elastic_yy[k], p.elastic_xy[k], p.elastic_zz[k]] = e;
        p.plastic_strain[k] = 0.0;
    }
    Ok(())
}

/// The largest elastic log strain a particle's initial stress may need (1: a stretch of
/// e ≈ 2.7, or a body crushed to 37% of its length, by elasticity alone).
pub const MAX_ELASTIC_STRAIN: f64 = 1.0;
