//! The records a checkpoint writes: every field of the option, body, particle and estimate
//! types, in order, in a form postcard can read back without field names.

use std::borrow::Cow;

use serde::{Deserialize, Serialize};

use crate::boundary::{BoundaryCondition, Condition, Edge, WallRule};
use crate::grid::{Grid, NodeOrder};
use crate::mass::MassOptions;
use crate::material::{LinearElastic, Material, NeoHookean};
use crate::particles::Particles;
use crate::schemes::PositionUpdate;
use crate::shape::ShapeFunction;
use crate::simulation::stability::{Basis, Stability};
use crate::simulation::{Body, Integrator, Options, TimeStep, Transfer, UpdateScheme};
use crate::stiffness::FrequencyEstimate;

#[derive(Serialize, Deserialize)]
pub(super) struct GridRecord {
    origin: [f64; 2],
    cell_size: [f64; 2],
    cells: [usize; 2],
    /// 0: x fastest, 1: y fastest.
    node_order: u8,
}

#[derive(Serialize, Deserialize)]
pub(super) struct OptionsRecord {
    shape: ShapeFunction,
    update: UpdateScheme,
    transfer: Transfer,
    mass: MassOptions,
    position_update: PositionUpdate,
    time_step: TimeStep,
    allow_unstable_time_step: bool,
    gravity: [f64; 2],
    boundaries: Vec<BoundaryRecord>,
    sort_interval: usize,
    stability_interval: usize,
    threads: usize,
    integrator: Integrator,
}

/// A [`BoundaryCondition`] with every field written (its own serde form omits absent ones,
/// which a format without field names cannot read back).
#[derive(Serialize, Deserialize)]
pub(super) struct BoundaryRecord {
    edge: Option<Edge>,
    layers: Option<usize>,
    rectangle: Option<[[f64; 2]; 2]>,
    nodes: Option<Vec<usize>>,
    condition: Condition,
    vx: Option<f64>,
    vy: Option<f64>,
    wall: Option<WallRule>,
}

#[derive(Serialize, Deserialize)]
pub(super) struct BodyRecord {
    name: String,
    material: MaterialRecord,
}

/// A [`Material`] tagged by position (its own serde form is tagged by a field, which needs a
/// self-describing format).
#[derive(Serialize, Deserialize)]
pub(super) enum MaterialRecord {
    LinearElastic(LinearElastic),
    NeoHookean(NeoHookean),
}

#[derive(Serialize, Deserialize)]
pub(super) struct ParticlesRecord<'a> {
    x: Cow<'a, [f64]>,
    y: Cow<'a, [f64]>,
    vx: Cow<'a, [f64]>,
    vy: Cow<'a, [f64]>,
    mass: Cow<'a, [f64]>,
    volume: Cow<'a, [f64]>,
    sxx: Cow<'a, [f64]>,
    syy: Cow<'a, [f64]>,
    sxy: Cow<'a, [f64]>,
    bx: Cow<'a, [f64]>,
    by: Cow<'a, [f64]>,
    fxx: Cow<'a, [f64]>,
    fxy: Cow<'a, [f64]>,
    fyx: Cow<'a, [f64]>,
    fyy: Cow<'a, [f64]>,
    affine_xx: Cow<'a, [f64]>,
    affine_xy: Cow<'a, [f64]>,
    affine_yx: Cow<'a, [f64]>,
    affine_yy: Cow<'a, [f64]>,
    body: Cow<'a, [usize]>,
    id: Cow<'a, [usize]>,
}

#[derive(Serialize, Deserialize)]
pub(super) struct StabilityRecord {
    wave_step: f64,
    wave_speed: f64,
    pub(super) at_step: usize,
    omega_squared: f64,
    lanczos_steps: usize,
    active_fingerprint: u64,
    substitutes: [bool; 2],
    due_at: usize,
    node_top: f64,
    travel: f64,
}

