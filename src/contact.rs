//! Contact between bodies: one grid velocity field per body (multi-velocity fields), with
//! Coulomb friction and bodies of prescribed motion.
//!
//! Without contact every body shares the grid's one velocity field: bodies that come within a
//! cell of each other stick through it. With contact ([`Contact`], `[contact]` in a scene)
//! each body `b` has its own operators, the columns of its particles,
//!
//! ```text
//! N_b = N diag(1_b),   G_b = G diag(1_b),   m_b = N_b m,   q_b = N_b (m ∘ v),
//! f_b = N_b (m ∘ g) − G_b (V ∘ σ),          M_b = N_b diag(m) N_bᵀ  (the consistent mass)
//! ```
//!
//! and its own grid velocity, projected and updated with its own mass (lumped, consistent, cg,
//! blended: every scheme of [`crate::mass`]). At a node where two bodies `a` and `b` both have
//! mass, their velocities are corrected toward the pair's centre-of-mass velocity (Bardenhagen,
//! Brackbill & Sulsky 2000; Bardenhagen et al. 2001) when they approach:
//!
//! ```text
//! μ_ab = m_a m_b / (m_a + m_b)                 (m_a if b is rigid)
//! Δp   = μ_ab (v_b − v_a)                     the momentum that sticks a to b
//! n    = (g_a − g_b) / |g_a − g_b|            a's outward normal, g_b = G_b V (Nairn's average;
//!                                              −g_b / |g_b| when b is rigid)
//! contact:   Δp · n < 0                        (a approaches b along n)
//! Δp_n = (Δp · n) n,   Δp_t = Δp − Δp_n
//! stick:     |Δp_t| ≤ μ |Δp · n|  →  Δp' = Δp
//! slide:                          →  Δp' = Δp_n + μ |Δp · n| Δp_t / |Δp_t|
//! v_a ← v_a + Δp' / m_a,    v_b ← v_b − Δp' / m_b
//! ```
//!
//! `g_b = [Gx V_b, Gy V_b]`, `V_b = 1_b ∘ V`, is the gradient of body `b`'s volume at the nodes
//! taken through the shape functions, `Σ_p ∇N_I(x_p) V_p`: it points out of the body (from its
//! particles toward the node). The normal is the average of the two bodies' (Nairn 2013: the mass gradient
//! fails for unequal densities, and each body's own normal does not conserve momentum), so
//! `Δp'` leaves the pair's momentum unchanged to round-off. Nodes where a body's share of the
//! pair's lumped mass is below [`Contact::min_mass_fraction`] are skipped. With three or more
//! bodies at a node the pairs are corrected one after another, in the order of their indices.
//!
//! The correction is applied to the projected velocities `v_b` (the momentum stage, in place,
//! as NairnMPM does: FLIP's increment `Nᵀ(w − v)` carries the force stage's correction) and to
//! the updated velocities `w_b = v_b + Δt a_b` (the force stage, whose normal impulse over `Δt`
//! is the contact force). Under MUSL the re-projected velocities that strain the particles are
//! corrected where the force stage found contact, whether or not they approach themselves: the
//! strain then follows the motion (decided by their own approach, two blocks in impact gained
//! 30% of their energy as they parted).
//!
//! **Which mass.** The correction acts on the velocities each body's lumped solve produced,
//! weighted by the lumped masses `m_L,b = N_b m`. A consistent mass per body,
//! `M_b = N_b diag(m) N_bᵀ`, is refused for now ([`Options::validate`]): a node-by-node
//! correction of the velocities is not dissipative in the metric of `M_b`, and applied to the
//! velocities, or through `M_b⁻¹` as the momentum it carries, it made two disks in impact gain
//! 4 to 55% of their energy.
//!
//! [`Options::validate`]: crate::simulation::Options::validate
//!
//! **Separation.** Sharing a node is not touching: a pair is in contact at a node only where
//! the mass centres of their particles as the node sees them are close enough along the normal
//! ([`Separation`], Nairn's position test).
//!
//! **Walls with friction** (a slip edge with [`BoundaryCondition::friction`]) are met the same
//! way, as a rigid half-space at rest beyond the wall line with the wall's normal, at every node
//! whose kernel support crosses the line.
//!
//! [`BoundaryCondition::friction`]: crate::boundary::BoundaryCondition::friction
//!
//! **Rigid bodies** ([`RigidBody`]) move at a prescribed velocity: their grid field is that
//! velocity wherever they have mass, they take part in contact with an infinite mass, and their
//! particles move with them (no stress).
//!
//! The work of friction, its impulses against the slip that remains, `Σ −Δp'_t · (w'_a − w'_b)`,
//! is reported (`friction_dissipation`), so that the energy balance of a frictional run closes;
//! the normal corrections are an inelastic collision at each node where the bodies meet.

