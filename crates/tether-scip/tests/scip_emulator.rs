//! The SCIP 2.0 driver against the emulator, over a pseudo-terminal (the serial path a
//! USB-ACM URG-04LX takes) and over loopback TCP (the Ethernet models), issue 7.
//!
//! What belongs here: whole sessions through real links. Each test checks every value
//! the driver delivers against the scan source the emulator served, and, for the
//! malformed cases (wrong check characters, truncated lines, unknown statuses,
//! garbage, a device that stops answering mid-scan), that the driver reports each one
//! as a typed fault, counts exactly what the emulator injected, and recovers.

#![allow(
    clippy::unwrap_used,
    reason = "test code: a failed unwrap is a failed test"
)]

use std::time::{Duration, Instant};

use tether_core::UrgGeometry;
use tether_scip::emulator::{
    Emulator, EmulatorConfig, EmulatorServer, Endpoint, Faults, FnSource, ScanSource, Stall,
};
use tether_scip::{
    DriverConfig, DriverEvent, DriverStats, Encoding, Fault, Link, ReplyFault, StatusKind,
    SystemClock, UrgDriver, UrgScan, connect_tcp, open_serial,
};

/// Scan `k`'s range at measured step index `i`, mm: beam 0 carries the scan index, a
/// few beams carry error codes (1..=19), the rest a pattern that changes every scan.
fn range_mm(k: u64, i: usize) -> u32 {
    if i == 0 {
        1000 + (k % 4000) as u32
    } else if i % 97 == 5 {
        1 + (i % 19) as u32
    } else {
        20 + ((i as u64 * 37 + k * 101) % 5500) as u32
    }
}

fn source() -> Box<dyn ScanSource> {
    Box::new(FnSource(|k: u64, out: &mut Vec<u32>| {
        out.extend((0..682).map(|i| range_mm(k, i)));
    }))
}

/// Checks a delivered scan against the source: geometry, every beam, error codes.
fn check_scan(s: &UrgScan) -> u64 {
    let scan = &s.scan;
    assert_eq!(scan.len(), 682);
    assert_eq!(scan.frame_id, "laser");
    let g = UrgGeometry::default();
    assert!((scan.angle_min_rad - g.angle_min_rad()).abs() < 1e-12);
    assert!((scan.angle_min_rad - -2.0862).abs() < 1e-4);
    assert!((scan.angle_increment_rad - 0.006_135_923_151_542_565).abs() < 1e-15);
    let k = u64::from((scan.ranges_m()[0] * 1000.0).round() as u32 - 1000);
    let mut errors = 0;
    for (i, &r) in scan.ranges_m().iter().enumerate() {
        let mm = range_mm(k, i);
        if mm < 20 {
            assert_eq!(r, f32::INFINITY, "scan {k} beam {i}: error code {mm}");
            errors += 1;
        } else {
            assert_eq!(r, mm as f32 / 1000.0, "scan {k} beam {i}");
        }
    }
    assert_eq!(s.error_beams, errors);
    assert!((s.scan_time_s - 0.1).abs() < 1e-12);
    k
}

fn driver_config() -> DriverConfig {
    DriverConfig {
        reply_timeout: Duration::from_millis(1500),
        ..DriverConfig::default()
    }
}

enum Host {
    Pty,
    Tcp,
}

fn serve(host: &Host, config: EmulatorConfig) -> EmulatorServer<Box<dyn ScanSource>> {
    let emulator = Emulator::new(config, source());
    match host {
        Host::Pty => EmulatorServer::pty(emulator).unwrap(),
        Host::Tcp => EmulatorServer::tcp(emulator, "127.0.0.1:0").unwrap(),
    }
}

/// A clean session: handshake, a stream of scans, a single scan, stop.
fn clean_run<L: Link>(mut urg: UrgDriver<L, SystemClock>) {
    let info = urg.info().clone();
    assert_eq!(info.geometry, UrgGeometry::default());
    assert_eq!(
        (info.range_min_mm, info.range_max_mm, info.scan_rpm),
        (20, 5600, 600)
    );
    assert_eq!(info.version["PROT"], "SCIP 2.0");
    assert_eq!(info.state["LASR"], "OFF");
    urg.start().unwrap();
    let mut previous: Option<UrgScan> = None;
    for _ in 0..15 {
        let s = urg.next_scan().unwrap();
        let k = check_scan(&s);
        if let Some(p) = &previous {
            assert_eq!(k, check_scan(p) + 1, "consecutive scans");
            assert_eq!(s.sensor_time_ms - p.sensor_time_ms, 100);
            let dt = s.scan.stamp.ns_since(p.scan.stamp);
            assert!(
                (95_000_000..=105_000_000).contains(&dt),
                "stamp step {dt} ns"
            );
        }
        // Stamped before it arrived, and not long before.
        let lag = s.received.ns_since(s.scan.stamp);
        assert!((0..1_000_000_000).contains(&lag), "lag {lag} ns");
        previous = Some(s);
    }
    urg.stop().unwrap();
    let single = urg.single_scan().unwrap();
    check_scan(&single);
    urg.stop().unwrap();
    let stats = *urg.stats();
    assert_eq!(stats.scans, 15);
    assert_eq!(
        stats.checksum_errors + stats.malformed_replies + stats.unknown_echoes,
        0
    );
    assert_eq!(stats.timeouts + stats.restarts, 0);
}

