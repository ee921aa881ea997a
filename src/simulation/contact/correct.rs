//! The contact corrections of one stage of the step: which pairs of bodies meet at which nodes
//! ([`candidate`]), and their impulses, node by node with the lumped mass ([`correct`]) or
//! through each body's mass with any other ([`super::solve`]).

use super::{Layer, State};
use crate::contact::{contact_normal, pair_correction, pair_correction_in_contact, Contact, NodeBody};
use crate::fields::VectorField;
use crate::kernels::GridState;
use crate::mass::Role;
use crate::simulation::Setup;

/// The three times a step corrects the bodies' velocities.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Stage {
    /// The projected velocities `v_b` (6).
    Momentum,
    /// The updated velocities `w_b = v_b + Δt a_b` (8).
    Force,
    /// MUSL's re-projected velocities, which strain the particles (11).
    Strain,
}

impl Stage {
    /// The field the stage corrects.
    pub(super) fn field(self, n: &mut GridState) -> &mut VectorField {
        match self {
            Stage::Momentum | Stage::Strain => &mut n.projected,
            Stage::Force => &mut n.updated,
        }
    }

    /// [`Stage::field`], to read.
    pub(super) fn field_of(self, n: &GridState) -> &VectorField {
        match self {
            Stage::Momentum | Stage::Strain => &n.projected,
            Stage::Force => &n.updated,
        }
    }

    /// The solve whose mass an impulse of this stage goes through: the velocity projection's
    /// for the projected velocities, the acceleration solve's for the updated ones (an impulse
    /// `J` over the step is the force `J / Δt`, `Δw = Δt M_a⁻¹ J / Δt`).
    pub(super) fn role(self) -> Role {
        match self {
            Stage::Momentum | Stage::Strain => Role::Velocity,
            Stage::Force => Role::Acceleration,
        }
    }
}

/// What one stage of corrections did: its normal impulses, and (the force stage) the work of
/// friction over the step, its tangential impulse against the slip that remains,
///
/// ```text
/// W_f = −Σ Δp'_t · (w'_a − w'_b)      (≥ 0: friction opposes the slip; 0 where the pair sticks)
/// ```
#[derive(Debug, Default, Clone, Copy)]
pub(super) struct Tally {
    pub(super) normal_impulse: f64,
    pub(super) friction: f64,
}

impl Tally {
    pub(super) fn add_to(self, state: &mut State) {
        state.relaxation.friction_dissipation += self.friction;
    }
}

/// The second index of a [`Touching`] pair that is a wall with friction (`WALL + w`, `w` its
/// place in [`Prescribed::friction`](crate::boundary::Prescribed::friction)).
pub(super) const WALL: usize = usize::MAX / 2;

/// A pair of bodies the force stage found in contact at a node.
#[derive(Debug, Clone, Copy)]
pub(super) struct Touching {
    pub(super) node: usize,
    pub(super) bodies: [usize; 2],
}

/// How [`correct`] decides where the bodies are in contact.
pub(super) enum Decide<'a> {
    /// Where they share a node and approach, each such pair recorded.
    Approach(&'a mut Vec<Touching>),
    /// Where the force stage found them (the strain update's velocities): MUSL's re-projected
    /// velocities are corrected where the step's motion was, whatever their own approach.
    Known(&'a [Touching]),
}

/// One pair of bodies at one node that the stage may correct: the pair's normal (`a`'s outward
/// one, toward `b`), its Coulomb coefficient, and each body's mass, velocity and volume
/// gradient there (a wall's: `a`'s mass, at rest, rigid).
#[derive(Debug, Clone, Copy)]
pub(super) struct Candidate {
    pub(super) node: usize,
    pub(super) bodies: [usize; 2],
    pub(super) normal: [f64; 2],
    pub(super) mu: f64,
    pub(super) a: NodeBody,
    pub(super) b: NodeBody,
}

/// What a stage reads besides the bodies' fields.
pub(super) struct Context<'a> {
    pub(super) contact: &'a Contact,
    pub(super) setup: &'a Setup,
    pub(super) rigid: Vec<Option<[f64; 2]>>,
    pub(super) stage: Stage,
}

