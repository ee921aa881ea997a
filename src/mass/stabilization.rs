//! Stabilisation of the consistent mass where a body's edge leaves nodes with little support.
//!
//! As a particle approaches a grid line, the nodes beyond it keep a support whose weights go to
//! zero. `M = N diag(m) Nᵀ` then has directions `φ` with `Nᵀφ ≈ 0` (no inertia) but
//! `Gxᵀφ, Gyᵀφ` not small (stiffness): their frequency is unbounded and no explicit step is
//! stable. This is the "small cut" problem of unfitted finite elements. Three remedies, each a
//! symmetric positive semi-definite change of `M` that keeps its row sums (`M_s 1 = m_L`, so
//! mass and momentum are transferred exactly and a uniform velocity stays uniform):
//!
//! - **Linear extension** (the default, [`super::extension`]): a penalty on the second
//!   differences of the nodal values through badly supported nodes, which ties them to the
//!   linear extension of their neighbours; zero on linear fields, so translations, rigid
//!   rotations and uniform strain rates are projected exactly with every kernel.
//! - **Ghost penalty** ([`ghost_penalty`], Burman 2010; Coombs 2023 for MPM): on each face
//!   between two cells that particles read, where one of the two cells lies on the body's
//!   boundary, penalise the jump of the `p`-th normal derivative of the grid field (`p` the
//!   polynomial degree of the kernel):
//!
//!   ```text
//!   M_s = M + γ Σ_F  m_F  h_n^{2p} / h_t ∫_F [∂ⁿ_p u] [∂ⁿ_p v] ds,    m_F = max_{I on F} m_L,I  (≈ ρ hx hy)
//!   ```
//!
//!   The jump vanishes for every polynomial of degree `p`, so the penalty changes nothing for
//!   the fields the grid represents exactly, and its effect on a smooth mode of wavenumber θ
//!   (per cell) is of order `γ θ^{2p+2}` against the `θ²` error of the mass itself.
//! - **Partial lumping** ([`partially_lumped`]): each off-diagonal entry `M_IJ` is scaled by
//!   `s_IJ = min(1, min(φ_I, φ_J)/θ)` and the removed part moved onto the two diagonals, where
//!   `φ_I = m_L,I / max_{J ~ I} m_L,J` is node I's mass relative to its heaviest neighbour
//!   (1 inside a body, ½ on a grid-aligned edge, ¼ at a corner, → 0 at a fringe).
//!
//! docs/mass.md compares them.

use nalgebra_sparse::{CooMatrix, CscMatrix};
use std::fmt;
use std::str::FromStr;

use super::extension::extension_penalty;
use crate::error::{MpmError, Result};
use crate::grid::Grid;
use crate::names::{self, Spelled};
use crate::operators::Operators;
use crate::shape::{bspline, ShapeFunction};

/// Default ghost-penalty weight γ of [`Stabilization::GhostPenalty`].
pub const DEFAULT_GHOST_PENALTY: f64 = 0.1;
/// Default ramp threshold θ of [`Stabilization::PartialLumping`].
pub const DEFAULT_LUMPING_THRESHOLD: f64 = 0.5;
/// Default penalty weight γ of [`Stabilization::LinearExtension`].
pub const DEFAULT_EXTENSION_WEIGHT: f64 = 0.3;
/// Largest penalty weight γ accepted by [`Stabilization::LinearExtension`] and
/// [`Stabilization::GhostPenalty`]: at 10⁶ the penalised modes are held to round-off already;
/// far beyond, the mass's own entries are lost beside the penalty's (γ = 3·10²⁹ made the
/// consistent mass of a shipped test scene singular in its first solve).
pub const MAX_PENALTY_WEIGHT: f64 = 1e6;
/// Default support threshold θ of [`Stabilization::LinearExtension`].
pub const DEFAULT_EXTENSION_THRESHOLD: f64 = 0.5;
/// Default onset ψ₀ of [`Stabilization::LinearExtension`] (kernels with continuous gradients).
pub const DEFAULT_EXTENSION_ONSET: f64 = 0.2;

