//! Recordings that are cut short, of the wrong type or unreadable, through the release
//! binary as a user meets them (issue 16, "Nothing is lost"; design section 13):
//!
//! - a ROS 1 bag cut short is read chunk by chunk up to the cut, with one warning saying
//!   where it stopped and how many messages it read; one with nothing readable is an
//!   error;
//! - an MCAP file cut short (a killed `tether run`, a copy cut off) is read by a linear
//!   scan up to the cut, inside the chunk it cuts too;
//! - a topic that holds no laser scans, or whose every scan fails to decode, is an error
//!   naming the topic's type and the topics that do hold scans, and leaves an earlier
//!   output as it was.
//!
//! The tests on leg_tracker's recordings skip when `../shared` is absent (and fail then
//! under `TETHER_REQUIRE_SHARED=1`); the others build their recordings.

#![allow(clippy::unwrap_used, reason = "a test should fail loudly on bad data")]

mod common;

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Output, Stdio};
use std::time::{Duration, Instant};

use common::live::{Proc, pty_path, tether_command, wheels_config};
use common::{leg_tracker, scratch, tether, text};
use tether_core::Stamp;
use tether_msgs::{Header, RawLaserScan};
use tether_recording::rosbag::BagWriter;

fn p(path: &Path) -> &str {
    path.to_str().unwrap()
}

fn ok(out: &Output) -> String {
    assert!(
        out.status.success(),
        "{}\nstderr:\n{}",
        out.status,
        text(&out.stderr)
    );
    text(&out.stderr)
}

fn failed(out: &Output) -> String {
    assert!(
        !out.status.success(),
        "expected a failure; stdout:\n{}\nstderr:\n{}",
        text(&out.stdout),
        text(&out.stderr)
    );
    text(&out.stderr)
}

/// The first `n` bytes of `from`, as `to`.
fn cut(from: &Path, n: usize, to: &Path) -> PathBuf {
    let bytes = std::fs::read(from).unwrap();
    std::fs::write(to, &bytes[..n.min(bytes.len())]).unwrap();
    to.to_path_buf()
}

fn lines(path: &Path) -> usize {
    std::fs::read_to_string(path).unwrap().lines().count()
}

/// The number in "after N messages" of the cut warning.
fn messages_read(stderr: &str) -> usize {
    let (_, after) = stderr
        .split_once("reading stopped there, after ")
        .unwrap_or_else(|| panic!("no cut warning in:\n{stderr}"));
    after.split(' ').next().unwrap().parse().unwrap()
}

/// "N scans" in replay's summary line.
fn replayed_scans(stdout: &str) -> usize {
    stdout
        .lines()
        .find_map(|l| l.split(" scans").next()?.trim().parse().ok())
        .unwrap_or_else(|| panic!("no scan count in {stdout}"))
}

#[test]
fn a_bag_cut_short_is_read_up_to_the_cut() {
    let Some(demo) = leg_tracker("demo_stationary_simple_environment.bag") else {
        return;
    };
    let dir = scratch("cut-bag");
    let full_out = dir.join("full.jsonl");
    ok(&tether(&[
        "track",
        p(&demo),
        "--scan-topic",
        "/scan",
        "--out",
        p(&full_out),
    ]));
    let full = lines(&full_out);
    assert_eq!(full, 1265);
    let trunc = cut(&demo, 1_000_000, &dir.join("trunc.bag"));
    let out = dir.join("t.jsonl");
    let stderr = ok(&tether(&[
        "track",
        p(&trunc),
        "--scan-topic",
        "/scan",
        "--out",
        p(&out),
    ]));
    assert_eq!(stderr.matches("is cut short").count(), 1, "{stderr}");
    assert!(stderr.contains("chunk record at byte"), "{stderr}");
    let read = messages_read(&stderr);
    assert_eq!(lines(&out), read, "one line per scan read");
    // The first chunk (about 787 KB) is whole, the second is cut.
    assert!(read > 300 && read < full, "{read}");
    // The lines are those of the whole bag's first scans.
    let whole = std::fs::read_to_string(&full_out).unwrap();
    let part = std::fs::read_to_string(&out).unwrap();
    assert!(whole.starts_with(&part));

    let legs = dir.join("l.jsonl");
    let stderr = ok(&tether(&[
        "legs",
        p(&trunc),
        "--topic",
        "/scan",
        "--out",
        p(&legs),
    ]));
    assert_eq!(lines(&legs), messages_read(&stderr));
    let stdout = text(
        &tether(&[
            "replay",
            p(&trunc),
            "--scan-topic",
            "/scan",
            "--out",
            p(&dir.join("r.mcap")),
        ])
        .stdout,
    );
    assert_eq!(replayed_scans(&stdout), read);

    // Nothing readable before the cut (inside the first chunk, or inside the bag
    // header): an error, and the earlier result stays.
    std::fs::write(&out, "earlier result\n").unwrap();
    for (n, what) in [
        (4400, "holds nothing readable"),
        (3000, "bag header record"),
    ] {
        let stub = cut(&demo, n, &dir.join("stub.bag"));
        let stderr = failed(&tether(&[
            "track",
            p(&stub),
            "--scan-topic",
            "/scan",
            "--out",
            p(&out),
        ]));
        assert!(stderr.contains(what), "{n} bytes: {stderr}");
        assert_eq!(std::fs::read_to_string(&out).unwrap(), "earlier result\n");
    }
}

