//! The coloured and stamped mappers' sensor-frame insertions against their naive definition:
//! the points outside the crop box in the sensor's own axes, moved into the world by
//! `pose * p` in `f64` narrowed once, inserted from the pose's translation.

use crate::color_map::{ColorMapper, ColorMerge};
use crate::filters::{CropBox, PointFilters};
use crate::stamped_map::StampedMapper;
use crate::{Frame, MapperOptions};
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion};
use octoquant_octree::io::{write_color_ot, write_stamped_ot};
use octoquant_octree::Color;

/// A turned and moved pose; a coloured, stamped cloud around the sensor in its own frame;
/// a crop box (in the sensor's axes) that holds part of it; and the naive world frame of
/// the points the box keeps, with their colours and the same stamp.
struct Case {
    pose: Isometry3<f64>,
    local: Frame,
    filters: PointFilters,
    kept_world: Frame,
}

fn case() -> Case {
    let pose = Isometry3::from_parts(
        Translation3::new(1.0, -2.0, 0.5),
        UnitQuaternion::from_euler_angles(0.3, -0.2, 1.9),
    );
    let points: Vec<Point3<f32>> = (0..3000)
        .map(|i| {
            let (a, b) = (i as f32 * 0.0137, i as f32 * 0.291);
            let r = 1.0 + (i % 13) as f32 * 0.4;
            Point3::new(r * a.cos() * b.cos(), r * a.sin() * b.cos(), r * b.sin())
        })
        .collect();
    let colors: Vec<Color> = (0..points.len())
        .map(|i| Color::new(i as u8, (i / 256) as u8, 7))
        .collect();
    let crop = CropBox::from_slice("crop_sensor", &[-1.0, -3.0, -0.5, 4.0, 0.5, 2.0]).unwrap();
    let (kept, kept_colors): (Vec<Point3<f32>>, Vec<Color>) = points
        .iter()
        .zip(&colors)
        .filter(|(p, _)| !crop.contains(&p.cast::<f64>()))
        .map(|(p, c)| ((pose * p.cast::<f64>()).cast::<f32>(), *c))
        .unzip();
    assert!(kept.len() + 200 < points.len() && kept.len() > 1000);
    let stamp = Some(1000.5);
    Case {
        pose,
        local: Frame {
            stamp,
            colors: Some(colors),
            // not used: the pose's translation is the origin
            ..Frame::new_f32(Point3::new(9.0, 9.0, 9.0), points)
        },
        filters: PointFilters {
            crop_sensor: Some(crop),
            ..PointFilters::default()
        },
        kept_world: Frame {
            stamp,
            colors: Some(kept_colors),
            ..Frame::new_f32(pose.translation.vector.cast::<f32>().into(), kept)
        },
    }
}

fn options(filters: PointFilters) -> MapperOptions {
    MapperOptions {
        resolution: 0.2,
        filters,
        ..MapperOptions::default()
    }
}

/// The shared transform itself: every point `pose * p` in `f64` narrowed once, the
/// origin the translation, stamp and colours kept, the given origin not used.
#[test]
fn world_frame_is_the_pose_applied_in_f64() {
    let c = case();
    let world = super::sensor_frame_to_world(&c.local, &c.pose);
    let want: Vec<Point3<f32>> = c
        .local
        .points
        .iter()
        .map(|p| (c.pose * p.cast::<f64>()).cast::<f32>())
        .collect();
    assert_eq!(world.points, want);
    assert_eq!(world.origin, c.kept_world.origin);
    assert_eq!(world.stamp, c.local.stamp);
    assert_eq!(world.colors, c.local.colors);
}

