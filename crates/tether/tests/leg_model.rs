//! A leg model of `tether train-legs --from-recording` is used by the pipeline when the
//! config names it (`[legs] model`, `[pipeline.legs] model` in a robot's config, a path
//! relative to the config file) or `--leg-model` does: `tether track` on the same
//! recording then writes other tracks than with the built-in model, the flag and the
//! config key give the same output, and a missing file, a file that is no model and a
//! model of other features are refused with an error naming the file.
//!
//! The recording is 20 s of `tests/scenarios/walk_in_front.toml` (a person walking
//! loops in front of the still robot) seen by the simulated YDLIDAR X4, a scanner the
//! built-in model never saw (see `self_labels.rs`), trained on with 30 rounds to keep
//! the test to seconds.

#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "test code: a failed unwrap is a failed test"
)]

mod common;

use std::path::{Path, PathBuf};

use common::{example_config, on_recording, scratch, tether, text};

/// `tether sim` of `scenario` seen by the YDLIDAR X4 for `seconds` with `seed`, recorded
/// as `dir/NAME.bag` (the sim's files in `dir/NAME`).
fn x4_bag(dir: &Path, scenario: &Path, seconds: &str, seed: &str, name: &str) -> PathBuf {
    let bag = dir.join(format!("{name}.bag"));
    let sim = tether(&[
        "sim",
        "--scenario",
        scenario.to_str().unwrap(),
        "--scanner",
        "ydlidar_x4",
        "--driver",
        "scenario",
        "--duration",
        seconds,
        "--seed",
        seed,
        "--out",
        dir.join(name).to_str().unwrap(),
        "--record-bag",
        bag.to_str().unwrap(),
    ]);
    assert!(sim.status.success(), "sim: {}", text(&sim.stderr));
    bag
}

/// `tether train-legs --from-recording BAG --scan-topic /scan --rounds 30 EXTRA... --out
/// dir/NAME`: its standard output; the model must be written.
fn train_from(dir: &Path, bag: &Path, extra: &[&str], name: &str) -> String {
    let model = dir.join(name);
    let mut args = vec![
        "train-legs",
        "--from-recording",
        bag.to_str().unwrap(),
        "--scan-topic",
        "/scan",
        "--rounds",
        "30",
        "--out",
        model.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let run = tether(&args);
    assert!(
        run.status.success(),
        "train-legs {extra:?}: {}",
        text(&run.stderr)
    );
    assert!(model.is_file());
    text(&run.stdout)
}

/// The walking scenario, `tests/scenarios/walk_in_front.toml`.
fn walk_in_front() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/scenarios/walk_in_front.toml")
}

/// `walk.bag` (20 s, YDLIDAR X4) and `legs.json` trained on it, in `dir`.
fn recording_and_model(dir: &Path) -> (PathBuf, PathBuf) {
    let bag = x4_bag(dir, &walk_in_front(), "20", "1", "walk");
    train_from(dir, &bag, &[], "legs.json");
    (bag, dir.join("legs.json"))
}

/// `tether track BAG --scan-topic /scan EXTRA... --out DIR/NAME`: its output, which
/// must be written.
fn track(dir: &Path, bag: &Path, extra: &[&str], name: &str) -> String {
    let out = dir.join(name);
    let run = on_recording("track", bag, "/scan", extra, &out);
    assert!(
        run.status.success(),
        "track {extra:?}: {}",
        text(&run.stderr)
    );
    std::fs::read_to_string(&out).unwrap()
}

/// `tether track` with `extra` must fail, saying `words` (and never panicking).
fn refused(dir: &Path, bag: &Path, extra: &[&str], words: &[&str]) {
    let run = on_recording("track", bag, "/scan", extra, &dir.join("refused.jsonl"));
    let err = text(&run.stderr);
    assert!(!run.status.success(), "track {extra:?} ran: {err}");
    assert!(!err.contains("panicked"), "{err}");
    for w in words {
        assert!(err.contains(w), "track {extra:?}: {w:?} not in {err}");
    }
}