/// How the consistent mass is stabilised at a body's fringe before it is solved with. Applies
/// to the consistent, blended and conjugate-gradient schemes (and to a regularised solve); the
/// truncated series keeps the plain `M` it is defined with.
///
/// As text ([`crate::names`]): `none`, `ghost_penalty:γ`, `partial_lumping:θ` (scene files may
/// also write `{ ghost_penalty = { gamma = γ } }`, `{ partial_lumping = { threshold = θ } }`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Stabilization {
    /// The plain consistent mass `M = N diag(m) Nᵀ`: unstable in a time loop once a body's edge
    /// crosses a grid line.
    None,
    /// Ghost penalty on the faces of the cells at a body's boundary.
    GhostPenalty {
        /// Penalty weight γ (> 0), relative to a full node's mass.
        gamma: f64,
    },
    /// Partial lumping of the nodes with little mass relative to their neighbours (θ = ½
    /// by default). Breaks the exact projection of linear fields at a body's edge.
    PartialLumping {
        /// Relative nodal mass θ in (0, 1] below which a node's couplings are lumped in
        /// proportion.
        threshold: f64,
    },
    /// The linear-extension penalty ([`super::extension`], the default, γ = 0.3, θ = ½):
    /// second differences through badly supported nodes penalised, so linear fields are
    /// projected exactly.
    LinearExtension {
        /// Penalty weight γ (> 0), relative to a full node's mass.
        gamma: f64,
        /// Relative nodal mass θ in (0, 1] below which a triple of nodes is penalised.
        threshold: f64,
        /// Support ψ₀ in [0, θ] below which the penalty of a triple fades in proportion
        /// (`min(1, ψ_T/ψ₀)`), with kernels whose gradient vanishes where their value does
        /// (GIMP and the B-splines; 0: no fade): so that the penalty does not appear at full
        /// weight the moment a particle's support reaches a node (docs/mass.md).
        onset: f64,
    },
}

impl Default for Stabilization {
    /// The linear-extension penalty with γ = 0.3, θ = ½: of the remedies measured
    /// (docs/mass.md), the one that keeps the exact projection of linear fields (rigid
    /// rotation, uniform strain) for every kernel, a nonsingular mass for bodies one cell thick
    /// and random layouts, and the consistent mass itself wherever nodes are as well supported
    /// as on a straight grid-aligned edge.
    fn default() -> Self {
        Stabilization::LinearExtension {
            gamma: DEFAULT_EXTENSION_WEIGHT,
            threshold: DEFAULT_EXTENSION_THRESHOLD,
            onset: DEFAULT_EXTENSION_ONSET,
        }
    }
}

impl Stabilization {
    /// Checks the parameters (a weight `γ` in `(0, MAX_PENALTY_WEIGHT]`, fractions in range).
    ///
    /// # Errors
    /// [`MpmError::InvalidParameter`] naming the parameter out of range.
    pub fn validate(&self) -> Result<()> {
        match *self {
            Stabilization::GhostPenalty { gamma } if !(gamma > 0.0 && gamma <= MAX_PENALTY_WEIGHT) => {
                Err(MpmError::InvalidParameter {
                    name: "gamma",
                    value: gamma,
                    reason: "the ghost-penalty weight must lie in (0, 1e6] (MAX_PENALTY_WEIGHT)",
                })
            }
            Stabilization::PartialLumping { threshold } if !(threshold > 0.0 && threshold <= 1.0) => {
                Err(MpmError::InvalidParameter {
                    name: "threshold",
                    value: threshold,
                    reason: "the partial-lumping threshold must lie in (0, 1]",
                })
            }
            Stabilization::LinearExtension { gamma, .. } if !(gamma > 0.0 && gamma <= MAX_PENALTY_WEIGHT) => {
                Err(MpmError::InvalidParameter {
                    name: "gamma",
                    value: gamma,
                    reason: "the linear-extension weight must lie in (0, 1e6] (MAX_PENALTY_WEIGHT)",
                })
            }
            Stabilization::LinearExtension { threshold, .. } if !(threshold > 0.0 && threshold <= 1.0) => {
                Err(MpmError::InvalidParameter {
                    name: "threshold",
                    value: threshold,
                    reason: "the linear-extension threshold must lie in (0, 1]",
                })
            }
            Stabilization::LinearExtension { threshold, onset, .. } if !(onset >= 0.0 && onset <= threshold) => {
                Err(MpmError::InvalidParameter {
                    name: "onset",
                    value: onset,
                    reason: "the linear-extension onset must lie in [0, threshold]",
                })
            }
            Stabilization::None
            | Stabilization::GhostPenalty { .. }
            | Stabilization::PartialLumping { .. }
            | Stabilization::LinearExtension { .. } => Ok(()),
        }
    }

