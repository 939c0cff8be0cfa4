//! CARMEN log files: the 2D laser scans of `FLASER` and `ROBOTLASER1` lines, each with its
//! laser pose. `.gz`/`.bz2` logs are decompressed on the fly ([`crate::source::open`]).
//!
//! * `FLASER n r_1 .. r_n x y theta odom_x odom_y odom_theta ipc_ts host logger_ts`: the first
//!   pose is the laser pose, the second the odometry. The message has no angles: the beams
//!   cover 180° counter-clockwise from -90°, `pi/(n-1)` apart (`linspace(-pi/2, pi/2, n)`, as
//!   the PLE code reads it), unless a `PARAM laser_front_laser_resolution` (degrees) came first.
//! * `ROBOTLASER1 type start_angle fov resolution max_range accuracy remission_mode n r_1 .. r_n
//!   m [m remissions] laser_x laser_y laser_theta robot_x robot_y robot_theta tv rv
//!   forward_safety side_safety turn_axis ipc_ts host logger_ts`.
//!
//! Other messages (`ODOM`, `PARAM`, `NEFF`, ...) and `#` comments are skipped. Every error names
//! the file and the 1-based line. A reading that is not finite, not positive, or at the
//! scanner's maximum range ("no return") is kept in [`LaserScan::ranges`] but flagged invalid
//! by [`LaserScan::is_valid`].

use crate::error::{FormatError, Location};
use crate::source;
use std::io::BufRead;
use std::path::{Path, PathBuf};

pub use crate::pose::Pose2;

/// Which message a scan came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ScanKind {
    /// `FLASER` (old front laser message).
    Flaser,
    /// `ROBOTLASER1` (laser message with its own angles, range limit and poses).
    RobotLaser1,
}

/// One laser scan from a CARMEN log.
#[derive(Debug, Clone, PartialEq)]
pub struct LaserScan {
    /// The message it came from.
    pub kind: ScanKind,
    /// 1-based line number in the (decompressed) file.
    pub line: u64,
    /// Angle of beam 0 relative to the laser heading, radians.
    pub start_angle: f64,
    /// Angle between consecutive beams, radians.
    pub angular_resolution: f64,
    /// Readings at or above `max_range - `[`NO_RETURN_MARGIN`] are "no return".
    pub max_range: f64,
    /// All readings in beam order, metres, invalid ones included.
    pub ranges: Vec<f64>,
    /// Pose of the laser in the world frame.
    pub laser_pose: Pose2,
    /// Pose of the robot (odometry for `FLASER`).
    pub robot_pose: Pose2,
    /// The `ipc_timestamp` field, seconds; `None` when the line ends before it.
    pub timestamp: Option<f64>,
}

/// How close to `max_range` a reading counts as "no return", metres (SICK logs store 81.83 or
/// 81.91 for a limit of 81.83 or 81.9).
pub const NO_RETURN_MARGIN: f64 = 0.01;

/// The "no return" range of SICK LMS scanners in `FLASER` logs, used as their `max_range`.
pub const FLASER_DEFAULT_MAX_RANGE: f64 = 81.83;

impl LaserScan {
    /// Angle of beam `i` relative to the laser heading, radians.
    pub fn beam_angle(&self, i: usize) -> f64 {
        self.start_angle + i as f64 * self.angular_resolution
    }

    /// Whether reading `i` is a real return: finite, `> 0`, and below the maximum range.
    pub fn is_valid(&self, i: usize) -> bool {
        self.ranges
            .get(i)
            .is_some_and(|&r| r.is_finite() && r > 0.0 && r < self.max_range - NO_RETURN_MARGIN)
    }

    /// Number of valid readings.
    pub fn valid_count(&self) -> usize {
        (0..self.ranges.len()).filter(|&i| self.is_valid(i)).count()
    }

    /// The valid returns as points in the laser frame, in beam order, into `out` (cleared).
    pub fn laser_points(&self, out: &mut Vec<[f64; 2]>) {
        out.clear();
        for (i, &r) in self.ranges.iter().enumerate() {
            if self.is_valid(i) {
                let (s, c) = self.beam_angle(i).sin_cos();
                out.push([r * c, r * s]);
            }
        }
    }

