//! The ROS 2 command line: `--ros-args` (remapping, parameters, node name and
//! namespace) and `ROS_DOMAIN_ID`, as `rcl` reads them.
//!
//! ```text
//! tether ros2 --ros-args -r scan:=/front/scan -r __ns:=/robot1 -p follow_distance:=1.5
//! ```
//!
//! A `--ros-args` block runs to a lone `--` or to the end; there may be several. Inside
//! it: `-r`/`--remap FROM:=TO` (`NODE:FROM:=TO` applies only to the node called
//! `NODE`), with the special names `__ns` and `__node` (also `__name`);
//! `-p`/`--param NAME:=VALUE`, whose value is typed as a YAML scalar (`true`, `42`,
//! `1.5`, anything else a string; quotes keep a string); and the logging flags, which
//! are accepted and left to tether's own `-v`. Anything else is an error that names
//! the argument, as `rcl` refuses it.

use std::collections::BTreeMap;

/// A parameter value as given on the command line.
#[derive(Debug, Clone, PartialEq)]
pub enum ParamValue {
    /// `true` / `false` (YAML 1.2 spellings, any case).
    Bool(bool),
    /// A whole number.
    Integer(i64),
    /// A number with a fraction or an exponent (also `.inf`, `.nan`).
    Double(f64),
    /// Anything else, or a quoted value.
    String(String),
}

impl ParamValue {
    /// Types a value as YAML does a plain scalar.
    pub fn parse(text: &str) -> ParamValue {
        let t = text.trim();
        for quote in ['"', '\''] {
            if let Some(inner) = t.strip_prefix(quote).and_then(|s| s.strip_suffix(quote)) {
                return ParamValue::String(inner.to_owned());
            }
        }
        match t.to_ascii_lowercase().as_str() {
            "true" => return ParamValue::Bool(true),
            "false" => return ParamValue::Bool(false),
            ".inf" | "+.inf" => return ParamValue::Double(f64::INFINITY),
            "-.inf" => return ParamValue::Double(f64::NEG_INFINITY),
            ".nan" => return ParamValue::Double(f64::NAN),
            _ => {}
        }
        if let Ok(i) = t.parse::<i64>() {
            return ParamValue::Integer(i);
        }
        let numeric = t
            .chars()
            .all(|c| c.is_ascii_digit() || matches!(c, '.' | 'e' | 'E' | '+' | '-'));
        if numeric
            && t.chars().any(|c| c.is_ascii_digit())
            && let Ok(x) = t.parse::<f64>()
        {
            return ParamValue::Double(x);
        }
        ParamValue::String(t.to_owned())
    }

    /// A number (integers are numbers too), for parameters given in SI units.
    pub fn as_f64(&self) -> Option<f64> {
        match self {
            ParamValue::Integer(i) => Some(*i as f64),
            ParamValue::Double(x) => Some(*x),
            _ => None,
        }
    }

    /// The value as a string, for names (frames, topics).
    pub fn as_str(&self) -> Option<&str> {
        match self {
            ParamValue::String(s) => Some(s),
            _ => None,
        }
    }

    /// A boolean.
    pub fn as_bool(&self) -> Option<bool> {
        match self {
            ParamValue::Bool(b) => Some(*b),
            _ => None,
        }
    }
}

/// One `-r FROM:=TO`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Remap {
    /// Only for the node of this name (`NODE:FROM:=TO`); `None`: for every node.
    pub node: Option<String>,
    /// The name as the node asks for it (`scan`, `/scan`).
    pub from: String,
    /// What it becomes.
    pub to: String,
}

/// What `--ros-args` and the environment say.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RosArgs {
    /// Topic remappings, in the order given (the first that matches wins, as in `rcl`).
    pub remaps: Vec<Remap>,
    /// `-p NAME:=VALUE`; a later value of the same name replaces an earlier one.
    pub params: BTreeMap<String, ParamValue>,
    /// `__node:=NAME`.
    pub node_name: Option<String>,
    /// `__ns:=/NS`.
    pub namespace: Option<String>,
}

/// A command line `rcl` would refuse.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ArgsError {
    /// A flag without its value.
    #[error("`{0}` needs a value after it")]
    MissingValue(String),
    /// `-r` or `-p` without `:=`.
    #[error("`{flag} {value}`: expected NAME:=VALUE")]
    NoAssignment {
        /// `-r` or `-p`.
        flag: String,
        /// What was given.
        value: String,
    },
    /// A name that ROS 2 does not allow.
    #[error(
        "`{0}` is not a valid ROS 2 name (letters, digits, `_`, `/`; not starting with a digit)"
    )]
    BadName(String),
    /// An argument inside `--ros-args` that is not a ROS 2 one.
    #[error(
        "`{0}` inside --ros-args is not a ROS 2 argument (-r FROM:=TO, -p NAME:=VALUE, \
         --params-file FILE, --log-level LEVEL; end the block with `--`)"
    )]
    Unknown(String),
    /// `--params-file`: not read yet.
    #[error(
        "--params-file {0}: parameter files are not read yet; give each parameter with \
         -p NAME:=VALUE"
    )]
    ParamsFile(String),
    /// `ROS_DOMAIN_ID` out of range.
    #[error("ROS_DOMAIN_ID={0}: must be a whole number from 0 to 232")]
    DomainId(String),
}

