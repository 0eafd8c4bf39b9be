//! `info.dat` annotations (`IMAGE COUNT x y w h ...` lines, what `train-cascade` and
//! `eval-cascade` read) on arbitrary text: never a panic, never a vector sized by an
//! unchecked count, and what parses holds as many boxes as its count, each of
//! positive size, on increasing lines.

#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use tether_cascade::info::parse_info;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let Ok(annotations) = parse_info(&text, Path::new("base"), Path::new("info.dat")) else {
        return;
    };
    assert!(!annotations.is_empty());
    let lines = text.lines().count();
    let mut last = 0;
    for a in &annotations {
        assert!(
            a.line > last && a.line <= lines,
            "line {} after {last}",
            a.line
        );
        last = a.line;
        // Relative to the file's folder, unless the line names an absolute path.
        assert!(
            a.image.starts_with("base") || a.image.is_absolute(),
            "{:?}",
            a.image
        );
        for b in &a.boxes {
            assert!(b.width > 0 && b.height > 0, "{b:?}");
        }
    }
});
