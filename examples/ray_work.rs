//! The work OctoMap's insertion does on a set of frames, counted: rays, DDA steps (the keys
//! `computeRayKeys` returns per ray, summed over every ray) and the distinct free and occupied
//! voxels each frame updates. Profiles divide instruction counts by these (BENCHMARKS.md, "What
//! the profiles say").
//!
//! `cargo run --release --example ray_work -- INPUT RES [FRAMES [OUT.frames]]`: with OUT, the
//! frames counted are also written as a `.frames` file (for the reference program and `map`
//! under a profiler, on exactly these frames).

use nalgebra::Point3;
use octoquant::formats::{frame_stream, ReadOptions};
use octoquant::pipeline::{Mapper, MapperOptions};
use octoquant_raycast::{compute_ray_keys_f32, KeyRay};
use std::path::PathBuf;

fn main() {
    if let Err(e) = run() {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let usage = "usage: ray_work INPUT RES [FRAMES [OUT.frames]]";
    let input = PathBuf::from(args.next().ok_or(usage)?);
    let res: f64 = args.next().ok_or(usage)?.parse()?;
    let frames: usize = match args.next() {
        Some(n) => n.parse()?,
        None => usize::MAX,
    };
    let out = args.next().map(PathBuf::from);
    let mut kept = Vec::new();
    let mut mapper = Mapper::new(MapperOptions {
        resolution: res,
        ..MapperOptions::default()
    })?;
    let conv = mapper.tree().converter().clone();
    let mut ray = KeyRay::new();
    let (mut n, mut points, mut rays, mut steps, mut free, mut occupied) = (0, 0, 0, 0, 0, 0);
    for frame in frame_stream(&input, &ReadOptions::default())?.take(frames) {
        let frame = frame?;
        let origin: Point3<f32> = frame.origin;
        for p in &frame.points {
            if compute_ray_keys_f32(&conv, &origin, p, &mut ray) {
                rays += 1;
                steps += ray.len();
            }
        }
        let st = mapper.insert(&frame);
        n += 1;
        points += st.points;
        free += st.free;
        occupied += st.occupied;
        if out.is_some() {
            kept.push(frame);
        }
    }
    if let Some(out) = &out {
        octoquant::formats::frames::write_frames_file(out, &kept)?;
    }
    println!("frames {n}");
    println!("points {points}");
    println!("rays {rays}");
    println!("dda_steps {steps}");
    println!("free_updates {free}");
    println!("occupied_updates {occupied}");
    Ok(())
}
