//! Film memory: the zeroed bins a render adds its contributions to, and one film its caller has
//! let go of, kept for the next render.
//!
//! A large film costs a render time to map before any path is traced: 6.9 % of a one-thread
//! render of tal's bunny (128×128×750, 49 MB) went to the kernel clearing its new pages, and
//! releasing them took more. A transient its caller no longer holds (the Python binding hands it
//! back when its NumPy array is freed) is kept, one at a time and up to [`KEEP_BYTES`], and the
//! next render whose film fits writes zeros over it instead, as Dr.Jit's allocation cache keeps
//! freed memory for mitransient's next render.

use crate::parallel::for_each_run;
use std::ptr::null_mut;
use std::sync::atomic::{AtomicPtr, Ordering};

/// Largest film kept (256 MiB): memory the process holds after every array is freed.
const KEEP_BYTES: usize = 256 << 20;
/// Smallest film kept, and taken (2 MiB, a huge page): a smaller one maps quickly, and the
/// small buffers of a render's chunks leave the kept film alone.
const KEEP_MIN: usize = 2 << 20;

/// The kept film, or null: swapped in and out whole, with no lock that a process forked during a
/// render could find held.
static KEPT: AtomicPtr<Vec<f32>> = AtomicPtr::new(null_mut());

/// Keep `bins`, a film no longer used, for the next render (in place of any kept before); one
/// outside [`KEEP_MIN`]..=[`KEEP_BYTES`] is freed.
pub fn keep(bins: Vec<f32>) {
    let bytes = size_of::<f32>() * bins.capacity();
    if (KEEP_MIN..=KEEP_BYTES).contains(&bytes) {
        free(KEPT.swap(Box::into_raw(Box::new(bins)), Ordering::AcqRel));
    }
}

/// The kept film, taken, if it holds from `n` to `2n` bins (one that does not is freed).
fn kept(n: usize) -> Option<Vec<f32>> {
    let p = KEPT.swap(null_mut(), Ordering::AcqRel);
    if p.is_null() {
        return None;
    }
    // SAFETY: a pointer in `KEPT` comes from `Box::into_raw` in `keep`, and each is swapped out
    // exactly once.
    let bins = *unsafe { Box::from_raw(p) };
    (n..=2 * n).contains(&bins.len()).then_some(bins)
}

/// Free a film swapped out of [`KEPT`] (null: none).
fn free(p: *mut Vec<f32>) {
    if !p.is_null() {
        // SAFETY: as in `kept`.
        drop(unsafe { Box::from_raw(p) });
    }
}

/// `n` zero bins for transient sums: the kept film if it fits ([`keep`]), zeros written over it;
/// otherwise new memory, each of its pages written once before the render adds to them. A fresh
/// allocation's pages are mapped at first access; where that access is a
/// read (a bin's `+=`), the kernel maps its shared zero page and, at the write that follows,
/// replaces it and flushes the old mapping from every core the process runs on: an interrupt to
/// the other cores for each 4 KiB page. On a two-core VM a 1-spp render of a 128×128×750 film
/// took 100 ms on two threads against 49 ms on one (32 ms on two with this). A first write maps
/// each page once, with no flush. (The stores are opaque to the optimiser, which would otherwise
/// drop them as zeros written over zeros.) Inside a render's thread pool the pages are written by
/// its threads, runs of 64 in parallel: the faults are most of a large film's fixed cost, and two
/// threads take them 1.5x faster than one (tal's 16×16 × 16×16 exhaustive plane, a 196 MB film:
/// a 1-spp render 1.35x faster on two threads, a 256-spp one 1.14x). Elsewhere (parts put
/// together) on the calling thread alone: never on rayon's global pool, which a forked child
/// would wait on forever (`parallel.rs`).
pub fn zero_bins(n: usize) -> Vec<f32> {
    const PAGE: usize = 4096 / std::mem::size_of::<f32>();
    if size_of::<f32>() * n >= KEEP_MIN
        && let Some(mut bins) = kept(n)
    {
        // Pages mapped already: zeros written over the last render's values.
        bins.truncate(n);
        for_each_run(&mut bins, 64 * PAGE, |run| run.fill(0.0));
        return bins;
    }
    let touch = |run: &mut [f32]| {
        for i in (0..run.len()).step_by(PAGE).chain(run.len().checked_sub(1)) {
            run[i] = std::hint::black_box(0.0);
        }
    };
    let mut bins = vec![0.0f32; n];
    huge_pages(&mut bins);
    for_each_run(&mut bins, 64 * PAGE, touch);
    bins
}

/// Ask Linux to back `bins` with 2 MiB pages where it can (transparent huge pages, in the
/// `madvise` mode most distributions set): a 128×128×750 film of 49 MB then takes about 25 page
/// faults instead of 12,000, and is released as quickly. A hint only, whose failure changes
/// nothing; elsewhere nothing is done.
fn huge_pages(bins: &mut [f32]) {
    #[cfg(target_os = "linux")]
    {
        const PAGE: usize = 4096;
        let start = bins.as_mut_ptr() as usize;
        let (first, end) = (
            start.next_multiple_of(PAGE),
            (start + size_of_val(bins)) / PAGE * PAGE,
        );
        if end >= first + (2 << 20) {
            // SAFETY: [first, end) is whole pages within `bins`' allocation; MADV_HUGEPAGE
            // changes how the kernel backs them, never what they hold.
            unsafe { libc::madvise(first as *mut libc::c_void, end - first, libc::MADV_HUGEPAGE) };
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = bins;
}
