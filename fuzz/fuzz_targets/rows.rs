//! The rows reader of `query`/`distance --points FILE` and `query --rays FILE`
//! (`octoquant::rows::parse_rows`): the first byte picks the row width (3 or 6, as the CLI
//! uses, or 1..8), the rest is the file. Success must mean rows of exactly that width, all
//! finite, no more than the file has lines; an error names a line the file has.
#![no_main]
use libfuzzer_sys::fuzz_target;
use octoquant::rows::{parse_rows, RowsError};

fuzz_target!(|data: &[u8]| {
    let Some((&w, text)) = data.split_first() else {
        return;
    };
    let width = match w % 4 {
        0 => 3,
        1 => 6,
        _ => 1 + usize::from(w / 4 % 8),
    };
    let lines = String::from_utf8_lossy(text).lines().count();
    match parse_rows(text, width) {
        Ok(rows) => {
            assert!(rows.len() <= lines);
            for r in &rows {
                assert_eq!(r.len(), width);
                assert!(r.iter().all(|v| v.is_finite()));
            }
        }
        Err(RowsError::Width {
            line,
            found,
            expected,
        }) => {
            assert!((1..=lines).contains(&line));
            assert_eq!(expected, width);
            assert_ne!(found, width);
        }
        Err(RowsError::NotFinite { line, field }) => {
            assert!((1..=lines).contains(&line));
            assert!(!field.is_empty());
            assert!(field.parse::<f64>().map_or(true, |v| !v.is_finite()));
        }
        Err(e) => panic!("unexpected error {e}"),
    }
});
