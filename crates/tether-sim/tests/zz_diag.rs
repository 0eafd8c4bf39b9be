#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]
use tether_core::{Laser, Point2};
use tether_laser::{DetectorConfig, LegClassifier, LegDetector};
use tether_sim::driver::driver_for;
use tether_sim::{BUILTIN_NAMES, Hit, Scenario, SensorData, Simulation};

fn diag(name: &str) {
    let model = match std::env::var("DIAG_MODEL") {
        Ok(p) => LegClassifier::from_json(&std::fs::read_to_string(p).unwrap()).unwrap(),
        Err(_) => LegClassifier::default_model().unwrap(),
    };
    let min_hits: usize = std::env::var("DIAG_HITS").map(|v| v.parse().unwrap()).unwrap_or(1);
    let (mut merged, mut merged_found) = (0usize, 0usize);
    let (mut scans, mut fps, mut found) = (0usize, 0usize, 0usize);
    let (mut legs, mut cand, mut pos) = (0usize, 0usize, 0usize);
    let mut feats: Vec<(f64, [f64; 26])> = Vec::new();
    for n in BUILTIN_NAMES {
        let mut s = Scenario::builtin(n).unwrap().with_scanner(name).unwrap();
        s.duration_s = s.duration_s.min(30.0);
        let mut sim = Simulation::new(&s, 0).unwrap();
        let mut driver = driver_for(&s);
        let mut det = LegDetector::learned(DetectorConfig::default(), s.laser.noise.clone(), model.clone()).unwrap();
        while let Some(event) = sim.advance() {
            if let Some(c) = driver.on_event(&event) { sim.set_command(c); }
            let SensorData::Scan(scan) = &event.data else { continue };
            let hits = sim.laser().unwrap().last_hits();
            let lfw = event.truth.world_from_laser.inverse();
            let cands = det.candidates(scan);
            let legs_found = tether_laser::statistics::detected_legs(&mut det, scan);
            scans += 1;
            let all: Vec<Point2<Laser>> = event.truth.people.iter().flat_map(|p| p.legs.iter().map(|l| lfw * l.center)).collect();
            fps += legs_found.iter().filter(|d| all.iter().all(|l| l.distance_m(**d) > 0.5)).count();
            for p in &event.truth.people {
                for (k, leg) in p.legs.iter().enumerate() {
                    let c: Point2<Laser> = lfw * leg.center;
                    let nhit = hits.iter().filter(|h| **h == Hit::Leg { person: p.id, leg: k as u8 }).count();
                    let seen = nhit >= min_hits;
                    if !(seen && (0.5..=1.5).contains(&c.range_m())) { continue; }
                    legs += 1;
                    let other = &p.legs[1 - k];
                    let gap = leg.center.distance_m(other.center) - leg.radius_m - other.radius_m;
                    if gap < 0.13 { merged += 1; if legs_found.iter().any(|d| d.distance_m(c) < 0.15) { merged_found += 1; } }
                    if legs_found.iter().any(|d| d.distance_m(c) < 0.15) { found += 1; }
                    if let Some(best) = cands.iter().min_by(|a, b| a.centroid_in_laser.distance_m(c).total_cmp(&b.centroid_in_laser.distance_m(c))) {
                        if best.centroid_in_laser.distance_m(c) < 0.15 {
                            cand += 1;
                            let m = model.margin(&best.features);
                            if model.is_leg(&best.features) { pos += 1; }
                            if feats.len() < 4000 { feats.push((m, best.features)); }
                        }
                    }
                }
            }
        }
    }
    println!("{name}: found {:.3} fp/scan {:.3} merged-share {:.3} merged-found {:.3} apart-found {:.3}", found as f64 / legs as f64, fps as f64 / scans as f64, merged as f64 / legs as f64, merged_found as f64 / merged as f64, (found - merged_found) as f64 / (legs - merged) as f64);
    if std::env::var("DIAG_BRIEF").is_ok() { return; }
    println!("{name}: legs {legs} with candidate {cand} ({:.3}) classified leg {pos} ({:.3})", cand as f64 / legs as f64, pos as f64 / legs as f64);
    // mean of each feature for refused vs accepted
    let names = tether_laser::features::FEATURE_NAMES;
    for i in 0..26 {
        let (mut a, mut na, mut r, mut nr) = (0.0, 0, 0.0, 0);
        for (m, f) in &feats { if *m > 0.0 { a += f[i]; na += 1 } else { r += f[i]; nr += 1 } }
        println!("  {:<32} acc {:>8.4} ref {:>8.4}", names[i], a / na.max(1) as f64, r / nr.max(1) as f64);
    }
}

#[test]
fn zz() {
    for n in tether_sim::scanners::SCANNER_NAMES.iter().copied() { diag(n); }
}