impl OptionsRecord {
    pub(super) fn of(options: &Options) -> OptionsRecord {
        let Options {
            shape,
            update,
            transfer,
            mass,
            position_update,
            time_step,
            allow_unstable_time_step,
            gravity,
            boundaries,
            sort_interval,
            stability_interval,
            threads,
            integrator,
        } = options;
        OptionsRecord {
            shape: *shape,
            update: *update,
            transfer: *transfer,
            mass: *mass,
            position_update: *position_update,
            time_step: *time_step,
            allow_unstable_time_step: *allow_unstable_time_step,
            gravity: *gravity,
            boundaries: boundaries.iter().map(BoundaryRecord::of).collect(),
            sort_interval: *sort_interval,
            stability_interval: *stability_interval,
            threads: *threads,
            integrator: *integrator,
        }
    }

    pub(super) fn into_options(self) -> Options {
        let OptionsRecord {
            shape,
            update,
            transfer,
            mass,
            position_update,
            time_step,
            allow_unstable_time_step,
            gravity,
            boundaries,
            sort_interval,
            stability_interval,
            threads,
            integrator,
        } = self;
        Options {
            shape,
            update,
            transfer,
            mass,
            position_update,
            time_step,
            allow_unstable_time_step,
            gravity,
            boundaries: boundaries.into_iter().map(BoundaryRecord::into_condition).collect(),
            sort_interval,
            stability_interval,
            threads,
            integrator,
        }
    }
}

impl BoundaryRecord {
    pub(super) fn of(bc: &BoundaryCondition) -> BoundaryRecord {
        let BoundaryCondition {
            edge,
            layers,
            rectangle,
            nodes,
            condition,
            vx,
            vy,
            wall,
        } = bc;
        BoundaryRecord {
            edge: *edge,
            layers: *layers,
            rectangle: *rectangle,
            nodes: nodes.clone(),
            condition: *condition,
            vx: *vx,
            vy: *vy,
            wall: *wall,
        }
    }

    pub(super) fn into_condition(self) -> BoundaryCondition {
        let BoundaryRecord {
            edge,
            layers,
            rectangle,
            nodes,
            condition,
            vx,
            vy,
            wall,
        } = self;
        BoundaryCondition {
            edge,
            layers,
            rectangle,
            nodes,
            condition,
            vx,
            vy,
            wall,
        }
    }
}

impl BodyRecord {
    pub(super) fn of(body: &Body) -> BodyRecord {
        let Body { name, material } = body;
        BodyRecord {
            name: name.clone(),
            material: match *material {
                Material::LinearElastic(m) => MaterialRecord::LinearElastic(m),
                Material::NeoHookean(m) => MaterialRecord::NeoHookean(m),
            },
        }
    }

    pub(super) fn into_body(self) -> Body {
        Body {
            name: self.name,
            material: match self.material {
                MaterialRecord::LinearElastic(m) => Material::LinearElastic(m),
                MaterialRecord::NeoHookean(m) => Material::NeoHookean(m),
            },
        }
    }
}

