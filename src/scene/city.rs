//! A seeded synthetic city: a grid of blocks of buildings separated by streets, with
//! sidewalks, street trees and cars parked along the kerbs, and a route for a car-mounted
//! spinning LiDAR driving those streets. It gives city-scale inputs (thousands of frames over
//! hundreds of metres) with nothing to download, for tiled and distributed building.
//!
//! Layout (metres, z up, the road surface at z = 0): the centre lines of the streets run
//! north–south at the x of [`City::streets_x`] and east–west at the y of
//! [`City::streets_y`]; each street is [`STREET_WIDTH`] wide, a [`SIDEWALK_WIDTH`] sidewalk
//! (a [`KERB_HEIGHT`] slab) on each side of a road. Between the streets lie the blocks, each
//! cut into lots carrying one building (a box of varied footprint and height) or left open.
//! Trees (a trunk box and a spherical crown) stand on the sidewalks; cars (a body box and a
//! cabin box) are parked in the lane along the kerb. The route follows street centre lines
//! only, so the sensor never enters a block.
//!
//! Everything comes from [`CityOptions::seed`] through a small built-in generator: the same
//! options give the same city and the same route, bit for bit, on every machine.
//!
//! ```
//! use octoquant::scene::{scan_lidar, City, CityOptions, ScanOptions};
//!
//! let city = City::generate(&CityOptions { blocks_x: 2, blocks_y: 2, ..CityOptions::default() })
//!     .unwrap();
//! let mut lidar = city.lidar(3).unwrap(); // three frames, one per metre of route
//! lidar.columns = 90; // a coarse sweep for the example
//! let (frames, _) = scan_lidar(&city.scene(), &lidar, &ScanOptions::default()).unwrap();
//! assert_eq!(frames.len(), 3);
//! ```

use super::scanner::{invalid, SplitMix64};
use super::{Scene, SceneError, SpinningLidar};
use nalgebra::{Isometry3, Point3};
use parry3d::shape::SharedShape;

/// Width of a street between two blocks' building lines: sidewalk, road, sidewalk (metres).
pub const STREET_WIDTH: f64 = 16.0;
/// Width of each sidewalk, from the building line to the kerb (metres).
pub const SIDEWALK_WIDTH: f64 = 3.0;
/// Height of the sidewalk slabs above the road (metres).
pub const KERB_HEIGHT: f64 = 0.15;
/// Height of the LiDAR above the road, on a car's roof (metres).
pub const MOUNT_HEIGHT: f64 = 1.8;
/// Largest number of blocks along either axis (a guard against absurd sizes).
pub const MAX_BLOCKS: u32 = 64;

/// Largest number of frames [`City::lidar`] plans (100 km of route; a guard against absurd
/// sizes, as the frames of a scan are held in memory).
pub const MAX_CITY_FRAMES: usize = 100_000;
/// Longest route [`City::route`] plans, metres (longer requests are cut to it).
pub const MAX_ROUTE_LENGTH: f64 = 1.0e7;

/// Distance between frames along the route (metres): one revolution per metre.
const FRAME_SPACING: f64 = 1.0;
/// Stream tags so that layout and route draw from independent generators.
const LAYOUT_STREAM: u64 = 0x6369_7479;
const ROUTE_STREAM: u64 = 0x726f_7574;

/// What city to generate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CityOptions {
    /// Seed of the layout and of the route.
    pub seed: u64,
    /// Blocks along x (west to east), 1 to [`MAX_BLOCKS`].
    pub blocks_x: u32,
    /// Blocks along y (south to north), 1 to [`MAX_BLOCKS`].
    pub blocks_y: u32,
}

impl Default for CityOptions {
    /// Seed 0, 6 × 6 blocks (about 430 m × 430 m).
    fn default() -> Self {
        CityOptions {
            seed: 0,
            blocks_x: 6,
            blocks_y: 6,
        }
    }
}

/// An axis-aligned box, solid, from its min and max corners (metres).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CityBox {
    /// Corner with the smallest coordinates.
    pub min: Point3<f64>,
    /// Corner with the largest coordinates.
    pub max: Point3<f64>,
}

