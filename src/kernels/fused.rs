//! The fused pass of the explicit step: the grid-to-particle pass of step `n` and the
//! particle-to-grid scatter of step `n + 1` in one sweep over the particles.
//!
//! Each group of particles (one, four or eight side by side, as in [`super::g2p`]) is updated,
//! moved, located in the grid at its new position (its new column written in place of the old,
//! [`crate::operators::relocate`]) and scattered into the next step's accumulator while its
//! data are in registers and its grid nodes in cache. The next step then starts from that
//! accumulator ([`super::p2g_prepared`]) instead of assembling the operators and scattering
//! again: what the sort, the assembly and (2)–(5) would have done, to the bit.
//!
//! **Order.** Every node must receive its terms in particle order, as in the separate
//! scatter, whatever the number of threads. The particles are cut into one range of whole
//! blocks per worker, each with a band of grid lines (from the line its first particle's
//! stencil started on at the start of the step). A worker adds its particles' terms to the
//! lines of its band and skips the runs outside it; lines where some worker skipped a run (the
//! few lines at the bands' edges that particles of two ranges share) are zeroed afterwards and
//! scattered again from every particle that reaches them, in order. With one worker the band
//! is the whole accumulator and nothing is skipped.
//!
//! **Which nodes it zeroes.** The next accumulator covers [`MARGIN`] lines around the last
//! step's, and within each line [`MARGIN`] nodes on either side of the columns the last node
//! pass read ([`crate::operators::Operators::column_span`]); each line is zeroed over those
//! columns just before its first terms. The next node pass reads the columns of the new
//! stencils only, so entries outside the zeroed columns are never read.
//!
//! **When it stops.** A particle the grid does not accept, a stencil shifted at the grid's
//! edge (uGIMP) or a stencil beyond the lines or columns prepared stops the scatter: the pass
//! still finishes the step, and the next step assembles and scatters as usual (reporting the
//! particle where the grid does not accept it).

use super::g2p::{g2p_block_next, split_pass, BlockColumns, Fused, G2pBlock, G2pInput, G2pOutput, G2pRule, Packed};
use super::p2g::{p2g_columns, p2g_columns_body, Band, P2gSource};
use super::{ApicInertia, GridState, ParticleScratch};
use crate::lanes::Real;
use crate::operators::{relocate, Operators};
use crate::parallel::{Splittable, Workers, REDUCTION_BLOCK};
use crate::particles::Particles;

/// Grid lines beyond the last step's line span that the next step's accumulator covers, and
/// nodes beyond its column span within each line that it zeroes: a particle whose stencil
/// moves further (more than a cell in a step) stops the fused scatter.
pub const MARGIN: usize = 2;

/// The next step's accumulator and what the fused pass found per block of particles.
#[derive(Debug, Clone, Default)]
pub(super) struct NextScatter {
    pub(super) acc: Vec<[f64; 5]>,
    /// Node number of `acc[0]`.
    pub(super) base: usize,
    /// Whether `acc` holds the terms of the particles as they are now.
    pub(super) ready: bool,
    stats: Vec<NextStats>,
}

impl NextScatter {
    /// Address space for `nodes` accumulator entries (pages are touched as the span needs them).
    pub(super) fn with_capacity(nodes: usize) -> NextScatter {
        NextScatter {
            acc: Vec::with_capacity(nodes),
            ..NextScatter::default()
        }
    }
}

/// The terms of the next step's (2)–(5): APIC's inertia, and 1 to include `f_int` (0 under USF,
/// whose stress update comes between the solves).
#[derive(Debug, Clone, Copy)]
pub(crate) struct NextTerms {
    pub apic: Option<ApicInertia>,
    pub internal: f64,
}

/// The grid velocities the pass reads: the lumped grid pass's `[w, v]` in the accumulator, or
/// packed apart.
pub(crate) enum Velocities<'a> {
    Lumped,
    Packed(Packed<'a>),
}