use serde::{Deserialize, Serialize};

use crate::error::{MpmError, Result};
use crate::mass::Stabilization;

/// The default [`Contact::min_mass_fraction`].
pub const DEFAULT_MIN_MASS_FRACTION: f64 = 1e-5;

/// Contact between bodies ([module docs](self)).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Contact {
    /// Coulomb's coefficient `μ` between every pair of bodies (0: frictionless), finite.
    pub friction: f64,
    /// Pairs of bodies with a coefficient or a normal of their own.
    pub pairs: Vec<Pair>,
    /// Bodies of prescribed motion.
    pub rigid: Vec<RigidBody>,
    /// Nodes where a body's share of the pair's lumped mass is below this are not corrected.
    pub min_mass_fraction: f64,
    /// The separation test ([`Separation`]).
    pub separation: Separation,
    /// The stabilisation of each body's own consistent (cg, blended) mass, `M_b` (partial
    /// lumping by default): where two bodies press together, each one's surface there is a
    /// fringe of its own grid that changes every step of the impact. Two disks in impact part
    /// with 102.8% of their energy under the schemes' default linear extension, 100.8% with
    /// partial lumping; a block sliding on an elastic ramp strays 7.5% from the closed form
    /// with the ghost penalty, 1.2% with partial lumping (docs/verification.md). The shared
    /// field's mass keeps the schemes' own.
    pub stabilization: Stabilization,
}

impl Default for Contact {
    fn default() -> Self {
        Contact {
            friction: 0.0,
            pairs: Vec::new(),
            rigid: Vec::new(),
            min_mass_fraction: DEFAULT_MIN_MASS_FRACTION,
            separation: Separation::default(),
            stabilization: DEFAULT_STABILIZATION,
        }
    }
}

/// The default [`Contact::stabilization`]: partial lumping with the threshold
/// [`DEFAULT_LUMPING_THRESHOLD`](crate::mass::stabilization::DEFAULT_LUMPING_THRESHOLD).
pub const DEFAULT_STABILIZATION: Stabilization = Stabilization::PartialLumping {
    threshold: crate::mass::stabilization::DEFAULT_LUMPING_THRESHOLD,
};

/// Whether two bodies that share a node are close enough there to be in contact, from the
/// positions of their material at the node (Nairn's position test): with `x̄_b = N_b (m ∘ x) / m_b`
/// the mass centre of body `b`'s particles as the node sees them,
///
/// ```text
/// in contact where  (x̄_b − x̄_a) · n  ≤  c h⊥,     h⊥ = max(|h_x n_x|, |h_y n_y|)
/// ```
///
/// Two half-spaces that touch at a node have their mass centres `2 ξ h⊥` apart, `ξ` the
/// distance from a node to the mass centre of half its kernel (1/3 of a cell for linear
/// functions, 0.406 for quadratic B-splines); the default cutoff is `c = 1.2 · 2 ξ` (0.8 for
/// linear functions, Nairn's default). Without it, bodies meet wherever their kernels overlap,
/// and a disk rolling on a floor has the nodes beside its contact point stopped against it.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub enum Separation {
    /// `c = 1.2 · 2 ξ` of the shape functions.
    #[default]
    Kernel,
    /// This cutoff `c`, in cells.
    Cutoff(f64),
    /// No test: contact wherever the bodies share a node and approach.
    Off,
}