#[test]
fn a_topic_without_scans_is_an_error_naming_the_scan_topics() {
    let Some(bag) = leg_tracker("positive_1_extracted.bag") else {
        return;
    };
    let dir = scratch("wrong-type-bag");
    let out = dir.join("l.jsonl");
    std::fs::write(&out, "earlier result\n").unwrap();
    for command in [
        vec!["legs", p(&bag), "--topic", "/leg_cluster_positions"],
        vec!["track", p(&bag), "--scan-topic", "/leg_cluster_positions"],
    ] {
        let mut args = command.clone();
        args.extend(["--out", p(&out)]);
        let stderr = failed(&tether(&args));
        assert!(
            stderr.contains("\"/leg_cluster_positions\"")
                && stderr.contains("holds geometry_msgs/PoseArray, not laser scans")
                && stderr.contains("the topics with laser scans are: /training_scan"),
            "{command:?}: {stderr}"
        );
        assert_eq!(std::fs::read_to_string(&out).unwrap(), "earlier result\n");
    }
    let stderr = failed(&tether(&[
        "eval-track",
        p(&bag),
        "--scan-topic",
        "/leg_cluster_positions",
        "--labels-topic",
        "/leg_cluster_positions",
    ]));
    assert!(stderr.contains("not laser scans"), "{stderr}");
    // Labels of the wrong type too.
    let stderr = failed(&tether(&[
        "eval-track",
        p(&bag),
        "--scan-topic",
        "/training_scan",
        "--labels-topic",
        "/visualization_marker_array",
    ]));
    assert!(
        stderr.contains("holds visualization_msgs/MarkerArray, not labels"),
        "{stderr}"
    );
}

/// A simulated corridor run recorded as MCAP (`/scan`, `/odom`, ...), `seconds` long.
fn sim_mcap(dir: &Path, seconds: u32) -> PathBuf {
    common::record_corridor(dir, seconds, &["--seed", "3"], "--record", "sim.mcap")
}

#[test]
fn replay_of_a_topic_without_scans_fails_and_keeps_the_earlier_result() {
    let dir = scratch("wrong-type-mcap");
    let record = sim_mcap(&dir, 4);
    let results = dir.join("r.mcap");
    ok(&tether(&["replay", p(&record), "--out", p(&results)]));
    let again = dir.join("r2.mcap");
    std::fs::write(&again, "earlier result").unwrap();
    let stderr = failed(&tether(&[
        "replay",
        p(&results),
        "--scan-topic",
        "/tether/people",
        "--out",
        p(&again),
    ]));
    assert!(
        stderr.contains("holds geometry_msgs/msg/PoseArray, not laser scans")
            && stderr.contains("the topics with laser scans are: none"),
        "{stderr}"
    );
    assert_eq!(std::fs::read_to_string(&again).unwrap(), "earlier result");
    let stderr = failed(&tether(&[
        "replay",
        p(&record),
        "--scan-topic",
        "/odom",
        "--out",
        p(&again),
    ]));
    assert!(
        stderr.contains("holds nav_msgs/msg/Odometry, not laser scans")
            && stderr.contains("the topics with laser scans are: /scan"),
        "{stderr}"
    );
}