/// What one block of the fused pass found.
#[derive(Debug, Clone, Copy)]
pub(super) struct NextStats {
    /// Lowest and highest first node, lowest and highest first line of the new stencils.
    lo: usize,
    hi: usize,
    min_line: usize,
    max_line: usize,
    /// Lowest and highest first node's index along the lines.
    along: [usize; 2],
    /// The lowest line below the band, and one past the highest line above it, of a skipped run.
    below: Option<usize>,
    above: Option<usize>,
    zero: bool,
    stopped: bool,
}

impl Default for NextStats {
    fn default() -> Self {
        NextStats {
            lo: usize::MAX,
            hi: 0,
            min_line: usize::MAX,
            max_line: 0,
            along: [usize::MAX, 0],
            below: None,
            above: None,
            zero: false,
            stopped: false,
        }
    }
}

/// What a block of the fused pass scatters into: its worker's band of the next accumulator.
pub(crate) struct NextBand<'a> {
    band: Band<'a>,
    /// The lines the whole next accumulator covers, and the indices along them it zeroes.
    prepared: std::ops::Range<usize>,
    columns: std::ops::Range<usize>,
    terms: NextTerms,
    stats: NextStats,
    /// The band's lines below this one are zeroed (the rest is zeroed as the particles reach
    /// it: each line just before its first terms, while it is about to be in cache anyway).
    cleared_to: usize,
    /// Nodes per grid line.
    line_len: usize,
}

impl NextBand<'_> {
    /// Zeroes the band's lines from `cleared_to` up to `line` (exclusive, at most the band's end).
    #[inline(always)]
    fn clear_to(&mut self, line: usize) {
        let line = line.min(self.band.lines.end);
        if line > self.cleared_to {
            let (first, len) = (self.band.lines.start, self.line_len);
            let (c0, c1) = (self.columns.start, self.columns.end);
            if c1 - c0 == len {
                self.band.acc[(self.cleared_to - first) * len..(line - first) * len].fill([0.0; 5]);
            } else {
                for l in self.cleared_to - first..line - first {
                    self.band.acc[l * len + c0..l * len + c1].fill([0.0; 5]);
                }
            }
            self.cleared_to = line;
        }
    }
}

/// Particles per batch of the fused pass: updated together, then relocated and scattered
/// together (a multiple of the widest group, eight).
pub(super) const FUSED_BATCH: usize = 64;

/// The particles `first + range`, just updated and moved by [`super::g2p`]'s groups: their new
/// columns written in place, their terms of the next step's (2)–(5) added to the band's nodes
/// (runs outside the band skipped and noted).
#[inline(always)]
pub(super) fn relocate_and_scatter<const S: usize, const V: usize>(
    input: &G2pInput,
    first: usize,
    range: std::ops::Range<usize>,
    out: &mut G2pOutput,
    next: &mut NextBand,
) {
    if next.stats.stopped {
        return;
    }
    let mut j = range.start;
    #[cfg(target_arch = "x86_64")]
    {
        while V >= 8 && j + 8 <= range.end {
            relocate_group::<crate::lanes::F64x8, S>(j, out, next);
            j += 8;
        }
        while V >= 4 && j + 4 <= range.end {
            relocate_group::<crate::lanes::F64x4, S>(j, out, next);
            j += 4;
        }
    }
    while j < range.end {
        relocate_group::<f64, S>(j, out, next);
        j += 1;
    }
    if next.stats.stopped {
        return;
    }
    // Every line the batch's stencils reach, zeroed before its first terms.
    if next.stats.min_line != usize::MAX {
        next.clear_to(next.stats.max_line + S);
    }
    let (stress, volume): ([&[f64]; 3], &[f64]) = match (&out.stress, input.held) {
        (Some(s), _) => ([&*s.sigma[0], &*s.sigma[1], &*s.sigma[2]], &*s.volume),
        (None, Some(([xx, yy, xy], v))) => ([&xx[first..], &yy[first..], &xy[first..]], &v[first..]),
        (None, None) => unreachable!("the pass reads or writes the stress"),
    };
    let source = P2gSource {
        cols: out.columns.view(),
        position: [&*out.position[0], &*out.position[1]],
        mass: &input.mass[first..],
        velocity: [&*out.velocity[0], &*out.velocity[1]],
        force: input.force.map(|[bx, by]| [&bx[first..], &by[first..]]),
        volume,
        stress,
        affine: [&*out.affine[0], &*out.affine[1], &*out.affine[2], &*out.affine[3]],
    };
    let band = Band {
        acc: &mut *next.band.acc,
        base: next.band.base,
        lines: next.band.lines.clone(),
    };
    let NextTerms { apic, internal } = next.terms;
    p2g_columns_body::<S, V>(&source, range, apic, internal, band);
}

