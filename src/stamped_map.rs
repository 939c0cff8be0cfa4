//! Time-stamped maps: frames into an OctoMap [`StampedOcTree`], each stamped with its own
//! acquisition time, optionally forgetting obstacles not seen for a while.
//!
//! A frame goes in as OctoMap's `insertPointCloud` puts a scan into an `OcTreeStamped`: one
//! miss per free voxel, then one hit per end-point voxel, eager, every voxel and inner node
//! an update reaches stamped with the frame's time ([`StampedOcTree::insert_update_at`]). The
//! time is the frame's [`Frame::stamp`] in whole seconds (OctoMap's `time(NULL)` resolution),
//! or the system clock for inputs without time stamps. With a degrade threshold, after each
//! frame every occupied leaf whose stamp is more than that many seconds older than the frame
//! gets one miss (`degradeOutdatedNodes`), as a long-running robot calls it between scans.
//!
//! The voxel sets come from [`FrameCaster`], so every mode with per-frame sets works; exact
//! and discretize mode give OctoMap's sets (the differential test checks the `.ot` bytes
//! against liboctomap's `OcTreeStamped` with the same clock).

use crate::pipeline::{sensor_frame_to_world, CasterError, FrameCaster, FrameStats, MapperOptions};
use nalgebra::{Isometry3, UnitQuaternion};
use octoquant_formats::Frame;
use octoquant_octree::{now_seconds, InnerNodes, OctreeError, StampedOcTree};
use std::time::Instant;

/// Why a stamped map cannot be built as asked.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum StampedMapError {
    /// Lazy insertion is not offered for stamped maps.
    #[error("stamped maps are built with eager updates (no lazy insertion)")]
    Lazy,
    /// A frame time that is no `unsigned int` second (negative, beyond 2^32 − 1 or NaN).
    #[error(
        "frame {frame}: time stamp {stamp} s is not a time OctoMap can store (0 ..= 4294967295 s)"
    )]
    BadStamp {
        /// The frame's index among those inserted.
        frame: usize,
        /// Its stamp.
        stamp: f64,
    },
    /// The tree cannot be made (an invalid resolution or sensor model).
    #[error(transparent)]
    Octree(#[from] OctreeError),
    /// The ray stage cannot be made (a mode without per-frame sets).
    #[error(transparent)]
    Caster(#[from] CasterError),
}

/// Builds a [`StampedOcTree`] frame by frame (see the module docs).
pub struct StampedMapper {
    tree: StampedOcTree,
    caster: FrameCaster,
    degrade_older_than: Option<u32>,
    frames: usize,
}

impl std::fmt::Debug for StampedMapper {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StampedMapper")
            .field("degrade_older_than", &self.degrade_older_than)
            .field("frames", &self.frames)
            .field("tree", &self.tree)
            .finish_non_exhaustive()
    }
}

impl StampedMapper {
    /// A mapper into a new tree of `options.resolution` and `options.params`; with
    /// `degrade_older_than`, obstacles not seen for more than that many seconds are degraded
    /// after each frame.
    pub fn new(
        options: MapperOptions,
        degrade_older_than: Option<u32>,
    ) -> Result<Self, StampedMapError> {
        if options.lazy {
            return Err(StampedMapError::Lazy);
        }
        Ok(StampedMapper {
            tree: StampedOcTree::with_params(options.resolution, options.params)?,
            caster: FrameCaster::new(options)?,
            degrade_older_than,
            frames: 0,
        })
    }

    /// The time a frame is stamped with: its stamp in whole seconds (floor), else the system
    /// clock.
    pub fn frame_time(frame: &Frame, index: usize) -> Result<u32, StampedMapError> {
        match frame.stamp {
            None => Ok(now_seconds()),
            Some(s) if (0.0..4_294_967_296.0).contains(&s) => Ok(s.floor() as u32),
            Some(stamp) => Err(StampedMapError::BadStamp {
                frame: index,
                stamp,
            }),
        }
    }

