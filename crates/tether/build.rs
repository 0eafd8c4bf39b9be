//! Collects the doc comments of the configuration structs of the pipeline's crates, so
//! that `tether config defaults` can print every parameter with its meaning (the first
//! line of the field's doc comment, which ends with the unit) next to its default.
//!
//! Written here rather than with a schema crate: the structs are plain serde structs
//! whose doc comments already say everything, and reading them from the sources costs
//! no dependency. The generated table is `struct name -> [(field, type, doc)]`.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Crates whose `src/` holds configuration structs.
const CRATES: &[&str] = &[
    "tether-core",
    "tether-laser",
    "tether-fusion",
    "tether-control",
    "tether-pipeline",
    "tether-scanmatch",
];

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let mut entries: Vec<PathBuf> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
    entries.sort();
    for path in entries {
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// `(struct, field, type, first doc line)` of every `pub` field of every `pub struct`
/// with named fields in `text`; for a `pub enum`, its own doc as field `<enum>` and
/// the named fields of its variants (a tagged enum is a TOML table of them).
fn fields(text: &str) -> Vec<(String, String, String, String)> {
    let mut out = Vec::new();
    let mut current: Option<String> = None;
    let mut in_enum = false;
    let mut doc: Option<String> = None;
    for line in text.lines() {
        let t = line.trim();
        let item = t
            .strip_prefix("pub struct ")
            .map(|r| (r, false))
            .or_else(|| t.strip_prefix("pub enum ").map(|r| (r, true)));
        if let Some((rest, is_enum)) = item {
            let name: String = rest
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            current = (rest.trim_end().ends_with('{') && !name.is_empty()).then_some(name);
            in_enum = is_enum;
            if let (Some(name), true) = (&current, is_enum) {
                out.push((
                    name.clone(),
                    "<enum>".to_string(),
                    String::new(),
                    doc.clone().unwrap_or_default(),
                ));
            }
            doc = None;
            continue;
        }
        if current.is_none() {
            // Doc comments of items outside structs, for the next enum.
            match t.strip_prefix("///") {
                Some(d) if doc.is_none() => doc = Some(d.trim().to_string()),
                Some(d) => {
                    let so_far = doc.get_or_insert_with(String::new);
                    if !so_far.ends_with('.') && !d.trim().is_empty() {
                        so_far.push(' ');
                        so_far.push_str(d.trim());
                    }
                }
                None if t.starts_with("#[") => {}
                None => doc = None,
            }
            continue;
        }
        let Some(name) = &current else {
            continue;
        };
        if t == "}" && line.starts_with('}') {
            current = None;
            continue;
        }
        if let Some(d) = t.strip_prefix("///") {
            // The first line of the comment: a sentence may go on over a few lines,
            // taken up to the first one that ends it.
            let d = d.trim();
            match &mut doc {
                None => doc = Some(d.to_string()),
                Some(so_far) if !so_far.ends_with('.') && !d.is_empty() => {
                    so_far.push(' ');
                    so_far.push_str(d);
                }
                _ => {}
            }
            continue;
        }
        if t.starts_with("#[") || t.starts_with("//") {
            continue;
        }
        let field_line = if in_enum {
            // Variant fields have no `pub`: `distance_m: f64,`.
            t.split_once(':')
                .filter(|(f, _)| {
                    f.chars()
                        .all(|c| c.is_ascii_lowercase() || c == '_' || c.is_ascii_digit())
                })
                .map(|_| t)
        } else {
            t.strip_prefix("pub ")
        };
        if let Some(rest) = field_line
            && let Some((field, ty)) = rest.split_once(':')
        {
            let ty = ty.trim().trim_end_matches(',');
            // The last path segment without generics: `tether_core::LaserModel` ->
            // `LaserModel`, `Option<f64>` -> `Option`.
            let base = ty.split('<').next().unwrap_or(ty);
            let base = base.rsplit("::").next().unwrap_or(base).trim().to_string();
            out.push((
                name.clone(),
                field.trim().to_string(),
                base,
                doc.take().unwrap_or_default(),
            ));
        }
        doc = None;
    }
    out
}

fn main() {
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap_or_default());
    let mut files = Vec::new();
    for krate in CRATES {
        let src = manifest.join("..").join(krate).join("src");
        println!("cargo:rerun-if-changed={}", src.display());
        rust_files(&src, &mut files);
    }
    let mut all = Vec::new();
    for file in &files {
        if let Ok(text) = std::fs::read_to_string(file) {
            all.extend(fields(&text));
        }
    }
    let mut code = String::from(
        "/// `(struct, field, type, doc)` of the configuration structs (from build.rs).\n\
         pub const CONFIG_DOCS: &[(&str, &str, &str, &str)] = &[\n",
    );
    for (s, f, t, d) in &all {
        let _ = writeln!(code, "    ({s:?}, {f:?}, {t:?}, {d:?}),");
    }
    code.push_str("];\n");
    let out = PathBuf::from(std::env::var("OUT_DIR").unwrap_or_default()).join("config_docs.rs");
    if let Err(e) = std::fs::write(&out, code) {
        println!("cargo:warning=cannot write {}: {e}", out.display());
    }
}