#[test]
fn every_scan_failing_to_decode_is_an_error_with_the_first_reason() {
    let dir = scratch("bad-scans");
    let bag_path = dir.join("zero_increment.bag");
    let mut bag = BagWriter::create(&bag_path).unwrap();
    let scan = bag.add_connection::<RawLaserScan>("/scan").unwrap();
    for k in 0..20u32 {
        let stamp = Stamp::from_ns(1_000_000_000 + i64::from(k) * 100_000_000);
        let msg = RawLaserScan {
            header: Header {
                seq: k,
                stamp,
                frame_id: "laser".into(),
            },
            angle_min: -1.0,
            angle_max: 1.0,
            angle_increment: if k % 2 == 0 { 0.0 } else { f32::NAN },
            time_increment: 0.0,
            scan_time: 0.1,
            range_min: 0.02,
            range_max: 5.6,
            ranges: vec![1.0; 11],
            intensities: vec![],
        };
        bag.write(scan, stamp, &msg).unwrap();
    }
    bag.finish().unwrap();
    let out = dir.join("out.jsonl");
    std::fs::write(&out, "earlier result\n").unwrap();
    for command in [
        vec!["legs", p(&bag_path), "--topic", "/scan"],
        vec!["track", p(&bag_path), "--scan-topic", "/scan"],
        vec!["replay", p(&bag_path), "--scan-topic", "/scan"],
    ] {
        let mut args = command.clone();
        args.extend(["--out", p(&out)]);
        let stderr = failed(&tether(&args));
        assert!(
            stderr.contains("none of the 20 messages on \"/scan\"")
                && stderr.contains("angle increment must be finite and non-zero, got 0"),
            "{command:?}: {stderr}"
        );
        assert_eq!(std::fs::read_to_string(&out).unwrap(), "earlier result\n");
    }
}

#[test]
fn an_mcap_cut_short_is_read_up_to_the_cut() {
    let dir = scratch("cut-mcap");
    let record = sim_mcap(&dir, 12);
    let bytes = std::fs::read(&record).unwrap().len();
    let full = replayed_scans(&text(
        &tether(&["replay", p(&record), "--odom-topic", "/odom"]).stdout,
    ));
    let mut previous = 0;
    for percent in [25, 50, 75, 99] {
        let part = cut(
            &record,
            bytes * percent / 100,
            &dir.join(format!("cut{percent}.mcap")),
        );
        let out = tether(&["replay", p(&part), "--odom-topic", "/odom"]);
        let stderr = ok(&out);
        let scans = replayed_scans(&text(&out.stdout));
        let warnings = stderr
            .lines()
            .filter(|l| l.contains("is cut short") || l.contains("walking its records"))
            .count();
        assert_eq!(
            warnings, 1,
            "{percent} %: one warning about the cut:\n{stderr}"
        );
        // The records of the chunk the cut falls in are read up to it (before issue 33
        // the whole chunk was lost: up to 1 s, 10 scans); the share of bytes is only
        // roughly the share of scans.
        let expected = full * percent / 100;
        assert!(
            scans + 25 >= expected && scans >= previous && scans <= full,
            "{percent} %: {scans} of {full} scans"
        );
        previous = scans;
    }
    let stub = cut(&record, 600, &dir.join("stub.mcap"));
    let stderr = failed(&tether(&["replay", p(&stub)]));
    assert!(stderr.contains("holds nothing readable"), "{stderr}");
}

/// The top-level chunk records of an MCAP file: (start, start of its records, end).
fn mcap_chunks(bytes: &[u8]) -> Vec<(usize, usize, usize)> {
    let le = |at: usize| u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap()) as usize;
    let mut chunks = Vec::new();
    let mut pos = 8;
    while pos + 9 <= bytes.len() && bytes[pos] != 0x0F {
        let end = pos + 9 + le(pos + 1);
        if bytes[pos] == 0x06 {
            // Two times, the uncompressed size and CRC, the compression, the length.
            let compression = pos + 9 + 8 + 8 + 8 + 4;
            let records = compression + 4 + le(compression) as u32 as usize + 8;
            chunks.push((pos, records, end));
        }
        pos = end;
    }
    chunks
}

