//! (6)–(8) with the lumped mass in both solves, in one pass over the grid nodes.

use super::{GridState, Packed};
use crate::boundary::Prescribed;
use crate::parallel::Workers;

/// (6)–(8) with the lumped mass in both solves, from what [`super::p2g`] accumulated (`m_L`,
/// `q`, `f` without gravity), in one pass over the nodes of the operators' span:
///
/// ```text
/// (6) v = q · (1/m_L),   (7) a = (f + m_L g) · (1/m_L),   (8) w = s (v + Δt a)
/// ```
///
/// with `1/m_L` the grid mass's inverse (0 on inactive nodes) and `s` 1 on active nodes, 0
/// elsewhere; then on every prescribed component `v = w = v_D` (`a = 0`). The same operations,
/// in the same order, as the lumped solves of [`crate::mass::GridMass`], the constraints and
/// the update of the general step. Writes `w` into `grid.updated` (0 outside the span but for
/// the prescribed components), and `[w, v]` node by node over the span into the accumulator in
/// place of `[m_L, q]` (what the grid-to-particle pass reads, [`GridState::lumped_velocities`]).
///
/// # Panics
/// If the inverse, the active set or the grid state do not have one entry per node.
pub(crate) fn update_lumped_grid(
    grid: &mut GridState,
    inverse: &[f64],
    is_active: &[bool],
    gravity: [f64; 2],
    dt: f64,
    prescribed: &Prescribed,
    workers: &Workers,
) {
    let (span, columns) = (grid.span.clone(), grid.columns.clone());
    let previous = std::mem::replace(&mut grid.lumped_span, span.clone());
    let previous_columns = std::mem::replace(&mut grid.lumped_columns, columns.clone());
    let n = grid.updated.len();
    assert!(
        inverse.len() == n && is_active.len() == n,
        "one mass and one flag per node"
    );
    let line_len = grid.line_len;
    // What the last pass left outside the new box (the nodes p2g wrote).
    crate::grid::outside_box((&previous, &previous_columns), (&span, &columns), line_len, |range| {
        grid.updated.x[range.clone()].fill(0.0);
        grid.updated.y[range].fill(0.0);
    });
    let [gx, gy] = gravity;
    let base = grid.base;
    let out = (
        [&mut grid.updated.x[span.clone()], &mut grid.updated.y[span.clone()]],
        &mut grid.accumulator[span.start - base..span.end - base],
    );
    // Blocks of nodes in parallel: every node on its own, `[w, v]` over its accumulator. The
    // nodes outside p2g's columns hold no mass (`w = 0`, as written before): skipped.
    let mut none: Vec<()> = Vec::new();
    workers.split_blocks(out, &mut none, |first, ([wx, wy], acc)| {
        let start = span.start + first;
        crate::grid::column_runs(start, wx.len(), line_len, &columns, |run, _, _| {
            let nodes = run.start + start..run.end + start;
            let grid = (inverse[nodes.clone()].iter()).zip(&is_active[nodes]);
            let w = wx[run.clone()].iter_mut().zip(&mut wy[run.clone()]);
            for ((node, (&inv, &active)), (wx, wy)) in acc[run].iter_mut().zip(grid).zip(w) {
                let [m, qx, qy, fx, fy] = *node;
                let (vx, vy) = (qx * inv, qy * inv);
                let (ax, ay) = ((fx + m * gx) * inv, (fy + m * gy) * inv);
                let s = if active { 1.0 } else { 0.0 };
                let (w_x, w_y) = (s * (vx + dt * ax), s * (vy + dt * ay));
                (*wx, *wy) = (w_x, w_y);
                *node = [w_x, w_y, vx, vy, m];
            }
        });
    });
    for (component, i, value) in prescribed.each() {
        let w = if component == 0 {
            &mut grid.updated.x
        } else {
            &mut grid.updated.y
        };
        w[i] = value;
        if span.contains(&i) {
            let node = &mut grid.accumulator[i - base];
            node[component] = value;
            node[2 + component] = value;
        }
    }
}

impl GridState {
    /// The `[w, v]` of every node of the span that [`update_lumped_grid`] left in the
    /// accumulator, for the grid-to-particle pass (stride 5: `[w_x, w_y, v_x, v_y, m_L]`).
    pub(crate) fn lumped_velocities(&self) -> Packed<'_> {
        let start = self.span.start - self.base;
        Packed {
            values: self.accumulator[start..start + self.span.len()].as_flattened(),
            stride: 5,
            layer: 0,
        }
    }

    /// Copies `updated` (`w`) over the span into what [`GridState::lumped_velocities`] reads
    /// (after the massless-node extension changed it).
    pub(crate) fn refresh_lumped_w(&mut self) {
        for i in self.span.clone() {
            let node = &mut self.accumulator[i - self.base];
            node[0] = self.updated.x[i];
            node[1] = self.updated.y[i];
        }
    }
}
