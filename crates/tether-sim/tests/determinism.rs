//! The same scenario and seed give byte-identical files; another seed does not.

#![allow(clippy::unwrap_used, reason = "a test should fail loudly on bad data")]

use std::path::Path;

use tether_sim::{Scenario, run_to_dir};

fn run(name: &str, seed: u64, dir: &Path) {
    let mut scenario = Scenario::builtin(name).unwrap();
    scenario.duration_s = 8.0;
    let toml = Scenario::builtin_toml(name).unwrap();
    run_to_dir(&scenario, toml, seed, dir, |_, _| {}).unwrap();
}

fn read(dir: &Path, file: &str) -> Vec<u8> {
    std::fs::read(dir.join(file)).unwrap_or_else(|e| panic!("{}: {e}", dir.join(file).display()))
}

const FILES: [&str; 7] = [
    "scans.jsonl",
    "camera.jsonl",
    "truth.jsonl",
    "camera_truth.jsonl",
    "scene.svg",
    "scenario.toml",
    "run.json",
];

#[test]
fn same_scenario_and_seed_give_identical_bytes() {
    let root = std::env::temp_dir().join(format!("tether-determinism-{}", std::process::id()));
    for name in ["office", "crossing"] {
        let (a, b, c) = (
            root.join(format!("{name}-a")),
            root.join(format!("{name}-b")),
            root.join(format!("{name}-c")),
        );
        run(name, 42, &a);
        run(name, 42, &b);
        run(name, 43, &c);
        for file in FILES {
            let (x, y) = (read(&a, file), read(&b, file));
            assert!(
                !x.is_empty() || file == "camera_truth.jsonl",
                "{name}/{file} is empty"
            );
            assert!(
                x == y,
                "{name}/{file} differs between two runs with the same seed"
            );
        }
        assert_ne!(
            read(&a, "scans.jsonl"),
            read(&c, "scans.jsonl"),
            "{name}: seeds 42 and 43 gave the same scans"
        );
        assert_ne!(read(&a, "camera.jsonl"), read(&c, "camera.jsonl"));
    }
    let _ = std::fs::remove_dir_all(&root);
}
