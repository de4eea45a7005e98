//! Large buffers mapped before they are written.
//!
//! A buffer of tens of megabytes (a film's sums, its finished image, the
//! error estimate's per-pixel values) is fresh memory from the kernel, and
//! writing it takes a page fault for every 4 KiB page. `MADV_POPULATE_WRITE`
//! (Linux 5.14) maps them all in one call: on 64 MB, 18–26 ms against
//! 27–34 ms for faulting them in by writing.

/// `n` copies of `zero` (a value whose bits are all zero, which the
/// allocator's fresh pages already hold), their pages mapped writable in
/// one call where the kernel can: a buffer about to be written whole.
pub(crate) fn mapped<T: Copy>(zero: T, n: usize) -> Vec<T> {
    let mut v = vec![zero; n];
    populate(&mut v);
    v
}

/// Maps the whole pages of `v` writable at once, leaving what they hold
/// as it is; whether the kernel did. Worth it for a large buffer just
/// allocated (zeroed pages not yet touched), which is about to be written.
#[cfg(target_os = "linux")]
pub(crate) fn populate<T: Copy>(v: &mut [T]) -> bool {
    const MADV_POPULATE_WRITE: libc::c_int = 23;
    const PAGE: usize = 4096;
    let (start, len) = (v.as_mut_ptr() as usize, std::mem::size_of_val(v));
    let (first, end) = (start.next_multiple_of(PAGE), (start + len) / PAGE * PAGE);
    if end <= first {
        return false;
    }
    // SAFETY: the range is whole pages inside `v`, which this function
    // borrows mutably; populating writes nothing the program can see (each
    // page reads as it did before).
    unsafe { libc::madvise(first as *mut libc::c_void, end - first, MADV_POPULATE_WRITE) == 0 }
}

#[cfg(not(target_os = "linux"))]
pub(crate) fn populate<T: Copy>(_: &mut [T]) -> bool {
    false
}
