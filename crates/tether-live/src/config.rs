//! The configuration of a live robot: `tether run --config robot.toml`.
//!
//! Strict: unknown keys are refused, and everything that differs from robot to robot
//! (the base's geometry and limits, where the sensors sit, how the robot follows, where
//! the devices are) has no default, so that a forgotten line is named in the error
//! rather than silently replaced by another robot's value. The algorithms' tuning
//! (leg detector, tracker, target selection, safety timeouts...) lives in the optional
//! `[pipeline]` table, the [`PipelineConfig`] that `tether sim`, `track` and `replay`
//! read too; the few values the tables above own may not be set there again.
//!
//! ```toml
//! [robot]              # the base
//! radius_m = 0.17
//! track_width_m = 0.235
//! max_speed_mps = 0.5
//! max_wheel_speed_mps = 0.5
//! max_accel_mps2 = 0.5
//!
//! [laser]              # serial = "/dev/ttyACM0" (+ baud) or tcp = "192.168.0.10:10940"
//! serial = "/dev/ttyACM0"
//! mount = { x_m = 0.10, y_m = 0.0, yaw_rad = 0.0, height_m = 0.30 }
//!
//! [follow]             # the virtual spring
//! follow_distance_m = 1.0
//! attach_ahead_m = 0.3
//! distance_omega_radps = 2.0
//! bearing_omega_radps = 2.0
//!
//! [base]               # kind = "none" | "create" | "wheels"
//! kind = "none"
//!
//! [output]
//! stdout = true
//! ```
//!
//! `configs/robot.example.toml` in the repository documents every key.

use std::path::{Path, PathBuf};

use serde::Deserialize;
use tether_control::{LimitsError, SafetyConfigError, SpringConfigError, SpringGains};
use tether_core::{
    CameraIntrinsics, CameraModel, CameraModelError, CameraMount, ExtraCamera, ExtraLaser,
    LaserModelError, LaserMount,
};
use tether_pipeline::PipelineConfig;

/// Why a configuration is refused.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file cannot be read.
    #[error("cannot read the config {path}: {error}")]
    Read {
        /// The file.
        path: PathBuf,
        /// What the system said.
        error: std::io::Error,
    },
    /// Not TOML, an unknown or missing key, a value of the wrong type.
    #[error("config {path}: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// The parser's message (names the key, with line and column).
        message: String,
    },
    /// A value that parses but cannot be right.
    #[error("config {path}: `{field}` {message}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// The key, dotted (`robot.track_width_m`).
        field: String,
        /// What is wrong and what is expected.
        message: String,
    },
}

/// Why the pipeline's settings that a config makes ([`RobotConfig::pipeline_config`])
/// are refused: the part, and what is wrong with it.
#[derive(Debug, thiserror::Error)]
pub enum PipelineConfigError {
    /// The laser's model (its mount).
    #[error("laser: {0}")]
    Laser(LaserModelError),
    /// The camera's model (its intrinsics and mount).
    #[error("camera: {0}")]
    Camera(CameraModelError),
    /// The base's limits.
    #[error("limits: {0}")]
    Limits(LimitsError),
    /// The safety layer (the robot's radius).
    #[error("safety: {0}")]
    Safety(SafetyConfigError),
    /// The follower.
    #[error("follower: {0}")]
    Follower(SpringConfigError),
}

impl ConfigError {
    /// The dotted key a validation error names (`None` for read and parse errors).
    pub fn field(&self) -> Option<&str> {
        match self {
            ConfigError::Invalid { field, .. } => Some(field),
            _ => None,
        }
    }
}

/// The whole file.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotConfig {
    /// The base: footprint, wheel geometry and limits.
    pub robot: RobotSection,
    /// The laser scanner: where it is plugged in and where it sits (`[laser]`), or the
    /// scanners (`[[laser]]` each; design 5.7).
    pub laser: Lasers,
    /// The camera, if the robot has one (`[camera]`), or the cameras (`[[camera]]`
    /// each; design 5.7).
    pub camera: Option<Cameras>,
    /// How the robot follows.
    pub follow: FollowSection,
    /// Where the commands go besides stdout.
    pub base: BaseSection,
    /// Outputs: JSON lines on stdout, an MCAP recording.
    pub output: OutputSection,
    /// Tuning of the algorithms (every key optional; see `PipelineConfig`).
    #[serde(default)]
    pub pipeline: PipelineConfig,
}

