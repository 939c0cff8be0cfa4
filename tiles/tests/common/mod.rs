//! Test support shared by the tiles crate's integration tests: the frames they build maps
//! from.
#![allow(dead_code)]

use nalgebra::Point3;
use proptest::prelude::*;

/// A frame: the sensor origin and its end points.
pub type Frame = (Point3<f32>, Vec<Point3<f32>>);

/// Points on a sphere of radius `r` around `c`, about `n` of them (a Fibonacci lattice).
pub fn sphere(c: Point3<f32>, r: f32, n: usize) -> Vec<Point3<f32>> {
    let g = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
            let s = (1.0 - z * z).sqrt();
            let a = g * i as f32;
            Point3::new(c.x + r * s * a.cos(), c.y + r * s * a.sin(), c.z + r * z)
        })
        .collect()
}

/// A few distinct frames (random points plus a dense sphere around the origin), repeated in
/// random order so that voxels reach the clamps.
pub fn frames_strategy() -> impl Strategy<Value = Vec<Frame>> {
    let frame = (
        (-1.0f32..1.0, -1.0f32..1.0, -0.5f32..0.5),
        proptest::collection::vec((-3.0f32..3.0, -3.0f32..3.0, -1.5f32..1.5), 1..300),
        0usize..600,
    )
        .prop_map(|((x, y, z), pts, dense)| {
            let o = Point3::new(x, y, z);
            let mut p: Vec<Point3<f32>> = pts
                .into_iter()
                .map(|(a, b, c)| Point3::new(a, b, c))
                .collect();
            p.extend(sphere(o, 1.2, dense));
            (o, p)
        });
    (
        proptest::collection::vec(frame, 1..4),
        proptest::collection::vec(0usize..4, 1..10),
    )
        .prop_map(|(pool, picks)| {
            picks
                .into_iter()
                .map(|i| pool[i % pool.len()].clone())
                .collect()
        })
}
