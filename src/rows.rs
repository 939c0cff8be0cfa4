//! Rows of numbers in a text file: the point files of `query`/`distance --points` (3 numbers
//! a line) and the ray files of `query --rays` (6).
//!
//! One row per line, the numbers separated by whitespace and/or commas; blank lines and lines
//! starting with `#` are skipped; every number must be finite. Invalid UTF-8 is read as its
//! replacement character (and then fails as a number). A library function, so the reader is
//! fuzzed as the CLI uses it.

/// What is wrong with a line of a rows file. Line numbers count from 1.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum RowsError {
    /// The line has another count of numbers than a row needs.
    #[error("line {line}: {found} numbers, expected {expected}")]
    Width {
        /// The line.
        line: usize,
        /// Numbers found on it.
        found: usize,
        /// Numbers a row has.
        expected: usize,
    },
    /// A field is not a number, or not finite (NaN, infinity, overflowing).
    #[error("line {line}: {field:?} is not a finite number")]
    NotFinite {
        /// The line.
        line: usize,
        /// The field as written.
        field: String,
    },
}

/// Parse `text` into rows of `width` finite numbers each (see the module docs). The first bad
/// line is an error; nothing is returned then.
pub fn parse_rows(text: &[u8], width: usize) -> Result<Vec<Vec<f64>>, RowsError> {
    let text = String::from_utf8_lossy(text);
    let mut rows = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = line
            .split(|c: char| c.is_whitespace() || c == ',')
            .filter(|f| !f.is_empty())
            .collect();
        if fields.len() != width {
            return Err(RowsError::Width {
                line: i + 1,
                found: fields.len(),
                expected: width,
            });
        }
        let row = fields
            .iter()
            .map(|f| {
                f.parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| RowsError::NotFinite {
                        line: i + 1,
                        field: (*f).to_string(),
                    })
            })
            .collect::<Result<Vec<f64>, RowsError>>()?;
        rows.push(row);
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_comments_separators_and_errors() {
        let text = b"# x y z\n1 2 3\n\n  4,5 ,6\t\n-1e3 0.5 7\n";
        assert_eq!(
            parse_rows(text, 3).unwrap(),
            vec![
                vec![1.0, 2.0, 3.0],
                vec![4.0, 5.0, 6.0],
                vec![-1000.0, 0.5, 7.0]
            ]
        );
        assert_eq!(
            parse_rows(b"1 2 3\n1 2\n", 3),
            Err(RowsError::Width {
                line: 2,
                found: 2,
                expected: 3
            })
        );
        for bad in ["nan", "inf", "1e999", "x", "\u{fffd}"] {
            let text = format!("1 2 3\n\n0 {bad} 1\n");
            assert_eq!(
                parse_rows(text.as_bytes(), 3),
                Err(RowsError::NotFinite {
                    line: 3,
                    field: bad.to_string()
                })
            );
        }
        assert_eq!(
            parse_rows(b"1 2 \xff\n", 3),
            Err(RowsError::NotFinite {
                line: 1,
                field: "\u{fffd}".to_string()
            })
        );
        assert!(parse_rows(b"", 6).unwrap().is_empty());
    }
}
