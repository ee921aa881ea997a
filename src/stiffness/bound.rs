//! The update bound of the stable step for a stabilised consistent mass `M_s = M + R` in both
//! solves: `λ_max(K, B)`, `B = M_s + R = M + 2R`, found from products and small local
//! problems, never a mass solve.
//!
//! The top of this spectrum on random particle layouts is made of modes localised on a few
//! nodes that few particles read, scattered over the body, beside the interior's checkerboard
//! band; they appear and vanish from one step to the next as particles move. So the estimate
//! takes the largest of lower bounds of `λ_max(K, B)` (each a Rayleigh quotient): the largest
//! single-node frequency, the largest frequency of small patches of nodes around the nodes
//! with the highest single-node frequencies (exact dense eigenvalues of principal
//! submatrices), LOBPCG polishing the best patch's mode on the whole grid, and LOBPCG on the
//! interior's band.

use super::FrequencyEstimate;
use crate::fields::VectorField;
use crate::operators::Operators;

/// The diagonal of the tangent stiffness per component, into `d` (zero outside the node span
/// first):
///
/// ```text
/// K_xx,II = Σ_p V_p (C11 ∂xN_Ip² + G ∂yN_Ip²),   K_yy,II = Σ_p V_p (C11 ∂yN_Ip² + G ∂xN_Ip²)
/// ```
fn tangent_diagonal_into(
    ops: &Operators,
    volume: &[f64],
    tangent: &impl Fn(usize) -> [f64; 3],
    d: &mut VectorField,
    xy: &mut [f64],
) {
    let span = ops.node_span();
    d.x[span.clone()].fill(0.0);
    d.y[span.clone()].fill(0.0);
    xy[span].fill(0.0);
    crate::with_support!(ops, diagonal_columns::<S>(ops, volume, tangent, d, xy));
}

fn diagonal_columns<const S: usize>(
    ops: &Operators,
    volume: &[f64],
    tangent: &impl Fn(usize) -> [f64; 3],
    d: &mut VectorField,
    xy: &mut [f64],
) {
    for p in 0..ops.num_particles() {
        let st = ops.stencil::<S>(p);
        let [c11, c12, g] = tangent(p);
        let v = volume[p];
        for b in 0..S {
            let (start, _, gx, gy) = st.row(b);
            let (dx, dy) = (&mut d.x[start..start + S], &mut d.y[start..start + S]);
            let dxy = &mut xy[start..start + S];
            for a in 0..S {
                let (xx, yy) = (gx[a] * gx[a], gy[a] * gy[a]);
                dx[a] += v * (c11 * xx + g * yy);
                dy[a] += v * (c11 * yy + g * xx);
                dxy[a] += v * (c12 + g) * gx[a] * gy[a];
            }
        }
    }
}

/// Work arrays of [`mpm_update_bound_estimate`] and [`node_frequency_top`], kept between
/// estimates so that an estimate allocates nothing once they have grown to size.
#[derive(Debug, Default)]
pub(crate) struct BoundWork {
    lobpcg: crate::spectral::LobpcgWork,
    /// `B = M_s + R` in stencil form ([`crate::mass::StencilMass::penalty_twice_into`]).
    b: crate::mass::StencilMass,
    /// The iterate, x components then y, each in `B`'s padded layout.
    x: Vec<f64>,
    /// Per degree of freedom in that layout: 1 where free, 0 elsewhere; and `1/B_II` there.
    mask: Vec<f64>,
    inverse_diagonal: Vec<f64>,
    /// The stiffness diagonal per node (x and y), and its `xy` block.
    f: VectorField,
    xy: Vec<f64>,
    /// Each particle's tangent `[C11, C12, G]`, formed once per estimate.
    tangents: Vec<[f64; 3]>,
    /// The diagonal of `B` per component.
    diagonal: Vec<f64>,
    /// Each node's own frequency ([`node_frequency_top`]).
    own: Vec<f64>,
    /// The patch owning each node, for [`patch_top`] (`u32::MAX`: none).
    owner: Vec<u32>,
}

