//! Threads change nothing: a run with 2 or 3 worker threads equals the serial run bit for bit,
//! for every shape function, update scheme and transfer, lumped and consistent mass
//! (`sparse_mpm::parallel` says why).

mod common;

use common::fingerprint;
use sparse_mpm::bench::{problem, BenchSpec};
use sparse_mpm::mass::MassScheme;
use sparse_mpm::simulation::{StepReport, Transfer, UpdateScheme};
use sparse_mpm::ShapeFunction;

/// The fingerprint after `steps` steps, or the error that stopped the run (some combinations
/// of the benchmark's fixed step are unstable; they must fail the same way).
fn run(spec: &BenchSpec, particles: usize, steps: usize) -> Result<Vec<u64>, String> {
    let mut sim = problem(particles, spec).expect("benchmark problem");
    let mut reports: Vec<StepReport> = Vec::new();
    for _ in 0..steps {
        reports.push(sim.step().map_err(|e| e.to_string())?);
    }
    Ok(fingerprint(sim.particles(), &reports))
}

#[test]
fn threaded_runs_equal_the_serial_run_bit_for_bit() {
    let shapes = sparse_mpm::shape::FAMILIES;
    let (mut cases, mut completed) = (0, 0);
    for shape in shapes {
        for (update, transfer) in [
            (UpdateScheme::Usl, Transfer::Apic),
            (UpdateScheme::Musl, Transfer::Flip),
            (UpdateScheme::Usf, Transfer::Pic),
            (UpdateScheme::Musl, Transfer::Xpic { k: 3 }),
            (UpdateScheme::Usl, Transfer::Fmpm { k: 2 }),
        ] {
            let spec = BenchSpec {
                shape,
                update,
                transfer,
                ..BenchSpec::default()
            };
            // 60 steps cross a re-sorting step (every 50).
            let serial = run(
                &BenchSpec {
                    threads: 1,
                    ..spec.clone()
                },
                6000,
                60,
            );
            for threads in [2, 3] {
                let threaded = run(
                    &BenchSpec {
                        threads,
                        ..spec.clone()
                    },
                    6000,
                    60,
                );
                assert!(
                    serial == threaded,
                    "{shape:?} {update:?} {transfer:?}: {threads} threads differ from the serial run"
                );
            }
            cases += 1;
            completed += usize::from(serial.is_ok());
        }
    }
    assert_eq!(cases, 20);
    assert!(
        completed >= 15,
        "only {completed} of 20 runs completed; the comparison needs real runs"
    );
}

#[test]
fn threaded_consistent_mass_runs_equal_the_serial_run_bit_for_bit() {
    for mass in [MassScheme::Consistent, MassScheme::TruncatedSeries { k: 3 }] {
        let spec = BenchSpec {
            shape: ShapeFunction::Linear,
            mass,
            transfer: Transfer::Flip,
            update: UpdateScheme::Musl,
            ..BenchSpec::default()
        };
        let serial = run(
            &BenchSpec {
                threads: 1,
                ..spec.clone()
            },
            3000,
            10,
        );
        let threaded = run(
            &BenchSpec {
                threads: 2,
                ..spec.clone()
            },
            3000,
            10,
        );
        assert!(serial.is_ok(), "{mass:?}: {serial:?}");
        assert!(serial == threaded, "{mass:?}: 2 threads differ from the serial run");
    }
}
