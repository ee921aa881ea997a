//! (2)–(5) and MUSL's re-projection: the particle-to-grid passes, into interleaved per-node
//! accumulators over bands of grid lines (one band per worker, see [`crate::parallel`]).

use super::columns::Columns;
use super::scatter::Scatter;
use super::{apic_affine, ApicInertia, GridState, P2gTerms, Stress};
use crate::fields::VectorField;
use crate::lanes::dispatch;
use crate::lanes::Real;
#[cfg(target_arch = "x86_64")]
use crate::lanes::{F64x4, F64x8};
use crate::operators::{ColumnView, Operators, Stencil};
use crate::parallel::Workers;
use crate::particles::Particles;

/// (2)–(5) in one pass over the shared pattern of N, Gx, Gy, into `lumped` (`m_L`),
/// `grid.momentum`, `grid.force` and `grid.angular_momentum`, with the `terms` of
/// [`P2gTerms`]:
///
/// ```text
/// m_L = N m,   q = N (m ∘ v) [+ APIC: Σ_p N_Ip m_p C_p (x_I − x_p)],
/// f = N (m ∘ b) + m_L g − [Gx (V∘σxx) + Gy (V∘σxy); Gx (V∘σxy) + Gy (V∘σyy)]   (Stress::Include)
/// ```
///
/// # Panics
/// If `lumped` or `grid` does not have one entry per node of the operators.
pub fn p2g(
    ops: &Operators,
    p: &Particles,
    terms: P2gTerms,
    lumped: &mut [f64],
    grid: &mut GridState,
    workers: &Workers,
) {
    let writes = NodeWrites {
        fields: true,
        boxed: false,
    };
    p2g_with(ops, p, terms, lumped, grid, workers, writes);
}

/// What the node pass of (2)–(5) writes: `q` and `f` as well as `m_L` (`fields`), and over
/// which nodes of the operators' node span: those in their column span
/// ([`Operators::column_span`], `boxed`; the others are left at the zero they hold) or all.
#[derive(Debug, Clone, Copy)]
pub(crate) struct NodeWrites {
    pub fields: bool,
    pub boxed: bool,
}

/// [`p2g`], writing `grid.momentum` and `grid.force` when `writes.fields` (otherwise only
/// `m_L` and the angular momentum: the lumped grid pass, [`super::update_lumped_grid`], reads
/// the rest from the accumulator), over the nodes of [`NodeWrites`].
pub(crate) fn p2g_with(
    ops: &Operators,
    p: &Particles,
    terms: P2gTerms,
    lumped: &mut [f64],
    grid: &mut GridState,
    workers: &Workers,
    writes: NodeWrites,
) {
    let P2gTerms { apic, gravity, stress } = terms;
    let internal = if stress == Stress::Include { 1.0 } else { 0.0 };
    let source = P2gSource::of(ops, p);
    let np = p.len();
    let (_, base) = scatter_bands(ops, &mut grid.accumulator, workers, |acc, base, lines| {
        let target = Band { acc, base, lines };
        crate::with_support!(ops, p2g_columns::<S>(&source, 0..np, apic, internal, target))
    });
    grid.base = base;
    p2g_nodes(ops, gravity, lumped, grid, workers, writes);
}

/// The node pass of [`p2g_with`] after the fused pass of the last step scattered this step's
/// particle terms ([`super::fused`]): the same results as [`p2g_with`] with the same `terms`.
pub(crate) fn p2g_prepared(
    ops: &Operators,
    gravity: [f64; 2],
    lumped: &mut [f64],
    grid: &mut GridState,
    workers: &Workers,
    writes: NodeWrites,
) {
    grid.take_next();
    p2g_nodes(ops, gravity, lumped, grid, workers, writes);
}