impl Context<'_> {
    /// The pair `[a, b]` at node `i` as the stage sees it now, or `None` where it cannot be in
    /// contact: no normal; unless `known`, a body's share of the pair's mass below
    /// `min_mass_fraction`, or mass centres further apart along the normal than the separation
    /// cutoff. `b ≥ WALL` is the wall `b − WALL`, its mass centre at `wall_centre` on its axis.
    pub(super) fn candidate(
        &self,
        bodies: &[Layer],
        i: usize,
        [a, b]: [usize; 2],
        known: bool,
        wall_centre: f64,
    ) -> Option<Candidate> {
        let walls = &self.setup.prescribed.friction;
        let at = |k: usize| {
            let l = &bodies[k];
            let u = self.stage.field_of(&l.nodes);
            NodeBody {
                mass: l.mass.lumped()[i],
                velocity: [u.x[i], u.y[i]],
                volume_gradient: [l.gradient.x[i], l.gradient.y[i]],
                rigid: self.rigid[k].is_some(),
            }
        };
        let na = at(a);
        let (nb, mu, n) = if b >= WALL {
            let wall = &walls[b - WALL];
            let mut n = [0.0; 2];
            n[wall.axis] = wall.outward;
            let at_rest = NodeBody {
                velocity: [0.0; 2],
                volume_gradient: [0.0; 2],
                rigid: true,
                ..na
            };
            (at_rest, wall.friction, n)
        } else {
            let nb = at(b);
            let n = contact_normal(&na, &nb, self.contact.normal_between(a, b))?;
            (nb, self.contact.friction_between(a, b), n)
        };
        if !known {
            let floor = self.contact.min_mass_fraction * (na.mass + nb.mass);
            if b < WALL && (na.mass < floor || nb.mass < floor) {
                return None;
            }
            // The separation test: the mass centres no further apart along n than the cutoff.
            let centre = |l: &Layer| [l.centre.x[i], l.centre.y[i]];
            let xa = centre(&bodies[a]);
            let xb = if b >= WALL {
                let mut x = xa;
                x[walls[b - WALL].axis] = wall_centre;
                x
            } else {
                centre(&bodies[b])
            };
            let [hx, hy] = self.setup.grid.cell_size();
            let gap = (xb[0] - xa[0]) * n[0] + (xb[1] - xa[1]) * n[1];
            if gap > self.setup.separation * (hx * n[0]).abs().max((hy * n[1]).abs()) {
                return None;
            }
        }
        Some(Candidate {
            node: i,
            bodies: [a, b],
            normal: n,
            mu,
            a: na,
            b: nb,
        })
    }

    /// Sets rigid bodies' fields to their velocities on their active nodes.
    pub(super) fn set_rigid(&self, bodies: &mut [Layer], span: std::ops::Range<usize>) {
        for (layer, v) in bodies.iter_mut().zip(&self.rigid) {
            if let Some([vx, vy]) = *v {
                let Layer { mass, nodes, .. } = layer;
                let u = self.stage.field(nodes);
                for i in span.clone().filter(|&i| mass.is_active()[i]) {
                    (u.x[i], u.y[i]) = (vx, vy);
                }
            }
        }
    }

    /// Every pair that shares node `i` of `span` (bodies in the order of their indices, then
    /// each body with each wall with friction at the wall's nodes), as `visit(bodies, i, pair,
    /// wall_centre)` sees them; `visit` says whether it recorded the pair as touching.
    pub(super) fn each_pair(
        &self,
        bodies: &mut [Layer],
        span: std::ops::Range<usize>,
        touching: &mut Vec<Touching>,
        mut visit: impl FnMut(&mut [Layer], usize, [usize; 2], f64) -> bool,
    ) {
        touching.clear();
        let present = |l: &Layer, i: usize| l.mass.is_active()[i] && l.mass.lumped()[i] > 0.0;
        let nb = bodies.len();
        for i in span {
            if bodies.iter().filter(|l| present(l, i)).count() < 2 {
                continue;
            }
            for a in 0..nb {
                for b in a + 1..nb {
                    if present(&bodies[a], i) && present(&bodies[b], i) && visit(bodies, i, [a, b], 0.0) {
                        touching.push(Touching {
                            node: i,
                            bodies: [a, b],
                        });
                    }
                }
            }
        }
        for (w, nodes) in self.setup.wall_nodes.iter().enumerate() {
            for &(i, wall_centre) in nodes {
                for a in (0..nb).filter(|&a| self.rigid[a].is_none()) {
                    if present(&bodies[a], i) && visit(bodies, i, [a, WALL + w], wall_centre) {
                        touching.push(Touching {
                            node: i,
                            bodies: [a, WALL + w],
                        });
                    }
                }
            }
        }
    }
}

/// The contact corrections of the stage's field of the pairs of bodies `decide` selects, node
/// by node with the lumped mass ([`pair_correction`]), pairs at a node in the order of their
/// indices; rigid bodies' fields set to their velocities first, and the prescribed components
/// of boundary conditions kept.
pub(super) fn correct(cx: &Context, bodies: &mut [Layer], span: std::ops::Range<usize>, decide: Decide) -> Tally {
    cx.set_rigid(bodies, span.clone());
    let mut tally = Tally::default();
    let stage = cx.stage;
    let mut pair = |bodies: &mut [Layer], i: usize, pair: [usize; 2], known: bool, wall_centre: f64| {
        let Some(c) = cx.candidate(bodies, i, pair, known, wall_centre) else {
            return false;
        };
        let (na, nb) = (c.a, c.b);
        let correction = if known {
            pair_correction_in_contact(&na, &nb, c.normal, c.mu)
        } else {
            pair_correction(&na, &nb, c.normal, c.mu)
        };
        let Some(c) = correction else {
            return false;
        };
        let mut after = [na.velocity, nb.velocity];
        for (slot, (k, body, sign)) in [(pair[0], na, 1.0), (pair[1], nb, -1.0)].into_iter().enumerate() {
            if body.rigid {
                continue;
            }
            let u = stage.field(&mut bodies[k].nodes);
            u.x[i] += sign * c.impulse[0] / body.mass;
            u.y[i] += sign * c.impulse[1] / body.mass;
            after[slot] = [u.x[i], u.y[i]];
        }
        if stage == Stage::Force {
            // Friction's work over the step: its impulse against the slip that remains.
            let slip = [after[0][0] - after[1][0], after[0][1] - after[1][1]];
            tally.friction -= c.tangential[0] * slip[0] + c.tangential[1] * slip[1];
        }
        tally.normal_impulse += c.normal_impulse;
        true
    };
    match decide {
        Decide::Known(touching) => {
            for t in touching {
                pair(bodies, t.node, t.bodies, true, 0.0);
            }
        }
        Decide::Approach(touching) => {
            cx.each_pair(bodies, span, touching, |bodies, i, p, centre| {
                pair(bodies, i, p, false, centre)
            });
        }
    }
    for layer in bodies.iter_mut() {
        let u = stage.field(&mut layer.nodes);
        cx.setup.prescribed.apply_velocity(&mut u.x, &mut u.y);
    }
    tally
}
