//! The MCAP recording of a live run, a sink beside the loop's outputs: what the sensors
//! sent and what the pipeline made of it, readable by `tether replay`, Foxglove and any
//! ROS 2 tool.

use std::path::{Path, PathBuf};
use std::sync::mpsc::{Receiver, SyncSender, TrySendError, sync_channel};
use std::thread::JoinHandle;

use tether_control::Twist;
use tether_core::{LaserScan, Pose2, Robot, Stamp, World};
use tether_msgs::{CompressedImageMsg, Header, LaserScanMsg, OdometryMsg, TwistMsg};
use tether_pipeline::Tick;
use tether_recording::mcap::McapError;

use crate::results::ResultWriter;
use crate::sources::frames::EncodedFrame;

/// Where a live run records the frames of its first camera, when that names no frame of
/// its own (`sensor_msgs/msg/CompressedImage`): `tether replay run.mcap --image-topic
/// /camera/image_raw/compressed` runs the cascade on them again.
pub const CAMERA_TOPIC: &str = "/camera/image_raw/compressed";

/// Where a live run records the frames of the camera whose frames carry `frame_id`:
/// `/{frame_id}/image_raw/compressed` (so [`CAMERA_TOPIC`] for `camera`), a topic per
/// camera as a ROS 2 robot publishes them, each frame's header naming its camera.
/// Characters a ROS topic name cannot hold become `_`.
pub fn camera_topic(frame_id: &str) -> String {
    let name: String = frame_id
        .trim_matches('/')
        .chars()
        .map(
            |c| match c.is_ascii_alphanumeric() || c == '_' || c == '/' {
                true => c,
                false => '_',
            },
        )
        .collect();
    format!("/{name}/image_raw/compressed")
}

/// How many messages may wait for the recording's writer thread; past that (a disk
/// that stalls) messages are dropped and counted rather than holding up the loop.
pub const RECORDING_QUEUE: usize = 512;

/// Why the recording failed.
#[derive(Debug, thiserror::Error)]
pub enum RecordingError {
    /// Writing the MCAP file failed.
    #[error(transparent)]
    Mcap(#[from] McapError),
    /// The writer thread is not there: it could not be started, or it panicked.
    #[error("the recording's writer thread {0}")]
    NoWriter(&'static str),
}

/// One message for the writer thread.
enum Record {
    /// A scan, its period, when it arrived.
    Scan(LaserScan, f64, Stamp),
    Tick(Box<Tick>, Pose2<World, Robot>, Twist),
    /// The camera's frame, the frame's stamp, when it arrived, the frame.
    Camera(String, Stamp, Stamp, EncodedFrame),
    FinalStop(Stamp),
}

/// The MCAP recording of a live run: the scans (`/scan`), the camera frames
/// ([`CAMERA_TOPIC`]), the dead-reckoned odometry (`/odom`, `odom` -> `base_link`) and
/// the pipeline's ticks (see [`ResultWriter`]).
///
/// It writes its messages unchunked through a buffered file flushed at least once a
/// second of log time ([`tether_recording::mcap::McapWriter::streaming`]): a run that is
/// killed leaves a recording readable up to its last second or so, and a run of hours
/// keeps no index that grows in memory.
///
/// The writing happens on a thread of its own, behind a queue of [`RECORDING_QUEUE`]
/// messages: a disk that stalls (a full or slow card, a network share) never holds up
/// the loop, its commands or its stops (issue 16). When the queue is full a message is
/// dropped and counted ([`Recorder::finish`] says how many); when the writer fails, the
/// next message returns its error and the run ends as for any failed output.
pub struct Recorder<W: std::io::Write + std::io::Seek + Send + 'static> {
    queue: Option<SyncSender<Record>>,
    writer: Option<JoinHandle<Result<W, McapError>>>,
    dropped: u64,
}

impl Recorder<std::io::BufWriter<std::fs::File>> {
    /// A recording at `path`.
    pub fn create(path: &Path) -> Result<Self, McapError> {
        Ok(Recorder::new(ResultWriter::create_streaming(path, "odom")?))
    }
}

/// Writes what comes through `queue` until it closes; the first error ends it.
fn write_all<W: std::io::Write + std::io::Seek>(
    mut writer: ResultWriter<W>,
    queue: &Receiver<Record>,
) -> Result<W, McapError> {
    for record in queue {
        match record {
            Record::Scan(scan, period_s, arrived) => {
                let beams = scan.len().max(1) as f64;
                let msg = LaserScanMsg::new(scan, period_s / beams, period_s);
                writer.mcap().write("/scan", arrived, &msg)?;
            }
            Record::Tick(tick, pose, moving) => {
                let odom = OdometryMsg::planar(
                    Header::new(tick.stamp, writer.frame()),
                    "base_link",
                    pose,
                    moving.v_mps,
                    moving.w_radps,
                );
                writer.mcap().write("/odom", tick.stamp, &odom)?;
                writer.write_tick(&tick)?;
            }
            Record::Camera(frame_id, stamp, arrived, frame) => {
                let topic = camera_topic(&frame_id);
                let msg = CompressedImageMsg::new(
                    Header::new(stamp, &frame_id),
                    frame.format,
                    frame.bytes,
                );
                writer.mcap().write(&topic, arrived, &msg)?;
            }
            Record::FinalStop(stamp) => {
                let cmd = TwistMsg::unicycle(0.0, 0.0);
                writer.mcap().write("/tether/cmd_vel", stamp, &cmd)?;
            }
        }
    }
    writer.finish()
}

impl<W: std::io::Write + std::io::Seek + Send + 'static> Recorder<W> {
    /// A recording into `writer` (its frame should be `odom`), written on a thread of
    /// its own.
    pub fn new(writer: ResultWriter<W>) -> Self {
        let (queue, records) = sync_channel(RECORDING_QUEUE);
        let thread = std::thread::Builder::new()
            .name("recording".into())
            .spawn(move || write_all(writer, &records));
        match thread {
            Ok(thread) => Recorder {
                queue: Some(queue),
                writer: Some(thread),
                dropped: 0,
            },
            // No thread: every message then fails as a closed writer would.
            Err(e) => {
                tracing::error!("cannot start the recording's thread: {e}");
                Recorder {
                    queue: None,
                    writer: None,
                    dropped: 0,
                }
            }
        }
    }

