//! Shared bench inputs: the real scan.dat frame when `OCTOQUANT_DATA` (or ../shared/data)
//! has it, otherwise a synthetic half-sphere scan of the same size.

#![allow(dead_code)]

use nalgebra::Point3;
use octoquant::formats::{read_frames, ReadOptions};
use octoquant::Frame;
use std::path::PathBuf;

/// The data directory, if present.
pub fn data_dir() -> Option<PathBuf> {
    let d = std::env::var_os("OCTOQUANT_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data")));
    d.is_dir().then_some(d)
}

/// OctoMap's scan.dat (88 206 points, origin 0), or a synthetic stand-in.
pub fn scan_frame() -> Frame {
    if let Some(d) = data_dir() {
        let p = d.join("lidar3d/octomap_scan_dat/scan.dat.bz2");
        if let Ok(mut f) = read_frames(&p, &ReadOptions::default()) {
            if let Some(f) = f.pop() {
                return f;
            }
        }
    }
    eprintln!("bench: scan.dat not found, using a synthetic scan");
    let mut pts = Vec::new();
    for i in 0..300 {
        for j in 0..294 {
            let az = i as f32 / 300.0 * std::f32::consts::PI - std::f32::consts::FRAC_PI_2;
            let el = j as f32 / 294.0 * 0.8 - 0.2;
            let r = 3.0 + 4.0 * ((i * 7 + j * 3) % 11) as f32 / 11.0;
            pts.push(Point3::new(
                r * el.cos() * az.cos(),
                r * el.cos() * az.sin(),
                r * el.sin(),
            ));
        }
    }
    Frame::new_f32(Point3::origin(), pts)
}
