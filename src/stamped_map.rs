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
use nalgebra::{Isometry3, Point3, UnitQuaternion};
use octoquant_formats::Frame;
use octoquant_octree::{now_seconds, InnerNodes, OctreeError, StampedOcTree};
use octoquant_raycast::ScanUpdate;
use std::borrow::Borrow;
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
    /// The pipeline's two updates and its scratch, kept from one run to the next.
    buffers: Buffers,
}

/// The sets a pipelined run casts into: the frame going into the tree, the next one, and the
/// casting's scratch.
#[derive(Default)]
struct Buffers {
    cur: ScanUpdate,
    next: ScanUpdate,
    centres: Vec<Point3<f32>>,
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
            buffers: Buffers::default(),
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
        Ok(self.insert_at(frame, rotation, now))
    }

    /// Cast `frame` and put it into the tree at time `now`.
    fn insert_at(&mut self, frame: &Frame, rotation: &UnitQuaternion<f64>, now: u32) -> FrameStats {
        let start = Instant::now();
        let (update, mut st) = self.caster.cast_oriented(frame, rotation);
        st.tree_seconds = apply_at(&mut self.tree, update, now, self.degrade_older_than);
        st.seconds = start.elapsed().as_secs_f64();
        self.frames += 1;
        st
    }

    /// Insert frames (world coordinates) in order, each at its time, with the same tree and
    /// stamps as [`StampedMapper::insert`] on each in turn, but pipelined when rayon has a
    /// thread to spare: while frame `i` goes into the tree, the rays of frame `i + 1` are cast
    /// (on LiDAR the tree update, with its stamps, is the larger part). A frame without a
    /// stamp is stamped by the clock as it goes into the tree, as `insert` stamps it.
    ///
    /// `after` is called with each frame's statistics and time once it is in the tree. The run
    /// stops at the first error, with the frames before it in the tree: one from the source
    /// (`frames`), from `after`, or a time stamp OctoMap cannot store (that frame not inserted).
    pub fn insert_stream<F, E>(
        &mut self,
        frames: impl Iterator<Item = Result<F, E>>,
        mut after: impl FnMut(&StampedMapper, &FrameStats, u32) -> Result<(), E>,
    ) -> Result<(), E>
    where
        F: Borrow<Frame> + Sync,
        E: From<StampedMapError>,
    {
        let mut frames = frames;
        if rayon::current_num_threads() < 2 {
            for f in frames {
                let f = f?;
                let now = Self::frame_time(f.borrow(), self.frames)?;
                let st = self.insert_at(f.borrow(), &UnitQuaternion::identity(), now);
                after(self, &st, now)?;
            }
            return Ok(());
        }
        let mut buffers = std::mem::take(&mut self.buffers);
        let result = self.pipeline(&mut frames, &mut after, &mut buffers);
        self.buffers = buffers;
        result
    }

    /// The pipelined loop of [`StampedMapper::insert_stream`], casting into `buffers`.
    fn pipeline<F, E>(
        &mut self,
        frames: &mut impl Iterator<Item = Result<F, E>>,
        after: &mut impl FnMut(&StampedMapper, &FrameStats, u32) -> Result<(), E>,
        buffers: &mut Buffers,
    ) -> Result<(), E>
    where
        F: Borrow<Frame> + Sync,
        E: From<StampedMapError>,
    {
        let Some(first) = frames.next() else {
            return Ok(());
        };
        let mut frame = first?;
        check_stamp(frame.borrow(), self.frames)?;
        let Buffers { cur, next, centres } = buffers;
        let mut mark = Instant::now();
        let mut st = self.caster.cast_into(frame.borrow(), cur, centres);
        loop {
            let upcoming = frames.next();
            // a frame's time is read as it goes into the tree (the clock, for no stamp)
            let now = Self::frame_time(frame.borrow(), self.frames)?;
            let next_stamp = match &upcoming {
                Some(Ok(f)) => check_stamp(f.borrow(), self.frames + 1),
                _ => Ok(()),
            };
            let cast_next = next_stamp.is_ok();
            let StampedMapper {
                tree,
                caster,
                degrade_older_than,
                ..
            } = self;
            let degrade = *degrade_older_than;
            let (tree_s, next_st) = match (&upcoming, cast_next) {
                (Some(Ok(f)), true) => {
                    // the tree needs only `cur`'s sets: its working buffers go to the next cast
                    next.pass_buffers(cur);
                    let (t, n) = rayon::join(
                        || apply_at(tree, cur, now, degrade),
                        || caster.cast_into(f.borrow(), next, centres),
                    );
                    (t, Some(n))
                }
                _ => (apply_at(tree, cur, now, degrade), None),
            };
            self.frames += 1;
            st.tree_seconds = tree_s;
            st.seconds = mark.elapsed().as_secs_f64();
            mark = Instant::now();
            after(self, &st, now)?;
            // the next frame's stamp that cannot be stored: the error `insert` gives
            next_stamp?;
            match (upcoming, next_st) {
                (Some(Ok(f)), Some(n)) => {
                    std::mem::swap(cur, next);
                    frame = f;
                    st = n;
                }
                (Some(Err(e)), _) => return Err(e),
                _ => return Ok(()),
            }
        }
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

/// A frame's sets into the stamped tree at time `now` (OctoMap's `insertPointCloud` into an
/// `OcTreeStamped`), then the degrading; returns the seconds it took.
fn apply_at(tree: &mut StampedOcTree, update: &ScanUpdate, now: u32, degrade: Option<u32>) -> f64 {
    let start = Instant::now();
    tree.insert_bricks_at(
        update.free_bricks(),
        update.occupied_bricks(),
        InnerNodes::Refresh,
        now,
    );
    if let Some(thres) = degrade {
        tree.degrade_outdated_nodes_at(thres, now);
    }
    start.elapsed().as_secs_f64()
}

/// A given time stamp's check (the clock, read later, needs none): the frame at `index`.
fn check_stamp(frame: &Frame, index: usize) -> Result<(), StampedMapError> {
    match frame.stamp {
        Some(_) => StampedMapper::frame_time(frame, index).map(|_| ()),
        None => Ok(()),
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

    /// The pipelined run equals inserting frame by frame: the same nodes, values and stamps,
    /// degrading included, and the same per-frame times; a stamp OctoMap cannot store stops it
    /// with the frames before in the tree.
    #[test]
    fn insert_stream_is_insert_frame_by_frame() {
        use crate::scene::{scan_lidar, ScanOptions, Scene, SpinningLidar};
        let scene = Scene::builtin();
        let (mut frames, _) = scan_lidar(
            &scene,
            &SpinningLidar::builtin_path(),
            &ScanOptions::default(),
        )
        .unwrap();
        frames.truncate(6);
        for (i, f) in frames.iter_mut().enumerate() {
            f.stamp = Some(100.0 + 0.7 * i as f64);
        }
        let options = MapperOptions {
            resolution: 0.2,
            ..MapperOptions::default()
        };
        let one_by_one = |frames: &[Frame]| {
            let mut m = StampedMapper::new(options.clone(), Some(1)).unwrap();
            for f in frames {
                m.insert(f).unwrap();
            }
            m.into_tree().nodes_with_stamps()
        };
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let piped = |frames: &[Frame]| {
            pool.install(|| {
                let mut m = StampedMapper::new(options.clone(), Some(1)).unwrap();
                let mut times = Vec::new();
                let r = m.insert_stream(
                    frames.iter().map(Ok::<&Frame, StampedMapError>),
                    |mapper, _, now| {
                        times.push((mapper.frames(), now));
                        Ok(())
                    },
                );
                (r, times, m.into_tree().nodes_with_stamps())
            })
        };
        let (r, times, nodes) = piped(&frames);
        assert!(r.is_ok());
        let want: Vec<(usize, u32)> = (0..6)
            .map(|i| (i + 1, (100.0 + 0.7 * i as f64) as u32))
            .collect();
        assert_eq!(times, want);
        assert_eq!(nodes, one_by_one(&frames));
        // frame 3's time cannot be stored: frames 0-2 go in, then the error
        frames[3].stamp = Some(-1.0);
        let (r, times, nodes) = piped(&frames);
        assert!(
            matches!(r, Err(StampedMapError::BadStamp { frame: 3, .. })),
            "{r:?}"
        );
        assert_eq!(times.len(), 3);
        assert_eq!(nodes, one_by_one(&frames[..3]));
    }
}
