//! tf: decoding `tf2_msgs/TFMessage` ([`decode_tf_message`]) and the transform tree
//! ([`TfTree`]) that composes the recorded transforms between two frames at a time.

use super::cdr::{DecodeError, Encoding, Reader};
use crate::pose::isometry;
use nalgebra::{Isometry3, Quaternion, Vector3};
use std::collections::{BTreeMap, HashMap};

/// The schema names of tf channels (ROS 1, ROS 2).
pub(super) const TF_SCHEMAS: [&str; 2] = ["tf2_msgs/TFMessage", "tf2_msgs/msg/TFMessage"];

/// One `geometry_msgs/TransformStamped`: `parent` ← `child`.
#[derive(Debug, Clone, PartialEq)]
pub struct Transform {
    /// `header.frame_id`.
    pub parent: String,
    /// `child_frame_id`.
    pub child: String,
    /// Maps child coordinates to parent coordinates.
    pub transform: Isometry3<f64>,
}

/// Decode a `tf2_msgs/TFMessage`.
pub fn decode_tf_message(msg: &[u8], encoding: Encoding) -> Result<Vec<Transform>, DecodeError> {
    let mut r = Reader::new(msg, encoding)?;
    let n = r.count("transforms", 60)?;
    let mut out = Vec::with_capacity(n);
    for _ in 0..n {
        let (parent, _) = r.header()?;
        let child = r.string("child_frame_id")?;
        let mut v = [0.0; 7];
        for (i, x) in v.iter_mut().enumerate() {
            *x = r.f64(if i < 3 { "translation" } else { "rotation" })?;
        }
        let q = Quaternion::new(v[6], v[3], v[4], v[5]);
        if !v.iter().all(|x| x.is_finite()) || q.norm() < 1e-9 {
            return Err(r.err(format!(
                "transform {parent} -> {child} is not finite or has a zero quaternion"
            )));
        }
        out.push(Transform {
            parent,
            child,
            transform: isometry(Vector3::new(v[0], v[1], v[2]), q),
        });
    }
    Ok(out)
}

/// The longest chain of transforms composed between a cloud's frame and the fixed frame.
/// Real tf trees are a few dozen frames deep; the cap keeps the work per cloud bounded, so a
/// file cannot make reading quadratic with one long chain and many clouds.
pub(super) const MAX_TF_CHAIN: usize = 256;

/// The recorded transforms of one (parent, child) edge.
#[derive(Default)]
struct Edge {
    /// The last static transform, which wins over every dynamic one.
    last_static: Option<Isometry3<f64>>,
    /// Dynamic transforms by log time (stable order among equal times), sorted on demand.
    timed: Vec<(u64, Isometry3<f64>)>,
}

impl Edge {
    /// The transform at `time`: the last static one; else the latest at or before `time`
    /// (the last recorded among equal times); else the earliest (the first recorded).
    fn at(&self, time: u64) -> Isometry3<f64> {
        if let Some(s) = self.last_static {
            return s;
        }
        let k = self.timed.partition_point(|e| e.0 <= time);
        let e = if k > 0 {
            self.timed.get(k - 1)
        } else {
            self.timed.first()
        };
        e.map(|e| e.1).unwrap_or_else(Isometry3::identity)
    }
}

/// How a frame was reached from a fixed frame: over edge `edge` from frame `from`, `forward`
/// when `from` is the edge's parent; `depth` edges from the fixed frame.
#[derive(Clone, Copy)]
struct Step {
    from: usize,
    edge: usize,
    forward: bool,
    depth: usize,
}

/// Transforms collected from a file: static ones and timed dynamic ones per (parent, child).
///
/// Lookups cost the length of the chain (at most [`MAX_TF_CHAIN`]) times a binary search per
/// edge: the graph is indexed once after the last [`TfTree::add`], and the search from a fixed
/// frame is done once per fixed frame and kept.
#[derive(Default)]
pub(super) struct TfTree {
    edges: BTreeMap<(String, String), Edge>,
    index: Option<Index>,
    /// Edge steps and searched frames so far, the measure of the lookup work (for tests).
    pub(super) work: u64,
}

