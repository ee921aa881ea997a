//! The timing harness shared by the benchmarks: one warm-up call sets how many samples (and
//! calls per sample) a kernel gets; results are the median and minimum per call.
#![allow(dead_code)]

use std::hint::black_box;
use std::time::{Duration, Instant};

/// Timed samples for a call that takes under 0.25 s.
pub const MAX_SAMPLES: usize = 11;
/// A sample lasts at least this long (short calls are repeated within one sample), so the 11
/// samples of a fast kernel span about a quarter of a second and a short burst of load from other
/// processes on the host shifts only a few of them.
pub const MIN_SAMPLE: Duration = Duration::from_millis(20);

/// Median and minimum time per call, in milliseconds.
#[derive(Debug, Clone, Copy)]
pub struct Stats {
    pub median_ms: f64,
    pub min_ms: f64,
    pub samples: usize,
    pub calls_per_sample: usize,
}

/// How many samples, and calls per sample, a kernel gets.
#[derive(Debug, Clone, Copy)]
pub struct Plan {
    pub samples: usize,
    pub calls: usize,
}

/// One timed call of `f`; the value it returns is passed through `black_box` and dropped outside
/// the timed region.
pub fn timed_call<R>(f: &mut impl FnMut() -> R) -> Duration {
    let start = Instant::now();
    let r = f();
    let elapsed = start.elapsed();
    black_box(&r);
    drop(r);
    elapsed
}

/// One warm-up call; its duration sets the plan.
pub fn warm_up<R>(f: &mut impl FnMut() -> R) -> Plan {
    let first = timed_call(f);
    let samples = if first > Duration::from_secs(1) {
        3
    } else if first > Duration::from_millis(250) {
        5
    } else {
        MAX_SAMPLES
    };
    let calls = if first >= MIN_SAMPLE {
        1
    } else {
        let per_call = first.as_secs_f64().max(1e-7);
        ((MIN_SAMPLE.as_secs_f64() / per_call).ceil() as usize).clamp(1, 100_000)
    };
    Plan { samples, calls }
}

/// Time per call in ms, averaged over `calls` calls.
pub fn sample<R>(f: &mut impl FnMut() -> R, calls: usize) -> f64 {
    let total: Duration = (0..calls).map(|_| timed_call(f)).sum();
    total.as_secs_f64() * 1e3 / calls as f64
}

pub fn summarize(mut times: Vec<f64>, calls: usize) -> Stats {
    times.sort_by(f64::total_cmp);
    Stats {
        median_ms: times[times.len() / 2],
        min_ms: times[0],
        samples: times.len(),
        calls_per_sample: calls,
    }
}

/// Empty cells around the block of particles on each side, so the grid has inactive nodes.
pub const MARGIN: usize = 2;

/// A square block of about `target_particles` particles, 2 × 2 per unit cell at the quarter
/// points, in cell-sorted order, with `MARGIN` empty cells around it: the grid and positions.
pub fn block(target_particles: usize) -> (sparse_mpm::Grid, Vec<f64>, Vec<f64>) {
    let nc = (((target_particles as f64) / 4.0).sqrt().round() as usize).max(1);
    let cells = nc + 2 * MARGIN;
    let grid = sparse_mpm::Grid::new([0.0, 0.0], [1.0, 1.0], [cells, cells]).expect("valid grid");
    let np = 4 * nc * nc;
    let (mut x, mut y) = (Vec::with_capacity(np), Vec::with_capacity(np));
    for cj in 0..nc {
        for ci in 0..nc {
            for b in [0.25, 0.75] {
                for a in [0.25, 0.75] {
                    x.push((MARGIN + ci) as f64 + a);
                    y.push((MARGIN + cj) as f64 + b);
                }
            }
        }
    }
    (grid, x, y)
}

/// The benchmarks' command line: `--quick` and `--sizes a,b` (particle counts such as `1e5`).
/// `cargo bench` also passes `--bench`, which is ignored.
pub struct Args {
    /// `--quick` was given.
    pub quick: bool,
    /// The sizes of `--sizes`, if given.
    pub sizes: Option<Vec<usize>>,
}

impl Args {
    /// The sizes asked for with `--sizes`, else `quick` with `--quick`, else `full`.
    pub fn sizes_or(&self, quick: &[usize], full: &[usize]) -> Vec<usize> {
        match &self.sizes {
            Some(sizes) => sizes.clone(),
            None if self.quick => quick.to_vec(),
            None => full.to_vec(),
        }
    }
}

/// Reads the command line; particle counts below `min_count` are refused.
pub fn args(min_count: usize) -> Args {
    let mut out = Args {
        quick: false,
        sizes: None,
    };
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "--quick" => out.quick = true,
            "--sizes" => {
                let list = args.next().unwrap_or_default();
                out.sizes = Some(
                    list.split(',')
                        .map(|s| {
                            let v: Option<f64> = s.trim().parse().ok();
                            v.filter(|v| v.is_finite() && *v >= min_count as f64)
                                .map(|v| v.round() as usize)
                                .unwrap_or_else(|| {
                                    panic!("--sizes: cannot read {s:?} as a particle count >= {min_count}")
                                })
                        })
                        .collect(),
                );
            }
            "--bench" => {}
            other => eprintln!("ignoring unknown argument {other:?} (known: --quick, --sizes 1e5,1e6)"),
        }
    }
    out
}

/// Milliseconds with three significant digits or so (`123`, `12.3`, `1.23`, `0.123`).
pub fn fmt_ms(ms: f64) -> String {
    if ms >= 100.0 {
        format!("{ms:.0}")
    } else if ms >= 10.0 {
        format!("{ms:.1}")
    } else if ms >= 1.0 {
        format!("{ms:.2}")
    } else {
        format!("{ms:.3}")
    }
}
