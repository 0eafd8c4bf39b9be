//! The simulated laser: 2-D ray casting with the URG-04LX geometry and noise model.
//!
//! Every beam of a scan is cast at the same instant (the scanner's 100 ms sweep is not
//! modelled). For speed, each circle and wall is only tested against the beams inside
//! its angular extent as seen from the scanner, so a scan costs about one test per beam
//! per wall behind it plus a dozen per nearby leg, not beams x primitives.
//!
//! A return is `r + bias(r) + N(0, sigma(r)^2)` from the simulated scanner's own error
//! model (`laser_sim.noise`, not the estimator's `laser.noise`), quantised to the
//! URG-04LX's 1 mm, lost with probability `dropout_prob` plus a long-range term (real
//! beams flicker between valid and invalid near the end of the range) and reported as
//! "no return" when nothing is hit within range.
//!
//! With `laser_sim.realistic` (the default) the scanner also fails the way tether's leg
//! detector sees real URG-04LX scans fail (issue 14; [`LaserSimSpec`]): weak leg
//! returns more likely with range, per-person dark spells (a two-state Markov chain:
//! misses in bursts), one-scan phantom leg-like returns, and foliage whose returns come
//! and go. Those draws come from a stream of their own (`laser/realism`), so switching
//! them off leaves every other draw as it was.
//!
//! Other scanners (the catalogue, [`crate::scanners`]) add no-returns inside objects
//! (`object_beam_loss_prob`, drawn only when it is not zero) and may list their beams
//! clockwise: the scan is cast and drawn counter-clockwise and then reversed, so a
//! clockwise scan holds the same points as its counter-clockwise twin.

use std::f64::consts::{PI, TAU};

use tether_core::{LaserModel, LaserScan, Point2, Pose2, Stamp, Vector2, World};

use crate::geometry::{Circle, Segment, ray_circle_m, ray_segment_m};
use crate::rng::SimRng;
use crate::scenario::{LaserSimSpec, RoomSpec};
use crate::world::{ObstacleKind, StaticWorld};

/// What a beam hit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Hit {
    /// Nothing within range.
    Nothing,
    /// A wall, by index in [`StaticWorld::walls`].
    Wall(u32),
    /// An obstacle, by index in [`StaticWorld::obstacles`].
    Obstacle(u32),
    /// A person's leg: person id and leg (0 left, 1 right).
    Leg {
        /// Person id.
        person: u32,
        /// 0 left, 1 right.
        leg: u8,
    },
    /// A phantom return (realistic mode), by index in
    /// [`SimLaser::last_ghosts`].
    Ghost(u32),
}

/// A dynamic circle seen by the laser (a leg).
#[derive(Debug, Clone, Copy)]
pub struct LegCircle {
    /// The leg at the laser's height.
    pub circle: Circle,
    /// Person id.
    pub person: u32,
    /// 0 left, 1 right.
    pub leg: u8,
}

/// A phantom this near a person's leg (beyond its own radius) goes, m: the clutter it
/// stands for is not where people walk, and a person's legs are judged with the space
/// around them (the detector's context features look as far as a stride, 0.6 m).
const GHOST_CLEARANCE_M: f64 = 0.5;

/// Clutter stands at least this far from the people's paths and the robot's start, m.
pub const CLUTTER_PATH_CLEARANCE_M: f64 = 1.0;

/// The laser of the simulator.
#[derive(Debug, Clone)]
pub struct SimLaser {
    model: LaserModel,
    spec: LaserSimSpec,
    rng: SimRng,
    directions: Vec<(f64, f64)>,
    true_ranges_m: Vec<f64>,
    hits: Vec<Hit>,
    /// Draws of the realistic failures.
    realism_rng: SimRng,
    /// Whether each person (by id) is in a dark spell.
    in_spell: Vec<bool>,
    /// Which legs of the last scan were weak, by person id.
    weak: Vec<[bool; 2]>,
    /// Transient phantoms alive at the last scan, world frame.
    ghosts: Vec<Circle>,
    /// Clutter that stays all run, world frame, and the probability that each piece
    /// shows in a scan ([`SimLaser::with_clutter`]).
    clutter: Vec<(Circle, f64)>,
    /// The phantoms drawn into the last scan (transient ones, then clutter not hidden
    /// by a person), world frame.
    shown: Vec<Circle>,
}

