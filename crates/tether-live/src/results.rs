//! What tether saw and commanded, as ROS 2 messages in an MCAP file: written by `tether
//! replay` and `tether sim --record`, readable by Foxglove and any ROS 2 tool.
//!
//! | topic | type | when |
//! |---|---|---|
//! | `/tether/people` | `geometry_msgs/msg/PoseArray` | every tick: the confirmed tracks |
//! | `/tether/laser_people` | `geometry_msgs/msg/PoseArray` | every scan: its person observations |
//! | `/tether/vision_people` | `geometry_msgs/msg/PoseArray` | every camera frame: its person observations |
//! | `/tether/target` | `geometry_msgs/msg/PoseWithCovarianceStamped` | every tick while locked (heading: walking direction, variance pi^2) |
//! | `/tether/cmd_vel` | `geometry_msgs/msg/Twist` | every tick: the command (`linear.x`, `angular.z`) |
//! | `/tether/markers` | `visualization_msgs/msg/MarkerArray` | every tick: tracks, their ellipses, the target and the observations for RViz and Foxglove ([`crate::markers`]) |
//! | `/tether/target_state` | `std_msgs/msg/String` | every tick: the target's state as JSON, e.g. `{"state":"lost","track":3,"reason":"unseen","refused":[{"track":5,"why":"not_walking"},{"track":7,"why":"somebody_else","because":"seen_beside"}]}`, with `"transition":"lost"` at the tick the lock moved |
//!
//! Positions are in the world (odometry) frame, named by the writer's `frame`. The list
//! is [`OUTPUTS`]: one entry per topic, which the results files and `tether ros2` both
//! take (a test holds this table, the design document's and `docs/ros2.md`'s to it).

use std::path::Path;

use tether_core::Stamp;
use tether_msgs::{
    Header, MarkerArrayMsg, Pose3, PoseArrayMsg, PoseWithCovarianceStampedMsg, Ros2Message,
    StringMsg, TwistMsg,
};
use tether_pipeline::{Tick, TickInput};
use tether_recording::mcap::{McapError, McapWriter};

/// The target's state at a tick, as `track`'s JSON lines and `/tether/target_state`
/// carry it.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct TargetStateLine {
    /// `searching`, `locked` or `lost`.
    pub state: &'static str,
    /// The followed track (locked) or the one that was followed (lost).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub track: Option<u64>,
    /// Why it is lost.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reason: Option<&'static str>,
    /// The transition the lock made at this tick (`chosen`, `coasting_handover`,
    /// `encounter_handover`, `led_off`, `lost`, `gave_up`, `back`, `reacquired`,
    /// `restarted`; design 5.6), if it made one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub transition: Option<&'static str>,
    /// Tracks refused as the lost target at this tick, and why.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub refused: Vec<RefusedLine>,
}

/// One refused candidate.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RefusedLine {
    /// The track.
    pub track: u64,
    /// Why it is not the target.
    pub why: &'static str,
    /// For `somebody_else`, why it is somebody else (`seen_beside`, `there_before`,
    /// `born_apart`, `born_elsewhere`, `led_off`; design 11.4).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub because: Option<&'static str>,
}

impl TargetStateLine {
    /// The state of `tick`.
    pub fn of(tick: &Tick) -> Self {
        use tether_fusion::TargetState;
        let state = tick.target.state;
        TargetStateLine {
            state: state.name(),
            track: match state {
                TargetState::Locked { track } | TargetState::Lost { track, .. } => Some(track),
                TargetState::Searching => None,
            },
            reason: state.loss_reason().map(|r| r.name()),
            transition: tick.transition.map(|t| t.name()),
            refused: tick
                .refusals
                .iter()
                .map(|&(track, r)| RefusedLine {
                    track,
                    why: r.name(),
                    because: tick
                        .somebody_else
                        .iter()
                        .find(|(t, _)| *t == track)
                        .map(|(_, b)| b.name()),
                })
                .collect(),
        }
    }
}

/// [`TargetStateLine::of`] as JSON.
pub fn target_state_json(tick: &Tick) -> String {
    serde_json::to_string(&TargetStateLine::of(tick)).unwrap_or_default()
}