#[test]
fn an_mcap_whose_writer_was_killed_inside_a_chunk_replays_up_to_the_cut() {
    // Issue 33: what an older tether's chunked live recording looks like when the run is
    // killed: the open chunk still has the `mcap` crate's placeholder header (length and
    // sizes u64::MAX, written when the chunk opened, filled in when it closes) and its
    // records so far after it. Built from a finished recording: its third chunk, with
    // the header it had while open and 60 % of its records.
    let dir = scratch("killed-chunk");
    let record = sim_mcap(&dir, 12);
    let bytes = std::fs::read(&record).unwrap();
    let chunks = mcap_chunks(&bytes);
    assert!(chunks.len() >= 5, "{} chunks", chunks.len());
    let (start, records, end) = chunks[2];
    let mut killed = bytes[..start].to_vec();
    killed.push(0x06);
    killed.extend_from_slice(&u64::MAX.to_le_bytes());
    killed.extend_from_slice(&[0; 16]); // message start and end times
    killed.extend_from_slice(&u64::MAX.to_le_bytes()); // uncompressed size
    killed.extend_from_slice(&u32::MAX.to_le_bytes()); // uncompressed CRC
    killed.extend_from_slice(&0u32.to_le_bytes()); // compression: none
    killed.extend_from_slice(&u64::MAX.to_le_bytes()); // records
    killed.extend_from_slice(&bytes[records..records + (end - records) * 3 / 5]);
    let path = dir.join("killed.mcap");
    std::fs::write(&path, &killed).unwrap();
    let before = cut(&record, start, &dir.join("before.mcap"));
    let replay = |p: &Path| {
        let out = tether(&[
            "replay",
            p.to_str().unwrap(),
            "--odom-topic",
            "/odom",
            "--out",
            dir.join("r.mcap").to_str().unwrap(),
        ]);
        let stderr = ok(&out);
        (replayed_scans(&text(&out.stdout)), stderr)
    };
    let (closed, _) = replay(&before);
    let (scans, stderr) = replay(&path);
    println!("{closed} scans in the closed chunks, {scans} with the killed one's");
    assert!(
        scans > closed,
        "{scans} scans, {closed} before the open chunk"
    );
    // One warning, at the record of the killed chunk the file ends in.
    let warning = format!("of the chunk at byte {start}:");
    assert_eq!(stderr.matches("is cut short").count(), 1, "{stderr}");
    assert!(stderr.contains(&warning), "{warning} in:\n{stderr}");
    assert!(
        messages_read(&stderr) > 0,
        "the warning counts what was read:\n{stderr}"
    );
}

#[test]
fn the_recording_of_a_killed_live_run_replays() {
    let dir = scratch("killed-run");
    let mut emu = Proc::start(
        "emulator",
        &dir,
        tether_command(&["urg-emulator", "--pty", "--scenario", "corridor"])
            .stdin(Stdio::null())
            .stdout(Stdio::piped()),
    );
    let pty = pty_path(&mut emu);
    let config = wheels_config(&dir, &pty, "");
    let mut run = Proc::start(
        "run",
        &dir,
        tether_command(&["run", "--config", p(&config)])
            .stdin(Stdio::null())
            .stdout(Stdio::piped()),
    );
    // Three seconds of commands (10 Hz), then SIGKILL: no chance to finish the file.
    let stdout = run.child.stdout.take().unwrap();
    let mut reader = BufReader::new(stdout);
    let started = Instant::now();
    let mut first_line = None;
    let mut line = String::new();
    while first_line.is_none_or(|t: Instant| t.elapsed() < Duration::from_millis(3500)) {
        line.clear();
        let n = reader.read_line(&mut line).unwrap();
        assert!(
            n > 0 && started.elapsed() < Duration::from_secs(60),
            "tether run stopped early: {}",
            run.stderr()
        );
        first_line.get_or_insert_with(Instant::now);
    }
    run.signal("-KILL");
    let _ = run.child.wait();
    drop(emu);
    // The recording (whatever name the run gave it) is readable up to the kill.
    let recordings: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|f| f.extension().is_some_and(|e| e == "mcap"))
        .collect();
    assert_eq!(recordings.len(), 1, "{recordings:?}");
    let out = tether(&[
        "replay",
        p(&recordings[0]),
        "--odom-topic",
        "/odom",
        "--out",
        p(&dir.join("replay.mcap")),
    ]);
    let stderr = ok(&out);
    assert!(
        stderr.contains("is cut short") || stderr.contains("linear scan"),
        "{stderr}"
    );
    let scans = replayed_scans(&text(&out.stdout));
    // 3 s of 10 Hz scans, less at most the second or so of the chunk still open.
    assert!(scans >= 10, "{scans} scans:\n{}", text(&out.stdout));
}
