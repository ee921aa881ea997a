//! The factored columns of one particle, or of four side by side ([`Real`]): what the
//! transfers read of the operators.
//!
//! A stencil's nodes come in runs of consecutive node numbers ([`crate::operators::Stencil`]):
//! the axis along a run is `α` (x for x-fastest node numbering), the axis across the runs `β`.
//! Node `a` of run `b` has `N = wα_a wβ_b`, `∂N/∂α = w′α_a wβ_b`, `∂N/∂β = wα_a w′β_b`, and the
//! offsets `x_I − x_p` are `dα_a` along `α` and `dβ_b` along `β`.

use crate::lanes::Real;
use crate::operators::{ColumnView, Operators};

/// Particles `k … k + R::LANES − 1`, one per lane: their 1D weights, derivatives and node
/// offsets along and across the runs of their stencils, and each one's first node.
pub(crate) struct Columns<R, const S: usize> {
    /// `wα_a`, `w′α_a`, `dα_a` (along a run).
    pub wa: [R; S],
    pub dwa: [R; S],
    pub da: [R; S],
    /// `wβ_b`, `w′β_b`, `dβ_b` (across the runs).
    pub wb: [R; S],
    pub dwb: [R; S],
    pub db: [R; S],
    /// Each lane's first node (0 past `R::LANES`).
    pub first: [usize; 8],
    /// Node-number distance between runs, and whether runs go along x (`α = x`).
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
        Columns::load_view(&ops.view(), k, xp, yp)
    }

    /// The columns of entries `k …` of `view`, at positions `(xp, yp)`.
    ///
    /// # Panics
    /// If `S` is not the support or `k + R::LANES` exceeds the view's length.
    #[inline(always)]
    pub(crate) fn load_view(view: &ColumnView, k: usize, xp: R, yp: R) -> Columns<R, S> {
        let layout = &view.layout;
        assert!(S == layout.support, "stencil size must equal the support");
        let zero = R::splat(0.0);
        let (mut wx, mut dwx, mut wy, mut dwy) = ([zero; S], [zero; S], [zero; S], [zero; S]);
        if let Some(factors) = view.factors {
            let per = 4 * S;
            let f = &factors[per * k..per * (k + R::LANES)];
            for a in 0..S {
                wx[a] = R::from_fn(|l| f[l * per + a]);
                dwx[a] = R::from_fn(|l| f[l * per + S + a]);
                wy[a] = R::from_fn(|l| f[l * per + 2 * S + a]);
                dwy[a] = R::from_fn(|l| f[l * per + 3 * S + a]);
            }
        } else {
            let ([fx, fy], [tx, ty]) = (&layout.frames, view.local);
            (wx, dwx) = fx.weights_at::<R, S>(R::load(tx, k));
            (wy, dwy) = fy.weights_at::<R, S>(R::load(ty, k));
        }
        let [sx, sy] = layout.strides;
        let ([ox, oy], [hx, hy]) = (layout.origin, layout.cell_size);
        let ([i0, j0], first) = R::first_nodes(view.first, k, [sx, sy]);
        // x_{i0+a} = x₀ + (i0 + a) h, with (i0 + a) an exact integer in either form.
        let (mut dx, mut dy) = ([zero; S], [zero; S]);
        for a in 0..S {
            let a_f = R::splat(a as f64);
            dx[a] = (R::splat(ox) + (i0 + a_f) * R::splat(hx)) - xp;
            dy[a] = (R::splat(oy) + (j0 + a_f) * R::splat(hy)) - yp;
        }
        let runs_along_x = sx == 1;
        if runs_along_x {
            Columns {
                wa: wx,
                dwa: dwx,
                da: dx,
                wb: wy,
                dwb: dwy,
                db: dy,
                first,
                run_stride: sy,
                runs_along_x,
            }
        } else {
            Columns {
                wa: wy,
                dwa: dwy,
                da: dy,
                wb: wx,
                dwb: dwx,
                db: dx,
                first,
                run_stride: sx,
                runs_along_x,
            }
        }
    }

    /// `(along, across)` as `(x, y)`.
    #[inline(always)]
    pub(crate) fn xy<T>(&self, along: T, across: T) -> (T, T) {
        if self.runs_along_x {
            (along, across)
        } else {
            (across, along)
        }
    }

    /// `N` at node `a` of run `b`: `wα_a wβ_b` (as [`crate::operators::Stencil::row`]).
    #[inline(always)]
    pub(crate) fn n(&self, b: usize, a: usize) -> R {
        self.wa[a] * self.wb[b]
    }

    /// `(x_I − x_p, y_I − y_p)` at node `a` of run `b`.
    #[inline(always)]
    pub(crate) fn offset(&self, b: usize, a: usize) -> (R, R) {
        self.xy(self.da[a], self.db[b])
    }

    /// The first node of run `b` of lane `l`.
    #[inline(always)]
    pub(crate) fn run_start(&self, l: usize, b: usize) -> usize {
        self.first[l] + b * self.run_stride
    }
}
