//! The mirror (odd-reflection) rule for fixed walls with GIMP and B-spline kernels.
//!
//! A wall lies on a node line `w` ([`Wall::line`]); the node lines beyond it are ghosts. Their
//! values are odd reflections of the interior, a linear constraint `v = C v_free` with one
//! entry per row of `C`:
//!
//! ```text
//! v_(w−k) = s · v_(w+k)     k ≥ 1,  s = Wall::sign = −1 (fixed wall: both components)
//! v_w     = 0               (the wall line is held by its condition)
//! ```
//!
//! In one dimension the rule replaces each particle's weights by their fold, which keeps the
//! stencil (the mirror of a ghost line a particle touches is always inside its stencil):
//!
//! ```text
//! Ŝ_(w+k) = S_(w+k) + s S_(w−k),   Ŝ'_(w+k) = S'_(w+k) + s S'_(w−k),   Ŝ_(w−k) = Ŝ'_(w−k) = 0
//! ```
//!
//! and in two dimensions the fold is the tensor product of the two axes' folds (a corner ghost
//! takes the product of the signs). With folded operators `N̂ = Cᵀ N`, `Ĝ = Cᵀ G` every product
//! of the time loop becomes the constrained one: `Cᵀ q`, `Cᵀ f`, the consistent mass
//! `N̂ diag(m) N̂ᵀ = Cᵀ M C` (for every scheme built on it), and the particles read
//! `N̂ᵀ v = Nᵀ C v`. The lumped mass is the diagonal of `Cᵀ M_L C`,
//!
//! ```text
//! m̂_L,(w+k) = m_L,(w+k) + m_L,(w−k)      (|C|ᵀ m_L)
//! ```
//!
//! which [`MirrorWalls::fold_lumped`] writes over the `Cᵀ m_L` the particle-to-grid pass
//! computes with the folded operators. Ghost nodes then carry no mass and are inactive.
//!
//! With the particles of a body and their odd images beyond the wall, the grid equations are
//! exactly those of this rule: a fixed–fixed bar behaves as one period of an infinite periodic
//! bar, and the interior (second-order) period error holds up to the walls.
//!
//! A particle that a time step carries past the wall (the odd field gives it zero normal
//! velocity at the wall, so only by the step's own error) is weighted as if it were on the
//! wall. APIC's affine momentum of a folded weight is taken at the mirror node's position.

use super::{Edge, WallRule};
use crate::error::{MpmError, Result};
use crate::grid::Grid;
use crate::operators::Operators;
use crate::particles::Particles;
use crate::shape::{AxisFrame, ShapeFunction, MAX_SUPPORT};

/// A mirrored wall: the node line it lies on (index along its axis) and the reflection sign.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Wall {
    /// The wall's node line, `layers − 1` lines in from its edge.
    pub line: usize,
    /// `s` in `v_(w−k) = s v_(w+k)`: −1 for a fixed wall.
    pub sign: f64,
    /// The condition that set it (its index in the list, for messages).
    pub condition: usize,
}

/// The mirrored walls of one axis, at its low and high end.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AxisWalls {
    /// The wall at the low end (left or bottom edge).
    pub low: Option<Wall>,
    /// The wall at the high end (right or top edge).
    pub high: Option<Wall>,
}

/// The mirrored walls of a grid, per axis (x, y), resolved from the boundary conditions by
/// [`super::resolve`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MirrorWalls {
    /// Walls of the x axis (left, right) and the y axis (bottom, top).
    pub axes: [AxisWalls; 2],
}

/// One axis of a particle's folded weights.
#[derive(Debug, Clone, Copy)]
struct FoldedAxis {
    first: usize,
    value: [f64; MAX_SUPPORT],
    derivative: [f64; MAX_SUPPORT],
    /// The fold with `|s|`: the lumped mass's weights.
    absolute: [f64; MAX_SUPPORT],
}

impl AxisWalls {
    /// Whether a stencil of `len` nodes from node `first` reaches a ghost line.
    fn reaches_ghost(&self, first: usize, len: usize) -> bool {
        self.low.is_some_and(|w| first < w.line) || self.high.is_some_and(|w| first + len - 1 > w.line)
    }

