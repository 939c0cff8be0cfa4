//! `sensor_msgs/PointCloud2`: decoding a message ([`decode_point_cloud2`]) and extracting the
//! valid `x y z` of any field layout ([`PointCloud2::points_f32`]).
//!
//! On request the colours come along ([`PointCloud2::points_colors_f32`]): the `rgb` or `rgba`
//! field, 4 bytes (`FLOAT32`, `UINT32` or `INT32`) packed as `0xAARRGGBB` (see
//! [`crate::packed_color`]), one colour per kept point.
//!
//! The point bytes follow the message's own `is_bigendian`, `point_step`, `row_step` and field
//! offsets; `x`, `y`, `z` may be `FLOAT32` or `FLOAT64`. Drivers store missing returns as NaN
//! or as exactly (0, 0, 0) (the Ouster driver does, even with `is_dense` set); both are skipped
//! and counted ([`CloudStats`]).

use super::cdr::{DecodeError, Encoding, Reader};
use crate::packed_color::unpack_rgb;
use nalgebra::Point3;
use octoquant_octree::Color;

/// The schema names of PointCloud2 channels (ROS 1, ROS 2).
pub(super) const CLOUD_SCHEMAS: [&str; 2] =
    ["sensor_msgs/PointCloud2", "sensor_msgs/msg/PointCloud2"];

/// Point counts of one cloud.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct CloudStats {
    /// Points in the message (`width * height`).
    pub points: usize,
    /// Points kept.
    pub kept: usize,
    /// Points skipped for a NaN or infinite coordinate.
    pub non_finite: usize,
    /// Points skipped for being exactly (0, 0, 0) (missing returns).
    pub zero: usize,
}

/// `sensor_msgs/PointField` datatypes.
pub mod datatype {
    /// `INT8`.
    pub const INT8: u8 = 1;
    /// `UINT8`.
    pub const UINT8: u8 = 2;
    /// `INT16`.
    pub const INT16: u8 = 3;
    /// `UINT16`.
    pub const UINT16: u8 = 4;
    /// `INT32`.
    pub const INT32: u8 = 5;
    /// `UINT32`.
    pub const UINT32: u8 = 6;
    /// `FLOAT32`.
    pub const FLOAT32: u8 = 7;
    /// `FLOAT64`.
    pub const FLOAT64: u8 = 8;
}

/// One `sensor_msgs/PointField`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PointField {
    /// Field name (`x`, `intensity`, ...).
    pub name: String,
    /// Byte offset inside a point.
    pub offset: u32,
    /// One of [`datatype`].
    pub datatype: u8,
    /// Number of elements.
    pub count: u32,
}

/// A decoded `sensor_msgs/PointCloud2`; the point bytes are kept as they are.
#[derive(Debug, Clone, PartialEq)]
pub struct PointCloud2 {
    /// `header.frame_id`.
    pub frame_id: String,
    /// `header.stamp` in seconds.
    pub stamp: f64,
    /// Rows.
    pub height: u32,
    /// Points per row.
    pub width: u32,
    /// Field layout.
    pub fields: Vec<PointField>,
    /// Whether the point bytes are big-endian.
    pub is_bigendian: bool,
    /// Bytes per point.
    pub point_step: u32,
    /// Bytes per row.
    pub row_step: u32,
    /// The point bytes.
    pub data: Vec<u8>,
    /// `is_dense` as recorded (not trusted: invalid points are checked regardless).
    pub is_dense: bool,
}

/// Decode a `sensor_msgs/PointCloud2` message in `encoding`.
///
/// Checks the layout: `x`, `y`, `z` present as `FLOAT32`/`FLOAT64` inside `point_step`,
/// `row_step ≥ width · point_step`, and enough data bytes for every point.
pub fn decode_point_cloud2(msg: &[u8], encoding: Encoding) -> Result<PointCloud2, DecodeError> {
    let mut r = Reader::new(msg, encoding)?;
    let (frame_id, stamp) = r.header()?;
    let height = r.u32("height")?;
    let width = r.u32("width")?;
    let n = r.count("fields", 13)?;
    let mut fields = Vec::with_capacity(n);
    for _ in 0..n {
        let name = r.string("field name")?;
        let offset = r.u32("field offset")?;
        let datatype = r.u8("field datatype")?;
        let count = r.u32("field count")?;
        fields.push(PointField {
            name,
            offset,
            datatype,
            count,
        });
    }
    let is_bigendian = r.u8("is_bigendian")? != 0;
    let point_step = r.u32("point_step")?;
    let row_step = r.u32("row_step")?;
    let len = r.count("data", 1)?;
    let data = r.take(len, "data")?.to_vec();
    let is_dense = r.u8("is_dense")? != 0;
    let cloud = PointCloud2 {
        frame_id,
        stamp,
        height,
        width,
        fields,
        is_bigendian,
        point_step,
        row_step,
        data,
        is_dense,
    };
    cloud.layout().map_err(|message| DecodeError {
        offset: msg.len(),
        message,
    })?;
    Ok(cloud)
}

