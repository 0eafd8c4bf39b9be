//! SCIP 2.0 character encodings and checksums (manual C-42-03320B, sections 6 and 7).
//!
//! A value is cut into 6-bit groups, most significant first, and `0x30` is added to
//! each, so every character lies in `0x30..=0x6F` (`'0'..='o'`): 2 characters carry 12
//! bits (`MS`/`GS`, up to 4095 mm), 3 characters 18 bits (`MD`/`GD`, up to 262,143
//! mm), 4 characters 24 bits (time stamps, ms). Example of section 6.2: 5,432 mm =
//! `000001 010100 111000` -> `1Dh`.
//!
//! Every reply line ends with a check character over the bytes before it (for
//! `VV`/`PP`/`II` lines: before the `;` that precedes it):
//! `sum = (sum of the bytes & 0x3F) + 0x30`. Example: status `00` has check `P`.
//!
//! Data blocks are cut into lines of at most 64 characters, each followed by its check
//! character and LF; a value may start on one line and end on the next.

/// Longest data line (without its check character and LF).
pub const DATA_LINE_CHARS: usize = 64;

/// How many characters encode one value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Encoding {
    /// 2 characters, 12 bits (`MS`, `GS`).
    Two,
    /// 3 characters, 18 bits (`MD`, `GD`).
    Three,
    /// 4 characters, 24 bits (time stamps).
    Four,
}

impl Encoding {
    /// Characters per value.
    pub const fn chars(self) -> usize {
        match self {
            Encoding::Two => 2,
            Encoding::Three => 3,
            Encoding::Four => 4,
        }
    }

    /// Largest value the encoding holds: `2^(6 * chars) - 1`.
    pub const fn max_value(self) -> u32 {
        (1 << (6 * self.chars())) - 1
    }
}

/// The check character of a line: `(sum & 0x3F) + 0x30`.
pub fn checksum(bytes: &[u8]) -> u8 {
    let sum = bytes
        .iter()
        .fold(0u32, |s, &b| s.wrapping_add(u32::from(b)));
    (sum & 0x3F) as u8 + 0x30
}

/// Appends `value` encoded with `encoding`; values above the encoding's maximum are
/// clamped to it (the emulator's behaviour for ranges beyond 4095 mm in `MS`/`GS`).
pub fn encode(value: u32, encoding: Encoding, out: &mut Vec<u8>) {
    let v = value.min(encoding.max_value());
    for i in (0..encoding.chars()).rev() {
        out.push(((v >> (6 * i)) & 0x3F) as u8 + 0x30);
    }
}

/// Decodes one value from its characters; `None` when a character is outside
/// `0x30..=0x6F` or there are more than 4.
pub fn decode(chars: &[u8]) -> Option<u32> {
    if chars.len() > 4 {
        return None;
    }
    chars.iter().try_fold(0u32, |acc, &c| {
        let d = c.wrapping_sub(0x30);
        (d < 64).then_some((acc << 6) | u32::from(d))
    })
}

/// Decodes a data block (the lines joined, check characters removed) into values.
/// Fails with the index of the first character outside the alphabet, or when the
/// block is not a whole number of values.
pub fn decode_values(block: &[u8], encoding: Encoding, out: &mut Vec<u32>) -> Result<(), usize> {
    let n = encoding.chars();
    if !block.len().is_multiple_of(n) {
        return Err(block.len() - block.len() % n);
    }
    out.reserve(block.len() / n);
    for (i, group) in block.chunks_exact(n).enumerate() {
        match decode(group) {
            Some(v) => out.push(v),
            None => {
                let bad = group
                    .iter()
                    .position(|c| c.wrapping_sub(0x30) >= 64)
                    .unwrap_or(0);
                return Err(i * n + bad);
            }
        }
    }
    Ok(())
}

/// Appends a data block as lines of at most 64 characters, each with its check
/// character and LF (not the blank line that ends the reply).
pub fn write_block(block: &[u8], out: &mut Vec<u8>) {
    for line in block.chunks(DATA_LINE_CHARS) {
        out.extend_from_slice(line);
        out.push(checksum(line));
        out.push(b'\n');
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn manual_examples() {
        // Section 6.1: 1,234 mm -> "CB"; 6.2: 5,432 mm -> "1Dh"; 6.3: 16,000,000 -> "m2@0".
        let mut out = Vec::new();
        encode(1234, Encoding::Two, &mut out);
        encode(5432, Encoding::Three, &mut out);
        encode(16_000_000, Encoding::Four, &mut out);
        assert_eq!(out, b"CB1Dhm2@0");
        assert_eq!(decode(b"CB"), Some(1234));
        assert_eq!(decode(b"1Dh"), Some(5432));
        assert_eq!(decode(b"m2@0"), Some(16_000_000));
        // Status lines "00P", "99b"; a parameter line of a URG-04LX, "DMIN:20;4".
        assert_eq!(checksum(b"00"), b'P');
        assert_eq!(checksum(b"99"), b'b');
        assert_eq!(checksum(b"DMIN:20"), b'4');
        assert_eq!(checksum(b"AMIN:44"), b'7');
    }

    #[test]
    fn refuses_bad_characters() {
        assert_eq!(decode(b"0p"), None);
        assert_eq!(decode(b"/0"), None);
        assert_eq!(decode(b"00000"), None);
        let mut v = Vec::new();
        assert_eq!(decode_values(b"0000p0", Encoding::Three, &mut v), Err(4));
        assert_eq!(decode_values(b"00000", Encoding::Three, &mut v), Err(3));
    }

    #[test]
    fn clamps_to_the_encoding() {
        let mut out = Vec::new();
        encode(5000, Encoding::Two, &mut out);
        assert_eq!(decode(&out), Some(4095));
    }

    proptest! {
        #[test]
        fn values_round_trip(values in proptest::collection::vec(0u32..(1 << 18), 0..1100),
                             two in any::<bool>()) {
            let enc = if two { Encoding::Two } else { Encoding::Three };
            let mut block = Vec::new();
            for &v in &values {
                encode(v, enc, &mut block);
            }
            let mut lines = Vec::new();
            write_block(&block, &mut lines);
            // Undo the line structure the way a reader does.
            let mut joined = Vec::new();
            for line in lines.split(|&b| b == b'\n').filter(|l| !l.is_empty()) {
                let (sum, body) = line.split_last().unwrap();
                prop_assert!(body.len() <= DATA_LINE_CHARS);
                prop_assert_eq!(checksum(body), *sum);
                joined.extend_from_slice(body);
            }
            let mut back = Vec::new();
            decode_values(&joined, enc, &mut back).unwrap();
            let expected: Vec<u32> = values.iter().map(|&v| v.min(enc.max_value())).collect();
            prop_assert_eq!(back, expected);
        }

        #[test]
        fn checksum_matches_its_definition(line in proptest::collection::vec(any::<u8>(), 0..200)) {
            let reference = (line.iter().map(|&b| u64::from(b)).sum::<u64>() % 64) as u8 + 0x30;
            let c = checksum(&line);
            prop_assert_eq!(c, reference);
            prop_assert!((0x30..0x70).contains(&c));
        }
    }
}
