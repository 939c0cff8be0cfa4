//! Property tests of `ColorOcTree` against a naive oracle: a plain pointer octree written
//! straight from OctoMap 1.9.7's definitions (`updateNodeRecurs`, `setNodeValueRecurs`,
//! `ColorOcTree::pruneNode`, `expandNode`, `prune`, `expand`, `toMaxLikelihood`,
//! `ColorOcTree::updateInnerOccupancy`, `setNodeColor`, `averageNodeColor`,
//! `integrateNodeColor`). Both serialise their nodes in `.ot` order; the bodies must be equal.

use octoquant_octree::io::{read_color_ot, write_color_ot};
use octoquant_octree::{Color, ColorOcTree, InnerNodes, Key, OccupancyParams, Update};
use proptest::prelude::*;

const WHITE: [u8; 3] = [255, 255, 255];

/// An OctoMap `ColorOcTreeNode`: log-odds, colour, optional array of eight children.
#[derive(Clone)]
struct Node {
    v: f32,
    c: [u8; 3],
    kids: Option<Box<[Option<Node>; 8]>>,
}

impl Node {
    fn new() -> Self {
        Node {
            v: 0.0,
            c: WHITE,
            kids: None,
        }
    }
    fn has_kids(&self) -> bool {
        self.kids
            .as_ref()
            .is_some_and(|k| k.iter().any(|c| c.is_some()))
    }
}

fn idx(key: Key, depth: u32) -> usize {
    let bit = 15 - depth;
    ((key.x() >> bit & 1) | (key.y() >> bit & 1) << 1 | (key.z() >> bit & 1) << 2) as usize
}

fn is_set(c: [u8; 3]) -> bool {
    c != WHITE
}

/// `getAverageChildColor`.
fn avg_child_color(n: &Node) -> [u8; 3] {
    let mut s = [0i32; 3];
    let mut cnt = 0;
    if let Some(k) = &n.kids {
        for ch in k.iter().flatten() {
            if is_set(ch.c) {
                for (sum, v) in s.iter_mut().zip(ch.c) {
                    *sum += v as i32;
                }
                cnt += 1;
            }
        }
    }
    if cnt == 0 {
        WHITE
    } else {
        s.map(|x| (x / cnt) as u8)
    }
}

struct Oracle {
    root: Option<Node>,
    p: OccupancyParams,
}

impl Oracle {
    /// `expandNode`: eight children copying the node's data.
    fn expand_node(n: &mut Node) {
        let copy = Node {
            v: n.v,
            c: n.c,
            kids: None,
        };
        n.kids = Some(Box::new(std::array::from_fn(|_| Some(copy.clone()))));
    }

    /// `ColorOcTree::pruneNode`.
    fn prune_node(n: &mut Node) -> bool {
        let Some(k) = &n.kids else { return false };
        let Some(first) = &k[0] else { return false };
        if first.has_kids() {
            return false;
        }
        for ch in k.iter() {
            match ch {
                Some(ch) if !ch.has_kids() && ch.v == first.v => {}
                _ => return false,
            }
        }
        n.v = first.v;
        n.c = first.c;
        if is_set(n.c) {
            n.c = avg_child_color(n);
        }
        n.kids = None;
        true
    }

    fn max_child(n: &Node) -> f32 {
        let mut m = f32::NEG_INFINITY;
        for ch in n.kids.as_ref().unwrap().iter().flatten() {
            if ch.v > m {
                m = ch.v;
            }
        }
        m
    }

    fn search(&self, key: Key) -> Option<&Node> {
        let mut n = self.root.as_ref()?;
        for d in 0..16 {
            if !n.has_kids() {
                return Some(n);
            }
            n = n.kids.as_ref().unwrap()[idx(key, d)].as_ref()?;
        }
        Some(n)
    }

    fn search_mut(&mut self, key: Key) -> Option<&mut Node> {
        let mut n = self.root.as_mut()?;
        for d in 0..16 {
            if !n.has_kids() {
                return Some(n);
            }
            n = n.kids.as_mut().unwrap()[idx(key, d)].as_mut()?;
        }
        Some(n)
    }

    /// `updateNodeRecurs` / `setNodeValueRecurs`: `leaf` changes the voxel's value.
    fn recurs(
        n: &mut Node,
        just_created: bool,
        key: Key,
        depth: u32,
        lazy: bool,
        leaf: &dyn Fn(f32) -> f32,
    ) {
        if depth < 16 {
            let pos = idx(key, depth);
            let mut created = false;
            let exists = n.kids.as_ref().is_some_and(|k| k[pos].is_some());
            if !exists {
                if !n.has_kids() && !just_created {
                    Self::expand_node(n);
                } else {
                    n.kids
                        .get_or_insert_with(|| Box::new(std::array::from_fn(|_| None)))[pos] =
                        Some(Node::new());
                    created = true;
                }
            }
            let ch = n.kids.as_mut().unwrap()[pos].as_mut().unwrap();
            Self::recurs(ch, created, key, depth + 1, lazy, leaf);
            if !lazy && !Self::prune_node(n) {
                n.v = Self::max_child(n);
            }
        } else {
            n.v = leaf(n.v);
        }
    }

