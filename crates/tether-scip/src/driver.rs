//! The URG driver: handshake, streaming, recovery, and conversion to
//! [`tether_core::LaserScan`].

use std::collections::{BTreeMap, VecDeque};
use std::io;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use tether_core::{LaserScan, NO_RETURN, ScanError, Stamp, UrgGeometry};
use thiserror::Error;

use crate::command::{Command, CommandError, Request, ScanKind, ScanRequest, TimeMode};
use crate::encoding::Encoding;
use crate::link::Link;
use crate::response::{ParseEvent, Reply, ReplyFault, ReplyParser, ScanReply, Status, StatusKind};
use crate::time::{RoundTrip, TimeSync};

/// A source of host time, ns. The driver reads it when bytes arrive (to stamp scans)
/// and to measure timeouts; algorithms get the numbers, never the clock.
pub trait Clock {
    /// Now, ns since the clock's epoch.
    fn now_ns(&self) -> i64;
}

/// The host's wall clock (ns since the Unix epoch), what ROS stamps use.
#[derive(Debug, Clone, Copy, Default)]
pub struct SystemClock;

impl Clock for SystemClock {
    fn now_ns(&self) -> i64 {
        SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(0, |d| i64::try_from(d.as_nanos()).unwrap_or(i64::MAX))
    }
}

/// Why the driver cannot go on.
#[derive(Debug, Error)]
pub enum ScipError {
    /// The device could not be opened.
    #[error("cannot open laser {device}: {source}")]
    Open {
        /// Device path or address.
        device: String,
        /// What the system said.
        source: io::Error,
    },
    /// Reading or writing the link failed.
    #[error("laser link failed while {doing}: {source}")]
    Io {
        /// What the driver was doing.
        doing: &'static str,
        /// What the system said.
        source: io::Error,
    },
    /// The link was closed by the other end.
    #[error("the laser closed the link (unplugged, or another program took it)")]
    Closed,
    /// No reply to a command in time.
    #[error(
        "no reply to {command} within {waited_ms} ms: is the device a SCIP 2.0 Hokuyo, powered, \
         and (serial) at the right baud rate?"
    )]
    Timeout {
        /// Command symbol.
        command: &'static str,
        /// Time waited.
        waited_ms: u64,
    },
    /// The sensor refused a command.
    #[error("the laser answered {command} with status {status} ({kind:?})")]
    Refused {
        /// Command symbol.
        command: &'static str,
        /// Status characters.
        status: String,
        /// Its meaning.
        kind: StatusKind,
    },
    /// The `PP` reply lacks a field or has a value that makes no sense.
    #[error(
        "the laser's PP reply has no valid `{field}` (got {value:?}); it is not a SCIP 2.0 URG"
    )]
    BadParameters {
        /// Field name.
        field: &'static str,
        /// Its value, if present.
        value: Option<String>,
    },
    /// A command could not be encoded (a configuration value out of range).
    #[error("invalid laser command: {0}")]
    Command(#[from] CommandError),
    /// Restarting the stream failed this many times in a row.
    #[error("the laser stopped answering: {attempts} attempts to restart the scan stream failed")]
    NotResponding {
        /// Attempts made.
        attempts: u32,
    },
    /// `next_event` was called without a running stream.
    #[error("the scan stream is not running; call start() first")]
    NotStreaming,
}

/// How the driver talks to the sensor. Every field has a default that suits a
/// URG-04LX.
#[derive(Debug, Clone)]
pub struct DriverConfig {
    /// `frame_id` of the scans. Default `laser`.
    pub frame_id: String,
    /// `Three` (`MD`, up to 262 m) or `Two` (`MS`, up to 4095 mm, faster on slow
    /// serial links). Default `Three`.
    pub encoding: Encoding,
    /// First and last step; default `None`: `AMIN..=AMAX` from `PP` (682 beams on a
    /// URG-04LX).
    pub steps: Option<(u16, u16)>,
    /// Neighbouring steps merged into one beam (the sensor reports their minimum).
    /// Default 1.
    pub cluster: u8,
    /// Scans the sensor skips between two it sends (`0..=9`). Default 0.
    pub skip_scans: u8,
    /// Wait for a command's reply. Default 1 s.
    pub reply_timeout: Duration,
    /// Silence while streaming after which the stream is restarted; default `None`:
    /// three scan periods plus the reply timeout.
    pub scan_timeout: Option<Duration>,
    /// `TM1` round trips for the time sync. Default 5.
    pub time_sync_rounds: u8,
    /// Restart attempts before giving up. Default 10.
    pub max_restart_attempts: u32,
    /// How long one read of the link blocks. Default 20 ms.
    pub read_timeout: Duration,
}