/// A pair of bodies (their indices) with a friction coefficient and a normal of its own.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Pair {
    /// The two bodies' indices.
    pub bodies: [usize; 2],
    /// Coulomb's coefficient `μ` between them.
    pub friction: f64,
    /// How their contact normal is found.
    pub normal: Normal,
}

/// How the contact normal of a pair is found at a node.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub enum Normal {
    /// The average of the two bodies' volume gradients, `unit(g_a − g_b)` (Nairn's
    /// recommendation; a rigid body's own gradient when one of the two is rigid).
    #[default]
    Average,
    /// The surface of this body (its index, one of the pair's): its own volume gradient. For a
    /// flat body met by a smaller one (a ramp and a block), whose corners would tilt the
    /// average: there the block's side faces turn the averaged normal sideways, and a block
    /// sliding frictionless on an elastic ramp was held back by 3% (linear) and stopped
    /// (quadratic B-splines).
    Body(usize),
    /// A fixed direction, from the first body of the pair toward the second (normalised).
    Direction([f64; 2]),
}

/// The normal rule [`contact_normal`] applies at a node, for bodies `a` and `b` in that order.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PairNormal {
    /// `unit(g_a − g_b)`, or a rigid body's own.
    Average,
    /// `unit(g_a)`.
    OfA,
    /// `−unit(g_b)`.
    OfB,
    /// This direction, from `a` toward `b`.
    Direction([f64; 2]),
}

/// A body whose particles move at a prescribed velocity (an indenter, a ramp, a floor).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RigidBody {
    /// The body's index.
    pub body: usize,
    /// Its velocity, constant in time.
    pub velocity: [f64; 2],
}

impl Contact {
    /// Checks the coefficients and the body indices against `bodies` bodies.
    ///
    /// # Errors
    /// [`MpmError::InvalidOption`] naming the key: a negative or non-finite friction coefficient, a
    /// body index out of range, a pair of a body with itself, a pair or rigid body given twice,
    /// a non-finite velocity, a mass fraction outside `[0, 1)`.
    pub fn validate(&self, bodies: usize) -> Result<()> {
        let bad = |option: &'static str, reason: String| Err(MpmError::InvalidOption { option, reason });
        let coefficient = |mu: f64| mu.is_finite() && mu >= 0.0;
        if !coefficient(self.friction) {
            return bad(
                "contact.friction",
                format!("{} is not a friction coefficient (finite, μ ≥ 0)", self.friction),
            );
        }
        if let Separation::Cutoff(c) = self.separation {
            if !(c.is_finite() && c > 0.0) {
                return bad(
                    "contact.separation",
                    format!("{c} is not a cutoff (finite, positive, in cells)"),
                );
            }
        }
        if let Err(e) = self.stabilization.validate() {
            return bad("contact.stabilization", e.to_string());
        }
        if !(0.0..1.0).contains(&self.min_mass_fraction) {
            return bad(
                "contact.min_mass_fraction",
                format!("{} is outside [0, 1)", self.min_mass_fraction),
            );
        }
        for (k, pair) in self.pairs.iter().enumerate() {
            let [a, b] = pair.bodies;
            match pair.normal {
                Normal::Body(c) if c != a && c != b => {
                    return bad(
                        "contact.pairs",
                        format!("pair {k}: the normal of body {c}, which is not one of the pair ({a}, {b})"),
                    );
                }
                Normal::Direction(d) if !(d[0].is_finite() && d[1].is_finite() && d[0].hypot(d[1]) > 0.0) => {
                    return bad(
                        "contact.pairs",
                        format!("pair {k}: the normal {d:?} is not a finite non-zero direction"),
                    );
                }
                _ => {}
            }
            if a >= bodies || b >= bodies {
                return bad("contact.pairs", format!("pair {k} names body {} of {bodies}", a.max(b)));
            }
            if a == b {
                return bad("contact.pairs", format!("pair {k} is body {a} with itself"));
            }
            if !coefficient(pair.friction) {
                return bad(
                    "contact.pairs",
                    format!(
                        "pair {k}: {} is not a friction coefficient (finite, μ ≥ 0)",
                        pair.friction
                    ),
                );
            }
            if self.pairs[..k].iter().any(|q| sorted(q.bodies) == sorted(pair.bodies)) {
                return bad("contact.pairs", format!("pair {k} (bodies {a}, {b}) is given twice"));
            }
        }
        for (k, rigid) in self.rigid.iter().enumerate() {
            if rigid.body >= bodies {
                return bad(
                    "contact.rigid",
                    format!("rigid body {k} names body {} of {bodies}", rigid.body),
                );
            }
            if rigid.velocity.iter().any(|v| !v.is_finite()) {
                return bad(
                    "contact.rigid",
                    format!("body {}: the velocity {:?} is not finite", rigid.body, rigid.velocity),
                );
            }
            if self.rigid[..k].iter().any(|r| r.body == rigid.body) {
                return bad("contact.rigid", format!("body {} is given twice", rigid.body));
            }
        }
        Ok(())
    }

