//! Shared helpers for the integration tests: locating real data and the C++ reference program.
//!
//! Under CI (`CI` set) a missing data set or reference program is a test failure with a clear
//! message; elsewhere the test prints that it was skipped and returns.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// `true` when running under CI, where nothing may be skipped.
pub fn in_ci() -> bool {
    std::env::var_os("CI").is_some_and(|v| !v.is_empty() && v != "0" && v != "false")
}

/// Report a missing prerequisite: panic under CI, print "skipped" otherwise.
/// Returns `None` so callers can write `let Some(x) = skip(..) else { return };`.
pub fn skip<T>(what: &str) -> Option<T> {
    if in_ci() {
        panic!("required under CI but missing: {what}");
    }
    eprintln!("SKIPPED (outside CI): {what}");
    None
}

/// The shared data directory from `OCTOQUANT_DATA`, or `../shared/data` beside the checkout.
pub fn data_dir() -> Option<PathBuf> {
    if let Some(d) = std::env::var_os("OCTOQUANT_DATA") {
        let d = PathBuf::from(d);
        let d = if d.is_relative() {
            Path::new(env!("CARGO_MANIFEST_DIR")).join(d)
        } else {
            d
        };
        if d.is_dir() {
            return Some(d);
        }
        return skip(&format!(
            "OCTOQUANT_DATA={} is not a directory",
            d.display()
        ));
    }
    let fallback = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data");
    if fallback.is_dir() {
        return Some(fallback);
    }
    skip("OCTOQUANT_DATA is not set and ../shared/data does not exist")
}

/// A file under the data directory, or `None` (skip / CI failure) when it is missing.
pub fn data_file(rel: &str) -> Option<PathBuf> {
    let d = data_dir()?;
    let p = d.join(rel);
    if p.exists() {
        Some(p)
    } else {
        skip(&format!("data file {}", p.display()))
    }
}

/// The project's own C++ reference program (tools/octoquant-ref), built once per test run
/// into target/octoquant-ref unless `OCTOQUANT_REF` names an existing binary.
pub fn reference_program() -> Option<PathBuf> {
    static REF: OnceLock<Result<PathBuf, String>> = OnceLock::new();
    let r = REF.get_or_init(|| {
        if let Some(p) = std::env::var_os("OCTOQUANT_REF") {
            let p = PathBuf::from(p);
            return if p.is_file() {
                Ok(p)
            } else {
                Err(format!("OCTOQUANT_REF={} does not exist", p.display()))
            };
        }
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let out = root.join("target/octoquant-ref");
        let bin = out.join("octoquant-ref");
        let status = std::process::Command::new("sh")
            .arg(root.join("tools/octoquant-ref/build.sh"))
            .arg(&out)
            .status();
        match status {
            Ok(s) if s.success() && bin.is_file() => Ok(bin),
            Ok(s) => Err(format!(
                "building tools/octoquant-ref failed ({s}); install liboctomap-dev g++ pkg-config"
            )),
            Err(e) => Err(format!("cannot run tools/octoquant-ref/build.sh: {e}")),
        }
    });
    match r {
        Ok(p) => Some(p.clone()),
        Err(e) => skip(&format!("the C++ reference program: {e}")),
    }
}

/// A fresh scratch directory under the target dir, unique per test name.
pub fn scratch(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("target/test-scratch")
        .join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("create scratch dir");
    d
}

/// Where two byte strings first differ, for assertion messages.
pub fn first_diff(a: &[u8], b: &[u8]) -> String {
    let i = a
        .iter()
        .zip(b)
        .position(|(x, y)| x != y)
        .unwrap_or(a.len().min(b.len()));
    format!(
        "lengths {} vs {}, first difference at byte {i}",
        a.len(),
        b.len()
    )
}

/// OctoMap's node surgery, one call on the node at exactly a depth, as the reference
/// program's `expand_node`, `prune_node`, `create_child`, `delete_child`, `integrate_hit`,
/// `integrate_miss`, `node_ml` and `log_odds` commands make it: skipped, on both sides alike,
/// where there is no such node or OctoMap would assert, and `delete_child` on a leaf child
/// only.
#[derive(Debug, Clone, Copy)]
pub struct Surgery {
    /// 0 expand, 1 prune, 2 create a child, 3 delete a child, 4 `integrateHit`, 5
    /// `integrateMiss`, 6 `nodeToMaxLikelihood`, 7 `updateNodeLogOdds` by `bits`.
    pub kind: u8,
    pub key: octoquant::Key,
    pub depth: u8,
    pub child: u8,
    /// The log-odds update of kind 7, as `f32` bits (finite).
    pub bits: u32,
}

/// The trees, as the surgery calls see them.
pub trait SurgeryTree {
    /// Whether the node at exactly `depth` holding `key` exists, and whether it has children.
    fn state(&self, key: octoquant::Key, depth: u8) -> Option<bool>;
    /// Whether child `i` exists, and whether it has children.
    fn child_state(&self, key: octoquant::Key, depth: u8, i: usize) -> Option<bool>;
    fn expand(&mut self, key: octoquant::Key, depth: u8) -> bool;
    fn prune(&mut self, key: octoquant::Key, depth: u8) -> bool;
    fn create(&mut self, key: octoquant::Key, depth: u8, i: usize) -> bool;
    fn delete(&mut self, key: octoquant::Key, depth: u8, i: usize) -> usize;
    /// `updateNodeLogOdds` on the node, at time `now` where the tree keeps stamps.
    fn log_odds(
        &mut self,
        key: octoquant::Key,
        depth: u8,
        update: octoquant::octree::Update,
        now: u32,
    ) -> Option<f32>;
    /// `nodeToMaxLikelihood` on the node.
    fn to_ml(&mut self, key: octoquant::Key, depth: u8) -> Option<f32>;
}

