//! binvox voxel grids (Patrick Min's mesh voxelizer), as OctoMap's `binvox2bt` reads them.
//!
//! Layout: an ASCII header of whitespace-separated words, `#binvox VERSION`, then keywords in
//! any order until `data`: `dim D H W` (the grid's three sizes, in that order), `translate X
//! Y Z` and `scale S` (the grid's corner and edge length); any other word is skipped with the
//! rest of its line. One byte (the line feed) follows `data`, then run-length coded cells:
//! pairs of bytes (value, count), `count` cells of `value`, cell `j` being
//! `x = j / (W·H)`, `z = (j / W) % H`, `y = j % W`.
//!
//! Stricter than binvox2bt, which reads what it can: a missing `dim`, `translate` or `scale`, a
//! size of zero, a grid whose cell count overflows, runs that end before the grid or run past
//! it, an odd byte at the end and data after the last run are errors naming the file and the
//! byte. Runs are kept as stored (two bytes each), so memory follows the file's size, never
//! the grid's.

use crate::error::{FormatError, Location};
use crate::source::read_all;
use std::path::Path;

/// One run of cells: `count` consecutive cells holding `value`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Run {
    /// The cells' value: 1 is a voxel (binvox2bt marks it occupied), 0 empty, anything else
    /// is kept as read.
    pub value: u8,
    /// How many cells (0 to 255; a run of 0 is allowed and covers nothing).
    pub count: u8,
}

/// A binvox file: header and runs.
#[derive(Debug, Clone, PartialEq)]
pub struct Binvox {
    /// The version after `#binvox` (binvox writes 1; any integer is accepted).
    pub version: i64,
    /// The sizes of `dim`, in file order: depth (the slowest index, `x`), height (`z`) and
    /// width (`y`, the fastest).
    pub dims: [usize; 3],
    /// `translate`: the grid's corner in world coordinates.
    pub translate: [f32; 3],
    /// `scale`: the length of the grid's longest side.
    pub scale: f32,
    /// The runs in file order; their counts add up to the cell count exactly.
    pub runs: Vec<Run>,
}

impl Binvox {
    /// Cells in the grid: `D·H·W` (checked when read, so it fits in a `usize`).
    pub fn cells(&self) -> usize {
        self.dims[0] * self.dims[1] * self.dims[2]
    }

    /// The longest side in cells.
    pub fn max_side(&self) -> usize {
        self.dims.into_iter().max().unwrap_or(0)
    }

    /// Each cell with its value, in file order, as `(x, y, z, value)` grid coordinates (see the
    /// [module docs](self)).
    pub fn cells_iter(&self) -> impl Iterator<Item = ([usize; 3], u8)> + '_ {
        let [_, h, w] = self.dims;
        let mut start = 0usize;
        self.runs.iter().flat_map(move |r| {
            let first = start;
            start += usize::from(r.count);
            (first..first + usize::from(r.count))
                .map(move |j| ([j / (w * h), j % w, (j / w) % h], r.value))
        })
    }
}

/// Header tokens: whitespace-separated words, as C++ `operator>>` reads them.
struct Header<'a> {
    data: &'a [u8],
    pos: usize,
    path: &'a Path,
}

