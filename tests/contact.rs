//! Contact between bodies ([`sparse_mpm::contact`]): closed forms on a slope, the two disks'
//! energy and momentum, bits where contact does not act, checkpoints, and the keys.

use sparse_mpm::mass::MassScheme;
use sparse_mpm::scene::Scene;
use sparse_mpm::simulation::Simulation;

const G: f64 = 9.81;

/// The grid (1 cm cells from `origin`), the schemes, the time and the gravity tilted by
/// `theta` degrees (reaching its full value over `ramp` seconds), and the block
/// (0.1 × 0.05 m, E = 1 MPa): what every slope scene here shares.
fn block_on_tilted_grid(theta: f64, shape: &str, origin: [f64; 2], cells: [usize; 2], ramp: f64, end: f64) -> String {
    let (s, c) = theta.to_radians().sin_cos();
    format!(
        r#"
[grid]
origin = [{ox}, {oy}]
cell_size = [0.01, 0.01]
cells = [{nx}, {ny}]
[schemes]
shape = "{shape}"
update = "musl"
transfer = "flip"
[time]
end = {end}
cfl = 0.4
[loads]
gravity = [{gx}, {gy}]
gravity_ramp = {ramp}
[[bodies]]
name = "block"
material = {{ model = "linear_elastic", youngs_modulus = 1e6, poisson_ratio = 0.3, plane = "strain" }}
density = 1000.0
geometry = {{ rectangle = {{ min = [0.05, 0.05], max = [0.15, 0.1] }} }}
"#,
        ox = origin[0],
        oy = origin[1],
        nx = cells[0],
        ny = cells[1],
        gx = G * s,
        gy = -G * c,
    )
}

/// The block on a floor under gravity tilted by `theta` degrees: the floor rigid, or an
/// elastic slab held at its base whose surface gives the normal.
fn slope(theta: f64, mu: f64, shape: &str, rigid: bool, ramp: f64, end: f64) -> String {
    let pad = if shape == "linear" { 0.0 } else { 0.02 };
    let cells = |l: f64| ((l + 2.0 * pad) / 0.01_f64).round() as usize;
    let head = block_on_tilted_grid(theta, shape, [-pad, -pad], [cells(0.6), cells(0.2)], ramp, end);
    let (held, floor) = if rigid {
        ("", "rigid = [\"floor\"]")
    } else {
        (
            "[[boundaries]]\nedge = \"bottom\"\ncondition = \"fixed\"",
            "[[contact.pairs]]\nbodies = [\"block\", \"floor\"]\nnormal = \"floor\"",
        )
    };
    format!(
        r#"{head}
[[bodies]]
name = "floor"
material = {{ model = "linear_elastic", youngs_modulus = 1e7, poisson_ratio = 0.3, plane = "strain" }}
density = 1000.0
geometry = {{ rectangle = {{ min = [0.0, 0.0], max = [0.6, 0.05] }} }}
{held}
[contact]
friction = {mu}
{floor}
"#
    )
}

/// Body 0's centre of mass along x.
fn centre(sim: &Simulation) -> f64 {
    let p = sim.particles();
    let (mut m, mut mx) = (0.0, 0.0);
    for k in (0..p.len()).filter(|&k| p.body[k] == 0) {
        m += p.mass[k];
        mx += p.mass[k] * p.x[k];
    }
    mx / m
}

/// The block's slide at each step of the scene's run, with the times.
fn slide(scene: &str) -> Vec<(f64, f64)> {
    let scene = Scene::from_toml_str(scene).unwrap();
    let mut sim = scene.build().unwrap();
    let x0 = centre(&sim);
    let mut out = Vec::new();
    sim.run_until(scene.time.end, |sim, _| {
        out.push((sim.time(), centre(sim) - x0));
        Ok(())
    })
    .unwrap();
    out
}

/// The largest error of `path` against `½ a t²` over its second half, relative to the slide at
/// its end.
fn slide_error(path: &[(f64, f64)], a: f64) -> f64 {
    let (end, _) = *path.last().unwrap();
    let exact = |t: f64| 0.5 * a * t * t;
    path.iter()
        .filter(|(t, _)| *t >= 0.5 * end)
        .map(|&(t, x)| (x - exact(t)).abs() / exact(end))
        .fold(0.0, f64::max)
}