impl CityBox {
    /// Whether `p` lies inside the box or on its surface.
    pub fn contains(&self, p: &Point3<f64>) -> bool {
        (0..3).all(|i| self.min[i] <= p[i] && p[i] <= self.max[i])
    }

    fn shape(&self) -> (Isometry3<f64>, SharedShape) {
        let c = nalgebra::center(&self.min, &self.max);
        let h = (self.max - self.min) / 2.0;
        (
            Isometry3::translation(c.x, c.y, c.z),
            SharedShape::cuboid(h.x as f32, h.y as f32, h.z as f32),
        )
    }
}

/// A street tree: a trunk box standing on the sidewalk and a spherical crown on top of it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tree {
    /// The trunk.
    pub trunk: CityBox,
    /// Centre of the crown.
    pub crown_centre: Point3<f64>,
    /// Radius of the crown.
    pub crown_radius: f64,
}

/// A parked car: a body box above the road and a shorter cabin box on it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Car {
    /// The body (wheels are left out: the body floats at the height of the axles).
    pub body: CityBox,
    /// The cabin.
    pub cabin: CityBox,
}

/// A generated city: its streets and every solid object, in world coordinates.
#[derive(Debug, Clone, PartialEq)]
pub struct City {
    /// The options it was generated from.
    pub options: CityOptions,
    /// x of the centre lines of the north–south streets, increasing (`blocks_x + 1` of them).
    pub streets_x: Vec<f64>,
    /// y of the centre lines of the east–west streets, increasing (`blocks_y + 1` of them).
    pub streets_y: Vec<f64>,
    /// The road surface: one slab under everything, its top at z = 0.
    pub ground: CityBox,
    /// One slab per block, the block and its sidewalks, [`KERB_HEIGHT`] high.
    pub sidewalks: Vec<CityBox>,
    /// The buildings.
    pub buildings: Vec<CityBox>,
    /// The street trees.
    pub trees: Vec<Tree>,
    /// The parked cars.
    pub cars: Vec<Car>,
}

/// One side of a block: points are placed by a position `t` along the side (from `t0` to
/// `t1`) and a distance `d` outwards from the building line.
struct Side {
    /// The side runs along x (true) or y (false).
    along_x: bool,
    /// Coordinate of the building line across the side (y for sides along x).
    line: f64,
    /// +1 or −1: the outward direction across the side.
    out: f64,
    t0: f64,
    t1: f64,
}

impl Side {
    /// The box over positions `[ta, tb]` along the side, distances `[da, db]` outwards,
    /// heights `[za, zb]`.
    fn rect(&self, (ta, tb): (f64, f64), (da, db): (f64, f64), (za, zb): (f64, f64)) -> CityBox {
        let (ca, cb) = (self.line + self.out * da, self.line + self.out * db);
        let (c0, c1) = (ca.min(cb), ca.max(cb));
        if self.along_x {
            CityBox {
                min: Point3::new(ta, c0, za),
                max: Point3::new(tb, c1, zb),
            }
        } else {
            CityBox {
                min: Point3::new(c0, ta, za),
                max: Point3::new(c1, tb, zb),
            }
        }
    }

    fn point(&self, t: f64, d: f64, z: f64) -> Point3<f64> {
        let c = self.line + self.out * d;
        if self.along_x {
            Point3::new(t, c, z)
        } else {
            Point3::new(c, t, z)
        }
    }
}

/// Uniform in `[a, b)`.
fn uniform(g: &mut SplitMix64, a: f64, b: f64) -> f64 {
    a + (b - a) * (1.0 - g.unit())
}

/// `x` rounded to a multiple of 0.05 m, so that layouts print and compare tidily.
fn tidy(x: f64) -> f64 {
    (x * 20.0).round() / 20.0
}

/// Cut `[a, b]` into `n` pieces at jittered positions (each piece at least `min` long when
/// `b - a >= n * min`).
fn cut(g: &mut SplitMix64, a: f64, b: f64, n: usize, min: f64) -> Vec<f64> {
    let mut edges = vec![a];
    let slack = ((b - a) - n as f64 * min).max(0.0);
    let mut weights: Vec<f64> = (0..n).map(|_| uniform(g, 0.5, 1.5)).collect();
    let total: f64 = weights.iter().sum();
    for w in &mut weights {
        *w /= total;
    }
    let mut x = a;
    for w in &weights[..n - 1] {
        x += min + slack * w;
        edges.push(tidy(x));
    }
    edges.push(b);
    edges
}

