//! The simulator served as a Hokuyo scanner (`tether urg-emulator`): the laser scans of
//! a scenario as the SCIP 2.0 emulator's [`ScanSource`], the simulated robot standing
//! still or driving the velocity commands read from a stream (what `tether run` prints,
//! or a wheels base's lines), and the ground truth of every scan served as JSON lines.
//! The simulated base keeps a command until the next one and stops when the stream
//! ends.

use std::collections::VecDeque;
use std::io::{BufRead, Write};
use std::sync::{Arc, Mutex};

use anyhow::Context;
use serde::{Deserialize, Serialize};
use tether_scip::emulator::{EmulatorConfig, ScanSource};
use tether_sim::{Command, Scenario, SensorData, Simulation, Truth};

/// The newest command received and how many came so far.
pub type CommandInbox = Arc<Mutex<(u64, Command)>>;

#[derive(Deserialize)]
#[serde(untagged)]
enum CommandIn {
    Velocity { v_mps: f64, w_radps: f64 },
    Wheels { left_mps: f64, right_mps: f64 },
}

/// The velocity of a command line: tether's JSON (`v_mps`, `w_radps`), a wheels JSON
/// line (`left_mps`, `right_mps`) or a text line `LEFT RIGHT`, the wheel speeds turned
/// into `v = (l + r) / 2`, `w = (r - l) / b` for the track width `b`.
pub fn parse_command(line: &str, track_width_m: f64) -> Option<Command> {
    let (v_mps, w_radps) = match serde_json::from_str::<CommandIn>(line) {
        Ok(CommandIn::Velocity { v_mps, w_radps }) => (v_mps, w_radps),
        Ok(CommandIn::Wheels {
            left_mps,
            right_mps,
        }) => (
            0.5 * (left_mps + right_mps),
            (right_mps - left_mps) / track_width_m,
        ),
        Err(_) => {
            let mut words = line.split_whitespace();
            let left: f64 = words.next()?.parse().ok()?;
            let right: f64 = words.next()?.parse().ok()?;
            if words.next().is_some() {
                return None;
            }
            (0.5 * (left + right), (right - left) / track_width_m)
        }
    };
    (v_mps.is_finite() && w_radps.is_finite()).then_some(Command { v_mps, w_radps })
}

/// Reads command lines from `input` into `inbox` until it ends, then posts a stop.
/// Lines that are not commands are skipped (the first is reported). `track_width_m`
/// turns wheel speeds into a velocity ([`parse_command`]). Returns how many commands
/// came and the last of them (a robot's last word before its commands ended).
pub fn read_commands(
    input: impl BufRead,
    inbox: &CommandInbox,
    track_width_m: f64,
) -> (u64, Option<Command>) {
    let mut count = 0_u64;
    let mut last = None;
    let post = |command: Command| {
        if let Ok(mut slot) = inbox.lock() {
            slot.0 += 1;
            slot.1 = command;
        }
    };
    let mut warned = false;
    for line in input.lines() {
        let Ok(line) = line else { break };
        let line = line.trim();
        if line.is_empty() {
            continue;
        }
        match parse_command(line, track_width_m) {
            Some(command) => {
                count += 1;
                last = Some(command);
                post(command);
            }
            None if !warned => {
                warned = true;
                tracing::warn!("ignoring input lines that are not commands, like: {line}");
            }
            _ => {}
        }
    }
    post(Command {
        v_mps: 0.0,
        w_radps: 0.0,
    });
    (count, last)
}

/// Reads commands from the FIFO at `path`, again after each time its writers close it
/// (one `tether run` after another).
pub fn read_command_file(path: &std::path::Path, inbox: &CommandInbox, track_width_m: f64) {
    use std::os::unix::fs::FileTypeExt;
    loop {
        // Opening a FIFO waits for a writer.
        let file = match std::fs::File::open(path) {
            Ok(file) => file,
            Err(e) => {
                tracing::error!("--commands {}: {e}; the robot stands", path.display());
                return;
            }
        };
        let fifo = file.metadata().is_ok_and(|m| m.file_type().is_fifo());
        let (count, last) = read_commands(std::io::BufReader::new(file), inbox, track_width_m);
        let last = last.map_or_else(
            || "none".to_string(),
            |c| format!("v {:.3} m/s, w {:.3} rad/s", c.v_mps, c.w_radps),
        );
        tracing::info!(
            "the commands' writers closed {} after {count} commands (the last: {last}): the \
             robot stops{}",
            path.display(),
            if fifo {
                "; waiting for the next writer"
            } else {
                ""
            }
        );
        if !fifo {
            return;
        }
    }
}

