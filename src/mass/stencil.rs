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
use crate::shape::ShapeFunction;
use crate::with_support;

mod assembly;
use assembly::assemble_into;

/// The consistent mass (optionally partially lumped) stored per node over the node span.
#[derive(Debug, Clone, Default)]
pub struct StencilMass {
    num_nodes: usize,
    /// The shape function the couplings are of (its support sets the stencil).
    shape: ShapeFunction,
    /// First node of the span and its length.
    start: usize,
    len: usize,
    /// Node-number strides along x and y.
    strides: [usize; 2],
    /// The offsets in node numbers, `dx·sx + dy·sy`, ascending: the `(2S − 1)²` of the
    /// kernel's couplings, and with [`StencilMass::reassemble_extended`] also `±2` grid lines
    /// along each axis where the kernel's own reach is shorter (the linear-extension penalty's
    /// couplings). Symmetric: offset `K − 1 − o` is `−offset o`, the centre is `K/2`.
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
    /// The terms `w_T d_T d_Tᵀ` of the linear-extension penalty added since the last assembly:
    /// the nodes `(a, b, c)` and `γ w_T` ([`StencilMass::penalty_product`]).
    penalty: Vec<([u32; 3], f64)>,
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
        self.reassemble_with(ops, m, false);
    }

    /// [`StencilMass::reassemble`] with room for couplings two grid lines apart along each
    /// axis (stored as zeros where the kernel does not couple them), which
    /// [`StencilMass::add_extension_penalty`] needs with linear shape functions.
    ///
    /// # Panics
    /// If `m.len()` is not the particle count.
    pub fn reassemble_extended(&mut self, ops: &Operators, m: &[f64]) {
        self.reassemble_with(ops, m, true);
    }

    fn reassemble_with(&mut self, ops: &Operators, m: &[f64], extended: bool) {
        assert_eq!(m.len(), ops.num_particles(), "one mass per particle");
        with_support!(ops, assemble_into::<S>(self, ops, m, extended));
        self.penalty.clear();
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

    /// Offsets per node.
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
        apply_segments(self, x, out, mask)
    }

    /// `y += R x` over all nodes, `R = γ Σ_T w_T d_T d_Tᵀ` the linear-extension penalty that
    /// [`StencilMass::add_extension_penalty`] added (nothing without it):
    ///
    /// ```text
    /// (R x)_a += g_T,  (R x)_b −= 2 g_T,  (R x)_c += g_T,   g_T = γ w_T (x_a − 2 x_b + x_c)
    /// ```
    ///
    /// # Panics
    /// If `x` or `y` does not have one entry per node.
    pub fn penalty_product(&self, x: &[f64], y: &mut [f64]) {
        assert!(
            x.len() == self.num_nodes && y.len() == self.num_nodes,
            "one value per node"
        );
        for &([a, b, c], w) in &self.penalty {
            let (a, b, c) = (a as usize, b as usize, c as usize);
            let g = w * (x[a] - 2.0 * x[b] + x[c]);
            y[a] += g;
            y[b] -= 2.0 * g;
            y[c] += g;
        }
    }

    /// The entry `M_IJ` (0 where not stored or off the span).
    pub(crate) fn entry(&self, i: usize, j: usize) -> f64 {
        let span = self.start..self.start + self.len;
        if !(span.contains(&i) && span.contains(&j)) {
            return 0.0;
        }
        match self.offset_index(j as isize - i as isize) {
            Some(o) => self.value(i - self.start, o),
            None => 0.0,
        }
    }

    /// Length of a work vector in the padded span layout of [`StencilMass::apply_masked`].
    pub(crate) fn padded_len(&self) -> usize {
        self.len + 2 * self.pad
    }

    /// The position of node `i` (in the span) in the padded layout.
    pub(crate) fn padded_position(&self, i: usize) -> usize {
        i - self.start + self.pad
    }

    /// `out_c = mask_c ∘ M x_c` in the padded layout over the rows with couplings (elsewhere left
    /// as it was) for two vectors (the x and y components of a field) in one sweep over the
    /// stored couplings, which are read once for both.
    pub(crate) fn apply_masked_pair(&self, x: [&[f64]; 2], out: [&mut [f64]; 2], mask: [&[f64]; 2]) {
        apply_segments_pair(self, x, out, mask)
    }

    /// The position of `offset` in [`StencilMass::offsets`], if stored.
    fn offset_index(&self, offset: isize) -> Option<usize> {
        self.offsets.binary_search(&offset).ok()
    }

    /// [`StencilMass::diagonal`] into `d` over the span (the rest left as it is).
    pub(crate) fn diagonal_into(&self, d: &mut [f64]) {
        d[self.start..self.start + self.len].copy_from_slice(&self.values[self.pad..self.pad + self.len]);
    }

    /// The diagonal `M_II` over all nodes (0 off the span).
    pub fn diagonal(&self) -> Vec<f64> {
        let mut d = vec![0.0; self.num_nodes];
        d[self.start..self.start + self.len].copy_from_slice(&self.values[self.pad..self.pad + self.len]);
        d
    }

    /// Adds the linear-extension penalty in place (the same matrix as
    /// `M + `[`super::extension::extension_penalty`], up to the order of the sums):
    ///
    /// ```text
    /// M_s = M + γ Σ_T w_T d_T d_Tᵀ,   d_T = e_a − 2 e_b + e_c,
    /// w_T = max_{I ∈ T} m_L,I · max(0, 1 − ψ_T/θ) · min(1, ψ_T/ψ₀),   ψ_T = min_{I ∈ T} ψ_I,
    /// ψ_I = min(φ_I, δ_I/δ_full),   φ_I = m_L,I / max_{J: M_IJ ≠ 0} m_L,J,   δ_I = M_II / m_L,I
    /// ```
    ///
    /// (`ψ₀` the onset as [`super::extension::effective_onset`] gives it for the kernel) over the
    /// triples `T = (a, b, c)` of consecutive active nodes along each grid line, with
    /// `φ` and `δ` of the plain matrix this stencil holds on entry; `full` is `δ_full`
    /// ([`super::extension::full_support_inertia`]).
    ///
    /// # Panics
    /// On length mismatch, or if the couplings two grid lines apart are not stored (assemble
    /// with [`StencilMass::reassemble_extended`]).
    pub fn add_extension_penalty(
        &mut self,
        nodes_per_axis: [usize; 2],
        lumped: &[f64],
        active: &[bool],
        [gamma, threshold, onset]: [f64; 3],
        full: f64,
    ) {
        let onset = super::extension::effective_onset(self.shape, onset);
        let n = self.num_nodes;
        assert!(
            lumped.len() == n && active.len() == n,
            "one lumped mass and one flag per node"
        );
        let (start, len, pad) = (self.start, self.len, self.pad);
        let k = self.width();
        // ψ on the span rows with couplings (0 elsewhere: such nodes are never in a triple).
        let phi = self.relative_support(lumped);
        let mut psi = vec![0.0; len];
        for r in self.segments.iter().flat_map(|&(lo, hi)| lo..hi) {
            let own = lumped[start + r];
            let delta = if own > 0.0 { self.values[pad + r] / own } else { 0.0 };
            psi[r] = phi[r].min(delta / full);
        }
        let [nx, ny] = nodes_per_axis;
        let [sx, sy] = self.strides;
        // Per axis: the stride, the slots of offsets +1 and +2 lines, and the line count.
        for (stride, lines_along, count_across) in [(sx, nx, ny), (sy, ny, nx)] {
            let other = if stride == sx { sy } else { sx };
            let (o1, o2) = (
                self.offset_index(stride as isize).expect("couplings one line apart"),
                self.offset_index(2 * stride as isize)
                    .expect("couplings two lines apart (reassemble_extended)"),
            );
            let (m1, m2) = (k - 1 - o1, k - 1 - o2);
            for across in 0..count_across {
                for along in 1..lines_along.saturating_sub(1) {
                    let b = along * stride + across * other;
                    let (a, c) = (b - stride, b + stride);
                    if a < start || c >= start + len || !(active[a] && active[b] && active[c]) {
                        continue;
                    }
                    let (ra, rb, rc) = (a - start, b - start, c - start);
                    let psi_t = psi[ra].min(psi[rb]).min(psi[rc]);
                    let ramp = super::extension::extension_ramp(psi_t, threshold, onset);
                    if ramp <= 0.0 {
                        continue;
                    }
                    let w = gamma * ramp * lumped[a].max(lumped[b]).max(lumped[c]);
                    self.penalty.push(([a as u32, b as u32, c as u32], w));
                    self.add_penalty_term([ra, rb, rc], w, [o1, o2]);
                    self.pattern[ra] |= 1 << o1 | 1 << o2;
                    self.pattern[rb] |= 1 << o1 | 1 << m1;
                    self.pattern[rc] |= 1 << m1 | 1 << m2;
                }
            }
        }
    }

    /// `w d_T d_Tᵀ` added to the stored values for the triple of span rows `[ra, rb, rc]`
    /// along a grid line whose offsets of one and two lines are `o1`, `o2` (the upper half:
    /// the diagonal, `−2w` one line on, `w` two lines on).
    fn add_penalty_term(&mut self, [ra, rb, rc]: [usize; 3], w: f64, [o1, o2]: [usize; 2]) {
        let (pad, centre) = (self.pad, self.width() / 2);
        let plen = self.len + 2 * pad;
        self.values[pad + ra] += w;
        self.values[pad + rb] += 4.0 * w;
        self.values[pad + rc] += w;
        self.values[(o1 - centre) * plen + pad + ra] -= 2.0 * w;
        self.values[(o1 - centre) * plen + pad + rb] -= 2.0 * w;
        self.values[(o2 - centre) * plen + pad + ra] += w;
    }

    /// `B = M_s + R` into `out` (its buffers reused): this matrix, `M_s = M + R` after
    /// [`StencilMass::add_extension_penalty`], with the recorded penalty `R` added once more,
    ///
    /// ```text
    /// B = M + 2R,   R = Σ_T γ w_T d_T d_Tᵀ
    /// ```
    ///
    /// so that a product with `B` is one sweep over the couplings. `out` records the same
    /// penalty terms as this matrix.
    pub(crate) fn penalty_twice_into(&self, out: &mut StencilMass) {
        out.num_nodes = self.num_nodes;
        out.shape = self.shape;
        (out.start, out.len, out.strides, out.pad) = (self.start, self.len, self.strides, self.pad);
        out.offsets.clone_from(&self.offsets);
        out.values.clone_from(&self.values);
        out.pattern.clone_from(&self.pattern);
        out.segments.clone_from(&self.segments);
        out.penalty.clone_from(&self.penalty);
        if self.penalty.is_empty() {
            return;
        }
        let k = self.width();
        let slots = |stride: usize| {
            let at = |o: isize| self.offsets.binary_search(&o).expect("a penalty's offsets are stored");
            [at(stride as isize), at(2 * stride as isize)]
        };
        let along = [slots(self.strides[0]), slots(self.strides[1])];
        debug_assert!(along.iter().all(|o| o.iter().all(|&o| o < k)));
        for &([a, b, c], w) in &self.penalty {
            let axis = usize::from(b as usize - a as usize != self.strides[0]);
            let rows = [a, b, c].map(|i| i as usize - self.start);
            out.add_penalty_term(rows, w, along[axis]);
        }
    }

    /// Partial lumping of the nodes with little mass relative to their neighbours (the same
    /// matrix as [`super::stabilization::partially_lumped`]):
    ///
    /// Per span row, the node's lumped mass relative to the heaviest node it is coupled to:
    ///
    /// ```text
    /// φ_I = m_L,I / max_{J: M_IJ stored} m_L,J     (1 where no coupled node has mass, and off the segments)
    /// ```
    fn relative_support(&self, lumped: &[f64]) -> Vec<f64> {
        let (k, start) = (self.width(), self.start);
        let mut phi = vec![1.0; self.len];
        for r in self.segments.iter().flat_map(|&(lo, hi)| lo..hi) {
            let own = lumped[start + r];
            let bits = self.pattern[r];
            let heaviest = (0..k)
                .filter(|&o| bits >> o & 1 == 1)
                .map(|o| lumped[(start as isize + r as isize + self.offsets[o]) as usize])
                .fold(own, f64::max);
            phi[r] = if heaviest > 0.0 { own / heaviest } else { 1.0 };
        }
        phi
    }

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
        let phi = self.relative_support(lumped);
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
fn apply_segments(m: &StencilMass, x: &[f64], out: &mut [f64], mask: &[f64]) -> f64 {
    let k = m.offsets.len();
    let centre = k / 2;
    let plen = m.len + 2 * m.pad;
    let mut dot = [0.0; 8];
    for &(lo, hi) in &m.segments {
        let (lo, hi) = (lo + m.pad, hi + m.pad);
        let y = &mut out[lo..hi];
        for ((y, a), x) in y.iter_mut().zip(&m.values[lo..hi]).zip(&x[lo..hi]) {
            *y = a * x;
        }
        for o in centre + 1..k {
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

/// [`apply_segments`] of two vectors with their own masks, one sweep over the couplings.
fn apply_segments_pair(m: &StencilMass, x: [&[f64]; 2], out: [&mut [f64]; 2], mask: [&[f64]; 2]) {
    let k = m.offsets.len();
    let centre = k / 2;
    let plen = m.len + 2 * m.pad;
    let [xa, xb] = x;
    let [oa, ob] = out;
    let [ma, mb] = mask;
    for &(lo, hi) in &m.segments {
        let (lo, hi) = (lo + m.pad, hi + m.pad);
        let len = hi - lo;
        let (ya, yb) = (&mut oa[lo..hi], &mut ob[lo..hi]);
        let diagonal = &m.values[lo..hi];
        for i in 0..len {
            ya[i] = diagonal[i] * xa[lo + i];
            yb[i] = diagonal[i] * xb[lo + i];
        }
        for o in centre + 1..k {
            let off = m.offsets[o];
            let base = (o - centre) * plen;
            let up = &m.values[base + lo..base + hi];
            let down_at = (base as isize + lo as isize - off) as usize;
            let down = &m.values[down_at..down_at + len];
            let (u_at, d_at) = ((lo as isize + off) as usize, (lo as isize - off) as usize);
            let (xau, xad) = (&xa[u_at..u_at + len], &xa[d_at..d_at + len]);
            let (xbu, xbd) = (&xb[u_at..u_at + len], &xb[d_at..d_at + len]);
            for i in 0..len {
                ya[i] += up[i] * xau[i] + down[i] * xad[i];
                yb[i] += up[i] * xbu[i] + down[i] * xbd[i];
            }
        }
        for i in 0..len {
            if ma[lo + i] == 0.0 {
                ya[i] = 0.0;
            }
            if mb[lo + i] == 0.0 {
                yb[i] = 0.0;
            }
        }
    }
}
