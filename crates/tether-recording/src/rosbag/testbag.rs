//! A minimal bag writer for tests: builds well-formed bags in memory that the tests then
//! damage in chosen ways.

use std::io::Write;

use super::record::field;
use super::writer;

use tether_core::Stamp;
use tether_msgs::{
    Header, LaserScanMsg, Pose3, PoseArrayMsg, RawLaserScan, RosMessage, RosMessageOut,
};

pub(crate) struct TestConnection {
    pub id: u32,
    pub topic: String,
    pub msg_type: String,
    pub md5sum: String,
}

pub(crate) struct TestBag {
    pub connections: Vec<TestConnection>,
    /// (connection id, record time ns, payload)
    pub messages: Vec<(u32, i64, Vec<u8>)>,
    pub compression: &'static str,
    pub messages_per_chunk: usize,
    /// A `size` (uncompressed length) to write in every chunk header instead of the
    /// true one, as a damaged file or a decompression bomb would.
    pub claimed_size: Option<u32>,
}

fn time(ns: i64) -> [u8; 8] {
    writer::time_bytes(Stamp::from_ns(ns)).unwrap()
}

fn record(out: &mut Vec<u8>, header: &[u8], data: &[u8]) {
    writer::record(out, header, data).unwrap();
}

impl TestConnection {
    pub(crate) fn new<M: RosMessage>(id: u32, topic: &str) -> Self {
        TestConnection {
            id,
            topic: topic.into(),
            msg_type: M::TYPE.into(),
            md5sum: M::MD5SUM.into(),
        }
    }

    fn write(&self, out: &mut Vec<u8>) {
        let mut h = Vec::new();
        field(&mut h, "op", &[0x07]);
        field(&mut h, "conn", &self.id.to_le_bytes());
        field(&mut h, "topic", self.topic.as_bytes());
        let mut d = Vec::new();
        field(&mut d, "topic", self.topic.as_bytes());
        field(&mut d, "type", self.msg_type.as_bytes());
        field(&mut d, "md5sum", self.md5sum.as_bytes());
        field(&mut d, "message_definition", b"# test\n");
        record(out, &h, &d);
    }
}

impl TestBag {
    /// A bag with a LaserScan topic `/scan` (connection 0) and a PoseArray topic
    /// `/legs` (connection 1).
    pub(crate) fn scans_and_labels(
        messages: Vec<(u32, i64, Vec<u8>)>,
        compression: &'static str,
        messages_per_chunk: usize,
    ) -> Self {
        TestBag {
            connections: vec![
                TestConnection::new::<LaserScanMsg>(0, "/scan"),
                TestConnection::new::<PoseArrayMsg>(1, "/legs"),
            ],
            messages,
            compression,
            messages_per_chunk,
            claimed_size: None,
        }
    }

