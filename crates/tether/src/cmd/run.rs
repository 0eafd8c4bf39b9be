//! `tether run --config robot.toml`: the live robot. The laser (serial or TCP), an
//! optional camera, the full pipeline, and the commands: JSON lines on stdout, an MCAP
//! recording, a base adapter (iRobot Create, wheel-speed lines).
//!
//! Threads: the laser driver and the camera (frames, then the cascade detector) each
//! send their data over one channel to the main loop (`tether::live::run_loop`), which
//! runs the pipeline on every scan and frame and on a 20 Hz timer. Ctrl-C (or SIGTERM)
//! ends the loop; every output then gets a final stop.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, SyncSender};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use anyhow::Context;
use tether::ego::EgoMotion;
use tether::live::base::{CommandLine, CommandSink, CreateBase, QueuedLines, WheelLines};
use tether::live::camera::{CameraError, FolderFrames, FrameSource, png_of};
use tether::live::clock::MonotonicClock;
use tether::live::config::{BaseKind, CameraSection, FrameInput, LaserLink, RobotConfig};
use tether::live::guard::{Guard, GuardSpec};
use tether::live::run_loop::{self, Ending, Input, LoopConfig, Recorder};
use tether_core::{CameraIntrinsics, Stamp};
use tether_io::scip::{
    Clock, DriverConfig, DriverEvent, Link, UrgDriver, connect_tcp, open_serial,
};
use tether_pipeline::{Pipeline, PipelineConfig};
use tether_scanmatch::ScanMatcherConfig;

use super::track::{Camera, CameraArgs};

/// Options of `tether run`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The robot's configuration (TOML; see configs/robot.example.toml).
    #[arg(long, value_name = "robot.toml")]
    pub config: PathBuf,
    /// Stop after this many seconds (default: run until Ctrl-C).
    #[arg(long, value_name = "S")]
    pub duration: Option<f64>,
    /// Where the robot's motion comes from: `auto` or `scans` (the dead reckoning of
    /// the commands corrected by matching each scan against the static scene), `odom`
    /// (dead reckoning of the commands alone). `none` is refused: a robot that drives
    /// cannot be taken to stand still.
    #[arg(long, value_enum, default_value_t = EgoMotion::Auto)]
    pub ego_motion: EgoMotion,
}

/// Scans and frames waiting for the main loop; a sensor thread blocks when it is full.
const CHANNEL_DEPTH: usize = 32;

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
            Ok(DriverEvent::Fault(fault)) => Input::LaserFault(fault.to_string()),
            Err(e) => {
                let _ = tx.send(Input::LaserFailed(e.to_string()));
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
/// stream started on its own thread. Returns the thread and the scan period.
fn start_laser<L: Link + Send + 'static>(
    link: L,
    clock: MonotonicClock,
    name: &str,
    pipeline: &mut PipelineConfig,
    tx: SyncSender<Input>,
    stop: Arc<AtomicBool>,
) -> anyhow::Result<(JoinHandle<()>, f64)> {
    let mut urg = UrgDriver::connect(link, clock, DriverConfig::default())
        .with_context(|| format!("laser {name}: handshake failed"))?;
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
        .with_context(|| format!("laser {name} ({model}) reports an unusable geometry"))?;
    urg.start()
        .with_context(|| format!("laser {name}: starting the scan stream"))?;
    tracing::info!(
        "laser {name}: {model}, {} beams, {:.1} Hz",
        info.geometry.beam_count(),
        1.0 / info.scan_period_s()
    );
    let thread = std::thread::Builder::new()
        .name("laser".into())
        .spawn(move || laser_thread(urg, tx, stop))
        .context("starting the laser thread")?;
    Ok((thread, info.scan_period_s()))
}

/// Frames in a row that cannot be used before the camera is taken for gone (3 s at
/// 10 fps); a single bad frame is skipped and counted.
const CAMERA_GIVES_UP_AFTER_BAD_FRAMES: u32 = 30;

