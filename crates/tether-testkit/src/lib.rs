//! Test support shared by every tether crate's tests (a `[dev-dependencies]` entry only;
//! see the README for why it is a crate of its own).
//!
//! - [`shared_dir`], [`shared`], [`skip`], [`skip_unless`], [`or_skip`]: the data beside
//!   the workspace (`../shared`) and the rule for a test whose prerequisite is missing:
//!   it prints `SKIPPED: reason` and passes, unless `TETHER_REQUIRE_SHARED=1` (set in
//!   CI), which makes it fail with the reason, or it runs under `tools/test` (the
//!   README's test command), which leaves out the tests whose prerequisites are
//!   missing, reports them as skipped, and fails a test that still reaches a skip (it
//!   is missing from its group in `tools/test-groups/`).
//! - [`python_modules`], [`python_cv2`], [`python`], [`opencv_reference`],
//!   [`opencv_cascade`]: the Python peers the tests compare against and Debian's OpenCV
//!   cascades.
//! - [`scratch`], [`text`], [`json_lines`], [`is_jpeg`]: a fresh temporary folder,
//!   output as text, JSON lines, JPEG file names.
//! - [`damage`]: the edits of the parsers' proptests (damaged-valid inputs).

use std::path::{Path, PathBuf};
use std::process::Command;

/// The variable that turns a skipped test into a failed one when it is `1`.
pub const REQUIRE_SHARED: &str = "TETHER_REQUIRE_SHARED";

/// The variable that points the tests at another shared folder than `../shared` beside
/// the workspace (a folder that does not exist shows what a machine without it does).
pub const SHARED_DIR: &str = "TETHER_SHARED_DIR";

/// The variable `tools/test` sets: the tests whose prerequisites are missing were left
/// out by its filter, so a test that reaches a skip is missing from its group.
pub const GROUPS_FILTERED: &str = "TETHER_TEST_GROUPS_FILTERED";

/// Whether `TETHER_REQUIRE_SHARED=1` demands that every test runs.
pub fn required() -> bool {
    std::env::var(REQUIRE_SHARED).is_ok_and(|v| v == "1")
}

/// What a test does when `reason` keeps it from running: `Ok` with the line it prints
/// before it passes without checking, or, when `required`, `Err` with its failure.
pub fn decide(reason: &str, required: bool) -> Result<String, String> {
    if required {
        Err(format!(
            "{reason}; {REQUIRE_SHARED}=1 demands that this test runs"
        ))
    } else {
        Ok(format!("SKIPPED: {reason}"))
    }
}

/// What a test that `tools/test` should have left out does: fail, saying so.
pub fn unfiltered(reason: &str) -> String {
    format!(
        "{reason}; this test skips, but tools/test did not leave it out: add it to the group \
         of tools/test-groups/ that names this prerequisite, so that it is reported as skipped"
    )
}

/// Prints why a test does not run (`SKIPPED: reason`, on standard error), or panics
/// with the reason under `TETHER_REQUIRE_SHARED=1` or under `tools/test` (at the
/// test's line).
#[track_caller]
pub fn skip(reason: &str) {
    match decide(reason, required()) {
        Ok(_) if std::env::var_os(GROUPS_FILTERED).is_some() => panic!("{}", unfiltered(reason)),
        Ok(line) => eprintln!("{line}"),
        Err(failure) => panic!("{failure}"),
    }
}

/// `ok`, after [`skip`] with `reason` when it is false.
#[track_caller]
pub fn skip_unless(ok: bool, reason: &str) -> bool {
    if !ok {
        skip(reason);
    }
    ok
}

/// The value, or `None` after [`skip`] with the reason.
#[track_caller]
pub fn or_skip<T>(prerequisite: Result<T, String>) -> Option<T> {
    match prerequisite {
        Ok(value) => Some(value),
        Err(reason) => {
            skip(&reason);
            None
        }
    }
}

/// The shared folder: `../shared` beside the workspace (the design, the real recordings
/// and images, the reference tools), or `$TETHER_SHARED_DIR` when set.
pub fn shared_dir() -> PathBuf {
    match std::env::var_os(SHARED_DIR) {
        Some(dir) if !dir.is_empty() => PathBuf::from(dir),
        _ => Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared"),
    }
}

/// Why the test cannot run when one of `paths` (relative to [`shared_dir`]) is absent.
pub fn shared_missing(paths: &[&str]) -> Result<(), String> {
    let dir = shared_dir();
    match paths.iter().map(|p| dir.join(p)).find(|p| !p.exists()) {
        None => Ok(()),
        Some(path) => Err(format!(
            "{} is absent (../shared sits beside the checkout for developers and CI)",
            path.display()
        )),
    }
}

/// `path` under the shared folder, or `None` after [`skip`] when it is absent.
#[track_caller]
pub fn shared(path: &str) -> Option<PathBuf> {
    or_skip(shared_missing(&[path]).map(|()| shared_dir().join(path)))
}

/// Where Debian's `opencv-data` puts OpenCV's pretrained Haar cascades.
pub const OPENCV_CASCADES: &str = "/usr/share/opencv4/haarcascades";

/// `name` among Debian's OpenCV cascades ([`OPENCV_CASCADES`]); else why not, with the
/// `apt-get` command that installs them.
pub fn opencv_cascade(name: &str) -> Result<PathBuf, String> {
    let path = Path::new(OPENCV_CASCADES).join(name);
    if path.is_file() {
        Ok(path)
    } else {
        Err(format!(
            "{} is absent: Debian's opencv-data cascades are not installed \
             (apt-get install opencv-data)",
            path.display()
        ))
    }
}

