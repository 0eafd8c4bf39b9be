//! What the cross-checks against independent Python implementations share: skipping (or,
//! in CI, failing) when a peer is missing, running a peer script, scratch directories.

#![allow(
    dead_code,
    clippy::unwrap_used,
    reason = "test support: each test uses a part; a failed unwrap is a failed test"
)]

use std::path::PathBuf;
use std::process::Command;

/// Skips (prints the reason) or, when `TETHER_REQUIRE_SHARED=1`, fails: the workspace's
/// rule, [`tether_testkit::skip`].
#[track_caller]
pub fn skip(reason: &str) {
    tether_testkit::skip(reason);
}

/// Whether `python3` runs `import IMPORTS`; if not, [`skip`] with `reason`.
#[track_caller]
pub fn have_python(imports: &str, reason: &str) -> bool {
    let ok = Command::new("python3")
        .args(["-c", &format!("import {imports}")])
        .output()
        .is_ok_and(|o| o.status.success());
    tether_testkit::skip_unless(ok, reason)
}

/// Runs `python3 SCRIPT ARGS...`; fails the test with its stderr if it fails.
pub fn python(script: &str, args: &[&str]) {
    let all: Vec<&str> = std::iter::once(script)
        .chain(args.iter().copied())
        .collect();
    tether_testkit::python(&all);
}

/// An empty directory of this process for `name`'s files.
pub fn scratch_dir(name: &str) -> PathBuf {
    tether_testkit::scratch(&format!("recording-{name}"))
}
