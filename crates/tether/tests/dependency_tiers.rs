//! The dependency rule per tier (issue 18; docs/design.md, *Crates and tiers*): every
//! workspace crate has a tier, and a crate's dependencies on other workspace crates point
//! down, to a lower tier, never sideways or up. Tests and benchmarks may reach sideways
//! or up (dev-dependencies: a simulated world or a recording as input) but never onto a
//! crate that depends on the crate itself. A test-support crate ([`TEST_SUPPORT`]) sits in
//! the bottom tier, so that every crate's tests may use it, and is a dev-dependency only.
//!
//! The arrows are read from `cargo metadata --no-deps` (the `Cargo.toml` files), so a
//! new arrow that points up fails here, in CI, before it takes root. A crate that is not
//! in the table fails too: place it in a tier. A crate in the table that does not exist
//! (yet) is allowed, so that the table can name a crate before it lands.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::process::Command;

use serde_json::Value;

/// The tiers, bottom up: the crates of each and what they are for. A crate may use the
/// crates of lower tiers only.
const TIERS: &[(&str, &[&str])] = &[
    (
        "shared types, picture helpers and test support",
        &["tether-core", "tether-svg", "tether-testkit"],
    ),
    (
        "image decoding and ROS messages",
        &["tether-image", "tether-msgs"],
    ),
    (
        "algorithms and sensor links",
        &[
            "tether-laser",
            "tether-vision",
            "tether-fusion",
            "tether-control",
            "tether-scanmatch",
            "tether-recording",
            "tether-scip",
        ],
    ),
    (
        "compositions of algorithms",
        &["tether-pipeline", "tether-cascade"],
    ),
    ("the simulated world", &["tether-sim"]),
    ("ROS 2", &["tether-ros2"]),
    ("the live runtime", &["tether-live"]),
    ("measures", &["tether-eval"]),
    ("reports", &["tether-report"]),
    ("the command line", &["tether"]),
];

/// Crates for tests only: no crate's `[dependencies]` or `[build-dependencies]` may name
/// them, only its `[dev-dependencies]`.
const TEST_SUPPORT: &[&str] = &["tether-testkit"];

/// Procedural macros, below every tier: any crate may use them, and they use no tether
/// crate (the derive of the configuration's docs, whose trait is `tether-core`'s).
const MACROS: &[&str] = &["tether-config-derive"];

/// The tier of each crate in [`TIERS`].
fn tier_of() -> BTreeMap<&'static str, usize> {
    let mut tiers = BTreeMap::new();
    for (tier, (_, crates)) in TIERS.iter().enumerate() {
        for name in *crates {
            assert!(
                tiers.insert(*name, tier).is_none(),
                "{name} is in two tiers"
            );
        }
    }
    tiers
}

/// One arrow between workspace crates: user, used, and whether only tests and
/// benchmarks use it.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
struct Arrow {
    from: String,
    to: String,
    dev: bool,
}

/// The workspace's crates and the arrows between them, from `cargo metadata`'s JSON.
fn arrows(metadata: &Value) -> (BTreeSet<String>, Vec<Arrow>) {
    let packages = metadata["packages"]
        .as_array()
        .expect("cargo metadata lists packages");
    let members: BTreeSet<String> = packages
        .iter()
        .filter_map(|p| p["name"].as_str().map(str::to_owned))
        .collect();
    let mut arrows = BTreeSet::new();
    for p in packages {
        let from = p["name"].as_str().unwrap_or_default();
        for d in p["dependencies"].as_array().into_iter().flatten() {
            let to = d["name"].as_str().unwrap_or_default();
            if !members.contains(to) || to == from {
                continue;
            }
            // `kind` is null for a normal dependency, "build" or "dev" otherwise.
            arrows.insert(Arrow {
                from: from.to_owned(),
                to: to.to_owned(),
                dev: d["kind"].as_str() == Some("dev"),
            });
        }
    }
    (members, arrows.into_iter().collect())
}

