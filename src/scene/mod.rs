//! A built-in scene and simulated range scanners, so octoquant runs with nothing to download.
//!
//! - [`Scene`]: solid shapes (parry3d) that rays hit; [`Scene::builtin`] is a small building
//!   (rooms, a corridor, furniture, pillars) on a flat floor, opening onto a sloped ground
//!   with crates and a fence. [`Scene::from_shapes`] takes any shapes.
//! - [`TerrestrialScanner`]: a tripod scanner sweeping a fixed angular step in azimuth and
//!   elevation from a few stations, so point density falls with range as on real scanners.
//! - [`SpinningLidar`]: a multi-beam spinning LiDAR (rings × columns per revolution) carried
//!   along a path at a fixed height above the ground, one frame per revolution.
//! - [`City`]: a seeded synthetic city (blocks of buildings, streets, trees, parked cars) and
//!   a route for a car-mounted [`SpinningLidar`] through its streets, for city-scale runs.
//! - [`scan_terrestrial`] / [`scan_lidar`] turn either into [`Frame`](crate::Frame)s in world
//!   coordinates under [`ScanOptions`] (seed, range noise, what to do with misses).
//!
//! Everything is deterministic for a seed: the noise comes from a small built-in generator
//! seeded per frame, so the same options give the same points, bit for bit, on every run.
//!
//! **Misses.** A beam that hits nothing within `max_range` returns, with
//! [`MissPolicy::MaxRange`] (the default), a point [`MISS_RANGE_FACTOR`] × `max_range` along
//! the beam. Inserted with the same `max_range` (OctoMap's `maxrange`), such a point clears
//! space up to `max_range` and marks nothing occupied, which is how OctoMap users carve free
//! space from no-return beams. Inserted *without* a range limit it would create phantom
//! obstacles, so use [`MissPolicy::Drop`] then. Each frame's miss count is in
//! [`ScanStats`].
//!
//! ```
//! use octoquant::scene::{scan_lidar, Scene, ScanOptions, SpinningLidar};
//!
//! let scene = Scene::builtin();
//! let mut lidar = SpinningLidar::builtin_path();
//! lidar.columns = 64; // a coarse, quick sweep
//! lidar.frame_spacing = 5.0;
//! let (frames, stats) = scan_lidar(&scene, &lidar, &ScanOptions::default()).unwrap();
//! assert_eq!(frames.len(), stats.len());
//! assert!(frames.iter().all(|f| f.points.len() <= 16 * 64));
//! ```

mod city;
mod depth_camera;
mod scanner;
mod shapes;

pub use city::{
    Car, City, CityBox, CityOptions, Tree, KERB_HEIGHT, MAX_BLOCKS, MAX_CITY_FRAMES,
    MAX_ROUTE_LENGTH, MOUNT_HEIGHT, SIDEWALK_WIDTH, STREET_WIDTH,
};
pub use depth_camera::{looking_along_x, scan_depth, DepthCamera};
pub use scanner::{
    scan_lidar, scan_terrestrial, MissPolicy, ScanOptions, ScanStats, SpinningLidar,
    TerrestrialScanner, MISS_RANGE_FACTOR,
};

use crate::query::convert::{point_from_parry, pose_to_parry, vector_to_parry};
use nalgebra::{Isometry3, Point3, Vector3};
use parry3d::query::{Ray, RayCast};
use parry3d::shape::{Compound, SharedShape};

/// Errors from building a scene or scanning it.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SceneError {
    /// A scene needs at least one shape.
    #[error("a scene needs at least one shape")]
    Empty,
    /// Shape `index` cannot be part of a scene (a compound or mesh-of-shapes, or non-finite).
    #[error("scene shape {index}: {message}")]
    BadShape {
        /// Position of the shape in the list given.
        index: usize,
        /// What is wrong with it.
        message: String,
    },
    /// A scanner or scan option is out of range.
    #[error("invalid scan option {name}: {message}")]
    InvalidOption {
        /// The option's field name.
        name: &'static str,
        /// Why it is invalid.
        message: String,
    },
}

/// Solid shapes that simulated rays hit: a parry3d compound with its bounding volume tree.
#[derive(Clone)]
pub struct Scene {
    compound: Compound,
}

