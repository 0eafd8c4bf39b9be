//! What drives the simulated robot until (and besides) tether's own follower.
//!
//! A [`Driver`] sees every sensor event and may change the command. The drivers here
//! serve the simulator's own tests and demos: [`OracleFollower`] reads the *true*
//! position of the target from the ground truth, which no real follower can do; its
//! results say nothing about tether's estimator.

use tether_core::{Stamp, wrap_angle_rad};

use crate::robot::Command;
use crate::scenario::{DriverKind, Scenario, ScriptedCommand};
use crate::sim::{Event, SensorData};

/// Produces robot commands from sensor events.
pub trait Driver {
    /// Called after every sensor event; returns the command to follow from now on, or
    /// `None` to keep the current one.
    fn on_event(&mut self, event: &Event) -> Option<Command>;
}

/// Never moves.
#[derive(Debug, Clone, Default)]
pub struct Still;

impl Driver for Still {
    fn on_event(&mut self, _event: &Event) -> Option<Command> {
        Some(Command::STOP)
    }
}

/// Plays a list of timed commands.
#[derive(Debug, Clone)]
pub struct Scripted {
    script: Vec<ScriptedCommand>,
}

impl Scripted {
    /// A driver playing `script` (sorted by `at_s`).
    pub fn new(script: Vec<ScriptedCommand>) -> Self {
        Scripted { script }
    }

    /// The command in force at `stamp`.
    pub fn command_at(&self, stamp: Stamp) -> Command {
        let t = stamp.secs_f64();
        self.script
            .iter()
            .rev()
            .find(|c| c.at_s <= t)
            .map_or(Command::STOP, |c| Command {
                v_mps: c.v_mps,
                w_radps: c.w_radps,
            })
    }
}

impl Driver for Scripted {
    fn on_event(&mut self, event: &Event) -> Option<Command> {
        Some(self.command_at(event.truth.stamp))
    }
}

/// Follows the target using ground truth: a test driver for the simulator.
///
/// A proportional law on the true range and bearing with a feed-forward of the target's
/// true speed: `v = v_target,x + k_d (d - d0)`, `w = k_b * bearing`, clamped; it stops
/// when the target is closer than 0.5 m or hidden from the laser, and never drives
/// towards a laser return within 0.35 m of its footprint. It acts on scans only.
#[derive(Debug, Clone)]
pub struct OracleFollower {
    /// Follow distance, m.
    pub follow_distance_m: f64,
    /// Gain on the distance error, 1/s.
    pub k_distance: f64,
    /// Gain on the bearing, 1/s.
    pub k_bearing: f64,
    /// Speed limit, m/s.
    pub max_speed_mps: f64,
    /// Turn-rate limit, rad/s.
    pub max_turn_radps: f64,
    /// Footprint radius of the robot, m.
    pub robot_radius_m: f64,
    /// Free space kept ahead of the footprint, m.
    pub stop_distance_m: f64,
}

impl OracleFollower {
    /// An oracle follower keeping `follow_distance_m` for a robot of `robot_radius_m`.
    pub fn new(follow_distance_m: f64, robot_radius_m: f64) -> Self {
        OracleFollower {
            follow_distance_m,
            k_distance: 1.2,
            k_bearing: 2.5,
            max_speed_mps: 1.5,
            max_turn_radps: 2.0,
            robot_radius_m,
            stop_distance_m: 0.35,
        }
    }
}

impl Driver for OracleFollower {
    fn on_event(&mut self, event: &Event) -> Option<Command> {
        let truth = &event.truth;
        let Some(target) = truth.target() else {
            return Some(Command::STOP);
        };
        // It sees perfectly but not through walls: when no beam of a scan reaches the
        // target it stops, as a follower should when its target is lost. Camera events
        // keep the last command.
        match target.laser_beams {
            None => return None,
            Some(0) => return Some(Command::STOP),
            Some(_) => {}
        }
        let robot_from_world = truth.world_from_robot.inverse();
        let p = robot_from_world * target.position;
        let v_target = truth.world_from_robot.inverse().rotate(target.velocity);
        let d = p.range_m();
        let bearing = wrap_angle_rad(p.bearing_rad());
        if d < 0.5 {
            return Some(Command::STOP);
        }
        let along = v_target.x.max(0.0) * bearing.cos().max(0.0);
        let v =
            (along + self.k_distance * (d - self.follow_distance_m)).clamp(0.0, self.max_speed_mps);
        // Slow down while turning hard so the target stays in front.
        let mut v = v * bearing.cos().max(0.0);
        // Never drive into something the laser sees just ahead (turning stays allowed).
        if let SensorData::Scan(scan) = &event.data {
            let robot_from_laser = truth.world_from_robot.inverse() * truth.world_from_laser;
            let blocked = scan.points().any(|(_, p)| {
                let q = robot_from_laser * p;
                q.x > 0.0
                    && q.x < self.robot_radius_m + self.stop_distance_m
                    && q.y.abs() < self.robot_radius_m + 0.05
            });
            if blocked {
                v = 0.0;
            }
        }
        let w = (self.k_bearing * bearing).clamp(-self.max_turn_radps, self.max_turn_radps);
        Some(Command {
            v_mps: v,
            w_radps: w,
        })
    }
}

/// The driver the scenario asks for.
pub fn driver_for(scenario: &Scenario) -> Box<dyn Driver> {
    match scenario.robot.driver {
        DriverKind::Still => Box::new(Still),
        DriverKind::Scripted => Box::new(Scripted::new(scenario.robot.script.clone())),
        DriverKind::Oracle => Box::new(OracleFollower::new(
            scenario.robot.follow_distance_m,
            scenario.robot.radius_m,
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn script_holds_each_command_until_the_next() {
        let s = Scripted::new(vec![
            ScriptedCommand {
                at_s: 1.0,
                v_mps: 0.5,
                w_radps: 0.0,
            },
            ScriptedCommand {
                at_s: 3.0,
                v_mps: 0.0,
                w_radps: 1.0,
            },
        ]);
        assert_eq!(s.command_at(Stamp::from_ns(500_000_000)), Command::STOP);
        assert_eq!(s.command_at(Stamp::from_ns(2_000_000_000)).v_mps, 0.5);
        assert_eq!(s.command_at(Stamp::from_ns(5_000_000_000)).w_radps, 1.0);
    }
}