impl SimLaser {
    /// A laser with the given model and dropout behaviour, drawing noise from `rng`.
    pub fn new(model: LaserModel, spec: LaserSimSpec, rng: SimRng) -> Self {
        let n = model.beam_count();
        let a0 = model.geometry.angle_min_rad();
        let inc = model.geometry.angle_increment_rad();
        let directions = (0..n)
            .map(|i| {
                let (s, c) = (a0 + i as f64 * inc).sin_cos();
                (c, s)
            })
            .collect();
        SimLaser {
            model,
            spec,
            rng,
            directions,
            true_ranges_m: vec![f64::INFINITY; n],
            hits: vec![Hit::Nothing; n],
            realism_rng: SimRng::stream(0, "laser/realism"),
            in_spell: Vec::new(),
            weak: Vec::new(),
            ghosts: Vec::new(),
            clutter: Vec::new(),
            shown: Vec::new(),
        }
    }

    /// Adds leg-like clutter that stays in place all run (realistic mode; world frame,
    /// from [`clutter_spots`]), each piece with the probability that it shows in a scan.
    pub fn with_clutter(mut self, clutter: Vec<(Circle, f64)>) -> Self {
        self.clutter = clutter;
        self
    }

    /// Draws the realistic failures from `rng` (by default a fixed stream; the
    /// simulation passes its run's `laser/realism` stream).
    pub fn with_realism_rng(mut self, rng: SimRng) -> Self {
        self.realism_rng = rng;
        self
    }

    /// Which legs of the last scan had weak returns, by person id (empty when not
    /// realistic).
    pub fn last_weak_legs(&self) -> &[[bool; 2]] {
        &self.weak
    }

    /// Whether each person (by id) was in a dark spell at the last scan.
    pub fn last_spells(&self) -> &[bool] {
        &self.in_spell
    }

    /// The phantoms drawn into the last scan (transient ones and clutter), world frame.
    pub fn last_ghosts(&self) -> &[Circle] {
        &self.shown
    }

    /// Draws the phantoms born in this scan (realistic mode): a Poisson number (mean
    /// `ghosts_per_scan`) of leg-sized circles (radius `ghost_radius_m`) on a uniformly
    /// drawn beam, at a range uniform between 0.5 m and 0.1 m short of that beam's true
    /// return (at most 4.5 m), so that every phantom is in sight when it appears; with
    /// probability `ghost_pair_prob` a second one stands 0.2-0.45 m from the first (real
    /// clutter comes in groups: a chair's legs, a bag beside a bin). Each is fixed in
    /// the world until it goes.
    fn birth_ghosts(&mut self, world_from_laser: Pose2<World, tether_core::Laser>) {
        let n = self.directions.len();
        let count = self.realism_rng.poisson(self.spec.ghosts_per_scan);
        let [r_lo, r_hi] = self.spec.ghost_radius_m;
        for _ in 0..count {
            let rng = &mut self.realism_rng;
            let beam = ((rng.unit() * n as f64) as usize).min(n.saturating_sub(1));
            let radius_m = rng.uniform(r_lo, r_hi);
            let far_m = self
                .true_ranges_m
                .get(beam)
                .copied()
                .unwrap_or(f64::INFINITY)
                .min(4.5)
                - 0.1;
            let u = rng.unit();
            if far_m <= 0.5 {
                continue;
            }
            // Distance to the circle's centre: the near side at `range`.
            let centre_m = 0.5 + u * (far_m - 0.5) + radius_m;
            let (dx, dy) = self.directions[beam];
            let centre =
                world_from_laser * Point2::<tether_core::Laser>::new(centre_m * dx, centre_m * dy);
            let center = Point2::<World>::new(centre.x, centre.y);
            self.ghosts.push(Circle { center, radius_m });
            if rng.chance(self.spec.ghost_pair_prob) {
                self.ghosts
                    .push(companion(center, self.spec.ghost_radius_m, rng));
            }
        }
    }

