//! Progress and colour on a terminal, none in a pipe (issue 17: "Long commands show
//! progress; colour codes only on a terminal"). The terminal is a pseudo-terminal from
//! util-linux's `script`, as a user's shell gives one.

#![allow(clippy::unwrap_used, reason = "a test should fail loudly")]

use std::process::{Command, Output};

fn tether() -> &'static str {
    env!("CARGO_BIN_EXE_tether")
}

/// `tether ARGS` on a pseudo-terminal: what the terminal showed (stdout and stderr as
/// one stream), or `None` (with the reason printed, a failure under
/// `TETHER_REQUIRE_SHARED=1`) where `script` is missing.
fn on_a_terminal(args: &[&str]) -> Option<Output> {
    let line = std::iter::once(tether())
        .chain(args.iter().copied())
        .collect::<Vec<_>>()
        .join(" ");
    let run = Command::new("script")
        .args(["-qefc", &line, "/dev/null"])
        .output();
    tether_testkit::or_skip(
        run.map_err(|e| format!("no util-linux `script` to give tether a terminal ({e})")),
    )
}

#[test]
fn a_long_command_shows_progress_and_colour_on_a_terminal_and_neither_in_a_pipe() {
    let dir = tether_testkit::scratch("terminal-sim");
    let terminal_out = dir.join("terminal");
    let args = [
        "sim",
        "--scenario",
        "corridor",
        "--duration",
        "3",
        "--out",
        terminal_out.to_str().unwrap(),
    ];
    let Some(shown) = on_a_terminal(&args) else {
        return;
    };
    assert!(shown.status.success(), "{shown:?}");
    let shown = String::from_utf8_lossy(&shown.stdout);
    assert!(shown.contains("simulating corridor"), "{shown}");
    assert!(shown.contains("% ("), "no percentage: {shown}");
    assert!(
        shown.contains("\u{1b}["),
        "no colour or cursor codes: {shown}"
    );

    let piped_out = dir.join("piped");
    let mut args = args;
    args[6] = piped_out.to_str().unwrap();
    let piped = Command::new(tether()).args(args).output().unwrap();
    assert!(piped.status.success(), "{piped:?}");
    for (stream, text) in [("stdout", &piped.stdout), ("stderr", &piped.stderr)] {
        let text = String::from_utf8_lossy(text);
        assert!(!text.contains("simulating corridor"), "{stream}: {text}");
        assert!(!text.contains('\u{1b}'), "{stream}: {text}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
