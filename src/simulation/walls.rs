//! Slip walls under the mirror rule in the time loop (`crate::boundary::mirror`).
//!
//! A slip wall reflects the velocity component normal to it oddly and the tangential one
//! evenly, `v_c = C_c v̂_c`, so the fold differs per component and cannot be put into the
//! operators, which both components share (the fixed walls' fold is). The operators stay as
//! assembled on the slip walls' axes and the grid fields are folded instead, as the particles
//! and their mirror images beyond the wall would give them:
//!
//! ```text
//! after p2g          m_L ← |C|ᵀ m_L,   q_c ← C_cᵀ q_c,   f_c ← C_cᵀ f_c      (ghosts: 0, inactive)
//! after the solves   v_c ← C_c v̂_c on every field the particles read           (ghosts: s v_mirror)
//! consistent mass    M_c = N̂_c diag(m) N̂_cᵀ,  N̂_c = C_cᵀ N                      (one grid mass per component)
//! ```
//!
//! The Newton stage of the implicit integrators folds through its reduction `T` instead
//! (`crate::implicit::newton`), whose rows of ghost degrees of freedom are their mirrors'.

use crate::boundary::MirrorWalls;
use crate::fields::VectorField;
use crate::grid::Grid;
use crate::operators::Operators;
use crate::particles::Particles;
use crate::shape::ShapeFunction;

/// `v_c ← C_cᵀ v_c` for both components of `v` (idempotent).
pub(super) fn fold(walls: &MirrorWalls, grid: &Grid, v: &mut VectorField) {
    if walls.is_empty() {
        return;
    }
    walls.component(0).fold_field(grid, false, &mut v.x);
    walls.component(1).fold_field(grid, false, &mut v.y);
}

/// `v_c ← C_c v_c` for both components of each field (idempotent).
pub(super) fn unfold(walls: &MirrorWalls, grid: &Grid, fields: &mut [&mut VectorField]) {
    if walls.is_empty() {
        return;
    }
    let [x, y] = [walls.component(0), walls.component(1)];
    for v in fields {
        x.unfold_field(grid, &mut v.x);
        y.unfold_field(grid, &mut v.y);
    }
}

/// The lumped mass `|C|ᵀ m_L`.
pub(super) fn fold_lumped(walls: &MirrorWalls, grid: &Grid, lumped: &mut [f64]) {
    walls.fold_field(grid, true, lumped);
}

/// `N̂_c = C_cᵀ N` for c = x, y into `out`, from the operators `ops` of the particles `p`
/// (the consistent mass of each component is assembled from them).
pub(super) fn component_operators(
    walls: &MirrorWalls,
    grid: &Grid,
    shape: ShapeFunction,
    p: &Particles,
    ops: &Operators,
    out: &mut [Operators; 2],
) {
    for (c, folded) in out.iter_mut().enumerate() {
        folded.clone_from(ops);
        walls.component(c).fold(grid, shape, &p.x, &p.y, folded);
    }
}

/// The fold of `walls` as a hook for the products that take one (`(v, true)`: `v ← Cᵀ v`,
/// `(v, false)`: `v ← C v`), `None` without slip walls under the mirror rule.
pub(super) fn hook<'a>(walls: &'a MirrorWalls, ops: &'a Operators) -> Option<impl Fn(&mut VectorField, bool) + 'a> {
    let grid = ops.grid().filter(|_| !walls.is_empty())?;
    Some(move |v: &mut VectorField, to_interior: bool| {
        if to_interior {
            fold(walls, grid, v);
        } else {
            unfold(walls, grid, &mut [v]);
        }
    })
}