    /// Insert one frame (world coordinates) at its time; errors, changing nothing, on a time
    /// stamp OctoMap cannot store.
    pub fn insert(&mut self, frame: &Frame) -> Result<FrameStats, StampedMapError> {
        self.insert_oriented(frame, &UnitQuaternion::identity())
    }

    /// [`StampedMapper::insert`] for a frame measured in the sensor frame: `frame`'s points
    /// are moved into the world by the sensor `pose` (sensor to world) exactly as
    /// [`crate::Mapper::insert_sensor_frame_f32`] moves them (`pose * p` in `f64`, narrowed
    /// once to `f32`; the origin is the pose's translation, `frame.origin` is not used), and
    /// the [`crate::filters::PointFilters::crop_sensor`] box is taken in the pose's axes, so
    /// that a robot's scans and poses go in as they come. The frame keeps its time stamp.
    pub fn insert_sensor_frame_f32(
        &mut self,
        frame: &Frame,
        pose: &Isometry3<f64>,
    ) -> Result<FrameStats, StampedMapError> {
        self.insert_oriented(&sensor_frame_to_world(frame, pose), &pose.rotation)
    }

    /// Insert a world-coordinate frame whose sensor has the orientation `rotation` (sensor to
    /// world; the crop box's axes).
    fn insert_oriented(
        &mut self,
        frame: &Frame,
        rotation: &UnitQuaternion<f64>,
    ) -> Result<FrameStats, StampedMapError> {
        let now = Self::frame_time(frame, self.frames)?;
        let start = Instant::now();
        let (update, mut st) = self.caster.cast_oriented(frame, rotation);
        let tree_start = Instant::now();
        self.tree.insert_update_at(
            update.free().iter().copied(),
            update.occupied().iter().copied(),
            InnerNodes::Refresh,
            now,
        );
        if let Some(thres) = self.degrade_older_than {
            self.tree.degrade_outdated_nodes_at(thres, now);
        }
        st.tree_seconds = tree_start.elapsed().as_secs_f64();
        st.seconds = start.elapsed().as_secs_f64();
        self.frames += 1;
        Ok(st)
    }

    /// Frames inserted so far.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// The tree built so far.
    pub fn tree(&self) -> &StampedOcTree {
        &self.tree
    }

    /// The tree, consuming the mapper.
    pub fn into_tree(self) -> StampedOcTree {
        self.tree
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Point3;

    fn frame(stamp: Option<f64>) -> Frame {
        Frame {
            stamp,
            ..Frame::new_f32(Point3::origin(), vec![Point3::new(1.05, 0.05, 0.05)])
        }
    }

    #[test]
    fn frames_are_stamped_with_their_time_and_stale_obstacles_degrade() {
        let mut m = StampedMapper::new(MapperOptions::default(), Some(10)).unwrap();
        m.insert(&frame(Some(100.7))).unwrap();
        let key = m
            .tree()
            .converter()
            .point_to_key(&Point3::new(1.05, 0.05, 0.05))
            .unwrap();
        assert_eq!(m.tree().timestamp(key), Some(100));
        let v0 = m.tree().search(key, 16).unwrap().node.value;
        // a frame 20 s later that does not see the voxel: it is degraded once
        let mut far = frame(Some(120.0));
        far.points = vec![Point3::new(-3.05, 0.05, 0.05)];
        m.insert(&far).unwrap();
        let v1 = m.tree().search(key, 16).unwrap().node.value;
        assert!(v1 < v0, "{v1} {v0}");
        assert_eq!(m.tree().timestamp(key), Some(100));
        assert_eq!(m.tree().last_update_time(), 120);
        for bad in [-1.0, f64::NAN, 5e9] {
            assert!(matches!(
                m.insert(&frame(Some(bad))),
                Err(StampedMapError::BadStamp { .. })
            ));
        }
        assert_eq!(m.frames(), 2);
    }
}