impl Default for DriverConfig {
    fn default() -> Self {
        DriverConfig {
            frame_id: "laser".into(),
            encoding: Encoding::Three,
            steps: None,
            cluster: 1,
            skip_scans: 0,
            reply_timeout: Duration::from_secs(1),
            scan_timeout: None,
            time_sync_rounds: 5,
            max_restart_attempts: 10,
            read_timeout: Duration::from_millis(20),
        }
    }
}

/// What the sensor said about itself in the handshake.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct SensorInfo {
    /// `VV` fields (`VEND`, `PROD`, `FIRM`, `PROT`, `SERI`).
    pub version: BTreeMap<String, String>,
    /// `PP` fields (`MODL`, `DMIN`, `DMAX`, `ARES`, `AMIN`, `AMAX`, `AFRT`, `SCAN`).
    pub parameters: BTreeMap<String, String>,
    /// `II` fields (`LASR`, `SCSP`, `MESM`, `SBPS`, `TIME`, `STAT`, ...).
    pub state: BTreeMap<String, String>,
    /// Steps from `PP`: `ARES`, `AMIN`, `AMAX`, `AFRT`.
    pub geometry: UrgGeometry,
    /// `DMIN`, mm: values below it are error codes.
    pub range_min_mm: u32,
    /// `DMAX`, mm.
    pub range_max_mm: u32,
    /// `SCAN`, motor speed, rpm (600 on a URG-04LX: a scan every 100 ms).
    pub scan_rpm: u32,
}

impl SensorInfo {
    /// Time between scans, s (`60 / SCAN`).
    pub fn scan_period_s(&self) -> f64 {
        60.0 / f64::from(self.scan_rpm.max(1))
    }
}

/// A scan from the sensor.
#[derive(Debug, Clone, PartialEq)]
pub struct UrgScan {
    /// The scan: host time of the sensor's stamp, beams from the first requested step,
    /// error codes (values below `DMIN`) as "no return".
    pub scan: LaserScan,
    /// The sensor's stamp, ms (24 bits).
    pub sensor_time_ms: u32,
    /// Host time the reply was complete.
    pub received: Stamp,
    /// Beams that carried an error code.
    pub error_beams: usize,
    /// Time between scans, s.
    pub scan_time_s: f64,
    /// Time between neighbouring beams, s (`scan_time * cluster / ARES`).
    pub time_increment_s: f64,
}

/// A problem the driver met and recovered from.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum Fault {
    /// A reply was dropped (wrong check character, truncated line, garbage, ...).
    #[error("reply dropped: {0}")]
    Reply(ReplyFault),
    /// A reply's status was an error or unknown.
    #[error("{command} reply with status {} ({kind:?})", status.as_str())]
    Status {
        /// Command symbol.
        command: &'static str,
        /// The status.
        status: Status,
        /// Its meaning.
        kind: StatusKind,
    },
    /// Nothing usable arrived for the scan timeout; the stream is being restarted.
    #[error("no scan for {waited_ms} ms (partial reply dropped: {partial_reply})")]
    Timeout {
        /// Time since the last good reply.
        waited_ms: u64,
        /// Whether part of a reply had arrived.
        partial_reply: bool,
    },
    /// The stream was restarted (`QT`, `BM`, `MD`).
    #[error("scan stream restarted after {attempts} attempt(s)")]
    Restarted {
        /// Attempts it took.
        attempts: u32,
    },
    /// A reply that decoded but cannot form a scan.
    #[error("scan dropped: {0}")]
    BadScan(ScanError),
}

/// What [`UrgDriver::next_event`] returns.
#[derive(Debug, Clone, PartialEq)]
pub enum DriverEvent {
    /// A scan.
    Scan(UrgScan),
    /// A problem the driver recovered from.
    Fault(Fault),
}

