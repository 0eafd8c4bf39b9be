//! The ROS 2 topics as the loop's sinks: the commands on `cmd_vel` (`Twist`, or
//! `TwistStamped` in the base's frame; none at all when Nav2 drives), the results on
//! `tether/...` as the MCAP results name them ([`crate::results`]), and the target for
//! Nav2's Following Server on `tether/target_pose` and as a frame on `/tf` (design 12):
//! an output like any other ([`CommandSink`]), so that `run` and `ros2` share one loop
//! and one safety path.

use std::io;

use ros2_client::dds::Publisher;
use tether_core::{Vector2, World};
use tether_msgs::{
    Header, MarkerArrayMsg, Pose3, PoseArrayMsg, PoseStampedMsg, PoseWithCovarianceStampedMsg,
    Ros2Message, StringMsg, TfMessage, TransformStampedMsg, TwistMsg, TwistStampedMsg,
};
use tether_pipeline::Tick;
use tether_ros2::{Ros2Error, RosNode, Wire, qos};

use crate::base::{CommandLine, CommandSink};
use crate::results::{Output, OutputKind, ResultMessage, ros_outputs};

/// A publisher of `M`.
fn publisher<M: Ros2Message>(
    node: &mut RosNode,
    topic: &str,
    depth: usize,
) -> Result<Publisher<Wire<M>>, Ros2Error> {
    node.publisher::<M>(topic, qos::reliable(depth))
}

/// The commands on `/cmd_vel` and the results on `/tether/...`, as the MCAP results
/// name them ([`crate::results`]), and the target on `tether/target_pose` and `/tf`.
pub struct RosOutputs {
    name: String,
    frame: String,
    /// `None`: no `cmd_vel` publisher at all (Nav2 drives).
    cmd_vel: Option<CmdVel>,
    /// The results ([`crate::results::ros_outputs`]), in their order.
    results: Vec<(&'static Output, ResultPublisher)>,
    target_pose: Publisher<Wire<PoseStampedMsg>>,
    tf: Publisher<Wire<TfMessage>>,
    target_frame: String,
    heading: WalkingHeading,
}

/// The publisher of one [`Output`], of its message type.
enum ResultPublisher {
    Poses(Publisher<Wire<PoseArrayMsg>>),
    PoseWithCovariance(Publisher<Wire<PoseWithCovarianceStampedMsg>>),
    Text(Publisher<Wire<StringMsg>>),
    Markers(Publisher<Wire<MarkerArrayMsg>>),
    Twist(Publisher<Wire<TwistMsg>>),
}

impl ResultPublisher {
    /// A publisher on `topic` of `kind`'s messages.
    fn new(node: &mut RosNode, topic: &str, kind: OutputKind) -> Result<Self, Ros2Error> {
        Ok(match kind {
            OutputKind::Poses => ResultPublisher::Poses(publisher(node, topic, 10)?),
            OutputKind::PoseWithCovariance => {
                ResultPublisher::PoseWithCovariance(publisher(node, topic, 10)?)
            }
            OutputKind::Text => ResultPublisher::Text(publisher(node, topic, 10)?),
            OutputKind::Markers => ResultPublisher::Markers(publisher(node, topic, 10)?),
            OutputKind::Twist => ResultPublisher::Twist(publisher(node, topic, 10)?),
        })
    }

