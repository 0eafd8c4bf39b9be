//! OMG CDR (XCDR1), the serialisation of ROS 2 messages, as `rmw` writes it.
//!
//! A payload starts with a 4-byte encapsulation header: `0x00 0x01` for little-endian
//! CDR (`CDR_LE`, what every ROS 2 machine writes), `0x00 0x00` for big-endian
//! (`CDR_BE`), then two option bytes (`0x00 0x00`). After it, every primitive is aligned
//! to its own size counted from the end of the header (an `f64` starts at a multiple of
//! 8); a string is a `u32` length that counts a terminating NUL, the bytes and the NUL;
//! a sequence is a `u32` element count and the elements; a fixed-size array is its
//! elements only; nested messages are inlined with no alignment of their own.
//!
//! [`CdrReader`] never reads past the end and names the field and offset of any
//! problem; [`CdrWriter`] writes little-endian CDR byte for byte as `rmw_fastrtps` and
//! Python `mcap-ros2-support` do (no trailing padding).

use crate::error::{DecodeError, EncodeError};
use tether_core::Stamp;

/// Length of the encapsulation header.
pub const ENCAPSULATION_LEN: usize = 4;

/// The encapsulation header of little-endian CDR, as ROS 2 writes it.
pub const CDR_LE_HEADER: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// Trailing bytes after the last field that are accepted as padding (some DDS
/// implementations pad a payload to a multiple of 4 or 8 bytes with zeros).
const MAX_TRAILING_PADDING: usize = 7;

/// A cursor over a CDR payload that never reads past its end.
#[derive(Debug)]
pub struct CdrReader<'a> {
    /// The payload after the encapsulation header.
    body: &'a [u8],
    pos: usize,
    big_endian: bool,
}

macro_rules! read_number {
    ($name:ident, $ty:ty, $n:literal) => {
        #[doc = concat!("Reads an aligned `", stringify!($ty), "`.")]
        pub fn $name(&mut self, field: &'static str) -> Result<$ty, DecodeError> {
            self.align(field, $n)?;
            let bytes: [u8; $n] = self.array(field)?;
            Ok(if self.big_endian {
                <$ty>::from_be_bytes(bytes)
            } else {
                <$ty>::from_le_bytes(bytes)
            })
        }
    };
}

impl<'a> CdrReader<'a> {
    /// Checks the encapsulation header of `payload` and starts after it.
    pub fn new(payload: &'a [u8]) -> Result<Self, DecodeError> {
        let Some((header, body)) = payload.split_first_chunk::<ENCAPSULATION_LEN>() else {
            return Err(DecodeError::Truncated {
                field: "encapsulation header",
                at: 0,
                needed: ENCAPSULATION_LEN as u64,
                available: payload.len(),
            });
        };
        let big_endian = match [header[0], header[1]] {
            [0x00, 0x01] => false,
            [0x00, 0x00] => true,
            kind => return Err(DecodeError::Encapsulation { kind }),
        };
        Ok(CdrReader {
            body,
            pos: 0,
            big_endian,
        })
    }

    /// Offset of the cursor in the payload (counting the encapsulation header).
    pub fn offset(&self) -> usize {
        self.pos + ENCAPSULATION_LEN
    }

    fn truncated(&self, field: &'static str, needed: u64) -> DecodeError {
        DecodeError::Truncated {
            field,
            at: self.offset(),
            needed,
            available: self.body.len() - self.pos,
        }
    }