    /// Writes the live phantoms into the cast ranges: each beam a phantom covers reads
    /// the circle's near side where that is nearer than the world and within range. A
    /// beam on a person's leg keeps it: the phantoms stand for clutter, which people
    /// walk around, not through.
    fn add_ghosts(
        &mut self,
        world_from_laser: Pose2<World, tether_core::Laser>,
        legs: &[LegCircle],
    ) {
        if !self.spec.realistic {
            return;
        }
        self.birth_ghosts(world_from_laser);
        // Clutter is not where people walk: a transient phantom a leg comes near goes,
        // and clutter a leg is near is not drawn while it is.
        let clear = |g: &Circle| {
            legs.iter()
                .all(|l| l.circle.center.distance_m(g.center) > GHOST_CLEARANCE_M + g.radius_m)
        };
        self.ghosts.retain(clear);
        self.shown.clear();
        self.shown.extend(self.ghosts.iter().copied());
        for &(spot, shown_prob) in &self.clutter {
            if clear(&spot) && self.realism_rng.chance(shown_prob) {
                self.shown.push(spot);
            }
        }
        let n = self.directions.len();
        let a0 = self.model.geometry.angle_min_rad();
        let inc = self.model.geometry.angle_increment_rad();
        let closes_circle = n as f64 * inc >= TAU - 1.5 * inc;
        let range_max_m = self.model.range_max_m;
        let laser_from_world = world_from_laser.inverse();
        for (k, ghost) in self.shown.iter().enumerate() {
            let p = laser_from_world * Point2::<World>::new(ghost.center.x, ghost.center.y);
            let local = Circle {
                center: Point2::<World>::new(p.x, p.y),
                radius_m: ghost.radius_m,
            };
            let centre_m = p.x.hypot(p.y);
            if centre_m <= ghost.radius_m || centre_m - ghost.radius_m > range_max_m {
                continue;
            }
            let mut bearing = p.y.atan2(p.x) - a0;
            if closes_circle {
                bearing = bearing.rem_euclid(TAU);
            }
            let mid = (bearing / inc).round() as i64;
            let span = ((ghost.radius_m / centre_m).asin() / inc).ceil() as i64 + 1;
            for j in mid - span..=mid + span {
                let i = if closes_circle {
                    j.rem_euclid(n as i64) as usize
                } else if (0..n as i64).contains(&j) {
                    j as usize
                } else {
                    continue;
                };
                let (cx, cy) = self.directions[i];
                if !matches!(self.hits[i], Hit::Leg { .. })
                    && let Some(t) = ray_circle_m(Point2::ORIGIN, Vector2::new(cx, cy), &local)
                    && t < self.true_ranges_m[i]
                    && t <= range_max_m
                {
                    self.true_ranges_m[i] = t;
                    self.hits[i] = Hit::Ghost(k as u32);
                }
            }
        }
    }

    /// Phantoms of the last scan that go before this one: each lasts a geometric number
    /// of scans of mean `ghost_mean_scans`.
    fn age_ghosts(&mut self) {
        let leave = 1.0 / self.spec.ghost_mean_scans.max(1.0);
        let rng = &mut self.realism_rng;
        self.ghosts.retain(|_| !rng.chance(leave));
    }

    /// Steps the dark-spell chains and draws the weak legs and the phantoms of one
    /// scan.
    fn draw_failures(
        &mut self,
        world_from_laser: Pose2<World, tether_core::Laser>,
        legs: &[LegCircle],
    ) {
        self.weak.clear();
        if !self.spec.realistic {
            self.ghosts.clear();
            self.shown.clear();
            return;
        }
        self.age_ghosts();
        let spec = &self.spec;
        let rng = &mut self.realism_rng;
        let n_people = legs
            .iter()
            .map(|l| l.person as usize + 1)
            .max()
            .unwrap_or(0);
        if self.in_spell.len() < n_people {
            self.in_spell.resize(n_people, false);
        }
        self.weak.resize(n_people, [false; 2]);
        // Two-state chain per person, one step per scan: enter with spell_start_prob,
        // leave with 1 / spell_mean_scans (a geometric duration of that mean).
        let leave = 1.0 / spec.spell_mean_scans.max(1.0);
        for spell in self.in_spell.iter_mut() {
            *spell = if *spell {
                !rng.chance(leave)
            } else {
                rng.chance(spec.spell_start_prob)
            };
        }
        let origin = world_from_laser.translation();
        for l in legs {
            let range_m = l.circle.center.distance_m(origin);
            let p = if self.in_spell[l.person as usize] {
                spec.spell_weak_leg_prob
            } else {
                spec.weak_leg_prob(range_m)
            };
            self.weak[l.person as usize][usize::from(l.leg.min(1))] = rng.chance(p);
        }
    }

    /// The laser's model.
    pub fn model(&self) -> &LaserModel {
        &self.model
    }

    /// What each beam of the last scan hit (ground truth).
    pub fn last_hits(&self) -> &[Hit] {
        &self.hits
    }

    /// Noise-free ranges of the last scan (`inf` for no hit), m.
    pub fn last_true_ranges_m(&self) -> &[f64] {
        &self.true_ranges_m
    }

