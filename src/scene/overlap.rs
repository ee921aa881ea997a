//! Bodies whose particles lie in the same place: a scene that is probably wrong but not
//! invalid, reported as a [`SceneWarning`].
//!
//! Bodies in contact scenes are put next to each other, so nearness alone is no fault. What is
//! one is material counted twice: particles of two bodies in the same place. The test: a
//! particle of one body lies closer to a particle of another than half the smaller of their
//! spacings (a particle's spacing is the square root of its volume, the lattice pitch for
//! rectangles and disks). Two bodies filled on the same lattice either share lattice points
//! (distance 0) or keep at least one pitch apart, so touching bodies never warn and
//! overlapping ones always do when the overlap holds a lattice point.

use std::collections::HashMap;
use std::fmt;

use super::Scene;
use crate::particles::Particles;

/// Particles of one body lying on particles of an earlier body.
#[derive(Debug, Clone, PartialEq)]
pub struct Overlap {
    /// The earlier body (index in [`Scene::bodies`]).
    pub first: usize,
    /// The later body.
    pub second: usize,
    /// Particles of `second` closer to a particle of `first` than half the smaller spacing.
    pub particles: usize,
    /// Where the first of them (the lowest particle id) is.
    pub at: [f64; 2],
}

/// A scene that is valid but probably not what was meant: the key it concerns (with the file
/// and line when the scene was read from a file, as in errors) and what is wrong.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneWarning {
    /// Where: `bodies[1].geometry`, or `scenes/x.toml: line 40, bodies[1].geometry`.
    pub key: String,
    /// What is probably wrong.
    pub message: String,
}

impl fmt::Display for SceneWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "`{}`: {}", self.key, self.message)
    }
}

/// Every pair of bodies whose particles lie in the same place (closer than half the smaller particle spacing), in
/// the order of the later body, then the earlier. Particles are binned in squares of the
/// largest half-spacing, so each is compared with the particles of its own and the eight
/// neighbouring squares: linear in the particle count for particles of similar sizes.
pub fn overlaps(p: &Particles) -> Vec<Overlap> {
    let n = p.x.len();
    if n == 0 || p.body.iter().all(|&b| b == p.body[0]) {
        return Vec::new();
    }
    let half = |i: usize| 0.5 * p.volume[i].sqrt();
    let bin = (0..n).map(half).fold(0.0_f64, f64::max);
    if !(bin.is_finite() && bin > 0.0) {
        return Vec::new();
    }
    let cell = |i: usize| ((p.x[i] / bin).floor() as i64, (p.y[i] / bin).floor() as i64);
    let mut bins: HashMap<(i64, i64), Vec<usize>> = HashMap::new();
    for i in 0..n {
        bins.entry(cell(i)).or_default().push(i);
    }
    // (earlier body, later body) → (count, lowest id, its position).
    let mut found: HashMap<(usize, usize), (usize, usize, [f64; 2])> = HashMap::new();
    let id = |i: usize| p.id.get(i).copied().unwrap_or(i);
    for i in 0..n {
        let (cx, cy) = cell(i);
        // The earlier bodies this particle lies on, each counted once.
        let mut under: Vec<usize> = Vec::new();
        for dx in -1..=1 {
            for dy in -1..=1 {
                let Some(list) = bins.get(&(cx + dx, cy + dy)) else {
                    continue;
                };
                for &j in list {
                    let (a, b) = (p.body[j], p.body[i]);
                    if a >= b || under.contains(&a) {
                        continue;
                    }
                    let limit = half(i).min(half(j));
                    if (p.x[i] - p.x[j]).hypot(p.y[i] - p.y[j]) < limit {
                        under.push(a);
                    }
                }
            }
        }
        for a in under {
            let entry = found.entry((a, p.body[i])).or_insert((0, id(i), [p.x[i], p.y[i]]));
            entry.0 += 1;
            if id(i) < entry.1 {
                (entry.1, entry.2) = (id(i), [p.x[i], p.y[i]]);
            }
        }
    }
    let mut list: Vec<Overlap> = found
        .into_iter()
        .map(|((first, second), (particles, _, at))| Overlap {
            first,
            second,
            particles,
            at,
        })
        .collect();
    list.sort_by_key(|o| (o.second, o.first));
    list
}

impl Scene {
    /// What is valid in the scene but probably not meant: bodies whose particles lie in the
    /// same place ([`overlaps`] of `particles`, the scene's particles as
    /// [`Scene::particles`] builds them). Each warning names the later body's geometry key,
    /// with the file and line as [`Scene::locate`] gives them.
    pub fn warnings_for(&self, particles: &Particles) -> Vec<SceneWarning> {
        let name = |k: usize| self.bodies.get(k).map_or("", |b| b.name.as_str());
        // A region with a material of its own is its body's part: overlaps are between bodies.
        let owner = self.region_owners();
        let mapped;
        let particles = if particles.body.iter().any(|&b| b >= self.bodies.len()) {
            let mut p = particles.clone();
            p.body
                .iter_mut()
                .for_each(|b| *b = owner.get(*b).copied().unwrap_or(*b));
            mapped = p;
            &mapped
        } else {
            particles
        };
        overlaps(particles)
            .into_iter()
            .map(|o| {
                let key = format!("bodies[{}].geometry", o.second);
                let key = match self.locate(super::invalid(key.clone(), "")) {
                    crate::error::MpmError::InvalidScene { key, .. } => key,
                    _ => key,
                };
                SceneWarning {
                    key,
                    message: format!(
                        "{} particles of body `{}` lie on particles of bodies[{}] (`{}`), closer than half a \
                         particle spacing (the first at ({}, {})): the material there is counted twice. Bodies \
                         in contact should share only a boundary.",
                        o.particles,
                        name(o.second),
                        o.first,
                        name(o.first),
                        crate::numbers::human(o.at[0]),
                        crate::numbers::human(o.at[1]),
                    ),
                }
            })
            .collect()
    }

    /// [`Scene::warnings_for`] the scene's particles, built here; none when they cannot be
    /// built (the build reports why).
    pub fn warnings(&self) -> Vec<SceneWarning> {
        match self.body_particles_all() {
            Ok(particles) => self.warnings_for(&particles),
            Err(_) => Vec::new(),
        }
    }
}
