//! The commands the documents give cannot drift from the program (issue 34): every
//! `tether ...` command of the README, `docs/`, the crates' READMEs, the configs'
//! comments (inline code and shell blocks, `cargo run --release --` read as `tether`)
//! and the `--help` of every subcommand
//! is parsed by the release binary (`TETHER_PARSE_ONLY=1`: parsing is all it does),
//! its placeholders (`BAG`, `N`, `FILE.json`, `[--optional ...]`) filled in; and the
//! commands of the walk-throughs that need no hardware, no files and little time are
//! run as written, from a scratch folder, in the order the documents give them.

#![allow(clippy::unwrap_used, reason = "a test should fail loudly")]

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::scratch;

/// The repository's root.
fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The documents whose commands are checked.
fn documents() -> Vec<PathBuf> {
    let mut files = vec![root().join("README.md")];
    for dir in ["docs", "configs"] {
        let mut more: Vec<PathBuf> = std::fs::read_dir(root().join(dir))
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "md" || e == "toml"))
            .collect();
        more.sort();
        files.extend(more);
    }
    let mut crates: Vec<PathBuf> = std::fs::read_dir(root().join("crates"))
        .unwrap()
        .map(|e| e.unwrap().path().join("README.md"))
        .filter(|p| p.is_file())
        .collect();
    crates.sort();
    files.extend(crates);
    files
}

/// The commands of every document, in the documents' order.
fn documented_commands() -> Vec<Found> {
    let mut all = Vec::new();
    for doc in documents() {
        let text = std::fs::read_to_string(&doc).unwrap();
        let name = doc
            .strip_prefix(root())
            .unwrap_or(&doc)
            .display()
            .to_string();
        all.extend(commands(&name, &text));
    }
    all
}

/// The subcommands listed under `Commands:` in a `--help` text (`help` left out).
fn subcommands(help: &str) -> Vec<String> {
    help.lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| !l.trim().is_empty())
        .filter_map(|l| {
            l.strip_prefix("  ")?
                .split_whitespace()
                .next()
                .map(str::to_owned)
        })
        .filter(|c| c != "help")
        .collect()
}

/// The commands that `tether [SUB [SUB2]] --help` name in backticks, as mentions.
fn help_mentions() -> Vec<Found> {
    let help = |args: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_tether"))
            .args(args)
            .arg("--help")
            .output()
            .unwrap();
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    let mut pages = vec![(String::new(), help(&[]))];
    for sub in subcommands(&pages[0].1) {
        let page = help(&[&sub]);
        for sub2 in subcommands(&page) {
            pages.push((format!("{sub} {sub2}"), help(&[&sub, &sub2])));
        }
        pages.push((sub, page));
    }
    let mut out = Vec::new();
    for (sub, page) in pages {
        // Help text is wrapped: a command in backticks may run over two lines.
        let joined: String = page.lines().map(str::trim).collect::<Vec<_>>().join(" ");
        for found in commands(&format!("tether {sub} --help"), &joined) {
            out.push(Found {
                whole: false,
                ..found
            });
        }
    }
    out
}

/// A command found in a document: where, its text, and whether it is a whole command
/// (a line of a shell block) or may be a mention in prose (`tether sim --record`),
/// which must name a subcommand and options that exist but may leave out what they
/// require.
#[derive(Debug, Clone)]
struct Found {
    at: String,
    text: String,
    whole: bool,
}

/// The `tether` commands of `text` (one document): inline code and the logical lines
/// of shell blocks, split at `&&`, `;` and `|`.
fn commands(name: &str, text: &str) -> Vec<Found> {
    let mut out = Vec::new();
    let mut push = |line_no: usize, s: &str, whole: bool| {
        for part in s
            .split("&&")
            .flat_map(|p| p.split(';'))
            .flat_map(|p| p.split(" | "))
        {
            let part = part.trim();
            let part = part
                .strip_prefix("cargo run --release -- ")
                .map(|r| format!("tether {r}"))
                .or_else(|| {
                    part.strip_prefix("target/release/tether ")
                        .map(|r| format!("tether {r}"))
                })
                .unwrap_or_else(|| part.to_owned());
            if part.starts_with("tether ") {
                out.push(Found {
                    at: format!("{name}:{line_no}"),
                    text: part,
                    whole,
                });
            }
        }
    };
    let mut in_block = false;
    let mut pending = String::new();
    let mut pending_line = 0;
    for (i, line) in text.lines().enumerate() {
        let n = i + 1;
        let trimmed = line.trim_start();
        if trimmed.starts_with("```") {
            in_block = !in_block && trimmed.trim_start_matches('`').starts_with("sh");
            continue;
        }
        if in_block {
            if pending.is_empty() {
                pending_line = n;
            }
            let code = match line.find(" #") {
                Some(k) if !line[..k].contains('\'') => &line[..k],
                _ => line,
            };
            if let Some(head) = code.trim_end().strip_suffix('\\') {
                pending.push_str(head);
                pending.push(' ');
                continue;
            }
            pending.push_str(code);
            push(pending_line, &pending, true);
            pending.clear();
            continue;
        }
        // Inline code of prose (a line of a TOML file's comments is prose too).
        let mut rest = line;
        while let Some(a) = rest.find('`') {
            let after = &rest[a + 1..];
            let Some(b) = after.find('`') else { break };
            push(n, &after[..b], false);
            rest = &after[b + 1..];
        }
    }
    out
}

