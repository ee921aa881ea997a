//! Shared fixtures and independent reference implementations for the integration tests.
//!
//! Nothing here calls the shape-function or operator code of the library: the reference
//! operators are built from a tent function written below, a node numbering written from the
//! formulas in the `grid` module docs, and a plain loop over every (node, particle) pair.
//! Only the grid's plain accessors (`origin`, `cell_size`, `cells`, `node_order`, `bounds`)
//! are used, because they are the parameters the grid was built from.
#![allow(dead_code)]

use nalgebra::{DMatrix, DVector};

pub mod scratch;
#[allow(unused_imports)]
pub use scratch::unique_temp_dir;
use sparse_mpm::{Grid, NodeOrder, Particles};

// ---------------------------------------------------------------------------------------------
// The seed assignment
// ---------------------------------------------------------------------------------------------

/// Seed node x coordinates `x_g`: 3 × 2 nodes listed y-fastest.
pub const SEED_NODE_X: [f64; 6] = [0.0, 0.0, 1.0, 1.0, 2.0, 2.0];
/// Seed node y coordinates `y_g`.
pub const SEED_NODE_Y: [f64; 6] = [0.0, 1.0, 0.0, 1.0, 0.0, 1.0];
/// Seed particle x coordinates.
pub const SEED_PARTICLE_X: [f64; 4] = [1.2, 1.7, 1.3, 1.8];
/// Seed particle y coordinates.
pub const SEED_PARTICLE_Y: [f64; 4] = [0.75, 0.81, 0.26, 0.24];
/// Seed particle mass (every particle).
pub const SEED_MASS: f64 = 1.0;
/// Seed particle volume (every particle).
pub const SEED_VOLUME: f64 = 2.0;

/// The seed grid, recovered from the seed's node coordinate lists.
pub fn seed_grid() -> Grid {
    Grid::from_node_coordinates(&SEED_NODE_X, &SEED_NODE_Y).expect("the seed nodes form a uniform grid")
}

/// The seed's four particles: mass 1, volume 2, at rest, stress-free.
pub fn seed_particles() -> Particles {
    Particles::new(
        SEED_PARTICLE_X.to_vec(),
        SEED_PARTICLE_Y.to_vec(),
        vec![SEED_MASS; 4],
        vec![SEED_VOLUME; 4],
    )
    .expect("the seed particles are valid")
}

// ---------------------------------------------------------------------------------------------
// Grids used by the property tests
// ---------------------------------------------------------------------------------------------

/// A family of grids covering both node orders, square and non-square cells, zero and
/// non-zero origins, a single cell, and cell sizes that are not exactly representable.
///
/// The non-representable grid (hx = 0.3, hy = 0.7) is chosen so that `x₀ + cx·hx` maps back
/// to exactly `cx` cell units; see the `shape_functions` tests for a grid where it does not.
pub fn test_grids() -> Vec<Grid> {
    let g = |origin, size, cells, order| {
        Grid::new(origin, size, cells)
            .expect("test grid parameters are valid")
            .with_node_order(order)
    };
    vec![
        seed_grid(),
        g([0.0, 0.0], [0.5, 0.5], [4, 3], NodeOrder::XFastest),
        g([0.0, 0.0], [0.5, 0.5], [4, 3], NodeOrder::YFastest),
        g([-1.5, 2.0], [0.25, 0.75], [3, 5], NodeOrder::YFastest),
        g([-1.5, 2.0], [0.25, 0.75], [3, 5], NodeOrder::XFastest),
        g([0.1, -0.35], [0.3, 0.7], [5, 2], NodeOrder::XFastest),
        g([0.1, -0.35], [0.3, 0.7], [5, 2], NodeOrder::YFastest),
        g([3.0, -4.0], [2.0, 0.5], [1, 1], NodeOrder::XFastest),
    ]
}

// ---------------------------------------------------------------------------------------------
// Reference node numbering (from the formulas in the grid module docs)
// ---------------------------------------------------------------------------------------------

