//! A URG that speaks SCIP 2.0 byte for byte, serving scans from a caller's source, with
//! fault injection; over a pseudo-terminal or TCP ([`EmulatorServer`]).
//!
//! [`Emulator`] is the protocol alone: it takes the host's bytes and the time (ms since
//! it started) and produces the sensor's bytes, so a test can drive it without any
//! I/O. It answers `SCIP2.0`, `VV`, `PP`, `II`, `BM`, `QT`, `RS`, `TM0/1/2`,
//! `MD`/`MS` (a scan every `60000 / SCAN` ms, with the cluster, skip and count of the
//! request; the echo carries the scans remaining) and `GD`/`GS`, with the statuses of
//! the manual's section 8 (`0E` for unknown commands, section 9). Choices where the
//! manual is silent: a command other than `TM` or `RS` in time-adjust mode gets `0E`;
//! steps outside `AMIN..=AMAX` read 0 (an error code); values beyond what `MS`/`GS`
//! can carry are sent as 4095; in SCIP 1.1 mode (`boot_in_scip1`) anything but
//! `SCIP2.0` is ignored.
//!
//! Scans come from a [`ScanSource`]: one range in mm per measured step (`AMIN` to
//! `AMAX`), values below `DMIN` being error codes ("no return").

mod server;

pub use server::{EmulatorServer, Endpoint};

use tether_core::UrgGeometry;

use crate::command::{Command, Request, ScanKind, ScanRequest, TimeMode, parse_request};
use crate::encoding::{checksum, encode, write_block};
use crate::response::{write_head, write_timestamp};
use crate::time::SENSOR_CLOCK_PERIOD_MS;

/// Gives the ranges of each scan the emulator sends.
pub trait ScanSource: Send {
    /// Fills `ranges_mm` (cleared by the caller) with one value per measured step,
    /// `AMIN` to `AMAX` of the emulator's geometry, in mm; values below `DMIN` are
    /// error codes. `scan_index` counts the scans made since the emulator started.
    fn scan(&mut self, scan_index: u64, ranges_mm: &mut Vec<u32>);
}

/// A [`ScanSource`] from a closure.
pub struct FnSource<F>(pub F);

impl<F: FnMut(u64, &mut Vec<u32>) + Send> ScanSource for FnSource<F> {
    fn scan(&mut self, scan_index: u64, ranges_mm: &mut Vec<u32>) {
        (self.0)(scan_index, ranges_mm);
    }
}

impl ScanSource for Box<dyn ScanSource> {
    fn scan(&mut self, scan_index: u64, ranges_mm: &mut Vec<u32>) {
        (**self).scan(scan_index, ranges_mm);
    }
}

/// A device that hangs in the middle of a scan.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Stall {
    /// The streamed scan (1 = first) cut in half before the device falls silent.
    pub at_scan: u64,
    /// How long it stays silent, ignoring every byte it receives, ms.
    pub duration_ms: u64,
}

/// Faults to inject into streamed scans (`MD`/`MS` replies), counted from 1; `None`
/// turns a fault off. Where several fall on one scan, the first of: stall, garbage,
/// unknown status, truncated line, wrong check character (so each injected fault costs
/// exactly one scan and shows as exactly one fault at the host).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Faults {
    /// Every n-th scan has a wrong check character on its first data line.
    pub bad_checksum_every: Option<u64>,
    /// Every n-th scan loses 3 characters of its first data line (its check
    /// character is recomputed, so the loss shows as a short data block).
    pub truncated_line_every: Option<u64>,
    /// Every n-th scan is replaced by a reply with status `7Z`, which the manual does
    /// not define.
    pub unknown_status_every: Option<u64>,
    /// Every n-th scan is preceded by 8 to 23 bytes of garbage without LF (they merge
    /// with the echo line).
    pub garbage_every: Option<u64>,
    /// The device stops answering mid-scan once.
    pub stall: Option<Stall>,
    /// Seed of the garbage bytes.
    pub seed: u64,
}