    /// Publishes `message` (of this publisher's type; another type is an error).
    fn publish(&self, topic: &str, message: ResultMessage) -> io::Result<()> {
        match (self, message) {
            (ResultPublisher::Poses(p), ResultMessage::Poses(m)) => {
                published(topic, p.publish(Wire(m)))
            }
            (ResultPublisher::PoseWithCovariance(p), ResultMessage::PoseWithCovariance(m)) => {
                published(topic, p.publish(Wire(*m)))
            }
            (ResultPublisher::Text(p), ResultMessage::Text(m)) => {
                published(topic, p.publish(Wire(m)))
            }
            (ResultPublisher::Markers(p), ResultMessage::Markers(m)) => {
                published(topic, p.publish(Wire(m)))
            }
            (ResultPublisher::Twist(p), ResultMessage::Twist(m)) => {
                published(topic, p.publish(Wire(m)))
            }
            (_, m) => Err(io::Error::other(format!(
                "publishing on {topic}: a {} message on a publisher of another type",
                m.kind().type_name()
            ))),
        }
    }
}

/// The commands' publisher: `Twist`, or `TwistStamped` in the base's frame.
enum CmdVel {
    Plain(Publisher<Wire<TwistMsg>>),
    Stamped {
        publisher: Publisher<Wire<TwistStampedMsg>>,
        base_frame: String,
    },
}

/// The topic names of the outputs, resolved by the caller (namespace, remapping).
#[derive(Debug, Clone)]
pub struct OutputTopics {
    /// The commands; `None`: tether publishes no commands and opens no `cmd_vel`
    /// publisher (`-p publish_cmd_vel:=false`: Nav2 drives).
    pub cmd_vel: Option<String>,
    /// `Some(base_frame)`: the commands as `geometry_msgs/msg/TwistStamped` in that frame,
    /// stamped with the time of the data that made them; `None`: `Twist`.
    pub cmd_vel_stamped: Option<String>,
    /// The topics of [`crate::results::ros_outputs`], in their order (`tether/people`
    /// and the others, resolved).
    pub results: Vec<String>,
    /// `tether/target_pose`: the target as `geometry_msgs/msg/PoseStamped`.
    pub target_pose: String,
    /// `/tf`, where the target's frame goes.
    pub tf: String,
    /// The target's frame on `/tf`, a child of the fixed frame (`target` by default).
    pub target_frame: String,
}

impl RosOutputs {
    /// The publishers; positions are stamped in `frame` (the fixed frame).
    pub fn new(node: &mut RosNode, topics: &OutputTopics, frame: &str) -> Result<Self, Ros2Error> {
        let mut results = Vec::new();
        for (output, topic) in ros_outputs().zip(&topics.results) {
            results.push((output, ResultPublisher::new(node, topic, output.kind)?));
        }
        Ok(RosOutputs {
            name: topics
                .cmd_vel
                .clone()
                .unwrap_or_else(|| topics.target_pose.clone()),
            frame: frame.to_owned(),
            cmd_vel: match (&topics.cmd_vel, &topics.cmd_vel_stamped) {
                (None, _) => None,
                (Some(topic), None) => Some(CmdVel::Plain(publisher(node, topic, 10)?)),
                (Some(topic), Some(base_frame)) => Some(CmdVel::Stamped {
                    publisher: publisher(node, topic, 10)?,
                    base_frame: base_frame.clone(),
                }),
            },
            results,
            target_pose: publisher(node, &topics.target_pose, 10)?,
            // `/tf`'s depth, as tf2's broadcasters use (design 12).
            tf: publisher(node, &topics.tf, 100)?,
            target_frame: topics.target_frame.clone(),
            heading: WalkingHeading::default(),
        })
    }
}

fn published<E: std::fmt::Debug>(topic: &str, result: Result<(), E>) -> io::Result<()> {
    result.map_err(|e| io::Error::other(format!("publishing on {topic}: {e:?}")))
}

/// The target's heading for Nav2: the direction it walks, from its velocity estimate,
/// held while it (nearly) stands, since a standing person's velocity points anywhere.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct WalkingHeading {
    /// The last heading taken from a walk, rad in the fixed frame.
    held_rad: Option<f64>,
}

impl WalkingHeading {
    /// Below this speed the heading is held, m/s: a standing person's velocity estimate
    /// wanders by a few cm/s to a tenth of a m/s; a slow walk is 0.5 m/s.
    pub const MIN_SPEED_MPS: f64 = 0.25;

