//! The consistent mass in stencil form: for each node in the operators' node span, its
//! couplings to the `(2S − 1)²` nodes within `S − 1` grid lines of it (`S` the support per
//! axis), assembled straight from the operators' factored columns:
//!
//! ```text
//! M_IJ = Σ_p m_p N_Ip N_Jp,   N_Ip = w_x,a(p) w_y,b(p)
//!      ⇒ M[I][(c − a, d − b)] += m_p w_x,a w_x,c · w_y,b w_y,d       (I = (i₀+a, j₀+b), J = (i₀+c, j₀+d))
//! ```
//!
//! This is the same matrix as [`super::consistent_mass`] (up to the order of the sums), but it
//! costs `S⁴` multiply-adds per particle with no index search, and a product `M x` reads one
//! dense row of `(2S − 1)²` values per node. The conjugate-gradient and truncated-series
//! schemes work on it; [`StencilMass::to_csc`] gives the compressed-column form.

use nalgebra_sparse::CscMatrix;

use super::cg::lanes_sum;
use crate::operators::Operators;
use crate::shape::{bspline, gimp, linear, ShapeFunction};
use crate::with_support;

/// The consistent mass (optionally partially lumped) stored per node over the node span.
#[derive(Debug, Clone, Default)]
pub struct StencilMass {
    num_nodes: usize,
    /// The shape function the couplings are of (its support sets the stencil).
    shape: ShapeFunction,
    /// First node of the span and its length.
    start: usize,
    len: usize,
    /// `(2S − 1)²` offsets in node numbers, `dx·sx + dy·sy`, `dx` fastest.
    offsets: Vec<isize>,
    /// Largest `|offset|`: the padding of work vectors.
    pad: usize,
    /// The upper half of the couplings (offsets `o ≥ K/2`; `M` is symmetric), one padded array
    /// per offset: offset `o` of node `start + r` at `(o − K/2)·(len + 2 pad) + pad + r`, so that
    /// a product runs along grid lines in SIMD lanes and reads each coupling once.
    values: Vec<f64>,
    /// Per node, a bit per offset: whether some particle touches both nodes (the structural
    /// pattern of `N diag(m) Nᵀ`).
    pattern: Vec<u64>,
    /// Runs `[lo, hi)` of span rows (`I − start`) with at least one coupling, ascending.
    segments: Vec<(usize, usize)>,
}

impl StencilMass {
    /// Assembles `M = N diag(m) Nᵀ` from the operators' factored columns.
    ///
    /// # Panics
    /// If `m.len()` is not the particle count.
    pub fn assemble(ops: &Operators, m: &[f64]) -> StencilMass {
        let mut s = StencilMass::default();
        s.reassemble(ops, m);
        s
    }

    /// [`StencilMass::assemble`] into the existing buffers.
    ///
    /// # Panics
    /// If `m.len()` is not the particle count.
    pub fn reassemble(&mut self, ops: &Operators, m: &[f64]) {
        assert_eq!(m.len(), ops.num_particles(), "one mass per particle");
        with_support!(ops, assemble_into::<S>(self, ops, m));
        self.segments.clear();
        let line = ops.line_length().max(1);
        let mut r = 0;
        while r < self.len {
            if self.pattern[r] == 0 {
                r += 1;
                continue;
            }
            let lo = r;
            // Runs end at a line's end, so that a gap in a line is not crossed.
            let line_end = ((self.start + r) / line + 1) * line - self.start;
            while r < self.len.min(line_end) && self.pattern[r] != 0 {
                r += 1;
            }
            self.segments.push((lo, r));
        }
    }

    /// Number of grid nodes (rows and columns of `M`).
    pub fn num_nodes(&self) -> usize {
        self.num_nodes
    }

    /// Offsets per node, `(2S − 1)²`.
    fn width(&self) -> usize {
        self.offsets.len()
    }

    /// Stored couplings (structural nonzeros of `M`).
    pub fn nnz(&self) -> usize {
        self.pattern.iter().map(|b| b.count_ones() as usize).sum()
    }

    /// Where the value of row `r` (span-local) at offset `o` is stored (the mirror entry of the
    /// neighbour for the lower half).
    fn slot(&self, r: usize, o: usize) -> usize {
        let (k, plen) = (self.width(), self.len + 2 * self.pad);
        let centre = k / 2;
        if o >= centre {
            (o - centre) * plen + self.pad + r
        } else {
            let j = (r as isize + self.offsets[o]) as usize;
            (k - 1 - o - centre) * plen + self.pad + j
        }
    }

    /// The stored value of row `r` (span-local) at offset `o`.
    fn value(&self, r: usize, o: usize) -> f64 {
        self.values[self.slot(r, o)]
    }