/// Number of nodes `(cx + 1)(cy + 1)`.
pub fn ref_num_nodes(grid: &Grid) -> usize {
    let [cx, cy] = grid.cells();
    (cx + 1) * (cy + 1)
}

/// Node number of node `(i, j)`: `i + j (cx + 1)` x-fastest, `j + i (cy + 1)` y-fastest.
pub fn ref_node_id(grid: &Grid, i: usize, j: usize) -> usize {
    let [cx, cy] = grid.cells();
    match grid.node_order() {
        NodeOrder::XFastest => i + j * (cx + 1),
        NodeOrder::YFastest => j + i * (cy + 1),
    }
}

/// `(i, j)` of node `id`.
pub fn ref_node_ij(grid: &Grid, id: usize) -> (usize, usize) {
    let [cx, cy] = grid.cells();
    match grid.node_order() {
        NodeOrder::XFastest => (id % (cx + 1), id / (cx + 1)),
        NodeOrder::YFastest => (id / (cy + 1), id % (cy + 1)),
    }
}

/// Position `(x₀ + i hx, y₀ + j hy)` of node `id`.
pub fn ref_node_position(grid: &Grid, id: usize) -> [f64; 2] {
    let (i, j) = ref_node_ij(grid, id);
    let ([x0, y0], [hx, hy]) = (grid.origin(), grid.cell_size());
    [x0 + i as f64 * hx, y0 + j as f64 * hy]
}

/// x and y coordinates of all nodes, in node order.
pub fn ref_node_coordinates(grid: &Grid) -> (Vec<f64>, Vec<f64>) {
    (0..ref_num_nodes(grid))
        .map(|k| {
            let [x, y] = ref_node_position(grid, k);
            (x, y)
        })
        .unzip()
}

// ---------------------------------------------------------------------------------------------
// Reference tent function and operators
// ---------------------------------------------------------------------------------------------

/// The 1D tent `S(ξ) = max(0, 1 − |ξ|)`.
pub fn tent(xi: f64) -> f64 {
    (1.0 - xi.abs()).max(0.0)
}

/// Right-hand derivative of the tent per unit ξ: `+1` on `[−1, 0)`, `−1` on `[0, 1)`, else 0.
pub fn tent_slope_right(xi: f64) -> f64 {
    if (-1.0..0.0).contains(&xi) {
        1.0
    } else if (0.0..1.0).contains(&xi) {
        -1.0
    } else {
        0.0
    }
}

/// Left-hand derivative of the tent per unit ξ: `+1` on `(−1, 0]`, `−1` on `(0, 1]`, else 0.
pub fn tent_slope_left(xi: f64) -> f64 {
    if xi > -1.0 && xi <= 0.0 {
        1.0
    } else if xi > 0.0 && xi <= 1.0 {
        -1.0
    } else {
        0.0
    }
}

/// Value and derivative per unit ξ of the 1D tent of grid line `i` at cell coordinate `s`
/// (`s = (x − x₀)/h`, so `ξ = s − i`) on an axis with `cells` cells, or `None` outside
/// `[0, cells]`. The derivative is right-hand except on the last grid line, where the point
/// belongs to the last cell and the derivative is left-hand.
pub fn ref_axis(s: f64, i: usize, cells: usize) -> Option<(f64, f64)> {
    if !(s >= 0.0 && s <= cells as f64) {
        return None;
    }
    let xi = s - i as f64;
    let slope = if s == cells as f64 {
        tent_slope_left(xi)
    } else {
        tent_slope_right(xi)
    };
    Some((tent(xi), slope))
}

/// Reference `(N_I, ∂N_I/∂x, ∂N_I/∂y)` of node `node` at `(x, y)`; zeros outside the grid.
pub fn ref_shape(grid: &Grid, node: usize, x: f64, y: f64) -> (f64, f64, f64) {
    let (i, j) = ref_node_ij(grid, node);
    let ([x0, y0], [hx, hy], [cx, cy]) = (grid.origin(), grid.cell_size(), grid.cells());
    let (s, t) = ((x - x0) / hx, (y - y0) / hy);
    match (ref_axis(s, i, cx), ref_axis(t, j, cy)) {
        (Some((vx, dx)), Some((vy, dy))) => (vx * vy, dx / hx * vy, vx * dy / hy),
        _ => (0.0, 0.0, 0.0),
    }
}

