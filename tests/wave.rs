//! Wave fronts in a long bar against d'Alembert (src/verification/wave.rs): every mass delivers
//! the wave on time, and the dispersion of the masses shows where the theory puts it: the
//! lumped mass's short waves trail behind the front, the consistent mass's run ahead of it.

use sparse_mpm::mass::{MassOptions, MassScheme};
use sparse_mpm::ShapeFunction;
use sparse_mpm_study::verification::wave::Wave;
use sparse_mpm_study::verification::Choices;

fn choices(velocity: MassScheme, acceleration: MassScheme) -> Choices {
    Choices {
        shape: ShapeFunction::Linear,
        mass: MassOptions {
            velocity,
            acceleration,
            ..MassOptions::both(velocity)
        },
        cfl: 0.5,
        ..Choices::default()
    }
}

#[test]
fn every_mass_delivers_the_step_and_the_pulse_within_a_cell_of_dalembert() {
    let blend = MassScheme::Blended { gamma: 13.0 / 18.0 };
    let pairs = [
        (MassScheme::Lumped, MassScheme::Lumped),
        (MassScheme::Consistent, MassScheme::Consistent),
        (MassScheme::Consistent, MassScheme::Lumped),
        (MassScheme::Lumped, MassScheme::Consistent),
        (blend, blend),
        (
            MassScheme::TruncatedSeries { k: 3 },
            MassScheme::TruncatedSeries { k: 3 },
        ),
    ];
    for wave in [Wave::step(), Wave::pulse(0.1)] {
        for (v, a) in pairs {
            let o = wave.run(100, &choices(v, a)).unwrap();
            let m = |n: &str| o.metric(n).unwrap();
            println!(
                "{} {v}/{a}: arrival {:+.3} cells, half-amplitude front {:+.3}, precursor {:.3}, trailing {:.3}",
                wave.name(),
                m("arrival_error"),
                m("front_error"),
                m("precursor"),
                m("trailing")
            );
            assert!(
                m("arrival_error").abs() <= 1.0,
                "{} {v}/{a}: arrival {} cells",
                wave.name(),
                m("arrival_error")
            );
            assert!(
                m("front_error").abs() <= 3.0,
                "{} {v}/{a}: front {} cells",
                wave.name(),
                m("front_error")
            );
        }
    }
}

#[test]
fn the_consistent_mass_rings_ahead_of_the_front_and_the_lumped_mass_behind_it() {
    for wave in [Wave::step(), Wave::pulse(0.1)] {
        for cells in [100, 200] {
            let lumped = wave
                .run(cells, &choices(MassScheme::Lumped, MassScheme::Lumped))
                .unwrap();
            let consistent = wave
                .run(cells, &choices(MassScheme::Consistent, MassScheme::Consistent))
                .unwrap();
            let m = |o: &sparse_mpm_study::verification::Outcome, n: &str| o.metric(n).unwrap();
            let (lp, lt) = (m(&lumped, "precursor"), m(&lumped, "trailing"));
            let (cp, ct) = (m(&consistent, "precursor"), m(&consistent, "trailing"));
            println!(
                "{} {cells}: lumped ahead {lp:.3} behind {lt:.3}; consistent ahead {cp:.3} behind {ct:.3}",
                wave.name()
            );
            assert!(lt > 1.5 * lp, "{} {cells}: lumped ahead {lp}, behind {lt}", wave.name());
            assert!(
                cp > 1.5 * ct,
                "{} {cells}: consistent ahead {cp}, behind {ct}",
                wave.name()
            );
            // the lumped mass's slow short waves lag the half-amplitude point behind the front,
            // the consistent mass's fast ones move it ahead
            assert!(m(&lumped, "front_error") < 0.0 && m(&consistent, "front_error") > 0.0);
        }
    }
}
