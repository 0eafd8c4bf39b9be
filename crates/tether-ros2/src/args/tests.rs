//! Tests of the ROS 2 command-line arguments and parameter files.

#![allow(clippy::unwrap_used, reason = "tests fail loudly")]

use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};

use proptest::prelude::*;

use super::*;

/// A file under the temporary directory, removed when dropped.
struct TempFile(PathBuf);

impl TempFile {
    fn new(text: &str) -> TempFile {
        static NEXT: AtomicUsize = AtomicUsize::new(0);
        let path = std::env::temp_dir().join(format!(
            "tether-ros2-params-{}-{}.yaml",
            std::process::id(),
            NEXT.fetch_add(1, Ordering::Relaxed)
        ));
        std::fs::write(&path, text).unwrap();
        TempFile(path)
    }

    fn path(&self) -> &str {
        self.0.to_str().unwrap()
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

/// `--ros-args` followed by `args`, where `@N` is the path of `files[N]`.
fn ros(files: &[&TempFile], args: &[&str]) -> Result<RosArgs, ArgsError> {
    let mut all = vec!["--ros-args".to_owned()];
    for arg in args {
        match arg.strip_prefix('@') {
            Some(n) => all.push(files[n.parse::<usize>().unwrap()].path().to_owned()),
            None => all.push((*arg).to_owned()),
        }
    }
    RosArgs::parse(&all).map(|(ros, rest)| {
        assert!(rest.is_empty(), "{rest:?}");
        ros
    })
}

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
fn dash_p_takes_a_node_prefix_and_arrays() {
    let ros = ros(
        &[],
        &[
            "-p",
            "tether:speed:=0.5",
            "-p",
            "other:speed:=9",
            "-p",
            "ids:=[1, 2, 3]",
            "-p",
            "frames:=[odom, 'base_link']",
            "-p",
            "note:=a [b]",
        ],
    )
    .unwrap();
    assert_eq!(ros.params["speed"], ParamValue::Double(0.5));
    assert_eq!(ros.params["ids"], ParamValue::IntegerArray(vec![1, 2, 3]));
    assert_eq!(
        ros.params["frames"],
        ParamValue::StringArray(vec!["odom".into(), "base_link".into()])
    );
    assert_eq!(ros.params["note"].as_str(), Some("a [b]"));
    assert_eq!(
        ros.params_for("other", "/")["speed"],
        ParamValue::Integer(9)
    );
    let e = RosArgs::parse(&["--ros-args", "-p", "xs:=[1, 2.5]"]).unwrap_err();
    assert!(
        matches!(&e, ArgsError::BadValue { name, .. } if name == "xs"),
        "{e:?}"
    );
    assert!(e.to_string().contains("mixed"), "{e}");
    assert!(matches!(
        RosArgs::parse(&["--ros-args", "-p", "xs:=[]"]).unwrap_err(),
        ArgsError::BadValue { .. }
    ));
    assert_eq!(
        RosArgs::parse(&["--ros-args", "-p", "a..b:=1"]).unwrap_err(),
        ArgsError::BadName("a..b".into())
    );
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
    assert_eq!(
        e(&["--ros-args", "--params-file"]),
        ArgsError::MissingValue("--params-file".into())
    );
}

const FILE: &str = r#"
# Every node.
/**:
  ros__parameters:
    use_sim_time: true
    shared: 1
tether:
  ros__parameters:
    follow_distance: 1.2
    fixed_frame: odom
    quoted: '42'
    tagged: !!str true
    nothing: "null"
    limits:
      max_speed: 0.3
      turn: {max: 1, min: -1}
    dotted.name: 2
    bools: [true, false, True]
    ints: [1, -2, 3]
    doubles: [0.5, 1e3, -.inf]
    strings: [odom, "1", base_link]
    block:
      - a
      - b
other:
  ros__parameters:
    follow_distance: 9.0
"#;

#[test]
fn a_params_file_gives_the_node_its_blocks_with_nested_names_and_arrays() {
    let f = TempFile::new(FILE);
    let ros = ros(&[&f], &["--params-file", "@0"]).unwrap();
    let p = &ros.params;
    assert_eq!(p["use_sim_time"], ParamValue::Bool(true));
    assert_eq!(p["shared"], ParamValue::Integer(1));
    assert_eq!(p["follow_distance"], ParamValue::Double(1.2));
    assert_eq!(p["fixed_frame"].as_str(), Some("odom"));
    assert_eq!(p["quoted"], ParamValue::String("42".into()));
    assert_eq!(p["tagged"], ParamValue::String("true".into()));
    assert_eq!(p["nothing"], ParamValue::String("null".into()));
    assert_eq!(p["limits.max_speed"], ParamValue::Double(0.3));
    assert_eq!(p["limits.turn.max"], ParamValue::Integer(1));
    assert_eq!(p["limits.turn.min"], ParamValue::Integer(-1));
    assert_eq!(p["dotted.name"], ParamValue::Integer(2));
    assert_eq!(p["bools"], ParamValue::BoolArray(vec![true, false, true]));
    assert_eq!(p["ints"], ParamValue::IntegerArray(vec![1, -2, 3]));
    assert_eq!(
        p["doubles"],
        ParamValue::DoubleArray(vec![0.5, 1000.0, f64::NEG_INFINITY])
    );
    assert_eq!(
        p["strings"],
        ParamValue::StringArray(vec!["odom".into(), "1".into(), "base_link".into()])
    );
    assert_eq!(
        p["block"],
        ParamValue::StringArray(vec!["a".into(), "b".into()])
    );
    assert_eq!(p.len(), 16, "{p:?}");
    assert_eq!(p["ints"].type_name(), "integer_array");
    // The other node's block is kept, and applies to it.
    let blocks: Vec<&str> = ros.param_blocks.iter().map(|b| b.node.as_str()).collect();
    assert_eq!(blocks, ["/**", "tether", "other"]);
    let other = ros.params_for("other", "/");
    assert_eq!(other["follow_distance"], ParamValue::Double(9.0));
    assert_eq!(other["use_sim_time"], ParamValue::Bool(true));
    assert!(!other.contains_key("fixed_frame"));
}

#[test]
fn dash_p_after_a_file_and_a_later_file_override() {
    let a = TempFile::new("tether:\n  ros__parameters:\n    x: 1\n    y: 1\n    z: 1\n");
    let b = TempFile::new("tether:\n  ros__parameters:\n    y: 2\n");
    let ros = ros(
        &[&a, &b],
        &["--params-file", "@0", "--params-file", "@1", "-p", "z:=3"],
    )
    .unwrap();
    assert_eq!(ros.params["x"], ParamValue::Integer(1));
    assert_eq!(ros.params["y"], ParamValue::Integer(2));
    assert_eq!(ros.params["z"], ParamValue::Integer(3));
    // The same with the files the other way round.
    let swapped = ros_of(&[&b, &a], &["--params-file", "@0", "--params-file", "@1"]);
    assert_eq!(swapped.params["y"], ParamValue::Integer(1));
    // A `/**` file and a later `-p`: the `-p` replaces the value in `/**`.
    let every = TempFile::new("/**:\n  ros__parameters:\n    z: 1\n");
    let ros3 = ros_of(&[&every], &["--params-file", "@0", "-p", "z:=3"]);
    assert_eq!(ros3.params["z"], ParamValue::Integer(3));
}

fn ros_of(files: &[&TempFile], args: &[&str]) -> RosArgs {
    ros(files, args).unwrap()
}

#[test]
fn between_node_names_the_one_that_first_appeared_later_wins_as_in_rcl() {
    let node = TempFile::new("tether:\n  ros__parameters:\n    x: 2\n");
    // `-p` first: the file's `tether` entry comes after `/**` and wins.
    let r = ros_of(&[&node], &["-p", "x:=1", "--params-file", "@0"]);
    assert_eq!(r.params["x"], ParamValue::Integer(2));
    // A `/**` block and after it a `tether` block: a later `-p` joins `/**`, and
    // the `tether` block still wins.
    let both = TempFile::new(
        "/**:\n  ros__parameters:\n    x: 0\ntether:\n  ros__parameters:\n    x: 2\n",
    );
    let r = ros_of(&[&both], &["--params-file", "@0", "-p", "x:=1"]);
    assert_eq!(r.params["x"], ParamValue::Integer(2));
    // The other way round in the file: `/**` came later, so it and the `-p` win.
    let reversed = TempFile::new(
        "tether:\n  ros__parameters:\n    x: 2\n/**:\n  ros__parameters:\n    x: 0\n",
    );
    let r = ros_of(&[&reversed], &["--params-file", "@0"]);
    assert_eq!(r.params["x"], ParamValue::Integer(0));
    let r = ros_of(&[&reversed], &["--params-file", "@0", "-p", "x:=1"]);
    assert_eq!(r.params["x"], ParamValue::Integer(1));
    // `tether` and `/tether` are two entries, as in rcl; both apply.
    let slash = TempFile::new("/tether:\n  ros__parameters:\n    x: 3\n");
    let r = ros_of(
        &[&node, &slash],
        &["--params-file", "@0", "--params-file", "@1"],
    );
    assert_eq!(r.params["x"], ParamValue::Integer(3));
    assert_eq!(r.param_blocks.len(), 2);
}

#[test]
fn wildcards_match_as_rclcpp_does() {
    for (pattern, name) in [
        ("/**", "/tether"),
        ("/**", "/robot1/tether"),
        ("**", "/a/b/c"),
        ("/**/tether", "/tether"),
        ("/**/tether", "/robot1/tether"),
        ("/**/tether", "/a/b/tether"),
        ("/*/tether", "/robot1/tether"),
        ("/robot1/*", "/robot1/tether"),
        ("*", "/tether"),
        ("/*", "/tether"),
        ("tether", "/tether"),
        ("/tether", "/tether"),
        ("robot1/tether", "/robot1/tether"),
        ("/robot1/**", "/robot1/a/tether"),
    ] {
        assert!(node_matches(pattern, name), "{pattern} should match {name}");
    }
    for (pattern, name) in [
        ("/**/tether", "/robot1/other"),
        ("/*/tether", "/tether"),
        ("/*/tether", "/a/b/tether"),
        ("*", "/robot1/tether"),
        ("tether", "/robot1/tether"),
        ("/robot1/tether", "/robot2/tether"),
        ("/robot1/*", "/robot1/a/tether"),
    ] {
        assert!(
            !node_matches(pattern, name),
            "{pattern} should not match {name}"
        );
    }
}

