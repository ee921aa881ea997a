//! The uniform 2D background grid and its node numbering.
//!
//! A grid has an origin `(x₀, y₀)`, a cell size `(hx, hy)` and `cx × cy` cells, so
//! `(cx + 1) × (cy + 1)` nodes. Node `(i, j)` (column `i` along x, row `j` along y) sits at
//! `(x₀ + i hx, y₀ + j hy)`.
//!
//! # Node numbering
//! Nodes are numbered 0-based in one of two orders ([`NodeOrder`]):
//! - [`NodeOrder::XFastest`] (the default): `id = i + j (cx + 1)`: along the bottom row first,
//!   then the next row up. This is the order VTK uses for structured grids.
//! - [`NodeOrder::YFastest`]: `id = j + i (cy + 1)`: up the first column first. This is the
//!   order of the seed assignment's `x_g = [0,0,1,1,2,2]`, `y_g = [0,1,0,1,0,1]`.
//!
//! In both orders the nodes of a cell, and of any tensor-product stencil, come out in ascending
//! order when the axis with the larger stride is the outer loop, which is what lets the
//! operators be assembled with sorted columns for free.
//!
//! # Cells and points on grid lines
//! Cell `(ci, cj)` is the half-open box `[x₀ + ci hx, x₀ + (ci+1) hx) × [y₀ + cj hy, y₀ + (cj+1) hy)`;
//! the last cell along each axis is closed on its upper side, so every point of the closed
//! rectangle `[x₀, x₀ + cx hx] × [y₀, y₀ + cy hy]` belongs to exactly one cell.

use crate::error::{MpmError, Result};

/// Two user-supplied coordinates closer than this fraction of the grid's extent are the same
/// grid line (coordinates typed with 9+ significant digits still match).
const COORDINATE_TOLERANCE: f64 = 1e-9;
/// Grid lines may deviate from even spacing by this fraction of the spacing (values typed
/// with 6 significant digits, such as `0.333333`, still form a uniform grid).
const SPACING_TOLERANCE: f64 = 1e-6;

/// How node `(i, j)` maps to a node number. See the [module docs](self).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum NodeOrder {
    /// `id = i + j (cx + 1)`.
    #[default]
    XFastest,
    /// `id = j + i (cy + 1)`.
    YFastest,
}

/// A uniform rectangular background grid. See the [module docs](self) for the numbering.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    origin: [f64; 2],
    cell_size: [f64; 2],
    cells: [usize; 2],
    order: NodeOrder,
}

impl Grid {
    /// A grid with `cells[0] × cells[1]` cells of size `cell_size[0] × cell_size[1]`, lower-left
    /// corner at `origin`, nodes numbered x-fastest.
    ///
    /// # Errors
    /// [`MpmError::InvalidGrid`] when the origin is not finite, a cell size is not a positive
    /// finite number, or there are no cells along an axis.
    pub fn new(origin: [f64; 2], cell_size: [f64; 2], cells: [usize; 2]) -> Result<Grid> {
        for (axis, name) in ["x", "y"].iter().enumerate() {
            if !origin[axis].is_finite() {
                return Err(MpmError::InvalidGrid {
                    reason: format!("origin {name} = {} is not finite", origin[axis]),
                });
            }
            if !(cell_size[axis].is_finite() && cell_size[axis] > 0.0) {
                return Err(MpmError::InvalidGrid {
                    reason: format!(
                        "cell size along {name} = {} must be a positive finite number",
                        cell_size[axis]
                    ),
                });
            }
            if cells[axis] == 0 {
                return Err(MpmError::InvalidGrid {
                    reason: format!("the grid needs at least one cell along {name}"),
                });
            }
        }
        Ok(Grid {
            origin,
            cell_size,
            cells,
            order: NodeOrder::XFastest,
        })
    }

    /// The same grid with nodes numbered in `order`.
    pub fn with_node_order(mut self, order: NodeOrder) -> Grid {
        self.order = order;
        self
    }