impl City {
    /// Generate the city of `options`. Errors when a block count is 0 or above
    /// [`MAX_BLOCKS`].
    pub fn generate(options: &CityOptions) -> Result<City, SceneError> {
        for (name, n) in [
            ("blocks_x", options.blocks_x),
            ("blocks_y", options.blocks_y),
        ] {
            if !(1..=MAX_BLOCKS).contains(&n) {
                return Err(invalid(name, format!("{n} is not in 1..={MAX_BLOCKS}")));
            }
        }
        let mut g = SplitMix64::for_frame(options.seed, LAYOUT_STREAM);
        // block sizes between building lines: 40 to 70 m
        let mut centre_lines = |n: u32| {
            let mut lines = vec![0.0];
            for _ in 0..n {
                let size = tidy(uniform(&mut g, 40.0, 70.0));
                let last = lines[lines.len() - 1];
                lines.push(last + STREET_WIDTH + size);
            }
            lines
        };
        let streets_x = centre_lines(options.blocks_x);
        let streets_y = centre_lines(options.blocks_y);
        let margin = STREET_WIDTH / 2.0 + 20.0;
        let ground = CityBox {
            min: Point3::new(-margin, -margin, -0.5),
            max: Point3::new(
                streets_x[streets_x.len() - 1] + margin,
                streets_y[streets_y.len() - 1] + margin,
                0.0,
            ),
        };
        let mut city = City {
            options: *options,
            streets_x,
            streets_y,
            ground,
            sidewalks: Vec::new(),
            buildings: Vec::new(),
            trees: Vec::new(),
            cars: Vec::new(),
        };
        let half = STREET_WIDTH / 2.0;
        for j in 0..options.blocks_y as usize {
            for i in 0..options.blocks_x as usize {
                let (x0, x1) = (city.streets_x[i] + half, city.streets_x[i + 1] - half);
                let (y0, y1) = (city.streets_y[j] + half, city.streets_y[j + 1] - half);
                city.add_block(&mut g, [x0, x1], [y0, y1]);
            }
        }
        Ok(city)
    }

    /// One block between building lines `xs` and `ys`: its sidewalk slab, buildings on its
    /// lots, trees on its sidewalks and cars along its kerbs.
    fn add_block(&mut self, g: &mut SplitMix64, [x0, x1]: [f64; 2], [y0, y1]: [f64; 2]) {
        let s = SIDEWALK_WIDTH;
        self.sidewalks.push(CityBox {
            min: Point3::new(x0 - s, y0 - s, 0.0),
            max: Point3::new(x1 + s, y1 + s, KERB_HEIGHT),
        });
        // lots: 1 to 3 along each axis, each at least 12 m
        let lots = |g: &mut SplitMix64, a: f64, b: f64| {
            let n = 1 + (g.next_u64() % 3) as usize;
            let n = n.min(((b - a) / 12.0).floor().max(1.0) as usize);
            cut(g, a, b, n, 12.0)
        };
        let xs = lots(g, x0, x1);
        let ys = lots(g, y0, y1);
        for wy in ys.windows(2) {
            for wx in xs.windows(2) {
                // one lot in eight is left open (a yard or a square)
                if g.next_u64().is_multiple_of(8) {
                    continue;
                }
                // set back 0 to 3 m from the lot's sides, keeping at least 6 m of footprint
                let mut set = |a: f64, b: f64| {
                    let room = ((b - a) - 6.0).max(0.0) / 2.0;
                    let lo = tidy(uniform(g, 0.0, room.min(3.0)));
                    let hi = tidy(uniform(g, 0.0, room.min(3.0)));
                    (a + lo, b - hi)
                };
                let (bx0, bx1) = set(wx[0], wx[1]);
                let (by0, by1) = set(wy[0], wy[1]);
                // mostly 6 to 30 m, one building in ten a tower of up to 60 m
                let h = if g.next_u64().is_multiple_of(10) {
                    uniform(g, 30.0, 60.0)
                } else {
                    uniform(g, 6.0, 30.0)
                };
                self.buildings.push(CityBox {
                    min: Point3::new(bx0, by0, 0.0),
                    max: Point3::new(bx1, by1, tidy(h)),
                });
            }
        }
        let sides = [
            Side {
                along_x: true,
                line: y0,
                out: -1.0,
                t0: x0,
                t1: x1,
            },
            Side {
                along_x: true,
                line: y1,
                out: 1.0,
                t0: x0,
                t1: x1,
            },
            Side {
                along_x: false,
                line: x0,
                out: -1.0,
                t0: y0,
                t1: y1,
            },
            Side {
                along_x: false,
                line: x1,
                out: 1.0,
                t0: y0,
                t1: y1,
            },
        ];
        for side in &sides {
            self.add_trees(g, side);
            self.add_cars(g, side);
        }
    }

