//! `tether ros2`'s runtime: the node's sources and sinks around the live loop.
//!
//! It joins the graph, subscribes to the scans (and the odometry, `/tf`, `/tf_static`,
//! `/clock` with sim time, the camera's images or detections), takes the laser's mount
//! from `/tf_static`, runs the same loop as `tether run` ([`run_loop::run`]: the
//! pipeline on every scan and on a 20 Hz timer, its watchdogs, a final stop on every
//! exit), and publishes the commands and the results ([`RosOutputs`]). Topic names are
//! resolved as the node's `--ros-args` say (namespace, remapping).
//!
//! The graph: every second the node compares its topics with the publishers and
//! subscribers discovery has found on them, and warns once about each that DDS will not
//! connect (another message type, a QoS that does not match), saying what to change.

use std::io;
use std::sync::atomic::AtomicBool;
use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

use ros2_client::dds::Publisher;
use tether_core::{FIRST_CAMERA_FRAME, LaserMount};
use tether_msgs::{Header, Pose3, TfMessage, TransformStampedMsg};
use tether_pipeline::{Pipeline, PipelineConfig, PipelineError};
use tether_ros2::{
    GraphWatcher, NodeIdentity, Received, Ros2Error, RosArgs, RosNode, StaticTransforms, Wire, qos,
    spawn_reader,
};
use tether_scanmatch::ScanMatcherConfig;
use tether_scip::Clock;

use super::camera_mount::{camera_mount_from_tf, camera_pose, is_optical_frame};
use super::cameras::{CameraFeed, NodeCamera};
use super::extra_scans::{self, ExtraScanTopic};
use super::guard::CmdVelGuardSpec;
use super::inputs::{
    CameraCounters, ScanCounters, start_clock_reader, start_odometry_reader, start_scan_reader,
    start_tf_reader,
};
use super::outputs::{OutputTopics, RosOutputs};
use crate::base::{CommandSink, QueuedLines};
use crate::clock::{LiveClock, MonotonicClock, SimClock};
use crate::guard::Guard;
use crate::recorder::Recorder;
use crate::results::ros_outputs;
use crate::run_loop::{self, LoopConfig, RunSummary};
use crate::sources::camera::DetectorError;
use crate::sources::{CHANNEL_DEPTH, Input};

/// What the node is and does: its name, its topics' remapping, the pipeline and the
/// loop's settings.
#[derive(Debug, Clone)]
pub struct NodeSettings {
    /// The node's name, namespace and DDS domain.
    pub identity: NodeIdentity,
    /// The `--ros-args` block (its remappings name the topics).
    pub ros: RosArgs,
    /// The pipeline's settings; the laser's mount is replaced by `/tf_static`'s when
    /// that is published.
    pub pipeline: PipelineConfig,
    /// The frame of the results and of the base's pose on `/tf`.
    pub fixed_frame: String,
    /// The robot's frame (the laser's mount is looked up in it).
    pub base_frame: String,
    /// Commands as `geometry_msgs/msg/TwistStamped` in `base_frame`, stamped with the
    /// time of the data that made them, rather than `Twist`.
    pub cmd_vel_stamped: bool,
    /// Publish commands on `cmd_vel`; `false`: no `cmd_vel` publisher at all, the
    /// target's pose and frame are for Nav2, which drives (design 12).
    pub publish_cmd_vel: bool,
    /// Start the `cmd_vel` guard beside the node when it publishes commands
    /// ([`super::guard`]).
    pub cmd_vel_guard: bool,
    /// The target's frame on `/tf`, a child of `fixed_frame`, while it is locked.
    pub target_frame: String,
    /// Time is the newest `/clock` (`rosgraph_msgs/msg/Clock`), which the node waits for
    /// at the start, rather than the host's.
    pub use_sim_time: bool,
    /// The camera, if one is used.
    pub camera: Option<NodeCamera>,
    /// The further cameras, in the order of the pipeline's `extra_cameras` (each read
    /// through its model): the topic of each (a name as `scan`'s, resolved alike) and
    /// where its people come from ([`super::cameras`]).
    pub extra_cameras: Vec<(String, NodeCamera)>,
    /// The pipeline's laser mount was given (a config, a scenario): it is warned about
    /// when `/tf_static` says otherwise, and published there when nobody else does.
    pub mount_given: bool,
    /// Stop after this long (on the node's clock); `None`: until `stop`.
    pub duration: Option<Duration>,
    /// Correct the dead reckoning of the commands by scan matching (see
    /// [`LoopConfig::scan_odometry`]).
    pub scan_odometry: Option<ScanMatcherConfig>,
    /// Take the `odom` topic (and `/tf`) as the robot's pose once it publishes (see
    /// [`LoopConfig::odometry_input`]).
    pub odometry_input: bool,
    /// The scan topics of more scanners (names as `scan`'s, resolved alike), each
    /// given a laser of its own at the start ([`super::extra_scans`]).
    pub extra_scan_topics: Vec<String>,
}