/// A PoseArray of points on the ground in `frame`.
fn poses(stamp: Stamp, frame: &str, points: impl Iterator<Item = (f64, f64)>) -> PoseArrayMsg {
    PoseArrayMsg {
        header: Header::new(stamp, frame),
        poses: points.map(|(x, y)| Pose3::planar(x, y, 0.0)).collect(),
    }
}

/// One message of a tick, whichever its type.
#[derive(Debug, Clone)]
pub enum ResultMessage {
    /// `geometry_msgs/msg/PoseArray`.
    Poses(PoseArrayMsg),
    /// `geometry_msgs/msg/PoseWithCovarianceStamped` (boxed: its covariance is 36
    /// numbers).
    PoseWithCovariance(Box<PoseWithCovarianceStampedMsg>),
    /// `std_msgs/msg/String`.
    Text(StringMsg),
    /// `visualization_msgs/msg/MarkerArray`.
    Markers(MarkerArrayMsg),
    /// `geometry_msgs/msg/Twist`.
    Twist(TwistMsg),
}

/// The message types an [`Output`] can carry ([`ResultMessage`]'s variants).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutputKind {
    /// [`ResultMessage::Poses`].
    Poses,
    /// [`ResultMessage::PoseWithCovariance`].
    PoseWithCovariance,
    /// [`ResultMessage::Text`].
    Text,
    /// [`ResultMessage::Markers`].
    Markers,
    /// [`ResultMessage::Twist`].
    Twist,
}

impl OutputKind {
    /// The ROS 2 type name.
    pub fn type_name(self) -> &'static str {
        match self {
            OutputKind::Poses => PoseArrayMsg::TYPE,
            OutputKind::PoseWithCovariance => PoseWithCovarianceStampedMsg::TYPE,
            OutputKind::Text => StringMsg::TYPE,
            OutputKind::Markers => MarkerArrayMsg::TYPE,
            OutputKind::Twist => TwistMsg::TYPE,
        }
    }
}

impl ResultMessage {
    /// Its kind.
    pub fn kind(&self) -> OutputKind {
        match self {
            ResultMessage::Poses(_) => OutputKind::Poses,
            ResultMessage::PoseWithCovariance(_) => OutputKind::PoseWithCovariance,
            ResultMessage::Text(_) => OutputKind::Text,
            ResultMessage::Markers(_) => OutputKind::Markers,
            ResultMessage::Twist(_) => OutputKind::Twist,
        }
    }

    /// Writes it on `topic` at `stamp`.
    pub fn write<W: std::io::Write + std::io::Seek>(
        &self,
        writer: &mut McapWriter<W>,
        topic: &str,
        stamp: Stamp,
    ) -> Result<(), McapError> {
        match self {
            ResultMessage::Poses(m) => writer.write(topic, stamp, m),
            ResultMessage::PoseWithCovariance(m) => writer.write(topic, stamp, m.as_ref()),
            ResultMessage::Text(m) => writer.write(topic, stamp, m),
            ResultMessage::Markers(m) => writer.write(topic, stamp, m),
            ResultMessage::Twist(m) => writer.write(topic, stamp, m),
        }
    }
}

/// One output of the pipeline's ticks: a topic of the MCAP results and, when
/// [`Output::on_ros`], of `tether ros2` (under its namespace). Adding a topic is adding
/// an entry to [`OUTPUTS`]: the results files, the ROS 2 node and its announcement all
/// take the list.
#[derive(Debug, Clone, Copy)]
pub struct Output {
    /// The topic, e.g. `/tether/people` (`tether ros2` publishes it relative to its
    /// namespace, `tether/people`).
    pub topic: &'static str,
    /// Its message type.
    pub kind: OutputKind,
    /// When it is sent and what it holds.
    pub when: &'static str,
    /// The message of a tick, positions in `frame`; `None` when there is none at this
    /// tick.
    pub message: fn(&Tick, &str) -> Option<ResultMessage>,
    /// Also published by `tether ros2` (the command is not: the node's `cmd_vel` is
    /// the robot's, with its guard).
    pub on_ros: bool,
}