/// Whether `name` is a ROS 2 name (`rcl`'s rules, simplified: tokens of letters,
/// digits and `_` between `/`, none starting with a digit, a leading `~` allowed).
pub fn is_valid_name(name: &str) -> bool {
    let body = name.strip_prefix('~').unwrap_or(name);
    let body = body.strip_prefix('/').unwrap_or(body);
    !body.is_empty()
        && body.split('/').all(|token| {
            !token.is_empty()
                && !token.starts_with(|c: char| c.is_ascii_digit())
                && token.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
        })
}

fn assignment<'a>(flag: &str, value: &'a str) -> Result<(&'a str, &'a str), ArgsError> {
    value
        .split_once(":=")
        .ok_or_else(|| ArgsError::NoAssignment {
            flag: flag.to_owned(),
            value: value.to_owned(),
        })
}

impl RosArgs {
    /// Reads every `--ros-args` block of `args`; the arguments outside them are
    /// returned for the program's own parser.
    pub fn parse<S: AsRef<str>>(args: &[S]) -> Result<(RosArgs, Vec<String>), ArgsError> {
        let mut ros = RosArgs::default();
        let mut rest = Vec::new();
        let mut inside = false;
        let mut it = args.iter().map(AsRef::as_ref);
        while let Some(arg) = it.next() {
            if !inside {
                if arg == "--ros-args" {
                    inside = true;
                } else {
                    rest.push(arg.to_owned());
                }
                continue;
            }
            let mut value = |flag: &str| {
                it.next()
                    .ok_or_else(|| ArgsError::MissingValue(flag.to_owned()))
            };
            match arg {
                "--" => inside = false,
                "--ros-args" => {}
                "-r" | "--remap" => ros.remap(value(arg)?)?,
                "-p" | "--param" => {
                    let (name, v) = assignment(arg, value(arg)?)?;
                    if !is_valid_name(name) && !name.contains('.') {
                        return Err(ArgsError::BadName(name.to_owned()));
                    }
                    ros.params.insert(name.to_owned(), ParamValue::parse(v));
                }
                "--params-file" => return Err(ArgsError::ParamsFile(value(arg)?.to_owned())),
                "--log-level" | "--log-config-file" | "-e" | "--enclave" => {
                    value(arg)?;
                }
                "--enable-rosout-logs"
                | "--disable-rosout-logs"
                | "--enable-stdout-logs"
                | "--disable-stdout-logs"
                | "--enable-external-lib-logs"
                | "--disable-external-lib-logs" => {}
                other => return Err(ArgsError::Unknown(other.to_owned())),
            }
        }
        Ok((ros, rest))
    }

    fn remap(&mut self, rule: &str) -> Result<(), ArgsError> {
        let (lhs, to) = assignment("-r", rule)?;
        // `NODE:FROM`; a `:` can only be the node separator (names have none).
        let (node, from) = match lhs.split_once(':') {
            Some((node, from)) => (Some(node.to_owned()), from),
            None => (None, lhs),
        };
        match from {
            "__ns" => {
                let ns = if to.starts_with('/') {
                    to.to_owned()
                } else {
                    format!("/{to}")
                };
                if ns != "/" && !is_valid_name(&ns) {
                    return Err(ArgsError::BadName(to.to_owned()));
                }
                self.namespace = Some(ns);
            }
            "__node" | "__name" => {
                if !is_valid_name(to) || to.contains('/') {
                    return Err(ArgsError::BadName(to.to_owned()));
                }
                self.node_name = Some(to.to_owned());
            }
            _ => {
                for name in [from, to] {
                    if !is_valid_name(name) {
                        return Err(ArgsError::BadName(name.to_owned()));
                    }
                }
                self.remaps.push(Remap {
                    node,
                    from: from.to_owned(),
                    to: to.to_owned(),
                });
            }
        }
        Ok(())
    }

    /// The name a topic the node calls `name` ends up with: the first remapping of
    /// `name` (as given, or made absolute in `namespace`) for every node or for
    /// `node_name`, else `name` itself.
    pub fn topic(&self, name: &str, node_name: &str, namespace: &str) -> String {
        let absolute = |n: &str| {
            if n.starts_with('/') {
                n.to_owned()
            } else if namespace == "/" || namespace.is_empty() {
                format!("/{n}")
            } else {
                format!("{}/{n}", namespace.trim_end_matches('/'))
            }
        };
        let asked = absolute(name);
        self.remaps
            .iter()
            .find(|r| {
                r.node.as_deref().is_none_or(|n| n == node_name)
                    && (r.from == name || absolute(&r.from) == asked)
            })
            .map_or(asked, |r| absolute(&r.to))
    }
}