    /// Hands `record` to the writer: dropped and counted when the queue is full, the
    /// writer's error when it has failed.
    fn send(&mut self, record: Record) -> Result<(), RecordingError> {
        let Some(queue) = &self.queue else {
            return Err(RecordingError::NoWriter("is not running"));
        };
        match queue.try_send(record) {
            Ok(()) => Ok(()),
            Err(TrySendError::Full(_)) => {
                self.dropped += 1;
                if self.dropped == 1 {
                    tracing::warn!(
                        "the recording falls behind (a slow or stalled disk): messages are \
                         dropped and counted until it catches up"
                    );
                }
                Ok(())
            }
            Err(TrySendError::Disconnected(_)) => {
                self.queue = None;
                match self.writer.take().map(JoinHandle::join) {
                    Some(Ok(Err(e))) => Err(e.into()),
                    Some(Ok(Ok(_))) => Err(RecordingError::NoWriter("stopped")),
                    Some(Err(_)) => Err(RecordingError::NoWriter("panicked")),
                    None => Err(RecordingError::NoWriter("is not running")),
                }
            }
        }
    }

    /// A scan as it arrived (at `arrived`, its log time; its header keeps its stamp).
    pub(crate) fn scan(
        &mut self,
        scan: &LaserScan,
        period_s: f64,
        arrived: Stamp,
    ) -> Result<(), RecordingError> {
        self.send(Record::Scan(scan.clone(), period_s, arrived))
    }

    pub(crate) fn tick(
        &mut self,
        tick: &Tick,
        pose: Pose2<World, Robot>,
        moving: Twist,
    ) -> Result<(), RecordingError> {
        self.send(Record::Tick(Box::new(tick.clone()), pose, moving))
    }

    /// A frame of the camera `frame_id` stamped `stamp` as it arrived (at `arrived`,
    /// its log time), on that camera's topic ([`camera_topic`]).
    pub(crate) fn camera(
        &mut self,
        frame_id: &str,
        stamp: Stamp,
        arrived: Stamp,
        frame: EncodedFrame,
    ) -> Result<(), RecordingError> {
        self.send(Record::Camera(frame_id.to_owned(), stamp, arrived, frame))
    }

    pub(crate) fn final_stop(&mut self, stamp: Stamp) -> Result<(), RecordingError> {
        self.send(Record::FinalStop(stamp))
    }