    /// The stabilised matrix `M_s` for the consistent mass `m` (from
    /// [`super::consistent_mass`]), the lumped mass and the active-node mask; `None` when the
    /// stabilisation is [`Stabilization::None`].
    ///
    /// # Panics
    /// If the operators were never assembled, or on length mismatch.
    pub fn apply(
        &self,
        ops: &Operators,
        m: &CscMatrix<f64>,
        lumped: &[f64],
        active: &[bool],
    ) -> Option<CscMatrix<f64>> {
        match *self {
            Stabilization::None => None,
            Stabilization::GhostPenalty { gamma } => Some(m + &ghost_penalty(ops, lumped, active, gamma)),
            Stabilization::PartialLumping { threshold } => Some(partially_lumped(m, lumped, threshold)),
            Stabilization::LinearExtension {
                gamma,
                threshold,
                onset,
            } => Some(m + &extension_penalty(ops, m, lumped, active, gamma, threshold, onset)),
        }
    }
}

impl fmt::Display for Stabilization {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Stabilization::None => f.pad("none"),
            Stabilization::GhostPenalty { gamma } => names::write(f, "ghost_penalty", &[gamma]),
            Stabilization::PartialLumping { threshold } => names::write(f, "partial_lumping", &[threshold]),
            Stabilization::LinearExtension {
                gamma,
                threshold,
                onset,
            } => {
                if onset == DEFAULT_EXTENSION_ONSET {
                    names::write(f, "linear_extension", &[gamma, threshold])
                } else {
                    names::write(f, "linear_extension", &[gamma, threshold, onset])
                }
            }
        }
    }
}

impl FromStr for Stabilization {
    type Err = String;

    fn from_str(text: &str) -> std::result::Result<Stabilization, String> {
        let s = Spelled::parse(text)?;
        match s.name {
            "none" => s.no_params().map(|()| Stabilization::None),
            "ghost_penalty" => Ok(Stabilization::GhostPenalty {
                gamma: s.param(0, Some(DEFAULT_GHOST_PENALTY))?,
            }),
            "partial_lumping" => Ok(Stabilization::PartialLumping {
                threshold: s.param(0, Some(DEFAULT_LUMPING_THRESHOLD))?,
            }),
            "linear_extension" => {
                let threshold = s.param(1, Some(DEFAULT_EXTENSION_THRESHOLD))?;
                Ok(Stabilization::LinearExtension {
                    gamma: s.param(0, Some(DEFAULT_EXTENSION_WEIGHT))?,
                    threshold,
                    onset: s.param(2, Some(DEFAULT_EXTENSION_ONSET.min(threshold)))?,
                })
            }
            _ => Err(format!(
                "unknown stabilization `{text}` (none, linear_extension[:γ[:θ[:ψ₀]]], ghost_penalty[:γ], partial_lumping[:θ])"
            )),
        }
    }
}

impl names::Choice for Stabilization {
    const EXPECTING: &'static str =
        "a stabilization (none, linear_extension:γ:θ:ψ₀, ghost_penalty:γ, partial_lumping:θ)";
    const PARAMETERS: &'static [(&'static str, &'static [&'static str])] = &[
        ("ghost_penalty", &["gamma"]),
        ("partial_lumping", &["threshold"]),
        ("linear_extension", &["gamma", "threshold", "onset"]),
    ];
}

names::choice_serde!(Stabilization);

/// The 1D grid function of degree `p` centred on node 0, at `ξ` cell units from it.
fn kernel(p: usize, xi: f64) -> f64 {
    match p {
        1 => (1.0 - xi.abs()).max(0.0),
        2 => bspline::quadratic(xi),
        _ => bspline::cubic(xi),
    }
}

