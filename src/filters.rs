//! Point filters applied to each frame before insertion: octomap_server's
//! `pointcloud_min_z`/`pointcloud_max_z` height band and `filter_ground` RANSAC ground removal,
//! plus a minimum range, a sensor-frame crop box (sensor housing, robot body), a world crop
//! box and the drivers' "no return" points at the sensor origin.
//!
//! # Semantics
//!
//! A [`Frame`](crate::Frame) holds world points `p` and the sensor origin `o` (both `f32`).
//! Every test below is computed in `f64` from those `f32` values. Each point is tested in this
//! order and counted under the **first** reason that drops it ([`DroppedPoints`]):
//!
//! 1. **non-finite**: a NaN or infinite coordinate (counted in `FrameStats::non_finite`, as
//!    without filters);
//! 2. **zero**: `p == o` exactly, which is where a driver's `(0, 0, 0)` "no return" point lands
//!    in the world (`pose * 0` is the pose's translation). Always *counted*
//!    (`FrameStats::zero`), *dropped* only with [`PointFilters::drop_zero`]: OctoMap's
//!    `insertPointCloud` inserts them (the sensor's own voxel becomes occupied), and the
//!    default keeps the map byte-identical to OctoMap's;
//! 3. **min_range**: `|p - o| < min_range`;
//! 4. **crop_sensor**: the point in the sensor frame, `s = R⁻¹ (p - o)`, lies inside the box
//!    (bounds included). `R` is the sensor's orientation when it is known
//!    ([`crate::pipeline::Mapper::insert_sensor_frame`]); a [`Frame`](crate::Frame) records
//!    only where the sensor was, not how it was turned, so for frames `R` is the identity: the
//!    box is centred on the sensor with the world's axes;
//! 5. **crop_world**: `p` lies outside the world box (bounds included in the box);
//! 6. **z_band**: `p.z < z_min` or `p.z > z_max` (world frame; bounds kept, as PCL's
//!    `PassThrough` that octomap_server uses);
//! 7. **ground**: `p` is within [`GroundFilter::distance`] of the frame's dominant ground plane,
//!    found by RANSAC among the points that passed 1-6 ([`fit_ground_plane`]).
//!
//! The points left then go through the maximum range, the density reduction and the ray caster
//! exactly as without filters (where points outside the map are counted as `outside_map`).
//! With no filter set, nothing is removed and the map stays byte-identical to OctoMap's.
//!
//! # Where octoquant differs from octomap_server
//!
//! - octomap_server applies the z band in the world frame, but in its `base_frame_id` when
//!   `filter_ground` is on, and looks for the ground plane in that base frame (a plane
//!   perpendicular to the base's z axis within `ground_filter/angle`, accepted as ground when
//!   its offset is below `ground_filter/plane_distance`, else set aside as a table and the
//!   search repeated). octoquant has no base frame: the band is always in the world frame, and
//!   the ground is the plane with the most inliers among those within [`GroundFilter::angle`]
//!   of the world's z axis that pass **below the sensor origin**, so that a ceiling or a table
//!   top seen from below is never taken for the ground.
//! - octomap_server inserts ground points as free space (their rays clear, their end voxel is
//!   not marked occupied). octoquant **drops** them by default (the space above the ground is
//!   then cleared by the other rays only), and inserts them as octomap_server does with
//!   [`GroundFilter::clear`] (`--ground-clears`): each kept ground point's ray is cast as any
//!   other's (cut at the maximum range as any other's), and only its end voxel is left alone;
//!   occupied still wins over free within the frame.
//! - octomap_server does not drop zero points itself (PCL's pass-through removes only NaNs);
//!   octoquant counts them always and drops them on request. (The MCAP reader already skips
//!   `(0, 0, 0)` points of PointCloud2 messages when it reads them.)
//! - octomap_server has no minimum range or sensor crop box; its `pointcloud_[min|max]_[x|y]`
//!   parameters are the world crop box.
//! - The maximum range (`sensor_model/max_range`) is [`crate::pipeline::MapperOptions`]'s
//!   `max_range`, with OctoMap's and octomap_server's semantics: a longer reading clears space
//!   up to the range and marks nothing occupied.

