//! The voxel block storage against a naive model (plain `f32` blocks), with palette limits
//! small enough that the wide fallback and the way back to narrow storage are exercised.

use super::*;
use proptest::prelude::*;

/// A small set of values with repeats, both zeros and values that clamp.
const VALS: [f32; 9] = [0.0, -0.0, 0.85, -0.4, 1.7, -2.0, 3.5, 0.45, 1e-30];

#[derive(Debug, Clone)]
enum Op {
    Alloc,
    Release(usize),
    Set(usize, usize, usize),
    Remove(usize, usize),
    Zero(usize, usize),
    Fill(usize, usize),
    Update(usize, usize, usize, bool, bool),
    Map(bool),
    Compact(Vec<usize>),
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        3 => Just(Op::Alloc),
        1 => any::<usize>().prop_map(Op::Release),
        4 => (any::<usize>(), 0usize..8, 0usize..VALS.len()).prop_map(|(b, s, v)| Op::Set(b, s, v)),
        1 => (any::<usize>(), 0usize..8).prop_map(|(b, s)| Op::Remove(b, s)),
        1 => (any::<usize>(), 0usize..8).prop_map(|(b, s)| Op::Zero(b, s)),
        1 => (any::<usize>(), 0usize..VALS.len()).prop_map(|(b, v)| Op::Fill(b, v)),
        6 => (any::<usize>(), 0usize..8, 0usize..3, any::<bool>(), any::<bool>())
            .prop_map(|(b, s, d, twice, fresh)| Op::Update(b, s, d, twice, fresh)),
        1 => any::<bool>().prop_map(Op::Map),
        1 => prop::collection::vec(any::<usize>(), 0..6).prop_map(Op::Compact),
    ]
}

/// The naive storage: blocks of values, and which of them are in use.
struct Model {
    blocks: Vec<[f32; 8]>,
    live: Vec<bool>,
}

