//! The live loop on a ROS 2 graph (`tether ros2`, feature `ros2`, design 12): topics as
//! its sources ([`inputs`]) and sinks ([`outputs`]), the node that wires them around the
//! loop ([`node`]), and the `cmd_vel` guard beside it ([`guard`]), with no ROS
//! installation (a pure-Rust DDS participant, `tether-ros2`). Names are relative, so
//! `__ns:=/robot1` puts them all under `/robot1`.
//!
//! | topic | type | QoS |
//! |---|---|---|
//! | `scan` (in) | `sensor_msgs/msg/LaserScan` | best effort, keep last 5 (matches reliable and best-effort publishers) |
//! | each of `extra_scan_topics` (in) | `sensor_msgs/msg/LaserScan` of another scanner, told apart by its `frame_id` ([`extra_scans`]) | as `scan` |
//! | `odom` (in) | `nav_msgs/msg/Odometry` (the pose of `child_frame_id` in `header.frame_id`) | best effort, keep last 5 |
//! | `tf` (in) | `tf2_msgs/msg/TFMessage`: `fixed_frame` -> `base_frame`, the base's pose while `odom` is silent | best effort, keep last 5 |
//! | `clock` (in, with `use_sim_time`) | `rosgraph_msgs/msg/Clock` | best effort, keep last 1 |
//! | `tf_static` (in) | `tf2_msgs/msg/TFMessage` (the laser's and the camera's mounts below `base_frame`; [`camera_mount`]) | reliable, transient local |
//! | `image_raw` or `image_raw/compressed` (in, when the config has a `[camera]`) | `sensor_msgs/msg/Image` (`mono8`, `rgb8`, `bgr8`) or `sensor_msgs/msg/CompressedImage` (JPEG, PNG) | best effort, keep last 5 |
//! | `detections` (in, with `camera_input:=detections`, and from the simulator) | `vision_msgs/msg/Detection2DArray` (upper-body boxes in pixels of the configured camera) | best effort, keep last 5 |
//! | each of `extra_camera_topics` (in; by default `FRAME/image_raw` or `FRAME/detections` of each further `[[camera]]`) | as the first camera's: another camera, its boxes read through its own model ([`cameras`]) | as the first camera's |
//! | `cmd_vel` (out, unless `publish_cmd_vel:=false`) | `geometry_msgs/msg/Twist` (or `TwistStamped`) | reliable, keep last 10 |
//! | `tether/people`, `tether/laser_people` (out) | `geometry_msgs/msg/PoseArray` | reliable, keep last 10 |
//! | `tether/target` (out) | `geometry_msgs/msg/PoseWithCovarianceStamped` | reliable, keep last 10 |
//! | `tether/target_pose` (out, while locked) | `geometry_msgs/msg/PoseStamped` (heading: walking direction, held while standing) | reliable, keep last 10 |
//! | `tf` (out, while locked) | `tf2_msgs/msg/TFMessage`: `fixed_frame` -> `target_frame` (`target`), the same pose | reliable, keep last 100 |
//! | `tether/target_state` (out) | `std_msgs/msg/String` (JSON) | reliable, keep last 10 |
//! | `tether/markers` (out) | `visualization_msgs/msg/MarkerArray` (tracks, ellipses, the target, observations) | reliable, keep last 10 |
//!
//! The camera: frames are taken as they arrive; the detector gets the newest one when
//! it is free (frames it had no time for are counted as superseded, never queued).

pub mod camera_mount;
pub mod cameras;
pub mod extra_scans;
pub mod guard;
pub mod inputs;
pub mod node;
pub mod outputs;

pub use cameras::NodeCamera;
pub use guard::{CmdVelGuardSpec, watch_cmd_vel};
pub use inputs::{CameraCounters, ScanCounters};
pub use node::{NodeError, NodeReport, NodeSettings, run_node};
pub use outputs::{OutputTopics, RosOutputs, WalkingHeading};