use nalgebra::{Matrix3, Point3, UnitQuaternion, Vector3};

/// Why a filter setting is invalid; the message names the option.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FilterError {
    /// A box whose minimum exceeds its maximum on an axis, or with a NaN or infinite bound.
    #[error("{option}: invalid box {min:?} .. {max:?} (each bound must be finite and min <= max on every axis)")]
    InvalidBox {
        /// The option's name as the caller spells it (`--crop-sensor`, `crop_world`, ...).
        option: String,
        /// The minimum corner given.
        min: [f64; 3],
        /// The maximum corner given.
        max: [f64; 3],
    },
    /// A box not given as six numbers.
    #[error("{option}: a box is six numbers XMIN YMIN ZMIN XMAX YMAX ZMAX, got {got}")]
    BoxArity {
        /// The option's name.
        option: String,
        /// How many numbers were given.
        got: usize,
    },
    /// A number outside its domain.
    #[error("{option}: {message}, got {value}")]
    InvalidValue {
        /// The option's name.
        option: String,
        /// What the value must be.
        message: &'static str,
        /// The value given.
        value: f64,
    },
}

/// An axis-aligned box, bounds included; always finite with `min <= max` per axis when built
/// with [`CropBox::new`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CropBox {
    /// The minimum corner.
    pub min: Point3<f64>,
    /// The maximum corner.
    pub max: Point3<f64>,
}

impl CropBox {
    /// A box from its corners; `option` names the setting in the error when a bound is NaN or
    /// infinite or `min > max` on an axis.
    pub fn new(option: &str, min: Point3<f64>, max: Point3<f64>) -> Result<Self, FilterError> {
        let ok = (0..3).all(|a| min[a].is_finite() && max[a].is_finite() && min[a] <= max[a]);
        if !ok {
            return Err(FilterError::InvalidBox {
                option: option.to_string(),
                min: min.coords.into(),
                max: max.coords.into(),
            });
        }
        Ok(CropBox { min, max })
    }

    /// A box from `[xmin, ymin, zmin, xmax, ymax, zmax]`, as the command line gives it.
    pub fn from_slice(option: &str, v: &[f64]) -> Result<Self, FilterError> {
        match v {
            [a, b, c, d, e, f] => {
                CropBox::new(option, Point3::new(*a, *b, *c), Point3::new(*d, *e, *f))
            }
            _ => Err(FilterError::BoxArity {
                option: option.to_string(),
                got: v.len(),
            }),
        }
    }

    /// Whether `p` lies inside the box or on its boundary (false for NaN).
    pub fn contains(&self, p: &Point3<f64>) -> bool {
        (0..3).all(|a| p[a] >= self.min[a] && p[a] <= self.max[a])
    }

    /// The six bounds, `[xmin, ymin, zmin, xmax, ymax, zmax]`.
    pub fn to_array(&self) -> [f64; 6] {
        [
            self.min.x, self.min.y, self.min.z, self.max.x, self.max.y, self.max.z,
        ]
    }
}

/// RANSAC ground-plane removal (octomap_server's `filter_ground`): in each frame, the plane
/// with the most points within `distance`, among planes through three of the frame's points
/// whose normal is within `angle` of the world's z axis and that pass below the sensor origin;
/// its points within `distance` are dropped. Deterministic: the samples come from a generator
/// seeded with `seed` (and the frame's point count), on one thread, so a frame gives the same
/// result on every run and for any thread count.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GroundFilter {
    /// Points within this distance of the plane (metres) are ground (octomap_server's
    /// `ground_filter/distance`, default 0.04 there).
    pub distance: f64,
    /// Maximum angle between the plane's normal and the z axis, radians
    /// (`ground_filter/angle`, 0.15).
    pub angle: f64,
    /// RANSAC iterations per frame (PCL's maximum in octomap_server is 200), 1 to
    /// [`MAX_GROUND_ITERATIONS`].
    pub iterations: u32,
    /// Seed of the sample generator.
    pub seed: u64,
    /// Insert the ground points as octomap_server does, as free space (their rays clear, their
    /// end voxels are not marked occupied), instead of dropping them.
    pub clear: bool,
}