    /// The heading at a tick whose target moves at `velocity` (fixed frame, m/s): its
    /// direction when at least [`Self::MIN_SPEED_MPS`], else the last such heading;
    /// before any, the direction of what velocity there is (0 rad when none).
    pub fn update(&mut self, velocity: Option<Vector2<World>>) -> f64 {
        let v = velocity.filter(|v| v.x.is_finite() && v.y.is_finite());
        match (v, self.held_rad) {
            (Some(v), _) if v.x.hypot(v.y) >= Self::MIN_SPEED_MPS => {
                let heading = v.y.atan2(v.x);
                self.held_rad = Some(heading);
                heading
            }
            (_, Some(held)) => held,
            (Some(v), None) if v.x != 0.0 || v.y != 0.0 => v.y.atan2(v.x),
            _ => 0.0,
        }
    }
}

impl RosOutputs {
    /// The target on `tether/target_pose` and `/tf` while it is locked, nothing
    /// otherwise: its estimate in the fixed frame, turned to where it walks. The held
    /// heading is forgotten when nobody is the target any more (searching): the next
    /// lock may be somebody else.
    fn publish_target(&mut self, tick: &Tick) -> io::Result<()> {
        if matches!(tick.target.state, tether_fusion::TargetState::Searching) {
            self.heading = WalkingHeading::default();
        }
        let (Some(_), Some(estimate)) = (tick.target.state.locked_track(), tick.target.estimate)
        else {
            return Ok(());
        };
        let heading_rad = self.heading.update(tick.target.velocity);
        let pose = Pose3::planar(estimate.mean.x, estimate.mean.y, heading_rad);
        let header = Header::new(tick.stamp, self.frame.as_str());
        let transform = TransformStampedMsg {
            header: header.clone(),
            child_frame_id: self.target_frame.clone(),
            transform: pose,
        };
        published(
            "target_pose",
            self.target_pose
                .publish(Wire(PoseStampedMsg { header, pose })),
        )?;
        published(
            "tf",
            self.tf.publish(Wire(TfMessage {
                transforms: vec![transform],
            })),
        )
    }
}

impl CommandSink for RosOutputs {
    fn name(&self) -> &str {
        &self.name
    }

    fn tick(&mut self, tick: &Tick) -> io::Result<()> {
        for (output, publisher) in &self.results {
            if let Some(message) = (output.message)(tick, &self.frame) {
                publisher.publish(output.topic, message)?;
            }
        }
        self.publish_target(tick)
    }

    fn send(&mut self, command: &CommandLine) -> io::Result<()> {
        let twist = TwistMsg::unicycle(command.v_mps, command.w_radps);
        match &self.cmd_vel {
            None => Ok(()),
            Some(CmdVel::Plain(p)) => published(&self.name, p.publish(Wire(twist))),
            Some(CmdVel::Stamped {
                publisher,
                base_frame,
            }) => {
                let stamp = tether_core::Stamp::from_ns(command.stamp_ns);
                let msg = TwistStampedMsg {
                    header: Header::new(stamp, base_frame.as_str()),
                    twist,
                };
                published(&self.name, publisher.publish(Wire(msg)))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f64, y: f64) -> Option<Vector2<World>> {
        Some(Vector2::new(x, y))
    }

    #[test]
    fn the_heading_is_the_walk_s_and_held_while_standing() {
        let mut h = WalkingHeading::default();
        // Nothing known yet: the direction of what velocity there is, or 0.
        assert_eq!(h.update(None), 0.0);
        assert!((h.update(v(0.0, 0.05)) - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        // A walk sets it.
        assert!((h.update(v(1.0, 1.0)) - std::f64::consts::FRAC_PI_4).abs() < 1e-12);
        // Standing (a wandering estimate, none, or not finite): held.
        assert!((h.update(v(-0.1, 0.05)) - std::f64::consts::FRAC_PI_4).abs() < 1e-12);
        assert!((h.update(None) - std::f64::consts::FRAC_PI_4).abs() < 1e-12);
        assert!((h.update(v(f64::NAN, 2.0)) - std::f64::consts::FRAC_PI_4).abs() < 1e-12);
        // Walking again, the other way.
        assert!((h.update(v(-0.3, 0.0)) - std::f64::consts::PI).abs() < 1e-12);
    }
}
