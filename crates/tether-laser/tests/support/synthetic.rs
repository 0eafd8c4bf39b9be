//! Synthetic URG-04LX scans for tests and benchmarks: a rectangular room, people's legs
//! and table legs as circles, ray-cast from the sensor, with seeded range noise.
//! (Shared by `#[path]` between the tests and the benchmark.)

use rand::{RngExt, SeedableRng};
use rand_distr::StandardNormal;
use rand_pcg::Pcg64Mcg;
use tether_core::{LaserModel, LaserScan, Stamp};

/// A circle in the laser frame: centre x, y and radius, m.
#[derive(Debug, Clone, Copy)]
pub struct Circle {
    pub x: f64,
    pub y: f64,
    pub r: f64,
}

/// Distance along the ray of direction (c, s) to the near side of `circle`, if hit.
pub fn hit_circle(c: f64, s: f64, circle: &Circle) -> Option<f64> {
    let proj = c * circle.x + s * circle.y;
    let disc = proj * proj - (circle.x * circle.x + circle.y * circle.y - circle.r * circle.r);
    (disc >= 0.0 && proj > 0.0).then(|| proj - disc.sqrt())
}

/// Distance along the ray to the walls of the room `[x0, x1] x [y0, y1]` around the
/// sensor.
pub fn hit_room(c: f64, s: f64, room: [f64; 4]) -> f64 {
    let [x0, x1, y0, y1] = room;
    let mut best = f64::INFINITY;
    if c > 1e-12 {
        best = best.min(x1 / c);
    } else if c < -1e-12 {
        best = best.min(x0 / c);
    }
    if s > 1e-12 {
        best = best.min(y1 / s);
    } else if s < -1e-12 {
        best = best.min(y0 / s);
    }
    best
}

/// A full URG-04LX scan (682 beams, -2.0862 .. 2.0923 rad) of a 7 m x 5 m room with
/// the sensor at (1.5, 2.5) facing +x and the given circles, with normal range noise
/// of `sigma_m` (real URG-04LX beams spread by 6-7 mm, design 2.1) and 2 % of beams
/// dropped; ranges beyond 5.6 m read as no return.
pub fn urg_scan(circles: &[Circle], sigma_m: f64, seed: u64) -> LaserScan {
    let model = LaserModel::urg_04lx();
    let g = model.geometry;
    let room = [-1.5, 5.5, -2.5, 2.5];
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let ranges: Vec<f32> = (0..g.beam_count())
        .map(|i| {
            let a = g.angle_min_rad() + i as f64 * g.angle_increment_rad();
            let (s, c) = a.sin_cos();
            let mut r = hit_room(c, s, room);
            for circle in circles {
                if let Some(d) = hit_circle(c, s, circle) {
                    r = r.min(d);
                }
            }
            let z: f64 = rng.sample(StandardNormal);
            let noisy = r + sigma_m * z;
            if noisy > model.range_max_m || rng.random::<f64>() < 0.02 {
                f32::INFINITY
            } else {
                noisy as f32
            }
        })
        .collect();
    LaserScan::new(
        Stamp::ZERO,
        "laser",
        g.angle_min_rad(),
        g.angle_increment_rad(),
        model.range_min_m,
        model.range_max_m,
        ranges,
    )
    .expect("the URG-04LX geometry is valid")
}

/// Two walking people (a stride each) and a table's four legs.
pub fn office_circles() -> Vec<Circle> {
    vec![
        Circle {
            x: 1.8,
            y: 0.4,
            r: 0.06,
        },
        Circle {
            x: 2.1,
            y: 0.5,
            r: 0.06,
        },
        Circle {
            x: 3.0,
            y: -0.9,
            r: 0.065,
        },
        Circle {
            x: 3.05,
            y: -1.15,
            r: 0.065,
        },
        Circle {
            x: 2.5,
            y: 1.5,
            r: 0.025,
        },
        Circle {
            x: 2.5,
            y: 2.2,
            r: 0.025,
        },
        Circle {
            x: 3.6,
            y: 1.5,
            r: 0.025,
        },
        Circle {
            x: 3.6,
            y: 2.2,
            r: 0.025,
        },
    ]
}