/// What a node's run did, for its summary.
pub struct NodeReport {
    /// The loop's summary.
    pub summary: RunSummary,
    /// The pipeline as the run left it (its statistics, the target selector's).
    pub pipeline: Pipeline,
    /// What the scan, odometry and `/tf` readers counted.
    pub scans: Arc<ScanCounters>,
    /// What the camera's readers counted.
    pub camera: Arc<CameraCounters>,
    /// The further cameras: each one's topic, frame and what its readers counted.
    pub extra_cameras: Vec<(String, String, Arc<CameraCounters>)>,
    /// Mismatches with the graph's topics that were warned about.
    pub graph_problems: usize,
    /// The node's clock (with sim time: where it ended, how often it went back).
    pub clock: LiveClock,
    /// The resolved `/tf` topic.
    pub tf_topic: String,
    /// The topic the scans were read from.
    pub scan_topic: String,
    /// The extra scan topics, with the frames they were taken for and their counts.
    pub extra_scans: Vec<Arc<ExtraScanTopic>>,
}

/// Why the node could not start.
#[derive(Debug, thiserror::Error)]
pub enum NodeError {
    /// The pipeline's settings are refused.
    #[error(transparent)]
    Pipeline(#[from] PipelineError),
    /// Joining the graph, a subscription or a publisher failed.
    #[error(transparent)]
    Ros2(#[from] Ros2Error),
    /// The camera's detector cannot be made.
    #[error(transparent)]
    Detector(#[from] DetectorError),
    /// A thread could not be started.
    #[error("starting the {what}")]
    Thread {
        /// Which thread.
        what: &'static str,
        /// What the system said.
        source: io::Error,
    },
    /// `use_sim_time` and no `/clock`.
    #[error(
        "use_sim_time is true but nothing was published on {topic} within {waited_s} s: start \
         the simulator (e.g. `tether sim --scenario corridor --ros2 --use-sim-time`), or set \
         -p use_sim_time:=false"
    )]
    NoClock {
        /// The clock topic.
        topic: String,
        /// How long the node waited, s.
        waited_s: u64,
    },
    /// The `cmd_vel` guard did not start.
    #[error(
        "starting the cmd_vel guard (`-p cmd_vel_guard:=false` runs without it, and without \
         a stop if tether is killed)"
    )]
    Guard(#[source] io::Error),
    /// The laser's mount could not be published on `/tf_static`.
    #[error("publishing the laser mount on {topic}: {message}")]
    PublishMount {
        /// The topic.
        topic: String,
        /// What DDS said.
        message: String,
    },
}