fn sliding(theta: f64, mu: f64) -> f64 {
    let (s, c) = f64::to_radians(theta).sin_cos();
    G * (s - mu * c)
}

#[test]
fn a_block_slides_on_a_rigid_floor_at_g_sin_minus_mu_cos_and_sticks_inside_the_friction_angle() {
    for (theta, mu) in [(30.0, 0.0), (30.0, 0.3), (45.0, 0.5)] {
        let path = slide(&slope(theta, mu, "quadratic_bspline", true, 1e-9, 0.25));
        let err = slide_error(&path, sliding(theta, mu));
        assert!(
            err < 0.02,
            "θ = {theta}, μ = {mu}: {err:.3e} from ½ g (sin θ − μ cos θ) t²"
        );
    }
    // μ = 0.7 > tan 30°: the load set down over 0.05 s, the block stays within 1e-3 of its
    // length (0.1 m).
    let path = slide(&slope(30.0, 0.7, "quadratic_bspline", true, 0.05, 0.25));
    let most = path.iter().map(|(_, x)| x.abs()).fold(0.0, f64::max);
    assert!(most < 1e-4, "the block that should stick moved {most:.3e} m");
}

#[test]
fn a_block_slides_on_an_elastic_ramp_through_body_to_body_contact() {
    for shape in ["linear", "quadratic_bspline"] {
        let path = slide(&slope(30.0, 0.3, shape, false, 1e-9, 0.4));
        let err = slide_error(&path, sliding(30.0, 0.3));
        assert!(err < 0.02, "{shape}: {err:.3e} from ½ g (sin θ − μ cos θ) t²");
    }
    let path = slide(&slope(30.0, 0.7, "linear", false, 0.05, 0.25));
    let most = path.iter().map(|(_, x)| x.abs()).fold(0.0, f64::max);
    assert!(most < 1e-4, "the block that should stick moved {most:.3e} m");
}

/// The block on the grid's bottom edge, a slip wall with friction (no floor body, no
/// `[contact]`): the wall on the innermost of the edge's node lines (quadratic B-splines: the
/// second, at y = 0.05).
fn on_a_wall(theta: f64, mu: f64, ramp: f64, end: f64) -> String {
    let head = block_on_tilted_grid(theta, "quadratic_bspline", [-0.02, 0.04], [64, 18], ramp, end);
    format!("{head}\n[[boundaries]]\nedge = \"bottom\"\ncondition = \"slip\"\nfriction = {mu}\n")
}

#[test]
fn a_block_slides_on_a_slip_wall_with_friction_as_the_closed_form_and_sticks_inside_the_friction_angle() {
    for (theta, mu) in [(30.0, 0.3), (45.0, 0.5)] {
        let path = slide(&on_a_wall(theta, mu, 1e-9, 0.25));
        let err = slide_error(&path, sliding(theta, mu));
        assert!(
            err < 0.02,
            "θ = {theta}, μ = {mu}: {err:.3e} from ½ g (sin θ − μ cos θ) t²"
        );
    }
    let path = slide(&on_a_wall(30.0, 0.7, 0.05, 0.25));
    let most = path.iter().map(|(_, x)| x.abs()).fold(0.0, f64::max);
    assert!(most < 1e-4, "the block that should stick moved {most:.3e} m");
    // The wall's normal force and friction's work are reported, and the balance closes.
    let scene = Scene::from_toml_str(&on_a_wall(30.0, 0.3, 1e-9, 0.25)).unwrap();
    let mut sim = scene.build().unwrap();
    let mut rows = Vec::new();
    sim.run_until(0.25, |_, r| {
        rows.push((r.contact_force, r.total_energy, r.friction_dissipation));
        Ok(())
    })
    .unwrap();
    let half = &rows[rows.len() / 2..];
    let force = half.iter().map(|r| r.0).sum::<f64>() / half.len() as f64;
    let weight = 0.1 * 0.05 * 1000.0 * G * f64::to_radians(30.0).cos();
    assert!(
        (force - weight).abs() < 0.03 * weight,
        "normal force {force} against {weight}"
    );
    // (From the second row: the first reports gravity at its start, zero on the ramp.)
    let (first, last) = (rows[1], rows[rows.len() - 1]);
    let released = first.1 - last.1;
    assert!(
        last.2 > 0.0 && (released - last.2).abs() < 0.05 * released.abs(),
        "{released} {}",
        last.2
    );
}

