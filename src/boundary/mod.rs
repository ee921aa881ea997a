//! Nodal boundary conditions: fixed nodes, slip (roller) walls on grid edges, prescribed
//! velocities on edges, rectangles of nodes or lists of nodes.
//!
//! A condition prescribes some velocity components of a set of grid nodes. Prescribed
//! components are eliminated from the mass solves (consistent mass: moved to the right-hand
//! side), take the prescribed value in the grid velocity, and have zero grid acceleration:
//!
//! ```text
//! v_I,c = v̂_I,c   and   a_I,c = 0      for every prescribed (node I, component c)
//! ```
//!
//! | condition | prescribes |
//! |---|---|
//! | `Fixed` | both components, zero |
//! | `Slip` (on an edge) | the component normal to the edge, zero; tangential motion is free |
//! | `Velocity { vx, vy }` | the components given (either or both) |
//!
//! When several conditions name the same node and component, the later one wins; a `nodes`
//! list names each node once.
//!
//! ## Edges and layers
//! An edge condition covers the outermost `layers` lines of nodes along that edge. The default
//! is [`ShapeFunction::boundary_layers`]: the number of node lines a wall must hold so that
//! no particle can come closer to the edge than its kernel's support allows (1 for linear,
//! 2 for GIMP and quadratic B-splines, 3 for cubic B-splines).
//!
//! ## Walls: mirrored or held ([`WallRule`])
//! The innermost of the `layers` lines is the **wall**; the lines beyond it are **ghost**
//! lines. With [`WallRule::Held`] every line is held at the prescribed value, which with
//! B-splines and GIMP makes the solution near the wall first order (a ghost node held at zero
//! is a kink in the interpolated field). With [`WallRule::Mirror`] (the default of a fixed
//! edge) the ghost values are odd reflections of the interior nodes, a linear constraint
//! `v = C v_free`:
//!
//! ```text
//! v_(w−k) = −v_(w+k)   (both components; wall line w: v_w = 0)
//! ```
//!
//! applied by folding each particle's weights on the ghost lines onto their mirrors with the
//! sign (`Cᵀ N`, `Cᵀ Gx`, `Cᵀ Gy`; see [`mirror`]), so that the consistent mass becomes
//! `Cᵀ M C`, momenta and forces `Cᵀ q`, `Cᵀ f`, and the particles read `Nᵀ C v`. The lumped mass
//! is `|C|ᵀ m_L` (ghost mass added to its mirror). The mirror rule is implemented for fixed
//! walls; slip and velocity edges are held.

use serde::{Deserialize, Serialize};

use crate::error::{MpmError, Result};
use crate::grid::Grid;
use crate::mass::Constraints;
use crate::numbers::exact;
use crate::shape::ShapeFunction;

pub mod mirror;
mod resolve;

pub use mirror::{AxisWalls, MirrorWalls, Wall};
pub use resolve::{resolve, MAX_NODE_VISITS_PER_NODE};

/// How an edge condition treats the node lines at and beyond its wall.
///
/// As text: `"mirror"` or `"held"` (the `wall` key of a scene's `[[boundaries]]`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WallRule {
    /// Every one of the `layers` node lines holds the prescribed value (the library's rule
    /// before the mirror rule; first order near the wall with kernels wider than linear).
    Held,
    /// The innermost line is the wall (held); the lines beyond it are ghosts whose values
    /// are reflections of the interior, `v_(w−k) = s v_(w+k)`: odd (`s = −1`) for both
    /// components of a fixed wall and the normal component of a slip wall, even (`s = +1`) for
    /// the tangential component of a slip wall. With [`Condition::Fixed`] and
    /// [`Condition::Slip`]. With linear kernels (one layer) it is the same as `Held`.
    Mirror,
}

impl WallRule {
    /// The rule an edge condition without a `wall` key gets: [`WallRule::Mirror`] for a fixed
    /// or slip edge when the kernel has ghost lines (`boundary_layers() > 1`: GIMP, B-splines),
    /// [`WallRule::Held`] otherwise.
    pub fn default_for(condition: Condition, shape: ShapeFunction) -> WallRule {
        match condition {
            Condition::Fixed | Condition::Slip if shape.boundary_layers() > 1 => WallRule::Mirror,
            Condition::Fixed | Condition::Slip | Condition::Velocity => WallRule::Held,
        }
    }

    /// `"mirror"` or `"held"`.
    pub fn name(&self) -> &'static str {
        match self {
            WallRule::Held => "held",
            WallRule::Mirror => "mirror",
        }
    }
}