    /// The valid returns as world points (through [`Self::laser_pose`]), into `out` (cleared).
    pub fn world_points(&self, out: &mut Vec<[f64; 2]>) {
        self.laser_points(out);
        for p in out.iter_mut() {
            *p = self.laser_pose.transform(*p);
        }
    }
}

/// Streaming reader of the scans in a CARMEN log.
pub struct CarmenReader {
    path: PathBuf,
    inner: Box<dyn BufRead + Send>,
    buf: Vec<u8>,
    line: u64,
    flaser_resolution: Option<f64>,
    flaser_max_range: f64,
}

impl CarmenReader {
    /// Open `path`, decompressing `.gz`/`.bz2` by extension.
    pub fn open(path: &Path) -> Result<Self, FormatError> {
        Ok(Self::new(path, source::open(path)?))
    }

    /// Read a log from any buffered reader; `path` only names it in errors.
    pub fn new(path: &Path, inner: Box<dyn BufRead + Send>) -> Self {
        CarmenReader {
            path: path.to_path_buf(),
            inner,
            buf: Vec::new(),
            line: 0,
            flaser_resolution: None,
            flaser_max_range: FLASER_DEFAULT_MAX_RANGE,
        }
    }

    /// The next scan, or `None` at the end of the file.
    pub fn next_scan(&mut self) -> Result<Option<LaserScan>, FormatError> {
        loop {
            self.buf.clear();
            let n = self
                .inner
                .read_until(b'\n', &mut self.buf)
                .map_err(|e| FormatError::io(&self.path, Location::Line(self.line + 1), e))?;
            if n == 0 {
                return Ok(None);
            }
            self.line += 1;
            let at = Location::Line(self.line);
            let text = std::str::from_utf8(&self.buf)
                .map_err(|_| FormatError::syntax(&self.path, at, "not valid UTF-8 text"))?;
            let mut toks = text.split_ascii_whitespace();
            let Some(name) = toks.next() else { continue };
            let fields = Fields {
                path: &self.path,
                at,
                line: self.line,
                toks: toks.collect(),
            };
            match name {
                "FLASER" => {
                    let res = self.flaser_resolution;
                    return fields.flaser(res, self.flaser_max_range).map(Some);
                }
                "ROBOTLASER1" => return fields.robot_laser1().map(Some),
                "PARAM" => apply_param(
                    &fields,
                    &mut self.flaser_resolution,
                    &mut self.flaser_max_range,
                )?,
                _ => {}
            }
        }
    }
}

/// Take the `PARAM`s that change how `FLASER` lines are read.
fn apply_param(
    f: &Fields<'_>,
    flaser_resolution: &mut Option<f64>,
    flaser_max_range: &mut f64,
) -> Result<(), FormatError> {
    let (Some(&name), Some(&value)) = (f.toks.first(), f.toks.get(1)) else {
        return Ok(());
    };
    match name {
        "laser_front_laser_resolution" => {
            let deg = f.number(1, "laser_front_laser_resolution")?;
            if !(deg > 0.0 && deg.is_finite()) {
                return Err(f.error(format!("bad laser_front_laser_resolution {value}")));
            }
            *flaser_resolution = Some(deg.to_radians());
        }
        "robot_front_laser_max" | "laser_front_laser_max_range" => {
            let m = f.number(1, name)?;
            if !(m > 0.0 && m.is_finite()) {
                return Err(f.error(format!("bad {name} {value}")));
            }
            *flaser_max_range = m;
        }
        _ => {}
    }
    Ok(())
}

impl Iterator for CarmenReader {
    type Item = Result<LaserScan, FormatError>;

    fn next(&mut self) -> Option<Self::Item> {
        self.next_scan().transpose()
    }
}

