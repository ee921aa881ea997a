//! The `stabilization` part's plan: the consistent mass under each stabilisation (and the
//! lumped mass for reference) on the cases that decide whether it can be trusted: a disk in
//! rigid rotation, the projection of a rotation from a strip one cell thick, cantilevers one
//! and two cells thick, and the two disks.

use super::{Problem, StudySpec};
use crate::verification::Choices;
use sparse_mpm::mass::{MassOptions, MassScheme, Stabilization};
use sparse_mpm::shape::ShapeFunction;
use sparse_mpm::simulation::Transfer;

/// The default stabilisations compared: partial lumping, the ghost penalty and the
/// linear-extension penalty (the default), each with its default parameters. The plain matrix
/// (`none`) is left out: at a fringe its stable step collapses (0.008 h/c), so its runs take
/// hundreds of thousands of steps before they fail.
pub(super) fn default_stabilizations() -> Vec<Stabilization> {
    ["partial_lumping", "ghost_penalty", "linear_extension"]
        .iter()
        .map(|s| s.parse().expect("the names parse"))
        .collect()
}

impl StudySpec {
    /// The runs of the stabilisation part: for the lumped mass and for the consistent mass in
    /// both solves under each of the spec's stabilisations (FLIP), the spinning disk and the
    /// strip projection with bilinear functions and quadratic B-splines, the cantilever one
    /// and two cells thick (quadratic B-splines, 4 and 8 cells along) and the two disks.
    pub(super) fn plan_stabilization(&self) -> Vec<(Problem, Choices, usize)> {
        let mut masses = vec![MassOptions::both(MassScheme::Lumped)];
        masses.extend(self.stabilizations.iter().map(|&stabilization| MassOptions {
            stabilization,
            ..MassOptions::both(MassScheme::Consistent)
        }));
        let (linear, quadratic) = (ShapeFunction::Linear, ShapeFunction::QuadraticBSpline);
        let mut runs = Vec::new();
        for mass in masses {
            let with = |shape| Choices {
                shape,
                transfer: Transfer::Flip,
                ..self.choices(mass)
            };
            for shape in [linear, quadratic] {
                runs.push((Problem::SpinningDisk, with(shape), self.rotation_cells));
                runs.push((Problem::StripProjection, with(shape), 1));
            }
            for cells in [4, 8] {
                runs.push((Problem::Cantilever, with(quadratic), cells));
            }
            runs.push((Problem::TwoDisks, with(linear), self.disks_cells));
        }
        runs
    }
}
