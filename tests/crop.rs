//! `octoquant crop` on a real map: every voxel inside the box keeps the original's value,
//! every voxel outside is unknown, checked by point look-ups (not by the crop's own walk).

use crate::common::{self, scratch};
use nalgebra::Point3;
use octoquant::treefile::read_tree_file;
use std::process::Command;

#[test]
fn crop_keeps_exactly_the_box_on_a_real_map() {
    let Some(map) = common::data_file("octomap_reference/geb079.bt") else {
        return;
    };
    let dir = scratch("crop");
    let out = dir.join("crop.ot");
    let (lo, hi) = ([-2.0, -2.0, -0.5], [3.0, 1.5, 1.0]);
    let st = Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .arg("crop")
        .arg(&map)
        .arg("--min")
        .args(lo.map(|v: f64| v.to_string()))
        .arg("--max")
        .args(hi.map(|v: f64| v.to_string()))
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );
    let original = read_tree_file(&map).unwrap();
    let cropped = read_tree_file(&out).unwrap();
    let conv = original.converter();
    let (kl, kh) = (
        conv.point_to_key(&Point3::from(lo)).unwrap(),
        conv.point_to_key(&Point3::from(hi)).unwrap(),
    );
    // points on a grid finer than the voxels, over the box and a margin around it
    let res = original.resolution();
    let (mut inside, mut known_inside, mut outside) = (0, 0, 0);
    let steps = |a: usize| {
        let from = lo[a] - 1.0;
        let n = ((hi[a] + 1.0 - from) / (0.37 * res)) as usize;
        (0..=n).map(move |i| from + i as f64 * 0.37 * res)
    };
    for x in steps(0) {
        for y in steps(1) {
            for z in steps(2) {
                let p = Point3::new(x, y, z);
                let k = conv.point_to_key(&p).unwrap();
                let in_box = (0..3).all(|a| kl[a] <= k[a] && k[a] <= kh[a]);
                let got = cropped.search_point(&p).map(|n| n.value);
                if in_box {
                    let want = original.search_point(&p).map(|n| n.value);
                    assert_eq!(got, want, "{p:?}");
                    inside += 1;
                    known_inside += usize::from(want.is_some());
                } else {
                    assert_eq!(got, None, "{p:?}");
                    outside += 1;
                }
            }
        }
    }
    assert!(
        known_inside > 10_000 && outside > 10_000,
        "{inside} {known_inside} {outside}"
    );
    // no leaf's cube reaches outside the box (a cube crossing its edge would)
    for l in cropped.leaves() {
        let size = 1u32 << (16 - l.depth);
        for a in 0..3 {
            let first = u32::from(l.key[a]) & !(size - 1);
            let last = first + size - 1;
            assert!(
                u32::from(kl[a]) <= first && last <= u32::from(kh[a]),
                "{l:?} reaches outside the box"
            );
        }
    }
}
