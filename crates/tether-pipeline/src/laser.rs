//! The laser's side of a tick (design 5.5): the people found in a scan become
//! observations in the world frame, those standing in learned static clutter are left
//! out, those the last scan could not see are marked as coming out of a shadow, the
//! tracker takes them, tracks this scan could not see are marked as hidden
//! ([`Shadow`]), and the clutter maps learn what no walking person explains.
//!
//! A robot may carry several scanners (front and rear, left and right): each is a
//! [`LaserSide`] with its own mount, detector, field of view and last returns, and its
//! scans are told apart by their `frame_id`. Their people all go to the one tracker in
//! the world frame, so that a person two scanners see is one track; the obstacle stop
//! and the trail take the returns of every scanner (design 5.7).

use tether_core::{Gaussian2, Laser, LaserModel, LaserScan, Point2, Pose2, Robot, Stamp, World};
use tether_fusion::{ClutterConfig, ClutterMap, Observation, Shadow, TargetState};
use tether_laser::preprocess::BeamTable;
use tether_laser::{Detection, LegClassifier, LegDetector, PersonKind};

use crate::{
    FusionMode, LaserMemory, LaserPerson, LegsConfig, Pipeline, PipelineError, Tick, TickInput,
    config_err, follow, leg_detector,
};

/// One scanner's side of the pipeline: its model, which scans are its, its leg detector,
/// and what its last scan left.
#[derive(Debug)]
pub(crate) struct LaserSide {
    /// The scans' `frame_id`; `None` for the first laser, which takes every scan whose
    /// frame no other laser names (with one laser: every scan).
    pub(crate) frame_id: Option<String>,
    pub(crate) model: LaserModel,
    detector: LegDetector,
    /// The beams' directions, kept between scans (no trigonometry per return).
    beams: BeamTable,
    /// The field of view of the last scan: first and last beam directions, rad, and
    /// the longest range, m.
    view: Option<(f64, f64, f64)>,
    /// Static clutter in this laser's frame (the robot's own parts, which move with it).
    clutter: ClutterMap<Laser>,
    /// The stamp of the last scan.
    pub(crate) last_scan: Option<Stamp>,
    /// The robot's pose at the last scan (with `returns`, what it could not see).
    last_scan_pose: Option<Pose2<World, Robot>>,
    /// The last scan's returns, robot frame.
    pub(crate) returns: Vec<Point2<Robot>>,
    /// Those of them that can be in the way within the stop distance (the obstacle
    /// stop), kept from scan to scan.
    pub(crate) near: Vec<Point2<Robot>>,
    /// The last scan's people (world) and the velocity of the track each updated, to
    /// carry them to a camera frame's time.
    pub(crate) people: Option<(Stamp, Vec<LaserMemory>)>,
}

impl LaserSide {
    pub(crate) fn new(
        frame_id: Option<String>,
        model: LaserModel,
        legs: &LegsConfig,
        clutter: &ClutterConfig,
        classifier: Option<LegClassifier>,
    ) -> Result<Self, PipelineError> {
        let part = if frame_id.is_some() {
            "extra_lasers"
        } else {
            "laser"
        };
        model.validate().map_err(|e| config_err(part, e))?;
        Ok(LaserSide {
            frame_id,
            detector: leg_detector(legs, model.noise.clone(), classifier)?,
            model,
            beams: BeamTable::default(),
            view: None,
            clutter: ClutterMap::new(clutter.clone()).map_err(|e| config_err("clutter", e))?,
            last_scan: None,
            last_scan_pose: None,
            returns: Vec::new(),
            near: Vec::new(),
            people: None,
        })
    }

    /// The laser frame in the robot frame.
    pub(crate) fn robot_from_laser(&self) -> Pose2<Robot, Laser> {
        self.model.robot_from_laser()
    }

