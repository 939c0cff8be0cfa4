//! TUM RGB-D depth images with the poses of an association file.
//!
//! Depth PNGs are 16-bit grayscale; `value / depth_scale` (5000 by TUM's convention) is the
//! depth in metres along the optical axis and 0 means no return (such pixels give no point).
//! A pixel (u, v) with depth z back-projects to `((u − cx)·z/fx, (v − cy)·z/fy, z)` in the
//! camera frame (x right, y down, z forward).
//!
//! The association file has rows `rgb/<t>.png depth/<t>.png tx ty tz qx qy qz qw` (paths
//! relative to the file); the pose is T_world←camera, so the world point is R(q)·p + t in
//! `f64`, stored as `f32`, and the origin is t. Rows whose depth file does not exist are
//! skipped (a subset of a sequence is the normal case).
//!
//! # Colour
//! TUM's depth images are registered to the colour camera, so with colours asked for
//! ([`tum_sequence_frames_with`]) the point of depth pixel (u, v) takes the colour of pixel
//! (u, v) of the row's RGB image, as TUM's own tools (`generate_pointcloud.py`) do. The RGB
//! image must exist and have the depth image's size; 8- and 16-bit grey, grey-alpha, RGB, RGBA
//! and palette PNGs are read (16-bit channels keep their high byte, alpha is ignored).

use crate::error::{FormatError, Location};
use crate::frame::{CameraPixels, Frame, RowFrames};
use crate::pose::{rigid_transform, unit_quaternion};
use crate::source::{decompression_limit, excerpt, open, LineReader};
use nalgebra::{Point3, Rotation3, UnitQuaternion, Vector3};
use octoquant_octree::Color;
use octoquant_raycast::PinholeCamera;
use std::path::{Path, PathBuf};

/// Pinhole intrinsics of the depth camera, in pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraIntrinsics {
    /// Focal length along x.
    pub fx: f64,
    /// Focal length along y.
    pub fy: f64,
    /// Principal point x.
    pub cx: f64,
    /// Principal point y.
    pub cy: f64,
}

impl Default for CameraIntrinsics {
    /// The ROS defaults TUM recommends for its registered depth images: fx = fy = 525,
    /// cx = 319.5, cy = 239.5.
    fn default() -> Self {
        CameraIntrinsics {
            fx: 525.0,
            fy: 525.0,
            cx: 319.5,
            cy: 239.5,
        }
    }
}

/// Options for depth images.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TumOptions {
    /// Camera intrinsics (default: [`CameraIntrinsics::default`]).
    pub intrinsics: CameraIntrinsics,
    /// Raw depth units per metre (default 5000, TUM's convention).
    pub depth_scale: f64,
    /// Use every `pixel_step`-th pixel in u and v, starting at (0, 0) (default 1: all).
    pub pixel_step: u32,
}

impl Default for TumOptions {
    fn default() -> Self {
        TumOptions {
            intrinsics: CameraIntrinsics::default(),
            depth_scale: 5000.0,
            pixel_step: 1,
        }
    }
}

impl TumOptions {
    fn check(&self, path: &Path) -> Result<(), FormatError> {
        let i = &self.intrinsics;
        let bad = |message: &str| FormatError::InvalidOption {
            path: path.to_path_buf(),
            message: message.to_string(),
        };
        if !(i.fx.is_finite() && i.fy.is_finite() && i.fx != 0.0 && i.fy != 0.0) {
            return Err(bad("focal lengths must be finite and non-zero"));
        }
        if !(i.cx.is_finite() && i.cy.is_finite()) {
            return Err(bad("principal point must be finite"));
        }
        if !(self.depth_scale.is_finite() && self.depth_scale > 0.0) {
            return Err(bad("depth scale must be finite and positive"));
        }
        if self.pixel_step == 0 {
            return Err(bad("pixel step must be at least 1"));
        }
        Ok(())
    }
}

/// A 16-bit depth image, row-major.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DepthImage {
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// `width × height` raw depth values; 0 = no return.
    pub data: Vec<u16>,
}

/// The most pixels a depth image may have: 64 Mi, sixty times a 1280 x 720 depth camera.
pub const MAX_DEPTH_PIXELS: u64 = 1 << 26;

/// A PNG decoder over a sensor file.
type PngReader = png::Reader<Box<dyn std::io::BufRead + Send>>;

