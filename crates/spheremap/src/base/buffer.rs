//! Large result buffers.
//!
//! A fresh buffer's first touch costs the kernel a page fault per 4 KiB page, each clearing its
//! page: some 2 ms for the 12 MB of a 1024² RGB float image, as much as the conversion itself.
//! On Linux a buffer of 4 MiB or more asks for transparent huge pages (`MADV_HUGEPAGE`: one
//! fault per 2 MiB), which systems grant on request in their default `madvise` mode; elsewhere,
//! or where the system declines, the buffer is an ordinary one.

/// Buffers from this size (bytes) on ask for huge pages.
const HUGE_FROM: usize = 4 << 20;

/// An empty vector with room for `n` values, not yet touched.
pub fn with_capacity<T>(n: usize) -> Vec<T> {
    let v: Vec<T> = Vec::with_capacity(n);
    advise(&v);
    v
}

#[cfg(target_os = "linux")]
fn advise<T>(v: &Vec<T>) {
    const PAGE: usize = 4096;
    let bytes = v.capacity() * std::mem::size_of::<T>();
    if bytes < HUGE_FROM {
        return;
    }
    // The whole pages inside the allocation (madvise takes a page-aligned start).
    let start = v.as_ptr() as usize;
    let first = start.next_multiple_of(PAGE);
    let end = (start + bytes) / PAGE * PAGE;
    if end > first {
        // SAFETY: the range lies inside this vector's allocation, and MADV_HUGEPAGE changes
        // how its pages are backed, never their contents.  A refusal (the kernel without
        // transparent huge pages) leaves ordinary pages, so the result is ignored.
        unsafe {
            libc::madvise(first as *mut libc::c_void, end - first, libc::MADV_HUGEPAGE);
        }
    }
}

#[cfg(not(target_os = "linux"))]
fn advise<T>(_: &Vec<T>) {
    let _ = HUGE_FROM;
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_large_buffer_holds_what_is_written() {
        for n in [0usize, 10, 3 << 20] {
            let mut v: Vec<f32> = super::with_capacity(n);
            assert!(v.capacity() >= n && v.is_empty());
            v.extend((0..n).map(|i| i as f32));
            assert!(v.iter().enumerate().all(|(i, x)| *x == i as f32));
        }
    }
}