#[derive(Serialize)]
struct PoseOut {
    x: f64,
    y: f64,
    yaw: f64,
}

#[derive(Serialize)]
struct PersonOut<'a> {
    id: u32,
    name: &'a str,
    target: bool,
    x: f64,
    y: f64,
}

#[derive(Serialize)]
struct TruthOut<'a> {
    t_s: f64,
    robot: PoseOut,
    v_mps: f64,
    w_radps: f64,
    collisions: u32,
    people: Vec<PersonOut<'a>>,
}

fn write_truth(out: &mut dyn Write, truth: &Truth) -> std::io::Result<()> {
    let p = truth.world_from_robot;
    let line = TruthOut {
        t_s: truth.stamp.secs_f64(),
        robot: PoseOut {
            x: p.x,
            y: p.y,
            yaw: p.yaw,
        },
        v_mps: truth.robot_velocity.v_mps,
        w_radps: truth.robot_velocity.w_radps,
        collisions: truth.collisions,
        people: truth
            .people
            .iter()
            .map(|q| PersonOut {
                id: q.id,
                name: &q.name,
                target: q.target,
                x: q.position.x,
                y: q.position.y,
            })
            .collect(),
    };
    serde_json::to_writer(&mut *out, &line)?;
    out.write_all(b"\n")?;
    out.flush()
}

/// One laser a [`SimulatedScans`] serves: the first (`frame` `None`) or an extra one,
/// its beam count, and the scans the simulation made for it that are not served yet.
struct Served {
    frame: Option<String>,
    beams: usize,
    queue: VecDeque<Vec<u32>>,
}

/// The most scans kept for a laser not read as fast as the others (or not at all: no
/// client on its port); the oldest go first.
const MAX_QUEUED_SCANS: usize = 4;

/// Laser scans of a scenario, in millimetres for the emulator; the robot stands still
/// or drives the commands of a [`CommandInbox`]. One simulation may serve several of
/// the robot's lasers ([`SimulatedScans::with_extra_laser`], [`SimulatedScans::shared`]):
/// one world and one robot, seen by each scanner.
pub struct SimulatedScans {
    scenario: Scenario,
    seed: u64,
    sim: Simulation,
    /// The lasers served; the truth is written at the first one's scans.
    served: Vec<Served>,
    commands: Option<(CommandInbox, u64)>,
    truth: Option<Box<dyn Write + Send>>,
}

impl SimulatedScans {
    /// The robot drives the newest command of `inbox` (each new one is given to the
    /// simulated base before the next scan).
    pub fn with_commands(mut self, inbox: CommandInbox) -> Self {
        self.commands = Some((inbox, 0));
        self
    }

    /// Writes the ground truth of every scan to `out` (a JSON line each, flushed).
    pub fn with_truth(mut self, out: Box<dyn Write + Send>) -> Self {
        self.truth = Some(out);
        self
    }

    /// Also serves the scenario's extra laser of `frame` from this simulation; its
    /// emulator configuration. Its scans come from [`SimulatedScans::shared`].
    pub fn with_extra_laser(mut self, frame: &str) -> anyhow::Result<(Self, EmulatorConfig)> {
        let laser = laser_of(&self.scenario, Some(frame))?;
        let config = emulator_config(laser);
        anyhow::ensure!(
            self.served
                .iter()
                .all(|s| s.frame.as_deref() != Some(frame)),
            "the laser of frame {frame:?} is served twice"
        );
        self.served.push(Served {
            frame: Some(frame.to_owned()),
            beams: laser.geometry.beam_count(),
            queue: VecDeque::new(),
        });
        Ok((self, config))
    }

    /// One [`ScanSource`] for each laser served, in the order they were added (the
    /// first laser, or the one [`simulated_scans`] was asked for, first), all from this
    /// simulation.
    pub fn shared(self) -> Vec<SharedLaser> {
        let beams: Vec<usize> = self.served.iter().map(|s| s.beams).collect();
        let scans = Arc::new(Mutex::new(self));
        beams
            .into_iter()
            .enumerate()
            .map(|(index, beams)| SharedLaser {
                scans: Arc::clone(&scans),
                index,
                beams,
            })
            .collect()
    }

    /// Takes the newest command, if a new one came.
    fn take_command(&mut self) {
        if let Some((inbox, seen)) = &mut self.commands
            && let Ok(slot) = inbox.lock()
            && slot.0 != *seen
        {
            *seen = slot.0;
            self.sim.set_command(slot.1);
        }
    }