/// A PNG decoder past its header, with the image's width and height. The header's size is
/// checked before any pixel is allocated: a damaged header could otherwise ask for gigabytes
/// (the png crate's own limit applies to its inner buffers). `what` names the image in errors.
fn png_reader(
    path: &Path,
    transformations: png::Transformations,
    what: &str,
) -> Result<(PngReader, u32, u32), FormatError> {
    let mut decoder = png::Decoder::new(open(path)?);
    decoder.set_transformations(transformations);
    let reader = decoder
        .read_info()
        .map_err(|e| FormatError::syntax(path, Location::File, e.to_string()))?;
    let (w, h) = (reader.info().width, reader.info().height);
    if w as u64 * h as u64 > MAX_DEPTH_PIXELS {
        return Err(FormatError::syntax(
            path,
            Location::File,
            format!(
                "{what} image header declares {w} x {h} pixels, more than the \
                 {MAX_DEPTH_PIXELS} this reader accepts"
            ),
        ));
    }
    Ok((reader, w, h))
}

/// Decode a 16-bit grayscale PNG depth image.
pub fn read_depth_png(path: &Path) -> Result<DepthImage, FormatError> {
    let png_err = |e: png::DecodingError| FormatError::syntax(path, Location::File, e.to_string());
    let (mut reader, w, h) = png_reader(path, png::Transformations::IDENTITY, "depth")?;
    // the pixel type and the decompression limit are checked before the buffer is allocated
    let (color, depth) = (reader.info().color_type, reader.info().bit_depth);
    if color != png::ColorType::Grayscale || depth != png::BitDepth::Sixteen {
        return Err(FormatError::unsupported(
            path,
            Location::File,
            format!("depth PNG must be 16-bit grayscale, found {color:?} {depth:?}"),
        ));
    }
    let file_len = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
    let pixel_bytes = w as u64 * h as u64 * 2;
    if let Some(msg) = decompression_limit().check(file_len, pixel_bytes) {
        return Err(FormatError::syntax(
            path,
            Location::File,
            format!("depth image header declares {w} x {h} pixels: {msg}"),
        ));
    }
    let mut buf = vec![0u8; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).map_err(png_err)?;
    // Read up to IEND so that a cut-off file is an error even when the pixels are complete.
    reader.finish().map_err(png_err)?;
    let n = info.width as usize * info.height as usize;
    let bytes = buf.get(..n * 2).ok_or_else(|| {
        FormatError::syntax(
            path,
            Location::File,
            "decoded image is smaller than its size",
        )
    })?;
    let data = bytes
        .chunks_exact(2)
        .map(|c| u16::from_be_bytes([c[0], c[1]]))
        .collect();
    Ok(DepthImage {
        width: info.width,
        height: info.height,
        data,
    })
}

/// An 8-bit colour image, row-major.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ColorImage {
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// `width × height` pixels.
    pub data: Vec<Color>,
}

/// Decode a colour PNG (the RGB image of a TUM frame) into 8-bit RGB: grey, grey-alpha, RGB,
/// RGBA or palette, 8 or 16 bits (16-bit channels keep their high byte; alpha is ignored).
pub fn read_color_png(path: &Path) -> Result<ColorImage, FormatError> {
    let png_err = |e: png::DecodingError| FormatError::syntax(path, Location::File, e.to_string());
    let (mut reader, w, h) =
        png_reader(path, png::Transformations::normalize_to_color8(), "colour")?;
    let file_len = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
    if let Some(msg) = decompression_limit().check(file_len, w as u64 * h as u64 * 4) {
        return Err(FormatError::syntax(
            path,
            Location::File,
            format!("colour image header declares {w} x {h} pixels: {msg}"),
        ));
    }
    let mut buf = vec![0u8; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).map_err(png_err)?;
    reader.finish().map_err(png_err)?;
    let channels = match info.color_type {
        png::ColorType::Grayscale => 1,
        png::ColorType::GrayscaleAlpha => 2,
        png::ColorType::Rgb => 3,
        png::ColorType::Rgba => 4,
        other => {
            return Err(FormatError::unsupported(
                path,
                Location::File,
                format!("colour PNG decodes to {other:?}"),
            ))
        }
    };
    let n = info.width as usize * info.height as usize;
    let bytes = buf.get(..n * channels).ok_or_else(|| {
        FormatError::syntax(
            path,
            Location::File,
            "decoded image is smaller than its size",
        )
    })?;
    let data = bytes
        .chunks_exact(channels)
        .map(|c| match channels {
            1 | 2 => Color::new(c[0], c[0], c[0]),
            _ => Color::new(c[0], c[1], c[2]),
        })
        .collect();
    Ok(ColorImage {
        width: info.width,
        height: info.height,
        data,
    })
}

