//! Elements kept in a vector by slot, with freed slots reused: the storage of
//! [`crate::KeyTable`]'s entries.

/// Put `item` in a freed slot of `items` if there is one, else at the end; returns its slot.
#[inline]
pub(crate) fn place<T>(items: &mut Vec<T>, free: &mut Vec<u32>, item: T) -> u32 {
    match free.pop() {
        Some(s) => {
            items[s as usize] = item;
            s
        }
        None => {
            items.push(item);
            (items.len() - 1) as u32
        }
    }
}