    /// The matrix in compressed-column form (structural entries only, rows ascending).
    pub fn to_csc(&self) -> CscMatrix<f64> {
        let n = self.num_nodes;
        // Offsets in ascending order of node number (for either node order).
        let mut order: Vec<usize> = (0..self.width()).collect();
        order.sort_by_key(|&o| self.offsets[o]);
        let mut col_ptr = Vec::with_capacity(n + 1);
        let nnz = self.nnz();
        let (mut rows, mut values) = (Vec::with_capacity(nnz), Vec::with_capacity(nnz));
        col_ptr.extend(std::iter::repeat_n(0, self.start + 1));
        // M is symmetric: column j holds row j's couplings.
        for r in 0..self.len {
            let bits = self.pattern[r];
            let j = self.start + r;
            for &o in &order {
                if bits >> o & 1 == 1 {
                    rows.push((j as isize + self.offsets[o]) as usize);
                    values.push(self.value(r, o));
                }
            }
            col_ptr.push(rows.len());
        }
        col_ptr.resize(n + 1, rows.len());
        CscMatrix::try_from_csc_data(n, n, col_ptr, rows, values).expect("rows ascending within each column")
    }

    /// A zero vector in the padded span layout of the work vectors.
    fn padded(&self) -> Vec<f64> {
        vec![0.0; self.len + 2 * self.pad]
    }

    /// `y = M x` over all nodes (`x` finite).
    ///
    /// # Panics
    /// If `x` does not have one entry per node.
    pub fn mul(&self, x: &[f64]) -> Vec<f64> {
        assert_eq!(x.len(), self.num_nodes, "one value per node");
        let mut padded = self.padded();
        padded[self.pad..self.pad + self.len].copy_from_slice(&x[self.start..self.start + self.len]);
        let mut out = self.padded();
        let ones = vec![1.0; padded.len()];
        self.apply_padded(&padded, &mut out, &ones);
        let mut y = vec![0.0; self.num_nodes];
        y[self.start..self.start + self.len].copy_from_slice(&out[self.pad..self.pad + self.len]);
        y
    }

    /// `out = mask ∘ M x` on the padded layout over the segments (elsewhere left as it was),
    /// with `mask` zero where the product is to be dropped; returns `x · out`.
    fn apply_padded(&self, x: &[f64], out: &mut [f64], mask: &[f64]) -> f64 {
        match self.shape {
            ShapeFunction::Linear => apply_segments::<{ width(linear::SUPPORT) }>(self, x, out, mask),
            ShapeFunction::Gimp { .. } => apply_segments::<{ width(gimp::SUPPORT) }>(self, x, out, mask),
            ShapeFunction::QuadraticBSpline => {
                apply_segments::<{ width(bspline::QUADRATIC_SUPPORT) }>(self, x, out, mask)
            }
            ShapeFunction::CubicBSpline => apply_segments::<{ width(bspline::CUBIC_SUPPORT) }>(self, x, out, mask),
        }
    }

    /// Partial lumping of the nodes with little mass relative to their neighbours (the same
    /// matrix as [`super::stabilization::partially_lumped`]):
    ///
    /// ```text
    /// M'_IJ = s_IJ M_IJ  (I ≠ J),   M'_II = M_II + Σ_{J≠I} (1 − s_IJ) M_IJ,
    /// s_IJ = min(1, min(φ_I, φ_J)/θ),   φ_I = m_L,I / max_{J: M_IJ stored} m_L,J
    /// ```
    ///
    /// # Panics
    /// If `lumped` does not have one entry per node.
    pub fn partially_lump(&mut self, lumped: &[f64], threshold: f64) {
        assert_eq!(lumped.len(), self.num_nodes, "one lumped mass per node");
        let k = self.width();
        let centre = k / 2;
        let (start, len) = (self.start, self.len);
        let offsets = &self.offsets;
        let node = |r: usize, o: usize| (start as isize + r as isize + offsets[o]) as usize;
        // φ on the rows with couplings (elsewhere it is never read).
        let mut phi = vec![1.0; len];
        for &(lo, hi) in &self.segments {
            for r in lo..hi {
                let own = lumped[start + r];
                let bits = self.pattern[r];
                let heaviest = (0..k)
                    .filter(|&o| bits >> o & 1 == 1)
                    .map(|o| lumped[node(r, o)])
                    .fold(own, f64::max);
                phi[r] = if heaviest > 0.0 { own / heaviest } else { 1.0 };
            }
        }
        // Each coupling once (upper half), its removed part onto both diagonals.
        let plen = len + 2 * self.pad;
        for r in self.segments.iter().flat_map(|&(lo, hi)| lo..hi) {
            let bits = self.pattern[r];
            for o in (centre + 1..k).filter(|&o| bits >> o & 1 == 1) {
                let j = node(r, o) - start;
                let s = (phi[r].min(phi[j]) / threshold).min(1.0);
                if s < 1.0 {
                    let at = (o - centre) * plen + self.pad + r;
                    let moved = (1.0 - s) * self.values[at];
                    self.values[at] *= s;
                    self.values[self.pad + r] += moved;
                    self.values[self.pad + j] += moved;
                }
            }
        }
    }
}