    /// Trees every 10 to 16 m along the sidewalk, 1.5 m out from the building line, some
    /// gaps.
    fn add_trees(&mut self, g: &mut SplitMix64, side: &Side) {
        let mut t = side.t0 + uniform(g, 3.0, 8.0);
        while t < side.t1 - 3.0 {
            if !g.next_u64().is_multiple_of(4) {
                let top = tidy(KERB_HEIGHT + uniform(g, 2.2, 3.5));
                let r = tidy(uniform(g, 1.2, 2.2));
                let trunk = side.rect((t - 0.15, t + 0.15), (1.35, 1.65), (KERB_HEIGHT, top));
                self.trees.push(Tree {
                    trunk,
                    crown_centre: side.point(t, 1.5, top + 0.6 * r),
                    crown_radius: r,
                });
            }
            t = tidy(t + uniform(g, 10.0, 16.0));
        }
    }

    /// Cars parked nose to tail in the lane along the kerb (0.2 to 2.0 m out from it), with
    /// gaps of 1 to 8 m, some places free.
    fn add_cars(&mut self, g: &mut SplitMix64, side: &Side) {
        let d0 = SIDEWALK_WIDTH + 0.2;
        let mut t = side.t0 + uniform(g, 1.0, 6.0);
        loop {
            let len = tidy(uniform(g, 3.8, 5.0));
            if t + len > side.t1 - 1.0 {
                break;
            }
            if g.next_u64() % 5 < 3 {
                let body = side.rect((t, t + len), (d0, d0 + 1.8), (0.3, 1.0));
                let cabin = side.rect(
                    (t + 0.25 * len, t + 0.8 * len),
                    (d0 + 0.1, d0 + 1.7),
                    (1.0, tidy(uniform(g, 1.4, 1.6))),
                );
                self.cars.push(Car { body, cabin });
            }
            t = tidy(t + len + uniform(g, 1.0, 8.0));
        }
    }

    /// Every box of the city: ground, sidewalks, buildings, tree trunks, car bodies and
    /// cabins (the tree crowns are spheres, in [`City::trees`]).
    pub fn boxes(&self) -> impl Iterator<Item = &CityBox> {
        std::iter::once(&self.ground)
            .chain(&self.sidewalks)
            .chain(&self.buildings)
            .chain(self.trees.iter().map(|t| &t.trunk))
            .chain(self.cars.iter().flat_map(|c| [&c.body, &c.cabin]))
    }

    /// The city as a [`Scene`] that rays hit.
    pub fn scene(&self) -> Scene {
        let mut shapes: Vec<(Isometry3<f64>, SharedShape)> =
            self.boxes().map(CityBox::shape).collect();
        for t in &self.trees {
            let c = t.crown_centre;
            shapes.push((
                Isometry3::translation(c.x, c.y, c.z),
                SharedShape::ball(t.crown_radius as f32),
            ));
        }
        // finite boxes and balls only, and never empty (the ground is always there)
        match Scene::from_shapes(shapes) {
            Ok(s) => s,
            Err(e) => unreachable!("a generated city is a valid scene: {e}"),
        }
    }