/// `[robot]`: the base.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotSection {
    /// Radius of a circle around the footprint, m (the obstacle stop keeps it clear).
    pub radius_m: f64,
    /// Distance between the drive wheels, m.
    pub track_width_m: f64,
    /// Top forward speed tether may command, m/s.
    pub max_speed_mps: f64,
    /// Top speed of either wheel, m/s.
    pub max_wheel_speed_mps: f64,
    /// Largest increase of speed, m/s^2 (braking may be harder: `[pipeline.limits]`).
    pub max_accel_mps2: f64,
}

/// `[laser]`: a SCIP 2.0 Hokuyo on a serial / USB-ACM port or on TCP.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LaserSection {
    /// Serial or USB-ACM device, e.g. `/dev/ttyACM0`.
    pub serial: Option<String>,
    /// Baud rate of `serial` (default 19200; any value works over USB-ACM).
    pub baud: Option<u32>,
    /// `host:port` of an Ethernet model (port 10940 when left out).
    pub tcp: Option<String>,
    /// Where the scanner sits on the robot.
    pub mount: MountSection,
    /// The `frame_id` of its scans: `laser` for the first when left out; each further
    /// `[[laser]]` names its own (e.g. `rear_laser`).
    #[serde(default)]
    pub frame_id: Option<String>,
    /// How long a laser that stops answering (a cable pulled and plugged back, a sensor
    /// restarting) is tried again before the run ends, s; `0` ends the run at once.
    /// The robot stands meanwhile (`[pipeline.safety] laser_timeout_s`). Optional,
    /// default [`DEFAULT_RECONNECT_S`].
    #[serde(default = "default_reconnect_s")]
    pub reconnect_s: f64,
}

/// How long a laser that stops answering is tried again by default, s: long enough
/// for a USB device to be enumerated again or a sensor to restart, short enough that
/// a laser really gone ends the run soon.
pub const DEFAULT_RECONNECT_S: f64 = 10.0;

fn default_reconnect_s() -> f64 {
    DEFAULT_RECONNECT_S
}

/// Where the laser is plugged in.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LaserLink {
    /// A serial or USB-ACM device at a baud rate.
    Serial {
        /// Device path.
        path: String,
        /// Baud rate.
        baud: u32,
    },
    /// An Ethernet sensor.
    Tcp {
        /// `host:port` or `host`.
        address: String,
    },
}

/// A sensor's pose on the robot (all keys required).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MountSection {
    /// Forward offset from the centre of the wheel axis, m.
    pub x_m: f64,
    /// Leftward offset, m.
    pub y_m: f64,
    /// Yaw relative to the robot's x axis, counter-clockwise, rad.
    pub yaw_rad: f64,
    /// Height above the floor, m.
    pub height_m: f64,
}

/// `[camera]`: frames from a V4L2 device or a folder of images, searched for upper
/// bodies with a Haar cascade.
// Alike in shape to `[laser]` (where from, optional settings, a mount), not in keys: each
// section is a TOML table of its own.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSection {
    /// A folder of PNG/JPEG images, served in name order.
    pub folder: Option<PathBuf>,
    /// Frames per second of `folder`.
    pub fps: Option<f64>,
    /// Start the folder over at its end (default false: the camera then falls silent).
    #[serde(default)]
    pub repeat: bool,
    /// A V4L2 device, e.g. `/dev/video0` (needs tether built with `--features v4l2`).
    pub v4l2: Option<String>,
    /// Pinhole intrinsics of the frames.
    pub intrinsics: IntrinsicsSection,
    /// Where the camera sits: the lens' offset and yaw as for the laser, its height
    /// and its upward tilt.
    pub mount: CameraMountSection,
    /// The `frame_id` of its frames: `camera` for the first when left out; each
    /// further `[[camera]]` names its own (e.g. `rear_camera`).
    #[serde(default)]
    pub frame_id: Option<String>,
    /// Cascade XML (default: Debian's `haarcascade_upperbody.xml` of `opencv-data`).
    pub cascade: Option<PathBuf>,
    /// Pyramid scale factor of the detector (default 1.1).
    pub scale_factor: Option<f64>,
    /// Neighbours a detection needs (default 3).
    pub min_neighbors: Option<u32>,
}