#[test]
fn the_blocks_apply_to_the_name_and_namespace_given_anywhere_on_the_line() {
    let f = TempFile::new(
        "/**/tether:\n  ros__parameters:\n    a: 1\n\
             /*/tether:\n  ros__parameters:\n    b: 2\n\
             /robot1/other:\n  ros__parameters:\n    c: 3\n\
             robot1:\n  tether:\n    ros__parameters:\n      d: 4\n\
             /robot1/:\n  follower:\n    ros__parameters:\n      e: 5\n",
    );
    // `__ns` after the file still decides.
    let r = ros_of(&[&f], &["--params-file", "@0", "-r", "__ns:=/robot1"]);
    let names: Vec<&str> = r.params.keys().map(String::as_str).collect();
    assert_eq!(names, ["a", "b", "d"]);
    let blocks: Vec<&str> = r.param_blocks.iter().map(|b| b.node.as_str()).collect();
    assert_eq!(
        blocks,
        [
            "/**/tether",
            "/*/tether",
            "/robot1/other",
            "robot1/tether",
            "/robot1/follower"
        ]
    );
    let r = ros_of(&[&f], &["--params-file", "@0"]);
    assert_eq!(r.params.keys().collect::<Vec<_>>(), ["a"]);
    let r = ros_of(
        &[&f],
        &[
            "--params-file",
            "@0",
            "-r",
            "__node:=follower",
            "-r",
            "__ns:=robot1",
        ],
    );
    assert_eq!(r.params.keys().collect::<Vec<_>>(), ["e"]);
    assert_eq!(
        r.params_for("other", "/robot1")["c"],
        ParamValue::Integer(3)
    );
    assert_eq!(
        RosArgs::parse_for_node(
            &[
                "--ros-args",
                "--params-file",
                f.path(),
                "-r",
                "__ns:=/robot1"
            ],
            "other"
        )
        .unwrap()
        .0
        .params
        .keys()
        .collect::<Vec<_>>(),
        ["c"]
    );
}

