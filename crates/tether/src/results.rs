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
//! | `/tether/target_state` | `std_msgs/msg/String` | every tick: the target's state as JSON, e.g. `{"state":"lost","track":3,"reason":"unseen","refused":[{"track":5,"why":"not_walking"}]}` |
//!
//! Positions are in the world (odometry) frame, named by the writer's `frame`.

use std::path::Path;

use tether_core::Stamp;
use tether_io::mcap::{
    Header, McapError, McapWriter, Pose3, PoseArrayMsg, PoseWithCovarianceStampedMsg, StringMsg,
    TwistMsg,
};
use tether_pipeline::{Tick, TickInput};

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
            refused: tick
                .refusals
                .iter()
                .map(|&(track, r)| RefusedLine {
                    track,
                    why: r.name(),
                })
                .collect(),
        }
    }
}

/// [`TargetStateLine::of`] as JSON.
pub fn target_state_json(tick: &Tick) -> String {
    serde_json::to_string(&TargetStateLine::of(tick)).unwrap_or_default()
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
}

impl<W: std::io::Write + std::io::Seek> ResultWriter<W> {
    /// Results into `w` (a file, a `Cursor`...); positions are labelled with `frame`.
    pub fn new(w: W, frame: &str) -> Result<Self, McapError> {
        Ok(ResultWriter {
            writer: McapWriter::new(w)?,
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
        PoseArrayMsg {
            header: Header::new(stamp, self.frame.clone()),
            poses: points.map(|(x, y)| Pose3::planar(x, y, 0.0)).collect(),
        }
    }

    /// Writes one tick's tracks, observations, target and command.
    pub fn write_tick(&mut self, tick: &Tick) -> Result<(), McapError> {
        let stamp = tick.stamp;
        let people = self.poses(
            stamp,
            tick.tracks
                .iter()
                .filter(|t| t.confirmed)
                .map(|t| (t.position.mean.x, t.position.mean.y)),
        );
        self.writer.write("/tether/people", stamp, &people)?;
        let observed = match tick.input {
            TickInput::Camera => Some(("/tether/vision_people", &tick.vision_people)),
            TickInput::Scan => Some(("/tether/laser_people", &tick.laser_people)),
            _ => None,
        };
        if let Some((topic, observed)) = observed {
            let msg = self.poses(stamp, observed.iter().map(|g| (g.mean.x, g.mean.y)));
            self.writer.write(topic, stamp, &msg)?;
        }
        if let (Some(_), Some(estimate)) = (tick.target.state.locked_track(), tick.target.estimate)
        {
            let heading = tick.target.velocity.map_or(0.0, |v| v.y.atan2(v.x));
            let msg = PoseWithCovarianceStampedMsg::from_gaussian(
                Header::new(stamp, self.frame.clone()),
                &estimate,
                heading,
                std::f64::consts::PI.powi(2),
            );
            self.writer.write("/tether/target", stamp, &msg)?;
        }
        let state = StringMsg {
            data: target_state_json(tick),
        };
        self.writer.write("/tether/target_state", stamp, &state)?;
        let cmd = TwistMsg::unicycle(tick.command.v_mps, tick.command.w_radps);
        self.writer.write("/tether/cmd_vel", stamp, &cmd)
    }

    /// Writes the summary and closes the file.
    pub fn finish(self) -> Result<W, McapError> {
        self.writer.finish()
    }
}