    fn take(&mut self, field: &'static str, n: u64) -> Result<&'a [u8], DecodeError> {
        let available = self.body.len() - self.pos;
        if n > available as u64 {
            return Err(self.truncated(field, n));
        }
        let out = &self.body[self.pos..self.pos + n as usize];
        self.pos += n as usize;
        Ok(out)
    }

    fn array<const N: usize>(&mut self, field: &'static str) -> Result<[u8; N], DecodeError> {
        let mut out = [0u8; N];
        out.copy_from_slice(self.take(field, N as u64)?);
        Ok(out)
    }

    /// Skips the padding that aligns the next value to `n` bytes.
    pub fn align(&mut self, field: &'static str, n: usize) -> Result<(), DecodeError> {
        let pad = (n - self.pos % n) % n;
        self.take(field, pad as u64).map(|_| ())
    }

    /// Reads a `u8` (also `uint8`, `byte`, `char`, `bool` on the wire).
    pub fn u8(&mut self, field: &'static str) -> Result<u8, DecodeError> {
        Ok(self.take(field, 1)?[0])
    }

    read_number!(u32, u32, 4);
    read_number!(i32, i32, 4);
    read_number!(f32, f32, 4);
    read_number!(f64, f64, 8);

    /// Reads a `u32` element count of a sequence whose elements take at least
    /// `min_elem_len` bytes, refusing counts the rest of the payload cannot hold (so a
    /// corrupt count never allocates).
    pub fn count(&mut self, field: &'static str, min_elem_len: u64) -> Result<usize, DecodeError> {
        let n = self.u32(field)?;
        let needed = u64::from(n) * min_elem_len;
        if needed > (self.body.len() - self.pos) as u64 {
            return Err(self.truncated(field, needed));
        }
        Ok(n as usize)
    }

    /// Reads a string: `u32` length counting the NUL, the bytes, the NUL. A length of 0
    /// (written by some non-conforming writers for "") is read as the empty string.
    pub fn string(&mut self, field: &'static str) -> Result<String, DecodeError> {
        let len = self.u32(field)?;
        if len == 0 {
            return Ok(String::new());
        }
        let bytes = self.take(field, u64::from(len))?;
        let (last, text) = bytes.split_last().unwrap_or((&0, &[]));
        if *last != 0 {
            return Err(DecodeError::BadValue {
                field,
                problem: "string does not end with NUL".into(),
            });
        }
        // Padding NULs before the terminator are tolerated; a NUL inside the text is
        // not (no ROS 2 string holds one, and it could not be written back).
        let end = text.iter().rposition(|&b| b != 0).map_or(0, |i| i + 1);
        let text = &text[..end];
        if text.contains(&0) {
            return Err(DecodeError::BadValue {
                field,
                problem: "string holds a NUL inside its text".into(),
            });
        }
        String::from_utf8(text.to_vec()).map_err(|_| DecodeError::NotUtf8 { field })
    }

    /// Reads a `uint8[]` sequence.
    pub fn bytes(&mut self, field: &'static str) -> Result<Vec<u8>, DecodeError> {
        let n = self.count(field, 1)?;
        Ok(self.take(field, n as u64)?.to_vec())
    }

    /// Reads a `float32[]` sequence.
    pub fn f32_seq(&mut self, field: &'static str) -> Result<Vec<f32>, DecodeError> {
        let n = self.count(field, 4)?;
        // The elements follow the count, which is itself 4-aligned: no padding.
        let bytes = self.take(field, n as u64 * 4)?;
        let big = self.big_endian;
        Ok(bytes
            .chunks_exact(4)
            .map(|b| {
                let b = [b[0], b[1], b[2], b[3]];
                if big {
                    f32::from_be_bytes(b)
                } else {
                    f32::from_le_bytes(b)
                }
            })
            .collect())
    }

    /// Reads a fixed-size `float64[N]` array.
    pub fn f64_array<const N: usize>(
        &mut self,
        field: &'static str,
    ) -> Result<[f64; N], DecodeError> {
        let mut out = [0.0; N];
        for v in &mut out {
            *v = self.f64(field)?;
        }
        Ok(out)
    }

    /// Reads a `builtin_interfaces/Time` (`int32 sec`, `uint32 nanosec`).
    pub fn time(&mut self, field: &'static str) -> Result<Stamp, DecodeError> {
        let sec = self.i32(field)?;
        let nanosec = self.u32(field)?;
        if nanosec >= 1_000_000_000 {
            return Err(DecodeError::BadValue {
                field,
                problem: format!("nanosec = {nanosec} is not below 1e9"),
            });
        }
        // i32 seconds always fit in i64 nanoseconds.
        Ok(Stamp::from_ns(
            i64::from(sec) * 1_000_000_000 + i64::from(nanosec),
        ))
    }

    /// Ends the message: anything left over but a little zero padding is an error.
    pub fn finish(self) -> Result<(), DecodeError> {
        let rest = &self.body[self.pos..];
        if rest.len() <= MAX_TRAILING_PADDING && rest.iter().all(|&b| b == 0) {
            Ok(())
        } else {
            Err(DecodeError::TrailingBytes { extra: rest.len() })
        }
    }
}

/// Writes little-endian CDR, starting with the encapsulation header.
#[derive(Debug, Clone)]
pub struct CdrWriter {
    out: Vec<u8>,
}

impl Default for CdrWriter {
    fn default() -> Self {
        Self::new()
    }
}

macro_rules! write_number {
    ($name:ident, $ty:ty, $n:literal) => {
        #[doc = concat!("Writes an aligned `", stringify!($ty), "`.")]
        pub fn $name(&mut self, v: $ty) {
            self.align($n);
            self.out.extend_from_slice(&v.to_le_bytes());
        }
    };
}

impl CdrWriter {
    /// An empty message (just the header).
    pub fn new() -> Self {
        Self::reusing(Vec::new())
    }