impl std::fmt::Debug for Scene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Scene")
            .field("shapes", &self.compound.shapes().len())
            .finish_non_exhaustive()
    }
}

impl Scene {
    /// The built-in scene: a 24 m × 16 m building without a roof (three rooms south of an
    /// east–west corridor, a hall split in two north of it, furniture, pillars), its corridor
    /// opening east onto ground sloping up 2.5 m over 16 m, with crates and a fence on it.
    ///
    /// z is up, the building floor is at z = 0 and spans x ∈ [0, 24], y ∈ [0, 16].
    pub fn builtin() -> Scene {
        // The built-in shape list is non-empty and holds only simple shapes.
        match Scene::from_parry_shapes(shapes::builtin_shapes()) {
            Ok(s) => s,
            Err(e) => unreachable!("built-in scene is valid: {e}"),
        }
    }

    /// A scene from shapes placed by nalgebra isometries (metres).
    ///
    /// Errors when the list is empty, when a shape is itself composite (parry compounds
    /// cannot nest; give the parts instead) or when a pose is not finite.
    pub fn from_shapes(shapes: Vec<(Isometry3<f64>, SharedShape)>) -> Result<Scene, SceneError> {
        for (index, (iso, _)) in shapes.iter().enumerate() {
            let finite = iso.translation.vector.iter().all(|v| v.is_finite())
                && iso.rotation.coords.iter().all(|v| v.is_finite());
            if !finite {
                return Err(SceneError::BadShape {
                    index,
                    message: "pose is not finite".into(),
                });
            }
        }
        Scene::from_parry_shapes(
            shapes
                .into_iter()
                .map(|(iso, s)| (pose_to_parry(&iso), s))
                .collect(),
        )
    }

    fn from_parry_shapes(
        shapes: Vec<(parry3d::math::Pose, SharedShape)>,
    ) -> Result<Scene, SceneError> {
        if shapes.is_empty() {
            return Err(SceneError::Empty);
        }
        for (index, (_, s)) in shapes.iter().enumerate() {
            if s.as_composite_shape().is_some() {
                return Err(SceneError::BadShape {
                    index,
                    message: "composite shapes cannot be nested in a scene; pass their parts"
                        .into(),
                });
            }
        }
        Ok(Scene {
            compound: Compound::new(shapes),
        })
    }

    /// Number of shapes.
    pub fn len(&self) -> usize {
        self.compound.shapes().len()
    }

    /// Always `false`: a scene has at least one shape.
    pub fn is_empty(&self) -> bool {
        self.compound.shapes().is_empty()
    }

    /// Axis-aligned bounds of all shapes (min, max) in metres.
    pub fn bounds(&self) -> (Point3<f64>, Point3<f64>) {
        let aabb = self.compound.local_aabb();
        (point_from_parry(aabb.mins), point_from_parry(aabb.maxs))
    }

    /// Distance from `origin` along the unit vector of `direction` to the first surface, if
    /// one lies within `max_range`. `None` for a zero or non-finite direction.
    ///
    /// Shapes are solid: an origin inside a shape gives distance 0.
    pub fn cast_ray(
        &self,
        origin: &Point3<f64>,
        direction: &Vector3<f64>,
        max_range: f64,
    ) -> Option<f64> {
        let n = direction.norm();
        let usable = n.is_finite() && n > 0.0 && max_range >= 0.0;
        if !usable {
            return None;
        }
        let ray = Ray::new(
            vector_to_parry(&origin.coords),
            vector_to_parry(&(direction / n)),
        );
        self.compound
            .cast_local_ray(&ray, max_range as f32, true)
            .map(f64::from)
    }

    /// Height of the highest surface below `(x, y)`, looking down from 100 m above the scene
    /// (furniture counts as ground); `None` when nothing is below.
    pub fn ground_height(&self, x: f64, y: f64) -> Option<f64> {
        let top = self.bounds().1.z + 100.0;
        let d = self.cast_ray(
            &Point3::new(x, y, top),
            &Vector3::new(0.0, 0.0, -1.0),
            top - self.bounds().0.z + 1.0,
        )?;
        Some(top - d)
    }
}
