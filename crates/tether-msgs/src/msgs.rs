//! The messages tether reads and writes, each defined once with its conversions to
//! tether's types, and their ROS 2 form: the CDR layout and the full `.msg` definitions
//! (the `ros2msg` schema encoding). The ROS 1 form of the same types is in
//! [`crate::ros1`].
//!
//! A schema's text is the message's own definition followed, for every type it uses,
//! by a line of 80 `=` and a line `MSG: package/Type` and that type's definition
//! (rosbag2's `docs/message_definition_encoding.md`): this is what `ros2 bag record`
//! stores and what Foxglove and `mcap-ros2-support` parse to decode without ROS.

use tether_core::{Cov2, CovError, Frame, GrayImage, ImageError, LaserScan, Point2, Pose2, Stamp};

use crate::cdr::{CdrReader, CdrWriter};
use crate::error::{DecodeError, EncodeError};

/// A ROS 2 message type this crate can serialise and deserialise.
pub trait Ros2Message: Sized {
    /// Type name as MCAP schemas and rosbag2 store it, e.g. `sensor_msgs/msg/LaserScan`.
    const TYPE: &'static str;
    /// The full `ros2msg` definition: the message and every type it uses.
    const DEFINITION: &'static str;
    /// Writes the fields after the encapsulation header.
    fn write_cdr(&self, w: &mut CdrWriter) -> Result<(), EncodeError>;
    /// Reads the fields after the encapsulation header.
    fn read_cdr(r: &mut CdrReader<'_>) -> Result<Self, DecodeError>;
    /// The header stamp, for message types that have a `std_msgs/Header`.
    fn header_stamp(&self) -> Option<Stamp> {
        None
    }
}

/// Serialises a message as a CDR payload (encapsulation header included).
pub fn to_cdr<M: Ros2Message>(msg: &M) -> Result<Vec<u8>, EncodeError> {
    let mut w = CdrWriter::new();
    msg.write_cdr(&mut w)?;
    Ok(w.into_bytes())
}

/// Deserialises a CDR payload; bytes left over (beyond a little zero padding) are an
/// error.
pub fn from_cdr<M: Ros2Message>(payload: &[u8]) -> Result<M, DecodeError> {
    let mut r = CdrReader::new(payload)?;
    let msg = M::read_cdr(&mut r)?;
    r.finish()?;
    Ok(msg)
}

/// Whether an MCAP schema name denotes `M` (`pkg/msg/Type`; the older `pkg/Type` spelling
/// is accepted too).
pub fn type_matches<M: Ros2Message>(schema_name: &str) -> bool {
    schema_name == M::TYPE || schema_name == M::TYPE.replacen("/msg/", "/", 1)
}

// The definition blocks. Macros rather than consts so that `concat!` can join them.
macro_rules! sep {
    ($name:literal) => {
        concat!(
            "================================================================================\n",
            "MSG: ",
            $name,
            "\n"
        )
    };
}
macro_rules! time_def {
    () => {
        concat!(
            sep!("builtin_interfaces/Time"),
            "int32 sec\n",
            "uint32 nanosec\n"
        )
    };
}
macro_rules! header_def {
    () => {
        concat!(
            sep!("std_msgs/Header"),
            "builtin_interfaces/Time stamp\n",
            "string frame_id\n",
            time_def!()
        )
    };
}
macro_rules! vector3_def {
    () => {
        concat!(
            sep!("geometry_msgs/Vector3"),
            "float64 x\n",
            "float64 y\n",
            "float64 z\n"
        )
    };
}
macro_rules! twist_def {
    () => {
        concat!(
            sep!("geometry_msgs/Twist"),
            "Vector3 linear\n",
            "Vector3 angular\n",
            vector3_def!()
        )
    };
}
macro_rules! pose_def {
    () => {
        concat!(
            sep!("geometry_msgs/Pose"),
            "Point position\n",
            "Quaternion orientation\n",
            sep!("geometry_msgs/Point"),
            "float64 x\n",
            "float64 y\n",
            "float64 z\n",
            sep!("geometry_msgs/Quaternion"),
            "float64 x 0\n",
            "float64 y 0\n",
            "float64 z 0\n",
            "float64 w 1\n"
        )
    };
}
macro_rules! pose_with_covariance_def {
    () => {
        concat!(
            sep!("geometry_msgs/PoseWithCovariance"),
            "Pose pose\n",
            "float64[36] covariance\n",
            pose_def!()
        )
    };
}

mod detections;
mod image;
mod markers;
mod pose_stamped;
pub use detections::{Detection2DArrayMsg, Detection2DMsg, ObjectHypothesisMsg};
pub use image::{CompressedFormat, CompressedImageMsg, ImageMsg, ImageMsgError, PixelEncoding};
pub use markers::{ClockMsg, ColorRgba, MarkerArrayMsg, MarkerMsg, MeshFile};
pub use pose_stamped::PoseStampedMsg;

/// `std_msgs/Header`: the ROS 1 form has a sequence number, the ROS 2 form
/// (`std_msgs/msg/Header`) does not; a CDR payload neither writes nor reads it (0).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Header {
    /// Sequence number (ROS 1 only; 0 in ROS 2 messages).
    pub seq: u32,
    /// Time of the data (for a scan: of its first beam).
    pub stamp: Stamp,
    /// Frame the data is expressed in.
    pub frame_id: String,
}

