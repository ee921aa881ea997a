//! The explicit step's fused pass (the grid-to-particle pass of a step with the next step's
//! assembly and particle-to-grid scatter, `Options::fused_passes`) changes nothing: runs with
//! it equal runs with the separate passes bit for bit, for every shape function, transfer and
//! update scheme, with the lumped and consistent masses, walls, one particle side by side, four
//! (AVX2) and eight (AVX-512), and on 1, 2 and 3 threads. The lane switch is process-wide, so
//! this file holds one test.

mod common;

use sparse_mpm::bench::{problem, BenchSpec};
use sparse_mpm::kernels::{kernel_lanes, set_kernel_lanes};
use sparse_mpm::mass::MassScheme;
use sparse_mpm::operators::{Operator, Operators};
use sparse_mpm::simulation::{StepReport, Transfer, UpdateScheme};
use sparse_mpm::ShapeFunction;

/// Every particle field, every report's energies and momenta ([`common::fingerprint`]) and the
/// last step's grid mass and velocity, as bits, after 60 steps (or the error that stopped the
/// run: it must be the same error).
fn run(spec: &BenchSpec, lanes: usize) -> Result<Vec<u64>, String> {
    set_kernel_lanes(lanes);
    // An odd count over three blocks of particles (three workers' ranges): the last particles
    // of a block go eight, four, then one at a time.
    let mut sim = problem(9001, spec).expect("benchmark problem");
    let mut reports: Vec<StepReport> = Vec::new();
    // Past the sort of step 50, which the fused pass before it must not anticipate.
    for _ in 0..60 {
        reports.push(sim.step().map_err(|e| e.to_string())?);
    }
    let mut bits = common::fingerprint(sim.particles(), &reports);
    bits.extend(sim.lumped_mass().iter().map(|v| v.to_bits()));
    let w = sim.grid_velocity();
    bits.extend(w.x.iter().chain(&w.y).map(|v| v.to_bits()));
    Ok(bits)
}

#[test]
fn the_fused_pass_equals_the_separate_passes_bit_for_bit() {
    let mut widths = vec![1];
    widths.extend([4, 8].into_iter().filter(|&w| {
        set_kernel_lanes(w);
        kernel_lanes() == w
    }));
    let shapes = [
        ShapeFunction::Linear,
        ShapeFunction::Gimp { half_width: 0.25 },
        ShapeFunction::QuadraticBSpline,
        ShapeFunction::CubicBSpline,
    ];
    let schemes = [
        (UpdateScheme::Usl, Transfer::Apic, MassScheme::Lumped),
        (UpdateScheme::Usl, Transfer::Flip, MassScheme::Lumped),
        (UpdateScheme::Usl, Transfer::Pic, MassScheme::Lumped),
        (UpdateScheme::Usl, Transfer::Blend { flip: 0.95 }, MassScheme::Lumped),
        (UpdateScheme::Usf, Transfer::Apic, MassScheme::Lumped),
        (UpdateScheme::Usf, Transfer::Flip, MassScheme::Lumped),
        (UpdateScheme::Musl, Transfer::Flip, MassScheme::Lumped),
        (UpdateScheme::Usl, Transfer::Xpic { k: 3 }, MassScheme::Lumped),
        (UpdateScheme::Usl, Transfer::Flip, MassScheme::Consistent),
    ];
    let (mut cases, mut completed) = (0, 0);
    for shape in shapes {
        for (update, transfer, mass) in schemes {
            let separate = BenchSpec {
                shape,
                update,
                transfer,
                mass,
                fused_passes: false,
                // The consistent mass at its own stable step (the peers' is above it).
                cfl: (mass != MassScheme::Lumped).then_some(0.5),
                ..BenchSpec::default()
            };
            let reference = run(&separate, 1);
            for &lanes in &widths {
                for threads in [1, 2, 3] {
                    let fused = BenchSpec {
                        fused_passes: true,
                        threads,
                        ..separate.clone()
                    };
                    assert!(
                        reference == run(&fused, lanes),
                        "{shape:?} {update:?} {transfer:?} {mass:?}: the fused pass ({lanes} side by side, \
                         {threads} threads) differs from the separate passes"
                    );
                }
            }
            cases += 1;
            completed += usize::from(reference.is_ok());
        }
    }
    set_kernel_lanes(8);
    assert_eq!(cases, 36);
    assert!(
        completed >= 28,
        "only {completed} of 36 runs completed; the comparison needs real runs"
    );
}

