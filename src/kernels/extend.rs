//! (8b): the massless nodes in a particle's support take their particles' mean velocity.

use crate::fields::VectorField;
use crate::operators::Operators;

/// Work arrays of [`extend_to_inactive_nodes`], kept between calls so that it allocates
/// nothing once they have grown to the node count. Only the entries of the nodes an extension
/// reaches are written (and set back to zero after it), so a pass that extends a few nodes
/// touches a few pages.
#[derive(Debug, Clone, Default)]
pub struct ExtensionScratch {
    sum: VectorField,
    count: Vec<u32>,
    /// The nodes of the last pass with a non-zero count, each once.
    reached: Vec<usize>,
}

impl ExtensionScratch {
    /// Work arrays already sized for `num_nodes` nodes (zeroed pages, not yet touched).
    pub fn new(num_nodes: usize) -> ExtensionScratch {
        ExtensionScratch {
            sum: VectorField::zeros(num_nodes),
            count: vec![0; num_nodes],
            reached: Vec::new(),
        }
    }

    /// All-zero arrays of `n` entries.
    fn reset(&mut self, n: usize) {
        for &i in &self.reached {
            self.sum.x[i] = 0.0;
            self.sum.y[i] = 0.0;
            self.count[i] = 0;
        }
        self.reached.clear();
        if self.count.len() != n {
            *self = ExtensionScratch::new(n);
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
/// Only the columns of particles that touch an inactive node are visited (a particle's
/// stencil is checked by its first node alone); returns whether any node was changed.
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
    scratch.reset(n);
    crate::with_support!(ops, extend_columns::<S>(ops, is_active, v, scratch));
    for &i in &scratch.reached {
        let c = scratch.count[i] as f64;
        v.x[i] = scratch.sum.x[i] / c;
        v.y[i] = scratch.sum.y[i] / c;
    }
    !scratch.reached.is_empty()
}

/// The particle loop of [`extend_to_inactive_nodes`]: sums and counts into the scratch, the
/// nodes reached listed.
fn extend_columns<const S: usize>(
    ops: &Operators,
    is_active: &[bool],
    v: &VectorField,
    scratch: &mut ExtensionScratch,
) {
    let [sx, sy] = ops.strides();
    let run_stride = sx.max(sy);
    for (p, &[i, j]) in ops.first_nodes().iter().enumerate() {
        let first = i as usize * sx + j as usize * sy;
        let all_active = (0..S).all(|b| {
            let start = first + b * run_stride;
            is_active[start..start + S].iter().all(|&x| x)
        });
        if all_active {
            continue;
        }
        let st = ops.stencil::<S>(p);
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
                    if scratch.count[i] == 0 {
                        scratch.reached.push(i);
                    }
                    scratch.sum.x[i] += vx;
                    scratch.sum.y[i] += vy;
                    scratch.count[i] += 1;
                }
            }
        }
    }
}