/// Everything wrong with the workspace's arrows against [`TIERS`], one line each.
fn violations(members: &BTreeSet<String>, arrows: &[Arrow]) -> Vec<String> {
    let tiers = tier_of();
    let mut out = Vec::new();
    for name in members {
        if !tiers.contains_key(name.as_str()) && !MACROS.contains(&name.as_str()) {
            out.push(format!(
                "{name} is in no tier: add it to TIERS (crates/tether/tests/dependency_tiers.rs) \
                 and to the table of docs/design.md (*Crates and tiers*)"
            ));
        }
    }
    // Which crates each crate uses, through normal and build dependencies.
    let mut uses: BTreeMap<&str, Vec<&str>> = BTreeMap::new();
    for a in arrows.iter().filter(|a| !a.dev) {
        uses.entry(&a.from).or_default().push(&a.to);
    }
    let reaches = |from: &str, to: &str| {
        let mut seen = BTreeSet::new();
        let mut stack = vec![from];
        while let Some(c) = stack.pop() {
            if c == to {
                return true;
            }
            if seen.insert(c) {
                stack.extend(uses.get(c).into_iter().flatten().copied());
            }
        }
        false
    };
    for a in arrows.iter().filter(|a| !a.dev) {
        if MACROS.contains(&a.from.as_str()) {
            out.push(format!(
                "{} -> {}: a procedural macro uses no tether crate",
                a.from, a.to
            ));
        }
        if TEST_SUPPORT.contains(&a.to.as_str()) {
            out.push(format!(
                "{} -> {}: test support, for [dev-dependencies] only",
                a.from, a.to
            ));
        }
    }
    for a in arrows {
        let (Some(&from), Some(&to)) = (tiers.get(a.from.as_str()), tiers.get(a.to.as_str()))
        else {
            continue;
        };
        if a.dev {
            if reaches(&a.to, &a.from) {
                out.push(format!(
                    "{} (tests) -> {}: a cycle, {} depends on {}",
                    a.from, a.to, a.to, a.from
                ));
            }
        } else if to >= from {
            out.push(format!(
                "{} (tier {from}, {}) -> {} (tier {to}, {}): an arrow {} a tier",
                a.from,
                TIERS[from].0,
                a.to,
                TIERS[to].0,
                if to == from { "within" } else { "up" }
            ));
        }
    }
    out
}

/// One package of `cargo metadata`'s JSON: `name` and its dependencies with their kind
/// (`None` for a normal one, `"dev"`, `"build"`).
fn crate_json(name: &str, deps: &[(&str, Option<&str>)]) -> Value {
    serde_json::json!({
        "name": name,
        "dependencies": deps
            .iter()
            .map(|(to, kind)| serde_json::json!({"name": to, "kind": kind}))
            .collect::<Vec<_>>(),
    })
}

#[test]
fn every_dependency_points_down_a_tier() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let output = Command::new(env!("CARGO"))
        .args([
            "metadata",
            "--format-version",
            "1",
            "--no-deps",
            "--offline",
        ])
        .arg("--manifest-path")
        .arg(root.join("Cargo.toml"))
        .output()
        .expect("cargo runs");
    assert!(
        output.status.success(),
        "cargo metadata failed: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    let metadata: Value = serde_json::from_slice(&output.stdout).expect("cargo metadata's JSON");
    let (members, arrows) = arrows(&metadata);
    // Not vacuous: the workspace's crates are found, and the app uses the pipeline.
    assert!(members.contains("tether-core") && members.contains("tether-pipeline"));
    assert!(arrows.contains(&Arrow {
        from: "tether".into(),
        to: "tether-pipeline".into(),
        dev: false,
    }));
    let problems = violations(&members, &arrows);
    assert!(
        problems.is_empty(),
        "dependencies against the tiers (docs/design.md, *Crates and tiers*):\n{}",
        problems.join("\n")
    );
}

#[test]
fn the_check_catches_arrows_up_and_within_a_tier_and_cycles_through_tests() {
    let metadata = serde_json::json!({
        "packages": [
            crate_json("tether-core", &[("serde", None), ("tether-laser", Some("dev"))]),
            crate_json("tether-laser", &[("tether-core", None), ("tether-fusion", None)]),
            crate_json("tether-fusion", &[("tether-core", None)]),
            crate_json("tether-control", &[("tether-sim", Some("build"))]),
            crate_json("tether-pipeline", &[("tether-laser", None), ("tether-sim", Some("dev"))]),
            crate_json("tether-sim", &[("tether-core", None)]),
            crate_json("tether-extra", &[("tether-core", None)]),
        ]
    });
    let (members, arrows) = arrows(&metadata);
    let problems = violations(&members, &arrows);
    // Neither tether-image nor tether-live exists here, and that is no problem; nor is
    // the pipeline's test using the simulator, nor an arrow to a crate outside the
    // workspace. Everything else is.
    let found = |what: &[&str]| problems.iter().any(|p| what.iter().all(|w| p.contains(w)));
    assert_eq!(problems.len(), 4, "{problems:#?}");
    assert!(found(&["tether-extra is in no tier"]), "{problems:#?}");
    assert!(
        found(&[
            "tether-control (tier 2",
            "-> tether-sim (tier 4",
            "up a tier"
        ]),
        "{problems:#?}"
    );
    assert!(
        found(&[
            "tether-laser (tier 2",
            "-> tether-fusion (tier 2",
            "within a tier"
        ]),
        "{problems:#?}"
    );
    assert!(
        found(&["tether-core (tests) -> tether-laser: a cycle"]),
        "{problems:#?}"
    );
}

