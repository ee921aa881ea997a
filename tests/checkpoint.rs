//! Checkpoint and resume: a run stopped after K steps, written to a file, dropped, read back and
//! continued equals the uninterrupted run bit for bit, in every particle field and every report
//! field; damaged files (a changed byte, a truncation, another format version, random bytes)
//! are clear errors, never panics.

#[path = "common/scratch.rs"]
mod scratch;
use std::path::Path;

use sparse_mpm::boundary::{BoundaryCondition, Condition, Edge};
use sparse_mpm::mass::{MassOptions, MassScheme};
use sparse_mpm::material::{LinearElastic, Material, NeoHookean, PlaneCondition};
use sparse_mpm::simulation::{
    Body, Options, Simulation, StepReport, TimeStep, Transfer, UpdateScheme, CHECKPOINT_FORMAT_VERSION,
};
use sparse_mpm::{Grid, MpmError, Particles, ShapeFunction};

/// Byte offset of the format version in the header (after the format name).
const VERSION_OFFSET: usize = b"sparse-mpm checkpoint\n".len();

/// A directory of its own for one test, emptied first.
fn scratch_dir(name: &str) -> scratch::Scratch {
    scratch::Scratch::new("checkpoint", name)
}

/// Particles of 2 × 2 per cell over cells `[i0, i1) × [j0, j1)` of body `body`, turning about
/// their centre at `omega` and moving with `velocity`.
fn block(grid: &Grid, cells: [[usize; 2]; 2], body: usize, density: f64, omega: f64, velocity: [f64; 2]) -> Particles {
    let [h, _] = grid.cell_size();
    let [ox, oy] = grid.origin();
    let [[i0, i1], [j0, j1]] = cells;
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for j in 2 * j0..2 * j1 {
        for i in 2 * i0..2 * i1 {
            x.push(ox + (i as f64 + 0.5) * h / 2.0);
            y.push(oy + (j as f64 + 0.5) * h / 2.0);
        }
    }
    let n = x.len();
    let (cx, cy) = (x.iter().sum::<f64>() / n as f64, y.iter().sum::<f64>() / n as f64);
    let vx = y.iter().map(|y| velocity[0] - omega * (y - cy)).collect();
    let vy = x.iter().map(|x| velocity[1] + omega * (x - cx)).collect();
    let v = h * h / 4.0;
    let mut p = Particles::new(x, y, vec![density * v; n], vec![v; n])
        .unwrap()
        .with_velocity(vx, vy)
        .unwrap();
    p.body = vec![body; n];
    p
}

/// How a run is set up.
#[derive(Debug, Clone)]
struct Case {
    name: &'static str,
    shape: ShapeFunction,
    update: UpdateScheme,
    transfer: Transfer,
    mass: MassOptions,
    time_step: TimeStep,
    threads: usize,
}

impl Case {
    fn new(
        name: &'static str,
        shape: ShapeFunction,
        update: UpdateScheme,
        transfer: Transfer,
        mass: MassScheme,
    ) -> Case {
        Case {
            name,
            shape,
            update,
            transfer,
            mass: MassOptions::both(mass),
            time_step: TimeStep::Cfl { number: 0.4 },
            threads: 1,
        }
    }
}

