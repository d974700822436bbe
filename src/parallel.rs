//! Thread pools made for one piece of work (a render, a BVH build), never rayon's global pool:
//! a process forked after a render (`os.fork`, a `multiprocessing` fork pool) then starts its own
//! threads instead of waiting forever on a pool whose threads the fork did not copy.

use crate::error::{NlosError, Result};

/// Largest number of worker threads accepted, per core.
pub const THREADS_PER_CORE: usize = 8;

/// The cores available to this process.
pub fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// A pool of `threads` workers (`None` = one per core), checked against [`THREADS_PER_CORE`].
pub fn pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    let n = threads.unwrap_or_else(cores);
    let max = THREADS_PER_CORE * cores();
    if n == 0 || n > max {
        return Err(NlosError::prop(
            "render",
            "threads",
            format!("must be in [1, {max}] ({THREADS_PER_CORE} per core), got {n}"),
        ));
    }
    rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build()
        .map_err(|e| NlosError::Scene(format!("cannot start {n} threads: {e}")))
}

/// `f(i)` for every `i` in `0..n`, in order: spread over the threads of the pool this is called
/// from (a render's, whose per-scan-point preparation this is), or on this thread alone outside
/// one (never on rayon's global pool). The result does not depend on which.
pub fn map_indices<T: Send>(n: usize, f: impl Fn(usize) -> T + Sync + Send) -> Vec<T> {
    use rayon::prelude::*;
    if rayon::current_thread_index().is_some() {
        (0..n).into_par_iter().map(f).collect()
    } else {
        (0..n).map(f).collect()
    }
}

/// `f` on each run of `len` items of `items` (the last may be shorter): spread over the threads of
/// the pool this is called from, or on this thread alone outside one, as [`map_indices`].
pub fn for_each_run<T: Send>(items: &mut [T], len: usize, f: impl Fn(&mut [T]) + Sync + Send) {
    use rayon::prelude::*;
    if rayon::current_thread_index().is_some() {
        items.par_chunks_mut(len).for_each(f);
    } else {
        items.chunks_mut(len).for_each(f);
    }
}
