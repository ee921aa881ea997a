//! The linear-extension penalty `R` of the update bound ([`super::bound`]) row by row.

/// The linear-extension penalty `R` row by row where it is not zero: per node, the entries
/// at offsets `±2, ±1` grid lines along x, then along y, then the diagonal.
#[derive(Debug, Default)]
pub(super) struct PenaltyRows {
    /// Per node, the index of its row in `rows` (`u32::MAX`: none); reset where set.
    slot_of: Vec<u32>,
    pub(super) nodes: Vec<usize>,
    rows: Vec<[f64; 9]>,
}

impl PenaltyRows {
    /// Slot of the coupling from node `a` to node `b` on the same grid line, `b − a = k · stride`.
    pub(super) fn slot(k: isize, along_x: bool) -> usize {
        let base = if along_x { 0 } else { 4 };
        match k {
            0 => 8,
            -2 => base,
            -1 => base + 1,
            1 => base + 2,
            2 => base + 3,
            _ => unreachable!("a penalty triple spans two lines"),
        }
    }

    /// The rows of `Σ_T w_T d_T d_Tᵀ` from its terms, over `n` nodes.
    pub(super) fn fill(&mut self, terms: &[([u32; 3], f64)], stride_x: usize, n: usize) {
        const D: [f64; 3] = [1.0, -2.0, 1.0];
        for &i in &self.nodes {
            self.slot_of[i] = u32::MAX;
        }
        self.slot_of.resize(n, u32::MAX);
        self.nodes.clear();
        self.rows.clear();
        for &(t, w) in terms {
            let t = t.map(|i| i as usize);
            let along_x = t[1] - t[0] == stride_x;
            for j in 0..3 {
                if self.slot_of[t[j]] == u32::MAX {
                    self.slot_of[t[j]] = self.rows.len() as u32;
                    self.rows.push([0.0; 9]);
                    self.nodes.push(t[j]);
                }
                let row = &mut self.rows[self.slot_of[t[j]] as usize];
                for k in 0..3 {
                    row[Self::slot(k as isize - j as isize, along_x)] += w * D[j] * D[k];
                }
            }
        }
    }

    /// `R_IJ` for nodes `i`, `j` (0 where the penalty does not couple them).
    pub(super) fn entry(&self, i: usize, j: usize, strides: [usize; 2]) -> f64 {
        let Some(&slot) = self.slot_of.get(i).filter(|&&s| s != u32::MAX) else {
            return 0.0;
        };
        let row = &self.rows[slot as usize];
        let d = j as isize - i as isize;
        if d == 0 {
            return row[8];
        }
        for (axis, &stride) in strides.iter().enumerate() {
            for (k, m) in [(-2isize, 0), (-1, 1), (1, 2), (2, 3)] {
                if d == k * stride as isize {
                    return row[4 * axis + m];
                }
            }
        }
        0.0
    }

    /// `R_II` for a node `i` in [`PenaltyRows::nodes`].
    pub(super) fn diagonal(&self, i: usize) -> f64 {
        self.rows[self.slot_of[i] as usize][8]
    }
}
