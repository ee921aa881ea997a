//! How a body's shape is filled with particles: the regular lattice, a jittered lattice, or
//! Poisson-disk sampling, the last two from a seed and the same on every machine (integer
//! arithmetic for the random numbers; additions, products, quotients and square roots only,
//! which IEEE 754 rounds the same everywhere).
//!
//! - `regular`: the centres of the `n × n` sub-cells of every grid cell (`n` =
//!   `particles_per_cell`), volume `d_x d_y` each (`d = h/n`).
//! - `jittered`: each sub-cell's point moved to a uniform random place in its sub-cell; kept when
//!   the shape holds it, with the sub-cell's volume `d_x d_y` (so the expected total volume is
//!   the shape's area).
//! - `poisson_disk`: Bridson's (2007) dart throwing, no two particles closer than
//!   `r = 0.79 √(d_x d_y)` (the radius at which the sampling has one particle per
//!   sub-cell), grown from the first lattice point of every part of the shape not yet covered;
//!   each particle's volume is the body's area as the regular lattice measures it (its count
//!   times `d_x d_y`) over the number of particles.

use serde::{Deserialize, Serialize};

use super::Geometry;
use crate::grid::Grid;

/// The sampling of a body's shape.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Sampling {
    /// The regular lattice (sub-cell centres).
    #[default]
    Regular,
    /// One point at a uniform random place in each sub-cell.
    Jittered,
    /// Poisson-disk sampling at about one particle per sub-cell.
    PoissonDisk,
}

impl Sampling {
    /// Whether this is the default, [`Sampling::Regular`].
    pub fn is_regular(&self) -> bool {
        *self == Sampling::Regular
    }
}

/// The Poisson-disk radius over the sub-cell spacing `√(d_x d_y)`.
pub const POISSON_DISK_RADIUS: f64 = 0.79;

/// Attempts around each active point before it is retired (Bridson's `k`).
const ATTEMPTS: usize = 30;

/// SplitMix64: a 64-bit generator whose every output is a fixed function of its seed.
#[derive(Debug, Clone)]
pub struct SplitMix64(u64);

