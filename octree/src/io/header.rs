//! The ASCII header shared by `.bt` and `.ot` (OctoMap's `AbstractOcTree::readHeader`).

use super::stream::Stream;
use crate::error::OctreeError;
use std::io::{Read, Write};

/// Parsed header fields.
pub(crate) struct Header {
    pub size: u64,
    pub res: f64,
}

/// Format a resolution as C++'s default `ostream << double` does (`%g`, 6 significant
/// digits): 0.1 -> `0.1`, 1e-5 -> `1e-05`, 0.123456789 -> `0.123457`.
pub fn format_resolution(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let sci = format!("{:.5e}", v);
    let (mant, exp) = sci.split_once('e').expect("exponent format");
    let exp: i32 = exp.parse().expect("exponent digits");
    let strip = |s: &str| -> String {
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s.to_string()
        }
    };
    if (-4..6).contains(&exp) {
        strip(&format!("{:.*}", (5 - exp) as usize, v))
    } else {
        let sign = if exp < 0 { '-' } else { '+' };
        format!("{}e{}{:02}", strip(mant), sign, exp.abs())
    }
}

/// Write the header lines after the format's first line, for an `OcTree`.
pub(crate) fn write_header<W: Write + ?Sized>(
    w: &mut W,
    first_line: &str,
    size: usize,
    res: f64,
) -> std::io::Result<()> {
    write_header_id(w, first_line, "OcTree", size, res)
}

/// Write the header lines with the tree type `id` (OctoMap's `getTreeType()`).
pub(crate) fn write_header_id<W: Write + ?Sized>(
    w: &mut W,
    first_line: &str,
    id: &str,
    size: usize,
    res: f64,
) -> std::io::Result<()> {
    write!(
        w,
        "{first_line}\n# (feel free to add / change comments, but leave the first line as it is!)\n#\nid {id}\nsize {size}\nres {}\ndata\n",
        format_resolution(res)
    )
}

/// Read header tokens up to and including the `data` line. The id must be `OcTree` (or the
/// deprecated `1`); `res` must be positive.
pub(crate) fn read_header<R: Read>(
    s: &mut Stream<R>,
    format: &'static str,
) -> Result<Header, OctreeError> {
    let (h, id) = read_header_any(s, format)?;
    if id != "OcTree" && id != "1" {
        return Err(OctreeError::UnsupportedTreeType { id });
    }
    Ok(h)
}

/// [`read_header`] for any tree type: the header and its id, unchecked.
pub(crate) fn read_header_any<R: Read>(
    s: &mut Stream<R>,
    format: &'static str,
) -> Result<(Header, String), OctreeError> {
    let start = s.offset;
    let mut id: Option<String> = None;
    let mut size: u64 = 0;
    let mut res: Option<f64> = None;
    loop {
        let Some((tok, at)) = s.token(format)? else {
            return Err(s.format_err(format, s.offset, "header ends without a 'data' line".into()));
        };
        match tok.as_str() {
            "data" => {
                s.skip_line()?;
                break;
            }
            t if t.starts_with('#') => s.skip_line()?,
            "id" => {
                let (v, _) = s
                    .token(format)?
                    .ok_or_else(|| s.format_err(format, at, "'id' without a value".into()))?;
                id = Some(v);
            }
            "res" => {
                let (v, vat) = s
                    .token(format)?
                    .ok_or_else(|| s.format_err(format, at, "'res' without a value".into()))?;
                let r: f64 = v.parse().map_err(|_| {
                    s.format_err(format, vat, format!("resolution {v:?} is not a number"))
                })?;
                res = Some(r);
            }
            "size" => {
                let (v, vat) = s
                    .token(format)?
                    .ok_or_else(|| s.format_err(format, at, "'size' without a value".into()))?;
                size = v.parse().map_err(|_| {
                    s.format_err(format, vat, format!("size {v:?} is not a node count"))
                })?;
            }
            _ => s.skip_line()?, // OctoMap warns and skips unknown keywords
        }
    }
    let id = id.ok_or_else(|| s.format_err(format, start, "header has no 'id'".into()))?;
    let res = match res {
        Some(r) if r.is_finite() && r > 0.0 => r,
        Some(r) => {
            return Err(s.format_err(format, start, format!("resolution {r} is not positive")))
        }
        None => return Err(s.format_err(format, start, "header has no 'res'".into())),
    };
    Ok((Header { size, res }, id))
}

#[cfg(test)]
mod tests {
    use super::format_resolution;

    #[test]
    fn like_cpp_ostream() {
        assert_eq!(format_resolution(0.1), "0.1");
        assert_eq!(format_resolution(0.05), "0.05");
        assert_eq!(format_resolution(0.08), "0.08");
        assert_eq!(format_resolution(1e-5), "1e-05");
        assert_eq!(format_resolution(0.123456789), "0.123457");
        assert_eq!(format_resolution(1.0), "1");
        assert_eq!(format_resolution(1234567.0), "1.23457e+06");
        assert_eq!(format_resolution(100000.0), "100000");
        assert_eq!(format_resolution(0.0001), "0.0001");
        assert_eq!(format_resolution(0.00999999977648258), "0.01");
    }
}
