//! Load a .bt map and ask what a planner asks: is this point occupied, free or unknown; does
//! a robot-sized shape at a pose collide; which occupied voxels are around it.
//!
//! `cargo run --release --example query_map -- MAP.bt [X Y Z]` (try the `map.bt` written by
//! `octoquant demo`).

use nalgebra::{Isometry3, Point3, UnitQuaternion, Vector3};
use octoquant::parry3d::math::Vector;
use octoquant::parry3d::shape::{Capsule, Cuboid};
use octoquant::query::{collides, colliding_voxels, occupied_in_bbox, CollisionOptions};
use octoquant::treefile::read_tree_file;

fn main() {
    if let Err(e) = run() {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.first() else {
        return Err("usage: query_map MAP.bt [X Y Z]".into());
    };
    let tree = read_tree_file(path.as_ref())?;
    let xyz: Vec<f64> = args[1..]
        .iter()
        .map(|s| s.parse())
        .collect::<Result<_, _>>()?;
    let p = match xyz.as_slice() {
        [x, y, z] => Point3::new(*x, *y, *z),
        _ => Point3::new(22.0, 8.0, 1.0),
    };

    // Occupancy of one point: None = unknown.
    let state = match tree.search_point(&p) {
        None => "unknown".to_string(),
        Some(n) if tree.params().is_occupied(n.value) => format!("occupied (depth {})", n.depth),
        Some(n) => format!("free (depth {})", n.depth),
    };
    println!("{p}: {state}");

    // A robot body: a vertical capsule 1.2 m tall, 0.3 m radius, standing at p.
    let body = Capsule::new_z(0.3, 0.3);
    let pose = Isometry3::translation(p.x, p.y, p.z);
    let strict = collides(&tree, &body, &pose, &CollisionOptions::default())?;
    let cautious = collides(
        &tree,
        &body,
        &pose,
        &CollisionOptions {
            unknown_is_occupied: true,
        },
    )?;
    println!("capsule at {p}: collides {strict}, counting unknown as occupied {cautious}");

    // A box turned 45° about z, and what it touches.
    let cart = Cuboid::new(Vector::new(1.0, 0.4, 0.5));
    let turned = Isometry3::from_parts(
        p.coords.into(),
        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), std::f64::consts::FRAC_PI_4),
    );
    let touching = colliding_voxels(&tree, &cart, &turned)?;
    let around = occupied_in_bbox(&tree, &cart, &turned)?;
    println!(
        "turned box: touches {} occupied leaves, {} occupied leaves in its bounding box",
        touching.len(),
        around.len()
    );
    if let Some(v) = touching.first() {
        println!("  first: centre {} size {} m", v.center, v.size);
    }
    Ok(())
}
