//! Simulated scanners: a terrestrial scanner with a fixed angular step and a spinning
//! multi-beam LiDAR moving along a path, both casting rays into a [`Scene`].

use super::{shapes, Scene, SceneError};
use crate::Frame;
use nalgebra::{Point3, Vector3};

/// Misses are returned this many times `max_range` along the beam (with
/// [`MissPolicy::MaxRange`]): beyond the range limit, so an insertion with that limit clears
/// the beam up to `max_range` and marks nothing occupied.
pub const MISS_RANGE_FACTOR: f64 = 1.01;

/// Largest number of rays one frame may cast (guards against a tiny angular step).
pub(super) const MAX_RAYS_PER_FRAME: u64 = 20_000_000;
/// Largest number of frames one scan may produce (guards against a tiny frame spacing).
const MAX_FRAMES: u64 = 1_000_000;

/// What a scan does with a beam that hits nothing within `max_range`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum MissPolicy {
    /// Return a point [`MISS_RANGE_FACTOR`] × `max_range` along the beam; insert the frames
    /// with `max_range` set so these only clear free space.
    #[default]
    MaxRange,
    /// Drop the beam: the frame holds hits only.
    Drop,
}

/// Options shared by every scanner.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScanOptions {
    /// Seed of the noise generator; the same seed gives the same points.
    pub seed: u64,
    /// Standard deviation of the Gaussian noise added to each hit's range, metres (0 = none).
    pub range_noise: f64,
    /// What to do with beams that hit nothing.
    pub misses: MissPolicy,
}

impl Default for ScanOptions {
    /// Seed 0, 1 cm range noise, misses returned beyond max range.
    fn default() -> Self {
        ScanOptions {
            seed: 0,
            range_noise: 0.01,
            misses: MissPolicy::MaxRange,
        }
    }
}

impl ScanOptions {
    /// Checks the options as every scan does (a finite range noise >= 0), without scanning.
    pub fn validate(&self) -> Result<(), SceneError> {
        check_options(self)
    }
}

/// Per-frame counts of a scan.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ScanStats {
    /// Beams cast.
    pub rays: usize,
    /// Beams that hit a surface within range (and not closer than `min_range`).
    pub hits: usize,
    /// Beams that hit nothing within `max_range` (returned or dropped per [`MissPolicy`]).
    pub misses: usize,
    /// Beams whose hit was closer than `min_range` (dropped, as real sensors do).
    pub too_close: usize,
}

/// A tripod scanner: from each station it sweeps the full azimuth and an elevation band with
/// the same angular step, so the spacing of its points on a surface grows with range.
#[derive(Debug, Clone, PartialEq)]
pub struct TerrestrialScanner {
    /// Sensor positions in world coordinates, one frame each.
    pub stations: Vec<Point3<f64>>,
    /// Step between beams in azimuth and in elevation, degrees.
    pub angular_step_deg: f64,
    /// Lowest elevation, degrees (−90 = straight down).
    pub min_elevation_deg: f64,
    /// Highest elevation, degrees (90 = straight up).
    pub max_elevation_deg: f64,
    /// Hits closer than this are dropped, metres.
    pub min_range: f64,
    /// Beams reach this far, metres.
    pub max_range: f64,
}

impl TerrestrialScanner {
    /// The built-in stations of [`Scene::builtin`] (one in a room, one in a hall, one on the
    /// slope), 1.5 m above the ground below them; 0.5° step, elevation −60°..90°, range
    /// 0.5–30 m (as the built-in LiDAR, so both insert with one `max_range`).
    pub fn builtin(scene: &Scene) -> TerrestrialScanner {
        let stations = shapes::builtin_stations()
            .into_iter()
            .map(|[x, y]| Point3::new(x, y, scene.ground_height(x, y).unwrap_or(0.0) + 1.5))
            .collect();
        TerrestrialScanner {
            stations,
            angular_step_deg: 0.5,
            min_elevation_deg: -60.0,
            max_elevation_deg: 90.0,
            min_range: 0.5,
            max_range: 30.0,
        }
    }

