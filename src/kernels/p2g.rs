//! (2)–(5) and MUSL's re-projection: the particle-to-grid passes, into interleaved per-node
//! accumulators over bands of grid lines (one band per worker, see [`crate::parallel`]).

use super::simd::dispatch;
use super::{apic_affine, Affine, ApicInertia, GridState, Stress};
use crate::fields::VectorField;
use crate::operators::{Operators, Stencil};
use crate::parallel::Workers;
use crate::particles::Particles;

/// (2)–(5) in one pass over the shared pattern of N, Gx, Gy, into `lumped` (`m_L`),
/// `grid.momentum`, `grid.force` and `grid.angular_momentum`:
///
/// ```text
/// m_L = N m,   q = N (m ∘ v) [+ APIC: Σ_p N_Ip m_p C_p (x_I − x_p)],
/// f = N (m ∘ b) + m_L g − [Gx (V∘σxx) + Gy (V∘σxy); Gx (V∘σxy) + Gy (V∘σyy)]   (Stress::Include)
/// ```
///
/// # Panics
/// If `lumped` or `grid` does not have one entry per node of the operators.
#[allow(clippy::too_many_arguments)]
pub fn p2g(
    ops: &Operators,
    p: &Particles,
    apic: Option<ApicInertia>,
    gravity: [f64; 2],
    stress: Stress,
    lumped: &mut [f64],
    grid: &mut GridState,
    workers: &Workers,
) {
    let n = ops.num_nodes();
    assert!(
        lumped.len() == n && grid.momentum.len() == n,
        "grid mass and state sized for the operators' nodes"
    );
    let span = ops.node_span();
    // Zero what the last p2g left outside the new span.
    let old = grid.span.clone();
    let below = old.start..old.end.min(span.start);
    let above = old.start.max(span.end)..old.end;
    for range in [below, above].into_iter().filter(|r| r.start < r.end) {
        lumped[range.clone()].fill(0.0);
        for field in [&mut grid.momentum, &mut grid.force] {
            field.x[range.clone()].fill(0.0);
            field.y[range.clone()].fill(0.0);
        }
    }
    let internal = if stress == Stress::Include { 1.0 } else { 0.0 };
    let (acc, base) = scatter_bands(ops, &mut grid.accumulator, workers, |acc, base, lines| {
        crate::with_support!(ops, p2g_columns::<S>(ops, p, apic, internal, acc, base, lines))
    });
    let [gx, gy] = gravity;
    let mut angular = 0.0;
    let (line_len, ([ox, oy], [hx, hy])) = (ops.line_length(), grid.frame);
    let runs_along_x = ops.strides()[0] == 1;
    // Node i's index along its line and its line, counted up with i.
    let (mut along, mut across) = (span.start % line_len.max(1), span.start / line_len.max(1));
    for i in span.clone() {
        let r = acc[i - base];
        lumped[i] = r[0];
        grid.momentum.x[i] = r[1];
        grid.momentum.y[i] = r[2];
        grid.force.x[i] = r[3] + r[0] * gx;
        grid.force.y[i] = r[4] + r[0] * gy;
        // Grid::node_position of node i, formed as it forms it.
        let (ix, iy) = if runs_along_x { (along, across) } else { (across, along) };
        let (xi, yi) = (ox + ix as f64 * hx, oy + iy as f64 * hy);
        angular += xi * r[2] - yi * r[1];
        along += 1;
        if along == line_len {
            (along, across) = (0, across + 1);
        }
    }
    grid.angular_momentum = angular;
    grid.span = span;
}

/// A deterministic scatter into the interleaved accumulator: zeroes it over the operators'
/// whole lines ([`Operators::line_span`]), cuts it into one band of lines per worker and runs
/// `fill(band, first node of the band, lines of the band)` on each (see [`crate::parallel`]).
/// Returns the accumulator and the node number of its first entry.
fn scatter_bands<'a>(
    ops: &Operators,
    acc: &'a mut Vec<[f64; 5]>,
    workers: &Workers,
    fill: impl Fn(&mut [[f64; 5]], usize, std::ops::Range<usize>) + Sync,
) -> (&'a [[f64; 5]], usize) {
    let (line_len, lines) = (ops.line_length(), ops.line_span());
    acc.clear();
    acc.resize(lines.len() * line_len, [0.0; 5]);
    let per_band = lines.len().div_ceil(workers.threads()).max(1);
    workers.chunks(acc, per_band * line_len, |t, band| {
        let first = lines.start + t * per_band;
        fill(band, first * line_len, first..(first + per_band).min(lines.end));
    });
    (acc, lines.start * line_len)
}