/// Every scan of the CARMEN log at `path`.
pub fn read_carmen_file(path: &Path) -> Result<Vec<LaserScan>, FormatError> {
    CarmenReader::open(path)?.collect()
}

/// The fields of one message line after its name.
struct Fields<'a> {
    path: &'a Path,
    at: Location,
    line: u64,
    toks: Vec<&'a str>,
}

impl Fields<'_> {
    fn error(&self, message: String) -> FormatError {
        FormatError::syntax(self.path, self.at, message)
    }

    fn token(&self, i: usize, what: &str) -> Result<&str, FormatError> {
        self.toks.get(i).copied().ok_or_else(|| {
            self.error(format!(
                "line ends after {} fields, expected {what} (field {})",
                self.toks.len() + 1,
                i + 2
            ))
        })
    }

    fn number(&self, i: usize, what: &str) -> Result<f64, FormatError> {
        let t = self.token(i, what)?;
        t.parse::<f64>().map_err(|_| {
            self.error(format!(
                "cannot parse {what} {:?} (field {})",
                source::excerpt(t),
                i + 2
            ))
        })
    }

    fn finite(&self, i: usize, what: &str) -> Result<f64, FormatError> {
        let v = self.number(i, what)?;
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.error(format!("{what} is {v} (field {})", i + 2)))
        }
    }

    fn count(&self, i: usize, what: &str) -> Result<usize, FormatError> {
        let t = self.token(i, what)?;
        let n = t.parse::<usize>().map_err(|_| {
            self.error(format!(
                "cannot parse {what} {:?} (field {})",
                source::excerpt(t),
                i + 2
            ))
        })?;
        // Each counted value needs a field: reject counts the line cannot hold before allocating.
        if n > self.toks.len().saturating_sub(i + 1) {
            return Err(self.error(format!(
                "{what} is {n} but only {} fields follow",
                self.toks.len() - i - 1
            )));
        }
        Ok(n)
    }

    fn pose(&self, i: usize, what: &str) -> Result<Pose2, FormatError> {
        Ok(Pose2 {
            x: self.finite(i, what)?,
            y: self.finite(i + 1, what)?,
            theta: self.finite(i + 2, what)?,
        })
    }

    fn ranges(&self, first: usize, n: usize) -> Result<Vec<f64>, FormatError> {
        (first..first + n)
            .map(|i| self.number(i, "range reading"))
            .collect()
    }

    fn timestamp(&self, i: usize) -> Result<Option<f64>, FormatError> {
        if i < self.toks.len() {
            self.finite(i, "ipc_timestamp").map(Some)
        } else {
            Ok(None)
        }
    }

    fn flaser(&self, resolution: Option<f64>, max_range: f64) -> Result<LaserScan, FormatError> {
        let n = self.count(0, "num_readings")?;
        let ranges = self.ranges(1, n)?;
        let laser_pose = self.pose(1 + n, "laser pose")?;
        let robot_pose = self.pose(4 + n, "odometry pose")?;
        let timestamp = self.timestamp(7 + n)?;
        let res = match resolution {
            Some(r) => r,
            None if n > 1 => std::f64::consts::PI / (n - 1) as f64,
            None => 0.0,
        };
        Ok(LaserScan {
            kind: ScanKind::Flaser,
            line: self.line,
            start_angle: -0.5 * res * n.saturating_sub(1) as f64,
            angular_resolution: res,
            max_range,
            ranges,
            laser_pose,
            robot_pose,
            timestamp,
        })
    }

    fn robot_laser1(&self) -> Result<LaserScan, FormatError> {
        let start_angle = self.finite(1, "start_angle")?;
        let resolution = self.finite(3, "angular_resolution")?;
        let max_range = self.number(4, "maximum_range")?;
        if max_range.is_nan() || max_range <= 0.0 {
            return Err(self.error(format!("maximum_range is {max_range}")));
        }
        let n = self.count(7, "num_readings")?;
        let ranges = self.ranges(8, n)?;
        let m = self.count(8 + n, "num_remissions")?;
        let p = 9 + n + m;
        let laser_pose = self.pose(p, "laser pose")?;
        let robot_pose = self.pose(p + 3, "robot pose")?;
        let timestamp = self.timestamp(p + 11)?;
        Ok(LaserScan {
            kind: ScanKind::RobotLaser1,
            line: self.line,
            start_angle,
            angular_resolution: resolution,
            max_range,
            ranges,
            laser_pose,
            robot_pose,
            timestamp,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Vec<LaserScan>, FormatError> {
        let r: Box<dyn BufRead + Send> = Box::new(std::io::Cursor::new(text.as_bytes().to_vec()));
        CarmenReader::new(Path::new("mem.clf"), r).collect()
    }

    #[test]
    fn flaser_and_robotlaser1() {
        let log = "# comment\nPARAM robot_frontlaser_offset 0.0 nohost 0\n\
                   ODOM 0 0 0 0 0 0 1.0 h 1.0\n\
                   FLASER 3 1.0 81.83 2.0 1 2 0.5 0 0 0 10.5 h 10.6\n\
                   ROBOTLASER1 0 -0.5 1.0 0.5 4.0 0.01 0 3 1.0 4.0 nan 1 0.3 \
                   1.22 0 0.1 1 0 0.1 0 0 0 0 0 12.5 h 12.6\n";
        let scans = parse(log).unwrap();
        assert_eq!(scans.len(), 2);
        let f = &scans[0];
        assert_eq!((f.kind, f.line), (ScanKind::Flaser, 4));
        assert_eq!(f.ranges, vec![1.0, 81.83, 2.0]);
        assert_eq!(
            (f.is_valid(0), f.is_valid(1), f.is_valid(2)),
            (true, false, true)
        );
        assert!((f.beam_angle(0) + std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert!((f.beam_angle(2) - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert_eq!(
            f.laser_pose,
            Pose2 {
                x: 1.0,
                y: 2.0,
                theta: 0.5
            }
        );
        assert_eq!(f.timestamp, Some(10.5));
        let r = &scans[1];
        assert_eq!(r.kind, ScanKind::RobotLaser1);
        assert_eq!(r.valid_count(), 1, "4.0 is max range, nan is invalid");
        assert_eq!(
            r.laser_pose,
            Pose2 {
                x: 1.22,
                y: 0.0,
                theta: 0.1
            }
        );
        assert_eq!(
            r.robot_pose,
            Pose2 {
                x: 1.0,
                y: 0.0,
                theta: 0.1
            }
        );
        assert_eq!(r.timestamp, Some(12.5));
        let mut pts = Vec::new();
        r.world_points(&mut pts);
        let (s, c) = (-0.5f64 + 0.1).sin_cos();
        assert!((pts[0][0] - (1.22 + c)).abs() < 1e-12 && (pts[0][1] - s).abs() < 1e-12);
    }

    #[test]
    fn errors_name_file_and_line() {
        for bad in [
            "FLASER 3 1.0 2.0\n",
            "FLASER 99999999999 1\n",
            "FLASER 2 1.0 x 0 0 0 0 0 0\n",
            "FLASER 1 1.0 nan 0 0 0 0 0\n",
            "ROBOTLASER1 0 -0.5 1.0 0.5 4.0 0.01 0 2 1.0 1.0 5 1 1\n",
        ] {
            let e = parse(&format!("# x\n{bad}")).unwrap_err().to_string();
            assert!(e.contains("mem.clf") && e.contains("line 2"), "{e}");
        }
        assert!(parse("").unwrap().is_empty());
    }

    #[test]
    fn resolution_param_sets_flaser_angles() {
        let scans =
            parse("PARAM laser_front_laser_resolution 0.5 h 0\nFLASER 3 1 1 1 0 0 0 0 0 0\n")
                .unwrap();
        assert!((scans[0].angular_resolution - 0.5f64.to_radians()).abs() < 1e-15);
        assert!((scans[0].beam_angle(1)).abs() < 1e-15);
        assert_eq!(scans[0].timestamp, None);
    }
}
