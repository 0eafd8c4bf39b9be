//! The MCAP reader's tests: files tether writes, then damaged in chosen ways.

use super::*;
use crate::mcap::McapWriter;
use tether_core::LaserScan;
use tether_msgs::{Header, LaserScanMsg, RawLaserScan, TwistMsg, to_cdr};

/// A recording of 40 scans and 40 commands, in chunks of about 8 KiB.
fn recording() -> Vec<u8> {
    let mut w = McapWriter::with_chunk_size(std::io::Cursor::new(Vec::new()), 8 << 10).unwrap();
    for k in 0..40i64 {
        let t = Stamp::from_ns(1_000_000_000 + k * 100_000_000);
        let ranges = (0..682)
            .map(|i| 0.5 + ((i + k) % 50) as f32 * 0.1)
            .collect();
        let scan = LaserScan::new(t, "laser", -2.0862, 0.006_135_923, 0.02, 5.6, ranges).unwrap();
        w.write_stamped("/scan", &LaserScanMsg::new(scan, 0.0, 0.1))
            .unwrap();
        w.write("/cmd_vel", t, &TwistMsg::unicycle(0.1, k as f64))
            .unwrap();
    }
    w.finish().unwrap().into_inner()
}

#[test]
fn reads_what_the_writer_wrote_and_agrees_with_the_mcap_crate() {
    let bytes = recording();
    let file = McapFile::from_bytes(bytes.clone()).unwrap();
    assert_eq!(file.topics(), ["/cmd_vel", "/scan"]);
    assert_eq!(file.message_count("/scan"), 40);
    let ours: Vec<RawMessage> = file.messages().map(|m| m.unwrap()).collect();
    // The `mcap` crate's own reader (uncompressed chunks need no feature).
    let theirs: Vec<_> = mcap::MessageStream::new(&bytes)
        .unwrap()
        .map(|m| m.unwrap())
        .collect();
    assert_eq!(ours.len(), 80);
    assert_eq!(ours.len(), theirs.len());
    for (a, b) in ours.iter().zip(&theirs) {
        assert_eq!(a.topic(), b.channel.topic);
        assert_eq!(a.log_time.ns() as u64, b.log_time);
        assert_eq!(a.data, b.data.as_ref());
    }
    let twists: Vec<_> = file
        .decoded::<TwistMsg>(&["/cmd_vel"])
        .map(|m| m.unwrap().message.w_radps())
        .collect();
    assert_eq!(twists, (0..40).map(f64::from).collect::<Vec<_>>());
}

/// The chunk records of a file (start, end) and, for each, how many messages the
/// full file has in it.
fn chunks_of(bytes: &[u8]) -> Vec<(u64, u64, usize)> {
    let file = McapFile::from_bytes(bytes.to_vec()).unwrap();
    let in_chunks: Vec<u64> = file
        .messages()
        .map(|m| match m.unwrap().at {
            Location::InChunk { chunk, .. } => chunk,
            Location::File(at) => panic!("message outside a chunk at {at}"),
        })
        .collect();
    let mut out = Vec::new();
    let mut pos = MAGIC.len();
    while pos + 9 <= bytes.len() {
        let len = u64::from_le_bytes(bytes[pos + 1..pos + 9].try_into().unwrap());
        let end = pos as u64 + 9 + len;
        if bytes[pos] == op::CHUNK {
            let n = in_chunks.iter().filter(|&&c| c == pos as u64).count();
            out.push((pos as u64, end, n));
        }
        if bytes[pos] == op::DATA_END {
            break;
        }
        pos = end as usize;
    }
    out
}

/// Reads a prefix of a file: the messages it gives (never an error) and the cut.
fn read_prefix(bytes: &[u8], cut: usize) -> Option<(usize, Option<CutShort>)> {
    let file = McapFile::from_bytes(bytes[..cut].to_vec()).ok()?;
    let mut messages = file.messages();
    let mut n = 0;
    for m in &mut messages {
        match m {
            Ok(_) => n += 1,
            Err(e) => panic!("a prefix of {cut} bytes gives an error: {e}"),
        }
    }
    Some((n, messages.cut().copied()))
}

