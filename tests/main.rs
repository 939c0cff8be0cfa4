//! Integration tests: one binary (see Cargo.toml `autotests = false`).

mod common;
mod octree_diff;
mod tree_files;
