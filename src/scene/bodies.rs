//! The particles of a scene's bodies: a lattice filling a rectangle or a disk, or a particle
//! file.

use super::particle_file::{read_particle_file, ParticleColumns};
use super::{invalid, BodySpec, Geometry, Scene};
use crate::error::Result;
use crate::grid::Grid;
use crate::particles::Particles;

impl Scene {
    /// The particles of every body, in body order, with `body` set.
    ///
    /// # Errors
    /// [`MpmError::InvalidScene`] for a body that yields no particles or an unreadable particle
    /// file (naming the file, the row and the column), located by [`Scene::locate`].
    ///
    /// [`MpmError::InvalidScene`]: crate::error::MpmError::InvalidScene
    pub fn particles(&self) -> Result<Particles> {
        self.body_particles_all().map_err(|e| self.locate(e))
    }

    /// [`Scene::particles`] with errors at their keys only.
    pub(super) fn body_particles_all(&self) -> Result<Particles> {
        let grid = self.grid()?;
        let mut all = Particles::default();
        for (k, body) in self.bodies.iter().enumerate() {
            let p = self.body_particles(k, body, &grid)?;
            // Each body's ids are 0..n, so the next free id is the count so far.
            let next = all.len();
            all.append_from(p, next)
                .map_err(|e| invalid(format!("bodies[{k}]"), e.to_string()))?;
        }
        Ok(all)
    }

    fn body_particles(&self, k: usize, body: &BodySpec, grid: &Grid) -> Result<Particles> {
        let key = |f: &str| format!("bodies[{k}].{f}");
        let columns = match &body.geometry {
            Geometry::File(written) => {
                let (shown, path) = self
                    .locate_particle_file(written)
                    .map_err(|reason| invalid(key("geometry.file"), reason))?;
                read_particle_file(&shown, &path, body.density)
                    .map_err(|reason| invalid(key("geometry.file"), reason))?
            }
            geometry => {
                inside_grid(k, geometry, grid)?;
                let (x, y, volume) =
                    super::sampling::sample(geometry, grid, body.particles_per_cell, body.sampling, body.seed);
                ParticleColumns {
                    volume,
                    x,
                    y,
                    ..ParticleColumns::default()
                }
            }
        };
        let count = columns.x.len();
        if count == 0 {
            return Err(invalid(
                key("geometry"),
                "contains no particle (is it inside the grid, and larger than a particle spacing?)",
            ));
        }
        let [vx, vy, mass, sxx, syy, sxy] = columns.optional;
        // The last region holding each particle.
        let region: Vec<Option<usize>> = (0..count)
            .map(|i| (body.regions.iter()).rposition(|r| r.geometry.contains(columns.x[i], columns.y[i])))
            .collect();
        let velocity = |i: usize| {
            region[i]
                .and_then(|r| body.regions[r].velocity)
                .unwrap_or(body.velocity)
        };
        let or_zero = |v: Option<Vec<f64>>| v.unwrap_or_else(|| vec![0.0; count]);
        let mass = mass.unwrap_or_else(|| columns.volume.iter().map(|v| body.density * v).collect());
        let vx = (or_zero(vx).iter().enumerate())
            .map(|(i, v)| v + velocity(i)[0])
            .collect();
        let vy = (or_zero(vy).iter().enumerate())
            .map(|(i, v)| v + velocity(i)[1])
            .collect();
        let mut p = Particles::new(columns.x, columns.y, mass, columns.volume)
            .and_then(|p| p.with_velocity(vx, vy))
            .and_then(|p| p.with_stress(or_zero(sxx), or_zero(syy), or_zero(sxy)))
            .and_then(|p| p.with_body_force(vec![body.body_force[0]; count], vec![body.body_force[1]; count]))
            .map_err(|e| invalid(key("geometry"), e.to_string()))?;
        let solver_body = self.region_bodies(k);
        p.body = (0..count)
            .map(|i| region[i].and_then(|r| solver_body[r]).unwrap_or(k))
            .collect();
        let g = [
            self.loads.gravity[0] + body.body_force[0],
            self.loads.gravity[1] + body.body_force[1],
        ];
        // The initial stress of each group of particles with the same material and initial
        // stress: the body's, and each region's that changes either.
        let own = |r: Option<usize>| {
            r.filter(|&r| body.regions[r].material.is_some() || body.regions[r].initial_stress.is_some())
        };
        let group: Vec<Option<usize>> = region.iter().map(|&r| own(r)).collect();
        let mut groups: Vec<Option<usize>> = group.clone();
        groups.sort_unstable();
        groups.dedup();
        for g_id in groups {
            let view = match g_id {
                None => body.clone(),
                Some(r) => {
                    let spec = &body.regions[r];
                    BodySpec {
                        material: spec.material.unwrap_or(body.material),
                        initial_stress: spec.initial_stress.or(body.initial_stress),
                        regions: Vec::new(),
                        ..body.clone()
                    }
                }
            };
            let select: Vec<bool> = group.iter().map(|&x| x == g_id).collect();
            let at = g_id.map_or(format!("bodies[{k}]"), |r| format!("bodies[{k}].regions[{r}]"));
            super::initial::apply(&at, &view, g, &mut p, &select)?;
        }
        Ok(p)
    }
}

/// Every shape of body `k`'s geometry inside the grid (to a relative 10⁻⁹ of the grid's size),
/// each part of a union, difference or transform on its own.
///
/// # Errors
/// [`MpmError::InvalidScene`] at the part outside (`bodies[k].geometry.union[1].disk`), with
/// its span and the grid's.
///
/// [`MpmError::InvalidScene`]: crate::error::MpmError::InvalidScene
pub(super) fn inside_grid(k: usize, geometry: &Geometry, grid: &Grid) -> Result<()> {
    let [x0, x1, y0, y1] = grid.bounds();
    let tol = 1e-9 * (x1 - x0).max(y1 - y0);
    let outside =
        |(lo, hi): ([f64; 2], [f64; 2])| lo[0] < x0 - tol || lo[1] < y0 - tol || hi[0] > x1 + tol || hi[1] > y1 + tol;
    let Some((key, (lo, hi))) = geometry.first_outside(&format!("bodies[{k}].geometry"), &outside) else {
        return Ok(());
    };
    Err(invalid(
        key,
        format!(
            "spans [{}, {}] x [{}, {}], which is not inside the grid [{x0}, {x1}] x [{y0}, {y1}]",
            lo[0], hi[0], lo[1], hi[1]
        ),
    ))
}
