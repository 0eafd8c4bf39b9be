//! Throughput of the recorded-data and sensor paths (issue 7):
//!
//! - MCAP: writing and reading 1,000 URG-04LX scans (682 beams, ROS 2 CDR) in memory;
//!   target: at least 100,000 scans/s read on one core;
//! - SCIP 2.0: decoding one 682-beam `MD` reply from bytes to a `tether_core::LaserScan`
//!   (line splitting, check characters, 3-character decoding, conversion); target: under
//!   10 us.
//!
//! Run: `cargo bench -p tether-io --bench io`.

#![allow(
    clippy::unwrap_used,
    reason = "benchmark set-up on data it makes itself"
)]

use std::io::Cursor;

use divan::counter::{BytesCount, ItemsCount};
use tether_core::{LaserScan, Stamp, UrgGeometry};
use tether_io::mcap::{LaserScanMsg, McapFile, McapWriter};
use tether_io::scip::encoding::{Encoding, encode, write_block};
use tether_io::scip::response::{write_head, write_timestamp};
use tether_io::scip::{ParseEvent, Reply, ReplyParser, SensorInfo, laser_scan};

fn main() {
    divan::main();
}

const SCANS: usize = 1000;

fn scans() -> Vec<LaserScanMsg> {
    (0..SCANS)
        .map(|k| {
            let t = Stamp::from_ns(1_700_000_000_000_000_000 + k as i64 * 100_000_000);
            let ranges = (0..682)
                .map(|i| {
                    if (i + k) % 23 == 0 {
                        f32::INFINITY
                    } else {
                        0.02 + ((i * 37 + k * 11) % 5500) as f32 / 1000.0
                    }
                })
                .collect();
            let scan =
                LaserScan::new(t, "laser", -2.0862, 0.006_135_923, 0.02, 5.6, ranges).unwrap();
            LaserScanMsg::new(scan, 9.8e-5, 0.1)
        })
        .collect()
}

fn write(scans: &[LaserScanMsg]) -> Vec<u8> {
    let mut w = McapWriter::new(Cursor::new(Vec::with_capacity(3 << 20))).unwrap();
    for s in scans {
        w.write_stamped("/scan", s).unwrap();
    }
    w.finish().unwrap().into_inner()
}

/// Writes 1,000 scans into an in-memory MCAP file.
#[divan::bench]
fn mcap_write_1000_scans(bencher: divan::Bencher) {
    let scans = scans();
    bencher
        .counter(ItemsCount::new(SCANS))
        .bench(|| divan::black_box(write(&scans)).len());
}

/// Reads and decodes 1,000 scans from an in-memory MCAP file into `LaserScan`s.
#[divan::bench]
fn mcap_read_1000_scans(bencher: divan::Bencher) {
    let bytes = write(&scans());
    bencher
        .counter(ItemsCount::new(SCANS))
        .with_inputs(|| bytes.clone())
        .bench_values(|bytes| {
            let file = McapFile::from_bytes(bytes).unwrap();
            let mut beams = 0;
            for m in file.decoded::<LaserScanMsg>(&["/scan"]) {
                beams += m.unwrap().message.scan.len();
            }
            assert_eq!(beams, SCANS * 682);
            beams
        });
}

/// The `MD` reply of one URG-04LX scan, as the sensor sends it.
fn md_reply() -> Vec<u8> {
    let mut out = Vec::new();
    write_head(b"MD0044072501000", *b"99", &mut out);
    write_timestamp(0x12_3456, &mut out);
    let mut block = Vec::new();
    for i in 0..682u32 {
        let mm = if i % 29 == 3 { 7 } else { 20 + (i * 37) % 5580 };
        encode(mm, Encoding::Three, &mut block);
    }
    write_block(&block, &mut out);
    out.push(b'\n');
    out
}

/// Decodes one 682-beam `MD` reply from bytes to a `LaserScan`.
#[divan::bench]
fn scip_decode_one_682_beam_scan(bencher: divan::Bencher) {
    let reply = md_reply();
    let info = SensorInfo {
        geometry: UrgGeometry::default(),
        range_min_mm: 20,
        range_max_mm: 5600,
        scan_rpm: 600,
        ..SensorInfo::default()
    };
    let mut parser = ReplyParser::new();
    bencher
        .counter(BytesCount::new(reply.len()))
        .bench_local(|| {
            parser.push(divan::black_box(&reply));
            let Some(ParseEvent::Reply(Reply::Scan(s))) = parser.next_event() else {
                unreachable!("the reply is well formed");
            };
            let (scan, errors) = laser_scan(&s, &info, Stamp::ZERO, "laser").unwrap();
            (scan.len(), errors)
        });
}
