//! The ROS 2 command line: `--ros-args` (remapping, parameters and parameter files,
//! node name and namespace) and `ROS_DOMAIN_ID`, as `rcl` reads them.
//!
//! ```text
//! tether ros2 --ros-args -r scan:=/front/scan -r __ns:=/robot1 -p follow_distance:=1.5
//! tether ros2 --ros-args --params-file tether.yaml -p use_sim_time:=true
//! ```
//!
//! A `--ros-args` block runs to a lone `--` or to the end; there may be several. Inside
//! it: `-r`/`--remap FROM:=TO` (`NODE:FROM:=TO` applies only to the node called
//! `NODE`), with the special names `__ns` and `__node` (also `__name`);
//! `-p`/`--param NAME:=VALUE` (`NODE:NAME:=VALUE` only for the node called `NODE`),
//! whose value is typed as a YAML scalar (`true`, `42`, `1.5`, anything else a string;
//! quotes keep a string) or, written `[a, b]`, is an array as in a parameter file;
//! `--params-file FILE`; and the logging flags, which are accepted and left to tether's
//! own `-v`. Anything else is an error that names the argument, as `rcl` refuses it.
//!
//! # Parameter files
//!
//! `--params-file FILE` reads the YAML of `rcl_yaml_param_parser`:
//!
//! ```yaml
//! /**:                          # every node
//!   ros__parameters:
//!     use_sim_time: true
//! /robot1/tether:               # or `tether`, `/*/tether`, `/**/tether`
//!   ros__parameters:
//!     follow_distance: 1.2
//!     limits: {max_speed: 0.3}  # the parameter `limits.max_speed`
//!     frames: [odom, base_link] # a string array
//! ```
//!
//! Top-level keys are node names, absolute or not (`tether` is `/tether`); keys nested
//! above `ros__parameters` join with `/` (`robot1: {tether: {ros__parameters: ...}}` is
//! `robot1/tether`). A name token `*` matches one name of the node's fully qualified
//! name and `**` any number of them, none included (rclcpp's rule); a `*` inside a token
//! (`/robot*/tether`) is refused, as rcl refuses it. Mappings under `ros__parameters`
//! flatten into dotted names. Plain scalars are typed as `-p` values are
//! ([`ParamValue::parse`]); quoted ones and `!!str` ones stay strings. (rcl also takes
//! `yes`/`no`/`on`/`off` for booleans and C forms such as `0x10` for numbers; here they
//! are strings, and a parameter that wants a number or a boolean says so.) A sequence
//! of scalars of one type is an array. As in rcl, a sequence mixing types (integers
//! with doubles too), an empty sequence, a parameter without a value and an alias are
//! refused; so are a node block without `ros__parameters` and bad names. Each error
//! names the file, the line, the node and the parameter.
//!
//! # Which values apply
//!
//! [`RosArgs::params`] holds what applies to the node named by `__node` and `__ns`
//! (else `tether` in `/`), merged as rcl and rclcpp merge them. Every `-p` and every node
//! block of every file goes, in command-line order, into one list of entries
//! ([`RosArgs::param_blocks`]), one for each node name as written; a `-p` without
//! `NODE:` belongs to the entry `/**`. A name seen again adds to its first entry, where a
//! parameter set again takes the later value. The node's parameters are those of the
//! entries whose name matches its fully qualified name, in the list's order, a later
//! entry overriding an earlier one. So:
//!
//! - the same parameter for the same node name, in a later file or a later `-p`, takes
//!   the later value;
//! - between different names, the one that first appeared later wins. A `-p` joins
//!   `/**`: `--params-file f.yaml -p x:=1` gives `x = 1` when `f.yaml` holds only
//!   `tether` blocks or only `/**` ones, but f's value when f has a `/**` block and after
//!   it a `tether` one; `-p x:=1 --params-file f.yaml` gives f's value whenever f sets
//!   `x` for the node.

use std::collections::BTreeMap;

use yaml_rust2::parser::{Event, Parser};
use yaml_rust2::scanner::TScalarStyle;