/// A side of the grid.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Edge {
    /// `x = x_min`.
    Left,
    /// `x = x_max`.
    Right,
    /// `y = y_min`.
    Bottom,
    /// `y = y_max`.
    Top,
}

impl Edge {
    /// `"left"`, `"right"`, `"bottom"` or `"top"`.
    pub fn name(&self) -> &'static str {
        match self {
            Edge::Left => "left",
            Edge::Right => "right",
            Edge::Bottom => "bottom",
            Edge::Top => "top",
        }
    }
}

/// What a condition prescribes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Condition {
    /// Both velocity components zero.
    Fixed,
    /// The component normal to the edge zero (roller); only on an edge. A symmetry plane is
    /// a slip wall (as text also `"symmetry"`).
    #[serde(alias = "symmetry")]
    Slip,
    /// The components `vx` and/or `vy` of the condition prescribed.
    Velocity,
}

/// One boundary condition: a set of nodes (exactly one of `edge`, `rectangle`, `nodes`) and
/// what is prescribed there.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoundaryCondition {
    /// A grid edge …
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub edge: Option<Edge>,
    /// … and how many node lines from it (default: the kernel's boundary layers).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub layers: Option<usize>,
    /// … over the part of it whose coordinate along the edge (y for the left and right edges,
    /// x for the bottom and top) lies in `[from, to]` (closed; default: the whole edge). A wall on
    /// part of an edge is held ([`WallRule::Held`]): its nodes in the range, on every one of its
    /// `layers` lines.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "crate::pairs::optional_pair"
    )]
    pub range: Option<[f64; 2]>,
    /// Or every node inside the rectangle `[[x_min, y_min], [x_max, y_max]]` (closed).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "crate::pairs::optional_two_pairs"
    )]
    pub rectangle: Option<[[f64; 2]; 2]>,
    /// Or these nodes (grid numbering).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nodes: Option<Vec<usize>>,
    /// What is prescribed.
    pub condition: Condition,
    /// Prescribed x velocity (with [`Condition::Velocity`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vx: Option<f64>,
    /// Prescribed y velocity (with [`Condition::Velocity`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vy: Option<f64>,
    /// The wall rule of an edge condition (default: [`WallRule::default_for`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wall: Option<WallRule>,
    /// Coulomb's coefficient of a slip edge: the wall then meets the bodies as a rigid body
    /// beyond its innermost node line, through contact ([`crate::contact`], [`FrictionWall`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction: Option<f64>,
}

/// A slip wall with friction ([`BoundaryCondition::friction`]): not prescribed on the grid, but
/// met by each body as a rigid half-space at rest beyond the wall line, through the contact
/// correction ([`crate::contact`]) at every node whose kernel support crosses the line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrictionWall {
    /// The boundary condition it comes from (its index).
    pub condition: usize,
    /// The axis of the wall's normal (0: x, a left or right wall; 1: y).
    pub axis: usize,
    /// The wall line's coordinate along `axis` (the innermost of the edge's node lines).
    pub at: f64,
    /// The normal pointing out of the domain (from a body toward the wall): −1 or +1 along
    /// `axis`.
    pub outward: f64,
    /// Coulomb's coefficient.
    pub friction: f64,
    /// The part of the wall, along it (`None`: the whole edge).
    pub range: Option<[f64; 2]>,
}

impl BoundaryCondition {
    /// `condition` on `edge`, with the kernel's default number of layers.
    pub fn edge(edge: Edge, condition: Condition) -> BoundaryCondition {
        BoundaryCondition {
            edge: Some(edge),
            layers: None,
            range: None,
            rectangle: None,
            nodes: None,
            condition,
            vx: None,
            vy: None,
            wall: None,
            friction: None,
        }
    }

    /// `condition` on the listed nodes.
    pub fn nodes(nodes: Vec<usize>, condition: Condition) -> BoundaryCondition {
        BoundaryCondition {
            nodes: Some(nodes),
            ..BoundaryCondition::edge(Edge::Left, condition)
        }
        .without_edge()
    }

    /// `condition` on the nodes inside `[[x_min, y_min], [x_max, y_max]]`.
    pub fn rectangle(rectangle: [[f64; 2]; 2], condition: Condition) -> BoundaryCondition {
        BoundaryCondition {
            rectangle: Some(rectangle),
            ..BoundaryCondition::edge(Edge::Left, condition)
        }
        .without_edge()
    }