/// Particles `j …` (`R::LANES` of them) located at their new positions, their columns written,
/// what the scatter needs to know noted (or the pass stopped).
#[inline(always)]
fn relocate_group<R: Real, const S: usize>(j: usize, out: &mut G2pOutput, next: &mut NextBand) {
    let st = &mut next.stats;
    if st.stopped {
        return;
    }
    let (x, y) = (R::load(out.position[0], j), R::load(out.position[1], j));
    let BlockColumns::Own {
        layout,
        first: firsts,
        local: [tx, ty],
    } = &mut out.columns
    else {
        unreachable!("the fused pass rewrites the block's own columns")
    };
    let found = relocate::<R>(layout, x, y, j, firsts, [&mut **tx, &mut **ty]);
    if !found.usable {
        st.stopped = true;
        return;
    }
    st.zero |= found.zero;
    let (band, prepared, columns) = (&next.band.lines, &next.prepared, &next.columns);
    // The lanes' lowest and highest lines, nodes and indices along the lines decide everything
    // noted.
    let ([low, high], [lo, hi], [left, right]) = (found.lines, found.nodes, found.along);
    if low < prepared.start || high + S > prepared.end || left < columns.start || right + S > columns.end {
        st.stopped = true;
        return;
    }
    (st.lo, st.hi) = (st.lo.min(lo), st.hi.max(hi));
    st.along = [st.along[0].min(left), st.along[1].max(right)];
    (st.min_line, st.max_line) = (st.min_line.min(low), st.max_line.max(high));
    if low < band.start {
        st.below = Some(st.below.map_or(low, |b| b.min(low)));
    }
    if high + S > band.end {
        st.above = Some(st.above.map_or(high + S, |a| a.max(high + S)));
    }
}

/// One worker's part of the fused pass: a range of whole blocks from particle `first`, and its
/// band of the next accumulator.
struct Task<'a> {
    first: usize,
    out: Option<G2pOutput<'a>>,
    blocks: &'a mut [G2pBlock],
    stats: &'a mut [NextStats],
    band: Band<'a>,
}

