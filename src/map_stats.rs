//! What a mapping run did: [`FrameStats`] of one frame and the running totals, [`MapStats`].
//!
//! They live apart from the [`Mapper`](crate::pipeline::Mapper) that fills them because the
//! checkpoint manifest ([`crate::checkpoint`]) records the totals too: with the statistics
//! here, the pipeline depends on the checkpoint and both on the statistics, and never the other
//! way round. Users name them by their public paths, `octoquant::pipeline::FrameStats` and
//! `octoquant::pipeline::MapStats`, which re-export them.

use crate::filters::DroppedPoints;

/// What happened to one frame.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FrameStats {
    /// Points in the frame.
    pub points: usize,
    /// Points with NaN/inf coordinates, skipped.
    pub non_finite: usize,
    /// Finite points outside the map, dropped (as OctoMap drops them).
    pub outside_map: usize,
    /// Points exactly at the sensor origin (drivers' `(0, 0, 0)` "no return" points), counted
    /// whether or not they are dropped (they are only with
    /// [`PointFilters::drop_zero`](crate::filters::PointFilters::drop_zero); OctoMap inserts
    /// them).
    pub zero: usize,
    /// Points dropped by the
    /// [`MapperOptions::filters`](crate::pipeline::MapperOptions::filters), by reason.
    pub dropped: DroppedPoints,
    /// Ground points kept to clear space only
    /// ([`GroundFilter::clear`](crate::filters::GroundFilter::clear)): their rays clear, their
    /// end voxels are not marked occupied. Counted before the density reduction.
    pub clearing: usize,
    /// Points left after the filters and density reduction (equal to `points` without them).
    pub reduced: usize,
    /// Rays cast (after quantization).
    pub rays: usize,
    /// Of which: depth-image rays walked only from where their neighbours stop covering them
    /// (the same map either way; see [`octoquant_raycast::compute_update_grid_f32`]).
    pub heads_skipped: usize,
    /// Free-voxel updates applied.
    pub free: usize,
    /// Occupied-voxel updates applied.
    pub occupied: usize,
    /// Wall-clock seconds spent on this frame.
    pub seconds: f64,
    /// Of which: reduction, quantization and ray casting into key sets.
    pub ray_seconds: f64,
    /// Of which: applying the key sets to the tree.
    pub tree_seconds: f64,
}

/// Totals over every frame inserted so far.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MapStats {
    /// Frames inserted.
    pub frames: usize,
    /// Sum of the per-frame statistics.
    pub total: FrameStats,
}

impl MapStats {
    /// Count one more frame with statistics `st`.
    pub fn add(&mut self, st: &FrameStats) {
        let t = &mut self.total;
        self.frames += 1;
        t.points += st.points;
        t.non_finite += st.non_finite;
        t.outside_map += st.outside_map;
        t.zero += st.zero;
        t.dropped.add(&st.dropped);
        t.clearing += st.clearing;
        t.reduced += st.reduced;
        t.rays += st.rays;
        t.heads_skipped += st.heads_skipped;
        t.free += st.free;
        t.occupied += st.occupied;
        t.seconds += st.seconds;
        t.ray_seconds += st.ray_seconds;
        t.tree_seconds += st.tree_seconds;
    }

    /// Count the frames of `other` too (statistics of another batch of the same run).
    pub fn merge(&mut self, other: &MapStats) {
        let frames = self.frames + other.frames;
        self.add(&other.total);
        self.frames = frames;
    }
}