/// Where the frames come from.
#[derive(Debug, Clone, PartialEq)]
pub enum FrameInput {
    /// A folder of images served at a rate.
    Folder {
        /// The folder.
        path: PathBuf,
        /// Frames per second.
        fps: f64,
        /// Start over at the end.
        repeat: bool,
    },
    /// A V4L2 device.
    V4l2 {
        /// Device path.
        device: String,
    },
}

/// Pinhole intrinsics (all keys required).
// Parallel to tether_core::CameraIntrinsics on purpose: a robot's config must state every
// key of its camera, where the pipeline's TOML takes a default for each.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IntrinsicsSection {
    /// Focal length along u, px.
    pub fx_px: f64,
    /// Focal length along v, px.
    pub fy_px: f64,
    /// Principal point u, px.
    pub cx_px: f64,
    /// Principal point v, px.
    pub cy_px: f64,
    /// Frame width, px.
    pub width_px: u32,
    /// Frame height, px.
    pub height_px: u32,
}

/// The camera's pose (all keys required).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraMountSection {
    /// Forward offset of the lens from the centre of the wheel axis, m.
    pub x_m: f64,
    /// Leftward offset, m.
    pub y_m: f64,
    /// Yaw of the optical axis relative to the robot's x axis, rad.
    pub yaw_rad: f64,
    /// Height of the lens above the floor, m.
    pub height_m: f64,
    /// Upward pitch of the optical axis, rad.
    pub tilt_rad: f64,
}

/// `[follow]`: the virtual spring.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FollowSection {
    /// Follow distance (the spring's free length), m.
    pub follow_distance_m: f64,
    /// Where the spring is attached, ahead of the wheel axis, m (> 0).
    pub attach_ahead_m: f64,
    /// Natural frequency of the distance loop, rad/s (gains critically damped).
    pub distance_omega_radps: f64,
    /// Natural frequency of the bearing loop, rad/s.
    pub bearing_omega_radps: f64,
    /// Explicit gains `{ k1, k2, k3, k4, mass_kg, inertia_kgm2 }`, replacing those the
    /// frequencies give.
    pub gains: Option<SpringGains>,
}

/// Which base adapter receives the commands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BaseKind {
    /// None: commands only go to stdout and the recording.
    None,
    /// An iRobot Create (1 or 2) over its Open Interface: Drive Direct on a serial port.
    Create,
    /// Left and right wheel speeds as text lines, on a serial port or into a file.
    Wheels,
}

/// Format of the wheel-speed lines.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WheelFormat {
    /// `{"stamp_ns":..,"left_mps":..,"right_mps":..}`
    #[default]
    Json,
    /// `left_mps right_mps` (m/s, 3 decimals, one space).
    Text,
}

/// `[base]`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BaseSection {
    /// `none`, `create` or `wheels`.
    pub kind: BaseKind,
    /// The serial device (`create`; `wheels`: a serial device when `baud` is set, a
    /// file otherwise).
    pub device: Option<PathBuf>,
    /// Baud rate (`create`: required, 57600 for a Create 1, 115200 for a Create 2).
    pub baud: Option<u32>,
    /// `wheels`: line format (default `json`).
    pub format: Option<WheelFormat>,
    /// Run the base guard (default true): a small process that holds its own handle
    /// on the device and stops the base when tether dies or hangs
    /// ([`crate::guard`]).
    #[serde(default)]
    pub guard: Option<bool>,
    /// The guard's patience: the base is stopped after this long without a command,
    /// s (default 0.5; 0.1 to 2).
    #[serde(default)]
    pub guard_silence_s: Option<f64>,
}

/// `[output]`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputSection {
    /// One JSON line per pipeline tick on stdout (the command, why it stops, the target).
    pub stdout: bool,
    /// An MCAP file (ROS 2 messages): the scans, the dead-reckoned odometry and
    /// tether's people, target and commands, for `tether replay` and Foxglove.
    pub record: Option<PathBuf>,
}