    fn descend(&mut self, key: Key, lazy: bool, leaf: &dyn Fn(f32) -> f32) {
        let created = self.root.is_none();
        let root = self.root.get_or_insert_with(Node::new);
        Self::recurs(root, created, key, 0, lazy, leaf);
    }

    fn update(&mut self, key: Key, delta: f32, lazy: bool) {
        let (lo, hi) = (self.p.clamp_min, self.p.clamp_max);
        if let Some(n) = self.search(key) {
            if (delta >= 0.0 && n.v >= hi) || (delta <= 0.0 && n.v <= lo) {
                return;
            }
        }
        self.descend(key, lazy, &|v| {
            let v = v + delta;
            if v < lo {
                lo
            } else if v > hi {
                hi
            } else {
                v
            }
        });
    }

    fn set(&mut self, key: Key, value: f32, lazy: bool) {
        let v = value.max(self.p.clamp_min).min(self.p.clamp_max);
        self.descend(key, lazy, &|_| v);
    }

    fn prune(&mut self) {
        fn recurs(n: &mut Node, depth: u32, max: u32, count: &mut usize) {
            if depth < max {
                if let Some(k) = n.kids.as_mut() {
                    for ch in k.iter_mut().flatten() {
                        recurs(ch, depth + 1, max, count);
                    }
                }
            } else if Oracle::prune_node(n) {
                *count += 1;
            }
        }
        let Some(root) = self.root.as_mut() else {
            return;
        };
        for depth in (1..16).rev() {
            let mut count = 0;
            recurs(root, 0, depth, &mut count);
            if count == 0 {
                break;
            }
        }
    }

    fn expand(&mut self) {
        fn recurs(n: &mut Node, depth: u32) {
            if depth >= 16 {
                return;
            }
            if !n.has_kids() {
                Oracle::expand_node(n);
            }
            for ch in n.kids.as_mut().unwrap().iter_mut().flatten() {
                recurs(ch, depth + 1);
            }
        }
        if let Some(r) = self.root.as_mut() {
            recurs(r, 0);
        }
    }

    fn max_likelihood(&mut self) {
        fn recurs(n: &mut Node, p: &OccupancyParams) {
            n.v = if n.v >= p.occupancy_threshold {
                p.clamp_max
            } else {
                p.clamp_min
            };
            if let Some(k) = n.kids.as_mut() {
                for ch in k.iter_mut().flatten() {
                    recurs(ch, p);
                }
            }
        }
        let p = self.p;
        if let Some(r) = self.root.as_mut() {
            recurs(r, &p);
        }
    }

    fn inner(&mut self) {
        fn recurs(n: &mut Node) {
            if n.has_kids() {
                for ch in n.kids.as_mut().unwrap().iter_mut().flatten() {
                    recurs(ch);
                }
                n.v = Oracle::max_child(n);
                n.c = avg_child_color(n);
            }
        }
        if let Some(r) = self.root.as_mut() {
            recurs(r);
        }
    }

    fn color(&mut self, op: u8, key: Key, c: [u8; 3]) {
        let Some(n) = self.search_mut(key) else {
            return;
        };
        let prev = n.c;
        n.c = match op {
            0 => c,
            _ if !is_set(prev) => c,
            1 => std::array::from_fn(|a| ((prev[a] as i32 + c[a] as i32) / 2) as u8),
            _ => {
                let p = 1.0 - 1.0 / (1.0 + (n.v as f64).exp());
                std::array::from_fn(|a| {
                    (prev[a] as f64 * p + c[a] as f64 * (0.99 - p)) as i32 as u8
                })
            }
        };
    }

    /// The `.ot` body: per node value, colour, child mask, pre-order; and the node count.
    fn body(&self) -> (Vec<u8>, usize) {
        fn recurs(n: &Node, out: &mut Vec<u8>, count: &mut usize) {
            *count += 1;
            out.extend_from_slice(&n.v.to_le_bytes());
            out.extend_from_slice(&n.c);
            let mut mask = 0u8;
            if let Some(k) = &n.kids {
                for (i, ch) in k.iter().enumerate() {
                    if ch.is_some() {
                        mask |= 1 << i;
                    }
                }
            }
            out.push(mask);
            if let Some(k) = &n.kids {
                for ch in k.iter().flatten() {
                    recurs(ch, out, count);
                }
            }
        }
        let mut out = Vec::new();
        let mut count = 0;
        if let Some(r) = &self.root {
            recurs(r, &mut out, &mut count);
        }
        (out, count)
    }
}

