//! The density reducer's store, [`DensityGrid`], and its input stage.
//!
//! One type, its `impl` split by concern, one file each:
//!
//! * `store.rs`: the struct, its cells' records (`Hot`, `Cell`, the packed `PackedCell`),
//!   construction, counts and the slot of a cell.
//! * `view.rs`: read access, [`CellView`] and the comparable [`GridState`].
//! * `representative.rs`: ranking members under the [`Selection`](crate::Selection) rule,
//!   choosing a cell's representative and repairing it after a change.
//! * `insert.rs` and `remove.rs`: the input stage one point at a time.
//! * `batch.rs`: the input stage for whole batches ([`DensityGrid::extend`]) and the one-pass
//!   build of an empty store; `batch_sort.rs` sorts a batch by cell, with the cell keys of
//!   `packing.rs`, the id table of `key_table.rs` and the radix sort of `octoquant-radix`.
//! * `order.rs`: the ordered index and the distance order (a compact `Vec` form after a
//!   build, B-trees once changed); `distance_sort.rs` sorts the distance order of a build.
//! * `lookup.rs`: the hash index from cell index to slot.
//! * `arena.rs`: the member arena (one span per cell, growth, compaction, the `f32` form).
//! * `validation.rs`: the invariant checks ([`DensityGrid::validate`]).
//!
//! The output stage, reading the store in read cycles, is `crate::output`.

mod arena;
mod batch;
mod batch_sort;
mod distance_sort;
mod insert;
mod key_table;
mod lookup;
mod order;
mod packing;
mod remove;
mod representative;
mod store;
mod validation;
mod view;

pub(crate) use lookup::hash_index;
pub(crate) use order::distance_slots_after;

pub use insert::InsertOutcome;
pub use store::{DensityGrid, GridCounts};
pub use view::{CellState, CellView, GridState};