    /// Recovers a grid from node coordinate vectors such as the seed's
    /// `x_g = [0,0,1,1,2,2]`, `y_g = [0,1,0,1,0,1]`: node `k` is at `(x_g[k], y_g[k])`.
    ///
    /// The coordinates must form a uniform grid listed in one of the two [`NodeOrder`]s.
    ///
    /// # Errors
    /// [`MpmError::LengthMismatch`] when the vectors differ in length;
    /// [`MpmError::NotAUniformGrid`] when the points are not a uniform tensor grid, or are listed
    /// in another order (the error names the first node that is out of place).
    pub fn from_node_coordinates(x_g: &[f64], y_g: &[f64]) -> Result<Grid> {
        if x_g.len() != y_g.len() {
            return Err(MpmError::LengthMismatch {
                field: "y_g",
                expected: x_g.len(),
                found: y_g.len(),
            });
        }
        let not_uniform = |reason: String| Err(MpmError::NotAUniformGrid { reason });
        if x_g.is_empty() {
            return not_uniform("no node coordinates were given".into());
        }
        if let Some(k) = (0..x_g.len()).find(|&k| !(x_g[k].is_finite() && y_g[k].is_finite())) {
            return not_uniform(format!("node {k} has a non-finite coordinate ({}, {})", x_g[k], y_g[k]));
        }
        let xs = distinct_sorted(x_g);
        let ys = distinct_sorted(y_g);
        let same = |a: f64, b: f64, v: &[f64]| (a - b).abs() <= COORDINATE_TOLERANCE * span(v);
        // A point listed twice: name the later node.
        let mut order: Vec<usize> = (0..x_g.len()).collect();
        order.sort_by(|&a, &b| {
            x_g[a]
                .total_cmp(&x_g[b])
                .then(y_g[a].total_cmp(&y_g[b]))
                .then(a.cmp(&b))
        });
        for w in order.windows(2) {
            let (a, b) = (w[0].min(w[1]), w[0].max(w[1]));
            if same(x_g[a], x_g[b], &xs) && same(y_g[a], y_g[b], &ys) {
                return not_uniform(format!("node {b} at ({}, {}) repeats node {a}", x_g[b], y_g[b]));
            }
        }
        if xs.len() < 2 || ys.len() < 2 {
            return not_uniform(format!(
                "need at least two distinct x and two distinct y values, found {} and {}",
                xs.len(),
                ys.len()
            ));
        }
        if xs.len() * ys.len() != x_g.len() {
            return not_uniform(format!(
                "{} distinct x values and {} distinct y values make {} nodes, but {} were given",
                xs.len(),
                ys.len(),
                xs.len() * ys.len(),
                x_g.len()
            ));
        }
        let hx = uniform_spacing(&xs, x_g, "x")?;
        let hy = uniform_spacing(&ys, y_g, "y")?;
        let grid = Grid::new([xs[0], ys[0]], [hx, hy], [xs.len() - 1, ys.len() - 1])?;
        // The intended order is the one the first two nodes follow.
        let order = if (x_g[1] - x_g[0]).abs() <= SPACING_TOLERANCE * hx {
            NodeOrder::YFastest
        } else {
            NodeOrder::XFastest
        };
        let candidate = grid.with_node_order(order);
        match (0..x_g.len()).find(|&k| !candidate.node_matches(k, x_g[k], y_g[k])) {
            None => Ok(candidate),
            Some(k) => {
                let [ex, ey] = candidate.node_position(k);
                let name = match order {
                    NodeOrder::XFastest => "x-fastest",
                    NodeOrder::YFastest => "y-fastest",
                };
                not_uniform(format!(
                    "node {k} is at ({}, {}) but the {name} order of the first nodes puts ({ex}, {ey}) there",
                    x_g[k], y_g[k]
                ))
            }
        }
    }

    fn node_matches(&self, k: usize, x: f64, y: f64) -> bool {
        let [px, py] = self.node_position(k);
        (px - x).abs() <= SPACING_TOLERANCE * self.cell_size[0]
            && (py - y).abs() <= SPACING_TOLERANCE * self.cell_size[1]
    }

    /// Lower-left corner `(x₀, y₀)`.
    pub fn origin(&self) -> [f64; 2] {
        self.origin
    }
    /// Cell size `(hx, hy)`.
    pub fn cell_size(&self) -> [f64; 2] {
        self.cell_size
    }
    /// Number of cells `(cx, cy)`.
    pub fn cells(&self) -> [usize; 2] {
        self.cells
    }
    /// The node numbering in use.
    pub fn node_order(&self) -> NodeOrder {
        self.order
    }
    /// Number of nodes along each axis, `(cx + 1, cy + 1)`.
    pub fn nodes_per_axis(&self) -> [usize; 2] {
        [self.cells[0] + 1, self.cells[1] + 1]
    }
    /// Total number of nodes `n = (cx + 1)(cy + 1)`: the row count of N, Gx, Gy.
    pub fn num_nodes(&self) -> usize {
        let [a, b] = self.nodes_per_axis();
        a * b
    }
    /// `[x_min, x_max, y_min, y_max]` of the gridded rectangle.
    pub fn bounds(&self) -> [f64; 4] {
        [
            self.origin[0],
            self.origin[0] + self.cells[0] as f64 * self.cell_size[0],
            self.origin[1],
            self.origin[1] + self.cells[1] as f64 * self.cell_size[1],
        ]
    }