    /// The folded weights of a particle at `coordinate` (accepted by `frame`): a particle
    /// beyond a wall is weighted on it; each ghost weight is added to its mirror with the sign.
    fn fold(&self, frame: &AxisFrame, coordinate: f64) -> FoldedAxis {
        let mut s = frame.accept(coordinate).expect("the operators accepted the particle");
        if let Some(w) = self.low {
            s = s.max(w.line as f64);
        }
        if let Some(w) = self.high {
            s = s.min(w.line as f64);
        }
        let raw = frame.weights(s);
        let mut out = FoldedAxis {
            first: raw.first,
            value: raw.value,
            derivative: raw.derivative,
            absolute: raw.value,
        };
        for k in 0..raw.len {
            let node = raw.first + k;
            let mirror = match (self.low, self.high) {
                (Some(w), _) if node < w.line => Some((2 * w.line - node, w.sign)),
                (_, Some(w)) if node > w.line => (2 * w.line).checked_sub(node).map(|m| (m, w.sign)),
                _ => None,
            };
            let Some((mirror, sign)) = mirror else { continue };
            match mirror.checked_sub(raw.first).filter(|&m| m < raw.len) {
                Some(m) => {
                    out.value[m] += sign * raw.value[k];
                    out.derivative[m] += sign * raw.derivative[k];
                    out.absolute[m] += raw.value[k];
                }
                // Only the outermost node of a stencil on the wall (a breakpoint of the
                // kernel), whose weight and derivative are zero.
                None => debug_assert!(raw.value[k] == 0.0 && raw.derivative[k] == 0.0),
            }
            out.value[k] = 0.0;
            out.derivative[k] = 0.0;
            out.absolute[k] = 0.0;
        }
        out
    }

    /// The weights of a particle at `coordinate` along this axis: folded when its stencil
    /// (`len` nodes from `first`) reaches a ghost line, as assembled otherwise.
    fn weights(&self, frame: &AxisFrame, coordinate: f64, first: usize, len: usize) -> FoldedAxis {
        if self.reaches_ghost(first, len) {
            self.fold(frame, coordinate)
        } else {
            let raw = frame.weights(frame.accept(coordinate).expect("the operators accepted the particle"));
            FoldedAxis {
                first: raw.first,
                value: raw.value,
                derivative: raw.derivative,
                absolute: raw.value,
            }
        }
    }
}

impl MirrorWalls {
    /// Whether no wall is mirrored.
    pub fn is_empty(&self) -> bool {
        self.axes.iter().all(|a| a.low.is_none() && a.high.is_none())
    }

    /// Records the rule of edge condition `k` (`layers` node lines on a grid of `nodes` per
    /// axis): a mirrored wall on line `layers − 1` from the edge when the rule is
    /// [`WallRule::Mirror`] and there is a ghost line, none otherwise (the later condition on an
    /// edge decides).
    pub(super) fn set(&mut self, k: usize, edge: Edge, layers: usize, nodes: [usize; 2], rule: WallRule) {
        let (axis, low) = match edge {
            Edge::Left => (0, true),
            Edge::Right => (0, false),
            Edge::Bottom => (1, true),
            Edge::Top => (1, false),
        };
        let wall = (rule == WallRule::Mirror && layers > 1).then(|| Wall {
            line: if low { layers - 1 } else { nodes[axis] - layers },
            sign: -1.0,
            condition: k,
        });
        let side = &mut self.axes[axis];
        if low {
            side.low = wall;
        } else {
            side.high = wall;
        }
    }

    /// The condition of the mirrored wall on `edge`, if there is one.
    pub fn wall_on(&self, edge: Edge) -> Option<usize> {
        let side = match edge {
            Edge::Left => &self.axes[0].low,
            Edge::Right => &self.axes[0].high,
            Edge::Bottom => &self.axes[1].low,
            Edge::Top => &self.axes[1].high,
        };
        side.as_ref().map(|w| w.condition)
    }

    /// The walls of slip edges as component `c` (0: x, 1: y) sees them: odd (`s = −1`) on the
    /// walls normal to `c`, even (`s = +1`) on the walls `c` runs along ([module docs](self),
    /// slip walls).
    pub fn component(&self, c: usize) -> MirrorWalls {
        let mut out = self.clone();
        for (axis, walls) in out.axes.iter_mut().enumerate() {
            let sign = if axis == c { -1.0 } else { 1.0 };
            for wall in [&mut walls.low, &mut walls.high].into_iter().flatten() {
                wall.sign = sign;
            }
        }
        out
    }