/// What (2)–(5) write per node from the accumulator of the particles' terms: `m_L`, `q` and
/// `f` (with gravity `m_L g`; only `m_L` without `fields`) over the nodes of `writes`, zero
/// outside them, and the angular momentum `Σ_I x_I × q_I`.
fn p2g_nodes(
    ops: &Operators,
    gravity: [f64; 2],
    lumped: &mut [f64],
    grid: &mut GridState,
    workers: &Workers,
    writes: NodeWrites,
) {
    let fields = writes.fields;
    let columns = if writes.boxed {
        ops.column_span()
    } else {
        0..ops.line_length()
    };
    let n = ops.num_nodes();
    assert!(
        lumped.len() == n && grid.momentum.len() == n,
        "grid mass and state sized for the operators' nodes"
    );
    let span = ops.node_span();
    let line_len = ops.line_length().max(1);
    // Zero what the last p2g left outside the new box.
    let old = (&grid.span, &grid.columns);
    crate::grid::outside_box(old, (&span, &columns), line_len, |range| {
        lumped[range.clone()].fill(0.0);
        // (Without `fields` they are never written, so never need clearing.)
        for field in [&mut grid.momentum, &mut grid.force].into_iter().filter(|_| fields) {
            field.x[range.clone()].fill(0.0);
            field.y[range.clone()].fill(0.0);
        }
    });
    let [gx, gy] = gravity;
    let ([ox, oy], [hx, hy]) = grid.frame;
    let runs_along_x = ops.strides()[0] == 1;
    let GridState {
        momentum,
        force,
        angular_blocks,
        accumulator,
        base,
        ..
    } = grid;
    let (acc, base) = (&accumulator[..], *base);
    let out = (
        &mut lumped[span.clone()],
        [
            &mut momentum.x[span.clone()],
            &mut momentum.y[span.clone()],
            &mut force.x[span.clone()],
            &mut force.y[span.clone()],
        ],
    );
    // Blocks of nodes in parallel; the angular momentum in fixed blocks, added in order. The
    // nodes outside the columns hold zeros, added as such before: skipped.
    workers.split_blocks(out, angular_blocks, |first, (lumped, [qx, qy, fx, fy])| {
        let start = span.start + first;
        let mut angular = 0.0;
        crate::grid::column_runs(start, lumped.len(), line_len, &columns, |run, along, across| {
            let nodes = &acc[start + run.start - base..start + run.end - base];
            for (k, (r, m)) in nodes.iter().zip(&mut lumped[run.clone()]).enumerate() {
                *m = r[0];
                // Grid::node_position of node i, formed as it forms it.
                let along = along + k;
                let (ix, iy) = if runs_along_x { (along, across) } else { (across, along) };
                let (xi, yi) = (ox + ix as f64 * hx, oy + iy as f64 * hy);
                angular += xi * r[2] - yi * r[1];
            }
            if fields {
                let out = (qx[run.clone()].iter_mut().zip(&mut qy[run.clone()]))
                    .zip(fx[run.clone()].iter_mut().zip(&mut fy[run.clone()]));
                for (r, ((qx, qy), (fx, fy))) in nodes.iter().zip(out) {
                    (*qx, *qy) = (r[1], r[2]);
                    (*fx, *fy) = (r[3] + r[0] * gx, r[4] + r[0] * gy);
                }
            }
        });
        angular
    });
    let angular = grid.angular_blocks.iter().sum();
    grid.angular_momentum = angular;
    grid.span = span;
    grid.columns = columns;
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

/// The accumulator of a band of grid lines: node `base + i` at entry `i`, the lines `lines`.
pub(crate) struct Band<'a> {
    pub acc: &'a mut [[f64; 5]],
    pub base: usize,
    pub lines: std::ops::Range<usize>,
}