/// Counts of everything the driver met.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DriverStats {
    /// Scans delivered.
    pub scans: u64,
    /// Replies dropped for a wrong check character.
    pub checksum_errors: u64,
    /// Replies dropped as malformed (bad line, wrong value count, oversized).
    pub malformed_replies: u64,
    /// Replies dropped because their first line echoes no command (garbage).
    pub unknown_echoes: u64,
    /// Replies with a status the manual does not define for their command.
    pub unknown_status: u64,
    /// Replies with a documented error status.
    pub error_status: u64,
    /// Stream timeouts.
    pub timeouts: u64,
    /// Successful stream restarts.
    pub restarts: u64,
    /// Partial replies dropped at a timeout.
    pub partial_replies_dropped: u64,
    /// Good replies that answered nothing the driver waited for.
    pub unexpected_replies: u64,
    /// Bytes received.
    pub bytes_received: u64,
}

/// A Hokuyo SCIP 2.0 laser on a [`Link`].
///
/// [`UrgDriver::connect`] performs the handshake: `SCIP2.0` (switches older URG-04LX
/// firmware out of SCIP 1.1), `QT` (stops a stream left running), `VV`, `PP` (the
/// step geometry and range limits), `II`, and the time sync (`TM0`, `TM1` a few times,
/// `TM2`). [`UrgDriver::start`] sends `BM` and `MD` (or `MS`); [`UrgDriver::next_event`]
/// then yields scans and the faults met on the way: damaged replies are dropped and
/// counted, and when nothing good arrives for the scan timeout the driver drops any
/// partial reply and restarts the stream with `QT`, `BM`, `MD`.
///
/// ```no_run
/// use tether_scip::{UrgDriver, DriverConfig, SystemClock, open_serial};
/// let port = open_serial("/dev/ttyACM0", 19_200)?;
/// let mut urg = UrgDriver::connect(port, SystemClock, DriverConfig::default())?;
/// urg.start()?;
/// loop {
///     let scan = urg.next_scan()?;
///     println!("{} beams at {}", scan.scan.len(), scan.scan.stamp);
/// }
/// # Ok::<(), tether_scip::ScipError>(())
/// ```
pub struct UrgDriver<L: Link, C: Clock> {
    link: L,
    clock: C,
    config: DriverConfig,
    parser: ReplyParser,
    info: SensorInfo,
    sync: TimeSync,
    streaming: bool,
    /// Parsed events with the host time their last byte arrived.
    pending: VecDeque<(ParseEvent, i64)>,
    /// Faults met while waiting for replies, delivered by `next_event`.
    faults: VecDeque<Fault>,
    stats: DriverStats,
    read_buf: Vec<u8>,
    last_good_ns: i64,
}

impl<L: Link, C: Clock> UrgDriver<L, C> {
    /// Performs the handshake and the time sync; the laser is off afterwards.
    pub fn connect(mut link: L, clock: C, config: DriverConfig) -> Result<Self, ScipError> {
        link.set_read_timeout(config.read_timeout)
            .map_err(|source| ScipError::Io {
                doing: "setting the read timeout",
                source,
            })?;
        let now = clock.now_ns();
        let mut driver = UrgDriver {
            link,
            clock,
            config,
            parser: ReplyParser::new(),
            info: SensorInfo::default(),
            sync: TimeSync::with_offset(0),
            streaming: false,
            pending: VecDeque::new(),
            faults: VecDeque::new(),
            stats: DriverStats::default(),
            read_buf: vec![0; 4096],
            last_good_ns: now,
        };
        // A SCIP 1.1 sensor answers `0`, a SCIP 2.0 one `0E` (not a command it knows).
        match driver.request(&Request::new(Command::Scip20))? {
            Reply::Status { status, .. }
                if matches!(
                    status.kind(&Command::Scip20),
                    StatusKind::Ok | StatusKind::UnknownCommand
                ) => {}
            other => return Err(refused(Command::Scip20.symbol(), &other)),
        }
        driver.expect_ok(Command::Quit, &[])?;
        let version = driver.fields(Command::Version)?;
        let parameters = driver.fields(Command::Parameters)?;
        let state = driver.fields(Command::Info)?;
        driver.info = sensor_info(version, parameters, state)?;
        driver.sync_time()?;
        Ok(driver)
    }

