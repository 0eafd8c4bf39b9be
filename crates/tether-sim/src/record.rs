//! Writing a run to a folder.
//!
//! | file | one line per | content |
//! |---|---|---|
//! | `scans.jsonl` | laser scan | `stamp_ns`, `frame_id`, `angle_min_rad`, `angle_increment_rad`, `range_min_m`, `range_max_m`, `ranges_m` (metres; `null` = no return) |
//! | `camera.jsonl` | camera frame | `stamp_ns`, `frame_id`, `width_px`, `height_px`, `boxes` (`[x, y, w, h]` px, top-left origin) |
//! | `truth.jsonl` | laser scan | `stamp_ns`; `robot`, `laser`, `camera` poses in the world (`x`, `y` m, `yaw` rad) and the robot's `v_mps`, `w_radps`; `collisions` so far; `people`: `id`, `name`, `target`, `world` and `laser` (`x`, `y`, `vx`, `vy`), `heading_rad`, `height_m`, `laser_beams` (beams of this scan on the person's legs), `legs` (world `x`, `y`, `radius_m`, at the laser's height) |
//! | `camera_truth.jsonl` | camera frame | `stamp_ns`, `people` (`id`, `true_box`, `in_image_frac`, `visible_frac`, `distance_m`, `detect_prob`, `box_index`), `false_positives` (indices into that frame's boxes) |
//! | `scene.svg` | run | top-down picture: walls, furniture, paths of people and robot |
//! | `scenario.toml` | run | the scenario that ran |
//! | `run.json` | run | scenario, seed, duration, counts |
//!
//! Positions in the laser frame are the body centre seen from the scanner; `vx`, `vy`
//! there are the person's world velocity expressed in the laser's axes (not relative to
//! the moving robot). All numbers are written by the same shortest-round-trip float
//! formatter, so a run's files are byte-identical for the same scenario and seed.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use serde_json::{Value, json};
use tether_core::{Frame, Pose2, Robot, Stamp, World};

use crate::driver::Driver;
use crate::robot::Command;
use crate::scenario::Scenario;
use crate::sim::{Event, SensorData, SimError, Simulation, Truth};
use crate::svg::{Track, person_color, scene_svg};
use crate::world::StaticWorld;

/// Why a run could not be recorded.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    /// Writing a file failed.
    #[error("cannot write {path}: {source}")]
    Io {
        /// File.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// The simulation could not start.
    #[error(transparent)]
    Sim(#[from] SimError),
}

/// Counts of a finished run.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RunSummary {
    /// Scenario name.
    pub scenario: String,
    /// Seed.
    pub seed: u64,
    /// Simulated time, s.
    pub duration_s: f64,
    /// Laser scans written.
    pub scans: u64,
    /// Camera frames written.
    pub camera_frames: u64,
    /// Boxes in all camera frames.
    pub camera_boxes: u64,
    /// Robot collisions with walls or furniture.
    pub collisions: u32,
}

/// Rounds to a micrometre (or micro-unit): more than any sensor resolves.
fn r6(x: f64) -> f64 {
    (x * 1e6).round() / 1e6
}

fn pose_json<A: Frame, B: Frame>(p: Pose2<A, B>) -> Value {
    json!({"x": r6(p.x), "y": r6(p.y), "yaw": r6(p.yaw)})
}

/// The `truth.jsonl` line of a scan event.
pub fn truth_line(truth: &Truth) -> Value {
    let laser_from_world = truth.world_from_laser.inverse();
    let people: Vec<Value> = truth
        .people
        .iter()
        .map(|p| {
            let in_laser = laser_from_world * p.position;
            let v_laser = laser_from_world.rotate(p.velocity);
            json!({
                "id": p.id,
                "name": p.name,
                "target": p.target,
                "world": {"x": r6(p.position.x), "y": r6(p.position.y), "vx": r6(p.velocity.x), "vy": r6(p.velocity.y)},
                "laser": {"x": r6(in_laser.x), "y": r6(in_laser.y), "vx": r6(v_laser.x), "vy": r6(v_laser.y)},
                "heading_rad": r6(p.heading_rad),
                "height_m": r6(p.height_m),
                "laser_beams": p.laser_beams,
                "legs": p.legs.iter().map(|l| json!({"x": r6(l.center.x), "y": r6(l.center.y), "radius_m": r6(l.radius_m)})).collect::<Vec<_>>(),
            })
        })
        .collect();
    let mut robot = pose_json(truth.world_from_robot);
    robot["v_mps"] = json!(r6(truth.robot_velocity.v_mps));
    robot["w_radps"] = json!(r6(truth.robot_velocity.w_radps));
    json!({
        "stamp_ns": truth.stamp.ns(),
        "robot": robot,
        "laser": pose_json(truth.world_from_laser),
        "camera": pose_json(truth.world_from_camera),
        "collisions": truth.collisions,
        "people": people,
    })
}