    /// The scanner settings of the online grid density reducer paper's experiment (a Riegl
    /// LMS-Z620): 0.075° steps in azimuth and elevation, a full turn in azimuth, vertical
    /// 50°–130° from the zenith (elevation −40°..40°), ranges 2–2000 m, at `stations`.
    pub fn riegl_lms_z620(stations: Vec<Point3<f64>>) -> TerrestrialScanner {
        TerrestrialScanner {
            stations,
            angular_step_deg: 0.075,
            min_elevation_deg: -40.0,
            max_elevation_deg: 40.0,
            min_range: 2.0,
            max_range: 2000.0,
        }
    }

    /// Checks the settings as [`scan_terrestrial`] does (elevations, ranges, angular step,
    /// stations, rays per station), without scanning.
    pub fn validate(&self) -> Result<(), SceneError> {
        check_angles(
            self.min_elevation_deg,
            self.max_elevation_deg,
            "min_elevation_deg",
        )?;
        check_ranges(self.min_range, self.max_range)?;
        let step = self.angular_step_deg;
        if !(step.is_finite() && step > 0.0) {
            return Err(invalid("angular_step_deg", format!("{step} is not > 0")));
        }
        if self
            .stations
            .iter()
            .any(|p| !p.coords.iter().all(|v| v.is_finite()))
        {
            return Err(invalid("stations", "a station is not finite".into()));
        }
        let az = (360.0 / step).ceil();
        let el = ((self.max_elevation_deg - self.min_elevation_deg) / step).floor() + 1.0;
        if az * el > MAX_RAYS_PER_FRAME as f64 {
            return Err(invalid(
                "angular_step_deg",
                format!(
                    "{step}° gives {} rays per station (limit {MAX_RAYS_PER_FRAME})",
                    az * el
                ),
            ));
        }
        Ok(())
    }
}

/// A spinning multi-beam LiDAR (Velodyne/Ouster style) carried along a path: `rings` beams
/// spread evenly in elevation, `columns` firings per revolution, one frame per revolution
/// every `frame_spacing` metres of path, the origin held at `height` above the ground.
#[derive(Debug, Clone, PartialEq)]
pub struct SpinningLidar {
    /// Number of beams (rings).
    pub rings: u32,
    /// Elevation of the lowest ring, degrees.
    pub min_elevation_deg: f64,
    /// Elevation of the highest ring, degrees.
    pub max_elevation_deg: f64,
    /// Firings per revolution (azimuth steps).
    pub columns: u32,
    /// Hits closer than this are dropped, metres.
    pub min_range: f64,
    /// Beams reach this far, metres.
    pub max_range: f64,
    /// Waypoints (x, y) in world coordinates; the sensor follows the polyline through them.
    pub path: Vec<[f64; 2]>,
    /// Height of the sensor above the ground below it (highest surface), metres.
    pub height: f64,
    /// Distance travelled between frames, metres.
    pub frame_spacing: f64,
    /// Revolutions per second; frame `i` is stamped `i / rate_hz` seconds.
    pub rate_hz: f64,
}

impl SpinningLidar {
    /// A 16-ring LiDAR (−15°..15°, 1024 columns, 0.3–30 m, 10 Hz), 1 m above the ground, on
    /// the built-in path of [`Scene::builtin`]: up the slope's corridor entrance, through the
    /// corridor, rooms and halls; a frame every 0.5 m.
    pub fn builtin_path() -> SpinningLidar {
        SpinningLidar {
            rings: 16,
            min_elevation_deg: -15.0,
            max_elevation_deg: 15.0,
            columns: 1024,
            min_range: 0.3,
            max_range: 30.0,
            path: shapes::builtin_path(),
            height: 1.0,
            frame_spacing: 0.5,
            rate_hz: 10.0,
        }
    }