/// Two bodies (neo-Hookean and linear elastic, 128 and 120 particles) turning and falling onto a
/// slip floor, beside a fixed left wall, a rectangle of nodes moving at a prescribed velocity and
/// a few fixed nodes; particles re-sorted every 5 steps, the stable step estimated every 7.
fn simulation(case: &Case) -> Simulation {
    // 3 cells of padding on every side keep the cubic and quadratic supports inside.
    let grid = Grid::new([-0.15, -0.15], [0.05, 0.05], [26, 26]).unwrap();
    let mut particles = block(&grid, [[6, 14], [6, 14]], 0, 1000.0, 3.0, [0.2, -0.4]);
    particles
        .append(block(&grid, [[15, 21], [9, 14]], 1, 800.0, -2.0, [-0.3, 0.1]))
        .unwrap();
    let bodies = vec![
        Body {
            name: "neo-Hookean block".into(),
            material: Material::NeoHookean(NeoHookean {
                youngs_modulus: 5.0e3,
                poisson_ratio: 0.3,
            }),
        },
        Body {
            name: "linear block".into(),
            material: Material::LinearElastic(LinearElastic {
                youngs_modulus: 8.0e3,
                poisson_ratio: 0.25,
                plane: PlaneCondition::Strain,
            }),
        },
    ];
    let boundaries = vec![
        BoundaryCondition::edge(Edge::Bottom, Condition::Slip).with_layers(4),
        BoundaryCondition::edge(Edge::Left, Condition::Fixed),
        BoundaryCondition::rectangle([[0.9, 0.0], [1.05, 1.1]], Condition::Velocity).with_velocity(Some(-0.05), None),
        BoundaryCondition::nodes(vec![700, 701], Condition::Fixed),
    ];
    let options = Options {
        shape: case.shape,
        update: case.update,
        transfer: case.transfer,
        mass: case.mass,
        time_step: case.time_step,
        gravity: [0.0, -9.81],
        boundaries,
        sort_interval: 5,
        stability_interval: 7,
        threads: case.threads,
        ..Options::default()
    };
    let mut sim = Simulation::new(grid, particles, bodies, options).unwrap();
    // A body force that differs per particle (kept in the particles).
    sim.set_body_force(|id, [x, _]| [0.1 * (id % 7) as f64, 0.5 * x]);
    sim
}

/// Every particle field, as bits, named.
fn particle_bits(p: &Particles) -> Vec<(&'static str, Vec<u64>)> {
    let f = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<u64>>();
    let u = |v: &[usize]| v.iter().map(|&x| x as u64).collect::<Vec<u64>>();
    vec![
        ("x", f(&p.x)),
        ("y", f(&p.y)),
        ("vx", f(&p.vx)),
        ("vy", f(&p.vy)),
        ("mass", f(&p.mass)),
        ("volume", f(&p.volume)),
        ("sxx", f(&p.sxx)),
        ("syy", f(&p.syy)),
        ("sxy", f(&p.sxy)),
        ("bx", f(&p.bx)),
        ("by", f(&p.by)),
        ("fxx", f(&p.fxx)),
        ("fxy", f(&p.fxy)),
        ("fyx", f(&p.fyx)),
        ("fyy", f(&p.fyy)),
        ("affine_xx", f(&p.affine_xx)),
        ("affine_xy", f(&p.affine_xy)),
        ("affine_yx", f(&p.affine_yx)),
        ("affine_yy", f(&p.affine_yy)),
        ("body", u(&p.body)),
        ("id", u(&p.id)),
    ]
}

/// Every report field as bits (the 25 CSV columns), and the solve reports in full.
fn report_bits(r: &StepReport) -> (Vec<u64>, String) {
    (
        r.values().iter().map(|v| v.to_bits()).collect(),
        format!("{:?} {:?}", r.velocity_solve, r.acceleration_solve),
    )
}

/// The state a simulation shows, as bits: particles, clock, stable step, frequency estimate,
/// grid fields of the last step.
fn state_bits(sim: &Simulation) -> Vec<(&'static str, Vec<u64>)> {
    let f = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<u64>>();
    let mut out = particle_bits(sim.particles());
    let estimate = sim
        .frequency_estimate()
        .map(|(e, at)| vec![e.omega_squared.to_bits(), e.lanczos_steps as u64, at as u64]);
    out.extend([
        ("time", vec![sim.time().to_bits()]),
        ("steps", vec![sim.steps() as u64]),
        ("stable_time_step", vec![sim.stable_time_step().to_bits()]),
        ("frequency_estimate", estimate.unwrap_or_default()),
        ("body_densities", f(sim.body_densities())),
        ("lumped_mass", f(sim.lumped_mass())),
        ("grid_velocity_x", f(&sim.grid_velocity().x)),
        ("grid_velocity_y", f(&sim.grid_velocity().y)),
    ]);
    out
}

fn assert_same_state(case: &str, what: &str, a: &Simulation, b: &Simulation) {
    for ((name, x), (_, y)) in state_bits(a).iter().zip(&state_bits(b)) {
        if let Some(k) = (0..x.len().max(y.len())).find(|&k| x.get(k) != y.get(k)) {
            panic!(
                "{case}: {what}: `{name}` differs first at entry {k} (of {} / {})",
                x.len(),
                y.len()
            );
        }
    }
}