/// Writes the files of a run as events arrive.
pub struct RunRecorder {
    dir: PathBuf,
    scans: BufWriter<File>,
    camera: BufWriter<File>,
    truth: BufWriter<File>,
    camera_truth: BufWriter<File>,
    tracks: Vec<Track>,
    robot_track: Track,
    robot_poses: Vec<Pose2<World, Robot>>,
    summary: RunSummary,
    width_px: u32,
    height_px: u32,
}

fn create(dir: &Path, name: &str) -> Result<BufWriter<File>, RecordError> {
    let path = dir.join(name);
    File::create(&path)
        .map(BufWriter::new)
        .map_err(|source| RecordError::Io { path, source })
}

impl RunRecorder {
    /// Creates `dir` and the per-event files in it.
    pub fn create(dir: &Path, scenario: &Scenario, seed: u64) -> Result<Self, RecordError> {
        std::fs::create_dir_all(dir).map_err(|source| RecordError::Io {
            path: dir.to_owned(),
            source,
        })?;
        let tracks = scenario
            .people
            .iter()
            .enumerate()
            .map(|(i, p)| Track {
                label: if p.target {
                    format!("{} (target)", p.name)
                } else {
                    p.name.clone()
                },
                color: person_color(i, p.target).to_owned(),
                points: Vec::new(),
            })
            .collect();
        Ok(RunRecorder {
            dir: dir.to_owned(),
            scans: create(dir, "scans.jsonl")?,
            camera: create(dir, "camera.jsonl")?,
            truth: create(dir, "truth.jsonl")?,
            camera_truth: create(dir, "camera_truth.jsonl")?,
            tracks,
            robot_track: Track {
                label: "robot".into(),
                color: "#222222".into(),
                points: Vec::new(),
            },
            robot_poses: Vec::new(),
            summary: RunSummary {
                scenario: scenario.name.clone(),
                seed,
                duration_s: scenario.duration_s,
                scans: 0,
                camera_frames: 0,
                camera_boxes: 0,
                collisions: 0,
            },
            width_px: scenario.camera.intrinsics.width_px,
            height_px: scenario.camera.intrinsics.height_px,
        })
    }

    fn write_line(&mut self, which: Which, value: &Value) -> Result<(), RecordError> {
        let (writer, name) = match which {
            Which::Scans => (&mut self.scans, "scans.jsonl"),
            Which::Camera => (&mut self.camera, "camera.jsonl"),
            Which::Truth => (&mut self.truth, "truth.jsonl"),
            Which::CameraTruth => (&mut self.camera_truth, "camera_truth.jsonl"),
        };
        let result = serde_json::to_writer(&mut *writer, value)
            .map_err(std::io::Error::from)
            .and_then(|()| writer.write_all(b"\n"));
        result.map_err(|source| RecordError::Io {
            path: self.dir.join(name),
            source,
        })
    }