impl Header {
    /// A header (sequence number 0).
    pub fn new(stamp: Stamp, frame_id: impl Into<String>) -> Self {
        Header {
            seq: 0,
            stamp,
            frame_id: frame_id.into(),
        }
    }

    fn write(&self, w: &mut CdrWriter) -> Result<(), EncodeError> {
        w.time("header.stamp", self.stamp)?;
        w.string("header.frame_id", &self.frame_id)
    }

    fn read(r: &mut CdrReader<'_>) -> Result<Self, DecodeError> {
        Ok(Header {
            seq: 0,
            stamp: r.time("header.stamp")?,
            frame_id: r.string("header.frame_id")?,
        })
    }
}

/// `geometry_msgs/Pose`: a position and an orientation quaternion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose3 {
    /// Position `[x, y, z]`, m.
    pub position_m: [f64; 3],
    /// Orientation quaternion `[x, y, z, w]`.
    pub orientation: [f64; 4],
}

impl Pose3 {
    /// Heading about z, rad: the yaw of the quaternion,
    /// `atan2(2 (w z + x y), 1 - 2 (y^2 + z^2))`.
    pub fn yaw_rad(&self) -> f64 {
        let [x, y, z, w] = self.orientation;
        (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z))
    }

    /// A pose on the ground plane: position `(x_m, y_m, 0)`, turned by `yaw_rad` about
    /// z (quaternion `(0, 0, sin(yaw/2), cos(yaw/2))`).
    pub fn planar(x_m: f64, y_m: f64, yaw_rad: f64) -> Self {
        let (s, c) = (0.5 * yaw_rad).sin_cos();
        Pose3 {
            position_m: [x_m, y_m, 0.0],
            orientation: [0.0, 0.0, s, c],
        }
    }

    /// A laser's mount on the robot as a pose: its offset, yaw and height (the scan
    /// plane level).
    pub fn laser_mount(m: &tether_core::LaserMount) -> Self {
        let mut pose = Pose3::planar(m.x_m, m.y_m, m.yaw_rad);
        pose.position_m[2] = m.height_m;
        pose
    }

    /// The same pose as a tether transform (`x`, `y`, yaw), dropping height, roll and
    /// pitch; the caller names the frames the message's `frame_id`s stand for.
    pub fn pose2<To: Frame, From: Frame>(&self) -> Pose2<To, From> {
        Pose2::new(self.position_m[0], self.position_m[1], self.yaw_rad())
    }

    /// [`Pose3::planar`] of a tether transform.
    pub fn from_pose2<To: Frame, From: Frame>(pose: Pose2<To, From>) -> Self {
        Self::planar(pose.x, pose.y, pose.yaw)
    }
}

fn write_pose(w: &mut CdrWriter, p: &Pose3) {
    w.f64_array(&p.position_m);
    w.f64_array(&p.orientation);
}

fn read_pose(r: &mut CdrReader<'_>, field: &'static str) -> Result<Pose3, DecodeError> {
    Ok(Pose3 {
        position_m: r.f64_array(field)?,
        orientation: r.f64_array(field)?,
    })
}

