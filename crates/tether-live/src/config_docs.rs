//! Every pipeline parameter with its default and its meaning, in the TOML layout that
//! `track`, `replay`, `sim` and a robot's `[pipeline]` read (`tether config defaults`).
//! The meanings are the first sentences of the fields' doc comments, which each
//! configuration type lists itself (`derive(ConfigDocs)`, gathered by
//! `tether_pipeline::config_docs`); units are in the key names (`_m`, `_s`, `_mps`, ...)
//! and at the end of each meaning.

use std::fmt::Write as _;
use std::sync::OnceLock;

use tether_core::config_docs::FieldDoc;
use tether_pipeline::PipelineConfig;

/// Every configuration type's fields.
fn docs() -> &'static [FieldDoc] {
    static DOCS: OnceLock<Vec<FieldDoc>> = OnceLock::new();
    DOCS.get_or_init(tether_pipeline::config_docs::config_docs)
}

/// The type and first doc sentence of `field` of struct `name`, if it has one.
fn doc_of(name: &str, field: &str) -> Option<(&'static str, &'static str)> {
    docs()
        .iter()
        .find(|d| d.strukt == name && d.field == field)
        .map(|d| (d.ty, d.doc))
}

/// The defaults as annotated TOML, and how many keys had no doc comment.
pub fn annotated_defaults() -> Result<(String, usize), toml::ser::Error> {
    let header = "# tether's pipeline parameters and their defaults (`tether config defaults`).\n\
         # The same layout as a --config file of track, replay and eval-target, and as\n\
         # the [pipeline] tables of a robot's config, which refuses (by name) the keys\n\
         # its own tables hold: laser.mount, camera, and the limits [robot] sets.\n\
         # Every table and key is optional. More scanners than one: an [[extra_lasers]]\n\
         # entry each, with the frame_id of its scans and an [extra_lasers.laser] table\n\
         # of [laser]'s keys (design 5.7).\n\n";
    annotated(header, &PipelineConfig::default(), &|_| None)
}

/// `config` as annotated TOML after `header`, each key with its meaning and, where
/// `source` names one for its dotted key (`safety.laser_timeout_s`), where its value
/// came from at the end of its line; and how many keys had no doc comment.
pub fn annotated(
    header: &str,
    config: &PipelineConfig,
    source: &dyn Fn(&str) -> Option<String>,
) -> Result<(String, usize), toml::ser::Error> {
    let table = toml::Table::try_from(config)?;
    let mut out = String::from(header);
    let mut undocumented = 0;
    write_table(
        &mut out,
        ("", false),
        Some("PipelineConfig"),
        &table,
        &mut undocumented,
        source,
    );
    Ok((out, undocumented))
}