#[test]
fn an_empty_file_or_node_sets_nothing() {
    for text in [
        "",
        "# nothing\n",
        "---\n",
        "tether:\n  ros__parameters: {}\n",
    ] {
        let f = TempFile::new(text);
        let r = ros_of(&[&f], &["--params-file", "@0"]);
        assert!(r.params.is_empty(), "{text:?}");
    }
}

/// The line and problem of a file `rcl` would refuse.
fn file_error(yaml: &str) -> (usize, String) {
    let f = TempFile::new(yaml);
    match ros(&[&f], &["--params-file", "@0"]) {
        Err(e @ ArgsError::ParamsFile { .. }) => {
            let text = e.to_string();
            assert!(text.contains(f.path()), "{text}");
            let ArgsError::ParamsFile { line, problem, .. } = e else {
                unreachable!()
            };
            (line, problem)
        }
        other => panic!("{yaml:?}: {other:?}"),
    }
}

#[test]
fn each_bad_file_is_an_error_that_names_the_file_the_line_and_the_parameter() {
    let missing = std::env::temp_dir().join("tether-ros2-no-such-params.yaml");
    let e =
        RosArgs::parse(&["--ros-args", "--params-file", missing.to_str().unwrap()]).unwrap_err();
    let ArgsError::ParamsFileRead { path, .. } = &e else {
        panic!("{e:?}")
    };
    assert!(path.ends_with("no-such-params.yaml"), "{path}");
    assert!(e.to_string().contains("cannot read"), "{e}");

    let cases: &[(&str, usize, &[&str])] = &[
        // YAML syntax.
        (
            "tether:\n  ros__parameters:\n    a: [1, 2\n    b: 3\n",
            4,
            &["not YAML"],
        ),
        (
            "tether:\n  ros__parameters:\n    a: 1\n   b: 2\n",
            4,
            &["not YAML"],
        ),
        (
            "tether:\n  ros__parameters:\n    a: 'open\n",
            3,
            &["not YAML", "column 8"],
        ),
        // A node without `ros__parameters`.
        (
            "tether:\n  follow_distance: 1.0\n",
            2,
            &["`tether/follow_distance`", "ros__parameters"],
        ),
        (
            "tether: 1\n",
            1,
            &["node `tether` has no `ros__parameters`"],
        ),
        (
            "tether: {}\n",
            1,
            &["node `tether` has no `ros__parameters`"],
        ),
        ("ros__parameters:\n  a: 1\n", 1, &["needs a node name"]),
        (
            "tether:\n  ros__parameters:\n    a: 1\n  speed: 2\n",
            4,
            &["node `tether`", "`speed`"],
        ),
        ("- tether\n", 1, &["top level"]),
        // `ros__parameters` that is not a mapping.
        (
            "tether:\n  ros__parameters: 5\n",
            2,
            &["node `tether`", "must be a mapping"],
        ),
        (
            "tether:\n  ros__parameters:\n    - a\n",
            2,
            &["must be a mapping"],
        ),
        ("tether:\n  ros__parameters:\n", 2, &["must be a mapping"]),
        // Bad names.
        (
            "tether:\n  ros__parameters:\n    9lives: 1\n",
            3,
            &["`9lives`", "parameter name"],
        ),
        (
            "tether:\n  ros__parameters:\n    a:\n      b-c: 1\n",
            4,
            &["`a.b-c`"],
        ),
        (
            "/robot*/tether:\n  ros__parameters:\n    a: 1\n",
            1,
            &["`/robot*/tether`", "alone"],
        ),
        (
            "/a//tether:\n  ros__parameters:\n    a: 1\n",
            1,
            &["`/a//tether`"],
        ),
        (
            "1robot:\n  ros__parameters:\n    a: 1\n",
            1,
            &["`1robot`", "digit"],
        ),
        // Arrays: mixed types, ints with doubles, empty, nested.
        (
            "tether:\n  ros__parameters:\n    a: [1, x]\n",
            3,
            &[
                "node `tether`, parameter `a`",
                "\"x\" (a string) among integers",
                "mixed",
            ],
        ),
        (
            "tether:\n  ros__parameters:\n    gains:\n      - 1\n      - 2.5\n",
            5,
            &["parameter `gains`", "2.5 (a double) among integers", "1.0"],
        ),
        (
            "tether:\n  ros__parameters:\n    a: [true, 1]\n",
            3,
            &["parameter `a`", "among bools"],
        ),
        (
            "tether:\n  ros__parameters:\n    a: []\n",
            3,
            &["parameter `a`", "empty list", "refuses"],
        ),
        (
            "tether:\n  ros__parameters:\n    a: [[1]]\n",
            3,
            &["parameter `a`", "list inside a list"],
        ),
        (
            "tether:\n  ros__parameters:\n    a: [{b: 1}]\n",
            3,
            &["parameter `a`", "mapping inside"],
        ),
        // No value; aliases.
        (
            "tether:\n  ros__parameters:\n    a:\n    b: 1\n",
            3,
            &["parameter `a`", "no value"],
        ),
        (
            "tether:\n  ros__parameters:\n    a: {}\n",
            3,
            &["parameter `a`", "no value"],
        ),
        (
            "tether:\n  ros__parameters:\n    a: &x 1\n    b: *x\n",
            4,
            &["alias"],
        ),
    ];
    for (yaml, line, words) in cases {
        let (got_line, problem) = file_error(yaml);
        assert_eq!(got_line, *line, "{yaml:?}: {problem}");
        for word in *words {
            assert!(
                problem.contains(word),
                "{yaml:?}: {problem:?} lacks {word:?}"
            );
        }
    }
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
    for good in ["a", "a.b", "limits.max_speed", "a_1.b2.c"] {
        assert!(is_valid_param_name(good), "{good}");
    }
    for bad in ["", ".", "a.", ".a", "a..b", "a.9", "~a", "a.b-c"] {
        assert!(!is_valid_param_name(bad), "{bad}");
    }
}