/// A parameter value, from the command line or a parameter file.
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
    /// A sequence of booleans.
    BoolArray(Vec<bool>),
    /// A sequence of whole numbers.
    IntegerArray(Vec<i64>),
    /// A sequence of numbers with a fraction or an exponent.
    DoubleArray(Vec<f64>),
    /// A sequence of strings.
    StringArray(Vec<String>),
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

    /// The type's name as ROS 2 spells it (`integer`, `double_array`, ...).
    pub fn type_name(&self) -> &'static str {
        match self {
            ParamValue::Bool(_) => "bool",
            ParamValue::Integer(_) => "integer",
            ParamValue::Double(_) => "double",
            ParamValue::String(_) => "string",
            ParamValue::BoolArray(_) => "bool_array",
            ParamValue::IntegerArray(_) => "integer_array",
            ParamValue::DoubleArray(_) => "double_array",
            ParamValue::StringArray(_) => "string_array",
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

/// The parameters given for one node name or pattern (see the module's *Which values
/// apply*).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ParamBlock {
    /// The node name as written: `tether`, `/robot1/tether`, `/**`, `/*/tether`, ...
    pub node: String,
    /// Its parameters, by (dotted) name.
    pub params: BTreeMap<String, ParamValue>,
}

/// What `--ros-args` and the environment say.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RosArgs {
    /// Topic remappings, in the order given (the first that matches wins, as in `rcl`).
    pub remaps: Vec<Remap>,
    /// The parameters that apply to the node `__node` in `__ns` (else the default node
    /// name, `tether` for [`RosArgs::parse`], in `/`): the `-p` values and the parameter
    /// files' blocks that match it, merged as rcl does ([`RosArgs::params_for`]).
    pub params: BTreeMap<String, ParamValue>,
    /// Every `-p` and parameter file block, one entry for each node name in the order
    /// the names first appeared (`-p NAME:=VALUE` is `/**`).
    pub param_blocks: Vec<ParamBlock>,
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
    /// A `-p` value written as an array (`[...]`) that is not one.
    #[error("-p {name}:={value}: {problem}")]
    BadValue {
        /// The parameter.
        name: String,
        /// The value as given.
        value: String,
        /// What is wrong with it.
        problem: String,
    },
    /// An argument inside `--ros-args` that is not a ROS 2 one.
    #[error(
        "`{0}` inside --ros-args is not a ROS 2 argument (-r FROM:=TO, -p NAME:=VALUE, \
         --params-file FILE, --log-level LEVEL; end the block with `--`)"
    )]
    Unknown(String),
    /// `--params-file FILE` that cannot be read.
    #[error("--params-file {path}: cannot read it: {reason}")]
    ParamsFileRead {
        /// The file as given.
        path: String,
        /// Why (the system's words).
        reason: String,
    },
    /// `--params-file FILE` whose content rcl would refuse.
    #[error("--params-file {path}, line {line}: {problem}")]
    ParamsFile {
        /// The file as given.
        path: String,
        /// Where (from 1).
        line: usize,
        /// What is wrong, with the node and the parameter.
        problem: String,
    },
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

/// Whether `name` is a parameter name: ROS 2 names (without `~`) joined by `.`.
fn is_valid_param_name(name: &str) -> bool {
    name.split('.')
        .all(|part| !part.starts_with('~') && is_valid_name(part))
}

/// Whether the node name (or pattern) `pattern` of a parameter block matches the node
/// `fully_qualified_name` (`/robot1/tether`), as rclcpp matches them: a token `*` is one
/// name, `**` any number of names (none included), any other token itself; a pattern
/// without a leading `/` is absolute all the same.
pub fn node_matches(pattern: &str, fully_qualified_name: &str) -> bool {
    let tokens = |s: &'_ str| -> Vec<String> {
        s.strip_prefix('/')
            .unwrap_or(s)
            .split('/')
            .map(str::to_owned)
            .collect()
    };
    let (p, n) = (tokens(pattern), tokens(fully_qualified_name));
    // matches[i][j]: the pattern from token i matches the name from token j.
    let mut matches = vec![vec![false; n.len() + 1]; p.len() + 1];
    matches[p.len()][n.len()] = true;
    for i in (0..p.len()).rev() {
        for j in (0..=n.len()).rev() {
            let one = j < n.len() && !n[j].is_empty();
            matches[i][j] = match p[i].as_str() {
                "**" => matches[i + 1][j] || (one && matches[i][j + 1]),
                "*" => one && matches[i + 1][j + 1],
                token => one && n[j] == token && matches[i + 1][j + 1],
            };
        }
    }
    matches[0][0]
}