fn two_disks(contact: &str, end: f64, threads: usize) -> Scene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/two_disks.toml");
    let text = std::fs::read_to_string(path).unwrap();
    let text = text.replace("end = 3.5", &format!("end = {end}"));
    let mut scene = Scene::from_toml_str(&format!("{text}\n{contact}\n[execution]\nthreads = {threads}\n")).unwrap();
    scene.output = Default::default();
    scene
}

#[test]
fn frictionless_disks_part_with_their_energy_and_the_pair_keeps_its_momentum() {
    let scene = two_disks("[contact]\nfriction = 0.0", 3.5, 1);
    let mut sim = scene.build().unwrap();
    let (mut first, mut last, mut touched) = (None, None, false);
    let mut reports = Vec::new();
    sim.run_until(scene.time.end, |_, r| {
        first.get_or_insert(r.total_energy);
        touched |= r.contact_force > 0.0;
        if touched && r.contact_force == 0.0 {
            last = Some(r.total_energy);
        }
        reports.push(r.momentum);
        Ok(())
    })
    .unwrap();
    let (e0, e1) = (first.unwrap(), last.expect("the disks part"));
    assert!((e1 - e0).abs() < 0.02 * e0, "energy after parting {e1} against {e0}");
    // The disks start with opposite momenta: the pair's stays zero to round-off.
    for p in reports {
        assert!(p[0].abs() < 1e-12 && p[1].abs() < 1e-12, "momentum {p:?}");
    }
}

#[test]
fn a_rigid_floor_moving_under_a_block_drags_it_up_to_its_own_speed_with_either_mass() {
    // The floor at V = 0.1 m/s under a block at rest, μ = 0.5: kinetic friction accelerates the
    // block at μ g until it moves with the floor (t* = V / μ g ≈ 0.02 s), so at T = 0.1 s it has
    // gone V T − V² / (2 μ g). Through the consistent mass, a moving rigid body enters the
    // pairs' coupling as no response of its own.
    let (v, mu, end) = (0.1, 0.5, 0.1);
    let exact = v * end - v * v / (2.0 * mu * G);
    for consistent in [false, true] {
        let mut scene = slope(0.0, mu, "linear", true, 1e-9, end).replace(
            "geometry = { rectangle = { min = [0.0, 0.0], max = [0.6, 0.05] } }",
            "geometry = { rectangle = { min = [0.0, 0.0], max = [0.5, 0.05] } }\nvelocity = [0.1, 0.0]",
        );
        if consistent {
            scene = with_consistent_mass(&scene, "");
        }
        let path = slide(&scene);
        let (_, x) = *path.last().unwrap();
        assert!(
            (x - exact).abs() < 0.02 * exact,
            "consistent {consistent}: the block went {x} against {exact}"
        );
    }
}

/// A solid disk of radius 0.05 m on 0.5 cm cells (10 across its radius; linear, lumped, FLIP,
/// MUSL) on a rigid floor under gravity tilted by 30°, set down over 0.05 s.
fn disk_on_a_slope(mu: f64, end: f64) -> String {
    let (s, c) = 30f64.to_radians().sin_cos();
    format!(
        r#"
[grid]
origin = [0.0, 0.0]
cell_size = [0.005, 0.005]
cells = [80, 24]
[schemes]
shape = "linear"
update = "musl"
transfer = "flip"
[time]
end = {end}
cfl = 0.4
[loads]
gravity = [{gx}, {gy}]
gravity_ramp = 0.05
[[bodies]]
name = "disk"
material = {{ model = "linear_elastic", youngs_modulus = 1e6, poisson_ratio = 0.3, plane = "strain" }}
density = 1000.0
geometry = {{ disk = {{ center = [0.06, 0.06], radius = 0.05 }} }}
[[bodies]]
name = "floor"
material = {{ model = "linear_elastic", youngs_modulus = 1e6, poisson_ratio = 0.3, plane = "strain" }}
density = 1000.0
geometry = {{ rectangle = {{ min = [0.0, 0.0], max = [0.4, 0.01] }} }}
[contact]
friction = {mu}
rigid = ["floor"]
"#,
        gx = G * s,
        gy = -G * c,
    )
}