impl GroundFilter {
    /// octomap_server's angle and iteration count with the given distance, seed 0, ground
    /// points dropped.
    pub fn with_distance(distance: f64) -> Self {
        GroundFilter {
            distance,
            angle: 0.15,
            iterations: 200,
            seed: 0,
            clear: false,
        }
    }

    /// Checks the parameters; `option` names the setting in the error.
    pub fn validate(&self, option: &str) -> Result<(), FilterError> {
        let bad = |message, value| {
            Err(FilterError::InvalidValue {
                option: option.to_string(),
                message,
                value,
            })
        };
        if !(self.distance.is_finite() && self.distance > 0.0) {
            return bad("the ground distance must be finite and > 0", self.distance);
        }
        if !(self.angle > 0.0 && self.angle <= std::f64::consts::FRAC_PI_2) {
            return bad("the ground angle must be in (0, pi/2] radians", self.angle);
        }
        if self.iterations == 0 {
            return bad("at least one RANSAC iteration is needed", 0.0);
        }
        if self.iterations > MAX_GROUND_ITERATIONS {
            return bad(
                "at most 100000 RANSAC iterations per frame (MAX_GROUND_ITERATIONS)",
                f64::from(self.iterations),
            );
        }
        Ok(())
    }
}

/// Which points to drop before insertion (see the [module docs](self) for the exact rules and
/// their order). `Default` drops nothing: the map is OctoMap's.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PointFilters {
    /// Drop points exactly at the sensor origin (drivers' `(0, 0, 0)` "no return" points).
    pub drop_zero: bool,
    /// Drop readings closer than this to the sensor origin (metres); `None` or 0 = off.
    pub min_range: Option<f64>,
    /// Drop points inside this box of the sensor frame (the sensor housing, the robot body).
    pub crop_sensor: Option<CropBox>,
    /// Keep only points inside this world box.
    pub crop_world: Option<CropBox>,
    /// Drop points below this world height (octomap_server's `pointcloud_min_z`).
    pub z_min: Option<f64>,
    /// Drop points above this world height (`pointcloud_max_z`).
    pub z_max: Option<f64>,
    /// Remove the frame's dominant ground plane.
    pub ground: Option<GroundFilter>,
}

/// How many points each filter dropped (each point counted once, under the first filter
/// that drops it, in the order of the [module docs](self)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DroppedPoints {
    /// Points at the sensor origin, dropped with [`PointFilters::drop_zero`].
    pub zero: usize,
    /// Closer than the minimum range.
    pub min_range: usize,
    /// Inside the sensor-frame crop box.
    pub crop_sensor: usize,
    /// Outside the world crop box.
    pub crop_world: usize,
    /// Outside the height band.
    pub z_band: usize,
    /// On the ground plane.
    pub ground: usize,
}

impl DroppedPoints {
    /// The sum over the filters.
    pub fn total(&self) -> usize {
        self.zero + self.min_range + self.crop_sensor + self.crop_world + self.z_band + self.ground
    }

    /// The counts as `(name, count)` pairs in the filters' order; the names are those of the
    /// fields (and of the JSON keys).
    pub fn named(&self) -> [(&'static str, usize); 6] {
        [
            ("zero", self.zero),
            ("min_range", self.min_range),
            ("crop_sensor", self.crop_sensor),
            ("crop_world", self.crop_world),
            ("z_band", self.z_band),
            ("ground", self.ground),
        ]
    }

    /// Add `other`'s counts to these.
    pub fn add(&mut self, other: &DroppedPoints) {
        self.zero += other.zero;
        self.min_range += other.min_range;
        self.crop_sensor += other.crop_sensor;
        self.crop_world += other.crop_world;
        self.z_band += other.z_band;
        self.ground += other.ground;
    }
}

/// What [`PointFilters::apply`] counted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FilterCounts {
    /// Points with a NaN or infinite coordinate (dropped).
    pub non_finite: usize,
    /// Points exactly at the sensor origin (dropped only with `drop_zero`).
    pub zero: usize,
    /// Points dropped by each filter.
    pub dropped: DroppedPoints,
    /// Ground points kept to clear space only ([`GroundFilter::clear`]): the last this many
    /// points appended to the output.
    pub clearing: usize,
}