    /// Where line `i` of `axis` lies after reflecting it into the walls' interval, and the
    /// product of the signs on the way (`(i, 1)` for a line at or between the walls). Walls
    /// closer than the kernel's support reflect a ghost more than once.
    fn reflect(&self, axis: usize, mut i: usize) -> (usize, f64) {
        let walls = &self.axes[axis];
        let mut sign = 1.0;
        loop {
            match (walls.low, walls.high) {
                (Some(w), _) if i < w.line => {
                    i = 2 * w.line - i;
                    sign *= w.sign;
                }
                (_, Some(w)) if i > w.line => match (2 * w.line).checked_sub(i) {
                    Some(m) => {
                        i = m;
                        sign *= w.sign;
                    }
                    None => return (i, 0.0), // beyond the grid's reach: no mirror
                },
                _ => return (i, sign),
            }
        }
    }

    /// Each ghost node of `grid` (a node on a ghost line of either axis) with its mirror, the
    /// interior node it reflects to across both axes, and the product of the signs.
    fn each_ghost(&self, grid: &Grid, mut visit: impl FnMut(usize, usize, f64)) {
        let ([nx, ny], [sx, sy]) = (grid.nodes_per_axis(), grid.strides());
        let range = |axis: usize, count: usize| {
            let w = &self.axes[axis];
            (w.low.map_or(0, |w| w.line), w.high.map_or(count - 1, |w| w.line))
        };
        let ([x0, x1], [y0, y1]) = ([range(0, nx).0, range(0, nx).1], [range(1, ny).0, range(1, ny).1]);
        for j in 0..ny {
            let row_ghost = j < y0 || j > y1;
            let (tj, sj) = self.reflect(1, j);
            let mut visit_node = |i: usize| {
                let (ti, si) = self.reflect(0, i);
                visit(i * sx + j * sy, ti * sx + tj * sy, si * sj);
            };
            if row_ghost {
                (0..nx).for_each(&mut visit_node);
            } else {
                (0..x0).chain(x1 + 1..nx).for_each(&mut visit_node);
            }
        }
    }

    /// `v ← Cᵀ v` on the grid: each ghost value added to its mirror with the product of the
    /// walls' signs (with `absolute`, without: `|C|ᵀ` for a mass), the ghost zeroed. Idempotent:
    /// a folded field has nothing on its ghosts.
    ///
    /// ```text
    /// v_(w+k) += s v_(w−k),   v_(w−k) = 0
    /// ```
    pub fn fold_field(&self, grid: &Grid, absolute: bool, v: &mut [f64]) {
        self.each_ghost(grid, |g, m, s| {
            let value = std::mem::take(&mut v[g]);
            v[m] += if absolute { value * s.abs() } else { s * value };
        });
    }

    /// `v ← C v` on the grid: each ghost value its mirror's times the product of the walls'
    /// signs, `v_(w−k) = s v_(w+k)` (a corner ghost reflects across both walls).
    pub fn unfold_field(&self, grid: &Grid, v: &mut [f64]) {
        self.each_ghost(grid, |g, m, s| v[g] = s * v[m]);
    }

    /// Each ghost node of these walls as `(ghost, mirror, sign)`: the mirror the interior node
    /// it reflects to, the sign the product along the way.
    pub fn ghost_map(&self, grid: &Grid) -> Vec<(usize, usize, f64)> {
        let mut out = Vec::new();
        self.each_ghost(grid, |g, m, s| out.push((g, m, s)));
        out
    }