/// Dense reference operators N, Gx, Gy (n × P) by a loop over every (node, particle) pair.
pub struct DenseOperators {
    pub n: DMatrix<f64>,
    pub gx: DMatrix<f64>,
    pub gy: DMatrix<f64>,
}

/// Builds the dense reference N, Gx, Gy for particles at `(x[p], y[p])`.
pub fn ref_operators(grid: &Grid, x: &[f64], y: &[f64]) -> DenseOperators {
    assert_eq!(x.len(), y.len());
    let (n, np) = (ref_num_nodes(grid), x.len());
    let mut out = DenseOperators {
        n: DMatrix::zeros(n, np),
        gx: DMatrix::zeros(n, np),
        gy: DMatrix::zeros(n, np),
    };
    for p in 0..np {
        for node in 0..n {
            let (v, dx, dy) = ref_shape(grid, node, x[p], y[p]);
            out.n[(node, p)] = v;
            out.gx[(node, p)] = dx;
            out.gy[(node, p)] = dy;
        }
    }
    out
}

/// The nodes of the cell a point belongs to (cells half-open, last cell closed), ascending:
/// the sparsity pattern of the point's column.
pub fn ref_support(grid: &Grid, x: f64, y: f64) -> Vec<usize> {
    let ([x0, y0], [hx, hy], [cx, cy]) = (grid.origin(), grid.cell_size(), grid.cells());
    let ci = (((x - x0) / hx).floor() as usize).min(cx - 1);
    let cj = (((y - y0) / hy).floor() as usize).min(cy - 1);
    let mut nodes = vec![
        ref_node_id(grid, ci, cj),
        ref_node_id(grid, ci + 1, cj),
        ref_node_id(grid, ci, cj + 1),
        ref_node_id(grid, ci + 1, cj + 1),
    ];
    nodes.sort_unstable();
    nodes
}

/// Largest absolute entry of a matrix (0 for an empty one).
pub fn max_abs(m: &DMatrix<f64>) -> f64 {
    m.iter().fold(0.0, |a: f64, v| a.max(v.abs()))
}

/// Largest absolute entrywise difference of two equally sized matrices.
pub fn max_abs_diff(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
    assert_eq!(a.shape(), b.shape(), "matrix shapes differ");
    a.iter().zip(b.iter()).fold(0.0, |m: f64, (x, y)| m.max((x - y).abs()))
}

/// Largest absolute entrywise difference of two equally long slices.
pub fn max_abs_diff_slice(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len(), "slice lengths differ");
    a.iter().zip(b).fold(0.0, |m: f64, (x, y)| m.max((x - y).abs()))
}

/// A dense column vector from a slice.
pub fn dvec(v: &[f64]) -> DVector<f64> {
    DVector::from_column_slice(v)
}

// ---------------------------------------------------------------------------------------------
// Deterministic pseudo-random numbers and particles
// ---------------------------------------------------------------------------------------------

/// A 64-bit linear congruential generator (Knuth's MMIX constants); the top 53 bits give
/// uniform doubles. Deterministic, so every test sees the same configuration on every run.
#[derive(Debug, Clone)]
pub struct Lcg(u64);

impl Lcg {
    const A: u64 = 6_364_136_223_846_793_005;
    const C: u64 = 1_442_695_040_888_963_407;

    pub fn new(seed: u64) -> Lcg {
        let mut lcg = Lcg(seed ^ 0x9E37_79B9_7F4A_7C15);
        lcg.next_u64();
        lcg
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_mul(Self::A).wrapping_add(Self::C);
        self.0
    }

    /// Uniform in `[0, 1)`.
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in `[lo, hi)`.
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }

    /// Uniform integer in `0..n`.
    pub fn below(&mut self, n: usize) -> usize {
        ((self.next_u64() >> 33) % n as u64) as usize
    }
}