/// Back-project the valid pixels of `image` into the camera frame (`f64`), row by row.
pub fn depth_to_points(image: &DepthImage, options: &TumOptions) -> Vec<Point3<f64>> {
    depth_to_camera(image, options, Rotation3::identity(), None).0
}

/// [`depth_to_points`] with each point's pixel on the used grid (every `pixel_step`-th pixel),
/// and that grid as a pinhole camera turned by `rotation`; with `rgb` (of the depth image's
/// size), the colour of each point's pixel too.
fn depth_to_camera(
    image: &DepthImage,
    options: &TumOptions,
    rotation: Rotation3<f64>,
    rgb: Option<&ColorImage>,
) -> (Vec<Point3<f64>>, CameraPixels, Option<Vec<Color>>) {
    let i = &options.intrinsics;
    let step = options.pixel_step.max(1) as usize;
    let w = image.width as usize;
    let mut points = Vec::new();
    let mut pixels = Vec::new();
    let mut colors = Vec::new();
    let cols = w.div_ceil(step);
    for (gv, (v, row)) in image
        .data
        .chunks(w.max(1))
        .enumerate()
        .step_by(step)
        .enumerate()
    {
        for (gu, (u, &d)) in row.iter().enumerate().step_by(step).enumerate() {
            if d == 0 {
                continue;
            }
            let z = f64::from(d) / options.depth_scale;
            let x = (u as f64 - i.cx) * z / i.fx;
            let y = (v as f64 - i.cy) * z / i.fy;
            points.push(Point3::new(x, y, z));
            pixels.push((gv * cols + gu) as u32);
            if let Some(rgb) = rgb {
                colors.push(rgb.data.get(v * w + u).copied().unwrap_or(Color::WHITE));
            }
        }
    }
    let k = step as f64;
    let camera = CameraPixels {
        camera: PinholeCamera {
            width: cols as u32,
            height: (image.height as usize).div_ceil(step) as u32,
            fx: i.fx / k,
            fy: i.fy / k,
            cx: i.cx / k,
            cy: i.cy / k,
            rotation,
        },
        pixels,
    };
    (points, camera, rgb.map(|_| colors))
}

/// One depth PNG as a frame in the camera frame: origin (0, 0, 0), no pose.
pub fn read_tum_depth(path: &Path, options: &TumOptions) -> Result<Vec<Frame>, FormatError> {
    options.check(path)?;
    let img = read_depth_png(path)?;
    let (points, camera, _) = depth_to_camera(&img, options, Rotation3::identity(), None);
    let mut f = Frame::new(Point3::origin(), &points);
    f.stamp = stamp_of(path);
    f.camera = Some(camera);
    Ok(vec![f])
}

/// One usable row of an association file.
#[derive(Debug, Clone, PartialEq)]
pub struct AssociationRow {
    /// 1-based line of the row.
    pub line: u64,
    /// The colour image, resolved against the association file's directory (it may not
    /// exist; only colour reads need it).
    pub rgb: PathBuf,
    /// The depth image, resolved against the association file's directory.
    pub depth: PathBuf,
    /// Camera position in the world (the sensor origin).
    pub translation: Vector3<f64>,
    /// Camera orientation (normalised when read).
    pub rotation: UnitQuaternion<f64>,
}