impl Faults {
    /// No faults.
    pub const NONE: Faults = Faults {
        bad_checksum_every: None,
        truncated_line_every: None,
        unknown_status_every: None,
        garbage_every: None,
        stall: None,
        seed: 0,
    };
}

/// What the emulated sensor is.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EmulatorConfig {
    /// Steps (`ARES`, `AMIN`, `AMAX`, `AFRT`). Default: a URG-04LX's.
    pub geometry: UrgGeometry,
    /// Largest step a request may name (768 on a URG-04LX).
    pub max_step: u16,
    /// `DMIN`, mm. Default 20.
    pub range_min_mm: u32,
    /// `DMAX`, mm. Default 5600.
    pub range_max_mm: u32,
    /// `SCAN`, rpm. Default 600 (a scan every 100 ms).
    pub scan_rpm: u32,
    /// Model name in `PP`/`II`.
    pub model: String,
    /// Serial number in `VV`.
    pub serial: String,
    /// Start in SCIP 1.1 (older URG-04LX firmware): only `SCIP2.0` is understood.
    pub boot_in_scip1: bool,
    /// The sensor's millisecond counter when the emulator starts (set it near 2^24 to
    /// test the wrap).
    pub clock_start_ms: u32,
    /// Faults to inject.
    pub faults: Faults,
}

impl Default for EmulatorConfig {
    fn default() -> Self {
        EmulatorConfig {
            geometry: UrgGeometry::default(),
            max_step: 768,
            range_min_mm: 20,
            range_max_mm: 5600,
            scan_rpm: 600,
            model: "URG-04LX".into(),
            serial: "H0000000".into(),
            boot_in_scip1: false,
            clock_start_ms: 0,
            faults: Faults::NONE,
        }
    }
}

/// What the emulator has done.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct EmulatorStats {
    /// Command lines received.
    pub commands: u64,
    /// Scan replies sent (streamed and single).
    pub scans_sent: u64,
    /// Faults injected, by kind.
    pub bad_checksums: u64,
    /// Truncated lines injected.
    pub truncated_lines: u64,
    /// Unknown statuses injected.
    pub unknown_statuses: u64,
    /// Garbage bursts injected.
    pub garbage_bursts: u64,
    /// Stalls injected.
    pub stalls: u64,
    /// Bytes ignored while stalled.
    pub bytes_ignored: u64,
}

#[derive(Debug, Clone)]
struct Stream {
    request: ScanRequest,
    tag: Option<String>,
    /// Scans still to send; `None`: endless.
    remaining: Option<u8>,
    /// Scans skipped between two sent, and how many remain to skip now.
    skip: u8,
    skip_left: u8,
    /// When the next scan is made, ms since start.
    next_ms: u64,
}

/// The protocol engine of an emulated URG (see the module docs).
pub struct Emulator<S> {
    config: EmulatorConfig,
    source: S,
    scip2: bool,
    laser_on: bool,
    adjust: bool,
    stream: Option<Stream>,
    input: Vec<u8>,
    /// Scans made (index given to the source).
    scans_made: u64,
    /// Streamed scan replies sent (fault schedule counter).
    streamed: u64,
    stalled_until_ms: Option<u64>,
    rng: u64,
    ranges: Vec<u32>,
    stats: EmulatorStats,
}

/// Longest command line kept; longer input is dropped up to the next line end.
const MAX_COMMAND_BYTES: usize = 128;

impl<S: ScanSource> Emulator<S> {
    /// An emulator in its power-on state.
    pub fn new(config: EmulatorConfig, source: S) -> Self {
        let rng = config.faults.seed ^ 0x9E37_79B9_7F4A_7C15;
        Emulator {
            scip2: !config.boot_in_scip1,
            config,
            source,
            laser_on: false,
            adjust: false,
            stream: None,
            input: Vec::new(),
            scans_made: 0,
            streamed: 0,
            stalled_until_ms: None,
            rng,
            ranges: Vec::new(),
            stats: EmulatorStats::default(),
        }
    }

    /// What the emulator has done so far.
    pub fn stats(&self) -> &EmulatorStats {
        &self.stats
    }

