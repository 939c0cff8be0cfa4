//! tf: decoding `tf2_msgs/TFMessage` ([`decode_tf_message`]) and the transform tree
//! ([`TfTree`]) that composes the recorded transforms between two frames at a time.

use super::cdr::{DecodeError, Encoding, Reader};
use crate::pose::isometry;
use nalgebra::{Isometry3, Quaternion, Vector3};
use std::collections::HashMap;

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

/// One recorded transform of an edge: (log time, static, parent ← child).
type Stamped = (u64, bool, Isometry3<f64>);

/// Transforms collected from a file: static ones and timed dynamic ones per (parent, child).
#[derive(Default)]
pub(super) struct TfTree {
    edges: HashMap<(String, String), Vec<Stamped>>,
}

impl TfTree {
    pub(super) fn add(&mut self, t: Transform, time: u64, is_static: bool) {
        self.edges
            .entry((t.parent, t.child))
            .or_default()
            .push((time, is_static, t.transform));
    }

    fn at(&self, list: &[Stamped], time: u64) -> Isometry3<f64> {
        if let Some(s) = list.iter().rev().find(|e| e.1) {
            return s.2;
        }
        list.iter()
            .filter(|e| e.0 <= time)
            .max_by_key(|e| e.0)
            .or_else(|| list.iter().min_by_key(|e| e.0))
            .map(|e| e.2)
            .unwrap_or_else(Isometry3::identity)
    }

    /// The root of `frame`'s tree (following child → parent), or `frame` itself.
    pub(super) fn root(&self, frame: &str) -> String {
        let mut cur = frame.to_string();
        let mut seen = vec![cur.clone()];
        while let Some(((p, _), _)) = self.edges.iter().find(|((_, c), _)| *c == cur) {
            if seen.contains(p) {
                break;
            }
            cur = p.clone();
            seen.push(cur.clone());
        }
        cur
    }

    /// `fixed ← frame` at `time`, composing edges either way; `None` if not connected.
    pub(super) fn lookup(&self, fixed: &str, frame: &str, time: u64) -> Option<Isometry3<f64>> {
        let mut known: HashMap<&str, Isometry3<f64>> = HashMap::new();
        known.insert(fixed, Isometry3::identity());
        loop {
            if let Some(t) = known.get(frame) {
                return Some(*t);
            }
            let mut grew = false;
            for ((p, c), list) in &self.edges {
                match (
                    known.get(p.as_str()).copied(),
                    known.get(c.as_str()).copied(),
                ) {
                    (Some(tp), None) => {
                        known.insert(c, tp * self.at(list, time));
                        grew = true;
                    }
                    (None, Some(tc)) => {
                        known.insert(p, tc * self.at(list, time).inverse());
                        grew = true;
                    }
                    _ => {}
                }
            }
            if !grew {
                return None;
            }
        }
    }

    pub(super) fn frames(&self) -> Vec<String> {
        let mut f: Vec<String> = self
            .edges
            .keys()
            .flat_map(|(p, c)| [p.clone(), c.clone()])
            .collect();
        f.sort();
        f.dedup();
        f
    }
}
