//! The message serializations of ROS bags: `ros1` (little-endian, packed, strings as `u32`
//! length + bytes) and `cdr` (ROS 2: a 4-byte encapsulation header selecting little or big
//! endian, then each primitive aligned to its size relative to the end of that header; strings
//! carry a NUL), read through one cursor ([`Reader`]) whose errors give the message byte.

/// The message encodings of the decoders ([`super::decode_point_cloud2`],
/// [`super::decode_tf_message`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Encoding {
    /// ROS 1 serialization (`ros1`).
    Ros1,
    /// ROS 2 CDR with its encapsulation header (`cdr`).
    Cdr,
}

impl Encoding {
    /// The encoding of an MCAP channel's `message_encoding`, `None` if unknown.
    pub fn from_mcap(name: &str) -> Option<Encoding> {
        match name {
            "ros1" => Some(Encoding::Ros1),
            "cdr" => Some(Encoding::Cdr),
            _ => None,
        }
    }
}

/// A decoding failure inside one message: what and at which byte of the message.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("byte {offset} of the message: {message}")]
pub struct DecodeError {
    /// Byte offset in the message where decoding failed.
    pub offset: usize,
    /// What is wrong.
    pub message: String,
}

/// Reads ROS 1 or CDR primitives from a message.
pub(super) struct Reader<'a> {
    buf: &'a [u8],
    pos: usize,
    /// CDR: alignment origin (just after the encapsulation header); `None` for ROS 1.
    cdr_origin: Option<usize>,
    big_endian: bool,
}

impl<'a> Reader<'a> {
    pub(super) fn new(buf: &'a [u8], encoding: Encoding) -> Result<Self, DecodeError> {
        match encoding {
            Encoding::Ros1 => Ok(Reader {
                buf,
                pos: 0,
                cdr_origin: None,
                big_endian: false,
            }),
            Encoding::Cdr => {
                let head = buf.get(..4).ok_or_else(|| DecodeError {
                    offset: 0,
                    message: "shorter than the 4-byte CDR encapsulation header".into(),
                })?;
                let big_endian = match head[1] {
                    0x00 | 0x02 => true,
                    0x01 | 0x03 => false,
                    k => {
                        return Err(DecodeError {
                            offset: 0,
                            message: format!("unknown CDR encapsulation kind {:#04x}", k),
                        })
                    }
                };
                Ok(Reader {
                    buf,
                    pos: 4,
                    cdr_origin: Some(4),
                    big_endian,
                })
            }
        }
    }

    pub(super) fn err(&self, message: impl Into<String>) -> DecodeError {
        DecodeError {
            offset: self.pos,
            message: message.into(),
        }
    }

    pub(super) fn align(&mut self, n: usize) {
        if let Some(o) = self.cdr_origin {
            let rel = self.pos - o;
            self.pos += (n - rel % n) % n;
        }
    }

    pub(super) fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], DecodeError> {
        let end = self.pos.checked_add(n).filter(|&e| e <= self.buf.len());
        match end {
            Some(e) => {
                let s = &self.buf[self.pos..e];
                self.pos = e;
                Ok(s)
            }
            None => Err(self.err(format!(
                "message ends inside {what} ({n} bytes needed, {} left)",
                self.buf.len().saturating_sub(self.pos)
            ))),
        }
    }

    pub(super) fn u8(&mut self, what: &str) -> Result<u8, DecodeError> {
        Ok(self.take(1, what)?[0])
    }

    pub(super) fn u32(&mut self, what: &str) -> Result<u32, DecodeError> {
        self.align(4);
        let b: [u8; 4] = self.take(4, what)?.try_into().unwrap_or([0; 4]);
        Ok(if self.big_endian {
            u32::from_be_bytes(b)
        } else {
            u32::from_le_bytes(b)
        })
    }

    pub(super) fn f64(&mut self, what: &str) -> Result<f64, DecodeError> {
        self.align(8);
        let b: [u8; 8] = self.take(8, what)?.try_into().unwrap_or([0; 8]);
        Ok(if self.big_endian {
            f64::from_be_bytes(b)
        } else {
            f64::from_le_bytes(b)
        })
    }

    /// A length-prefixed string; CDR strings end in a NUL counted in the length.
    pub(super) fn string(&mut self, what: &str) -> Result<String, DecodeError> {
        let n = self.u32(what)? as usize;
        let bytes = self.take(n, what)?;
        let bytes = if self.cdr_origin.is_some() {
            bytes.strip_suffix(&[0]).unwrap_or(bytes)
        } else {
            bytes
        };
        String::from_utf8(bytes.to_vec()).map_err(|_| self.err(format!("{what} is not UTF-8")))
    }

    /// A sequence count, checked against the bytes left (each element needs `min_size`).
    pub(super) fn count(&mut self, what: &str, min_size: usize) -> Result<usize, DecodeError> {
        let n = self.u32(what)? as usize;
        let left = self.buf.len().saturating_sub(self.pos);
        if n.saturating_mul(min_size) > left {
            return Err(self.err(format!("{what}: count {n} exceeds the {left} bytes left")));
        }
        Ok(n)
    }

    /// `std_msgs/Header` -> (frame_id, stamp seconds).
    pub(super) fn header(&mut self) -> Result<(String, f64), DecodeError> {
        if self.cdr_origin.is_none() {
            self.u32("header.seq")?;
        }
        let sec = self.u32("header.stamp.sec")?;
        let nsec = self.u32("header.stamp.nanosec")?;
        let sec = if self.cdr_origin.is_some() {
            sec as i32 as f64
        } else {
            sec as f64
        };
        let frame = self.string("header.frame_id")?;
        Ok((frame, sec + nsec as f64 * 1e-9))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cdr_alignment_is_relative_to_the_payload() {
        // encapsulation (LE), then u8 1, pad to 4, u32 7, pad to 8, f64 2.5
        let mut m = vec![0, 1, 0, 0, 1, 0, 0, 0];
        m.extend_from_slice(&7u32.to_le_bytes());
        m.extend_from_slice(&2.5f64.to_le_bytes());
        let mut r = Reader::new(&m, Encoding::Cdr).unwrap();
        assert_eq!(r.u8("a").unwrap(), 1);
        assert_eq!(r.u32("b").unwrap(), 7);
        assert_eq!(r.f64("c").unwrap(), 2.5);
        assert_eq!(r.pos, m.len());
    }

    #[test]
    fn truncated_messages_are_errors() {
        let mut r = Reader::new(&[0, 1, 0, 0, 9], Encoding::Cdr).unwrap();
        let e = r.u32("height").unwrap_err();
        assert!(e.message.contains("height"), "{e}");
    }
}