    /// What the sensor said about itself.
    pub fn info(&self) -> &SensorInfo {
        &self.info
    }

    /// Counts of everything met so far.
    pub fn stats(&self) -> &DriverStats {
        &self.stats
    }

    /// The current sensor-to-host time mapping.
    pub fn time_sync(&self) -> &TimeSync {
        &self.sync
    }

    /// Whether the scan stream is running.
    pub fn is_streaming(&self) -> bool {
        self.streaming
    }

    /// Gives the link back (after `stop`, so that the sensor is quiet).
    pub fn into_link(self) -> L {
        self.link
    }

    /// The scan request the configuration asks for.
    fn scan_request(&self, kind: ScanKind) -> ScanRequest {
        let g = &self.info.geometry;
        let (start, end) = self
            .config
            .steps
            .unwrap_or((g.first_step as u16, g.last_step as u16));
        ScanRequest {
            encoding: self.config.encoding,
            start_step: start,
            end_step: end,
            cluster: self.config.cluster,
            kind,
        }
    }

    /// Laser on (`BM`) and the scan stream (`MD`/`MS`, endless).
    pub fn start(&mut self) -> Result<(), ScipError> {
        self.laser_on()?;
        let md = Command::Scan(self.scan_request(ScanKind::Continuous {
            interval: self.config.skip_scans,
            count: 0,
        }));
        self.expect_ok(md, &[])?;
        self.streaming = true;
        self.last_good_ns = self.clock.now_ns();
        Ok(())
    }

    /// Stops the stream, laser off (`QT`).
    pub fn stop(&mut self) -> Result<(), ScipError> {
        self.streaming = false;
        self.expect_ok(Command::Quit, &[])
    }

    /// Resets the sensor to its power-on state (`RS`); the stream stops.
    pub fn reset(&mut self) -> Result<(), ScipError> {
        self.streaming = false;
        self.expect_ok(Command::Reset, &[])
    }

    fn laser_on(&mut self) -> Result<(), ScipError> {
        // `02`: the laser is already on.
        self.expect_ok(Command::LaserOn, &[*b"02"])
    }

    /// One scan (`GD`/`GS`) while no stream runs; the laser is switched on first.
    pub fn single_scan(&mut self) -> Result<UrgScan, ScipError> {
        if self.streaming {
            self.stop()?;
        }
        self.laser_on()?;
        let request = self.scan_request(ScanKind::Single);
        match self.request(&Request::new(Command::Scan(request)))? {
            Reply::Scan(reply) => {
                let received = self.clock.now_ns();
                self.make_scan(reply, received)
                    .map_err(|e| ScipError::BadParameters {
                        field: "scan",
                        value: Some(e.to_string()),
                    })
            }
            other => Err(refused(Command::Scan(request).symbol(), &other)),
        }
    }

    /// Measures the offset between the sensor's clock and the host's with `TM`; stops
    /// the stream first (the sensor refuses range commands in adjust mode).
    pub fn sync_time(&mut self) -> Result<(), ScipError> {
        if self.streaming {
            self.stop()?;
        }
        // `02`: adjust mode was already on.
        self.expect_ok(Command::Time(TimeMode::Start), &[*b"02"])?;
        let mut trips = Vec::new();
        for _ in 0..self.config.time_sync_rounds.max(1) {
            let sent = self.clock.now_ns();
            let reply = self.request(&Request::new(Command::Time(TimeMode::Request)))?;
            let received = self.clock.now_ns();
            match reply {
                Reply::Time { sensor_ms, .. } => trips.push(RoundTrip {
                    host_sent_ns: sent,
                    sensor_ms,
                    host_received_ns: received,
                }),
                other => return Err(refused("TM", &other)),
            }
        }
        self.expect_ok(Command::Time(TimeMode::End), &[*b"03"])?;
        if let Some(sync) = TimeSync::from_round_trips(&trips) {
            self.sync = sync;
        }
        Ok(())
    }

    /// The next scan, skipping (and counting) faults.
    pub fn next_scan(&mut self) -> Result<UrgScan, ScipError> {
        loop {
            if let DriverEvent::Scan(scan) = self.next_event()? {
                return Ok(scan);
            }
        }
    }

