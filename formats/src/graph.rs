//! OctoMap ScanGraph `.graph` files (`ScanGraph::readBinary` / `writeBinary`), and OctoMap's
//! exact `f32` pose arithmetic (`octomath::Pose6D`, `octomath::Quaternion`).
//!
//! Layout (little-endian): `u32` node count; per node a point cloud (`u32 n`, then n ×
//! (`i32 3` + 3 × `f64`)), a pose (`i32 3` + 3 × `f64` translation, `i32 4` + 4 × `f64`
//! quaternion w, x, y, z) and a `u32` id; then a `u32` edge count and per edge `u32 first`,
//! `u32 second`, a pose and an `f64` weight. Doubles are cast to `f32` on reading, as OctoMap
//! stores them.
//!
//! [`graph_to_frames`] reproduces graph2tree: each node's points go through
//! `Pointcloud::transform(pose)` in `f32`, and the sensor origin is the pose translation
//! computed the way graph2tree does (through the inverse pose and back).

use crate::error::FormatError;
use crate::source::{read_all, ByteReader};
use crate::Frame;
use nalgebra::{Point3, Quaternion, Vector3};
use std::io::{self, Write};
use std::path::Path;

/// An OctoMap pose: `f32` translation and an `f32` quaternion that is used as stored.
///
/// OctoMap never normalises the quaternion before rotating, so a non-unit quaternion scales
/// points; this type keeps that behaviour.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose6D {
    /// Translation (metres).
    pub translation: Vector3<f32>,
    /// Rotation quaternion; `Quaternion::new(w, x, y, z)`.
    pub rotation: Quaternion<f32>,
}

impl Default for Pose6D {
    fn default() -> Self {
        Pose6D::from_translation(Vector3::zeros())
    }
}

impl Pose6D {
    /// A pose with identity rotation `(1, 0, 0, 0)`.
    pub fn from_translation(translation: Vector3<f32>) -> Self {
        Pose6D {
            translation,
            rotation: Quaternion::new(1.0, 0.0, 0.0, 0.0),
        }
    }

    /// OctoMap's `Pose6D(x, y, z, roll, pitch, yaw)`: the quaternion comes from
    /// [`quaternion_from_euler`].
    pub fn from_euler(translation: Vector3<f32>, roll: f64, pitch: f64, yaw: f64) -> Self {
        Pose6D {
            translation,
            rotation: quaternion_from_euler(roll, pitch, yaw),
        }
    }

    /// `Pose6D::transform`: `rotate(v) + translation`, all in `f32`.
    pub fn transform(&self, p: &Point3<f32>) -> Point3<f32> {
        let r = rotate(&self.rotation, &p.coords);
        Point3::new(
            r.x + self.translation.x,
            r.y + self.translation.y,
            r.z + self.translation.z,
        )
    }

    /// `Pose6D::inv`: rotation `normalized(conj(q))`, translation `rotate(-t)` by it.
    pub fn inverse(&self) -> Pose6D {
        let q = self.rotation;
        let rot = normalized(&Quaternion::new(q.w, -q.i, -q.j, -q.k));
        let neg = Vector3::new(
            -self.translation.x,
            -self.translation.y,
            -self.translation.z,
        );
        Pose6D {
            translation: rotate(&rot, &neg),
            rotation: rot,
        }
    }

    /// The sensor origin graph2tree uses for this pose:
    /// `pose.transform(pose.inv().transform(pose.trans()))`, which is the translation up to
    /// `f32` rounding of the round trip.
    pub fn graph2tree_origin(&self) -> Point3<f32> {
        let t = Point3::from(self.translation);
        self.transform(&self.inverse().transform(&t))
    }
}

/// The quaternion product `a * b` with OctoMap's operand order and left-to-right evaluation
/// (`Quaternion::operator*`).
fn mul(a: &Quaternion<f32>, b: &Quaternion<f32>) -> Quaternion<f32> {
    let (u1, x1, y1, z1) = (a.w, a.i, a.j, a.k);
    let (u2, x2, y2, z2) = (b.w, b.i, b.j, b.k);
    Quaternion::new(
        u1 * u2 - x1 * x2 - y1 * y2 - z1 * z2,
        y1 * z2 - y2 * z1 + u1 * x2 + u2 * x1,
        z1 * x2 - z2 * x1 + u1 * y2 + u2 * y1,
        x1 * y2 - x2 * y1 + u1 * z2 + u2 * z1,
    )
}