/// `[pipeline]` keys that belong to the tables above (where they are required): the
/// pipeline key (or table) and the robot file's key it comes from
/// ([`RobotConfig::pipeline_config`]); a robot file that sets one in `[pipeline]` is
/// refused.
pub const OWNED_ELSEWHERE: &[(&str, &str)] = &[
    ("pipeline.laser.mount", "laser.mount"),
    ("pipeline.camera", "camera.intrinsics and camera.mount"),
    ("pipeline.extra_cameras", "[[camera]]"),
    ("pipeline.limits.track_width_m", "robot.track_width_m"),
    ("pipeline.limits.max_speed_mps", "robot.max_speed_mps"),
    (
        "pipeline.limits.max_wheel_speed_mps",
        "robot.max_wheel_speed_mps",
    ),
    ("pipeline.limits.max_accel_mps2", "robot.max_accel_mps2"),
    ("pipeline.safety.robot_radius_m", "robot.radius_m"),
    (
        "pipeline.follower.follow_distance_m",
        "follow.follow_distance_m",
    ),
    ("pipeline.follower.attach_ahead_m", "follow.attach_ahead_m"),
    (
        "pipeline.follower.distance_omega_radps",
        "follow.distance_omega_radps",
    ),
    (
        "pipeline.follower.bearing_omega_radps",
        "follow.bearing_omega_radps",
    ),
    ("pipeline.follower.gains", "follow.gains"),
];

fn positive(field: &str, value: f64) -> Result<(), (String, String)> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err((
            field.to_owned(),
            format!("= {value}: must be a positive number"),
        ))
    }
}

/// A positive number no larger than `top` (a limit that high switches the limit off).
fn at_most(field: &str, value: f64, top: f64, unit: &str) -> Result<(), (String, String)> {
    if value.is_finite() && value > 0.0 && value <= top {
        Ok(())
    } else {
        Err((
            field.to_owned(),
            format!("= {value:?}: must be in (0, {top}] {unit}"),
        ))
    }
}

fn finite(field: &str, value: f64) -> Result<(), (String, String)> {
    if value.is_finite() {
        Ok(())
    } else {
        Err((
            field.to_owned(),
            format!("= {value}: must be a finite number"),
        ))
    }
}

impl LaserSection {
    /// Checks one scanner's table, named `key` in errors (`laser`, `laser[1]`);
    /// `laser_link`: the run reads the laser itself (`tether run`), so it needs
    /// `serial` or `tcp`.
    fn validate(&self, laser_link: bool, key: &str) -> Result<(), (String, String)> {
        let l = self;
        let field = |name: &str| format!("{key}.{name}");
        match (&l.serial, &l.tcp) {
            (Some(_), Some(_)) => {
                return Err((
                    key.into(),
                    "has both `serial` and `tcp`: the laser is on one of them".into(),
                ));
            }
            (None, None) if laser_link => {
                return Err((
                    key.into(),
                    "needs `serial = \"/dev/ttyACM0\"` or `tcp = \"host:port\"`".into(),
                ));
            }
            (Some(path), None) if path.is_empty() => {
                return Err((field("serial"), "is empty".into()));
            }
            (None, Some(addr)) if addr.is_empty() => {
                return Err((field("tcp"), "is empty".into()));
            }
            _ => {}
        }
        if l.tcp.is_some() && l.baud.is_some() {
            return Err((
                field("baud"),
                "only applies to `serial`, not to `tcp`".into(),
            ));
        }
        if l.baud == Some(0) {
            return Err((field("baud"), "= 0: must be a baud rate".into()));
        }
        if !(l.reconnect_s.is_finite() && (0.0..=3600.0).contains(&l.reconnect_s)) {
            return Err((
                field("reconnect_s"),
                format!("= {:?}: must be in [0, 3600] s", l.reconnect_s),
            ));
        }
        let m = &l.mount;
        finite(&field("mount.x_m"), m.x_m)?;
        finite(&field("mount.y_m"), m.y_m)?;
        finite(&field("mount.yaw_rad"), m.yaw_rad)?;
        positive(&field("mount.height_m"), m.height_m)?;
        Ok(())
    }

    /// Where this scanner is plugged in.
    pub fn link(&self) -> LaserLink {
        match (&self.serial, &self.tcp) {
            (Some(path), _) => LaserLink::Serial {
                path: path.clone(),
                baud: self.baud.unwrap_or(tether_scip::DEFAULT_BAUD_RATE),
            },
            (None, Some(address)) => LaserLink::Tcp {
                address: address.clone(),
            },
            // `validate` refuses a laser without either.
            (None, None) => LaserLink::Tcp {
                address: String::new(),
            },
        }
    }

