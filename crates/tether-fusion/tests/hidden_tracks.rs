//! A person who goes behind something and comes out of its shadow away from where their
//! track coasted to is taken up by that track (design 5.5, "hidden tracks"); a lone leg
//! as far off that did not come out of a shadow is not.

#![allow(clippy::unwrap_used)]

use tether_core::{Cov2, Gaussian2, Point2, Stamp, World};
use tether_fusion::{Observation, Shadow, Tracker, TrackerConfig};

fn at(ms: i64) -> Stamp {
    Stamp::from_ns(ms * 1_000_000)
}

fn leg(x: f64, y: f64) -> Gaussian2<World> {
    Gaussian2::new(Point2::new(x, y), Cov2::isotropic(0.0025).unwrap()).unwrap()
}

/// A board 1.2 m wide standing across the view 1.7 m ahead of the scanner at the
/// origin, a return every 2 cm along it, and nothing else in range.
fn scan_with_board() -> Vec<Point2<World>> {
    (-30..=30)
        .map(|i| Point2::new(1.7, f64::from(i) * 0.02))
        .collect()
}

/// A track on somebody walking away from the scanner at 1 m/s just behind the board
/// until 0.3 s; from then on, for 0.8 s, they are out of sight behind it.
fn walker_gone_behind_the_post() -> (Tracker, u64) {
    let mut tr = Tracker::new(TrackerConfig::default()).unwrap();
    for ms in [0, 100, 200, 300] {
        let x = 2.6 + f64::from(ms as i32) * 1e-3;
        tr.process(at(ms), &[Observation::laser(leg(x, 0.0), true, false)]);
    }
    let id = tr.tracks()[0].id;
    let returns = scan_with_board();
    let shadow = Shadow::new(Point2::ORIGIN, &returns, 0.3);
    for ms in (400..=1100).step_by(100) {
        tr.process(at(ms), &[]);
        tr.note_shadow(at(ms), |p| shadow.hides(p));
    }
    (tr, id)
}

#[test]
fn a_lone_leg_out_of_the_shadow_takes_the_hidden_track_one_elsewhere_does_not() {
    let (tr, id) = walker_gone_behind_the_post();
    assert!(
        tr.track(id).unwrap().hidden_since_update(),
        "it went behind the board"
    );
    // They come out 0.7 m to the side of where the track coasted to, one leg first.
    let predicted = {
        let mut t = tr.clone();
        t.process(at(1200), &[]);
        t.track(id).unwrap().position().mean
    };
    let out = leg(predicted.x - 0.3, predicted.y + 0.63);
    assert!(predicted.distance_m(out.mean) > 0.5);
    let from_shadow = Observation {
        from_shadow: true,
        ..Observation::laser(out, false, true)
    };
    let mut t = tr.clone();
    assert_eq!(t.process(at(1200), &[from_shadow]).track_of[0], Some(id));
    // The same leg not coming out of a shadow is too far off for a lone leg.
    let mut t = tr.clone();
    let plain = Observation::laser(out, false, true);
    assert_ne!(t.process(at(1200), &[plain]).track_of[0], Some(id));
}

#[test]
fn a_track_in_plain_view_is_not_hidden() {
    let mut tr = Tracker::new(TrackerConfig::default()).unwrap();
    for ms in [0, 100, 200, 300] {
        tr.process(at(ms), &[Observation::laser(leg(1.0, 1.0), true, false)]);
    }
    let id = tr.tracks()[0].id;
    let returns = scan_with_board();
    let shadow = Shadow::new(Point2::ORIGIN, &returns, 0.3);
    for ms in [400, 500] {
        tr.process(at(ms), &[]);
        tr.note_shadow(at(ms), |p| shadow.hides(p));
    }
    assert!(!tr.track(id).unwrap().hidden_since_update());
}
