//! The records of an MCAP file: finding one in a buffer, and reading the fields of its
//! body with errors that name the record and the place (split from `reader.rs`).

use std::collections::BTreeMap;
use std::sync::Arc;

use super::{Channel, Schema, op};
use crate::mcap::{Location, McapError};
/// A bounded reader over one record's body, naming the record in its errors.
pub(super) struct Body<'a> {
    pub(super) data: &'a [u8],
    pub(super) pos: usize,
    pub(super) record: &'static str,
    pub(super) at: Location,
}

impl<'a> Body<'a> {
    pub(super) fn corrupt(&self, problem: impl Into<String>) -> McapError {
        McapError::Corrupt {
            record: self.record,
            at: self.at,
            problem: problem.into(),
        }
    }

    pub(super) fn take(&mut self, field: &str, n: u64) -> Result<&'a [u8], McapError> {
        let left = self.data.len() - self.pos;
        if n > left as u64 {
            return Err(self.corrupt(format!(
                "field `{field}` needs {n} bytes at byte {} of the body, {left} remain",
                self.pos
            )));
        }
        let out = &self.data[self.pos..self.pos + n as usize];
        self.pos += n as usize;
        Ok(out)
    }

    pub(super) fn array<const N: usize>(&mut self, field: &str) -> Result<[u8; N], McapError> {
        let mut out = [0u8; N];
        out.copy_from_slice(self.take(field, N as u64)?);
        Ok(out)
    }

    pub(super) fn u16(&mut self, field: &str) -> Result<u16, McapError> {
        self.array(field).map(u16::from_le_bytes)
    }

    pub(super) fn u32(&mut self, field: &str) -> Result<u32, McapError> {
        self.array(field).map(u32::from_le_bytes)
    }

    pub(super) fn u64(&mut self, field: &str) -> Result<u64, McapError> {
        self.array(field).map(u64::from_le_bytes)
    }

    pub(super) fn bytes(&mut self, field: &str) -> Result<&'a [u8], McapError> {
        let n = self.u32(field)?;
        self.take(field, u64::from(n))
    }

    pub(super) fn string(&mut self, field: &str) -> Result<String, McapError> {
        let b = self.bytes(field)?;
        String::from_utf8(b.to_vec()).map_err(|_| self.corrupt(format!("`{field}` is not UTF-8")))
    }

    pub(super) fn map(&mut self, field: &str) -> Result<BTreeMap<String, String>, McapError> {
        let n = self.u32(field)?;
        let inner = self.take(field, u64::from(n))?;
        let mut sub = Body {
            data: inner,
            pos: 0,
            record: self.record,
            at: self.at,
        };
        let mut out = BTreeMap::new();
        while sub.pos < inner.len() {
            let k = sub.string(field)?;
            let v = sub.string(field)?;
            out.insert(k, v);
        }
        Ok(out)
    }

    pub(super) fn rest(&mut self) -> &'a [u8] {
        let out = &self.data[self.pos..];
        self.pos = self.data.len();
        out
    }
}

/// One record found in a buffer: opcode and body range.
pub(super) struct Record {
    pub(super) op: u8,
    pub(super) body: std::ops::Range<usize>,
}

/// Reads the record starting at `pos` of `buf`; `at` maps a position to a location.
pub(super) fn record_at(
    buf: &[u8],
    pos: usize,
    at: impl Fn(usize) -> Location,
) -> Result<Record, McapError> {
    let available = (buf.len() - pos) as u64;
    if available < 9 {
        return Err(McapError::Truncated {
            record: "record",
            at: at(pos),
            needed: 9,
            available,
        });
    }
    let op = buf[pos];
    let mut len = [0u8; 8];
    len.copy_from_slice(&buf[pos + 1..pos + 9]);
    let len = u64::from_le_bytes(len);
    if len > available - 9 {
        return Err(McapError::Truncated {
            record: op::name(op),
            at: at(pos),
            needed: len.saturating_add(9),
            available,
        });
    }
    let start = pos + 9;
    Ok(Record {
        op,
        body: start..start + len as usize,
    })
}

pub(super) fn parse_schema(body: &mut Body<'_>) -> Result<Option<Schema>, McapError> {
    let id = body.u16("id")?;
    let name = body.string("name")?;
    let encoding = body.string("encoding")?;
    let data = body.bytes("data")?.to_vec();
    // Schema id 0 is reserved ("no schema"); such a record is ignored.
    Ok((id != 0).then_some(Schema {
        id,
        name,
        encoding,
        data,
    }))
}

pub(super) fn parse_channel(
    body: &mut Body<'_>,
    schemas: &BTreeMap<u16, Arc<Schema>>,
) -> Result<Channel, McapError> {
    let id = body.u16("id")?;
    let schema_id = body.u16("schema_id")?;
    let topic = body.string("topic")?;
    let message_encoding = body.string("message_encoding")?;
    let metadata = body.map("metadata")?;
    let schema = match schema_id {
        0 => None,
        id => Some(schemas.get(&id).cloned().ok_or_else(|| {
            body.corrupt(format!(
                "channel {topic:?} refers to schema {id}, which no earlier record defines"
            ))
        })?),
    };
    Ok(Channel {
        id,
        topic,
        message_encoding,
        schema,
        metadata,
    })
}

pub(super) fn parse_statistics(body: &mut Body<'_>) -> Result<BTreeMap<u16, u64>, McapError> {
    body.u64("message_count")?;
    body.u16("schema_count")?;
    body.u32("channel_count")?;
    body.u32("attachment_count")?;
    body.u32("metadata_count")?;
    body.u32("chunk_count")?;
    body.u64("message_start_time")?;
    body.u64("message_end_time")?;
    let n = body.u32("channel_message_counts")?;
    let raw = body.take("channel_message_counts", u64::from(n))?;
    let mut out = BTreeMap::new();
    for entry in raw.chunks_exact(10) {
        let id = u16::from_le_bytes([entry[0], entry[1]]);
        let mut c = [0u8; 8];
        c.copy_from_slice(&entry[2..]);
        out.insert(id, u64::from_le_bytes(c));
    }
    Ok(out)
}