    /// Its mount, as the pipeline's laser model takes it.
    pub fn laser_mount(&self) -> LaserMount {
        let m = &self.mount;
        LaserMount {
            x_m: m.x_m,
            y_m: m.y_m,
            yaw_rad: m.yaw_rad,
            height_m: m.height_m,
        }
    }
}

impl CameraSection {
    /// Checks `[camera]` (or the `[[camera]]` its errors name `key`).
    fn validate(&self, key: &str) -> Result<(), (String, String)> {
        let c = self;
        let field = |name: &str| format!("{key}.{name}");
        match (&c.folder, &c.v4l2) {
            (Some(_), Some(_)) => {
                return Err((
                    key.into(),
                    "has both `folder` and `v4l2`: frames come from one of them".into(),
                ));
            }
            (None, None) => {
                return Err((
                    key.into(),
                    "needs `folder = \"DIR\"` (with `fps`) or `v4l2 = \"/dev/video0\"`".into(),
                ));
            }
            (Some(_), None) => match c.fps {
                Some(fps) => positive(&field("fps"), fps)?,
                None => {
                    return Err((
                        field("fps"),
                        "is missing: a folder of frames needs a rate".into(),
                    ));
                }
            },
            (None, Some(_)) => {
                if c.fps.is_some() {
                    return Err((
                        field("fps"),
                        "only applies to `folder` (a V4L2 device runs at its own rate)".into(),
                    ));
                }
                if c.repeat {
                    return Err((field("repeat"), "only applies to `folder`".into()));
                }
            }
        }
        if let Some(s) = c.scale_factor
            && !(s.is_finite() && s > 1.0)
        {
            return Err((
                field("scale_factor"),
                format!("= {s}: must be above 1 (OpenCV's default is 1.1)"),
            ));
        }
        let i = &c.intrinsics;
        positive(&field("intrinsics.fx_px"), i.fx_px)?;
        positive(&field("intrinsics.fy_px"), i.fy_px)?;
        finite(&field("intrinsics.cx_px"), i.cx_px)?;
        finite(&field("intrinsics.cy_px"), i.cy_px)?;
        positive(&field("intrinsics.width_px"), f64::from(i.width_px))?;
        positive(&field("intrinsics.height_px"), f64::from(i.height_px))?;
        let m = &c.mount;
        finite(&field("mount.x_m"), m.x_m)?;
        finite(&field("mount.y_m"), m.y_m)?;
        finite(&field("mount.yaw_rad"), m.yaw_rad)?;
        positive(&field("mount.height_m"), m.height_m)?;
        finite(&field("mount.tilt_rad"), m.tilt_rad)?;
        Ok(())
    }

    /// Where its frames come from.
    pub fn frame_input(&self) -> Option<FrameInput> {
        match (&self.folder, &self.v4l2) {
            (Some(path), _) => Some(FrameInput::Folder {
                path: path.clone(),
                fps: self.fps.unwrap_or(10.0),
                repeat: self.repeat,
            }),
            (None, Some(device)) => Some(FrameInput::V4l2 {
                device: device.clone(),
            }),
            (None, None) => None,
        }
    }

    /// Its model, as the pipeline takes it.
    pub fn camera_model(&self) -> CameraModel {
        let i = &self.intrinsics;
        let m = &self.mount;
        CameraModel {
            intrinsics: CameraIntrinsics {
                fx_px: i.fx_px,
                fy_px: i.fy_px,
                cx_px: i.cx_px,
                cy_px: i.cy_px,
                width_px: i.width_px,
                height_px: i.height_px,
            },
            mount: CameraMount {
                x_m: m.x_m,
                y_m: m.y_m,
                yaw_rad: m.yaw_rad,
                height_m: m.height_m,
                tilt_rad: m.tilt_rad,
            },
        }
    }
}