/// The largest frequency of a single node of the pencil `(K, B)` of
/// [`mpm_update_bound_estimate`], each node's two free components on their own:
///
/// ```text
/// ω²_node = max_I λ_max(K_II, B_II),   K_II, B_II the 2 × 2 blocks of node I (B_II diagonal)
/// ```
///
/// a Rayleigh quotient of `(K, B)`, so a lower bound of its `λ_max`; with the node reaching
/// it. `B_II = (M_s)_II + R_II` exactly. One pass over the particles (the
/// stiffness diagonal) and one over the nodes.
pub(crate) fn node_frequency_top(
    ops: &Operators,
    volume: &[f64],
    tangent: &dyn Fn(usize) -> [f64; 3],
    free: &[bool],
    bound: &crate::mass::BoundingMass<'_>,
    work: &mut BoundWork,
) -> (f64, usize) {
    let n = ops.num_nodes();
    node_diagonals(ops, volume, tangent, bound, work);
    let BoundWork {
        f,
        xy,
        diagonal,
        own: owns,
        ..
    } = work;
    let diagonal = [&*diagonal, &*diagonal];
    owns.resize(n, 0.0);
    // With no free degree of freedom (every node held) the top is 0 at the span's first node.
    let (mut top, mut at) = (0.0f64, ops.node_span().start);
    for i in ops.node_span() {
        let (fx, fy) = (free[i], free[n + i]);
        if !(fx || fy) {
            continue;
        }
        let (bx, by) = (diagonal[0][i], diagonal[1][i]);
        let (kx, ky) = (f.x[i], f.y[i]);
        let own = match (fx && bx > 0.0, fy && by > 0.0) {
            (true, true) => {
                let (a, d, o) = (kx / bx, ky / by, xy[i] / (bx * by).sqrt());
                0.5 * (a + d) + (0.25 * (a - d) * (a - d) + o * o).sqrt()
            }
            (true, false) => kx / bx,
            (false, true) => ky / by,
            (false, false) => 0.0,
        };
        owns[i] = own;
        if own > top {
            (top, at) = (own, i);
        }
    }
    (top, at)
}

/// The largest single-node frequency when each velocity component has its own mass (slip walls
/// under the mirror rule, which the update bound does not cover): over the free components `c`
/// of the nodes `I`,
///
/// ```text
/// max K_cc,II / m_L,I       K_cc,II from the operators folded for c (ops[c])
/// ```
///
/// and the node reaching it. The lumped mass bounds the consistent diagonal from above and the
/// coupling between a node's components is left out, so this is below the node's own
/// frequency and the check against it more eager than the update bound's: on a block of 2 × 2
/// particles per cell resting on a slip floor (quadratic B-splines, consistent mass) the ratio
/// of the top frequency to it stayed below 9.4 over 126 estimates, against the limit of 50; at
/// one particle per cell it was 10⁷ and more.
pub(crate) fn component_node_top(
    ops: [&Operators; 2],
    volume: &[f64],
    tangent: &dyn Fn(usize) -> [f64; 3],
    free: &[bool],
    lumped: &[f64],
) -> (f64, usize) {
    let n = ops[0].num_nodes();
    let (mut top, mut at) = (0.0f64, ops[0].node_span().start);
    for (c, ops_c) in ops.into_iter().enumerate() {
        let mut d = VectorField::zeros(n);
        let mut xy = vec![0.0; n];
        tangent_diagonal_into(ops_c, volume, &tangent, &mut d, &mut xy);
        let k = if c == 0 { &d.x } else { &d.y };
        for i in ops_c.node_span() {
            let b = lumped[i];
            if free[c * n + i] && b > 0.0 && k[i] / b > top {
                (top, at) = (k[i] / b, i);
            }
        }
    }
    (top, at)
}