/// The x coordinate of vertical grid line `i` (`i = cx` is the right boundary).
pub fn grid_line_x(grid: &Grid, i: usize) -> f64 {
    grid.origin()[0] + i as f64 * grid.cell_size()[0]
}

/// The y coordinate of horizontal grid line `j` (`j = cy` is the top boundary).
pub fn grid_line_y(grid: &Grid, j: usize) -> f64 {
    grid.origin()[1] + j as f64 * grid.cell_size()[1]
}

/// `count` deterministic positions in the closed rectangle of `grid`.
///
/// The first ones (as many as `count` allows) are the special cases: the four corners, a
/// point on each outer edge, an interior node (when there is one) and points on an interior
/// vertical and horizontal grid line. The rest are drawn at random: mostly uniform in the
/// rectangle, some on a random grid line (interior or boundary), some on a random node, some
/// on the outer boundary.
pub fn random_positions(grid: &Grid, count: usize, seed: u64) -> (Vec<f64>, Vec<f64>) {
    let mut rng = Lcg::new(seed);
    let [cx, cy] = grid.cells();
    let [x0, x1, y0, y1] = grid.bounds();
    let mut special = vec![(x0, y0), (x1, y0), (x0, y1), (x1, y1)];
    special.push((rng.range(x0, x1), y0));
    special.push((rng.range(x0, x1), y1));
    special.push((x0, rng.range(y0, y1)));
    special.push((x1, rng.range(y0, y1)));
    if cx > 1 && cy > 1 {
        special.push((
            grid_line_x(grid, 1 + rng.below(cx - 1)),
            grid_line_y(grid, 1 + rng.below(cy - 1)),
        ));
    }
    if cx > 1 {
        special.push((grid_line_x(grid, 1 + rng.below(cx - 1)), rng.range(y0, y1)));
    }
    if cy > 1 {
        special.push((rng.range(x0, x1), grid_line_y(grid, 1 + rng.below(cy - 1))));
    }
    special.truncate(count);
    let mut points = special;
    while points.len() < count {
        let point = match rng.below(10) {
            0 => (grid_line_x(grid, rng.below(cx + 1)), rng.range(y0, y1)),
            1 => (rng.range(x0, x1), grid_line_y(grid, rng.below(cy + 1))),
            2 => (
                grid_line_x(grid, rng.below(cx + 1)),
                grid_line_y(grid, rng.below(cy + 1)),
            ),
            3 => match rng.below(4) {
                0 => (x0, rng.range(y0, y1)),
                1 => (x1, rng.range(y0, y1)),
                2 => (rng.range(x0, x1), y0),
                _ => (rng.range(x0, x1), y1),
            },
            _ => (rng.range(x0, x1), rng.range(y0, y1)),
        };
        points.push(point);
    }
    points.into_iter().unzip()
}

/// `count` uniformly random positions strictly inside cells, at least `margin` cell units
/// away from every grid line (for finite differences that must not cross a kink).
pub fn positions_off_grid_lines(grid: &Grid, count: usize, margin: f64, seed: u64) -> (Vec<f64>, Vec<f64>) {
    let mut rng = Lcg::new(seed);
    let ([x0, y0], [hx, hy], [cx, cy]) = (grid.origin(), grid.cell_size(), grid.cells());
    (0..count)
        .map(|_| {
            let s = rng.below(cx) as f64 + rng.range(margin, 1.0 - margin);
            let t = rng.below(cy) as f64 + rng.range(margin, 1.0 - margin);
            (x0 + s * hx, y0 + t * hy)
        })
        .unzip()
}

/// `per_axis × per_axis` particles in every cell of `grid`, at the regular sub-cell positions
/// `(k + ½)/per_axis` each moved by a random offset of up to `jitter` sub-cell widths, so that
/// they are in general position (no two on a line) and never on a grid line.
pub fn positions_per_cell(grid: &Grid, per_axis: usize, jitter: f64, seed: u64) -> (Vec<f64>, Vec<f64>) {
    positions_per_cell_in(grid, (0..grid.cells()[0]).collect(), per_axis, jitter, seed)
}

