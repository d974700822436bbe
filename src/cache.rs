//! Hints to the CPU's data caches: memory the next steps will read or write, asked for ahead
//! of them so that the wait for it overlaps other work.

/// Ask for the `bytes` bytes from `p` on in the first-level data cache, a 64-byte line at a
/// time: a hint, which never faults and reads nothing the program sees, whatever the address.
/// Only on x86-64 (elsewhere nothing is done: the loads come when the data is used).
#[inline(always)]
pub fn prefetch<T>(p: *const T, bytes: usize) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        let p: *const i8 = p.cast();
        for line in (0..bytes).step_by(64) {
            // SAFETY: SSE is part of x86-64, and a prefetch is a hint (above).
            unsafe { _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(line)) };
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (p, bytes);
}
