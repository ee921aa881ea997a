//! The AVX2 build of the transfers changes nothing: runs with it equal runs with the scalar
//! build bit for bit, for every shape function, update scheme and transfer, serial and threaded
//! (`sparse_mpm::kernels::set_scalar_kernels`; the kernels' module note says why). The switch
//! is process-wide, so this file holds one test.

use sparse_mpm::bench::{problem, BenchSpec};
use sparse_mpm::kernels::set_scalar_kernels;
use sparse_mpm::simulation::{StepReport, Transfer, UpdateScheme};
use sparse_mpm::ShapeFunction;

/// Every particle field and every report's energies and momenta, as bits, after `steps` steps
/// (or the error that stopped the run: it must be the same error).
fn run(spec: &BenchSpec, scalar: bool) -> Result<Vec<u64>, String> {
    set_scalar_kernels(scalar);
    // An odd count: the four-particle scatter's last particles go one by one.
    let mut sim = problem(4003, spec).expect("benchmark problem");
    let mut reports: Vec<StepReport> = Vec::new();
    for _ in 0..55 {
        reports.push(sim.step().map_err(|e| e.to_string())?);
    }
    let p = sim.particles();
    let mut bits: Vec<u64> = Vec::new();
    for field in [
        &p.x,
        &p.y,
        &p.vx,
        &p.vy,
        &p.sxx,
        &p.syy,
        &p.sxy,
        &p.volume,
        &p.fxx,
        &p.fyy,
        &p.affine_xx,
        &p.affine_xy,
        &p.affine_yx,
        &p.affine_yy,
    ] {
        bits.extend(field.iter().map(|v| v.to_bits()));
    }
    for r in &reports {
        for v in [
            r.dt,
            r.kinetic_energy,
            r.strain_energy,
            r.momentum[0],
            r.momentum[1],
            r.angular_momentum,
        ] {
            bits.push(v.to_bits());
        }
    }
    Ok(bits)
}

#[test]
fn the_vectorised_transfers_equal_the_scalar_ones_bit_for_bit() {
    #[cfg(target_arch = "x86_64")]
    if !std::arch::is_x86_feature_detected!("avx2") {
        eprintln!("this CPU has no AVX2: both runs take the scalar build");
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
            let scalar = run(&spec, true);
            let vector = run(&spec, false);
            assert!(
                scalar == vector,
                "{shape:?} {update:?} {transfer:?}: the AVX2 transfers differ from the scalar ones"
            );
            for threads in [2, 3] {
                let threaded = run(
                    &BenchSpec {
                        threads,
                        ..spec.clone()
                    },
                    false,
                );
                assert!(
                    scalar == threaded,
                    "{shape:?} {update:?} {transfer:?}: the AVX2 transfers on {threads} threads differ"
                );
            }
            cases += 1;
            completed += usize::from(scalar.is_ok());
        }
    }
    set_scalar_kernels(false);
    assert_eq!(cases, 28);
    assert!(
        completed >= 20,
        "only {completed} of 28 runs completed; the comparison needs real runs"
    );
}
