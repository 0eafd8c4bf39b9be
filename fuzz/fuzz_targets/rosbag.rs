//! The ROS 1 bag reader on arbitrary files, strict and salvaging: opening, walking every
//! record and chunk (decompressing bz2 and lz4 under the size caps of
//! `tether_recording::limits`) and decoding every message as the types tether reads must never
//! panic, and a walk yields at most one error, as its last item.

#![no_main]

use std::io::Cursor;

use libfuzzer_sys::fuzz_target;
use tether_msgs::{LaserScanMsg, OdometryMsg, PersonArrayMsg, PoseArrayMsg};
use tether_recording::rosbag::{Bag, BagError};

fn walk(bag: Result<Bag<Cursor<&[u8]>>, BagError>) {
    let Ok(mut bag) = bag else {
        return;
    };
    let _ = bag.topics();
    let mut errors = 0;
    let mut messages = bag.messages();
    for m in &mut messages {
        assert_eq!(errors, 0, "nothing comes after an error");
        match m {
            Ok(raw) => {
                let _ = raw.decode::<LaserScanMsg>();
                let _ = raw.decode::<PoseArrayMsg>();
                let _ = raw.decode::<PersonArrayMsg>();
                let _ = raw.decode::<OdometryMsg>();
            }
            Err(_) => errors += 1,
        }
    }
    let _ = messages.cut().map(|c| c.to_string());
}

fuzz_target!(|data: &[u8]| {
    // Most inputs would fail the magic: put it in front of all but a few (not in front
    // of one already there, as in the seeds).
    const MAGIC: &[u8] = b"#ROSBAG V2.0\n";
    let mut bytes = Vec::with_capacity(data.len() + 13);
    if !data.starts_with(MAGIC) && data.first().is_some_and(|b| b % 16 != 0) {
        bytes.extend_from_slice(MAGIC);
    }
    bytes.extend_from_slice(data);
    walk(Bag::from_reader(Cursor::new(&bytes[..])));
    walk(Bag::from_reader_salvaging(Cursor::new(&bytes[..])));
});