    /// The friction coefficient between bodies `a` and `b`: the pair's own, else
    /// [`Contact::friction`].
    pub fn friction_between(&self, a: usize, b: usize) -> f64 {
        self.pairs
            .iter()
            .find(|p| sorted(p.bodies) == sorted([a, b]))
            .map_or(self.friction, |p| p.friction)
    }

    /// The normal rule between bodies `a` and `b`, in that order: the pair's own, else the
    /// average.
    pub fn normal_between(&self, a: usize, b: usize) -> PairNormal {
        let Some(pair) = self.pairs.iter().find(|p| sorted(p.bodies) == sorted([a, b])) else {
            return PairNormal::Average;
        };
        match pair.normal {
            Normal::Average => PairNormal::Average,
            Normal::Body(c) if c == a => PairNormal::OfA,
            Normal::Body(_) => PairNormal::OfB,
            Normal::Direction(d) => {
                let sign = if pair.bodies[0] == a { 1.0 } else { -1.0 };
                let l = d[0].hypot(d[1]);
                PairNormal::Direction([sign * d[0] / l, sign * d[1] / l])
            }
        }
    }

    /// The prescribed velocity of body `b`, if it is rigid.
    pub fn rigid_velocity(&self, b: usize) -> Option<[f64; 2]> {
        self.rigid.iter().find(|r| r.body == b).map(|r| r.velocity)
    }
}

fn sorted([a, b]: [usize; 2]) -> [usize; 2] {
    [a.min(b), a.max(b)]
}

/// One body's share of a node, as the correction reads it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NodeBody {
    /// Lumped mass `m_L,b` at the node.
    pub mass: f64,
    /// Grid velocity.
    pub velocity: [f64; 2],
    /// `g_b = G_b V` at the node, which points out of the body ([module docs](self)).
    pub volume_gradient: [f64; 2],
    /// Whether the body's motion is prescribed (an infinite mass in the correction).
    pub rigid: bool,
}

/// The correction of one pair at one node ([`pair_correction`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Correction {
    /// `Δp'`, the momentum body `a` gains (body `b` loses it).
    pub impulse: [f64; 2],
    /// `|Δp · n|`, the normal impulse.
    pub normal_impulse: f64,
    /// The tangential part of `Δp'` (the friction's impulse).
    pub tangential: [f64; 2],
}

/// The contact correction of bodies `a` and `b` at one node, with Coulomb coefficient `mu`
/// ([module docs](self)):
///
/// ```text
/// Δp = μ_ab (v_b − v_a), n the normal ([`contact_normal`]);  none unless Δp · n < 0
/// Δp' = Δp                                           if |Δp_t| ≤ μ |Δp · n|
///     = Δp_n + μ |Δp · n| Δp_t / |Δp_t|              otherwise
/// ```
///
/// `None` when the bodies do not approach or when both are rigid.
pub fn pair_correction(a: &NodeBody, b: &NodeBody, n: [f64; 2], mu: f64) -> Option<Correction> {
    correction(a, b, n, mu, true)
}

