//! The laser of `tether run`: a SCIP 2.0 Hokuyo on a serial or USB-ACM port, or on TCP
//! (`tether_scip`). The handshake gives the sensor's own geometry, which replaces the
//! configured one; then the driver streams scans on a thread of its own until the run
//! ends, and switches the laser off.
//!
//! A laser that stops answering (a USB cable pulled and plugged back, a sensor that
//! restarts, an Ethernet link that drops) is opened again: the thread says so
//! ([`Input::LaserLost`]; the loop's laser watchdog has the robot standing within
//! `laser_timeout_s`), tries the port or address every [`REOPEN_EVERY`] for up to
//! `reconnect_s`, and goes on streaming when the same sensor answers the handshake again
//! ([`Input::LaserBack`]). Past `reconnect_s` (or at once with `reconnect_s = 0`) the
//! laser has failed for good ([`Input::LaserFailed`]) and the run ends with its final
//! stop.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::SyncSender;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use tether_core::{LaserModel, LaserModelError, UrgGeometry};
use tether_scip::{
    DriverConfig, DriverEvent, Link, ScipError, UrgDriver, connect_tcp, open_serial,
};

use super::Input;
use crate::clock::MonotonicClock;
use crate::config::LaserLink;

/// Why the laser could not be started.
#[derive(Debug, thiserror::Error)]
pub enum LaserStartError {
    /// The port or the address could not be opened.
    #[error(transparent)]
    Link(ScipError),
    /// The sensor did not answer the handshake as a SCIP 2.0 URG does.
    #[error("laser {name}: handshake failed")]
    Handshake {
        /// The port or address.
        name: String,
        /// What the driver met.
        source: ScipError,
    },
    /// The geometry the sensor reports cannot be used.
    #[error("laser {name} ({model}) reports an unusable geometry")]
    Geometry {
        /// The port or address.
        name: String,
        /// The model the sensor names.
        model: String,
        /// What is wrong with it.
        source: LaserModelError,
    },
    /// The scan stream did not start.
    #[error("laser {name}: starting the scan stream")]
    Stream {
        /// The port or address.
        name: String,
        /// What the driver met.
        source: ScipError,
    },
    /// The thread could not be started.
    #[error("starting the laser thread")]
    Thread(#[source] std::io::Error),
}

/// The laser, streaming on its own thread.
#[derive(Debug)]
pub struct Laser {
    /// The driver's thread: it ends at the stop flag, when the loop goes away, or after
    /// sending [`Input::LaserFailed`].
    pub thread: JoinHandle<()>,
    /// Time between scans, s (what the sensor says).
    pub scan_period_s: f64,
}

/// How often a laser that stopped answering is tried again.
pub const REOPEN_EVERY: Duration = Duration::from_millis(500);

/// One scanner of the robot: where it is plugged in, how long it is tried again when
/// it stops answering, and the frame its scans carry.
#[derive(Debug, Clone)]
pub struct LaserSpec {
    /// The port or address.
    pub link: LaserLink,
    /// How long a laser that stops answering is tried again, s.
    pub reconnect_s: f64,
    /// The `frame_id` of its scans (the pipeline tells the scanners apart by it).
    pub frame_id: String,
}

/// Opens the laser of `spec`, takes its geometry into `model` and starts its scans on
/// a thread that sends them to `tx` until `stop` is set. A laser that stops answering
/// is opened again for up to `reconnect_s` (the module's doc).
pub fn start(
    spec: &LaserSpec,
    clock: MonotonicClock,
    model: &mut LaserModel,
    (tx, stop): (SyncSender<Input>, Arc<AtomicBool>),
) -> Result<Laser, LaserStartError> {
    let reconnect =
        Duration::try_from_secs_f64(spec.reconnect_s.max(0.0)).unwrap_or(Duration::ZERO);
    match &spec.link {
        LaserLink::Serial { path, baud } => {
            let (path, baud) = (path.clone(), *baud);
            let open = move || open_serial(&path, baud);
            start_laser(open, reconnect, clock, spec, model, (tx, stop))
        }
        LaserLink::Tcp { address } => {
            let address = address.clone();
            let open = move || connect_tcp(&address, Duration::from_secs(3));
            start_laser(open, reconnect, clock, spec, model, (tx, stop))
        }
    }
}

/// The port or address of `link`, for messages.
fn link_name(link: &LaserLink) -> &str {
    match link {
        LaserLink::Serial { path, .. } => path,
        LaserLink::Tcp { address } => address,
    }
}

/// What the laser thread needs to open its laser again.
struct Reopen<O> {
    /// Opens the port or connects to the address.
    open: O,
    /// The host clock the driver stamps scans with.
    clock: MonotonicClock,
    /// The sensor's geometry at the start: a laser that comes back with another is not
    /// the one the pipeline was set up for.
    geometry: UrgGeometry,
    /// How long to keep trying.
    within: Duration,
    /// The port or address.
    name: String,
    /// The driver's settings (the scans' frame).
    driver: DriverConfig,
}

impl<L: Link, O: FnMut() -> Result<L, ScipError>> Reopen<O> {
    /// One attempt: the link, the handshake, the same geometry, the stream started.
    fn attempt(&mut self) -> Result<UrgDriver<L, MonotonicClock>, ScipError> {
        let link = (self.open)()?;
        let mut urg = UrgDriver::connect(link, self.clock, self.driver.clone())?;
        if urg.info().geometry != self.geometry {
            return Err(ScipError::BadParameters {
                field: "ARES/AMIN/AMAX/AFRT",
                value: Some(format!(
                    "{:?}, not the {:?} of the laser the run started with",
                    urg.info().geometry,
                    self.geometry
                )),
            });
        }
        urg.start()?;
        Ok(urg)
    }

