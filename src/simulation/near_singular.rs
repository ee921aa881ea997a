//! A stabilised consistent mass that is nearly singular although its factorization stands:
//! the update bound's estimates and guards ([`super::stability`]) compare their top frequency
//! with the largest single-node frequency, and the time loop applies the singularity policy
//! where the ratio is large ([`crate::mass::GridMass`]).

/// The ratio of the update bound's top frequency `λ_max(K, B)` to the largest single-node
/// frequency ([`node_frequency_top`](crate::stiffness)) at or above which the time loop treats the
/// stabilised consistent mass as singular and applies the singularity policy for the step
/// (an error, the lumped mass, or the regularized mass):
///
/// ```text
/// λ_max(K, B) ≥ NEARLY_SINGULAR_RATIO · max_I λ_max(K_II, B_II)
/// ```
///
/// A top mode far above every single node's is a combination of nodes that moves with almost
/// no mass. At one particle per cell on a floor the ratio reached 10⁵–10⁶ while the
/// factorization's pivots stayed at 10⁻³ and above: the step fell to 10⁻³ of the lumped step,
/// a particle inverted, or the guard's Ritz value, chasing an ever higher frequency, drove the
/// step to zero. At the estimates and guards of well-sampled runs (the dropped block and the
/// block in a box at 2 × 2 per cell, the two disks, the benchmark's random block of 256 to
/// 65,536 particles with every kernel) it stayed within 0.56–12. Between, the limit decides how
/// much of a nearly singular stretch the consistent mass keeps: at one particle per cell the
/// block at rest on a floor moved its energy by 0.97–1.5% under the fallback with limits of
/// 30–100 (lumped 1.4%) and the two disks by 5.5–10.6% (lumped 6.4%; 5.5% at 50)
/// (docs/simulation.md, "The time step").
pub const NEARLY_SINGULAR_RATIO: f64 = 50.0;

/// A nearly singular mass found by the update bound: the ratio of [`NEARLY_SINGULAR_RATIO`]
/// and the node where the top mode is largest.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct NearlySingular {
    pub(super) ratio: f64,
    pub(super) node: usize,
}

/// [`NearlySingular`] when `omega_squared / node_top` reaches [`NEARLY_SINGULAR_RATIO`], with
/// the node of the largest entry of `mode` (`2n` entries, x then y).
pub(super) fn nearly_singular(omega_squared: f64, node_top: f64, mode: &[f64]) -> Option<NearlySingular> {
    let ratio = omega_squared / node_top;
    if !(node_top > 0.0 && ratio >= NEARLY_SINGULAR_RATIO) {
        return None;
    }
    let n = (mode.len() / 2).max(1);
    let at = (0..mode.len())
        .max_by(|&a, &b| mode[a].abs().total_cmp(&mode[b].abs()))
        .unwrap_or(0);
    Some(NearlySingular { ratio, node: at % n })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_top_frequency_far_above_every_single_node_marks_the_mass_nearly_singular() {
        // 2 nodes: x of 0, x of 1, y of 0, y of 1; the mode is largest on y of node 1.
        let mode = [0.1, -0.2, 0.05, -0.9];
        let limit = NEARLY_SINGULAR_RATIO;
        assert_eq!(nearly_singular(0.99 * limit, 1.0, &mode), None);
        let found = nearly_singular(limit * 3.0, 3.0, &mode).unwrap();
        assert_eq!(found.node, 1);
        assert!((found.ratio - limit).abs() < 1e-12);
        // No single-node frequency (nothing free): no verdict.
        assert_eq!(nearly_singular(1.0, 0.0, &mode), None);
    }
}
