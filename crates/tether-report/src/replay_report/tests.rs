//! Tests of the replay report's pictures and table.

use super::frame::{AXIS_BOTTOM, AXIS_LEFT, AXIS_RIGHT};
use super::*;
use tether_core::{Cov2, Gaussian2, LaserScan, Point2, Pose2, Stamp, Vector2};
use tether_fusion::{LossReason, TargetState};
use tether_laser::Leg;
use tether_pipeline::TrackView;

#[test]
fn the_scale_bar_is_a_round_length() {
    assert_eq!(scale_bar_m(2.5), 2.0);
    assert_eq!(scale_bar_m(1.0), 1.0);
    assert_eq!(scale_bar_m(0.7), 0.5);
    assert_eq!(scale_bar_m(13.0), 10.0);
    assert_eq!(scale_bar_m(4.99), 2.0);
    assert_eq!(scale_bar_m(0.3), 0.2);
    assert!((scale_bar_m(0.03) - 0.02).abs() < 1e-12);
    assert_eq!(scale_bar_m(f64::NAN), 1.0);
    for max in [0.13, 0.9, 1.9, 3.3, 7.7, 42.0, 999.0] {
        let m = scale_bar_m(max);
        assert!(m <= max && m > max / 2.6, "{max} -> {m}");
    }
    // Drawn at a quarter of the plot at most, labelled.
    let frame = MapFrame::fit(
        Bounds {
            x0: 0.0,
            x1: 10.0,
            y0: 0.0,
            y1: 5.0,
        },
        500.0,
        500.0,
        0.0,
    );
    assert_eq!(frame.px_per_m(), 50.0);
    let bar = frame.scale_bar();
    assert!(
        bar.contains("class=\"scale-bar\"") && bar.contains(">2 m<"),
        "{bar}"
    );
}

#[test]
fn the_map_keeps_one_scale_both_ways_and_fits() {
    let b = Bounds {
        x0: -2.0,
        x1: 18.0,
        y0: 1.0,
        y1: 6.0,
    };
    let f = MapFrame::fit(b, 800.0, 600.0, 10.0);
    // 20 m across in 800 px: 40 px/m, so 5 m up is 200 px.
    assert_eq!(f.px_per_m(), 40.0);
    assert_eq!(f.px(-2.0, 6.0), (AXIS_LEFT, 10.0));
    assert_eq!(f.px(18.0, 1.0), (AXIS_LEFT + 800.0, 210.0));
    assert!(f.width() <= 800.0 + AXIS_LEFT + AXIS_RIGHT);
    let axes = f.axes("odom");
    // Ticks every 2 m both ways (tick_step(20) = 2): x at -2, 0, ..., 18; y at 2, 4, 6.
    for label in [
        ">-2<",
        ">0<",
        ">10<",
        ">18<",
        ">6<",
        "x (m, odom)",
        "y (m, odom)",
    ] {
        assert!(axes.contains(label), "{label}: {axes}");
    }
    // A tall map is limited by the height.
    let tall = MapFrame::fit(
        Bounds {
            x0: 0.0,
            x1: 1.0,
            y0: 0.0,
            y1: 30.0,
        },
        800.0,
        600.0,
        0.0,
    );
    assert_eq!(tall.px_per_m(), 20.0);
    assert!(tall.height() <= 600.0 + AXIS_BOTTOM);
}

#[test]
fn thinning_keeps_a_bounded_even_sample() {
    let mut t = Thinned::new(8);
    let mut made = 0;
    for i in 0..1000 {
        t.offer(i, || {
            made += 1;
            i
        });
        assert!(t.indices().len() <= 8);
    }
    // Strides doubled to 128: 0, 128, ..., 896.
    assert_eq!(t.indices(), [0, 128, 256, 384, 512, 640, 768, 896]);
    // Only kept items were built.
    // 9, then 4 more at each of 6 doublings.
    assert!(made <= 40, "{made}");
    // Four parts of 1000: middles 124.5, 374.5, 624.5, 874.5.
    let picked: Vec<usize> = t.pick(4, 1000).into_iter().map(|(i, _)| i).collect();
    assert_eq!(picked, [128, 384, 640, 896]);
    // Few items: all of them.
    let mut few = Thinned::new(8);
    for i in 0..3 {
        few.offer(i, || i);
    }
    assert_eq!(few.pick(4, 3).len(), 3);
}