/// A plane `normal · p + offset = 0`, `normal` of unit length with `normal.z >= 0`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plane {
    /// Unit normal, pointing up.
    pub normal: Vector3<f64>,
    /// Offset: minus the normal's component of any point of the plane.
    pub offset: f64,
}

impl Plane {
    /// Signed distance of `p` (positive above).
    pub fn distance(&self, p: &Point3<f64>) -> f64 {
        self.normal.dot(&p.coords) + self.offset
    }
}

/// The number of points exactly at `origin` (see the [module docs](self)): one comparison per
/// point, cheap enough to run on every frame. `f32`, as a [`Frame`](crate::Frame) stores them.
pub fn count_zero_f32(origin: &Point3<f32>, points: &[Point3<f32>]) -> usize {
    points.iter().filter(|p| *p == origin).count()
}

impl PointFilters {
    /// Whether any filter is set (otherwise [`PointFilters::apply`] keeps every finite point
    /// and callers skip it).
    pub fn is_active(&self) -> bool {
        self.drop_zero
            || self.min_range.is_some_and(|m| m > 0.0)
            || self.crop_sensor.is_some()
            || self.crop_world.is_some()
            || self.z_min.is_some()
            || self.z_max.is_some()
            || self.ground.is_some()
    }

    /// Checks every setting, naming the field in the error.
    pub fn validate(&self) -> Result<(), FilterError> {
        if let Some(m) = self.min_range {
            if !(m.is_finite() && m >= 0.0) {
                return Err(FilterError::InvalidValue {
                    option: "min_range".into(),
                    message: "the minimum range must be finite and >= 0",
                    value: m,
                });
            }
        }
        for (name, b) in [
            ("crop_sensor", self.crop_sensor),
            ("crop_world", self.crop_world),
        ] {
            if let Some(b) = b {
                CropBox::new(name, b.min, b.max)?;
            }
        }
        for (name, z) in [("z_min", self.z_min), ("z_max", self.z_max)] {
            if let Some(z) = z {
                if !z.is_finite() {
                    return Err(FilterError::InvalidValue {
                        option: name.into(),
                        message: "the height bound must be finite",
                        value: z,
                    });
                }
            }
        }
        if let (Some(lo), Some(hi)) = (self.z_min, self.z_max) {
            if lo > hi {
                return Err(FilterError::InvalidValue {
                    option: "z_min".into(),
                    message: "the height band's minimum exceeds its maximum",
                    value: lo,
                });
            }
        }
        if let Some(g) = &self.ground {
            g.validate("ground")?;
        }
        Ok(())
    }

