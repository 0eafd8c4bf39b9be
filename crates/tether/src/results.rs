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
//!
//! Positions are in the world (odometry) frame, named by the writer's `frame`.

use std::path::Path;

use tether_core::Stamp;
use tether_io::mcap::{
    Header, McapError, McapWriter, Pose3, PoseArrayMsg, PoseWithCovarianceStampedMsg, TwistMsg,
};
use tether_pipeline::{Tick, TickInput};

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
        let cmd = TwistMsg::unicycle(tick.command.v_mps, tick.command.w_radps);
        self.writer.write("/tether/cmd_vel", stamp, &cmd)
    }

    /// Writes the summary and closes the file.
    pub fn finish(self) -> Result<W, McapError> {
        self.writer.finish()
    }
}