fn assignment<'a>(flag: &str, value: &'a str) -> Result<(&'a str, &'a str), ArgsError> {
    value
        .split_once(":=")
        .ok_or_else(|| ArgsError::NoAssignment {
            flag: flag.to_owned(),
            value: value.to_owned(),
        })
}

/// The node block name a `-p` without `NODE:` belongs to.
const EVERY_NODE: &str = "/**";

impl RosArgs {
    /// The node name [`RosArgs::parse`] resolves the parameters for without `__node`.
    pub const DEFAULT_NODE_NAME: &'static str = "tether";

    /// Reads every `--ros-args` block of `args` (and the parameter files they name);
    /// the arguments outside them are returned for the program's own parser.
    /// [`RosArgs::params`] is resolved for `__node` and `__ns`, else
    /// [`RosArgs::DEFAULT_NODE_NAME`] in `/`.
    pub fn parse<S: AsRef<str>>(args: &[S]) -> Result<(RosArgs, Vec<String>), ArgsError> {
        Self::parse_for_node(args, Self::DEFAULT_NODE_NAME)
    }

    /// [`RosArgs::parse`] for a node whose name without `__node` is
    /// `default_node_name`.
    pub fn parse_for_node<S: AsRef<str>>(
        args: &[S],
        default_node_name: &str,
    ) -> Result<(RosArgs, Vec<String>), ArgsError> {
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
                "-p" | "--param" => ros.param(value(arg)?)?,
                "--params-file" => ros.read_params_file(value(arg)?)?,
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
        let node_name = ros.node_name.as_deref().unwrap_or(default_node_name);
        let namespace = ros.namespace.as_deref().unwrap_or("/");
        ros.params = ros.params_for(node_name, namespace);
        Ok((ros, rest))
    }

    /// The parameters that apply to the node `node_name` in `namespace` (`/robot1`;
    /// `/` or empty: the root): those of the [`RosArgs::param_blocks`] whose name
    /// matches, a later block overriding an earlier one.
    pub fn params_for(&self, node_name: &str, namespace: &str) -> BTreeMap<String, ParamValue> {
        let namespace = namespace.trim_end_matches('/');
        let fully_qualified = if namespace.is_empty() || namespace.starts_with('/') {
            format!("{namespace}/{node_name}")
        } else {
            format!("/{namespace}/{node_name}")
        };
        let mut params = BTreeMap::new();
        for block in &self.param_blocks {
            if node_matches(&block.node, &fully_qualified) {
                params.extend(block.params.iter().map(|(k, v)| (k.clone(), v.clone())));
            }
        }
        params
    }

    /// The parameters of the entry for `node`, made at the end when it is new.
    fn entry(&mut self, node: &str) -> &mut BTreeMap<String, ParamValue> {
        let index = match self.param_blocks.iter().position(|b| b.node == node) {
            Some(index) => index,
            None => {
                self.param_blocks.push(ParamBlock {
                    node: node.to_owned(),
                    params: BTreeMap::new(),
                });
                self.param_blocks.len() - 1
            }
        };
        &mut self.param_blocks[index].params
    }

    fn param(&mut self, rule: &str) -> Result<(), ArgsError> {
        let (lhs, text) = assignment("-p", rule)?;
        // `NODE:NAME`; a `:` can only be the node separator (names have none).
        let (node, name) = match lhs.split_once(':') {
            Some((node, name)) => {
                if !is_valid_name(node) || node.contains('/') || node.starts_with('~') {
                    return Err(ArgsError::BadName(node.to_owned()));
                }
                (node, name)
            }
            None => (EVERY_NODE, lhs),
        };
        if !is_valid_param_name(name) {
            return Err(ArgsError::BadName(name.to_owned()));
        }
        let value = command_line_value(text).map_err(|problem| ArgsError::BadValue {
            name: name.to_owned(),
            value: text.to_owned(),
            problem,
        })?;
        self.entry(node).insert(name.to_owned(), value);
        Ok(())
    }

