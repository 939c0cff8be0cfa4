//! Starting the SIMD lanes on rays: a walk's state as scalars ([`LaneInit`]) and the first step
//! at which any walk can stop ([`first_stop`]), shared by the AVX2 and AVX-512 lanes; and the
//! restart of the lanes whose walks stopped on the next rays of the batch, lane by lane
//! ([`restart`], the AVX2 lanes; the AVX-512 lanes expand a batch's states into the stopped
//! lanes at once).

use super::brick_walk::lane_start;
use crate::brickset::BrickSink;
use crate::dda::RaySetup;
use octoquant_octree::Brick;

/// The bits of a voxel's Morton code. A caller may mark a ray's codes in the bits above
/// (`crate::ray_order`): the walks keep them, and idle lanes, which repeat the first walk's
/// origin voxel, write it without its mark.
pub(crate) const VOXEL_CODE: u64 = (1 << 48) - 1;

/// One walk's state as scalars, for starting a SIMD lane on a new ray.
pub(crate) struct LaneInit {
    pub(crate) t: [f64; 3],
    pub(crate) d: [f64; 3],
    pub(crate) len: f64,
    pub(crate) m: u64,
    pub(crate) end: u64,
    pub(crate) flip: u64,
    pub(crate) budget: i64,
    /// The code of the voxel the walk starts in.
    pub(crate) origin: u64,
}

impl LaneInit {
    /// The walk of `r` at its origin voxel.
    pub(crate) fn new(r: &RaySetup) -> Self {
        let (m, end, flip) = lane_start(r);
        LaneInit {
            t: r.t_max,
            d: r.t_delta,
            len: r.length,
            m,
            end,
            flip,
            budget: r.budget as i64,
            origin: m ^ flip,
        }
    }

    /// The step at which this walk runs out of budget when it starts after step `now`, as a
    /// countdown from `budget` would (`u64::MAX` for idle lanes, in effect never).
    pub(crate) fn due(&self, now: u64) -> u64 {
        now.saturating_add(self.budget.max(0) as u64)
    }

    /// A lane without a ray: it never moves (its step mask is cleared by `active`), never
    /// ends, and keeps writing `code`, a voxel already recorded.
    pub(crate) fn idle(code: u64) -> Self {
        LaneInit {
            t: [0.0; 3],
            d: [0.0; 3],
            len: f64::INFINITY,
            m: code,
            end: !code,
            flip: 0,
            budget: i64::MAX,
            origin: code,
        }
    }
}

/// The first step at which a walk can stop, given the first step `due` at which one runs out
/// of budget (the Manhattan key distance plus [`crate::dda::STEP_MARGIN`] after its start):
/// [`crate::dda::untold_watch`]'s rule.
pub(crate) fn first_stop(due: u64) -> u64 {
    crate::dda::untold_watch(due.saturating_sub(u64::from(crate::dda::STEP_MARGIN)))
}

/// Restart the lanes whose walks stopped at this step (bit `l` of `stopped` for lane `l`) on
/// the next rays of `next`, through `set(lane, state, active)`: a lane's code becomes its new
/// walk's origin voxel, or `idle_code` (a voxel already recorded) when the rays are used up, and
/// `live` counts down. A walk that stopped without being done (bit clear in `done`) ran out of
/// budget: the voxel it just entered is handed to `flush` and it is counted as degenerate.
/// Returns that count.
#[allow(clippy::too_many_arguments)]
pub(crate) fn restart<F, S>(
    codes: &mut [u64],
    stopped: u32,
    done: u32,
    next: &mut std::slice::Iter<'_, RaySetup>,
    idle_code: u64,
    live: &mut usize,
    flush: &mut F,
    mut set: S,
) -> usize
where
    F: BrickSink,
    S: FnMut(usize, &LaneInit, bool),
{
    let mut degenerate = 0;
    // only the stopped lanes, lowest first: a test of every lane's bit would be a branch
    // the predictor misses whenever neighbouring walks end at different steps
    let mut left = stopped;
    while left != 0 {
        let l = left.trailing_zeros() as usize;
        left &= left - 1;
        let Some(code) = codes.get_mut(l) else {
            break;
        };
        if done & (1 << l) == 0 {
            flush.put(Brick::of_voxel(*code));
            degenerate += 1;
        }
        match next.next() {
            Some(r) => {
                let s = LaneInit::new(r);
                *code = s.origin;
                set(l, &s, true);
            }
            None => {
                *code = idle_code;
                set(l, &LaneInit::idle(idle_code), false);
                *live -= 1;
            }
        }
    }
    degenerate
}