/// A scalar or an array, as a file would hold it (no NaN: it equals nothing).
fn value() -> impl Strategy<Value = ParamValue> {
    let double = any::<f64>().prop_filter("NaN", |x| !x.is_nan());
    let string = "[ -~\u{e9}\u{4e2d}]{0,12}";
    prop_oneof![
        any::<bool>().prop_map(ParamValue::Bool),
        any::<i64>().prop_map(ParamValue::Integer),
        double.clone().prop_map(ParamValue::Double),
        string.prop_map(ParamValue::String),
        prop::collection::vec(any::<bool>(), 1..4).prop_map(ParamValue::BoolArray),
        prop::collection::vec(any::<i64>(), 1..4).prop_map(ParamValue::IntegerArray),
        prop::collection::vec(double, 1..4).prop_map(ParamValue::DoubleArray),
        prop::collection::vec(string, 1..4).prop_map(ParamValue::StringArray),
    ]
}

/// `value` as YAML: doubles always with a fraction or an exponent, strings quoted.
fn yaml(value: &ParamValue) -> String {
    let double = |x: f64| match x {
        f64::INFINITY => ".inf".to_owned(),
        f64::NEG_INFINITY => "-.inf".to_owned(),
        x => format!("{x:?}"),
    };
    let string = |s: &str| format!("\"{}\"", s.replace('\\', "\\\\").replace('"', "\\\""));
    let list = |items: Vec<String>| format!("[{}]", items.join(", "));
    match value {
        ParamValue::Bool(b) => b.to_string(),
        ParamValue::Integer(i) => i.to_string(),
        ParamValue::Double(x) => double(*x),
        ParamValue::String(s) => string(s),
        ParamValue::BoolArray(v) => list(v.iter().map(bool::to_string).collect()),
        ParamValue::IntegerArray(v) => list(v.iter().map(i64::to_string).collect()),
        ParamValue::DoubleArray(v) => list(v.iter().map(|x| double(*x)).collect()),
        ParamValue::StringArray(v) => list(v.iter().map(|s| string(s)).collect()),
    }
}