    pub(crate) fn build(&self) -> Vec<u8> {
        let mut out = b"#ROSBAG V2.0\n".to_vec();
        let header_at = out.len();
        out.extend(vec![0u8; 4096]); // patched below
        let mut chunk_infos = Vec::new();
        for group in self.messages.chunks(self.messages_per_chunk.max(1)) {
            let chunk_pos = out.len() as u64;
            let mut inner = Vec::new();
            let mut index: Vec<(u32, Vec<(i64, u32)>)> = Vec::new();
            for (conn, t, data) in group {
                let pos = match index.iter_mut().find(|(c, _)| c == conn) {
                    Some(entry) => entry,
                    None => {
                        if let Some(c) = self.connections.iter().find(|c| c.id == *conn) {
                            c.write(&mut inner);
                        }
                        index.push((*conn, Vec::new()));
                        index.last_mut().expect("just pushed")
                    }
                };
                pos.1.push((*t, inner.len() as u32));
                let mut h = Vec::new();
                field(&mut h, "op", &[0x02]);
                field(&mut h, "conn", &conn.to_le_bytes());
                field(&mut h, "time", &time(*t));
                record(&mut inner, &h, data);
            }
            let stored = match self.compression {
                "none" => inner.clone(),
                "bz2" => {
                    let mut e =
                        bzip2::write::BzEncoder::new(Vec::new(), bzip2::Compression::best());
                    e.write_all(&inner).expect("in memory");
                    e.finish().expect("in memory")
                }
                "lz4" => {
                    let mut e = lz4_flex::frame::FrameEncoder::new(Vec::new());
                    e.write_all(&inner).expect("in memory");
                    e.finish().expect("in memory")
                }
                other => other.as_bytes().to_vec(),
            };
            let mut h = Vec::new();
            field(&mut h, "op", &[0x05]);
            field(&mut h, "compression", self.compression.as_bytes());
            let size = self.claimed_size.unwrap_or(inner.len() as u32);
            field(&mut h, "size", &size.to_le_bytes());
            record(&mut out, &h, &stored);
            for (conn, entries) in &index {
                let mut h = Vec::new();
                field(&mut h, "op", &[0x04]);
                field(&mut h, "ver", &1u32.to_le_bytes());
                field(&mut h, "conn", &conn.to_le_bytes());
                field(&mut h, "count", &(entries.len() as u32).to_le_bytes());
                let mut d = Vec::new();
                for (t, off) in entries {
                    d.extend(time(*t));
                    d.extend(off.to_le_bytes());
                }
                record(&mut out, &h, &d);
            }
            let start = group.iter().map(|m| m.1).min().unwrap_or(0);
            let end = group.iter().map(|m| m.1).max().unwrap_or(0);
            let counts: Vec<(u32, u32)> = index.iter().map(|(c, e)| (*c, e.len() as u32)).collect();
            chunk_infos.push((chunk_pos, start, end, counts));
        }
        let index_pos = out.len() as u64;
        for c in &self.connections {
            c.write(&mut out);
        }
        for (chunk_pos, start, end, counts) in &chunk_infos {
            let mut h = Vec::new();
            field(&mut h, "op", &[0x06]);
            field(&mut h, "ver", &1u32.to_le_bytes());
            field(&mut h, "chunk_pos", &chunk_pos.to_le_bytes());
            field(&mut h, "start_time", &time(*start));
            field(&mut h, "end_time", &time(*end));
            field(&mut h, "count", &(counts.len() as u32).to_le_bytes());
            let mut d = Vec::new();
            for (c, n) in counts {
                d.extend(c.to_le_bytes());
                d.extend(n.to_le_bytes());
            }
            record(&mut out, &h, &d);
        }
        let header_record = writer::bag_header_record(
            index_pos,
            self.connections.len() as u32,
            chunk_infos.len() as u32,
        )
        .unwrap();
        out[header_at..header_at + 4096].copy_from_slice(&header_record);
        out
    }
}

/// A PoseArray payload of one point `(x, y)` on the plane of frame `laser`, identity
/// orientation, at stamp 0 (header sequence number 0).
pub(crate) fn pose_array(x: f64, y: f64) -> Vec<u8> {
    let msg = PoseArrayMsg {
        header: Header::new(Stamp::ZERO, "laser"),
        poses: vec![Pose3::planar(x, y, 0.0)],
    };
    let mut out = Vec::new();
    msg.encode(&mut out);
    out
}

/// A LaserScan payload in frame `laser` from -1 rad in steps of 0.25 rad (header
/// sequence number 7). Written with the codec, where tether-msgs' own tests write bytes
/// by hand to check it.
pub(crate) fn laser_scan(stamp_ns: i64, ranges: &[f32]) -> Vec<u8> {
    let raw = RawLaserScan {
        header: Header {
            seq: 7,
            stamp: Stamp::from_ns(stamp_ns),
            frame_id: "laser".into(),
        },
        angle_min: -1.0,
        angle_max: -1.0 + 0.25 * (ranges.len() as f32 - 1.0),
        angle_increment: 0.25,
        time_increment: 1e-4,
        scan_time: 0.1,
        range_min: 0.02,
        range_max: 5.6,
        ranges: ranges.to_vec(),
        intensities: Vec::new(),
    };
    let mut out = Vec::new();
    raw.encode(&mut out);
    out
}