    /// The configuration.
    pub fn config(&self) -> &EmulatorConfig {
        &self.config
    }

    /// Time between scans, ms.
    pub fn scan_period_ms(&self) -> u64 {
        60_000 / u64::from(self.config.scan_rpm.max(1))
    }

    /// Whether a scan stream is running.
    pub fn is_streaming(&self) -> bool {
        self.stream.is_some()
    }

    /// The host went away: stop the stream and forget partial input (the state a URG
    /// is in when its USB or TCP connection closes).
    pub fn disconnect(&mut self) {
        self.stream = None;
        self.laser_on = false;
        self.input.clear();
    }

    fn sensor_ms(&self, now_ms: u64) -> u32 {
        ((u64::from(self.config.clock_start_ms) + now_ms) % SENSOR_CLOCK_PERIOD_MS as u64) as u32
    }

    fn stalled(&mut self, now_ms: u64) -> bool {
        match self.stalled_until_ms {
            Some(until) if now_ms < until => true,
            Some(_) => {
                self.stalled_until_ms = None;
                false
            }
            None => false,
        }
    }

    /// Takes bytes from the host; replies are appended to `out`.
    pub fn receive(&mut self, bytes: &[u8], now_ms: u64, out: &mut Vec<u8>) {
        if self.stalled(now_ms) {
            self.stats.bytes_ignored += bytes.len() as u64;
            return;
        }
        for &b in bytes {
            if b == b'\n' || b == b'\r' {
                if !self.input.is_empty() {
                    let line = std::mem::take(&mut self.input);
                    if line.len() <= MAX_COMMAND_BYTES {
                        self.command(&line, now_ms, out);
                    }
                }
            } else if self.input.len() <= MAX_COMMAND_BYTES {
                self.input.push(b);
            }
        }
    }

    /// Makes the scans that are due by `now_ms`; their replies are appended to `out`.
    /// Returns when the next scan is due (ms since start), if a stream runs.
    pub fn poll(&mut self, now_ms: u64, out: &mut Vec<u8>) -> Option<u64> {
        if self.stalled(now_ms) {
            return self.stalled_until_ms;
        }
        let period = self.scan_period_ms();
        while let Some(stream) = self.stream.as_mut() {
            if now_ms < stream.next_ms {
                break;
            }
            let made_ms = stream.next_ms;
            // A host that stopped reading for long: skip ahead rather than flood.
            stream.next_ms = if now_ms - made_ms > 5 * period {
                (now_ms / period + 1) * period
            } else {
                made_ms + period
            };
            if stream.skip_left > 0 {
                stream.skip_left -= 1;
                self.scans_made += 1;
                continue;
            }
            stream.skip_left = stream.skip;
            self.stream_scan(made_ms, now_ms, out);
            if self.stalled_until_ms.is_some() {
                break;
            }
        }
        self.stream.as_ref().map(|s| s.next_ms)
    }