    /// Node-number increments `(sx, sy)` for a step of one node along x and along y:
    /// `id(i, j) = i sx + j sy`.
    pub fn strides(&self) -> [usize; 2] {
        let [a, b] = self.nodes_per_axis();
        match self.order {
            NodeOrder::XFastest => [1, a],
            NodeOrder::YFastest => [b, 1],
        }
    }

    /// Node number of node `(i, j)`.
    ///
    /// # Panics
    /// If `i > cx` or `j > cy`.
    pub fn node_index(&self, i: usize, j: usize) -> usize {
        let [a, b] = self.nodes_per_axis();
        assert!(i < a && j < b, "node ({i}, {j}) is outside a {a} x {b} node grid");
        let [sx, sy] = self.strides();
        i * sx + j * sy
    }

    /// `(i, j)` of node `id`.
    ///
    /// # Panics
    /// If `id >= num_nodes()`.
    pub fn node_ij(&self, id: usize) -> (usize, usize) {
        assert!(
            id < self.num_nodes(),
            "node {id} does not exist ({} nodes)",
            self.num_nodes()
        );
        let [a, b] = self.nodes_per_axis();
        match self.order {
            NodeOrder::XFastest => (id % a, id / a),
            NodeOrder::YFastest => (id / b, id % b),
        }
    }

    /// Position `(x₀ + i hx, y₀ + j hy)` of node `id`.
    ///
    /// # Panics
    /// If `id >= num_nodes()`.
    pub fn node_position(&self, id: usize) -> [f64; 2] {
        let (i, j) = self.node_ij(id);
        [
            self.origin[0] + i as f64 * self.cell_size[0],
            self.origin[1] + j as f64 * self.cell_size[1],
        ]
    }

    /// x coordinates of all nodes, in node order (the seed's `x_g`).
    pub fn node_x(&self) -> Vec<f64> {
        (0..self.num_nodes()).map(|k| self.node_position(k)[0]).collect()
    }

    /// y coordinates of all nodes, in node order (the seed's `y_g`).
    pub fn node_y(&self) -> Vec<f64> {
        (0..self.num_nodes()).map(|k| self.node_position(k)[1]).collect()
    }

    /// Whether `(x, y)` lies in the closed gridded rectangle.
    pub fn contains(&self, x: f64, y: f64) -> bool {
        let [x0, x1, y0, y1] = self.bounds();
        x >= x0 && x <= x1 && y >= y0 && y <= y1
    }

    /// Position in cell units along `axis`: `(x − x₀)/h`. Integer values are grid lines.
    pub fn cell_coordinate(&self, axis: usize, value: f64) -> f64 {
        (value - self.origin[axis]) / self.cell_size[axis]
    }

    /// The cell `(ci, cj)` containing `(x, y)` under the half-open convention of the
    /// [module docs](self), or `None` outside the grid.
    pub fn cell_of(&self, x: f64, y: f64) -> Option<(usize, usize)> {
        if !self.contains(x, y) {
            return None;
        }
        let c = |axis: usize, v: f64| {
            let s = self.cell_coordinate(axis, v).floor().max(0.0) as usize;
            s.min(self.cells[axis] - 1)
        };
        Some((c(0, x), c(1, y)))
    }
}

fn span(values: &[f64]) -> f64 {
    (values[values.len() - 1] - values[0]).abs().max(f64::MIN_POSITIVE)
}

/// Distinct values, ascending; `values` must not be empty.
fn distinct_sorted(values: &[f64]) -> Vec<f64> {
    let mut v: Vec<f64> = values.to_vec();
    v.sort_by(f64::total_cmp);
    let span = span(&v);
    v.dedup_by(|a, b| (*a - *b).abs() <= COORDINATE_TOLERANCE * span);
    v
}

/// The spacing of the distinct values `lines`, or an error naming the first node of `all`
/// that sits on an out-of-place line.
fn uniform_spacing(lines: &[f64], all: &[f64], axis: &str) -> Result<f64> {
    let h = (lines[lines.len() - 1] - lines[0]) / (lines.len() - 1) as f64;
    for (k, v) in lines.iter().enumerate() {
        let expected = lines[0] + k as f64 * h;
        if (v - expected).abs() > SPACING_TOLERANCE * h {
            let node = all
                .iter()
                .position(|a| (a - v).abs() <= SPACING_TOLERANCE * h)
                .unwrap_or(0);
            return Err(MpmError::NotAUniformGrid {
                reason: format!(
                    "{axis} values are not evenly spaced: node {node} has {axis} = {v} where a spacing of {h} puts {expected}"
                ),
            });
        }
    }
    Ok(h)
}

