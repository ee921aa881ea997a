//! The stabilisation part: the consistent mass under each stabilisation, against the lumped
//! mass, on a rigid rotation, a strip one cell thick, thin cantilevers and the two disks.

use std::fmt::Write as _;

use super::{Finished, StudyRun};
use sparse_mpm::mass::MassScheme;
use sparse_mpm::shape::ShapeFunction;

/// The row a run belongs to: `lumped`, or the consistent mass's stabilisation.
fn row_of(r: &StudyRun) -> String {
    let m = &r.choices.mass;
    if m.velocity == MassScheme::Lumped && m.acceleration == MassScheme::Lumped {
        "lumped".into()
    } else {
        format!("consistent, {:#}", m.stabilization)
    }
}

/// Writes the stabilisation section: one table, a row per mass, a column per case, "failed"
/// where the run did not finish (its error is listed at the end of the report).
pub(super) fn write(all: &[&StudyRun], ok: &[Finished], md: &mut String) {
    writeln!(
        md,
        "## Stabilising the consistent mass\n\nThe consistent mass in both solves (FLIP) under each \
         stabilisation, and the lumped mass for reference. A rigid rotation lies in the span of the \
         shape functions, so the consistent projection should reproduce it exactly: the spinning disk \
         (neo-Hookean, one revolution) should keep its angular momentum and the projection of a rotation \
         from the particles of a strip one cell thick should be exact to round-off. The cantilever one \
         and two cells thick (quadratic B-splines) should swing as far as with the lumped mass (a mass \
         matrix cannot change a static deflection); the two disks should keep their energy.\n\n\
         | mass | rotation \\|ΔL\\|/L, linear | quadratic | peak strain / KE₀, linear | quadratic | \
         strip projection error, linear | quadratic | cantilever tip, 1 cell thick | 2 cells thick | \
         two disks, energy drift |\n|---|---|---|---|---|---|---|---|---|---|"
    )
    .ok();
    let mut rows: Vec<String> = Vec::new();
    for r in all {
        let key = row_of(r);
        if !rows.contains(&key) {
            rows.push(key);
        }
    }
    let linear = |s: ShapeFunction| s == ShapeFunction::Linear;
    for key in rows {
        let find = |problem: &str, want: &dyn Fn(&StudyRun) -> bool, metric: &str, digits: usize| {
            ok.iter()
                .find(|(r, o)| row_of(r) == key && o.problem == problem && want(r))
                .and_then(|(_, o)| o.metric(metric))
                .map_or("failed".into(), |v| {
                    if digits == 0 {
                        format!("{v:.2e}")
                    } else {
                        format!("{v:.digits$}")
                    }
                })
        };
        let lin: &dyn Fn(&StudyRun) -> bool = &|r| linear(r.choices.shape);
        let quad: &dyn Fn(&StudyRun) -> bool = &|r| !linear(r.choices.shape);
        let cells = |c: usize| move |r: &StudyRun| r.cells == c;
        writeln!(
            md,
            "| {key} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            find("spinning_disk", lin, "angular_momentum_change", 4),
            find("spinning_disk", quad, "angular_momentum_change", 4),
            find("spinning_disk", lin, "strain_energy_peak", 0),
            find("spinning_disk", quad, "strain_energy_peak", 0),
            find("strip_projection", lin, "projection_error", 0),
            find("strip_projection", quad, "projection_error", 0),
            find("cantilever", &cells(4), "tip_deflection", 3),
            find("cantilever", &cells(8), "tip_deflection", 3),
            find("two_disks", lin, "energy_drift", 4),
        )
        .ok();
    }
    md.push('\n');
}