/// Runs the node until `settings.duration` passes, `stop` is set, or an output fails;
/// every output then gets a final stop.
pub fn run_node(settings: NodeSettings, stop: &AtomicBool) -> Result<NodeReport, NodeError> {
    let started = std::time::Instant::now();
    let NodeSettings {
        identity,
        ros,
        mut pipeline,
        fixed_frame,
        base_frame,
        cmd_vel_stamped,
        publish_cmd_vel,
        cmd_vel_guard,
        target_frame,
        use_sim_time,
        camera,
        extra_cameras,
        mount_given,
        duration,
        scan_odometry,
        odometry_input,
        extra_scan_topics,
    } = settings;
    // Checked now, so a bad config fails before the node joins the graph.
    crate::leg_model::pipeline(pipeline.clone())?;
    let topic = |name: &str| ros.topic(name, &identity.name, &identity.namespace);
    let scan_topic = topic("scan");
    let extra_scans: Vec<Arc<ExtraScanTopic>> = extra_scan_topics
        .iter()
        .map(|t| Arc::new(ExtraScanTopic::new(&topic(t))))
        .collect();
    let tf_topic = topic("tf");
    let outputs = OutputTopics {
        cmd_vel: publish_cmd_vel.then(|| topic("cmd_vel")),
        cmd_vel_stamped: cmd_vel_stamped.then(|| base_frame.clone()),
        target_pose: topic("tether/target_pose"),
        tf: tf_topic.clone(),
        target_frame,
        results: ros_outputs()
            .map(|o| topic(o.topic.trim_start_matches('/')))
            .collect(),
    };
    let cameras = super::cameras::feeds(camera.as_ref(), &extra_cameras, &pipeline, &topic);

    let mut node = RosNode::start(identity.clone())?;
    let guard = match &outputs.cmd_vel {
        Some(cmd_vel) if cmd_vel_guard => Some(CmdVelGuardSpec::beside(
            &identity,
            cmd_vel,
            outputs.cmd_vel_stamped.clone(),
        )),
        _ => None,
    };
    let (mut sinks, guard) = open_sinks(&mut node, &outputs, &fixed_frame, guard.as_ref())?;
    let (tx, rx) = mpsc::sync_channel(CHANNEL_DEPTH);
    let Inputs {
        clock,
        threads,
        counters,
        transforms,
    } = start_inputs(
        &mut node,
        &topic,
        tx,
        use_sim_time,
        (&fixed_frame, &base_frame),
        &cameras,
        &extra_scans,
    )?;
    let tf_static_topic = topic("tf_static");
    let (stop_graph, graph_stops) = mpsc::channel::<()>();
    let graph_thread = watch_graph(node.graph_watcher(), graph_stops)?;
    announce(
        &identity,
        &std::iter::once(scan_topic.as_str())
            .chain(extra_scans.iter().map(|t| t.topic.as_str()))
            .collect::<Vec<_>>()
            .join(", "),
        &outputs,
        &fixed_frame,
        guard.is_some(),
    );

    let mounts = StartMounts {
        rx: &rx,
        transforms: &transforms,
        cameras: &cameras,
        base_frame: &base_frame,
        scan_topic: &scan_topic,
        extra_scans: &extra_scans,
        tf_static_topic: &tf_static_topic,
        mount_given,
    };
    let clock_start_ns = clock.now_ns();
    let mount_publisher = mounts.take(&mut node, &mut pipeline, clock_start_ns)?;
    let mut pipeline = crate::leg_model::pipeline(pipeline)?;
    // `duration` counts from the start, the wait for the first scan and the mounts
    // included: on sim time in simulated seconds, else on the wall clock.
    let spent = if use_sim_time {
        Duration::from_nanos(u64::try_from(clock.now_ns() - clock_start_ns).unwrap_or(0))
    } else {
        started.elapsed()
    };
    let loop_config = LoopConfig {
        control_period: crate::control_timer::CONTROL_PERIOD,
        duration: duration.map(|d| d.saturating_sub(spent)),
        track_width_m: pipeline.config().limits.track_width_m,
        scan_odometry,
        odometry_input,
    };
    let scan_period_s = pipeline.config().laser.scan_period_s;
    let summary = run_loop::run(
        &mut pipeline,
        &clock,
        &rx,
        &mut sinks,
        None::<&mut Recorder<io::Cursor<Vec<u8>>>>,
        stop,
        &loop_config,
        scan_period_s,
    );
    // A reliable writer resends what its readers have not acknowledged: give the final
    // stop time to arrive before the participant goes.
    std::thread::sleep(Duration::from_millis(300));
    let _ = stop_graph.send(());
    drop(rx);
    for feed in &cameras {
        feed.latest.close();
    }
    stop_threads(threads);
    let graph_problems = graph_thread.join().unwrap_or_else(|_| {
        tracing::error!("the graph thread panicked");
        0
    });
    drop(sinks);
    // The guard's pipe closed with the sinks: it publishes its (second) stop and exits.
    if let Some(guard) = guard {
        end_guard(guard);
    }
    drop(mount_publisher);
    drop(node);
    Ok(NodeReport {
        summary,
        pipeline,
        scans: counters,
        camera: cameras
            .iter()
            .find(|f| f.frame_id == FIRST_CAMERA_FRAME)
            .map_or_else(Arc::default, |f| Arc::clone(&f.counters)),
        extra_cameras: cameras
            .iter()
            .filter(|f| f.frame_id != FIRST_CAMERA_FRAME)
            .map(|f| (f.topic.clone(), f.frame_id.clone(), Arc::clone(&f.counters)))
            .collect(),
        graph_problems,
        clock,
        tf_topic,
        scan_topic,
        extra_scans,
    })
}

