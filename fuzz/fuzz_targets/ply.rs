//! PLY (ascii, binary little and big endian): `parse_ply_f32` on any bytes (the in-memory
//! function `read_ply_f32` calls). Points that read must survive a binary write and read back
//! bit for bit. With colours (`parse_ply_colored`), a cloud that reads has the same points
//! and one colour per point.
#![no_main]
use libfuzzer_sys::fuzz_target;
use octoquant_formats::ply::{parse_ply_colored, parse_ply_f32, write_ply, PlyEncoding};
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let path = Path::new("input.ply");
    let colored = parse_ply_colored(path, data, true);
    let Ok(points) = parse_ply_f32(path, data) else {
        return;
    };
    if let Ok((cpoints, colors)) = colored {
        assert_eq!(cpoints.len(), points.len());
        for (a, b) in cpoints.iter().zip(&points) {
            for k in 0..3 {
                assert_eq!(
                    a[k].to_bits(),
                    b[k].to_bits(),
                    "colour decoding changed a point"
                );
            }
        }
        if let Some(c) = colors {
            assert_eq!(c.len(), points.len());
        }
    }
    let mut out = Vec::new();
    write_ply(&mut out, &points, PlyEncoding::BinaryLittleEndian).unwrap();
    let back = parse_ply_f32(path, &out).expect("our own PLY output does not read back");
    assert_eq!(back.len(), points.len());
    for (a, b) in points.iter().zip(&back) {
        for k in 0..3 {
            assert_eq!(a[k].to_bits(), b[k].to_bits());
        }
    }
});
