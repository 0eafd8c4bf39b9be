//! The emulator's parser of host commands on arbitrary lines: it must never panic, and a
//! command it accepts and can encode again must parse back to itself.

#![no_main]

use libfuzzer_sys::fuzz_target;
use tether_scip::command::parse_request;

fuzz_target!(|data: &[u8]| {
    if let Ok(request) = parse_request(data)
        && let Ok(line) = request.encode()
    {
        let again = parse_request(line.strip_suffix(b"\n").unwrap_or(&line));
        assert_eq!(
            again.ok(),
            Some(request),
            "{:?}",
            String::from_utf8_lossy(data)
        );
    }
});