/// What (2)–(5) read of particles `first …` (entry `k` of each array is particle `first + k`'s):
/// their columns, positions, masses, velocities, body forces, volumes, stresses and APIC
/// moments.
#[derive(Clone, Copy)]
pub(crate) struct P2gSource<'a> {
    pub cols: ColumnView<'a>,
    pub position: [&'a [f64]; 2],
    pub mass: &'a [f64],
    pub velocity: [&'a [f64]; 2],
    /// The body forces (`None`: all +0, not read).
    pub force: Option<[&'a [f64]; 2]>,
    pub volume: &'a [f64],
    /// `σxx`, `σyy`, `σxy`.
    pub stress: [&'a [f64]; 3],
    /// `B_p` (or `C_p`), row-major.
    pub affine: [&'a [f64]; 4],
}

impl<'a> P2gSource<'a> {
    /// Every particle of `p`, with the columns of `ops`.
    pub(crate) fn of(ops: &'a Operators, p: &'a Particles) -> P2gSource<'a> {
        P2gSource {
            cols: ops.view(),
            position: [&p.x, &p.y],
            mass: &p.mass,
            velocity: [&p.vx, &p.vy],
            force: Some([&p.bx, &p.by]),
            volume: &p.volume,
            stress: [&p.sxx, &p.syy, &p.sxy],
            affine: [&p.affine_xx, &p.affine_xy, &p.affine_yx, &p.affine_yy],
        }
    }
}

dispatch! {
    /// The particle loop of [`p2g`] for a support of `S` nodes per axis: the entries `range`
    /// of `source`, into the band `target`.
    pub(super) fn p2g_columns / p2g_columns_avx2, p2g_columns_avx512 = p2g_columns_body(
        source: &P2gSource,
        range: std::ops::Range<usize>,
        apic: Option<ApicInertia>,
        internal: f64,
        target: Band
    ) -> ()
}

/// The body of [`p2g_columns`]: every particle of `range` whose stencil reaches the band, in
/// order, its terms added to the nodes of the band; four particles at a time in the vector
/// builds ([`p2g_lanes`]; the AVX-512 build too: its scatter goes lane by lane, and eight lanes
/// side by side measured slower than four) where all their stencils lie in the band, one at a
/// time otherwise. Every node receives its terms in particle order either way.
#[inline(always)]
pub(crate) fn p2g_columns_body<const S: usize, const V: usize>(
    source: &P2gSource,
    range: std::ops::Range<usize>,
    apic: Option<ApicInertia>,
    internal: f64,
    target: Band,
) {
    let Band { acc, base, lines } = target;
    let cols = &source.cols;
    let inside = |k: usize| {
        let l0 = cols.first_line(k);
        l0 >= lines.start && l0 + S <= lines.end
    };
    let mut k = range.start;
    while k < range.end {
        #[cfg(target_arch = "x86_64")]
        {
            if V >= 8 && k + 8 <= range.end && (k..k + 8).all(inside) {
                p2g_lanes8::<S>(source, apic, internal, k, acc, base);
                k += 8;
                continue;
            }
            if V >= 4 && k + 4 <= range.end && (k..k + 4).all(inside) {
                p2g_lanes::<F64x4, S>(source, apic, internal, k, acc, base);
                k += 4;
                continue;
            }
        }
        let l0 = cols.first_line(k);
        if l0 + S > lines.start && l0 < lines.end {
            let group = Group::<f64, S>::new(source, apic, internal, k);
            for b in lines.start.saturating_sub(l0)..(lines.end - l0).min(S) {
                f64::scatter_run(&group.run(b), &group.cols, b, acc, base);
            }
        }
        k += 1;
    }
}

/// Particles `k …` side by side (`R::LANES` of them, all stencils in the band): their terms
/// added run by run where they start on one grid line (every lane's run `b` then lies on the
/// same line and different runs on different lines, so each run's nodes lane after lane keep
/// particle order), every lane's terms first otherwise (stencils on different lines may meet
/// at different runs), then lane after lane.
#[inline(always)]
fn p2g_lanes<R: Scatter, const S: usize>(
    source: &P2gSource,
    apic: Option<ApicInertia>,
    internal: f64,
    k: usize,
    acc: &mut [[f64; 5]],
    base: usize,
) {
    let group = Group::<R, S>::new(source, apic, internal, k);
    let cols = &source.cols;
    let l0 = cols.first_line(k);
    if (k + 1..k + R::LANES).all(|q| cols.first_line(q) == l0) {
        for b in 0..S {
            R::scatter_run(&group.run(b), &group.cols, b, acc, base);
        }
    } else {
        let mut all = [[[R::splat(0.0); 5]; S]; S];
        for (b, run) in all.iter_mut().enumerate() {
            *run = group.run(b);
        }
        R::scatter_lanes(&all, &group.cols, acc, base);
    }
}

/// Particles `k … k + 7` (all stencils in the band), their terms formed eight side by side and
/// added as two groups of four ([`F64x4`]'s scatter, lane after lane: particle order at every
/// node, as [`p2g_lanes`]).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn p2g_lanes8<const S: usize>(
    source: &P2gSource,
    apic: Option<ApicInertia>,
    internal: f64,
    k: usize,
    acc: &mut [[f64; 5]],
    base: usize,
) {
    let group = Group::<F64x8, S>::new(source, apic, internal, k);
    let mut halves = [[[[F64x4::splat(0.0); 5]; S]; S]; 2];
    for b in 0..S {
        let run = group.run(b);
        for a in 0..S {
            for c in 0..5 {
                (halves[0][b][a][c], halves[1][b][a][c]) = run[a][c].halves();
            }
        }
    }
    let first = group.cols.first;
    for (h, terms) in halves.iter().enumerate() {
        let at = [first[4 * h], first[4 * h + 1], first[4 * h + 2], first[4 * h + 3]];
        F64x4::scatter_lanes_at(terms, at, group.cols.run_stride, acc, base);
    }
}

/// APIC's `C_p` of the particles of `cols` (as [`super::apic_affine`] forms it), or zero
/// without APIC.
#[inline(always)]
pub(super) fn affine_velocity<R: Real, const S: usize>(
    cols: &Columns<R, S>,
    affine: [&[f64]; 4],
    apic: Option<ApicInertia>,
    k: usize,
) -> [R; 4] {
    let [dxx, dyy] = match apic {
        None => return [R::splat(0.0); 4],
        Some(ApicInertia::StoredC) => [R::splat(1.0); 2],
        Some(ApicInertia::Constant([dxx, dyy])) => [R::splat(dxx), R::splat(dyy)],
        Some(ApicInertia::Column) => column_inertia(cols),
    };
    let b = [
        R::load(affine[0], k),
        R::load(affine[1], k),
        R::load(affine[2], k),
        R::load(affine[3], k),
    ];
    if apic == Some(ApicInertia::StoredC) {
        return b;
    }
    [b[0] / dxx, b[1] / dyy, b[2] / dxx, b[3] / dyy]
}

/// `D_p = diag(Σ_I N_I dx², Σ_I N_I dy²)` over the particles' columns (GIMP), as
/// [`super::column_inertia`].
#[inline(always)]
fn column_inertia<R: Real, const S: usize>(cols: &Columns<R, S>) -> [R; 2] {
    let (mut dxx, mut dyy) = (R::splat(0.0), R::splat(0.0));
    for b in 0..S {
        for a in 0..S {
            let n = cols.n(b, a);
            let (dx, dy) = cols.offset(b, a);
            dxx = dxx + n * dx * dx;
            dyy = dyy + n * dy * dy;
        }
    }
    [dxx, dyy]
}

/// The sources of (2)–(5) of particles `k …` (one per lane) and their columns, whose terms
/// [`Group::run`] forms run by run, factored along the runs ([`Columns`]: node `a` of run `b`
/// has `N = wα_a wβ_b`):
///
/// ```text
/// m_L:  wα_a (m wβ_b)
/// q:    N (m v + mC (x_I − x_p)) = N (P_b + Q_a),   Q_a = (mC)_·α dα_a,  P_b = m v + (mC)_·β dβ_b
/// f:    N m b − (∂N/∂x V σ_x· + ∂N/∂y V σ_y·) = wα_a F_b − w′α_a G_b,
///       F_b = wβ_b m b − w′β_b (Vσ)_·β,   G_b = wβ_b (Vσ)_·α
/// ```
///
/// (`mC = m C_p` the APIC affine momentum): per node one product for `N`, one for `m_L`, two
/// for each momentum and three for each force component.
struct Group<R, const S: usize> {
    cols: Columns<R, S>,
    m: R,
    mv: [R; 2],
    mb: [R; 2],
    /// Each row of `mC` and of `Vσ` as (along, across).
    c_rows: [(R, R); 2],
    s_rows: [(R, R); 2],
    /// `Q_a` of `q_x`, `q_y`.
    q: [[R; S]; 2],
}

impl<R: Real, const S: usize> Group<R, S> {
    #[inline(always)]
    fn new(p: &P2gSource, apic: Option<ApicInertia>, internal: f64, k: usize) -> Self {
        let [x, y] = p.position;
        let cols = Columns::<R, S>::load_view(&p.cols, k, R::load(x, k), R::load(y, k));
        let m = R::load(p.mass, k);
        let mv = [m * R::load(p.velocity[0], k), m * R::load(p.velocity[1], k)];
        let [bx, by] = super::g2p::body_force::<R>(p.force, k);
        let mb = [m * bx, m * by];
        let v = R::splat(internal) * R::load(p.volume, k);
        // (Written out: a closure of `array::map` is not compiled for the vector build's CPU.)
        let [sxx, syy, sxy] = [
            v * R::load(p.stress[0], k),
            v * R::load(p.stress[1], k),
            v * R::load(p.stress[2], k),
        ];
        let c = affine_velocity(&cols, p.affine, apic, k);
        let mc = [m * c[0], m * c[1], m * c[2], m * c[3]];
        let c_rows = [cols.xy(mc[0], mc[1]), cols.xy(mc[2], mc[3])];
        let s_rows = [cols.xy(sxx, sxy), cols.xy(sxy, syy)];
        let mut q = [[R::splat(0.0); S]; 2];
        for a in 0..S {
            q[0][a] = c_rows[0].0 * cols.da[a];
            q[1][a] = c_rows[1].0 * cols.da[a];
        }
        Group {
            cols,
            m,
            mv,
            mb,
            c_rows,
            s_rows,
            q,
        }
    }

    /// The terms `[m, q_x, q_y, f_x, f_y]` of the nodes of run `b`.
    #[inline(always)]
    fn run(&self, b: usize) -> [[R; 5]; S] {
        let Group {
            cols,
            m,
            mv,
            mb,
            c_rows,
            s_rows,
            q,
        } = self;
        let wb = cols.wb[b];
        let mwb = *m * wb;
        // (Fused multiply-adds: one rounding each, the same in every lane of every width.)
        let pb = [
            c_rows[0].1.mul_add(cols.db[b], mv[0]),
            c_rows[1].1.mul_add(cols.db[b], mv[1]),
        ];
        let fb = [
            (-cols.dwb[b]).mul_add(s_rows[0].1, wb * mb[0]),
            (-cols.dwb[b]).mul_add(s_rows[1].1, wb * mb[1]),
        ];
        let gb = [wb * s_rows[0].0, wb * s_rows[1].0];
        let mut terms = [[R::splat(0.0); 5]; S];
        for a in 0..S {
            let wa = cols.wa[a];
            let n = wa * wb;
            terms[a] = [
                wa * mwb,
                n * (pb[0] + q[0][a]),
                n * (pb[1] + q[1][a]),
                (-cols.dwa[a]).mul_add(gb[0], wa * fb[0]),
                (-cols.dwa[a]).mul_add(gb[1], wa * fb[1]),
            ];
        }
        terms
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