/// `Quaternion::rotate`: `(q * (0, v)) * conj(q)` in `f32`; the conjugate is not normalised.
pub fn rotate(q: &Quaternion<f32>, v: &Vector3<f32>) -> Vector3<f32> {
    let pure = Quaternion::new(0.0, v.x, v.y, v.z);
    let conj = Quaternion::new(q.w, -q.i, -q.j, -q.k);
    let r = mul(&mul(q, &pure), &conj);
    Vector3::new(r.i, r.j, r.k)
}

/// `Quaternion::normalized`: squares in `f32` summed in `f64`, the norm cast to `f32`, then
/// each component divided by it (unchanged when the norm is 0).
fn normalized(q: &Quaternion<f32>) -> Quaternion<f32> {
    let c = [q.w, q.i, q.j, q.k];
    let n: f64 = c.iter().map(|&x| f64::from(x * x)).sum();
    let len = n.sqrt() as f32;
    if f64::from(len) > 0.0 {
        Quaternion::new(c[0] / len, c[1] / len, c[2] / len, c[3] / len)
    } else {
        *q
    }
}

/// OctoMap's `Quaternion(roll, pitch, yaw)`: a rotation matrix in `f64`, then the quaternion
/// from its diagonal with signs from the off-diagonal, cast to `f32`.
pub fn quaternion_from_euler(roll: f64, pitch: f64, yaw: f64) -> Quaternion<f32> {
    let (sr, sp, sy) = (roll.sin(), pitch.sin(), yaw.sin());
    let (cr, cp, cy) = (roll.cos(), pitch.cos(), yaw.cos());
    let m = [
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ];
    // std::max(0., v): NaN gives 0.
    let half_sqrt = |v: f64| ((if 0.0 < v { v } else { 0.0 }).sqrt() / 2.0) as f32;
    let u = half_sqrt(1.0 + m[0][0] + m[1][1] + m[2][2]);
    let x = half_sqrt(1.0 + m[0][0] - m[1][1] - m[2][2]);
    let y = half_sqrt(1.0 - m[0][0] + m[1][1] - m[2][2]);
    let z = half_sqrt(1.0 - m[0][0] - m[1][1] + m[2][2]);
    let sign = |d: f64, v: f32| if d >= 0.0 { v.abs() } else { -v.abs() };
    Quaternion::new(
        u,
        sign(m[2][1] - m[1][2], x),
        sign(m[0][2] - m[2][0], y),
        sign(m[1][0] - m[0][1], z),
    )
}

/// One ScanGraph node: a point cloud in the node's local (sensor) frame and the sensor pose.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ScanNode {
    /// The node id as stored.
    pub id: u32,
    /// The sensor pose in the world.
    pub pose: Pose6D,
    /// Points in the sensor frame (or already global, see [`GraphOptions::points_global`]).
    pub points: Vec<Point3<f32>>,
}

/// One ScanGraph edge (graph2tree ignores edges; they are kept for round trips).
#[derive(Debug, Clone, PartialEq)]
pub struct ScanEdge {
    /// Id of the first node.
    pub first: u32,
    /// Id of the second node.
    pub second: u32,
    /// Relative pose constraint.
    pub constraint: Pose6D,
    /// Edge weight.
    pub weight: f64,
}

/// An OctoMap ScanGraph: nodes and edges in file order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ScanGraph {
    /// Nodes in file order.
    pub nodes: Vec<ScanNode>,
    /// Edges in file order.
    pub edges: Vec<ScanEdge>,
}

/// How graph nodes become frames.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct GraphOptions {
    /// Points are already in world coordinates (graph2tree `-g`): they are not transformed
    /// and the origin is the pose translation as stored.
    pub points_global: bool,
}

const POINT_BYTES: usize = 4 + 3 * 8;
const POSE_BYTES: usize = 4 + 3 * 8 + 4 + 4 * 8;

fn read_vector3(r: &mut ByteReader<'_>, what: &str) -> Result<Vector3<f32>, FormatError> {
    let tag = r.i32(what)?;
    if tag != 3 {
        return Err(r.error_at(4, format!("{what}: element count {tag}, expected 3")));
    }
    let x = r.f64(what)? as f32;
    let y = r.f64(what)? as f32;
    let z = r.f64(what)? as f32;
    Ok(Vector3::new(x, y, z))
}

fn read_pose(r: &mut ByteReader<'_>, what: &str) -> Result<Pose6D, FormatError> {
    let translation = read_vector3(r, what)?;
    let tag = r.i32(what)?;
    if tag != 4 {
        return Err(r.error_at(
            4,
            format!("{what} quaternion: element count {tag}, expected 4"),
        ));
    }
    let mut q = [0f32; 4];
    for c in &mut q {
        *c = r.f64(what)? as f32;
    }
    Ok(Pose6D {
        translation,
        rotation: Quaternion::new(q[0], q[1], q[2], q[3]),
    })
}

