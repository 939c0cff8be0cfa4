//! OctoMap ScanGraph `.graph` files (`ScanGraph::readBinary` / `writeBinary`), their poses in
//! OctoMap's exact `f32` arithmetic ([`Pose6D`], from [`crate::pose`]).
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
use crate::frame::Frame;
use crate::output::write_atomic;
use crate::source::{read_all, ByteReader, FieldStream, Fields, RecordProgress};
use nalgebra::{Point3, Quaternion, Vector3};
use std::io::{self, Write};
use std::path::Path;

pub use crate::pose::{quaternion_from_euler, rotate, Pose6D};

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

fn read_vector3(r: &mut impl Fields, what: &str) -> Result<Vector3<f32>, FormatError> {
    let tag = r.i32(what)?;
    if tag != 3 {
        return Err(r.error_back(4, format!("{what}: element count {tag}, expected 3")));
    }
    let x = r.f64(what)? as f32;
    let y = r.f64(what)? as f32;
    let z = r.f64(what)? as f32;
    Ok(Vector3::new(x, y, z))
}

fn read_pose(r: &mut impl Fields, what: &str) -> Result<Pose6D, FormatError> {
    let translation = read_vector3(r, what)?;
    let tag = r.i32(what)?;
    if tag != 4 {
        return Err(r.error_back(
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

/// What follows node `i`'s points: its pose and id.
fn read_node_tail(r: &mut impl Fields, i: u32) -> Result<(Pose6D, u32), FormatError> {
    let pose = read_pose(r, &format!("pose of node {i}"))?;
    let id = r.u32(&format!("id of node {i}"))?;
    Ok((pose, id))
}

/// Edge `i`.
fn read_edge(r: &mut impl Fields, i: u32) -> Result<ScanEdge, FormatError> {
    let what = format!("edge {i}");
    let first = r.u32(&what)?;
    let second = r.u32(&what)?;
    let constraint = read_pose(r, &what)?;
    let weight = r.f64(&what)?;
    Ok(ScanEdge {
        first,
        second,
        constraint,
        weight,
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
        let (pose, id) = read_node_tail(&mut r, i)?;
        nodes.push(ScanNode { id, pose, points });
    }
    let n_edges = r.u32("edge count")?;
    let mut edges = Vec::with_capacity(r.capacity_for(n_edges.into(), 8 + POSE_BYTES + 8));
    for i in 0..n_edges {
        edges.push(read_edge(&mut r, i)?);
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
        .map(|node| node_frame(&node.pose, node.points.clone(), options))
        .collect()
}

/// The frame graph2tree inserts for a node with `pose` and `points` (see [`graph_to_frames`]).
fn node_frame(pose: &Pose6D, mut points: Vec<Point3<f32>>, options: &GraphOptions) -> Frame {
    if options.points_global {
        Frame::new_f32(Point3::from(pose.translation), points)
    } else {
        for p in &mut points {
            *p = pose.transform(p);
        }
        Frame::new_f32(pose.graph2tree_origin(), points)
    }
}

/// Read a `.graph` file straight into frames (see [`graph_to_frames`]), one node at a time
/// ([`graph_file_stream`]): the file's bytes are never all in memory.
pub fn read_graph_frames(path: &Path, options: &GraphOptions) -> Result<Vec<Frame>, FormatError> {
    graph_file_stream(path, options)?.collect()
}

/// A `.graph` file (optionally `.gz`/`.bz2`) read one node at a time as frames (what
/// [`graph_to_frames`] gives for [`read_graph`]'s graph): only the node being read is in
/// memory. The edges after the nodes are checked when the last frame has been read, and any
/// error ends the stream. A damaged file fails as [`parse_graph`] fails, though not always
/// with the same message (a stream cannot see that a node's points run past the end of the
/// file before reading them).
pub fn graph_file_stream(path: &Path, options: &GraphOptions) -> Result<GraphStream, FormatError> {
    let mut fields = FieldStream::open(path)?;
    let count = fields.u32("node count")?;
    Ok(GraphStream {
        fields,
        options: *options,
        progress: RecordProgress::new(count),
    })
}

/// The frames of a `.graph` file, read as they are asked for ([`graph_file_stream`]), or
/// passed over without reading their points ([`GraphStream::skip_frames`]).
pub struct GraphStream {
    fields: FieldStream,
    options: GraphOptions,
    progress: RecordProgress,
}

/// Node `i`, read whole: its pose and its points (its id is read and dropped: frames have none).
fn read_node(s: &mut FieldStream, i: u32) -> Result<(Pose6D, Vec<Point3<f32>>), FormatError> {
    let n = s.u32(&format!("point count of node {i}"))?;
    let start = s.pos();
    let needed = u64::from(n) * POINT_BYTES as u64;
    let what = || format!("{n} points of node {i}");
    // as `parse_graph`: points the file cannot hold are a truncation, whatever they hold
    if s.remaining().is_some_and(|left| left < needed) {
        s.skip(needed, &what())?;
    }
    // the points grow as they arrive: a count read from the file allocates nothing
    let mut points = Vec::new();
    for _ in 0..n {
        match read_vector3(s, "point") {
            Ok(v) => points.push(Point3::from(v)),
            // cut short: named as `parse_graph` names it
            Err(FormatError::Truncated { .. }) => return Err(s.truncated(&what(), needed, start)),
            Err(e) => return Err(e),
        }
    }
    let (pose, _) = read_node_tail(s, i)?;
    Ok((pose, points))
}

/// Node `i` passed over: its point count, pose and id read, its points skipped.
fn skip_node(s: &mut FieldStream, i: u32) -> Result<(), FormatError> {
    let n = s.u32(&format!("point count of node {i}"))?;
    let what = format!("{n} points of node {i}");
    s.skip(u64::from(n) * POINT_BYTES as u64, &what)?;
    read_node_tail(s, i).map(drop)
}

/// After the last node: the edges, then nothing.
fn finish_graph(s: &mut FieldStream) -> Result<(), FormatError> {
    let n_edges = s.u32("edge count")?;
    for i in 0..n_edges {
        read_edge(s, i)?;
    }
    s.check_end("the graph")
}

impl GraphStream {
    /// Pass over the next `n` frames (fewer when the file announces fewer), returning how
    /// many were passed: each node's point count, pose and id are read, and its points are
    /// skipped (an uncompressed file seeks over them), so a slice of a large graph costs
    /// about what its own nodes cost. Errors inside skipped points are not seen; a file cut
    /// short is the truncation error reading gives, and ends the stream.
    pub fn skip_frames(&mut self, n: usize) -> Result<usize, FormatError> {
        self.progress.skip(&mut self.fields, n, skip_node)
    }
}

impl Iterator for GraphStream {
    type Item = Result<Frame, FormatError>;

    fn next(&mut self) -> Option<Self::Item> {
        let options = &self.options;
        self.progress.next_item(
            &mut self.fields,
            |s, i| read_node(s, i).map(|(pose, points)| node_frame(&pose, points, options)),
            finish_graph,
        )
    }

    /// The nodes the header still announces (and perhaps the error of the end).
    fn size_hint(&self) -> (usize, Option<usize>) {
        self.progress.size_hint()
    }
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
    Ok(write_atomic(path, |w| write_graph(w, graph))?)
}

#[cfg(test)]
mod tests {
    use super::*;

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