/// `sensor_msgs/LaserScan` (ROS 2: `sensor_msgs/msg/LaserScan`) exactly as serialised,
/// before any interpretation; what [`LaserScanMsg`] is built from.
#[derive(Debug, Clone, PartialEq)]
pub struct RawLaserScan {
    /// ROS header.
    pub header: Header,
    /// Direction of the first beam, rad.
    pub angle_min: f32,
    /// Direction of the last beam, rad.
    pub angle_max: f32,
    /// Angle between beams, rad.
    pub angle_increment: f32,
    /// Time between beams, s.
    pub time_increment: f32,
    /// Time between scans, s.
    pub scan_time: f32,
    /// Shortest valid range, m.
    pub range_min: f32,
    /// Longest valid range, m.
    pub range_max: f32,
    /// Ranges as sent, m.
    pub ranges: Vec<f32>,
    /// Intensities as sent.
    pub intensities: Vec<f32>,
}

impl Ros2Message for RawLaserScan {
    const TYPE: &'static str = "sensor_msgs/msg/LaserScan";
    const DEFINITION: &'static str = concat!(
        "std_msgs/Header header\n",
        "float32 angle_min\n",
        "float32 angle_max\n",
        "float32 angle_increment\n",
        "float32 time_increment\n",
        "float32 scan_time\n",
        "float32 range_min\n",
        "float32 range_max\n",
        "float32[] ranges\n",
        "float32[] intensities\n",
        header_def!()
    );

    fn write_cdr(&self, w: &mut CdrWriter) -> Result<(), EncodeError> {
        self.header.write(w)?;
        for v in self.geometry() {
            w.f32(v);
        }
        w.f32_seq("ranges", &self.ranges)?;
        w.f32_seq("intensities", &self.intensities)
    }

    fn read_cdr(r: &mut CdrReader<'_>) -> Result<Self, DecodeError> {
        Ok(RawLaserScan {
            header: Header::read(r)?,
            angle_min: r.f32("angle_min")?,
            angle_max: r.f32("angle_max")?,
            angle_increment: r.f32("angle_increment")?,
            time_increment: r.f32("time_increment")?,
            scan_time: r.f32("scan_time")?,
            range_min: r.f32("range_min")?,
            range_max: r.f32("range_max")?,
            ranges: r.f32_seq("ranges")?,
            intensities: r.f32_seq("intensities")?,
        })
    }

    fn header_stamp(&self) -> Option<Stamp> {
        Some(self.header.stamp)
    }
}

/// `sensor_msgs/LaserScan` (ROS 2: `sensor_msgs/msg/LaserScan`) as a
/// [`tether_core::LaserScan`].
///
/// The scan keeps the ROS header's stamp and `frame_id`. Reading follows REP 117 and
/// tether's convention, in both codecs: beams
/// outside `[range_min, range_max]` or `+inf` are "no return" (`+inf`); NaN, negative
/// values and `-inf` are also "no return" and are counted in
/// [`LaserScan::malformed_beams`]; a header whose beam count
/// (`(angle_max - angle_min) / angle_increment + 1`) disagrees with the ranges makes the
/// message bad ([`DecodeError::Scan`]), and so does a zero angle increment. Writing
/// stores "no return" as `+inf`; a ROS 1 bag gets `angle_max` as
/// [`LaserScanMsg::angle_max_rad`] (what was read, bit for bit), a CDR payload the
/// direction of the scan's last beam (what MCAP files and DDS peers have always had).
#[derive(Debug, Clone, PartialEq)]
pub struct LaserScanMsg {
    /// Sequence number of the ROS 1 header (0 in ROS 2 messages).
    pub seq: u32,
    /// The scan (stamp and frame from the ROS header).
    pub scan: LaserScan,
    /// Direction of the last beam as the message states it, rad.
    pub angle_max_rad: f64,
    /// Time between beams, s.
    pub time_increment_s: f64,
    /// Time between scans, s.
    pub scan_time_s: f64,
    /// Intensities (often empty).
    pub intensities: Vec<f32>,
}

