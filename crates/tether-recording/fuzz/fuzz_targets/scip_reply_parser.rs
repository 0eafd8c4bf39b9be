//! Fuzzes the SCIP 2.0 reply parser: any bytes, fed in pieces whose sizes the input
//! chooses, must give events (never a panic), and the parser must stay usable: a good
//! reply pushed afterwards (after the LF LF that ends whatever came before) parses.
#![no_main]

use libfuzzer_sys::fuzz_target;
use tether_io::scip::command::parse_request;
use tether_io::scip::{ParseEvent, Reply, ReplyParser};

fuzz_target!(|data: &[u8]| {
    let Some((&split, bytes)) = data.split_first() else {
        return;
    };
    let mut parser = ReplyParser::new();
    let piece = usize::from(split).max(1);
    for chunk in bytes.chunks(piece) {
        parser.push(chunk);
        while let Some(event) = parser.next_event() {
            if let ParseEvent::Reply(Reply::Scan(scan)) = event {
                assert_eq!(scan.values_mm.len(), scan.request.value_count());
            }
        }
    }
    for line in bytes.split(|&b| b == b'\n') {
        let _ = parse_request(line);
    }
    parser.push(b"\n\nQT\n00P\n\n");
    let mut last = None;
    while let Some(event) = parser.next_event() {
        last = Some(event);
    }
    assert!(matches!(
        last,
        Some(ParseEvent::Reply(Reply::Status { .. }))
    ));
});
