//! Huffman tables and the entropy-coded bit stream, with libjpeg's behaviour at markers
//! and at the end of the data.
//!
//! When the entropy decoder reaches a marker (or the end of the file), libjpeg feeds it
//! zero bits and, from the next MCU on, stops decoding until the next restart marker
//! (the blocks stay zero: grey). Which MCU is the first one left out decides the
//! picture of a truncated file, so the rule is reproduced exactly: an MCU is left out
//! when an earlier one used a bit past the end of the data.

use super::source::Source;
use super::{JpegError, Warning};

/// A table as a DHT segment defines it: code counts per length and the symbols.
#[derive(Clone)]
pub(crate) struct HuffSpec {
    /// `counts[l]`: number of codes of length `l` (1..=16); `counts[0]` unused.
    pub counts: [u8; 17],
    /// The symbols in code order (the unused tail is zero).
    pub symbols: [u8; 256],
}

impl HuffSpec {
    fn from_std(counts: &[u8; 16], symbols: &[u8]) -> Self {
        let mut spec = HuffSpec {
            counts: [0; 17],
            symbols: [0; 256],
        };
        spec.counts[1..].copy_from_slice(counts);
        spec.symbols[..symbols.len()].copy_from_slice(symbols);
        spec
    }

    /// The standard luminance DC table (ITU-T T.81 K.3), which libjpeg-turbo installs for
    /// sequential files that do not define one (Motion-JPEG frames).
    pub fn std_dc_luminance() -> Self {
        Self::from_std(
            &[0, 1, 5, 1, 1, 1, 1, 1, 1, 0, 0, 0, 0, 0, 0, 0],
            &[0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11],
        )
    }

    /// The standard chrominance DC table.
    pub fn std_dc_chrominance() -> Self {
        Self::from_std(
            &[0, 3, 1, 1, 1, 1, 1, 1, 1, 1, 1, 0, 0, 0, 0, 0],
            &[0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11],
        )
    }

    /// The standard luminance AC table.
    pub fn std_ac_luminance() -> Self {
        Self::from_std(
            &[0, 2, 1, 3, 3, 2, 4, 3, 5, 5, 4, 4, 0, 0, 1, 0x7d],
            &STD_AC_LUMINANCE,
        )
    }

    /// The standard chrominance AC table.
    pub fn std_ac_chrominance() -> Self {
        Self::from_std(
            &[0, 2, 1, 2, 4, 4, 3, 4, 7, 5, 4, 4, 0, 1, 2, 0x77],
            &STD_AC_CHROMINANCE,
        )
    }
}

const STD_AC_LUMINANCE: [u8; 162] = [
    0x01, 0x02, 0x03, 0x00, 0x04, 0x11, 0x05, 0x12, 0x21, 0x31, 0x41, 0x06, 0x13, 0x51, 0x61, 0x07,
    0x22, 0x71, 0x14, 0x32, 0x81, 0x91, 0xa1, 0x08, 0x23, 0x42, 0xb1, 0xc1, 0x15, 0x52, 0xd1, 0xf0,
    0x24, 0x33, 0x62, 0x72, 0x82, 0x09, 0x0a, 0x16, 0x17, 0x18, 0x19, 0x1a, 0x25, 0x26, 0x27, 0x28,
    0x29, 0x2a, 0x34, 0x35, 0x36, 0x37, 0x38, 0x39, 0x3a, 0x43, 0x44, 0x45, 0x46, 0x47, 0x48, 0x49,
    0x4a, 0x53, 0x54, 0x55, 0x56, 0x57, 0x58, 0x59, 0x5a, 0x63, 0x64, 0x65, 0x66, 0x67, 0x68, 0x69,
    0x6a, 0x73, 0x74, 0x75, 0x76, 0x77, 0x78, 0x79, 0x7a, 0x83, 0x84, 0x85, 0x86, 0x87, 0x88, 0x89,
    0x8a, 0x92, 0x93, 0x94, 0x95, 0x96, 0x97, 0x98, 0x99, 0x9a, 0xa2, 0xa3, 0xa4, 0xa5, 0xa6, 0xa7,
    0xa8, 0xa9, 0xaa, 0xb2, 0xb3, 0xb4, 0xb5, 0xb6, 0xb7, 0xb8, 0xb9, 0xba, 0xc2, 0xc3, 0xc4, 0xc5,
    0xc6, 0xc7, 0xc8, 0xc9, 0xca, 0xd2, 0xd3, 0xd4, 0xd5, 0xd6, 0xd7, 0xd8, 0xd9, 0xda, 0xe1, 0xe2,
    0xe3, 0xe4, 0xe5, 0xe6, 0xe7, 0xe8, 0xe9, 0xea, 0xf1, 0xf2, 0xf3, 0xf4, 0xf5, 0xf6, 0xf7, 0xf8,
    0xf9, 0xfa,
];