    /// Casts one scan from `world_from_laser`.
    pub fn scan(
        &mut self,
        stamp: Stamp,
        world_from_laser: Pose2<World, tether_core::Laser>,
        world: &StaticWorld,
        legs: &[LegCircle],
    ) -> Result<LaserScan, tether_core::ScanError> {
        self.draw_failures(world_from_laser, legs);
        self.cast(world_from_laser, world, legs);
        self.add_ghosts(world_from_laser, legs);
        let n = self.directions.len();
        let mut ranges = Vec::with_capacity(n);
        let range_max = self.model.range_max_m;
        let span = (range_max - self.spec.long_range_start_m).max(1e-6);
        for i in 0..n {
            let r = self.true_ranges_m[i];
            if !r.is_finite() || r > range_max + 0.1 {
                ranges.push(f32::INFINITY);
                continue;
            }
            let object_loss = self.spec.object_beam_loss_prob;
            if object_loss > 0.0 && self.rng.chance(object_loss) {
                ranges.push(f32::INFINITY);
                continue;
            }
            let noise = &self.spec.noise;
            let mut measured = r + noise.bias_m(r) + self.rng.normal(0.0, noise.sigma_m(r));
            if self.spec.realistic {
                match self.hits[i] {
                    Hit::Leg { person, leg }
                        if self
                            .weak
                            .get(person as usize)
                            .is_some_and(|w| w[usize::from(leg.min(1))]) =>
                    {
                        if self.realism_rng.chance(self.spec.weak_beam_loss_prob) {
                            ranges.push(f32::INFINITY);
                            continue;
                        }
                        measured += self.realism_rng.normal(0.0, self.spec.weak_range_sigma_m);
                    }
                    Hit::Obstacle(k)
                        if world.obstacles.get(k as usize).map(|o| o.kind)
                            == Some(ObstacleKind::Foliage)
                            && self.realism_rng.chance(self.spec.foliage_beam_loss_prob) =>
                    {
                        ranges.push(f32::INFINITY);
                        continue;
                    }
                    _ => {}
                }
            }
            let far = ((r - self.spec.long_range_start_m) / span).clamp(0.0, 1.0);
            let p_drop = self.spec.dropout_prob + self.spec.long_range_dropout_prob * far;
            if self.rng.chance(p_drop) {
                ranges.push(f32::INFINITY);
                continue;
            }
            ranges.push(((measured * 1000.0).round() / 1000.0) as f32);
        }
        let g = &self.model.geometry;
        if g.clockwise {
            // Cast and drawn counter-clockwise; listed clockwise, the truth with them.
            ranges.reverse();
            self.hits.reverse();
            self.true_ranges_m.reverse();
        }
        LaserScan::new(
            stamp,
            <tether_core::Laser as tether_core::Frame>::NAME,
            g.first_beam_angle_rad(),
            g.beam_increment_rad(),
            self.model.range_min_m,
            self.model.range_max_m,
            ranges,
        )
    }

