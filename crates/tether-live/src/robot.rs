//! `tether run`'s runtime: the robot's own sensors and base around the live loop.
//!
//! The outputs open first (JSON lines on stdout, the base guard, the base adapter of
//! `[base]`, the recording), so that a base that cannot be opened stops the run before
//! the laser spins; then the camera (its frames and detector: a wrong cascade path is
//! found before the laser spins), the laser (its handshake and stream) and the camera's
//! thread. The laser driver and the camera send their data over one channel to the loop
//! ([`run_loop::run`]), which runs the pipeline on every scan and frame and on a 20 Hz
//! timer. When the run ends (its duration, the stop flag, a failed laser or output)
//! every output gets a final stop; when a sensor cannot be started after the outputs
//! were opened, they get one too (`startup_failed`).

use std::io;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use tether_pipeline::{Pipeline, PipelineConfig, PipelineError};
use tether_recording::mcap::McapError;
use tether_scanmatch::ScanMatcherConfig;
use tether_scip::Clock;

use crate::base::{BaseError, CommandLine, CommandSink, QueuedLines, open_base};
use crate::clock::MonotonicClock;
use crate::config::RobotConfig;
use crate::guard::{Guard, GuardSpec};
use crate::recorder::{Recorder, RecordingError, fresh_recording_path};
use crate::run_loop::{self, LoopConfig, RunSummary};
use crate::sources::camera::{CameraSource, CameraStartError};
use crate::sources::scip::{self, LaserStartError};
use crate::sources::{CHANNEL_DEPTH, Input};

/// How the run goes besides what the robot's config says.
#[derive(Debug, Clone, Default)]
pub struct RobotSettings {
    /// Stop after this long; `None`: until the stop flag.
    pub duration: Option<Duration>,
    /// Correct the dead reckoning of the commands by matching each scan against the
    /// static scene; `None`: dead reckoning alone (the base reports no odometry).
    pub scan_odometry: Option<ScanMatcherConfig>,
}

/// What a run did, for its summary.
pub struct RobotReport {
    /// The loop's summary.
    pub summary: RunSummary,
    /// The pipeline as the run left it (its statistics, the target selector's).
    pub pipeline: Pipeline,
    /// Why the recording could not be finished, if it could not.
    pub recording_error: Option<RecordingError>,
}