impl LaserScanMsg {
    /// A message for `scan` with the sensor's timing and no intensities.
    pub fn new(scan: LaserScan, time_increment_s: f64, scan_time_s: f64) -> Self {
        LaserScanMsg {
            seq: 0,
            angle_max_rad: scan.angle_max_rad(),
            scan,
            time_increment_s,
            scan_time_s,
            intensities: Vec::new(),
        }
    }

    /// The message's fields exactly as a CDR payload serialises them (`f32`; `angle_max`
    /// the direction of the scan's last beam).
    pub fn to_raw(&self) -> RawLaserScan {
        let mut raw = RawLaserScan::from_scan(
            self.seq,
            &self.scan,
            self.time_increment_s,
            self.scan_time_s,
        );
        raw.intensities.clone_from(&self.intensities);
        raw
    }
}

impl RawLaserScan {
    /// The message of a tether scan: `angle_max = angle_min + (n - 1) increment`; "no
    /// return" beams are written as `+inf` (REP 117).
    pub fn from_scan(seq: u32, scan: &LaserScan, time_increment_s: f64, scan_time_s: f64) -> Self {
        RawLaserScan {
            header: Header {
                seq,
                stamp: scan.stamp,
                frame_id: scan.frame_id.clone(),
            },
            angle_min: scan.angle_min_rad as f32,
            angle_max: scan.angle_max_rad() as f32,
            angle_increment: scan.angle_increment_rad as f32,
            time_increment: time_increment_s as f32,
            scan_time: scan_time_s as f32,
            range_min: scan.range_min_m as f32,
            range_max: scan.range_max_m as f32,
            ranges: scan.ranges_m().to_vec(),
            intensities: Vec::new(),
        }
    }
}

impl RawLaserScan {
    /// The seven numbers between the header and the ranges, in wire order: `angle_min`,
    /// `angle_max`, `angle_increment`, `time_increment`, `scan_time`, `range_min`,
    /// `range_max`.
    pub fn geometry(&self) -> [f32; 7] {
        [
            self.angle_min,
            self.angle_max,
            self.angle_increment,
            self.time_increment,
            self.scan_time,
            self.range_min,
            self.range_max,
        ]
    }

    /// Interprets the message as a tether scan (see [`LaserScanMsg`]).
    pub fn into_msg(self) -> Result<LaserScanMsg, DecodeError> {
        let scan = LaserScan::with_angle_max(
            self.header.stamp,
            self.header.frame_id,
            f64::from(self.angle_min),
            f64::from(self.angle_max),
            f64::from(self.angle_increment),
            f64::from(self.range_min),
            f64::from(self.range_max),
            self.ranges,
        )?;
        Ok(LaserScanMsg {
            seq: self.header.seq,
            scan,
            angle_max_rad: f64::from(self.angle_max),
            time_increment_s: f64::from(self.time_increment),
            scan_time_s: f64::from(self.scan_time),
            intensities: self.intensities,
        })
    }
}

impl Ros2Message for LaserScanMsg {
    const TYPE: &'static str = RawLaserScan::TYPE;
    const DEFINITION: &'static str = RawLaserScan::DEFINITION;

    fn write_cdr(&self, w: &mut CdrWriter) -> Result<(), EncodeError> {
        // Written field by field (not through `to_raw`) to avoid copying the ranges.
        let s = &self.scan;
        w.time("header.stamp", s.stamp)?;
        w.string("header.frame_id", &s.frame_id)?;
        for v in [
            s.angle_min_rad,
            s.angle_max_rad(),
            s.angle_increment_rad,
            self.time_increment_s,
            self.scan_time_s,
            s.range_min_m,
            s.range_max_m,
        ] {
            w.f32(v as f32);
        }
        w.f32_seq("ranges", s.ranges_m())?;
        w.f32_seq("intensities", &self.intensities)
    }

    fn read_cdr(r: &mut CdrReader<'_>) -> Result<Self, DecodeError> {
        RawLaserScan::read_cdr(r)?.into_msg()
    }

    fn header_stamp(&self) -> Option<Stamp> {
        Some(self.scan.stamp)
    }
}

/// `geometry_msgs/msg/Twist`: a velocity command. A differential base uses
/// `linear.x` (forward, m/s) and `angular.z` (counter-clockwise, rad/s).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TwistMsg {
    /// Linear velocity `[x, y, z]`, m/s.
    pub linear_mps: [f64; 3],
    /// Angular velocity `[x, y, z]`, rad/s.
    pub angular_radps: [f64; 3],
}

