//! Thin bodies: cantilevers one and two cells thick with quadratic B-splines, clamped by a
//! mirrored wall and released under gravity. Where the stiffness is nonsingular the mass cannot
//! change the static deflection, so the first swings of consistent and lumped mass must agree
//! with each other and with beam theory. One cell thick the particles' stiffness has four
//! zero-energy modes and the static deflection of the MUSL update depends on the mass
//! (`examples/thin_beam_statics.rs`: 0.0563 lumped, 0.0617 consistent, 0.0596 four cells thick).

use sparse_mpm_study::verification::cantilever::thin_beam::{self, LENGTH};

/// The largest downward deflection of the middle of the free end of the thin beam
/// (`verification::cantilever::thin_beam`) `cells_thick` cells thick with `mass` in both
/// solves during the first swing (until it has come back up by half).
fn first_swing(cells_thick: usize, mass: &str) -> f64 {
    let scene = thin_beam::scene(cells_thick, mass).unwrap();
    let mut sim = scene.build().unwrap();
    let p = sim.particles();
    let tip = (0..p.len())
        .min_by(|&a, &b| {
            let d = |k: usize| (p.x[k] - LENGTH).hypot(p.y[k] - 0.5);
            d(a).total_cmp(&d(b))
        })
        .map(|k| p.id[k])
        .unwrap();
    let tip_y = |s: &sparse_mpm::simulation::Simulation| {
        let p = s.particles();
        (0..p.len()).find(|&k| p.id[k] == tip).map(|k| p.y[k]).unwrap()
    };
    let y0 = tip_y(&sim);
    let mut largest = 0.0f64;
    let mut done = false;
    sim.run_until(scene.time.end, |s, _| {
        let d = y0 - tip_y(s);
        if !done {
            largest = largest.max(d);
            done = largest > 0.0 && d < 0.5 * largest;
        }
        Ok(())
    })
    .unwrap_or_else(|e| panic!("{cells_thick} cells thick, {mass}: {e}"));
    assert!(
        done,
        "{cells_thick} cells thick, {mass}: the first swing ends within the run (largest {largest}, last {}, t {})",
        y0 - tip_y(&sim),
        sim.time()
    );
    largest
}

#[test]
fn cantilevers_one_and_two_cells_thick_swing_as_far_with_the_consistent_mass() {
    let theory = thin_beam::euler_bernoulli_first_swing();
    // The converged answer (lumped and consistent agree to 0.4% four cells thick: 0.1203 and
    // 0.1208) lies 2.5% above Euler–Bernoulli (shear, large rotation).
    let converged = first_swing(4, "consistent");
    for cells_thick in [1, 2] {
        let lumped = first_swing(cells_thick, "lumped");
        let consistent = first_swing(cells_thick, "consistent");
        println!(
            "{cells_thick} cells thick: lumped {lumped:.5}, consistent {consistent:.5}, \
             Euler–Bernoulli {theory:.5}, converged {converged:.5}"
        );
        let off = |a: f64, b: f64| (a - b).abs() / b;
        assert!(
            off(consistent, theory) <= 0.1,
            "{cells_thick} cells thick: the consistent mass's first swing {consistent:.4} is {:.1}% from \
             Euler–Bernoulli ({theory:.4})",
            100.0 * off(consistent, theory)
        );
        // Both masses within 10% of the converged answer.
        for (name, value) in [("lumped", lumped), ("consistent", consistent)] {
            assert!(
                off(value, converged) <= 0.1,
                "{cells_thick} cells thick: {name} {value:.4} is {:.1}% from the converged {converged:.4}",
                100.0 * off(value, converged)
            );
        }
        // Measured: 12.8% apart one cell thick (lumped 0.1107, 8% short of the converged
        // answer; consistent 0.1249, 3% beyond it: the statics of the two differ there,
        // see the module docs), 0.9% two cells thick. One cell thick the consistent mass is the
        // closer of the two to the converged answer.
        let bound = if cells_thick == 1 { 0.15 } else { 0.1 };
        assert!(
            off(consistent, lumped) <= bound,
            "{cells_thick} cells thick: consistent {consistent:.4} is {:.1}% from lumped ({lumped:.4})",
            100.0 * off(consistent, lumped)
        );
        assert!(
            cells_thick > 1 || off(consistent, converged) <= off(lumped, converged),
            "{cells_thick} cells thick: consistent {consistent:.4} is further than lumped {lumped:.4} from {converged:.4}"
        );
    }
}