/// `B` ([`crate::mass::StencilMass::penalty_twice_into`]) into `work.b`, the stiffness
/// diagonal (`work.f`, `work.xy`) and the diagonal of `B` (`work.diagonal`, the same for both
/// components) over the node span.
fn node_diagonals(
    ops: &Operators,
    volume: &[f64],
    tangent: &dyn Fn(usize) -> [f64; 3],
    bound: &crate::mass::BoundingMass<'_>,
    work: &mut BoundWork,
) {
    let n = ops.num_nodes();
    let BoundWork {
        b,
        f,
        xy,
        diagonal,
        tangents,
        ..
    } = work;
    bound.stencil().penalty_twice_into(b);
    if f.len() != n {
        *f = VectorField::zeros(n);
    }
    xy.resize(n, 0.0);
    tangents.clear();
    tangents.extend((0..ops.num_particles()).map(tangent));
    let tangents = &*tangents;
    tangent_diagonal_into(ops, volume, &|p: usize| tangents[p], f, xy);
    if diagonal.len() != n {
        *diagonal = vec![0.0; n];
    }
    b.diagonal_into(diagonal);
}

/// The particles' stiffness `K = Σ_p V_p Gᵀ D_p G` as the bound estimate reads it, never
/// formed: the operators, the volumes `V_p` and each particle's tangent `[C11, C12, G]`.
pub(crate) struct ParticleStiffness<'a, T: Fn(usize) -> [f64; 3]> {
    /// The operators (`G` from Gx, Gy).
    pub(crate) ops: &'a Operators,
    /// Particle volumes `V_p`.
    pub(crate) volume: &'a [f64],
    /// The tangent `[C11, C12, G]` of particle `p`.
    pub(crate) tangent: &'a T,
}

/// What [`mpm_update_bound_estimate`] runs.
#[derive(Debug, Clone, Copy)]
pub(crate) enum BoundRun {
    /// A full estimate (patches, the polish and the band), LOBPCG to the relative `tolerance`
    /// in at most `max_steps` steps.
    Estimate { max_steps: usize, tolerance: f64 },
    /// The guard: `steps` LOBPCG steps from the tracked mode.
    Guard { steps: usize },
}

