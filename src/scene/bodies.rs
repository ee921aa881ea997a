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
            let mut p = self.body_particles(k, body, &grid)?;
            p.body = vec![k; p.len()];
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
        let or_zero = |v: Option<Vec<f64>>| v.unwrap_or_else(|| vec![0.0; count]);
        let mass = mass.unwrap_or_else(|| columns.volume.iter().map(|v| body.density * v).collect());
        let vx = or_zero(vx).iter().map(|v| v + body.velocity[0]).collect();
        let vy = or_zero(vy).iter().map(|v| v + body.velocity[1]).collect();
        let mut p = Particles::new(columns.x, columns.y, mass, columns.volume)
            .and_then(|p| p.with_velocity(vx, vy))
            .and_then(|p| p.with_stress(or_zero(sxx), or_zero(syy), or_zero(sxy)))
            .and_then(|p| p.with_body_force(vec![body.body_force[0]; count], vec![body.body_force[1]; count]))
            .map_err(|e| invalid(key("geometry"), e.to_string()))?;
        let g = [
            self.loads.gravity[0] + body.body_force[0],
            self.loads.gravity[1] + body.body_force[1],
        ];
        super::initial::apply(k, body, g, &mut p)?;
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
