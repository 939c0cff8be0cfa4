//! [`DistanceMap`]: dynamicEDT3D's distance transform tied to an [`OcTree`] and its keys.

use nalgebra::{Point3, Vector3};
use octoquant_octree::{Key, KeyConverter, OcTree, TREE_DEPTH};

use crate::error::DistanceError;
use crate::grid::Grid;

/// Distance returned for a point outside the bounding box (dynamicEDT3D's
/// `distanceValue_Error`).
pub const DISTANCE_OUTSIDE: f32 = -1.0;

/// Squared cell distance returned for a point outside the bounding box (dynamicEDT3D's
/// `distanceInCellsValue_Error`).
pub const SQ_CELLS_OUTSIDE: i32 = -1;

/// Most voxels a distance map may cover (each costs 24 bytes): 2^28, about 6 GiB.
pub const MAX_CELLS: u64 = 1 << 28;

/// Largest maximum distance in cells whose square still fits an `i32`.
const MAX_DIST_CELLS: i32 = 46_340;

/// What to compute: OctoMap's `DynamicEDTOctomap` constructor arguments.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DistanceOptions {
    /// Distances are clamped here, in metres. In cells it becomes
    /// `trunc(max_dist / resolution + 1)`, whose square is the clamp of squared distances.
    pub max_dist: f32,
    /// Smallest corner of the box, in metres; the box is every voxel whose key lies between
    /// the corners' keys, inclusive.
    pub bbx_min: Point3<f64>,
    /// Largest corner of the box, in metres.
    pub bbx_max: Point3<f64>,
    /// Whether unknown voxels count as obstacles (otherwise as free space).
    pub unknown_occupied: bool,
}

/// A 3D distance map over a box of an [`OcTree`]: for every voxel, the distance to the
/// nearest occupied voxel (centre to centre) up to a maximum, and that voxel, with the
/// numbers of OctoMap's `DynamicEDTOctomap`.
///
/// Query coordinates are rounded to `f32` first, as OctoMap's `point3d` holds them.
#[derive(Debug, Clone)]
pub struct DistanceMap {
    grid: Grid,
    conv: KeyConverter,
    min_key: Key,
    max_key: Key,
    unknown_occupied: bool,
}

/// A coordinate as OctoMap's `point3d` holds it.
fn as_point3d(p: &Point3<f64>) -> Point3<f64> {
    p.map(|v| f64::from(v as f32))
}

impl DistanceMap {
    /// Build the map and compute every distance (OctoMap's constructor followed by
    /// `update()`).
    pub fn new(tree: &OcTree, options: &DistanceOptions) -> Result<Self, DistanceError> {
        let mut map = Self::staged(tree, options)?;
        map.grid.propagate(true);
        Ok(map)
    }

