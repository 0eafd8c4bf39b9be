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
//! Positions are in the world (odometry) frame, named by the writer's `frame`.

use std::path::Path;

use tether_core::Stamp;
use tether_msgs::{
    Header, MarkerArrayMsg, Pose3, PoseArrayMsg, PoseWithCovarianceStampedMsg, StringMsg, TwistMsg,
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

/// One tick as the messages of the table above: what the MCAP results hold and what
/// `tether ros2` publishes.
#[derive(Debug, Clone)]
pub struct TickMessages {
    /// `/tether/people`: the confirmed tracks.
    pub people: PoseArrayMsg,
    /// `/tether/laser_people` or `/tether/vision_people` (the topic with it), on scans
    /// and camera frames.
    pub observed: Option<(&'static str, PoseArrayMsg)>,
    /// `/tether/target`, while locked.
    pub target: Option<PoseWithCovarianceStampedMsg>,
    /// `/tether/target_state`.
    pub target_state: StringMsg,
    /// `/tether/markers`.
    pub markers: MarkerArrayMsg,
    /// The command.
    pub cmd_vel: TwistMsg,
}

impl TickMessages {
    /// The tracks' topic.
    pub const PEOPLE: &'static str = "/tether/people";
    /// The laser observations' topic.
    pub const LASER_PEOPLE: &'static str = "/tether/laser_people";
    /// The camera observations' topic.
    pub const VISION_PEOPLE: &'static str = "/tether/vision_people";
    /// The target's topic.
    pub const TARGET: &'static str = "/tether/target";
    /// The target state's topic.
    pub const TARGET_STATE: &'static str = "/tether/target_state";
    /// The markers' topic.
    pub const MARKERS: &'static str = "/tether/markers";

    /// The messages of `tick`, positions in `frame`.
    pub fn of(tick: &Tick, frame: &str) -> TickMessages {
        let stamp = tick.stamp;
        let people = poses(
            stamp,
            frame,
            tick.tracks
                .iter()
                .filter(|t| t.confirmed)
                .map(|t| (t.position.mean.x, t.position.mean.y)),
        );
        let observed = match tick.input {
            TickInput::Camera => Some((Self::VISION_PEOPLE, &tick.vision_people)),
            TickInput::Scan => Some((Self::LASER_PEOPLE, &tick.laser_people)),
            _ => None,
        }
        .map(|(topic, observed)| {
            let points = observed.iter().map(|g| (g.mean.x, g.mean.y));
            (topic, poses(stamp, frame, points))
        });
        let target = match (tick.target.state.locked_track(), tick.target.estimate) {
            (Some(_), Some(estimate)) => {
                let heading = tick.target.velocity.map_or(0.0, |v| v.y.atan2(v.x));
                Some(PoseWithCovarianceStampedMsg::from_gaussian(
                    Header::new(stamp, frame),
                    &estimate,
                    heading,
                    std::f64::consts::PI.powi(2),
                ))
            }
            _ => None,
        };
        TickMessages {
            people,
            observed,
            target,
            target_state: StringMsg {
                data: target_state_json(tick),
            },
            cmd_vel: TwistMsg::unicycle(tick.command.v_mps, tick.command.w_radps),
            markers: crate::markers::tick_markers(tick, frame),
        }
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

    /// Writes one tick's tracks, observations, target and command.
    pub fn write_tick(&mut self, tick: &Tick) -> Result<(), McapError> {
        let stamp = tick.stamp;
        let m = TickMessages::of(tick, &self.frame);
        self.writer.write(TickMessages::PEOPLE, stamp, &m.people)?;
        if let Some((topic, observed)) = &m.observed {
            self.writer.write(topic, stamp, observed)?;
        }
        if let Some(target) = &m.target {
            self.writer.write(TickMessages::TARGET, stamp, target)?;
        }
        self.writer
            .write(TickMessages::TARGET_STATE, stamp, &m.target_state)?;
        self.writer
            .write(TickMessages::MARKERS, stamp, &m.markers)?;
        self.writer.write("/tether/cmd_vel", stamp, &m.cmd_vel)
    }

    /// Writes the summary and closes the file.
    pub fn finish(self) -> Result<W, McapError> {
        self.writer.finish()
    }
}
