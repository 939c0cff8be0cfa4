//! The built-in scene's layout: walls, floor, furniture and the sloped ground as parry shapes.
//!
//! Units are metres, z is up. The building has no roof so a top view shows its inside.

use parry3d::math::{Pose, Rot3, Vector};
use parry3d::shape::SharedShape;

/// Wall height and thickness.
const WALL_H: f32 = 3.0;
const WALL_T: f32 = 0.2;
/// Rise of the sloped ground over its length (east of the building, x from 24 to 40).
pub(crate) const SLOPE_RISE: f32 = 2.5;
pub(crate) const SLOPE_X0: f32 = 24.0;
pub(crate) const SLOPE_X1: f32 = 40.0;

/// An axis-aligned box from its min and max corners.
fn aabox(out: &mut Vec<(Pose, SharedShape)>, min: [f32; 3], max: [f32; 3]) {
    let c = Vector::new(
        (min[0] + max[0]) / 2.0,
        (min[1] + max[1]) / 2.0,
        (min[2] + max[2]) / 2.0,
    );
    let h = [
        (max[0] - min[0]) / 2.0,
        (max[1] - min[1]) / 2.0,
        (max[2] - min[2]) / 2.0,
    ];
    out.push((
        Pose::from_translation(c),
        SharedShape::cuboid(h[0], h[1], h[2]),
    ));
}

/// A wall along x at `y` (centre line) from `x0` to `x1`, with door gaps `[a, b]` along x.
fn wall_x(out: &mut Vec<(Pose, SharedShape)>, y: f32, x0: f32, x1: f32, doors: &[(f32, f32)]) {
    let mut start = x0;
    for &(a, b) in doors {
        if a > start {
            aabox(
                out,
                [start, y - WALL_T / 2.0, 0.0],
                [a, y + WALL_T / 2.0, WALL_H],
            );
        }
        start = b;
    }
    if x1 > start {
        aabox(
            out,
            [start, y - WALL_T / 2.0, 0.0],
            [x1, y + WALL_T / 2.0, WALL_H],
        );
    }
}

/// A wall along y at `x` from `y0` to `y1`, with door gaps along y.
fn wall_y(out: &mut Vec<(Pose, SharedShape)>, x: f32, y0: f32, y1: f32, doors: &[(f32, f32)]) {
    let mut start = y0;
    for &(a, b) in doors {
        if a > start {
            aabox(
                out,
                [x - WALL_T / 2.0, start, 0.0],
                [x + WALL_T / 2.0, a, WALL_H],
            );
        }
        start = b;
    }
    if y1 > start {
        aabox(
            out,
            [x - WALL_T / 2.0, start, 0.0],
            [x + WALL_T / 2.0, y1, WALL_H],
        );
    }
}

/// Height of the sloped ground's top surface at `x` (0 west of it).
pub(crate) fn slope_height(x: f32) -> f32 {
    ((x - SLOPE_X0) / (SLOPE_X1 - SLOPE_X0)).clamp(0.0, 1.0) * SLOPE_RISE
}