    fn command(&mut self, line: &[u8], now_ms: u64, out: &mut Vec<u8>) {
        self.stats.commands += 1;
        if !self.scip2 {
            if line == b"SCIP2.0" {
                out.extend_from_slice(b"SCIP2.0\n0\n\n");
                self.scip2 = true;
            }
            return;
        }
        let request = match parse_request(line) {
            Ok(r) => r,
            Err(e) => return reply_status(line, e.status(), out),
        };
        if self.adjust && !matches!(request.command, Command::Time(_) | Command::Reset) {
            return reply_status(line, *b"0E", out);
        }
        match request.command {
            Command::Scip20 => reply_status(line, *b"0E", out),
            Command::Version => {
                let fields = [
                    (
                        "VEND",
                        "Hokuyo Automatic Co.,Ltd. (tether emulator)".to_owned(),
                    ),
                    ("PROD", format!("SOKUIKI Sensor {}", self.config.model)),
                    ("FIRM", "3.1.04(tether emulator)".to_owned()),
                    ("PROT", "SCIP 2.0".to_owned()),
                    ("SERI", self.config.serial.clone()),
                ];
                reply_fields(line, &fields, out);
            }
            Command::Parameters => {
                let c = &self.config;
                let g = &c.geometry;
                let fields = [
                    ("MODL", format!("{}(Hokuyo Automatic Co.,Ltd.)", c.model)),
                    ("DMIN", c.range_min_mm.to_string()),
                    ("DMAX", c.range_max_mm.to_string()),
                    ("ARES", g.steps_per_rev.to_string()),
                    ("AMIN", g.first_step.to_string()),
                    ("AMAX", g.last_step.to_string()),
                    ("AFRT", g.front_step.to_string()),
                    ("SCAN", c.scan_rpm.to_string()),
                ];
                reply_fields(line, &fields, out);
            }
            Command::Info => {
                let fields = [
                    (
                        "MODL",
                        format!("{}(Hokuyo Automatic Co.,Ltd.)", self.config.model),
                    ),
                    ("LASR", if self.laser_on { "ON" } else { "OFF" }.to_owned()),
                    ("SCSP", format!("Initial({}[rpm])", self.config.scan_rpm)),
                    (
                        "MESM",
                        if self.stream.is_some() {
                            "Measuring"
                        } else {
                            "IDLE"
                        }
                        .to_owned(),
                    ),
                    ("SBPS", "19200[bps]".to_owned()),
                    ("TIME", format!("{:06X}", self.sensor_ms(now_ms))),
                    ("STAT", "Sensor works well.".to_owned()),
                ];
                reply_fields(line, &fields, out);
            }
            Command::LaserOn => {
                if self.laser_on {
                    reply_status(line, *b"02", out);
                } else {
                    self.laser_on = true;
                    reply_status(line, *b"00", out);
                }
            }
            Command::Quit => {
                self.stream = None;
                self.laser_on = false;
                reply_status(line, *b"00", out);
            }
            Command::Reset => {
                self.stream = None;
                self.laser_on = false;
                self.adjust = false;
                reply_status(line, *b"00", out);
            }
            Command::Time(mode) => self.time(line, mode, now_ms, out),
            Command::Scan(scan) => self.scan_command(line, scan, request, now_ms, out),
        }
    }

    fn time(&mut self, line: &[u8], mode: TimeMode, now_ms: u64, out: &mut Vec<u8>) {
        match mode {
            TimeMode::Start if self.adjust => reply_status(line, *b"02", out),
            TimeMode::Start => {
                self.adjust = true;
                self.stream = None;
                self.laser_on = false;
                reply_status(line, *b"00", out);
            }
            TimeMode::Request if !self.adjust => reply_status(line, *b"04", out),
            TimeMode::Request => {
                write_head(line, *b"00", out);
                write_timestamp(self.sensor_ms(now_ms), out);
                out.push(b'\n');
            }
            TimeMode::End if !self.adjust => reply_status(line, *b"03", out),
            TimeMode::End => {
                self.adjust = false;
                reply_status(line, *b"00", out);
            }
        }
    }

    fn scan_command(
        &mut self,
        line: &[u8],
        scan: ScanRequest,
        request: Request,
        now_ms: u64,
        out: &mut Vec<u8>,
    ) {
        if scan.end_step > self.config.max_step {
            return reply_status(line, *b"04", out);
        }
        match scan.kind {
            ScanKind::Single => {
                if !self.laser_on {
                    return reply_status(line, *b"10", out);
                }
                write_head(line, *b"00", out);
                self.scan_body(&scan, self.sensor_ms(now_ms), out);
                self.stats.scans_sent += 1;
            }
            ScanKind::Continuous { interval, count } => {
                reply_status(line, *b"00", out);
                self.laser_on = true;
                let period = self.scan_period_ms();
                self.stream = Some(Stream {
                    request: scan,
                    tag: request.tag,
                    remaining: (count > 0).then_some(count),
                    skip: interval,
                    skip_left: 0,
                    next_ms: (now_ms / period + 1) * period,
                });
            }
        }
    }

