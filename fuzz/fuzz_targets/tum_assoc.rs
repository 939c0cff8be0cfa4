//! TUM association files (`stamp depth.png ... tx ty tz qx qy qz qw` rows): `read_association`
//! and the detection `is_association_file` on a `.txt` file. (The sequence reader would open
//! the image paths the input names, so it is not run here; `tum_png` covers the images.)
#![no_main]
use libfuzzer_sys::fuzz_target;
use octoquant_formats::tum::{is_association_file, read_association};
use octoquant_fuzz::with_file;

fuzz_target!(|data: &[u8]| {
    with_file("associations.txt", data, |path| {
        let _ = is_association_file(path);
        let _ = read_association(path);
    });
});