    /// The next scan or fault of the running stream. Restarts the stream itself when it
    /// falls silent; fails only when the link fails or restarting does not work.
    pub fn next_event(&mut self) -> Result<DriverEvent, ScipError> {
        if !self.streaming {
            return Err(ScipError::NotStreaming);
        }
        loop {
            if let Some(fault) = self.faults.pop_front() {
                return Ok(DriverEvent::Fault(fault));
            }
            if let Some((event, at_ns)) = self.pending.pop_front() {
                if let Some(out) = self.stream_event(event, at_ns) {
                    return Ok(out);
                }
                continue;
            }
            let now = self.clock.now_ns();
            let waited_ns = now.saturating_sub(self.last_good_ns);
            if waited_ns > self.scan_timeout_ns() {
                let partial_reply = self.parser.reset();
                self.pending.clear();
                self.stats.timeouts += 1;
                if partial_reply {
                    self.stats.partial_replies_dropped += 1;
                }
                self.restart()?;
                return Ok(DriverEvent::Fault(Fault::Timeout {
                    waited_ms: (waited_ns.max(0) / 1_000_000) as u64,
                    partial_reply,
                }));
            }
            self.read_some()?;
        }
    }

    fn scan_timeout_ns(&self) -> i64 {
        let d = self.config.scan_timeout.unwrap_or_else(|| {
            Duration::from_secs_f64(3.0 * self.info.scan_period_s()) + self.config.reply_timeout
        });
        i64::try_from(d.as_nanos()).unwrap_or(i64::MAX)
    }

    /// What a parsed event means while streaming.
    fn stream_event(&mut self, event: ParseEvent, at_ns: i64) -> Option<DriverEvent> {
        match event {
            ParseEvent::Reply(Reply::Scan(reply))
                if matches!(reply.request.kind, ScanKind::Continuous { .. }) =>
            {
                self.last_good_ns = at_ns;
                match self.make_scan(reply, at_ns) {
                    Ok(scan) => {
                        self.stats.scans += 1;
                        Some(DriverEvent::Scan(scan))
                    }
                    Err(e) => Some(DriverEvent::Fault(Fault::BadScan(e))),
                }
            }
            ParseEvent::Reply(Reply::Status { request, status }) => {
                let kind = status.kind(&request.command);
                if kind == StatusKind::Ok {
                    self.stats.unexpected_replies += 1;
                    return None;
                }
                self.count_status(kind);
                // The sensor is alive and talking: not a reason to restart.
                self.last_good_ns = at_ns;
                Some(DriverEvent::Fault(Fault::Status {
                    command: request.command.symbol(),
                    status,
                    kind,
                }))
            }
            ParseEvent::Reply(_) => {
                self.stats.unexpected_replies += 1;
                None
            }
            ParseEvent::Fault(f) => {
                self.count_fault(&f);
                Some(DriverEvent::Fault(Fault::Reply(f)))
            }
        }
    }

    fn count_status(&mut self, kind: StatusKind) {
        if kind == StatusKind::Unknown {
            self.stats.unknown_status += 1;
        } else {
            self.stats.error_status += 1;
        }
    }

    fn count_fault(&mut self, f: &ReplyFault) {
        match f {
            ReplyFault::Checksum { .. } => self.stats.checksum_errors += 1,
            ReplyFault::UnknownEcho { .. } => self.stats.unknown_echoes += 1,
            _ => self.stats.malformed_replies += 1,
        }
    }

    /// `QT`, `BM`, `MD` until the sensor answers, up to the configured attempts.
    fn restart(&mut self) -> Result<(), ScipError> {
        self.streaming = false;
        let attempts = self.config.max_restart_attempts.max(1);
        // The caller dropped the partial reply; later attempts keep what arrives (a
        // reply that completes late is parsed and counted like any other).
        for attempt in 1..=attempts {
            match self
                .expect_ok(Command::Quit, &[])
                .and_then(|()| self.start())
            {
                Ok(()) => {
                    self.stats.restarts += 1;
                    self.faults
                        .push_back(Fault::Restarted { attempts: attempt });
                    return Ok(());
                }
                Err(ScipError::Timeout { .. } | ScipError::Refused { .. }) => continue,
                Err(e) => return Err(e),
            }
        }
        Err(ScipError::NotResponding { attempts })
    }