/// Frames from `source` through the detector, stamped on arrival, until `stop` or the
/// end of the frames.
fn camera_thread(
    mut source: Box<dyn FrameSource>,
    mut camera: Camera,
    intrinsics: CameraIntrinsics,
    clock: MonotonicClock,
    tx: SyncSender<Input>,
    stop: Arc<AtomicBool>,
    record: bool,
) {
    // Consecutive frames that could not be used: a bad frame is skipped, a camera
    // that sends nothing usable for this many frames in a row is gone.
    let mut bad_in_a_row = 0_u32;
    while !stop.load(Ordering::Relaxed) {
        let input = match source.next_frame() {
            Ok(Some(image)) => {
                let stamp = Stamp::from_ns(clock.now_ns());
                // The recording keeps the frame as it came (or as PNG).
                let frame = record.then(|| source.take_encoded().unwrap_or_else(|| png_of(&image)));
                match camera.boxes(&image, &intrinsics) {
                    Ok(boxes) => Input::Camera {
                        stamp,
                        boxes,
                        frame,
                    },
                    Err(e) => Input::CameraFrameBad(format!("{e:#}")),
                }
            }
            Ok(None) => Input::CameraEnded(None),
            Err(e @ CameraError::Frame { .. }) => Input::CameraFrameBad(e.to_string()),
            Err(e) => Input::CameraEnded(Some(e.to_string())),
        };
        let input = match input {
            Input::CameraFrameBad(why) => {
                bad_in_a_row += 1;
                if bad_in_a_row >= CAMERA_GIVES_UP_AFTER_BAD_FRAMES {
                    Input::CameraEnded(Some(format!(
                        "{bad_in_a_row} frames in a row could not be used; the last: {why}"
                    )))
                } else {
                    Input::CameraFrameBad(why)
                }
            }
            other => {
                bad_in_a_row = 0;
                other
            }
        };
        let ended = matches!(input, Input::CameraEnded(_));
        if tx.send(input).is_err() || ended {
            break;
        }
    }
}

fn frame_source(
    input: &FrameInput,
    intrinsics: &CameraIntrinsics,
) -> anyhow::Result<Box<dyn FrameSource>> {
    match input {
        FrameInput::Folder { path, fps, repeat } => Ok(Box::new(
            FolderFrames::open(path, *fps, *repeat)?
                .sized(intrinsics.width_px, intrinsics.height_px),
        )),
        #[cfg(feature = "v4l2")]
        FrameInput::V4l2 { device } => Ok(Box::new(tether::live::camera::V4l2Frames::open(
            device,
            intrinsics.width_px,
            intrinsics.height_px,
        )?)),
        #[cfg(not(feature = "v4l2"))]
        FrameInput::V4l2 { device } => {
            let _ = intrinsics;
            anyhow::bail!(
                "camera.v4l2 = {device:?}: this tether was built without V4L2 support; build it \
                 with `cargo build --release --features v4l2` (needs libclang-dev), or use \
                 `camera.folder`"
            )
        }
    }
}

/// The upper-body detector of `[camera]` (its cascade and search settings).
pub fn camera_detector(section: &CameraSection) -> anyhow::Result<Camera> {
    Camera::new(&CameraArgs {
        cascade: section.cascade.clone(),
        search: super::detect::DetectOptions {
            scale_factor: section.scale_factor.unwrap_or(1.1),
            min_neighbors: section.min_neighbors.unwrap_or(3),
            min_size: None,
            max_size: None,
        },
        threads: 1,
    })
}

