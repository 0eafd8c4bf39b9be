//! The simulated URG-04LX sees walking legs the way the real one does (design 4):
//! leg clusters 9-16 cm wide (median ~12.7 cm), ~13 points at 1.7 m, leg centres
//! 0.2-0.35 m apart most of the time and never much more than 0.58 m.

#![allow(clippy::unwrap_used, reason = "a test should fail loudly on bad data")]

#[path = "support/still_laser.rs"]
mod still_laser;

use tether_sim::laser::Hit;
use tether_sim::{Scenario, SensorData, Simulation};

/// People walking back and forth 1-3 m in front of a still robot, across and along the
/// beams, with body sizes drawn from the seed.
fn scene() -> String {
    still_laser::still_laser_scene(
        "leg_statistics",
        "people walking 1-3 m in front of a still laser",
        [-7.0, -7.0],
        [7.0, 7.0],
        r#"
[[people]]
name = "across_near"
path = [[1.4, -1.6], [1.4, 1.6]]
speed_mps = 1.1
repeat = true

[[people]]
name = "across_far"
path = [[2.7, 1.8], [2.7, -1.8]]
speed_mps = 1.3
repeat = true

[[people]]
name = "across_mid"
path = [[1.75, 1.3], [1.75, -1.3]]
speed_mps = 1.0
repeat = true

[[people]]
name = "around"
path = [[1.7, 0.0], [1.2, 1.2], [0.0, 1.7], [-1.2, 1.2], [-1.7, 0.0], [-1.2, -1.2], [0.0, -1.7], [1.2, -1.2]]
speed_mps = 1.2
repeat = true

[[people]]
name = "along"
path = [[1.0, -0.6], [3.0, -0.9]]
speed_mps = 0.9
repeat = true

[[people]]
name = "diagonal"
path = [[1.2, 1.2], [2.4, 2.2]]
speed_mps = 1.0
repeat = true
"#,
    )
}

struct Cluster {
    width_m: f64,
    points: usize,
    range_m: f64,
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

#[test]
fn simulated_legs_match_real_urg_04lx_statistics() {
    let mut clusters = Vec::new();
    let mut separations = Vec::new();
    for seed in 0..6 {
        let scenario = Scenario::from_toml_str(&scene(), "realism").unwrap();
        let mut sim = Simulation::new(&scenario, seed).unwrap();
        while let Some(event) = sim.advance() {
            let SensorData::Scan(scan) = &event.data else {
                continue;
            };
            let hits = sim.laser().unwrap().last_hits().to_vec();
            for person in &event.truth.people {
                let [l, r] = person.legs;
                separations.push(l.center.distance_m(r.center));
            }
            // Ground-truth clusters: maximal runs of beams on one leg, kept only when
            // the leg is wholly visible (no neighbour beam on the same person's other
            // leg, no missing return inside or at the ends).
            let mut i = 0;
            while i < hits.len() {
                let Hit::Leg { person, leg } = hits[i] else {
                    i += 1;
                    continue;
                };
                let start = i;
                while i < hits.len() && hits[i] == (Hit::Leg { person, leg }) {
                    i += 1;
                }
                let end = i - 1;
                let other = Hit::Leg {
                    person,
                    leg: 1 - leg,
                };
                let touches_other =
                    (start > 0 && hits[start - 1] == other) || (i < hits.len() && hits[i] == other);
                let points: Vec<_> = (start..=end)
                    .filter_map(|k| scan.range_m(k).map(|r| (k, f64::from(r))))
                    .collect();
                if touches_other || points.len() != end - start + 1 || points.len() < 2 {
                    continue;
                }
                let xy = |(k, r): (usize, f64)| {
                    let a = scan.angle_rad(k);
                    (r * a.cos(), r * a.sin())
                };
                let (a, b) = (xy(points[0]), xy(points[points.len() - 1]));
                clusters.push(Cluster {
                    width_m: (a.0 - b.0).hypot(a.1 - b.1),
                    points: points.len(),
                    range_m: points.iter().map(|p| p.1).sum::<f64>() / points.len() as f64,
                });
            }
        }
    }
    assert!(clusters.len() > 2000, "only {} clusters", clusters.len());

    let near: Vec<&Cluster> = clusters
        .iter()
        .filter(|c| (1.0..=3.0).contains(&c.range_m))
        .collect();
    let mut widths: Vec<f64> = near.iter().map(|c| c.width_m).collect();
    let in_band =
        widths.iter().filter(|w| (0.09..=0.16).contains(*w)).count() as f64 / widths.len() as f64;
    let median_width = median(&mut widths);
    println!(
        "{} clusters 1-3 m: median width {median_width:.4} m, {:.1} % within 9-16 cm",
        near.len(),
        100.0 * in_band
    );
    assert!(
        (0.11..=0.14).contains(&median_width),
        "median width {median_width}"
    );
    assert!(in_band >= 0.8, "only {in_band} of widths in 9-16 cm");

    let mut at_1_7: Vec<f64> = clusters
        .iter()
        .filter(|c| (1.6..=1.8).contains(&c.range_m))
        .map(|c| c.points as f64)
        .collect();
    assert!(at_1_7.len() > 100, "{} clusters at 1.7 m", at_1_7.len());
    let median_points = median(&mut at_1_7);
    println!(
        "{} clusters at 1.6-1.8 m: median {median_points} points",
        at_1_7.len()
    );
    assert!(
        (11.0..=15.0).contains(&median_points),
        "{median_points} points at 1.7 m"
    );

    let typical = separations
        .iter()
        .filter(|s| (0.2..=0.35).contains(*s))
        .count() as f64
        / separations.len() as f64;
    let widest = separations.iter().copied().fold(0.0, f64::max);
    println!(
        "leg separation within 0.2-0.35 m {:.1} % of the time, widest {widest:.3} m",
        100.0 * typical
    );
    assert!(typical > 0.5, "leg separation typical only {typical}");
    assert!(widest < 0.6, "legs {widest} m apart");
}