    /// Time stamp, data lines and the closing LF of a scan reply.
    fn scan_body(&mut self, scan: &ScanRequest, stamp_ms: u32, out: &mut Vec<u8>) {
        let g = self.config.geometry;
        self.ranges.clear();
        self.source.scan(self.scans_made, &mut self.ranges);
        self.scans_made += 1;
        write_timestamp(stamp_ms, out);
        let cluster = u32::from(scan.cluster_steps());
        let min_mm = self.config.range_min_mm;
        let mut block = Vec::with_capacity(scan.value_count() * 3);
        let mut step = u32::from(scan.start_step);
        let end = u32::from(scan.end_step);
        while step <= end {
            let group_end = (step + cluster - 1).min(end);
            let mut best: Option<u32> = None;
            let mut first_code = None;
            for s in step..=group_end {
                let v = if (g.first_step..=g.last_step).contains(&s) {
                    self.ranges
                        .get((s - g.first_step) as usize)
                        .copied()
                        .unwrap_or(0)
                } else {
                    0
                };
                if v >= min_mm {
                    best = Some(best.map_or(v, |b| b.min(v)));
                } else if first_code.is_none() {
                    first_code = Some(v);
                }
            }
            encode(best.or(first_code).unwrap_or(0), scan.encoding, &mut block);
            step = group_end + 1;
        }
        write_block(&block, out);
        out.push(b'\n');
    }

    fn stream_scan(&mut self, made_ms: u64, now_ms: u64, out: &mut Vec<u8>) {
        let Some(stream) = self.stream.as_mut() else {
            return;
        };
        let remaining = stream.remaining.map(|r| r.saturating_sub(1));
        stream.remaining = remaining;
        let request = stream.request;
        let tag = stream.tag.clone();
        if remaining == Some(0) {
            self.stream = None;
            self.laser_on = false;
        }
        let echo = stream_echo(&request, remaining.unwrap_or(0), tag.as_deref());
        self.streamed += 1;
        self.stats.scans_sent += 1;
        let k = self.streamed;
        let f = self.config.faults;
        let stall = f.stall.filter(|s| s.at_scan == k);
        let garbage = stall.is_none()
            && f.garbage_every
                .is_some_and(|n| n > 0 && k.is_multiple_of(n));
        // Garbage costs the scan anyway: no other fault is injected into it.
        let due =
            |every: Option<u64>| !garbage && every.is_some_and(|n| n > 0 && k.is_multiple_of(n));
        if garbage {
            self.stats.garbage_bursts += 1;
            let n = 8 + (self.next_random() % 16) as usize;
            for _ in 0..n {
                let mut b = (self.next_random() >> 24) as u8;
                if b == b'\n' {
                    b = b'#';
                }
                out.push(b);
            }
        }
        let start = out.len();
        if due(f.unknown_status_every) {
            self.stats.unknown_statuses += 1;
            write_head(&echo, *b"7Z", out);
            out.push(b'\n');
            return;
        }
        write_head(&echo, *b"99", out);
        self.scan_body(&request, self.sensor_ms(made_ms), out);
        // The first data line starts after echo, status (3 + LF) and stamp (5 + LF).
        let line_start = start + echo.len() + 1 + 4 + 6;
        let Some(line_len) = out[line_start..].iter().position(|&b| b == b'\n') else {
            return;
        };
        let sum_at = line_start + line_len - 1;
        if let Some(stall) = stall {
            self.stats.stalls += 1;
            out.truncate(start + (out.len() - start) / 2);
            self.stalled_until_ms = Some(now_ms + stall.duration_ms);
        } else if due(f.truncated_line_every) && line_len > 4 {
            self.stats.truncated_lines += 1;
            out.drain(line_start..line_start + 3);
            let sum = checksum(&out[line_start..sum_at - 3]);
            out[sum_at - 3] = sum;
        } else if due(f.bad_checksum_every) {
            self.stats.bad_checksums += 1;
            let c = out[sum_at];
            out[sum_at] = if c == b'0' { b'1' } else { c - 1 };
        }
    }