/// Runs `case` for `n` steps straight, and again stopping after each step in `stops` to write a
/// checkpoint, drop the simulation and read it back; compares everything bit for bit.
fn check_resume(case: &Case, stops: &[usize], n: usize) {
    let dir = scratch_dir(case.name);
    let path = dir.join("run.ckpt");

    let mut straight = simulation(case);
    let mut straight_reports = Vec::new();
    let mut at_stop = Vec::new();
    for k in 0..n {
        if stops.contains(&k) {
            at_stop.push(state_bits(&straight));
        }
        straight_reports.push(
            straight
                .step()
                .unwrap_or_else(|e| panic!("{}: step {k}: {e}", case.name)),
        );
    }

    let mut resumed = simulation(case);
    let mut resumed_reports = Vec::new();
    let mut stop = 0;
    for k in 0..n {
        if stops.contains(&k) {
            resumed.write_checkpoint(&path).unwrap();
            let options = resumed.options().clone();
            let bodies = resumed.bodies().to_vec();
            let prescribed = format!("{:?}", resumed.prescribed());
            drop(resumed);
            resumed = Simulation::read_checkpoint(&path).unwrap();
            assert_eq!(resumed.options(), &options, "{}: options", case.name);
            assert_eq!(resumed.bodies(), &bodies[..], "{}: bodies", case.name);
            assert_eq!(
                format!("{:?}", resumed.prescribed()),
                prescribed,
                "{}: boundaries",
                case.name
            );
            let loaded = state_bits(&resumed);
            for ((name, x), (_, y)) in loaded.iter().zip(&at_stop[stop]) {
                assert!(
                    x == y,
                    "{}: after reading the checkpoint of step {k}, `{name}` differs",
                    case.name
                );
            }
            stop += 1;
        }
        resumed_reports.push(
            resumed
                .step()
                .unwrap_or_else(|e| panic!("{}: resumed step {k}: {e}", case.name)),
        );
    }
    assert_eq!(stop, stops.len());

    for (k, (a, b)) in straight_reports.iter().zip(&resumed_reports).enumerate() {
        assert!(
            report_bits(a) == report_bits(b),
            "{}: report of step {} differs:\n{a:?}\n{b:?}",
            case.name,
            k + 1
        );
    }
    assert_same_state(case.name, "after the last step", &straight, &resumed);
    // Nothing but the checkpoint itself is left in the directory.
    let names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, vec![std::ffi::OsString::from("run.ckpt")], "{}", case.name);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Steps of each comparison, and where it stops: 10 is a re-sorting step (every 5) between two
/// stable-step estimates (every 7: at 7, 14, 21), so the next estimate falls after the restart.
const STEPS: usize = 24;
const STOP: usize = 10;

#[test]
fn lumped_flip_with_linear_kernels_resumes_bit_for_bit() {
    let case = Case::new(
        "lumped-flip-linear",
        ShapeFunction::Linear,
        UpdateScheme::Usl,
        Transfer::Flip,
        MassScheme::Lumped,
    );
    check_resume(&case, &[STOP], STEPS);
}

#[test]
fn quadratic_apic_resumes_bit_for_bit() {
    let case = Case::new(
        "quadratic-apic",
        ShapeFunction::QuadraticBSpline,
        UpdateScheme::Usl,
        Transfer::Apic,
        MassScheme::Lumped,
    );
    check_resume(&case, &[STOP], STEPS);
}

#[test]
fn consistent_mass_direct_solve_resumes_bit_for_bit() {
    let case = Case::new(
        "consistent-direct",
        ShapeFunction::Linear,
        UpdateScheme::Musl,
        Transfer::Flip,
        MassScheme::Consistent,
    );
    check_resume(&case, &[STOP], STEPS);
}

#[test]
fn conjugate_gradient_resumes_bit_for_bit_with_its_warm_start() {
    let case = Case::new(
        "consistent-cg",
        ShapeFunction::QuadraticBSpline,
        UpdateScheme::Musl,
        Transfer::Flip,
        MassScheme::Iterative {
            tolerance: 1e-8,
            max_iterations: 500,
        },
    );
    check_resume(&case, &[STOP], STEPS);
}

#[test]
fn musl_resumes_bit_for_bit_across_repeated_checkpoints() {
    // Checkpoints before the first step, at a step with an estimate due right after the restart
    // (14 = 7 + 7), and at the last step.
    let case = Case::new(
        "musl-repeated",
        ShapeFunction::Gimp { half_width: 0.25 },
        UpdateScheme::Musl,
        Transfer::Blend { flip: 0.9 },
        MassScheme::Lumped,
    );
    check_resume(&case, &[0, 3, 14, STEPS - 1], STEPS);
}