dispatch! {
    /// The particle loop of [`p2g`] for a support of `S` nodes per axis, into the interleaved
    /// accumulator of the nodes from `base`.
    fn p2g_columns / p2g_columns_avx2 = p2g_columns_body(
        ops: &Operators,
        p: &Particles,
        apic: Option<ApicInertia>,
        internal: f64,
        acc: &mut [[f64; 5]],
        base: usize,
        lines: std::ops::Range<usize>
    ) -> ()
}

/// One particle's terms of (2)–(5) that do not depend on the node.
#[derive(Clone, Copy)]
struct Sources {
    m: f64,
    mv: [f64; 2],
    mb: [f64; 2],
    /// `V σ` as `[xx, yy, xy]` (zero when the stress is omitted).
    vs: [f64; 3],
    /// APIC's `C_p` (zero without APIC).
    c: [f64; 4],
}

#[inline(always)]
fn sources(ops: &Operators, p: &Particles, apic: Option<ApicInertia>, internal: f64, k: usize) -> Sources {
    let m = p.mass[k];
    let v = internal * p.volume[k];
    Sources {
        m,
        mv: [m * p.vx[k], m * p.vy[k]],
        mb: [m * p.bx[k], m * p.by[k]],
        vs: [v * p.sxx[k], v * p.syy[k], v * p.sxy[k]],
        c: apic.map_or([0.0; 4], |kind| apic_affine(p, k, ops, kind).c),
    }
}

/// The body of [`p2g_columns`]: every particle whose stencil reaches the band, in order, its
/// terms added to the nodes of the band ([`scatter_one`], or its AVX2 form).
#[inline(always)]
fn p2g_columns_body<const S: usize, const AVX2: bool>(
    ops: &Operators,
    p: &Particles,
    apic: Option<ApicInertia>,
    internal: f64,
    acc: &mut [[f64; 5]],
    base: usize,
    lines: std::ops::Range<usize>,
) {
    #[cfg(target_arch = "x86_64")]
    if AVX2 {
        debug_assert!(std::arch::is_x86_feature_detected!("avx2"));
        // SAFETY: the AVX2 instance runs only where the CPU has AVX2 (`dispatch!`).
        unsafe { p2g_four_lanes::<S>(ops, p, apic, internal, acc, base, lines) };
        return;
    }
    in_band::<S>(ops, p.len(), &lines, |k, rows| {
        let q = sources(ops, p, apic, internal, k);
        scatter_one::<S>(ops, p, &q, k, acc, base, rows)
    });
}

/// [`p2g_columns_body`]'s particle walk in the AVX2 build: four particles at a time where all
/// four stencils lie in the band ([`scatter_four`]), one at a time otherwise
/// ([`scatter_one_avx2`]); every node still receives its terms in particle order.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn p2g_four_lanes<const S: usize>(
    ops: &Operators,
    p: &Particles,
    apic: Option<ApicInertia>,
    internal: f64,
    acc: &mut [[f64; 5]],
    base: usize,
    lines: std::ops::Range<usize>,
) {
    let np = p.len();
    let inside = |k: usize| {
        let l0 = ops.first_line(k);
        l0 >= lines.start && l0 + S <= lines.end
    };
    let mut k = 0;
    while k < np {
        if k + 4 <= np && inside(k) && inside(k + 1) && inside(k + 2) && inside(k + 3) {
            scatter_four::<S>(ops, p, apic, internal, k, acc, base);
            k += 4;
            continue;
        }
        let l0 = ops.first_line(k);
        if l0 + S > lines.start && l0 < lines.end {
            let rows = lines.start.saturating_sub(l0)..(lines.end - l0).min(S);
            let q = sources(ops, p, apic, internal, k);
            scatter_one_avx2::<S>(ops, p, &q, k, acc, base, rows);
        }
        k += 1;
    }
}