/// The node's inputs, started: their threads send to the loop's channel.
struct Inputs {
    /// The node's clock (with sim time, `/clock`'s, already started).
    clock: LiveClock,
    /// The readers' and the camera detector's threads.
    threads: Vec<(&'static str, StoppableThread)>,
    /// What the scan, odometry and `/tf` readers count.
    counters: Arc<ScanCounters>,
    /// The mounts heard on `/tf_static`.
    transforms: Arc<Mutex<StaticTransforms>>,
}

/// Starts the inputs: `/clock` with sim time (and waits for it), `odom`, `/tf` (the
/// base's pose, `frames` = (fixed, base)), the camera, `/tf_static` and the scans,
/// resolving their names with `topic`.
fn start_inputs(
    node: &mut RosNode,
    topic: &dyn Fn(&str) -> String,
    tx: mpsc::SyncSender<Input>,
    use_sim_time: bool,
    (fixed_frame, base_frame): (&str, &str),
    cameras: &[CameraFeed],
    extra_scans: &[Arc<ExtraScanTopic>],
) -> Result<Inputs, NodeError> {
    let mut threads: Vec<(&'static str, StoppableThread)> = Vec::new();
    let clock = if use_sim_time {
        let sim = SimClock::new();
        let clock_topic = topic("clock");
        let (stop_clock, clock_stops) = mpsc::channel();
        let reader = start_clock_reader(node, &clock_topic, sim.clone(), tx.clone(), clock_stops)?;
        threads.push(("clock", (stop_clock, reader)));
        wait_for_clock(&sim, &clock_topic)?;
        LiveClock::Sim(sim)
    } else {
        LiveClock::Host(MonotonicClock::new())
    };
    let counters = Arc::new(ScanCounters::default());
    let (stop_odometry, odometry_stops) = mpsc::channel();
    let odometry_reader = start_odometry_reader(
        node,
        &topic("odom"),
        clock.clone(),
        tx.clone(),
        odometry_stops,
        Arc::clone(&counters),
    )?;
    threads.push(("odometry", (stop_odometry, odometry_reader)));
    // The base's pose from /tf while odom is silent (fixed_frame -> base_frame).
    let (stop_tf_poses, tf_pose_stops) = mpsc::channel();
    let tf_pose_reader = start_tf_reader(
        node,
        &topic("tf"),
        fixed_frame,
        base_frame,
        clock.clone(),
        tx.clone(),
        tf_pose_stops,
        Arc::clone(&counters),
    )?;
    threads.push(("tf", (stop_tf_poses, tf_pose_reader)));
    for feed in cameras {
        let camera_threads = feed.start(node, &clock, &tx)?;
        threads.extend(camera_threads.into_iter().map(|t| ("camera", t)));
    }
    let transforms = Arc::new(Mutex::new(StaticTransforms::default()));
    threads.push((
        "tf_static",
        start_tf_static_reader(node, &topic("tf_static"), &transforms)?,
    ));
    for extra in extra_scans {
        let (stop_reader, reader_stops) = mpsc::channel();
        let reader = start_scan_reader(
            node,
            &extra.topic,
            clock.clone(),
            (tx.clone(), reader_stops),
            Arc::clone(&counters),
            Some(Arc::clone(extra)),
        )?;
        threads.push(("extra scan", (stop_reader, reader)));
    }
    let (stop_reader, reader_stops) = mpsc::channel();
    let reader = start_scan_reader(
        node,
        &topic("scan"),
        clock.clone(),
        (tx, reader_stops),
        Arc::clone(&counters),
        None,
    )?;
    threads.push(("scan", (stop_reader, reader)));
    Ok(Inputs {
        clock,
        threads,
        counters,
        transforms,
    })
}

/// Tells each thread to stop, then waits for it (the loop's channel is gone, so none
/// is held up sending to it).
fn stop_threads(threads: Vec<(&'static str, StoppableThread)>) {
    for (_, (stop, _)) in &threads {
        let _ = stop.send(());
    }
    for (name, (_, thread)) in threads {
        if thread.join().is_err() {
            tracing::error!("the {name} thread panicked");
        }
    }
}

/// Waits for the `cmd_vel` guard to end after its pipe closed.
fn end_guard(guard: Guard) {
    match guard.wait(GUARD_END_WAIT) {
        Some(status) if status.success() => {}
        other => tracing::warn!(
            "the cmd_vel guard ended badly ({}); tether's own final stop went out",
            other.map_or_else(|| "no status".into(), |s| s.to_string())
        ),
    }
}

/// Says who the node is and where its inputs and outputs are.
fn announce(
    identity: &NodeIdentity,
    scan_topic: &str,
    outputs: &OutputTopics,
    fixed_frame: &str,
    guarded: bool,
) {
    tracing::info!(
        "node {}{}{} on ROS 2 domain {} ({} graph ids): scans from {scan_topic}, commands to \
         {}, results in {fixed_frame} on {}, the target on {} and as frame `{}` on {}{}",
        identity.namespace,
        if identity.namespace.ends_with('/') {
            ""
        } else {
            "/"
        },
        identity.name,
        identity.domain_id,
        tether_ros2::DISTRIBUTION,
        outputs
            .cmd_vel
            .as_deref()
            .unwrap_or("nothing (publish_cmd_vel is false: Nav2 drives)"),
        outputs.results.join(", "),
        outputs.target_pose,
        outputs.target_frame,
        outputs.tf,
        if guarded {
            ", guarded by a cmd_vel guard"
        } else {
            ""
        }
    );
}

/// The `/tf_static` reader: every mount it hears goes into `transforms`.
fn start_tf_static_reader(
    node: &mut RosNode,
    topic: &str,
    transforms: &Arc<Mutex<StaticTransforms>>,
) -> Result<StoppableThread, NodeError> {
    let (stop_tf, tf_stops) = mpsc::channel();
    let transforms = Arc::clone(transforms);
    let subscription = node.subscribe::<TfMessage>(topic, qos::latched(100))?;
    let thread = spawn_reader("ros2-tf-static", subscription, tf_stops, move |received| {
        if let Received::Message { message, .. } = received {
            let mut tree = transforms.lock().unwrap_or_else(|e| e.into_inner());
            let skipped = tree.insert(&message);
            if skipped > 0 {
                tracing::warn!("/tf_static: {skipped} transforms skipped (not a rotation)");
            }
        }
        true
    })
    .map_err(|source| NodeError::Thread {
        what: "/tf_static reader",
        source,
    })?;
    Ok((stop_tf, thread))
}

/// What the start needs to take the sensors' mounts from `/tf_static`.
struct StartMounts<'a> {
    rx: &'a mpsc::Receiver<Input>,
    transforms: &'a Mutex<StaticTransforms>,
    /// The cameras, the first camera first when there is one.
    cameras: &'a [CameraFeed],
    base_frame: &'a str,
    scan_topic: &'a str,
    extra_scans: &'a [Arc<ExtraScanTopic>],
    tf_static_topic: &'a str,
    mount_given: bool,
}

impl StartMounts<'_> {
    /// Takes the lasers' (and the cameras') mounts from `/tf_static` into `pipeline`,
    /// waiting up to [`TF_WAIT`]; publishes the config's mounts of the frames nobody
    /// described, as the robot's description would give them. The publisher must live
    /// as long as the node.
    fn take(
        &self,
        node: &mut RosNode,
        pipeline: &mut PipelineConfig,
        stamp_ns: i64,
    ) -> Result<Option<Publisher<Wire<TfMessage>>>, NodeError> {
        let mounts_by = std::time::Instant::now() + TF_WAIT;
        let (first_frame, unmounted_frame) = mount_from_tf(
            self.rx,
            self.transforms,
            self.base_frame,
            self.scan_topic,
            self.mount_given,
            pipeline,
        );
        let extra_unmounted = self.extra_mounts(first_frame.as_deref(), mounts_by, pipeline);
        let mut unmounted_cameras = Vec::new();
        for feed in self.cameras {
            let name = feed.name();
            let mount = match pipeline
                .extra_cameras
                .iter_mut()
                .find(|c| c.frame_id == feed.frame_id)
            {
                Some(extra) => &mut extra.camera.mount,
                None => &mut pipeline.camera.mount,
            };
            let counted = (name.as_str(), &*feed.counters);
            if let Some(frame) = camera_mount_from_tf(
                self.rx,
                counted,
                self.transforms,
                self.base_frame,
                mounts_by,
                mount,
            ) {
                unmounted_cameras.push((frame, *mount));
            }
        }
        let mut unmounted = Vec::new();
        if self.mount_given {
            if let Some(frame) = unmounted_frame {
                unmounted.push(("laser", frame, Pose3::laser_mount(&pipeline.laser.mount)));
            }
            for (frame, m) in extra_unmounted {
                unmounted.push(("laser", frame, Pose3::laser_mount(&m)));
            }
            for (frame, mount) in unmounted_cameras {
                let pose = camera_pose(&mount, is_optical_frame(&frame));
                unmounted.push(("camera", frame, pose));
            }
        }
        if unmounted.is_empty() {
            return Ok(None);
        }
        publish_mounts(
            node,
            self.tf_static_topic,
            self.base_frame,
            &unmounted,
            stamp_ns,
        )
        .map(Some)
    }
}

impl StartMounts<'_> {
    /// Waits until `mounts_by` for each extra scan topic's first scan and its mount on
    /// `/tf_static` (the loop's inputs meanwhile are dropped, as they are while the
    /// first laser's mount is awaited), then gives each its laser
    /// ([`extra_scans::give_lasers`]). Returns the mounts taken from the configuration.
    fn extra_mounts(
        &self,
        first_frame: Option<&str>,
        mounts_by: std::time::Instant,
        pipeline: &mut PipelineConfig,
    ) -> Vec<(String, LaserMount)> {
        if self.extra_scans.is_empty() {
            return Vec::new();
        }
        let all_known = || {
            let tree = self.transforms.lock().unwrap_or_else(|e| e.into_inner());
            self.extra_scans.iter().all(|t| {
                t.heard()
                    .is_some_and(|f| tree.lookup(self.base_frame, &f).is_some())
            })
        };
        while std::time::Instant::now() < mounts_by && !all_known() {
            let _ = self.rx.recv_timeout(Duration::from_millis(50));
        }
        let tree = self.transforms.lock().unwrap_or_else(|e| e.into_inner());
        extra_scans::give_lasers(
            self.extra_scans,
            &tree,
            self.base_frame,
            first_frame,
            self.mount_given,
            pipeline,
        )
    }
}

