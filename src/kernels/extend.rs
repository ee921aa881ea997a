//! (8b): the massless nodes in a particle's support take their particles' mean velocity.

use crate::fields::VectorField;
use crate::operators::Operators;

/// Work arrays of [`extend_to_inactive_nodes`], kept between calls so that it allocates
/// nothing once they have grown to the node count.
#[derive(Debug, Clone, Default)]
pub struct ExtensionScratch {
    sum: VectorField,
    count: Vec<u32>,
}

impl ExtensionScratch {
    /// Work arrays already sized for `num_nodes` nodes.
    pub fn new(num_nodes: usize) -> ExtensionScratch {
        ExtensionScratch {
            sum: VectorField::zeros(num_nodes),
            count: vec![0; num_nodes],
        }
    }
}

/// Gives the inactive nodes in some particle's support the mean interpolated velocity of those
/// particles ([`crate::transfer::extend_to_massless_nodes`]), with the active nodes as a mask
/// (`is_active[I]`) and reused work arrays:
///
/// ```text
/// v_I = (1/|P_I|) Σ_{p ∈ P_I} (Nᵀ v)_p     for inactive I,   P_I = {p : I in the support of p}
/// ```
///
/// Only the columns of particles that touch an inactive node are visited; returns whether any
/// node was changed.
///
/// # Panics
/// If `v` or `is_active` does not have one entry per node.
pub fn extend_to_inactive_nodes(
    ops: &Operators,
    is_active: &[bool],
    v: &mut VectorField,
    scratch: &mut ExtensionScratch,
) -> bool {
    let n = ops.num_nodes();
    assert!(
        v.len() == n && is_active.len() == n,
        "one velocity and one flag per node"
    );
    let any = crate::with_support!(ops, extend_columns::<S>(ops, is_active, v, scratch));
    if any {
        for i in 0..n {
            if scratch.count[i] > 0 {
                let c = scratch.count[i] as f64;
                v.x[i] = scratch.sum.x[i] / c;
                v.y[i] = scratch.sum.y[i] / c;
            }
        }
    }
    any
}

/// The particle loop of [`extend_to_inactive_nodes`]: sums and counts into the scratch; whether
/// any particle touches an inactive node.
fn extend_columns<const S: usize>(
    ops: &Operators,
    is_active: &[bool],
    v: &VectorField,
    scratch: &mut ExtensionScratch,
) -> bool {
    let n = ops.num_nodes();
    let mut any = false;
    for p in 0..ops.num_particles() {
        let st = ops.stencil::<S>(p);
        let all_active = (0..S).all(|b| {
            let (start, _) = st.n_row(b);
            is_active[start..start + S].iter().all(|&x| x)
        });
        if all_active {
            continue;
        }
        if !any {
            scratch.sum.x.clear();
            scratch.sum.x.resize(n, 0.0);
            scratch.sum.y.clear();
            scratch.sum.y.resize(n, 0.0);
            scratch.count.clear();
            scratch.count.resize(n, 0);
            any = true;
        }
        let (mut vx, mut vy) = (0.0, 0.0);
        for b in 0..S {
            let (start, nv) = st.n_row(b);
            for a in 0..S {
                vx += nv[a] * v.x[start + a];
                vy += nv[a] * v.y[start + a];
            }
        }
        for b in 0..S {
            let (start, _) = st.n_row(b);
            for a in 0..S {
                let i = start + a;
                if !is_active[i] {
                    scratch.sum.x[i] += vx;
                    scratch.sum.y[i] += vy;
                    scratch.count[i] += 1;
                }
            }
        }
    }
    any
}