/// Where each message record of the file's (uncompressed) chunks ends, in file bytes.
fn message_ends(bytes: &[u8], chunks: &[(u64, u64, usize)]) -> Vec<u64> {
    let mut ends = Vec::new();
    for &(start, end, _) in chunks {
        // The chunk's header: two times, a size, a CRC, the compression, the length.
        let mut pos = start as usize + 9 + 8 + 8 + 8 + 4;
        let compression = u32::from_le_bytes(bytes[pos..pos + 4].try_into().unwrap());
        assert_eq!(compression, 0, "uncompressed");
        pos += 4 + 8;
        while (pos as u64) < end {
            let len = u64::from_le_bytes(bytes[pos + 1..pos + 9].try_into().unwrap());
            let record_end = pos as u64 + 9 + len;
            if bytes[pos] == op::MESSAGE {
                ends.push(record_end);
            }
            pos = record_end as usize;
        }
    }
    ends
}

/// Messages whose records end by `cut`.
fn complete_before(ends: &[u64], cut: usize) -> usize {
    ends.iter().filter(|&&e| e <= cut as u64).count()
}

#[test]
fn every_prefix_gives_every_message_complete_before_it() {
    // A copy cut off anywhere: the messages of the chunks before the cut and those of
    // the chunk it cuts, up to the cut (issue 33; before, the cut chunk's were lost).
    let bytes = recording();
    let chunks = chunks_of(&bytes);
    assert!(chunks.len() >= 4, "{} chunks", chunks.len());
    let full: usize = chunks.iter().map(|c| c.2).sum();
    assert_eq!(full, 80);
    let ends = message_ends(&bytes, &chunks);
    assert_eq!(ends.len(), 80);
    let header_end = {
        let len = u64::from_le_bytes(bytes[9..17].try_into().unwrap());
        17 + len as usize
    };
    for cut in (0..=bytes.len())
        .step_by(97)
        .chain([bytes.len() - 1, bytes.len()])
    {
        let Some((n, cut_at)) = read_prefix(&bytes, cut) else {
            assert!(
                cut < header_end,
                "only a cut in the magic or header may refuse"
            );
            continue;
        };
        assert_eq!(n, complete_before(&ends, cut), "cut at {cut}");
        if let Some(c) = cut_at {
            let at = match c.at {
                Location::File(at) | Location::InChunk { chunk: at, .. } => at,
            };
            assert!((at as usize) < cut, "{c}");
        }
    }
    // Cut inside the second chunk: the walk says where it stopped.
    let cut = ((chunks[1].0 + chunks[1].1) / 2) as usize;
    let file = McapFile::from_bytes(bytes[..cut].to_vec()).unwrap();
    assert!(file.salvaged().unwrap().contains("footer"));
    assert_eq!(
        file.topics(),
        ["/cmd_vel", "/scan"],
        "channels found in chunks"
    );
    let mut messages = file.messages();
    let n = (&mut messages).count();
    assert!(n > chunks[0].2 && n < chunks[0].2 + chunks[1].2, "{n}");
    assert_eq!(n, complete_before(&ends, cut));
    let c = messages.cut().unwrap();
    let in_second = match c.at {
        Location::File(at) => at == chunks[1].0,
        Location::InChunk { chunk, .. } => chunk == chunks[1].0,
    };
    assert!(in_second, "{c}");
    assert!(McapFile::from_bytes(bytes).unwrap().salvaged().is_none());
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]
    #[test]
    fn any_prefix_reads_without_error(fraction in 0.0..1.0f64) {
        let bytes = recording();
        let chunks = chunks_of(&bytes);
        let ends = message_ends(&bytes, &chunks);
        let cut = (bytes.len() as f64 * fraction) as usize;
        if let Some((n, _)) = read_prefix(&bytes, cut) {
            proptest::prop_assert_eq!(n, complete_before(&ends, cut));
        }
    }
}

/// A writer target that can be looked at while the writer still holds it.
#[derive(Clone, Default)]
struct Shared(std::rc::Rc<std::cell::RefCell<std::io::Cursor<Vec<u8>>>>);

