//! Assembly of [`StencilMass`] from the operators' factored columns: the general particle loop
//! (any node order) and, where node numbers run along x, the same sums added as runs of
//! adjacent rows.

use super::StencilMass;
use crate::operators::Operators;

pub(super) fn assemble_into<const S: usize>(s: &mut StencilMass, ops: &Operators, m: &[f64], extended: bool) {
    let w = 2 * S - 1;
    let [sx, sy] = ops.strides();
    let span = ops.node_span();
    s.num_nodes = ops.num_nodes();
    s.shape = ops.shape_function();
    s.strides = [sx, sy];
    s.start = span.start;
    s.len = span.len();
    let len = s.len;
    // The square of the kernel's couplings, `dx` fastest, then where each lands in the
    // ascending list of stored offsets.
    let mut square = Vec::with_capacity(w * w);
    for dy in -(S as isize - 1)..S as isize {
        for dx in -(S as isize - 1)..S as isize {
            square.push(dx * sx as isize + dy * sy as isize);
        }
    }
    s.offsets.clone_from(&square);
    if extended && S < 3 {
        s.offsets
            .extend([-2 * sx as isize, 2 * sx as isize, -2 * sy as isize, 2 * sy as isize]);
    }
    s.offsets.sort_unstable();
    s.offsets.dedup();
    let k = s.offsets.len();
    assert!(k <= 64, "at most 64 couplings per node");
    let at: Vec<usize> = square
        .iter()
        .map(|o| s.offsets.binary_search(o).expect("every square offset is stored"))
        .collect();
    s.pad = s.offsets.iter().map(|o| o.unsigned_abs()).max().unwrap_or(0);
    let plen = len + 2 * s.pad;
    let centre = k / 2;
    // Where a square offset's value goes, relative to `pad + row`: its own slot past the
    // list's centre, or the mirror slot of the node it couples to (when the node order makes
    // the square's upper half differ from the list's).
    let rel: Vec<isize> = square
        .iter()
        .zip(&at)
        .map(|(&o, &i)| {
            if i >= centre {
                ((i - centre) * plen) as isize
            } else {
                ((k - 1 - i - centre) * plen) as isize + o
            }
        })
        .collect();
    s.values.clear();
    s.values.resize((k - centre) * plen, 0.0);
    s.pattern.clear();
    s.pattern.resize(len, 0);
    // The offsets a node at (a, b) of a stencil shares with the others.
    let masks: [[u64; S]; S] = std::array::from_fn(|b| {
        std::array::from_fn(|a| {
            let mut bits = 0u64;
            for d in 0..S {
                for c in 0..S {
                    bits |= 1 << at[(d + S - 1 - b) * w + c + S - 1 - a];
                }
            }
            bits
        })
    });
    if sx == 1 && sy >= 2 * S {
        // Runs along x and lines long enough that the square's offsets are distinct and its
        // upper half is the list's: each unordered pair of a particle's nodes lands in its
        // own slot, so the pairs of one y-pair and one x-offset are a run of adjacent rows.
        add_runs::<S>(s, ops, m, &rel, &masks, sy);
        return;
    }
    for (p, &mp) in m.iter().enumerate() {
        let st = ops.stencil::<S>(p);
        let wxx: [[f64; S]; S] = std::array::from_fn(|a| std::array::from_fn(|c| st.wx[a] * st.wx[c]));
        for b in 0..S {
            for a in 0..S {
                let row = st.first + a * sx + b * sy - s.start;
                s.pattern[row] |= masks[b][a];
                // Each coupling once: the square offsets (d − b + S − 1) w + (c − a + S − 1)
                // past the square's centre, stored where `rel` says.
                for d in b..S {
                    let cy = mp * st.wy[b] * st.wy[d];
                    let base = (d + S - 1 - b) * w + S - 1 - a;
                    let c0 = if d == b { a } else { 0 };
                    for c in c0..S {
                        s.values[(rel[base + c] + (s.pad + row) as isize) as usize] += cy * wxx[a][c];
                    }
                }
            }
        }
    }
}

/// The particle loop of [`assemble_into`] with node numbers running along x (`s_x = 1`) and
/// lines of at least `2S` nodes, in runs: for nodes `(a, b)` and `(a + δ, d)` with `b ≤ d` (and
/// `δ ≥ 0` where `b = d`), the coupling at offset `(δ, d − b)` of row `(a, b)` is
///
/// ```text
/// M[(a, b)][(δ, d − b)] += (m_p w_y,b w_y,d) · (w_x,a w_x,a+δ)
/// ```
///
/// the same products, each added once per particle in particle order, as the general loop
/// (so the same bits); for fixed `(b, d, δ)` the rows `a` are adjacent, and they are added as
/// `S` adjacent values with zeros where `a + δ` leaves the stencil (rows of the grid all the
/// same, and `x + 0 = x` for the sums of non-negative terms held there).
fn add_runs<const S: usize>(
    s: &mut StencilMass,
    ops: &Operators,
    m: &[f64],
    rel: &[isize],
    masks: &[[u64; S]; S],
    line: usize,
) {
    let w = 2 * S - 1;
    // Slot bases of the square's upper-half offsets, `(dy, δ)` at `dy·w + δ + S − 1`.
    let base: Vec<usize> = (0..w * w)
        .map(|i| {
            let (dy, dx) = (i / w, i % w);
            let square = (dy + S - 1) * w + dx;
            match rel.get(square) {
                Some(&r) if dy < S && (dx + 1 >= S || dy > 0) => {
                    debug_assert!(r >= 0, "an upper-half coupling in its own slot");
                    r as usize
                }
                _ => 0,
            }
        })
        .collect();
    let pad = s.pad;
    for (p, &mp) in m.iter().enumerate() {
        let st = ops.stencil::<S>(p);
        let r0 = st.first - s.start;
        for b in 0..S {
            for a in 0..S {
                s.pattern[r0 + a + b * line] |= masks[b][a];
            }
        }
        // `w_x,a w_x,a+δ` by `δ + S − 1`, zero where `a + δ` is outside `0..S` (at most seven
        // offsets: the cubic B-spline's).
        let mut wxx = [[0.0; S]; 7];
        for (k, products) in wxx.iter_mut().enumerate().take(w) {
            for (a, v) in products.iter_mut().enumerate() {
                let c = a + k;
                if (S - 1..2 * S - 1).contains(&c) {
                    *v = st.wx[a] * st.wx[c + 1 - S];
                }
            }
        }
        for b in 0..S {
            let row = pad + r0 + b * line;
            for d in b..S {
                let cy = mp * st.wy[b] * st.wy[d];
                let dy = d - b;
                let first = if dy == 0 { S - 1 } else { 0 };
                for (k, products) in wxx.iter().enumerate().take(w).skip(first) {
                    let at = base[dy * w + k] + row;
                    let target = &mut s.values[at..at + S];
                    for (v, x) in target.iter_mut().zip(products) {
                        *v += cy * x;
                    }
                }
            }
        }
    }
}
