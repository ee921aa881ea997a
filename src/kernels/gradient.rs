//! (11) alone: the velocity gradient `L = [Gxᵀ u, Gyᵀ u]` at every particle, of one grid
//! velocity or (contact) of each particle's own body's.

use crate::fields::VectorField;
use crate::lanes::Real;
use crate::operators::Operators;
use crate::parallel::Workers;

/// The velocity gradient of the grid velocity `u` at every particle, into `l`:
///
/// ```text
/// Lxx = Gxᵀ ux,  Lxy = Gyᵀ ux,  Lyx = Gxᵀ uy,  Lyy = Gyᵀ uy
/// ```
///
/// # Panics
/// If `u` does not have one entry per node.
pub fn velocity_gradient_into(ops: &Operators, u: &VectorField, l: &mut [Vec<f64>; 4], workers: &Workers) {
    let np = ops.num_particles();
    assert_eq!(u.len(), ops.num_nodes(), "one velocity per node");
    for c in l.iter_mut() {
        c.resize(np, 0.0);
    }
    let mut none: Vec<()> = Vec::new();
    workers.split_blocks(l.each_mut().map(|c| &mut c[..]), &mut none, |first, out| {
        crate::with_support!(ops, gradient_block::<S>(ops, |_| u, first, out))
    });
}

/// `L += [∂N/∂x u_x, ∂N/∂y u_x; ∂N/∂x u_y, ∂N/∂y u_y]` for one node: the one definition of
/// a node's term of `L = [Gxᵀ u, Gyᵀ u]` (row-major `[xx, xy, yx, yy]`).
#[inline(always)]
fn add_gradient<R: Real>(l: &mut [R; 4], gx: R, gy: R, ux: R, uy: R) {
    l[0] = l[0] + gx * ux;
    l[1] = l[1] + gy * ux;
    l[2] = l[2] + gx * uy;
    l[3] = l[3] + gy * uy;
}

/// [`velocity_gradient_into`] with one grid velocity per body (contact, [`crate::contact`]):
/// particle `p` of body `b` reads `u[b]`, `L_p = [Gxᵀ u_b, Gyᵀ u_b]_p`.
///
/// # Panics
/// If a body has no field, or a field does not have one entry per node.
pub fn velocity_gradient_layered(
    ops: &Operators,
    u: &[&VectorField],
    body: &[usize],
    l: &mut [Vec<f64>; 4],
    workers: &Workers,
) {
    let np = ops.num_particles();
    assert!(u.iter().all(|u| u.len() == ops.num_nodes()), "one velocity per node");
    for c in l.iter_mut() {
        c.resize(np, 0.0);
    }
    let mut none: Vec<()> = Vec::new();
    workers.split_blocks(l.each_mut().map(|c| &mut c[..]), &mut none, |first, out| {
        crate::with_support!(ops, gradient_block::<S>(ops, |p| u[body[p]], first, out))
    });
}

fn gradient_block<'a, const S: usize>(
    ops: &Operators,
    field: impl Fn(usize) -> &'a VectorField,
    first: usize,
    l: [&mut [f64]; 4],
) {
    for j in 0..l[0].len() {
        let mut g = [0.0; 4];
        let u = field(first + j);
        let st = ops.stencil::<S>(first + j);
        for b in 0..S {
            let (start, _, gx, gy) = st.row(b);
            let (ux, uy) = (&u.x[start..start + S], &u.y[start..start + S]);
            for a in 0..S {
                add_gradient(&mut g, gx[a], gy[a], ux[a], uy[a]);
            }
        }
        for c in 0..4 {
            l[c][j] = g[c];
        }
    }
}
