//! Linear-time DBSCAN for sorted 1D data and line segmentation of 2D laser scans, after
//! Meglicki, "Linear time DBSCAN for sorted 1D data and laser range scan segmentation"
//! (arXiv:2103.16245).
//!
//! The main entry points: [`dbscan1d`] clusters sorted values (optionally on a circle of any
//! period) into a reusable [`Clustering`], exactly as the original DBSCAN would, in O(N) whatever
//! epsilon; [`Dbscan1dParams`] holds epsilon, `min_points`, the [`BorderPolicy`] and the period.
//! [`segment_scan`] turns the points of one laser scan into fitted [`Line`]s inside a reusable
//! [`Segmentation`], tuned by [`LineParams`]: angle clusters, distance clusters, then the
//! paper's collinear lines separation (a wall broken by a doorway gives one line per piece),
//! with an optional [`Resegment`] step for close parallel features. Two baselines from the
//! comparison the paper calls for (Nguyen et al. 2007) fill the same [`Segmentation`]:
//! [`split_and_merge`], [`incremental_lines`] (line tracking), [`ransac_lines`] and
//! [`hough_lines`] (with [`hough_peak`], the strongest accumulator cell). Errors are one
//! [`SegmentError`] enum.
//!
//! ```
//! use octoquant_segment::{dbscan1d, segment_scan, Clustering, Dbscan1dParams, LineParams,
//!     Segmentation, NOISE};
//! use std::f64::consts::PI;
//!
//! // Angles on a circle: 7pi/4, 0 and pi/4 form one cluster across the seam; pi is noise.
//! let x = [0.0, PI / 4.0, PI, 7.0 * PI / 4.0];
//! let params = Dbscan1dParams::new(PI / 2.0, 2).unwrap().with_period(2.0 * PI).unwrap();
//! let mut clusters = Clustering::new();
//! dbscan1d(&x, &params, &mut clusters).unwrap();
//! assert_eq!(clusters.labels(), &[0, 0, NOISE, 0]);
//!
//! // A corner seen from the origin: two walls, x = 3 and y = 2.
//! let mut pts: Vec<[f64; 2]> = (0..30).map(|i| [3.0, -1.0 + 0.1 * i as f64]).collect();
//! pts.extend((0..30).map(|i| [2.9 - 0.1 * i as f64, 2.0]));
//! let mut seg = Segmentation::new();
//! segment_scan(&pts, &LineParams::default(), &mut seg).unwrap();
//! assert_eq!(seg.lines().len(), 2);
//! ```
#![deny(missing_docs)]
#![forbid(unsafe_code)]

mod dbscan1d;
mod error;
mod hough_lines;
mod incremental_lines;
mod laser_lines;
mod ransac_lines;
mod split_and_merge;

pub use dbscan1d::{
    dbscan1d, dbscan1d_by, recluster_in_place, BorderPolicy, Clustering, Dbscan1dParams, NOISE,
};
pub use error::SegmentError;
pub use hough_lines::{hough_lines, hough_peak, HoughParams, HoughPeak};
pub use incremental_lines::{incremental_lines, IncrementalParams};
pub use laser_lines::{segment_scan, Line, LineParams, Resegment, Segmentation};
pub use ransac_lines::{ransac_lines, RansacParams};
pub use split_and_merge::{split_and_merge, SplitMergeParams};
