//! The vector builds of the kernels change nothing: runs with four particles side by side
//! (AVX2) and with eight (AVX-512) equal runs with the scalar build bit for bit, for every shape
//! function, update scheme and transfer, serial and threaded
//! (`sparse_mpm::kernels::set_kernel_lanes`; the lanes module note says why). The switch is
//! process-wide, so this file holds one test.

mod common;

use sparse_mpm::bench::{problem, BenchSpec};
use sparse_mpm::kernels::{kernel_lanes, set_kernel_lanes};
use sparse_mpm::simulation::{StepReport, Transfer, UpdateScheme};
use sparse_mpm::ShapeFunction;

/// Every particle field and every report field as bits ([`common::fingerprint`]) after 55
/// steps (or the error that stopped the run: it must be the same error).
fn run(spec: &BenchSpec, lanes: usize) -> Result<Vec<u64>, String> {
    set_kernel_lanes(lanes);
    // An odd count: the last particles of a block go four, then one at a time.
    let mut sim = problem(4003, spec).expect("benchmark problem");
    let mut reports: Vec<StepReport> = Vec::new();
    for _ in 0..55 {
        reports.push(sim.step().map_err(|e| e.to_string())?);
    }
    let bits = common::fingerprint(sim.particles(), &reports);
    Ok(bits)
}

#[test]
fn the_vectorised_transfers_equal_the_scalar_ones_bit_for_bit() {
    let widths: Vec<usize> = [4, 8]
        .into_iter()
        .filter(|&w| {
            set_kernel_lanes(w);
            kernel_lanes() == w
        })
        .collect();
    if widths.is_empty() {
        eprintln!("this CPU has no AVX2: every run takes the scalar build");
    }
    let shapes = [
        ShapeFunction::Linear,
        ShapeFunction::Gimp { half_width: 0.25 },
        ShapeFunction::QuadraticBSpline,
        ShapeFunction::CubicBSpline,
    ];
    let (mut cases, mut completed) = (0, 0);
    for shape in shapes {
        for (update, transfer) in [
            (UpdateScheme::Usl, Transfer::Apic),
            (UpdateScheme::Usl, Transfer::Flip),
            (UpdateScheme::Usl, Transfer::Blend { flip: 0.95 }),
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
            let scalar = run(&spec, 1);
            for &lanes in &widths {
                let vector = run(&spec, lanes);
                assert!(
                    scalar == vector,
                    "{shape:?} {update:?} {transfer:?}: {lanes} particles side by side differ from the scalar build"
                );
            }
            let widest = widths.last().copied().unwrap_or(1);
            for threads in [2, 3] {
                let threaded = run(
                    &BenchSpec {
                        threads,
                        ..spec.clone()
                    },
                    widest,
                );
                assert!(
                    scalar == threaded,
                    "{shape:?} {update:?} {transfer:?}: {widest} particles side by side on {threads} threads differ"
                );
            }
            cases += 1;
            completed += usize::from(scalar.is_ok());
        }
    }
    set_kernel_lanes(8);
    assert_eq!(cases, 28);
    assert!(
        completed >= 20,
        "only {completed} of 28 runs completed; the comparison needs real runs"
    );
}