/// The built-in scene's shapes.
pub(crate) fn builtin_shapes() -> Vec<(Pose, SharedShape)> {
    let mut s = Vec::new();
    // Floor of the building and a strip around it.
    aabox(&mut s, [-3.0, -3.0, -0.3], [SLOPE_X0, 19.0, 0.0]);

    // Outer walls; the corridor opens east onto the slope, a door opens south.
    wall_x(&mut s, 0.1, 0.0, 24.0, &[(13.0, 14.4)]);
    wall_x(&mut s, 15.9, 0.0, 24.0, &[]);
    wall_y(&mut s, 0.1, 0.2, 15.8, &[]);
    wall_y(&mut s, 23.9, 0.2, 15.8, &[(7.1, 8.9)]);

    // Corridor (y from 7 to 9) with doors into the rooms.
    wall_x(
        &mut s,
        7.0,
        0.2,
        23.8,
        &[(3.0, 4.2), (11.0, 12.2), (19.0, 20.2)],
    );
    wall_x(&mut s, 9.0, 0.2, 23.8, &[(5.0, 6.2), (17.0, 18.2)]);
    // Three rooms south, a hall split in two (with a wide opening) north.
    wall_y(&mut s, 8.0, 0.2, 6.9, &[]);
    wall_y(&mut s, 16.0, 0.2, 6.9, &[]);
    wall_y(&mut s, 12.0, 9.1, 15.8, &[(11.5, 13.5)]);

    // South-west room: a table, a shelf, a ball on the table.
    aabox(&mut s, [1.0, 1.0, 0.0], [2.6, 1.8, 0.75]);
    aabox(&mut s, [6.0, 0.4, 0.0], [7.6, 0.8, 2.0]);
    s.push((Pose::translation(1.8, 1.4, 1.05), SharedShape::ball(0.3)));
    // Middle room: crates, one turned 30 degrees.
    aabox(&mut s, [9.0, 1.0, 0.0], [10.0, 2.0, 1.0]);
    aabox(&mut s, [9.0, 1.0, 1.0], [9.8, 1.8, 1.6]);
    s.push((
        Pose::from_parts(
            Vector::new(13.5, 4.0, 0.6),
            Rot3::from_rotation_z(std::f32::consts::FRAC_PI_6),
        ),
        SharedShape::cuboid(0.8, 0.5, 0.6),
    ));
    // South-east room: a long bench and a cabinet.
    aabox(&mut s, [17.0, 3.0, 0.0], [22.0, 4.0, 0.9]);
    aabox(&mut s, [22.8, 0.6, 0.0], [23.6, 2.0, 1.8]);
    // North halls: pillars (cylinders stood up along z) and tables.
    for (x, y) in [(3.0, 12.5), (8.0, 12.5), (16.0, 11.5), (20.0, 13.5)] {
        s.push((
            Pose::from_parts(
                Vector::new(x, y, WALL_H / 2.0),
                Rot3::from_rotation_x(std::f32::consts::FRAC_PI_2),
            ),
            SharedShape::cylinder(WALL_H / 2.0, 0.25),
        ));
    }
    aabox(&mut s, [1.0, 14.0, 0.0], [4.0, 15.0, 0.75]);
    aabox(&mut s, [18.0, 10.0, 0.0], [21.0, 10.8, 0.75]);

    // Sloped ground east of the building: a thick slab tilted about y.
    let len = SLOPE_X1 - SLOPE_X0;
    let angle = (SLOPE_RISE / len).atan();
    let half_len = (len * len + SLOPE_RISE * SLOPE_RISE).sqrt() / 2.0;
    let thick = 0.3f32;
    let centre_top = Vector::new((SLOPE_X0 + SLOPE_X1) / 2.0, 8.0, SLOPE_RISE / 2.0);
    // Rotating by -angle about y takes x to (cos a, 0, sin a) and z to (-sin a, 0, cos a).
    let normal = Vector::new(-angle.sin(), 0.0, angle.cos());
    s.push((
        Pose::from_parts(
            centre_top - normal * (thick / 2.0),
            Rot3::from_rotation_y(-angle),
        ),
        SharedShape::cuboid(half_len, 11.0, thick / 2.0),
    ));
    // Crates on the slope (sunk 0.2 m so they sit on it) and a fence at its top.
    for (x, y, w, h) in [
        (28.0, 4.0, 1.2, 1.2),
        (31.0, 12.0, 2.0, 0.8),
        (35.0, 6.0, 1.0, 2.0),
    ] {
        let z0 = slope_height(x - w / 2.0) - 0.2;
        aabox(
            &mut s,
            [x - w / 2.0, y - w / 2.0, z0],
            [x + w / 2.0, y + w / 2.0, z0 + h + 0.2],
        );
    }
    aabox(
        &mut s,
        [SLOPE_X1 - 0.6, -2.5, SLOPE_RISE - 0.5],
        [SLOPE_X1 - 0.4, 18.5, SLOPE_RISE + 1.2],
    );
    s
}

/// The built-in LiDAR path (x, y) through the building: up the corridor from the slope, into
/// rooms and halls.
pub(crate) fn builtin_path() -> Vec<[f64; 2]> {
    vec![
        [36.0, 8.0],
        [25.0, 8.0],
        [19.6, 8.0],
        [19.6, 5.0],
        [19.6, 8.0],
        [17.6, 8.0],
        [17.6, 12.5],
        [5.6, 12.5],
        [5.6, 8.0],
        [3.6, 8.0],
        [3.6, 3.5],
    ]
}

/// The built-in terrestrial scanner stations (x, y); heights come from the ground.
pub(crate) fn builtin_stations() -> Vec<[f64; 2]> {
    vec![[4.5, 4.0], [10.0, 12.0], [30.0, 8.0]]
}