/// The least-squares `a` of `x = x₀ + v₀ t + ½ a t²` over the second half of `path`.
fn fitted_acceleration(path: &[(f64, f64)]) -> f64 {
    let (end, _) = *path.last().unwrap();
    // Normal equations of the basis 1, t, t²/2, solved by Cramer's rule.
    let (mut a, mut b) = ([[0.0; 3]; 3], [0.0; 3]);
    for &(t, x) in path.iter().filter(|(t, _)| *t >= 0.5 * end) {
        let phi = [1.0, t, 0.5 * t * t];
        for i in 0..3 {
            for j in 0..3 {
                a[i][j] += phi[i] * phi[j];
            }
            b[i] += phi[i] * x;
        }
    }
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let mut third = a;
    for i in 0..3 {
        third[i][2] = b[i];
    }
    det(third) / det(a)
}

#[test]
fn a_disk_rolls_at_two_thirds_g_sin_theta_and_slides_below_the_friction_it_needs() {
    // Rolling needs μ ≥ tan θ / 3 = 0.19: at μ = 0.3 it rolls at ⅔ g sin θ; at μ = 0.1 it slides
    // at g (sin θ − μ cos θ). (With 5 cells across the radius it rolls 6% slow: the nodes'
    // stick holds the disk's material at their mass centre, inside the disk.)
    let sin = 30f64.to_radians().sin();
    for (mu, end, exact) in [(0.3, 0.4, 2.0 / 3.0 * G * sin), (0.1, 0.3, sliding(30.0, 0.1))] {
        let a = fitted_acceleration(&slide(&disk_on_a_slope(mu, end)));
        assert!((a - exact).abs() < 0.03 * exact, "μ = {mu}: {a} against {exact}");
    }
}

/// `scene` with the consistent mass in both solves (`stabilization` its table entry, or the
/// default), and a floor as stiff as the block: a rigid floor's stiffness plays no part, and
/// the stable step is then the block's.
fn with_consistent_mass(scene: &str, stabilization: &str) -> String {
    let mass = format!("mass = {{ velocity = \"consistent\", acceleration = \"consistent\"{stabilization} }}");
    scene
        .replace("transfer = \"flip\"", &format!("transfer = \"flip\"\n{mass}"))
        .replace("youngs_modulus = 1e7", "youngs_modulus = 1e6")
}

#[test]
fn with_the_consistent_mass_a_block_slides_at_the_closed_form_and_sticks_inside_the_friction_angle() {
    // The pairs' impulses solved through the block's mass: on their coupling formed column by
    // column (11 pairs), and by the accelerated iteration (41 pairs, a block 0.4 m long).
    for (long, end) in [(false, 0.15), (true, 0.03)] {
        let mut scene = with_consistent_mass(&slope(30.0, 0.3, "linear", true, 1e-9, end), "");
        if long {
            scene = scene.replace("max = [0.15, 0.1]", "max = [0.45, 0.1]");
        }
        let err = slide_error(&slide(&scene), sliding(30.0, 0.3));
        assert!(err < 0.02, "long {long}: {err:.3e} from ½ g (sin θ − μ cos θ) t²");
    }
    let path = slide(&with_consistent_mass(&slope(30.0, 0.7, "linear", true, 0.05, 0.15), ""));
    let most = path.iter().map(|(_, x)| x.abs()).fold(0.0, f64::max);
    assert!(most < 1e-4, "the block that should stick moved {most:.3e} m");
}

/// The total energy when the disks of `scene` part (the first report after the last one with a
/// contact force), against the start, and the largest momentum component of the pair.
fn parting(scene: &Scene) -> (f64, f64) {
    let mut sim = scene.build().unwrap();
    let (mut history, mut momentum) = (Vec::new(), 0.0_f64);
    sim.run_until(scene.time.end, |_, r| {
        history.push((r.contact_force, r.total_energy));
        momentum = momentum.max(r.momentum[0].abs()).max(r.momentum[1].abs());
        Ok(())
    })
    .unwrap();
    let last_contact = history.iter().rposition(|(f, _)| *f > 0.0).expect("the disks meet");
    let (_, parted) = history.get(last_contact + 1).expect("the disks part");
    (parted / history[0].1, momentum)
}