impl PointCloud2 {
    /// Offsets and sizes of x, y, z; errors name the missing or unusable field.
    fn layout(&self) -> Result<[(usize, bool); 3], String> {
        let mut out = [(0usize, false); 3];
        for (slot, name) in out.iter_mut().zip(["x", "y", "z"]) {
            let f = self.fields.iter().find(|f| f.name == name).ok_or_else(|| {
                let names: Vec<&str> = self.fields.iter().map(|f| f.name.as_str()).collect();
                format!("no field {name:?} (fields: {})", names.join(", "))
            })?;
            let size = match f.datatype {
                datatype::FLOAT32 => 4,
                datatype::FLOAT64 => 8,
                d => {
                    return Err(format!(
                        "field {name:?} has datatype {d}; only FLOAT32 (7) and FLOAT64 (8) are supported"
                    ))
                }
            };
            if f.offset as u64 + size > self.point_step as u64 {
                return Err(format!(
                    "field {name:?} at offset {} does not fit in point_step {}",
                    f.offset, self.point_step
                ));
            }
            *slot = (f.offset as usize, size == 8);
        }
        let row_bytes = self.width as u64 * self.point_step as u64;
        if self.height > 0 && self.width > 0 {
            if (self.row_step as u64) < row_bytes {
                return Err(format!(
                    "row_step {} is less than width {} × point_step {}",
                    self.row_step, self.width, self.point_step
                ));
            }
            // at most (2^32)^2 · 2: u128 cannot overflow
            let need = (self.height as u128 - 1) * self.row_step as u128 + row_bytes as u128;
            if (self.data.len() as u128) < need {
                return Err(format!(
                    "data holds {} bytes, {} × {} points need {need}",
                    self.data.len(),
                    self.height,
                    self.width
                ));
            }
        }
        Ok(out)
    }

    /// The byte offset of the packed colour field (`rgb`, else `rgba`), `None` when the cloud
    /// has neither; errors when it is not 4 bytes or not inside `point_step`.
    fn color_offset(&self) -> Result<Option<usize>, String> {
        let Some(f) = ["rgb", "rgba"]
            .iter()
            .find_map(|n| self.fields.iter().find(|f| f.name == *n))
        else {
            return Ok(None);
        };
        if !matches!(
            f.datatype,
            datatype::FLOAT32 | datatype::UINT32 | datatype::INT32
        ) {
            return Err(format!(
                "colour field {:?} has datatype {}; only 4-byte packed colours (FLOAT32, UINT32, INT32) are supported",
                f.name, f.datatype
            ));
        }
        if f.offset as u64 + 4 > self.point_step as u64 {
            return Err(format!(
                "colour field {:?} at offset {} does not fit in point_step {}",
                f.name, f.offset, self.point_step
            ));
        }
        Ok(Some(f.offset as usize))
    }

    /// The valid points (row by row, as `f32` storage) and the counts of skipped ones.
    pub fn points_f32(&self) -> Result<(Vec<Point3<f32>>, CloudStats), String> {
        self.points_colors_f32(false).map(|(p, _, st)| (p, st))
    }