    /// Sets the prescribed velocity components (and the condition to [`Condition::Velocity`]).
    pub fn with_velocity(mut self, vx: Option<f64>, vy: Option<f64>) -> BoundaryCondition {
        self.condition = Condition::Velocity;
        self.vx = vx;
        self.vy = vy;
        self
    }

    /// Sets the number of node layers of an edge condition.
    pub fn with_layers(mut self, layers: usize) -> BoundaryCondition {
        self.layers = Some(layers);
        self
    }

    /// Sets the friction coefficient of a slip edge ([`BoundaryCondition::friction`]).
    pub fn with_friction(mut self, friction: f64) -> BoundaryCondition {
        self.friction = Some(friction);
        self
    }

    /// Sets the wall rule of an edge condition.
    pub fn with_wall(mut self, wall: WallRule) -> BoundaryCondition {
        self.wall = Some(wall);
        self
    }

    /// The wall rule in force: `wall`, or [`WallRule::default_for`] the condition and kernel.
    pub fn wall_rule(&self, shape: ShapeFunction) -> WallRule {
        if self.range.is_some() {
            return WallRule::Held;
        }
        self.wall
            .unwrap_or_else(|| WallRule::default_for(self.condition, shape))
    }

    /// The node lines an edge condition holds: `layers`, or by default the kernel's
    /// [`ShapeFunction::boundary_layers`], and one more for a fixed wall on part of an edge
    /// with a kernel that has ghost lines (GIMP, B-splines). A held wall is a kink in the
    /// interpolated field where a mirror has none: clamping the first node line inside the
    /// wall as well keeps a clamp on part of an edge as stiff as a mirrored one (a beam's
    /// first swing 1.7% under Euler–Bernoulli, against 6–7% over it with the kernel's lines
    /// alone, which also let a beam under large deflection creep out of its clamp;
    /// tests/partial_walls.rs).
    pub fn layers_for(&self, shape: ShapeFunction) -> usize {
        self.layers.unwrap_or_else(|| {
            let lines = shape.boundary_layers();
            let clamp = self.range.is_some() && self.condition == Condition::Fixed && lines > 1;
            lines + usize::from(clamp)
        })
    }

    /// Restricts an edge condition to the part of the edge whose coordinate along it lies in
    /// `[from, to]` ([`BoundaryCondition::range`]).
    pub fn with_range(mut self, from: f64, to: f64) -> BoundaryCondition {
        self.range = Some([from, to]);
        self
    }

    fn without_edge(mut self) -> BoundaryCondition {
        self.edge = None;
        self
    }
}

/// The prescribed nodal velocity components of a grid, resolved from a list of conditions:
/// the prescribed degrees of freedom as lists and their values beside them (nothing per free
/// node).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Prescribed {
    /// The prescribed degrees of freedom as lists, ascending (for the mass solves).
    pub constraints: Constraints,
    /// The prescribed value of each entry of `constraints.fixed_x` (then of `fixed_y`), in the
    /// same order.
    pub values: [Vec<f64>; 2],
    /// The fixed walls under [`WallRule::Mirror`], whose ghost lines the operators fold.
    pub mirror: MirrorWalls,
    /// The slip walls under [`WallRule::Mirror`], folded on the grid component by component
    /// ([`MirrorWalls::component`]: the normal component odd, the tangential even).
    pub slip: MirrorWalls,
    /// The slip walls with friction, met through contact instead of prescribed.
    pub friction: Vec<FrictionWall>,
}

impl Prescribed {
    /// Whether no component of any node is prescribed.
    pub fn is_empty(&self) -> bool {
        self.constraints.fixed_x.is_empty() && self.constraints.fixed_y.is_empty()
    }

    /// The prescribed `[x, y]` velocity components of `node` (`None` where free).
    pub fn velocity(&self, node: usize) -> [Option<f64>; 2] {
        let c = &self.constraints;
        let at = |k: usize, list: &[usize]| list.binary_search(&node).ok().map(|j| self.values[k][j]);
        [at(0, &c.fixed_x), at(1, &c.fixed_y)]
    }