/// Parse a `.graph` from its bytes; `path` only names the file in errors.
///
/// Stricter than OctoMap, which stops quietly at the first bad node: any truncation or wrong
/// element count is an error naming the byte offset.
pub fn parse_graph(path: &Path, data: &[u8]) -> Result<ScanGraph, FormatError> {
    let mut r = ByteReader::new(path, data);
    let n_nodes = r.u32("node count")?;
    let mut nodes = Vec::with_capacity(r.capacity_for(n_nodes.into(), 4 + POSE_BYTES + 4));
    for i in 0..n_nodes {
        let n = r.u32(&format!("point count of node {i}"))?;
        let needed = u64::from(n) * POINT_BYTES as u64;
        if (r.remaining() as u64) < needed {
            return Err(FormatError::Truncated {
                path: path.to_path_buf(),
                offset: data.len() as u64,
                what: format!(
                    "{n} points of node {i} ({needed} bytes from byte {})",
                    r.pos()
                ),
            });
        }
        let mut points = Vec::with_capacity(n as usize);
        for _ in 0..n {
            points.push(Point3::from(read_vector3(&mut r, "point")?));
        }
        let pose = read_pose(&mut r, &format!("pose of node {i}"))?;
        let id = r.u32(&format!("id of node {i}"))?;
        nodes.push(ScanNode { id, pose, points });
    }
    let n_edges = r.u32("edge count")?;
    let mut edges = Vec::with_capacity(r.capacity_for(n_edges.into(), 8 + POSE_BYTES + 8));
    for i in 0..n_edges {
        let what = format!("edge {i}");
        let first = r.u32(&what)?;
        let second = r.u32(&what)?;
        let constraint = read_pose(&mut r, &what)?;
        let weight = r.f64(&what)?;
        edges.push(ScanEdge {
            first,
            second,
            constraint,
            weight,
        });
    }
    if r.remaining() != 0 {
        return Err(r.error_at(
            0,
            format!("{} bytes of trailing data after the graph", r.remaining()),
        ));
    }
    Ok(ScanGraph { nodes, edges })
}

/// Read a `.graph` file (optionally `.gz`/`.bz2`).
pub fn read_graph(path: &Path) -> Result<ScanGraph, FormatError> {
    parse_graph(path, &read_all(path)?)
}

/// Frames as graph2tree inserts them: one per node, in file order.
///
/// Unless `points_global`, points are transformed by `Pose6D::transform` and the origin is
/// [`Pose6D::graph2tree_origin`]; with it, points are kept and the origin is the translation.
pub fn graph_to_frames(graph: &ScanGraph, options: &GraphOptions) -> Vec<Frame> {
    graph
        .nodes
        .iter()
        .map(|node| {
            if options.points_global {
                Frame::new(Point3::from(node.pose.translation), node.points.clone())
            } else {
                let points = node.points.iter().map(|p| node.pose.transform(p)).collect();
                Frame::new(node.pose.graph2tree_origin(), points)
            }
        })
        .collect()
}

/// Read a `.graph` file straight into frames (see [`graph_to_frames`]).
pub fn read_graph_frames(path: &Path, options: &GraphOptions) -> Result<Vec<Frame>, FormatError> {
    Ok(graph_to_frames(&read_graph(path)?, options))
}

/// A graph holding world-coordinate frames for graph2tree `-g`: node i has id i, the
/// frame's points unchanged, and pose (origin, identity). Consecutive nodes get no edges.
pub fn graph_from_frames(frames: &[Frame]) -> ScanGraph {
    let nodes = frames
        .iter()
        .zip(0u32..)
        .map(|(f, id)| ScanNode {
            id,
            pose: Pose6D::from_translation(f.origin.coords),
            points: f.points.clone(),
        })
        .collect();
    ScanGraph {
        nodes,
        edges: Vec::new(),
    }
}

fn write_vector3(w: &mut (impl Write + ?Sized), v: &Vector3<f32>) -> io::Result<()> {
    w.write_all(&3i32.to_le_bytes())?;
    for c in [v.x, v.y, v.z] {
        w.write_all(&f64::from(c).to_le_bytes())?;
    }
    Ok(())
}