impl TwistMsg {
    /// The command `(v, w)` of a unicycle / differential-drive base.
    pub fn unicycle(v_mps: f64, w_radps: f64) -> Self {
        TwistMsg {
            linear_mps: [v_mps, 0.0, 0.0],
            angular_radps: [0.0, 0.0, w_radps],
        }
    }

    /// Forward speed `linear.x`, m/s.
    pub fn v_mps(&self) -> f64 {
        self.linear_mps[0]
    }

    /// Turn rate `angular.z`, rad/s.
    pub fn w_radps(&self) -> f64 {
        self.angular_radps[2]
    }

    fn write(&self, w: &mut CdrWriter) {
        w.f64_array(&self.linear_mps);
        w.f64_array(&self.angular_radps);
    }

    fn read(r: &mut CdrReader<'_>) -> Result<Self, DecodeError> {
        Ok(TwistMsg {
            linear_mps: r.f64_array("linear")?,
            angular_radps: r.f64_array("angular")?,
        })
    }
}

impl Ros2Message for TwistMsg {
    const TYPE: &'static str = "geometry_msgs/msg/Twist";
    const DEFINITION: &'static str =
        concat!("Vector3 linear\n", "Vector3 angular\n", vector3_def!());

    fn write_cdr(&self, w: &mut CdrWriter) -> Result<(), EncodeError> {
        self.write(w);
        Ok(())
    }

    fn read_cdr(r: &mut CdrReader<'_>) -> Result<Self, DecodeError> {
        Self::read(r)
    }
}

/// `geometry_msgs/msg/TwistStamped`: a velocity command with the time it was made and
/// the frame it is in (what Jazzy's diff-drive controller and Nav2 take on `cmd_vel`).
#[derive(Debug, Clone, PartialEq)]
pub struct TwistStampedMsg {
    /// ROS header (the command's time, the base's frame).
    pub header: Header,
    /// The command.
    pub twist: TwistMsg,
}

impl Ros2Message for TwistStampedMsg {
    const TYPE: &'static str = "geometry_msgs/msg/TwistStamped";
    const DEFINITION: &'static str = concat!(
        "std_msgs/Header header\n",
        "Twist twist\n",
        header_def!(),
        twist_def!()
    );

    fn write_cdr(&self, w: &mut CdrWriter) -> Result<(), EncodeError> {
        self.header.write(w)?;
        self.twist.write(w);
        Ok(())
    }

    fn read_cdr(r: &mut CdrReader<'_>) -> Result<Self, DecodeError> {
        Ok(TwistStampedMsg {
            header: Header::read(r)?,
            twist: TwistMsg::read(r)?,
        })
    }

    fn header_stamp(&self) -> Option<Stamp> {
        Some(self.header.stamp)
    }
}

/// `geometry_msgs/PoseArray` (ROS 2: `geometry_msgs/msg/PoseArray`).
#[derive(Debug, Clone, PartialEq)]
pub struct PoseArrayMsg {
    /// ROS header (stamp and the frame of the poses).
    pub header: Header,
    /// The poses.
    pub poses: Vec<Pose3>,
}

impl PoseArrayMsg {
    /// The poses' positions projected on the x-y plane, in frame `F`: the caller names
    /// the tether frame that `header.frame_id` stands for.
    pub fn positions_2d<F: Frame>(&self) -> Vec<Point2<F>> {
        self.poses
            .iter()
            .map(|p| Point2::new(p.position_m[0], p.position_m[1]))
            .collect()
    }
}

impl Ros2Message for PoseArrayMsg {
    const TYPE: &'static str = "geometry_msgs/msg/PoseArray";
    const DEFINITION: &'static str = concat!(
        "std_msgs/Header header\n",
        "Pose[] poses\n",
        header_def!(),
        pose_def!()
    );

    fn write_cdr(&self, w: &mut CdrWriter) -> Result<(), EncodeError> {
        self.header.write(w)?;
        w.count("poses", self.poses.len())?;
        for p in &self.poses {
            write_pose(w, p);
        }
        Ok(())
    }

    fn read_cdr(r: &mut CdrReader<'_>) -> Result<Self, DecodeError> {
        let header = Header::read(r)?;
        let n = r.count("poses", 7 * 8)?;
        let mut poses = Vec::with_capacity(n);
        for _ in 0..n {
            poses.push(read_pose(r, "poses")?);
        }
        Ok(PoseArrayMsg { header, poses })
    }

    fn header_stamp(&self) -> Option<Stamp> {
        Some(self.header.stamp)
    }
}

