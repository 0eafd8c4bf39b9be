//! The record layer of the ROS bag format 2.0.
//!
//! A bag is the magic line `#ROSBAG V2.0\n` followed by records. Every record is
//!
//! ```text
//! header_len: u32 LE | header: header_len bytes | data_len: u32 LE | data: data_len bytes
//! ```
//!
//! and its header is a sequence of fields `field_len: u32 LE | name=value` (field_len
//! counts `name=value`). The field `op` (one byte) says what the record is; the other
//! fields depend on it. Integers are little-endian; a time is `sec: u32, nsec: u32`.

use tether_core::Stamp;
use tether_msgs::ros1::time_from_bytes;

/// The line every ROS 1 bag of format 2.0 starts with.
pub(crate) const MAGIC: &[u8; 13] = b"#ROSBAG V2.0\n";

/// Kinds of record (the `op` header field).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Op {
    /// A serialised message: fields `conn`, `time`; data: the message.
    MessageData,
    /// The bag header: `index_pos`, `conn_count`, `chunk_count`; data: padding.
    BagHeader,
    /// Index of one connection's messages in the preceding chunk: `ver`, `conn`,
    /// `count`; data: `count` x (time, offset into the chunk's data).
    IndexData,
    /// A chunk: `compression`, `size` (uncompressed); data: connection and message
    /// records, compressed.
    Chunk,
    /// Summary of one chunk: `ver`, `chunk_pos`, `start_time`, `end_time`, `count`;
    /// data: `count` x (conn, message count).
    ChunkInfo,
    /// A connection: `conn`, `topic`; data: a header with `topic`, `type`, `md5sum`,
    /// `message_definition` and optionally `callerid`, `latching`.
    Connection,
}

impl Op {
    /// The record kind for an `op` byte, if it is one of the six.
    pub(crate) fn from_byte(op: u8) -> Option<Op> {
        Some(match op {
            0x02 => Op::MessageData,
            0x03 => Op::BagHeader,
            0x04 => Op::IndexData,
            0x05 => Op::Chunk,
            0x06 => Op::ChunkInfo,
            0x07 => Op::Connection,
            _ => return None,
        })
    }

    /// Human name ("chunk record"), as error messages use it.
    pub(crate) fn name(self) -> &'static str {
        match self {
            Op::MessageData => "message data record",
            Op::BagHeader => "bag header record",
            Op::IndexData => "index data record",
            Op::Chunk => "chunk record",
            Op::ChunkInfo => "chunk info record",
            Op::Connection => "connection record",
        }
    }
}

/// The `name=value` fields of a record header (or of a connection record's data).
#[derive(Debug, Clone, Default)]
pub(crate) struct Fields {
    entries: Vec<(Vec<u8>, Vec<u8>)>,
}

impl Fields {
    /// Splits a header into its fields. Fails with a description if a length runs past
    /// the end or a field has no `=`.
    pub(crate) fn parse(bytes: &[u8]) -> Result<Fields, String> {
        let mut entries = Vec::new();
        let mut pos = 0usize;
        while pos < bytes.len() {
            let Some(len_bytes) = bytes.get(pos..pos + 4) else {
                return Err(format!(
                    "header ends inside a field length at header byte {pos} of {}",
                    bytes.len()
                ));
            };
            let len = u32::from_le_bytes([len_bytes[0], len_bytes[1], len_bytes[2], len_bytes[3]])
                as usize;
            pos += 4;
            let Some(field) = pos.checked_add(len).and_then(|end| bytes.get(pos..end)) else {
                return Err(format!(
                    "header field at header byte {} claims {len} bytes but only {} remain",
                    pos - 4,
                    bytes.len() - pos
                ));
            };
            let Some(eq) = field.iter().position(|&b| b == b'=') else {
                return Err(format!(
                    "header field at header byte {} has no '=' (starts {:?})",
                    pos - 4,
                    String::from_utf8_lossy(&field[..field.len().min(16)])
                ));
            };
            entries.push((field[..eq].to_vec(), field[eq + 1..].to_vec()));
            pos += len;
        }
        Ok(Fields { entries })
    }

    /// The raw value of field `name` (the first one if repeated).
    pub(crate) fn get(&self, name: &str) -> Option<&[u8]> {
        self.entries
            .iter()
            .find(|(n, _)| n.as_slice() == name.as_bytes())
            .map(|(_, v)| v.as_slice())
    }