    /// xorshift64*: the garbage bytes, reproducible from the seed.
    fn next_random(&mut self) -> u64 {
        self.rng ^= self.rng >> 12;
        self.rng ^= self.rng << 25;
        self.rng ^= self.rng >> 27;
        self.rng.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
}

/// The echo of a streamed scan: the request with the scans remaining as its count.
fn stream_echo(request: &ScanRequest, remaining: u8, tag: Option<&str>) -> Vec<u8> {
    let mut echo = Command::Scan(*request).symbol().as_bytes().to_vec();
    let (interval, _) = match request.kind {
        ScanKind::Continuous { interval, count } => (interval, count),
        ScanKind::Single => (0, 0),
    };
    echo.extend(
        format!(
            "{:04}{:04}{:02}{}{:02}",
            request.start_step,
            request.end_step,
            request.cluster,
            interval.min(9),
            remaining.min(99)
        )
        .bytes(),
    );
    if let Some(tag) = tag {
        echo.push(b';');
        echo.extend_from_slice(tag.as_bytes());
    }
    echo
}

fn reply_status(echo: &[u8], status: [u8; 2], out: &mut Vec<u8>) {
    write_head(echo, status, out);
    out.push(b'\n');
}

fn reply_fields(echo: &[u8], fields: &[(&str, String)], out: &mut Vec<u8>) {
    write_head(echo, *b"00", out);
    for (key, value) in fields {
        let start = out.len();
        out.extend_from_slice(key.as_bytes());
        out.push(b':');
        out.extend_from_slice(value.as_bytes());
        let sum = checksum(&out[start..]);
        out.push(b';');
        out.push(sum);
        out.push(b'\n');
    }
    out.push(b'\n');
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::response::{ParseEvent, Reply, ReplyFault, ReplyParser};

    fn ramp() -> FnSource<impl FnMut(u64, &mut Vec<u32>) + Send> {
        FnSource(|k: u64, out: &mut Vec<u32>| {
            out.extend((0..682u32).map(|i| {
                if i % 50 == 7 {
                    1
                } else {
                    100 + i * 5 + k as u32
                }
            }))
        })
    }

    fn run(emu: &mut Emulator<impl ScanSource>, input: &[u8], until_ms: u64) -> Vec<ParseEvent> {
        let mut out = Vec::new();
        emu.receive(input, 0, &mut out);
        let mut t = 0;
        while t <= until_ms {
            emu.poll(t, &mut out);
            t += 10;
        }
        let mut p = ReplyParser::new();
        p.push(&out);
        std::iter::from_fn(|| p.next_event()).collect()
    }

    #[test]
    fn answers_the_handshake() {
        let mut emu = Emulator::new(EmulatorConfig::default(), ramp());
        let events = run(&mut emu, b"SCIP2.0\nVV\nPP\r\nII\rBM\nBM\nXX\nTM1\n", 0);
        assert_eq!(events.len(), 8, "{events:?}");
        let statuses: Vec<String> = events
            .iter()
            .filter_map(|e| match e {
                ParseEvent::Reply(Reply::Status { status, .. }) => Some(status.as_str()),
                _ => None,
            })
            .collect();
        // `XX` is answered `0E` too, but its echo is no command: the parser drops it.
        assert_eq!(statuses, ["0E", "00", "02", "04"]);
        assert!(matches!(
            events[6],
            ParseEvent::Fault(ReplyFault::UnknownEcho { .. })
        ));
        let ParseEvent::Reply(Reply::Fields { fields, .. }) = &events[2] else {
            panic!("{:?}", events[2]);
        };
        assert!(fields.contains(&("AMIN".into(), "44".into())));
        assert!(fields.contains(&("AFRT".into(), "384".into())));
    }

    #[test]
    fn streams_scans_with_counts_clusters_and_skips() {
        let mut emu = Emulator::new(EmulatorConfig::default(), ramp());
        // 3 scans, cluster 2, skipping 1 between two: scans at 100, 300, 500 ms.
        let events = run(&mut emu, b"MD0044072502103;abc\n", 1000);
        let scans: Vec<_> = events
            .iter()
            .filter_map(|e| match e {
                ParseEvent::Reply(Reply::Scan(s)) => Some(s),
                _ => None,
            })
            .collect();
        assert_eq!(scans.len(), 3);
        assert_eq!(scans[0].timestamp_ms, 100);
        assert_eq!(scans[1].timestamp_ms, 300);
        assert_eq!(scans[2].values_mm.len(), 341);
        assert_eq!(scans[0].tag.as_deref(), Some("abc"));
        assert_eq!(
            scans
                .iter()
                .map(|s| match s.request.kind {
                    ScanKind::Continuous { count, .. } => count,
                    ScanKind::Single => 99,
                })
                .collect::<Vec<_>>(),
            [2, 1, 0]
        );
        // Cluster of steps 44, 45 (beams 0, 1 of scan 0): min of 100 and 105.
        assert_eq!(scans[0].values_mm[0], 100);
        // Beam 7 is an error code (1) and its neighbour 6 a distance: the distance wins.
        assert_eq!(scans[0].values_mm[3], 100 + 6 * 5);
        assert!(!emu.is_streaming(), "the stream ends after its count");
    }

    #[test]
    fn injects_each_fault_on_schedule() {
        let faults = Faults {
            bad_checksum_every: Some(2),
            truncated_line_every: Some(3),
            unknown_status_every: Some(5),
            garbage_every: Some(7),
            stall: None,
            seed: 1,
        };
        let config = EmulatorConfig {
            faults,
            ..EmulatorConfig::default()
        };
        let mut emu = Emulator::new(config, ramp());
        let events = run(&mut emu, b"MD0044072501000\n", 3000);
        let kinds: Vec<&str> = events[1..]
            .iter()
            .map(|e| match e {
                ParseEvent::Reply(Reply::Scan(_)) => "scan",
                ParseEvent::Reply(Reply::Status { .. }) => "status",
                ParseEvent::Reply(_) => "reply",
                ParseEvent::Fault(ReplyFault::Checksum { .. }) => "checksum",
                ParseEvent::Fault(ReplyFault::ValueCount { .. }) => "short",
                ParseEvent::Fault(ReplyFault::UnknownEcho { .. }) => "garbage",
                ParseEvent::Fault(_) => "other",
            })
            .collect();
        // Scans 1..=30: 5, 10, ... unknown status; 3, 6, 9 ... short; 2, 4, ... checksum;
        // 7, 14, 21, 28 garbage (which wins over the scan's other faults).
        assert_eq!(
            &kinds[..10],
            [
                "scan", "checksum", "short", "checksum", "status", "short", "garbage", "checksum",
                "short", "status"
            ]
        );
        assert_eq!(emu.stats().garbage_bursts, 4);
    }

    #[test]
    fn stalls_mid_scan_and_ignores_input() {
        let config = EmulatorConfig {
            faults: Faults {
                stall: Some(Stall {
                    at_scan: 2,
                    duration_ms: 500,
                }),
                ..Faults::NONE
            },
            ..EmulatorConfig::default()
        };
        let mut emu = Emulator::new(config, ramp());
        let mut out = Vec::new();
        emu.receive(b"MD0044072501000\n", 0, &mut out);
        emu.poll(250, &mut out);
        let mut p = ReplyParser::new();
        p.push(&out);
        assert_eq!(
            std::iter::from_fn(|| p.next_event()).count(),
            2,
            "ack and scan 1"
        );
        assert!(p.has_partial(), "scan 2 is cut in half");
        out.clear();
        emu.receive(b"QT\n", 300, &mut out);
        assert!(out.is_empty() && emu.stats().bytes_ignored == 3);
        emu.receive(b"QT\n", 800, &mut out);
        assert_eq!(out, b"QT\n00P\n\n");
    }

    #[test]
    fn boots_in_scip_1_1_when_asked() {
        let config = EmulatorConfig {
            boot_in_scip1: true,
            ..EmulatorConfig::default()
        };
        let mut emu = Emulator::new(config, ramp());
        let mut out = Vec::new();
        emu.receive(b"VV\nSCIP2.0\nSCIP2.0\n", 0, &mut out);
        assert_eq!(out, b"SCIP2.0\n0\n\nSCIP2.0\n0Ee\n\n");
    }
}
