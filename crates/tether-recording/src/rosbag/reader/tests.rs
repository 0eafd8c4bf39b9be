use std::io::Cursor;

use proptest::prelude::*;
use tether_core::Laser;

use tether_msgs::{LaserScanMsg, PoseArrayMsg};

use super::super::testbag::{self, TestBag};
use super::*;

/// Six scans on `/scan` interleaved with label arrays on `/legs`.
fn messages() -> Vec<(u32, i64, Vec<u8>)> {
    let mut out = Vec::new();
    for i in 0..6i64 {
        let t = 1_000_000_000 + i * 100_000_000;
        out.push((1, t, testbag::pose_array(i as f64, 0.5)));
        let ranges: Vec<f32> = (0..9).map(|b| 1.0 + 0.1 * b as f32 + i as f32).collect();
        out.push((0, t + 1, testbag::laser_scan(t - 5, &ranges)));
    }
    out
}

/// The error the first message of a bag that opens gives.
fn first_error(bytes: &[u8]) -> BagError {
    open(bytes).unwrap().messages().next().unwrap().unwrap_err()
}

fn open(bytes: &[u8]) -> Result<Bag<Cursor<&[u8]>>, BagError> {
    Bag::from_reader(Cursor::new(bytes))
}

#[test]
fn reads_every_compression_in_bag_order() {
    for compression in ["none", "bz2", "lz4"] {
        let bytes = TestBag::scans_and_labels(messages(), compression, 5).build();
        let mut bag = open(&bytes).unwrap();
        assert_eq!(bag.topics(), vec!["/legs", "/scan"]);
        assert_eq!(bag.chunk_infos().len(), 3, "{compression}");
        assert_eq!(bag.message_count("/scan"), 6);
        let all: Vec<RawMessage> = bag.messages().map(|m| m.unwrap()).collect();
        assert_eq!(all.len(), 12, "{compression}");
        let times: Vec<i64> = all.iter().map(|m| m.time.ns()).collect();
        let expected: Vec<i64> = messages().iter().map(|m| m.1).collect();
        assert_eq!(times, expected, "{compression}: bag order");
        let mut scans = bag.decoded::<LaserScanMsg>(&["/scan"]);
        let got: Vec<_> = (&mut scans).map(|m| m.unwrap()).collect();
        assert_eq!(scans.bad_count(), 0);
        assert_eq!(got.len(), 6);
        assert_eq!(got[2].message.scan.range_m(0), Some(3.0));
        assert_eq!(
            got[2].message.scan.stamp.ns(),
            1_000_000_000 + 200_000_000 - 5
        );
        let labels: Vec<_> = bag
            .decoded::<PoseArrayMsg>(&["/legs"])
            .map(|m| m.unwrap().message.positions_2d::<Laser>())
            .collect();
        assert_eq!(labels[4][0].x, 4.0);
    }
}

#[test]
fn truncated_bag_names_offset_and_record() {
    let bytes = TestBag::scans_and_labels(messages(), "none", 4).build();
    for cut in 0..bytes.len() {
        let err = open(&bytes[..cut]).expect_err("a cut bag must not open");
        let text = err.to_string();
        assert!(
            text.contains("byte") || matches!(err, BagError::NotABag { .. }),
            "cut at {cut}: {text}"
        );
    }
    let err = open(&bytes[..bytes.len() - 3]).unwrap_err();
    assert!(matches!(err, BagError::Truncated { .. }), "{err}");
    let err = open(&bytes[..5000]).unwrap_err();
    assert!(
        matches!(err, BagError::IndexPastEnd { file_len: 5000, .. }),
        "{err}"
    );
    assert!(
        err.to_string()
            .starts_with("bag is cut short: its header puts the index at byte"),
        "{err}"
    );
}