    /// Filter one frame: the points of `points` (world) that every filter keeps are appended
    /// to `out` in their order, and, when `pixels` (one per point) is given, their pixels to
    /// `out_pixels`. With [`GroundFilter::clear`], the ground points follow the others (each
    /// part in its order), and [`FilterCounts::clearing`] says how many they are. `origin` is the sensor origin (world) and `rotation` the sensor's
    /// orientation (identity when unknown). Never panics; NaN settings drop nothing or
    /// everything but stay counted.
    pub fn apply(
        &self,
        origin: &Point3<f32>,
        rotation: &UnitQuaternion<f64>,
        points: &[Point3<f32>],
        pixels: Option<&[u32]>,
        out: &mut Vec<Point3<f32>>,
        out_pixels: &mut Vec<u32>,
    ) -> FilterCounts {
        let mut c = FilterCounts::default();
        let o = origin.cast::<f64>();
        let inverse = rotation.inverse();
        let min_range = self.min_range.filter(|m| *m > 0.0);
        let start = out.len();
        let start_px = out_pixels.len();
        for (i, p) in points.iter().enumerate() {
            if !p.iter().all(|v| v.is_finite()) {
                c.non_finite += 1;
                continue;
            }
            if p == origin {
                c.zero += 1;
                if self.drop_zero {
                    c.dropped.zero += 1;
                    continue;
                }
            }
            let w = p.cast::<f64>();
            let rel = w - o;
            if let Some(m) = min_range {
                if rel.norm() < m {
                    c.dropped.min_range += 1;
                    continue;
                }
            }
            if let Some(b) = &self.crop_sensor {
                if b.contains(&Point3::from(inverse * rel)) {
                    c.dropped.crop_sensor += 1;
                    continue;
                }
            }
            if let Some(b) = &self.crop_world {
                if !b.contains(&w) {
                    c.dropped.crop_world += 1;
                    continue;
                }
            }
            // (a NaN bound drops everything: w is finite here)
            let below = self.z_min.is_some_and(|z| w.z < z || z.is_nan());
            let above = self.z_max.is_some_and(|z| w.z > z || z.is_nan());
            if below || above {
                c.dropped.z_band += 1;
                continue;
            }
            out.push(*p);
            if let Some(px) = pixels {
                out_pixels.push(px.get(i).copied().unwrap_or(u32::MAX));
            }
        }
        if let Some(g) = &self.ground {
            let kept: Vec<Point3<f64>> = out[start..].iter().map(|p| p.cast()).collect();
            if let Some(plane) = fit_ground_plane(&kept, &o, g) {
                let mut w = start;
                let mut wp = start_px;
                let (mut ground, mut ground_px) = (Vec::new(), Vec::new());
                for (r, q) in kept.iter().enumerate() {
                    if plane.distance(q).abs() <= g.distance {
                        if g.clear {
                            ground.push(out[start + r]);
                            if pixels.is_some() {
                                ground_px.push(out_pixels[start_px + r]);
                            }
                        } else {
                            c.dropped.ground += 1;
                        }
                        continue;
                    }
                    out[w] = out[start + r];
                    w += 1;
                    if pixels.is_some() {
                        out_pixels[wp] = out_pixels[start_px + r];
                        wp += 1;
                    }
                }
                out.truncate(w);
                out.extend_from_slice(&ground);
                c.clearing = ground.len();
                if pixels.is_some() {
                    out_pixels.truncate(wp);
                    out_pixels.extend_from_slice(&ground_px);
                }
            }
        }
        c
    }
}

/// SplitMix64: a tiny, well-mixed, portable generator (the same sequence everywhere).
struct SplitMix64(u64);

impl SplitMix64 {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `0..n` (`n > 0`), by the multiply-shift reduction.
    fn below(&mut self, n: usize) -> usize {
        (((self.next() >> 32) * n as u64) >> 32) as usize
    }
}

/// At most this many points score each RANSAC candidate (an even stride through the frame);
/// the final inlier set is taken over all points.
const SCORE_SAMPLE: usize = 4096;

/// The most RANSAC iterations a frame may take: each scores a plane over up to 4096 points,
/// so this bounds a frame's ground search to seconds (a `u32`'s range would take hours).
pub const MAX_GROUND_ITERATIONS: u32 = 100_000;

/// The frame's ground plane: RANSAC over planes through three of `points` whose upward normal
/// is within `g.angle` of the z axis and that pass below `origin`, scored by the number of
/// points within `g.distance` (on an even subsample of at most 4096 points), the best
/// refined by a least-squares fit to its inliers (kept if it still satisfies the angle and
/// origin conditions). `None` when fewer than three points support any candidate. The same
/// input always gives the same plane (one thread, seeded samples).
pub fn fit_ground_plane(
    points: &[Point3<f64>],
    origin: &Point3<f64>,
    g: &GroundFilter,
) -> Option<Plane> {
    let n = points.len();
    if n < 3 {
        return None;
    }
    let min_nz = g.angle.cos();
    let accept = |plane: &Plane| plane.normal.z >= min_nz && plane.distance(origin) > 0.0;
    let stride = n.div_ceil(SCORE_SAMPLE).max(1);
    let score = |plane: &Plane| {
        points
            .iter()
            .step_by(stride)
            .filter(|p| plane.distance(p).abs() <= g.distance)
            .count()
    };
    let mut rng = SplitMix64(g.seed ^ (n as u64).wrapping_mul(0xA24B_AED4_963E_E407));
    let mut best: Option<(usize, Plane)> = None;
    for _ in 0..g.iterations {
        let (i, j, k) = (rng.below(n), rng.below(n), rng.below(n));
        if i == j || j == k || i == k {
            continue;
        }
        let Some(plane) = plane_through(&points[i], &points[j], &points[k]) else {
            continue;
        };
        if !accept(&plane) {
            continue;
        }
        let s = score(&plane);
        if best.is_none_or(|(b, _)| s > b) {
            best = Some((s, plane));
        }
    }
    let (count, plane) = best?;
    if count < 3 {
        return None;
    }
    let inliers: Vec<Point3<f64>> = points
        .iter()
        .filter(|p| plane.distance(p).abs() <= g.distance)
        .copied()
        .collect();
    Some(
        least_squares_plane(&inliers)
            .filter(|p| accept(p))
            .unwrap_or(plane),
    )
}

