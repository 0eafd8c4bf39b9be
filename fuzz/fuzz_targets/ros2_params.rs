//! ROS 2 parameter files (`tether ros2 --ros-args --params-file FILE`, the YAML of
//! `rcl_yaml_param_parser`) and `-p NAME:=VALUE` values on arbitrary text: reading them
//! must never panic, and the parameters read must resolve for any node name and
//! namespace (wildcard node blocks) without a panic. The first byte picks what the rest
//! is: a parameter file (even) or the value of a `-p` (odd).

#![no_main]

use libfuzzer_sys::fuzz_target;
use tether_ros2::RosArgs;

/// The file the parameters go through: `RosArgs` reads a path, as rcl does.
fn params_file() -> &'static std::path::Path {
    static PATH: std::sync::OnceLock<std::path::PathBuf> = std::sync::OnceLock::new();
    PATH.get_or_init(|| {
        std::env::temp_dir().join(format!("tether-fuzz-params-{}.yaml", std::process::id()))
    })
}

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    let Ok(text) = std::str::from_utf8(rest) else {
        return;
    };
    let parsed = if mode % 2 == 0 {
        let path = params_file();
        std::fs::write(path, text).expect("the temporary directory is writable");
        let path = path.to_str().expect("a UTF-8 path");
        RosArgs::parse(&["--ros-args", "--params-file", path])
    } else {
        let rule = format!("tether:value:={text}");
        RosArgs::parse(&["--ros-args", "-p", rule.as_str()])
    };
    let Ok((ros, rest)) = parsed else {
        return;
    };
    assert!(rest.is_empty(), "{rest:?}");
    for (node, namespace) in [
        ("tether", "/"),
        ("tether", "/robot1/arm"),
        ("a_b", ""),
        ("x", "ns"),
    ] {
        for (name, value) in ros.params_for(node, namespace) {
            let _ = (
                name,
                value.type_name(),
                value.as_f64(),
                value.as_str(),
                value.as_bool(),
            );
        }
    }
});