impl BaseSection {
    /// Checks `[base]`.
    fn validate(&self) -> Result<(), (String, String)> {
        let b = self;
        match b.kind {
            BaseKind::None => {
                for (key, set) in [
                    ("device", b.device.is_some()),
                    ("baud", b.baud.is_some()),
                    ("format", b.format.is_some()),
                ] {
                    if set {
                        tracing::warn!(
                            "base.{key} is set but `kind = \"none\"` drives no base: ignored"
                        );
                    }
                }
            }
            BaseKind::Create => {
                if b.device.is_none() {
                    return Err((
                        "base.device".into(),
                        "is missing: the Create's serial port, e.g. \"/dev/ttyUSB0\"".into(),
                    ));
                }
                if b.baud.is_none() {
                    return Err((
                        "base.baud".into(),
                        "is missing: 57600 for a Create 1, 115200 for a Create 2".into(),
                    ));
                }
                if b.format.is_some() {
                    return Err(("base.format".into(), "only applies to `wheels`".into()));
                }
            }
            BaseKind::Wheels => {
                if b.device.is_none() {
                    return Err((
                        "base.device".into(),
                        "is missing: a serial device (with `baud`) or a file".into(),
                    ));
                }
            }
        }
        if b.baud == Some(0) {
            return Err(("base.baud".into(), "= 0: must be a baud rate".into()));
        }
        if let Some(s) = b.guard_silence_s
            && !(s.is_finite() && (0.1..=2.0).contains(&s))
        {
            return Err((
                "base.guard_silence_s".into(),
                format!(
                    "= {s:?}: must be in [0.1, 2] s (the control loop commands at 20 Hz; \
                     longer lets a hung tether drive on)"
                ),
            ));
        }
        Ok(())
    }
}