fn clean_session(host: Host) {
    let server = serve(&host, EmulatorConfig::default());
    match server.endpoint().clone() {
        Endpoint::Pty(path) => {
            let port = open_serial(&path, 19_200).unwrap();
            clean_run(UrgDriver::connect(port, SystemClock, driver_config()).unwrap());
        }
        Endpoint::Tcp(addr) => {
            let stream = connect_tcp(&addr.to_string(), Duration::from_secs(2)).unwrap();
            clean_run(UrgDriver::connect(stream, SystemClock, driver_config()).unwrap());
        }
    }
    let emulator = server.stop().unwrap();
    assert_eq!(emulator.stats().bad_checksums, 0);
    assert!(!emulator.is_streaming());
}

#[test]
fn pty_session_delivers_every_beam() {
    clean_session(Host::Pty);
}

#[test]
fn tcp_session_delivers_every_beam() {
    clean_session(Host::Tcp);
}

/// Collects events until 25 good scans came; checks each and that every kind of
/// fault was reported.
fn faulty_run<L: Link>(mut urg: UrgDriver<L, SystemClock>) -> DriverStats {
    urg.start().unwrap();
    let mut seen = std::collections::BTreeMap::<&str, u64>::new();
    let mut scans = 0;
    let deadline = Instant::now() + Duration::from_secs(60);
    while scans < 25 && Instant::now() < deadline {
        let what = match urg.next_event().unwrap() {
            DriverEvent::Scan(s) => {
                check_scan(&s);
                scans += 1;
                "scan"
            }
            DriverEvent::Fault(Fault::Reply(ReplyFault::Checksum { .. })) => "checksum",
            DriverEvent::Fault(Fault::Reply(ReplyFault::ValueCount { .. })) => "truncated",
            DriverEvent::Fault(Fault::Reply(ReplyFault::UnknownEcho { .. })) => "garbage",
            DriverEvent::Fault(Fault::Status {
                kind: StatusKind::Unknown,
                status,
                ..
            }) => {
                assert_eq!(&status.0, b"7Z");
                "unknown status"
            }
            // The stall: a timeout with half a reply received, then a restart that
            // needed more than one QT (the first ones fell into the stall). A heavily
            // loaded machine may add timeouts of its own; they must recover too.
            DriverEvent::Fault(Fault::Timeout {
                partial_reply: true,
                ..
            }) => "timeout mid-reply",
            DriverEvent::Fault(Fault::Timeout { .. }) => "timeout",
            DriverEvent::Fault(Fault::Restarted { attempts }) if attempts >= 2 => {
                "restarted after retries"
            }
            DriverEvent::Fault(Fault::Restarted { .. }) => "restarted",
            DriverEvent::Fault(other) => panic!("unexpected fault {other:?}"),
        };
        *seen.entry(what).or_default() += 1;
    }
    urg.stop().unwrap();
    for kind in [
        "scan",
        "checksum",
        "truncated",
        "garbage",
        "unknown status",
        "timeout mid-reply",
        "restarted after retries",
    ] {
        assert!(
            seen.get(kind).is_some_and(|&n| n > 0),
            "{kind} never seen: {seen:?}"
        );
    }
    *urg.stats()
}

/// Every malformed case at once; the driver reports each and keeps delivering good
/// scans until 25 have come.
fn faulty_session(host: Host) {
    let faults = Faults {
        bad_checksum_every: Some(3),
        truncated_line_every: Some(4),
        unknown_status_every: Some(5),
        garbage_every: Some(7),
        stall: Some(Stall {
            at_scan: 11,
            duration_ms: 2000,
        }),
        seed: 7,
    };
    let server = serve(
        &host,
        EmulatorConfig {
            faults,
            ..EmulatorConfig::default()
        },
    );
    let config = DriverConfig {
        reply_timeout: Duration::from_millis(500),
        scan_timeout: Some(Duration::from_millis(900)),
        max_restart_attempts: 20,
        ..DriverConfig::default()
    };
    let stats = match server.endpoint().clone() {
        Endpoint::Pty(path) => {
            let port = open_serial(&path, 19_200).unwrap();
            faulty_run(UrgDriver::connect(port, SystemClock, config).unwrap())
        }
        Endpoint::Tcp(addr) => {
            let stream = connect_tcp(&addr.to_string(), Duration::from_secs(2)).unwrap();
            faulty_run(UrgDriver::connect(stream, SystemClock, config).unwrap())
        }
    };
    let injected = *server.stop().unwrap().stats();
    // Every injected fault was seen and counted once (stop() drained the stream).
    assert_eq!(
        stats.checksum_errors, injected.bad_checksums,
        "{stats:?} {injected:?}"
    );
    assert_eq!(stats.malformed_replies, injected.truncated_lines);
    assert_eq!(stats.unknown_status, injected.unknown_statuses);
    assert_eq!(stats.unknown_echoes, injected.garbage_bursts);
    assert_eq!(injected.stalls, 1);
    assert!(stats.partial_replies_dropped >= 1);
    assert!(stats.timeouts >= 1);
    assert_eq!(
        stats.restarts, stats.timeouts,
        "every timeout was recovered"
    );
    assert!(
        injected.bytes_ignored > 0,
        "the restart's first QT fell into the stall"
    );
}

