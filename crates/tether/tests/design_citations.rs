//! The design belongs to the project (issue 18): the code cites `docs/design.md` by section
//! number, and every section it cites must exist there.
//!
//! A citation is the word "design" followed by a section number, optionally after
//! "section": `design 3.2`, `design section 4`, `(design 2.1, 4.1)`, `design 2.2 and 3.2`;
//! or the path of the document followed by one (`docs/design.md section 4.3`,
//! `docs/design.md, 5`). A section exists when the document has a heading that starts
//! with its number (`## 3. Vision`, `### 3.2 Monocular range and bearing`).
//!
//! Citations of the old design notes, which live outside the repository, must not come
//! back: a second test fails on any (a third checks that each section such a citation
//! would name exists in `docs/design.md`, which held while they were being replaced).

use std::collections::BTreeSet;
use std::fs;
use std::path::{Path, PathBuf};

/// The old notes' name, as the citations spell it (assembled so that this file does not
/// cite them itself).
const OLD_NOTES: &str = concat!("SP", "EC");

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The numbers of the document's headings: `## 3. Vision` gives `3`, `### 3.2 ...` gives
/// `3.2`. Lines inside fenced code blocks are not headings.
fn design_sections() -> BTreeSet<String> {
    let path = workspace().join("docs/design.md");
    let text =
        fs::read_to_string(&path).unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    let mut sections = BTreeSet::new();
    let mut fenced = false;
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            continue;
        }
        if fenced {
            continue;
        }
        let hashes = line.bytes().take_while(|&b| b == b'#').count();
        if !(2..=6).contains(&hashes) || !line[hashes..].starts_with(' ') {
            continue;
        }
        let Some(word) = line[hashes..].split_whitespace().next() else {
            continue;
        };
        let word = word.strip_suffix('.').unwrap_or(word);
        if let Some((number, len)) = section_number(word)
            && len == word.len()
        {
            sections.insert(number);
        }
    }
    sections
}

/// Every `.rs` file under `dir`, in a stable order (build output and hidden folders
/// left out).
fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = fs::read_dir(dir) else {
        return;
    };
    let mut paths: Vec<PathBuf> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
    paths.sort();
    for path in paths {
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
        if path.is_dir() {
            if name != "target" && !name.starts_with('.') {
                rust_files(&path, out);
            }
        } else if name.ends_with(".rs") {
            out.push(path);
        }
    }
}

/// The source files to check: every `.rs` file under `crates/` but this one, whose
/// comments and examples talk about citations without being any.
fn sources() -> Vec<(PathBuf, String)> {
    let root = workspace();
    let mut files = Vec::new();
    rust_files(&root.join("crates"), &mut files);
    assert!(
        files.len() > 100,
        "found only {} .rs files under {}",
        files.len(),
        root.join("crates").display()
    );
    files
        .into_iter()
        .filter(|p| !p.ends_with("tether/tests/design_citations.rs"))
        .filter_map(|p| {
            let text = fs::read_to_string(&p).ok()?;
            let shown = p.strip_prefix(&root).unwrap_or(&p).to_path_buf();
            Some((shown, text))
        })
        .collect()
}

/// A section number at the start of `s` (`4`, `3.2`, `11.10`) and its length in bytes.
fn section_number(s: &str) -> Option<(String, usize)> {
    let b = s.as_bytes();
    let digits = |from: usize| b[from..].iter().take_while(|c| c.is_ascii_digit()).count();
    let mut end = digits(0);
    if end == 0 {
        return None;
    }
    while end + 1 < b.len() && b[end] == b'.' && b[end + 1].is_ascii_digit() {
        end += 1 + digits(end + 1);
    }
    Some((s[..end].to_owned(), end))
}

/// Whether a section number in a list ends where a list item ends (not `5 m`, `0.3 s`).
fn ends_item(rest: &str) -> bool {
    match rest.chars().next() {
        None => true,
        Some(c) if ",;:)]'\"`.".contains(c) => true,
        Some(_) => rest.starts_with(" and ") || rest.trim().is_empty(),
    }
}

/// The section numbers cited after `keyword` in `line`: the first number right after it
/// (past "section" or "sections"), then any further ones listed with ", " or " and ".
/// `keyword` matches as a whole word; with `ignore_case` in any case. For "design", the
/// document's path `docs/design.md` (or `design.md`) also cites.
fn cited_sections(line: &str, keyword: &str, ignore_case: bool) -> Vec<String> {
    let haystack = if ignore_case {
        line.to_ascii_lowercase()
    } else {
        line.to_owned()
    };
    let needle = if ignore_case {
        keyword.to_ascii_lowercase()
    } else {
        keyword.to_owned()
    };
    let bytes = haystack.as_bytes();
    let mut found = Vec::new();
    let mut from = 0;
    while let Some(pos) = haystack[from..].find(&needle) {
        let at = from + pos;
        from = at + needle.len();
        if at > 0 && (bytes[at - 1].is_ascii_alphanumeric() || bytes[at - 1] == b'_') {
            continue;
        }
        let mut rest = &line[from..];
        if let Some(after) = rest.strip_prefix(".md") {
            // The document's path: separators, then perhaps a section.
            rest = after.trim_start_matches([' ', ',', ':', '#', '§']);
        } else {
            // The word: it must end here and be followed by a space.
            let trimmed = rest.trim_start();
            if trimmed.len() == rest.len() {
                continue;
            }
            rest = trimmed;
        }
        for word in ["sections ", "section ", "§"] {
            if rest
                .get(..word.len())
                .is_some_and(|start| start.eq_ignore_ascii_case(word))
            {
                rest = rest[word.len()..].trim_start();
                break;
            }
        }
        let Some((first, len)) = section_number(rest) else {
            continue;
        };
        rest = &rest[len..];
        if rest.starts_with(|c: char| c.is_ascii_alphanumeric() || c == '_') {
            continue;
        }
        found.push(first);
        'list: loop {
            for separator in [", and ", " and ", ", "] {
                if let Some(item) = rest.strip_prefix(separator)
                    && let Some((number, len)) = section_number(item)
                    && ends_item(&item[len..])
                {
                    found.push(number);
                    rest = &item[len..];
                    continue 'list;
                }
            }
            break;
        }
    }
    found
}

