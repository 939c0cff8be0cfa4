use super::*;

fn k(x: u16, y: u16, z: u16) -> Key {
    Key::new(x, y, z)
}

/// The eight voxels of the depth-15 node holding `base` (`base` even on every axis).
fn siblings(base: Key) -> [Key; 8] {
    std::array::from_fn(|i| {
        k(
            base.x() + (i & 1) as u16,
            base.y() + (i >> 1 & 1) as u16,
            base.z() + (i >> 2 & 1) as u16,
        )
    })
}

#[test]
fn prune_keeps_child_zero_white_else_averages() {
    let base = k(32768, 32768, 32768);
    let vox = siblings(base);
    let mut t = ColorOcTree::new(0.1).unwrap();
    for v in vox {
        t.set_node_value(v, 1.0, InnerNodes::Defer).unwrap();
    }
    // child 0 white, others coloured: the parent keeps child 0's white
    for (i, v) in vox.iter().enumerate().skip(1) {
        t.set_node_color(*v, Color::new(i as u8, 0, 0));
    }
    let mut a = t.clone();
    a.prune();
    assert_eq!(a.size(), t.size() - 8);
    assert_eq!(a.node_color(vox[3]), Some(Color::WHITE));
    assert_eq!(a.num_colored_nodes(), 0);
    // child 0 coloured: the average of the coloured children
    t.set_node_color(vox[0], Color::new(100, 8, 16));
    t.prune();
    // (100 + 1 + ... + 7) / 8 = 16, 8 / 8 = 1, 16 / 8 = 2
    assert_eq!(t.node_color(vox[5]), Some(Color::new(16, 1, 2)));
    assert_eq!(t.num_colored_nodes(), 1);
}

#[test]
fn expansion_copies_colour_and_eager_prune_restores_it() {
    let base = k(100, 200, 300);
    let mut t = ColorOcTree::new(0.1).unwrap();
    for v in siblings(base) {
        t.set_node_value(v, 2.0, InnerNodes::Refresh).unwrap();
    }
    let before = t.size();
    assert_eq!(t.search(base, 16).unwrap().node.depth, 15);
    t.set_node_color(base, Color::new(1, 2, 3));
    // changing one voxel expands the pruned node: every child gets its colour
    t.update_node(base, Update::Miss, InnerNodes::Refresh);
    assert_eq!(t.size(), before + 8);
    for v in siblings(base) {
        assert_eq!(t.node_color(v), Some(Color::new(1, 2, 3)));
    }
    t.set_node_value(base, 2.0, InnerNodes::Refresh).unwrap();
    assert_eq!(t.size(), before);
    assert_eq!(t.node_color(base), Some(Color::new(1, 2, 3)));
    assert_eq!(t.num_colored_nodes(), 1);
}

#[test]
fn colour_ops_in_unknown_space_change_nothing() {
    let mut t = ColorOcTree::new(0.1).unwrap();
    assert_eq!(t.set_node_color(k(1, 2, 3), Color::new(0, 0, 0)), None);
    t.update_node(k(1, 2, 3), Update::Hit, InnerNodes::Refresh);
    assert_eq!(
        t.integrate_node_color(k(1, 2, 5), Color::new(0, 0, 0)),
        None
    );
    assert_eq!(t.num_colored_nodes(), 0);
}

#[test]
fn delete_forgets_colours() {
    let mut t = ColorOcTree::new(0.1).unwrap();
    let v = k(10, 10, 10);
    t.update_node(v, Update::Hit, InnerNodes::Refresh);
    t.set_node_color(v, Color::new(9, 9, 9));
    t.update_inner_occupancy();
    assert!(t.num_colored_nodes() > 1);
    assert!(t.delete_node(v, 16));
    // the root stays, with its colour; the deleted path has none left
    assert_eq!(t.num_colored_nodes(), 1);
    // the childless root is expanded by the next update (as OctoMap does): the new path
    // inherits the root's colour, not the deleted voxel's
    t.set_node_color(v, Color::new(7, 7, 7));
    t.update_node(v, Update::Hit, InnerNodes::Refresh);
    assert_eq!(t.node_color(v), Some(Color::new(7, 7, 7)));
    assert_eq!(t.node_color(k(40000, 10, 10)), Some(Color::new(7, 7, 7)));
}

#[test]
fn colours_at_a_depth_and_average_of_children() {
    let base = k(1000, 2000, 3000);
    let vox = siblings(base);
    let mut t = ColorOcTree::new(0.1).unwrap();
    // three of the eight children exist, two coloured
    for v in &vox[..3] {
        t.set_node_value(*v, 1.0, InnerNodes::Defer).unwrap();
    }
    t.set_node_color(vox[1], Color::new(10, 20, 31));
    t.set_node_color(vox[2], Color::new(0, 1, 2));
    assert_eq!(t.color_at(base, 16), Some(Color::WHITE));
    assert_eq!(t.color_at(vox[1], 16), Some(Color::new(10, 20, 31)));
    assert_eq!(t.average_child_color(base, 15), Some(Color::new(5, 10, 16)));
    assert_eq!(t.average_child_color(vox[1], 16), Some(Color::WHITE));
    // the inner node's own colour is separate from its children's
    assert_eq!(t.color_at(base, 15), Some(Color::WHITE));
    assert!(t.set_color_at(base, 15, Color::new(7, 7, 7)));
    assert_eq!(t.color_at(base, 15), Some(Color::new(7, 7, 7)));
    assert_eq!(t.node_color(vox[0]), Some(Color::WHITE));
    // no node there: nothing changes
    let far = k(9, 9, 9);
    assert_eq!(t.color_at(far, 16), None);
    assert_eq!(t.average_child_color(far, 10), None);
    assert!(!t.set_color_at(far, 16, Color::new(1, 1, 1)));
    assert_eq!(t.num_colored_nodes(), 3);
}