#[test]
fn with_the_consistent_mass_frictionless_disks_part_with_their_energy_and_keep_their_momentum() {
    // The pairs' impulses through each disk's mass, stabilised by partial lumping (the default
    // of [contact]) or the ghost penalty. (The schemes' default linear extension parts them
    // with 102.8%: docs/verification.md.)
    for stabilization in ["", "\nstabilization = \"ghost_penalty\""] {
        let mut scene = two_disks(&format!("[contact]\nfriction = 0.0{stabilization}"), 3.5, 1);
        let mass = &mut scene.schemes.mass;
        (mass.velocity, mass.acceleration) = (MassScheme::Consistent, MassScheme::Consistent);
        let (energy, momentum) = parting(&scene);
        assert!(
            (energy - 1.0).abs() < 0.02,
            "{stabilization}: energy after parting {energy}"
        );
        assert!(momentum < 1e-12, "{stabilization}: momentum {momentum}");
    }
}

#[test]
fn with_the_consistent_mass_a_block_slides_on_an_elastic_ramp_and_on_a_wall_with_friction() {
    // Body-to-body contact with an elastic slab held at its base (E = 10 MPa: its stiffness
    // counts), and the grid's bottom edge a slip wall with friction met through contact (one
    // consistent mass per component there), both at θ = 30°, μ = 0.3.
    let mass = "transfer = \"flip\"\nmass = { velocity = \"consistent\", acceleration = \"consistent\" }";
    for (ramp, scene) in [
        (true, slope(30.0, 0.3, "linear", false, 1e-9, 0.1)),
        (false, on_a_wall(30.0, 0.3, 1e-9, 0.1)),
    ] {
        let scene = scene.replace("transfer = \"flip\"", mass);
        let err = slide_error(&slide(&scene), sliding(30.0, 0.3));
        assert!(err < 0.02, "ramp {ramp}: {err:.3e} from ½ g (sin θ − μ cos θ) t²");
    }
}

fn particle_bits(sim: &Simulation) -> Vec<u64> {
    let p = sim.particles();
    [&p.x, &p.y, &p.vx, &p.vy, &p.sxx, &p.syy, &p.sxy, &p.volume]
        .iter()
        .flat_map(|f| f.iter().map(|v| v.to_bits()))
        .collect()
}

#[test]
fn bodies_that_never_share_a_node_take_the_same_bits_with_contact_on_any_thread_count() {
    // The disks share no node before t ≈ 1.2.
    let run = |contact: &str, threads: usize| {
        let scene = two_disks(contact, 0.9, threads);
        let mut sim = scene.build().unwrap();
        let mut forces = 0.0;
        sim.run_until(scene.time.end, |_, r| {
            forces += r.contact_force;
            Ok(())
        })
        .unwrap();
        assert_eq!(forces, 0.0);
        particle_bits(&sim)
    };
    let without = run("", 1);
    assert!(
        without == run("[contact]\nfriction = 0.3", 1),
        "contact changed bodies apart"
    );
    assert!(without == run("[contact]\nfriction = 0.3", 2), "two threads");
}