#[derive(Debug, Clone)]
enum Op {
    Update(Key, bool, bool),
    /// Five updates of each of the eight voxels of the depth-15 node holding the key, so
    /// octants reach a clamp together and prune (with whatever colours they hold).
    Block(Key, bool, bool),
    Set(Key, f32, bool),
    Color(u8, Key, [u8; 3]),
    Prune,
    Expand,
    MaxLikelihood,
    Inner,
}

fn keys() -> impl Strategy<Value = Key> {
    prop_oneof![
        6 => (0u16..4, 0u16..4, 0u16..4)
            .prop_map(|(x, y, z)| Key::new(32766 + x, 32766 + y, 32766 + z)),
        2 => (0u16..16, 0u16..16, 0u16..16).prop_map(|(x, y, z)| Key::new(x, 100 + y, 65520 + z)),
        1 => any::<[u16; 3]>().prop_map(Key),
    ]
}

fn colors() -> impl Strategy<Value = [u8; 3]> {
    prop_oneof![
        Just(WHITE),
        Just([0, 0, 0]),
        Just([255, 255, 254]),
        any::<[u8; 3]>(),
        any::<[u8; 3]>(),
    ]
}

fn ops() -> impl Strategy<Value = Vec<Op>> {
    let op = prop_oneof![
        30 => (keys(), any::<bool>(), prop::bool::weighted(0.2))
            .prop_map(|(k, h, l)| Op::Update(k, h, l)),
        6 => (keys(), any::<bool>(), prop::bool::weighted(0.2))
            .prop_map(|(k, h, l)| Op::Block(k, h, l)),
        5 => (keys(), -3.0f32..3.0, prop::bool::weighted(0.2)).prop_map(|(k, v, l)| Op::Set(k, v, l)),
        25 => (0u8..3, keys(), colors()).prop_map(|(o, k, c)| Op::Color(o, k, c)),
        2 => Just(Op::Prune),
        1 => Just(Op::Expand),
        1 => Just(Op::MaxLikelihood),
        2 => Just(Op::Inner),
    ];
    prop::collection::vec(op, 1..250)
}

/// The body of our `.ot` (after the `data` line) and the header's node count.
fn our_body(t: &ColorOcTree) -> (Vec<u8>, usize) {
    let mut bytes = Vec::new();
    write_color_ot(t, &mut bytes).unwrap();
    let tag = b"\ndata\n";
    let at = bytes.windows(tag.len()).position(|w| w == tag).unwrap() + tag.len();
    (bytes[at..].to_vec(), t.size())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    #[test]
    fn color_tree_matches_naive_octomap(ops in ops()) {
        let mut t = ColorOcTree::new(0.1).unwrap();
        let mut o = Oracle { root: None, p: *t.params() };
        for op in &ops {
            match *op {
                Op::Update(k, hit, lazy) => {
                    let u = if hit { Update::Hit } else { Update::Miss };
                    t.update_node(k, u, InnerNodes::from_lazy(lazy));
                    o.update(k, t.occupancy().delta(u), lazy);
                }
                Op::Block(k, hit, lazy) => {
                    let u = if hit { Update::Hit } else { Update::Miss };
                    for _ in 0..5 {
                        for i in 0..8u16 {
                            let v = Key::new(
                                k.x() & !1 | (i & 1),
                                k.y() & !1 | (i >> 1 & 1),
                                k.z() & !1 | (i >> 2 & 1),
                            );
                            t.update_node(v, u, InnerNodes::from_lazy(lazy));
                            o.update(v, t.occupancy().delta(u), lazy);
                        }
                    }
                }
                Op::Set(k, v, lazy) => {
                    t.set_node_value(k, v, InnerNodes::from_lazy(lazy)).unwrap();
                    o.set(k, v, lazy);
                }
                Op::Color(which, k, c) => {
                    let col = Color::new(c[0], c[1], c[2]);
                    let got = match which {
                        0 => t.set_node_color(k, col),
                        1 => t.average_node_color(k, col),
                        _ => t.integrate_node_color(k, col),
                    };
                    o.color(which, k, c);
                    let want = o.search(k).map(|n| Color::new(n.c[0], n.c[1], n.c[2]));
                    prop_assert_eq!(got, want);
                }
                Op::Prune => { t.prune(); o.prune(); }
                Op::Expand => { t.expand(); o.expand(); }
                Op::MaxLikelihood => { t.to_max_likelihood(); o.max_likelihood(); }
                Op::Inner => { t.update_inner_occupancy(); o.inner(); }
            }
        }
        let (ours, our_size) = our_body(&t);
        let (theirs, their_size) = o.body();
        prop_assert_eq!(our_size, their_size);
        prop_assert!(ours == theirs, "bodies differ ({} vs {} bytes)", ours.len(), theirs.len());
        // the file reads back to the same tree
        let mut bytes = Vec::new();
        write_color_ot(&t, &mut bytes).unwrap();
        let back = read_color_ot(&bytes[..]).unwrap();
        prop_assert_eq!(our_body(&back), (ours, our_size));
        prop_assert_eq!(back.num_colored_nodes(), t.num_colored_nodes());
    }
}