// Data, not logic: the standard AC tables (ITU T.81 K.3) share their tail of symbols.
const STD_AC_CHROMINANCE: [u8; 162] = [
    0x00, 0x01, 0x02, 0x03, 0x11, 0x04, 0x05, 0x21, 0x31, 0x06, 0x12, 0x41, 0x51, 0x07, 0x61, 0x71,
    0x13, 0x22, 0x32, 0x81, 0x08, 0x14, 0x42, 0x91, 0xa1, 0xb1, 0xc1, 0x09, 0x23, 0x33, 0x52, 0xf0,
    0x15, 0x62, 0x72, 0xd1, 0x0a, 0x16, 0x24, 0x34, 0xe1, 0x25, 0xf1, 0x17, 0x18, 0x19, 0x1a, 0x26,
    0x27, 0x28, 0x29, 0x2a, 0x35, 0x36, 0x37, 0x38, 0x39, 0x3a, 0x43, 0x44, 0x45, 0x46, 0x47, 0x48,
    0x49, 0x4a, 0x53, 0x54, 0x55, 0x56, 0x57, 0x58, 0x59, 0x5a, 0x63, 0x64, 0x65, 0x66, 0x67, 0x68,
    0x69, 0x6a, 0x73, 0x74, 0x75, 0x76, 0x77, 0x78, 0x79, 0x7a, 0x82, 0x83, 0x84, 0x85, 0x86, 0x87,
    0x88, 0x89, 0x8a, 0x92, 0x93, 0x94, 0x95, 0x96, 0x97, 0x98, 0x99, 0x9a, 0xa2, 0xa3, 0xa4, 0xa5,
    0xa6, 0xa7, 0xa8, 0xa9, 0xaa, 0xb2, 0xb3, 0xb4, 0xb5, 0xb6, 0xb7, 0xb8, 0xb9, 0xba, 0xc2, 0xc3,
    0xc4, 0xc5, 0xc6, 0xc7, 0xc8, 0xc9, 0xca, 0xd2, 0xd3, 0xd4, 0xd5, 0xd6, 0xd7, 0xd8, 0xd9, 0xda,
    0xe2, 0xe3, 0xe4, 0xe5, 0xe6, 0xe7, 0xe8, 0xe9, 0xea, 0xf2, 0xf3, 0xf4, 0xf5, 0xf6, 0xf7, 0xf8,
    0xf9, 0xfa,
];

/// Codes of up to this many bits are decoded with one table lookup.
const LOOKUP_BITS: u32 = 9;

/// A table ready for decoding (libjpeg's `d_derived_tbl`).
pub(crate) struct HuffTable {
    /// Per `LOOKUP_BITS`-bit prefix: `(length << 8) | symbol`, or 0 if the code is longer.
    lookup: [u16; 1 << LOOKUP_BITS],
    /// Largest code of each length (-1 if none); index 17 is a sentinel.
    maxcode: [i32; 18],
    /// Symbol index of a code of each length, minus that length's first code.
    valoffset: [i32; 18],
    symbols: [u8; 256],
    /// AC tables: per `LOOKUP_BITS`-bit prefix holding a whole nonzero coefficient (code
    /// and value bits), `(value << 16) | (run << 8) | bits`; 0 otherwise.
    fast_ac: Box<[u32; 1 << LOOKUP_BITS]>,
}

