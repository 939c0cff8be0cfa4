//! The `.gz` / `.bz2` wrappers of every input (`source::read_all`, and the streaming line
//! reader through `read_text`): the first byte picks gzip or bzip2, the rest is the file.
#![no_main]
use libfuzzer_sys::fuzz_target;
use octoquant_formats::source::read_all;
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
    with_file(name, file, |path| {
        let _ = read_all(path);
        let _ = read_text(path);
    });
});
