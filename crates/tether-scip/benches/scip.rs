//! Throughput of the sensor path (issue 7): decoding one 682-beam SCIP 2.0 `MD` reply
//! from bytes to a `tether_core::LaserScan` (line splitting, check characters,
//! 3-character decoding, conversion); target: under 10 us.
//!
//! Run: `cargo bench -p tether-scip --bench scip`.

#![allow(
    clippy::unwrap_used,
    reason = "benchmark set-up on data it makes itself"
)]

use divan::counter::BytesCount;
use tether_core::{Stamp, UrgGeometry};
use tether_scip::encoding::{Encoding, encode, write_block};
use tether_scip::response::{write_head, write_timestamp};
use tether_scip::{ParseEvent, Reply, ReplyParser, SensorInfo, laser_scan};

fn main() {
    divan::main();
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