/// The upper bound of the update's `ω²_max` for a solve mass `M_s = M + R` in both solves, `R`
/// positive semi-definite (the linear-extension penalty), from products only:
///
/// ```text
/// ω²_max = λ_max(M_s⁻¹ K M_s⁻¹ M) = λ_max(K, M_s M⁻¹ M_s) ≤ λ_max(K, B),   B = M_s + R = M + 2R
/// ```
///
/// on the free degrees of freedom, since `M_s M⁻¹ M_s = M + 2R + R M⁻¹ R ⪰ B`. `B` is closer to
/// the update's own mass than `M_s` is ([`mpm_mass_bound_frequency_squared`]) where the penalty
/// holds a node whose support empties. (The further term `R M_L⁻¹ R ⪯ R M⁻¹ R` was measured to
/// change the step of the benchmark's block by 0.3% and cost a tenth of the time.)
///
/// The top of this spectrum on random layouts is made of modes localised on a few nodes that
/// few particles read, scattered over the body, beside the interior's checkerboard band; they
/// appear and vanish from one step to the next, and one LOBPCG iterate converges to whichever
/// it meets first. So a new estimate (`warm = None`) is the largest of four lower bounds of
/// `λ_max(K, B)` (Rayleigh quotients):
/// - the largest single-node frequency ([`node_frequency_top`]);
/// - the largest eigenvalue of 3 × 3-node patches around the nodes of highest single-node
///   frequency ([`patch_top`], dense);
/// - LOBPCG from the best patch's mode (at most [`POLISH_STEPS`] steps);
/// - LOBPCG from a start alternating in sign from node to node (the band, at most
///   [`BAND_STEPS`] steps).
///
/// [`BoundRun::Guard`] is the guard between estimates: its LOBPCG steps from `mode`, the
/// tracked top mode over all `2n` degrees of freedom, beside the single-node frequency. Either
/// way `mode` is left holding the top mode found.
///
/// Products: `K` without forming it ([`apply_tangent_stiffness`]) and `B` in stencil form
/// ([`crate::mass::StencilMass::penalty_twice_into`]), both components in one sweep, on the
/// padded layout of the stencil (no gathering of the free degrees of freedom); preconditioned
/// by `diag(B)⁻¹`. Returns the estimate (LOBPCG steps summed) and the
/// single-node frequency.
pub(crate) fn mpm_update_bound_estimate<T: Fn(usize) -> [f64; 3]>(
    stiffness: ParticleStiffness<'_, T>,
    free: &[bool],
    bound: &crate::mass::BoundingMass<'_>,
    run: BoundRun,
    work: &mut BoundWork,
    mode: &mut Vec<f64>,
) -> (FrequencyEstimate, f64) {
    let ParticleStiffness { ops, volume, tangent } = stiffness;
    let (max_steps, tolerance, warm) = match run {
        BoundRun::Estimate { max_steps, tolerance } => (max_steps, tolerance, None),
        BoundRun::Guard { steps } => (steps, 0.0, Some(steps)),
    };
    let n = ops.num_nodes();
    assert_eq!(free.len(), 2 * n, "one flag per degree of freedom");
    let (node_top, top_node) = node_frequency_top(ops, volume, tangent, free, bound, work);
    let patch = match warm {
        None => patch_top(ops, volume, &work.tangents, free, &work.b, &work.own, &mut work.owner),
        Some(_) => None,
    };
    let BoundWork {
        lobpcg,
        b,
        x,
        mask,
        inverse_diagonal,
        tangents,
        diagonal,
        ..
    } = work;
    let b = &*b;
    let tangents = &*tangents;
    // The padded layout of `B`: node `i` of the span at `i + shift`, x components in the first
    // `plen` entries, y in the next.
    let plen = b.padded_len();
    let span = ops.node_span();
    let shift = b.padded_position(span.start).wrapping_sub(span.start);
    let at = |c: usize, i: usize| c * plen + i.wrapping_add(shift);
    mask.clear();
    mask.resize(2 * plen, 0.0);
    inverse_diagonal.clear();
    inverse_diagonal.resize(2 * plen, 0.0);
    for c in 0..2 {
        for i in span.clone().filter(|&i| free[c * n + i]) {
            mask[at(c, i)] = 1.0;
            if diagonal[i] > 0.0 {
                inverse_diagonal[at(c, i)] = 1.0 / diagonal[i];
            }
        }
    }
    let (mask, inverse_diagonal) = (&*mask, &*inverse_diagonal);
    fn halves(v: &[f64], plen: usize) -> [&[f64]; 2] {
        let (a, b) = v.split_at(plen);
        [a, b]
    }
    let precondition = |r: &[f64], out: &mut [f64]| {
        for ((r, d), o) in r.iter().zip(inverse_diagonal).zip(out.iter_mut()) {
            *o = r * d;
        }
    };
    let mut apply_k = |v: &[f64], out: &mut [f64]| {
        let (ox, oy) = out.split_at_mut(plen);
        super::apply_tangent_stiffness_shifted(
            ops,
            volume,
            tangents,
            halves(v, plen),
            [ox, oy],
            shift,
            halves(mask, plen),
        );
    };
    let mut apply_b = |v: &[f64], out: &mut [f64]| {
        // Rows without couplings are left as they were by the product: zero them first.
        out.fill(0.0);
        let (ox, oy) = out.split_at_mut(plen);
        b.apply_masked_pair(halves(v, plen), [ox, oy], halves(mask, plen));
    };
    // The tracked mode (over all `2n` degrees of freedom) in the padded layout, and back.
    let load_mode = |mode: &[f64], x: &mut Vec<f64>| {
        x.clear();
        x.resize(2 * plen, 0.0);
        if mode.len() == 2 * n {
            for c in 0..2 {
                for i in span.clone() {
                    x[at(c, i)] = mode[c * n + i] * mask[at(c, i)];
                }
            }
        }
    };
    let store_mode = |x: &[f64], mode: &mut Vec<f64>| {
        mode.clear();
        mode.resize(2 * n, 0.0);
        for c in 0..2 {
            for i in span.clone() {
                mode[c * n + i] = x[at(c, i)];
            }
        }
    };
    let single_node = |x: &mut Vec<f64>| {
        x.clear();
        x.resize(2 * plen, 0.0);
        for c in (0..2).filter(|_| span.contains(&top_node)) {
            x[at(c, top_node)] = mask[at(c, top_node)];
        }
    };
    // A guard: `steps` LOBPCG steps from the tracked mode (from the node with the largest
    // frequency where nothing of the mode is left on the free degrees of freedom).
    if let Some(steps) = warm {
        load_mode(mode, x);
        if x.iter().all(|&v| v == 0.0) {
            single_node(x);
        }
        let found = crate::spectral::lobpcg_top(x, steps, 0.0, &mut apply_k, &mut apply_b, precondition, lobpcg);
        store_mode(x, mode);
        let (value, steps) = found.unwrap_or((0.0, 0));
        let estimate = FrequencyEstimate {
            omega_squared: value.max(0.0),
            lanczos_steps: steps,
        };
        return (estimate, node_top);
    }
    // (1) The best patch's mode, polished on the whole grid (from the node with the largest
    // frequency where there is no patch).
    let mut patch_value = 0.0f64;
    match &patch {
        Some((value, patch_mode)) => {
            patch_value = *value;
            x.clear();
            x.resize(2 * plen, 0.0);
            for &(c, i, v) in patch_mode {
                x[at(c, i)] = v;
            }
        }
        None => single_node(x),
    }
    let local = crate::spectral::lobpcg_top(
        x,
        max_steps.min(POLISH_STEPS),
        tolerance,
        &mut apply_k,
        &mut apply_b,
        precondition,
        lobpcg,
    );
    // (2) The interior's band: the start of [`crate::spectral::start_vector`] on the free
    // degrees of freedom, alternating in sign from node to node.
    let local_mode = std::mem::take(x);
    x.resize(2 * plen, 0.0);
    crate::spectral::start_sequence(2 * n, |d, value| {
        let (c, i) = (d / n, d % n);
        if span.contains(&i) && mask[at(c, i)] != 0.0 {
            let flip = ops.grid().is_some_and(|g| {
                let (a, b) = g.node_ij(i);
                (a + b) % 2 == 1
            });
            x[at(c, i)] = if flip { -value } else { value };
        }
    });
    let band = crate::spectral::lobpcg_top(
        x,
        max_steps.min(BAND_STEPS),
        tolerance,
        &mut apply_k,
        &mut apply_b,
        precondition,
        lobpcg,
    );
    // The mode the guards track: the higher of the two.
    let higher = |r: Option<(f64, usize)>| r.map_or(0.0, |(v, _)| v);
    if higher(local) > higher(band) {
        store_mode(&local_mode, mode);
    } else {
        store_mode(x, mode);
    }
    let [(a, sa), (b, sb)] = [local, band].map(|r| r.unwrap_or((0.0, 0)));
    let estimate = FrequencyEstimate {
        omega_squared: a.max(b).max(node_top).max(patch_value).max(0.0),
        lanczos_steps: sa + sb,
    };
    (estimate, node_top)
}