#[test]
fn color_mapper_sensor_frame_is_the_naive_world_frame() {
    let c = case();
    let mut m = ColorMapper::new(options(c.filters), ColorMerge::Average).unwrap();
    let mut naive =
        ColorMapper::new(options(PointFilters::default()), ColorMerge::Average).unwrap();
    // twice: the second sighting colours the voxels
    for _ in 0..2 {
        let st = m.insert_sensor_frame_f32(&c.local, &c.pose).unwrap();
        assert_eq!(
            st.dropped.crop_sensor,
            c.local.points.len() - c.kept_world.points.len()
        );
        naive.insert(&c.kept_world).unwrap();
    }
    let (mut a, mut b) = (Vec::new(), Vec::new());
    write_color_ot(m.tree(), &mut a).unwrap();
    write_color_ot(naive.tree(), &mut b).unwrap();
    assert_eq!(a, b);
    // a frame without colours is refused, changing nothing
    let bare = Frame::new_f32(Point3::origin(), c.local.points.clone());
    assert!(m.insert_sensor_frame_f32(&bare, &c.pose).is_err());
    assert_eq!(m.frames(), 2);
}

#[test]
fn stamped_mapper_sensor_frame_is_the_naive_world_frame() {
    let c = case();
    let mut m = StampedMapper::new(options(c.filters), None).unwrap();
    let mut naive = StampedMapper::new(options(PointFilters::default()), None).unwrap();
    let st = m.insert_sensor_frame_f32(&c.local, &c.pose).unwrap();
    assert_eq!(
        st.dropped.crop_sensor,
        c.local.points.len() - c.kept_world.points.len()
    );
    naive.insert(&c.kept_world).unwrap();
    let (mut a, mut b) = (Vec::new(), Vec::new());
    write_stamped_ot(m.tree(), &mut a).unwrap();
    write_stamped_ot(naive.tree(), &mut b).unwrap();
    assert_eq!(a, b);
    assert_eq!(m.tree().last_update_time(), 1000);
    // a time OctoMap cannot store is refused, changing nothing
    let late = Frame {
        stamp: Some(-1.0),
        ..c.local.clone()
    };
    assert!(m.insert_sensor_frame_f32(&late, &c.pose).is_err());
    assert_eq!(m.frames(), 1);
}

/// A depth image given in the camera's own frame keeps its pixel grid under a pose: the
/// camera turns with the points, so `exact` mode skips the covered ray heads, and the map is
/// the one of the same world points without a camera, byte for byte.
#[test]
fn depth_frame_in_the_sensor_frame_keeps_its_pixel_grid() {
    use crate::scene::{scan_depth, DepthCamera, ScanOptions, Scene};
    let scene = Scene::builtin();
    let (frames, _) = scan_depth(
        &scene,
        &DepthCamera::builtin(&scene),
        &ScanOptions::default(),
    )
    .unwrap();
    let world = &frames[0];
    let cam = world.camera.as_ref().unwrap();
    let pose = Isometry3::from_parts(
        Translation3::from(world.origin.coords.cast::<f64>()),
        UnitQuaternion::from_euler_angles(0.2, -0.4, 2.5),
    );
    // the frame as the camera saw it: points and orientation in the camera's own frame
    let inverse = pose.inverse();
    let mut local = Frame::new_f32(
        Point3::origin(),
        world
            .points
            .iter()
            .map(|p| (inverse * p.cast::<f64>()).cast::<f32>())
            .collect(),
    );
    local.stamp = world.stamp;
    let mut camera = cam.clone();
    camera.camera.rotation = inverse.rotation.to_rotation_matrix() * cam.camera.rotation;
    local.camera = Some(camera);
    let bare = Frame {
        camera: None,
        ..local.clone()
    };
    let exact = MapperOptions {
        resolution: 0.05,
        ..MapperOptions::default()
    };
    let mut with_grid = StampedMapper::new(exact.clone(), None).unwrap();
    let mut without = StampedMapper::new(exact, None).unwrap();
    let a = with_grid.insert_sensor_frame_f32(&local, &pose).unwrap();
    let b = without.insert_sensor_frame_f32(&bare, &pose).unwrap();
    assert!(
        a.heads_skipped > a.rays / 2,
        "{} of {} heads skipped",
        a.heads_skipped,
        a.rays
    );
    assert_eq!(b.heads_skipped, 0);
    assert_eq!((a.free, a.occupied), (b.free, b.occupied));
    let (mut x, mut y) = (Vec::new(), Vec::new());
    write_stamped_ot(with_grid.tree(), &mut x).unwrap();
    write_stamped_ot(without.tree(), &mut y).unwrap();
    assert_eq!(x, y);
}
