//! Memory and time bounds of the `.bt` / `.ot` readers on hostile input: headers that claim
//! 2^32 nodes, absurd sizes in the legacy header, huge header lines and token counts, and the
//! widest trees the depth limit allows. Peak memory is measured by a counting global
//! allocator, work by a counting `Read` wrapper (bytes and calls pulled from the input) and
//! by the bytes allocated in all.

use octoquant_alloc_count::{measure, serial, CountingAlloc};
use octoquant_octree::io::{read_bt, read_ot, read_tree};
use octoquant_octree::OcTree;
use std::io::Read;

#[global_allocator]
static ALLOC: CountingAlloc = CountingAlloc;

/// A reader over bytes that counts what is pulled from it.
struct CountingRead<'a> {
    data: &'a [u8],
    bytes: u64,
    calls: u64,
}

impl Read for CountingRead<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        self.calls += 1;
        let n = self.data.len().min(buf.len());
        buf[..n].copy_from_slice(&self.data[..n]);
        self.data = &self.data[n..];
        self.bytes += n as u64;
        Ok(n)
    }
}

/// What one read cost.
#[derive(Debug)]
struct Cost {
    /// Most bytes live at once beyond those live before.
    peak: usize,
    /// Bytes allocated in all.
    total: u64,
    /// Bytes pulled from the input.
    bytes: u64,
    /// `read` calls on the input.
    calls: u64,
}