    /// Tries every [`REOPEN_EVERY`] until a driver streams again (`Some`), `stop` is set
    /// (`None`) or `within` has passed (the last attempt's error).
    fn until_back(
        &mut self,
        stop: &AtomicBool,
    ) -> Result<Option<UrgDriver<L, MonotonicClock>>, ScipError> {
        let since = Instant::now();
        loop {
            std::thread::sleep(REOPEN_EVERY);
            if stop.load(Ordering::Relaxed) {
                return Ok(None);
            }
            match self.attempt() {
                Ok(urg) => return Ok(Some(urg)),
                Err(e) if since.elapsed() >= self.within => return Err(e),
                Err(e) => tracing::debug!("laser {}: not back yet: {e}", self.name),
            }
        }
    }
}

/// Runs the laser driver until `stop` is set or the main loop goes away. A driver
/// error is sent as [`Input::LaserLost`] while the laser is opened again, then
/// [`Input::LaserBack`]; when it does not come back, as [`Input::LaserFailed`], which
/// ends the thread. The laser is switched off at the end.
fn laser_thread<L: Link, O: FnMut() -> Result<L, ScipError>>(
    mut urg: UrgDriver<L, MonotonicClock>,
    mut reopen: Reopen<O>,
    tx: SyncSender<Input>,
    stop: Arc<AtomicBool>,
) {
    while !stop.load(Ordering::Relaxed) {
        let input = match urg.next_event() {
            Ok(DriverEvent::Scan(scan)) => Input::Scan(scan.scan),
            Ok(DriverEvent::Fault(fault)) => Input::LaserFault(fault.into()),
            Err(error) if reopen.within.is_zero() => {
                tracing::error!("laser {}: {error}", reopen.name);
                let _ = tx.send(Input::LaserFailed(error));
                return;
            }
            Err(error) => {
                let message = error.to_string();
                let within_s = reopen.within.as_secs_f64();
                let laser = reopen.name.clone();
                if tx
                    .send(Input::LaserLost {
                        laser,
                        error,
                        within_s,
                    })
                    .is_err()
                {
                    return;
                }
                let since = Instant::now();
                match reopen.until_back(&stop) {
                    Ok(Some(back)) => {
                        urg = back;
                        Input::LaserBack {
                            laser: reopen.name.clone(),
                            after_s: since.elapsed().as_secs_f64(),
                        }
                    }
                    Ok(None) => return,
                    Err(last) => {
                        tracing::error!(
                            "laser {}: lost ({message}) and not back: {last}",
                            reopen.name
                        );
                        let _ = tx.send(Input::LaserFailed(last));
                        return;
                    }
                }
            }
        };
        if tx.send(input).is_err() {
            break;
        }
    }
    if let Err(e) = urg.stop() {
        tracing::debug!("switching the laser off: {e}");
    }
}

/// Handshake with the laser, its geometry into the pipeline's laser model, and the
/// stream started on its own thread, which opens it again with `open` when it stops
/// answering, for up to `reconnect`.
fn start_laser<L: Link + Send + 'static, O: FnMut() -> Result<L, ScipError> + Send + 'static>(
    mut open: O,
    reconnect: Duration,
    clock: MonotonicClock,
    spec: &LaserSpec,
    laser: &mut LaserModel,
    (tx, stop): (SyncSender<Input>, Arc<AtomicBool>),
) -> Result<Laser, LaserStartError> {
    let name = link_name(&spec.link);
    let driver = DriverConfig {
        frame_id: spec.frame_id.clone(),
        ..DriverConfig::default()
    };
    let port = open().map_err(LaserStartError::Link)?;
    let mut urg = UrgDriver::connect(port, clock, driver.clone()).map_err(|source| {
        LaserStartError::Handshake {
            name: name.to_owned(),
            source,
        }
    })?;
    let info = urg.info().clone();
    let model = info.parameters.get("MODL").cloned().unwrap_or_default();
    // The sensor knows its own steps and range limits better than a config file.
    laser.geometry = info.geometry;
    laser.range_min_m = f64::from(info.range_min_mm) / 1000.0;
    laser.range_max_m = f64::from(info.range_max_mm) / 1000.0;
    laser.scan_period_s = info.scan_period_s();
    laser
        .validate()
        .map_err(|source| LaserStartError::Geometry {
            name: name.to_owned(),
            model: model.clone(),
            source,
        })?;
    urg.start().map_err(|source| LaserStartError::Stream {
        name: name.to_owned(),
        source,
    })?;
    tracing::info!(
        "laser {name}: {model}, {} beams, {:.1} Hz, frame {}",
        info.geometry.beam_count(),
        1.0 / info.scan_period_s(),
        spec.frame_id
    );
    let reopen = Reopen {
        open,
        clock,
        geometry: info.geometry,
        within: reconnect,
        name: name.to_owned(),
        driver,
    };
    let thread = std::thread::Builder::new()
        .name(format!("laser {}", spec.frame_id))
        .spawn(move || laser_thread(urg, reopen, tx, stop))
        .map_err(LaserStartError::Thread)?;
    Ok(Laser {
        thread,
        scan_period_s: info.scan_period_s(),
    })
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, reason = "tests fail loudly")]

    use std::sync::mpsc::{Receiver, RecvTimeoutError, sync_channel};

    use tether_scip::emulator::{Emulator, EmulatorConfig, EmulatorServer, Endpoint, FnSource};

    use super::*;

    /// An emulated sensor serving scans from a plain function.
    type Server = EmulatorServer<FnSource<fn(u64, &mut Vec<u32>)>>;

    /// An emulated URG-04LX on TCP (loopback), every beam at 2 m.
    fn serve(address: &str) -> Server {
        fn two_metres(_: u64, ranges_mm: &mut Vec<u32>) {
            ranges_mm.resize(682, 2000);
        }
        let source: FnSource<fn(u64, &mut Vec<u32>)> = FnSource(two_metres);
        EmulatorServer::tcp(Emulator::new(EmulatorConfig::default(), source), address).unwrap()
    }

    fn address(server: &Server) -> String {
        match server.endpoint() {
            Endpoint::Tcp(address) => address.to_string(),
            other => panic!("not TCP: {other:?}"),
        }
    }

    /// The next input that is not a scan or a recovered fault, waiting up to `limit`;
    /// counts the scans on the way.
    fn next_event(rx: &Receiver<Input>, limit: Duration, scans: &mut u32) -> Option<Input> {
        let deadline = Instant::now() + limit;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match rx.recv_timeout(left) {
                Ok(Input::Scan(_)) => *scans += 1,
                Ok(Input::LaserFault(_)) => {}
                Ok(other) => return Some(other),
                Err(RecvTimeoutError::Timeout | RecvTimeoutError::Disconnected) => return None,
            }
        }
    }

    fn start_on(address: &str, reconnect_s: f64) -> (Laser, Receiver<Input>, Arc<AtomicBool>) {
        let (tx, rx) = sync_channel(crate::sources::CHANNEL_DEPTH);
        let stop = Arc::new(AtomicBool::new(false));
        let spec = LaserSpec {
            link: LaserLink::Tcp {
                address: address.to_owned(),
            },
            reconnect_s,
            frame_id: "laser".into(),
        };
        let mut model = LaserModel::default();
        let laser = start(
            &spec,
            MonotonicClock::new(),
            &mut model,
            (tx, Arc::clone(&stop)),
        )
        .unwrap();
        (laser, rx, stop)
    }

    #[test]
    fn a_laser_that_goes_away_and_comes_back_streams_again() {
        let server = serve("127.0.0.1:0");
        let address = address(&server);
        let (laser, rx, stop) = start_on(&address, 10.0);
        let mut scans = 0;
        assert!(next_event(&rx, Duration::from_millis(600), &mut scans).is_none());
        assert!(scans >= 2, "{scans} scans before the link went away");
        drop(server);
        match next_event(&rx, Duration::from_secs(5), &mut scans) {
            Some(Input::LaserLost { within_s, .. }) => assert_eq!(within_s, 10.0),
            other => panic!("not LaserLost: {other:?}"),
        }
        // The same sensor on the same address, 1 s later.
        std::thread::sleep(Duration::from_secs(1));
        let server = serve(&address);
        match next_event(&rx, Duration::from_secs(8), &mut scans) {
            Some(Input::LaserBack { after_s, .. }) => assert!(after_s >= 1.0, "{after_s}"),
            other => panic!("not LaserBack: {other:?}"),
        }
        let before = scans;
        assert!(next_event(&rx, Duration::from_millis(600), &mut scans).is_none());
        assert!(
            scans >= before + 2,
            "{} scans after it came back",
            scans - before
        );
        stop.store(true, Ordering::Relaxed);
        drop(rx);
        laser.thread.join().unwrap();
        drop(server);
    }

    #[test]
    fn a_laser_that_does_not_come_back_fails_after_reconnect_s() {
        let server = serve("127.0.0.1:0");
        let address = address(&server);
        let (laser, rx, _stop) = start_on(&address, 1.0);
        let mut scans = 0;
        drop(server);
        let lost_at = Instant::now();
        assert!(matches!(
            next_event(&rx, Duration::from_secs(5), &mut scans),
            Some(Input::LaserLost { .. })
        ));
        match next_event(&rx, Duration::from_secs(10), &mut scans) {
            Some(Input::LaserFailed(_)) => {}
            other => panic!("not LaserFailed: {other:?}"),
        }
        let waited = lost_at.elapsed();
        assert!(
            waited >= Duration::from_secs(1) && waited < Duration::from_secs(6),
            "failed {waited:?} after the loss"
        );
        laser.thread.join().unwrap();
    }

    #[test]
    fn reconnect_s_zero_fails_at_once() {
        let server = serve("127.0.0.1:0");
        let address = address(&server);
        let (laser, rx, _stop) = start_on(&address, 0.0);
        let mut scans = 0;
        drop(server);
        assert!(matches!(
            next_event(&rx, Duration::from_secs(5), &mut scans),
            Some(Input::LaserFailed(_))
        ));
        laser.thread.join().unwrap();
    }
}