    /// The next scan of the `k`-th laser served: one the simulation made already, or the
    /// simulation runs on to it (keeping the other lasers' scans for them).
    fn next_scan(&mut self, k: usize, ranges_mm: &mut Vec<u32>) {
        self.take_command();
        let beams = self.served.get(k).map_or(0, |s| s.beams);
        if let Some(scan) = self.served.get_mut(k).and_then(|s| s.queue.pop_front()) {
            ranges_mm.extend(scan);
            return;
        }
        // At most two passes: the scenario may end and start over once.
        for _ in 0..2 {
            while let Some(event) = self.sim.advance() {
                let Some(j) = self.served.iter().position(|s| match &s.frame {
                    None => event.data.first_laser_scan().is_some(),
                    Some(f) => matches!(&event.data, SensorData::Scan(scan) if scan.frame_id == *f),
                }) else {
                    continue;
                };
                let SensorData::Scan(scan) = &event.data else {
                    continue;
                };
                if j == 0
                    && let Some(out) = self.truth.as_mut()
                    && let Err(e) = write_truth(out.as_mut(), &event.truth)
                {
                    tracing::error!("writing the ground truth failed ({e}); no more of it");
                    self.truth = None;
                }
                let mut mm: Vec<u32> = scan
                    .ranges_m()
                    .iter()
                    .map(|&r| {
                        if r.is_finite() {
                            (f64::from(r) * 1000.0).round().max(0.0) as u32
                        } else {
                            NO_ECHO_CODE_MM
                        }
                    })
                    .collect();
                mm.resize(self.served[j].beams, NO_ECHO_CODE_MM);
                if j == k {
                    ranges_mm.extend(mm);
                    return;
                }
                let queue = &mut self.served[j].queue;
                if queue.len() >= MAX_QUEUED_SCANS {
                    queue.pop_front();
                }
                queue.push_back(mm);
            }
            tracing::warn!(
                "scenario `{}` ended after {:.1} s of scans: it starts over (the people and \
                 the robot go back to their start; a run still reading sees them jump)",
                self.scenario.name,
                self.scenario.duration_s
            );
            match Simulation::new(&self.scenario, self.seed) {
                Ok(sim) => self.sim = sim,
                Err(_) => break,
            }
            for served in &mut self.served {
                served.queue.clear();
            }
        }
        ranges_mm.resize(beams, NO_ECHO_CODE_MM);
    }
}

/// What the emulator sends for a beam without return: an error code (below `DMIN`).
const NO_ECHO_CODE_MM: u32 = 1;

impl ScanSource for SimulatedScans {
    fn scan(&mut self, _scan_index: u64, ranges_mm: &mut Vec<u32>) {
        self.next_scan(0, ranges_mm);
    }
}

/// One laser of a simulation that serves several ([`SimulatedScans::shared`]).
pub struct SharedLaser {
    scans: Arc<Mutex<SimulatedScans>>,
    index: usize,
    beams: usize,
}

impl ScanSource for SharedLaser {
    fn scan(&mut self, _scan_index: u64, ranges_mm: &mut Vec<u32>) {
        match self.scans.lock() {
            Ok(mut scans) => scans.next_scan(self.index, ranges_mm),
            // Another laser's server panicked inside the simulation: no returns.
            Err(_) => ranges_mm.resize(self.beams, NO_ECHO_CODE_MM),
        }
    }
}

/// The first laser of `scenario` (`frame` `None`) or its extra laser of `frame`.
fn laser_of<'s>(
    scenario: &'s Scenario,
    frame: Option<&str>,
) -> anyhow::Result<&'s tether_core::LaserModel> {
    Ok(match frame {
        None => &scenario.laser,
        Some(f) => match scenario.extra_lasers.iter().find(|l| l.frame_id == f) {
            Some(extra) => &extra.laser,
            None => anyhow::bail!(
                "scenario `{}` has no extra laser of frame {f:?} (it has: {})",
                scenario.name,
                if scenario.extra_lasers.is_empty() {
                    "none".to_owned()
                } else {
                    scenario
                        .extra_lasers
                        .iter()
                        .map(|l| l.frame_id.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                }
            ),
        },
    })
}

