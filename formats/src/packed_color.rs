//! Colours packed into one 32-bit value, as PCL (`rgb`, `rgba`) and ROS PointCloud2 store
//! them: `0xAARRGGBB` with blue in the lowest byte; `rgb` is the same bits stored in a
//! `float` (PCL's historical layout), so its value is reinterpreted, never converted.

use octoquant_octree::Color;

/// The colour in the packed bits `0x??RRGGBB` (alpha, if any, ignored).
pub fn unpack_rgb(bits: u32) -> Color {
    let [b, g, r, _] = bits.to_le_bytes();
    Color::new(r, g, b)
}

/// A text token of a packed colour field of `kind`, or `None` when it is not a number of that
/// kind. `U`/`I`: the integer. `F`: PCL writes an `rgb` float field in ASCII PCD as the
/// unsigned integer of its bits (several opaque colours are NaN as floats), older writers as
/// the float itself; a token of digits only is read the first way, anything else as a float
/// whose bits hold the colour.
pub fn parse_packed_token(token: &str, kind: char) -> Option<Color> {
    let bits = match kind {
        'F' if !token.is_empty() && token.bytes().all(|b| b.is_ascii_digit()) => {
            token.parse::<u32>().ok()?
        }
        'F' => token.parse::<f32>().ok()?.to_bits(),
        'U' => token.parse::<u32>().ok()?,
        _ => token.parse::<i32>().ok()? as u32,
    };
    Some(unpack_rgb(bits))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unpacks_pcl_layout() {
        assert_eq!(unpack_rgb(0xFF10_2030), Color::new(0x10, 0x20, 0x30));
        // PCL's float rgb: the bits of the float, not its value
        let f = f32::from_bits(0x00ff_8001);
        assert_eq!(
            parse_packed_token(&format!("{f:e}"), 'F'),
            Some(Color::new(255, 128, 1))
        );
        assert_eq!(
            parse_packed_token("4278190335", 'U'),
            Some(Color::new(0, 0, 255))
        );
        assert_eq!(
            parse_packed_token("-1", 'I'),
            Some(Color::new(255, 255, 255))
        );
        assert_eq!(parse_packed_token("red", 'U'), None);
        // PCL's ASCII writer: the float field as the integer of its bits
        assert_eq!(
            parse_packed_token("16744449", 'F'),
            Some(Color::new(255, 128, 1))
        );
    }
}