/// Every output of a tick, in the order they are written and published.
pub const OUTPUTS: &[Output] = &[
    Output {
        topic: "/tether/people",
        kind: OutputKind::Poses,
        when: "every tick: the confirmed tracks",
        message: |tick, frame| Some(ResultMessage::Poses(people(tick, frame))),
        on_ros: true,
    },
    Output {
        topic: "/tether/laser_people",
        kind: OutputKind::Poses,
        when: "every scan: its person observations",
        message: |tick, frame| {
            (tick.input == TickInput::Scan)
                .then(|| ResultMessage::Poses(observed(tick, &tick.laser_people, frame)))
        },
        on_ros: true,
    },
    Output {
        topic: "/tether/vision_people",
        kind: OutputKind::Poses,
        when: "every camera frame: its person observations",
        message: |tick, frame| {
            (tick.input == TickInput::Camera)
                .then(|| ResultMessage::Poses(observed(tick, &tick.vision_people, frame)))
        },
        on_ros: true,
    },
    Output {
        topic: "/tether/target",
        kind: OutputKind::PoseWithCovariance,
        when: "every tick while locked (heading: walking direction, variance pi^2)",
        message: |tick, frame| {
            target(tick, frame).map(|m| ResultMessage::PoseWithCovariance(Box::new(m)))
        },
        on_ros: true,
    },
    Output {
        topic: "/tether/target_state",
        kind: OutputKind::Text,
        when: "every tick: the target's state as JSON",
        message: |tick, _| {
            Some(ResultMessage::Text(StringMsg {
                data: target_state_json(tick),
            }))
        },
        on_ros: true,
    },
    Output {
        topic: "/tether/markers",
        kind: OutputKind::Markers,
        when: "every tick: tracks, their ellipses, the target and the observations",
        message: |tick, frame| {
            Some(ResultMessage::Markers(crate::markers::tick_markers(
                tick, frame,
            )))
        },
        on_ros: true,
    },
    Output {
        topic: "/tether/cmd_vel",
        kind: OutputKind::Twist,
        when: "every tick: the command (`linear.x`, `angular.z`)",
        message: |tick, _| {
            Some(ResultMessage::Twist(TwistMsg::unicycle(
                tick.command.v_mps,
                tick.command.w_radps,
            )))
        },
        on_ros: false,
    },
];

/// The outputs `tether ros2` publishes ([`Output::on_ros`]).
pub fn ros_outputs() -> impl Iterator<Item = &'static Output> {
    OUTPUTS.iter().filter(|o| o.on_ros)
}

/// `/tether/people`: the confirmed tracks.
fn people(tick: &Tick, frame: &str) -> PoseArrayMsg {
    poses(
        tick.stamp,
        frame,
        tick.tracks
            .iter()
            .filter(|t| t.confirmed)
            .map(|t| (t.position.mean.x, t.position.mean.y)),
    )
}

/// The person observations of a scan or a camera frame.
fn observed(
    tick: &Tick,
    observed: &[tether_core::Gaussian2<tether_core::World>],
    frame: &str,
) -> PoseArrayMsg {
    poses(
        tick.stamp,
        frame,
        observed.iter().map(|g| (g.mean.x, g.mean.y)),
    )
}

/// `/tether/target` while locked: the estimate, heading the walking direction.
fn target(tick: &Tick, frame: &str) -> Option<PoseWithCovarianceStampedMsg> {
    match (tick.target.state.locked_track(), tick.target.estimate) {
        (Some(_), Some(estimate)) => {
            let heading = tick.target.velocity.map_or(0.0, |v| v.y.atan2(v.x));
            Some(PoseWithCovarianceStampedMsg::from_gaussian(
                Header::new(tick.stamp, frame),
                &estimate,
                heading,
                std::f64::consts::PI.powi(2),
            ))
        }
        _ => None,
    }
}

/// Writes pipeline ticks as ROS 2 messages.
pub struct ResultWriter<W: std::io::Write + std::io::Seek> {
    writer: McapWriter<W>,
    frame: String,
}

