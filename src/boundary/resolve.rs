//! [`resolve`]: the node sets and prescribed values of a list of conditions on a grid.

use super::{BoundaryCondition, Condition, Edge, FrictionWall, MirrorWalls, Prescribed, WallRule};
use crate::error::{MpmError, Result};
use crate::grid::Grid;
use crate::numbers::exact;
use crate::shape::ShapeFunction;

/// The node visits all boundary conditions together may make, per grid node: [`resolve`]'s
/// work is at most this many times the grid's nodes, however many conditions a scene lists
/// (each condition costs the nodes it reaches; 20,000 conditions over a whole grid of 10⁶
/// nodes took over a minute to resolve).
pub const MAX_NODE_VISITS_PER_NODE: usize = 16;

/// Resolves `conditions` on `grid` for kernels `shape`.
///
/// # Errors
/// [`MpmError::InvalidScene`] naming the condition (`boundaries[k]`, or the key within it) when
/// [`BoundaryCondition::validate`] refuses it (before anything is allocated for the grid), or
/// when a rectangle contains no grid node, or when the conditions together reach more than
/// [`MAX_NODE_VISITS_PER_NODE`] times the grid's nodes.
pub fn resolve(grid: &Grid, shape: ShapeFunction, conditions: &[BoundaryCondition]) -> Result<Prescribed> {
    for (k, bc) in conditions.iter().enumerate() {
        bc.validate(k, grid, shape)?;
    }
    let n = grid.num_nodes();
    // The values per node while the conditions are read (a later condition overrides an earlier
    // one on a node they share); kept as lists.
    let (mut vx_of, mut vy_of) = (vec![f64::NAN; n], vec![f64::NAN; n]);
    let mut out = Prescribed::default();
    let [nx, ny] = grid.nodes_per_axis();
    let mut nodes = Vec::new();
    // The nodes the conditions may visit in all, so that the work is bounded by the grid's
    // size however many conditions there are.
    let mut budget = MAX_NODE_VISITS_PER_NODE.saturating_mul(n);
    let spend = |k: usize, visits: usize, budget: &mut usize| {
        *budget = budget.checked_sub(visits).ok_or_else(|| MpmError::InvalidScene {
            key: format!("boundaries[{k}]"),
            reason: format!(
                "the boundary conditions up to this one reach more than {MAX_NODE_VISITS_PER_NODE} times the \
                 grid's {n} nodes in all: merge the conditions that overlap"
            ),
        })?;
        Ok::<(), MpmError>(())
    };
    for (k, bc) in conditions.iter().enumerate() {
        let (vx, vy) = match bc.condition {
            Condition::Fixed => (Some(0.0), Some(0.0)),
            Condition::Slip => match bc.edge {
                Some(Edge::Left | Edge::Right) => (Some(0.0), None),
                _ => (None, Some(0.0)),
            },
            Condition::Velocity => (bc.vx, bc.vy),
        };
        nodes.clear();
        if let (Some(edge), Some(friction)) = (bc.edge, bc.friction) {
            // A frictional wall prescribes nothing: contact meets the bodies there.
            let layers = bc.layers_for(shape);
            if bc.range.is_none() {
                out.mirror.set(k, edge, layers, [nx, ny], WallRule::Held);
                out.slip.set(k, edge, layers, [nx, ny], WallRule::Held);
            }
            let line = (layers - 1) as f64;
            let ([ox, oy], [hx, hy]) = (grid.origin(), grid.cell_size());
            let (axis, at, outward) = match edge {
                Edge::Left => (0, ox + line * hx, -1.0),
                Edge::Right => (0, ox + ((nx - 1) as f64 - line) * hx, 1.0),
                Edge::Bottom => (1, oy + line * hy, -1.0),
                Edge::Top => (1, oy + ((ny - 1) as f64 - line) * hy, 1.0),
            };
            out.friction.push(FrictionWall {
                condition: k,
                axis,
                at,
                outward,
                friction,
                range: bc.range,
            });
            continue;
        }
        if let Some(edge) = bc.edge {
            let layers = bc.layers_for(shape);
            // The later condition on an edge decides: the other kind's wall there is cleared.
            let rule = |kind| {
                if bc.condition == kind {
                    bc.wall_rule(shape)
                } else {
                    WallRule::Held
                }
            };
            if bc.range.is_none() {
                out.mirror.set(k, edge, layers, [nx, ny], rule(Condition::Fixed));
                out.slip.set(k, edge, layers, [nx, ny], rule(Condition::Slip));
            }
            // The edge's band of `layers` node lines only (its own nodes, not the grid's), and
            // of those the nodes in the range along the edge.
            let along = |count: usize, axis: usize| match bc.range {
                Some([from, to]) => node_lines_within(grid, axis, from, to, count),
                None => 0..count,
            };
            let (is, js) = match edge {
                Edge::Left => (0..layers.min(nx), along(ny, 1)),
                Edge::Right => (nx.saturating_sub(layers)..nx, along(ny, 1)),
                Edge::Bottom => (along(nx, 0), 0..layers.min(ny)),
                Edge::Top => (along(nx, 0), ny.saturating_sub(layers)..ny),
            };
            if is.is_empty() || js.is_empty() {
                let [from, to] = bc.range.unwrap_or([f64::NAN; 2]);
                return Err(MpmError::InvalidScene {
                    key: format!("boundaries[{k}].range"),
                    reason: format!("[{}, {}] holds no node line of the edge", exact(from), exact(to)),
                });
            }
            spend(k, is.len() * js.len(), &mut budget)?;
            for j in js {
                nodes.extend(is.clone().map(|i| grid.node_index(i, j)));
            }
        } else if let Some([[x0, y0], [x1, y1]]) = bc.rectangle {
            let tol = 1e-9 * grid.cell_size()[0].min(grid.cell_size()[1]);
            // The node lines the rectangle can reach, one line wider on each side than the
            // division says (rounding), then the test on each node's position.
            let [ox, oy] = grid.origin();
            let [hx, hy] = grid.cell_size();
            let span = |low: f64, high: f64, origin: f64, h: f64, count: usize| {
                let first = ((low - tol - origin) / h).floor() - 1.0;
                let last = ((high + tol - origin) / h).ceil() + 1.0;
                let clip = |v: f64| v.clamp(0.0, count as f64) as usize;
                clip(first)..clip(last + 1.0)
            };
            let (is, js) = (span(x0, x1, ox, hx, nx), span(y0, y1, oy, hy, ny));
            spend(k, is.len() * js.len(), &mut budget)?;
            for j in js {
                nodes.extend(is.clone().map(|i| grid.node_index(i, j)).filter(|&id| {
                    let [x, y] = grid.node_position(id);
                    x >= x0 - tol && x <= x1 + tol && y >= y0 - tol && y <= y1 + tol
                }));
            }
            if nodes.is_empty() {
                return Err(MpmError::InvalidScene {
                    key: format!("boundaries[{k}].rectangle"),
                    reason: format!(
                        "[[{}, {}], [{}, {}]] contains no grid node",
                        exact(x0),
                        exact(y0),
                        exact(x1),
                        exact(y1)
                    ),
                });
            }
        } else if let Some(ids) = &bc.nodes {
            spend(k, ids.len(), &mut budget)?;
            nodes.extend_from_slice(ids);
        }
        for &i in &nodes {
            if let Some(v) = vx {
                vx_of[i] = v;
            }
            if let Some(v) = vy {
                vy_of[i] = v;
            }
        }
    }
    MirrorWalls::validate_together([&out.mirror, &out.slip], shape)?;
    // A wall on part of an edge is held: a mirrored wall on the same edge would fold the held
    // nodes' ghost lines away.
    for (k, bc) in conditions.iter().enumerate() {
        let (Some(edge), Some(_)) = (bc.edge, bc.range) else {
            continue;
        };
        if let Some(j) = [&out.mirror, &out.slip].iter().find_map(|w| w.wall_on(edge)) {
            return Err(MpmError::InvalidScene {
                key: format!("boundaries[{k}].range"),
                reason: format!(
                    "boundaries[{j}] mirrors the whole {} edge, and a wall on part of an edge is held: give \
                     boundaries[{j}] wall = \"held\" (or a `range` too)",
                    edge.name()
                ),
            });
        }
    }
    out.constraints.fixed_x = (0..n).filter(|&i| !vx_of[i].is_nan()).collect();
    out.constraints.fixed_y = (0..n).filter(|&i| !vy_of[i].is_nan()).collect();
    out.values = [
        out.constraints.fixed_x.iter().map(|&i| vx_of[i]).collect(),
        out.constraints.fixed_y.iter().map(|&i| vy_of[i]).collect(),
    ];
    Ok(out)
}

/// The node lines of `axis` (`count` of them) whose coordinate lies in `[from, to]` (to a
/// relative 10⁻⁹ of the cell size).
fn node_lines_within(grid: &Grid, axis: usize, from: f64, to: f64, count: usize) -> std::ops::Range<usize> {
    let (o, h) = (grid.origin()[axis], grid.cell_size()[axis]);
    let tol = 1e-9;
    // The first and one past the last line, clamped to the grid's lines before any cast (a
    // range far beyond the grid holds every line or none, never an overflow).
    let first = ((from - o) / h - tol).ceil().clamp(0.0, count as f64);
    let end = (((to - o) / h + tol).floor() + 1.0).clamp(0.0, count as f64);
    if first.is_nan() || end.is_nan() || end <= first {
        return 0..0;
    }
    first as usize..end as usize
}