#[test]
fn contact_runs_resume_from_a_checkpoint_bit_for_bit_and_threads_do_not_change_them() {
    let dir = std::env::temp_dir().join(format!("sparse-mpm-contact-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("contact.ckpt");
    // The lumped and the consistent mass (the impulses solved through each disk's mass).
    for consistent in [false, true] {
        let scene = |threads: usize| {
            let mut scene = two_disks("[contact]\nfriction = 0.2", 1.8, threads);
            if consistent {
                let mass = &mut scene.schemes.mass;
                (mass.velocity, mass.acceleration) = (MassScheme::Consistent, MassScheme::Consistent);
            }
            scene
        };
        // The disks in contact from t ≈ 1.6: run to 1.7, checkpoint, go on to 1.8.
        let straight = {
            let mut sim = scene(1).build().unwrap();
            // (Stopping at 1.7 shortens a step, as the checkpointed run does.)
            sim.run_until(1.7, |_, _| Ok(())).unwrap();
            sim.run_until(1.8, |_, _| Ok(())).unwrap();
            sim
        };
        let mut two = scene(2).build().unwrap();
        two.run_until(1.7, |_, _| Ok(())).unwrap();
        two.run_until(1.8, |_, _| Ok(())).unwrap();
        assert!(particle_bits(&two) == particle_bits(&straight), "two threads");
        let mut sim = scene(2).build().unwrap();
        sim.run_until(1.7, |_, _| Ok(())).unwrap();
        sim.write_checkpoint(&file).unwrap();
        let mut resumed = Simulation::read_checkpoint(&file).unwrap();
        let mut last = None;
        resumed
            .run_until(1.8, |_, r| {
                last = Some((r.contact_force, r.friction_dissipation));
                Ok(())
            })
            .unwrap();
        assert!(
            particle_bits(&resumed) == particle_bits(&straight),
            "consistent {consistent}: resumed on two threads"
        );
        let (force, friction) = last.unwrap();
        assert!(
            force > 0.0 && friction > 0.0,
            "consistent {consistent}: the disks press and rub: {force}, {friction}"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn contact_keys_and_the_schemes_it_works_with_are_checked_by_name() {
    let base = slope(30.0, 0.3, "linear", true, 1e-9, 0.1);
    let base = &base[..base.find("[contact]").unwrap()];
    let error = |text: &str| match Scene::from_toml_str(text).and_then(|s| s.build().map(|_| ())) {
        Ok(()) => panic!("accepted:\n{text}"),
        Err(e) => e.to_string(),
    };
    for (contact, key) in [
        ("[contact]\nfrictoin = 0.1", "frictoin"),
        ("[contact]\nfriction = -0.1", "contact.friction"),
        (
            "[contact]\n[[contact.pairs]]\nbodies = [\"block\", \"flor\"]",
            "contact.pairs[0].bodies[1]",
        ),
        ("[contact]\nrigid = [\"ramp\"]", "contact.rigid[0]"),
        ("[contact]\nstabilization = \"ghost\"", "stabilization"),
        (
            "[contact]\nstabilization = { ghost_penalty = { gamma = -1.0 } }",
            "contact.stabilization",
        ),
        (
            "[contact]\n[[contact.pairs]]\nbodies = [\"block\", \"floor\"]\nnormal = \"wall\"",
            "contact.pairs[0].normal",
        ),
        (
            "[contact]\n[[contact.pairs]]\nbodies = [\"block\", \"block\"]",
            "with itself",
        ),
    ] {
        let message = error(&format!("{base}{contact}"));
        assert!(message.contains(key), "{contact:?}: {message}");
    }
    for (from, to, what) in [
        (
            "transfer = \"flip\"",
            "transfer = \"flip\"\nmass = { velocity = \"consistent\", acceleration = \"lumped\" }",
            "lumped mass in both solves or in neither",
        ),
        ("transfer = \"flip\"", "transfer = \"xpic:2\"", "XPIC"),
        ("update = \"musl\"", "update = \"usf\"", "USF"),
    ] {
        let message = error(&format!("{}[contact]\n", base.replace(from, to)));
        assert!(message.contains("contact") && message.contains(what), "{to}: {message}");
    }
    // Friction on a fixed wall, a negative coefficient, a frictional wall between two bodies
    // without contact.
    let wall = on_a_wall(30.0, 0.3, 1e-9, 0.1);
    let message = error(&wall.replace("condition = \"slip\"", "condition = \"fixed\""));
    assert!(message.contains("boundaries[0].friction"), "{message}");
    let message = error(&wall.replace("friction = 0.3", "friction = -1"));
    assert!(message.contains("boundaries[0].friction"), "{message}");
    let second = "[[bodies]]\nname = \"second\"\nmaterial = { model = \"linear_elastic\", youngs_modulus = 1e6, \
                  poisson_ratio = 0.3 }\ndensity = 1000.0\ngeometry = { rectangle = { min = [0.3, 0.05], max = [0.4, 0.1] } }\n";
    let message = error(&wall.replace("[[boundaries]]", &format!("{second}[[boundaries]]")));
    assert!(message.contains("[contact]"), "{message}");
}