#[test]
fn usf_xpic_with_a_fixed_step_resumes_bit_for_bit() {
    let case = Case {
        time_step: TimeStep::Fixed { dt: 1.0e-3 },
        ..Case::new(
            "usf-xpic-fixed",
            ShapeFunction::CubicBSpline,
            UpdateScheme::Usf,
            Transfer::Xpic { k: 3 },
            MassScheme::Lumped,
        )
    };
    check_resume(&case, &[STOP], STEPS);
}

#[test]
fn a_run_on_two_threads_resumes_bit_for_bit() {
    for (name, mass) in [
        ("threads-lumped", MassScheme::Lumped),
        (
            "threads-cg",
            MassScheme::Iterative {
                tolerance: 1e-8,
                max_iterations: 500,
            },
        ),
    ] {
        let case = Case {
            threads: 2,
            ..Case::new(
                name,
                ShapeFunction::QuadraticBSpline,
                UpdateScheme::Musl,
                Transfer::Flip,
                mass,
            )
        };
        check_resume(&case, &[STOP], STEPS);
    }
}

#[test]
fn a_checkpoint_written_on_two_threads_resumes_on_one_with_the_same_bits() {
    // Results do not depend on the threads, so neither does a checkpoint's continuation.
    let serial = Case::new(
        "threads-serial",
        ShapeFunction::Linear,
        UpdateScheme::Musl,
        Transfer::Flip,
        MassScheme::Consistent,
    );
    let threaded = Case {
        threads: 2,
        ..serial.clone()
    };
    let mut straight = simulation(&serial);
    let mut sim = simulation(&threaded);
    for _ in 0..STOP {
        straight.step().unwrap();
        sim.step().unwrap();
    }
    let bytes = checkpoint_bytes(&sim, "threads-switch");
    let mut resumed = Simulation::from_checkpoint_bytes(&bytes).unwrap();
    assert_eq!(resumed.options().threads, 2);
    for _ in STOP..STEPS {
        let a = straight.step().unwrap();
        let b = resumed.step().unwrap();
        assert!(report_bits(&a) == report_bits(&b));
    }
    assert_same_state("threads-switch", "after the last step", &straight, &resumed);
}

#[test]
fn a_failed_simulation_stays_failed_after_a_checkpoint() {
    // A fixed step far above the stable one, allowed: the run blows up.
    let case = Case {
        time_step: TimeStep::Fixed { dt: 0.05 },
        ..Case::new(
            "failed",
            ShapeFunction::Linear,
            UpdateScheme::Usl,
            Transfer::Flip,
            MassScheme::Lumped,
        )
    };
    let mut sim = {
        let s = simulation(&Case {
            time_step: TimeStep::Cfl { number: 0.5 },
            ..case.clone()
        });
        let mut options = s.options().clone();
        options.time_step = case.time_step;
        options.allow_unstable_time_step = true;
        let grid = s.grid().clone();
        let particles = s.particles().clone();
        let bodies = s.bodies().to_vec();
        Simulation::new(grid, particles, bodies, options).unwrap()
    };
    let error = (0..200).find_map(|_| sim.step().err()).expect("the run blows up");
    let bytes = checkpoint_bytes(&sim, "failed");
    let mut resumed = Simulation::from_checkpoint_bytes(&bytes).unwrap();
    match resumed.step() {
        Err(MpmError::EarlierFailure { cause, .. }) => assert_eq!(cause, error.to_string()),
        other => panic!("expected the earlier failure, got {other:?}"),
    }
}

/// The bytes of a checkpoint of `sim`, written through a file.
fn checkpoint_bytes(sim: &Simulation, name: &str) -> Vec<u8> {
    let dir = scratch_dir(name);
    let path = dir.join("state.ckpt");
    sim.write_checkpoint(&path).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    bytes
}

/// A small checkpoint after a few steps (consistent mass, so that every part is filled).
fn sample_bytes(name: &'static str) -> Vec<u8> {
    let mut sim = simulation(&Case::new(
        name,
        ShapeFunction::Linear,
        UpdateScheme::Musl,
        Transfer::Flip,
        MassScheme::Iterative {
            tolerance: 1e-8,
            max_iterations: 500,
        },
    ));
    for _ in 0..3 {
        sim.step().unwrap();
    }
    checkpoint_bytes(&sim, name)
}

