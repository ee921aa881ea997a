//! The single-point part: one material point under each update scheme.

use std::fmt::Write as _;

use super::Finished;
use sparse_mpm::simulation::UpdateScheme;

/// Writes the single-point section: the problem, a table of velocity, position and energy
/// errors per update scheme, and how USL's energy drift compares with USF's.
pub(super) fn write(ok: &[Finished], md: &mut String) {
    writeln!(
        md,
        "## The single material point\n\nOne particle in one bilinear cell (v₀ = 0.01, Δt = 0.001, to \
         t = 2), lumped mass, FLIP, against `v = v₀ cos 2πt`, `x = x₀ exp((v₀/2π) sin 2πt)`.\n\n\
         | update | max \\|v − v_exact\\| / v₀ | max \\|x − x_exact\\| / amplitude | energy drift |\n|---|---|---|---|"
    )
    .ok();
    for (r, o) in ok {
        let m = |n: &str| o.metric(n).map_or("–".into(), |v| format!("{v:.2e}"));
        writeln!(
            md,
            "| {:?} | {} | {} | {} |",
            r.choices.update,
            m("velocity_error"),
            m("position_error"),
            m("energy_drift")
        )
        .ok();
    }
    usl_against_usf(ok, md);
}

/// When USL's energy drift is over five times USF's, says so (Bardenhagen's finding).
fn usl_against_usf(ok: &[Finished], md: &mut String) {
    let drift = |u: UpdateScheme| {
        ok.iter()
            .find(|(r, _)| r.choices.update == u)
            .and_then(|(_, o)| o.metric("energy_drift"))
            .unwrap_or(f64::NAN)
    };
    let (usf, usl) = (drift(UpdateScheme::Usf), drift(UpdateScheme::Usl));
    if usl > 5.0 * usf {
        writeln!(
            md,
            "\nUSL's energy drift ({:.2}%) is {:.0} times USF's ({:.2}%): one order of the updates nearly \
             conserves this problem's energy and the other dissipates it, as Bardenhagen (2002) found.\n",
            100.0 * usl,
            usl / usf,
            100.0 * usf
        )
        .ok();
    }
}
