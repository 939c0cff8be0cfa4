//! **`PageVec<T>`**: a growable array of plain (`Copy`) blocks whose large buffers grow by
//! remapping pages instead of copying.
//!
//! Why: the octree keeps its nodes in arenas, arrays of 64-byte blocks aligned to cache lines.
//! A `Vec` of such blocks grows by allocating a buffer twice as large, copying, then freeing
//! the old one, because the system allocator cannot `realloc` in place for alignments above
//! 16 bytes. At that moment the process holds the arena twice: for a map of a few hundred
//! megabytes the copy, not the map, sets the peak resident memory. On Linux a `PageVec` whose
//! buffer passed [`MAPPED_FROM`] bytes lives in its own anonymous mapping, which `mremap` grows
//! by moving page-table entries: no byte is copied and the old pages are never held twice.
//! Pages past the length are not touched, so they cost address space, not memory.
//!
//! Small buffers stay in an ordinary `Vec` (many small trees must not each take a mapping of
//! their own: the kernel limits their number); elsewhere than on Linux it is always a `Vec`.
//! Either way a `PageVec` dereferences to a slice, so indexing and iteration are a slice's.
//!
//! ```
//! use octoquant_pages::PageVec;
//!
//! let mut v = PageVec::new();
//! for i in 0..100_000u64 {
//!     v.push(i);
//! }
//! assert_eq!(v.len(), 100_000);
//! assert_eq!(v[99_999], 99_999);
//! assert_eq!(v.iter().sum::<u64>(), 99_999 * 100_000 / 2);
//! ```
#![deny(missing_docs)]

use std::alloc::Layout;
use std::ops::{Deref, DerefMut};
use std::ptr::NonNull;

/// Buffers of at least this many bytes move into a mapping of their own (Linux).
pub const MAPPED_FROM: usize = 1 << 20;

/// A growable array of `Copy` blocks; see the crate docs.
///
/// Invariants: `ptr` points to a buffer of `cap` elements (dangling when `cap == 0`): from the
/// global allocator with `Layout::array::<T>(cap)` when `!mapped`, else the start of an
/// anonymous mapping of the whole pages that hold `cap` elements; the first `len <= cap` elements
/// are initialised. `T` is not zero-sized (checked on first growth).
pub struct PageVec<T: Copy> {
    ptr: NonNull<T>,
    len: usize,
    cap: usize,
    mapped: bool,
}

// SAFETY: a `PageVec<T>` owns its buffer exclusively, as a `Vec<T>` does.
unsafe impl<T: Copy + Send> Send for PageVec<T> {}
// SAFETY: shared access only reads, as for `Vec<T>`.
unsafe impl<T: Copy + Sync> Sync for PageVec<T> {}

impl<T: Copy> Default for PageVec<T> {
    fn default() -> Self {
        Self::new()
    }
}

fn capacity_overflow() -> ! {
    panic!("capacity overflow")
}

impl<T: Copy> PageVec<T> {
    /// An empty array (no allocation).
    pub const fn new() -> Self {
        PageVec {
            ptr: NonNull::dangling(),
            len: 0,
            cap: 0,
            mapped: false,
        }
    }

    /// Append `value`.
    #[inline]
    pub fn push(&mut self, value: T) {
        if self.len == self.cap {
            self.grow(1);
        }
        // SAFETY: `len < cap` now, so the slot lies inside the buffer.
        unsafe { self.ptr.as_ptr().add(self.len).write(value) };
        self.len += 1;
    }

    /// Remove every element (the buffer is kept).
    pub fn clear(&mut self) {
        self.len = 0;
    }

    /// Make room for at least `additional` more elements, with no spare beyond that (as
    /// `Vec::reserve_exact`, but a mapped buffer still grows by whole pages).
    pub fn reserve_exact(&mut self, additional: usize) {
        if self.cap - self.len < additional {
            let cap = self
                .len
                .checked_add(additional)
                .unwrap_or_else(|| capacity_overflow());
            self.grow_to(cap);
        }
    }

    /// Elements the buffer holds without growing.
    pub fn capacity(&self) -> usize {
        self.cap
    }

    /// `true` when the buffer lives in a mapping of its own (always `false` off Linux).
    pub fn is_mapped(&self) -> bool {
        self.mapped
    }

    /// Grow for `additional` more elements, at least doubling (amortised O(1) pushes).
    #[cold]
    fn grow(&mut self, additional: usize) {
        let need = self
            .len
            .checked_add(additional)
            .unwrap_or_else(|| capacity_overflow());
        self.grow_to(need.max(self.cap.saturating_mul(2)).max(4));
    }

