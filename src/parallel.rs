//! Opt-in threads whose results do not depend on the number of threads, to the last bit.
//!
//! Two rules make every kernel deterministic:
//!
//! - **Scatters** (particle → grid sums such as `q = N (m ∘ v)`) split the grid, not the
//!   particles: each worker owns a band of whole grid lines and walks *all* particles in order,
//!   adding only the runs of their stencils that fall in its band. Every node therefore receives
//!   its contributions in particle order, exactly as in a serial pass, whatever the bands.
//! - **Reductions** (energies, momenta, sums over nodes) add fixed blocks of
//!   [`REDUCTION_BLOCK`] items in order, then the block sums in order. The blocks do not depend
//!   on the number of threads, so neither does the sum.
//!
//! Gathers (grid → particle, such as `v_p = Nᵀ w`) and per-particle updates are independent per
//! particle and are split into blocks freely. `tests/parallel.rs` holds serial and threaded
//! runs equal bit for bit.

use crate::error::{MpmError, Result};

/// Items per block of a deterministic reduction.
pub const REDUCTION_BLOCK: usize = 4096;

/// The most worker threads a simulation starts (`Options::threads`, `execution.threads`,
/// `--threads`): more would only cost memory and start-up time on any machine this runs on.
pub const MAX_THREADS: usize = 256;

/// The worker threads of a simulation: none (serial) or a pool of its own.
#[derive(Debug, Default)]
pub struct Workers {
    pool: Option<rayon::ThreadPool>,
}

impl Workers {
    /// `threads` workers; 1 runs everything on the calling thread.
    ///
    /// # Errors
    /// [`MpmError::InvalidParameter`] for 0 threads or when the pool cannot be started.
    pub fn new(threads: usize) -> Result<Workers> {
        if threads == 0 {
            return Err(MpmError::InvalidParameter {
                name: "threads",
                value: 0.0,
                reason: "at least one thread is needed",
            });
        }
        if threads > MAX_THREADS {
            return Err(MpmError::InvalidParameter {
                name: "threads",
                value: threads as f64,
                reason: "at most MAX_THREADS (256) worker threads",
            });
        }
        if threads == 1 {
            return Ok(Workers { pool: None });
        }
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .thread_name(|i| format!("sparse-mpm-{i}"))
            .build()
            .map_err(|_| MpmError::InvalidParameter {
                name: "threads",
                value: threads as f64,
                reason: "the thread pool could not be started",
            })?;
        Ok(Workers { pool: Some(pool) })
    }

    /// Number of threads (1 when serial).
    pub fn threads(&self) -> usize {
        self.pool.as_ref().map_or(1, |p| p.current_num_threads())
    }

    /// Runs `f(t, item)` for every item of `items`, in parallel when there is a pool; `t` is
    /// the item's index.
    pub fn each<T: Send>(&self, items: &mut [T], f: impl Fn(usize, &mut T) + Sync) {
        match &self.pool {
            None => items.iter_mut().enumerate().for_each(|(t, x)| f(t, x)),
            Some(pool) => pool.scope(|s| {
                for (t, x) in items.iter_mut().enumerate() {
                    let f = &f;
                    s.spawn(move |_| f(t, x));
                }
            }),
        }
    }

    /// Runs `f(block, chunk)` over consecutive chunks of `data` of `block` items (the last may
    /// be shorter), in parallel when there is a pool.
    pub fn chunks<T: Send>(&self, data: &mut [T], block: usize, f: impl Fn(usize, &mut [T]) + Sync) {
        let block = block.max(1);
        match &self.pool {
            None => data.chunks_mut(block).enumerate().for_each(|(b, c)| f(b, c)),
            Some(pool) => {
                use rayon::prelude::*;
                pool.install(|| data.par_chunks_mut(block).enumerate().for_each(|(b, c)| f(b, c)))
            }
        }
    }