    /// Length of the path, metres.
    pub fn path_length(&self) -> f64 {
        self.path
            .windows(2)
            .map(|w| ((w[1][0] - w[0][0]).powi(2) + (w[1][1] - w[0][1]).powi(2)).sqrt())
            .sum()
    }

    /// Checks the settings as [`scan_lidar`] does (elevations, ranges, rings and columns,
    /// path, frame spacing, rate, frame count), without scanning.
    pub fn validate(&self) -> Result<(), SceneError> {
        check_angles(
            self.min_elevation_deg,
            self.max_elevation_deg,
            "min_elevation_deg",
        )?;
        check_ranges(self.min_range, self.max_range)?;
        if self.rings == 0 {
            return Err(invalid("rings", "0 is not at least 1".into()));
        }
        if self.columns == 0 {
            return Err(invalid("columns", "0 is not at least 1".into()));
        }
        if self.rings as u64 * self.columns as u64 > MAX_RAYS_PER_FRAME {
            return Err(invalid(
                "columns",
                format!("rings × columns exceeds {MAX_RAYS_PER_FRAME}"),
            ));
        }
        if self.path.is_empty() {
            return Err(invalid(
                "path",
                "the path needs at least one waypoint".into(),
            ));
        }
        if self.path.iter().flatten().any(|v| !v.is_finite()) {
            return Err(invalid("path", "a waypoint is not finite".into()));
        }
        if !self.height.is_finite() {
            return Err(invalid("height", format!("{} is not finite", self.height)));
        }
        let s = self.frame_spacing;
        if !(s.is_finite() && s > 0.0) {
            return Err(invalid("frame_spacing", format!("{s} is not > 0")));
        }
        if !(self.rate_hz.is_finite() && self.rate_hz > 0.0) {
            return Err(invalid("rate_hz", format!("{} is not > 0", self.rate_hz)));
        }
        if self.path_length() / s + 1.0 > MAX_FRAMES as f64 {
            return Err(invalid(
                "frame_spacing",
                format!("{s} m gives more than {MAX_FRAMES} frames"),
            ));
        }
        Ok(())
    }

    /// Pose of frame `i`: position (x, y) at arc length `i * frame_spacing` and heading (yaw).
    fn pose_at(&self, i: usize) -> ([f64; 2], f64) {
        let mut remaining = i as f64 * self.frame_spacing;
        let mut yaw = 0.0;
        for w in self.path.windows(2) {
            let (dx, dy) = (w[1][0] - w[0][0], w[1][1] - w[0][1]);
            let len = (dx * dx + dy * dy).sqrt();
            if len > 0.0 {
                yaw = dy.atan2(dx);
                if remaining <= len {
                    let t = remaining / len;
                    return ([w[0][0] + t * dx, w[0][1] + t * dy], yaw);
                }
                remaining -= len;
            }
        }
        (self.path[self.path.len() - 1], yaw)
    }
}

pub(super) fn invalid(name: &'static str, message: String) -> SceneError {
    SceneError::InvalidOption { name, message }
}

fn check_angles(min: f64, max: f64, name: &'static str) -> Result<(), SceneError> {
    let ok = min.is_finite()
        && max.is_finite()
        && (-90.0..=90.0).contains(&min)
        && (min..=90.0).contains(&max);
    if !ok {
        return Err(invalid(
            name,
            format!("elevations {min}°..{max}° must satisfy −90 ≤ min ≤ max ≤ 90"),
        ));
    }
    Ok(())
}

pub(super) fn check_ranges(min: f64, max: f64) -> Result<(), SceneError> {
    if !(min.is_finite() && max.is_finite() && min >= 0.0 && max > min) {
        return Err(invalid(
            "max_range",
            format!("ranges {min}..{max} m must satisfy 0 ≤ min_range < max_range"),
        ));
    }
    Ok(())
}

pub(super) fn check_options(o: &ScanOptions) -> Result<(), SceneError> {
    if !(o.range_noise.is_finite() && o.range_noise >= 0.0) {
        return Err(invalid(
            "range_noise",
            format!("{} is not a finite value ≥ 0", o.range_noise),
        ));
    }
    Ok(())
}

