//! After the first step, a step with lumped mass allocates nothing (the estimate of the stable
//! step every `Options::stability_interval` steps does; the ten counted steps hold none). This
//! file holds a single test so that the counting allocator sees no other test's allocations,
//! and the allocator counts only on the test's own thread (the test harness allocates on its
//! own threads, e.g. to report a test running over 60 seconds on a loaded machine; the
//! simulation runs on one thread here, `Options::threads` = 1).

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicUsize, Ordering};

use sparse_mpm::boundary::{BoundaryCondition, Condition, Edge};
use sparse_mpm::material::{Material, NeoHookean};
use sparse_mpm::simulation::{Body, Options, Simulation, TimeStep, Transfer, UpdateScheme};
use sparse_mpm::{Grid, Particles, ShapeFunction};

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

thread_local! {
    /// Whether this thread's allocations are counted (const-initialised: no allocation).
    static COUNTED: Cell<bool> = const { Cell::new(false) };
}

fn count() {
    if COUNTED.try_with(Cell::get).unwrap_or(false) {
        ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
    }
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn steps_after_the_first_allocate_nothing_with_lumped_mass() {
    COUNTED.with(|c| c.set(true));
    let shapes = [
        ShapeFunction::Linear,
        ShapeFunction::Gimp { half_width: 0.25 },
        ShapeFunction::QuadraticBSpline,
        ShapeFunction::CubicBSpline,
    ];
    for shape in shapes {
        for update in [UpdateScheme::Usf, UpdateScheme::Usl, UpdateScheme::Musl] {
            for transfer in [
                Transfer::Pic,
                Transfer::Flip,
                Transfer::Blend { flip: 0.9 },
                Transfer::Apic,
            ] {
                let grid = Grid::new([0.0, 0.0], [0.1, 0.1], [16, 16]).unwrap();
                let (mut x, mut y) = (Vec::new(), Vec::new());
                for j in 8..20 {
                    for i in 8..24 {
                        x.push((i as f64 + 0.5) * 0.05);
                        y.push((j as f64 + 0.5) * 0.05);
                    }
                }
                let n = x.len();
                let particles = Particles::new(x, y, vec![0.25; n], vec![0.0025; n])
                    .unwrap()
                    .with_velocity(vec![0.3; n], vec![-0.2; n])
                    .unwrap();
                let options = Options {
                    shape,
                    update,
                    transfer,
                    gravity: [0.0, -9.81],
                    boundaries: vec![BoundaryCondition::edge(Edge::Bottom, Condition::Slip)],
                    time_step: TimeStep::Cfl { number: 0.5 },
                    sort_interval: 3,
                    ..Options::default()
                };
                let bodies = vec![Body {
                    name: "block".into(),
                    material: Material::NeoHookean(NeoHookean {
                        youngs_modulus: 1.0e4,
                        poisson_ratio: 0.3,
                    }),
                }];
                let mut sim = Simulation::new(grid, particles, bodies, options).unwrap();
                let start = ALLOCATIONS.load(Ordering::SeqCst);
                sim.step().unwrap();
                let before = ALLOCATIONS.load(Ordering::SeqCst);
                // The counter works: the first step sizes its work arrays.
                assert!(before > start, "the first step should allocate its work arrays");
                for _ in 0..10 {
                    sim.step().unwrap();
                }
                let during = ALLOCATIONS.load(Ordering::SeqCst) - before;
                assert_eq!(
                    during, 0,
                    "{shape:?} {update:?} {transfer:?}: {during} allocations in 10 steps"
                );
            }
        }
    }
}
