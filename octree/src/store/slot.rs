//! A node's value slot: its `f32` log-odds, or the absent marker of a child that does not
//! exist.
//!
//! Inner blocks and wide voxel blocks keep eight value slots each; a missing child is marked
//! in its slot by a reserved NaN bit pattern, so that no separate presence mask is needed.

/// Bit pattern of the value slot of a child that does not exist (a quiet NaN that the tree
/// never stores, since NaN log-odds are rejected at the API).
pub(crate) const ABSENT_BITS: u32 = 0x7fc0_0a5e;
/// The value of an absent slot.
pub(crate) const ABSENT: f32 = f32::from_bits(ABSENT_BITS);

/// `true` when a value slot holds a node.
#[inline]
pub(crate) fn present(v: f32) -> bool {
    v.to_bits() != ABSENT_BITS
}

/// The largest present value of a child block (`-f32::MAX` when none): absent children hold
/// a NaN, which `>` never picks, and strict `>` in child order keeps OctoMap's choice between
/// equal values (+0.0 and -0.0).
#[inline]
pub(crate) fn max_present(vals: &[f32; 8]) -> f32 {
    let mut m = -f32::MAX;
    for &v in vals {
        if v > m {
            m = v;
        }
    }
    m
}