/// The checkpoint error's reason, checking it names `path`.
fn reason(result: Result<Simulation, MpmError>, path: Option<&Path>) -> String {
    match result {
        Err(MpmError::Checkpoint { path: p, reason }) => {
            assert_eq!(p.as_deref(), path);
            reason
        }
        Err(other) => panic!("expected a checkpoint error, got {other}"),
        Ok(_) => panic!("expected a checkpoint error, got a simulation"),
    }
}

/// The CRC-32 trailer recomputed after an edit, so that only the edit is wrong.
fn reseal(bytes: &mut [u8]) {
    let end = bytes.len() - 4;
    let crc = crc32(&bytes[..end]);
    bytes[end..].copy_from_slice(&crc.to_le_bytes());
}

/// CRC-32 (IEEE), bit by bit: an independent check of the file's checksum.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= b as u32;
        for _ in 0..8 {
            crc = if crc & 1 == 1 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

#[test]
fn the_file_has_the_documented_header_and_checksum() {
    let bytes = sample_bytes("header");
    assert!(bytes.starts_with(b"sparse-mpm checkpoint\n"));
    let version = u32::from_le_bytes(bytes[VERSION_OFFSET..VERSION_OFFSET + 4].try_into().unwrap());
    assert_eq!(version, CHECKPOINT_FORMAT_VERSION);
    let at = VERSION_OFFSET + 4;
    let len = bytes[at] as usize;
    assert_eq!(&bytes[at + 1..at + 1 + len], env!("CARGO_PKG_VERSION").as_bytes());
    let at = at + 1 + len;
    let payload = u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap()) as usize;
    assert_eq!(at + 8 + payload + 4, bytes.len());
    let end = bytes.len() - 4;
    assert_eq!(
        u32::from_le_bytes(bytes[end..].try_into().unwrap()),
        crc32(&bytes[..end])
    );
}

#[test]
fn a_changed_byte_is_a_clear_error() {
    let bytes = sample_bytes("corrupted");
    let dir = scratch_dir("corrupted-file");
    let path = dir.join("bad.ckpt");
    // One byte changed in the middle of the particle data, read through a file: the error names it.
    let mut bad = bytes.clone();
    bad[bytes.len() / 2] ^= 0x10;
    std::fs::write(&path, &bad).unwrap();
    let why = reason(Simulation::read_checkpoint(&path), Some(&path));
    assert!(why.contains("corrupted") && why.contains("checksum"), "{why}");
    let shown = Simulation::read_checkpoint(&path).err().unwrap().to_string();
    assert!(shown.contains("bad.ckpt") && shown.contains("corrupted"), "{shown}");
    std::fs::remove_dir_all(&dir).unwrap();
    // Every header byte and a spread of payload and checksum bytes: always an error.
    let header = 64;
    let positions = (0..header)
        .chain((header..bytes.len()).step_by(37))
        .chain(bytes.len() - 4..bytes.len());
    for k in positions {
        for flip in [0x01u8, 0x80, 0xff] {
            let mut bad = bytes.clone();
            bad[k] ^= flip;
            let why = reason(Simulation::from_checkpoint_bytes(&bad), None);
            assert!(!why.is_empty());
        }
    }
}

#[test]
fn a_truncated_file_is_a_clear_error() {
    let bytes = sample_bytes("truncated");
    let lengths = (0..80)
        .chain((80..bytes.len()).step_by(53))
        .chain(bytes.len() - 5..bytes.len());
    for len in lengths {
        let why = reason(Simulation::from_checkpoint_bytes(&bytes[..len]), None);
        assert!(why.contains("truncated"), "{len} bytes: {why}");
    }
    // Bytes after the end are refused too.
    let mut longer = bytes.clone();
    longer.extend_from_slice(&[0; 3]);
    let why = reason(Simulation::from_checkpoint_bytes(&longer), None);
    assert!(why.contains("after the end"), "{why}");
}