/// Most LOBPCG steps of the band estimate of `mpm_update_bound_estimate` (the interior's
/// checkerboard band converges in about ten; beyond, the iterate creeps towards the localised
/// modes, which the other two parts find).
pub const BAND_STEPS: usize = 150;

/// Most LOBPCG steps polishing the best patch's mode in [`mpm_update_bound_estimate`].
pub const POLISH_STEPS: usize = 150;

/// Half-width of the patches of [`patch_top`], in nodes: a patch is the `(2r + 1)²` nodes
/// around its centre (3 × 3).
pub const PATCH_RADIUS: usize = 1;

/// Most patches of [`patch_top`]: centred on the nodes with the highest single-node
/// frequencies, far enough apart that no particle reads two of them.
pub const PATCH_CANDIDATES: usize = 96;

/// A patch's mode as `(component, node, value)`.
type PatchMode = Vec<(usize, usize, f64)>;

/// One patch of [`patch_top`]: its nodes (`usize::MAX` off the grid) and the stiffness of its
/// particles on them, `2P × 2P` (x components of the `P` nodes, then y).
struct Patch {
    nodes: Vec<usize>,
    origin: [isize; 2],
    stiffness: Vec<f64>,
}

/// The largest eigenvalue of the pencil `(K_PP, B_PP)` over small patches `P` of nodes (their
/// free degrees of freedom), the principal submatrices of `(K, B)`: each a lower bound of
/// `λ_max(K, B)` (Cauchy interlacing), and close to it where the top mode is localised on a
/// patch. Patches are centred on the [`PATCH_CANDIDATES`] nodes of highest single-node
/// frequency `own` that lie far enough apart; `K_PP` is summed from the particles that read the
/// patch (one pass over the particles), `B_PP` from the stencil of
/// `B`. Returns the value and its mode as `(component, node, value)`.
fn patch_top(
    ops: &Operators,
    volume: &[f64],
    tangents: &[[f64; 3]],
    free: &[bool],
    b_matrix: &crate::mass::StencilMass,
    own: &[f64],
    owner: &mut Vec<u32>,
) -> Option<(f64, PatchMode)> {
    let grid = ops.grid()?;
    let n = ops.num_nodes();
    let [nx, ny] = grid.nodes_per_axis();
    let r = PATCH_RADIUS as isize;
    let width = 2 * PATCH_RADIUS + 1;
    let support = ops.support() as isize;
    // Candidates: the highest single-node frequencies, greedily kept apart.
    let mut ranked: Vec<(f64, usize)> = ops.node_span().filter(|&i| own[i] > 0.0).map(|i| (own[i], i)).collect();
    let keep = (8 * PATCH_CANDIDATES).min(ranked.len());
    if keep == 0 {
        return None;
    }
    if keep < ranked.len() {
        ranked.select_nth_unstable_by(keep - 1, |a, b| b.0.total_cmp(&a.0));
        ranked.truncate(keep);
    }
    ranked.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    let apart = 2 * r + support;
    let mut centres: Vec<[isize; 2]> = Vec::new();
    for &(_, i) in &ranked {
        let (a, b) = grid.node_ij(i);
        let c = [a as isize, b as isize];
        if centres
            .iter()
            .all(|o| (o[0] - c[0]).abs() > apart || (o[1] - c[1]).abs() > apart)
        {
            centres.push(c);
            if centres.len() == PATCH_CANDIDATES {
                break;
            }
        }
    }
    let mut patches: Vec<Patch> = centres
        .iter()
        .map(|c| {
            let origin = [c[0] - r, c[1] - r];
            let nodes = (0..width * width)
                .map(|l| {
                    let (a, b) = (origin[0] + (l % width) as isize, origin[1] + (l / width) as isize);
                    if a >= 0 && b >= 0 && (a as usize) < nx && (b as usize) < ny {
                        grid.node_index(a as usize, b as usize)
                    } else {
                        usize::MAX
                    }
                })
                .collect();
            Patch {
                nodes,
                origin,
                stiffness: vec![0.0; 4 * width * width * width * width],
            }
        })
        .collect();
    // Each patch owns the first nodes of the stencils that reach it.
    owner.clear();
    owner.resize(n, u32::MAX);
    let mut owned = Vec::new();
    for (k, p) in patches.iter().enumerate() {
        for b in p.origin[1] - support + 1..=p.origin[1] + 2 * r {
            for a in p.origin[0] - support + 1..=p.origin[0] + 2 * r {
                if a >= 0 && b >= 0 && (a as usize) < nx && (b as usize) < ny {
                    let i = grid.node_index(a as usize, b as usize);
                    owner[i] = k as u32;
                    owned.push(i);
                }
            }
        }
    }
    crate::with_support!(ops, patch_stiffness::<S>(ops, volume, tangents, owner, &mut patches));
    for i in owned {
        owner[i] = u32::MAX;
    }
    // Each patch's pencil on its free degrees of freedom.
    let p_count = width * width;
    let mut best: Option<(f64, PatchMode)> = None;
    for patch in &patches {
        let dofs: Vec<(usize, usize)> = (0..2)
            .flat_map(|c| (0..p_count).map(move |l| (c, l)))
            .filter(|&(c, l)| patch.nodes[l] != usize::MAX && free[c * n + patch.nodes[l]])
            .collect();
        let m = dofs.len();
        if m == 0 {
            continue;
        }
        let k = nalgebra::DMatrix::from_fn(m, m, |s, t| {
            let ((c, l), (d, q)) = (dofs[s], dofs[t]);
            patch.stiffness[(c * p_count + l) * 2 * p_count + d * p_count + q]
        });
        let b = nalgebra::DMatrix::from_fn(m, m, |s, t| {
            let ((c, l), (d, q)) = (dofs[s], dofs[t]);
            if c != d {
                return 0.0;
            }
            let (i, j) = (patch.nodes[l], patch.nodes[q]);
            b_matrix.entry(i, j)
        });
        let Some(chol) = nalgebra::Cholesky::new(b) else {
            continue;
        };
        let Some(l_inv) = chol.l().try_inverse() else {
            continue;
        };
        let reduced = &l_inv * k * l_inv.transpose();
        let reduced = 0.5 * (&reduced + reduced.transpose());
        let eig = nalgebra::SymmetricEigen::new(reduced);
        let top = eig.eigenvalues.imax();
        let value = eig.eigenvalues[top];
        if best.as_ref().is_none_or(|(v, _)| value > *v) {
            let y = l_inv.transpose() * eig.eigenvectors.column(top);
            let mode = dofs
                .iter()
                .zip(y.iter())
                .map(|(&(c, l), &v)| (c, patch.nodes[l], v))
                .collect();
            best = Some((value, mode));
        }
    }
    best
}

