//! The command line as a user runs it.

#![allow(clippy::unwrap_used, reason = "a test should fail loudly on bad data")]

mod common;

use std::path::{Path, PathBuf};

use common::{on_recording, scratch, tether, text};

/// tether's own upper-body cascade, trained on vtest.
fn upperbody_model() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tether-cascade/models/vtest_upperbody.xml")
}

/// `tether track` on a 2 s corridor recording in `dir` reads `config` and succeeds.
fn tracks_with(dir: &Path, config: &Path) {
    let bag = common::corridor_bag(dir, 2);
    let out = on_recording(
        "track",
        &bag,
        "/scan",
        &["--config", config.to_str().unwrap()],
        &dir.join("t.jsonl"),
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
}

#[test]
fn scenarios_lists_every_builtin_with_one_line() {
    let out = tether(&["scenarios"]);
    assert!(out.status.success());
    let stdout = text(&out.stdout);
    let lines: Vec<&str> = stdout.lines().collect();
    assert_eq!(lines.len(), 8, "{stdout}");
    // Kept apart from tether-sim's BUILTIN_NAMES: read from it, a lost scenario would pass.
    for name in [
        "corridor",
        "office",
        "crossing",
        "stop_and_go",
        "turns",
        "occlusion",
        "outdoor_follow",
        "all_round",
    ] {
        assert!(
            lines.iter().any(|l| l.starts_with(name)),
            "{name} missing:\n{stdout}"
        );
    }
}

#[test]
fn sim_writes_identical_files_for_the_same_seed() {
    let dir = scratch("sim");
    let run = |sub: &str| {
        let out_dir = dir.join(sub);
        let out = tether(&[
            "sim",
            "--scenario",
            "office",
            "--seed",
            "3",
            "--duration",
            "3",
            "--out",
            out_dir.to_str().unwrap(),
        ]);
        assert!(out.status.success(), "{}", text(&out.stderr));
        assert!(
            text(&out.stdout).contains("31 scans"),
            "{}",
            text(&out.stdout)
        );
        out_dir
    };
    let (a, b) = (run("a"), run("b"));
    for file in [
        "scans.jsonl",
        "camera.jsonl",
        "truth.jsonl",
        "camera_truth.jsonl",
        "scene.svg",
        "run.json",
        "report.html",
    ] {
        let x = std::fs::read(a.join(file)).unwrap();
        assert!(!x.is_empty(), "{file} is empty");
        assert_eq!(x, std::fs::read(b.join(file)).unwrap(), "{file} differs");
    }
    // Spot-check the documented formats.
    let scans = std::fs::read_to_string(a.join("scans.jsonl")).unwrap();
    let first: serde_json::Value = serde_json::from_str(scans.lines().next().unwrap()).unwrap();
    assert_eq!(first["ranges_m"].as_array().unwrap().len(), 682);
    let truth = std::fs::read_to_string(a.join("truth.jsonl")).unwrap();
    let line: serde_json::Value = serde_json::from_str(truth.lines().nth(10).unwrap()).unwrap();
    assert_eq!(line["stamp_ns"], 1_000_000_000);
    assert!(
        line["people"][0]["laser"]["x"].is_number() && line["people"][0]["world"]["vx"].is_number()
    );
    let svg = std::fs::read_to_string(a.join("scene.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("polyline"));
    // The demo's report, for this run.
    let report = std::fs::read_to_string(a.join("report.html")).unwrap();
    assert!(report.contains("<h1>tether sim: office</h1>"), "no title");
    assert!(report.contains("id=\"office\"") || report.contains("href=\"#office\""));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn sim_runs_tethers_pipeline_with_the_config_given() {
    let dir = scratch("sim-config");
    let run = |sub: &str, config: Option<&Path>| {
        let out_dir = dir.join(sub);
        let mut args = vec![
            "sim".to_owned(),
            "--scenario".into(),
            "corridor".into(),
            "--duration".into(),
            "6".into(),
            "--out".into(),
            out_dir.to_str().unwrap().into(),
        ];
        if let Some(c) = config {
            args.extend(["--config".into(), c.to_str().unwrap().into()]);
        }
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let out = tether(&args);
        (out, out_dir)
    };
    let (out, plain) = run("plain", None);
    assert!(out.status.success(), "{}", text(&out.stderr));
    // A softer spring drives otherwise (the follow distance is the scenario's robot's).
    let far = dir.join("soft.toml");
    std::fs::write(&far, "[follower]\ndistance_omega_radps = 1.0\n").unwrap();
    let (out, farther) = run("far", Some(&far));
    assert!(out.status.success(), "{}", text(&out.stderr));
    let metrics = |d: &Path| std::fs::read_to_string(d.join("metrics.json")).unwrap();
    assert_ne!(
        metrics(&plain),
        metrics(&farther),
        "--config changed nothing"
    );
    // The robot file of the README's walk-through is read for its pipeline keys.
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/robot.example.toml");
    let (out, _) = run("robot", Some(&example));
    assert!(out.status.success(), "{}", text(&out.stderr));
    // A bad value is refused, naming the key, and nothing is written.
    let bad = dir.join("bad.toml");
    std::fs::write(&bad, "[follower]\ndistance_omega_radps = -1.0\n").unwrap();
    let (out, none) = run("bad", Some(&bad));
    assert!(!out.status.success());
    assert!(
        text(&out.stderr).contains("distance_omega_radps"),
        "{}",
        text(&out.stderr)
    );
    assert!(!none.exists(), "a refused run wrote {}", none.display());
    let _ = std::fs::remove_dir_all(&dir);
}

/// Writes the corridor scenario with one edit, runs it, and returns stderr, the file
/// and the 1-based line on which `marker` stands in the edited file.
fn bad_scenario(
    dir: &Path,
    name: &str,
    replace: (&str, &str),
    marker: &str,
) -> (String, PathBuf, usize) {
    let base = text(&tether(&["scenarios", "--show", "corridor"]).stdout);
    assert!(base.contains(replace.0), "{base}");
    let path = dir.join(name);
    let edited = base.replacen(replace.0, replace.1, 1);
    let line = edited
        .lines()
        .position(|l| l.contains(marker))
        .map_or(1, |i| i + 1);
    std::fs::write(&path, edited).unwrap();
    let out = tether(&[
        "sim",
        "--scenario",
        path.to_str().unwrap(),
        "--out",
        dir.join("out").to_str().unwrap(),
    ]);
    assert!(!out.status.success(), "accepted {name}");
    (text(&out.stderr), path, line)
}

#[test]
fn bad_scenario_files_are_refused_with_file_line_and_field() {
    let dir = scratch("bad");
    // (file, edit, the text on the line the error names, "COLUMN: message" after the line)
    let cases = [
        (
            "unknown_key.toml",
            ("speed_mps = 1.0", "speed_mps = 1.0\nsped_mps = 2.0"),
            "sped_mps",
            "1: unknown field `sped_mps`",
        ),
        (
            "negative_radius.toml",
            ("[robot]\n", "[robot]\nradius_m = -0.2\n"),
            "radius_m",
            "12: field `robot.radius_m`",
        ),
        (
            "outside.toml",
            ("[22.5, 1.2]", "[30.0, 1.2]"),
            "[30.0, 1.2]",
            "21: field `people[0].path[1]`",
        ),
        // A missing top-level field is reported at the start of the document (line 1:
        // every line contains "").
        (
            "missing.toml",
            ("duration_s = 26.0\n", ""),
            "",
            "1: missing field `duration_s`",
        ),
    ];
    for (name, edit, marker, column_and_message) in cases {
        let (err, path, line) = bad_scenario(&dir, name, edit, marker);
        assert!(
            err.contains(&format!("{}:{line}:{column_and_message}", path.display())),
            "{err}"
        );
        if name == "outside.toml" {
            assert!(err.contains("outside the walls"), "{err}");
        }
    }

    let out = tether(&[
        "sim",
        "--scenario",
        "no_such_scenario",
        "--out",
        dir.join("o").to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    assert!(
        text(&out.stderr).contains("tether scenarios"),
        "{}",
        text(&out.stderr)
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn train_and_eval_cascade_explain_bad_input() {
    let dir = scratch("cascade");
    let out_xml = dir.join("c.xml");
    let out_xml = out_xml.to_str().unwrap();
    let missing = tether(&[
        "train-cascade",
        "--info",
        "/nonexistent/info.dat",
        "--out",
        out_xml,
    ]);
    assert!(!missing.status.success());
    let err = text(&missing.stderr);
    assert!(
        err.contains("cannot read annotation file /nonexistent/info.dat"),
        "{err}"
    );

    let info = dir.join("info.dat");
    std::fs::write(&info, "a.jpg 1 0 0 10 20\nb.jpg 2 0 0 10 20\n").unwrap();
    let bad = tether(&[
        "train-cascade",
        "--info",
        info.to_str().unwrap(),
        "--out",
        out_xml,
    ]);
    assert!(!bad.status.success());
    let err = text(&bad.stderr);
    assert!(
        err.contains("info.dat:2") && err.contains("need 8 numbers"),
        "{err}"
    );

    std::fs::write(&info, "missing.jpg 1 0 0 10 20\n").unwrap();
    let no_image = tether(&[
        "train-cascade",
        "--info",
        info.to_str().unwrap(),
        "--out",
        out_xml,
    ]);
    let err = text(&no_image.stderr);
    assert!(
        err.contains("missing.jpg") && err.contains("info.dat:1"),
        "{err}"
    );

    let window = tether(&[
        "train-cascade",
        "--info",
        info.to_str().unwrap(),
        "--window",
        "16",
        "--out",
        out_xml,
    ]);
    assert!(!window.status.success());
    assert!(text(&window.stderr).contains("WxH"));

    let upper = tether(&[
        "eval-cascade",
        "--cascade",
        "/nonexistent.xml",
        "--info",
        info.to_str().unwrap(),
        "--upper",
        "1.5",
    ]);
    assert!(!upper.status.success());
    assert!(text(&upper.stderr).contains("--upper must be in (0, 1]"));
    assert!(!Path::new(out_xml).exists());
}

#[test]
fn a_failed_track_or_replay_leaves_the_earlier_result_as_it_was() {
    let dir = scratch("cli-atomic");
    let bag = common::corridor_bag(&dir, 3);
    // Results of an earlier, good run.
    let track_out = dir.join("t.jsonl");
    let replay_out = dir.join("r.mcap");
    let out = on_recording("track", &bag, "/scan", &[], &track_out);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let out = on_recording("replay", &bag, "/scan", &[], &replay_out);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let tracked = std::fs::read(&track_out).unwrap();
    let replayed = std::fs::read(&replay_out).unwrap();
    assert!(!tracked.is_empty() && !replayed.is_empty());
    // A wrong topic, a missing recording: the commands fail, and the results stay.
    let out = on_recording("track", &bag, "/nope", &[], &track_out);
    assert!(!out.status.success());
    let out = on_recording(
        "replay",
        &dir.join("missing.bag"),
        "/scan",
        &[],
        &replay_out,
    );
    assert!(!out.status.success());
    assert_eq!(std::fs::read(&track_out).unwrap(), tracked);
    assert_eq!(std::fs::read(&replay_out).unwrap(), replayed);
    let partial: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains("partial"))
        .collect();
    assert!(partial.is_empty(), "{partial:?}");
}

#[test]
fn detect_names_each_bad_image_and_goes_on_when_asked() {
    let Some(jpeg) = tether_testkit::shared("data/images/people/messi5.jpg") else {
        return;
    };
    let dir = scratch("detect-bad");
    let cascade = upperbody_model();
    let cascade = cascade.to_str().unwrap();
    let bytes = std::fs::read(&jpeg).unwrap();
    let cut = dir.join("cut.jpg");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let empty = dir.join("empty.png");
    std::fs::write(&empty, b"").unwrap();
    // A 1 KB progressive JPEG whose frame header claims 8000 x 8000 pixels.
    let mut huge = vec![
        0xff, 0xd8, 0xff, 0xc2, 0, 11, 8, 0x1f, 0x40, 0x1f, 0x40, 1, 1, 0x11, 0,
    ];
    huge.resize(1024, 0);
    let huge_path = dir.join("huge.jpg");
    std::fs::write(&huge_path, &huge).unwrap();
    let good = jpeg.to_str().unwrap();
    let (cut, empty, huge_path) = (
        cut.to_str().unwrap(),
        empty.to_str().unwrap(),
        huge_path.to_str().unwrap(),
    );

    // Without --keep-going the first bad image ends it, by name.
    let out = tether(&["detect", "--cascade", cascade, good, empty, cut]);
    assert!(!out.status.success());
    let err = text(&out.stderr);
    assert!(
        err.contains(empty) && err.contains("the file is empty"),
        "{err}"
    );
    let out = tether(&["detect", "--cascade", cascade, huge_path]);
    assert!(!out.status.success());
    let err = text(&out.stderr);
    assert!(
        err.contains(huge_path) && err.contains("8000x8000"),
        "{err}"
    );

    // With it, every image is in the report, the bad ones with their error; the cut
    // JPEG decodes (grey past the cut, as OpenCV) and says so.
    let out = tether(&[
        "detect",
        "--keep-going",
        "--cascade",
        cascade,
        good,
        empty,
        cut,
        huge_path,
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let err = text(&out.stderr);
    assert!(err.contains("2 of 4 images could not be read"), "{err}");
    assert!(
        err.contains(&format!("{cut}: premature end of JPEG data")),
        "{err}"
    );
    assert!(!err.contains("\u{1b}["), "colour codes in a pipe: {err}");
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let images = report["images"].as_array().unwrap();
    assert_eq!(images.len(), 4);
    assert!(images[0].get("error").is_none());
    assert!(images[1]["error"].as_str().unwrap().contains("empty"));
    assert!(!images[2]["damage"].as_array().unwrap().is_empty());
    assert!(images[3]["error"].as_str().unwrap().contains("truncated"));

    // An image passed as the cascade is named as such.
    let out = tether(&["detect", "--cascade", good, good]);
    let err = text(&out.stderr);
    assert!(
        err.contains("is not an XML text file (it is a JPEG image)"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_small_things_a_user_trips_on() {
    let dir = scratch("small-things");
    let bag = common::corridor_bag(&dir, 4);
    let bag = bag.to_str().unwrap();

    // `--out -` is standard output: the JSON lines there, the summary in the log.
    let out = tether(&["track", bag, "--scan-topic", "/scan", "--out", "-"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let lines = tether_testkit::json_lines(&text(&out.stdout));
    assert!(lines.len() >= 30, "{} lines", lines.len());
    let err = text(&out.stderr);
    assert!(err.contains("-> stdout"), "{err}");
    assert!(!dir.join("-").exists());
    // Nothing happened: no warning that says "0".
    assert!(!err.contains(" 0 scans"), "{err}");
    assert!(!err.contains("WARN"), "{err}");
    let out = tether(&["legs", bag, "--topic", "/scan", "--out", "-"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(text(&out.stdout).lines().count() >= 30);

    // The emulator says which modes there are.
    let out = tether(&["urg-emulator"]);
    let err = text(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains("--pty") && err.contains("--tcp"), "{err}");

    // `--duration 0` says what is allowed.
    let out = tether(&[
        "sim",
        "--scenario",
        "corridor",
        "--duration",
        "0",
        "--out",
        dir.join("zero").to_str().unwrap(),
    ]);
    let err = text(&out.stderr);
    assert!(err.contains("more than 0 s and at most 86400 s"), "{err}");

    // A missing --data says where it looked.
    let out = tether(&["eval-legs", "--data", "no/such/folder"]);
    let err = text(&out.stderr);
    assert!(
        err.contains("looked for /") && err.contains("no/such/folder"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_robots_own_config_tunes_a_replay() {
    let dir = scratch("robot-config");
    let bag = common::corridor_bag(&dir, 4);
    let config = common::example_config();
    let config = config.to_str().unwrap();
    let bag_arg = bag.to_str().unwrap();
    let out = tether(&[
        "-v",
        "track",
        bag_arg,
        "--scan-topic",
        "/scan",
        "--config",
        config,
        "--out",
        dir.join("t.jsonl").to_str().unwrap(),
    ]);
    let err = text(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("not used here: [base], [output], laser.serial, laser.baud"),
        "{err}"
    );
    let out = on_recording(
        "replay",
        &bag,
        "/scan",
        &["--config", config],
        &dir.join("r.mcap"),
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    // A robot config with a mistake is refused by name, as `tether run` would.
    let bad = dir.join("bad.toml");
    std::fs::write(
        &bad,
        std::fs::read_to_string(config)
            .unwrap()
            .replace("max_speed_mps = 0.5 ", "max_speed_mps = 1e300 "),
    )
    .unwrap();
    let out = on_recording(
        "track",
        &bag,
        "/scan",
        &["--config", bad.to_str().unwrap()],
        &dir.join("t2.jsonl"),
    );
    assert!(!out.status.success());
    assert!(
        text(&out.stderr).contains("robot.max_speed_mps"),
        "{}",
        text(&out.stderr)
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn detect_draws_its_boxes() {
    let Some(image) = tether_testkit::shared("data/images/people/messi5.jpg") else {
        return;
    };
    let dir = scratch("detect-draw");
    let cascade = upperbody_model();
    let drawn = dir.join("drawn");
    let out = tether(&[
        "detect",
        "--cascade",
        cascade.to_str().unwrap(),
        "--min-neighbors",
        "0",
        "--draw",
        drawn.to_str().unwrap(),
        image.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let boxes = report["images"][0]["boxes"].as_array().unwrap();
    assert!(!boxes.is_empty(), "no boxes to draw");
    let decoder = png::Decoder::new(std::io::BufReader::new(
        std::fs::File::open(drawn.join("messi5.png")).unwrap(),
    ));
    let mut reader = decoder.read_info().unwrap();
    let mut pixels = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut pixels).unwrap();
    assert_eq!(
        (info.width, info.height, info.color_type),
        (
            report["images"][0]["width"].as_u64().unwrap() as u32,
            report["images"][0]["height"].as_u64().unwrap() as u32,
            png::ColorType::Rgb
        )
    );
    let b: Vec<usize> = boxes[0]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_u64().unwrap() as usize)
        .collect();
    let at = 3 * (b[1] * info.width as usize + b[0]);
    assert_eq!(
        &pixels[at..at + 3],
        &[230, 20, 20],
        "the box's corner is red"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn calibrate_laser_prints_the_block_that_pastes_into_the_robots_config() {
    let dir = scratch("calibrate-paste");
    let mut csv = String::from("true_range_m,measured_range_m\n");
    for (k, r) in [0.5, 1.0, 2.0, 3.0, 4.0, 5.0].iter().enumerate() {
        for i in 0..30 {
            // A 10 mm bias and a spread that grows with range (deterministic).
            let e = 0.010 + (0.003 + 0.002 * r) * (((i * 7 + k * 3) % 11) as f64 - 5.0) / 5.0;
            csv.push_str(&format!("{r},{}\n", r + e));
        }
    }
    let samples = dir.join("s.csv");
    std::fs::write(&samples, csv).unwrap();
    let out = tether(&[
        "calibrate",
        "laser",
        "--samples",
        samples.to_str().unwrap(),
        "--out",
        dir.join("laser.toml").to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    let block = &stdout[stdout.find("[pipeline.laser.noise]").expect(&stdout)..];
    // Pasted at the end of the example robot config, it is read by the commands.
    let example = std::fs::read_to_string(common::example_config()).unwrap();
    let config = dir.join("robot.toml");
    std::fs::write(&config, format!("{example}\n{block}")).unwrap();
    tracks_with(&dir, &config);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn calibrate_camera_prints_what_goes_into_the_robots_config() {
    let dir = scratch("calibrate-camera-paste");
    let samples = dir.join("cam.csv");
    std::fs::write(
        &samples,
        "distance_m,x,y,w,h\n2.0,290,60,80,160\n3.0,300,110,56,112\n4.0,305,135,42,84\n5.0,310,150,34,68\n",
    )
    .unwrap();
    let out = tether(&[
        "calibrate",
        "camera",
        "--samples",
        samples.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    let mount = stdout
        .lines()
        .find(|l| l.starts_with("mount = {"))
        .unwrap_or_else(|| panic!("{stdout}"));
    let vision = &stdout[stdout.find("[pipeline.vision]").expect(&stdout)..];
    assert!(vision.contains("box_margin_frac = "), "{stdout}");
    // The mount line replaces the example's, the table goes at the end: the commands
    // read the result.
    let example = std::fs::read_to_string(common::example_config()).unwrap();
    let old = example
        .lines()
        .find(|l| l.starts_with("mount = { x_m = 0.05"))
        .unwrap();
    let config = dir.join("robot.toml");
    std::fs::write(
        &config,
        format!("{}\n{vision}", example.replace(old, mount)),
    )
    .unwrap();
    tracks_with(&dir, &config);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_file_that_is_no_recording_is_named_for_what_it_is() {
    let dir = scratch("not-a-recording");
    let fake = dir.join("fake.mcap");
    std::fs::write(&fake, "hello\n").unwrap();
    let image = dir.join("image.bag");
    std::fs::write(&image, b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR").unwrap();
    for (file, says) in [(&fake, "(text;"), (&image, "(a PNG image;")] {
        for args in [
            vec![
                "track",
                file.to_str().unwrap(),
                "--scan-topic",
                "/scan",
                "--out",
            ],
            vec!["legs", file.to_str().unwrap(), "--topic", "/scan", "--out"],
        ] {
            let mut args = args;
            let out_path = dir.join("out.jsonl");
            args.push(out_path.to_str().unwrap());
            let out = tether(&args);
            let err = text(&out.stderr);
            assert!(!out.status.success());
            assert!(err.contains("is not a ROS 1 bag or MCAP file"), "{err}");
            assert!(err.contains(says), "{err}");
        }
    }
    let out = tether(&[
        "replay",
        dir.to_str().unwrap(),
        "--out",
        dir.join("r.mcap").to_str().unwrap(),
    ]);
    assert!(
        text(&out.stderr)
            .contains("is a folder, not a recording file; it holds fake.mcap, image.bag"),
        "{}",
        text(&out.stderr)
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A number outside its range is named by its dotted key and refused when the file is
/// read, whichever table holds it and whichever command reads it.
#[test]
fn a_number_outside_its_range_is_named_when_the_config_is_read() {
    let dir = scratch("config-range");
    for (table, key, value, range) in [
        ("safety", "laser_timeout_s", "5.0", "> 0, <= 1"),
        ("tracker.gate", "threshold", "0.0", "> 0"),
        ("vision", "max_range_m", "-1.0", "> 0"),
        ("scan_matcher.icp", "trim_fraction", "1.0", ">= 0, < 1"),
    ] {
        let config = dir.join("range.toml");
        std::fs::write(&config, format!("[{table}]\n{key} = {value}\n")).unwrap();
        let out = tether(&[
            "replay",
            dir.join("nothing.mcap").to_str().unwrap(),
            "--config",
            config.to_str().unwrap(),
        ]);
        assert!(!out.status.success());
        let stderr = text(&out.stderr);
        assert!(
            stderr.contains(&format!("`{table}.{key}` is {value}, must be {range}")),
            "{stderr}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn config_defaults_prints_a_config_the_commands_read() {
    let dir = scratch("config-defaults");
    let out = tether(&["config", "defaults"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let defaults = text(&out.stdout);
    assert!(
        defaults.contains(
            "# Stop when the newest laser scan is older than this, s. (> 0, <= 1)\n\
             laser_timeout_s = 0.3"
        ),
        "{defaults}"
    );
    assert!(defaults.contains("\n[safety]\n"), "{defaults}");
    let config = dir.join("defaults.toml");
    std::fs::write(&config, &defaults).unwrap();
    tracks_with(&dir, &config);
    let _ = std::fs::remove_dir_all(&dir);
}