/// The emulator configuration of `laser`: step geometry, range limits, scan rate.
fn emulator_config(laser: &tether_core::LaserModel) -> EmulatorConfig {
    EmulatorConfig {
        geometry: laser.geometry,
        // A URG-04LX accepts steps up to 768, 43 past its last measured one.
        max_step: (laser.geometry.last_step + 43).min(9999) as u16,
        range_min_mm: (laser.range_min_m * 1000.0).round() as u32,
        range_max_mm: (laser.range_max_m * 1000.0).round() as u32,
        scan_rpm: (60.0 / laser.scan_period_s).round().max(1.0) as u32,
        ..EmulatorConfig::default()
    }
}

/// The scans of `scenario` (robot still) and the emulator configuration of its laser
/// (step geometry, range limits, scan rate): the first laser's, or with `frame` the
/// extra laser's of that frame.
pub fn simulated_scans(
    scenario: &Scenario,
    seed: u64,
    frame: Option<&str>,
) -> anyhow::Result<(SimulatedScans, EmulatorConfig)> {
    anyhow::ensure!(
        scenario.laser_sim.enabled,
        "scenario `{}` has no simulated laser (laser_sim.enabled = false)",
        scenario.name
    );
    let sim = Simulation::new(scenario, seed)
        .with_context(|| format!("building scenario `{}`", scenario.name))?;
    let laser = laser_of(scenario, frame)?;
    let scans = SimulatedScans {
        scenario: scenario.clone(),
        seed,
        sim,
        served: vec![Served {
            frame: frame.map(str::to_owned),
            beams: laser.geometry.beam_count(),
            queue: VecDeque::new(),
        }],
        commands: None,
        truth: None,
    };
    Ok((scans, emulator_config(laser)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_come_as_velocities_or_wheel_speeds() {
        let v = |line: &str| parse_command(line, 0.3).map(|c| (c.v_mps, c.w_radps));
        assert_eq!(
            v(r#"{"v_mps":0.5,"w_radps":0.1,"stop":null}"#),
            Some((0.5, 0.1))
        );
        let (speed, turn) = v(r#"{"stamp_ns":1,"left_mps":0.4,"right_mps":0.6}"#).unwrap();
        assert!((speed - 0.5).abs() < 1e-12 && (turn - 0.2 / 0.3).abs() < 1e-12);
        let (speed, turn) = v("0.400 0.600").unwrap();
        assert!((speed - 0.5).abs() < 1e-12 && (turn - 0.2 / 0.3).abs() < 1e-12);
        for bad in [
            "",
            "0.4",
            "0.4 0.6 0.8",
            "nan 0.1",
            r#"{"v_mps":1e999,"w_radps":0}"#,
            "x y",
        ] {
            assert_eq!(v(bad), None, "{bad}");
        }
    }

    /// The first `n` scans a single-laser emulator of `frame` serves.
    fn alone(frame: Option<&str>, n: usize) -> Vec<Vec<u32>> {
        let scenario = Scenario::resolve("all_round").unwrap().0;
        let (mut scans, _) = simulated_scans(&scenario, 4, frame).unwrap();
        (0..n)
            .map(|i| {
                let mut r = Vec::new();
                scans.scan(i as u64, &mut r);
                r
            })
            .collect()
    }

    /// Two scanners served from one simulation get the scans each would get alone (the
    /// same world, the same robot), however their reads interleave; a scanner nobody
    /// reads keeps only its newest few.
    #[test]
    fn one_simulation_serves_each_scanner_its_own_scans() {
        let scenario = Scenario::resolve("all_round").unwrap().0;
        let with_rear = || {
            let (scans, _) = simulated_scans(&scenario, 4, None).unwrap();
            scans.with_extra_laser("rear_laser").unwrap().0
        };
        assert!(with_rear().with_extra_laser("rear_laser").is_err());
        assert!(with_rear().with_extra_laser("no_such_laser").is_err());
        let mut lasers = with_rear().shared();
        let (front, rear) = (alone(None, 5), alone(Some("rear_laser"), 24));
        let mut next = |k: usize| {
            let mut r = Vec::new();
            lasers[k].scan(0, &mut r);
            r
        };
        // Front three ahead, then the rear catches up, then in turns.
        let mut got = [Vec::new(), Vec::new()];
        for k in [0, 0, 0, 1, 1, 1, 1, 0, 1, 0, 1] {
            got[k].push(next(k));
        }
        assert_eq!(got[0], front[..5]);
        assert_eq!(got[1], rear[..6]);
        assert_ne!(front[0], rear[0]);
        // Ten front scans with nobody reading the rear: it keeps its newest four.
        for _ in 0..10 {
            next(0);
        }
        let kept = next(1);
        let at = rear.iter().position(|r| *r == kept);
        assert!(at.is_some_and(|i| i > 7), "served rear scan {at:?}");
    }
}