/// `(file:line, cited section)` for every citation after `keyword` in the sources.
fn citations(keyword: &str, ignore_case: bool) -> Vec<(String, String)> {
    let mut all = Vec::new();
    for (path, text) in sources() {
        for (i, line) in text.lines().enumerate() {
            for section in cited_sections(line, keyword, ignore_case) {
                all.push((format!("{}:{}", path.display(), i + 1), section));
            }
        }
    }
    all
}

#[test]
fn the_citation_parser_reads_what_the_code_writes() {
    let cite = |line: &str| cited_sections(line, "design", true);
    assert_eq!(cite("//! tether's vision (design section 3)."), ["3"]);
    assert_eq!(cite("(design 2.1, 4.1). Beams"), ["2.1", "4.1"]);
    assert_eq!(cite("in log order (design 4, 5), with"), ["4", "5"]);
    assert_eq!(
        cite("tilt, planar pose), design 2.2 and 3.2."),
        ["2.2", "3.2"]
    );
    assert_eq!(cite("(design 5, paper eq. 5-7; Julier)"), ["5"]);
    assert_eq!(
        cite("the paper's eq. 1-3 as design 3.2 restates them"),
        ["3.2"]
    );
    assert_eq!(cite("design section 6's gate at 95 %"), ["6"]);
    assert_eq!(cite("see docs/design.md section 11.10"), ["11.10"]);
    assert_eq!(cite("see docs/design.md, 4.3"), ["4.3"]);
    assert_eq!(cite("(design 5, 0.3 m apart)"), ["5"]);
    assert!(cite("the design of the base, 3 wheels").is_empty());
    assert!(cite("a redesign 4 times; designs 2; design_3").is_empty());
    assert!(cite("docs/design.md describes it").is_empty());
    let old = |line: &str| cited_sections(line, OLD_NOTES, false);
    assert_eq!(old(&format!("({OLD_NOTES} 4.4, 4.5)")), ["4.4", "4.5"]);
    assert!(old(&format!("({OLD_NOTES}: 0.1-0.2 m)")).is_empty());
}

#[test]
fn every_design_citation_names_a_section_of_the_document() {
    let sections = design_sections();
    let missing_top: Vec<String> = (1..=13)
        .map(|n| n.to_string())
        .filter(|n| !sections.contains(n))
        .collect();
    assert!(
        missing_top.is_empty(),
        "docs/design.md lacks the numbered sections {missing_top:?} (headings like `## 3. Vision`); \
         it has {sections:?}"
    );
    let wrong: Vec<String> = citations("design", true)
        .into_iter()
        .filter(|(_, section)| !sections.contains(section))
        .map(|(at, section)| format!("{at}: design {section}"))
        .collect();
    assert!(
        wrong.is_empty(),
        "{} citation(s) of sections that docs/design.md does not have (its sections: {sections:?}):\n{}",
        wrong.len(),
        wrong.join("\n")
    );
}

#[test]
fn every_section_the_old_notes_are_cited_for_exists_in_the_document() {
    // Until the old citations are replaced, each must name a section of docs/design.md,
    // so that replacing the word is all the replacement takes.
    let sections = design_sections();
    let wrong: Vec<String> = citations(OLD_NOTES, false)
        .into_iter()
        .filter(|(_, section)| !sections.contains(section))
        .map(|(at, section)| format!("{at}: {OLD_NOTES} {section}"))
        .collect();
    assert!(
        wrong.is_empty(),
        "{} citation(s) whose section docs/design.md does not have:\n{}",
        wrong.len(),
        wrong.join("\n")
    );
}

#[test]

fn no_citation_points_outside_the_repository() {
    let mut outside = Vec::new();
    for (path, text) in sources() {
        for (i, line) in text.lines().enumerate() {
            let mut from = 0;
            while let Some(pos) = line[from..].find(OLD_NOTES) {
                let at = from + pos;
                from = at + OLD_NOTES.len();
                let before = line[..at].chars().next_back();
                let after = line[from..].chars().next();
                let word = |c: Option<char>| c.is_some_and(|c| c.is_alphanumeric() || c == '_');
                if !word(before) && !word(after) {
                    outside.push(format!("{}:{}: {}", path.display(), i + 1, line.trim()));
                    break;
                }
            }
        }
    }
    assert!(
        outside.is_empty(),
        "{} line(s) cite the design notes outside the repository ({OLD_NOTES}); cite \
         docs/design.md instead (`design N.M`):\n{}",
        outside.len(),
        outside.join("\n")
    );
}