/// Opens the base adapter of `[base]`.
fn open_base(config: &RobotConfig) -> anyhow::Result<Option<Box<dyn CommandSink>>> {
    let base = &config.base;
    let Some(device) = &base.device else {
        return Ok(None);
    };
    let shown = device.display().to_string();
    let serial = |baud: u32| {
        serialport::new(shown.clone(), baud)
            .timeout(Duration::from_millis(200))
            .open()
            .with_context(|| format!("cannot open the base's serial port {shown} at {baud} baud"))
    };
    match base.kind {
        BaseKind::None => Ok(None),
        BaseKind::Create => {
            let baud = base.baud.context("base.baud is missing")?;
            let port = serial(baud)?;
            let create = CreateBase::start(format!("create {shown}"), port)
                .with_context(|| format!("starting the Create's Open Interface on {shown}"))?;
            Ok(Some(Box::new(create)))
        }
        BaseKind::Wheels => {
            let format = base.format.unwrap_or_default();
            let name = format!("wheels {shown}");
            Ok(Some(match base.baud {
                Some(baud) => Box::new(WheelLines::new(name, format, serial(baud)?)),
                None => {
                    let file = std::fs::File::create(device)
                        .with_context(|| format!("cannot open {shown} for the wheel speeds"))?;
                    Box::new(WheelLines::new(name, format, file))
                }
            }))
        }
    }
}

