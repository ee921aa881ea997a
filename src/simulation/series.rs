//! XPIC(k) and FMPM(k) (Hammerquist & Nairn; Nairn & Hammerquist) behind one interface: the
//! transfers that pass a lumped grid velocity through `k` terms of the full-mass series
//!
//! ```text
//! XPIC(k):  v* = Σ_{ℓ<k} (I − M_L⁻¹M)^ℓ v + (w − v)      (v: this step's projected velocity)
//! FMPM(k):  v* = Σ_{ℓ<k} (I − M_L⁻¹M)^ℓ w                 (w: the updated velocity)
//! ```
//!
//! by particle–grid products ([`crate::mass::series_velocity_into`]). The new particle
//! velocities interpolate `v*` (with each transfer's position rule, in the grid-to-particle
//! pass); FMPM's stress update and stable step read its series too.

use crate::boundary::Prescribed;
use crate::fields::VectorField;
use crate::kernels::GridField;
use crate::mass::{series_velocity_into, GridMass, SeriesOperator, SeriesScratch};
use crate::operators::Operators;
use crate::schemes::Transfer;

/// A transfer with a full-mass series.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum SeriesTransfer {
    /// XPIC(k).
    Xpic { k: usize },
    /// FMPM(k).
    Fmpm { k: usize },
}

impl SeriesTransfer {
    /// The series of `transfer`, if it has one.
    pub(super) fn of(transfer: Transfer) -> Option<SeriesTransfer> {
        match transfer {
            Transfer::Xpic { k } => Some(SeriesTransfer::Xpic { k }),
            Transfer::Fmpm { k } => Some(SeriesTransfer::Fmpm { k }),
            Transfer::Pic | Transfer::Flip | Transfer::Blend { .. } | Transfer::Apic => None,
        }
    }

    /// The terms of the series the stress update (and so the stable step) passes its grid
    /// velocity through: FMPM's `k`; none for XPIC, whose stress update reads the velocity
    /// itself.
    pub(super) fn stress_terms(self) -> Option<usize> {
        match self {
            SeriesTransfer::Fmpm { k } => Some(k),
            SeriesTransfer::Xpic { .. } => None,
        }
    }

    /// The field the stress update reads when the update scheme gives it `field`: the series
    /// field under FMPM, `field` itself under XPIC.
    pub(super) fn stress_field(this: Option<SeriesTransfer>, field: GridField) -> GridField {
        match this.and_then(SeriesTransfer::stress_terms) {
            Some(_) => GridField::Series,
            None => field,
        }
    }

    /// `v*` of the module docs into `series`, from the projected `v` and updated `w`.
    pub(super) fn particle_velocity(
        self,
        op: SeriesOperator<'_>,
        v: &VectorField,
        w: &VectorField,
        series: &mut VectorField,
        scratch: &mut SeriesScratch,
    ) {
        match self {
            SeriesTransfer::Fmpm { k } => series_velocity_into(op, k, w, series, scratch),
            SeriesTransfer::Xpic { k } => {
                series_velocity_into(op, k, v, series, scratch);
                for i in 0..w.len() {
                    series.x[i] += w.x[i] - v.x[i];
                    series.y[i] += w.y[i] - v.y[i];
                }
            }
        }
    }
}

/// The time loop's [`SeriesOperator`] (the particles' masses `m`, the grid mass's `1/m_L`, the
/// prescribed components held) handed to `f`.
pub(super) fn with_series_operator<T>(
    ops: &Operators,
    m: &[f64],
    mass: &GridMass,
    prescribed: &Prescribed,
    f: impl FnOnce(SeriesOperator<'_>) -> T,
) -> T {
    let constrain = |u: &mut VectorField| prescribed.zero(&mut u.x, &mut u.y);
    let walls = super::walls::hook(&prescribed.slip, ops);
    f(SeriesOperator {
        ops,
        m,
        inv_m: mass.inverse_lumped(),
        constrain: &constrain,
        walls: walls.as_ref().map(|w| w as &dyn Fn(&mut VectorField, bool)),
    })
}