    /// Whether `(x, y)` lies on the centre line of a street (within 1 mm), where the route
    /// runs.
    pub fn on_centre_line(&self, x: f64, y: f64) -> bool {
        let near = |lines: &[f64], v: f64| lines.iter().any(|l| (l - v).abs() < 1e-3);
        let inside =
            |lines: &[f64], v: f64| lines[0] - 1e-3 <= v && v <= lines[lines.len() - 1] + 1e-3;
        (near(&self.streets_x, x) && inside(&self.streets_y, y))
            || (near(&self.streets_y, y) && inside(&self.streets_x, x))
    }

    /// A drive of `length` metres along the street centre lines: from a seeded corner of the
    /// grid, at each crossing a seeded choice among the streets ahead, left and right (a
    /// U-turn only at a dead end, which a grid has none of). Waypoints (x, y) for
    /// [`SpinningLidar::path`]; the last segment is cut so the polyline is `length` long
    /// (a non-positive or non-finite length gives the start alone; lengths above
    /// [`MAX_ROUTE_LENGTH`] are cut to it).
    pub fn route(&self, length: f64) -> Vec<[f64; 2]> {
        let mut g = SplitMix64::for_frame(self.options.seed, ROUTE_STREAM);
        let (nx, ny) = (self.streets_x.len(), self.streets_y.len());
        let at = |(i, j): (usize, usize)| [self.streets_x[i], self.streets_y[j]];
        let mut node = (
            if g.next_u64().is_multiple_of(2) {
                0
            } else {
                nx - 1
            },
            if g.next_u64().is_multiple_of(2) {
                0
            } else {
                ny - 1
            },
        );
        let mut prev: Option<(usize, usize)> = None;
        let mut path = vec![at(node)];
        if !(length.is_finite() && length > 0.0) {
            return path;
        }
        let mut left = length.min(MAX_ROUTE_LENGTH);
        loop {
            let (i, j) = node;
            let mut next = Vec::with_capacity(4);
            if i > 0 {
                next.push((i - 1, j));
            }
            if i + 1 < nx {
                next.push((i + 1, j));
            }
            if j > 0 {
                next.push((i, j - 1));
            }
            if j + 1 < ny {
                next.push((i, j + 1));
            }
            if next.len() > 1 {
                next.retain(|n| Some(*n) != prev);
            }
            let to = next[(g.next_u64() % next.len() as u64) as usize];
            let (a, b) = (at(node), at(to));
            let seg = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
            if seg >= left {
                let t = left / seg;
                path.push([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
                return path;
            }
            left -= seg;
            path.push(b);
            prev = Some(node);
            node = to;
        }
    }

    /// A car-mounted spinning LiDAR driving [`City::route`] for `frames` frames, one per
    /// metre: 16 rings from −15° to 15° (Velodyne VLP-16 style), 1024 columns, 0.5–80 m,
    /// 10 Hz, [`MOUNT_HEIGHT`] above the road. Change its fields for another sensor (a
    /// different `frame_spacing` changes the frame count). Errors for 0 frames or more
    /// than [`MAX_CITY_FRAMES`].
    pub fn lidar(&self, frames: usize) -> Result<SpinningLidar, SceneError> {
        if !(1..=MAX_CITY_FRAMES).contains(&frames) {
            return Err(invalid(
                "frames",
                format!("{frames} is not in 1..={MAX_CITY_FRAMES}"),
            ));
        }
        // half a spacing past the last frame, so the frame count does not hang on rounding
        let length = (frames - 1) as f64 * FRAME_SPACING + FRAME_SPACING / 2.0;
        Ok(SpinningLidar {
            rings: 16,
            min_elevation_deg: -15.0,
            max_elevation_deg: 15.0,
            columns: 1024,
            min_range: 0.5,
            max_range: 80.0,
            path: self.route(length),
            height: MOUNT_HEIGHT,
            frame_spacing: FRAME_SPACING,
            rate_hz: 10.0,
        })
    }

    /// Whether `p` lies inside a solid object of the city (a box or a crown), on its surface
    /// included.
    pub fn is_solid(&self, p: &Point3<f64>) -> bool {
        self.boxes().any(|b| b.contains(p))
            || self
                .trees
                .iter()
                .any(|t| (p - t.crown_centre).norm() <= t.crown_radius)
    }
}