/// The grid-to-particle pass of this step ([`super::g2p_packed`] with `fused`, which must move
/// the particles) and the particle-to-grid scatter of the next ([`super::p2g_with`] with
/// `terms`) in one sweep (see the [module docs](self)), the pass's results per block into
/// `blocks`. Returns whether the next step's terms are ready in `grid`; if not, the operators
/// are unusable until reassembled.
#[allow(clippy::too_many_arguments)]
pub(crate) fn g2p_then_p2g(
    ops: &mut Operators,
    velocities: Velocities,
    grid: &mut GridState,
    rule: &G2pRule,
    dt: f64,
    fused: &Fused,
    p: &mut Particles,
    scratch: &mut ParticleScratch,
    workers: &Workers,
    blocks: &mut Vec<G2pBlock>,
    terms: NextTerms,
) -> bool {
    assert!(fused.moves.is_some(), "the fused pass moves the particles");
    assert!(
        ops.relocatable(),
        "the fused pass rewrites columns of kernel coordinates"
    );
    let (np, support, lo) = (p.len(), ops.support(), ops.node_span().start);
    let line_len = ops.line_length();
    let all_lines = ops.num_nodes() / line_len;
    let now = ops.line_span();
    let prepared = now.start.saturating_sub(MARGIN)..(now.end + MARGIN).min(all_lines);
    // The indices along the lines the next accumulator zeroes: [`MARGIN`] around the columns
    // this step's node pass read (all of each line when it read whole lines).
    let (c0, c1) = (grid.columns.start.min(line_len), grid.columns.end);
    let zeroed = c0.saturating_sub(MARGIN)..c1.saturating_add(MARGIN).min(line_len);
    let count = np.div_ceil(REDUCTION_BLOCK);
    let tasks = workers.threads().min(count).max(1);
    let task_block = |t: usize| t * count / tasks;
    // Each band from the line the first particle of its range started on.
    let mut bounds = vec![prepared.start; tasks + 1];
    bounds[tasks] = prepared.end;
    for t in 1..tasks {
        let line = ops.first_line(task_block(t) * REDUCTION_BLOCK);
        bounds[t] = line.clamp(bounds[t - 1], prepared.end);
    }
    let GridState {
        accumulator,
        base,
        span,
        next,
        ..
    } = grid;
    next.ready = false;
    // Zeroed by each worker as its particles reach the lines (NextBand::clear_to).
    let len = prepared.len() * line_len;
    if next.acc.len() < len {
        next.acc.resize(len, [0.0; 5]);
    }
    next.acc.truncate(len);
    next.stats.clear();
    next.stats.resize(count, NextStats::default());
    blocks.clear();
    blocks.resize_with(count, G2pBlock::default);
    let packed = match velocities {
        Velocities::Lumped => Packed {
            values: accumulator[span.start - *base..span.end - *base].as_flattened(),
            stride: 5,
            layer: 0,
        },
        Velocities::Packed(packed) => packed,
    };
    let (layout, firsts, local) = ops.relocation();
    let columns = BlockColumns::Own {
        layout,
        first: firsts,
        local,
    };
    let (input, out) = split_pass(columns, support, lo, packed, rule, dt, fused, p, scratch);
    let mut parts = Vec::with_capacity(tasks);
    let (mut out, mut block_rest, mut stat_rest) = (out, &mut blocks[..], &mut next.stats[..]);
    let mut acc_rest = &mut next.acc[..];
    for t in 0..tasks {
        let (b0, b1) = (task_block(t), task_block(t + 1));
        let particles = (b1 * REDUCTION_BLOCK).min(np) - b0 * REDUCTION_BLOCK;
        let (mine, rest) = out.split_at(particles);
        out = rest;
        let (mine_blocks, rest) = block_rest.split_at_mut(b1 - b0);
        block_rest = rest;
        let (mine_stats, rest) = stat_rest.split_at_mut(b1 - b0);
        stat_rest = rest;
        let lines = bounds[t]..bounds[t + 1];
        let (acc, rest) = acc_rest.split_at_mut(lines.len() * line_len);
        acc_rest = rest;
        parts.push(Task {
            first: b0 * REDUCTION_BLOCK,
            out: Some(mine),
            blocks: mine_blocks,
            stats: mine_stats,
            band: Band {
                acc,
                base: lines.start * line_len,
                lines,
            },
        });
    }
    let width = rule.packed_width();
    workers.chunks(&mut parts, 1, |_, task| {
        run_task(
            &input,
            &mut task[0],
            [prepared.clone(), zeroed.clone()],
            terms,
            width,
            line_len,
        );
    });
    drop((parts, out, input));
    let stats = &next.stats;
    if stats.iter().any(|s| s.stopped) {
        return false;
    }
    // The lines where a worker skipped runs, merged, scattered again in particle order.
    let mut redo: Vec<std::ops::Range<usize>> = Vec::new();
    for t in 0..tasks {
        for s in &stats[task_block(t)..task_block(t + 1)] {
            if let Some(below) = s.below {
                redo.push(below..bounds[t]);
            }
            if let Some(above) = s.above {
                redo.push(bounds[t + 1]..above);
            }
        }
    }
    redo.sort_by_key(|r| r.start);
    let mut merged: Vec<std::ops::Range<usize>> = Vec::new();
    for r in redo {
        match merged.last_mut() {
            Some(last) if r.start <= last.end => last.end = last.end.max(r.end),
            _ => merged.push(r),
        }
    }
    let next_base = prepared.start * line_len;
    let source = P2gSource::of(ops, p);
    for lines in merged {
        let rows = (lines.start - prepared.start) * line_len..(lines.end - prepared.start) * line_len;
        next.acc[rows].fill([0.0; 5]);
        for (b, s) in stats.iter().enumerate() {
            if s.max_line + support <= lines.start || s.min_line >= lines.end {
                continue;
            }
            let range = b * REDUCTION_BLOCK..((b + 1) * REDUCTION_BLOCK).min(np);
            let target = Band {
                acc: &mut next.acc,
                base: next_base,
                lines: lines.clone(),
            };
            crate::with_support!(
                ops,
                p2g_columns::<S>(&source, range, terms.apic, terms.internal, target)
            );
        }
    }
    let (lo, hi, zero) = stats.iter().fold((usize::MAX, 0, false), |(lo, hi, z), s| {
        (lo.min(s.lo), hi.max(s.hi), z | s.zero)
    });
    let along = stats
        .iter()
        .fold([usize::MAX, 0], |[a, b], s| [a.min(s.along[0]), b.max(s.along[1])]);
    ops.finish_relocation([lo, hi], along, zero);
    next.base = next_base;
    next.ready = np > 0;
    next.ready
}