impl std::io::Write for Shared {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.borrow_mut().write(buf)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl std::io::Seek for Shared {
    fn seek(&mut self, pos: std::io::SeekFrom) -> std::io::Result<u64> {
        self.0.borrow_mut().seek(pos)
    }
}

#[test]
fn an_unfinished_recording_holds_every_message_written_before_the_cut() {
    // A chunked recording whose writer was killed: the chunks closed at 2 s and 3 s of
    // log time are whole; the open one starts with a placeholder length (u64::MAX) and
    // holds what was written to it. Every message whose record is complete is read,
    // whatever byte the file ends at (issue 33; before, the open chunk's were lost).
    let target = Shared::default();
    let mut w = McapWriter::new(target.clone()).unwrap();
    let mut ends = Vec::new();
    // 3.5 s of 10 Hz scans of 100 beams: far less than a 1 MiB chunk.
    for k in 0..35i64 {
        let t = Stamp::from_ns(1_000_000_000 + k * 100_000_000);
        let scan = LaserScan::new(t, "laser", -1.0, 0.02, 0.02, 5.6, vec![1.5; 100]).unwrap();
        w.write_stamped("/scan", &LaserScanMsg::new(scan, 0.0, 0.1))
            .unwrap();
        ends.push(target.0.borrow().get_ref().len());
    }
    // The process dies here: what is in the file is all there is.
    let bytes = target.0.borrow().get_ref().clone();
    let stamps_of = |bytes: &[u8]| {
        let file = McapFile::from_bytes(bytes.to_vec()).unwrap();
        let mut scans = file.decoded::<LaserScanMsg>(&["/scan"]);
        let stamps: Vec<i64> = (&mut scans)
            .map(|m| m.unwrap().message.scan.stamp.ns())
            .collect();
        (stamps, scans.cut().copied())
    };
    let (stamps, cut) = stamps_of(&bytes);
    assert_eq!(stamps.len(), 35);
    assert_eq!(stamps[34], 4_400_000_000);
    let cut = cut.expect("the cut is reported");
    assert!(cut.to_string().contains("never written"), "{cut}");
    // Cut anywhere in the open chunk (the chunks before it closed at 30 scans).
    for at in (ends[29] + 1..=bytes.len())
        .step_by(37)
        .chain([bytes.len() - 1])
    {
        let (stamps, cut) = stamps_of(&bytes[..at]);
        let complete = ends.iter().filter(|&&e| e <= at).count();
        assert_eq!(stamps.len(), complete.max(30), "cut at byte {at}");
        assert!(cut.is_some(), "cut at byte {at}");
    }
    w.finish().unwrap();
    // Finished, every scan is there.
    let bytes = target.0.borrow().get_ref().clone();
    assert_eq!(
        McapFile::from_bytes(bytes).unwrap().message_count("/scan"),
        35
    );
}

#[test]
fn a_streaming_recording_cut_anywhere_holds_every_message_written_before() {
    let target = Shared::default();
    let mut w = McapWriter::streaming(target.clone()).unwrap();
    let mut ends = Vec::new();
    for k in 0..35i64 {
        let t = Stamp::from_ns(1_000_000_000 + k * 100_000_000);
        let scan = LaserScan::new(t, "laser", -1.0, 0.02, 0.02, 5.6, vec![1.5; 100]).unwrap();
        w.write_stamped("/scan", &LaserScanMsg::new(scan, 0.0, 0.1))
            .unwrap();
        ends.push(target.0.borrow().get_ref().len());
    }
    // The process dies here; any prefix of what it wrote is read up to its last
    // complete message, in order.
    let bytes = target.0.borrow().get_ref().clone();
    for cut in (ends[0]..=bytes.len()).step_by(53).chain([bytes.len()]) {
        let file = McapFile::from_bytes(bytes[..cut].to_vec()).unwrap();
        let stamps: Vec<i64> = file
            .decoded::<LaserScanMsg>(&["/scan"])
            .map(|m| m.unwrap().message.scan.stamp.ns())
            .collect();
        let complete = ends.iter().filter(|&&e| e <= cut).count();
        assert_eq!(stamps.len(), complete, "cut at {cut}");
        assert!(stamps.windows(2).all(|p| p[0] < p[1]));
    }
    w.finish().unwrap();
    let bytes = target.0.borrow().get_ref().clone();
    let file = McapFile::from_bytes(bytes).unwrap();
    assert!(file.salvaged().is_none());
    assert_eq!(file.message_count("/scan"), 35);
}

/// An MCAP file of a header and one chunk record with these fields.
fn one_chunk(compression: &str, uncompressed_size: u64, records: &[u8]) -> Vec<u8> {
    fn string(out: &mut Vec<u8>, s: &str) {
        out.extend((s.len() as u32).to_le_bytes());
        out.extend(s.as_bytes());
    }
    let mut out = MAGIC.to_vec();
    let mut header = Vec::new();
    string(&mut header, "ros2");
    string(&mut header, "test");
    out.push(op::HEADER);
    out.extend((header.len() as u64).to_le_bytes());
    out.extend(header);
    let mut chunk = Vec::new();
    chunk.extend(0u64.to_le_bytes());
    chunk.extend(0u64.to_le_bytes());
    chunk.extend(uncompressed_size.to_le_bytes());
    chunk.extend(0u32.to_le_bytes());
    string(&mut chunk, compression);
    chunk.extend((records.len() as u64).to_le_bytes());
    chunk.extend(records);
    out.push(op::CHUNK);
    out.extend((chunk.len() as u64).to_le_bytes());
    out.extend(chunk);
    out
}

#[test]
fn a_decompression_bomb_is_refused_before_anything_is_allocated() {
    for compression in ["lz4", "zstd"] {
        // 200 MiB claimed from 100 bytes: refused by the ratio; 1 TiB by the size cap.
        for (claim, cap) in [(200u64 << 20, "decompression bomb"), (1 << 40, "256 MiB")] {
            let file = McapFile::from_bytes(one_chunk(compression, claim, &[7; 100])).unwrap();
            let err = file.messages().next().unwrap().unwrap_err();
            assert!(err.to_string().contains(cap), "{compression}: {err}");
            assert!(err.to_string().contains("chunk record at byte 33"), "{err}");
        }
    }
    // An honest small chunk of zeros in lz4 (255:1) still reads.
    // Zeros are records of opcode 0 and length 0 (9 bytes each): no messages.
    let records = vec![0u8; 9 << 17];
    let mut e = lz4_flex::frame::FrameEncoder::new(Vec::new());
    std::io::Write::write_all(&mut e, &records).unwrap();
    let stored = e.finish().unwrap();
    assert!(stored.len() * 200 < records.len());
    let file = McapFile::from_bytes(one_chunk("lz4", 9 << 17, &stored)).unwrap();
    assert_eq!(file.messages().filter(Result::is_err).count(), 0);
}

#[test]
fn a_damaged_chunk_fails_its_crc() {
    let mut bytes = recording();
    // A byte in the middle of the first chunk's records.
    let first = chunks_of(&bytes)[0];
    let at = ((first.0 + first.1) / 2) as usize;
    bytes[at] ^= 0x55;
    let file = McapFile::from_bytes(bytes).unwrap();
    let err = file.messages().find_map(Result::err).expect("an error");
    assert!(err.to_string().contains("CRC-32"), "{err}");
}

#[test]
fn bad_messages_are_skipped_and_counted() {
    let mut w = McapWriter::new(std::io::Cursor::new(Vec::new())).unwrap();
    let good = RawLaserScan {
        header: Header::new(Stamp::from_ns(5), "laser"),
        angle_min: -1.0,
        angle_max: 1.0,
        angle_increment: 0.5,
        time_increment: 0.0,
        scan_time: 0.1,
        range_min: 0.02,
        range_max: 5.6,
        ranges: vec![1.0; 5],
        intensities: vec![],
    };
    let mut bad = good.clone();
    bad.angle_max = 3.0; // says 9 beams, carries 5
    for m in [&good, &bad, &good] {
        w.write_stamped("/scan", m).unwrap();
    }
    let bytes = w.finish().unwrap().into_inner();
    let file = McapFile::from_bytes(bytes).unwrap();
    let mut scans = file.decoded::<LaserScanMsg>(&["/scan"]);
    let read: Vec<_> = scans.by_ref().map(|m| m.unwrap()).collect();
    assert_eq!(read.len(), 2);
    assert_eq!(scans.bad_count(), 1);
    assert!(matches!(
        scans.bad_messages()[0].error,
        DecodeError::Scan(_)
    ));
    let mut wrong = file.decoded::<TwistMsg>(&["/scan"]);
    assert_eq!(wrong.by_ref().count(), 0);
    assert!(matches!(
        wrong.bad_messages()[0].error,
        DecodeError::WrongType { .. }
    ));
    assert!(to_cdr(&good).is_ok());
}

#[test]
fn refuses_other_files() {
    assert!(matches!(
        McapFile::from_bytes(b"#ROSBAG V2.0\n".to_vec()),
        Err(McapError::NotMcap { .. })
    ));
    assert!(McapFile::from_bytes(Vec::new()).is_err());
}

/// Opens `bytes` and, if they open, walks every message and decodes every topic as
/// a scan: an error or a result, never a panic; a walk gives at most one error, as
/// its last item (what the `mcap_file` fuzz target checks).
fn open_and_walk(bytes: Vec<u8>) -> Result<usize, McapError> {
    let file = McapFile::from_bytes(bytes)?;
    let _ = (file.salvaged(), file.profile(), file.library());
    let topics: Vec<String> = file.topics().iter().map(|t| t.to_string()).collect();
    let mut n = 0;
    let mut messages = file.messages();
    let mut last_error = None;
    for m in &mut messages {
        assert!(
            last_error.is_none(),
            "a message after the error {last_error:?}"
        );
        match m {
            Ok(_) => n += 1,
            Err(e) => last_error = Some(e),
        }
    }
    if let Some(c) = messages.cut() {
        let _ = c.to_string();
    }
    let names: Vec<&str> = topics.iter().map(String::as_str).collect();
    let mut scans = file.decoded::<LaserScanMsg>(&names);
    for m in &mut scans {
        let _ = m.map(|m| m.message);
    }
    let _ = (scans.bad_count(), scans.skipped().len());
    match last_error {
        Some(e) => Err(e),
        None => Ok(n),
    }
}

/// Records that look like MCAP's: a known or random opcode, a length that is the
/// body's, or random, or far too large, and a random body (small).
fn mcap_like_records() -> impl proptest::strategy::Strategy<Value = Vec<u8>> {
    use proptest::prelude::*;
    let record = (
        prop_oneof![0x01u8..=0x0F, any::<u8>()],
        prop_oneof![
            Just(None),
            any::<u64>().prop_map(Some),
            (0u64..64).prop_map(Some)
        ],
        proptest::collection::vec(any::<u8>(), 0..96),
    )
        .prop_map(|(op, len, body)| {
            let mut out = vec![op];
            out.extend(len.unwrap_or(body.len() as u64).to_le_bytes());
            out.extend(body);
            out
        });
    (proptest::collection::vec(record, 0..12), any::<bool>()).prop_map(|(records, end)| {
        let mut out = MAGIC.to_vec();
        out.extend(records.concat());
        if end {
            out.extend(MAGIC);
        }
        out
    })
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(256))]

    /// Random bytes, alone and after the magic, and MCAP-like records: an error or
    /// a file whose walk ends, never a panic.
    #[test]
    fn random_bytes_give_an_error_or_a_result_never_a_panic(
        bytes in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..2000),
        after_magic in proptest::prelude::any::<bool>(),
    ) {
        let mut input = if after_magic { MAGIC.to_vec() } else { Vec::new() };
        input.extend(&bytes);
        let _ = open_and_walk(input);
    }

    #[test]
    fn mcap_like_records_give_an_error_or_a_result_never_a_panic(
        bytes in mcap_like_records(),
    ) {
        let _ = open_and_walk(bytes);
    }

    /// A valid recording with bytes changed, inserted or removed anywhere.
    #[test]
    fn a_damaged_recording_gives_an_error_or_a_result_never_a_panic(
        edits in proptest::collection::vec(
            (proptest::prelude::any::<proptest::sample::Index>(), proptest::prelude::any::<u8>(), 0u8..3),
            1..8,
        ),
    ) {
        static RECORDING: std::sync::OnceLock<Vec<u8>> = std::sync::OnceLock::new();
        let mut bytes = RECORDING.get_or_init(recording).clone();
        tether_testkit::damage(&mut bytes, edits);
        let _ = open_and_walk(bytes);
    }
}