    /// Copy the occupancy of the box into the map without computing distances yet: the state
    /// right after OctoMap's constructor (octomap-python's `dynamicEDT_generate`). Obstacles
    /// whose 26 neighbours are all obstacles already read 0; every other voxel reads the
    /// maximum distance until [`DistanceMap::update`].
    pub fn staged(tree: &OcTree, options: &DistanceOptions) -> Result<Self, DistanceError> {
        let res = tree.resolution();
        let cells_f = f64::from(options.max_dist) / res + 1.0;
        if !options.max_dist.is_finite() || options.max_dist < 0.0 {
            return Err(DistanceError::InvalidMaxDist {
                max_dist: options.max_dist,
                reason: "must be finite and >= 0",
            });
        }
        if cells_f >= f64::from(MAX_DIST_CELLS + 1) {
            return Err(DistanceError::InvalidMaxDist {
                max_dist: options.max_dist,
                reason: "more than 46340 voxels: its squared value in voxels overflows",
            });
        }
        let max_cells = cells_f as i32;
        let max_sq = max_cells * max_cells;

        let conv = tree.converter().clone();
        let corner_key = |p: &Point3<f64>, which: &'static str| {
            let q = as_point3d(p);
            conv.point_to_key(&q)
                .ok_or(DistanceError::BoxCornerOutOfMap {
                    which,
                    corner: [p.x, p.y, p.z],
                })
        };
        let min_key = corner_key(&options.bbx_min, "min")?;
        let max_key = corner_key(&options.bbx_max, "max")?;
        let mut size = [0i32; 3];
        for a in 0..3 {
            if max_key[a] < min_key[a] {
                return Err(DistanceError::EmptyBox {
                    axis: a,
                    min_key: min_key[a],
                    max_key: max_key[a],
                });
            }
            size[a] = i32::from(max_key[a]) - i32::from(min_key[a]) + 1;
        }
        let cells = size.iter().map(|&s| s as u64).product::<u64>();
        if cells > MAX_CELLS {
            return Err(DistanceError::TooLarge {
                cells,
                limit: MAX_CELLS,
            });
        }
        let grid = Grid::new(size, max_sq).ok_or(DistanceError::OutOfMemory { cells })?;
        let mut map = DistanceMap {
            grid,
            conv,
            min_key,
            max_key,
            unknown_occupied: options.unknown_occupied,
        };
        map.load(tree);
        Ok(map)
    }

    /// Copy the occupied voxels of the box into the grid, in OctoMap's order: leaves in
    /// tree-iterator order (a pruned leaf's voxels x-major, then y, then z) when unknown
    /// space is free; every voxel of the box x-major when unknown space is occupied.
    fn load(&mut self, tree: &OcTree) {
        let (lo, hi) = (self.min_key, self.max_key);
        if !self.unknown_occupied {
            let params = tree.params();
            for leaf in tree.leaves_in_bbx(lo, hi) {
                if !params.is_occupied(leaf.value) {
                    continue;
                }
                if leaf.depth == TREE_DEPTH {
                    self.insert_initial(tree, leaf.key);
                    continue;
                }
                let base = leaf.min_key();
                let w = leaf.width();
                for dx in 0..w {
                    for dy in 0..w {
                        for dz in 0..w {
                            let k = [dx, dy, dz];
                            let key = Key([0, 1, 2].map(|a| (u32::from(base[a]) + k[a]) as u16));
                            if (0..3).any(|a| key[a] < lo[a] || key[a] > hi[a]) {
                                continue;
                            }
                            self.insert_initial(tree, key);
                        }
                    }
                }
            }
        } else {
            let size = self.grid.size();
            for x in 0..size[0] {
                for y in 0..size[1] {
                    for z in 0..size[2] {
                        let key = self.key_of([x, y, z]);
                        if tree.is_occupied(key) != Some(false) {
                            self.insert_initial(tree, key);
                        }
                    }
                }
            }
        }
    }

    /// Whether the voxel `key` counts as an obstacle (unknown space per the option).
    fn tree_occupied(&self, tree: &OcTree, key: Key) -> bool {
        tree.is_occupied(key).unwrap_or(self.unknown_occupied)
    }

    /// An obstacle found while loading: settled at once when all 26 neighbours in the tree
    /// (inside the box or not) are obstacles too, otherwise queued for the lower wave.
    fn insert_initial(&mut self, tree: &OcTree, key: Key) {
        let mut surrounded = true;
        'scan: for dx in -1i32..=1 {
            for dy in -1i32..=1 {
                for dz in -1i32..=1 {
                    if dx == 0 && dy == 0 && dz == 0 {
                        continue;
                    }
                    let d = [dx, dy, dz];
                    let n = Key([0, 1, 2].map(|a| (i32::from(key[a]) + d[a]) as u16));
                    if !self.tree_occupied(tree, n) {
                        surrounded = false;
                        break 'scan;
                    }
                }
            }
        }
        let p = self.cell_of(key);
        if surrounded {
            self.grid.settle_obstacle(p);
        } else {
            self.grid.add_obstacle(p);
        }
    }

    /// Bring the map up to date with the voxels `tree` changed since the last update
    /// (OctoMap's `update(updateRealDist)`): the tree's change detection is read and reset.
    /// Changes outside the box are ignored. With `real_dist` false only squared distances
    /// are refreshed.
    ///
    /// The changes are applied in the order OctoMap's changed-keys map walks them
    /// ([`OcTree::changed_keys_octomap_order`]), so where two obstacles are equally near a
    /// voxel, the one reported is OctoMap's too when the tree saw the same single-voxel
    /// updates (`update_node`, `set_node_value`) in the same order. Batch insertions update
    /// voxels in another order than OctoMap's `insertPointCloud`; the distances are the same,
    /// the reported obstacle of a tie may differ. Change detection must be on (see
    /// [`OcTree::enable_change_detection`]) for any change to be seen.
    pub fn update(&mut self, tree: &mut OcTree, real_dist: bool) -> Result<(), DistanceError> {
        if tree.resolution() != self.conv.resolution() {
            return Err(DistanceError::ResolutionMismatch {
                tree: tree.resolution(),
                map: self.conv.resolution(),
            });
        }
        let changed: Vec<Key> = tree.changed_keys_octomap_order().map(|(k, _)| k).collect();
        for key in changed {
            if (0..3).any(|a| key[a] < self.min_key[a] || key[a] > self.max_key[a]) {
                continue;
            }
            let p = self.cell_of(key);
            if self.tree_occupied(tree, key) {
                self.grid.add_obstacle(p);
            } else {
                self.grid.remove_obstacle(p);
            }
        }
        tree.reset_change_detection();
        self.grid.propagate(real_dist);
        Ok(())
    }

    /// Grid cell of a key inside the box.
    fn cell_of(&self, key: Key) -> [i32; 3] {
        [0, 1, 2].map(|a| i32::from(key[a]) - i32::from(self.min_key[a]))
    }

    /// Key of a grid cell.
    fn key_of(&self, p: [i32; 3]) -> Key {
        Key([0, 1, 2].map(|a| (i32::from(self.min_key[a]) + p[a]) as u16))
    }

    /// Grid cell of a point, `None` outside the key range; errors for NaN or infinity.
    fn locate(&self, p: &Point3<f64>) -> Result<Option<[i32; 3]>, DistanceError> {
        let q = as_point3d(p);
        if !q.iter().all(|v| v.is_finite()) {
            return Err(DistanceError::NonFinitePoint {
                point: [p.x, p.y, p.z],
            });
        }
        Ok(self
            .conv
            .point_to_key(&q)
            .map(|k| self.cell_of(k))
            .filter(|c| self.grid.contains(*c)))
    }

    /// Distance in metres from `point` to the nearest obstacle, clamped at
    /// [`DistanceMap::max_dist`]; [`DISTANCE_OUTSIDE`] (-1) outside the box.
    ///
    /// Unknown voxels have no special value: they get a distance like free ones (0 when
    /// unknown space counts as occupied). A point beyond the tree's key range is outside
    /// (OctoMap would wrap its key around instead).
    pub fn distance(&self, point: &Point3<f64>) -> Result<f32, DistanceError> {
        Ok(match self.locate(point)? {
            Some(c) => self.metres(c),
            None => DISTANCE_OUTSIDE,
        })
    }

    /// Distance at the voxel `key` (OctoMap's `getDistance(OcTreeKey)`), [`DISTANCE_OUTSIDE`]
    /// outside the box.
    pub fn distance_at_key(&self, key: Key) -> f32 {
        let c = self.cell_of(key);
        if self.grid.contains(c) {
            self.metres(c)
        } else {
            DISTANCE_OUTSIDE
        }
    }

    /// Stored cell distance scaled to metres the way OctoMap does it: `float * double`,
    /// rounded to `float`.
    fn metres(&self, c: [i32; 3]) -> f32 {
        (f64::from(self.grid.dist(c)) * self.conv.resolution()) as f32
    }

    /// Distance as [`DistanceMap::distance`] and the centre of the obstacle voxel it is
    /// measured to (as OctoMap's `float` point). The obstacle is `None` outside the box and
    /// where no obstacle lies within the maximum distance.
    pub fn distance_and_closest_obstacle(
        &self,
        point: &Point3<f64>,
    ) -> Result<(f32, Option<Point3<f64>>), DistanceError> {
        let Some(c) = self.locate(point)? else {
            return Ok((DISTANCE_OUTSIDE, None));
        };
        let obstacle = self
            .grid
            .obstacle(c)
            .map(|o| self.conv.key_to_point_f32(&self.key_of(o)).map(f64::from));
        Ok((self.metres(c), obstacle))
    }

    /// Squared distance in voxels (OctoMap's `getSquaredDistanceInCells`), clamped at
    /// [`DistanceMap::max_sq_cells`]; [`SQ_CELLS_OUTSIDE`] (-1) outside the box.
    pub fn squared_distance_in_cells(&self, point: &Point3<f64>) -> Result<i32, DistanceError> {
        Ok(match self.locate(point)? {
            Some(c) => self.grid.sq_dist(c),
            None => SQ_CELLS_OUTSIDE,
        })
    }

    /// The distance clamp in metres (OctoMap's `getMaxDist`): `sqrt(max_sq_cells) *
    /// resolution` as a `float`. It is at least the requested maximum distance.
    pub fn max_dist(&self) -> f32 {
        (self.grid.max_dist() * self.conv.resolution()) as f32
    }

    /// The clamp of squared distances in voxels (OctoMap's `getSquaredMaxDistCells`).
    pub fn max_sq_cells(&self) -> i32 {
        self.grid.max_sq()
    }

    /// Smallest key of the box.
    pub fn min_key(&self) -> Key {
        self.min_key
    }

    /// Largest key of the box (inclusive).
    pub fn max_key(&self) -> Key {
        self.max_key
    }

    /// Voxels per axis of the box.
    pub fn size(&self) -> Vector3<usize> {
        let s = self.grid.size();
        Vector3::new(s[0] as usize, s[1] as usize, s[2] as usize)
    }

    /// Leaf size of the tree the map was built from, in metres.
    pub fn resolution(&self) -> f64 {
        self.conv.resolution()
    }

    /// Whether unknown voxels count as obstacles.
    pub fn unknown_occupied(&self) -> bool {
        self.unknown_occupied
    }

    /// Whether the map's obstacles are exactly the tree's occupied voxels in the box
    /// (OctoMap's `checkConsistency`): false while the tree has changes not yet taken in by
    /// [`DistanceMap::update`].
    pub fn check_consistency(&self, tree: &OcTree) -> bool {
        if tree.num_changes_detected() > 0 {
            return false;
        }
        let size = self.grid.size();
        for x in 0..size[0] {
            for y in 0..size[1] {
                for z in 0..size[2] {
                    let key = self.key_of([x, y, z]);
                    if self.grid.is_obstacle([x, y, z]) != self.tree_occupied(tree, key) {
                        return false;
                    }
                }
            }
        }
        true
    }
}