#[test]
fn pty_driver_reports_and_recovers_from_every_fault() {
    faulty_session(Host::Pty);
}

#[test]
fn tcp_driver_reports_and_recovers_from_every_fault() {
    faulty_session(Host::Tcp);
}

#[test]
fn switches_a_scip_1_1_sensor_and_unwraps_its_clock() {
    // An older URG-04LX boots in SCIP 1.1; its 24-bit clock is 400 ms from wrapping.
    let config = EmulatorConfig {
        boot_in_scip1: true,
        clock_start_ms: (1 << 24) - 400,
        ..EmulatorConfig::default()
    };
    let server = serve(&Host::Tcp, config);
    let Endpoint::Tcp(addr) = server.endpoint().clone() else {
        panic!("tcp");
    };
    let stream = connect_tcp(&addr.to_string(), Duration::from_secs(2)).unwrap();
    let mut urg = UrgDriver::connect(stream, SystemClock, driver_config()).unwrap();
    urg.start().unwrap();
    let mut last: Option<UrgScan> = None;
    let mut wrapped = false;
    for _ in 0..12 {
        let s = urg.next_scan().unwrap();
        check_scan(&s);
        if let Some(p) = &last {
            wrapped |= s.sensor_time_ms < p.sensor_time_ms;
            let dt = s.scan.stamp.ns_since(p.scan.stamp);
            assert!(
                (95_000_000..=105_000_000).contains(&dt),
                "stamp step {dt} ns"
            );
        }
        last = Some(s);
    }
    assert!(wrapped, "the sensor clock wrapped during the test");
    urg.stop().unwrap();
}

#[test]
fn two_character_clustered_scans() {
    let server = serve(&Host::Tcp, EmulatorConfig::default());
    let Endpoint::Tcp(addr) = server.endpoint().clone() else {
        panic!("tcp");
    };
    let stream = connect_tcp(&addr.to_string(), Duration::from_secs(2)).unwrap();
    let config = DriverConfig {
        encoding: Encoding::Two,
        cluster: 3,
        steps: Some((44, 724)),
        ..driver_config()
    };
    let mut urg = UrgDriver::connect(stream, SystemClock, config).unwrap();
    let s = urg.single_scan().unwrap();
    // 681 steps in clusters of 3: 227 beams, centred on the middle step of each.
    assert_eq!(s.scan.len(), 227);
    let g = UrgGeometry::default();
    assert!((s.scan.angle_min_rad - g.angle_of_step_rad(45)).abs() < 1e-12);
    assert!((s.scan.angle_increment_rad - 3.0 * g.angle_increment_rad()).abs() < 1e-15);
    // The first scan the emulator makes; each beam is the smallest distance of its
    // three steps, clamped to 4095 mm by the 2-character encoding.
    let k = 0;
    for (b, &r) in s.scan.ranges_m().iter().enumerate() {
        let group: Vec<u32> = (3 * b..3 * b + 3).map(|i| range_mm(k, i)).collect();
        let distances: Vec<u32> = group.iter().copied().filter(|&v| v >= 20).collect();
        match distances.iter().min() {
            Some(&mm) => assert_eq!(r, mm.min(4095) as f32 / 1000.0, "beam {b}"),
            None => assert_eq!(r, f32::INFINITY),
        }
    }
    urg.stop().unwrap();
}

#[test]
fn refusals_are_errors_not_panics() {
    let server = serve(&Host::Tcp, EmulatorConfig::default());
    let Endpoint::Tcp(addr) = server.endpoint().clone() else {
        panic!("tcp");
    };
    let stream = connect_tcp(&addr.to_string(), Duration::from_secs(2)).unwrap();
    // Step 800 is beyond the URG-04LX's last step (768): status 04.
    let config = DriverConfig {
        steps: Some((44, 800)),
        ..driver_config()
    };
    let mut urg = UrgDriver::connect(stream, SystemClock, config).unwrap();
    let err = urg.start().unwrap_err();
    assert!(err.to_string().contains("status 04"), "{err}");
    assert!(matches!(
        urg.next_event(),
        Err(tether_scip::ScipError::NotStreaming)
    ));
}
