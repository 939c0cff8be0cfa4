//! How well a map predicts scans: OctoMap's `eval_octree_accuracy`.
//!
//! For each scan evaluated, the voxels OctoMap's `computeUpdate` would touch are listed (the
//! free voxels along the rays and the occupied voxels at their end points, each once,
//! occupied winning; see [`octoquant_raycast::compute_update_f32`]) and looked up in the map,
//! which is only queried, never changed:
//!
//! - a free voxel is *correct* when the map holds it free, *wrong* when it holds it occupied;
//! - an end-point voxel is *correct* when the map holds it occupied, *wrong* when free;
//! - either is *unknown* when the map knows nothing there.
//!
//! The figure the tool prints is `correct / (correct + wrong)` ([`Accuracy::share_correct`]).
//!
//! [`cross_validate`] is the tool's whole protocol: scans are numbered from 1, every scan whose
//! number is a multiple of 5 is held out, the others build a map (OctoMap's `insertPointCloud`
//! at the given resolution and maximum range), and the held-out scans are evaluated against
//! it. [`evaluate_scan`] evaluates one scan against any map.
//!
//! ```
//! use nalgebra::Point3;
//! use octoquant::eval::{cross_validate, CrossValidation};
//! use octoquant::Frame;
//!
//! // five views of the same wall: four build the map, the fifth is held out and checked
//! let wall: Vec<Point3<f64>> = (0..100)
//!     .map(|i| Point3::new(2.02, 0.02 + 0.05 * (i % 10) as f64, 0.02 + 0.05 * (i / 10) as f64))
//!     .collect();
//! let frames: Vec<Frame> = (0..5).map(|_| Frame::new(Point3::new(0.0, 0.2, 0.2), &wall)).collect();
//! let run = cross_validate(&frames, &CrossValidation::default()).unwrap();
//! assert_eq!(run.scans_evaluated, 1);
//! assert_eq!(run.accuracy.points, 100);
//! assert_eq!(run.accuracy.wrong, 0);
//! assert_eq!(run.accuracy.unknown, 0);
//! assert_eq!(run.accuracy.share_correct(), 1.0);
//! ```

use crate::pipeline::{Mapper, MapperOptions};
use crate::Frame;
use octoquant_octree::{OcTree, OctreeError};
use octoquant_raycast::{compute_update_f32, ScanUpdate};

/// The tallies of an evaluation (what `eval_octree_accuracy` prints).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Accuracy {
    /// End points in the scans evaluated (every point, including those dropped as not
    /// finite or outside the map: the tool's `scan.size()`).
    pub points: u64,
    /// Voxels the map predicts right (free as free, end points as occupied).
    pub correct: u64,
    /// Voxels the map predicts wrong (free as occupied, end points as free).
    pub wrong: u64,
    /// Voxels the map knows nothing about.
    pub unknown: u64,
}

impl Accuracy {
    /// `correct / (correct + wrong)`, the tool's "% correct" (a share, not a percentage);
    /// NaN when no known voxel was checked, as the tool's division gives.
    pub fn share_correct(&self) -> f64 {
        self.correct as f64 / (self.correct + self.wrong) as f64
    }

    /// Voxels checked in all (`correct + wrong + unknown`).
    pub fn voxels(&self) -> u64 {
        self.correct + self.wrong + self.unknown
    }
}

/// Evaluate one scan (world coordinates) against `tree`, adding to `acc`. `max_range` is
/// OctoMap's `maxrange` (`None` = no limit): farther end points give free voxels only.
/// `scratch` is reused from scan to scan.
pub fn evaluate_scan(
    tree: &OcTree,
    frame: &Frame,
    max_range: Option<f64>,
    scratch: &mut ScanUpdate,
    acc: &mut Accuracy,
) {
    compute_update_f32(
        tree.converter(),
        &frame.points,
        &frame.origin,
        max_range,
        scratch,
    );
    acc.points += frame.points.len() as u64;
    for (keys, predicted) in [(scratch.free(), false), (scratch.occupied(), true)] {
        for key in keys {
            match tree.is_occupied(*key) {
                Some(occupied) if occupied == predicted => acc.correct += 1,
                Some(_) => acc.wrong += 1,
                None => acc.unknown += 1,
            }
        }
    }
}

/// The settings of [`cross_validate`]; `Default` is the tool's: 0.1 m, no maximum range,
/// every 5th scan held out, all scans.
#[derive(Debug, Clone, PartialEq)]
pub struct CrossValidation {
    /// How the map is built from the scans not held out (resolution, sensor model, maximum
    /// range; the maximum range also applies to the evaluation). The tool uses OctoMap's
    /// default exact insertion.
    pub mapper: MapperOptions,
    /// Scans whose 1-based number is a multiple of this are held out (the tool's 5).
    pub every: usize,
    /// Use only the first this many scans (the tool's `-n`); `None`: all.
    pub max_scans: Option<usize>,
}

