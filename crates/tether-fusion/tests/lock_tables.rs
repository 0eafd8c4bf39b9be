//! The rules of the target lock are written down once in `docs/design.md` (5.6, 11.4),
//! and the tables there match the code (issue 31): every transition with the states it
//! goes from and to, every refusal, every state's memory, and the table of "may this
//! track be the target?" that `target/eligible.rs` holds in its doc comment.

#![allow(
    clippy::unwrap_used,
    reason = "test code: a failed unwrap is a failed test"
)]

use std::collections::BTreeSet;
use std::path::Path;

use tether_fusion::{Refusal, Transition};

fn read(relative: &str) -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(relative);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn design() -> String {
    read("../../docs/design.md")
}

/// The rows of the table whose header line is `header`, as cells (without the
/// separator line).
fn table(text: &str, header: &str) -> Vec<Vec<String>> {
    let mut lines = text.lines().skip_while(|l| l.trim() != header);
    assert!(lines.next().is_some(), "no table headed {header:?}");
    lines
        .skip(1)
        .take_while(|l| l.starts_with('|'))
        .map(|l| {
            l.trim_matches('|')
                .split('|')
                .map(|c| c.trim().to_owned())
                .collect()
        })
        .collect()
}

/// `` `chosen` `` as `chosen`.
fn unquote(cell: &str) -> &str {
    cell.trim_matches('`')
}

#[test]
fn the_design_lists_every_transition_with_its_states() {
    let rows = table(&design(), "| transition | from | to | when |");
    let written: Vec<(String, String, String)> = rows
        .iter()
        .map(|r| (unquote(&r[0]).to_owned(), r[1].clone(), r[2].clone()))
        .collect();
    let code: Vec<(String, String, String)> = Transition::ALL
        .iter()
        .map(|t| {
            let (from, to) = t.from_to();
            (t.name().to_owned(), from.to_owned(), to.to_owned())
        })
        .collect();
    assert_eq!(written, code);
}

#[test]
fn the_design_names_every_refusal() {
    let rows = table(&design(), "| refusal | the track |");
    let written: BTreeSet<&str> = rows.iter().map(|r| unquote(&r[0])).collect();
    let code: BTreeSet<&str> = Refusal::ALL.iter().map(|r| r.name()).collect();
    assert_eq!(written, code);
}

#[test]
fn the_design_says_what_each_state_remembers() {
    let rows = table(&design(), "| state | remembers |");
    let written: Vec<&str> = rows.iter().map(|r| unquote(&r[0])).collect();
    assert_eq!(written, ["Searching", "Locked", "Lost"]);
}

#[test]
fn the_table_of_who_may_be_the_target_is_the_same_in_code_and_design() {
    let code: Vec<String> = read("src/target/eligible.rs")
        .lines()
        .filter_map(|l| l.strip_prefix("//! "))
        .filter(|l| l.starts_with('|'))
        .map(str::to_owned)
        .collect();
    let header = code.first().unwrap().clone();
    let design = design();
    let written: Vec<&str> = design
        .lines()
        .skip_while(|l| *l != header)
        .take_while(|l| l.starts_with('|'))
        .collect();
    assert_eq!(written, code);
    assert_eq!(code.len(), 7, "a header, a separator and five checks");
}