    fn cast(
        &mut self,
        world_from_laser: Pose2<World, tether_core::Laser>,
        world: &StaticWorld,
        legs: &[LegCircle],
    ) {
        self.true_ranges_m.fill(f64::INFINITY);
        self.hits.fill(Hit::Nothing);
        let laser_from_world = world_from_laser.inverse();
        let a0 = self.model.geometry.angle_min_rad();
        let inc = self.model.geometry.angle_increment_rad();
        let n = self.directions.len();
        let max_range = self.model.range_max_m + 0.1;
        let to_laser = |p: Point2<World>| {
            let q = laser_from_world * p;
            Point2::<World>::new(q.x, q.y)
        };
        let origin = Point2::<World>::ORIGIN;

        // Beams inside the angular interval [lo, hi] (rad, laser frame), any wrap.
        let beam_ranges = move |lo: f64, hi: f64| {
            let rel_lo = lo - a0;
            let rel_hi = hi - a0;
            let base = (rel_lo / TAU).floor() * TAU;
            [base - TAU, base, base + TAU]
                .into_iter()
                .filter_map(move |shift| {
                    let first = ((rel_lo - shift) / inc).ceil().max(0.0);
                    let last = ((rel_hi - shift) / inc).floor().min(n as f64 - 1.0);
                    (first <= last).then_some(first as usize..=last as usize)
                })
        };

        let laser_height_m = self.model.mount.height_m;
        let circles = world
            .obstacles
            .iter()
            .enumerate()
            .filter(|(_, o)| o.kind.top_m() > laser_height_m)
            .map(|(i, o)| (o.circle, Hit::Obstacle(i as u32)))
            .chain(legs.iter().map(|l| {
                (
                    l.circle,
                    Hit::Leg {
                        person: l.person,
                        leg: l.leg,
                    },
                )
            }));
        for (circle, hit) in circles {
            let c = to_laser(circle.center);
            let d = c.range_m();
            if d - circle.radius_m > max_range || d <= circle.radius_m {
                continue;
            }
            let half = (circle.radius_m / d).asin();
            let bearing = c.bearing_rad();
            let local = Circle {
                center: c,
                radius_m: circle.radius_m,
            };
            for range in beam_ranges(bearing - half, bearing + half) {
                for i in range {
                    let (dx, dy) = self.directions[i];
                    if let Some(t) = ray_circle_m(origin, Vector2::new(dx, dy), &local)
                        && t < self.true_ranges_m[i]
                    {
                        self.true_ranges_m[i] = t;
                        self.hits[i] = hit;
                    }
                }
            }
        }
        for (wi, wall) in world.walls.iter().enumerate() {
            let seg = Segment::new(to_laser(wall.a), to_laser(wall.b));
            if seg.closest_point(origin).range_m() > max_range {
                continue;
            }
            let ba = seg.a.bearing_rad();
            let bb = seg.b.bearing_rad();
            let (mut lo, mut hi) = if ba <= bb { (ba, bb) } else { (bb, ba) };
            if hi - lo > PI {
                // The wall spans the +-pi direction: the short way round.
                (lo, hi) = (hi, lo + TAU);
            }
            for range in beam_ranges(lo - inc, hi + inc) {
                for i in range {
                    let (dx, dy) = self.directions[i];
                    if let Some(t) = ray_segment_m(origin, Vector2::new(dx, dy), &seg)
                        && t < self.true_ranges_m[i]
                    {
                        self.true_ranges_m[i] = t;
                        self.hits[i] = Hit::Wall(wi as u32);
                    }
                }
            }
        }
        for i in 0..n {
            if self.true_ranges_m[i] > max_range {
                self.true_ranges_m[i] = f64::INFINITY;
                self.hits[i] = Hit::Nothing;
            }
        }
    }
}

/// The second piece of a pair of phantoms or clutter: 0.2-0.45 m from `center` in a
/// uniformly drawn direction, its radius uniform in `radius_m` (real clutter comes in
/// groups: a chair's legs, a bag beside a bin).
fn companion(center: Point2<World>, radius_m: [f64; 2], rng: &mut SimRng) -> Circle {
    let gap_m = rng.uniform(0.2, 0.45);
    let (s, c) = rng.uniform(0.0, TAU).sin_cos();
    Circle {
        center: Point2::new(center.x + gap_m * c, center.y + gap_m * s),
        radius_m: rng.uniform(radius_m[0], radius_m[1]),
    }
}