    fn read_params_file(&mut self, path: &str) -> Result<(), ArgsError> {
        let text = std::fs::read_to_string(path).map_err(|e| ArgsError::ParamsFileRead {
            path: path.to_owned(),
            reason: e.to_string(),
        })?;
        let blocks = param_blocks(&text).map_err(|p| ArgsError::ParamsFile {
            path: path.to_owned(),
            line: p.line,
            problem: p.text,
        })?;
        for block in blocks {
            self.entry(&block.node).extend(block.params);
        }
        Ok(())
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

/// What is wrong with a parameter file, and where.
#[derive(Debug)]
struct Problem {
    line: usize,
    text: String,
}

impl Problem {
    fn new(line: usize, text: impl Into<String>) -> Problem {
        Problem {
            line,
            text: text.into(),
        }
    }
}

/// A YAML node and the line it starts on.
#[derive(Debug)]
struct Node {
    line: usize,
    kind: Kind,
}

#[derive(Debug)]
enum Kind {
    /// `typed`: a plain scalar without `!!str`, typed as `-p` values are; else a string.
    Scalar {
        text: String,
        typed: bool,
    },
    Seq(Vec<Node>),
    Map(Vec<(Node, Node)>),
}

/// A sequence or mapping not closed yet.
enum Open {
    Seq(usize, Vec<Node>),
    /// With the key waiting for its value.
    Map(usize, Vec<(Node, Node)>, Option<Node>),
}

/// Deeper nesting than this is refused (and keeps the walks over the tree shallow).
const MAX_DEPTH: usize = 64;

/// The key under a node name that holds its parameters.
const PARAMS_KEY: &str = "ros__parameters";

/// The YAML documents of `text`, with their lines.
fn load_yaml(text: &str) -> Result<Vec<Node>, Problem> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut parser = Parser::new_from_str(text);
    let mut documents = Vec::new();
    let mut open: Vec<Open> = Vec::new();
    loop {
        let (event, mark) = parser.next_token().map_err(|e| {
            Problem::new(
                e.marker().line(),
                format!("not YAML: {} (column {})", e.info(), e.marker().col() + 1),
            )
        })?;
        let line = mark.line();
        let node = match event {
            Event::StreamEnd => break,
            Event::Nothing | Event::StreamStart | Event::DocumentStart | Event::DocumentEnd => {
                continue;
            }
            Event::Alias(_) => {
                return Err(Problem::new(
                    line,
                    "an alias (`*name`): rcl does not read aliases; write the value out",
                ));
            }
            Event::Scalar(text, style, _, tag) => {
                let str_tag =
                    tag.is_some_and(|t| t.handle == "tag:yaml.org,2002:" && t.suffix == "str");
                Node {
                    line,
                    kind: Kind::Scalar {
                        text,
                        typed: style == TScalarStyle::Plain && !str_tag,
                    },
                }
            }
            Event::SequenceStart(..) | Event::MappingStart(..) => {
                if open.len() >= MAX_DEPTH {
                    return Err(Problem::new(
                        line,
                        format!("nested deeper than {MAX_DEPTH} levels"),
                    ));
                }
                open.push(if matches!(event, Event::SequenceStart(..)) {
                    Open::Seq(line, Vec::new())
                } else {
                    Open::Map(line, Vec::new(), None)
                });
                continue;
            }
            Event::SequenceEnd | Event::MappingEnd => match open.pop() {
                Some(Open::Seq(line, items)) => Node {
                    line,
                    kind: Kind::Seq(items),
                },
                Some(Open::Map(line, entries, _)) => Node {
                    line,
                    kind: Kind::Map(entries),
                },
                None => return Err(Problem::new(line, "not YAML: a close without an open")),
            },
        };
        match open.last_mut() {
            None => documents.push(node),
            Some(Open::Seq(_, items)) => items.push(node),
            Some(Open::Map(_, entries, key)) => match key.take() {
                None => *key = Some(node),
                Some(key) => entries.push((key, node)),
            },
        }
    }
    Ok(documents)
}

/// The node blocks of a parameter file, in the file's order.
fn param_blocks(text: &str) -> Result<Vec<ParamBlock>, Problem> {
    let mut blocks = Vec::new();
    for document in load_yaml(text)? {
        match &document.kind {
            Kind::Map(entries) => node_blocks("", entries, &mut blocks)?,
            // An empty document (`---` alone, or only comments).
            Kind::Scalar { text, typed: true } if text.is_empty() => {}
            _ => {
                return Err(Problem::new(
                    document.line,
                    "the top level must map node names to their blocks \
                     (`tether:`, under it `ros__parameters:`, under that the parameters)",
                ));
            }
        }
    }
    Ok(blocks)
}

/// The text of a mapping key.
fn key_text(key: &Node) -> Result<&str, Problem> {
    match &key.kind {
        Kind::Scalar { text, .. } if !text.is_empty() => Ok(text),
        Kind::Scalar { .. } => Err(Problem::new(key.line, "an empty key")),
        _ => Err(Problem::new(
            key.line,
            "a key must be a name, not a list or a mapping",
        )),
    }
}

fn is_params_key(key: &Node) -> bool {
    matches!(&key.kind, Kind::Scalar { text, .. } if text == PARAMS_KEY)
}

/// Reads the node level of a file: node names (joined below `namespace`) down to their
/// `ros__parameters`.
fn node_blocks(
    namespace: &str,
    entries: &[(Node, Node)],
    out: &mut Vec<ParamBlock>,
) -> Result<(), Problem> {
    for (key, value) in entries {
        let key_name = key_text(key)?;
        if key_name == PARAMS_KEY {
            return Err(Problem::new(
                key.line,
                "`ros__parameters` needs a node name above it (`tether:`, and under it \
                 `ros__parameters:`)",
            ));
        }
        let name = if namespace.is_empty() {
            key_name.to_owned()
        } else if namespace.ends_with('/') {
            format!("{namespace}{key_name}")
        } else {
            format!("{namespace}/{key_name}")
        };
        let no_params = || {
            Problem::new(
                key.line,
                format!(
                    "node `{name}` has no `ros__parameters`: a node's parameters go under \
                     `{name}:` then `ros__parameters:`"
                ),
            )
        };
        let Kind::Map(inner) = &value.kind else {
            return Err(no_params());
        };
        if !inner.iter().any(|(k, _)| is_params_key(k)) {
            if inner.is_empty() {
                return Err(no_params());
            }
            // More of the node's name (`robot1:` then `tether:`).
            node_blocks(&name, inner, out)?;
            continue;
        }
        if let Some((other, _)) = inner.iter().find(|(k, _)| !is_params_key(k)) {
            return Err(Problem::new(
                other.line,
                format!(
                    "node `{name}`: nothing may stand beside its `ros__parameters` (found \
                     `{}`; a parameter goes under `ros__parameters`)",
                    key_text(other)?
                ),
            ));
        }
        check_node_name(&name).map_err(|why| {
            Problem::new(
                key.line,
                format!("`{name}` is not a node name rcl accepts: {why}"),
            )
        })?;
        for (params_key, params) in inner {
            let Kind::Map(params) = &params.kind else {
                return Err(Problem::new(
                    params_key.line,
                    format!(
                        "node `{name}`: `ros__parameters` must be a mapping of parameter \
                         names to values"
                    ),
                ));
            };
            let mut block = ParamBlock {
                node: name.clone(),
                params: BTreeMap::new(),
            };
            flatten(&name, "", params, &mut block.params)?;
            out.push(block);
        }
    }
    Ok(())
}

/// rcl's check of a node name in a parameter file: names between `/`, or the
/// wildcards `*` and `**` standing alone.
fn check_node_name(name: &str) -> Result<(), &'static str> {
    let body = name.strip_prefix('/').unwrap_or(name);
    for token in body.split('/') {
        if token == "*" || token == "**" {
            continue;
        }
        if token.is_empty() {
            return Err("it has an empty name between `/`");
        }
        if token.contains('*') {
            return Err(
                "`*` (one name) and `**` (any number of names) stand only alone between `/` \
                 (`/*/tether`, `/**/tether`)",
            );
        }
        if token.starts_with(|c: char| c.is_ascii_digit()) {
            return Err("a name in it starts with a digit");
        }
        if !token.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
            return Err("names are letters, digits and `_`, between `/`");
        }
    }
    Ok(())
}