/// `geometry_msgs/msg/TransformStamped`: where frame `child_frame_id` is in
/// `header.frame_id` (the transform takes points in the child frame to the parent's).
#[derive(Debug, Clone, PartialEq)]
pub struct TransformStampedMsg {
    /// ROS header: the parent frame.
    pub header: Header,
    /// The child frame.
    pub child_frame_id: String,
    /// Translation and rotation (a `geometry_msgs/Transform` has the layout of a pose).
    pub transform: Pose3,
}

impl TransformStampedMsg {
    fn write(&self, w: &mut CdrWriter) -> Result<(), EncodeError> {
        self.header.write(w)?;
        w.string("child_frame_id", &self.child_frame_id)?;
        write_pose(w, &self.transform);
        Ok(())
    }

    fn read(r: &mut CdrReader<'_>) -> Result<Self, DecodeError> {
        Ok(TransformStampedMsg {
            header: Header::read(r)?,
            child_frame_id: r.string("child_frame_id")?,
            transform: read_pose(r, "transform")?,
        })
    }
}

/// `tf2_msgs/msg/TFMessage`: what `/tf` and `/tf_static` carry.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TfMessage {
    /// The transforms.
    pub transforms: Vec<TransformStampedMsg>,
}

impl Ros2Message for TfMessage {
    const TYPE: &'static str = "tf2_msgs/msg/TFMessage";
    const DEFINITION: &'static str = concat!(
        "geometry_msgs/TransformStamped[] transforms\n",
        sep!("geometry_msgs/TransformStamped"),
        "std_msgs/Header header\n",
        "string child_frame_id\n",
        "Transform transform\n",
        header_def!(),
        sep!("geometry_msgs/Transform"),
        "Vector3 translation\n",
        "Quaternion rotation\n",
        vector3_def!(),
        sep!("geometry_msgs/Quaternion"),
        "float64 x 0\n",
        "float64 y 0\n",
        "float64 z 0\n",
        "float64 w 1\n"
    );

    fn write_cdr(&self, w: &mut CdrWriter) -> Result<(), EncodeError> {
        w.count("transforms", self.transforms.len())?;
        for t in &self.transforms {
            t.write(w)?;
        }
        Ok(())
    }

    fn read_cdr(r: &mut CdrReader<'_>) -> Result<Self, DecodeError> {
        // Each element is at least a stamp, an empty frame, an empty child and 7 f64.
        let n = r.count("transforms", 8 + 4 + 4 + 7 * 8)?;
        let mut transforms = Vec::with_capacity(n);
        for _ in 0..n {
            transforms.push(TransformStampedMsg::read(r)?);
        }
        Ok(TfMessage { transforms })
    }
}

/// `leg_tracker/PersonArray` (`msg/PersonArray.msg` of github.com/angusleigh/leg_tracker;
/// `leg_tracker/msg/PersonArray` in ROS 2): `std_msgs/Header header` and
/// `Person[] people`. leg_tracker publishes its tracked people this way; annotations in
/// that format give each labelled person's `id` and pose in the scan's frame.
#[derive(Debug, Clone, PartialEq)]
pub struct PersonArrayMsg {
    /// ROS header (stamp and the frame of the poses).
    pub header: Header,
    /// The people.
    pub people: Vec<PersonMsg>,
}

/// `leg_tracker/Person` (github.com/angusleigh/leg_tracker, `msg/Person.msg`): a
/// tracked or labelled person, `geometry_msgs/Pose pose` and `uint32 id`. It has no
/// header of its own: the frame and stamp are the enclosing [`PersonArrayMsg`]'s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PersonMsg {
    /// Pose of the person in the array's frame.
    pub pose: Pose3,
    /// Identity of the person (a track id, or a label id in annotations).
    pub id: u32,
}