    /// Records one event.
    pub fn record(&mut self, event: &Event) -> Result<(), RecordError> {
        match &event.data {
            SensorData::Scan(scan) => {
                let ranges: Vec<Value> = scan
                    .ranges_m()
                    .iter()
                    .map(|&r| if r.is_finite() { json!(r) } else { Value::Null })
                    .collect();
                let line = json!({
                    "stamp_ns": scan.stamp.ns(),
                    "frame_id": scan.frame_id,
                    "angle_min_rad": scan.angle_min_rad,
                    "angle_increment_rad": scan.angle_increment_rad,
                    "range_min_m": scan.range_min_m,
                    "range_max_m": scan.range_max_m,
                    "ranges_m": ranges,
                });
                self.write_line(Which::Scans, &line)?;
                self.write_line(Which::Truth, &truth_line(&event.truth))?;
                for (track, person) in self.tracks.iter_mut().zip(&event.truth.people) {
                    track.points.push(person.position);
                }
                self.robot_track
                    .points
                    .push(event.truth.world_from_robot.translation());
                self.robot_poses.push(event.truth.world_from_robot);
                self.summary.scans += 1;
                self.summary.collisions = event.truth.collisions;
            }
            SensorData::Camera(frame) => {
                let boxes: Vec<[f64; 4]> =
                    frame.boxes.iter().map(|b| [b.x, b.y, b.w, b.h]).collect();
                let line = json!({
                    "stamp_ns": frame.stamp.ns(),
                    "frame_id": frame.frame_id,
                    "width_px": self.width_px,
                    "height_px": self.height_px,
                    "boxes": boxes,
                });
                self.write_line(Which::Camera, &line)?;
                if let Some(ct) = &event.camera_truth {
                    let line = json!({
                        "stamp_ns": frame.stamp.ns(),
                        "people": ct.people.iter().map(|v| json!({
                            "id": v.id,
                            "true_box": v.true_box.map(|b| [r6(b.x), r6(b.y), r6(b.w), r6(b.h)]),
                            "in_image_frac": r6(v.in_image_frac),
                            "visible_frac": r6(v.visible_frac),
                            "distance_m": r6(v.distance_m),
                            "detect_prob": r6(v.detect_prob),
                            "box_index": v.box_index,
                        })).collect::<Vec<_>>(),
                        "false_positives": ct.false_positives,
                    });
                    self.write_line(Which::CameraTruth, &line)?;
                }
                self.summary.camera_frames += 1;
                self.summary.camera_boxes += frame.boxes.len() as u64;
            }
            SensorData::Timer => {}
        }
        Ok(())
    }

    /// Flushes the streams and writes the picture, the scenario and the summary.
    pub fn finish(
        mut self,
        scenario: &Scenario,
        world: &StaticWorld,
        collisions: u32,
        scenario_toml: &str,
    ) -> Result<RunSummary, RecordError> {
        self.summary.collisions = collisions;
        for (w, name) in [
            (&mut self.scans, "scans.jsonl"),
            (&mut self.camera, "camera.jsonl"),
            (&mut self.truth, "truth.jsonl"),
            (&mut self.camera_truth, "camera_truth.jsonl"),
        ] {
            w.flush().map_err(|source| RecordError::Io {
                path: self.dir.join(name),
                source,
            })?;
        }
        let svg = scene_svg(
            scenario,
            world,
            &self.tracks,
            &self.robot_track,
            &self.robot_poses,
        );
        let summary_json = serde_json::to_string_pretty(&self.summary).unwrap_or_default() + "\n";
        for (name, text) in [
            ("scene.svg", svg.as_str()),
            ("scenario.toml", scenario_toml),
            ("run.json", summary_json.as_str()),
        ] {
            let path = self.dir.join(name);
            std::fs::write(&path, text).map_err(|source| RecordError::Io { path, source })?;
        }
        Ok(self.summary)
    }
}

#[derive(Clone, Copy)]
enum Which {
    Scans,
    Camera,
    Truth,
    CameraTruth,
}

/// Runs a whole simulation with `driver`, calling `on_event` with every event and the
/// command the driver chose (handy for recorders and progress bars).
pub fn run(
    sim: &mut Simulation,
    driver: &mut dyn Driver,
    mut on_event: impl FnMut(&Event, Command) -> Result<(), RecordError>,
) -> Result<(), RecordError> {
    while let Some(event) = sim.advance() {
        if let Some(command) = driver.on_event(&event) {
            sim.set_command(command);
        }
        on_event(&event, sim.robot().command())?;
    }
    Ok(())
}

/// Runs `scenario` with `seed` and writes every file into `dir`. `progress` is called
/// after each event with (now, end).
pub fn run_to_dir(
    scenario: &Scenario,
    scenario_toml: &str,
    seed: u64,
    dir: &Path,
    mut progress: impl FnMut(Stamp, Stamp),
) -> Result<RunSummary, RecordError> {
    let mut sim = Simulation::new(scenario, seed)?;
    let mut driver = crate::driver::driver_for(scenario);
    let mut recorder = RunRecorder::create(dir, scenario, seed)?;
    let end = sim.end();
    run(&mut sim, driver.as_mut(), |event, _| {
        progress(event.truth.stamp, end);
        recorder.record(event)
    })?;
    progress(end, end);
    recorder.finish(scenario, sim.world(), sim.collisions(), scenario_toml)
}