/// The blocks of one worker's range in order, each with [`super::g2p`]'s block and
/// [`relocate_and_scatter`] after each group.
fn run_task(
    input: &G2pInput,
    task: &mut Task,
    [prepared, columns]: [std::ops::Range<usize>; 2],
    terms: NextTerms,
    width: usize,
    line_len: usize,
) {
    let mut out = task.out.take().expect("a task runs once");
    let mut first = task.first;
    let mut cleared_to = task.band.lines.start;
    for (slot, stats) in task.blocks.iter_mut().zip(task.stats.iter_mut()) {
        let len = out.len().min(REDUCTION_BLOCK);
        let (this, rest) = out.split_at(len);
        out = rest;
        let mut next = NextBand {
            band: Band {
                acc: &mut *task.band.acc,
                base: task.band.base,
                lines: task.band.lines.clone(),
            },
            prepared: prepared.clone(),
            columns: columns.clone(),
            terms,
            stats: NextStats::default(),
            cleared_to,
            line_len,
        };
        let next_ref = &mut next;
        *slot = match (input.support, width) {
            (2, 4) => g2p_block_next::<2, 4>(input, first, this, next_ref),
            (3, 4) => g2p_block_next::<3, 4>(input, first, this, next_ref),
            (4, 4) => g2p_block_next::<4, 4>(input, first, this, next_ref),
            (2, _) => g2p_block_next::<2, 8>(input, first, this, next_ref),
            (3, _) => g2p_block_next::<3, 8>(input, first, this, next_ref),
            (4, _) => g2p_block_next::<4, 8>(input, first, this, next_ref),
            (s, _) => unreachable!("a support of {s} nodes per axis (at most MAX_SUPPORT = 4)"),
        };
        *stats = next.stats;
        cleared_to = next.cleared_to;
        first += len;
    }
    // The band's lines no particle reached.
    task.band.acc[(cleared_to - task.band.lines.start) * line_len..].fill([0.0; 5]);
}