impl Ros2Message for PersonArrayMsg {
    const TYPE: &'static str = "leg_tracker/msg/PersonArray";
    const DEFINITION: &'static str = concat!(
        "std_msgs/Header header\n",
        "Person[] people\n",
        header_def!(),
        sep!("leg_tracker/Person"),
        "geometry_msgs/Pose pose\n",
        "uint32 id\n",
        pose_def!()
    );

    fn write_cdr(&self, w: &mut CdrWriter) -> Result<(), EncodeError> {
        self.header.write(w)?;
        w.count("people", self.people.len())?;
        for p in &self.people {
            write_pose(w, &p.pose);
            w.u32(p.id);
        }
        Ok(())
    }

    fn read_cdr(r: &mut CdrReader<'_>) -> Result<Self, DecodeError> {
        let header = Header::read(r)?;
        let n = r.count("people", 7 * 8 + 4)?;
        let mut people = Vec::with_capacity(n);
        for _ in 0..n {
            let pose = read_pose(r, "people.pose")?;
            people.push(PersonMsg {
                pose,
                id: r.u32("people.id")?,
            });
        }
        Ok(PersonArrayMsg { header, people })
    }

    fn header_stamp(&self) -> Option<Stamp> {
        Some(self.header.stamp)
    }
}

/// Index of `(row, col)` in a row-major 6x6 covariance over
/// `(x, y, z, rotation about x, rotation about y, rotation about z)`.
const fn cov6(row: usize, col: usize) -> usize {
    row * 6 + col
}

/// `geometry_msgs/msg/PoseWithCovarianceStamped`: a pose and its 6x6 covariance (row
/// major over x, y, z, roll, pitch, yaw; m^2, rad^2).
#[derive(Debug, Clone, PartialEq)]
pub struct PoseWithCovarianceStampedMsg {
    /// ROS header.
    pub header: Header,
    /// The pose.
    pub pose: Pose3,
    /// Covariance, row major.
    pub covariance: [f64; 36],
}

impl PoseWithCovarianceStampedMsg {
    /// A position estimate on the ground plane: mean and x-y covariance from
    /// `estimate`, heading `yaw_rad`, `yaw_var_rad2` as the yaw variance. The variances
    /// of z, roll and pitch are 0 (the estimate lives on the plane).
    pub fn from_gaussian<F: Frame>(
        header: Header,
        estimate: &tether_core::Gaussian2<F>,
        yaw_rad: f64,
        yaw_var_rad2: f64,
    ) -> Self {
        let mut covariance = [0.0; 36];
        covariance[cov6(0, 0)] = estimate.cov.xx();
        covariance[cov6(0, 1)] = estimate.cov.xy();
        covariance[cov6(1, 0)] = estimate.cov.xy();
        covariance[cov6(1, 1)] = estimate.cov.yy();
        covariance[cov6(5, 5)] = yaw_var_rad2;
        PoseWithCovarianceStampedMsg {
            header,
            pose: Pose3::planar(estimate.mean.x, estimate.mean.y, yaw_rad),
            covariance,
        }
    }

    /// The position estimate on the x-y plane in frame `F` (the caller names the frame
    /// `header.frame_id` stands for); fails when the x-y block is not a valid covariance.
    pub fn gaussian<F: Frame>(&self) -> Result<tether_core::Gaussian2<F>, CovError> {
        let c = &self.covariance;
        let cov = Cov2::new(c[cov6(0, 0)], c[cov6(0, 1)], c[cov6(1, 1)])?;
        tether_core::Gaussian2::new(
            Point2::new(self.pose.position_m[0], self.pose.position_m[1]),
            cov,
        )
    }
}

impl Ros2Message for PoseWithCovarianceStampedMsg {
    const TYPE: &'static str = "geometry_msgs/msg/PoseWithCovarianceStamped";
    const DEFINITION: &'static str = concat!(
        "std_msgs/Header header\n",
        "PoseWithCovariance pose\n",
        header_def!(),
        pose_with_covariance_def!()
    );

    fn write_cdr(&self, w: &mut CdrWriter) -> Result<(), EncodeError> {
        self.header.write(w)?;
        write_pose(w, &self.pose);
        w.f64_array(&self.covariance);
        Ok(())
    }

    fn read_cdr(r: &mut CdrReader<'_>) -> Result<Self, DecodeError> {
        Ok(PoseWithCovarianceStampedMsg {
            header: Header::read(r)?,
            pose: read_pose(r, "pose.pose")?,
            covariance: r.f64_array("pose.covariance")?,
        })
    }

    fn header_stamp(&self) -> Option<Stamp> {
        Some(self.header.stamp)
    }
}

