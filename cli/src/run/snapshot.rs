//! The particle snapshots of a run: the arrays written, and the positions the displacement is
//! measured from.

use std::path::Path;

use crate::vtk::{write_vtp, Field, Snapshot};
use sparse_mpm::error::Result;
use sparse_mpm::particles::Particles;
use sparse_mpm::simulation::Simulation;

/// The particles' positions at the start of a run, by particle id: the reference of the
/// snapshots' `displacement` array (`u_p = x_p − X_p`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ReferencePositions {
    /// `(id, X, Y)`, sorted by id.
    by_id: Vec<(usize, f64, f64)>,
}

impl ReferencePositions {
    /// The positions of `particles` now.
    pub fn of(particles: &Particles) -> Self {
        Self::from_triples(
            particles
                .id
                .iter()
                .zip(&particles.x)
                .zip(&particles.y)
                .map(|((&i, &x), &y)| (i, x, y)),
        )
    }

    /// The positions in a snapshot that has an `id` array (every snapshot a run writes);
    /// `None` without one, or with an id that is negative, fractional or not finite.
    pub fn from_snapshot(snapshot: &Snapshot) -> Option<Self> {
        let ids = snapshot.array("id").filter(|a| a.components == 1)?;
        let valid = |v: f64| v >= 0.0 && v.fract() == 0.0 && v < 2f64.powi(53);
        if !ids.values.iter().all(|&v| valid(v)) {
            return None;
        }
        Some(Self::from_triples(
            ids.values
                .iter()
                .zip(&snapshot.x)
                .zip(&snapshot.y)
                .map(|((&i, &x), &y)| (i as usize, x, y)),
        ))
    }

    fn from_triples(triples: impl Iterator<Item = (usize, f64, f64)>) -> Self {
        let mut by_id: Vec<_> = triples.collect();
        by_id.sort_by_key(|t| t.0);
        ReferencePositions { by_id }
    }

    /// The reference position of the particle with id `id`.
    pub fn get(&self, id: usize) -> Option<[f64; 2]> {
        let hit = match self.by_id.get(id) {
            Some(&(i, x, y)) if i == id => return Some([x, y]),
            _ => self.by_id.binary_search_by_key(&id, |t| t.0).ok()?,
        };
        let (_, x, y) = self.by_id[hit];
        Some([x, y])
    }
}

/// Writes the particles of `sim` to `path` as a `.vtp` snapshot with the arrays `id` and
/// `body` (integers), `mass`, `volume`, `radius` (`√V/2`, half the side of the particle's
/// square, for glyphs), `velocity`, `stress` (symmetric tensor), `pressure`
/// (`p = −(σxx + σyy)/2`, with `+0` for a zero), `strain` (the Green–Lagrange strain
/// `E = ½(FᵀF − I)`), `deformation_gradient` and `J` (`det F`); with an elastoplastic body,
/// `plastic_strain` (the equivalent plastic strain) and `elastic_strain` (the in-plane elastic
/// log strain, [`sparse_mpm::material::hencky`]). Vectors and tensors name their
/// components (`x`, `y`, `z`; `xx`, `xy`, …). [`write_snapshot_with_reference`] adds the
/// displacement.
///
/// # Errors
/// [`MpmError::Io`](sparse_mpm::MpmError::Io) naming the file.
pub fn write_snapshot(sim: &Simulation, path: &Path) -> Result<()> {
    write_snapshot_fields(sim, None, path)
}

/// [`write_snapshot`] with a `displacement` array, `u_p = x_p − X_p` with `X_p` the particle's
/// position in `reference` (NaN for a particle it does not hold). `mpm run` writes every
/// snapshot so, with the positions at the start of the run.
///
/// # Errors
/// [`MpmError::Io`](sparse_mpm::MpmError::Io) naming the file.
pub fn write_snapshot_with_reference(sim: &Simulation, reference: &ReferencePositions, path: &Path) -> Result<()> {
    write_snapshot_fields(sim, Some(reference), path)
}

fn write_snapshot_fields(sim: &Simulation, reference: Option<&ReferencePositions>, path: &Path) -> Result<()> {
    let p = sim.particles();
    let n = p.len();
    // `+ 0.0` turns the `−0` of a zero stress into `+0`.
    let pressure: Vec<f64> = (0..n).map(|k| -0.5 * (p.sxx[k] + p.syy[k]) + 0.0).collect();
    let j: Vec<f64> = (0..n).map(|k| p.fxx[k] * p.fyy[k] - p.fxy[k] * p.fyx[k]).collect();
    let radius: Vec<f64> = p.volume.iter().map(|v| 0.5 * v.sqrt()).collect();
    // E = ½(FᵀF − I): (FᵀF)_xx = Fxx² + Fyx², (FᵀF)_yy = Fxy² + Fyy², (FᵀF)_xy = Fxx Fxy + Fyx Fyy.
    let exx: Vec<f64> = (0..n)
        .map(|k| 0.5 * (p.fxx[k] * p.fxx[k] + p.fyx[k] * p.fyx[k] - 1.0))
        .collect();
    let eyy: Vec<f64> = (0..n)
        .map(|k| 0.5 * (p.fxy[k] * p.fxy[k] + p.fyy[k] * p.fyy[k] - 1.0))
        .collect();
    let exy: Vec<f64> = (0..n)
        .map(|k| 0.5 * (p.fxx[k] * p.fxy[k] + p.fyx[k] * p.fyy[k]))
        .collect();
    let (ux, uy): (Vec<f64>, Vec<f64>) = match reference {
        Some(r) => (0..n)
            .map(|k| {
                r.get(p.id[k])
                    .map_or((f64::NAN, f64::NAN), |[x, y]| (p.x[k] - x, p.y[k] - y))
            })
            .unzip(),
        None => (Vec::new(), Vec::new()),
    };
    let mut fields = vec![
        Field::Index {
            name: "id",
            values: &p.id,
        },
        Field::Index {
            name: "body",
            values: &p.body,
        },
        Field::Scalar {
            name: "mass",
            values: &p.mass,
        },
        Field::Scalar {
            name: "volume",
            values: &p.volume,
        },
        Field::Scalar {
            name: "radius",
            values: &radius,
        },
        Field::Vector {
            name: "velocity",
            x: &p.vx,
            y: &p.vy,
        },
    ];
    if reference.is_some() {
        fields.push(Field::Vector {
            name: "displacement",
            x: &ux,
            y: &uy,
        });
    }
    fields.extend([
        Field::Tensor {
            name: "stress",
            xx: &p.sxx,
            xy: &p.sxy,
            yx: &p.sxy,
            yy: &p.syy,
        },
        Field::Scalar {
            name: "pressure",
            values: &pressure,
        },
        Field::Tensor {
            name: "strain",
            xx: &exx,
            xy: &exy,
            yx: &exy,
            yy: &eyy,
        },
        Field::Tensor {
            name: "deformation_gradient",
            xx: &p.fxx,
            xy: &p.fxy,
            yx: &p.fyx,
            yy: &p.fyy,
        },
        Field::Scalar { name: "J", values: &j },
    ]);
    // Elastoplastic bodies: the equivalent plastic strain and the elastic log strain.
    if p.has_plastic_state() {
        fields.extend([
            Field::Scalar {
                name: "plastic_strain",
                values: &p.plastic_strain,
            },
            Field::Tensor {
                name: "elastic_strain",
                xx: &p.elastic_xx,
                xy: &p.elastic_xy,
                yx: &p.elastic_xy,
                yy: &p.elastic_yy,
            },
        ]);
    }
    write_vtp(path, &p.x, &p.y, &fields)
}
