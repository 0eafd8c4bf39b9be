//! The MCAP reader on arbitrary files: opening (summary, or the linear scan of a file
//! without one), walking every record and chunk (zstd and lz4 under the size caps of
//! `tether_recording::limits`) and decoding every message as a scan and as an image
//! (converted to grey) must never panic, and a walk yields at most one error, as its last
//! item.

#![no_main]

use libfuzzer_sys::fuzz_target;
use tether_msgs::{ImageMsg, LaserScanMsg};
use tether_recording::mcap::{MAGIC, McapFile};

fuzz_target!(|data: &[u8]| {
    let mut bytes = Vec::with_capacity(data.len() + 8);
    if !data.starts_with(MAGIC) && data.first().is_some_and(|b| b % 16 != 0) {
        bytes.extend_from_slice(MAGIC);
    }
    bytes.extend_from_slice(data);
    let Ok(file) = McapFile::from_bytes(bytes) else {
        return;
    };
    let _ = (file.topics(), file.salvaged());
    let topics: Vec<String> = file.topics().iter().map(|t| t.to_string()).collect();
    let mut errors = 0;
    let mut messages = file.messages();
    for m in &mut messages {
        assert_eq!(errors, 0, "nothing comes after an error");
        if m.is_err() {
            errors += 1;
        }
    }
    let _ = messages.cut().map(|c| c.to_string());
    let names: Vec<&str> = topics.iter().map(String::as_str).collect();
    for m in file.decoded::<LaserScanMsg>(&names) {
        let _ = m;
    }
    for m in file.decoded::<ImageMsg>(&names).take(10_000) {
        let _ = m.map(|m| m.message.to_gray());
    }
});