/// Where this run records: `path`, or when an earlier run's recording is there, the
/// first free `NAME-2.mcap`, `NAME-3.mcap`... beside it (said in the log): a new run
/// never overwrites an old one.
fn fresh_recording_path(path: &Path) -> PathBuf {
    if !path.exists() {
        return path.to_path_buf();
    }
    let stem = path
        .file_stem()
        .map_or_else(|| "run".into(), |s| s.to_string_lossy().into_owned());
    let ext = path
        .extension()
        .map(|e| format!(".{}", e.to_string_lossy()))
        .unwrap_or_default();
    let fresh = (2u32..)
        .map(|n| path.with_file_name(format!("{stem}-{n}{ext}")))
        .find(|p| !p.exists())
        .unwrap_or_else(|| path.to_path_buf());
    tracing::warn!(
        "{} holds an earlier run's recording; this run records to {}",
        path.display(),
        fresh.display()
    );
    fresh
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

/// The sensors' threads, their channel and the pipeline, ready to run.
struct Started {
    rx: mpsc::Receiver<Input>,
    threads: Vec<(&'static str, JoinHandle<()>)>,
    scan_period_s: f64,
    pipeline: Pipeline,
}

/// The camera's detector, the laser's handshake and stream, the camera thread and the
/// pipeline (whose laser model takes the sensor's own geometry). On an error the
/// threads already started end by themselves (their channel is gone).
fn start(
    config: &RobotConfig,
    clock: MonotonicClock,
    mut pipeline_config: PipelineConfig,
    stop: &Arc<AtomicBool>,
) -> anyhow::Result<Started> {
    // The camera side first: a wrong cascade path is found before the laser spins.
    let camera = match (config.frame_input(), &config.camera) {
        (Some(input), Some(section)) => {
            let intrinsics = pipeline_config.camera.intrinsics;
            let source = frame_source(&input, &intrinsics)?;
            let detector = camera_detector(section)?;
            tracing::info!("camera: {}", source.describe());
            Some((source, detector, intrinsics))
        }
        _ => None,
    };
    let (tx, rx) = mpsc::sync_channel(CHANNEL_DEPTH);
    let (laser, scan_period_s) = match config.laser_link() {
        LaserLink::Serial { path, baud } => {
            let port = open_serial(&path, baud)?;
            start_laser(
                port,
                clock,
                &path,
                &mut pipeline_config,
                tx.clone(),
                Arc::clone(stop),
            )?
        }
        LaserLink::Tcp { address } => {
            let stream = connect_tcp(&address, Duration::from_secs(3))?;
            start_laser(
                stream,
                clock,
                &address,
                &mut pipeline_config,
                tx.clone(),
                Arc::clone(stop),
            )?
        }
    };
    let mut threads = vec![("laser", laser)];
    if let Some((source, detector, intrinsics)) = camera {
        let thread_stop = Arc::clone(stop);
        let record = config.output.record.is_some();
        let thread = std::thread::Builder::new()
            .name("camera".into())
            .spawn(move || {
                camera_thread(source, detector, intrinsics, clock, tx, thread_stop, record);
            })
            .context("starting the camera thread")?;
        threads.push(("camera", thread));
    }
    let pipeline = Pipeline::new(pipeline_config, None)?;
    Ok(Started {
        rx,
        threads,
        scan_period_s,
        pipeline,
    })
}

/// Runs the robot.
pub fn run(args: Args) -> anyhow::Result<()> {
    let config = RobotConfig::load(&args.config)?;
    let duration = match args.duration {
        Some(s) if s.is_finite() && s > 0.0 && s <= 1e6 => Some(Duration::from_secs_f64(s)),
        Some(s) => anyhow::bail!("--duration must be a positive number of seconds, got {s}"),
        None => None,
    };
    // The base reports no odometry: the commands' dead reckoning, corrected by the scans
    // unless asked not to be.
    let scan_odometry = match args.ego_motion {
        EgoMotion::Auto | EgoMotion::Scans => Some(ScanMatcherConfig::default()),
        EgoMotion::Odom => None,
        EgoMotion::None => anyhow::bail!(
            "--ego-motion none: a robot that drives cannot be taken to stand still; use \
             scans (the default) or odom (dead reckoning of the commands)"
        ),
    };
    let pipeline_config = config
        .pipeline_config()
        .map_err(|e| anyhow::anyhow!("config {}: {e}", args.config.display()))?;
    // One clock for the laser's stamps, the camera's and the control loop's.
    let clock = MonotonicClock::new();
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    ctrlc::set_handler(move || flag.store(true, Ordering::Relaxed))
        .context("cannot catch Ctrl-C, so the robot could not be stopped cleanly")?;

    // Outputs first: a base that cannot be opened stops the run before the laser spins.
    let mut sinks: Vec<Box<dyn CommandSink>> = Vec::new();
    if config.output.stdout {
        // On a thread of its own: a reader that stops reading must not hold up the
        // base's commands and stops.
        sinks.push(Box::new(
            QueuedLines::new("stdout", std::io::stdout()).context("starting the stdout writer")?,
        ));
    }
    // The guard opens the base's device before tether does (tether's serial port
    // would lock it out), and gets every command after the base has it.
    let guard = match GuardSpec::of(&config.base) {
        Some(spec) => {
            let exe = std::env::current_exe()
                .context("cannot find tether's own binary to start the base guard")?;
            let (guard, pipe) = Guard::spawn(&exe, &spec, Duration::from_secs(5)).context(
                "starting the base guard (`[base] guard = false` runs without it, and \
                 without a stop if tether is killed)",
            )?;
            Some((guard, pipe))
        }
        None => None,
    };
    if let Some(base) = open_base(&config)? {
        sinks.push(base);
    }
    let guard = match guard {
        Some((guard, pipe)) => {
            sinks.push(Box::new(
                QueuedLines::new("base guard", pipe).context("starting the base guard's writer")?,
            ));
            Some(guard)
        }
        None => None,
    };
    // The guard's pipe closes when the sinks go: it then sends its stop and exits.
    let end_guard = move |sinks: Vec<Box<dyn CommandSink>>| {
        drop(sinks);
        if let Some(guard) = guard {
            match guard.wait(Duration::from_secs(1)) {
                Some(status) if status.success() => {}
                other => tracing::warn!(
                    "the base guard ended badly ({}); tether's own final stop went out",
                    other.map_or_else(|| "no status".into(), |s| s.to_string())
                ),
            }
        }
    };
    let mut recorder = match &config.output.record {
        Some(path) => Some({
            let path = fresh_recording_path(path);
            Recorder::create(&path)
                .with_context(|| format!("cannot create the recording {}", path.display()))?
        }),
        None => None,
    };

    let Started {
        rx,
        threads,
        scan_period_s,
        mut pipeline,
    } = match start(&config, clock, pipeline_config, &stop) {
        Ok(started) => started,
        Err(e) => {
            // The base may already be in Safe mode: leave it stopped and passive.
            let line = CommandLine::final_stop(clock.now_ns(), "startup_failed");
            for sink in &mut sinks {
                if let Err(f) = sink.finish(&line) {
                    tracing::error!("the final stop to {} failed: {f}", sink.name());
                }
            }
            stop.store(true, Ordering::Relaxed);
            end_guard(sinks);
            return Err(e);
        }
    };
    let track_width_m = pipeline.config().limits.track_width_m;
    let loop_config = LoopConfig {
        control_period: Duration::from_millis(50),
        duration,
        track_width_m,
        scan_odometry,
        // The base reports no odometry of its own.
        odometry_input: false,
    };
    let summary = run_loop::run(
        &mut pipeline,
        &clock,
        &rx,
        &mut sinks,
        recorder.as_mut(),
        &stop,
        &loop_config,
        scan_period_s,
    );
    // The threads end at their next datum (a send to the dropped channel fails).
    stop.store(true, Ordering::Relaxed);
    drop(rx);
    end_guard(sinks);
    let mut problems = Vec::new();
    if let Some(recorder) = recorder
        && let Err(e) = recorder.finish()
    {
        problems.push(format!("finishing the recording: {e}"));
    }
    for (name, thread) in threads {
        join_within(thread, Duration::from_secs(1), name);
    }
    let stats = pipeline.stats();
    tracing::info!(
        "{}: {} scans, {} camera frames, {} ticks ({} with a target), {:.1} m driven by dead \
         reckoning, {} laser faults recovered, {} camera frames skipped",
        summary.ending.name(),
        summary.scans,
        summary.frames,
        summary.ticks,
        summary.ticks_with_target,
        summary.distance_m,
        summary.laser_faults,
        summary.bad_frames,
    );
    if summary.clamped_stamps > 0 {
        tracing::info!(
            "{} scans or frames were stamped before the loop's last tick (a sensor thread a \
             little late, a busy machine) and were processed at that tick's time instead",
            summary.clamped_stamps
        );
    }
    if stats.out_of_order_ticks > 0 {
        tracing::warn!(
            "{} inputs came out of order and were kept out of the tracks",
            stats.out_of_order_ticks
        );
    }
    tracing::info!("{}", summary.target.one_line(pipeline.selector().stats()));
    if summary.cannot_keep_up > 0 {
        tracing::warn!(
            "the robot could not keep up with the target {} times (at its speed limit, {:.2} \
             m/s, the target pulled away): raise [robot] max_speed_mps if the base allows",
            summary.cannot_keep_up,
            pipeline.config().limits.max_speed_mps
        );
    }
    for (output, error) in &summary.final_stop_failures {
        problems.push(format!("the final stop to {output} failed: {error}"));
    }
    match &summary.ending {
        Ending::Duration | Ending::Interrupted => {}
        Ending::LaserFailed(e) => problems.insert(
            0,
            format!("the laser failed (unplugged, powered off, or taken by another program?): {e}"),
        ),
        Ending::OutputFailed { output, error } => {
            problems.insert(
                0,
                format!("writing the commands to {output} failed: {error}"),
            );
        }
        Ending::InputsClosed => problems.insert(0, "every sensor thread ended".into()),
        Ending::Panicked(why) => {
            problems.insert(0, format!("the control loop panicked (a bug): {why}"))
        }
    }
    if problems.is_empty() {
        Ok(())
    } else {
        anyhow::bail!(
            "{}; a final stop was sent to every output that still worked",
            problems.join("; ")
        )
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, reason = "tests fail loudly")]

    use super::*;

    #[test]
    fn a_new_run_never_records_over_an_old_one() {
        let dir = std::env::temp_dir().join(format!("tether-record-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("run.mcap");
        assert_eq!(fresh_recording_path(&path), path);
        std::fs::write(&path, b"earlier").unwrap();
        assert_eq!(fresh_recording_path(&path), dir.join("run-2.mcap"));
        std::fs::write(dir.join("run-2.mcap"), b"earlier too").unwrap();
        assert_eq!(fresh_recording_path(&path), dir.join("run-3.mcap"));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