/// Read an association file; only rows whose depth file exists are returned, in file order.
/// Every row is checked, used or not.
pub fn read_association(path: &Path) -> Result<Vec<AssociationRow>, FormatError> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut lines = LineReader::open(path)?;
    let mut rows = Vec::new();
    while let Some((at, line)) = lines.next_line()? {
        let t = line.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        let toks: Vec<&str> = t.split_ascii_whitespace().collect();
        if toks.len() != 9 {
            return Err(FormatError::syntax(
                path,
                at,
                format!(
                    "expected 'rgb depth tx ty tz qx qy qz qw' (9 fields), found {}",
                    toks.len()
                ),
            ));
        }
        let mut v = [0f64; 7];
        for (x, tok) in v.iter_mut().zip(&toks[2..]) {
            *x = tok.parse().map_err(|_| {
                FormatError::syntax(
                    path,
                    at,
                    format!("cannot parse {:?} as a number", excerpt(tok)),
                )
            })?;
        }
        let translation = Vector3::new(v[0], v[1], v[2]);
        let rotation = unit_quaternion(v[6], v[3], v[4], v[5])
            .filter(|_| translation.iter().all(|c| c.is_finite()))
            .ok_or_else(|| {
                FormatError::missing_pose(path, at, "non-finite position or zero quaternion")
            })?;
        let depth = dir.join(toks[1]);
        if depth.is_file() {
            rows.push(AssociationRow {
                line: at_line(at),
                rgb: dir.join(toks[0]),
                depth,
                translation,
                rotation,
            });
        }
    }
    Ok(rows)
}

fn at_line(at: Location) -> u64 {
    match at {
        Location::Line(l) => l,
        _ => 0,
    }
}

/// The time stamp in a TUM file name `<seconds>.png`.
fn stamp_of(path: &Path) -> Option<f64> {
    path.file_stem()?.to_str()?.parse::<f64>().ok()
}

/// Read every depth frame of an association file whose depth image exists, in file order,
/// transformed to the world. No existing depth image at all is an error.
pub fn read_tum_sequence(
    association: &Path,
    options: &TumOptions,
) -> Result<Vec<Frame>, FormatError> {
    tum_sequence_frames(association, options)?.collect()
}

/// [`read_tum_sequence`] one image at a time: the association file is read first, then each
/// depth image only when its frame is asked for.
pub fn tum_sequence_frames(
    association: &Path,
    options: &TumOptions,
) -> Result<RowFrames<AssociationRow>, FormatError> {
    tum_sequence_frames_with(association, options, false)
}

/// [`tum_sequence_frames`], with [`Frame::colors`] from each row's RGB image when `colors` is
/// set (see the module docs); a missing or differently sized RGB image is then an error
/// naming it.
pub fn tum_sequence_frames_with(
    association: &Path,
    options: &TumOptions,
    colors: bool,
) -> Result<RowFrames<AssociationRow>, FormatError> {
    options.check(association)?;
    let rows = read_association(association)?;
    if rows.is_empty() {
        return Err(FormatError::syntax(
            association,
            Location::File,
            "no depth image named in the association file exists",
        ));
    }
    let options = *options;
    Ok(RowFrames::new(rows, move |row: AssociationRow| {
        let img = read_depth_png(&row.depth)?;
        let rgb = if colors {
            let rgb = read_color_png(&row.rgb)?;
            if (rgb.width, rgb.height) != (img.width, img.height) {
                return Err(FormatError::syntax(
                    &row.rgb,
                    Location::File,
                    format!(
                        "colour image is {} x {}, its depth image {} is {} x {}",
                        rgb.width,
                        rgb.height,
                        row.depth.display(),
                        img.width,
                        img.height
                    ),
                ));
            }
            Some(rgb)
        } else {
            None
        };
        let rotation = row.rotation.to_rotation_matrix();
        let (points, camera, colors) = depth_to_camera(&img, &options, rotation, rgb.as_ref());
        let points = points
            .iter()
            .map(|p| rigid_transform(&rotation, &row.translation, p))
            .collect();
        let mut f = Frame::new_f32(row.translation.cast::<f32>().into(), points);
        f.stamp = stamp_of(&row.depth);
        f.camera = Some(camera);
        f.colors = colors;
        Ok(f)
    }))
}

/// Whether `path` looks like a TUM association file: its first data line has 9 fields and
/// the first two end in `.png`.
pub fn is_association_file(path: &Path) -> bool {
    let Ok(mut lines) = LineReader::open(path) else {
        return false;
    };
    for _ in 0..64 {
        let Ok(Some((_, line))) = lines.next_line() else {
            return false;
        };
        let t = line.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        let toks: Vec<&str> = t.split_ascii_whitespace().collect();
        return toks.len() == 9
            && toks[0].to_ascii_lowercase().ends_with(".png")
            && toks[1].to_ascii_lowercase().ends_with(".png");
    }
    false
}