#[test]
fn a_salvaged_walk_reports_the_cut_and_reads_the_chunks_before_it() {
    for compression in ["none", "bz2", "lz4"] {
        let bytes = TestBag::scans_and_labels(messages(), compression, 4).build();
        let whole = open(&bytes).unwrap();
        let chunks: Vec<u64> = whole.chunk_infos().iter().map(|c| c.chunk_pos).collect();
        assert_eq!(chunks.len(), 3);
        // Cut in the middle of the third chunk: the first two are read whole.
        let cut = (chunks[2] + 80) as usize;
        let mut bag = Bag::from_reader_salvaging(Cursor::new(&bytes[..cut])).unwrap();
        assert!(bag.salvaged().is_some());
        let mut all = bag.messages();
        let read: Vec<RawMessage> = (&mut all).map(|m| m.unwrap()).collect();
        assert_eq!(read.len(), 8, "{compression}: two chunks of four");
        let cut_at = *all.cut().expect("the cut is reported");
        assert_eq!(cut_at.at, Location::File(chunks[2]), "{compression}");
        assert_eq!(cut_at.record, "chunk record");
        assert_eq!(cut_at.available, cut as u64 - chunks[2]);
        assert_eq!(all.skipped_count(), 0, "a cut is not a skipped message");
    }
}

#[test]
fn a_decompression_bomb_is_refused_before_it_is_inflated() {
    // A chunk of 16 MiB of zeros (one message) compresses to a few hundred bytes with
    // bz2: honest about its size, but a 1000:1 ratio is no recording.
    let zeros = vec![(0u32, 1_000_000_000i64, vec![0u8; 16 << 20])];
    let bytes = TestBag::scans_and_labels(zeros, "bz2", 1).build();
    assert!(bytes.len() < 12_000, "{} bytes", bytes.len());
    let mut bag = open(&bytes).unwrap();
    let err = bag.messages().next().unwrap().unwrap_err();
    assert!(
        matches!(&err, BagError::Decompress { at: 4109, .. }),
        "{err}"
    );
    assert!(err.to_string().contains("decompression bomb"), "{err}");
    // A chunk that claims 4 GiB is refused by the size cap, whatever it holds.
    for compression in ["bz2", "lz4"] {
        let mut bomb = TestBag::scans_and_labels(messages(), compression, 100);
        bomb.claimed_size = Some(u32::MAX);
        let bytes = bomb.build();
        let started = std::time::Instant::now();
        let err = first_error(&bytes);
        assert!(err.to_string().contains("256 MiB"), "{compression}: {err}");
        assert!(started.elapsed().as_secs() < 2);
    }
    // Real chunks pass: a few KB of scans in bz2 and lz4.
    for compression in ["bz2", "lz4"] {
        let bytes = TestBag::scans_and_labels(messages(), compression, 100).build();
        assert_eq!(open(&bytes).unwrap().messages().count(), 12);
    }
}

#[test]
fn bad_messages_are_skipped_and_counted() {
    let mut msgs = messages();
    // Scan 1 gets a zero angle increment, scan 3 loses its last byte, and label 2
    // goes to a connection that does not exist.
    let zero_inc = {
        let mut d = msgs[3].2.clone();
        let at = 4 + 8 + 4 + "laser".len() + 8;
        d[at..at + 4].copy_from_slice(&0f32.to_le_bytes());
        d
    };
    msgs[3].2 = zero_inc;
    msgs[7].2.pop();
    msgs[4].0 = 9;
    let bytes = TestBag::scans_and_labels(msgs, "lz4", 100).build();
    let mut bag = open(&bytes).unwrap();
    let mut scans = bag.decoded::<LaserScanMsg>(&["/scan"]);
    let good: Vec<_> = (&mut scans).map(|m| m.unwrap()).collect();
    assert_eq!(good.len(), 4);
    assert_eq!(scans.bad_count(), 3, "two bad scans and one orphan record");
    assert!(matches!(
        scans.bad_messages()[0].error,
        DecodeError::Scan(tether_core::ScanError::BadAngleIncrement(_))
    ));
    assert!(matches!(
        scans.bad_messages()[1].error,
        DecodeError::Truncated { .. }
    ));
    assert!(scans.skipped()[0].reason.contains("connection 9"));
    let labels = bag.decoded::<LaserScanMsg>(&["/legs"]);
    let n_wrong: usize = labels.filter(|m| m.is_ok()).count();
    assert_eq!(n_wrong, 0, "a PoseArray is not a LaserScan");
}

