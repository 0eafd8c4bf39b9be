//! The ROS 2 topics as the loop's sinks: the commands on `cmd_vel` (`Twist`, or
//! `TwistStamped` in the base's frame) and the results on `tether/...`, as the MCAP
//! results name them ([`crate::results`]): an output like any other
//! ([`CommandSink`]), so that `run` and `ros2` share one loop and one safety path.

use std::io;

use ros2_client::dds::Publisher;
use tether_msgs::{
    Header, MarkerArrayMsg, PoseArrayMsg, PoseWithCovarianceStampedMsg, Ros2Message, StringMsg,
    TwistMsg, TwistStampedMsg,
};
use tether_pipeline::Tick;
use tether_ros2::{Ros2Error, RosNode, Wire, qos};

use crate::base::{CommandLine, CommandSink};
use crate::results::TickMessages;

/// A publisher of `M`.
fn publisher<M: Ros2Message>(
    node: &mut RosNode,
    topic: &str,
    depth: usize,
) -> Result<Publisher<Wire<M>>, Ros2Error> {
    node.publisher::<M>(topic, qos::reliable(depth))
}

/// The commands on `/cmd_vel` and the results on `/tether/...`, as the MCAP results
/// name them ([`crate::results`]).
pub struct RosOutputs {
    name: String,
    frame: String,
    cmd_vel: CmdVel,
    people: Publisher<Wire<PoseArrayMsg>>,
    laser_people: Publisher<Wire<PoseArrayMsg>>,
    vision_people: Publisher<Wire<PoseArrayMsg>>,
    target: Publisher<Wire<PoseWithCovarianceStampedMsg>>,
    target_state: Publisher<Wire<StringMsg>>,
    markers: Publisher<Wire<MarkerArrayMsg>>,
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
    /// The commands.
    pub cmd_vel: String,
    /// `Some(base_frame)`: the commands as `geometry_msgs/msg/TwistStamped` in that frame,
    /// stamped with the time of the data that made them; `None`: `Twist`.
    pub cmd_vel_stamped: Option<String>,
    /// `/tether/people` and the others, in the order of [`TickMessages`]'s constants:
    /// people, laser people, vision people, target, target state, markers.
    pub results: [String; 6],
}

impl RosOutputs {
    /// The publishers; positions are stamped in `frame` (the fixed frame).
    pub fn new(node: &mut RosNode, topics: &OutputTopics, frame: &str) -> Result<Self, Ros2Error> {
        let [people, laser, vision, target, state, markers] = &topics.results;
        Ok(RosOutputs {
            name: topics.cmd_vel.clone(),
            frame: frame.to_owned(),
            cmd_vel: match &topics.cmd_vel_stamped {
                None => CmdVel::Plain(publisher(node, &topics.cmd_vel, 10)?),
                Some(base_frame) => CmdVel::Stamped {
                    publisher: publisher(node, &topics.cmd_vel, 10)?,
                    base_frame: base_frame.clone(),
                },
            },
            people: publisher(node, people, 10)?,
            laser_people: publisher(node, laser, 10)?,
            vision_people: publisher(node, vision, 10)?,
            target: publisher(node, target, 10)?,
            target_state: publisher(node, state, 10)?,
            markers: publisher(node, markers, 10)?,
        })
    }
}

fn published<E: std::fmt::Debug>(topic: &str, result: Result<(), E>) -> io::Result<()> {
    result.map_err(|e| io::Error::other(format!("publishing on {topic}: {e:?}")))
}

impl CommandSink for RosOutputs {
    fn name(&self) -> &str {
        &self.name
    }

    fn tick(&mut self, tick: &Tick) -> io::Result<()> {
        let m = TickMessages::of(tick, &self.frame);
        published("people", self.people.publish(Wire(m.people)))?;
        if let Some((topic, observed)) = m.observed {
            let publisher = if topic == TickMessages::VISION_PEOPLE {
                &self.vision_people
            } else {
                &self.laser_people
            };
            published(topic, publisher.publish(Wire(observed)))?;
        }
        if let Some(target) = m.target {
            published("target", self.target.publish(Wire(target)))?;
        }
        published(
            "target_state",
            self.target_state.publish(Wire(m.target_state)),
        )?;
        published("markers", self.markers.publish(Wire(m.markers)))
    }

    fn send(&mut self, command: &CommandLine) -> io::Result<()> {
        let twist = TwistMsg::unicycle(command.v_mps, command.w_radps);
        match &self.cmd_vel {
            CmdVel::Plain(p) => published(&self.name, p.publish(Wire(twist))),
            CmdVel::Stamped {
                publisher,
                base_frame,
            } => {
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
