//! The report of `tether replay` (`--out`'s HTML beside the MCAP results): what is
//! gathered tick by tick while replaying ([`ReplaySummary`]) and the page made of it:
//! the overview, the snapshots, the target's locks and losses, the tracks and the plots
//! over time.

use std::collections::BTreeMap;
use std::path::Path;

use tether_core::{Gaussian2, Laser, LaserScan, Pose2, Robot, Stamp, World};
use tether_fusion::tracker::Track;
use tether_fusion::{TargetState, TargetStats};
use tether_laser::LegDetector;
use tether_live::target_log::TargetLog;
use tether_pipeline::Tick;
use tether_svg::xml_escape;

use super::{
    Chosen, Snapshot, SnapshotPicker, TrackSeen, TrackTable, overview_svg, snapshots_html,
};
use crate::plot::{Plot, Series};
use crate::sim_report::simple_page;

/// What the report shows of one tick.
struct TickRow {
    t_s: f64,
    target_range_m: Option<f64>,
    target_bearing_rad: Option<f64>,
    v_mps: f64,
    w_radps: f64,
    tracks: usize,
}

/// The last scan replayed, with the robot's pose at it and its laser people: what a
/// snapshot draws (a loss on a camera frame draws the scan before it).
struct LastScan {
    index: usize,
    scan: LaserScan,
    world_from_robot: Pose2<World, Robot>,
    laser_people: Vec<Gaussian2<World>>,
}

impl LastScan {
    /// A snapshot of this scan with the tick's tracks and target.
    fn snapshot(
        &self,
        tick: &Tick,
        start: Stamp,
        robot_from_laser: Pose2<Robot, Laser>,
        chosen: Chosen,
    ) -> Snapshot {
        Snapshot {
            t_s: tick.stamp.secs_since(start),
            stamp: tick.stamp,
            scan_index: self.index,
            chosen,
            scan: self.scan.clone(),
            world_from_robot: self.world_from_robot,
            robot_from_laser,
            laser_people: self.laser_people.clone(),
            tracks: tick.tracks.clone(),
            target: tick.target.state,
            target_estimate: tick.target.estimate,
        }
    }
}

/// Everything the report of a replay needs, gathered while replaying (`tether replay`'s
/// `--out` report and its last line).
pub struct ReplaySummary {
    /// Scans read.
    pub scans: usize,
    /// Camera frames read.
    pub frames: usize,
    /// Boxes the camera found.
    pub boxes: usize,
    /// Odometry messages.
    pub odom: usize,
    /// Scans before the first odometry message (not used).
    pub waiting_for_odom: usize,
    ticks: Vec<TickRow>,
    /// Each confirmed track's path.
    pub trails: BTreeMap<u64, Vec<(f64, f64)>>,
    robot_path: Vec<(f64, f64)>,
    /// The tracks followed, in order.
    pub target_ids: Vec<u64>,
    start: Option<Stamp>,
    /// The target's locks and losses.
    pub target: TargetLog,
    robot_from_laser: Pose2<Robot, Laser>,
    /// Scans that reached the pipeline (with a pose).
    scans_replayed: usize,
    last_scan: Option<LastScan>,
    snapshots: SnapshotPicker,
    track_table: TrackTable,
    lost: bool,
}

impl ReplaySummary {
    /// A summary for a laser mounted at `robot_from_laser`.
    pub fn new(robot_from_laser: Pose2<Robot, Laser>) -> Self {
        ReplaySummary {
            scans: 0,
            frames: 0,
            boxes: 0,
            odom: 0,
            waiting_for_odom: 0,
            ticks: Vec::new(),
            trails: BTreeMap::new(),
            robot_path: Vec::new(),
            target_ids: Vec::new(),
            start: None,
            target: TargetLog::new(),
            robot_from_laser,
            scans_replayed: 0,
            last_scan: None,
            snapshots: SnapshotPicker::new(),
            track_table: TrackTable::new(),
            lost: false,
        }
    }

    /// A scan went through the pipeline: it is the last scan, and perhaps one of the
    /// evenly spaced snapshots.
    /// A scan replayed, with the robot's pose at it and its tick.
    pub fn scan(&mut self, scan: LaserScan, world_from_robot: Pose2<World, Robot>, tick: &Tick) {
        let start = *self.start.get_or_insert(tick.stamp);
        let index = self.scans_replayed;
        self.scans_replayed += 1;
        let last = LastScan {
            index,
            scan,
            world_from_robot,
            laser_people: tick.laser_people.clone(),
        };
        let robot_from_laser = self.robot_from_laser;
        self.snapshots.scan(index, || {
            last.snapshot(tick, start, robot_from_laser, Chosen::Evenly)
        });
        self.last_scan = Some(last);
    }