/// The terms of particles `k … k + 3`, one per lane, formed with [`scatter_one`]'s operations
/// in its order, then added to each node lane after lane (particle order): the same bits as
/// four calls of [`scatter_one`].
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
#[allow(clippy::too_many_arguments)]
fn scatter_four<const S: usize>(
    ops: &Operators,
    p: &Particles,
    apic: Option<ApicInertia>,
    internal: f64,
    k: usize,
    acc: &mut [[f64; 5]],
    base: usize,
) {
    use super::simd::four::{four, lanes, load, transpose};
    use std::arch::x86_64::*;
    let f = four::<S>(ops, &p.x, &p.y, k);
    let m = load(&p.mass, k);
    let (mvx, mvy) = (_mm256_mul_pd(m, load(&p.vx, k)), _mm256_mul_pd(m, load(&p.vy, k)));
    let (mbx, mby) = (_mm256_mul_pd(m, load(&p.bx, k)), _mm256_mul_pd(m, load(&p.by, k)));
    let v = _mm256_mul_pd(_mm256_set1_pd(internal), load(&p.volume, k));
    let (vsxx, vsyy, vsxy) = (
        _mm256_mul_pd(v, load(&p.sxx, k)),
        _mm256_mul_pd(v, load(&p.syy, k)),
        _mm256_mul_pd(v, load(&p.sxy, k)),
    );
    // C_p as apic_affine forms it.
    let c: [__m256d; 4] = match apic {
        None => [_mm256_setzero_pd(); 4],
        Some(ApicInertia::StoredC) => [
            load(&p.affine_xx, k),
            load(&p.affine_xy, k),
            load(&p.affine_yx, k),
            load(&p.affine_yy, k),
        ],
        Some(ApicInertia::Constant([dxx, dyy])) => {
            let (dxx, dyy) = (_mm256_set1_pd(dxx), _mm256_set1_pd(dyy));
            [
                _mm256_div_pd(load(&p.affine_xx, k), dxx),
                _mm256_div_pd(load(&p.affine_xy, k), dyy),
                _mm256_div_pd(load(&p.affine_yx, k), dxx),
                _mm256_div_pd(load(&p.affine_yy, k), dyy),
            ]
        }
        Some(kind @ ApicInertia::Column) => {
            let cs: [[f64; 4]; 4] = std::array::from_fn(|l| apic_affine(p, k + l, ops, kind).c);
            std::array::from_fn(|i| _mm256_setr_pd(cs[0][i], cs[1][i], cs[2][i], cs[3][i]))
        }
    };
    // Every lane's terms first, then lane after lane into the grid: lanes whose stencils
    // overlap at different stencil positions still reach a shared node in particle order.
    let mut terms = [[_mm256_setzero_pd(); 4]; 16];
    let mut fy = [[0.0; 4]; 16];
    for b in 0..S {
        for a in 0..S {
            let (xi, yi) = if f.runs_along_x { (a, b) } else { (b, a) };
            let n = _mm256_mul_pd(f.wx[xi], f.wy[yi]);
            let gx = _mm256_mul_pd(f.dwx[xi], f.wy[yi]);
            let gy = _mm256_mul_pd(f.wx[xi], f.dwy[yi]);
            let (ddx, ddy) = (f.dx[xi], f.dy[yi]);
            // Affine::velocity: n (C (x_I − x_p)).
            let ax = _mm256_mul_pd(n, _mm256_add_pd(_mm256_mul_pd(c[0], ddx), _mm256_mul_pd(c[1], ddy)));
            let ay = _mm256_mul_pd(n, _mm256_add_pd(_mm256_mul_pd(c[2], ddx), _mm256_mul_pd(c[3], ddy)));
            let t0 = _mm256_mul_pd(n, m);
            let t1 = _mm256_add_pd(_mm256_mul_pd(n, mvx), _mm256_mul_pd(m, ax));
            let t2 = _mm256_add_pd(_mm256_mul_pd(n, mvy), _mm256_mul_pd(m, ay));
            let t3 = _mm256_sub_pd(
                _mm256_mul_pd(n, mbx),
                _mm256_add_pd(_mm256_mul_pd(gx, vsxx), _mm256_mul_pd(gy, vsxy)),
            );
            let t4 = _mm256_sub_pd(
                _mm256_mul_pd(n, mby),
                _mm256_add_pd(_mm256_mul_pd(gx, vsxy), _mm256_mul_pd(gy, vsyy)),
            );
            // Lane l's [m, q_x, q_y, f_x] terms, and its f_y term.
            terms[b * S + a] = transpose([t0, t1, t2, t3]);
            fy[b * S + a] = lanes(t4);
        }
    }
    for l in 0..4 {
        for b in 0..S {
            let start = f.first[l] + b * f.run_stride - base;
            let r = &mut acc[start..start + S];
            for a in 0..S {
                let r = &mut r[a];
                // SAFETY: a node's accumulator holds 5 values; the load and store take the first 4.
                unsafe {
                    let sum = _mm256_add_pd(_mm256_loadu_pd(r.as_ptr()), terms[b * S + a][l]);
                    _mm256_storeu_pd(r.as_mut_ptr(), sum);
                }
                r[4] += fy[b * S + a][l];
            }
        }
    }
}

