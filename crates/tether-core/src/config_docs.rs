//! What each key of tether's configuration means: every configuration struct and enum
//! derives [`ConfigDocs`] (`tether-config-derive`), which lists its named fields with
//! the last segment of their type and the first sentence of their doc comment (ending
//! with the unit). `tether config defaults` and `tether config show` print each key with
//! it (design 13); a test there fails on a key without one.

pub use tether_config_derive::ConfigDocs;

/// One field of a configuration struct (or of an enum's variant).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FieldDoc {
    /// The struct's (or enum's) name, e.g. `SafetyConfig`.
    pub strukt: &'static str,
    /// The field's name (`<enum>` for an enum's own doc, which says what its tag is).
    pub field: &'static str,
    /// The last path segment of its type without generics (`Option<f64>` -> `Option`;
    /// a list's element type, `Vec<ExtraLaser>` -> `ExtraLaser`).
    pub ty: &'static str,
    /// The first sentence of its doc comment.
    pub doc: &'static str,
}

/// A configuration struct or enum whose fields are documented ([`FieldDoc`]).
pub trait ConfigDocs {
    /// Its fields, in declaration order.
    const FIELDS: &'static [FieldDoc];
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What the derive lists.
    #[allow(dead_code, reason = "only the derive reads the fields")]
    #[derive(ConfigDocs)]
    struct Example {
        /// Stop when the newest scan is older than this, s.
        timeout_s: f64,
        /// A sentence that goes on
        /// over two lines, m.
        /// A second one, left out.
        over_lines_m: f64,
        /// Set or not, rad.
        maybe: Option<f64>,
        /// In another crate.
        model: crate::laser::LaserModel,
        /// A list of tables.
        more: Vec<crate::laser::ExtraLaser>,
        undocumented: bool,
    }

    /// How a thing is done.
    #[allow(dead_code, reason = "only the derive reads the variants")]
    #[derive(ConfigDocs)]
    enum Kind {
        /// The plain way.
        Plain,
        /// With a margin.
        Margin {
            /// The margin, m.
            margin_m: f64,
        },
    }

    #[test]
    fn each_field_has_its_type_s_last_segment_and_its_first_sentence() {
        let doc = |field: &str| {
            Example::FIELDS
                .iter()
                .find(|d| d.field == field)
                .map(|d| (d.strukt, d.ty, d.doc))
        };
        assert_eq!(
            doc("timeout_s"),
            Some((
                "Example",
                "f64",
                "Stop when the newest scan is older than this, s."
            ))
        );
        assert_eq!(
            doc("over_lines_m"),
            Some((
                "Example",
                "f64",
                "A sentence that goes on over two lines, m."
            ))
        );
        assert_eq!(doc("maybe").map(|d| d.1), Some("Option"));
        assert_eq!(doc("model").map(|d| d.1), Some("LaserModel"));
        assert_eq!(doc("more").map(|d| d.1), Some("ExtraLaser"));
        assert_eq!(doc("undocumented"), Some(("Example", "bool", "")));
        assert_eq!(
            Kind::FIELDS,
            &[
                FieldDoc {
                    strukt: "Kind",
                    field: "<enum>",
                    ty: "",
                    doc: "How a thing is done."
                },
                FieldDoc {
                    strukt: "Kind",
                    field: "margin_m",
                    ty: "f64",
                    doc: "The margin, m."
                }
            ]
        );
    }
}
