//! Incremental update against regenerating, timed on a real map.
//!
//! `cargo run --release -p octoquant-distance --example update_timing -- MAP.bt [ROUNDS]`
//!
//! Builds the distance map over the whole map (clamp 1 m), then for each round writes a
//! simulated new scan into the tree (a 0.4 m cube of new obstacles and the voxels around it
//! cleared, at a different place each round), and times `update` against `DistanceMap::new`
//! on the changed tree. Prints the medians; checks that both give the same distances.

use nalgebra::Point3;
use octoquant_distance::{DistanceMap, DistanceOptions};
use octoquant_octree::{InnerNodes, OcTree, Update};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let path = args.get(1).ok_or("usage: update_timing MAP.bt [ROUNDS]")?;
    let rounds: usize = args.get(2).map_or(Ok(7), |s| s.parse())?;
    let mut tree =
        octoquant_octree::io::read_tree(std::io::BufReader::new(std::fs::File::open(path)?))?;
    let res = tree.resolution();
    let (lo, hi) = tree.metric_bounds().ok_or("empty map")?;
    let opts = DistanceOptions {
        max_dist: 1.0,
        bbx_min: lo.map(|v| v + res / 2.0),
        bbx_max: hi.map(|v| v - res / 2.0),
        unknown_occupied: false,
    };
    let t = Instant::now();
    let mut map = DistanceMap::new(&tree, &opts)?;
    println!(
        "{} voxels in the box, first build {:.3} s",
        map.size().iter().product::<usize>(),
        t.elapsed().as_secs_f64()
    );
    tree.enable_change_detection(true);
    let (mut upd, mut regen) = (vec![], vec![]);
    for r in 0..rounds {
        let f = (r as f64 + 0.5) / rounds as f64;
        let c = lo + (hi - lo).component_mul(&nalgebra::Vector3::new(f, 0.5, 0.3));
        scan(&mut tree, &c, res);
        let changes = tree.num_changes_detected();
        let t = Instant::now();
        map.update(&mut tree, true)?;
        upd.push(t.elapsed().as_secs_f64());
        let t = Instant::now();
        let fresh = DistanceMap::new(&tree, &opts)?;
        regen.push(t.elapsed().as_secs_f64());
        let same = (0..200_000).all(|i| {
            let p = lo
                + (hi - lo).component_mul(&nalgebra::Vector3::new(
                    ((i * 7919) % 1000) as f64 / 1000.0,
                    ((i * 104_729) % 1000) as f64 / 1000.0,
                    ((i * 1_299_709) % 1000) as f64 / 1000.0,
                ));
            map.distance(&p).ok() == fresh.distance(&p).ok()
        });
        println!(
            "round {r}: {changes} changed voxels, update {:.4} s, regenerate {:.3} s, same distances: {same}",
            upd[r], regen[r]
        );
    }
    upd.sort_by(f64::total_cmp);
    regen.sort_by(f64::total_cmp);
    let (mu, mr) = (upd[rounds / 2], regen[rounds / 2]);
    println!(
        "median update {mu:.4} s, regenerate {mr:.3} s: update {:.0}x faster",
        mr / mu
    );
    Ok(())
}

/// A simulated scan: a cube of new obstacles, the shell around it cleared.
fn scan(tree: &mut OcTree, c: &Point3<f64>, res: f64) {
    let n = (0.2 / res).round() as i32;
    for dx in -n - 2..=n + 2 {
        for dy in -n - 2..=n + 2 {
            for dz in -n - 2..=n + 2 {
                let p = c + nalgebra::Vector3::new(dx as f64, dy as f64, dz as f64) * res;
                let Some(k) = tree.converter().point_to_key(&p) else {
                    continue;
                };
                let inside = dx.abs() <= n && dy.abs() <= n && dz.abs() <= n;
                let u = if inside {
                    Update::LogOdds(3.0)
                } else {
                    Update::LogOdds(-3.0)
                };
                tree.update_node(k, u, InnerNodes::Refresh);
            }
        }
    }
}