    /// Messages dropped so far because the writer was behind.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    /// Waits for the writer to take in what is queued, writes the summary and closes
    /// the file; says how many messages were dropped, if any.
    pub fn finish(mut self) -> Result<W, RecordingError> {
        if self.dropped > 0 {
            tracing::warn!(
                "the recording dropped {} messages while the disk was behind",
                self.dropped
            );
        }
        drop(self.queue.take());
        match self.writer.take().map(JoinHandle::join) {
            Some(Ok(result)) => Ok(result?),
            Some(Err(_)) => Err(RecordingError::NoWriter("panicked")),
            None => Err(RecordingError::NoWriter("is not running")),
        }
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
    fn each_camera_records_on_a_topic_of_its_own() {
        assert_eq!(camera_topic("camera"), CAMERA_TOPIC);
        assert_eq!(
            camera_topic("rear_camera"),
            "/rear_camera/image_raw/compressed"
        );
        assert_eq!(
            camera_topic("/robot/left cam"),
            "/robot/left_cam/image_raw/compressed"
        );
    }

    use std::io::{Cursor, Seek, SeekFrom, Write};
    use std::sync::{Arc, Condvar, Mutex};
    use std::time::Duration;

    use tether_core::Stamp;
    use tether_recording::mcap::McapFile;

    /// What the disk under a [`Disk`] does.
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    enum State {
        Writes,
        Stalls,
        Fails,
    }

    /// The shared state of a [`Disk`], to change while it is in use.
    type Control = Arc<(Mutex<State>, Condvar)>;

    /// A file on a disk that can be made to stall or to fail.
    struct Disk {
        file: Cursor<Vec<u8>>,
        control: Control,
    }

    fn disk() -> (Disk, Control) {
        let control = Arc::new((Mutex::new(State::Writes), Condvar::new()));
        let disk = Disk {
            file: Cursor::new(Vec::new()),
            control: Arc::clone(&control),
        };
        (disk, control)
    }

    fn set(control: &Control, state: State) {
        *control.0.lock().unwrap() = state;
        control.1.notify_all();
    }

    impl Write for Disk {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            let (state, changed) = &*self.control;
            let mut now = state.lock().unwrap();
            while *now == State::Stalls {
                now = changed.wait(now).unwrap();
            }
            if *now == State::Fails {
                return Err(std::io::Error::other("no space left on device"));
            }
            self.file.write(buf)
        }

        fn flush(&mut self) -> std::io::Result<()> {
            self.file.flush()
        }
    }

    impl Seek for Disk {
        fn seek(&mut self, to: SeekFrom) -> std::io::Result<u64> {
            self.file.seek(to)
        }
    }

    fn scan(k: i64) -> LaserScan {
        LaserScan::new(
            Stamp::from_ns(1_000_000_000 + k * 100_000_000),
            "laser",
            -2.0,
            0.006,
            0.02,
            5.6,
            vec![1.5; 682],
        )
        .unwrap()
    }

    #[test]
    fn a_stalled_disk_never_holds_up_the_loop_and_what_was_queued_is_written() {
        let (disk, control) = disk();
        let mut recorder = Recorder::new(ResultWriter::streaming(disk, "odom").unwrap());
        set(&control, State::Stalls);
        // The loop's side on a thread of its own, so that a recorder that blocks fails
        // this test instead of hanging it.
        let sent = RECORDING_QUEUE as u64 + 200;
        let (done, finished) = std::sync::mpsc::channel();
        let loop_side = std::thread::spawn(move || {
            for k in 0..sent {
                recorder
                    .scan(&scan(k as i64), 0.1, Stamp::from_ns(k as i64))
                    .unwrap();
            }
            done.send(()).unwrap();
            recorder
        });
        finished
            .recv_timeout(Duration::from_secs(60))
            .expect("the loop was held up by the stalled disk");
        let recorder = loop_side.join().unwrap();
        // The queue is full and the writer holds one message: the rest were dropped.
        let dropped = recorder.dropped();
        assert!((199..=200).contains(&dropped), "{dropped} dropped");
        set(&control, State::Writes);
        let disk = recorder.finish().unwrap();
        let file = McapFile::from_bytes(disk.file.into_inner()).unwrap();
        let scans = file
            .messages()
            .filter(|m| m.as_ref().is_ok_and(|m| m.channel.topic == "/scan"))
            .count() as u64;
        assert_eq!(scans, sent - dropped);
    }

    #[test]
    fn a_disk_that_fails_ends_the_recording_with_its_error() {
        let (disk, control) = disk();
        let mut recorder = Recorder::new(ResultWriter::streaming(disk, "odom").unwrap());
        recorder.scan(&scan(0), 0.1, Stamp::from_ns(0)).unwrap();
        set(&control, State::Fails);
        let error = (1..10_000)
            .find_map(|k| {
                std::thread::sleep(Duration::from_millis(1));
                recorder.scan(&scan(k), 0.1, Stamp::from_ns(k)).err()
            })
            .expect("the failed disk never showed");
        let chain: Vec<String> =
            std::iter::successors(Some(&error as &dyn std::error::Error), |e| e.source())
                .map(ToString::to_string)
                .collect();
        assert!(
            chain.iter().any(|e| e.contains("no space left")),
            "{chain:?}"
        );
        // Once failed, it stays failed, and finishing says so too.
        assert!(recorder.scan(&scan(0), 0.1, Stamp::from_ns(0)).is_err());
        assert!(recorder.finish().is_err());
    }

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
