//! Fuzzes the MCAP reader and the CDR decoders: any file must open or be refused, and
//! reading it must end (with messages, skipped records or one error), never panic.
#![no_main]

use libfuzzer_sys::fuzz_target;
use tether_io::mcap::{
    CompressedImageMsg, ImageMsg, LaserScanMsg, McapFile, OdometryMsg, PoseArrayMsg,
    PoseWithCovarianceStampedMsg, TwistMsg, from_cdr,
};

fuzz_target!(|data: &[u8]| {
    // The CDR decoders on the raw bytes.
    let _ = from_cdr::<LaserScanMsg>(data);
    let _ = from_cdr::<ImageMsg>(data).map(|m| m.to_gray());
    let _ = from_cdr::<CompressedImageMsg>(data);
    let _ = from_cdr::<TwistMsg>(data);
    let _ = from_cdr::<PoseArrayMsg>(data);
    let _ = from_cdr::<PoseWithCovarianceStampedMsg>(data);
    let _ = from_cdr::<OdometryMsg>(data);
    // The file reader, with the magic in front so that the fuzzer reaches the records.
    let mut file = tether_io::mcap::MAGIC.to_vec();
    file.extend_from_slice(data);
    for bytes in [data.to_vec(), file] {
        if let Ok(f) = McapFile::from_bytes(bytes) {
            for m in f.messages().take(10_000) {
                if let Ok(m) = m {
                    let _ = m.decode::<LaserScanMsg>();
                }
            }
            let _ = f.decoded::<ImageMsg>(&["/image"]).take(10_000).count();
        }
    }
});
