//! [`Lanes`]: the arrays the vectorized passes stream through, placed for the vectors.
//!
//! A plain `Vec<f32>` starts wherever the allocator puts it: 16 bytes past a cache line,
//! typically.  Every 64-byte vector load or store of a pass then touches two cache lines.
//! And a pass's arrays, allocated one after another with the same length, lie at nearly
//! the same address modulo 4 KiB (a few 16-byte headers apart), so a load from one often
//! looks, to the CPU's store forwarding, like a load from a store just made to another
//! ("4K aliasing"), and waits.  A `Lanes` starts on a cache line, and consecutive ones
//! are staggered by 5 lines modulo 4 KiB (12 arrays before the pattern repeats).
//!
//! Measured (J4, one core): 109 → 103 ms.  That is the alignment: page-aligned
//! arrays, all at the same offset, ran as fast; the stagger is a precaution that costs
//! nothing.
//!
//! ```text
//!  4 KiB page offset:  0        320       640       960  …  3520
//!                      |array 0  |array 1  |array 2  |  …  |array 11   (then 0 again)
//! ```

use std::ops::{Deref, DerefMut};
use std::sync::atomic::{AtomicUsize, Ordering};

/// A fixed-length array that derefs to a slice, its first element on a 64-byte boundary
/// at a staggered offset modulo 4 KiB (see the module's comment).
pub(crate) struct Lanes<T> {
    /// The first element (inside `buf`), and the length: what a slice of them is, kept
    /// ready so that a deref is two loads, as a `Vec`'s (an offset added on every deref
    /// kept the compiler from hoisting it out of loops: measured 10 % on a gather loop).
    ptr: *mut T,
    len: usize,
    /// The allocation (never touched again: `ptr` points into its heap buffer, which stays
    /// where it is while the Vec lives and is not grown).
    _buf: Vec<T>,
}

// SAFETY: a `Lanes` owns its elements as a Vec does (`ptr` points into its own `_buf`).
unsafe impl<T: Send> Send for Lanes<T> {}
// SAFETY: shared access only reads through `ptr`, as through a `&Vec`.
unsafe impl<T: Sync> Sync for Lanes<T> {}

/// Bytes between consecutive arrays' offsets modulo 4 KiB (a multiple of the 64-byte line).
const STAGGER: usize = 320;
/// How many staggered offsets fit a 4 KiB page.
const SLOTS: usize = 4096 / STAGGER;

impl<T: Copy + Default> Lanes<T> {
    /// `len` copies of `v`, at the next slot.
    pub(crate) fn new(len: usize, v: T) -> Self {
        static NEXT: AtomicUsize = AtomicUsize::new(0);
        Lanes::placed(len, v, NEXT.fetch_add(1, Ordering::Relaxed) % SLOTS)
    }

    /// `len` copies of `v`, the first at `slot` · STAGGER bytes modulo 4 KiB.
    fn placed(len: usize, v: T, slot: usize) -> Self {
        // Offsets in whole elements (below) need T's size to divide the 64-byte line.
        const { assert!(std::mem::size_of::<T>() > 0 && 64 % std::mem::size_of::<T>() == 0) };
        let size = std::mem::size_of::<T>();
        // Room to move the start anywhere within a page, in whole elements.
        let room = 4096 / size + 1;
        let buf = vec![v; len + room];
        let addr = buf.as_ptr() as usize;
        let want = slot * STAGGER;
        // Whole elements: T's size divides 64, and the allocation is aligned to T (for the
        // types used here, alignment = size), so `want − addr` is a multiple of it.
        let off = ((want + 4096 - addr % 4096) % 4096) / size;
        assert!(off + len <= buf.len());
        let mut buf = buf;
        // SAFETY: `off ≤ buf.len()` (just checked).
        let ptr = unsafe { buf.as_mut_ptr().add(off) };
        Lanes {
            ptr,
            len,
            _buf: buf,
        }
    }

    /// A copy of `v`.
    pub(crate) fn from_slice(v: &[T]) -> Self {
        let mut l = Lanes::new(v.len(), T::default());
        l.copy_from_slice(v);
        l
    }
}

impl<T> Deref for Lanes<T> {
    type Target = [T];
    #[inline(always)]
    fn deref(&self) -> &[T] {
        // SAFETY: `ptr..ptr + len` lies in `_buf` (by construction), initialized.
        unsafe { std::slice::from_raw_parts(self.ptr, self.len) }
    }
}

impl<T> DerefMut for Lanes<T> {
    #[inline(always)]
    fn deref_mut(&mut self) -> &mut [T] {
        // SAFETY: as in `deref`; `&mut self` makes the access unique.
        unsafe { std::slice::from_raw_parts_mut(self.ptr, self.len) }
    }
}

impl<T: Copy + Default> Clone for Lanes<T> {
    fn clone(&self) -> Self {
        // A fresh placement (a clone of the Vec would keep the offset, not the alignment).
        Lanes::from_slice(self)
    }
}

impl<T: std::fmt::Debug> std::fmt::Debug for Lanes<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.deref().fmt(f)
    }
}

impl<T: PartialEq> PartialEq for Lanes<T> {
    fn eq(&self, other: &Self) -> bool {
        self.deref() == other.deref()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lanes_start_on_a_cache_line_at_staggered_page_offsets() {
        for slot in 0..SLOTS {
            for len in [0, 1, 1000, 4096] {
                let a = Lanes::placed(len, 1.5f32, slot);
                let addr = a.as_ptr() as usize;
                assert_eq!(addr % 4096, slot * STAGGER, "slot {slot}, len {len}");
                assert_eq!(a.len(), len);
                assert!(a.iter().all(|&v| v == 1.5));
                let b = Lanes::placed(len, 7u32, slot);
                assert_eq!(b.as_ptr() as usize % 4096, slot * STAGGER);
            }
        }
        let b = Lanes::new(7, true);
        let c = b.clone();
        assert_eq!(b, c);
        assert_eq!(c.as_ptr() as usize % 64, 0);
        let d = Lanes::from_slice(&[3u32, 4, 5]);
        assert_eq!(&d[..], &[3, 4, 5]);
        assert_eq!(d.as_ptr() as usize % 64, 0);
    }
}
