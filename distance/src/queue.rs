//! The brushfire's open list: a priority queue keyed by squared cell distance.
//!
//! dynamicEDT3D keeps one first-in first-out bucket per squared distance and always takes
//! from the smallest non-empty bucket. Ties are therefore broken by insertion order, and that
//! order decides which of several equally near obstacles a cell ends up pointing at, so the
//! queue here keeps exactly that discipline.

use std::collections::{BTreeMap, VecDeque};

/// Buckets of grid indices, one per priority, popped smallest priority first and first in
/// first out within a priority.
#[derive(Debug, Default, Clone)]
pub(crate) struct BucketQueue {
    buckets: BTreeMap<i32, VecDeque<u32>>,
    len: usize,
}

impl BucketQueue {
    /// Whether nothing is queued.
    #[cfg(test)]
    pub(crate) fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Queue `item` behind everything already queued at `priority`.
    pub(crate) fn push(&mut self, priority: i32, item: u32) {
        self.buckets.entry(priority).or_default().push_back(item);
        self.len += 1;
    }

    /// Take the oldest item of the smallest priority.
    pub(crate) fn pop(&mut self) -> Option<u32> {
        let mut first = self.buckets.first_entry()?;
        let item = first.get_mut().pop_front();
        if first.get().is_empty() {
            first.remove();
        }
        if item.is_some() {
            self.len -= 1;
        }
        item
    }
}

#[cfg(test)]
mod tests {
    use super::BucketQueue;

    #[test]
    fn smallest_priority_first_and_fifo_within_one() {
        let mut q = BucketQueue::default();
        q.push(5, 1);
        q.push(2, 2);
        q.push(5, 3);
        q.push(2, 4);
        assert_eq!(q.pop(), Some(2));
        q.push(0, 9);
        assert_eq!(q.pop(), Some(9));
        assert_eq!(q.pop(), Some(4));
        assert_eq!(q.pop(), Some(1));
        assert_eq!(q.pop(), Some(3));
        assert!(q.is_empty());
        assert_eq!(q.pop(), None);
    }
}