macro_rules! surgery_tree {
    ($t:ty, $info:ident => $has_children:expr, $log_odds:expr) => {
        impl SurgeryTree for $t {
            fn state(&self, key: octoquant::Key, depth: u8) -> Option<bool> {
                self.node_at_depth(key, depth).map(|$info| $has_children)
            }
            fn child_state(&self, key: octoquant::Key, depth: u8, i: usize) -> Option<bool> {
                self.node_child(key, depth, i).map(|$info| $has_children)
            }
            fn expand(&mut self, key: octoquant::Key, depth: u8) -> bool {
                self.expand_node(key, depth)
            }
            fn prune(&mut self, key: octoquant::Key, depth: u8) -> bool {
                self.prune_node(key, depth)
            }
            fn create(&mut self, key: octoquant::Key, depth: u8, i: usize) -> bool {
                self.create_node_child(key, depth, i).is_some()
            }
            fn delete(&mut self, key: octoquant::Key, depth: u8, i: usize) -> usize {
                self.delete_node_child(key, depth, i)
            }
            fn log_odds(
                &mut self,
                key: octoquant::Key,
                depth: u8,
                update: octoquant::octree::Update,
                now: u32,
            ) -> Option<f32> {
                #[allow(clippy::redundant_closure_call)]
                ($log_odds)(self, key, depth, update, now).expect("a finite update")
            }
            fn to_ml(&mut self, key: octoquant::Key, depth: u8) -> Option<f32> {
                self.node_to_max_likelihood(key, depth)
            }
        }
    };
}
surgery_tree!(
    octoquant::octree::ColorOcTree,
    n => n.node.has_children,
    |t: &mut octoquant::octree::ColorOcTree, k, d, u, _now| t.update_node_log_odds(k, d, u)
);
surgery_tree!(
    octoquant::octree::StampedOcTree,
    n => n.node.has_children,
    |t: &mut octoquant::octree::StampedOcTree, k, d, u, now| t.update_node_log_odds_at(k, d, u, now)
);
surgery_tree!(
    octoquant::octree::OcTree,
    n => n.has_children,
    |t: &mut octoquant::octree::OcTree, k, d, u, _now| t.update_node_log_odds(k, d, u)
);

impl Surgery {
    /// Apply the call to `tree` as the reference program does, at time `now` where the tree
    /// keeps stamps (the reference program's clock).
    pub fn apply(&self, tree: &mut impl SurgeryTree, now: u32) {
        use octoquant::octree::Update;
        let (k, d, i) = (self.key, self.depth, usize::from(self.child));
        let Some(has_children) = tree.state(k, d) else {
            return;
        };
        match self.kind {
            0 if d < 16 && !has_children => {
                assert!(tree.expand(k, d));
            }
            1 if has_children => {
                tree.prune(k, d);
            }
            2 if d < 16 && tree.child_state(k, d, i).is_none() => {
                assert!(tree.create(k, d, i));
            }
            3 if tree.child_state(k, d, i) == Some(false) => {
                assert_eq!(tree.delete(k, d, i), 1);
            }
            4..=7 => {
                let v = match self.kind {
                    4 => tree.log_odds(k, d, Update::Hit, now),
                    5 => tree.log_odds(k, d, Update::Miss, now),
                    6 => tree.to_ml(k, d),
                    _ => tree.log_odds(k, d, Update::LogOdds(f32::from_bits(self.bits)), now),
                };
                assert!(v.is_some(), "the node exists");
            }
            _ => {}
        }
    }

    /// The reference program's command line for the call.
    pub fn line(&self) -> String {
        let (k, d) = (self.key, self.depth);
        let cmd = [
            "expand_node",
            "prune_node",
            "create_child",
            "delete_child",
            "integrate_hit",
            "integrate_miss",
            "node_ml",
            "log_odds",
        ][usize::from(self.kind)];
        let tail = match self.kind {
            2 | 3 => format!(" {}", self.child),
            7 => format!(" {:08x}", self.bits),
            _ => String::new(),
        };
        format!("{cmd} {} {} {} {d}{tail}\n", k.x(), k.y(), k.z())
    }
}

/// A strategy for [`Surgery`] calls on the nodes holding the keys of `keys`, at depths 12
/// to 16.
pub fn surgery_strategy(
    keys: impl proptest::strategy::Strategy<Value = octoquant::Key>,
) -> impl proptest::strategy::Strategy<Value = Surgery> {
    use proptest::prelude::*;
    let kind = prop_oneof![4 => 0u8..4, 3 => 4u8..8];
    (kind, keys, 12u8..=16, 0u8..8, -5.0f32..5.0).prop_map(|(kind, key, depth, child, v)| Surgery {
        kind,
        key,
        depth,
        child,
        bits: v.to_bits(),
    })
}