    /// Whether this laser would see a world point: within the last scan's beams and
    /// longest range (before the first scan, the laser model's).
    pub(crate) fn sees(
        &self,
        world_from_robot: Pose2<World, Robot>,
    ) -> impl Fn(Point2<World>) -> bool + use<> {
        let laser_from_world = (world_from_robot * self.robot_from_laser()).inverse();
        let (first, last, reach) = self.view.unwrap_or((
            self.model.geometry.angle_min_rad(),
            self.model.geometry.angle_max_rad(),
            self.model.range_max_m,
        ));
        move |p: Point2<World>| {
            let q = laser_from_world * p;
            q.range_m() <= reach && (first..=last).contains(&q.bearing_rad())
        }
    }

    /// Whether a world point stands in this laser's learned clutter at `stamp`, for
    /// the robot at `world_from_robot`.
    pub(crate) fn clutter_at(
        &self,
        world_from_robot: Pose2<World, Robot>,
        stamp: Stamp,
    ) -> impl Fn(Point2<World>) -> bool + '_ {
        let laser_from_world = (world_from_robot * self.robot_from_laser()).inverse();
        move |p: Point2<World>| self.clutter.is_static(laser_from_world * p, stamp)
    }
}

/// The people of a detection as the pipeline takes them: the strong ones, the
/// unconfirmed legs, then the weak candidates.
fn people_of(detection: &Detection) -> Vec<LaserPerson> {
    detection
        .people
        .iter()
        .map(|p| LaserPerson {
            estimate: p.estimate,
            two_legs: matches!(p.kind, PersonKind::TwoLegs(_)),
            weak: false,
            unconfirmed: false,
        })
        .chain(detection.unconfirmed_people.iter().map(|p| LaserPerson {
            estimate: p.estimate,
            two_legs: false,
            weak: false,
            unconfirmed: true,
        }))
        .chain(detection.weak_people.iter().map(|p| LaserPerson {
            estimate: p.estimate,
            two_legs: false,
            weak: true,
            unconfirmed: false,
        }))
        .collect()
}

impl Pipeline {
    /// One laser scan, with the robot's pose at its stamp: leg detection, then
    /// [`Pipeline::on_laser_people`]. The scan is the laser's whose `frame_id` it
    /// carries (`[[extra_lasers]]`), else the first laser's.
    pub fn on_scan(&mut self, scan: &LaserScan, world_from_robot: Pose2<World, Robot>) -> Tick {
        self.stats.malformed_beams += scan.malformed_beams() as u64;
        if 2 * scan.malformed_beams() > scan.len() {
            // Mostly NaN or negative ranges: a sick sensor, not an empty room. The scan
            // neither feeds the tracks nor counts as fresh data, so the watchdog stops
            // the robot rather than let it drive blind.
            self.stats.unusable_scans += 1;
            return self.idle_tick(scan.stamp, TickInput::Scan);
        }
        let k = self.laser_of(&scan.frame_id);
        let mut detection = std::mem::take(&mut self.detection);
        let side = &mut self.lasers[k];
        side.detector.detect_into(scan, &mut detection);
        let people = people_of(&detection);
        let (first, last) = (scan.angle_min_rad, scan.angle_max_rad());
        side.view = Some((first.min(last), first.max(last), scan.range_max_m));
        self.detection = detection;
        let robot_from_laser = side.robot_from_laser().point_map();
        side.beams.update(scan);
        let mut obstacles = std::mem::take(&mut self.scan_obstacles);
        side.beams
            .points_into(scan, robot_from_laser, &mut obstacles);
        let tick = self.on_laser_people_from(k, scan.stamp, &people, &obstacles, world_from_robot);
        self.scan_obstacles = obstacles;
        tick
    }

    /// Where the laser that takes the scans of `frame_id` sits on the robot.
    pub fn robot_from_laser_of(&self, frame_id: &str) -> Pose2<Robot, Laser> {
        self.lasers[self.laser_of(frame_id)].robot_from_laser()
    }