/// Adds each particle's stiffness on the nodes of the patch that owns its stencil's first node
/// (`K[αx, βx] = V (C11 ∂xN_α ∂xN_β + G ∂yN_α ∂yN_β)`, and likewise for the other blocks, as
/// [`apply_tangent_stiffness_into`] applies them).
fn patch_stiffness<const S: usize>(
    ops: &Operators,
    volume: &[f64],
    tangents: &[[f64; 3]],
    owner: &[u32],
    patches: &mut [Patch],
) {
    let width = (2 * PATCH_RADIUS + 1) as isize;
    let p_count = (width * width) as usize;
    for p in 0..ops.num_particles() {
        let st = ops.stencil::<S>(p);
        let k = owner[st.first];
        if k == u32::MAX {
            continue;
        }
        let patch = &mut patches[k as usize];
        let [c11, c12, g] = tangents[p];
        let v = volume[p];
        // The particle's nodes inside the patch: local index and gradient.
        let mut local: [(usize, f64, f64); 16] = [(0, 0.0, 0.0); 16];
        let mut count = 0;
        for b in 0..S {
            for a in 0..S {
                let (i, j) = (
                    st.first_ij[0] as isize + a as isize - patch.origin[0],
                    st.first_ij[1] as isize + b as isize - patch.origin[1],
                );
                if (0..width).contains(&i) && (0..width).contains(&j) && count < 16 {
                    let (gx, gy) = (st.dwx[a] * st.wy[b], st.wx[a] * st.dwy[b]);
                    local[count] = ((i + width * j) as usize, gx, gy);
                    count += 1;
                }
            }
        }
        let row = 2 * p_count;
        for &(l, gxa, gya) in &local[..count] {
            for &(q, gxb, gyb) in &local[..count] {
                let s = &mut patch.stiffness;
                s[l * row + q] += v * (c11 * gxa * gxb + g * gya * gyb);
                s[l * row + p_count + q] += v * (c12 * gxa * gyb + g * gya * gxb);
                s[(p_count + l) * row + q] += v * (c12 * gya * gxb + g * gxa * gyb);
                s[(p_count + l) * row + p_count + q] += v * (c11 * gya * gyb + g * gxa * gxb);
            }
        }
    }
}