impl<'a> ParticlesRecord<'a> {
    pub(super) fn of(p: &'a Particles) -> ParticlesRecord<'a> {
        let Particles {
            x,
            y,
            vx,
            vy,
            mass,
            volume,
            sxx,
            syy,
            sxy,
            bx,
            by,
            fxx,
            fxy,
            fyx,
            fyy,
            affine_xx,
            affine_xy,
            affine_yx,
            affine_yy,
            body,
            id,
        } = p;
        let b = |v: &'a Vec<f64>| Cow::Borrowed(v.as_slice());
        ParticlesRecord {
            x: b(x),
            y: b(y),
            vx: b(vx),
            vy: b(vy),
            mass: b(mass),
            volume: b(volume),
            sxx: b(sxx),
            syy: b(syy),
            sxy: b(sxy),
            bx: b(bx),
            by: b(by),
            fxx: b(fxx),
            fxy: b(fxy),
            fyx: b(fyx),
            fyy: b(fyy),
            affine_xx: b(affine_xx),
            affine_xy: b(affine_xy),
            affine_yx: b(affine_yx),
            affine_yy: b(affine_yy),
            body: Cow::Borrowed(body),
            id: Cow::Borrowed(id),
        }
    }

    pub(super) fn into_particles(self) -> Particles {
        let ParticlesRecord {
            x,
            y,
            vx,
            vy,
            mass,
            volume,
            sxx,
            syy,
            sxy,
            bx,
            by,
            fxx,
            fxy,
            fyx,
            fyy,
            affine_xx,
            affine_xy,
            affine_yx,
            affine_yy,
            body,
            id,
        } = self;
        Particles {
            x: x.into_owned(),
            y: y.into_owned(),
            vx: vx.into_owned(),
            vy: vy.into_owned(),
            mass: mass.into_owned(),
            volume: volume.into_owned(),
            sxx: sxx.into_owned(),
            syy: syy.into_owned(),
            sxy: sxy.into_owned(),
            bx: bx.into_owned(),
            by: by.into_owned(),
            fxx: fxx.into_owned(),
            fxy: fxy.into_owned(),
            fyx: fyx.into_owned(),
            fyy: fyy.into_owned(),
            affine_xx: affine_xx.into_owned(),
            affine_xy: affine_xy.into_owned(),
            affine_yx: affine_yx.into_owned(),
            affine_yy: affine_yy.into_owned(),
            body: body.into_owned(),
            id: id.into_owned(),
        }
    }
}

impl GridRecord {
    pub(super) fn of(grid: &Grid) -> GridRecord {
        GridRecord {
            origin: grid.origin(),
            cell_size: grid.cell_size(),
            cells: grid.cells(),
            node_order: match grid.node_order() {
                NodeOrder::XFastest => 0,
                NodeOrder::YFastest => 1,
            },
        }
    }

    /// The grid, or what is wrong with the record.
    pub(super) fn into_grid(self) -> std::result::Result<Grid, String> {
        let order = match self.node_order {
            0 => NodeOrder::XFastest,
            1 => NodeOrder::YFastest,
            other => {
                return Err(format!(
                    "grid: node order {other} is not 0 (x fastest) or 1 (y fastest)"
                ))
            }
        };
        let [cx, cy] = self.cells;
        if cx
            .checked_add(1)
            .zip(cy.checked_add(1))
            .and_then(|(a, b)| a.checked_mul(b))
            .is_none()
        {
            return Err(format!("grid: {cx} x {cy} cells are too many"));
        }
        Ok(Grid::new(self.origin, self.cell_size, self.cells)
            .map_err(|e| format!("grid: {e}"))?
            .with_node_order(order))
    }
}

impl StabilityRecord {
    pub(super) fn of(s: &Stability) -> StabilityRecord {
        StabilityRecord {
            wave_step: s.wave_step,
            wave_speed: s.wave_speed,
            at_step: s.at_step,
            omega_squared: s.estimate.omega_squared,
            lanczos_steps: s.estimate.lanczos_steps,
            active_fingerprint: s.basis.active,
            substitutes: s.basis.substitutes,
            due_at: s.due_at,
            node_top: s.node_top,
            travel: s.travel,
        }
    }

    pub(super) fn into_stability(self) -> Stability {
        Stability {
            wave_step: self.wave_step,
            wave_speed: self.wave_speed,
            at_step: self.at_step,
            estimate: FrequencyEstimate {
                omega_squared: self.omega_squared,
                lanczos_steps: self.lanczos_steps,
            },
            basis: Basis {
                active: self.active_fingerprint,
                substitutes: self.substitutes,
            },
            due_at: self.due_at,
            node_top: self.node_top,
            travel: self.travel,
        }
    }
}