    /// An empty message written into `buf` (cleared), to reuse its allocation.
    pub fn reusing(mut buf: Vec<u8>) -> Self {
        buf.clear();
        buf.extend_from_slice(&CDR_LE_HEADER);
        CdrWriter { out: buf }
    }

    /// The payload, header included.
    pub fn into_bytes(self) -> Vec<u8> {
        self.out
    }

    /// Pads with zeros to a multiple of `n` bytes after the header.
    pub fn align(&mut self, n: usize) {
        let pos = self.out.len() - ENCAPSULATION_LEN;
        let pad = (n - pos % n) % n;
        self.out.resize(self.out.len() + pad, 0);
    }

    /// Writes a `u8`.
    pub fn u8(&mut self, v: u8) {
        self.out.push(v);
    }

    write_number!(u32, u32, 4);
    write_number!(i32, i32, 4);
    write_number!(f32, f32, 4);
    write_number!(f64, f64, 8);

    /// Writes a sequence length; fails when it does not fit the `u32` of CDR.
    pub fn count(&mut self, field: &'static str, n: usize) -> Result<(), EncodeError> {
        let n = u32::try_from(n).map_err(|_| EncodeError::TooLong { field, len: n })?;
        self.u32(n);
        Ok(())
    }

    /// Writes a string (length with NUL, bytes, NUL). Strings with NUL bytes inside
    /// cannot be represented and are refused.
    pub fn string(&mut self, field: &'static str, s: &str) -> Result<(), EncodeError> {
        if s.as_bytes().contains(&0) {
            return Err(EncodeError::NulInString { field });
        }
        self.count(field, s.len() + 1)?;
        self.out.extend_from_slice(s.as_bytes());
        self.out.push(0);
        Ok(())
    }

    /// Writes a `uint8[]` sequence.
    pub fn bytes(&mut self, field: &'static str, b: &[u8]) -> Result<(), EncodeError> {
        self.count(field, b.len())?;
        self.out.extend_from_slice(b);
        Ok(())
    }

    /// Writes a `float32[]` sequence.
    pub fn f32_seq(&mut self, field: &'static str, v: &[f32]) -> Result<(), EncodeError> {
        self.count(field, v.len())?;
        self.out.reserve(v.len() * 4);
        for x in v {
            self.out.extend_from_slice(&x.to_le_bytes());
        }
        Ok(())
    }

    /// Writes a fixed-size `float64[N]` array.
    pub fn f64_array(&mut self, v: &[f64]) {
        for &x in v {
            self.f64(x);
        }
    }