/// Whether `python3` imports every one of `modules`; else why not, with the `pip`
/// command that installs them (`pip` names them as `install` says).
pub fn python_modules(modules: &[&str], install: &str) -> Result<(), String> {
    let imports = format!("import {}", modules.join(", "));
    match Command::new("python3").args(["-c", &imports]).output() {
        Ok(out) if out.status.success() => Ok(()),
        Ok(_) => Err(format!(
            "python3 with {} is not available (python3 -m pip install {install})",
            modules
                .iter()
                .map(|m| format!("`{m}`"))
                .collect::<Vec<_>>()
                .join(", ")
        )),
        Err(e) => Err(format!("python3 cannot run: {e}")),
    }
}

/// The version of Python's OpenCV when it is 4.x; else why not, with the `pip` command
/// that installs the version CI uses.
pub fn python_cv2() -> Result<String, String> {
    let out = Command::new("python3")
        .args(["-c", "import cv2; print(cv2.__version__)"])
        .output()
        .map_err(|e| format!("python3 cannot run: {e}"))?;
    let version = String::from_utf8_lossy(&out.stdout).trim().to_string();
    if out.status.success() && version.starts_with('4') {
        Ok(version)
    } else {
        Err(format!(
            "python3 has no OpenCV 4.x ({version}{}); pip install \
             opencv-python-headless==4.14.0.94 numpy",
            String::from_utf8_lossy(&out.stderr).trim()
        ))
    }
}

/// Runs `python3 ARGS`, which must succeed; its standard output.
pub fn python<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> String {
    let out = Command::new("python3")
        .args(args)
        .output()
        .expect("python3 runs");
    let shown: Vec<_> = args.iter().map(|a| a.as_ref().to_string_lossy()).collect();
    assert!(
        out.status.success(),
        "python3 {shown:?} failed: {}",
        text(&out.stderr)
    );
    text(&out.stdout)
}

/// OpenCV's `detectMultiScale` boxes for `images` with `cascade` at `min_neighbors`, as
/// the JSON the shared `tools/opencv_reference.py` prints (OpenCV on 2 threads; its
/// result does not depend on them).
pub fn opencv_reference(cascade: &Path, min_neighbors: u32, images: &[PathBuf]) -> String {
    let mut args = vec![
        shared_dir()
            .join("tools/opencv_reference.py")
            .into_os_string(),
        "--cascade".into(),
        cascade.as_os_str().to_owned(),
        "--min-neighbors".into(),
        min_neighbors.to_string().into(),
        "--threads".into(),
        "2".into(),
    ];
    args.extend(images.iter().map(|p| p.as_os_str().to_owned()));
    python(&args)
}

/// Whether `path` names a JPEG file (`.jpg` or `.jpeg`, any case).
pub fn is_jpeg(path: &Path) -> bool {
    matches!(
        path.extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref(),
        Some("jpg" | "jpeg")
    )
}

/// A fresh folder under the temporary directory, unique to this process and `name`.
pub fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("tether-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("the temporary directory is writable");
    dir
}

/// Output bytes as text.
pub fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// Each line of `text` as JSON; a line that is not JSON fails the test, with the line.
pub fn json_lines(text: &str) -> Vec<serde_json::Value> {
    text.lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("not JSON ({e}): {l}")))
        .collect()
}

/// The damage of the parsers' proptests: each edit `(where, what, op)` replaces
/// (`op` 0), inserts before (1) or removes (any other) the item at `where` of `items`,
/// in turn; edits stop when nothing is left.
pub fn damage<T>(
    items: &mut Vec<T>,
    edits: impl IntoIterator<Item = (proptest::sample::Index, T, u8)>,
) {
    for (at, item, op) in edits {
        if items.is_empty() {
            break;
        }
        let i = at.index(items.len());
        match op {
            0 => items[i] = item,
            1 => items.insert(i, item),
            _ => {
                items.remove(i);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_prerequisite_skips_unless_required_then_fails_with_the_reason() {
        assert_eq!(
            decide("../shared is absent", false),
            Ok("SKIPPED: ../shared is absent".to_string())
        );
        assert_eq!(
            decide("../shared is absent", true),
            Err("../shared is absent; TETHER_REQUIRE_SHARED=1 demands that this test runs".into())
        );
    }

    #[test]
    fn an_absent_shared_path_is_named_in_the_reason() {
        let why = shared_missing(&["no/such/file-in-shared"]).unwrap_err();
        assert!(why.contains("no/such/file-in-shared is absent"), "{why}");
        assert!(shared_missing(&[]).is_ok());
    }

    #[test]
    fn jpeg_names_in_any_case() {
        assert!(is_jpeg(Path::new("a/b.jpg")) && is_jpeg(Path::new("B.JPEG")));
        assert!(!is_jpeg(Path::new("b.png")) && !is_jpeg(Path::new("jpg")));
    }

    #[test]
    fn json_lines_reads_each_line() {
        let v = json_lines("{\"a\":1}\n[2]\n");
        assert_eq!(v.len(), 2);
        assert_eq!(v[0]["a"], 1);
        assert_eq!(v[1][0], 2);
    }

    #[test]
    #[should_panic(expected = "not JSON")]
    fn json_lines_fails_on_a_line_that_is_not_json() {
        json_lines("{\"a\":1}\nnot json\n");
    }

    #[test]
    #[should_panic(expected = "not JSON")]
    fn json_lines_fails_on_a_blank_line() {
        json_lines("{\"a\":1}\n\n[2]\n");
    }
}