/// The loop's outputs.
type Sinks = Vec<Box<dyn CommandSink>>;

/// A reader's or worker's thread, with the sender that tells it to stop.
pub(super) type StoppableThread = (mpsc::Sender<()>, JoinHandle<()>);

/// How long the node waits for the `cmd_vel` guard to join the graph.
const GUARD_READY_WAIT: Duration = Duration::from_secs(10);

/// How long the node waits for the `cmd_vel` guard to end after its pipe closed (its
/// stops, its linger, its participant's goodbye).
const GUARD_END_WAIT: Duration = Duration::from_secs(3);

/// The node's sinks: its topics ([`RosOutputs`]) and, with `guard`, the `cmd_vel`
/// guard's pipe, after the guard has joined the graph.
fn open_sinks(
    node: &mut RosNode,
    outputs: &OutputTopics,
    fixed_frame: &str,
    guard: Option<&CmdVelGuardSpec>,
) -> Result<(Sinks, Option<Guard>), NodeError> {
    let mut sinks: Sinks = vec![Box::new(RosOutputs::new(node, outputs, fixed_frame)?)];
    let Some(spec) = guard else {
        return Ok((sinks, None));
    };
    let exe = std::env::current_exe().map_err(NodeError::Guard)?;
    let (guard, pipe) = Guard::start(&exe, &spec.args(), "the cmd_vel guard", GUARD_READY_WAIT)
        .map_err(NodeError::Guard)?;
    // After the topics: the guard gets each command once it is published.
    sinks.push(Box::new(
        QueuedLines::new("cmd_vel guard", pipe).map_err(NodeError::Guard)?,
    ));
    tracing::info!(
        "cmd_vel guard: node {} publishes zero commands on {} if tether ros2 is killed or \
         silent for {} ms",
        spec.identity.name,
        spec.topic,
        spec.silence.as_millis()
    );
    Ok((sinks, Some(guard)))
}