impl HuffTable {
    /// Builds the decoding table, with libjpeg's checks: at most 256 codes, a code
    /// set that fits its lengths, and for DC tables symbols no larger than 15.
    pub fn new(spec: &HuffSpec, is_dc: bool) -> Result<Self, &'static str> {
        let mut sizes = Vec::with_capacity(257);
        for l in 1..=16u8 {
            for _ in 0..spec.counts[usize::from(l)] {
                sizes.push(l);
            }
        }
        if sizes.len() > 256 {
            return Err("more than 256 codes");
        }
        let n = sizes.len();
        // Canonical codes (Figure C.2), checking that no length overflows.
        let mut codes = vec![0u32; n];
        let mut code = 0u32;
        let mut p = 0;
        let mut si = sizes.first().copied().unwrap_or(0);
        while p < n {
            while p < n && sizes[p] == si {
                codes[p] = code;
                code += 1;
                p += 1;
            }
            if code >= 1 << si {
                return Err("the code lengths do not form a valid code");
            }
            code <<= 1;
            si += 1;
        }
        let mut maxcode = [-1i32; 18];
        let mut valoffset = [0i32; 18];
        let mut p = 0usize;
        for l in 1..=16usize {
            let count = usize::from(spec.counts[l]);
            if count > 0 {
                valoffset[l] = p as i32 - codes[p] as i32;
                p += count;
                maxcode[l] = codes[p - 1] as i32;
            }
        }
        maxcode[17] = 0xfffff;
        let mut lookup = [0u16; 1 << LOOKUP_BITS];
        for (i, (&len, &c)) in sizes.iter().zip(&codes).enumerate() {
            let len = u32::from(len);
            if len > LOOKUP_BITS {
                break;
            }
            let first = (c << (LOOKUP_BITS - len)) as usize;
            let entry = ((len as u16) << 8) | u16::from(spec.symbols[i]);
            for slot in &mut lookup[first..first + (1 << (LOOKUP_BITS - len))] {
                *slot = entry;
            }
        }
        if is_dc && spec.symbols[..n].iter().any(|&s| s > 15) {
            return Err("a DC table symbol is larger than 15");
        }
        let mut fast_ac = Box::new([0u32; 1 << LOOKUP_BITS]);
        if !is_dc {
            for (prefix, slot) in fast_ac.iter_mut().enumerate() {
                let entry = lookup[prefix];
                let (len, rs) = (u32::from(entry >> 8), entry as u8);
                let (run, size) = (u32::from(rs >> 4), u32::from(rs & 15));
                if entry != 0 && size != 0 && len + size <= LOOKUP_BITS {
                    let bits = (prefix as u32 >> (LOOKUP_BITS - len - size)) & ((1 << size) - 1);
                    let value = extend(bits as i32, size);
                    *slot = (u32::from(value as i16 as u16) << 16) | (run << 8) | (len + size);
                }
            }
        }
        Ok(HuffTable {
            lookup,
            maxcode,
            valoffset,
            symbols: spec.symbols,
            fast_ac,
        })
    }
}

/// The bit stream of one scan.
#[derive(Clone, Copy)]
pub(crate) struct BitReader {
    /// Bits, most significant first; the low bits beyond `nbits` are zero.
    buf: u64,
    /// Valid bits in `buf`, real and padding.
    nbits: u32,
    /// How many of the last `nbits` are zero padding after a marker.
    padding: u32,
    /// libjpeg's `insufficient_data`: an earlier MCU read past the end of the data.
    pub insufficient: bool,
    /// A bad Huffman code was seen (reported once per scan).
    pub bad_code: bool,
}

impl BitReader {
    pub fn new() -> Self {
        BitReader {
            buf: 0,
            nbits: 0,
            padding: 0,
            insufficient: false,
            bad_code: false,
        }
    }

    /// Fills the buffer to at least 57 bits: bytes of entropy-coded data with stuffing
    /// removed, or, once a marker is reached, zeros.
    #[inline]
    fn refill(&mut self, src: &mut Source<'_>) {
        if src.unread_marker.is_none() {
            // Fast path: eight bytes with no 0xFF among them.
            if self.nbits <= 56
                && let Some(chunk) = src.rest().get(..8)
            {
                let mut b = [0u8; 8];
                b.copy_from_slice(chunk);
                let word = u64::from_be_bytes(b);
                // Any 0xFF byte? (the classic has-zero-byte test on the complement)
                let inv = !word;
                let has_ff = inv.wrapping_sub(0x0101_0101_0101_0101) & !inv & 0x8080_8080_8080_8080;
                if has_ff == 0 {
                    let take = (64 - self.nbits) / 8;
                    let bytes = word >> (64 - 8 * take);
                    self.buf |= bytes << (64 - self.nbits - 8 * take);
                    self.nbits += 8 * take;
                    src.advance(take as usize);
                    return;
                }
            }
            while self.nbits <= 56 {
                let mut c = src.byte();
                if c == 0xff {
                    loop {
                        c = src.byte();
                        if c != 0xff {
                            break;
                        }
                    }
                    if c == 0 {
                        c = 0xff;
                    } else {
                        src.unread_marker = Some(c);
                        break;
                    }
                }
                self.buf |= u64::from(c) << (56 - self.nbits);
                self.nbits += 8;
            }
            if self.nbits > 56 {
                return;
            }
        }
        // At a marker: zeros.
        self.padding += 64 - self.nbits;
        self.nbits = 64;
    }

    /// Takes `n` (1..=16) bits.
    #[inline]
    pub fn bits(&mut self, n: u32, src: &mut Source<'_>) -> u32 {
        if self.nbits < n {
            self.refill(src);
        }
        let v = (self.buf >> (64 - n)) as u32;
        self.buf <<= n;
        self.nbits -= n;
        v
    }