/// The graph of a [`TfTree`], built on first use.
struct Index {
    /// Frame names, sorted; a frame's number is its position.
    names: Vec<String>,
    /// (parent, child, edge) in key order.
    edges: Vec<(usize, usize, Edge)>,
    /// Per frame: its edges (edge number, whether the frame is the parent).
    adjacent: Vec<Vec<(usize, bool)>>,
    /// Per frame: its first parent in key order.
    parent: Vec<Option<usize>>,
    /// Per fixed frame searched: how each reachable frame is reached from it.
    searches: HashMap<usize, Vec<Option<Step>>>,
}

impl Index {
    fn build(edges: &mut BTreeMap<(String, String), Edge>) -> Index {
        let mut names: Vec<String> = edges
            .keys()
            .flat_map(|(p, c)| [p.clone(), c.clone()])
            .collect();
        names.sort();
        names.dedup();
        let id = |n: &str| names.binary_search_by(|x| x.as_str().cmp(n)).unwrap_or(0);
        let mut adjacent = vec![Vec::new(); names.len()];
        let mut parent = vec![None; names.len()];
        let mut list = Vec::with_capacity(edges.len());
        for (k, ((p, c), mut e)) in std::mem::take(edges).into_iter().enumerate() {
            e.timed.sort_by_key(|t| t.0);
            let (p, c) = (id(&p), id(&c));
            adjacent[p].push((k, true));
            adjacent[c].push((k, false));
            parent[c].get_or_insert(p);
            list.push((p, c, e));
        }
        Index {
            names,
            edges: list,
            adjacent,
            parent,
            searches: HashMap::new(),
        }
    }

    fn id(&self, frame: &str) -> Option<usize> {
        self.names.binary_search_by(|x| x.as_str().cmp(frame)).ok()
    }

    /// Breadth-first search from `fixed` over edges in either direction.
    fn search(&self, fixed: usize, work: &mut u64) -> Vec<Option<Step>> {
        let mut steps: Vec<Option<Step>> = vec![None; self.names.len()];
        let mut queue = std::collections::VecDeque::from([fixed]);
        let mut seen = vec![false; self.names.len()];
        seen[fixed] = true;
        while let Some(cur) = queue.pop_front() {
            let depth = steps[cur].map_or(0, |s| s.depth);
            for &(edge, forward) in &self.adjacent[cur] {
                *work += 1;
                let (p, c, _) = &self.edges[edge];
                let next = if forward { *c } else { *p };
                if !seen[next] {
                    seen[next] = true;
                    steps[next] = Some(Step {
                        from: cur,
                        edge,
                        forward,
                        depth: depth + 1,
                    });
                    queue.push_back(next);
                }
            }
        }
        steps
    }
}

impl TfTree {
    pub(super) fn add(&mut self, t: Transform, time: u64, is_static: bool) {
        if let Some(index) = self.index.take() {
            // new transforms after a lookup: fold the indexed edges back in
            for (p, c, e) in index.edges {
                self.edges
                    .insert((index.names[p].clone(), index.names[c].clone()), e);
            }
        }
        let e = self.edges.entry((t.parent, t.child)).or_default();
        if is_static {
            e.last_static = Some(t.transform);
        } else {
            e.timed.push((time, t.transform));
        }
    }

    fn index(&mut self) -> &mut Index {
        self.index
            .get_or_insert_with(|| Index::build(&mut self.edges))
    }

    /// The root of `frame`'s tree (following child → first parent), or `frame` itself; at a
    /// cycle, the last frame before it closes.
    pub(super) fn root(&mut self, frame: &str) -> String {
        let index = self.index();
        let Some(mut cur) = index.id(frame) else {
            return frame.to_string();
        };
        let mut seen = vec![cur];
        let mut steps = 0u64;
        while let Some(p) = index.parent[cur] {
            steps += 1;
            if seen.contains(&p) || seen.len() > MAX_TF_CHAIN {
                break;
            }
            cur = p;
            seen.push(cur);
        }
        let root = index.names[cur].clone();
        self.work += steps;
        root
    }