impl super::cg::CgLayout for StencilMass {
    fn layout_len(&self) -> usize {
        self.len + 2 * self.pad
    }
    fn segments(&self) -> Vec<std::ops::Range<usize>> {
        self.segments
            .iter()
            .map(|&(lo, hi)| lo + self.pad..hi + self.pad)
            .collect()
    }
    fn position(&self, i: usize) -> usize {
        i - self.start + self.pad
    }
    fn apply(&self, x: &[f64], out: &mut [f64], mask: &[f64]) -> f64 {
        self.apply_padded(x, out, mask)
    }
}

/// `out[r] = mask[r] Σ_o M_o[r] x[r + offset_o]` over the segments, padded layout: the centre,
/// then each upper offset and its mirror, one sweep along each segment (SIMD across nodes).
/// Returns `Σ x[r] out[r]`.
fn apply_segments<const K: usize>(m: &StencilMass, x: &[f64], out: &mut [f64], mask: &[f64]) -> f64 {
    let centre = K / 2;
    let plen = m.len + 2 * m.pad;
    let mut dot = [0.0; 8];
    for &(lo, hi) in &m.segments {
        let (lo, hi) = (lo + m.pad, hi + m.pad);
        let y = &mut out[lo..hi];
        for ((y, a), x) in y.iter_mut().zip(&m.values[lo..hi]).zip(&x[lo..hi]) {
            *y = a * x;
        }
        for o in centre + 1..K {
            let off = m.offsets[o];
            let base = (o - centre) * plen;
            let up = &m.values[base + lo..base + hi];
            let down_at = (base as isize + lo as isize - off) as usize;
            let down = &m.values[down_at..down_at + (hi - lo)];
            let xu_at = (lo as isize + off) as usize;
            let xd_at = (lo as isize - off) as usize;
            let xu = &x[xu_at..xu_at + (hi - lo)];
            let xd = &x[xd_at..xd_at + (hi - lo)];
            for k in 0..hi - lo {
                y[k] += up[k] * xu[k] + down[k] * xd[k];
            }
        }
        let (mask, x) = (&mask[lo..hi], &x[lo..hi]);
        for ((y, mask), x) in y.chunks_exact_mut(8).zip(mask.chunks_exact(8)).zip(x.chunks_exact(8)) {
            for l in 0..8 {
                y[l] = if mask[l] == 0.0 { 0.0 } else { y[l] };
                dot[l] += y[l] * x[l];
            }
        }
        let done = y.len() / 8 * 8;
        for k in done..y.len() {
            y[k] = if mask[k] == 0.0 { 0.0 } else { y[k] };
            dot[k - done] += y[k] * x[k];
        }
    }
    lanes_sum(&dot)
}

/// Couplings per node of a kernel of support `s`: `(2s − 1)²`.
const fn width(s: usize) -> usize {
    (2 * s - 1) * (2 * s - 1)
}

fn assemble_into<const S: usize>(s: &mut StencilMass, ops: &Operators, m: &[f64]) {
    let w = 2 * S - 1;
    let k = w * w;
    let [sx, sy] = ops.strides();
    let span = ops.node_span();
    s.num_nodes = ops.num_nodes();
    s.shape = ops.shape_function();
    s.start = span.start;
    s.len = span.len();
    let len = s.len;
    s.offsets.clear();
    for dy in -(S as isize - 1)..S as isize {
        for dx in -(S as isize - 1)..S as isize {
            s.offsets.push(dx * sx as isize + dy * sy as isize);
        }
    }
    s.pad = s.offsets.iter().map(|o| o.unsigned_abs()).max().unwrap_or(0);
    let plen = len + 2 * s.pad;
    let centre = k / 2;
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
                    bits |= 1 << ((d + S - 1 - b) * w + c + S - 1 - a);
                }
            }
            bits
        })
    });
    for (p, &mp) in m.iter().enumerate() {
        let st = ops.stencil::<S>(p);
        let wxx: [[f64; S]; S] = std::array::from_fn(|a| std::array::from_fn(|c| st.wx[a] * st.wx[c]));
        for b in 0..S {
            for a in 0..S {
                let row = st.first + a * sx + b * sy - s.start;
                s.pattern[row] |= masks[b][a];
                // The upper half: offsets o = (d − b + S − 1) w + (c − a + S − 1) ≥ centre.
                for d in b..S {
                    let cy = mp * st.wy[b] * st.wy[d];
                    let base = (d + S - 1 - b) * w + S - 1 - a;
                    let c0 = if d == b { a } else { 0 };
                    for c in c0..S {
                        s.values[(base + c - centre) * plen + s.pad + row] += cy * wxx[a][c];
                    }
                }
            }
        }
    }
}
