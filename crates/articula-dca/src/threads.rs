//! How many cores the parallel entry points use: [`Threads`], a thread count and the rayon
//! pool that runs it (feature `parallel`).

use thiserror::Error;

/// A thread count, and with the `parallel` feature the work-stealing pool (rayon) of that many
/// threads that [`crate::Batch`] and articula-view's scenes run on.
///
/// `Threads::new(1)` runs everything on the calling thread, with no pool. Results never depend
/// on the count: work is split into a fixed partition and reduced in a fixed order, so one
/// thread and eight give the same bits. Without the `parallel` feature every count runs on
/// the calling thread ([`Threads::count`] is then 1).
///
/// Cloning shares the pool.
#[derive(Clone, Debug)]
pub struct Threads {
    count: usize,
    #[cfg(feature = "parallel")]
    pool: Option<std::sync::Arc<rayon::ThreadPool>>,
}

/// Why a [`Threads`] could not be made.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum ThreadsError {
    /// A count of zero threads.
    #[error("a thread count must be at least 1")]
    Zero,
    /// More threads than [`Threads::max_count`]: a pool that size only competes with itself,
    /// and a runaway count would exhaust the machine's processes.
    #[error(
        "{count} threads is more than the cap of {cap} (8 per core on this machine, at least \
         64; results do not depend on the count)"
    )]
    TooMany {
        /// The count asked for.
        count: usize,
        /// [`Threads::max_count`].
        cap: usize,
    },
    /// The operating system refused to start the pool's threads.
    #[error("could not start {count} threads: {reason}")]
    Spawn {
        /// The count asked for.
        count: usize,
        /// The system's reason.
        reason: String,
    },
}

impl Threads {
    /// `count` threads (at least 1). With the `parallel` feature and `count > 1`, starts a pool
    /// of `count` threads; without it, the count is 1 whatever is asked.
    pub fn new(count: usize) -> Result<Threads, ThreadsError> {
        if count == 0 {
            return Err(ThreadsError::Zero);
        }
        let cap = Threads::max_count();
        if count > cap {
            return Err(ThreadsError::TooMany { count, cap });
        }
        #[cfg(feature = "parallel")]
        {
            if count == 1 {
                return Ok(Threads::serial());
            }
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(count)
                .thread_name(|i| format!("articula-{i}"))
                .build()
                .map_err(|e| ThreadsError::Spawn {
                    count,
                    reason: e.to_string(),
                })?;
            Ok(Threads {
                count,
                pool: Some(std::sync::Arc::new(pool)),
            })
        }
        #[cfg(not(feature = "parallel"))]
        Ok(Threads::serial())
    }

    /// The largest count [`Threads::new`] accepts: 8 per core
    /// (`std::thread::available_parallelism`), and at least 64.
    pub fn max_count() -> usize {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        cores.saturating_mul(8).max(64)
    }

    /// One thread: the calling one.
    pub fn serial() -> Threads {
        Threads {
            count: 1,
            #[cfg(feature = "parallel")]
            pool: None,
        }
    }

    /// One thread per core (`std::thread::available_parallelism`; 1 when unknown, or without
    /// the `parallel` feature). The pool is started once per process and shared by every
    /// `Threads::all()` and [`Threads::default`] (like rayon's global pool), so a workspace
    /// per character can hold one at no cost; [`Threads::new`] starts a pool of its own.
    pub fn all() -> Result<Threads, ThreadsError> {
        static ALL: std::sync::OnceLock<Result<Threads, ThreadsError>> = std::sync::OnceLock::new();
        ALL.get_or_init(|| {
            Threads::new(std::thread::available_parallelism().map_or(1, |n| n.get()))
        })
        .clone()
    }

    /// The number of threads work is spread over.
    pub fn count(&self) -> usize {
        self.count
    }

    /// Runs `f` inside the pool (so that rayon's parallel iterators and `join` in `f` use its
    /// threads), or on the calling thread for a serial count.
    pub fn install<R: Send>(&self, f: impl FnOnce() -> R + Send) -> R {
        #[cfg(feature = "parallel")]
        if let Some(pool) = &self.pool {
            return pool.install(f);
        }
        f()
    }

    /// `f(i, item)` for each item of `items`, the items split into [`Threads::count`]
    /// contiguous runs of near-equal length, one run per thread. The partition depends only on
    /// `items.len()` and the count, and each call sees only its own item, so results are the
    /// same for any count.
    pub fn for_each_mut<T: Send>(&self, items: &mut [T], f: impl Fn(usize, &mut T) + Sync) {
        #[cfg(feature = "parallel")]
        if self.pool.is_some() && items.len() > 1 {
            use rayon::prelude::*;
            let run = items.len().div_ceil(self.count);
            let f = &f;
            self.install(|| {
                items
                    .par_chunks_mut(run)
                    .enumerate()
                    .for_each(|(c, chunk)| {
                        for (j, item) in chunk.iter_mut().enumerate() {
                            f(c * run + j, item);
                        }
                    })
            });
            return;
        }
        for (i, item) in items.iter_mut().enumerate() {
            f(i, item);
        }
    }