/// How long the node waits at the start for a scan and its mount on `/tf_static` (and,
/// with a camera, for the camera's).
const TF_WAIT: Duration = Duration::from_secs(5);

/// Takes the laser's mount from `/tf_static` (`base_frame` -> the scans' frame) when it
/// is published within [`TF_WAIT`] of the start: the robot's description is what a ROS
/// robot says about itself. Otherwise the config's (or the default) mount stays, with a
/// warning naming the frames. The scans that arrive meanwhile are dropped. Returns the
/// scans' frame when one came, and again when no transform to it did.
fn mount_from_tf(
    rx: &mpsc::Receiver<Input>,
    transforms: &Mutex<StaticTransforms>,
    base_frame: &str,
    scan_topic: &str,
    mount_given: bool,
    pipeline: &mut PipelineConfig,
) -> (Option<String>, Option<String>) {
    let started = std::time::Instant::now();
    let mut scan_frame = None;
    while started.elapsed() < TF_WAIT {
        if let Ok(Input::Scan(scan)) = rx.recv_timeout(Duration::from_millis(50)) {
            scan_frame = Some(scan.frame_id);
        }
        let Some(frame) = &scan_frame else {
            continue;
        };
        let tree = transforms.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(pose) = tree.lookup(base_frame, frame) {
            let mount = LaserMount {
                x_m: pose.position_m[0],
                y_m: pose.position_m[1],
                yaw_rad: pose.yaw_rad(),
                height_m: pose.position_m[2],
            };
            let old = pipeline.laser.mount;
            if mount_given
                && ((old.x_m - mount.x_m).hypot(old.y_m - mount.y_m) > 0.01
                    || (old.yaw_rad - mount.yaw_rad).abs() > 0.01)
            {
                tracing::warn!(
                    "the laser's mount in the config ({:.3}, {:.3}, yaw {:.3}) is not the one \
                     on /tf_static; using /tf_static's",
                    old.x_m,
                    old.y_m,
                    old.yaw_rad
                );
            }
            tracing::info!(
                "laser mount from /tf_static: {base_frame} -> {frame} at ({:.3}, {:.3}) m, \
                 yaw {:.3} rad, {:.3} m up",
                mount.x_m,
                mount.y_m,
                mount.yaw_rad,
                mount.height_m
            );
            pipeline.laser.mount = mount;
            return (scan_frame, None);
        }
    }
    let m = pipeline.laser.mount;
    let source = if mount_given {
        "the config's"
    } else {
        "the default"
    };
    match &scan_frame {
        Some(frame) => {
            let heard = transforms
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .frames();
            tracing::warn!(
                "no transform from {base_frame} to {frame} on /tf_static within {} s (frames \
                 heard: {}); the laser is taken at {source} mount ({:.3}, {:.3}), yaw {:.3}",
                TF_WAIT.as_secs(),
                if heard.is_empty() {
                    "none".into()
                } else {
                    heard.join(", ")
                },
                m.x_m,
                m.y_m,
                m.yaw_rad
            );
        }
        None => tracing::warn!(
            "no scan on {scan_topic} within {} s; the laser is taken at {source} mount",
            TF_WAIT.as_secs()
        ),
    }
    (scan_frame.clone(), scan_frame)
}