impl ResultWriter<std::io::BufWriter<std::fs::File>> {
    /// A results file at `path`; positions are labelled with `frame` (e.g. `odom`).
    pub fn create(path: &Path, frame: &str) -> Result<Self, McapError> {
        Ok(ResultWriter {
            writer: McapWriter::create(path)?,
            frame: frame.to_owned(),
        })
    }

    /// [`ResultWriter::create`] for a live recording of unbounded length: no chunks,
    /// flushed every second ([`McapWriter::streaming`]).
    pub fn create_streaming(path: &Path, frame: &str) -> Result<Self, McapError> {
        Ok(ResultWriter {
            writer: McapWriter::create_streaming(path)?,
            frame: frame.to_owned(),
        })
    }
}

impl<W: std::io::Write + std::io::Seek> ResultWriter<W> {
    /// Results into `w` (a file, a `Cursor`...); positions are labelled with `frame`.
    pub fn new(w: W, frame: &str) -> Result<Self, McapError> {
        Ok(ResultWriter {
            writer: McapWriter::new(w)?,
            frame: frame.to_owned(),
        })
    }

    /// [`ResultWriter::new`] unchunked ([`McapWriter::streaming`]): every message goes
    /// through to `w` as it is written.
    pub fn streaming(w: W, frame: &str) -> Result<Self, McapError> {
        Ok(ResultWriter {
            writer: McapWriter::streaming(w)?,
            frame: frame.to_owned(),
        })
    }

    /// The underlying writer, to add other topics (sensor data, ground truth).
    pub fn mcap(&mut self) -> &mut McapWriter<W> {
        &mut self.writer
    }

    /// The frame name of the positions.
    pub fn frame(&self) -> &str {
        &self.frame
    }

    /// A PoseArray of points on the ground, in the writer's frame.
    pub fn poses(&self, stamp: Stamp, points: impl Iterator<Item = (f64, f64)>) -> PoseArrayMsg {
        poses(stamp, &self.frame, points)
    }

    /// Writes one tick's outputs ([`OUTPUTS`]): tracks, observations, target, state,
    /// markers and command.
    pub fn write_tick(&mut self, tick: &Tick) -> Result<(), McapError> {
        for output in OUTPUTS {
            if let Some(message) = (output.message)(tick, &self.frame) {
                message.write(&mut self.writer, output.topic, tick.stamp)?;
            }
        }
        Ok(())
    }

    /// Writes the summary and closes the file.
    pub fn finish(self) -> Result<W, McapError> {
        self.writer.finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every output is in the tables that document it: this module's, the design
    /// document's (section 9) and, for those `tether ros2` publishes, `docs/ros2.md`'s.
    #[test]
    fn every_output_is_in_the_documents_tables() {
        let here = include_str!("results.rs");
        let design = include_str!("../../../docs/design.md");
        let ros2 = include_str!("../../../docs/ros2.md");
        for o in OUTPUTS {
            let short = o.kind.type_name().rsplit('/').next().unwrap_or_default();
            let row = |doc: &str, topic: &str| {
                doc.lines().any(|l| {
                    let l = l.trim_start_matches("//! ");
                    l.starts_with('|') && l.contains(&format!("`{topic}`")) && l.contains(short)
                })
            };
            assert!(
                row(here, o.topic),
                "{} is not in results.rs's table",
                o.topic
            );
            assert!(
                row(design, o.topic),
                "{} is not in design.md's table",
                o.topic
            );
            if o.on_ros {
                let relative = o.topic.trim_start_matches('/');
                assert!(
                    row(ros2, relative),
                    "{relative} is not in docs/ros2.md's table"
                );
            }
        }
    }

    /// The messages of a tick come out in the order of [`OUTPUTS`], each of its kind.
    #[test]
    fn each_output_makes_a_message_of_its_kind() {
        let mut pipeline = tether_pipeline::Pipeline::new(Default::default(), None).unwrap();
        let tick = pipeline.on_timer(Stamp::from_ns(1), tether_core::Pose2::IDENTITY);
        for o in OUTPUTS {
            if let Some(m) = (o.message)(&tick, "odom") {
                assert_eq!(m.kind(), o.kind, "{}", o.topic);
            }
        }
    }
}
