//! Integration tests: one binary (see Cargo.toml `autotests = false`).

mod checkpoint;
mod cli;
mod color_tree_diff;
mod common;
mod compare;
mod crop;
mod filters;
mod formats;
mod grid;
mod map_diff;
mod mcap;
mod merge;
mod octree_diff;
mod output_failures;
mod peers;
mod query;
mod raycast_diff;
mod reduce;
mod render;
mod scene;
mod segment;
mod stream;
mod tiled;
mod tree_files;