    /// Whether the scans of `frame_id` are the first laser's (no `[[extra_lasers]]`
    /// entry takes them): the ones the scan matcher aligns, at the first laser's mount.
    pub fn is_first_lasers(&self, frame_id: &str) -> bool {
        self.laser_of(frame_id) == 0
    }

    /// Which laser a scan of `frame_id` is from: the extra laser of that frame, else
    /// the first.
    fn laser_of(&self, frame_id: &str) -> usize {
        self.lasers
            .iter()
            .position(|l| l.frame_id.as_deref() == Some(frame_id))
            .unwrap_or(0)
    }

    /// The people found in one scan of the first laser (laser frame) and the scan's
    /// returns (robot frame, for the obstacle stop), with the robot's pose at the
    /// scan's stamp.
    pub fn on_laser_people(
        &mut self,
        stamp: Stamp,
        people: &[LaserPerson],
        obstacles_in_robot: &[Point2<Robot>],
        world_from_robot: Pose2<World, Robot>,
    ) -> Tick {
        self.on_laser_people_from(0, stamp, people, obstacles_in_robot, world_from_robot)
    }

    /// [`Pipeline::on_laser_people`] for laser `k` (0: the first, then the
    /// `[[extra_lasers]]` in order).
    fn on_laser_people_from(
        &mut self,
        k: usize,
        stamp: Stamp,
        people: &[LaserPerson],
        obstacles_in_robot: &[Point2<Robot>],
        world_from_robot: Pose2<World, Robot>,
    ) -> Tick {
        if !self.accept(stamp, world_from_robot) {
            return self.idle_tick(stamp, TickInput::Scan);
        }
        self.scan_gap_s = self.lasers[k]
            .last_scan
            .map_or(0.0, |t| stamp.secs_since(t));
        self.lasers[k].last_scan = Some(stamp);
        self.last_scan = Some(stamp);
        let world_from_laser = world_from_robot * self.lasers[k].robot_from_laser();
        let world: Vec<Gaussian2<World>> = people
            .iter()
            .map(|p| p.estimate.transformed(world_from_laser))
            .collect();
        let near_m = self.obstacle_reach_m();
        follow::keep_mapped(
            obstacles_in_robot,
            |p| p.range_at_most(near_m),
            |p| p,
            &mut self.lasers[k].near,
        );
        // People standing in learned static clutter are clutter: they neither start nor
        // feed tracks (a coasting track walking past a bush must not take it).
        let mut used = Vec::with_capacity(people.len());
        for (p, g) in people.iter().zip(&world) {
            let clutter = self.clutter_world.is_static(g.mean, stamp)
                || self.lasers[k].clutter.is_static(p.estimate.mean, stamp);
            self.stats.clutter_observations += u64::from(clutter);
            used.push(!clutter);
        }
        let tracking =
            self.config.fusion.use_laser && self.config.fusion.mode == FusionMode::Tracker;
        let lone_spawns = self.config.fusion.lone_legs_spawn_tracks;
        let observations: Vec<Observation> = people
            .iter()
            .zip(&world)
            .zip(&used)
            .filter(|(_, used)| **used)
            .map(|((p, g), _)| Observation {
                from_shadow: self.hidden_at_last_scan(k, g.mean),
                ..match (p.weak, p.unconfirmed) {
                    (true, _) => Observation::weak_laser(*g),
                    (false, true) => Observation {
                        may_spawn: false,
                        ..Observation::laser(*g, false, lone_spawns)
                    },
                    (false, false) => Observation::laser(*g, p.two_legs, lone_spawns),
                }
            })
            .collect();
        // This scan is the last one from now on.
        let side = &mut self.lasers[k];
        side.last_scan_pose = Some(world_from_robot);
        side.returns.clear();
        side.returns.extend_from_slice(obstacles_in_robot);
        let track_of = if tracking {
            let track_of = self.tracker.process(stamp, &observations).track_of;
            // Tracks behind the scan's returns went unseen because they could not be seen.
            let robot_from_world = world_from_robot.inverse();
            let shadow = self.shadow_of(k, obstacles_in_robot);
            self.tracker
                .note_shadow(stamp, |p| shadow.hides(robot_from_world * p));
            track_of
        } else {
            self.tracker.advance(stamp);
            vec![None; observations.len()]
        };
        self.learn_clutter(k, stamp, people, &world, &used, &track_of);
        // The people this scan reports (and carries to the next camera frame): the
        // strong observations that were used.
        let (laser_people, track_of): (Vec<Gaussian2<World>>, Vec<Option<u64>>) = observations
            .iter()
            .zip(&track_of)
            .filter(|(o, _)| !o.weak)
            .map(|(o, id)| (o.estimate, *id))
            .unzip();
        let motion = |id: Option<u64>| {
            let t = self.tracker.track(id?)?;
            Some((t.velocity(), t.filter.velocity_cov()?))
        };
        self.lasers[k].people = Some((
            stamp,
            laser_people
                .iter()
                .zip(&track_of)
                .map(|(g, id)| (*g, motion(*id), *id))
                .collect(),
        ));
        let mut tick = self.finish(stamp, TickInput::Scan, world_from_robot);
        tick.laser_people = laser_people;
        tick
    }

