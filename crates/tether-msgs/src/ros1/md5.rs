//! MD5 (RFC 1321) and the MD5 sum ROS 1 gives a message definition.
//!
//! ROS 1 names a message type's layout by the MD5 of its *normalised* definition
//! (genmsg's `compute_md5_text`): comments and blank lines dropped, constants first as
//! `type NAME=value`, then one line per field, `type name` for a built-in type (arrays
//! keep their brackets, `float32[] ranges`) and `md5 name` for a nested message (the
//! nested type's own MD5, array brackets dropped), lines joined by `\n` without a final
//! newline. Nested definitions come from the `MSG: pkg/Type` sections that follow the
//! main one in a bag's `message_definition`, after a line of 80 `=`.

use std::fmt::Write as _;

/// Per-round shift amounts (RFC 1321, section 3.4).
const SHIFTS: [u32; 64] = [
    7, 12, 17, 22, 7, 12, 17, 22, 7, 12, 17, 22, 7, 12, 17, 22, 5, 9, 14, 20, 5, 9, 14, 20, 5, 9,
    14, 20, 5, 9, 14, 20, 4, 11, 16, 23, 4, 11, 16, 23, 4, 11, 16, 23, 4, 11, 16, 23, 6, 10, 15,
    21, 6, 10, 15, 21, 6, 10, 15, 21, 6, 10, 15, 21,
];

/// `K[i] = floor(2^32 |sin(i + 1)|)`.
fn constants() -> [u32; 64] {
    let mut k = [0u32; 64];
    for (i, v) in k.iter_mut().enumerate() {
        *v = ((i as f64 + 1.0).sin().abs() * 4_294_967_296.0) as u32;
    }
    k
}

/// The MD5 digest of `data`.
pub fn md5(data: &[u8]) -> [u8; 16] {
    let k = constants();
    let mut state: [u32; 4] = [0x6745_2301, 0xefcd_ab89, 0x98ba_dcfe, 0x1032_5476];
    // Padding: a 1 bit, zeros to 56 mod 64 bytes, then the bit length (little-endian).
    let mut msg = data.to_vec();
    let bit_len = (data.len() as u64).wrapping_mul(8);
    msg.push(0x80);
    while msg.len() % 64 != 56 {
        msg.push(0);
    }
    msg.extend_from_slice(&bit_len.to_le_bytes());
    for block in msg.chunks_exact(64) {
        let mut m = [0u32; 16];
        for (w, b) in m.iter_mut().zip(block.chunks_exact(4)) {
            *w = u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
        }
        let [mut a, mut b, mut c, mut d] = state;
        for i in 0..64 {
            let (f, g) = match i / 16 {
                0 => ((b & c) | (!b & d), i),
                1 => ((d & b) | (!d & c), (5 * i + 1) % 16),
                2 => (b ^ c ^ d, (3 * i + 5) % 16),
                _ => (c ^ (b | !d), (7 * i) % 16),
            };
            let rotated = a
                .wrapping_add(f)
                .wrapping_add(k[i])
                .wrapping_add(m[g])
                .rotate_left(SHIFTS[i]);
            a = d;
            d = c;
            c = b;
            b = b.wrapping_add(rotated);
        }
        state[0] = state[0].wrapping_add(a);
        state[1] = state[1].wrapping_add(b);
        state[2] = state[2].wrapping_add(c);
        state[3] = state[3].wrapping_add(d);
    }
    let mut out = [0u8; 16];
    for (o, s) in out.chunks_exact_mut(4).zip(state) {
        o.copy_from_slice(&s.to_le_bytes());
    }
    out
}

/// The MD5 digest of `data` in lowercase hex, as ROS prints it.
pub fn md5_hex(data: &[u8]) -> String {
    let mut s = String::with_capacity(32);
    for b in md5(data) {
        let _ = write!(s, "{b:02x}");
    }
    s
}

/// ROS 1 built-in field types (genmsg's `BUILTIN_TYPES`).
const BUILTIN: &[&str] = &[
    "bool", "byte", "char", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64",
    "uint64", "float32", "float64", "string", "time", "duration",
];

/// Why a definition's MD5 sum cannot be computed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DefinitionError {
    /// A field line is not `type name`.
    #[error("line {line:?} of {msg_type} is not `type name`")]
    BadLine {
        /// The message type whose section holds the line.
        msg_type: String,
        /// The line.
        line: String,
    },
    /// A field's type is neither built in nor defined in a `MSG:` section.
    #[error("{msg_type} uses {missing}, which the definition does not include")]
    Missing {
        /// The message type whose field it is.
        msg_type: String,
        /// The type not found.
        missing: String,
    },
    /// The definition refers to itself (directly or through others).
    #[error("the definition of {0} is recursive")]
    Recursive(String),
}