/// SplitMix64 (Steele, Lea, Flood 2014): tiny, fast, and plenty for sensor noise.
pub(super) struct SplitMix64(u64);

impl SplitMix64 {
    /// A generator for frame `frame` of a scan seeded with `seed`.
    pub(super) fn for_frame(seed: u64, frame: u64) -> Self {
        let mut g = SplitMix64(seed ^ frame.wrapping_mul(0xD1B5_4A32_D192_ED03));
        g.next_u64();
        g
    }

    pub(super) fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in (0, 1].
    pub(super) fn unit(&mut self) -> f64 {
        ((self.next_u64() >> 11) + 1) as f64 / (1u64 << 53) as f64
    }

    /// Standard normal (Box–Muller, one of the pair).
    fn gaussian(&mut self) -> f64 {
        let (u, v) = (self.unit(), self.unit());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }
}

/// Casts one beam and records the outcome in `points` and `stats`.
pub(super) struct BeamCaster<'a> {
    scene: &'a Scene,
    options: &'a ScanOptions,
    min_range: f64,
    max_range: f64,
    rng: SplitMix64,
}

impl<'a> BeamCaster<'a> {
    /// The caster of frame `frame` of a scan of `scene` (its noise drawn from the frame's own
    /// generator, so frames do not depend on each other).
    pub(super) fn new(
        scene: &'a Scene,
        options: &'a ScanOptions,
        (min_range, max_range): (f64, f64),
        frame: u64,
    ) -> Self {
        BeamCaster {
            scene,
            options,
            min_range,
            max_range,
            rng: SplitMix64::for_frame(options.seed, frame),
        }
    }

    /// Cast the beam from `origin` along the unit vector `dir`: a hit (or, with
    /// [`MissPolicy::MaxRange`], a miss) appends one point.
    pub(super) fn cast(
        &mut self,
        origin: &Point3<f64>,
        dir: &Vector3<f64>,
        points: &mut Vec<Point3<f32>>,
        stats: &mut ScanStats,
    ) {
        stats.rays += 1;
        match self.scene.cast_ray(origin, dir, self.max_range) {
            Some(d) if d < self.min_range => stats.too_close += 1,
            Some(d) => {
                stats.hits += 1;
                let d = if self.options.range_noise > 0.0 {
                    (d + self.options.range_noise * self.rng.gaussian()).max(0.0)
                } else {
                    d
                };
                points.push((origin + dir * d).cast::<f32>());
            }
            None => {
                stats.misses += 1;
                if self.options.misses == MissPolicy::MaxRange {
                    points
                        .push((origin + dir * (self.max_range * MISS_RANGE_FACTOR)).cast::<f32>());
                }
            }
        }
    }
}

/// Unit direction at azimuth `az` and elevation `el` (radians), z up.
fn direction(az: f64, el: f64) -> Vector3<f64> {
    Vector3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin())
}

/// One frame per station of a [`TerrestrialScanner`], stamped `60 s × station index`.
///
/// Beams run over azimuth `k · step` (k = 0.. while below 360°) and elevation
/// `min + j · step` up to `max`; errors on an invalid scanner or options.
pub fn scan_terrestrial(
    scene: &Scene,
    scanner: &TerrestrialScanner,
    options: &ScanOptions,
) -> Result<(Vec<Frame>, Vec<ScanStats>), SceneError> {
    scanner.validate()?;
    check_options(options)?;
    let step = scanner.angular_step_deg;
    let n_az = (360.0 / step).ceil() as usize;
    let n_el = ((scanner.max_elevation_deg - scanner.min_elevation_deg) / step + 1e-9).floor()
        as usize
        + 1;
    let mut frames = Vec::with_capacity(scanner.stations.len());
    let mut all_stats = Vec::with_capacity(scanner.stations.len());
    for (i, origin) in scanner.stations.iter().enumerate() {
        let mut caster = BeamCaster {
            scene,
            options,
            min_range: scanner.min_range,
            max_range: scanner.max_range,
            rng: SplitMix64::for_frame(options.seed, i as u64),
        };
        let mut points = Vec::with_capacity(n_az * n_el);
        let mut stats = ScanStats::default();
        for j in 0..n_el {
            let el = (scanner.min_elevation_deg + j as f64 * step).to_radians();
            for k in 0..n_az {
                let az = (k as f64 * step).to_radians();
                caster.cast(origin, &direction(az, el), &mut points, &mut stats);
            }
        }
        frames.push(Frame {
            origin: origin.cast::<f32>(),
            points,
            stamp: Some(60.0 * i as f64),
            camera: None,
            colors: None,
        });
        all_stats.push(stats);
    }
    Ok((frames, all_stats))
}

