//! A new directory for output nobody named: the demo, and `map` without inputs, write into
//! `octoquant-demo/` (or `octoquant-demo-2/`, `-3/`, ... when that exists) instead of files of
//! the current directory, so that trying the tool never overwrites anything.

use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};

/// The base name of the directories [`create_fresh_dir`] makes.
pub const DEMO_DIR: &str = "octoquant-demo";

/// Create a directory in `parent` that did not exist before: `NAME`, else `NAME-2`, `NAME-3`,
/// ... The creation itself is the test (`create_dir` fails on an existing entry), so two runs
/// at once never share a directory.
pub fn create_fresh_dir(parent: &Path, name: &str) -> Result<PathBuf> {
    for n in 1..=10_000u32 {
        let dir = if n == 1 {
            parent.join(name)
        } else {
            parent.join(format!("{name}-{n}"))
        };
        match std::fs::create_dir(&dir) {
            Ok(()) => return Ok(dir),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(e) => {
                return Err(e).with_context(|| format!("cannot create directory {}", dir.display()))
            }
        }
    }
    bail!(
        "{}: {name}, {name}-2, ... {name}-10000 all exist; pass an output name",
        parent.display()
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn never_reuses_an_existing_entry() {
        let root = std::env::temp_dir().join(format!("oq-fresh-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        std::fs::create_dir_all(&root).unwrap();
        // a file under the first name counts as taken, as does a directory
        std::fs::write(root.join("x"), b"keep").unwrap();
        let a = create_fresh_dir(&root, "x").unwrap();
        let b = create_fresh_dir(&root, "x").unwrap();
        assert_eq!(a, root.join("x-2"));
        assert_eq!(b, root.join("x-3"));
        assert!(a.is_dir() && b.is_dir());
        assert_eq!(std::fs::read(root.join("x")).unwrap(), b"keep");
        std::fs::remove_dir_all(&root).unwrap();
    }
}