    /// The shadows cast by a scan's returns (robot frame) as seen from scanner `k`.
    fn shadow_of<'a>(&self, k: usize, returns_in_robot: &'a [Point2<Robot>]) -> Shadow<'a, Robot> {
        let scanner = self.lasers[k].robot_from_laser() * Point2::<Laser>::ORIGIN;
        let margin_m = self.tracker.config().shadow_margin_m;
        Shadow::new(scanner, returns_in_robot, margin_m)
    }

    /// Whether laser `k`'s last scan could not see `p` (a person found there now comes
    /// out from behind something).
    fn hidden_at_last_scan(&self, k: usize, p: Point2<World>) -> bool {
        let side = &self.lasers[k];
        side.last_scan_pose.is_some_and(|world_from_robot| {
            self.shadow_of(k, &side.returns).hides_near(
                world_from_robot.inverse() * p,
                self.tracker.config().shadow_edge_m,
            )
        })
    }

    /// Teaches the clutter maps this scan's people, except those a walking person (or
    /// the target) explains: the track they updated, or one within half a metre.
    fn learn_clutter(
        &mut self,
        k: usize,
        stamp: Stamp,
        people: &[LaserPerson],
        world: &[Gaussian2<World>],
        used: &[bool],
        track_of_used: &[Option<u64>],
    ) {
        if !self.config.clutter.enabled {
            return;
        }
        let target = match self.selector.state() {
            TargetState::Locked { track } | TargetState::Lost { track, .. } => Some(track),
            TargetState::Searching => None,
        };
        let min_walked_m = self.config.target.min_walked_m;
        let protected: Vec<(u64, Point2<World>)> = self
            .tracker
            .tracks()
            .iter()
            .filter(|t| Some(t.id) == target || (t.confirmed && t.walked_m >= min_walked_m))
            .map(|t| (t.id, t.position().mean))
            .collect();
        let mut track_of = track_of_used.iter();
        let (mut in_world, mut in_laser) = (Vec::new(), Vec::new());
        for ((p, g), &was_used) in people.iter().zip(world).zip(used) {
            let updated = if was_used {
                track_of.next().copied().flatten()
            } else {
                None
            };
            let explained = protected
                .iter()
                .any(|(id, q)| updated == Some(*id) || q.distance_m(g.mean) < 0.5);
            if !explained {
                in_world.push(g.mean);
                in_laser.push(p.estimate.mean);
            }
        }
        self.clutter_world.observe(stamp, &in_world);
        self.lasers[k].clutter.observe(stamp, &in_laser);
    }
}