proptest! {
    #[test]
    fn any_valid_flat_parameters_read_back_equal(
        params in prop::collection::btree_map(
            "[a-z_][a-z0-9_]{0,6}(\\.[a-z_][a-z0-9_]{0,6}){0,2}",
            value(),
            0..12,
        )
    ) {
        let mut text = String::from("tether:\n  ros__parameters:\n");
        for (name, v) in &params {
            text.push_str(&format!("    {name}: {}\n", yaml(v)));
        }
        if params.is_empty() {
            text = "tether:\n  ros__parameters: {}\n".to_owned();
        }
        let blocks = param_blocks(&text).map_err(|p| {
            TestCaseError::fail(format!("{text}\nline {}: {}", p.line, p.text))
        })?;
        prop_assert_eq!(blocks.len(), 1);
        prop_assert_eq!(&blocks[0].params, &params, "{}", text);
    }

    #[test]
    fn any_text_is_read_or_refused_without_a_panic(
        text in "[a-z_/*:\\-\\[\\]{},&!#'\" .0-9\n]{0,120}|\\PC{0,120}"
    ) {
        let _ = param_blocks(&text);
        let _ = command_line_value(&text);
    }

    /// A real parameter file with characters changed, inserted or removed anywhere
    /// (indentation, `:`, brackets, tags): read or refused, and what is read resolves
    /// for any node (wildcard blocks) without a panic.
    #[test]
    fn a_damaged_file_is_read_or_refused_without_a_panic(
        edits in prop::collection::vec(
            (any::<prop::sample::Index>(), prop::sample::select(
                vec![' ', '\n', ':', '-', '[', ']', '{', '}', ',', '*', '/', '!', '&', '\'', '"', '#', 'a', '1', '.'],
            ), 0u8..3),
            1..6,
        )
    ) {
        let mut text: Vec<char> = FILE.chars().collect();
        tether_testkit::damage(&mut text, edits);
        let text: String = text.into_iter().collect();
        if let Ok(blocks) = param_blocks(&text) {
            let ros = RosArgs { param_blocks: blocks, ..RosArgs::default() };
            for (node, namespace) in [("tether", "/"), ("other", "/robot1"), ("x", "")] {
                let _ = ros.params_for(node, namespace);
            }
        }
    }
}