    /// Opposite mirrored walls at least `support()` cells apart when one is a fixed wall (whose
    /// fold of the operators reflects a ghost once), so that no stencil reaches the ghost lines
    /// of both; two slip walls (`slip`, folded on the grid) at least a cell apart.
    ///
    /// # Errors
    /// [`MpmError::InvalidScene`] at `boundaries[k].wall` of the later wall.
    pub(super) fn validate_together([fixed, slip]: [&MirrorWalls; 2], shape: ShapeFunction) -> Result<()> {
        for axis in 0..2 {
            let low = fixed.axes[axis].low.or(slip.axes[axis].low);
            let high = fixed.axes[axis].high.or(slip.axes[axis].high);
            // The fold of the operators reflects a ghost once; the grid's fold of slip walls
            // reflects it as often as it takes, and a cell between the walls is enough.
            let least = if fixed.axes[axis].low.is_some() || fixed.axes[axis].high.is_some() {
                shape.support()
            } else {
                1
            };
            if let (Some(lo), Some(hi)) = (low, high) {
                let apart = hi.line.saturating_sub(lo.line);
                if apart < least {
                    return Err(MpmError::InvalidScene {
                        key: format!("boundaries[{}].wall", lo.condition.max(hi.condition)),
                        reason: format!(
                            "\"mirror\": the walls across {} at node lines {} and {} are {apart} cells apart, fewer \
                             than {least} (the kernel's support when a fixed wall is one of them)",
                            ["x", "y"][axis],
                            lo.line,
                            hi.line
                        ),
                    });
                }
            }
        }
        Ok(())
    }

    /// Folds the assembled operators' weights on the ghost lines onto their mirrors
    /// (`N̂ = Cᵀ N`, `Ĝx = Cᵀ Gx`, `Ĝy = Cᵀ Gy`; [module docs](self)), for particles at
    /// `(x[p], y[p])`. Only particles whose stencil reaches a ghost line change. Serial, so the
    /// result does not depend on the thread count.
    ///
    /// # Panics
    /// If the operators were not assembled on `grid` with `shape` for these positions.
    pub fn fold(&self, grid: &Grid, shape: ShapeFunction, x: &[f64], y: &[f64], ops: &mut Operators) {
        if self.is_empty() {
            return;
        }
        let frames = [shape.axis_frame(grid, 0), shape.axis_frame(grid, 1)];
        let len = ops.support();
        ops.refold(|p, first, factors| {
            let at = [x[p], y[p]];
            for a in 0..2 {
                if !self.axes[a].reaches_ghost(first[a] as usize, len) {
                    continue;
                }
                let folded = self.axes[a].fold(&frames[a], at[a]);
                first[a] = folded.first as u32;
                factors[2 * a * len..(2 * a + 1) * len].copy_from_slice(&folded.value[..len]);
                factors[(2 * a + 1) * len..(2 * a + 2) * len].copy_from_slice(&folded.derivative[..len]);
            }
        });
    }

    /// Turns the lumped mass of the folded operators, `Cᵀ m_L`, into the diagonal of
    /// `Cᵀ M_L C`,
    ///
    /// ```text
    /// m̂_L += Σ_p m_p (|Ĉx|ᵀ Sx ⊗ |Ĉy|ᵀ Sy − Ĉxᵀ Sx ⊗ Ĉyᵀ Sy)     over particles reaching a ghost line
    /// ```
    ///
    /// (ghost mass added to its mirror rather than subtracted). Serial.
    ///
    /// # Panics
    /// If `ops` were not folded by [`MirrorWalls::fold`] for these particles, or `lumped` does
    /// not have one entry per node.
    pub fn fold_lumped(&self, grid: &Grid, particles: &Particles, ops: &Operators, lumped: &mut [f64]) {
        if self.is_empty() {
            return;
        }
        let (shape, x, y, m) = (ops.shape_function(), &particles.x, &particles.y, &particles.mass);
        let frames = [shape.axis_frame(grid, 0), shape.axis_frame(grid, 1)];
        let (len, [sx, sy]) = (ops.support(), grid.strides());
        for (p, first) in ops.first_nodes().iter().enumerate() {
            let [i, j] = [first[0] as usize, first[1] as usize];
            if !(self.axes[0].reaches_ghost(i, len) || self.axes[1].reaches_ghost(j, len)) {
                continue;
            }
            let wx = self.axes[0].weights(&frames[0], x[p], i, len);
            let wy = self.axes[1].weights(&frames[1], y[p], j, len);
            for b in 0..len {
                for a in 0..len {
                    let node = (wx.first + a) * sx + (wy.first + b) * sy;
                    lumped[node] += m[p] * (wx.absolute[a] * wy.absolute[b] - wx.value[a] * wy.value[b]);
                }
            }
        }
    }
}