/// As [`positions_per_cell`], but only in the cell columns `columns` (so the other cells stay
/// empty and their nodes inactive).
pub fn positions_per_cell_in(
    grid: &Grid,
    columns: Vec<usize>,
    per_axis: usize,
    jitter: f64,
    seed: u64,
) -> (Vec<f64>, Vec<f64>) {
    assert!(jitter < 0.5, "jitter must keep particles inside their sub-cell");
    let mut rng = Lcg::new(seed);
    let ([x0, y0], [hx, hy], [_, cy]) = (grid.origin(), grid.cell_size(), grid.cells());
    let k = per_axis as f64;
    let mut xs = Vec::new();
    let mut ys = Vec::new();
    for &ci in &columns {
        for cj in 0..cy {
            for a in 0..per_axis {
                for b in 0..per_axis {
                    let s = ci as f64 + (a as f64 + 0.5 + rng.range(-jitter, jitter)) / k;
                    let t = cj as f64 + (b as f64 + 0.5 + rng.range(-jitter, jitter)) / k;
                    xs.push(x0 + s * hx);
                    ys.push(y0 + t * hy);
                }
            }
        }
    }
    (xs, ys)
}

/// Random particles at the given positions: masses in `[0.5, 2)`, volumes in `[0.1, 0.5)`,
/// velocities in `[−1, 1)`, stresses in `[−100, 100)`, body forces in `[−10, 10)`.
pub fn random_particles_at(x: Vec<f64>, y: Vec<f64>, seed: u64) -> Particles {
    let mut rng = Lcg::new(seed.wrapping_add(0x5EED));
    let np = x.len();
    let mut draw = |lo: f64, hi: f64| -> Vec<f64> { (0..np).map(|_| rng.range(lo, hi)).collect() };
    let mass = draw(0.5, 2.0);
    let volume = draw(0.1, 0.5);
    let (vx, vy) = (draw(-1.0, 1.0), draw(-1.0, 1.0));
    let (sxx, syy, sxy) = (draw(-100.0, 100.0), draw(-100.0, 100.0), draw(-100.0, 100.0));
    let (bx, by) = (draw(-10.0, 10.0), draw(-10.0, 10.0));
    Particles::new(x, y, mass, volume)
        .and_then(|p| p.with_velocity(vx, vy))
        .and_then(|p| p.with_stress(sxx, syy, sxy))
        .and_then(|p| p.with_body_force(bx, by))
        .expect("random particle values are valid")
}

/// `count` random particles in `grid` (positions from [`random_positions`], including grid
/// lines and the outer boundary; other fields from [`random_particles_at`]).
pub fn random_particles(grid: &Grid, count: usize, seed: u64) -> Particles {
    let (x, y) = random_positions(grid, count, seed);
    random_particles_at(x, y, seed)
}

// ---------------------------------------------------------------------------------------------
// Runs compared bit for bit
// ---------------------------------------------------------------------------------------------

/// Every particle field and every report field as bits.
pub fn fingerprint(p: &Particles, reports: &[sparse_mpm::simulation::StepReport]) -> Vec<u64> {
    let mut bits = Vec::new();
    for field in [
        &p.x,
        &p.y,
        &p.vx,
        &p.vy,
        &p.sxx,
        &p.syy,
        &p.sxy,
        &p.volume,
        &p.fxx,
        &p.fxy,
        &p.fyx,
        &p.fyy,
        &p.affine_xx,
        &p.affine_xy,
        &p.affine_yx,
        &p.affine_yy,
    ] {
        bits.extend(field.iter().map(|v| v.to_bits()));
    }
    bits.extend(p.id.iter().map(|&i| i as u64));
    for r in reports {
        for v in [
            r.dt,
            r.kinetic_energy,
            r.strain_energy,
            r.potential_energy,
            r.momentum[0],
            r.momentum[1],
            r.angular_momentum,
            r.grid_angular_momentum,
            r.grid_kinetic_energy_lumped,
            r.grid_kinetic_energy_consistent,
            r.transfer_loss,
            r.max_speed,
        ] {
            bits.push(v.to_bits());
        }
    }
    bits
}
