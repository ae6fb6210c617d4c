//! A hint that the walker will soon read a tet's record: the one place in
//! this crate with `unsafe` code.
//!
//! A ray's walk is a chain of dependent loads (tet → its neighbour's record
//! → that record's new vertex), and on meshes far larger than the caches
//! each link of the chain waits for memory. While one step's edge tests
//! run, the records of the three neighbours the ray may step into next are
//! requested, so the one it does step into is on its way.
//!
//! The portable twin (every other architecture) does nothing; a prefetch
//! changes no value the program computes, so images are the same either
//! way (`tests/walk.rs` compares them bit for bit).
#![allow(unsafe_code)]

/// Asks the cache hierarchy for the line holding `slice[i]`. An index out
/// of bounds (a boundary link's) asks for an address outside the slice,
/// which is harmless: the hint is dropped, nothing is read.
#[inline(always)]
pub fn prefetch<T>(slice: &[T], i: usize) {
    #[cfg(target_arch = "x86_64")]
    {
        // `wrapping_add`: defined for any index, no bounds check in the
        // walker's hottest loop.
        let p = slice.as_ptr().wrapping_add(i).cast::<i8>();
        // SAFETY: `_mm_prefetch` needs SSE, which every x86-64 CPU has (it
        // is in the x86-64 baseline the crate is built for). PREFETCHT0 is a
        // hint: it never faults, whatever the address (an unmapped or
        // non-canonical one is ignored), and it writes nothing and returns
        // nothing the program can observe, so no Rust aliasing or validity
        // rule is involved.
        unsafe { std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(p) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (slice, i);
}