type Reader = fn(&mut CountingRead<'_>) -> Result<OcTree, octoquant_octree::OctreeError>;

fn run(read: Reader, input: &[u8]) -> (Result<OcTree, String>, Cost) {
    let mut r = CountingRead {
        data: input,
        bytes: 0,
        calls: 0,
    };
    let (out, alloc) = measure(|| read(&mut r).map_err(|e| e.to_string()));
    let cost = Cost {
        peak: alloc.peak,
        total: alloc.total,
        bytes: r.bytes,
        calls: r.calls,
    };
    (out, cost)
}

const BT: Reader = |r| read_bt(r);
const OT: Reader = |r| read_ot(r);
const ANY: Reader = |r| read_tree(r);

/// Fixed allowance: the 64 KiB read buffer, an empty tree, error strings.
const SLACK: usize = 1 << 20;

/// Bytes read and calls made: each input byte pulled at most once, in 64 KiB reads.
fn assert_streamed(cost: &Cost, len: usize) {
    assert!(cost.bytes <= len as u64, "{cost:?} for {len} bytes");
    assert!(
        cost.calls <= len as u64 / (1 << 16) + 4,
        "{cost:?}: unbuffered reads for {len} bytes"
    );
}

fn refused(read: Reader, input: &[u8], want: &str) -> Cost {
    let (r, cost) = run(read, input);
    let e = r.err().unwrap_or_else(|| panic!("accepted: {want}"));
    assert!(e.contains(want), "error lacks {want:?}: {e}");
    assert!(
        cost.peak <= 4 * input.len() + SLACK,
        "{cost:?} for {} bytes",
        input.len()
    );
    assert_streamed(&cost, input.len());
    cost
}

fn header(first: &str, size: u64) -> Vec<u8> {
    format!("{first}\n# comment\nid OcTree\nsize {size}\nres 0.1\ndata\n").into_bytes()
}

#[test]
fn bt_claiming_2_pow_32_nodes() {
    let _serial = serial();
    let mut b = header("# Octomap OcTree binary file", 1 << 32);
    b.extend_from_slice(&[0xaa, 0xaa]); // eight occupied leaves
    refused(BT, &b, "header says 4294967296 nodes but the data holds 9");
    refused(ANY, &b, "header says 4294967296 nodes");
    // and a body cut short
    let mut b = header("# Octomap OcTree binary file", 1 << 32);
    b.extend_from_slice(&[0xff, 0xff, 0xff]);
    refused(BT, &b, "truncated");
}

#[test]
fn legacy_bt_claiming_2_pow_32_nodes() {
    let _serial = serial();
    let mut b = 3i32.to_le_bytes().to_vec();
    b.extend_from_slice(&0.1f64.to_le_bytes());
    b.extend_from_slice(&u32::MAX.to_le_bytes());
    b.extend_from_slice(&[0x55, 0x55]);
    refused(BT, &b, "header says 4294967295 nodes");
}

#[test]
fn ot_claiming_2_pow_32_nodes() {
    let _serial = serial();
    let mut b = header("# Octomap OcTree file", 1 << 32);
    b.extend_from_slice(&0.5f32.to_le_bytes());
    b.push(0xff);
    b.extend_from_slice(&[0u8; 7]);
    refused(OT, &b, "truncated");
    let mut b = header("# Octomap OcTree file", u64::MAX);
    b.extend_from_slice(&0.5f32.to_le_bytes());
    b.push(0);
    refused(OT, &b, "header says 18446744073709551615 nodes");
    // a size beyond u64 is not a node count
    let b = header("# Octomap OcTree file", 0);
    let b = String::from_utf8_lossy(&b).replace("size 0", "size 99999999999999999999999");
    refused(OT, b.as_bytes(), "not a node count");
}

#[test]
fn long_header_lines_and_many_tokens_stream_in_linear_work() {
    let _serial = serial();
    // 200000 unknown header lines, a 4 MiB comment, then a one-node tree
    let mut b = b"# Octomap OcTree binary file\n".to_vec();
    for _ in 0..200_000 {
        b.extend_from_slice(b"x 1\n");
    }
    b.extend_from_slice(b"# ");
    b.extend(std::iter::repeat_n(b'c', 4 << 20));
    b.extend_from_slice(b"\nid OcTree\nsize 9\nres 0.1\ndata\n\xaa\xaa");
    let (r, cost) = run(BT, &b);
    assert_eq!(r.map(|t| t.size()).ok(), Some(9));
    assert_streamed(&cost, b.len());
    assert!(cost.peak <= SLACK, "{cost:?}");
    assert!(
        cost.total <= 4 * b.len() as u64,
        "{cost:?} for {} bytes",
        b.len()
    );
    // a header token of 4 MiB is refused at 4 KiB
    let mut b = b"# Octomap OcTree binary file\n".to_vec();
    b.extend(std::iter::repeat_n(b't', 4 << 20));
    let (r, cost) = run(BT, &b);
    assert!(r.err().is_some_and(|e| e.contains("too long")));
    assert!(cost.bytes < 1 << 17, "{cost:?}");
}

/// A `.bt` body of a tree whose inner nodes all have eight inner children down to `depth`,
/// then eight occupied leaves.
fn full_bt(depth: u32) -> (Vec<u8>, u64) {
    fn node(out: &mut Vec<u8>, level: u32, depth: u32, nodes: &mut u64) {
        *nodes += 8;
        if level == depth {
            out.extend_from_slice(&[0xaa, 0xaa]);
        } else {
            out.extend_from_slice(&[0xff, 0xff]);
            for _ in 0..8 {
                node(out, level + 1, depth, nodes);
            }
        }
    }
    let mut body = Vec::new();
    let mut nodes = 1;
    node(&mut body, 0, depth, &mut nodes);
    (body, nodes)
}

#[test]
fn widest_trees_cost_memory_and_work_linear_in_the_input() {
    let _serial = serial();
    for depth in [3, 5] {
        let (body, nodes) = full_bt(depth);
        let mut b = header("# Octomap OcTree binary file", nodes);
        b.extend_from_slice(&body);
        let (r, cost) = run(BT, &b);
        assert_eq!(r.map(|t| t.size() as u64).ok(), Some(nodes));
        assert_streamed(&cost, b.len());
        // each 2-byte record creates a block of 8 children: a fixed number of bytes each
        // (about 64, up to three times that while the block arena grows)
        let records = body.len() / 2;
        assert!(
            cost.peak <= 256 * records + SLACK,
            "depth {depth}: {cost:?} for {records} records"
        );
        assert!(
            cost.total <= 512 * records as u64 + SLACK as u64,
            "depth {depth}: {cost:?} for {records} records"
        );
    }
}