impl<'a> Header<'a> {
    fn word(&mut self) -> Option<&'a [u8]> {
        while self.pos < self.data.len() && self.data[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        let start = self.pos;
        while self.pos < self.data.len() && !self.data[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        (self.pos > start).then(|| &self.data[start..self.pos])
    }

    fn error(&self, message: impl Into<String>) -> FormatError {
        FormatError::syntax(self.path, Location::Byte(self.pos as u64), message)
    }

    fn value<T: std::str::FromStr>(&mut self, what: &str) -> Result<T, FormatError> {
        let w = self
            .word()
            .ok_or_else(|| self.error(format!("the header ends before {what}")))?;
        std::str::from_utf8(w)
            .ok()
            .and_then(|s| s.parse().ok())
            .ok_or_else(|| {
                self.error(format!(
                    "{what}: {:?} is not a number of that kind",
                    String::from_utf8_lossy(w)
                ))
            })
    }

    fn finite(&mut self, what: &str) -> Result<f32, FormatError> {
        let v: f32 = self.value(what)?;
        if !v.is_finite() {
            return Err(self.error(format!("{what} is not finite")));
        }
        Ok(v)
    }

    fn skip_line(&mut self) {
        while self.pos < self.data.len() {
            self.pos += 1;
            if self.data[self.pos - 1] == b'\n' {
                break;
            }
        }
    }
}

/// Parse a binvox file from its bytes; `path` only names the file in errors.
pub fn parse_binvox(path: &Path, data: &[u8]) -> Result<Binvox, FormatError> {
    let mut h = Header { data, pos: 0, path };
    if h.word() != Some(b"#binvox".as_slice()) {
        return Err(FormatError::syntax(
            path,
            Location::Byte(0),
            "not a binvox file (it does not start with #binvox)",
        ));
    }
    let version: i64 = h.value("the version")?;
    let (mut dims, mut translate, mut scale) = (None, None, None);
    loop {
        let Some(word) = h.word() else {
            return Err(h.error("the header ends without a data line"));
        };
        match word {
            b"data" => break,
            b"dim" => {
                let mut d = [0usize; 3];
                for (v, name) in d.iter_mut().zip(["depth", "height", "width"]) {
                    *v = h.value(&format!("the {name} of dim"))?;
                    if *v == 0 {
                        return Err(h.error(format!("the {name} of dim is 0")));
                    }
                }
                dims = Some(d);
            }
            b"translate" => {
                let mut t = [0f32; 3];
                for (v, axis) in t.iter_mut().zip(["x", "y", "z"]) {
                    *v = h.finite(&format!("translate {axis}"))?;
                }
                translate = Some(t);
            }
            b"scale" => scale = Some(h.finite("scale")?),
            _ => h.skip_line(),
        }
    }
    let missing = |what| h.error(format!("the header has no {what} line"));
    let dims = dims.ok_or_else(|| missing("dim"))?;
    let translate = translate.ok_or_else(|| missing("translate"))?;
    let scale = scale.ok_or_else(|| missing("scale"))?;
    let cells = dims
        .iter()
        .try_fold(1usize, |acc, &d| acc.checked_mul(d))
        .ok_or_else(|| h.error(format!("dim {dims:?}: the cell count overflows")))?;
    // the byte after "data" (its line feed)
    let start = h.pos + 1;
    let body = data.get(start..).unwrap_or_default();
    if body.len() % 2 != 0 {
        return Err(FormatError::Truncated {
            path: path.to_path_buf(),
            offset: data.len() as u64,
            what: "the count of the last (value, count) pair".into(),
        });
    }
    let mut runs = Vec::with_capacity(body.len() / 2);
    let mut covered = 0usize;
    for (i, pair) in body.chunks_exact(2).enumerate() {
        let at = (start + 2 * i) as u64;
        if covered == cells {
            return Err(FormatError::syntax(
                path,
                Location::Byte(at),
                format!(
                    "{} bytes of data after the last of the grid's {cells} cells",
                    body.len() - 2 * i
                ),
            ));
        }
        let run = Run {
            value: pair[0],
            count: pair[1],
        };
        covered += usize::from(run.count);
        if covered > cells {
            return Err(FormatError::syntax(
                path,
                Location::Byte(at),
                format!(
                    "a run of {} cells goes past the grid's {cells} cells",
                    run.count
                ),
            ));
        }
        runs.push(run);
    }
    if covered < cells {
        return Err(FormatError::Truncated {
            path: path.to_path_buf(),
            offset: data.len() as u64,
            what: format!(
                "runs for {} more of the grid's {cells} cells",
                cells - covered
            ),
        });
    }
    Ok(Binvox {
        version,
        dims,
        translate,
        scale,
        runs,
    })
}

/// Read a binvox file (optionally `.gz`/`.bz2`).
pub fn read_binvox(path: &Path) -> Result<Binvox, FormatError> {
    parse_binvox(path, &read_all(path)?)
}

/// The binvox bytes of a grid: header (`#binvox 1`, `dim`, `translate`, `scale`, `data`) and
/// runs of at most 255 cells, as binvox writes them. `cells` is in file order (see the
/// [module docs](self)) and must hold `D·H·W` values; floats are written in their shortest
/// exact form.
pub fn write_binvox(dims: [usize; 3], translate: [f32; 3], scale: f32, cells: &[u8]) -> Vec<u8> {
    let mut out = format!(
        "#binvox 1\ndim {} {} {}\ntranslate {:?} {:?} {:?}\nscale {:?}\ndata\n",
        dims[0], dims[1], dims[2], translate[0], translate[1], translate[2], scale
    )
    .into_bytes();
    let mut i = 0;
    while i < cells.len() {
        let v = cells[i];
        let mut n = 1;
        while i + n < cells.len() && cells[i + n] == v && n < 255 {
            n += 1;
        }
        out.push(v);
        out.push(n as u8);
        i += n;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(data: &[u8]) -> Result<Binvox, FormatError> {
        parse_binvox(Path::new("t.binvox"), data)
    }

    #[test]
    fn round_trips_and_lists_cells_in_binvox_order() {
        // 2 x 3 x 4 cells (x slowest, then z, then y), a few set
        let dims = [2, 3, 4];
        let cells: Vec<u8> = (0..24).map(|j| u8::from(j % 5 == 0 || j >= 20)).collect();
        let bytes = write_binvox(dims, [0.5, -1.0, 2.25], 3.0, &cells);
        let b = parse(&bytes).unwrap();
        assert_eq!(
            (b.dims, b.translate, b.scale, b.version),
            (dims, [0.5, -1.0, 2.25], 3.0, 1)
        );
        assert_eq!(b.cells(), 24);
        let listed: Vec<_> = b.cells_iter().collect();
        assert_eq!(listed.len(), 24);
        for (j, ([x, y, z], v)) in listed.into_iter().enumerate() {
            assert_eq!(v, cells[j]);
            assert_eq!(x * 12 + z * 4 + y, j);
        }
    }

    #[test]
    fn long_runs_are_split_at_255() {
        let cells = vec![1u8; 600];
        let b = parse(&write_binvox([600, 1, 1], [0.0; 3], 1.0, &cells)).unwrap();
        let counts: Vec<u8> = b.runs.iter().map(|r| r.count).collect();
        assert_eq!(counts, [255, 255, 90]);
    }

    #[test]
    fn unknown_header_lines_are_skipped() {
        let data = b"#binvox 1\ncomment anything here 1 2\ndim 1 1 2\nscale 1\ntranslate 0 0 0\ndata\n\x01\x02";
        assert_eq!(parse(data).unwrap().runs, [Run { value: 1, count: 2 }]);
    }

    #[test]
    fn hostile_inputs_are_errors_naming_the_place() {
        let head = b"#binvox 1\ndim 2 2 2\ntranslate 0 0 0\nscale 1\ndata\n".to_vec();
        let with = |tail: &[u8]| {
            let mut d = head.clone();
            d.extend_from_slice(tail);
            d
        };
        let cases: Vec<(Vec<u8>, &str)> =
            vec![
            (b"#binvo 1".to_vec(), "#binvox"),
            (b"#binvox 1\ndim 2 2\n".to_vec(), "ends before the width"),
            (b"#binvox 1\ndim 0 2 2 translate 0 0 0 scale 1 data\n".to_vec(), "is 0"),
            (b"#binvox 1\ndim 2 2 2\nscale 1\ndata\n\x00\x08".to_vec(), "no translate"),
            (b"#binvox 1\ndim 2 2 2\ntranslate 0 0 0\nscale nan\ndata\n".to_vec(), "not finite"),
            (
                b"#binvox 1\ndim 4294967296 4294967296 4294967296 translate 0 0 0 scale 1 data\n"
                    .to_vec(),
                "overflows",
            ),
            (b"#binvox 1\ndim 2 2 2\n".to_vec(), "without a data line"),
            (with(b"\x01\x07"), "1 more"),
            (with(b"\x01\x09"), "goes past"),
            (with(b"\x01\x08\x00\x01"), "after the last"),
            (with(b"\x01\x08\x00"), "truncated"),
            (with(b""), "8 more"),
        ];
        for (data, expected) in cases {
            let e = parse(&data).unwrap_err().to_string();
            assert!(e.contains(expected), "{e} (expected {expected:?})");
            assert!(e.contains("t.binvox"), "{e}");
        }
    }
}