/// The contact normal at a node of bodies `a` and `b` (`a`'s outward normal, toward `b`) under
/// `rule`; `None` where it is not defined (a zero gradient).
///
/// ```text
/// Average:  unit(g_a − g_b)  (−unit(g_b) if b is rigid, unit(g_a) if a is)
/// OfA: unit(g_a)    OfB: −unit(g_b)    Direction(d): d
/// ```
pub fn contact_normal(a: &NodeBody, b: &NodeBody, rule: PairNormal) -> Option<[f64; 2]> {
    let (ga, gb) = (a.volume_gradient, b.volume_gradient);
    let g = match rule {
        PairNormal::Direction(d) => return Some(d),
        PairNormal::OfB => [-gb[0], -gb[1]],
        PairNormal::OfA => ga,
        // A rigid body's surface is the one to meet: its own gradient gives the normal.
        PairNormal::Average if b.rigid => [-gb[0], -gb[1]],
        PairNormal::Average if a.rigid => ga,
        PairNormal::Average => [ga[0] - gb[0], ga[1] - gb[1]],
    };
    let length = g[0].hypot(g[1]);
    // (NaN fails this too.)
    (length.partial_cmp(&0.0) == Some(std::cmp::Ordering::Greater)).then(|| [g[0] / length, g[1] / length])
}

/// [`pair_correction`] of a pair known to be in contact (the strain update's velocities, after
/// the force stage found the contact): no approach test, the normal impulse's magnitude
/// `|Δp · n|` bounds the friction.
pub(crate) fn pair_correction_in_contact(a: &NodeBody, b: &NodeBody, n: [f64; 2], mu: f64) -> Option<Correction> {
    correction(a, b, n, mu, false)
}