    /// [`PointCloud2::points_f32`] with, when `colors` is set and the cloud has an `rgb` or
    /// `rgba` field, the colour of each kept point.
    #[allow(clippy::type_complexity)]
    pub fn points_colors_f32(
        &self,
        colors: bool,
    ) -> Result<(Vec<Point3<f32>>, Option<Vec<Color>>, CloudStats), String> {
        let layout = self.layout()?;
        let color = if colors { self.color_offset()? } else { None };
        let total = self.height as usize * self.width as usize;
        let mut stats = CloudStats {
            points: total,
            ..CloudStats::default()
        };
        if total == 0 {
            // a zero width (or height) must not cost a loop over 2^32 empty rows
            return Ok((Vec::new(), color.map(|_| Vec::new()), stats));
        }
        let mut pts = Vec::with_capacity(total);
        let mut cols = Vec::with_capacity(if color.is_some() { total } else { 0 });
        let be = self.is_bigendian;
        let read = |at: usize, f64_: bool| -> f64 {
            if f64_ {
                let b: [u8; 8] = self.data[at..at + 8].try_into().unwrap_or([0; 8]);
                if be {
                    f64::from_be_bytes(b)
                } else {
                    f64::from_le_bytes(b)
                }
            } else {
                let b: [u8; 4] = self.data[at..at + 4].try_into().unwrap_or([0; 4]);
                (if be {
                    f32::from_be_bytes(b)
                } else {
                    f32::from_le_bytes(b)
                }) as f64
            }
        };
        for row in 0..self.height as usize {
            let row_base = row * self.row_step as usize;
            for col in 0..self.width as usize {
                let base = row_base + col * self.point_step as usize;
                let p = layout.map(|(off, wide)| read(base + off, wide));
                if !p.iter().all(|v| v.is_finite()) {
                    stats.non_finite += 1;
                } else if p == [0.0; 3] {
                    stats.zero += 1;
                } else {
                    pts.push(Point3::new(p[0] as f32, p[1] as f32, p[2] as f32));
                    if let Some(off) = color {
                        let b: [u8; 4] = self.data[base + off..base + off + 4]
                            .try_into()
                            .unwrap_or([0; 4]);
                        let bits = if be {
                            u32::from_be_bytes(b)
                        } else {
                            u32::from_le_bytes(b)
                        };
                        cols.push(unpack_rgb(bits));
                    }
                }
            }
        }
        stats.kept = pts.len();
        Ok((pts, color.map(|_| cols), stats))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn huge_dimensions_with_little_data_are_errors() {
        let field = |name: &str, offset| PointField {
            name: name.into(),
            offset,
            datatype: datatype::FLOAT32,
            count: 1,
        };
        let cloud = PointCloud2 {
            frame_id: "f".into(),
            stamp: 0.0,
            height: u32::MAX,
            width: u32::MAX,
            fields: vec![field("x", 0), field("y", 4), field("z", 8)],
            is_bigendian: false,
            point_step: u32::MAX,
            row_step: u32::MAX,
            data: vec![0; 64],
            is_dense: true,
        };
        let e = cloud.points_f32().unwrap_err();
        assert!(e.contains("row_step"), "{e}");
        let cloud = PointCloud2 {
            width: 1 << 28,
            point_step: 12,
            row_step: 12 << 28,
            ..cloud
        };
        let e = cloud.points_f32().unwrap_err();
        assert!(e.contains("data holds 64 bytes"), "{e}");
    }

    #[test]
    fn colours_follow_the_kept_points_in_either_byte_order() {
        let field = |name: &str, offset, datatype| PointField {
            name: name.into(),
            offset,
            datatype,
            count: 1,
        };
        let mut data = Vec::new();
        // (1, 2, 3) red, (0, 0, 0) skipped, (4, 5, 6) blue; big-endian
        for (p, c) in [
            ([1f32, 2., 3.], 0x00ff_0000u32),
            ([0., 0., 0.], 0x00ff_ffff),
            ([4., 5., 6.], 0x0000_00ff),
        ] {
            for v in p {
                data.extend_from_slice(&v.to_be_bytes());
            }
            data.extend_from_slice(&c.to_be_bytes());
        }
        let cloud = PointCloud2 {
            frame_id: "f".into(),
            stamp: 0.0,
            height: 1,
            width: 3,
            fields: vec![
                field("x", 0, datatype::FLOAT32),
                field("y", 4, datatype::FLOAT32),
                field("z", 8, datatype::FLOAT32),
                field("rgb", 12, datatype::FLOAT32),
            ],
            is_bigendian: true,
            point_step: 16,
            row_step: 48,
            data,
            is_dense: false,
        };
        let (p, c, st) = cloud.points_colors_f32(true).unwrap();
        assert_eq!((p.len(), st.zero), (2, 1));
        assert_eq!(c, Some(vec![Color::new(255, 0, 0), Color::new(0, 0, 255)]));
        assert_eq!(cloud.points_colors_f32(false).unwrap().1, None);
        let mut bad = cloud.clone();
        bad.fields[3].offset = 13;
        assert!(bad
            .points_colors_f32(true)
            .unwrap_err()
            .contains("does not fit"));
        bad.fields[3] = field("rgba", 12, datatype::UINT8);
        assert!(bad
            .points_colors_f32(true)
            .unwrap_err()
            .contains("4-byte packed"));
    }

    #[test]
    fn truncated_messages_are_errors() {
        assert!(decode_point_cloud2(&[], Encoding::Ros1).is_err());
        assert!(decode_point_cloud2(&[0, 7, 0, 0], Encoding::Cdr).is_err());
    }
}