    /// Runs `f(range)` for the consecutive ranges of `0..n` of [`REDUCTION_BLOCK`] items, in
    /// parallel when there is a pool, and writes each result to `out[block]` (resized; no
    /// allocation once it has grown).
    pub fn blocks<R: Send + Default>(
        &self,
        n: usize,
        out: &mut Vec<R>,
        f: impl Fn(std::ops::Range<usize>) -> R + Sync,
    ) {
        let count = n.div_ceil(REDUCTION_BLOCK);
        out.clear();
        out.resize_with(count, R::default);
        self.chunks(out, 1, |b, slot| {
            let start = b * REDUCTION_BLOCK;
            slot[0] = f(start..(start + REDUCTION_BLOCK).min(n));
        });
    }
}

/// Several mutable per-particle arrays (or one) that can be cut at the same index, so that
/// a block of particles can go to a worker with all its outputs.
pub trait Splittable: Sized + Send {
    /// Items (particles) held.
    fn len(&self) -> usize;
    /// Whether there are no items.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// The first `mid` items and the rest.
    fn split_at(self, mid: usize) -> (Self, Self);
}

impl<T: Send> Splittable for &mut [T] {
    fn len(&self) -> usize {
        <[T]>::len(self)
    }
    fn split_at(self, mid: usize) -> (Self, Self) {
        self.split_at_mut(mid)
    }
}

/// A slice holding `stride` values per item, cut between items.
#[derive(Debug)]
pub struct Strided<'a, T>(pub &'a mut [T], pub usize);

impl<T: Send> Splittable for Strided<'_, T> {
    fn len(&self) -> usize {
        self.0.len() / self.1.max(1)
    }
    fn split_at(self, mid: usize) -> (Self, Self) {
        let (a, b) = self.0.split_at_mut(mid * self.1);
        (Strided(a, self.1), Strided(b, self.1))
    }
}

impl<A: Splittable, B: Splittable> Splittable for (A, B) {
    fn len(&self) -> usize {
        self.0.len()
    }
    fn split_at(self, mid: usize) -> (Self, Self) {
        let (a0, a1) = self.0.split_at(mid);
        let (b0, b1) = self.1.split_at(mid);
        ((a0, b0), (a1, b1))
    }
}

impl<T: Send, const K: usize> Splittable for [&mut [T]; K] {
    fn len(&self) -> usize {
        self.first().map_or(0, |s| s.len())
    }
    fn split_at(self, mid: usize) -> (Self, Self) {
        let mut left: [&mut [T]; K] = std::array::from_fn(|_| <&mut [T]>::default());
        let mut right: [&mut [T]; K] = std::array::from_fn(|_| <&mut [T]>::default());
        for (k, s) in self.into_iter().enumerate() {
            let (a, b) = s.split_at_mut(mid);
            left[k] = a;
            right[k] = b;
        }
        (left, right)
    }
}

impl Workers {
    /// Runs `f(first, part)` on consecutive parts of `data` of [`REDUCTION_BLOCK`] items (`first`
    /// the index of the part's first item), in parallel when there is a pool, and writes each
    /// result to `out[block]` (resized; no allocation once it has grown). The parts and so any
    /// sum of `out` in order do not depend on the number of threads.
    pub fn split_blocks<D: Splittable, R: Send + Default>(
        &self,
        data: D,
        out: &mut Vec<R>,
        f: impl Fn(usize, D) -> R + Sync,
    ) {
        let n = data.len();
        out.clear();
        out.resize_with(n.div_ceil(REDUCTION_BLOCK), R::default);
        fn go<D: Splittable, R: Send>(
            data: D,
            first_block: usize,
            out: &mut [R],
            f: &(impl Fn(usize, D) -> R + Sync),
            parallel: bool,
        ) {
            if out.len() <= 1 {
                if let Some(slot) = out.first_mut() {
                    *slot = f(first_block * REDUCTION_BLOCK, data);
                }
                return;
            }
            let half = out.len() / 2;
            let (a, b) = data.split_at(half * REDUCTION_BLOCK);
            let (oa, ob) = out.split_at_mut(half);
            if parallel {
                rayon::join(
                    || go(a, first_block, oa, f, true),
                    || go(b, first_block + half, ob, f, true),
                );
            } else {
                go(a, first_block, oa, f, false);
                go(b, first_block + half, ob, f, false);
            }
        }
        match &self.pool {
            None => go(data, 0, out, &f, false),
            Some(pool) => pool.install(|| go(data, 0, out, &f, true)),
        }
    }
}