/// `command` with its placeholders filled in: `[...]` optional parts kept, `...`
/// dropped, the first of `a|b` choices taken, upper-case words (`N`, `S`, `BAG`,
/// `FILE.json`, `IMAGE...`) made values.
fn filled(command: &str) -> String {
    let mut words = Vec::new();
    // A command inside `sh -c '...'` was cut out of its quotes.
    let command = if command.matches('\'').count() % 2 == 1 {
        command.replace('\'', "")
    } else {
        command.to_owned()
    };
    for word in command.replace(['[', ']'], " ").split_whitespace() {
        let word = word.trim_end_matches("...");
        // `a|b|c`: one of the choices.
        let word = word.split('|').next().unwrap_or(word);
        if word.is_empty() {
            continue;
        }
        let stem = word.split('.').next().unwrap_or(word);
        let placeholder = !stem.is_empty()
            && stem.chars().next().unwrap().is_ascii_uppercase()
            && stem
                .chars()
                .all(|c| c.is_ascii_uppercase() || c.is_ascii_digit() || c == '_');
        // A bare number's placeholder (no file extension).
        let bare = placeholder && stem == word;
        words.push(match (placeholder, stem) {
            (true, "N" | "K") if bare => "2".to_owned(),
            (true, "S") if bare => "1".to_owned(),
            (true, "FRAC" | "R" | "F") if bare => "0.5".to_owned(),
            (false, "WxH") => "24x24".to_owned(),
            (true, _) => format!("x{}", &word[stem.len()..]),
            (false, _) => word.to_owned(),
        });
    }
    words.join(" ")
}

/// A folder whose `tether` is the binary under test.
fn bin_dir(dir: &Path) -> PathBuf {
    let bin = dir.join("bin");
    std::fs::create_dir_all(&bin).unwrap();
    let link = bin.join("tether");
    if !link.exists() {
        std::os::unix::fs::symlink(env!("CARGO_BIN_EXE_tether"), &link).unwrap();
    }
    bin
}

/// Runs `script` with bash in `dir`, `tether` on the PATH; returns success and output.
fn bash(dir: &Path, script: &str, parse_only: bool) -> (bool, String) {
    let path = format!(
        "{}:{}",
        bin_dir(dir).display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let mut cmd = Command::new("bash");
    cmd.args(["-c", script]).current_dir(dir).env("PATH", path);
    if parse_only {
        cmd.env("TETHER_PARSE_ONLY", "1");
    }
    let out = cmd.output().unwrap();
    (
        out.status.success(),
        format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        ),
    )
}

#[test]
fn every_documented_command_parses() {
    let dir = scratch("walkthrough-parse");
    let mut all = documented_commands();
    let from_help = help_mentions();
    assert!(
        from_help.len() > 20,
        "too few commands in --help: {}",
        from_help.len()
    );
    all.extend(from_help);
    let mut failures = Vec::new();
    for found in &all {
        let line = filled(&found.text);
        if line == "tether" {
            continue;
        }
        let (ok, said) = bash(&dir, &line, true);
        // A mention may leave out what its command requires; nothing else.
        let mention_ok = !found.whole
            && (said.contains("the following required arguments were not provided")
                || said.contains("a value is required for"));
        if !ok && !mention_ok {
            failures.push(format!(
                "{}: `{}` (as `{line}`):\n{}",
                found.at,
                found.text,
                said.lines().take(3).collect::<Vec<_>>().join("\n")
            ));
        }
    }
    println!(
        "{} commands of {} documents parsed, {} refused",
        all.len(),
        documents().len(),
        failures.len()
    );
    assert!(all.len() > 100, "too few commands found: {}", all.len());
    assert!(failures.is_empty(), "\n{}", failures.join("\n\n"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn placeholders_are_filled_and_compound_lines_split() {
    let found = commands(
        "x.md",
        "Try `tether eval-target --seeds N --json t.json` and `tether track BAG [--image-topic T] --out F.jsonl`.\n\
         ```sh\ncargo run --release -- demo\ntether sim --scenario crossing --out out/x \\\n    --record-bag x.bag && tether eval-track x.bag # and then\n```\n",
    );
    let texts: Vec<String> = found.iter().map(|f| filled(&f.text)).collect();
    assert_eq!(
        texts,
        [
            "tether eval-target --seeds 2 --json t.json",
            "tether track x --image-topic x --out x.jsonl",
            "tether demo",
            "tether sim --scenario crossing --out out/x --record-bag x.bag",
            "tether eval-track x.bag",
        ]
    );
    assert_eq!(found[3].at, "x.md:4");
}

/// Subcommands quick enough, and needing nothing but the binary, to run as written.
const QUICK: [&str; 4] = ["scenarios", "scanners", "sim", "config"];

#[test]
fn the_walk_throughs_quick_commands_run_as_written() {
    let dir = scratch("walkthrough-run");
    let mut ran = 0;
    let mut failures = Vec::new();
    for found in documented_commands() {
        let sub = found.text.split_whitespace().nth(1).unwrap_or("");
        let as_written = filled(&found.text) == found.text;
        if !QUICK.contains(&sub) || !as_written || found.text.contains("--ros2") {
            continue;
        }
        // A mention in prose (`tether sim --record`) is no command to run.
        if !bash(&dir, &found.text, true).0 {
            continue;
        }
        let (ok, said) = bash(&dir, &found.text, false);
        println!(
            "{}: {} ({})",
            found.at,
            found.text,
            if ok { "ok" } else { "FAILED" }
        );
        ran += 1;
        if !ok {
            failures.push(format!("{}: `{}`:\n{said}", found.at, found.text));
        }
    }
    println!("{ran} commands run as written, {} failed", failures.len());
    assert!(ran > 10, "too few commands run: {ran}");
    assert!(failures.is_empty(), "\n{}", failures.join("\n\n"));
    let _ = std::fs::remove_dir_all(&dir);
}
