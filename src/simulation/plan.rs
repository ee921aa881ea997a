//! The step plan: what a step does, decided once per step from the options and the walls.

use super::series::SeriesTransfer;
use super::{Options, Setup, Transfer};
use crate::grid::Grid;
use crate::kernels::GridField;
use crate::schemes::StressFrom;
use crate::shape::ApicInertia;

/// The smallest relative lumped mass of a node the quasi-static step solves for: lighter nodes
/// (a particle's fringe, where cubic B-splines and GIMP reach with weights of 10⁻⁶ and less)
/// follow their particles by the extension, since their stiffness, without the inertia that
/// holds them in a dynamic step, leaves the Newton matrix too ill-conditioned to converge (a
/// cantilever two cells thick with cubic B-splines stalled at a relative residual of 1e-3).
pub(super) const QUASI_STATIC_ACTIVE_TOLERANCE: f64 = 1e-3;

/// What a step does, decided once per step from the options and the walls: which grid pass,
/// where the stress update goes, which series and affine terms.
#[derive(Debug, Clone, Copy)]
pub(super) struct StepPlan {
    /// (6)–(8) in one pass over the grid ([`crate::kernels::update_lumped_grid`]): the lumped mass in
    /// both solves, no stress update between them (not USF), no series velocity (not XPIC,
    /// FMPM), no mirrored walls (whose lumped mass is folded), no damping, no contact, the
    /// explicit integrator.
    pub(super) lumped_grid_pass: bool,
    /// USF: the stress update between (6) and (7), so p2g leaves out `f_int`.
    pub(super) stress_first: bool,
    /// USL, MUSL: the velocity the stress update after the particle pass reads.
    pub(super) stress_last: Option<StressFrom>,
    /// XPIC(k), FMPM(k).
    pub(super) series: Option<SeriesTransfer>,
    /// The APIC inertia of the shape functions, when the transfer is APIC.
    pub(super) apic: Option<ApicInertia>,
    /// The implicit step's motion field `u/Δt` ([`GridField::Motion`]), which moves and strains
    /// the particles in the grid-to-particle pass in place of the updated velocity.
    pub(super) motion: Option<GridField>,
    /// The particle velocity update: the options' transfer, PIC for the quasi-static step
    /// (whose grid velocities are zero: the particles are at rest).
    pub(super) transfer: Transfer,
    /// The mass options the grid mass is prepared with: the lumped mass alone for the
    /// quasi-static step (only its active set enters).
    pub(super) mass: crate::mass::MassOptions,
    /// Gravity in this step ([`Options::gravity_at`] the step's start).
    pub(super) gravity: [f64; 2],
}

impl StepPlan {
    /// The plan of the next step, from time `t`, of a simulation with `setup` and `options`.
    pub(super) fn of(setup: &Setup, options: &Options, t: f64) -> StepPlan {
        let schedule = options.update.schedule();
        let explicit = options.integrator == super::Integrator::Explicit;
        let quasi_static = matches!(options.integrator, super::Integrator::QuasiStatic(_));
        let series = SeriesTransfer::of(options.transfer).filter(|_| !quasi_static);
        StepPlan {
            lumped_grid_pass: options.mass.velocity == crate::mass::MassScheme::Lumped
                && options.mass.acceleration == crate::mass::MassScheme::Lumped
                && !schedule.stress_first
                && series.is_none()
                && setup.prescribed.mirror.is_empty()
                && setup.prescribed.slip.is_empty()
                && options.damping.is_none()
                && setup.contact.is_none()
                && explicit,
            stress_first: schedule.stress_first && explicit,
            // The implicit step strains the particles in its grid-to-particle pass.
            stress_last: if explicit {
                schedule.stress_last
            } else {
                Some(StressFrom::Updated)
            },
            series,
            apic: apic_inertia(options, &setup.grid).filter(|_| !quasi_static),
            motion: (!explicit).then_some(GridField::Motion),
            transfer: if quasi_static { Transfer::Pic } else { options.transfer },
            mass: if quasi_static {
                crate::mass::MassOptions {
                    velocity: crate::mass::MassScheme::Lumped,
                    acceleration: crate::mass::MassScheme::Lumped,
                    active_tolerance: options.mass.active_tolerance.max(QUASI_STATIC_ACTIVE_TOLERANCE),
                    ..options.mass
                }
            } else {
                options.mass
            },
            gravity: options.gravity_at(t),
        }
    }
}

/// The APIC inertia of the shape functions, when the transfer is APIC.
fn apic_inertia(options: &Options, grid: &Grid) -> Option<ApicInertia> {
    (options.transfer == Transfer::Apic).then(|| ApicInertia::of(options.shape, grid))
}