/// `E_ab = ∫ S(s − a) S(s − b) ds` over one knot span `[(p−1)/2, (p+1)/2]` of unit length, for
/// the `p + 1` grid functions `a, b = 0..=p` that are non-zero on it (8-point Gauss–Legendre,
/// exact for these piecewise polynomials of degree ≤ 6).
fn span_mass(p: usize) -> [[f64; 4]; 4] {
    const X: [f64; 4] = [
        0.183_434_642_495_649_8,
        0.525_532_409_916_329,
        0.796_666_477_413_626_7,
        0.960_289_856_497_536_3,
    ];
    const W: [f64; 4] = [
        0.362_683_783_378_362,
        0.313_706_645_877_887_3,
        0.222_381_034_453_374_5,
        0.101_228_536_290_376_3,
    ];
    let start = (p as f64 - 1.0) / 2.0;
    let mut e = [[0.0; 4]; 4];
    for (x, w) in X.iter().zip(W) {
        for t in [0.5 - 0.5 * x, 0.5 + 0.5 * x] {
            let s = start + t;
            for a in 0..=p {
                for b in 0..=p {
                    e[a][b] += 0.5 * w * kernel(p, s - a as f64) * kernel(p, s - b as f64);
                }
            }
        }
    }
    e
}

/// `(−1)^a C(p + 1, a)`, `a = 0..=p+1`: the jump of the `p`-th derivative across a knot, per
/// unit coefficient, of the `p + 2` grid functions that are non-zero on either side.
fn jump_coefficients(p: usize) -> [f64; 5] {
    let mut c = [0.0; 5];
    let mut binomial = 1.0;
    for a in 0..=p + 1 {
        c[a] = if a % 2 == 0 { binomial } else { -binomial };
        binomial = binomial * (p + 1 - a) as f64 / (a + 1) as f64;
    }
    c
}

/// The cells whose polynomial some particle reads, as a mask over the knot spans ("spline
/// cells") of the grid: cell `(k, l)` spans the grid functions of nodes `k..=k+p` along x and
/// `l..=l+p` along y. A particle reads the cell holding it; a GIMP particle, every bilinear
/// cell its domain overlaps.
fn read_cells(ops: &Operators, grid: &Grid, p: usize) -> (Vec<bool>, [usize; 2]) {
    let [nx, ny] = grid.nodes_per_axis();
    let dims = [nx - p, ny - p];
    let mut read = vec![false; dims[0] * dims[1]];
    let gimp = matches!(ops.shape_function(), ShapeFunction::Gimp { .. });
    for q in 0..ops.num_particles() {
        // Rows ascend, so the first is the stencil's lower-left node in either numbering.
        let Some((first, ..)) = ops.column(q).next() else {
            continue;
        };
        let (fx, fy) = grid.node_ij(first);
        if !gimp {
            read[fy * dims[0] + fx] = true;
            continue;
        }
        // Along each axis, the stencil nodes with weight: a cell is overlapped when both its
        // nodes carry weight.
        let (mut wx, mut wy) = ([false; 3], [false; 3]);
        for (node, n, _, _) in ops.column(q) {
            if n > 0.0 {
                let (i, j) = grid.node_ij(node);
                wx[i - fx] = true;
                wy[j - fy] = true;
            }
        }
        for a in 0..2 {
            for b in 0..2 {
                if wx[a] && wx[a + 1] && wy[b] && wy[b + 1] {
                    read[(fy + b) * dims[0] + fx + a] = true;
                }
            }
        }
    }
    (read, dims)
}

