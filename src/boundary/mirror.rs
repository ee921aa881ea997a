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

    /// Opposite mirrored walls at least `support()` cells apart, so that no stencil reaches
    /// the ghost lines of both.
    ///
    /// # Errors
    /// [`MpmError::InvalidScene`] at `boundaries[k].wall` of the later wall.
    pub(super) fn validate(&self, shape: ShapeFunction) -> Result<()> {
        for (axis, walls) in self.axes.iter().enumerate() {
            if let (Some(lo), Some(hi)) = (walls.low, walls.high) {
                let apart = hi.line.saturating_sub(lo.line);
                if apart < shape.support() {
                    return Err(MpmError::InvalidScene {
                        key: format!("boundaries[{}].wall", lo.condition.max(hi.condition)),
                        reason: format!(
                            "\"mirror\": the walls across {} at node lines {} and {} are {apart} cells apart, fewer \
                             than the kernel's support ({})",
                            ["x", "y"][axis],
                            lo.line,
                            hi.line,
                            shape.support()
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