fn check(l: &VoxelBlocks, m: &Model) -> Result<(), TestCaseError> {
    prop_assert_eq!(l.live(), m.live.iter().filter(|&&x| x).count());
    for (b, want) in m.blocks.iter().enumerate() {
        let b32 = b as u32;
        let got = l.vals(b32);
        prop_assert_eq!(got.map(f32::to_bits), want.map(f32::to_bits), "block {}", b);
        for (s, w) in want.iter().enumerate() {
            prop_assert_eq!(l.get(b32, s).to_bits(), w.to_bits());
            prop_assert_eq!(l.is_present(b32, s), present(*w));
        }
        prop_assert_eq!(l.max(b32).to_bits(), max_present(want).to_bits());
        let v0 = want[0];
        let uniform = (present(v0) && want.iter().all(|&v| v == v0)).then_some(v0);
        prop_assert_eq!(l.uniform(b32).map(f32::to_bits), uniform.map(f32::to_bits));
    }
    if let View::Narrow(_, palette) = l.view() {
        prop_assert!(palette.len() <= palette.limit);
        prop_assert_eq!(palette.vals[0].to_bits(), ABSENT.to_bits());
        prop_assert_eq!(palette.vals[1].to_bits(), 0);
        // the hash index finds every value at its own index
        let mut p = palette.clone();
        for (i, v) in palette.values().iter().enumerate().skip(1) {
            prop_assert_eq!(p.intern(*v), Some(i as u16));
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    /// Every operation leaves the storage reading back what plain `f32` blocks hold,
    /// whether it is narrow, became wide on the way, or was compacted back to narrow.
    #[test]
    fn storage_matches_plain_blocks(limit in 1usize..8, ops in prop::collection::vec(op(), 1..120)) {
        let mut l = VoxelBlocks::new(limit);
        let mut m = Model { blocks: Vec::new(), live: Vec::new() };
        let deltas = [0.85f32, -0.4, 0.7];
        let (cmin, cmax) = (-2.0f32, 3.5f32);
        for op in ops {
            let live: Vec<usize> = (0..m.live.len()).filter(|&b| m.live[b]).collect();
            let pick = |i: usize| live.get(i % live.len().max(1)).copied();
            match op {
                Op::Alloc => {
                    let b = l.alloc() as usize;
                    if b == m.blocks.len() {
                        m.blocks.push([ABSENT; 8]);
                        m.live.push(false);
                    }
                    prop_assert!(!m.live[b], "allocated a live block");
                    prop_assert!(m.blocks[b].iter().all(|v| !present(*v)));
                    m.live[b] = true;
                }
                Op::Release(i) => if let Some(b) = pick(i) {
                    l.release(b as u32);
                    m.blocks[b] = [ABSENT; 8];
                    m.live[b] = false;
                },
                Op::Set(i, s, v) => if let Some(b) = pick(i) {
                    l.set(b as u32, s, VALS[v]);
                    m.blocks[b][s] = VALS[v];
                },
                Op::Remove(i, s) => if let Some(b) = pick(i) {
                    l.set(b as u32, s, ABSENT);
                    m.blocks[b][s] = ABSENT;
                },
                Op::Zero(i, s) => if let Some(b) = pick(i) {
                    l.set_zero(b as u32, s);
                    m.blocks[b][s] = 0.0;
                },
                Op::Fill(i, v) => if let Some(b) = pick(i) {
                    l.fill(b as u32, VALS[v]);
                    m.blocks[b] = [VALS[v]; 8];
                },
                Op::Update(i, s, d, twice, fresh) => if let Some(b) = pick(i) {
                    let add = l.adder(deltas[d], cmin, cmax);
                    let mut memo = l.take_memo(&add);
                    for round in 0..1 + usize::from(twice) {
                        // a fresh voxel is one just created: it holds 0
                        let fresh = fresh && round == 0;
                        if fresh {
                            l.set_zero(b as u32, s);
                            m.blocks[b][s] = 0.0;
                        }
                        let old = m.blocks[b][s];
                        let created = fresh || !present(old);
                        let want = if !created && add.exits_at(old) {
                            Outcome::Exit
                        } else {
                            let base = if created { 0.0 } else { old };
                            m.blocks[b][s] = (base + deltas[d]).clamp(cmin, cmax);
                            Outcome::Applied(created)
                        };
                        prop_assert_eq!(l.update(b as u32, s, &add, fresh, &mut memo), want);
                    }
                    l.put_memo(&add, memo);
                },
                Op::Map(ml) => {
                    let f = |v: f32| if ml { if v >= 0.0 { cmax } else { cmin } } else { v * 0.5 };
                    l.map_values(f);
                    for blk in &mut m.blocks {
                        for v in blk.iter_mut().filter(|v| present(**v)) {
                            *v = f(*v);
                        }
                    }
                }
                Op::Compact(keep) => {
                    // keep some live blocks, in a shuffled order
                    let mut order: Vec<u32> = Vec::new();
                    for i in keep {
                        if let Some(b) = pick(i) {
                            if !order.contains(&(b as u32)) {
                                order.push(b as u32);
                            }
                        }
                    }
                    l = l.compacted(&order, limit);
                    m.blocks = order.iter().map(|&b| m.blocks[b as usize]).collect();
                    m.live = vec![true; order.len()];
                    let distinct: std::collections::BTreeSet<u32> = m.blocks.iter().flatten()
                        .filter(|v| present(**v)).map(|v| v.to_bits()).chain([0]).collect();
                    // narrow again exactly when the values in use fit
                    prop_assert_eq!(l.is_wide(), distinct.len() > limit);
                }
            }
            check(&l, &m)?;
        }
    }
}

/// `selected_to` gives, for every selection of slots, `to` in the selected slots and `from`
/// in the others, slot by slot as a naive loop writes them.
#[test]
fn selected_slots_take_the_new_index() {
    for (from, to) in [(ABSENT_IDX, 0u16), (3, 0xfffe), (0x1234, 0x8001), (7, 7)] {
        for bits in 0..=u8::MAX {
            let mut want = [from; 8];
            for (k, slot) in want.iter_mut().enumerate() {
                if bits >> k & 1 == 1 {
                    *slot = to;
                }
            }
            assert_eq!(selected_to(from, bits, to), want, "bits {bits:#010b}");
        }
    }
}
