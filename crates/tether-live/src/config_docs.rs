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

/// The keys of `config` whose value is outside the range its field admits
/// (`#[config(range = ...)]`, design 13): each its dotted key (`safety.laser_timeout_s`,
/// `extra_lasers[0].laser.range_max_m`) and why, `is -1, must be > 0`. The one check of
/// every bounded number, whichever file or `-p` set it.
pub fn out_of_range(config: &PipelineConfig) -> Vec<(String, String)> {
    let mut out = Vec::new();
    match toml::Table::try_from(config) {
        Ok(table) => check_table("", "PipelineConfig", &table, &mut out),
        Err(e) => out.push((String::new(), format!("cannot be read as TOML: {e}"))),
    }
    out
}

/// [`out_of_range`] of `table` (at dotted `path`, of type `strukt`).
fn check_table(path: &str, strukt: &str, table: &toml::Table, out: &mut Vec<(String, String)>) {
    for (key, value) in table {
        let dotted = if path.is_empty() {
            key.clone()
        } else {
            format!("{path}.{key}")
        };
        let Some(field) = entry(strukt, key) else {
            continue;
        };
        match value {
            toml::Value::Table(inner) => check_table(&dotted, field.ty, inner, out),
            toml::Value::Array(items) => {
                for (i, item) in items.iter().enumerate() {
                    if let Some(inner) = item.as_table() {
                        check_table(&format!("{dotted}[{i}]"), field.ty, inner, out);
                    }
                }
            }
            number => {
                let x = number
                    .as_float()
                    .or_else(|| number.as_integer().map(|i| i as f64));
                if let (Some(range), Some(x)) = (field.range, x)
                    && !range.admits(x)
                {
                    out.push((dotted, format!("is {number}, must be {}", range.text)));
                }
            }
        }
    }
}

/// The registry's entry of a dotted key of the pipeline's configuration
/// (`follower.follow_distance_m`), if it has one.
pub fn field_doc(dotted: &str) -> Option<&'static FieldDoc> {
    let mut strukt = "PipelineConfig";
    let mut found = None;
    for part in dotted.split('.') {
        let d = entry(strukt, part)?;
        strukt = d.ty;
        found = Some(d);
    }
    found
}

/// The unit a key's name carries (`_m`: metres, `_radps`: rad/s, ...; design 1), or
/// `""`.
pub fn unit_of_key(dotted: &str) -> &'static str {
    const UNITS: [(&str, &str); 13] = [
        ("_mps2", "m/s^2"),
        ("_mps3", "m/s^3"),
        ("_mps", "m/s"),
        ("_radps2", "rad/s^2"),
        ("_radps3", "rad/s^3"),
        ("_radps", "rad/s"),
        ("_rad", "rad"),
        ("_kgm2", "kg m^2"),
        ("_kg", "kg"),
        ("_px", "px"),
        ("_hz", "Hz"),
        ("_m", "m"),
        ("_s", "s"),
    ];
    let name = dotted.rsplit('.').next().unwrap_or(dotted);
    UNITS
        .iter()
        .find(|(suffix, _)| name.ends_with(suffix))
        .map_or("", |(_, unit)| unit)
}

/// The registry's entry of `field` of struct (or enum) `name`.
fn entry(name: &str, field: &str) -> Option<&'static FieldDoc> {
    docs().iter().find(|d| d.strukt == name && d.field == field)
}

/// The range of `field` of struct `name`, if it is bounded.
fn range_of(name: &str, field: &str) -> Option<tether_core::config_docs::ValueRange> {
    entry(name, field).and_then(|d| d.range)
}

/// The type and first doc sentence of `field` of struct `name`, if it has one.
fn doc_of(name: &str, field: &str) -> Option<(&'static str, &'static str)> {
    entry(name, field).map(|d| (d.ty, d.doc))
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
                let range = strukt
                    .and_then(|s| range_of(s, key))
                    .map_or(String::new(), |r| format!(" ({})", r.text));
                let _ = writeln!(out, "# {d}{range}");
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

    /// Every bounded key under `table` (of type `strukt`, at `path`): its path, range and
    /// whether it is an integer.
    fn bounded(
        path: &[String],
        strukt: &str,
        table: &toml::Table,
        out: &mut Vec<(Vec<String>, tether_core::config_docs::ValueRange, bool)>,
    ) {
        for (key, value) in table {
            let Some(field) = entry(strukt, key) else {
                continue;
            };
            let mut here = path.to_vec();
            here.push(key.clone());
            match (value, field.range) {
                (toml::Value::Table(inner), _) => bounded(&here, field.ty, inner, out),
                (number, Some(range)) => out.push((here, range, number.is_integer())),
                _ => {}
            }
        }
    }

    /// The registry's ranges are what the pipeline's own checks refuse: a value just
    /// outside each bound of each key is named by the loader's check and refused by
    /// `Pipeline::new`; every default is inside its range.
    #[test]
    fn every_range_is_enforced_and_every_default_is_in_it() {
        let defaults = toml::Table::try_from(PipelineConfig::default()).unwrap();
        assert!(out_of_range(&PipelineConfig::default()).is_empty());
        let mut keys = Vec::new();
        bounded(&[], "PipelineConfig", &defaults, &mut keys);
        assert!(keys.len() > 100, "{} bounded keys", keys.len());
        let (mut checked, mut taken) = (0, Vec::new());
        for (path, range, integer) in keys {
            let dotted = path.join(".");
            let outside = [
                range.min.map(|(lo, inclusive)| {
                    if !inclusive {
                        lo
                    } else if integer {
                        lo - 1.0
                    } else {
                        lo - 1e-3 * (1.0 + lo.abs())
                    }
                }),
                range.max.map(|(hi, inclusive)| {
                    if !inclusive {
                        hi
                    } else if integer {
                        hi + 1.0
                    } else {
                        hi + 1e-3 * (1.0 + hi.abs())
                    }
                }),
            ];
            for x in outside.into_iter().flatten() {
                let mut table = defaults.clone();
                let (last, parents) = path.split_last().unwrap();
                let mut at = &mut table;
                for key in parents {
                    at = at.get_mut(key).and_then(toml::Value::as_table_mut).unwrap();
                }
                let value = if integer {
                    toml::Value::Integer(x as i64)
                } else {
                    toml::Value::Float(x)
                };
                at.insert(last.clone(), value);
                let config: PipelineConfig = match table.try_into() {
                    Ok(c) => c,
                    // An unsigned count below zero does not even read.
                    Err(_) if integer && x < 0.0 => continue,
                    Err(e) => panic!("{dotted} = {x}: {e}"),
                };
                let named = out_of_range(&config);
                assert!(
                    named.iter().any(|(k, _)| *k == dotted),
                    "{dotted} = {x} is outside {} but not named: {named:?}",
                    range.text
                );
                if tether_pipeline::Pipeline::new(config, None).is_ok() {
                    taken.push(format!("{dotted} = {x} (outside {})", range.text));
                }
                checked += 1;
            }
        }
        assert!(checked > 100, "{checked} values checked");
        assert!(
            taken.is_empty(),
            "outside their range, yet the pipeline takes: {taken:#?}"
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