/// Particle `k`'s terms of (2)–(5), `q` its node-independent factors, added to the nodes of
/// its stencil rows `rows`.
#[inline(always)]
fn scatter_one<const S: usize>(
    ops: &Operators,
    p: &Particles,
    q: &Sources,
    k: usize,
    acc: &mut [[f64; 5]],
    base: usize,
    rows: std::ops::Range<usize>,
) {
    let affine = Affine { c: q.c };
    let st = ops.stencil::<S>(k);
    let offsets = st.offsets(p.x[k], p.y[k]);
    for b in rows {
        let (start, n, gx, gy) = st.row(b);
        let (dx, dy) = st.run_offsets(&offsets, b);
        let r = &mut acc[start - base..start - base + S];
        for a in 0..S {
            let [ax, ay] = affine.velocity(dx[a], dy[a], n[a]);
            let r = &mut r[a];
            r[0] += n[a] * q.m;
            r[1] += n[a] * q.mv[0] + q.m * ax;
            r[2] += n[a] * q.mv[1] + q.m * ay;
            r[3] += n[a] * q.mb[0] - (gx[a] * q.vs[0] + gy[a] * q.vs[2]);
            r[4] += n[a] * q.mb[1] - (gx[a] * q.vs[2] + gy[a] * q.vs[1]);
        }
    }
}

/// [`scatter_one`] with a node's `[m, q_x, q_y, f_x]` in one 4-wide vector (`f_y` beside it):
/// the same products and sums, lane by lane, in the same order (so the same bits; see
/// [`super::simd`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn scatter_one_avx2<const S: usize>(
    ops: &Operators,
    p: &Particles,
    q: &Sources,
    k: usize,
    acc: &mut [[f64; 5]],
    base: usize,
    rows: std::ops::Range<usize>,
) {
    use std::arch::x86_64::*;
    let st = ops.stencil::<S>(k);
    let offsets = st.offsets(p.x[k], p.y[k]);
    let sources = _mm256_setr_pd(q.m, q.mv[0], q.mv[1], q.mb[0]);
    let mass = _mm256_set1_pd(q.m);
    // Lanes 1 and 2: Affine::velocity's C rows; lane 3: the stress of f_x.
    let (c_dx, c_dy) = (
        _mm256_setr_pd(0.0, q.c[0], q.c[2], 0.0),
        _mm256_setr_pd(0.0, q.c[1], q.c[3], 0.0),
    );
    let (s_gx, s_gy) = (
        _mm256_setr_pd(0.0, 0.0, 0.0, q.vs[0]),
        _mm256_setr_pd(0.0, 0.0, 0.0, q.vs[2]),
    );
    for b in rows {
        let (start, n, gx, gy) = st.row(b);
        let (dx, dy) = st.run_offsets(&offsets, b);
        let r = &mut acc[start - base..start - base + S];
        for a in 0..S {
            let nn = _mm256_set1_pd(n[a]);
            // [·, ax, ay, ·] = n (C (x_I − x_p)), as Affine::velocity.
            let dxy = _mm256_add_pd(
                _mm256_mul_pd(c_dx, _mm256_set1_pd(dx[a])),
                _mm256_mul_pd(c_dy, _mm256_set1_pd(dy[a])),
            );
            let affine = _mm256_mul_pd(mass, _mm256_mul_pd(nn, dxy));
            // gx V σxx + gy V σxy in lane 3.
            let stress = _mm256_add_pd(
                _mm256_mul_pd(_mm256_set1_pd(gx[a]), s_gx),
                _mm256_mul_pd(_mm256_set1_pd(gy[a]), s_gy),
            );
            // Lane 0 n m, lanes 1–2 n m v + m a, lane 3 n m b − stress: the scalar operations
            // exactly, non-finite values included.
            let own = _mm256_mul_pd(nn, sources);
            let plus = _mm256_add_pd(own, affine);
            let minus = _mm256_sub_pd(own, stress);
            let term = _mm256_blend_pd::<0b1000>(_mm256_blend_pd::<0b0110>(own, plus), minus);
            let r = &mut r[a];
            // SAFETY: a node's accumulator holds 5 values; the load and store take the first 4.
            unsafe {
                let sum = _mm256_add_pd(_mm256_loadu_pd(r.as_ptr()), term);
                _mm256_storeu_pd(r.as_mut_ptr(), sum);
            }
            r[4] += n[a] * q.mb[1] - (gx[a] * q.vs[2] + gy[a] * q.vs[1]);
        }
    }
}

