//! CARMEN laser logs (`FLASER`, `ROBOTLASER1`): `CarmenReader` over the bytes in memory,
//! every scan read and converted to laser and world points.
#![no_main]
use libfuzzer_sys::fuzz_target;
use octoquant_formats::carmen::CarmenReader;
use std::io::Cursor;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let mut reader =
        CarmenReader::new(Path::new("input.log"), Box::new(Cursor::new(data.to_vec())));
    let mut out = Vec::new();
    while let Ok(Some(scan)) = reader.next_scan() {
        let _ = scan.valid_count();
        scan.laser_points(&mut out);
        scan.world_points(&mut out);
        out.clear();
    }
});