/// One frame per revolution of a [`SpinningLidar`] along its path (the path's length divided
/// by `frame_spacing`, plus one), all beams of a revolution from the same origin.
///
/// Column `c` fires at azimuth `yaw + c · 360°/columns`, where `yaw` is the heading of the
/// path segment; ring `r` at elevation `min + r · (max − min)/(rings − 1)`. Errors on an
/// invalid LiDAR or options.
pub fn scan_lidar(
    scene: &Scene,
    lidar: &SpinningLidar,
    options: &ScanOptions,
) -> Result<(Vec<Frame>, Vec<ScanStats>), SceneError> {
    lidar.validate()?;
    check_options(options)?;
    let n_frames = (lidar.path_length() / lidar.frame_spacing + 1e-9).floor() as usize + 1;
    let ring_step = if lidar.rings > 1 {
        (lidar.max_elevation_deg - lidar.min_elevation_deg) / (lidar.rings - 1) as f64
    } else {
        0.0
    };
    let col_step = std::f64::consts::TAU / lidar.columns as f64;
    let mut frames = Vec::with_capacity(n_frames);
    let mut all_stats = Vec::with_capacity(n_frames);
    for i in 0..n_frames {
        let ([x, y], yaw) = lidar.pose_at(i);
        let ground = scene.ground_height(x, y).unwrap_or(0.0);
        let origin = Point3::new(x, y, ground + lidar.height);
        let mut caster = BeamCaster {
            scene,
            options,
            min_range: lidar.min_range,
            max_range: lidar.max_range,
            rng: SplitMix64::for_frame(options.seed, i as u64),
        };
        let mut points = Vec::with_capacity(lidar.rings as usize * lidar.columns as usize);
        let mut stats = ScanStats::default();
        for c in 0..lidar.columns {
            let az = yaw + c as f64 * col_step;
            for r in 0..lidar.rings {
                let el = (lidar.min_elevation_deg + r as f64 * ring_step).to_radians();
                caster.cast(&origin, &direction(az, el), &mut points, &mut stats);
            }
        }
        frames.push(Frame {
            origin: origin.cast::<f32>(),
            points,
            stamp: Some(i as f64 / lidar.rate_hz),
            camera: None,
            colors: None,
        });
        all_stats.push(stats);
    }
    Ok((frames, all_stats))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaussian_has_unit_variance() {
        let mut g = SplitMix64::for_frame(7, 0);
        let n = 20_000;
        let xs: Vec<f64> = (0..n).map(|_| g.gaussian()).collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        assert!(mean.abs() < 0.03, "mean {mean}");
        assert!((var - 1.0).abs() < 0.05, "variance {var}");
    }

    #[test]
    fn pose_follows_the_path() {
        let mut l = SpinningLidar::builtin_path();
        l.path = vec![[0.0, 0.0], [2.0, 0.0], [2.0, 2.0]];
        l.frame_spacing = 1.0;
        assert_eq!(l.pose_at(0).0, [0.0, 0.0]);
        assert_eq!(l.pose_at(3).0, [2.0, 1.0]);
        assert!((l.pose_at(3).1 - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert_eq!(l.pose_at(9).0, [2.0, 2.0]);
    }
}
