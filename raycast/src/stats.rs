//! The counts of one scan: what happened to its points and rays, and how many voxels it
//! updates. Every scan function returns them ([`crate::compute_update`],
//! [`crate::discretize()`], [`crate::insert_point_cloud`], their `_f32` paths, ...).

/// Counts gathered while turning a scan into key sets (and while inserting it).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ScanStats {
    /// Points given.
    pub points: usize,
    /// Points with a NaN or infinite coordinate: skipped, never inserted.
    pub non_finite: usize,
    /// Finite points outside the map (`[-32768·res, 32768·res)` per axis). OctoMap drops them
    /// (their ray and their hit both fail), and so do we; with `discretize`, OctoMap's
    /// unchecked key wraps them into the map instead, and that is reproduced (they are still
    /// counted here).
    pub outside_map: usize,
    /// With `discretize`: points whose voxel was already seen in this scan (no ray of their
    /// own).
    pub duplicates: usize,
    /// Rays whose keys were computed (both ends inside the map), max-range rays included.
    pub rays: usize,
    /// Rays that could not be computed because an end lies outside the map (or the float
    /// arithmetic degenerated); their free space is lost, exactly as in OctoMap.
    pub failed_rays: usize,
    /// Points beyond the maximum range: their ray was cut and they add no occupied voxel.
    pub max_range_rays: usize,
    /// Rays of a depth image walked only from where their neighbours stop covering them (see
    /// [`crate::compute_update_grid_f32`]); the key sets are the same either way.
    pub heads_skipped: usize,
    /// Distinct free voxels (after removing the occupied ones), or free updates applied.
    pub free: usize,
    /// Distinct occupied voxels, or hit updates applied.
    pub occupied: usize,
}
