//! Text inputs: `x y z` point lists, OctoMap `NODE` logs and `origin` frames, through
//! `read_text`, `text_kind` and `read_log_graph` on `.txt` and `.log` files.
#![no_main]
use libfuzzer_sys::fuzz_target;
use octoquant_formats::text::{read_log_graph, read_text, text_kind};
use octoquant_fuzz::with_file;

fuzz_target!(|data: &[u8]| {
    with_file("input.txt", data, |path| {
        let _ = text_kind(path);
        let _ = read_text(path);
    });
    with_file("input.log", data, |path| {
        let _ = read_log_graph(path);
    });
});