/// Calls `f(k, rows)` for every particle `k` (in order) whose stencil reaches the band of grid
/// lines `lines`, with `rows` the stencil's rows (of `S`) inside the band: the particle walk of
/// every band scatter (see [`crate::parallel`]).
#[inline(always)]
fn in_band<const S: usize>(
    ops: &Operators,
    np: usize,
    lines: &std::ops::Range<usize>,
    mut f: impl FnMut(usize, std::ops::Range<usize>),
) {
    for k in 0..np {
        let l0 = ops.first_line(k);
        if l0 + S <= lines.start || l0 >= lines.end {
            continue;
        }
        f(k, lines.start.saturating_sub(l0)..(lines.end - l0).min(S));
    }
}

/// (5) added to `f`:
///
/// ```text
/// f_x −= Gx (V∘σxx) + Gy (V∘σxy),   f_y −= Gx (V∘σxy) + Gy (V∘σyy)
/// ```
///
/// # Panics
/// If `f` does not have one entry per node.
pub fn add_internal_force(ops: &Operators, volume: &[f64], sxx: &[f64], syy: &[f64], sxy: &[f64], f: &mut VectorField) {
    let np = ops.num_particles();
    for field in [volume, sxx, syy, sxy] {
        assert_eq!(field.len(), np, "particle field length must equal the particle count");
    }
    assert_eq!(f.len(), ops.num_nodes(), "one force per node");
    crate::with_support!(ops, internal_force_columns::<S>(ops, [volume, sxx, syy, sxy], f));
}

fn internal_force_columns<const S: usize>(ops: &Operators, [volume, sxx, syy, sxy]: [&[f64]; 4], f: &mut VectorField) {
    for k in 0..ops.num_particles() {
        let t = [volume[k] * sxx[k], volume[k] * syy[k], volume[k] * sxy[k]];
        subtract_particle_force(&ops.stencil::<S>(k), t, f);
    }
}

/// One particle's part of (5) over its stencil `st`, with `t = V σ` as `[xx, yy, xy]`:
///
/// ```text
/// f_x −= Gx t_xx + Gy t_xy,   f_y −= Gx t_xy + Gy t_yy     (the particle's column)
/// ```
#[inline(always)]
pub(crate) fn subtract_particle_force<const S: usize>(st: &Stencil<S>, [txx, tyy, txy]: [f64; 3], f: &mut VectorField) {
    for b in 0..S {
        let (start, _, gx, gy) = st.row(b);
        let (fx, fy) = (&mut f.x[start..start + S], &mut f.y[start..start + S]);
        for a in 0..S {
            fx[a] -= gx[a] * txx + gy[a] * txy;
            fy[a] -= gx[a] * txy + gy[a] * tyy;
        }
    }
}

/// MUSL's re-projection of the updated particle velocities into `grid.momentum`, with the
/// operators and positions of the start of the step:
///
/// ```text
/// q' = N (m ∘ v_p) [+ APIC: Σ_p N_Ip m_p C_p (x_I − x_p)]
/// ```
pub fn reproject_momentum(
    ops: &Operators,
    p: &Particles,
    apic: Option<ApicInertia>,
    grid: &mut GridState,
    workers: &Workers,
) {
    let span = ops.node_span();
    assert!(
        span.end <= grid.momentum.len() && grid.span == span,
        "reproject_momentum follows a p2g with the same operators"
    );
    let (acc, base) = scatter_bands(ops, &mut grid.accumulator, workers, |acc, base, lines| {
        crate::with_support!(ops, reproject_columns::<S>(ops, p, apic, acc, base, lines))
    });
    for i in span {
        grid.momentum.x[i] = acc[i - base][1];
        grid.momentum.y[i] = acc[i - base][2];
    }
}

fn reproject_columns<const S: usize>(
    ops: &Operators,
    p: &Particles,
    apic: Option<ApicInertia>,
    acc: &mut [[f64; 5]],
    base: usize,
    lines: std::ops::Range<usize>,
) {
    in_band::<S>(ops, p.len(), &lines, |k, rows| {
        let m = p.mass[k];
        let affine = apic.map(|kind| apic_affine(p, k, ops, kind));
        let st = ops.stencil::<S>(k);
        let offsets = st.offsets(p.x[k], p.y[k]);
        for b in 0..S {
            if !rows.contains(&b) {
                continue;
            }
            let (start, n) = st.n_row(b);
            let (dx, dy) = st.run_offsets(&offsets, b);
            let r = &mut acc[start - base..start - base + S];
            for a in 0..S {
                let [ax, ay] = affine.map_or([0.0, 0.0], |af| af.velocity(dx[a], dy[a], n[a]));
                r[a][1] += n[a] * m * p.vx[k] + m * ax;
                r[a][2] += n[a] * m * p.vy[k] + m * ay;
            }
        }
    });
}