impl Default for CrossValidation {
    fn default() -> Self {
        CrossValidation {
            mapper: MapperOptions::default(),
            every: 5,
            max_scans: None,
        }
    }
}

/// The outcome of [`cross_validate`].
#[derive(Debug, Clone)]
pub struct CrossValidationRun {
    /// The map built from the scans not held out.
    pub tree: OcTree,
    /// Scans inserted into the map.
    pub scans_inserted: usize,
    /// Scans held out and evaluated.
    pub scans_evaluated: usize,
    /// End points in the scans considered (the first `max_scans`, inserted or held out):
    /// the tool's "data points in graph" (except for `-n 1`, where the tool counts every
    /// scan: its `getNumPoints(0)` takes node id 0 for "no limit").
    pub points_considered: u64,
    /// The tallies over the held-out scans.
    pub accuracy: Accuracy,
}

/// OctoMap's `eval_octree_accuracy` protocol on `frames`: build a map from the scans not held
/// out, evaluate the held-out ones against it. Errors only for an invalid resolution; an
/// `every` of 0 holds out nothing.
pub fn cross_validate(
    frames: &[Frame],
    options: &CrossValidation,
) -> Result<CrossValidationRun, OctreeError> {
    let used = &frames[..options
        .max_scans
        .map_or(frames.len(), |n| n.min(frames.len()))];
    let held_out = |i: usize| options.every > 0 && (i + 1).is_multiple_of(options.every);
    // the map is only evaluated, never checkpointed: no frame fingerprints
    let mut mapper = Mapper::new(options.mapper.clone())?.without_checkpoints();
    let mut scans_inserted = 0;
    for (i, f) in used.iter().enumerate() {
        if !held_out(i) {
            mapper.insert(f);
            scans_inserted += 1;
        }
    }
    let tree = mapper.into_tree();
    let mut acc = Accuracy::default();
    let mut scratch = ScanUpdate::new();
    let mut scans_evaluated = 0;
    for (i, f) in used.iter().enumerate() {
        if held_out(i) {
            evaluate_scan(&tree, f, options.mapper.max_range, &mut scratch, &mut acc);
            scans_evaluated += 1;
        }
    }
    Ok(CrossValidationRun {
        tree,
        scans_inserted,
        scans_evaluated,
        points_considered: used.iter().map(|f| f.points.len() as u64).sum(),
        accuracy: acc,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Point3;
    use octoquant_octree::{InnerNodes, Update};

    /// A naive oracle: every voxel along each ray by sampling, looked up one by one.
    #[test]
    fn evaluate_scan_counts_each_voxel_once_by_class() {
        let mut tree = OcTree::new(0.1).unwrap();
        let conv = tree.converter().clone();
        // along +x from the origin voxel: x voxels 0..=9 free, 10 occupied; voxel 5 is held
        // occupied (wrong), voxel 3 unknown, the end voxel free (wrong)
        for i in 0..=10 {
            if i == 3 {
                continue;
            }
            let key = conv
                .point_to_key(&Point3::new(0.05 + 0.1 * i as f64, 0.05, 0.05))
                .unwrap();
            let u = if i == 5 { Update::Hit } else { Update::Miss };
            tree.update_node(key, u, InnerNodes::Refresh);
        }
        let frame = Frame::new(
            Point3::new(0.05, 0.05, 0.05),
            &[Point3::new(1.05, 0.05, 0.05)],
        );
        let mut acc = Accuracy::default();
        evaluate_scan(&tree, &frame, None, &mut ScanUpdate::new(), &mut acc);
        assert_eq!(
            acc,
            Accuracy {
                points: 1,
                correct: 8,
                wrong: 2,
                unknown: 1
            }
        );
        // with a range of 0.5 m the ray stops early: only free voxels, no end point
        let mut acc = Accuracy::default();
        evaluate_scan(&tree, &frame, Some(0.5), &mut ScanUpdate::new(), &mut acc);
        assert_eq!(acc.points, 1);
        assert_eq!(acc.voxels(), 5);
        assert_eq!(acc.unknown, 1);
    }

    #[test]
    fn every_fifth_scan_is_held_out() {
        let frame = Frame::new(Point3::new(0.0, 0.0, 0.0), &[Point3::new(1.0, 0.0, 0.0)]);
        let frames = vec![frame; 12];
        let run = cross_validate(&frames, &CrossValidation::default()).unwrap();
        assert_eq!((run.scans_inserted, run.scans_evaluated), (10, 2));
        assert_eq!(run.points_considered, 12);
        let opts = CrossValidation {
            max_scans: Some(4),
            ..CrossValidation::default()
        };
        let run = cross_validate(&frames, &opts).unwrap();
        assert_eq!((run.scans_inserted, run.scans_evaluated), (4, 0));
        assert!(run.accuracy.share_correct().is_nan());
    }
}
