//! The explicit step's fused pass ([`crate::kernels::g2p_then_p2g`]): when a step may scatter
//! the next step's particle terms in its grid-to-particle pass, and the pass itself.

use super::phases::StepInput;
use super::{Options, Setup};
use crate::kernels::{self, Fused, G2pBlock, G2pRule, GridState, ParticleScratch};
use crate::operators::Operators;
use crate::particles::Particles;

/// The terms of the next step's (2)–(5) when this step's grid-to-particle pass scatters them
/// ([`kernels::g2p_then_p2g`]): the explicit integrator with [`Options::fused_passes`], a pass
/// that moves the particles with their stress final (USL updating it in the pass, or USF before
/// it; not MUSL, whose stress update and move follow the pass, nor an elastoplastic USL, whose
/// stress update follows it), one velocity field (no contact), no mirrored walls (which fold
/// the columns), columns of kernel coordinates, and no sort before the next step (step
/// `steps + 1`).
pub(super) fn next_terms(input: StepInput, steps: usize, ops: &Operators, fused: &Fused) -> Option<kernels::NextTerms> {
    let StepInput { setup, options, plan } = input;
    let interval = options.sort_interval;
    let sorts_next = interval > 0 && (steps + 1).is_multiple_of(interval);
    let stress_final = fused.stress.is_some() || plan.stress_first;
    let fuse = options.fused_passes
        && options.integrator == super::Integrator::Explicit
        && plan.motion.is_none()
        && fused.moves.is_some()
        && stress_final
        && setup.contact.is_none()
        && setup.prescribed.mirror.is_empty()
        && !sorts_next
        && ops.relocatable();
    fuse.then_some(kernels::NextTerms {
        apic: plan.apic,
        internal: if plan.stress_first { 0.0 } else { 1.0 },
    })
}

/// One fused pass of a step: its rule, what it fuses, whether the lumped grid pass left the
/// grid velocities in the accumulator, the step and the next step's terms.
pub(super) struct FusedPass<'a> {
    pub(super) rule: &'a G2pRule,
    pub(super) fused: &'a Fused<'a>,
    pub(super) by_grid_pass: bool,
    pub(super) dt: f64,
    pub(super) terms: kernels::NextTerms,
}

impl FusedPass<'_> {
    /// (9)–(13) and the next step's (1)–(5) in one pass; where the pass stopped (a particle
    /// the grid does not accept, a stencil beyond the lines prepared), the columns assembled
    /// again for the present positions, or marked unusable when the grid refuses them (the
    /// next step assembles and reports the particle).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn run(
        &self,
        setup: &Setup,
        options: &Options,
        ops: &mut Operators,
        nodes: &mut GridState,
        p: &mut Particles,
        particle: &mut ParticleScratch,
        packed: &mut Vec<f64>,
        blocks: &mut Vec<G2pBlock>,
    ) {
        let rule = self.rule;
        let velocities = if self.by_grid_pass {
            kernels::Velocities::Lumped
        } else {
            kernels::pack_velocities(ops, nodes, rule, packed);
            kernels::Velocities::Packed(kernels::Packed {
                values: packed,
                stride: rule.packed_width(),
                layer: 0,
            })
        };
        let workers = &setup.workers;
        let (fused, dt, terms) = (self.fused, self.dt, self.terms);
        let ready = kernels::g2p_then_p2g(
            ops, velocities, nodes, rule, dt, fused, p, particle, workers, blocks, terms,
        );
        if !ready
            && ops
                .reassemble_with(&setup.grid, options.shape, &p.x, &p.y, workers)
                .is_err()
        {
            ops.invalidate();
        }
    }
}
