//! tether on a ROS 2 graph, without a ROS installation.
//!
//! A DDS participant from `ros2-client` (pure Rust, on RustDDS) that rclcpp and rclpy
//! nodes see as a node, the command line ROS users type (`--ros-args`,
//! `ROS_DOMAIN_ID`), and tether's messages on the wire with the same CDR codec its MCAP
//! files use ([`wire`]). The live loop that runs the pipeline on what arrives here is
//! the `tether` crate's (`tether ros2`); this crate knows nothing of tracking.

#[cfg(all(feature = "jazzy", feature = "humble"))]
compile_error!(
    "tether-ros2: the features `jazzy` and `humble` exclude each other (build with \
     --no-default-features --features humble for a Humble graph)"
);
#[cfg(not(any(feature = "jazzy", feature = "humble")))]
compile_error!("tether-ros2: choose the ROS 2 distribution: feature `jazzy` or `humble`");

/// The ROS 2 distribution this build joins.
pub const DISTRIBUTION: &str = if cfg!(feature = "humble") {
    "humble"
} else {
    "jazzy"
};

pub mod args;
pub mod graph;
pub mod node;
pub mod tf;
pub mod wire;

pub use args::{ArgsError, ParamValue, Remap, RosArgs, domain_id};
pub use node::{
    GraphWatcher, NodeIdentity, Received, Ros2Error, RosNode, offer, qos, spawn_reader,
};
/// What [`RosNode::publisher`] returns (ros2-client's, re-exported so that a user of the
/// node names it without depending on ros2-client).
pub use ros2_client::dds::Publisher;
pub use tf::StaticTransforms;
pub use wire::Wire;
