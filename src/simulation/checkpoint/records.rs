//! The records a checkpoint writes: every field of the option, body, particle and estimate
//! types, in order, in a form postcard can read back without field names.

use std::borrow::Cow;

use serde::{Deserialize, Serialize};

use crate::boundary::{BoundaryCondition, Condition, Edge, WallRule};
use crate::grid::{Grid, NodeOrder};
use crate::mass::MassOptions;
use crate::material::{DruckerPrager, LinearElastic, Material, NeoHookean, VonMises};
use crate::particles::{Particles, REAL_FIELDS};
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
    gravity_ramp: Option<f64>,
    boundaries: Vec<BoundaryRecord>,
    sort_interval: usize,
    stability_interval: usize,
    threads: usize,
    integrator: Integrator,
    damping: Option<crate::damping::Damping>,
    contact: Option<crate::contact::Contact>,
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
    friction: Option<f64>,
    range: Option<[f64; 2]>,
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
    VonMises(VonMises),
    DruckerPrager(DruckerPrager),
}

/// The particles' fields in the order of their one list (`Particles::fields`): postcard
/// writes a fixed-size array as the fields of a struct, one after the other.
#[derive(Serialize, Deserialize)]
pub(super) struct ParticlesRecord<'a> {
    reals: [Cow<'a, [f64]>; REAL_FIELDS],
    indices: [Cow<'a, [usize]>; 2],
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
            gravity_ramp,
            boundaries,
            sort_interval,
            stability_interval,
            threads,
            // An execution choice with the same bits either way, not kept: a resumed run takes
            // the separate passes.
            fused_passes: _,
            integrator,
            damping,
            contact,
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
            gravity_ramp: *gravity_ramp,
            boundaries: boundaries.iter().map(BoundaryRecord::of).collect(),
            sort_interval: *sort_interval,
            stability_interval: *stability_interval,
            threads: *threads,
            integrator: *integrator,
            damping: *damping,
            contact: contact.clone(),
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
            gravity_ramp,
            boundaries,
            sort_interval,
            stability_interval,
            threads,
            integrator,
            damping,
            contact,
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
            gravity_ramp,
            boundaries: boundaries.into_iter().map(BoundaryRecord::into_condition).collect(),
            sort_interval,
            stability_interval,
            threads,
            fused_passes: false,
            integrator,
            damping,
            contact,
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
            friction,
            range,
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
            friction: *friction,
            range: *range,
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
            friction,
            range,
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
            friction,
            range,
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
                Material::VonMises(m) => MaterialRecord::VonMises(m),
                Material::DruckerPrager(m) => MaterialRecord::DruckerPrager(m),
            },
        }
    }

    pub(super) fn into_body(self) -> Body {
        Body {
            name: self.name,
            material: match self.material {
                MaterialRecord::LinearElastic(m) => Material::LinearElastic(m),
                MaterialRecord::NeoHookean(m) => Material::NeoHookean(m),
                MaterialRecord::VonMises(m) => Material::VonMises(m),
                MaterialRecord::DruckerPrager(m) => Material::DruckerPrager(m),
            },
        }
    }
}

impl<'a> ParticlesRecord<'a> {
    pub(super) fn of(p: &'a Particles) -> ParticlesRecord<'a> {
        ParticlesRecord {
            reals: p.fields().map(|(_, v)| Cow::Borrowed(v.as_slice())),
            indices: p.index_fields().map(|v| Cow::Borrowed(v.as_slice())),
        }
    }

    pub(super) fn into_particles(self) -> Particles {
        let mut p = Particles::default();
        for ((_, field), record) in p.fields_mut().into_iter().zip(self.reals) {
            *field = record.into_owned();
        }
        for (field, record) in p.index_fields_mut().into_iter().zip(self.indices) {
            *field = record.into_owned();
        }
        p
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