/// The sensors' mounts as the robot's description: `base_frame` -> each sensor's frame
/// on `/tf_static` (latched, one message), for RViz and other nodes, when the config
/// gives the mounts and nobody else publishes them. The publisher must live as long as
/// the node.
fn publish_mounts(
    node: &mut RosNode,
    topic: &str,
    base_frame: &str,
    mounts: &[(&str, String, Pose3)],
    stamp_ns: i64,
) -> Result<Publisher<Wire<TfMessage>>, NodeError> {
    let publisher = node.publisher::<TfMessage>(topic, qos::latched(1))?;
    // One message with every transform: a latched topic keeps only the last one.
    let message = TfMessage {
        transforms: mounts
            .iter()
            .map(|(_, frame, pose)| TransformStampedMsg {
                header: Header::new(tether_core::Stamp::from_ns(stamp_ns), base_frame),
                child_frame_id: frame.clone(),
                transform: *pose,
            })
            .collect(),
    };
    publisher
        .publish(Wire(message))
        .map_err(|e| NodeError::PublishMount {
            topic: topic.to_owned(),
            message: format!("{e:?}"),
        })?;
    for (sensor, frame, _) in mounts {
        tracing::info!(
            "published the config's {sensor} mount on {topic}: {base_frame} -> {frame} \
             (nobody else did)"
        );
    }
    Ok(publisher)
}

