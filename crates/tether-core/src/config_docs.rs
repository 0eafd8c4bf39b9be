//! What each key of tether's configuration means: every configuration struct and enum
//! derives [`ConfigDocs`] (`tether-config-derive`), which lists its named fields with
//! the last segment of their type and the first sentence of their doc comment (ending
//! with the unit). `tether config defaults` and `tether config show` print each key with
//! it (design 13); a test there fails on a key without one.

pub use tether_config_derive::ConfigDocs;

/// One field of a configuration struct (or of an enum's variant).
#[derive(Debug, Clone, Copy, PartialEq)]
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
    /// The values a number admits (`#[config(range = "> 0")]`), if it is bounded.
    pub range: Option<ValueRange>,
}

/// The values a number of the configuration admits: `text` as written beside the field
/// (`"> 0, <= 1"`), and its bounds, each with whether it is admitted itself.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ValueRange {
    /// The conditions as written, e.g. `> 0, <= 1`.
    pub text: &'static str,
    /// The lower bound and whether it is admitted.
    pub min: Option<(f64, bool)>,
    /// The upper bound and whether it is admitted.
    pub max: Option<(f64, bool)>,
}

impl ValueRange {
    /// Whether `x` is in the range (never NaN).
    pub fn admits(&self, x: f64) -> bool {
        let above = self
            .min
            .is_none_or(|(lo, inclusive)| if inclusive { x >= lo } else { x > lo });
        let below = self
            .max
            .is_none_or(|(hi, inclusive)| if inclusive { x <= hi } else { x < hi });
        !x.is_nan() && above && below
    }
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
        /// A fraction.
        #[config(range = "> 0, <= 1")]
        fraction: f64,
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
        let fraction = Example::FIELDS
            .iter()
            .find(|d| d.field == "fraction")
            .and_then(|d| d.range)
            .unwrap_or_else(|| panic!("no range"));
        assert_eq!(fraction.text, "> 0, <= 1");
        assert_eq!(
            (fraction.min, fraction.max),
            (Some((0.0, false)), Some((1.0, true)))
        );
        let admitted: Vec<bool> = [-1.0, 0.0, 1e-9, 0.5, 1.0, 1.5, f64::NAN]
            .iter()
            .map(|&x| fraction.admits(x))
            .collect();
        assert_eq!(admitted, [false, false, true, true, true, false, false]);
        assert_eq!(
            Kind::FIELDS,
            &[
                FieldDoc {
                    strukt: "Kind",
                    field: "<enum>",
                    ty: "",
                    doc: "How a thing is done.",
                    range: None,
                },
                FieldDoc {
                    strukt: "Kind",
                    field: "margin_m",
                    ty: "f64",
                    doc: "The margin, m.",
                    range: None,
                }
            ]
        );
    }
}