#[test]
fn a_trained_model_is_used_through_the_flag_and_the_config_and_bad_ones_are_refused() {
    let dir = scratch("leg-model");
    let (bag, model) = recording_and_model(&dir);
    let model_arg = model.to_str().unwrap();

    let built_in = track(&dir, &bag, &[], "built_in.jsonl");
    let by_flag = track(&dir, &bag, &["--leg-model", model_arg], "flag.jsonl");
    assert_ne!(by_flag, built_in, "the named model changes nothing");

    // A pipeline config in a folder of its own, naming the model relative to itself.
    let configs = dir.join("configs");
    std::fs::create_dir_all(&configs).unwrap();
    let pipeline = configs.join("pipeline.toml");
    std::fs::write(&pipeline, "[legs]\nmodel = \"../legs.json\"\n").unwrap();
    let by_config = track(
        &dir,
        &bag,
        &["--config", pipeline.to_str().unwrap()],
        "config.jsonl",
    );
    assert_eq!(
        by_config, by_flag,
        "`[legs] model` and `--leg-model` differ"
    );

    // The README's robot config with the key, beside the model.
    let example = std::fs::read_to_string(example_config()).unwrap();
    let robot = dir.join("robot.toml");
    std::fs::write(&robot, example.clone()).unwrap();
    let robot_with = dir.join("robot_with_model.toml");
    std::fs::write(
        &robot_with,
        example + "\n[pipeline.legs]\nmodel = \"legs.json\"\n",
    )
    .unwrap();
    let robot_built_in = track(
        &dir,
        &bag,
        &["--config", robot.to_str().unwrap()],
        "robot.jsonl",
    );
    let robot_model = track(
        &dir,
        &bag,
        &["--config", robot_with.to_str().unwrap()],
        "robot_model.jsonl",
    );
    let robot_flag = track(
        &dir,
        &bag,
        &[
            "--config",
            robot.to_str().unwrap(),
            "--leg-model",
            model_arg,
        ],
        "robot_flag.jsonl",
    );
    assert_ne!(
        robot_model, robot_built_in,
        "[pipeline.legs] model is not used"
    );
    assert_eq!(robot_model, robot_flag, "the key and the flag differ");

    // The flag overrides the config: a missing file named by the flag is refused even
    // though the config names a good one.
    let missing = dir.join("missing.json");
    refused(
        &dir,
        &bag,
        &[
            "--config",
            pipeline.to_str().unwrap(),
            "--leg-model",
            missing.to_str().unwrap(),
        ],
        &["missing.json", "cannot read the leg model"],
    );
    // A file that is no model: the recording itself, and JSON of something else.
    refused(
        &dir,
        &bag,
        &["--leg-model", bag.to_str().unwrap()],
        &["walk.bag", "leg model"],
    );
    let other = dir.join("other.json");
    std::fs::write(&other, "{\"format\": 1}\n").unwrap();
    refused(
        &dir,
        &bag,
        &["--leg-model", other.to_str().unwrap()],
        &["other.json", "leg model"],
    );
    // A model of features this build does not compute: retrain it.
    let json = std::fs::read_to_string(&model).unwrap();
    let renamed = json.replacen("\"features\": [\"", "\"features\": [\"old_", 1);
    assert_ne!(renamed, json, "the model's feature list moved");
    let stale = dir.join("stale.json");
    std::fs::write(&stale, renamed).unwrap();
    refused(
        &dir,
        &bag,
        &["--leg-model", stale.to_str().unwrap()],
        &["stale.json", "retrain"],
    );
    // A missing file named by a config: its path resolved against the config's folder.
    let bad_config = configs.join("bad.toml");
    std::fs::write(&bad_config, "[legs]\nmodel = \"nowhere.json\"\n").unwrap();
    refused(
        &dir,
        &bag,
        &["--config", bad_config.to_str().unwrap()],
        &[&configs.join("nowhere.json").display().to_string()],
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The number after `on ` ... `legs and ` ... ` non-legs` in train-legs' summary line
/// ("trained 30 trees on 426 legs and 6490 non-legs ...").
fn non_legs_trained(stdout: &str) -> usize {
    let line = stdout
        .lines()
        .find(|l| l.starts_with("trained "))
        .unwrap_or_else(|| panic!("no summary line in\n{stdout}"));
    let words: Vec<&str> = line.split_whitespace().collect();
    let k = words
        .iter()
        .position(|w| *w == "non-legs")
        .unwrap_or_else(|| panic!("no non-legs in {line}"));
    words[k - 1].parse().unwrap()
}

#[test]
fn a_recording_of_the_empty_scene_adds_its_clusters_as_non_legs() {
    let dir = scratch("leg-model-empty");
    let (bag, _) = recording_and_model(&dir);
    // The same room with nobody in it: walk_in_front.toml up to its people.
    let scenario = std::fs::read_to_string(walk_in_front()).unwrap();
    let empty_room: String = scenario
        .lines()
        .take_while(|l| !l.starts_with("[[people]]"))
        .map(|l| format!("{l}\n"))
        .collect();
    let empty_toml = dir.join("empty_room.toml");
    std::fs::write(&empty_toml, empty_room).unwrap();
    let empty_bag = x4_bag(&dir, &empty_toml, "10", "2", "empty");
    let alone = train_from(&dir, &bag, &[], "alone.json");
    let with_empty = train_from(
        &dir,
        &bag,
        &["--empty", empty_bag.to_str().unwrap()],
        "with_empty.json",
    );
    assert!(with_empty.contains("of the empty scene"), "{with_empty}");
    // Every cluster of the empty scene's training part is one more non-leg.
    let (a, b) = (non_legs_trained(&alone), non_legs_trained(&with_empty));
    println!("non-legs trained on: {a} alone, {b} with the empty scene");
    assert!(b > a + 500, "{a} -> {b}\n{with_empty}");
    // A recording with no scan on the topic is refused, not taken as an empty scene.
    let wrong = tether(&[
        "train-legs",
        "--from-recording",
        bag.to_str().unwrap(),
        "--scan-topic",
        "/scan",
        "--empty",
        dir.join("no-such.bag").to_str().unwrap(),
        "--out",
        dir.join("never.json").to_str().unwrap(),
    ]);
    assert!(!wrong.status.success());
    assert!(!dir.join("never.json").exists());
}