/// The parameters of `entries` (under `prefix`, dotted) into `out`; a name given again
/// takes the later value, as in rcl.
fn flatten(
    node: &str,
    prefix: &str,
    entries: &[(Node, Node)],
    out: &mut BTreeMap<String, ParamValue>,
) -> Result<(), Problem> {
    for (key, value) in entries {
        let key_name = key_text(key)?;
        let name = if prefix.is_empty() {
            key_name.to_owned()
        } else {
            format!("{prefix}.{key_name}")
        };
        if !is_valid_param_name(&name) {
            return Err(Problem::new(
                key.line,
                format!(
                    "node `{node}`: `{name}` is not a valid parameter name (names of letters, \
                     digits and `_`, not starting with a digit, joined by `.`)"
                ),
            ));
        }
        match &value.kind {
            Kind::Map(inner) if !inner.is_empty() => flatten(node, &name, inner, out)?,
            _ => {
                // An empty value's line is the next token's: name the key's.
                let empty = matches!(&value.kind, Kind::Scalar { text, .. } if text.is_empty());
                let v = param_value(value).map_err(|p| Problem {
                    line: if empty { key.line } else { p.line },
                    text: format!("node `{node}`, parameter `{name}`: {}", p.text),
                })?;
                out.insert(name, v);
            }
        }
    }
    Ok(())
}