    /// A tick (a scan's or a camera frame's), with the tracker's tracks after it.
    pub fn record(&mut self, tick: &Tick, world_from_robot: Pose2<World, Robot>, tracks: &[Track]) {
        let start = *self.start.get_or_insert(tick.stamp);
        self.target.record_tick(tick);
        let lost = matches!(tick.target.state, TargetState::Lost { .. });
        if let (TargetState::Lost { reason, .. }, false, Some(last)) =
            (tick.target.state, self.lost, &self.last_scan)
        {
            let robot_from_laser = self.robot_from_laser;
            self.snapshots
                .loss(|| last.snapshot(tick, start, robot_from_laser, Chosen::Loss(reason)));
        }
        self.lost = lost;
        let seen: Vec<TrackSeen> = tracks.iter().map(TrackSeen::of).collect();
        self.track_table.update(
            tick.stamp,
            matches!(tick.input, tether_pipeline::TickInput::Scan),
            &seen,
            tick.target.state.locked_track(),
        );
        let robot = world_from_robot.translation();
        self.robot_path.push((robot.x, robot.y));
        let target = tick
            .target
            .state
            .locked_track()
            .zip(tick.target.estimate)
            .map(|(id, e)| {
                if self.target_ids.last() != Some(&id) {
                    self.target_ids.push(id);
                }
                world_from_robot.inverse() * e.mean
            });
        for t in tick.tracks.iter().filter(|t| t.confirmed) {
            self.trails
                .entry(t.id)
                .or_default()
                .push((t.position.mean.x, t.position.mean.y));
        }
        self.ticks.push(TickRow {
            t_s: tick.stamp.secs_since(start),
            target_range_m: target.map(|p| p.range_m()),
            target_bearing_rad: target.map(|p| p.bearing_rad()),
            v_mps: tick.command.v_mps,
            w_radps: tick.command.w_radps,
            tracks: tick.tracks.iter().filter(|t| t.confirmed).count(),
        });
    }

    fn series(&self, label: &str, color: &str, f: impl Fn(&TickRow) -> Option<f64>) -> Series {
        Series {
            label: label.into(),
            color: color.into(),
            dashed: false,
            points: self.ticks.iter().map(|r| (r.t_s, f(r))).collect(),
        }
    }

    /// The report's page: `recording` replayed in `frame`, with the lock's `counts`;
    /// `detector` finds the legs drawn in the snapshots.
    pub fn html(
        &mut self,
        recording: &Path,
        frame: &str,
        counts: TargetStats,
        detector: &mut LegDetector,
    ) -> String {
        let duration = self.ticks.last().map_or(0.0, |r| r.t_s);
        let locked = self
            .ticks
            .windows(2)
            .filter(|w| w[0].target_range_m.is_some())
            .map(|w| w[1].t_s - w[0].t_s)
            .sum::<f64>();
        let intro = format!(
            "<p>Replay of <code>{}</code>: {} scans, {} camera frames ({} detections), {} \
             odometry messages over {duration:.1} s; positions in <code>{}</code>. \
             {} people tracked; a target locked for {locked:.1} s (track ids {:?}).</p>",
            xml_escape(&recording.display().to_string()),
            self.scans,
            self.frames,
            self.boxes,
            self.odom,
            xml_escape(frame),
            self.trails.len(),
            self.target_ids
        );
        let target = Plot {
            title: "Target relative to the robot".into(),
            y_label: "range m / bearing rad".into(),
            series: vec![
                self.series("range (m)", "#d62728", |r| r.target_range_m),
                self.series("bearing (rad)", "#1f77b4", |r| r.target_bearing_rad),
            ],
            ..Plot::default()
        };
        let commands = Plot {
            title: "Commands tether would have sent".into(),
            y_label: "m/s, rad/s".into(),
            series: vec![
                self.series("v (m/s)", "#2ca02c", |r| Some(r.v_mps)),
                self.series("w (rad/s)", "#9467bd", |r| Some(r.w_radps)),
            ],
            ..Plot::default()
        };
        let tracks = Plot {
            title: "Confirmed tracks".into(),
            y_label: "count".into(),
            series: vec![self.series("tracks", "#333", |r| Some(r.tracks as f64))],
            ..Plot::default()
        };
        let snapshots = std::mem::take(&mut self.snapshots).finish(self.scans_replayed);
        let start = self.start.unwrap_or(Stamp::ZERO);
        let sections = vec![
            (
                "Map".to_string(),
                overview_svg(&self.trails, &self.robot_path, &self.target_ids, frame),
            ),
            (
                "Snapshots".to_string(),
                snapshots_html(&snapshots, detector, frame),
            ),
            (
                "Target: locks, losses and why".to_string(),
                crate::sim_report::target_html(&self.target, counts),
            ),
            ("Tracks".to_string(), self.track_table.html(start)),
            (
                "Over time".to_string(),
                [target, commands, tracks]
                    .iter()
                    .map(|p| format!("<div class=\"figure\">{}</div>", p.svg()))
                    .collect::<String>(),
            ),
        ];
        simple_page("tether replay", &intro, &sections)
    }
}