/// The MD5 sum ROS 1 gives `msg_type` (`pkg/Name`) whose full definition, as a bag's
/// connection record stores it, is `definition`.
pub fn definition_md5(msg_type: &str, definition: &str) -> Result<String, DefinitionError> {
    let mut sections: Vec<(String, String)> = vec![(msg_type.to_string(), String::new())];
    for line in definition.lines() {
        if line.starts_with("====") && line.trim_end().chars().all(|c| c == '=') {
            sections.push((String::new(), String::new()));
            continue;
        }
        let last = sections.len() - 1;
        if sections[last].0.is_empty()
            && let Some(name) = line.trim().strip_prefix("MSG:")
        {
            sections[last].0 = name.trim().to_string();
            continue;
        }
        sections[last].1.push_str(line);
        sections[last].1.push('\n');
    }
    md5_of(msg_type, &sections, &mut Vec::new())
}

/// The full `pkg/Name` of a field type written inside package `package`.
fn resolve(field_type: &str, package: &str) -> String {
    if field_type == "Header" {
        "std_msgs/Header".to_string()
    } else if field_type.contains('/') {
        field_type.to_string()
    } else {
        format!("{package}/{field_type}")
    }
}

fn md5_of(
    msg_type: &str,
    sections: &[(String, String)],
    visiting: &mut Vec<String>,
) -> Result<String, DefinitionError> {
    if visiting.iter().any(|v| v == msg_type) {
        return Err(DefinitionError::Recursive(msg_type.to_string()));
    }
    let short = |t: &str| t.rsplit('/').next().unwrap_or(t).to_string();
    let text = sections
        .iter()
        .find(|(name, _)| name == msg_type)
        .or_else(|| {
            sections
                .iter()
                .find(|(name, _)| short(name) == short(msg_type))
        })
        .map(|(_, text)| text.as_str())
        .ok_or_else(|| DefinitionError::Missing {
            msg_type: visiting.last().cloned().unwrap_or_default(),
            missing: msg_type.to_string(),
        })?;
    let package = msg_type.split('/').next().unwrap_or("");
    visiting.push(msg_type.to_string());
    let mut constants = Vec::new();
    let mut fields = Vec::new();
    for raw in text.lines() {
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let bad = || DefinitionError::BadLine {
            msg_type: msg_type.to_string(),
            line: raw.to_string(),
        };
        let (field_type, rest) = line.split_once(char::is_whitespace).ok_or_else(bad)?;
        let rest = rest.trim();
        if let Some((name, value)) = rest.split_once('=') {
            // A string constant keeps everything after `=` (comments included); the
            // others lose the comment, as genmsg parses them.
            let value = if field_type == "string" {
                raw.split_once('=').map_or("", |(_, v)| v).trim()
            } else {
                value.trim()
            };
            constants.push(format!("{field_type} {}={value}", name.trim()));
            continue;
        }
        if rest.is_empty() || rest.contains(char::is_whitespace) {
            return Err(bad());
        }
        let base = field_type.split('[').next().unwrap_or(field_type);
        if BUILTIN.contains(&base) {
            fields.push(format!("{field_type} {rest}"));
        } else {
            let sub = md5_of(&resolve(base, package), sections, visiting)?;
            fields.push(format!("{sub} {rest}"));
        }
    }
    visiting.pop();
    constants.extend(fields);
    Ok(md5_hex(constants.join("\n").as_bytes()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rfc_1321_test_suite() {
        let cases = [
            ("", "d41d8cd98f00b204e9800998ecf8427e"),
            ("a", "0cc175b9c0f1b6a831c399e269772661"),
            ("abc", "900150983cd24fb0d6963f7d28e17f72"),
            ("message digest", "f96b697d7cb7938d525a2f31aaf161d0"),
            (
                "abcdefghijklmnopqrstuvwxyz",
                "c3fcd3d76192e4007dfb496cca67e13b",
            ),
            (
                "12345678901234567890123456789012345678901234567890123456789012345678901234567890",
                "57edf4a22be3c955ac49da2e2107b67a",
            ),
        ];
        for (input, want) in cases {
            assert_eq!(md5_hex(input.as_bytes()), want, "{input:?}");
        }
    }

    #[test]
    fn header_and_constants() {
        // std_msgs/Header, as rosmsg md5 gives it.
        let header = "uint32 seq\ntime stamp\nstring frame_id\n";
        assert_eq!(
            definition_md5("std_msgs/Header", header).unwrap(),
            "2176decaecbce78abc3b96ef049fabed"
        );
        // Comments and blank lines do not count.
        let noisy = "# meta\n\nuint32 seq  # id\ntime stamp\n  string frame_id\n";
        assert_eq!(
            definition_md5("std_msgs/Header", noisy).unwrap(),
            "2176decaecbce78abc3b96ef049fabed"
        );
        assert!(matches!(
            definition_md5("a/B", "Header header\n"),
            Err(DefinitionError::Missing { .. })
        ));
        assert!(matches!(
            definition_md5("a/B", "uint32\n"),
            Err(DefinitionError::BadLine { .. })
        ));
    }
}
