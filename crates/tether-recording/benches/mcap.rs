//! Throughput of the recorded-data path (issue 7): writing and reading 1,000 URG-04LX
//! scans (682 beams, ROS 2 CDR) in memory as MCAP; target: at least 100,000 scans/s read
//! on one core.
//!
//! Run: `cargo bench -p tether-recording --bench mcap`.

#![allow(
    clippy::unwrap_used,
    reason = "benchmark set-up on data it makes itself"
)]

use std::io::Cursor;

use divan::counter::ItemsCount;
use tether_core::{LaserScan, Stamp};
use tether_msgs::LaserScanMsg;
use tether_recording::mcap::{McapFile, McapWriter};

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