impl RobotConfig {
    /// Reads and checks a config file.
    pub fn load(path: &Path) -> Result<Self, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|error| ConfigError::Read {
            path: path.to_path_buf(),
            error,
        })?;
        Self::parse(&text, path)
    }

    /// Reads and checks a config for `tether ros2`: the scans come from a topic, so
    /// `[laser]` needs only its mount (a `serial` or `tcp` there is accepted and not
    /// used).
    pub fn load_for_ros2(path: &Path) -> Result<Self, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|error| ConfigError::Read {
            path: path.to_path_buf(),
            error,
        })?;
        Self::parse_checked(&text, path, false)
    }

    /// Reads and checks a robot's config for a command that replays a recording
    /// (`track`, `replay`, `eval-track`): like [`RobotConfig::load_for_ros2`], the
    /// scans come from elsewhere, so `[laser]` needs only its mount.
    pub fn load_for_recordings(path: &Path) -> Result<Self, ConfigError> {
        Self::load_for_ros2(path)
    }

    /// Parses and checks a config; `path` names it in errors.
    pub fn parse(text: &str, path: &Path) -> Result<Self, ConfigError> {
        Self::parse_checked(text, path, true)
    }

    /// Parses and checks a config; `laser_link`: whether `[laser]` must say where the
    /// scanner is plugged in.
    fn parse_checked(text: &str, path: &Path, laser_link: bool) -> Result<Self, ConfigError> {
        let parse_error = |message: String| ConfigError::Parse {
            path: path.to_path_buf(),
            message: message.trim_end().to_owned(),
        };
        // Keys of `[pipeline]` that the required tables own: refused, not overridden
        // behind the user's back.
        let table: toml::Table = toml::from_str(text).map_err(|e| parse_error(e.to_string()))?;
        for (key, owner) in OWNED_ELSEWHERE {
            let mut parts = key.split('.');
            let mut node = parts.next().and_then(|first| table.get(first));
            for part in parts {
                node = node.and_then(|n| n.get(part));
            }
            if node.is_some() {
                return Err(ConfigError::Invalid {
                    path: path.to_path_buf(),
                    field: (*key).to_owned(),
                    message: format!("is set in `{owner}` on a live robot; remove it here"),
                });
            }
        }
        // `tether run` reads the scanners of `[[laser]]` (design 5.7): extra ones here
        // would never be heard, and the laser watchdog would hold the robot for good.
        // `tether ros2` reads each from a topic of its own.
        if laser_link
            && table
                .get("pipeline")
                .and_then(|p| p.get("extra_lasers"))
                .is_some()
        {
            return Err(ConfigError::Invalid {
                path: path.to_path_buf(),
                field: "pipeline.extra_lasers".into(),
                message: "is not read by `tether run`, which reads its scanners from \
                          `[[laser]]` (one table each, with `frame_id` and where it is plugged \
                          in; design 5.7): move it there"
                    .into(),
            });
        }
        let mut config: RobotConfig =
            toml::from_str(text).map_err(|e| parse_error(e.to_string()))?;
        crate::leg_model::resolve(&mut config.pipeline.legs, crate::leg_model::folder_of(path));
        config
            .validate(laser_link)
            .map_err(|(field, message)| ConfigError::Invalid {
                path: path.to_path_buf(),
                field,
                message,
            })?;
        let pipeline = config.pipeline_config().map_err(|e| ConfigError::Invalid {
            path: path.to_path_buf(),
            field: "pipeline".into(),
            message: e.to_string(),
        })?;
        crate::pipeline_file::check_ranges(path, &pipeline)?;
        Ok(config)
    }

    fn validate(&self, laser_link: bool) -> Result<(), (String, String)> {
        let r = &self.robot;
        positive("robot.radius_m", r.radius_m)?;
        // The same ranges as `[pipeline.limits]` (tether_control::MotionLimits), named
        // by the key the user wrote.
        at_most("robot.track_width_m", r.track_width_m, 2.0, "m")?;
        at_most("robot.max_speed_mps", r.max_speed_mps, 3.0, "m/s")?;
        at_most(
            "robot.max_wheel_speed_mps",
            r.max_wheel_speed_mps,
            3.0,
            "m/s",
        )?;
        at_most("robot.max_accel_mps2", r.max_accel_mps2, 10.0, "m/s^2")?;
        self.laser.validate(|l, key| l.validate(laser_link, key))?;
        if let Some(c) = &self.camera {
            c.validate(CameraSection::validate)?;
        }
        let f = &self.follow;
        positive("follow.follow_distance_m", f.follow_distance_m)?;
        positive("follow.attach_ahead_m", f.attach_ahead_m)?;
        positive("follow.distance_omega_radps", f.distance_omega_radps)?;
        positive("follow.bearing_omega_radps", f.bearing_omega_radps)?;
        self.base.validate()?;
        Ok(())
    }

    /// Where the (first) laser is.
    pub fn laser_link(&self) -> LaserLink {
        self.laser.link()
    }

    /// The pipeline's configuration: `[pipeline]` with the robot's geometry, the
    /// sensors' poses and the follower's settings put in; the laser only without a
    /// camera.
    pub fn pipeline_config(&self) -> Result<PipelineConfig, PipelineConfigError> {
        let mut p = self.pipeline.clone();
        let r = &self.robot;
        p.limits.track_width_m = r.track_width_m;
        p.limits.max_speed_mps = r.max_speed_mps;
        p.limits.max_wheel_speed_mps = r.max_wheel_speed_mps;
        p.limits.max_accel_mps2 = r.max_accel_mps2;
        p.safety.robot_radius_m = r.radius_m;
        p.laser.mount = self.laser.laser_mount();
        // Each further scanner: the first's model at its own mount (a SCIP sensor's
        // geometry replaces it at the start), its scans told apart by their frame.
        for extra in self.laser.extra() {
            let mut laser = p.laser.clone();
            laser.mount = extra.laser_mount();
            p.extra_lasers.push(ExtraLaser {
                frame_id: extra.frame_id.clone().unwrap_or_default(),
                laser,
            });
        }
        let f = &self.follow;
        p.follower.follow_distance_m = f.follow_distance_m;
        p.follower.attach_ahead_m = f.attach_ahead_m;
        p.follower.distance_omega_radps = f.distance_omega_radps;
        p.follower.bearing_omega_radps = f.bearing_omega_radps;
        p.follower.gains = f.gains;
        match &self.camera {
            Some(cameras) => {
                p.camera = cameras.camera_model();
                p.extra_cameras = cameras
                    .extra()
                    .iter()
                    .map(|c| ExtraCamera {
                        frame_id: c.frame_id.clone().unwrap_or_default(),
                        camera: c.camera_model(),
                    })
                    .collect();
            }
            None => p.fusion.use_vision = false,
        }
        p.laser.validate().map_err(PipelineConfigError::Laser)?;
        p.camera.validate().map_err(PipelineConfigError::Camera)?;
        p.limits.validate().map_err(PipelineConfigError::Limits)?;
        p.safety.validate().map_err(PipelineConfigError::Safety)?;
        p.follower
            .validate()
            .map_err(PipelineConfigError::Follower)?;
        Ok(p)
    }
}

mod sensors;
#[cfg(test)]
mod tests;

pub use sensors::{Cameras, FIRST_LASER_FRAME, Lasers, SensorTable, Sensors};