/// The plane through three points, normal pointing up; `None` when they are (nearly) collinear.
fn plane_through(a: &Point3<f64>, b: &Point3<f64>, c: &Point3<f64>) -> Option<Plane> {
    let n = (b - a).cross(&(c - a));
    let len = n.norm();
    if len.is_nan() || len <= 1e-12 {
        return None;
    }
    Some(oriented(n / len, a))
}

fn oriented(normal: Vector3<f64>, through: &Point3<f64>) -> Plane {
    let normal = if normal.z < 0.0 { -normal } else { normal };
    Plane {
        normal,
        offset: -normal.dot(&through.coords),
    }
}

/// The total-least-squares plane of `points` (through the centroid, normal along the
/// covariance's least eigenvector); `None` for fewer than three points or a degenerate fit.
fn least_squares_plane(points: &[Point3<f64>]) -> Option<Plane> {
    if points.len() < 3 {
        return None;
    }
    let centroid = points.iter().fold(Vector3::zeros(), |s, p| s + p.coords) / points.len() as f64;
    let mut cov = Matrix3::zeros();
    for p in points {
        let d = p.coords - centroid;
        cov += d * d.transpose();
    }
    let eig = cov.symmetric_eigen();
    let (k, _) = eig
        .eigenvalues
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))?;
    let n = eig.eigenvectors.column(k).into_owned();
    let len = n.norm();
    if !(len > 0.5 && len.is_finite()) {
        return None;
    }
    Some(oriented(n / len, &Point3::from(centroid)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn boxes_refuse_nan_and_inverted_bounds_naming_the_option() {
        let e = CropBox::from_slice("--crop-world", &[0.0, 0.0, 0.0, -1.0, 1.0, 1.0]).unwrap_err();
        assert!(e.to_string().starts_with("--crop-world:"), "{e}");
        let e = CropBox::from_slice("crop_sensor", &[f64::NAN, 0.0, 0.0, 1.0, 1.0, 1.0]);
        assert!(matches!(e, Err(FilterError::InvalidBox { .. })));
        assert!(CropBox::from_slice("x", &[1.0; 5]).is_err());
        let b = CropBox::from_slice("x", &[-1.0, -2.0, -3.0, 1.0, 2.0, 3.0]).unwrap();
        assert!(b.contains(&Point3::new(1.0, -2.0, 0.0)));
        assert!(!b.contains(&Point3::new(1.0001, 0.0, 0.0)));
        assert!(!b.contains(&Point3::new(f64::NAN, 0.0, 0.0)));
    }

    #[test]
    fn generator_is_uniform_enough_and_in_range() {
        let mut r = SplitMix64(7);
        let mut hist = [0usize; 10];
        for _ in 0..10_000 {
            hist[r.below(10)] += 1;
        }
        assert!(hist.iter().all(|&h| (800..1200).contains(&h)), "{hist:?}");
    }

    #[test]
    fn least_squares_recovers_a_tilted_plane() {
        let n = Vector3::new(0.1, -0.05, 1.0).normalize();
        let pts: Vec<Point3<f64>> = (0..100)
            .map(|i| {
                let (x, y) = ((i % 10) as f64, (i / 10) as f64);
                // z from n·p + 0.5 = 0
                Point3::new(x, y, -(n.x * x + n.y * y + 0.5) / n.z)
            })
            .collect();
        let p = least_squares_plane(&pts).unwrap();
        assert!((p.normal - n).norm() < 1e-7, "{p:?}");
        assert!((p.offset - 0.5).abs() < 1e-7, "{p:?}");
    }
}