/// Leg-like clutter spread over the floor of `world`'s rooms (realistic mode): a
/// Poisson number of spots (mean `clutter_per_m2` times each room's area), each uniform
/// in its room at least 0.3 m clear of walls and obstacles and [`CLUTTER_PATH_CLEARANCE_M`]
/// clear of the `walkways` (the people's paths and the robot's start: people walk around
/// clutter, and the robot follows them), a circle of radius
/// `ghost_radius_m` with a second one 0.2-0.45 m beside it with probability
/// `ghost_pair_prob`: the bags, boxes, bins and chair columns of a real room. Each piece
/// shows as a leg-like blob in a scan with its own probability, uniform in
/// `clutter_shown_prob` (both of a pair alike): real clutter looks like a leg now and
/// then, as the noise, the light and the point of view change.
pub fn clutter_spots(
    rooms: &[RoomSpec],
    walkways: &[Segment],
    world: &StaticWorld,
    spec: &LaserSimSpec,
    rng: &mut SimRng,
) -> Vec<(Circle, f64)> {
    let mut spots = Vec::new();
    if !spec.realistic || spec.clutter_per_m2 <= 0.0 {
        return spots;
    }
    let [r_lo, r_hi] = spec.ghost_radius_m;
    let [q_lo, q_hi] = spec.clutter_shown_prob;
    let clear = |c: &Circle| {
        world.clearance_m(c.center) >= c.radius_m + 0.3
            && walkways
                .iter()
                .all(|w| w.closest_point(c.center).distance_m(c.center) >= CLUTTER_PATH_CLEARANCE_M)
    };
    for room in rooms {
        let ([x0, y0], [x1, y1]) = (room.min, room.max);
        let area_m2 = (x1 - x0).max(0.0) * (y1 - y0).max(0.0);
        let count = rng.poisson(spec.clutter_per_m2 * area_m2);
        for _ in 0..count {
            let center = Point2::<World>::new(rng.uniform(x0, x1), rng.uniform(y0, y1));
            let spot = Circle {
                center,
                radius_m: rng.uniform(r_lo, r_hi),
            };
            let shown_prob = rng.uniform(q_lo, q_hi);
            if !clear(&spot) {
                continue;
            }
            spots.push((spot, shown_prob));
            if rng.chance(spec.ghost_pair_prob) {
                let second = companion(center, spec.ghost_radius_m, rng);
                if clear(&second) {
                    spots.push((second, shown_prob));
                }
            }
        }
    }
    spots
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::{Obstacle, ObstacleKind};

    fn quiet_laser() -> SimLaser {
        let model = LaserModel::urg_04lx();
        let mut spec = LaserSimSpec {
            dropout_prob: 0.0,
            long_range_dropout_prob: 0.0,
            ..LaserSimSpec::ideal()
        };
        spec.noise.sigma_m = tether_core::Polynomial(vec![0.0]);
        spec.noise.sigma_floor_m = 1e-9;
        SimLaser::new(model, spec, SimRng::stream(0, "laser"))
    }

    /// Brute force: every beam against every primitive.
    fn brute_force(
        laser: &SimLaser,
        pose: Pose2<World, tether_core::Laser>,
        world: &StaticWorld,
    ) -> Vec<f64> {
        laser
            .directions
            .iter()
            .map(|&(c, s)| {
                let origin = pose.translation();
                let dir = pose.rotate(Vector2::new(c, s));
                let dir = Vector2::<World>::new(dir.x, dir.y);
                let mut best = f64::INFINITY;
                for o in &world.obstacles {
                    if let Some(t) = ray_circle_m(origin, dir, &o.circle) {
                        best = best.min(t);
                    }
                }
                for w in &world.walls {
                    if let Some(t) = ray_segment_m(origin, dir, w) {
                        best = best.min(t);
                    }
                }
                if best > laser.model.range_max_m + 0.1 {
                    f64::INFINITY
                } else {
                    best
                }
            })
            .collect()
    }

    #[test]
    fn culled_casting_matches_brute_force() {
        let scenario = crate::Scenario::builtin("office").unwrap();
        let world = StaticWorld::from_scenario(&scenario);
        let mut laser = quiet_laser();
        let mut rng = SimRng::stream(3, "poses");
        for _ in 0..40 {
            let pose = Pose2::new(
                rng.uniform(1.0, 9.0),
                rng.uniform(1.0, 7.0),
                rng.uniform(-PI, PI),
            );
            laser.cast(pose, &world, &[]);
            let fast = laser.true_ranges_m.clone();
            let slow = brute_force(&laser, pose, &world);
            for (i, (a, b)) in fast.iter().zip(&slow).enumerate() {
                assert!(
                    (a.is_infinite() && b.is_infinite()) || (a - b).abs() < 1e-9,
                    "beam {i}: {a} vs {b}"
                );
            }
        }
    }

    #[test]
    fn noise_free_scan_sees_a_pillar_at_the_right_range() {
        let world = StaticWorld {
            walls: vec![],
            obstacles: vec![Obstacle {
                circle: Circle {
                    center: Point2::new(2.0, 0.0),
                    radius_m: 0.2,
                },
                kind: ObstacleKind::Pillar,
            }],
        };
        let mut laser = quiet_laser();
        let scan = laser
            .scan(Stamp::ZERO, Pose2::IDENTITY, &world, &[])
            .unwrap();
        assert_eq!(scan.len(), 682);
        // Front beam is index 384 - 44 = 340.
        assert!((scan.range_m(340).unwrap() - 1.8).abs() < 0.0011);
        assert_eq!(scan.range_m(0), None);
        assert!(laser.last_hits()[340] == Hit::Obstacle(0));
    }

    /// An open field with one still person 2 m ahead.
    fn person_ahead() -> Vec<LegCircle> {
        [(0u8, -0.12), (1u8, 0.12)]
            .into_iter()
            .map(|(leg, y_m)| LegCircle {
                circle: Circle {
                    center: Point2::new(2.0, y_m),
                    radius_m: 0.06,
                },
                person: 0,
                leg,
            })
            .collect()
    }

    #[test]
    fn the_ideal_sensor_has_no_failures_and_the_realistic_one_has_them_at_their_rates() {
        let world = StaticWorld::default();
        let legs = person_ahead();
        let mut ideal = SimLaser::new(
            LaserModel::urg_04lx(),
            LaserSimSpec::ideal(),
            SimRng::stream(1, "laser"),
        );
        for k in 0..50 {
            ideal
                .scan(Stamp::from_ns(k), Pose2::IDENTITY, &world, &legs)
                .unwrap();
            assert!(ideal.last_ghosts().is_empty());
            assert!(ideal.last_weak_legs().iter().all(|w| w == &[false, false]));
        }
        let spec = LaserSimSpec::default();
        let mut real = SimLaser::new(
            LaserModel::urg_04lx(),
            spec.clone(),
            SimRng::stream(1, "laser"),
        )
        .with_realism_rng(SimRng::stream(1, "laser/realism"));
        let n = 80_000;
        let (mut ghosts, mut weak, mut spell_scans, mut spells) = (0usize, 0usize, 0usize, 0usize);
        let mut was_in_spell = false;
        for k in 0..n {
            real.scan(Stamp::from_ns(k), Pose2::IDENTITY, &world, &legs)
                .unwrap();
            ghosts += real.last_ghosts().len();
            let in_spell = real.last_spells()[0];
            if in_spell {
                spell_scans += 1;
                spells += usize::from(!was_in_spell);
            } else {
                weak += real.last_weak_legs()[0].iter().filter(|w| **w).count();
            }
            was_in_spell = in_spell;
        }
        let n = n as f64;
        // In the steady state a scan holds the phantoms of the last ghost_mean_scans
        // scans' births, each birth one or two (a few go beside the person's legs).
        let ghost_rate = ghosts as f64 / n;
        let expected = spec.ghosts_per_scan * (1.0 + spec.ghost_pair_prob) * spec.ghost_mean_scans;
        assert!(
            (ghost_rate - expected).abs() < 0.1 * expected,
            "{ghost_rate} against {expected}"
        );
        let mean_spell = spell_scans as f64 / spells as f64;
        assert!(
            (mean_spell - spec.spell_mean_scans).abs() < 0.6,
            "{mean_spell}"
        );
        let p_weak = weak as f64 / (2.0 * (n - spell_scans as f64));
        let expected = spec.weak_leg_prob(2.0 - 0.0);
        assert!((p_weak - expected).abs() < 0.01, "{p_weak} vs {expected}");
    }

    #[test]
    fn a_weak_leg_loses_returns_and_reads_noisier() {
        let world = StaticWorld::default();
        let legs = person_ahead();
        let mut spec = LaserSimSpec {
            dropout_prob: 0.0,
            ghosts_per_scan: 0.0,
            spell_start_prob: 0.0,
            weak_leg_prob_near: 1.0,
            weak_leg_prob_far: 1.0,
            ..LaserSimSpec::default()
        };
        let mut weak = SimLaser::new(
            LaserModel::urg_04lx(),
            spec.clone(),
            SimRng::stream(2, "laser"),
        );
        spec.weak_leg_prob_near = 0.0;
        spec.weak_leg_prob_far = 0.0;
        let mut strong = SimLaser::new(LaserModel::urg_04lx(), spec, SimRng::stream(2, "laser"));
        let (mut lost_weak, mut lost_strong) = (0u32, 0u32);
        let (mut err_weak, mut err_strong) = (0.0f64, 0.0f64);
        let mut hits = 0u32;
        for k in 0..200 {
            let a = weak
                .scan(Stamp::from_ns(k), Pose2::IDENTITY, &world, &legs)
                .unwrap();
            let b = strong
                .scan(Stamp::from_ns(k), Pose2::IDENTITY, &world, &legs)
                .unwrap();
            for i in 0..a.len() {
                if !matches!(strong.last_hits()[i], Hit::Leg { .. }) {
                    continue;
                }
                hits += 1;
                let truth = strong.last_true_ranges_m()[i];
                match a.range_m(i) {
                    None => lost_weak += 1,
                    Some(r) => err_weak += (f64::from(r) - truth).abs(),
                }
                match b.range_m(i) {
                    None => lost_strong += 1,
                    Some(r) => err_strong += (f64::from(r) - truth).abs(),
                }
            }
        }
        let share = f64::from(lost_weak) / f64::from(hits);
        assert!((share - 0.4).abs() < 0.05, "{share}");
        assert_eq!(lost_strong, 0);
        assert!(err_weak / f64::from(hits - lost_weak) > 3.0 * err_strong / f64::from(hits));
    }

    #[test]
    fn long_range_beams_flicker() {
        let mut model = LaserModel::urg_04lx();
        model.range_max_m = 5.6;
        let world = StaticWorld {
            walls: vec![Segment::new(
                Point2::new(5.3, -20.0),
                Point2::new(5.3, 20.0),
            )],
            obstacles: vec![],
        };
        let mut laser = SimLaser::new(model, LaserSimSpec::ideal(), SimRng::stream(0, "laser"));
        let mut lost = 0;
        let mut total = 0;
        for k in 0..50 {
            let scan = laser
                .scan(Stamp::from_ns(k), Pose2::IDENTITY, &world, &[])
                .unwrap();
            // Beams within 3 degrees of the front hit the wall at ~5.3 m.
            for i in 331..=349 {
                total += 1;
                if scan.range_m(i).is_none() {
                    lost += 1;
                }
            }
        }
        let frac = f64::from(lost) / f64::from(total);
        assert!((0.25..0.55).contains(&frac), "{frac}");
    }

    /// A 10 m x 6 m room with walls, a path along y = 3 m, and the default clutter.
    fn room_with_clutter(seed: u64) -> (StaticWorld, Segment, Vec<(Circle, f64)>) {
        let (min, max) = (Point2::new(0.0, 0.0), Point2::new(10.0, 6.0));
        let corners = [min, Point2::new(10.0, 0.0), max, Point2::new(0.0, 6.0)];
        let world = StaticWorld {
            walls: (0..4)
                .map(|k| Segment::new(corners[k], corners[(k + 1) % 4]))
                .collect(),
            obstacles: vec![],
        };
        let path = Segment::new(Point2::new(1.0, 3.0), Point2::new(9.0, 3.0));
        let room = RoomSpec {
            min: [0.0, 0.0],
            max: [10.0, 6.0],
        };
        let spots = clutter_spots(
            &[room],
            &[path],
            &world,
            &LaserSimSpec::default(),
            &mut SimRng::stream(seed, "laser/clutter"),
        );
        (world, path, spots)
    }

    #[test]
    fn clutter_stands_clear_of_walls_and_paths_in_groups() {
        let spec = LaserSimSpec::default();
        let (mut pieces, mut paired) = (0usize, 0usize);
        for seed in 0..200 {
            let (world, path, spots) = room_with_clutter(seed);
            for (k, (c, shown)) in spots.iter().enumerate() {
                assert!(world.clearance_m(c.center) >= c.radius_m + 0.3, "{c:?}");
                let off_path = path.closest_point(c.center).distance_m(c.center);
                assert!(off_path >= CLUTTER_PATH_CLEARANCE_M, "{c:?}");
                assert!((spec.ghost_radius_m[0]..=spec.ghost_radius_m[1]).contains(&c.radius_m));
                assert!((spec.clutter_shown_prob[0]..=spec.clutter_shown_prob[1]).contains(shown));
                // A second piece of a pair stands 0.2-0.45 m from the one before it.
                let d = k
                    .checked_sub(1)
                    .map(|j| spots[j].0.center.distance_m(c.center));
                paired += usize::from(d.is_some_and(|d| (0.2..=0.45).contains(&d)));
            }
            pieces += spots.len();
        }
        // Placements clash with the walls and the path for about half of the room, so
        // fewer pieces than the density times the area stand; many come in pairs.
        let per_room = pieces as f64 / 200.0;
        assert!((0.5..3.6).contains(&per_room), "{per_room}");
        assert!(
            paired as f64 > 0.3 * pieces as f64 / 2.0,
            "{paired} of {pieces}"
        );
        // The same seed places the same clutter.
        assert_eq!(room_with_clutter(7).2, room_with_clutter(7).2);
    }

    #[test]
    fn clutter_shows_now_and_then_and_never_beside_a_leg() {
        let piece = Circle {
            center: Point2::new(2.0, 0.0),
            radius_m: 0.08,
        };
        let shown = |legs: &[LegCircle]| {
            let mut laser = SimLaser::new(
                LaserModel::urg_04lx(),
                LaserSimSpec {
                    ghosts_per_scan: 0.0,
                    ..LaserSimSpec::default()
                },
                SimRng::stream(3, "laser"),
            )
            .with_clutter(vec![(piece, 0.5)]);
            (0..400)
                .filter(|&k| {
                    laser
                        .scan(
                            Stamp::from_ns(k),
                            Pose2::IDENTITY,
                            &StaticWorld::default(),
                            legs,
                        )
                        .unwrap();
                    !laser.last_ghosts().is_empty()
                })
                .count()
        };
        let alone = shown(&[]);
        assert!((150..250).contains(&alone), "{alone}");
        let leg_beside = [LegCircle {
            circle: Circle {
                center: Point2::new(2.0, 0.45),
                radius_m: 0.06,
            },
            person: 0,
            leg: 0,
        }];
        assert_eq!(shown(&leg_beside), 0);
    }
}