    /// Each prescribed component as `(component, node, value)`: x components first.
    pub fn each(&self) -> impl Iterator<Item = (usize, usize, f64)> + '_ {
        let c = &self.constraints;
        [&c.fixed_x, &c.fixed_y]
            .into_iter()
            .enumerate()
            .flat_map(move |(k, list)| list.iter().zip(&self.values[k]).map(move |(&i, &v)| (k, i, v)))
    }

    /// Overwrites the prescribed components of a grid velocity with their values.
    pub fn apply_velocity(&self, vx: &mut [f64], vy: &mut [f64]) {
        for (k, i, v) in self.each() {
            if k == 0 {
                vx[i] = v;
            } else {
                vy[i] = v;
            }
        }
    }

    /// Sets the prescribed components of a grid acceleration (or any rate) to zero.
    pub fn zero(&self, ax: &mut [f64], ay: &mut [f64]) {
        for &i in &self.constraints.fixed_x {
            ax[i] = 0.0;
        }
        for &i in &self.constraints.fixed_y {
            ay[i] = 0.0;
        }
    }
}

impl BoundaryCondition {
    /// Checks condition `k` (numbered as in a scene's `[[boundaries]]`, for the messages) on
    /// `grid` with kernels `shape`, without allocating anything in proportion to the grid:
    /// exactly one node set, `layers` only with an edge and within the grid, `slip` only on an
    /// edge, `wall` only on an edge and `"mirror"` only with a fixed condition and its ghost
    /// lines' mirrors on the grid, `vx`/`vy` finite and only with a velocity condition, a
    /// finite ordered rectangle,
    /// and a `nodes` list that names existing nodes, each once (a list longer than the grid's
    /// node count is refused before it is looked at further).
    ///
    /// # Errors
    /// [`MpmError::InvalidScene`] naming the key (`boundaries[k].nodes` …) and the value.
    pub fn validate(&self, k: usize, grid: &Grid, shape: ShapeFunction) -> Result<()> {
        self.validate_kind(k)?;
        self.validate_extent(k, grid, shape)
    }

    /// Exactly one node set, `layers` only with an edge, `slip` only on an edge, `vx`/`vy`
    /// finite and only with a velocity condition (which needs one of them).
    fn validate_kind(&self, k: usize) -> Result<()> {
        let err = |field: &str, reason: String| scene_error(k, field, reason);
        let given: Vec<String> = [
            ("edge", self.edge.is_some()),
            ("rectangle", self.rectangle.is_some()),
            ("nodes", self.nodes.is_some()),
        ]
        .iter()
        .filter(|(_, g)| *g)
        .map(|(name, _)| format!("`{name}`"))
        .collect();
        if given.len() != 1 {
            let found = if given.is_empty() {
                "none is given".to_string()
            } else {
                format!("{} are given", given.join(" and "))
            };
            return Err(err(
                "",
                format!("give exactly one of `edge`, `rectangle`, `nodes` ({found})"),
            ));
        }
        if let (Some(layers), None) = (self.layers, self.edge) {
            return Err(err(
                "layers",
                format!("{layers}: `layers` applies only to an `edge` condition"),
            ));
        }
        if let Some([from, to]) = self.range {
            if self.edge.is_none() {
                return Err(err(
                    "range",
                    format!(
                        "[{}, {}]: `range` applies only to an `edge` condition",
                        exact(from),
                        exact(to)
                    ),
                ));
            }
            if !(from.is_finite() && to.is_finite() && from <= to) {
                return Err(err(
                    "range",
                    format!(
                        "[{}, {}] must be [from, to] along the edge with finite values and from <= to",
                        exact(from),
                        exact(to)
                    ),
                ));
            }
            if self.wall == Some(WallRule::Mirror) {
                return Err(err(
                    "wall",
                    "\"mirror\" with a `range`: a mirrored wall spans its whole edge; a wall on part of an edge \
                     is held (leave `wall` out, or wall = \"held\")"
                        .into(),
                ));
            }
        }
        self.validate_wall(k)?;
        if let Some(mu) = self.friction {
            if self.condition != Condition::Slip || self.edge.is_none() {
                return Err(err(
                    "friction",
                    format!(
                        "{}: friction goes with a slip edge (condition = \"slip\" and an `edge`); a fixed wall \
                         already holds the tangential velocity",
                        exact(mu)
                    ),
                ));
            }
            if !mu.is_finite() || mu < 0.0 {
                return Err(err(
                    "friction",
                    format!("{} is not a friction coefficient (finite, μ ≥ 0)", exact(mu)),
                ));
            }
        }
        match self.condition {
            Condition::Slip if self.edge.is_none() => {
                return Err(err(
                    "condition",
                    "`slip` needs an `edge` (its normal); for other node sets use condition = \"velocity\" with \
                     vx = 0 or vy = 0"
                        .into(),
                ))
            }
            Condition::Velocity if self.vx.is_none() && self.vy.is_none() => {
                return Err(err(
                    "condition",
                    "condition \"velocity\" needs `vx`, `vy` or both".into(),
                ))
            }
            _ => {}
        }
        for (name, v) in [("vx", self.vx), ("vy", self.vy)] {
            let Some(v) = v else { continue };
            if self.condition != Condition::Velocity {
                return Err(err(
                    name,
                    format!("{}: `vx` and `vy` go with condition = \"velocity\"", exact(v)),
                ));
            }
            if !v.is_finite() {
                return Err(err(name, format!("`{name}` = {} is not a finite number", exact(v))));
            }
        }
        Ok(())
    }