    /// Reads what the link has (waiting at most the read timeout) into the parser.
    fn read_some(&mut self) -> Result<(), ScipError> {
        match self.link.read(&mut self.read_buf) {
            Ok(0) => Err(ScipError::Closed),
            Ok(n) => {
                let at = self.clock.now_ns();
                self.stats.bytes_received += n as u64;
                self.parser.push(&self.read_buf[..n]);
                while let Some(event) = self.parser.next_event() {
                    self.pending.push_back((event, at));
                }
                Ok(())
            }
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::TimedOut
                        | io::ErrorKind::WouldBlock
                        | io::ErrorKind::Interrupted
                ) =>
            {
                Ok(())
            }
            Err(source) => Err(ScipError::Io {
                doing: "reading",
                source,
            }),
        }
    }

    /// Sends `request` and waits for the reply that echoes it. Other replies are
    /// dropped (scans of a stream being stopped) and counted; faults are kept for
    /// `next_event`.
    fn request(&mut self, request: &Request) -> Result<Reply, ScipError> {
        let bytes = request.encode()?;
        self.link
            .write_all(&bytes)
            .and_then(|()| self.link.flush())
            .map_err(|source| match source.kind() {
                io::ErrorKind::BrokenPipe | io::ErrorKind::ConnectionReset => ScipError::Closed,
                _ => ScipError::Io {
                    doing: "writing a command",
                    source,
                },
            })?;
        let start = self.clock.now_ns();
        let timeout_ns = i64::try_from(self.config.reply_timeout.as_nanos()).unwrap_or(i64::MAX);
        loop {
            while let Some((event, _)) = self.pending.pop_front() {
                match event {
                    ParseEvent::Reply(reply) if answers(&reply, request) => return Ok(reply),
                    ParseEvent::Reply(Reply::Status { request, status })
                        if status.kind(&request.command) != StatusKind::Ok =>
                    {
                        // A stream's error or unknown status, met while waiting.
                        let kind = status.kind(&request.command);
                        self.count_status(kind);
                        self.faults.push_back(Fault::Status {
                            command: request.command.symbol(),
                            status,
                            kind,
                        });
                    }
                    ParseEvent::Reply(_) => self.stats.unexpected_replies += 1,
                    ParseEvent::Fault(f) => {
                        self.count_fault(&f);
                        self.faults.push_back(Fault::Reply(f));
                    }
                }
            }
            let waited = self.clock.now_ns().saturating_sub(start);
            if waited > timeout_ns {
                return Err(ScipError::Timeout {
                    command: request.command.symbol(),
                    waited_ms: (waited.max(0) / 1_000_000) as u64,
                });
            }
            self.read_some()?;
        }
    }

    /// Sends a command whose reply carries only a status; `00` and the `also_ok`
    /// statuses are success.
    fn expect_ok(&mut self, command: Command, also_ok: &[[u8; 2]]) -> Result<(), ScipError> {
        match self.request(&Request::new(command))? {
            Reply::Status { status, .. } if status == Status::OK || also_ok.contains(&status.0) => {
                Ok(())
            }
            other => Err(refused(command.symbol(), &other)),
        }
    }

    fn fields(&mut self, command: Command) -> Result<BTreeMap<String, String>, ScipError> {
        match self.request(&Request::new(command))? {
            Reply::Fields { fields, .. } => Ok(fields.into_iter().collect()),
            other => Err(refused(command.symbol(), &other)),
        }
    }

    fn make_scan(&mut self, reply: ScanReply, received_ns: i64) -> Result<UrgScan, ScanError> {
        let stamp_ns = self.sync.observe(reply.timestamp_ms, received_ns);
        let (scan, error_beams) = laser_scan(
            &reply,
            &self.info,
            Stamp::from_ns(stamp_ns),
            &self.config.frame_id,
        )?;
        let scan_time_s = self.info.scan_period_s();
        Ok(UrgScan {
            scan,
            sensor_time_ms: reply.timestamp_ms,
            received: Stamp::from_ns(received_ns),
            error_beams,
            scan_time_s,
            time_increment_s: scan_time_s * f64::from(reply.request.cluster_steps())
                / f64::from(self.info.geometry.steps_per_rev.max(1)),
        })
    }
}

