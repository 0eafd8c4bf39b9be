//! The static world built from a scenario: wall segments and round obstacles.

use tether_core::{Point2, Vector2, World};

use crate::geometry::{Circle, Segment};
use crate::rng::SimRng;
use crate::scenario::Scenario;

/// Stems and leaf clumps of a bush of radius `radius_m` at `center`: about one per
/// 0.04 m^2 of its footprint (at least 3), each a circle of radius 0.015-0.07 m placed
/// uniformly in the footprint. Drawn from a stream named after the bush's index, so a
/// bush looks the same in every run and every seed.
pub fn bush_parts(index: usize, center: Point2<World>, radius_m: f64) -> Vec<Circle> {
    let mut rng = SimRng::stream(0, &format!("bush/{index}"));
    let area = std::f64::consts::PI * radius_m * radius_m;
    let n = ((area / 0.04).round() as usize).clamp(3, 200);
    (0..n)
        .map(|_| {
            let r = radius_m * rng.unit().sqrt();
            let a = rng.uniform(-std::f64::consts::PI, std::f64::consts::PI);
            Circle {
                center: center + Vector2::new(r * a.cos(), r * a.sin()),
                radius_m: rng.uniform(0.015, 0.07),
            }
        })
        .collect()
}

/// What a round obstacle is; decides what it blocks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ObstacleKind {
    /// Full-height pillar: blocks the laser, the camera and people.
    Pillar,
    /// Thin post: blocks the laser.
    Post,
    /// Table leg (up to table height, ~0.75 m).
    TableLeg,
    /// Chair leg (up to seat height, ~0.45 m).
    ChairLeg,
    /// Litter bin (~1 m tall).
    Bin,
    /// A stem or clump of leaves of a bush (~1 m tall); its returns flicker.
    Foliage,
}

impl ObstacleKind {
    /// Height of the obstacle's top, m (pillars and posts reach the ceiling).
    pub fn top_m(self) -> f64 {
        match self {
            ObstacleKind::Pillar | ObstacleKind::Post => f64::INFINITY,
            ObstacleKind::TableLeg => 0.75,
            ObstacleKind::ChairLeg => 0.45,
            ObstacleKind::Bin | ObstacleKind::Foliage => 1.0,
        }
    }

    /// Name used in files.
    pub fn name(self) -> &'static str {
        match self {
            ObstacleKind::Pillar => "pillar",
            ObstacleKind::Post => "post",
            ObstacleKind::TableLeg => "table_leg",
            ObstacleKind::ChairLeg => "chair_leg",
            ObstacleKind::Bin => "bin",
            ObstacleKind::Foliage => "foliage",
        }
    }
}

/// A round obstacle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Obstacle {
    /// Its footprint at any height below its top.
    pub circle: Circle,
    /// What it is.
    pub kind: ObstacleKind,
}

/// Everything that does not move.
#[derive(Debug, Clone, Default)]
pub struct StaticWorld {
    /// Walls (full height).
    pub walls: Vec<Segment>,
    /// Round obstacles.
    pub obstacles: Vec<Obstacle>,
}

/// Four corners of a rectangle of half-sizes (hx, hy) around `c`, rotated by `yaw`.
fn corners(c: Point2<World>, hx: f64, hy: f64, yaw: f64) -> [Point2<World>; 4] {
    [(hx, hy), (-hx, hy), (-hx, -hy), (hx, -hy)].map(|(x, y)| c + Vector2::new(x, y).rotated(yaw))
}

impl StaticWorld {
    /// Expands the scenario's rooms, tables and chairs into primitives.
    pub fn from_scenario(scenario: &Scenario) -> Self {
        let walls = scenario
            .wall_segments()
            .into_iter()
            .map(|(s, _)| s)
            .collect();
        let w = &scenario.world;
        let mut obstacles = Vec::new();
        let circle = |c: [f64; 2], r: f64| Circle {
            center: Point2::new(c[0], c[1]),
            radius_m: r,
        };
        for p in &w.pillars {
            obstacles.push(Obstacle {
                circle: circle(p.center, p.radius_m),
                kind: ObstacleKind::Pillar,
            });
        }
        for p in &w.posts {
            obstacles.push(Obstacle {
                circle: circle(p.center, p.radius_m),
                kind: ObstacleKind::Post,
            });
        }
        for b in &w.bins {
            obstacles.push(Obstacle {
                circle: circle(b.center, b.radius_m),
                kind: ObstacleKind::Bin,
            });
        }
        for (i, b) in w.bushes.iter().enumerate() {
            for part in bush_parts(i, Point2::new(b.center[0], b.center[1]), b.radius_m) {
                obstacles.push(Obstacle {
                    circle: part,
                    kind: ObstacleKind::Foliage,
                });
            }
        }
        for t in &w.tables {
            // Legs sit inset from the corners of the top by 1.5 leg radii + 3 cm.
            let inset = 1.5 * t.leg_radius_m + 0.03;
            let c = Point2::new(t.center[0], t.center[1]);
            for p in corners(
                c,
                0.5 * t.size_m[0] - inset,
                0.5 * t.size_m[1] - inset,
                t.yaw_rad,
            ) {
                obstacles.push(Obstacle {
                    circle: Circle {
                        center: p,
                        radius_m: t.leg_radius_m,
                    },
                    kind: ObstacleKind::TableLeg,
                });
            }
        }
        for ch in &w.chairs {
            let half = 0.5 * ch.size_m - ch.leg_radius_m - 0.01;
            let c = Point2::new(ch.center[0], ch.center[1]);
            for p in corners(c, half, half, ch.yaw_rad) {
                obstacles.push(Obstacle {
                    circle: Circle {
                        center: p,
                        radius_m: ch.leg_radius_m,
                    },
                    kind: ObstacleKind::ChairLeg,
                });
            }
        }
        StaticWorld { walls, obstacles }
    }

    /// Distance from `p` to the nearest wall or obstacle surface, m (negative inside an
    /// obstacle; infinite in an empty world).
    pub fn clearance_m(&self, p: Point2<World>) -> f64 {
        let walls = self.walls.iter().map(|w| w.closest_point(p).distance_m(p));
        let obstacles = self
            .obstacles
            .iter()
            .map(|o| o.circle.center.distance_m(p) - o.circle.radius_m);
        walls.chain(obstacles).fold(f64::INFINITY, f64::min)
    }

    /// True when a disc of radius `r` at `p` overlaps a wall or an obstacle.
    pub fn disc_collides(&self, p: Point2<World>, r: f64) -> bool {
        self.clearance_m(p) < r
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn office_has_furniture_legs() {
        let s = Scenario::builtin("office").unwrap();
        let w = StaticWorld::from_scenario(&s);
        let table_legs = w
            .obstacles
            .iter()
            .filter(|o| o.kind == ObstacleKind::TableLeg)
            .count();
        let chair_legs = w
            .obstacles
            .iter()
            .filter(|o| o.kind == ObstacleKind::ChairLeg)
            .count();
        assert_eq!(table_legs, 4 * s.world.tables.len());
        assert_eq!(chair_legs, 4 * s.world.chairs.len());
        assert!(table_legs >= 8 && chair_legs >= 16);
        assert_eq!(w.walls.len(), 4 * s.world.rooms.len() + s.world.walls.len());
    }
}
