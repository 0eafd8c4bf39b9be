//! The MCAP recording of a live run, a sink beside the loop's outputs: what the sensors
//! sent and what the pipeline made of it, readable by `tether replay`, Foxglove and any
//! ROS 2 tool.

use std::path::{Path, PathBuf};

use tether_control::Twist;
use tether_core::{LaserScan, Pose2, Robot, Stamp, World};
use tether_io::mcap::{CompressedImageMsg, Header, LaserScanMsg, McapError, OdometryMsg, TwistMsg};
use tether_pipeline::Tick;

use crate::results::ResultWriter;
use crate::sources::frames::EncodedFrame;

/// Where a live run records its camera frames (`sensor_msgs/msg/CompressedImage`):
/// `tether replay run.mcap --image-topic /camera/image_raw/compressed` runs the
/// cascade on them again.
pub const CAMERA_TOPIC: &str = "/camera/image_raw/compressed";

/// The MCAP recording of a live run: the scans (`/scan`), the camera frames
/// ([`CAMERA_TOPIC`]), the dead-reckoned odometry (`/odom`, `odom` -> `base_link`) and
/// the pipeline's ticks (see [`ResultWriter`]).
///
/// It writes its messages unchunked through a buffered file flushed at least once a
/// second of log time ([`tether_io::mcap::McapWriter::streaming`]): a run that is
/// killed leaves a recording readable up to its last second or so, and a run of hours
/// keeps no index that grows in memory.
pub struct Recorder<W: std::io::Write + std::io::Seek> {
    writer: ResultWriter<W>,
}

impl Recorder<std::io::BufWriter<std::fs::File>> {
    /// A recording at `path`.
    pub fn create(path: &Path) -> Result<Self, McapError> {
        Ok(Recorder {
            writer: ResultWriter::create_streaming(path, "odom")?,
        })
    }
}

impl<W: std::io::Write + std::io::Seek> Recorder<W> {
    /// A recording into `writer` (its frame should be `odom`).
    pub fn new(writer: ResultWriter<W>) -> Self {
        Recorder { writer }
    }

    pub(crate) fn scan(&mut self, scan: &LaserScan, period_s: f64) -> Result<(), McapError> {
        let beams = scan.len().max(1) as f64;
        let msg = LaserScanMsg::new(scan.clone(), period_s / beams, period_s);
        self.writer.mcap().write("/scan", scan.stamp, &msg)
    }

    pub(crate) fn tick(
        &mut self,
        tick: &Tick,
        pose: Pose2<World, Robot>,
        moving: Twist,
    ) -> Result<(), McapError> {
        let odom = OdometryMsg::planar(
            Header::new(tick.stamp, self.writer.frame()),
            "base_link",
            pose,
            moving.v_mps,
            moving.w_radps,
        );
        self.writer.mcap().write("/odom", tick.stamp, &odom)?;
        self.writer.write_tick(tick)
    }

    /// A camera frame as it arrived, on [`CAMERA_TOPIC`] (frame `camera`).
    pub(crate) fn camera(&mut self, stamp: Stamp, frame: EncodedFrame) -> Result<(), McapError> {
        let msg = CompressedImageMsg::new(Header::new(stamp, "camera"), frame.format, frame.bytes);
        self.writer.mcap().write(CAMERA_TOPIC, stamp, &msg)
    }

    pub(crate) fn final_stop(&mut self, stamp: Stamp) -> Result<(), McapError> {
        let cmd = TwistMsg::unicycle(0.0, 0.0);
        self.writer.mcap().write("/tether/cmd_vel", stamp, &cmd)
    }

    /// Writes the summary and closes the file.
    pub fn finish(self) -> Result<W, McapError> {
        self.writer.finish()
    }
}

/// Where this run records: `path`, or when an earlier run's recording is there, the
/// first free `NAME-2.mcap`, `NAME-3.mcap`... beside it (said in the log): a new run
/// never overwrites an old one.
pub fn fresh_recording_path(path: &Path) -> PathBuf {
    if !path.exists() {
        return path.to_path_buf();
    }
    let stem = path
        .file_stem()
        .map_or_else(|| "run".into(), |s| s.to_string_lossy().into_owned());
    let ext = path
        .extension()
        .map(|e| format!(".{}", e.to_string_lossy()))
        .unwrap_or_default();
    let fresh = (2u32..)
        .map(|n| path.with_file_name(format!("{stem}-{n}{ext}")))
        .find(|p| !p.exists())
        .unwrap_or_else(|| path.to_path_buf());
    tracing::warn!(
        "{} holds an earlier run's recording; this run records to {}",
        path.display(),
        fresh.display()
    );
    fresh
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, reason = "tests fail loudly")]

    use super::*;

    #[test]
    fn a_new_run_never_records_over_an_old_one() {
        let dir = std::env::temp_dir().join(format!("tether-record-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("run.mcap");
        assert_eq!(fresh_recording_path(&path), path);
        std::fs::write(&path, b"earlier").unwrap();
        assert_eq!(fresh_recording_path(&path), dir.join("run-2.mcap"));
        std::fs::write(dir.join("run-2.mcap"), b"earlier too").unwrap();
        assert_eq!(fresh_recording_path(&path), dir.join("run-3.mcap"));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