/// Calls `f` on each range of nodes of the box (`span`, `columns`) outside the box
/// (`new_span`, `new_columns`): a box being the nodes of a range of node numbers whose index
/// along their line (`line_len` nodes per line; columns beyond it are clamped) lies in a range.
pub(crate) fn outside_box(
    (span, columns): (&std::ops::Range<usize>, &std::ops::Range<usize>),
    (new_span, new_columns): (&std::ops::Range<usize>, &std::ops::Range<usize>),
    line_len: usize,
    mut f: impl FnMut(std::ops::Range<usize>),
) {
    if span.is_empty() || line_len == 0 {
        return;
    }
    let segment = |line: usize, span: &std::ops::Range<usize>, columns: &std::ops::Range<usize>| {
        let at = line * line_len;
        let (a, b) = (at + columns.start.min(line_len), at + columns.end.min(line_len));
        a.max(span.start)..b.min(span.end)
    };
    for line in span.start / line_len..(span.end - 1) / line_len + 1 {
        let old = segment(line, span, columns);
        let new = segment(line, new_span, new_columns);
        if new.start >= new.end {
            if old.start < old.end {
                f(old);
            }
            continue;
        }
        for part in [old.start..old.end.min(new.start), old.start.max(new.end)..old.end] {
            if part.start < part.end {
                f(part);
            }
        }
    }
}

/// Calls `f(range, along, line)` on each run of the nodes `start .. start + len` whose index
/// along their line (`line_len` nodes per line) lies in `columns`: `range` the run's offsets
/// from `start`, `along` the index of its first node along line `line`.
#[inline(always)]
pub(crate) fn column_runs(
    start: usize,
    len: usize,
    line_len: usize,
    columns: &std::ops::Range<usize>,
    mut f: impl FnMut(std::ops::Range<usize>, usize, usize),
) {
    let end = start + len;
    if len == 0 || line_len == 0 {
        return;
    }
    let (c0, c1) = (columns.start.min(line_len), columns.end.min(line_len));
    for line in start / line_len..(end - 1) / line_len + 1 {
        let at = line * line_len;
        let (a, b) = ((at + c0).max(start), (at + c1).min(end));
        if a < b {
            f(a - start..b - start, a - at, line);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{column_runs, outside_box};
    use std::ops::Range;

    /// Whether node `i` lies in the box (`span`, `columns`) of lines of `len` nodes.
    fn inside(i: usize, span: &Range<usize>, columns: &Range<usize>, len: usize) -> bool {
        span.contains(&i) && columns.contains(&(i % len))
    }

    #[test]
    fn boxes_and_runs_are_the_nodes_counted_one_by_one() {
        let len = 7;
        let n = 8 * len;
        let mut seed = 12345u64;
        let mut draw = |m: usize| {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 33) as usize % m
        };
        for _ in 0..2000 {
            let mut range = |m: usize| {
                let (a, b) = (draw(m + 1), draw(m + 1));
                a.min(b)..a.max(b)
            };
            let (span, columns) = (range(n), range(len));
            let (new_span, new_columns) = (range(n), range(len));
            let mut marked = vec![0; n];
            outside_box((&span, &columns), (&new_span, &new_columns), len, |r| {
                r.for_each(|i| marked[i] += 1)
            });
            for (i, &m) in marked.iter().enumerate() {
                let expected = inside(i, &span, &columns, len) && !inside(i, &new_span, &new_columns, len);
                assert_eq!(
                    m,
                    usize::from(expected),
                    "node {i} of {span:?} {columns:?} -> {new_span:?} {new_columns:?}"
                );
            }
            let (start, count) = (span.start, span.len());
            let mut seen = vec![0; n];
            column_runs(start, count, len, &columns, |run, along, line| {
                assert_eq!((start + run.start) % len, along);
                assert_eq!((start + run.start) / len, line);
                run.for_each(|j| seen[start + j] += 1)
            });
            for (i, &s) in seen.iter().enumerate() {
                assert_eq!(
                    s,
                    usize::from(inside(i, &span, &columns, len)),
                    "node {i} of {span:?} {columns:?}"
                );
            }
        }
    }
}