fn write_pose(w: &mut (impl Write + ?Sized), p: &Pose6D) -> io::Result<()> {
    write_vector3(w, &p.translation)?;
    w.write_all(&4i32.to_le_bytes())?;
    let q = &p.rotation;
    for c in [q.w, q.i, q.j, q.k] {
        w.write_all(&f64::from(c).to_le_bytes())?;
    }
    Ok(())
}

fn count_u32(n: usize, what: &str) -> io::Result<u32> {
    u32::try_from(n).map_err(|_| {
        io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("too many {what} for a .graph file: {n}"),
        )
    })
}

/// Write `graph` in OctoMap's binary layout (`ScanGraph::writeBinary`), `f32` values widened
/// to `f64`. Fails only on I/O or a count above `u32::MAX`.
pub fn write_graph(w: &mut (impl Write + ?Sized), graph: &ScanGraph) -> io::Result<()> {
    w.write_all(&count_u32(graph.nodes.len(), "nodes")?.to_le_bytes())?;
    for node in &graph.nodes {
        w.write_all(&count_u32(node.points.len(), "points")?.to_le_bytes())?;
        for p in &node.points {
            write_vector3(w, &p.coords)?;
        }
        write_pose(w, &node.pose)?;
        w.write_all(&node.id.to_le_bytes())?;
    }
    w.write_all(&count_u32(graph.edges.len(), "edges")?.to_le_bytes())?;
    for e in &graph.edges {
        w.write_all(&e.first.to_le_bytes())?;
        w.write_all(&e.second.to_le_bytes())?;
        write_pose(w, &e.constraint)?;
        w.write_all(&e.weight.to_le_bytes())?;
    }
    Ok(())
}

/// Write `graph` to `path` atomically (temporary file, then rename).
pub fn write_graph_file(path: &Path, graph: &ScanGraph) -> Result<(), FormatError> {
    crate::output::write_atomic(path, |w| write_graph(w, graph)).map_err(|e| match e {
        crate::output::OutputError::Io { source, .. } => FormatError::Write {
            path: path.to_path_buf(),
            source,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identity_pose_only_translates() {
        let pose = Pose6D::from_translation(Vector3::new(1.0, 0.0, -0.5));
        let p = pose.transform(&Point3::new(4.01, 0.01, 0.01));
        assert_eq!(p, Point3::new(5.01f32, 0.01, -0.49));
        assert_eq!(pose.graph2tree_origin(), Point3::new(1.0, 0.0, -0.5));
    }

    #[test]
    fn euler_yaw_quarter_turn() {
        let q = quaternion_from_euler(0.0, 0.0, std::f64::consts::FRAC_PI_2);
        let v = rotate(&q, &Vector3::new(1.0, 0.0, 0.0));
        assert!((v - Vector3::new(0.0, 1.0, 0.0)).norm() < 1e-6, "{v:?}");
    }

    #[test]
    fn non_unit_quaternion_scales() {
        // OctoMap does not normalise: q = 2·identity scales by |q|² = 4.
        let v = rotate(
            &Quaternion::new(2.0, 0.0, 0.0, 0.0),
            &Vector3::new(1.0, 2.0, 3.0),
        );
        assert_eq!(v, Vector3::new(4.0, 8.0, 12.0));
    }

    #[test]
    fn write_then_parse_round_trips() {
        let g = ScanGraph {
            nodes: vec![ScanNode {
                id: 7,
                pose: Pose6D::from_euler(Vector3::new(1.0, 2.0, 3.0), 0.1, -0.2, 0.3),
                points: vec![
                    Point3::new(1.5, -2.25, 1e-3),
                    Point3::new(f32::NAN, 0.0, 0.0),
                ],
            }],
            edges: vec![ScanEdge {
                first: 7,
                second: 7,
                constraint: Pose6D::default(),
                weight: 0.5,
            }],
        };
        let mut bytes = Vec::new();
        write_graph(&mut bytes, &g).ok();
        assert_eq!(bytes.len(), 4 + 4 + 2 * 28 + 64 + 4 + 4 + 8 + 64 + 8);
        let back = parse_graph(Path::new("t.graph"), &bytes);
        let back = back.as_ref().map(|b| &b.nodes[0]);
        assert!(matches!(back, Ok(n) if n.id == 7 && n.points[0] == g.nodes[0].points[0]));
    }

    #[test]
    fn absurd_point_count_is_an_error_not_an_allocation() {
        let mut bytes = 1u32.to_le_bytes().to_vec();
        bytes.extend_from_slice(&u32::MAX.to_le_bytes());
        let e = parse_graph(Path::new("bad.graph"), &bytes);
        assert!(matches!(e, Err(FormatError::Truncated { .. })));
    }
}
