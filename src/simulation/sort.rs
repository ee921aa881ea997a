//! The particles' order: a counting sort by the first node of their stencils, every
//! `Options::sort_interval` steps, so that the transfers find a cell's particles together.

use crate::grid::Grid;
use crate::particles::Particles;
use crate::shape::ShapeFunction;

/// The counting sort's arrays, with 32-bit indices (the operators number at most 2³² nodes; a
/// simulation of more particles than that is not sorted).
#[derive(Debug, Default)]
pub(super) struct Sorting {
    keys: Vec<u32>,
    counts: Vec<u32>,
    order: Vec<u32>,
}

impl Sorting {
    /// Arrays sized for the cells of `grid`.
    pub(super) fn for_grid(grid: &Grid) -> Sorting {
        let [cx, cy] = grid.cells();
        Sorting {
            counts: vec![0; cx * cy + 1],
            ..Sorting::default()
        }
    }
}

/// Counting sort of the particles by the first node of their stencils under `shape` (row-major
/// over the cells; particles the operators would refuse last), allocation-free: particles that
/// share a stencil come together, and so do the stencils that start on one grid line, which
/// the transfers take four at a time.
pub(super) fn sort_particles(
    grid: &Grid,
    shape: ShapeFunction,
    p: &mut Particles,
    s: &mut Sorting,
    work: &mut Vec<f64>,
) {
    let np = p.len();
    let [cx, cy] = grid.cells();
    if u32::try_from(np).is_err() || u32::try_from(cx * cy + 1).is_err() {
        return;
    }
    let frames = [shape.axis_frame(grid, 0), shape.axis_frame(grid, 1)];
    s.keys.resize(np, 0);
    s.order.resize(np, 0);
    s.counts.iter_mut().for_each(|c| *c = 0);
    for k in 0..np {
        let first = |a: usize, v: f64| frames[a].accept(v).map(|t| frames[a].locate(t).first);
        let key = match (first(0, p.x[k]), first(1, p.y[k])) {
            (Some(i), Some(j)) => j * cx + i,
            _ => cx * cy,
        };
        s.keys[k] = key.min(cx * cy) as u32;
        s.counts[s.keys[k] as usize] += 1;
    }
    let mut start = 0;
    for c in s.counts.iter_mut() {
        let n = *c;
        *c = start;
        start += n;
    }
    for k in 0..np {
        let key = s.keys[k] as usize;
        s.order[s.counts[key] as usize] = k as u32;
        s.counts[key] += 1;
    }
    p.permute_u32(&s.order, work);
}