/// A parameter's value: a scalar, or a sequence of scalars of one type.
fn param_value(value: &Node) -> Result<ParamValue, Problem> {
    match &value.kind {
        Kind::Seq(items) => array(value.line, items),
        _ => scalar(value),
    }
}

fn scalar(node: &Node) -> Result<ParamValue, Problem> {
    match &node.kind {
        Kind::Scalar { text, typed: true } if text.is_empty() => Err(Problem::new(
            node.line,
            "no value (write `''` for an empty string)",
        )),
        Kind::Scalar { text, typed: true } => Ok(ParamValue::parse(text)),
        Kind::Scalar { text, typed: false } => Ok(ParamValue::String(text.clone())),
        Kind::Map(entries) if entries.is_empty() => {
            Err(Problem::new(node.line, "no value (an empty mapping)"))
        }
        Kind::Map(_) => Err(Problem::new(
            node.line,
            "a mapping inside a list: an array holds single values",
        )),
        Kind::Seq(_) => Err(Problem::new(
            node.line,
            "a list inside a list: an array holds single values",
        )),
    }
}

/// A value as a file would write it, for messages.
fn shown(value: &ParamValue) -> String {
    match value {
        ParamValue::String(s) => format!("{s:?}"),
        ParamValue::Bool(b) => b.to_string(),
        ParamValue::Integer(i) => i.to_string(),
        ParamValue::Double(x) => format!("{x:?}"),
        other => format!("{other:?}"),
    }
}

/// An array of `items`, all of one type, as rcl requires.
fn array(line: usize, items: &[Node]) -> Result<ParamValue, Problem> {
    let values = items
        .iter()
        .map(|item| Ok((item.line, scalar(item)?)))
        .collect::<Result<Vec<_>, Problem>>()?;
    let Some((_, first)) = values.first() else {
        return Err(Problem::new(
            line,
            "an empty list: rcl cannot tell the array's type and refuses it",
        ));
    };
    let kind = first.type_name();
    if let Some((odd_line, odd)) = values.iter().find(|(_, v)| v.type_name() != kind) {
        let numbers = [kind, odd.type_name()]
            .iter()
            .all(|t| matches!(*t, "integer" | "double"));
        return Err(Problem::new(
            *odd_line,
            format!(
                "an array holds one type: {} (a {}) among {kind}s; rcl refuses mixed arrays{}",
                shown(odd),
                odd.type_name(),
                if numbers {
                    " (write whole numbers as `1.0` for an array of doubles)"
                } else {
                    ""
                }
            ),
        ));
    }
    let values = values.into_iter().map(|(_, v)| v);
    Ok(match kind {
        "bool" => ParamValue::BoolArray(values.filter_map(|v| v.as_bool()).collect()),
        "integer" => ParamValue::IntegerArray(
            values
                .filter_map(|v| match v {
                    ParamValue::Integer(i) => Some(i),
                    _ => None,
                })
                .collect(),
        ),
        "double" => ParamValue::DoubleArray(values.filter_map(|v| v.as_f64()).collect()),
        _ => ParamValue::StringArray(
            values
                .filter_map(|v| match v {
                    ParamValue::String(s) => Some(s),
                    _ => None,
                })
                .collect(),
        ),
    })
}

/// A `-p` value: a scalar typed as YAML types a plain one, or, written `[...]`, an array
/// read as a parameter file's.
fn command_line_value(text: &str) -> Result<ParamValue, String> {
    if !text.trim_start().starts_with('[') {
        return Ok(ParamValue::parse(text));
    }
    let documents = load_yaml(text).map_err(|p| p.text)?;
    match documents.as_slice() {
        [
            Node {
                line,
                kind: Kind::Seq(items),
            },
        ] => array(*line, items).map_err(|p| p.text),
        _ => Err("not one YAML list (`[1, 2, 3]`)".to_owned()),
    }
}

#[cfg(test)]
mod tests;