/// `nav_msgs/msg/Odometry`: the pose of `child_frame_id` in `header.frame_id` and its
/// velocity in `child_frame_id`, each with a 6x6 covariance.
#[derive(Debug, Clone, PartialEq)]
pub struct OdometryMsg {
    /// ROS header (`frame_id`: usually `odom`).
    pub header: Header,
    /// The moving frame (usually `base_link`).
    pub child_frame_id: String,
    /// Pose of the child frame.
    pub pose: Pose3,
    /// Pose covariance, row major.
    pub pose_covariance: [f64; 36],
    /// Velocity of the child frame, in the child frame.
    pub twist: TwistMsg,
    /// Velocity covariance, row major.
    pub twist_covariance: [f64; 36],
}

impl OdometryMsg {
    /// Planar odometry: pose `(x, y, yaw)` of `child_frame_id` and its velocity
    /// `(v, w)`, covariances zero (unknown).
    pub fn planar<To: Frame, From: Frame>(
        header: Header,
        child_frame_id: impl Into<String>,
        pose: Pose2<To, From>,
        v_mps: f64,
        w_radps: f64,
    ) -> Self {
        OdometryMsg {
            header,
            child_frame_id: child_frame_id.into(),
            pose: Pose3::from_pose2(pose),
            pose_covariance: [0.0; 36],
            twist: TwistMsg::unicycle(v_mps, w_radps),
            twist_covariance: [0.0; 36],
        }
    }
}

impl Ros2Message for OdometryMsg {
    const TYPE: &'static str = "nav_msgs/msg/Odometry";
    const DEFINITION: &'static str = concat!(
        "std_msgs/Header header\n",
        "string child_frame_id\n",
        "geometry_msgs/PoseWithCovariance pose\n",
        "geometry_msgs/TwistWithCovariance twist\n",
        header_def!(),
        pose_with_covariance_def!(),
        sep!("geometry_msgs/TwistWithCovariance"),
        "Twist twist\n",
        "float64[36] covariance\n",
        twist_def!()
    );

    fn write_cdr(&self, w: &mut CdrWriter) -> Result<(), EncodeError> {
        self.header.write(w)?;
        w.string("child_frame_id", &self.child_frame_id)?;
        write_pose(w, &self.pose);
        w.f64_array(&self.pose_covariance);
        self.twist.write(w);
        w.f64_array(&self.twist_covariance);
        Ok(())
    }

    fn read_cdr(r: &mut CdrReader<'_>) -> Result<Self, DecodeError> {
        Ok(OdometryMsg {
            header: Header::read(r)?,
            child_frame_id: r.string("child_frame_id")?,
            pose: read_pose(r, "pose.pose")?,
            pose_covariance: r.f64_array("pose.covariance")?,
            twist: TwistMsg::read(r)?,
            twist_covariance: r.f64_array("twist.covariance")?,
        })
    }

    fn header_stamp(&self) -> Option<Stamp> {
        Some(self.header.stamp)
    }
}

/// `std_msgs/msg/String`: free text (tether writes its target state as one JSON object
/// per tick on `/tether/target_state`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StringMsg {
    /// The text (no NUL characters: CDR strings end at the first).
    pub data: String,
}

impl Ros2Message for StringMsg {
    const TYPE: &'static str = "std_msgs/msg/String";
    const DEFINITION: &'static str = "string data\n";

    fn write_cdr(&self, w: &mut CdrWriter) -> Result<(), EncodeError> {
        w.string("data", &self.data)
    }

    fn read_cdr(r: &mut CdrReader<'_>) -> Result<Self, DecodeError> {
        Ok(StringMsg {
            data: r.string("data")?,
        })
    }
}

#[cfg(test)]
mod tests;
