//! `tether scanners` and `--scanner` through the binary (issue 30).

#![allow(clippy::unwrap_used, reason = "a test should fail loudly on bad data")]

mod common;

use common::{scratch, tether, text};

/// The catalogue's names, kept apart from tether-sim's list: read from it, a lost
/// scanner would pass.
const NAMES: [&str; 9] = [
    "urg_04lx",
    "ust_10lx",
    "utm_30lx",
    "uhg_08lx",
    "sick_tim571",
    "rplidar_a1",
    "rplidar_a2",
    "lds_01",
    "ydlidar_x4",
];

#[test]
fn scanners_lists_the_catalogue_as_a_table_and_as_json() {
    let out = tether(&["scanners"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    for name in NAMES {
        let row = stdout
            .lines()
            .find(|l| l.starts_with(&format!("{name} ")))
            .unwrap_or_else(|| panic!("{name} missing:\n{stdout}"));
        assert!(row.split_whitespace().count() > 12, "{row}");
    }
    let out = tether(&["scanners", "--json"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let all: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let all = all.as_array().unwrap();
    assert_eq!(all.len(), NAMES.len());
    let a1 = all.iter().find(|s| s["name"] == "rplidar_a1").unwrap();
    assert_eq!(a1["laser"]["geometry"]["steps_per_rev"], 360);
    assert_eq!(a1["rotation"], "clockwise");
    assert_eq!(a1["sim"]["object_beam_loss_prob"], 0.25);
}

/// The scans of `tether sim ARGS --duration 2` in a fresh folder `sub`.
fn sim_scans(sub: &str, args: &[&str]) -> Vec<serde_json::Value> {
    let dir = scratch(sub);
    let mut all = vec!["sim", "--duration", "2", "--out", dir.to_str().unwrap()];
    all.extend_from_slice(args);
    let out = tether(&all);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let scans = std::fs::read_to_string(dir.join("scans.jsonl")).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    scans
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

#[test]
fn sim_runs_a_scenario_with_a_360_degree_scanner_and_a_clockwise_one() {
    let scans = sim_scans(
        "scanner-a1",
        &["--scenario", "office", "--scanner", "rplidar_a1"],
    );
    // 5.5 scans a second for 2 s.
    assert_eq!(scans.len(), 11, "{}", scans.len());
    let first = &scans[0];
    assert_eq!(first["ranges_m"].as_array().unwrap().len(), 360);
    let inc = first["angle_increment_rad"].as_f64().unwrap();
    assert!((inc - 1f64.to_radians()).abs() < 1e-9, "{inc}");
    assert!((first["angle_min_rad"].as_f64().unwrap() + std::f64::consts::PI).abs() < 1e-9);
    assert_eq!(first["range_min_m"], 0.15);

    // The same scanner publishing clockwise, from a scenario file.
    let dir = scratch("scanner-cw");
    std::fs::create_dir_all(&dir).unwrap();
    let office = text(&tether(&["scenarios", "--show", "office"]).stdout);
    let file = dir.join("office_cw.toml");
    std::fs::write(
        &file,
        format!(
            "{office}\n[laser.geometry]\nclockwise = true\n[laser_sim]\nscanner = \"rplidar_a1\"\n"
        ),
    )
    .unwrap();
    let cw = sim_scans("scanner-cw-out", &["--scenario", file.to_str().unwrap()]);
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(cw.len(), scans.len());
    let inc = cw[0]["angle_increment_rad"].as_f64().unwrap();
    assert!((inc + 1f64.to_radians()).abs() < 1e-9, "{inc}");
    // The same points, listed the other way round.
    for (a, b) in scans.iter().zip(&cw) {
        let mut back = b["ranges_m"].as_array().unwrap().clone();
        back.reverse();
        assert_eq!(a["ranges_m"].as_array().unwrap(), &back);
    }
}

#[test]
fn an_unknown_scanner_is_an_error_that_lists_the_known_ones() {
    for cmd in [
        vec!["sim", "--scenario", "office", "--out", "/nonexistent/x"],
        vec!["eval-target", "--seeds", "1", "--scenario", "office"],
        vec!["demo", "--scenario", "office", "--out", "/nonexistent/x"],
    ] {
        let mut args = cmd.clone();
        args.extend_from_slice(&["--scanner", "lms200"]);
        let out = tether(&args);
        assert!(!out.status.success(), "{cmd:?}");
        let stderr = text(&out.stderr);
        assert!(stderr.contains("lms200"), "{stderr}");
        for name in NAMES {
            assert!(stderr.contains(name), "{cmd:?}: {stderr}");
        }
    }
}
