//! tether's ROS messages, each defined once, with both of their wire formats.
//!
//! - The message types: `sensor_msgs/LaserScan` ([`LaserScanMsg`], a
//!   [`tether_core::LaserScan`]; [`RawLaserScan`] as serialised), `sensor_msgs/Image`
//!   ([`ImageMsg`], mono8, rgb8, bgr8, to a [`tether_core::GrayImage`]),
//!   `sensor_msgs/CompressedImage` ([`CompressedImageMsg`], JPEG or PNG kept as is),
//!   `geometry_msgs/Twist` ([`TwistMsg`], [`TwistStampedMsg`]), `geometry_msgs/PoseArray`
//!   ([`PoseArrayMsg`]), `geometry_msgs/PoseStamped` ([`PoseStampedMsg`]),
//!   `geometry_msgs/PoseWithCovarianceStamped`
//!   ([`PoseWithCovarianceStampedMsg`], to a [`tether_core::Gaussian2`]),
//!   `nav_msgs/Odometry` ([`OdometryMsg`], to a [`tether_core::Pose2`]), `tf2_msgs`,
//!   markers, detections, `rosgraph_msgs/Clock`, and leg_tracker's `PersonArray`
//!   ([`PersonArrayMsg`], [`PersonMsg`]).
//! - [`Ros2Message`] and [`cdr`]: the ROS 2 form, CDR with the 4-byte encapsulation
//!   header and the full `ros2msg` definitions, as MCAP files (tether-recording) and DDS
//!   (tether-ros2) carry them ([`to_cdr`], [`from_cdr`]).
//! - [`ros1`]: the ROS 1 form ([`RosMessage`], [`RosMessageOut`]) as bags carry it, with
//!   the full definitions and their MD5 sums ([`definition_md5`]).
//!
//! A payload comes from outside, so nothing here panics on one: a payload that does not
//! decode is a [`DecodeError`] naming the field and the byte offset.
//!
//! Dependencies point one way (STYLE.md): this crate depends on `tether-core` only.

pub mod cdr;
mod error;
mod msgs;
pub mod ros1;

pub use error::{DecodeError, EncodeError};
pub use msgs::{
    ClockMsg, ColorRgba, CompressedFormat, CompressedImageMsg, Detection2DArrayMsg, Detection2DMsg,
    Header, ImageMsg, ImageMsgError, LaserScanMsg, MarkerArrayMsg, MarkerMsg, MeshFile,
    ObjectHypothesisMsg, OdometryMsg, PersonArrayMsg, PersonMsg, PixelEncoding, Pose3,
    PoseArrayMsg, PoseStampedMsg, PoseWithCovarianceStampedMsg, RawLaserScan, Ros2Message,
    StringMsg, TfMessage, TransformStampedMsg, TwistMsg, TwistStampedMsg, from_cdr, to_cdr,
    type_matches,
};
pub use ros1::{DefinitionError, RosMessage, RosMessageOut, definition_md5, md5_hex};