/// The DDS domain of `ROS_DOMAIN_ID` (unset or empty: 0, as in ROS 2).
pub fn domain_id(value: Option<&str>) -> Result<u16, ArgsError> {
    match value.map(str::trim) {
        None | Some("") => Ok(0),
        Some(v) => match v.parse::<u16>() {
            Ok(id) if id <= 232 => Ok(id),
            _ => Err(ArgsError::DomainId(v.to_owned())),
        },
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, reason = "tests fail loudly")]

    use super::*;

    #[test]
    fn remaps_params_name_and_namespace_come_out_of_the_block() {
        let (ros, rest) = RosArgs::parse(&[
            "--config",
            "robot.toml",
            "--ros-args",
            "-r",
            "scan:=/front/scan",
            "--remap",
            "tether:cmd_vel:=/base/cmd_vel",
            "-r",
            "__ns:=robot1",
            "-r",
            "__node:=follower",
            "-p",
            "follow_distance:=1.5",
            "-p",
            "fixed_frame:=odom",
            "--log-level",
            "debug",
            "--",
            "-v",
        ])
        .unwrap();
        assert_eq!(rest, ["--config", "robot.toml", "-v"]);
        assert_eq!(ros.namespace.as_deref(), Some("/robot1"));
        assert_eq!(ros.node_name.as_deref(), Some("follower"));
        assert_eq!(ros.params["follow_distance"], ParamValue::Double(1.5));
        assert_eq!(ros.params["fixed_frame"].as_str(), Some("odom"));
        assert_eq!(ros.remaps.len(), 2);
        assert_eq!(ros.topic("scan", "follower", "/robot1"), "/front/scan");
        // Relative names resolve in the namespace.
        assert_eq!(ros.topic("odom", "follower", "/robot1"), "/robot1/odom");
        // A rule for another node does not apply.
        assert_eq!(
            ros.topic("cmd_vel", "follower", "/robot1"),
            "/robot1/cmd_vel"
        );
        assert_eq!(ros.topic("cmd_vel", "tether", "/"), "/base/cmd_vel");
    }

    #[test]
    fn parameter_values_are_typed_as_yaml_scalars() {
        assert_eq!(ParamValue::parse("true"), ParamValue::Bool(true));
        assert_eq!(ParamValue::parse("False"), ParamValue::Bool(false));
        assert_eq!(ParamValue::parse("42"), ParamValue::Integer(42));
        assert_eq!(ParamValue::parse("-1.5e-1"), ParamValue::Double(-0.15));
        assert_eq!(ParamValue::parse("'42'"), ParamValue::String("42".into()));
        assert_eq!(
            ParamValue::parse("base_link"),
            ParamValue::String("base_link".into())
        );
        assert_eq!(
            ParamValue::parse("1.2.3"),
            ParamValue::String("1.2.3".into())
        );
        assert_eq!(ParamValue::Integer(2).as_f64(), Some(2.0));
    }

    #[test]
    fn what_rcl_refuses_is_an_error_that_names_it() {
        let e = |args: &[&str]| RosArgs::parse(args).unwrap_err();
        assert_eq!(
            e(&["--ros-args", "-r"]),
            ArgsError::MissingValue("-r".into())
        );
        assert!(matches!(
            e(&["--ros-args", "-p", "speed=1"]),
            ArgsError::NoAssignment { .. }
        ));
        assert_eq!(
            e(&["--ros-args", "-r", "scan:=9lives"]),
            ArgsError::BadName("9lives".into())
        );
        assert_eq!(
            e(&["--ros-args", "--config", "x"]),
            ArgsError::Unknown("--config".into())
        );
        assert!(
            e(&["--ros-args", "--params-file", "p.yaml"])
                .to_string()
                .contains("-p NAME:=VALUE")
        );
    }

    #[test]
    fn the_domain_comes_from_ros_domain_id() {
        assert_eq!(domain_id(None), Ok(0));
        assert_eq!(domain_id(Some("")), Ok(0));
        assert_eq!(domain_id(Some("42")), Ok(42));
        assert!(domain_id(Some("233")).is_err());
        assert!(domain_id(Some("-1")).is_err());
        assert!(domain_id(Some("x")).is_err());
    }

    #[test]
    fn names_follow_ros_2_rules() {
        for good in ["scan", "/scan", "~/scan", "robot_1/cmd_vel", "/a/b_c"] {
            assert!(is_valid_name(good), "{good}");
        }
        for bad in ["", "/", "1scan", "a//b", "a-b", "sc an", "a/"] {
            assert!(!is_valid_name(bad), "{bad}");
        }
    }
}