#[test]
fn refuses_foreign_and_unindexed_files() {
    assert!(matches!(
        open(b"#ROSRECORD V1.2\nxxxx"),
        Err(BagError::NotABag { .. })
    ));
    assert!(matches!(open(b""), Err(BagError::NotABag { .. })));
    let mut bytes = TestBag::scans_and_labels(messages(), "none", 4).build();
    // index_pos is the first field of the bag header: 13 + 4 + 4 + "op=".len() + 1 + 4 + "index_pos=".len()
    let at = 13 + 4 + 4 + 4 + 4 + 10;
    assert_eq!(&bytes[at - 10..at], b"index_pos=");
    bytes[at..at + 8].copy_from_slice(&0u64.to_le_bytes());
    assert!(matches!(open(&bytes), Err(BagError::NotIndexed { at: 13 })));
}

#[test]
fn names_bad_chunks() {
    let bytes = TestBag::scans_and_labels(messages(), "zstd", 100).build();
    let err = first_error(&bytes);
    assert!(
        matches!(&err, BagError::UnsupportedCompression { at: 4109, compression } if compression == "zstd"),
        "{err}"
    );
    let mut bytes = TestBag::scans_and_labels(messages(), "lz4", 100).build();
    let n = bytes.len();
    // Damage the compressed data in the middle of the chunk.
    for b in &mut bytes[4200..4260] {
        *b ^= 0x5a;
    }
    assert!(n > 4300);
    let mut bag = open(&bytes).unwrap();
    let results: Vec<_> = bag.messages().collect();
    let err = results.last().unwrap().as_ref().unwrap_err();
    assert!(err.to_string().contains("chunk at byte 4109"), "{err}");
    assert!(results[..results.len() - 1].iter().all(|r| r.is_ok()));
}

#[test]
fn names_damaged_records_inside_chunks() {
    let mut bytes = TestBag::scans_and_labels(messages(), "none", 100).build();
    // The first inner record (a connection) starts at the chunk's data; break its op.
    let chunk_data = {
        let mut bag = open(&bytes).unwrap();
        assert!(bag.messages().all(|m| m.is_ok()));
        let h = u32::from_le_bytes(bytes[4109..4113].try_into().unwrap()) as usize;
        4109 + 4 + h + 4
    };
    let op_at = chunk_data + 4 + 4 + 3;
    assert_eq!(bytes[op_at], 0x07);
    bytes[op_at] = 0x09;
    let err = first_error(&bytes);
    assert_eq!(
        err.to_string(),
        "bag is corrupt: record at byte 0 of the uncompressed data of the chunk at \
             byte 4109: unknown record op 0x09"
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]
    #[test]
    fn damaged_bytes_never_panic(
        compression in prop::sample::select(vec!["none", "bz2", "lz4"]),
        damage in prop::collection::vec((0.0..1.0f64, any::<u8>()), 1..8),
    ) {
        let mut bytes = TestBag::scans_and_labels(messages(), compression, 3).build();
        let n = bytes.len();
        for (where_, value) in damage {
            let at = 13 + ((n - 13) as f64 * where_) as usize;
            bytes[at.min(n - 1)] = value;
        }
        if let Ok(mut bag) = open(&bytes) {
            let mut count = 0;
            for m in bag.messages() {
                match m {
                    Ok(raw) => {
                        let _ = raw.decode::<LaserScanMsg>();
                        let _ = raw.decode::<PoseArrayMsg>();
                        count += 1;
                    }
                    Err(e) => prop_assert!(e.to_string().contains("byte")),
                }
            }
            prop_assert!(count <= 12);
        }
    }
}