/// The ghost-penalty matrix (n × n, symmetric positive semi-definite, zero on polynomials of
/// the kernel's degree p):
///
/// ```text
/// P = γ Σ_F m_F Σ_{a,a'} Σ_{b,b'} c_a c_a' E_bb' e_(a,b) e_(a',b')ᵀ
/// ```
///
/// over the faces F between two cells that particles read, at least one of which has a cell
/// around it (of its eight neighbours) that no particle reads. `c_a = (−1)^a C(p+1, a)` are
/// the jump coefficients of the `p + 2` nodes across the face, `E` the mass of the `p + 1` grid
/// functions along it over one span, and `m_F` the largest lumped mass on the face's stencil
/// (a full node's mass, `≈ ρ hx hy`): the face integral `γ ρ h_n^{2p+1} ∫_F [∂ⁿ_p u]²` in the
/// nodal values. Faces whose stencil holds an inactive node (`active[I]` false) are skipped.
///
/// # Panics
/// If the operators were never assembled, or `lumped` / `active` do not have one entry per node.
pub fn ghost_penalty(ops: &Operators, lumped: &[f64], active: &[bool], gamma: f64) -> CscMatrix<f64> {
    let grid = ops.grid().expect("operators assembled on a grid");
    let n = ops.num_nodes();
    assert!(
        lumped.len() == n && active.len() == n,
        "one lumped mass and one flag per node"
    );
    let p = ops.shape_function().degree();
    let (read, dims) = read_cells(ops, grid, p);
    let is_read = |k: isize, l: isize| {
        k >= 0 && l >= 0 && (k as usize) < dims[0] && (l as usize) < dims[1] && read[l as usize * dims[0] + k as usize]
    };
    let on_boundary = |k: usize, l: usize| {
        let (k, l) = (k as isize, l as isize);
        (-1..=1).any(|dk| (-1..=1).any(|dl| !is_read(k + dk, l + dl)))
    };
    let e = span_mass(p);
    let c = jump_coefficients(p);
    let mut coo = CooMatrix::new(n, n);
    let mut stencil = Vec::with_capacity(20);
    // axis 0: faces normal to x, between cells (k, l) and (k + 1, l); axis 1: normal to y.
    for axis in 0..2 {
        let (dk, dl) = if axis == 0 { (1, 0) } else { (0, 1) };
        for l in 0..dims[1] - dl {
            for k in 0..dims[0] - dk {
                if !(read[l * dims[0] + k] && read[(l + dl) * dims[0] + k + dk]) {
                    continue;
                }
                if !(on_boundary(k, l) || on_boundary(k + dk, l + dl)) {
                    continue;
                }
                // Node (normal a, tangential b) of the face's stencil.
                stencil.clear();
                for a in 0..p + 2 {
                    for b in 0..p + 1 {
                        let (i, j) = if axis == 0 { (k + a, l + b) } else { (k + b, l + a) };
                        stencil.push((grid.node_index(i, j), a, b));
                    }
                }
                if stencil.iter().any(|&(node, _, _)| !active[node]) {
                    continue;
                }
                let m_face = stencil.iter().map(|&(node, _, _)| lumped[node]).fold(0.0, f64::max);
                let w = gamma * m_face;
                for &(r, a, b) in &stencil {
                    for &(s, a2, b2) in &stencil {
                        coo.push(r, s, w * c[a] * c[a2] * e[b][b2]);
                    }
                }
            }
        }
    }
    CscMatrix::from(&coo)
}

/// The consistent mass `m` partially lumped at nodes with little mass relative to their
/// neighbours (same pattern, row sums kept):
///
/// ```text
/// M'_IJ = s_IJ M_IJ  (I ≠ J),   M'_II = M_II + Σ_{J≠I} (1 − s_IJ) M_IJ,
/// s_IJ = min(1, min(φ_I, φ_J)/θ),   φ_I = m_L,I / max_{J: M_IJ stored} m_L,J
/// ```
///
/// # Panics
/// If `m` is not square or `lumped` does not have one entry per row.
pub fn partially_lumped(m: &CscMatrix<f64>, lumped: &[f64], threshold: f64) -> CscMatrix<f64> {
    let n = m.nrows();
    assert!(
        m.ncols() == n && lumped.len() == n,
        "a square matrix and one lumped mass per node"
    );
    let mut phi = vec![0.0; n];
    for (j, col) in m.col_iter().enumerate() {
        let heaviest = col.row_indices().iter().map(|&i| lumped[i]).fold(lumped[j], f64::max);
        phi[j] = if heaviest > 0.0 { lumped[j] / heaviest } else { 1.0 };
    }
    let mut out = m.clone();
    let mut moved = vec![0.0; n];
    let (offsets, rows, values) = out.csc_data_mut();
    for j in 0..n {
        for e in offsets[j]..offsets[j + 1] {
            let i = rows[e];
            if i != j {
                let s = (phi[i].min(phi[j]) / threshold).min(1.0);
                moved[j] += (1.0 - s) * values[e];
                values[e] *= s;
            }
        }
    }
    for j in 0..n {
        if moved[j] != 0.0 {
            if let Some(e) = (offsets[j]..offsets[j + 1]).find(|&e| rows[e] == j) {
                values[e] += moved[j];
            }
        }
    }
    out
}
