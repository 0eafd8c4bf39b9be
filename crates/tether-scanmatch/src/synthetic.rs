//! Synthetic scenes for tests, examples and benchmarks: walls and posts ray-cast with the
//! URG-04LX geometry (design 2.1), with seeded Gaussian range noise. Not a simulator
//! (`tether-sim` is); just enough to know the true motion between two scans.

use tether_core::{Laser, LaserModel, Point2, Pose2, World};

use crate::points::ScanPoints;

/// A static 2-D scene.
#[derive(Debug, Clone, Default)]
pub struct Scene {
    /// Wall segments `(a, b)`, world frame.
    pub walls: Vec<(Point2<World>, Point2<World>)>,
    /// Posts (circles) `(centre, radius_m)`, world frame.
    pub posts: Vec<(Point2<World>, f64)>,
}

impl Scene {
    /// A closed polygon of walls through `corners`.
    pub fn polygon(corners: &[(f64, f64)]) -> Self {
        let mut s = Scene::default();
        for i in 0..corners.len() {
            let a = corners[i];
            let b = corners[(i + 1) % corners.len()];
            s.walls.push((Point2::new(a.0, a.1), Point2::new(b.0, b.1)));
        }
        s
    }

    /// An irregular room about 8 m x 6 m with a pillar, a cabinet and table legs: every
    /// direction of motion is constrained.
    pub fn room() -> Self {
        let mut s = Scene::polygon(&[
            (-3.0, -2.5),
            (4.0, -2.5),
            (4.0, 0.5),
            (5.0, 0.5),
            (5.0, 3.0),
            (-1.0, 3.5),
            (-3.0, 2.0),
        ]);
        // A cabinet.
        s.walls.push((Point2::new(1.0, 2.2), Point2::new(2.2, 2.2)));
        s.walls.push((Point2::new(2.2, 2.2), Point2::new(2.2, 2.9)));
        s.posts.push((Point2::new(-1.2, -1.0), 0.15));
        for (x, y) in [(2.0, -1.0), (2.8, -1.0), (2.0, -1.6), (2.8, -1.6)] {
            s.posts.push((Point2::new(x, y), 0.025));
        }
        s
    }

    /// Two long parallel walls 2 m apart along x, with no end in sight: motion along x is
    /// not constrained.
    pub fn corridor() -> Self {
        let mut s = Scene::default();
        s.walls
            .push((Point2::new(-50.0, -1.0), Point2::new(50.0, -1.0)));
        s.walls
            .push((Point2::new(-50.0, 1.0), Point2::new(50.0, 1.0)));
        s
    }

    /// Distance along the ray from `o` in direction `(dx, dy)` (unit) to the nearest
    /// surface, or `None`.
    pub fn cast(&self, o: Point2<World>, dx: f64, dy: f64) -> Option<f64> {
        let mut best = f64::INFINITY;
        for &(a, b) in &self.walls {
            let (ex, ey) = (b.x - a.x, b.y - a.y);
            let den = dx * ey - dy * ex;
            if den.abs() < 1e-12 {
                continue;
            }
            let (ax, ay) = (a.x - o.x, a.y - o.y);
            let t = (ax * ey - ay * ex) / den;
            let u = (ax * dy - ay * dx) / den;
            if t > 0.0 && (0.0..=1.0).contains(&u) && t < best {
                best = t;
            }
        }
        for &(c, r) in &self.posts {
            let (cx, cy) = (c.x - o.x, c.y - o.y);
            let along = cx * dx + cy * dy;
            let perp_sq = cx * cx + cy * cy - along * along;
            if perp_sq > r * r {
                continue;
            }
            let t = along - (r * r - perp_sq).sqrt();
            if t > 0.0 && t < best {
                best = t;
            }
        }
        best.is_finite().then_some(best)
    }

    /// The ranges a URG-04LX at `world_from_laser` measures, with Gaussian noise of
    /// `sigma_m` from a generator seeded with `seed`; `+inf` beyond `model.range_max_m`.
    /// Also returns the beam angles.
    pub fn urg_scan(
        &self,
        model: &LaserModel,
        world_from_laser: Pose2<World, Laser>,
        sigma_m: f64,
        seed: u64,
    ) -> (Vec<f64>, Vec<f64>) {
        let mut rng = Gauss::new(seed);
        let g = &model.geometry;
        let n = g.beam_count();
        let mut angles = Vec::with_capacity(n);
        let mut ranges = Vec::with_capacity(n);
        for i in 0..n {
            let a = g.angle_min_rad() + i as f64 * g.angle_increment_rad();
            let (s, c) = (world_from_laser.yaw + a).sin_cos();
            let r = self
                .cast(world_from_laser.translation(), c, s)
                .map(|r| r + sigma_m * rng.normal())
                .filter(|&r| r >= model.range_min_m && r <= model.range_max_m)
                .unwrap_or(f64::INFINITY);
            angles.push(a);
            ranges.push(r);
        }
        (angles, ranges)
    }

    /// [`Scene::urg_scan`] as [`ScanPoints`] for a scanner at `model.mount` on a robot
    /// at `world_from_robot`.
    pub fn urg_points(
        &self,
        model: &LaserModel,
        world_from_robot: Pose2<World, tether_core::Robot>,
        sigma_m: f64,
        seed: u64,
    ) -> ScanPoints {
        let robot_from_laser = model.robot_from_laser();
        let (angles, ranges) =
            self.urg_scan(model, world_from_robot * robot_from_laser, sigma_m, seed);
        // The angles are strictly increasing and finite and the mount is the model's:
        // nothing here can be refused; an empty set is the fallback all the same.
        ScanPoints::from_polar(&angles, &ranges, robot_from_laser).unwrap_or_default()
    }
}

/// Standard normal draws from SplitMix64 (Steele, Lea and Flood, OOPSLA 2014) and the
/// Box-Muller transform: deterministic for a seed, no dependency.
#[derive(Debug, Clone)]
pub struct Gauss {
    state: u64,
    spare: Option<f64>,
}

impl Gauss {
    /// A generator for `seed`.
    pub fn new(seed: u64) -> Self {
        Gauss {
            state: seed,
            spare: None,
        }
    }

    fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in (0, 1].
    pub fn uniform(&mut self) -> f64 {
        ((self.next_u64() >> 11) as f64 + 1.0) / (1u64 << 53) as f64
    }

    /// A standard normal draw.
    pub fn normal(&mut self) -> f64 {
        if let Some(s) = self.spare.take() {
            return s;
        }
        let u1 = self.uniform();
        let u2 = self.uniform();
        let r = (-2.0 * u1.ln()).sqrt();
        let (s, c) = (std::f64::consts::TAU * u2).sin_cos();
        self.spare = Some(r * s);
        r * c
    }
}