    /// Grow the buffer to hold at least `cap` elements.
    fn grow_to(&mut self, cap: usize) {
        assert!(std::mem::size_of::<T>() > 0, "zero-sized blocks");
        if cap <= self.cap {
            return;
        }
        let layout = Layout::array::<T>(cap).unwrap_or_else(|_| capacity_overflow());
        #[cfg(target_os = "linux")]
        if self.mapped {
            let (ptr, cap) = mapped::grow(self.ptr, self.cap, cap);
            (self.ptr, self.cap) = (ptr, cap);
            return;
        } else if layout.size() >= MAPPED_FROM && std::mem::align_of::<T>() <= mapped::page() {
            // the last copy this array makes: from the heap into its own mapping
            let (ptr, new_cap) = mapped::new::<T>(cap);
            // SAFETY: both buffers hold at least `len` elements and do not overlap; the
            // first `len` of the old one are initialised.
            unsafe { std::ptr::copy_nonoverlapping(self.ptr.as_ptr(), ptr.as_ptr(), self.len) };
            self.free();
            (self.ptr, self.cap, self.mapped) = (ptr, new_cap, true);
            return;
        }
        // SAFETY: the layout has a non-zero size (`cap > 0`, `T` not zero-sized); a buffer
        // being grown was allocated with `Layout::array::<T>(self.cap)` (invariant).
        let p = unsafe {
            if self.cap == 0 {
                std::alloc::alloc(layout)
            } else {
                let old = Layout::array::<T>(self.cap).unwrap_or_else(|_| capacity_overflow());
                std::alloc::realloc(self.ptr.as_ptr().cast(), old, layout.size())
            }
        };
        self.ptr = NonNull::new(p.cast()).unwrap_or_else(|| std::alloc::handle_alloc_error(layout));
        self.cap = cap;
    }

    /// Give the buffer back (leaves the fields stale: the caller resets them).
    fn free(&mut self) {
        if self.cap == 0 {
            return;
        }
        #[cfg(target_os = "linux")]
        if self.mapped {
            mapped::free(self.ptr, self.cap);
            return;
        }
        let layout = Layout::array::<T>(self.cap).unwrap_or_else(|_| capacity_overflow());
        // SAFETY: allocated by the global allocator with this layout (invariant).
        unsafe { std::alloc::dealloc(self.ptr.as_ptr().cast(), layout) };
    }
}

impl<T: Copy> Drop for PageVec<T> {
    fn drop(&mut self) {
        self.free();
    }
}

impl<T: Copy> Deref for PageVec<T> {
    type Target = [T];
    #[inline(always)]
    fn deref(&self) -> &[T] {
        // SAFETY: the first `len` elements are initialised and inside the buffer (or `len`
        // is 0 and `ptr` dangling but aligned).
        unsafe { std::slice::from_raw_parts(self.ptr.as_ptr(), self.len) }
    }
}

impl<T: Copy> DerefMut for PageVec<T> {
    #[inline(always)]
    fn deref_mut(&mut self) -> &mut [T] {
        // SAFETY: as `deref`, and `&mut self` makes the access exclusive.
        unsafe { std::slice::from_raw_parts_mut(self.ptr.as_ptr(), self.len) }
    }
}

impl<T: Copy> Clone for PageVec<T> {
    fn clone(&self) -> Self {
        self.iter().copied().collect()
    }
}

impl<T: Copy> FromIterator<T> for PageVec<T> {
    fn from_iter<I: IntoIterator<Item = T>>(iter: I) -> Self {
        let mut v = PageVec::new();
        v.extend(iter);
        v
    }
}

impl<T: Copy> Extend<T> for PageVec<T> {
    fn extend<I: IntoIterator<Item = T>>(&mut self, iter: I) {
        let iter = iter.into_iter();
        let hint = iter.size_hint().0;
        if self.cap - self.len < hint {
            // amortised, as `Vec::extend`: repeated extends must not grow one at a time
            self.grow(hint);
        }
        for x in iter {
            self.push(x);
        }
    }
}

impl<T: Copy + std::fmt::Debug> std::fmt::Debug for PageVec<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

impl<'a, T: Copy> IntoIterator for &'a PageVec<T> {
    type Item = &'a T;
    type IntoIter = std::slice::Iter<'a, T>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

impl<'a, T: Copy> IntoIterator for &'a mut PageVec<T> {
    type Item = &'a mut T;
    type IntoIter = std::slice::IterMut<'a, T>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter_mut()
    }
}

#[cfg(target_os = "linux")]
mod mapped {
    //! Mapped buffers: anonymous private mappings grown with `mremap(MREMAP_MAYMOVE)`.

    use std::ptr::NonNull;

    /// The page size.
    pub(super) fn page() -> usize {
        // SAFETY: sysconf has no preconditions.
        let p = unsafe { libc::sysconf(libc::_SC_PAGESIZE) };
        if p > 0 {
            p as usize
        } else {
            4096
        }
    }