/// A scan reply as a tether scan, and the number of beams that carried an error code.
///
/// Beam `i` covers steps `start + i * cluster ..` and points at the middle of them:
/// `angle = (start + i * cluster + (cluster - 1) / 2 - AFRT) * 2 pi / ARES`. Values below
/// `DMIN` are error codes and become "no return" (`+inf`); the others are mm.
pub fn laser_scan(
    reply: &ScanReply,
    info: &SensorInfo,
    stamp: Stamp,
    frame_id: &str,
) -> Result<(LaserScan, usize), ScanError> {
    let g = info.geometry;
    let r = reply.request;
    let cluster = f64::from(r.cluster_steps());
    let step_rad = g.angle_increment_rad();
    let angle_min_rad =
        (f64::from(r.start_step) + (cluster - 1.0) / 2.0 - f64::from(g.front_step)) * step_rad;
    let min_mm = info.range_min_mm;
    let mut error_beams = 0;
    let ranges_m: Vec<f32> = reply
        .values_mm
        .iter()
        .map(|&v| {
            if v < min_mm {
                error_beams += 1;
                NO_RETURN
            } else {
                v as f32 / 1000.0
            }
        })
        .collect();
    let scan = LaserScan::new(
        stamp,
        frame_id,
        angle_min_rad,
        cluster * step_rad,
        f64::from(min_mm) / 1000.0,
        f64::from(info.range_max_mm) / 1000.0,
        ranges_m,
    )?;
    Ok((scan, error_beams))
}

/// Whether `reply` answers `request`: same echo (symbol, parameters, tag). Stream scans
/// never answer a request (their echo carries the scans remaining).
fn answers(reply: &Reply, request: &Request) -> bool {
    match reply {
        Reply::Status { request: echo, .. } | Reply::Fields { request: echo, .. } => {
            echo == request
        }
        Reply::Time { tag, .. } => {
            request.command == Command::Time(TimeMode::Request) && *tag == request.tag
        }
        Reply::Scan(scan) => {
            scan.request.kind == ScanKind::Single
                && request.command == Command::Scan(scan.request)
                && scan.tag == request.tag
        }
    }
}

fn refused(command: &'static str, reply: &Reply) -> ScipError {
    match reply {
        Reply::Status { request, status } => ScipError::Refused {
            command,
            status: status.as_str(),
            kind: status.kind(&request.command),
        },
        _ => ScipError::Refused {
            command,
            status: "(unexpected reply)".into(),
            kind: StatusKind::Unknown,
        },
    }
}

fn sensor_info(
    version: BTreeMap<String, String>,
    parameters: BTreeMap<String, String>,
    state: BTreeMap<String, String>,
) -> Result<SensorInfo, ScipError> {
    let num = |field: &'static str| -> Result<u32, ScipError> {
        let value = parameters.get(field);
        value
            .and_then(|v| v.trim().parse::<u32>().ok())
            .ok_or_else(|| ScipError::BadParameters {
                field,
                value: value.cloned(),
            })
    };
    let geometry = UrgGeometry {
        steps_per_rev: num("ARES")?,
        first_step: num("AMIN")?,
        last_step: num("AMAX")?,
        front_step: num("AFRT")?,
        // SCIP scanners turn counter-clockwise (the protocol's step order).
        clockwise: false,
    };
    if !(geometry.steps_per_rev > 0
        && geometry.first_step <= geometry.front_step
        && geometry.front_step <= geometry.last_step
        && geometry.last_step < geometry.steps_per_rev
        && geometry.last_step <= 9999)
    {
        return Err(ScipError::BadParameters {
            field: "AMIN/AMAX/AFRT/ARES",
            value: Some(format!("{geometry:?}")),
        });
    }
    let range_min_mm = num("DMIN")?;
    let range_max_mm = num("DMAX")?;
    if range_min_mm >= range_max_mm {
        return Err(ScipError::BadParameters {
            field: "DMIN/DMAX",
            value: Some(format!("{range_min_mm}/{range_max_mm}")),
        });
    }
    let scan_rpm = num("SCAN")?;
    if scan_rpm == 0 {
        return Err(ScipError::BadParameters {
            field: "SCAN",
            value: Some("0".into()),
        });
    }
    Ok(SensorInfo {
        version,
        parameters,
        state,
        geometry,
        range_min_mm,
        range_max_mm,
        scan_rpm,
    })
}
