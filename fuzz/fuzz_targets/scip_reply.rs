//! The SCIP 2.0 reply parser on arbitrary bytes: it must never panic, and how the bytes
//! are split into reads must not change what it finds.

#![no_main]

use libfuzzer_sys::fuzz_target;
use tether_scip::{ParseEvent, ReplyParser};

fn parse(pieces: &[&[u8]]) -> Vec<ParseEvent> {
    let mut parser = ReplyParser::new();
    let mut events = Vec::new();
    for piece in pieces {
        parser.push(piece);
        events.extend(std::iter::from_fn(|| parser.next_event()));
    }
    events
}

fuzz_target!(|data: &[u8]| {
    // The first byte picks where to split the rest.
    if let Some((&first, rest)) = data.split_first() {
        let cut = usize::from(first) * rest.len() / 255;
        let (a, b) = rest.split_at(cut.min(rest.len()));
        assert_eq!(parse(&[a, b]), parse(&[rest]), "split at {cut}");
    }
});