    /// `wall` only with an edge, `"mirror"` only with a fixed or slip condition.
    fn validate_wall(&self, k: usize) -> Result<()> {
        let err = |field: &str, reason: String| scene_error(k, field, reason);
        if let (Some(wall), None) = (self.wall, self.edge) {
            return Err(err(
                "wall",
                format!("\"{}\": `wall` applies only to an `edge` condition", wall.name()),
            ));
        }
        if self.wall == Some(WallRule::Mirror) && self.condition == Condition::Velocity {
            return Err(err(
                "wall",
                "\"mirror\" with condition = \"velocity\": the mirror rule is implemented for fixed and slip \
                 walls (use wall = \"held\")"
                    .into(),
            ));
        }
        Ok(())
    }

    /// An edge's `layers` within the grid, a finite ordered rectangle, a `nodes` list of existing
    /// nodes, each once.
    fn validate_extent(&self, k: usize, grid: &Grid, shape: ShapeFunction) -> Result<()> {
        let err = |field: &str, reason: String| scene_error(k, field, reason);
        let [nx, ny] = grid.nodes_per_axis();
        if let Some(edge) = self.edge {
            let layers = self.layers_for(shape);
            let across = match edge {
                Edge::Left | Edge::Right => nx,
                Edge::Bottom | Edge::Top => ny,
            };
            if layers == 0 || layers > across {
                return Err(err(
                    "layers",
                    format!("{layers} layers: must be between 1 and {across} (the node lines across the grid)"),
                ));
            }
            if self.wall_rule(shape) == WallRule::Mirror && layers > 1 && layers >= across {
                return Err(err(
                    "wall",
                    format!(
                        "\"mirror\" with {layers} layers: the ghost line next to the wall needs a node line inside \
                         the wall to mirror onto, and the grid has {across} across"
                    ),
                ));
            }
        }
        if let Some([[x0, y0], [x1, y1]]) = self.rectangle {
            if ![x0, y0, x1, y1].iter().all(|v| v.is_finite()) || x0 > x1 || y0 > y1 {
                return Err(err(
                    "rectangle",
                    format!(
                        "[[{}, {}], [{}, {}]] must be [[x_min, y_min], [x_max, y_max]] with finite values and min <= \
                         max",
                        exact(x0),
                        exact(y0),
                        exact(x1),
                        exact(y1)
                    ),
                ));
            }
        }
        if let Some(ids) = &self.nodes {
            let n = grid.num_nodes();
            if ids.len() > n {
                return Err(err(
                    "nodes",
                    format!(
                        "lists {} nodes, more than the {n} nodes of the grid (each node can be listed once)",
                        ids.len()
                    ),
                ));
            }
            if let Some(&bad) = ids.iter().find(|&&i| i >= n) {
                return Err(err(
                    "nodes",
                    format!("node {bad} does not exist (the grid has {n} nodes, numbered from 0)"),
                ));
            }
            // The list is no longer than the grid: a set of its entries is no larger.
            let mut first_at = std::collections::HashMap::with_capacity(ids.len());
            for (at, &id) in ids.iter().enumerate() {
                if let Some(first) = first_at.insert(id, at) {
                    return Err(err(
                        "nodes",
                        format!("node {id} is listed twice: at index {first} and again at index {at} (each node once)"),
                    ));
                }
            }
        }
        Ok(())
    }
}

/// An [`MpmError::InvalidScene`] at `boundaries[k]`, or at `boundaries[k].{field}` when `field`
/// is not empty.
fn scene_error(k: usize, field: &str, reason: String) -> MpmError {
    MpmError::InvalidScene {
        key: if field.is_empty() {
            format!("boundaries[{k}]")
        } else {
            format!("boundaries[{k}].{field}")
        },
        reason,
    }
}