#[test]
fn test_support_is_a_dev_dependency_of_any_crate_and_a_dependency_of_none() {
    let metadata = serde_json::json!({
        "packages": [
            crate_json("tether-testkit", &[("serde_json", None)]),
            crate_json("tether-core", &[("tether-testkit", Some("dev"))]),
            crate_json("tether", &[("tether-core", None), ("tether-testkit", Some("dev"))]),
            crate_json("tether-laser", &[("tether-core", None), ("tether-testkit", None)]),
            crate_json("tether-fusion", &[("tether-testkit", Some("build"))]),
        ]
    });
    let (members, arrows) = arrows(&metadata);
    let problems = violations(&members, &arrows);
    // The tests of the bottom tier and of the top one may use it; a normal or a build
    // dependency on it is refused, though it points down.
    assert_eq!(problems.len(), 2, "{problems:#?}");
    for user in ["tether-laser", "tether-fusion"] {
        assert!(
            problems.iter().any(|p| p
                == &format!("{user} -> tether-testkit: test support, for [dev-dependencies] only")),
            "{problems:#?}"
        );
    }
}

/// Every `.rs` file under `dir`, recursively.
fn rust_files(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    let entries = std::fs::read_dir(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The house rules of issue 33 on the sizes of things (STYLE.md): no file under
/// `crates/` over 1,000 lines, the command line's crate under 7,000 lines of source,
/// and no command reaching into another (they share through library crates and the
/// app's `args` only). Function lengths are clippy's `too_many_lines` (Cargo.toml).
#[test]
fn files_stay_short_and_commands_share_nothing() {
    let crates = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut files = Vec::new();
    rust_files(&crates, &mut files);
    assert!(files.len() > 100, "{} files", files.len());
    let lines = |path: &Path| std::fs::read_to_string(path).unwrap().lines().count();
    let long: Vec<String> = files
        .iter()
        .filter(|f| lines(f) > 1000)
        .map(|f| format!("{}: {} lines", f.display(), lines(f)))
        .collect();
    assert!(long.is_empty(), "files over 1,000 lines: {long:#?}");
    let app = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut app_files = Vec::new();
    rust_files(&app, &mut app_files);
    let app_lines: usize = app_files.iter().map(|f| lines(f)).sum();
    assert!(
        app_lines < 7000,
        "the app crate has {app_lines} lines of source"
    );
    let mut commands = Vec::new();
    rust_files(&app.join("cmd"), &mut commands);
    for file in commands {
        let text = std::fs::read_to_string(&file).unwrap();
        for (n, line) in text.lines().enumerate() {
            let code = line.split("//").next().unwrap_or_default();
            // `super::X` inside a command's own folder (train_legs/) is its own.
            let reaches = code.contains("crate::cmd::")
                || (code.contains("super::")
                    && !code.contains("super::*")
                    && !file.parent().is_some_and(|p| p.ends_with("train_legs")));
            assert!(!reaches, "{}:{}: {line}", file.display(), n + 1);
        }
    }
}

/// One driver of the pipeline (issue 33): outside tests, benchmarks and the pipeline's
/// own crate, only `tether-live`'s `driver.rs` hands the pipeline its scans, camera
/// boxes and timer ticks, so the rules of time and of the robot's pose are the same in
/// `run`, `ros2`, `replay`, `track`, `eval-track` and the simulator's closed loop.
#[test]
fn only_the_driver_ticks_the_pipeline() {
    let crates = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut files = Vec::new();
    rust_files(&crates, &mut files);
    let mut callers = Vec::new();
    for file in &files {
        let path = file.to_string_lossy().replace('\\', "/");
        if [
            "/tests/",
            "/benches/",
            "/examples/",
            "/fuzz/",
            "tether-pipeline/",
        ]
        .iter()
        .any(|part| path.contains(part))
        {
            continue;
        }
        let text = std::fs::read_to_string(file).unwrap();
        // The unit tests at the end of a file drive pipelines of their own.
        let library = text.split("#[cfg(test)]").next().unwrap_or_default();
        for (n, line) in library.lines().enumerate() {
            let code = line.split("//").next().unwrap_or_default();
            let ticks = [
                ".on_scan(",
                ".on_timer(",
                ".on_camera_boxes(",
                ".on_camera(",
            ]
            .iter()
            .any(|call| code.contains(call));
            // `TrackEval::on_scan` takes the driver's steps; it is not the pipeline's.
            if ticks && !code.contains("eval.on_scan(") {
                callers.push(format!("{path}:{}: {}", n + 1, line.trim()));
            }
        }
    }
    assert!(
        callers
            .iter()
            .all(|c| c.contains("tether-live/src/driver.rs")),
        "the pipeline ticked outside the driver: {callers:#?}"
    );
    assert!(
        !callers.is_empty(),
        "the driver no longer ticks the pipeline?"
    );
}