    /// Bytes of the whole pages that hold `cap` elements of `T`.
    pub(super) fn bytes<T>(cap: usize) -> usize {
        let page = page();
        cap.checked_mul(std::mem::size_of::<T>())
            .and_then(|b| b.checked_add(page - 1))
            .map(|b| b / page * page)
            .unwrap_or_else(|| super::capacity_overflow())
    }

    fn out_of_memory(bytes: usize) -> ! {
        // as a `Vec` does when the allocator fails
        std::alloc::handle_alloc_error(
            std::alloc::Layout::from_size_align(bytes.max(1), 1)
                .unwrap_or(std::alloc::Layout::new::<u8>()),
        )
    }

    fn checked<T>(p: *mut libc::c_void, bytes: usize) -> NonNull<T> {
        if p == libc::MAP_FAILED {
            out_of_memory(bytes);
        }
        NonNull::new(p.cast()).unwrap_or_else(|| out_of_memory(bytes))
    }

    /// A new mapping for at least `cap > 0` elements; returns it and the capacity its whole
    /// pages give.
    pub(super) fn new<T>(cap: usize) -> (NonNull<T>, usize) {
        let bytes = bytes::<T>(cap);
        // SAFETY: an anonymous private mapping of `bytes` > 0 bytes at an address the kernel
        // chooses; checked against MAP_FAILED.
        let p = unsafe {
            libc::mmap(
                std::ptr::null_mut(),
                bytes,
                libc::PROT_READ | libc::PROT_WRITE,
                libc::MAP_PRIVATE | libc::MAP_ANONYMOUS,
                -1,
                0,
            )
        };
        (checked(p, bytes), bytes / std::mem::size_of::<T>())
    }

    /// Grow the mapping `ptr` of `old_cap` elements to at least `cap`, moving pages, never
    /// bytes; returns its new address and capacity.
    pub(super) fn grow<T>(ptr: NonNull<T>, old_cap: usize, cap: usize) -> (NonNull<T>, usize) {
        let (old, new) = (bytes::<T>(old_cap), bytes::<T>(cap));
        // SAFETY: `ptr` starts a live mapping of `old` bytes (the caller's invariant);
        // MREMAP_MAYMOVE lets the kernel move it with its contents, and the caller uses only
        // the returned address from now on. Checked against MAP_FAILED.
        let p = unsafe { libc::mremap(ptr.as_ptr().cast(), old, new, libc::MREMAP_MAYMOVE) };
        (checked(p, new), new / std::mem::size_of::<T>())
    }

    /// Unmap the mapping `ptr` of `cap` elements.
    pub(super) fn free<T>(ptr: NonNull<T>, cap: usize) {
        // SAFETY: `ptr` starts a live mapping of `bytes(cap)` bytes that nothing uses after.
        unsafe { libc::munmap(ptr.as_ptr().cast(), bytes::<T>(cap)) };
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A cache-line block like the octree's inner nodes.
    #[derive(Clone, Copy, Debug, PartialEq)]
    #[repr(C, align(64))]
    struct Block([u32; 16]);

    #[test]
    fn large_arrays_move_into_a_mapping_and_keep_their_contents() {
        let mut v = PageVec::new();
        let n = 3 * MAPPED_FROM / 64 + 17;
        for i in 0..n as u32 {
            v.push(Block([i; 16]));
        }
        if cfg!(target_os = "linux") {
            assert!(v.is_mapped());
        }
        assert_eq!(v.len(), n);
        assert!(v.iter().enumerate().all(|(i, b)| b.0 == [i as u32; 16]));
        assert_eq!(v.as_ptr() as usize % 64, 0, "blocks stay aligned");
        v[5].0[3] = 99;
        assert_eq!(v[5].0[3], 99);
        let c = v.clone();
        assert!(c[..] == v[..]);
        v.clear();
        assert!(v.is_empty());
        v.push(Block([7; 16]));
        assert_eq!(v[..], [Block([7; 16])]);
    }

    #[test]
    fn small_arrays_stay_on_the_heap() {
        let v: PageVec<u64> = (0..1000).collect();
        assert!(!v.is_mapped());
        assert_eq!(v.len(), 1000);
    }

    proptest! {
        /// Any sequence of pushes, clears and reservations leaves the same elements as a
        /// `Vec` given the same sequence.
        #[test]
        fn behaves_as_a_vec(ops in prop::collection::vec((0u8..10, 0usize..40_000), 0..40)) {
            let (mut ours, mut theirs) = (PageVec::<u64>::new(), Vec::<u64>::new());
            for (op, n) in ops {
                match op {
                    0 => {
                        ours.clear();
                        theirs.clear();
                    }
                    1 => {
                        ours.reserve_exact(n);
                        prop_assert!(ours.capacity() >= ours.len() + n);
                    }
                    _ => {
                        for i in 0..n as u64 {
                            ours.push(i ^ n as u64);
                            theirs.push(i ^ n as u64);
                        }
                    }
                }
                prop_assert_eq!(&ours[..], &theirs[..]);
            }
        }
    }
}