#[test]
fn another_format_version_is_refused() {
    let bytes = sample_bytes("version");
    for version in [0, CHECKPOINT_FORMAT_VERSION + 1, u32::MAX] {
        let mut other = bytes.clone();
        other[VERSION_OFFSET..VERSION_OFFSET + 4].copy_from_slice(&version.to_le_bytes());
        reseal(&mut other);
        let why = reason(Simulation::from_checkpoint_bytes(&other), None);
        assert!(
            why.contains(&format!("format version {version}"))
                && why.contains(&format!("reads version {CHECKPOINT_FORMAT_VERSION}")),
            "{why}"
        );
    }
    // Not a checkpoint at all.
    let why = reason(Simulation::from_checkpoint_bytes(b"[grid]\ncells = [4, 4]\n"), None);
    assert!(why.contains("not a sparse-mpm checkpoint"), "{why}");
}

#[test]
fn unreadable_and_unwritable_paths_are_io_errors_naming_the_file() {
    let dir = scratch_dir("paths");
    let missing = dir.join("missing.ckpt");
    match Simulation::read_checkpoint(&missing) {
        Err(MpmError::Io { path, .. }) => assert_eq!(path, missing),
        other => panic!("expected an I/O error, got {:?}", other.err()),
    }
    let sim = simulation(&Case::new(
        "paths",
        ShapeFunction::Linear,
        UpdateScheme::Usl,
        Transfer::Flip,
        MassScheme::Lumped,
    ));
    // Into a directory that does not exist.
    let nowhere = dir.join("no-such-directory").join("run.ckpt");
    match sim.write_checkpoint(&nowhere) {
        Err(MpmError::Io { path, .. }) => assert_eq!(path, nowhere),
        other => panic!("expected an I/O error, got {other:?}"),
    }
    // Over a directory: the rename fails, and the temporary file is removed.
    let occupied = dir.join("occupied");
    std::fs::create_dir(&occupied).unwrap();
    std::fs::write(occupied.join("keep"), b"x").unwrap();
    match sim.write_checkpoint(&occupied) {
        Err(MpmError::Io { path, .. }) => assert_eq!(path, occupied),
        other => panic!("expected an I/O error, got {other:?}"),
    }
    let mut names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    names.sort();
    assert_eq!(names, vec![std::ffi::OsString::from("occupied")]);
    // Over an older checkpoint: replaced whole.
    let path = dir.join("run.ckpt");
    std::fs::write(&path, b"an older file").unwrap();
    sim.write_checkpoint(&path).unwrap();
    let back = Simulation::read_checkpoint(&path).unwrap();
    assert_eq!(back.particles(), sim.particles());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// SplitMix64.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
}

#[test]
fn random_bytes_never_panic() {
    let mut rng = Rng(7);
    let bytes = sample_bytes("random");
    let header_len = bytes.len() - 4 - {
        let at = VERSION_OFFSET + 4;
        let len = bytes[at] as usize;
        let at = at + 1 + len;
        u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap()) as usize
    };
    for trial in 0..400 {
        let len = (rng.next() % 4096) as usize;
        let noise: Vec<u8> = (0..len).map(|_| rng.next() as u8).collect();
        // Plain noise, and noise behind the real format name.
        assert!(Simulation::from_checkpoint_bytes(&noise).is_err());
        let mut named = b"sparse-mpm checkpoint\n".to_vec();
        named.extend_from_slice(&noise);
        assert!(Simulation::from_checkpoint_bytes(&named).is_err());
        // Noise as the payload of a well-formed, correctly sealed file: the decoder sees it.
        let mut sealed = bytes[..header_len - 8].to_vec();
        sealed.extend_from_slice(&(len as u64).to_le_bytes());
        sealed.extend_from_slice(&noise);
        sealed.extend_from_slice(&[0; 4]);
        reseal(&mut sealed);
        assert!(Simulation::from_checkpoint_bytes(&sealed).is_err(), "trial {trial}");
        // A real payload with a few bytes changed and the file sealed again: decoded or refused,
        // and a decoded state steps or fails with an error.
        let mut edited = bytes.clone();
        for _ in 0..1 + rng.next() % 4 {
            let k = header_len + (rng.next() as usize) % (bytes.len() - header_len - 4);
            edited[k] = rng.next() as u8;
        }
        reseal(&mut edited);
        if let Ok(mut sim) = Simulation::from_checkpoint_bytes(&edited) {
            for _ in 0..2 {
                if sim.step().is_err() {
                    break;
                }
            }
        }
    }
}