    /// Writes a `builtin_interfaces/Time`; fails when the seconds do not fit an `i32`
    /// (before 1901 or after 2038 on the Unix epoch).
    pub fn time(&mut self, field: &'static str, stamp: Stamp) -> Result<(), EncodeError> {
        let ns = stamp.ns();
        let sec = i32::try_from(ns.div_euclid(1_000_000_000))
            .map_err(|_| EncodeError::StampOutOfRange { field, stamp })?;
        self.i32(sec);
        self.u32(ns.rem_euclid(1_000_000_000) as u32);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn aligns_after_the_header() {
        let mut w = CdrWriter::new();
        w.u8(7);
        w.f64(1.5);
        w.string("s", "ab").unwrap();
        let bytes = w.into_bytes();
        // header, u8, 7 bytes of padding, f64, u32 length 3, "ab\0".
        assert_eq!(bytes.len(), 4 + 1 + 7 + 8 + 4 + 3);
        let mut r = CdrReader::new(&bytes).unwrap();
        assert_eq!(r.u8("a").unwrap(), 7);
        assert_eq!(r.f64("b").unwrap(), 1.5);
        assert_eq!(r.string("s").unwrap(), "ab");
        r.finish().unwrap();
    }

    #[test]
    fn a_nul_inside_a_string_is_refused_padding_nuls_are_not() {
        let read = |body: &[u8]| {
            let mut bytes = vec![0, 1, 0, 0];
            bytes.extend_from_slice(body);
            CdrReader::new(&bytes).unwrap().string("s")
        };
        assert_eq!(read(&[4, 0, 0, 0, b'a', b'b', 0, 0]).unwrap(), "ab");
        assert!(read(&[2, 0, 0, 0, 0, 0]).unwrap().is_empty());
        assert!(read(&[4, 0, 0, 0, b'a', 0, b'b', 0]).is_err());
        assert!(read(&[3, 0, 0, 0, b'a', b'b', b'c']).is_err());
    }

    #[test]
    fn reads_big_endian() {
        let bytes = [0, 0, 0, 0, 0, 0, 0, 2, 0x3f, 0x80, 0, 0];
        let mut r = CdrReader::new(&bytes).unwrap();
        assert_eq!(r.u32("n").unwrap(), 2);
        assert_eq!(r.f32("x").unwrap(), 1.0);
    }

    #[test]
    fn refuses_damage() {
        assert!(matches!(
            CdrReader::new(&[0, 3, 0, 0]),
            Err(DecodeError::Encapsulation { kind: [0, 3] })
        ));
        assert!(CdrReader::new(&[0, 1]).is_err());
        let mut w = CdrWriter::new();
        w.u32(u32::MAX);
        let bytes = w.into_bytes();
        let mut r = CdrReader::new(&bytes).unwrap();
        assert!(matches!(
            r.f32_seq("ranges"),
            Err(DecodeError::Truncated {
                field: "ranges",
                ..
            })
        ));
        let mut r = CdrReader::new(&[0, 1, 0, 0, 2, 0, 0, 0, b'a', b'b']).unwrap();
        assert!(matches!(
            r.string("s"),
            Err(DecodeError::BadValue { field: "s", .. })
        ));
        let r = CdrReader::new(&[0, 1, 0, 0, 1]).unwrap();
        assert_eq!(r.finish(), Err(DecodeError::TrailingBytes { extra: 1 }));
        let r = CdrReader::new(&[0, 1, 0, 0, 0, 0, 0]).unwrap();
        assert_eq!(r.finish(), Ok(()), "zero padding is accepted");
    }

    #[test]
    fn times_round_trip_and_refuse_overflow() {
        for ns in [
            0,
            -1,
            1_700_000_000_123_456_789,
            -2_000_000_000_000_000_000 / 1000,
        ] {
            let mut w = CdrWriter::new();
            w.time("t", Stamp::from_ns(ns)).unwrap();
            let bytes = w.into_bytes();
            assert_eq!(CdrReader::new(&bytes).unwrap().time("t").unwrap().ns(), ns);
        }
        let mut w = CdrWriter::new();
        assert!(w.time("t", Stamp::from_ns(i64::MAX)).is_err());
    }
}
