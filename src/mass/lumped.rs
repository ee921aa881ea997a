//! The lumped solve, the one definition of `u = M_L⁻¹ r` in the crate: the lumped scheme, the
//! fallback of a singular matrix, the first term of the truncated series, the initial guess of
//! the conjugate gradient, the time loop and the stable-step estimate all call it.

use super::GridMass;
use crate::fields::VectorField;

impl GridMass {
    /// `u = M_L⁻¹ r` with the prescribed components set:
    ///
    /// ```text
    /// u_I = r_I · (1 / m_L,I)    on active nodes,   u_I = 0 on inactive nodes,
    /// u_I,c = u_D,I,c            on the prescribed components c of active nodes (0 without u_D)
    /// ```
    ///
    /// with the inverse of [`GridMass::inverse_lumped`]. Allocates nothing once `u` has one
    /// entry per node.
    ///
    /// # Panics
    /// If `r` (or `prescribed`) does not have one entry per node.
    pub fn solve_lumped(&self, r: &VectorField, prescribed: Option<&VectorField>, u: &mut VectorField) {
        let inv = &self.inverse;
        let n = inv.len();
        assert_eq!(r.len(), n, "right-hand side must have one entry per node");
        u.x.resize(n, 0.0);
        u.y.resize(n, 0.0);
        for (c, rc) in [(&mut u.x, &r.x), (&mut u.y, &r.y)] {
            for ((u, r), inv) in c.iter_mut().zip(rc).zip(inv) {
                *u = r * inv;
            }
        }
        let fixed = [&self.constraints.fixed_x, &self.constraints.fixed_y];
        for (c, out) in [&mut u.x, &mut u.y].into_iter().enumerate() {
            let value = prescribed.map(|p| if c == 0 { &p.x } else { &p.y });
            for &i in fixed[c].iter().filter(|&&i| i < n) {
                out[i] = match value {
                    Some(v) if self.is_active[i] => v[i],
                    _ => 0.0,
                };
            }
        }
    }
}
