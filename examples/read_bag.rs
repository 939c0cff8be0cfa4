//! MCAP -> frames -> map: read `sensor_msgs/PointCloud2` from a ROS 1 or ROS 2 bag, place each
//! cloud with `/tf_static` and `/tf`, insert into a map and write it.
//!
//! `cargo run --release --example read_bag -- BAG.mcap [TOPIC] [OUT.bt]`, e.g. with
//! `$OCTOQUANT_DATA/mcap/pointcloudset_ouster_os1/test.mcap`.

use octoquant::formats::mcap::{list_topics, read_mcap, McapOptions};
use octoquant::pipeline::{Mapper, MapperOptions};
use octoquant::treefile::write_tree_file;
use std::path::PathBuf;

fn main() {
    if let Err(e) = run() {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let Some(bag) = args.next().map(PathBuf::from) else {
        return Err("usage: read_bag BAG.mcap [TOPIC] [OUT.bt]".into());
    };
    for t in list_topics(&bag)? {
        println!("{:<32} {:<32} {}", t.topic, t.schema, t.encoding);
    }
    let options = McapOptions {
        topic: args.next().filter(|t| !t.is_empty()),
        ..McapOptions::default()
    };
    let out = PathBuf::from(args.next().unwrap_or_else(|| "bag.bt".into()));

    let (frames, stats) = read_mcap(&bag, &options)?;
    let mut mapper = Mapper::new(MapperOptions {
        resolution: 0.05,
        ..MapperOptions::default()
    })?;
    for (frame, s) in frames.iter().zip(&stats) {
        mapper.insert(frame);
        println!(
            "cloud at {:.3} s: {} points, {} kept, {} at (0,0,0), {} NaN",
            frame.stamp.unwrap_or(0.0),
            s.points,
            s.kept,
            s.zero,
            s.non_finite
        );
    }
    let mut tree = mapper.into_tree();
    write_tree_file(&mut tree, &out)?;
    println!("wrote {} ({} leaves)", out.display(), tree.num_leaves());
    Ok(())
}