    /// `f(worker, first, run)` for contiguous runs of `items`, one per worker state of
    /// `workers` (at most [`Threads::count`] runs, `⌈len / runs⌉` items each; `first` is the
    /// index of the run's first item). For work that needs a scratch of its own per thread:
    /// each run has its own worker, and with one thread (or one item) `workers[0]` takes every
    /// item in one call. The partition depends only on `items.len()`, the count and
    /// `workers.len()`; what a run computes must not depend on its worker's scratch contents
    /// for the result to be the same for any count. Panics when `workers` is empty.
    pub fn for_each_run<T: Send, W: Send>(
        &self,
        items: &mut [T],
        workers: &mut [W],
        f: impl Fn(&mut W, usize, &mut [T]) + Sync,
    ) {
        assert!(!workers.is_empty(), "for_each_run needs a worker");
        #[cfg(feature = "parallel")]
        {
            let runs = self.count.min(workers.len());
            if self.pool.is_some() && runs > 1 && items.len() > 1 {
                use rayon::prelude::*;
                let run = items.len().div_ceil(runs);
                let f = &f;
                self.install(|| {
                    workers[..runs]
                        .par_iter_mut()
                        .zip(items.par_chunks_mut(run))
                        .enumerate()
                        .for_each(|(c, (w, chunk))| f(w, c * run, chunk))
                });
                return;
            }
        }
        f(&mut workers[0], 0, items);
    }

    /// `f(worker, first, chunk)` for the chunks of `chunk` items of `items` (the last one
    /// shorter; `first` is the index of a chunk's first item), handed to the threads as they
    /// come free: a thread that finishes its chunks early takes others (rayon's work
    /// stealing), so runs of unequal cost — characters near the camera with many joints, far
    /// ones with none — and a thread that the system deschedules for a while do not leave
    /// the other threads idle. Each call holds a worker state of `workers` that no other
    /// running call holds (the one of its thread when free); with one thread (or one item)
    /// `workers[0]` takes every item in one call.
    ///
    /// Which worker and which thread get a chunk depends on timing: what a call computes must
    /// depend only on its items, not on its worker's scratch contents or on the other chunks,
    /// for the result to be the same for any count. `f` must not wait for work on this pool
    /// (a nested `join` could hand its thread a second chunk while it holds a worker).
    /// Panics when `workers` is empty or `chunk` is 0.
    pub fn for_each_chunk<T: Send, W: Send>(
        &self,
        items: &mut [T],
        workers: &[std::sync::Mutex<W>],
        chunk: usize,
        f: impl Fn(&mut W, usize, &mut [T]) + Sync,
    ) {
        assert!(!workers.is_empty(), "for_each_chunk needs a worker");
        assert!(
            chunk > 0,
            "for_each_chunk needs chunks of at least one item"
        );
        #[cfg(feature = "parallel")]
        if self.pool.is_some() && workers.len() > 1 && items.len() > chunk {
            use rayon::prelude::*;
            let f = &f;
            self.install(|| {
                items
                    .par_chunks_mut(chunk)
                    .with_max_len(1)
                    .enumerate()
                    .for_each(|(c, run)| f(&mut acquire(workers), c * chunk, run))
            });
            return;
        }
        f(&mut acquire(workers), 0, items);
    }
}

/// A worker state no other running call holds: its own thread's first (the pool's threads are
/// numbered from 0), else the first free one, waiting while every one is held (a thread
/// preempted inside its chunk).
fn acquire<W>(workers: &[std::sync::Mutex<W>]) -> std::sync::MutexGuard<'_, W> {
    use std::sync::TryLockError;
    #[cfg(feature = "parallel")]
    let start = rayon::current_thread_index().unwrap_or(0);
    #[cfg(not(feature = "parallel"))]
    let start = 0;
    loop {
        for k in 0..workers.len() {
            match workers[(start + k) % workers.len()].try_lock() {
                Ok(g) => return g,
                // A call that panicked left it: the panic reaches the caller anyway.
                Err(TryLockError::Poisoned(p)) => return p.into_inner(),
                Err(TryLockError::WouldBlock) => {}
            }
        }
        std::thread::yield_now();
    }
}

impl Default for Threads {
    /// [`Threads::all`], or one thread when the pool cannot start.
    fn default() -> Threads {
        Threads::all().unwrap_or_else(|_| Threads::serial())
    }
}