/// Why the run could not start. When a sensor could not be started, the outputs already
/// opened have had their final stop.
#[derive(Debug, thiserror::Error)]
pub enum StartError {
    /// The writer of stdout's JSON lines did not start.
    #[error("starting the stdout writer")]
    Stdout(#[source] io::Error),
    /// tether's own binary, which the base guard runs as, cannot be found.
    #[error("cannot find tether's own binary to start the base guard")]
    GuardProgram(#[source] io::Error),
    /// The base guard did not start or did not open the base.
    #[error(
        "starting the base guard (`[base] guard = false` runs without it, and without a stop \
         if tether is killed)"
    )]
    Guard(#[source] io::Error),
    /// The writer of the base guard's pipe did not start.
    #[error("starting the base guard's writer")]
    GuardWriter(#[source] io::Error),
    /// The base adapter cannot be opened.
    #[error(transparent)]
    Base(#[from] BaseError),
    /// The recording cannot be created.
    #[error("cannot create the recording {}", path.display())]
    Recording {
        /// The file.
        path: PathBuf,
        /// What the writer said.
        source: McapError,
    },
    /// The camera cannot be started.
    #[error(transparent)]
    Camera(#[from] CameraStartError),
    /// The laser cannot be started.
    #[error(transparent)]
    Laser(#[from] LaserStartError),
    /// The pipeline refuses its settings (with the laser's own geometry).
    #[error(transparent)]
    Pipeline(#[from] PipelineError),
}

/// Runs the robot of `config` with the pipeline of `pipeline` until `settings.duration`
/// passes, `stop` is set, the laser fails or an output fails; every output then gets a
/// final stop.
pub fn run(
    config: &RobotConfig,
    pipeline: PipelineConfig,
    settings: &RobotSettings,
    stop: &Arc<AtomicBool>,
) -> Result<RobotReport, StartError> {
    // One clock for the laser's stamps, the camera's and the control loop's.
    let clock = MonotonicClock::new();
    let mut outputs = Outputs::open(config)?;
    let mut recording_path = None;
    let mut recorder = match &config.output.record {
        Some(path) => {
            let path = fresh_recording_path(path);
            let recorder = Recorder::create(&path).map_err(|source| StartError::Recording {
                path: path.clone(),
                source,
            })?;
            recording_path = Some(path);
            Some(recorder)
        }
        None => None,
    };
    let Started {
        rx,
        threads,
        scan_period_s,
        mut pipeline,
    } = match start(config, clock, pipeline, stop) {
        Ok(started) => started,
        Err(e) => {
            // The base may already be in Safe mode: leave it stopped and passive.
            let line = CommandLine::final_stop(clock.now_ns(), "startup_failed");
            for sink in &mut outputs.sinks {
                if let Err(f) = sink.finish(&line) {
                    tracing::error!("the final stop to {} failed: {f}", sink.name());
                }
            }
            stop.store(true, Ordering::Relaxed);
            outputs.end();
            // A run that never started leaves no recording: the file is new and empty
            // of data ([`fresh_recording_path`] never reuses one).
            if let Some(r) = recorder {
                let _ = r.finish();
            }
            if let Some(path) = recording_path
                && let Err(f) = std::fs::remove_file(&path)
            {
                tracing::warn!("cannot remove {} of the failed start: {f}", path.display());
            }
            return Err(e);
        }
    };
    let loop_config = LoopConfig {
        control_period: crate::control_timer::CONTROL_PERIOD,
        duration: settings.duration,
        track_width_m: pipeline.config().limits.track_width_m,
        scan_odometry: settings.scan_odometry.clone(),
        // The base reports no odometry of its own.
        odometry_input: false,
    };
    let summary = run_loop::run(
        &mut pipeline,
        &clock,
        &rx,
        &mut outputs.sinks,
        recorder.as_mut(),
        stop,
        &loop_config,
        scan_period_s,
    );
    // The threads end at their next datum (a send to the dropped channel fails).
    stop.store(true, Ordering::Relaxed);
    drop(rx);
    outputs.end();
    let recording_error = recorder.and_then(|r| r.finish().err());
    for (name, thread) in threads {
        join_within(thread, Duration::from_secs(1), name);
    }
    Ok(RobotReport {
        summary,
        pipeline,
        recording_error,
    })
}

/// The outputs of a run and the base guard beside them.
struct Outputs {
    sinks: Vec<Box<dyn CommandSink>>,
    guard: Option<Guard>,
}

impl Outputs {
    /// JSON lines on stdout when asked for, the base guard, the base adapter and the
    /// guard's pipe. On an error the outputs already opened are dropped (a guard whose
    /// pipe closes sends its stop and exits).
    fn open(config: &RobotConfig) -> Result<Outputs, StartError> {
        let mut sinks: Vec<Box<dyn CommandSink>> = Vec::new();
        if config.output.stdout {
            // On a thread of its own: a reader that stops reading must not hold up the
            // base's commands and stops.
            sinks.push(Box::new(
                QueuedLines::new("stdout", io::stdout()).map_err(StartError::Stdout)?,
            ));
        }
        // The guard opens the base's device before tether does (tether's serial port
        // would lock it out), and gets every command after the base has it.
        let guard = match GuardSpec::of(&config.base) {
            Some(spec) => {
                let exe = std::env::current_exe().map_err(StartError::GuardProgram)?;
                let (guard, pipe) =
                    Guard::spawn(&exe, &spec, Duration::from_secs(5)).map_err(StartError::Guard)?;
                Some((guard, pipe))
            }
            None => None,
        };
        if let Some(base) = open_base(&config.base)? {
            sinks.push(base);
        }
        let guard = match guard {
            Some((guard, pipe)) => {
                sinks.push(Box::new(
                    QueuedLines::new("base guard", pipe).map_err(StartError::GuardWriter)?,
                ));
                Some(guard)
            }
            None => None,
        };
        Ok(Outputs { sinks, guard })
    }

    /// Closes the outputs; the guard's pipe closes with them, and the guard then sends
    /// its stop and exits.
    fn end(&mut self) {
        self.sinks.clear();
        if let Some(guard) = self.guard.take() {
            match guard.wait(Duration::from_secs(1)) {
                Some(status) if status.success() => {}
                other => tracing::warn!(
                    "the base guard ended badly ({}); tether's own final stop went out",
                    other.map_or_else(|| "no status".into(), |s| s.to_string())
                ),
            }
        }
    }
}

/// The sensors' threads, their channel and the pipeline, ready to run.
struct Started {
    rx: Receiver<Input>,
    threads: Vec<(&'static str, JoinHandle<()>)>,
    scan_period_s: f64,
    pipeline: Pipeline,
}

/// The cameras' frames and detectors, the lasers' handshakes and streams, the camera
/// threads and the pipeline (whose laser model takes the sensor's own geometry). On an
/// error the threads already started end by themselves (their channel is gone).
fn start(
    config: &RobotConfig,
    clock: MonotonicClock,
    mut pipeline_config: PipelineConfig,
    stop: &Arc<AtomicBool>,
) -> Result<Started, StartError> {
    // The cameras first: a wrong cascade path is found before the laser spins.
    let mut cameras = Vec::new();
    for (_, frame_id, section) in config.camera.iter().flat_map(|c| c.keyed()) {
        if let Some(input) = section.frame_input() {
            let intrinsics = section.camera_model().intrinsics;
            cameras.push(CameraSource::open(&input, section, intrinsics, frame_id)?);
        }
    }
    let (tx, rx) = mpsc::sync_channel(CHANNEL_DEPTH);
    // The leg model is read once, before the laser spins: a wrong path is found now.
    let leg_model = crate::leg_model::classifier(&pipeline_config.legs)?;
    let spec = |l: &crate::config::LaserSection, frame: &str| scip::LaserSpec {
        link: l.link(),
        reconnect_s: l.reconnect_s,
        frame_id: frame.to_owned(),
    };
    let laser = scip::start(
        &spec(&config.laser, config.laser.first_frame()),
        clock,
        &mut pipeline_config.laser,
        (tx.clone(), Arc::clone(stop)),
    )?;
    let mut threads = vec![("laser", laser.thread)];
    // Each further scanner streams on a thread of its own into the same channel; its
    // geometry goes into its extra laser (`pipeline_config` made one per `[[laser]]`).
    for (section, extra) in config
        .laser
        .extra()
        .iter()
        .zip(pipeline_config.extra_lasers.iter_mut())
    {
        let started = scip::start(
            &spec(section, &extra.frame_id),
            clock,
            &mut extra.laser,
            (tx.clone(), Arc::clone(stop)),
        )?;
        threads.push(("laser", started.thread));
    }
    let record = config.output.record.is_some();
    for camera in cameras {
        threads.push((
            "camera",
            camera.spawn(clock, tx.clone(), Arc::clone(stop), record)?,
        ));
    }
    drop(tx);
    let pipeline = Pipeline::new(pipeline_config, leg_model)?;
    Ok(Started {
        rx,
        threads,
        scan_period_s: laser.scan_period_s,
        pipeline,
    })
}

/// Waits up to `limit` for a thread to end.
fn join_within(thread: JoinHandle<()>, limit: Duration, name: &str) {
    let started = Instant::now();
    while !thread.is_finished() {
        if started.elapsed() > limit {
            tracing::debug!("the {name} thread is still busy; leaving it");
            return;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    if thread.join().is_err() {
        tracing::error!("the {name} thread panicked");
    }
}