/// Writes `table` (at dotted `path`, of type `strukt`) as annotated TOML: its keys, then
/// its tables, then its lists of tables. `element`: it is one table of a list, whose
/// `[[path]]` header the caller wrote.
fn write_table(
    out: &mut String,
    (path, element): (&str, bool),
    strukt: Option<&str>,
    table: &toml::Table,
    undocumented: &mut usize,
    source: &dyn Fn(&str) -> Option<String>,
) {
    // A tagged enum's tag (`rule = "euclidean"`) is said by the enum's own doc.
    let doc = |key: &str| {
        strukt.and_then(|s| {
            doc_of(s, key).or_else(|| {
                let (_, d) = doc_of(s, "<enum>")?;
                table
                    .get(key)
                    .is_some_and(toml::Value::is_str)
                    .then_some(("", d))
            })
        })
    };
    // The dotted key of `key` in this table (`safety.laser_timeout_s`).
    let dotted = |key: &str| {
        if path.is_empty() {
            key.to_owned()
        } else {
            format!("{path}.{key}")
        }
    };
    // Lists of tables (`[[extra_lasers]]`) come last, a table each.
    let list_of_tables = |v: &toml::Value| {
        v.as_array()
            .is_some_and(|a| !a.is_empty() && a.iter().all(toml::Value::is_table))
    };
    let (lists, rest): (Vec<_>, Vec<_>) = table.iter().partition(|(_, v)| list_of_tables(v));
    let (tables, scalars): (Vec<_>, Vec<_>) = rest.into_iter().partition(|(_, v)| v.is_table());
    if !path.is_empty() && !scalars.is_empty() && !element {
        let _ = writeln!(out, "\n[{path}]");
    }
    for (key, value) in scalars {
        match doc(key) {
            Some((_, d)) if !d.is_empty() => {
                let _ = writeln!(out, "# {d}");
            }
            _ => *undocumented += 1,
        }
        match source(&dotted(key)) {
            Some(from) => {
                let _ = writeln!(out, "{key} = {value}  # {from}");
            }
            None => {
                let _ = writeln!(out, "{key} = {value}");
            }
        }
    }
    // Optional keys, unset by default: said, commented out.
    for d in docs()
        .iter()
        .filter(|d| Some(d.strukt) == strukt && d.ty == "Option" && !table.contains_key(d.field))
    {
        let _ = writeln!(out, "# {}\n# {} = (not set by default)", d.doc, d.field);
    }
    for (key, value) in tables {
        let inner = dotted(key);
        let found = doc(key);
        if let Some((_, d)) = found
            && !d.is_empty()
        {
            let _ = write!(out, "\n# [{inner}]: {d}");
        }
        if let Some(t) = value.as_table() {
            write_table(
                out,
                (&inner, false),
                found.map(|(ty, _)| ty),
                t,
                undocumented,
                source,
            );
        }
    }
    for (key, value) in lists {
        let inner = dotted(key);
        let found = doc(key);
        if let Some((_, d)) = found
            && !d.is_empty()
        {
            let _ = write!(out, "\n# [[{inner}]]: {d}");
        }
        // Where the list came from, once; its tables' keys are the list's.
        let from = source(&inner).map_or(String::new(), |f| format!("  # {f}"));
        for t in value
            .as_array()
            .into_iter()
            .flatten()
            .filter_map(toml::Value::as_table)
        {
            let _ = writeln!(out, "\n[[{inner}]]{from}");
            write_table(
                out,
                (&inner, true),
                found.map(|(ty, _)| ty),
                t,
                undocumented,
                &|_| None,
            );
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, reason = "tests fail loudly")]

    use super::*;

    #[test]
    fn the_defaults_read_back_as_the_defaults_and_every_key_says_what_it_is() {
        let (text, undocumented) = annotated_defaults().unwrap();
        let back: PipelineConfig = toml::from_str(&text).unwrap();
        assert_eq!(back, PipelineConfig::default());
        assert_eq!(undocumented, 0, "keys without a meaning:\n{text}");
        assert!(text.contains("[safety]\n"), "{text}");
        assert!(text.contains("laser_timeout_s = 0.3"), "{text}");
        assert!(
            text.contains("\n# model = (not set by default)\n"),
            "{text}"
        );
    }

    #[test]
    fn a_list_of_tables_is_written_a_table_each_and_reads_back() {
        let mut config = PipelineConfig::default();
        for (frame, x_m) in [("rear_laser", -0.1), ("left_laser", 0.0)] {
            let mut laser = config.laser.clone();
            laser.mount.x_m = x_m;
            config.extra_lasers.push(tether_core::ExtraLaser {
                frame_id: frame.into(),
                laser,
            });
        }
        let (text, undocumented) = annotated("", &config, &|key| {
            (key == "extra_lasers").then(|| "robot.toml: [[laser]]".to_owned())
        })
        .unwrap();
        let back: PipelineConfig = toml::from_str(&text).unwrap();
        assert_eq!(back, config);
        assert_eq!(undocumented, 0, "{text}");
        assert_eq!(
            text.matches("\n[[extra_lasers]]  # robot.toml: [[laser]]\n")
                .count(),
            2,
            "{text}"
        );
        assert!(text.contains("\n[extra_lasers.laser.mount]\n"), "{text}");
        assert!(text.contains("frame_id = \"left_laser\"\n"), "{text}");
    }
}
