//! The laser of `tether run`: a SCIP 2.0 Hokuyo on a serial or USB-ACM port, or on TCP
//! (`tether_io::scip`). The handshake gives the sensor's own geometry, which replaces the
//! configured one; then the driver streams scans on a thread of its own until the run
//! ends, and switches the laser off.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::SyncSender;
use std::thread::JoinHandle;
use std::time::Duration;

use tether_core::LaserModelError;
use tether_io::scip::{
    Clock, DriverConfig, DriverEvent, Link, ScipError, UrgDriver, connect_tcp, open_serial,
};
use tether_pipeline::PipelineConfig;

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

/// Opens the laser of `link`, takes its geometry into `pipeline`'s laser model and
/// starts its scans on a thread that sends them to `tx` until `stop` is set.
pub fn start(
    link: &LaserLink,
    clock: MonotonicClock,
    pipeline: &mut PipelineConfig,
    tx: SyncSender<Input>,
    stop: Arc<AtomicBool>,
) -> Result<Laser, LaserStartError> {
    match link {
        LaserLink::Serial { path, baud } => {
            let port = open_serial(path, *baud).map_err(LaserStartError::Link)?;
            start_laser(port, clock, path, pipeline, tx, stop)
        }
        LaserLink::Tcp { address } => {
            let stream =
                connect_tcp(address, Duration::from_secs(3)).map_err(LaserStartError::Link)?;
            start_laser(stream, clock, address, pipeline, tx, stop)
        }
    }
}

/// Runs the laser driver until `stop` is set or the main loop goes away; a driver
/// error is sent as `LaserFailed` and ends the thread. The laser is switched off at the
/// end.
fn laser_thread<L: Link, C: Clock>(
    mut urg: UrgDriver<L, C>,
    tx: SyncSender<Input>,
    stop: Arc<AtomicBool>,
) {
    while !stop.load(Ordering::Relaxed) {
        let input = match urg.next_event() {
            Ok(DriverEvent::Scan(scan)) => Input::Scan(scan.scan),
            Ok(DriverEvent::Fault(fault)) => Input::LaserFault(fault.into()),
            Err(e) => {
                let _ = tx.send(Input::LaserFailed(e));
                return;
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
/// stream started on its own thread.
fn start_laser<L: Link + Send + 'static>(
    link: L,
    clock: MonotonicClock,
    name: &str,
    pipeline: &mut PipelineConfig,
    tx: SyncSender<Input>,
    stop: Arc<AtomicBool>,
) -> Result<Laser, LaserStartError> {
    let mut urg = UrgDriver::connect(link, clock, DriverConfig::default()).map_err(|source| {
        LaserStartError::Handshake {
            name: name.to_owned(),
            source,
        }
    })?;
    let info = urg.info().clone();
    let model = info.parameters.get("MODL").cloned().unwrap_or_default();
    // The sensor knows its own steps and range limits better than a config file.
    pipeline.laser.geometry = info.geometry;
    pipeline.laser.range_min_m = f64::from(info.range_min_mm) / 1000.0;
    pipeline.laser.range_max_m = f64::from(info.range_max_mm) / 1000.0;
    pipeline.laser.scan_period_s = info.scan_period_s();
    pipeline
        .laser
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
        "laser {name}: {model}, {} beams, {:.1} Hz",
        info.geometry.beam_count(),
        1.0 / info.scan_period_s()
    );
    let thread = std::thread::Builder::new()
        .name("laser".into())
        .spawn(move || laser_thread(urg, tx, stop))
        .map_err(LaserStartError::Thread)?;
    Ok(Laser {
        thread,
        scan_period_s: info.scan_period_s(),
    })
}