fn scan(stamp: Stamp) -> LaserScan {
    LaserScan::new(stamp, "laser", -1.0, 0.5, 0.02, 5.6, vec![2.0; 5]).unwrap()
}

fn snapshot(i: usize, chosen: Chosen) -> Snapshot {
    let stamp = Stamp::from_ns(i as i64 * 100_000_000);
    let g = Gaussian2::new(Point2::new(2.0, 0.5), Cov2::isotropic(0.1).unwrap()).unwrap();
    Snapshot {
        t_s: i as f64 * 0.1,
        stamp,
        scan_index: i,
        chosen,
        scan: scan(stamp),
        world_from_robot: Pose2::new(0.0, 0.0, 0.3),
        robot_from_laser: Pose2::new(0.1, 0.0, 0.0),
        laser_people: vec![g],
        tracks: vec![
            TrackView {
                id: 7,
                confirmed: true,
                position: g,
                velocity: Vector2::new(0.5, 0.0),
            },
            TrackView {
                id: 9,
                confirmed: false,
                position: g,
                velocity: Vector2::ZERO,
            },
        ],
        target: TargetState::Locked { track: 7 },
        target_estimate: Some(g),
    }
}

#[test]
fn snapshots_are_spread_and_losses_come_first() {
    // 7,200 scans (a 12-minute log) and no loss: 8 evenly spaced, within a
    // sixteenth of the recording of the middles of eight equal parts.
    let mut p = SnapshotPicker::new();
    let mut built = 0;
    for i in 0..7200 {
        p.scan(i, || {
            built += 1;
            snapshot(i, Chosen::Evenly)
        });
    }
    // Kept candidates only: 33, then 16 more at each of 7 doublings of the stride.
    assert!(built < 160, "{built} snapshots built");
    let chosen = p.finish(7200);
    assert_eq!(chosen.len(), MAX_SNAPSHOTS);
    for (k, s) in chosen.iter().enumerate() {
        let middle = (k as f64 + 0.5) * 900.0;
        assert!(
            (s.scan_index as f64 - middle).abs() <= 7200.0 / 16.0,
            "{k}: {}",
            s.scan_index
        );
    }
    // Ten losses: four of them, spread over the ten, and four evenly spaced.
    let mut p = SnapshotPicker::new();
    for i in 0..1000 {
        p.scan(i, || snapshot(i, Chosen::Evenly));
        if i % 100 == 50 {
            p.loss(|| snapshot(i, Chosen::Loss(LossReason::Unseen)));
        }
    }
    let chosen = p.finish(1000);
    let losses: Vec<usize> = chosen
        .iter()
        .filter(|s| s.chosen != Chosen::Evenly)
        .map(|s| s.scan_index)
        .collect();
    // Held: losses 0, 2, 4, 6, 8 (the stride doubled at the ninth); picked nearest
    // the middles 0.75, 3.25, 5.75 and 8.25 of four parts of ten.
    assert_eq!(losses, [50, 450, 650, 850]);
    assert_eq!(chosen.len(), MAX_SNAPSHOTS);
    assert!(chosen.windows(2).all(|w| w[0].stamp <= w[1].stamp));
    // Two losses: both, and six evenly spaced.
    let mut p = SnapshotPicker::new();
    for i in 0..60 {
        p.scan(i, || snapshot(i, Chosen::Evenly));
        if i == 20 || i == 41 {
            p.loss(|| snapshot(i, Chosen::Loss(LossReason::LeftView)));
        }
    }
    let chosen = p.finish(60);
    assert_eq!(chosen.len(), 8);
    assert_eq!(
        chosen
            .iter()
            .filter(|s| matches!(s.chosen, Chosen::Loss(_)))
            .count(),
        2
    );
}

