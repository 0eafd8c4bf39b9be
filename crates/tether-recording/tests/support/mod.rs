//! What the cross-checks against independent Python implementations share: skipping (or,
//! in CI, failing) when a peer is missing, running a peer script, scratch directories.

#![allow(
    dead_code,
    clippy::unwrap_used,
    reason = "test support: each test uses a part; a failed unwrap is a failed test"
)]

use std::path::PathBuf;
use std::process::Command;

/// Skips (prints the reason) or, when `TETHER_REQUIRE_SHARED=1`, fails.
pub fn skip(reason: &str) {
    if std::env::var("TETHER_REQUIRE_SHARED").is_ok_and(|v| v == "1") {
        panic!("{reason}; TETHER_REQUIRE_SHARED=1 demands that this test runs");
    }
    eprintln!("SKIPPED: {reason}");
}

/// Whether `python3` runs `import IMPORTS`; if not, [`skip`] with `reason`.
pub fn have_python(imports: &str, reason: &str) -> bool {
    let ok = Command::new("python3")
        .args(["-c", &format!("import {imports}")])
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        skip(reason);
    }
    ok
}

/// Runs `python3 SCRIPT ARGS...`; fails the test with its stderr if it fails.
pub fn python(script: &str, args: &[&str]) {
    let out = Command::new("python3")
        .arg(script)
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "python3 {script} {args:?} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// An empty directory of this process for `name`'s files.
pub fn scratch_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("tether-recording-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}