/// How often the node compares its topics with the graph's.
const GRAPH_CHECK_PERIOD: Duration = Duration::from_secs(1);

/// Warns, once each, about publishers and subscribers on tether's topics that DDS will
/// not connect to it (another type, an incompatible QoS), with the fix; returns how many
/// there were when `stop` fires.
fn watch_graph(
    watcher: GraphWatcher,
    stop: mpsc::Receiver<()>,
) -> Result<JoinHandle<usize>, NodeError> {
    std::thread::Builder::new()
        .name("ros2-graph".into())
        .spawn(move || {
            let mut told = std::collections::BTreeSet::new();
            loop {
                for mismatch in watcher.mismatches() {
                    let text = mismatch.to_string();
                    if told.insert(text.clone()) {
                        tracing::warn!("{text}");
                    }
                }
                if !matches!(
                    stop.recv_timeout(GRAPH_CHECK_PERIOD),
                    Err(mpsc::RecvTimeoutError::Timeout)
                ) {
                    return told.len();
                }
            }
        })
        .map_err(|source| NodeError::Thread {
            what: "graph thread",
            source,
        })
}

/// How long the node waits at the start for `/clock` with `use_sim_time`.
const CLOCK_WAIT: Duration = Duration::from_secs(10);

/// Waits for the first `/clock` (nothing can be stamped before it).
fn wait_for_clock(clock: &SimClock, topic: &str) -> Result<(), NodeError> {
    let started = std::time::Instant::now();
    while !clock.started() {
        if started.elapsed() >= CLOCK_WAIT {
            return Err(NodeError::NoClock {
                topic: topic.to_owned(),
                waited_s: CLOCK_WAIT.as_secs(),
            });
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    tracing::info!(
        "sim time from {topic}: {:.3} s",
        clock.now_ns() as f64 * 1e-9
    );
    Ok(())
}