fn correction(a: &NodeBody, b: &NodeBody, n: [f64; 2], mu: f64, approach: bool) -> Option<Correction> {
    let reduced = match (a.rigid, b.rigid) {
        (true, true) => return None,
        (false, true) => a.mass,
        (true, false) => b.mass,
        (false, false) => a.mass * b.mass / (a.mass + b.mass),
    };
    if reduced.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let dp = [
        reduced * (b.velocity[0] - a.velocity[0]),
        reduced * (b.velocity[1] - a.velocity[1]),
    ];
    let dn = dp[0] * n[0] + dp[1] * n[1];
    if approach && dn.partial_cmp(&0.0) != Some(std::cmp::Ordering::Less) {
        return None;
    }
    let normal = [dn * n[0], dn * n[1]];
    let tangential = [dp[0] - normal[0], dp[1] - normal[1]];
    let t = tangential[0].hypot(tangential[1]);
    let bound = mu * dn.abs();
    let impulse = if t <= bound {
        dp
    } else {
        let s = bound / t;
        [normal[0] + s * tangential[0], normal[1] + s * tangential[1]]
    };
    Some(Correction {
        impulse,
        normal_impulse: dn.abs(),
        tangential: [impulse[0] - normal[0], impulse[1] - normal[1]],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn body(mass: f64, velocity: [f64; 2], gradient: [f64; 2]) -> NodeBody {
        NodeBody {
            mass,
            velocity,
            volume_gradient: gradient,
            rigid: false,
        }
    }

    #[test]
    fn approaching_bodies_meet_at_the_centre_of_mass_velocity_frictionless_along_the_normal() {
        // a below b (a's volume gradient points up, out of a; b's down): normal +y from a.
        let a = body(2.0, [1.0, 3.0], [0.0, 1.0]);
        let b = body(1.0, [0.0, -3.0], [0.0, -1.0]);
        let n = contact_normal(&a, &b, PairNormal::Average).unwrap();
        assert_eq!(n, [0.0, 1.0]);
        let c = pair_correction(&a, &b, n, 0.0).unwrap();
        let va = [
            a.velocity[0] + c.impulse[0] / a.mass,
            a.velocity[1] + c.impulse[1] / a.mass,
        ];
        let vb = [
            b.velocity[0] - c.impulse[0] / b.mass,
            b.velocity[1] - c.impulse[1] / b.mass,
        ];
        // Normal velocities equal (the centre of mass's, 1), tangential untouched.
        assert!((va[1] - 1.0).abs() < 1e-15 && (vb[1] - 1.0).abs() < 1e-15);
        assert_eq!((va[0], vb[0]), (1.0, 0.0));
        // Momentum conserved, energy lost (an inelastic normal collision), no friction.
        let p0 = [2.0 * 1.0 + 0.0, 2.0 * 3.0 - 3.0];
        assert!((2.0 * va[0] + vb[0] - p0[0]).abs() < 1e-15 && (2.0 * va[1] + vb[1] - p0[1]).abs() < 1e-15);
        let k = |m: f64, v: [f64; 2]| 0.5 * m * (v[0] * v[0] + v[1] * v[1]);
        assert!(k(2.0, a.velocity) + k(1.0, b.velocity) > k(2.0, va) + k(1.0, vb));
        assert_eq!(c.tangential, [0.0, 0.0]);
        // Separating: nothing.
        let away = body(1.0, [0.0, 5.0], [0.0, -1.0]);
        assert!(pair_correction(&a, &away, n, 0.3).is_none());
    }

    #[test]
    fn coulomb_friction_sticks_inside_the_cone_and_slides_on_it() {
        let a = body(1.0, [0.0, -1.0], [0.0, -1.0]); // above b: normal −y from a
        let b = NodeBody {
            rigid: true,
            ..body(5.0, [0.0, 0.0], [0.0, 1.0])
        };
        // |Δp_t| = 0.2 ≤ 0.3 · 1: sticks (a stops).
        let slow = NodeBody {
            velocity: [0.2, -1.0],
            ..a
        };
        // The rigid body's own normal, whatever the other's gradient.
        let tilted = NodeBody {
            volume_gradient: [5.0, -1.0],
            ..slow
        };
        let n = contact_normal(&tilted, &b, PairNormal::Average).unwrap();
        assert_eq!(n, [0.0, -1.0]);
        let c = pair_correction(&slow, &b, n, 0.3).unwrap();
        assert_eq!(c.impulse, [-0.2, 1.0]);
        assert_eq!(c.tangential, [-0.2, 0.0]);
        // |Δp_t| = 2 > 0.3: slides, the tangential change μ |Δp·n|.
        let fast = NodeBody {
            velocity: [2.0, -1.0],
            ..a
        };
        let c = pair_correction(&fast, &b, n, 0.3).unwrap();
        assert!((c.impulse[0] + 0.3).abs() < 1e-15 && (c.impulse[1] - 1.0).abs() < 1e-15);
        assert_eq!(c.normal_impulse, 1.0);
        // On the cone: |Δp_t| = μ |Δp · n|.
        assert!((c.tangential[0].hypot(c.tangential[1]) - 0.3).abs() < 1e-15);
        // Known to be in contact, a separating pair is held along the normal.
        let away = NodeBody {
            velocity: [0.0, 1.0],
            ..a
        };
        assert!(pair_correction(&away, &b, n, 0.3).is_none());
        let held = pair_correction_in_contact(&away, &b, n, 0.0).unwrap();
        assert_eq!(held.impulse, [0.0, -1.0]);
        // Two rigid bodies never correct each other.
        assert!(pair_correction(&b, &b, n, 0.3).is_none());
    }

    #[test]
    fn validation_names_the_key() {
        let mut c = Contact {
            friction: -0.1,
            ..Contact::default()
        };
        let text = |c: &Contact| c.validate(2).unwrap_err().to_string();
        assert!(text(&c).contains("contact.friction"));
        c.friction = 0.2;
        c.pairs = vec![Pair {
            bodies: [0, 2],
            friction: 0.1,
            normal: Normal::Body(1),
        }];
        assert!(text(&c).contains("contact.pairs"));
        c.pairs[0].bodies = [1, 0];
        c.validate(2).unwrap();
        assert_eq!(c.friction_between(0, 1), 0.1);
        assert_eq!(c.normal_between(0, 1), PairNormal::OfB);
        c.pairs[0].normal = Normal::Direction([0.0, 2.0]);
        assert_eq!(c.normal_between(0, 1), PairNormal::Direction([0.0, -1.0]));
        c.pairs[0].normal = Normal::Direction([0.0, 0.0]);
        assert!(text(&c).contains("contact.pairs"));
        c.pairs[0].normal = Normal::Average;
        c.rigid = vec![RigidBody {
            body: 1,
            velocity: [f64::NAN, 0.0],
        }];
        assert!(text(&c).contains("contact.rigid"));
    }
}