#[test]
fn a_snapshot_draws_returns_legs_people_tracks_target_and_robot() {
    let s = snapshot(3, Chosen::Evenly);
    let leg = Leg {
        centre_in_laser: Point2::new(1.9, 0.3),
        radius_m: 0.06,
        centroid_in_laser: Point2::new(1.85, 0.3),
        score: 0.9,
        first_beam: 1,
        last_beam: 2,
        n_points: 2,
    };
    let svg = s.svg(1, &[leg], "odom");
    assert_eq!(svg.matches("class=\"leg\"").count(), 1);
    assert_eq!(svg.matches("class=\"person\"").count(), 1);
    assert_eq!(svg.matches("class=\"track\"").count(), 1, "tentative apart");
    assert!(svg.contains("tentative track 9"));
    assert!(svg.contains("class=\"target\"") && svg.contains(">7 target<"));
    assert!(svg.contains("class=\"robot\"") && svg.contains("class=\"scale-bar\""));
    // Five returns, five dots.
    let scan = svg
        .split("class=\"scan\" d=\"")
        .nth(1)
        .and_then(|r| r.split('"').next())
        .unwrap();
    assert_eq!(scan.matches("h0").count(), 5);
    let caption = s.caption(1, 1);
    assert!(caption.contains("t = 0.3 s") && caption.contains("locked on track 7"));
}

#[test]
fn the_track_table_counts_walks_and_updates() {
    let at = |ms: i64| Stamp::from_ns(ms * 1_000_000);
    let seen = |id, confirmed, t: i64, x: f64, updated: bool| TrackSeen {
        id,
        confirmed,
        born: at(100),
        last_update: if updated { at(t) } else { at(100) },
        last_laser: updated.then(|| at(t)),
        position: Point2::new(x, 0.0),
    };
    let mut table = TrackTable::new();
    // Track 1 walks 0.1 m per scan for 20 scans (2 m in 2 s), then coasts; track 2
    // stands, jittering by 5 cm; track 3 is tentative and vanishes.
    for k in 0..=20 {
        let t = 100 + 100 * k;
        let jitter = if k % 2 == 0 { 0.05 } else { 0.0 };
        let mut tracks = vec![
            seen(1, k >= 3, t, 0.1 * k as f64, true),
            seen(2, k >= 3, t, 5.0 + jitter, true),
        ];
        if k < 5 {
            tracks.push(seen(3, false, t, 9.0, true));
        }
        table.update(at(t), true, &tracks, (k >= 4).then_some(1));
    }
    for k in 21..25 {
        let t = 100 + 100 * k;
        let tracks = [seen(1, true, t, 2.0 + 0.1 * (k - 20) as f64, false)];
        table.update(at(t), true, &tracks, Some(1));
    }
    let (rows, left_out) = table.rows(at(0));
    assert_eq!(left_out, 0);
    assert_eq!(rows.len(), 2, "{rows:?}");
    let r1 = &rows[0];
    assert_eq!((r1.id, r1.scans_updated, r1.target), (1, 21, true));
    assert!((r1.first_s - 0.1).abs() < 1e-9 && (r1.last_s - 2.1).abs() < 1e-9);
    assert!((r1.walked_m - 1.8).abs() < 1e-9, "{}", r1.walked_m);
    assert!((r1.mean_speed_mps.unwrap() - 0.9).abs() < 1e-9);
    let r2 = &rows[1];
    assert_eq!((r2.id, r2.walked_m, r2.target), (2, 0.0, false));
    let html = table.html(at(0));
    assert!(html.contains("class=\"tracks\"") && html.contains("1 tentative"));
}

#[test]
fn the_track_table_keeps_the_target_and_the_longest() {
    let at = |ms: i64| Stamp::from_ns(ms * 1_000_000);
    let mut table = TrackTable::new();
    let n = MAX_TRACK_ROWS as u64 + 10;
    // Track k lives k ticks; track 0 (the shortest) is the target.
    let tracks: Vec<TrackSeen> = (0..n)
        .map(|id| TrackSeen {
            id,
            confirmed: true,
            born: at(0),
            last_update: at(10 * (id as i64 + 1)),
            last_laser: None,
            position: Point2::new(id as f64, 0.0),
        })
        .collect();
    for t in &tracks {
        table.update(t.last_update, false, &[*t], Some(0).filter(|_| t.id == 0));
    }
    let (rows, left_out) = table.rows(at(0));
    assert_eq!((rows.len(), left_out), (MAX_TRACK_ROWS, 10));
    assert!(rows.iter().any(|r| r.id == 0 && r.target));
    assert!(!rows.iter().any(|r| (1..=10).contains(&r.id)));
    assert!(table.html(at(0)).contains("10 shorter ones are left out"));
}