impl SplitMix64 {
    /// A generator from `seed`.
    pub fn new(seed: u64) -> SplitMix64 {
        SplitMix64(seed)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// A uniform number in `[0, 1)` (53 random bits).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

/// The generator of lattice site `(i, j)` under `seed`: independent of the order sites are
/// visited in.
fn site_rng(seed: u64, i: usize, j: usize) -> SplitMix64 {
    let mut g = SplitMix64::new(seed ^ (i as u64).wrapping_mul(0xD1B5_4A32_D192_ED03));
    let k = g.next_u64() ^ (j as u64).wrapping_mul(0x8CB9_2BA7_2F3D_8DD7);
    SplitMix64::new(k)
}

/// The particles of `geometry` (not a particle file) on `grid` with `per_cell` particles per
/// cell and axis: positions and volumes.
pub fn sample(
    geometry: &Geometry,
    grid: &Grid,
    per_cell: usize,
    sampling: Sampling,
    seed: u64,
) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let bounds = geometry.bounding_box().map(|(lo, hi)| [lo, hi]);
    let inside = |x: f64, y: f64| geometry.contains(x, y);
    let n = per_cell.max(1);
    let [hx, hy] = grid.cell_size();
    let (dx, dy) = (hx / n as f64, hy / n as f64);
    match sampling {
        Sampling::Regular => {
            let (x, y, volume) = crate::particles::lattice_within(grid, n, bounds, inside);
            let v = vec![volume; x.len()];
            (x, y, v)
        }
        Sampling::Jittered => {
            let [ox, oy] = grid.origin();
            let (mut x, mut y) = (Vec::new(), Vec::new());
            for_sites(grid, n, bounds, |i, j| {
                let mut g = site_rng(seed, i, j);
                let px = ox + (i as f64 + g.uniform()) * dx;
                let py = oy + (j as f64 + g.uniform()) * dy;
                if inside(px, py) {
                    x.push(px);
                    y.push(py);
                }
            });
            let v = vec![dx * dy; x.len()];
            (x, y, v)
        }
        Sampling::PoissonDisk => {
            let (lx, ly, volume) = crate::particles::lattice_within(grid, n, bounds, inside);
            let area = lx.len() as f64 * volume;
            let r = POISSON_DISK_RADIUS * (dx * dy).sqrt();
            let (x, y) = poisson_disk(&lx, &ly, r, bounds, &inside, seed);
            let v = vec![if x.is_empty() { 0.0 } else { area / x.len() as f64 }; x.len()];
            (x, y, v)
        }
    }
}

/// Calls `f(i, j)` for every sub-cell the box can hold (the grid's whole lattice for `None`),
/// row by row, as [`crate::particles::lattice_within`] visits them.
fn for_sites(grid: &Grid, n: usize, bounds: Option<[[f64; 2]; 2]>, mut f: impl FnMut(usize, usize)) {
    let (is, js) = crate::particles::lattice_ranges(grid, n, bounds);
    for j in js {
        for i in is.clone() {
            f(i, j);
        }
    }
}

/// Bridson's Poisson-disk sampling with radius `r` inside `inside`, grown from the lattice
/// points `(lx, ly)` in order (each one not within `r` of a particle starts a new front).
fn poisson_disk(
    lx: &[f64],
    ly: &[f64],
    r: f64,
    bounds: Option<[[f64; 2]; 2]>,
    inside: &dyn Fn(f64, f64) -> bool,
    seed: u64,
) -> (Vec<f64>, Vec<f64>) {
    let (mut x, mut y) = (Vec::new(), Vec::new());
    let Some([lo, hi]) = bounds else {
        return (x, y);
    };
    // A background grid of cells of side r/√2: each holds at most one particle.
    let cell = r / std::f64::consts::SQRT_2;
    let nx = (((hi[0] - lo[0]) / cell).ceil() as usize).max(1) + 1;
    let ny = (((hi[1] - lo[1]) / cell).ceil() as usize).max(1) + 1;
    let mut owner = vec![u32::MAX; nx * ny];
    let index = |px: f64, py: f64| -> Option<(usize, usize)> {
        let (u, v) = ((px - lo[0]) / cell, (py - lo[1]) / cell);
        (u >= 0.0 && v >= 0.0 && u < nx as f64 && v < ny as f64).then_some((u as usize, v as usize))
    };
    let r2 = r * r;
    let free = |x: &[f64], y: &[f64], owner: &[u32], px: f64, py: f64| -> bool {
        let Some((ci, cj)) = index(px, py) else {
            return false;
        };
        for j in cj.saturating_sub(2)..(cj + 3).min(ny) {
            for i in ci.saturating_sub(2)..(ci + 3).min(nx) {
                let k = owner[j * nx + i];
                if k != u32::MAX {
                    let (ex, ey) = (x[k as usize] - px, y[k as usize] - py);
                    if ex * ex + ey * ey < r2 {
                        return false;
                    }
                }
            }
        }
        true
    };
    let mut rng = SplitMix64::new(seed ^ 0x005E_ED0F_D15C);
    let mut active: Vec<usize> = Vec::new();
    for (&sx, &sy) in lx.iter().zip(ly) {
        if !free(&x, &y, &owner, sx, sy) {
            continue;
        }
        let add = |x: &mut Vec<f64>, y: &mut Vec<f64>, owner: &mut [u32], px: f64, py: f64| {
            let (ci, cj) = index(px, py).expect("checked free");
            owner[cj * nx + ci] = x.len() as u32;
            x.push(px);
            y.push(py);
            x.len() - 1
        };
        active.push(add(&mut x, &mut y, &mut owner, sx, sy));
        while !active.is_empty() {
            // The active point: a random one, swapped out when it is retired.
            let a = (rng.next_u64() % active.len() as u64) as usize;
            let (ax, ay) = (x[active[a]], y[active[a]]);
            let mut placed = false;
            for _ in 0..ATTEMPTS {
                // A uniform point of the ring r ≤ |d| < 2r, by rejection from its square.
                let (dx, dy) = loop {
                    let (u, v) = (4.0 * rng.uniform() - 2.0, 4.0 * rng.uniform() - 2.0);
                    let q = u * u + v * v;
                    if (1.0..4.0).contains(&q) {
                        break (u * r, v * r);
                    }
                };
                let (px, py) = (ax + dx, ay + dy);
                if inside(px, py) && free(&x, &y, &owner, px, py) {
                    active.push(add(&mut x, &mut y, &mut owner, px, py));
                    placed = true;
                    break;
                }
            }
            if !placed {
                active.swap_remove(a);
            }
        }
    }
    (x, y)
}