    fn fixed<const N: usize>(&self, name: &str) -> Result<[u8; N], String> {
        let value = self
            .get(name)
            .ok_or_else(|| format!("header field `{name}` is missing"))?;
        value.try_into().map_err(|_| {
            format!(
                "header field `{name}` has {} bytes, expected {N}",
                value.len()
            )
        })
    }

    pub(crate) fn u8(&self, name: &str) -> Result<u8, String> {
        Ok(self.fixed::<1>(name)?[0])
    }

    pub(crate) fn u32(&self, name: &str) -> Result<u32, String> {
        Ok(u32::from_le_bytes(self.fixed::<4>(name)?))
    }

    pub(crate) fn u64(&self, name: &str) -> Result<u64, String> {
        Ok(u64::from_le_bytes(self.fixed::<8>(name)?))
    }

    /// A ROS time field: `sec: u32, nsec: u32`.
    pub(crate) fn time(&self, name: &str) -> Result<Stamp, String> {
        Ok(time_from_bytes(self.fixed::<8>(name)?))
    }

    /// A text field.
    pub(crate) fn string(&self, name: &str) -> Result<String, String> {
        let value = self
            .get(name)
            .ok_or_else(|| format!("header field `{name}` is missing"))?;
        String::from_utf8(value.to_vec()).map_err(|_| format!("header field `{name}` is not UTF-8"))
    }

    /// The record kind.
    pub(crate) fn op(&self) -> Result<Op, String> {
        let op = self.u8("op")?;
        Op::from_byte(op).ok_or_else(|| format!("unknown record op 0x{op:02x}"))
    }
}

/// Appends a header field `field_len: u32 LE | name=value`.
pub(crate) fn field(out: &mut Vec<u8>, name: &str, value: &[u8]) {
    out.extend(((name.len() + 1 + value.len()) as u32).to_le_bytes());
    out.extend(name.as_bytes());
    out.push(b'=');
    out.extend(value);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn field(name: &str, value: &[u8]) -> Vec<u8> {
        let mut out = ((name.len() + 1 + value.len()) as u32)
            .to_le_bytes()
            .to_vec();
        out.extend_from_slice(name.as_bytes());
        out.push(b'=');
        out.extend_from_slice(value);
        out
    }

    #[test]
    fn reads_typed_fields() {
        let mut h = field("op", &[0x05]);
        h.extend(field("size", &1234u32.to_le_bytes()));
        h.extend(field("compression", b"lz4"));
        h.extend(field("time", &[1, 0, 0, 0, 2, 0, 0, 0]));
        h.extend(field("eq", b"a=b"));
        let f = Fields::parse(&h).unwrap();
        assert_eq!(f.op().unwrap(), Op::Chunk);
        assert_eq!(f.u32("size").unwrap(), 1234);
        assert_eq!(f.string("compression").unwrap(), "lz4");
        assert_eq!(f.time("time").unwrap(), Stamp::from_ns(1_000_000_002));
        assert_eq!(f.get("eq"), Some(&b"a=b"[..]), "value may contain '='");
        assert!(f.u64("size").unwrap_err().contains("expected 8"));
        assert!(f.u32("conn").unwrap_err().contains("missing"));
    }

    #[test]
    fn refuses_broken_headers() {
        let mut h = field("op", &[0x05]);
        h.extend_from_slice(&[9, 0]);
        assert!(Fields::parse(&h).unwrap_err().contains("field length"));
        let mut h = field("op", &[0x05]);
        h.extend_from_slice(&100u32.to_le_bytes());
        h.extend_from_slice(b"a=b");
        assert!(Fields::parse(&h).unwrap_err().contains("claims 100 bytes"));
        let h = [3u8, 0, 0, 0, b'a', b'b', b'c'];
        assert!(Fields::parse(&h).unwrap_err().contains("no '='"));
        let f = Fields::parse(&field("op", &[0x42])).unwrap();
        assert!(f.op().unwrap_err().contains("0x42"));
    }

    #[test]
    fn largest_time_fits() {
        let s = time_from_bytes([0xff; 8]);
        assert_eq!(
            s.ns(),
            i64::from(u32::MAX) * 1_000_000_000 + i64::from(u32::MAX)
        );
    }
}