    /// Takes one bit.
    #[inline]
    pub fn bit(&mut self, src: &mut Source<'_>) -> bool {
        self.bits(1, src) != 0
    }

    /// Takes `s` bits and sign-extends them as a JPEG magnitude category value.
    #[inline]
    pub fn receive_extend(&mut self, s: u32, src: &mut Source<'_>) -> i32 {
        extend(self.bits(s, src) as i32, s)
    }

    /// A whole AC coefficient (code and value bits) when the next bits hold a short one:
    /// `(run, value)`.
    #[inline]
    pub fn fast_ac(&mut self, table: &HuffTable, src: &mut Source<'_>) -> Option<(usize, i16)> {
        if self.nbits < 16 {
            self.refill(src);
        }
        let f = table.fast_ac[(self.buf >> (64 - LOOKUP_BITS)) as usize];
        if f == 0 {
            return None;
        }
        let len = f & 0xff;
        self.buf <<= len;
        self.nbits -= len;
        Some((((f >> 8) & 0xff) as usize, (f >> 16) as u16 as i16))
    }

    /// Decodes one Huffman symbol.
    #[inline]
    pub fn decode(&mut self, table: &HuffTable, src: &mut Source<'_>) -> u8 {
        if self.nbits < 16 {
            self.refill(src);
        }
        let look = (self.buf >> (64 - LOOKUP_BITS)) as usize;
        let entry = table.lookup[look];
        if entry != 0 {
            let len = u32::from(entry >> 8);
            self.buf <<= len;
            self.nbits -= len;
            return entry as u8;
        }
        self.decode_slow(table, src)
    }

    #[cold]
    fn decode_slow(&mut self, table: &HuffTable, src: &mut Source<'_>) -> u8 {
        // Codes longer than the lookup (or no code at all): bit by bit, Figure F.16.
        let mut l = LOOKUP_BITS + 1;
        let mut code = self.bits(l, src) as i32;
        while code > table.maxcode[l as usize] {
            code = (code << 1) | self.bits(1, src) as i32;
            l += 1;
        }
        if l > 16 {
            // libjpeg: "fake a zero as the safest result".
            self.bad_code = true;
            return 0;
        }
        let idx = (code + table.valoffset[l as usize]) as usize;
        table.symbols[idx & 0xff]
    }

    /// After an MCU: did it read past the end of the data?
    #[inline]
    pub fn end_mcu(&mut self) {
        if self.nbits < self.padding {
            self.insufficient = true;
        }
    }

    /// At a restart marker: drops the buffered bits (whole bytes count as discarded).
    pub fn reset(&mut self, src: &mut Source<'_>) {
        let real = self.nbits.saturating_sub(self.padding);
        src.add_discarded((real / 8) as usize);
        self.buf = 0;
        self.nbits = 0;
        self.padding = 0;
    }

    /// Reports a bad code, once.
    pub fn take_warning(&mut self, offset: usize) -> Option<Warning> {
        std::mem::take(&mut self.bad_code).then_some(Warning::BadHuffmanCode { offset })
    }
}

/// Sign-extends the `s` bits `x` of a JPEG magnitude category (`HUFF_EXTEND`).
#[inline]
fn extend(x: i32, s: u32) -> i32 {
    if x < (1 << (s - 1)) {
        x + (-1 << s) + 1
    } else {
        x
    }
}

/// Zigzag position to natural (row-major) position, with 16 extra entries so that a
/// corrupt run length past the end lands on the last coefficient, as in libjpeg.
pub(crate) const NATURAL_ORDER: [usize; 80] = [
    0, 1, 8, 16, 9, 2, 3, 10, 17, 24, 32, 25, 18, 11, 4, 5, 12, 19, 26, 33, 40, 48, 41, 34, 27, 20,
    13, 6, 7, 14, 21, 28, 35, 42, 49, 56, 57, 50, 43, 36, 29, 22, 15, 23, 30, 37, 44, 51, 58, 59,
    52, 45, 38, 31, 39, 46, 53, 60, 61, 54, 47, 55, 62, 63, 63, 63, 63, 63, 63, 63, 63, 63, 63, 63,
    63, 63, 63, 63, 63, 63,
];

/// Turns a table-building failure into an error naming the table.
pub(crate) fn table_error(offset: usize, is_dc: bool, index: usize, why: &str) -> JpegError {
    JpegError::corrupt(
        offset,
        Some(super::source::marker::SOS),
        format!(
            "bogus Huffman table ({} table {index}): {why}",
            if is_dc { "DC" } else { "AC" }
        ),
    )
}
