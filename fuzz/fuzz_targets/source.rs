//! The `.gz` / `.bz2` wrappers of every input (`source::read_all`, and the streaming line
//! reader through `read_text`): the first byte picks gzip or bzip2, the rest is the file.
//! Under a decompression limit with a 1 MiB floor (the default floor is 64 MiB): the same
//! code paths, including the bomb error, at a cost per input that lets the campaign reach its
//! execution count; the limit's arithmetic is the same for any floor.
#![no_main]
use libfuzzer_sys::fuzz_target;
use octoquant_formats::source::{read_all, with_decompression_limit, DecompressionLimit};
use octoquant_formats::text::read_text;
use octoquant_fuzz::with_file;

fuzz_target!(|data: &[u8]| {
    let Some((&first, file)) = data.split_first() else {
        return;
    };
    let name = if first & 1 == 0 {
        "input.txt.gz"
    } else {
        "input.txt.bz2"
    };
    let limit = DecompressionLimit {
        min_bytes: 1 << 20,
        ..DecompressionLimit::DEFAULT
    };
    with_decompression_limit(limit, || {
        with_file(name, file, |path| {
            let _ = read_all(path);
            let _ = read_text(path);
        })
    });
});
