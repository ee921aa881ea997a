//! The factored columns of one particle, or of four side by side ([`Real`]): what the
//! transfers read of the operators.

use crate::lanes::Real;
use crate::operators::Operators;

/// Particles `k … k + R::LANES − 1`, one per lane: their 1D weights and derivatives per axis,
/// the offsets to the stencil's node lines, and each one's first node.
pub(crate) struct Columns<R, const S: usize> {
    /// `wx[a]`, `w′x[a]`, `wy[a]`, `w′y[a]` (as [`crate::operators::Stencil`]).
    pub wx: [R; S],
    pub dwx: [R; S],
    pub wy: [R; S],
    pub dwy: [R; S],
    /// `x_{i0+a} − x_p` and `y_{j0+a} − y_p` (as [`crate::operators::Stencil::offsets`]).
    pub dx: [R; S],
    pub dy: [R; S],
    /// Each lane's first node.
    pub first: [usize; 4],
    /// Node-number distance between runs, and whether runs go along x.
    pub run_stride: usize,
    pub runs_along_x: bool,
}

impl<R: Real, const S: usize> Columns<R, S> {
    /// The columns of particles `k …` of `ops`, at positions `(xp, yp)`.
    ///
    /// # Panics
    /// If `S` is not the operators' support or `k + R::LANES` exceeds the particle count.
    #[inline(always)]
    pub(crate) fn load(ops: &Operators, k: usize, xp: R, yp: R) -> Columns<R, S> {
        assert_eq!(S, ops.support(), "stencil size must equal the support");
        let firsts = &ops.first_nodes()[k..k + R::LANES];
        let zero = R::splat(0.0);
        let (mut wx, mut dwx, mut wy, mut dwy) = ([zero; S], [zero; S], [zero; S], [zero; S]);
        if ops.stores_factors() {
            let f = ops.factors_block(k, R::LANES);
            let per = 4 * S;
            for a in 0..S {
                wx[a] = R::from_fn(|l| f[l * per + a]);
                dwx[a] = R::from_fn(|l| f[l * per + S + a]);
                wy[a] = R::from_fn(|l| f[l * per + 2 * S + a]);
                dwy[a] = R::from_fn(|l| f[l * per + 3 * S + a]);
            }
        } else {
            let ([fx, fy], [tx, ty]) = (ops.frames(), ops.local());
            (wx, dwx) = fx.weights_at::<R, S>(R::load(tx, k));
            (wy, dwy) = fy.weights_at::<R, S>(R::load(ty, k));
        }
        let [sx, sy] = ops.strides();
        let ([ox, oy], [hx, hy]) = (ops.origin(), ops.cell_size());
        let lane = |l: usize| firsts[l.min(R::LANES - 1)];
        let mut first = [0; 4];
        for (l, f) in first.iter_mut().enumerate() {
            let [i, j] = lane(l);
            *f = i as usize * sx + j as usize * sy;
        }
        // x_{i0+a} = x₀ + (i0 + a) h, with (i0 + a) an exact integer in either form.
        let (i0, j0) = (R::from_fn(|l| lane(l)[0] as f64), R::from_fn(|l| lane(l)[1] as f64));
        let (mut dx, mut dy) = ([zero; S], [zero; S]);
        for a in 0..S {
            let a_f = R::splat(a as f64);
            dx[a] = (R::splat(ox) + (i0 + a_f) * R::splat(hx)) - xp;
            dy[a] = (R::splat(oy) + (j0 + a_f) * R::splat(hy)) - yp;
        }
        let runs_along_x = sx == 1;
        Columns {
            wx,
            dwx,
            wy,
            dwy,
            dx,
            dy,
            first,
            run_stride: if runs_along_x { sy } else { sx },
            runs_along_x,
        }
    }

    /// The axis indices `(x, y)` of stencil position `a` along run `b`.
    #[inline(always)]
    pub(crate) fn axes(&self, b: usize, a: usize) -> (usize, usize) {
        if self.runs_along_x {
            (a, b)
        } else {
            (b, a)
        }
    }

    /// `N`, `Gx`, `Gy` at stencil position `a` of run `b`:
    /// `wx wy`, `w′x wy`, `wx w′y` (as [`crate::operators::Stencil::row`]).
    #[inline(always)]
    pub(crate) fn values(&self, b: usize, a: usize) -> (R, R, R) {
        let (i, j) = self.axes(b, a);
        (self.wx[i] * self.wy[j], self.dwx[i] * self.wy[j], self.wx[i] * self.dwy[j])
    }

    /// `N` alone at stencil position `a` of run `b`.
    #[inline(always)]
    pub(crate) fn n(&self, b: usize, a: usize) -> R {
        let (i, j) = self.axes(b, a);
        self.wx[i] * self.wy[j]
    }

    /// `(x_I − x_p, y_I − y_p)` at stencil position `a` of run `b`.
    #[inline(always)]
    pub(crate) fn offset(&self, b: usize, a: usize) -> (R, R) {
        let (i, j) = self.axes(b, a);
        (self.dx[i], self.dy[j])
    }

    /// The first node of run `b` of lane `l`.
    #[inline(always)]
    pub(crate) fn run_start(&self, l: usize, b: usize) -> usize {
        self.first[l] + b * self.run_stride
    }
}