/// A run of colours merged with one search is the same as merging them one call at a time,
/// for both rules, a run passing through white (no colour) included, into a voxel and into
/// a pruned leaf; in unknown space a run changes nothing.
#[test]
fn colour_runs_are_single_merges_in_turn() {
    let runs: [&[Color]; 4] = [
        &[Color::new(10, 200, 30)],
        &[
            Color::new(0, 0, 0),
            Color::new(255, 255, 255),
            Color::new(90, 7, 255),
        ],
        &[Color::WHITE, Color::WHITE],
        &[
            Color::new(255, 255, 253),
            Color::new(255, 255, 255),
            Color::new(1, 2, 3),
            Color::new(200, 100, 50),
        ],
    ];
    let base = k(32768, 32768, 32768);
    for integrate in [false, true] {
        let (mut one, mut many) = (
            ColorOcTree::new(0.1).unwrap(),
            ColorOcTree::new(0.1).unwrap(),
        );
        for t in [&mut one, &mut many] {
            t.update_node(base, Update::Hit, InnerNodes::Refresh);
            for s in siblings(k(32770, 32768, 32768)) {
                t.update_node(s, Update::Hit, InnerNodes::Refresh);
            }
            t.prune();
        }
        for (i, run) in runs.iter().enumerate() {
            let key = if i % 2 == 0 {
                base
            } else {
                k(32771, 32769, 32768)
            };
            let mut last = None;
            for &c in *run {
                last = if integrate {
                    one.integrate_node_color(key, c)
                } else {
                    one.average_node_color(key, c)
                };
            }
            let got = if integrate {
                many.integrate_node_colors(key, run.iter().copied())
            } else {
                many.average_node_colors(key, run.iter().copied())
            };
            assert_eq!(got, last, "run {i}, integrate {integrate}");
            assert_eq!(many.node_color(key), one.node_color(key));
        }
        assert_eq!(
            many.average_node_colors(k(100, 100, 100), runs[1].iter().copied()),
            None
        );
        assert!(many.node_color(k(100, 100, 100)).is_none());
    }
}

/// Node surgery as OctoMap defines it on a `ColorOcTree`: `expandNode` copies the node's
/// colour to its eight new children (`copyData`), `pruneNode` collapses children of equal
/// occupancy whatever their colours (child 0's colour, the average when child 0 has one),
/// `createNodeChild` makes a white child, and `deleteNodeChild` takes the subtree's colours
/// with it.
#[test]
fn node_surgery_follows_the_colour_rules() {
    let base = k(32768, 32768, 32768);
    let vox = siblings(base);
    let mut t = ColorOcTree::new(0.1).unwrap();
    for v in vox {
        t.set_node_value(v, 1.0, InnerNodes::Refresh).unwrap();
    }
    // eight equal voxels were pruned into their depth-15 parent as they were set
    let leaf = t.search(base, TREE_DEPTH).unwrap();
    assert_eq!(leaf.node.depth, 15);
    t.set_color_at(base, 15, Color::new(10, 20, 30));
    assert!(!t.is_node_collapsible(base, 15), "no children");
    assert!(t.expand_node(base, 15));
    assert!(!t.expand_node(base, 15), "has children now");
    assert!(!t.expand_node(base, 16), "a voxel");
    for (i, v) in vox.iter().enumerate() {
        let c = t.node_child(base, 15, i).unwrap();
        assert_eq!((c.node.depth, c.color), (16, Color::new(10, 20, 30)));
        assert_eq!(t.node_at_depth(*v, 16), Some(c));
    }
    // other colours below: still collapsible, and child 0 is coloured, so the average
    t.set_color_at(vox[1], 16, Color::new(90, 20, 30));
    assert!(t.is_node_collapsible(base, 15));
    assert!(t.prune_node(base, 15));
    assert_eq!(t.node_color(vox[7]), Some(Color::new(20, 20, 30)));
    assert_eq!(t.num_colored_nodes(), 1);
    // a new child is white and has log-odds 0; its deletion takes its colour
    assert!(t.expand_node(base, 15));
    let size = t.size();
    assert!(t.create_node_child(base, 15, 0).is_none(), "exists");
    assert_eq!(t.delete_node_child(base, 15, 0), 1);
    assert_eq!(t.size(), size - 1);
    assert_eq!(t.num_colored_nodes(), 8, "the parent and seven children");
    assert!(!t.is_node_collapsible(base, 15), "a child is missing");
    assert!(!t.prune_node(base, 15));
    let c = t.create_node_child(base, 15, 0).unwrap();
    assert_eq!((c.node.value, c.color), (0.0, Color::WHITE));
    assert!(!t.is_node_collapsible(base, 15), "log-odds differ");
    assert_eq!(t.delete_node_child(base, 15, 0), 1);
    assert_eq!(t.delete_node_child(base, 15, 0), 0, "gone");
    // a whole subtree: the depth-14 node's child holding `base` goes with its eight voxels
    let up = base.at_depth(14);
    let i = base.child_index(14);
    assert_eq!(t.delete_node_child(up, 14, i), 8);
    assert_eq!(t.num_colored_nodes(), 0);
    assert!(t.node_at_depth(base, 15).is_none());
}