/// The bits of the particles' positions and velocities, and the error that stopped the run.
fn after_changes(fused_passes: bool, kick: f64) -> (Vec<u64>, Option<String>) {
    let spec = BenchSpec {
        fused_passes,
        ..BenchSpec::default()
    };
    let mut sim = problem(3001, &spec).expect("benchmark problem");
    let mut error = None;
    for step in 0..40 {
        // Between steps the particles change: the next step's prepared terms must not be used.
        if step == 10 {
            sim.set_velocity(|id, [vx, vy]| [vx + 0.05 * (id % 3) as f64, vy])
                .expect("finite");
        }
        if step == 15 {
            sim.set_stress(|id, [sxx, syy, sxy]| [sxx + 0.1 * (id % 7) as f64, syy, sxy])
                .expect("finite");
        }
        if step == 20 {
            sim.set_body_force(|id, _| [0.0, -((id % 5) as f64)]);
        }
        // For one step the block translates at `kick`: more than two grid lines in a step (the
        // fused pass stops and the columns are assembled again), or out of the grid (the error,
        // at the same step).
        if step == 30 {
            sim.set_velocity(|_, _| [0.0, -kick]).expect("finite");
        }
        if step == 31 {
            sim.set_velocity(|_, _| [0.0, 0.0]).expect("finite");
        }
        // The same along the lines (past the two columns prepared on each side), there and back
        // into columns the accumulators held terms of before.
        if step == 32 || step == 36 {
            let kick = if step == 32 { kick } else { -kick };
            sim.set_velocity(|_, _| [kick, 0.0]).expect("finite");
        }
        if step == 33 || step == 37 {
            sim.set_velocity(|_, _| [0.0, 0.0]).expect("finite");
        }
        if let Err(e) = sim.step() {
            error = Some(e.to_string());
            break;
        }
        // After a step the operators are those of the particles' present positions when the
        // fused pass ran or stopped (assembled again), those of the step's start otherwise.
        if fused_passes && [30, 32, 35, 36].contains(&step) {
            let ops = sim.operators();
            // (A particle out of the grid: the columns are marked unusable, the next step fails.)
            let Ok(now) = Operators::assemble(sim.grid(), sim.options().shape, sim.particles()) else {
                assert_eq!(ops.num_particles(), 0, "step {step}: the columns marked unusable");
                continue;
            };
            assert!(
                ops.row_indices() == now.row_indices(),
                "step {step}: the columns' nodes"
            );
            assert!(ops.values(Operator::N) == now.values(Operator::N), "step {step}: N");
            assert!(ops.values(Operator::Gx) == now.values(Operator::Gx), "step {step}: Gx");
            assert_eq!(ops.node_span(), now.node_span(), "step {step}: the node span");
            assert_eq!(ops.column_span(), now.column_span(), "step {step}: the column span");
        }
    }
    let p = sim.particles();
    let bits =
        p.x.iter()
            .chain(&p.y)
            .chain(&p.vx)
            .chain(&p.vy)
            .chain(&p.sxx)
            .map(|v| v.to_bits())
            .collect();
    (bits, error)
}

#[test]
fn changes_between_steps_and_stops_of_the_fused_pass_change_nothing() {
    // The 3001-particle block on 55 cells, steps of 4.65e-4 s: 0.5 m/s moves it a hundredth of a
    // cell; 120 m/s three cells (past the two lines prepared, which run along x); 1e4 m/s out of the grid.
    for kick in [0.5, 120.0, 1e4] {
        let separate = after_changes(false, kick);
        let fused = after_changes(true, kick);
        assert_eq!(separate.1, fused.1, "kick {kick}: the runs stop alike");
        assert!(separate == fused, "kick {kick}: the fused pass changed the particles");
        if kick == 1e4 {
            assert!(fused.1.is_some(), "a particle thrown out of the grid stops the run");
        }
    }
}
