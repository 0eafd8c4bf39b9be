//! The SCIP 2.0 reply parser on arbitrary bytes: it must never panic, how the bytes are
//! split into reads must not change what it finds, a scan it gives holds one value per
//! requested beam, and it stays usable: a good reply pushed afterwards (after the LF LF
//! that ends whatever came before) parses.

#![no_main]

use libfuzzer_sys::fuzz_target;
use tether_scip::{ParseEvent, Reply, ReplyParser};

fn parse(pieces: &[&[u8]]) -> (ReplyParser, Vec<ParseEvent>) {
    let mut parser = ReplyParser::new();
    let mut events = Vec::new();
    for piece in pieces {
        parser.push(piece);
        events.extend(std::iter::from_fn(|| parser.next_event()));
    }
    (parser, events)
}

fuzz_target!(|data: &[u8]| {
    // The first byte picks where to split the rest.
    let Some((&first, rest)) = data.split_first() else {
        return;
    };
    let cut = usize::from(first) * rest.len() / 255;
    let (a, b) = rest.split_at(cut.min(rest.len()));
    let (mut parser, events) = parse(&[rest]);
    assert_eq!(parse(&[a, b]).1, events, "split at {cut}");
    for event in &events {
        if let ParseEvent::Reply(Reply::Scan(scan)) = event {
            assert_eq!(scan.values_mm.len(), scan.request.value_count());
        }
    }
    parser.push(b"\n\nQT\n00P\n\n");
    let last = std::iter::from_fn(|| parser.next_event()).last();
    assert!(matches!(
        last,
        Some(ParseEvent::Reply(Reply::Status { .. }))
    ));
});