    /// `fixed ← frame` at `time`, composing edges either way along the shortest chain; an
    /// error says why there is none (not connected, or longer than [`MAX_TF_CHAIN`]).
    pub(super) fn lookup(
        &mut self,
        fixed: &str,
        frame: &str,
        time: u64,
    ) -> Result<Isometry3<f64>, String> {
        if fixed == frame {
            return Ok(Isometry3::identity());
        }
        let mut work = 0;
        let index = self.index();
        let not_connected = || "no transform chain".to_string();
        let (Some(f), Some(target)) = (index.id(fixed), index.id(frame)) else {
            return Err(not_connected());
        };
        if !index.searches.contains_key(&f) {
            let steps = index.search(f, &mut work);
            index.searches.insert(f, steps);
        }
        let steps = &index.searches[&f];
        let Some(last) = steps[target] else {
            self.work += work;
            return Err(not_connected());
        };
        if last.depth > MAX_TF_CHAIN {
            self.work += work;
            return Err(format!(
                "the transform chain has {} links, more than the {MAX_TF_CHAIN} accepted",
                last.depth
            ));
        }
        // walk back to the fixed frame, then compose outward from it
        let mut chain = Vec::with_capacity(last.depth);
        let mut cur = target;
        while let Some(step) = steps[cur] {
            chain.push(step);
            cur = step.from;
        }
        let mut t = Isometry3::identity();
        for step in chain.iter().rev() {
            work += 1;
            let e = index.edges[step.edge].2.at(time);
            t *= if step.forward { e } else { e.inverse() };
        }
        self.work += work;
        Ok(t)
    }

    pub(super) fn frames(&mut self) -> Vec<String> {
        self.index().names.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shift(parent: &str, child: &str, x: f64) -> Transform {
        Transform {
            parent: parent.into(),
            child: child.into(),
            transform: Isometry3::translation(x, 0.0, 0.0),
        }
    }

    fn x_of(t: Result<Isometry3<f64>, String>) -> f64 {
        t.map(|t| t.translation.x).unwrap_or(f64::NAN)
    }

    #[test]
    fn transforms_at_a_time() {
        let mut tf = TfTree::default();
        for (time, x) in [(10, 1.0), (20, 2.0), (20, 3.0), (30, 4.0)] {
            tf.add(shift("map", "s", x), time, false);
        }
        // latest at or before the time (the last recorded among equal times)
        assert_eq!(x_of(tf.lookup("map", "s", 25)), 3.0);
        assert_eq!(x_of(tf.lookup("map", "s", 30)), 4.0);
        // before every transform: the earliest
        assert_eq!(x_of(tf.lookup("map", "s", 5)), 1.0);
        // the other way round
        assert_eq!(x_of(tf.lookup("s", "map", 10)), -1.0);
        // a static transform wins, added after lookups
        tf.add(shift("map", "s", 9.0), 0, true);
        assert_eq!(x_of(tf.lookup("map", "s", 25)), 9.0);
        assert_eq!(tf.root("s"), "map");
        assert!(tf.lookup("map", "elsewhere", 0).is_err());
    }

    #[test]
    fn lookups_search_once_and_compose_only_the_chain() {
        // a chain of 10 links from map, and 2000 frames hanging off map
        let mut tf = TfTree::default();
        let mut parent = "map".to_string();
        for i in 0..10 {
            let child = format!("c{i}");
            tf.add(shift(&parent, &child, 1.0), 0, true);
            parent = child;
        }
        for i in 0..2000 {
            tf.add(shift("map", &format!("leaf{i}"), 0.5), 0, true);
        }
        let edges = 2010;
        let lookups = 2000;
        for t in 0..lookups {
            assert_eq!(x_of(tf.lookup("map", "c9", t)), 10.0);
            assert_eq!(tf.root("c9"), "map");
        }
        // one search over every edge (each seen from both ends), then 10 links and 10 root
        // steps per lookup: a search per lookup would cost 2000 times the edges
        assert!(
            tf.work <= 2 * edges + lookups * (10 + 10),
            "work {} for {lookups} lookups",
            tf.work
        );
    }

    #[test]
    fn chains_longer_than_the_cap_are_refused() {
        let mut tf = TfTree::default();
        for i in 0..MAX_TF_CHAIN + 1 {
            tf.add(
                shift(&format!("f{i}"), &format!("f{}", i + 1), 1.0),
                0,
                true,
            );
        }
        let far = format!("f{}", MAX_TF_CHAIN + 1);
        let e = tf.lookup("f0", &far, 0).err().unwrap_or_default();
        assert!(e.contains("more than the 256"), "{e}");
        assert_eq!(x_of(tf.lookup("f0", &format!("f{MAX_TF_CHAIN}"), 0)), 256.0);
    }
}
