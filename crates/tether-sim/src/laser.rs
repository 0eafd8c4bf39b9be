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

use std::f64::consts::{PI, TAU};

use tether_core::{LaserModel, LaserScan, Point2, Pose2, Stamp, Vector2, World};

use crate::geometry::{Circle, Segment, ray_circle_m, ray_segment_m};
use crate::rng::SimRng;
use crate::scenario::LaserSimSpec;
use crate::world::StaticWorld;

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

/// The laser of the simulator.
#[derive(Debug, Clone)]
pub struct SimLaser {
    model: LaserModel,
    spec: LaserSimSpec,
    rng: SimRng,
    directions: Vec<(f64, f64)>,
    true_ranges_m: Vec<f64>,
    hits: Vec<Hit>,
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
        self.cast(world_from_laser, world, legs);
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
            let noise = &self.spec.noise;
            let measured = r + noise.bias_m(r) + self.rng.normal(0.0, noise.sigma_m(r));
            let far = ((r - self.spec.long_range_start_m) / span).clamp(0.0, 1.0);
            let p_drop = self.spec.dropout_prob + self.spec.long_range_dropout_prob * far;
            if self.rng.chance(p_drop) {
                ranges.push(f32::INFINITY);
                continue;
            }
            ranges.push(((measured * 1000.0).round() / 1000.0) as f32);
        }
        let g = &self.model.geometry;
        LaserScan::new(
            stamp,
            <tether_core::Laser as tether_core::Frame>::NAME,
            g.angle_min_rad(),
            g.angle_increment_rad(),
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::{Obstacle, ObstacleKind};

    fn quiet_laser() -> SimLaser {
        let model = LaserModel::urg_04lx();
        let mut spec = LaserSimSpec {
            dropout_prob: 0.0,
            long_range_dropout_prob: 0.0,
            ..LaserSimSpec::default()
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
        let mut laser = SimLaser::new(model, LaserSimSpec::default(), SimRng::stream(0, "laser"));
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
}
