//! Legacy ASCII VTK (`read_vtk` on a `.vtk` file), the trajectory CSV of a VTK scan sequence
//! (`read_trajectory_csv` on a `.csv` file) and the scan file-name stamp parser.
#![no_main]
use libfuzzer_sys::fuzz_target;
use octoquant_formats::vtk::{parse_scan_stamp, read_trajectory_csv, read_vtk};
use octoquant_fuzz::with_file;

fuzz_target!(|data: &[u8]| {
    with_file("input.vtk", data, |path| {
        let _ = read_vtk(path);
    });
    with_file("trajectory.csv", data, |path| {
        let _ = read_trajectory_csv(path);
    });
    if let Ok(name) = std::str::from_utf8(data) {
        let _ = parse_scan_stamp(name);
    }
});
