//! A person who goes behind something and comes out of its shadow away from where their
//! track coasted to is taken up by that track (design 5.5, "hidden tracks"); a lone leg
//! as far off that did not come out of a shadow is not. A lost target whose track takes
//! up such a leg is back at once, and lost again if the next scans do not confirm it.

#![allow(clippy::unwrap_used)]

use tether_core::{Cov2, Gaussian2, Point2, Pose2, Stamp, World};
use tether_fusion::{
    MotionBounds, Observation, Refusal, Shadow, TargetConfig, TargetSelector, TargetState, Tracker,
    TrackerConfig, Transition,
};

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

/// The walker of [`walker_gone_behind_the_post`], followed (locked by id) and hidden
/// until 1.5 s: lost at 1.4 s, 1.1 s after its last update.
fn target_lost_behind_the_board() -> (Tracker, TargetSelector, u64) {
    let mut tr = Tracker::new(TrackerConfig::default()).unwrap();
    let mut selector = TargetSelector::new(
        TargetConfig {
            track_id: Some(1),
            ..TargetConfig::default()
        },
        MotionBounds::default(),
    );
    let returns = scan_with_board();
    let shadow = Shadow::new(Point2::ORIGIN, &returns, 0.3);
    for ms in (0..=1500).step_by(100) {
        let x = 2.6 + f64::from(ms as i32) * 1e-3;
        let legs = if ms <= 300 {
            vec![Observation::laser(leg(x, 0.0), true, false)]
        } else {
            vec![]
        };
        tr.process(at(ms), &legs);
        tr.note_shadow(at(ms), |p| shadow.hides(p));
        selector.update(at(ms), tr.tracks(), Pose2::IDENTITY);
    }
    let id = tr.tracks()[0].id;
    assert_eq!(id, 1);
    assert!(
        matches!(selector.state(), TargetState::Lost { .. }),
        "{:?}",
        selector.state()
    );
    (tr, selector, id)
}

/// One lone leg beside where the lost target's track coasted to, at `ms`.
fn one_leg_out(tr: &Tracker, id: u64, ms: i64, from_shadow: bool) -> Observation {
    let mut t = tr.clone();
    t.process(at(ms), &[]);
    let p = t.track(id).unwrap().position().mean;
    Observation {
        from_shadow,
        ..Observation::laser(leg(p.x, p.y + 0.3), false, true)
    }
}

#[test]
fn the_lost_target_comes_back_on_the_first_leg_out_of_its_shadow() {
    let (tr, selector, id) = target_lost_behind_the_board();
    // Out of the shadow: the track takes the leg and the target is back at once.
    let (mut t, mut s) = (tr.clone(), selector.clone());
    let out = one_leg_out(&tr, id, 1600, true);
    assert_eq!(t.process(at(1600), &[out]).track_of[0], Some(id));
    assert_eq!(t.track(id).unwrap().came_out, Some(at(1600)));
    s.update(at(1600), t.tracks(), Pose2::IDENTITY);
    assert_eq!(s.state().locked_track(), Some(id));
    assert_eq!(s.transition(), Some(Transition::Back));
    // The same leg where the last scan saw nothing: one lone leg in a coasting track's
    // wide reach may be a phantom, and the track needs more before it is taken back.
    let (mut t, mut s) = (tr.clone(), selector.clone());
    let plain = one_leg_out(&tr, id, 1600, false);
    assert_eq!(t.process(at(1600), &[plain]).track_of[0], Some(id));
    assert_eq!(t.track(id).unwrap().came_out, None);
    s.update(at(1600), t.tracks(), Pose2::IDENTITY);
    assert_eq!(s.state().locked_track(), None);
    assert_eq!(s.refusals(), &[(id, Refusal::NoNewEvidence)]);
}

#[test]
fn a_target_back_on_one_leg_out_of_its_shadow_must_be_seen_again_soon() {
    let (tr, selector, id) = target_lost_behind_the_board();
    let back = |legs_after: bool| {
        let (mut t, mut s) = (tr.clone(), selector.clone());
        let out = one_leg_out(&tr, id, 1600, true);
        t.process(at(1600), &[out]);
        s.update(at(1600), t.tracks(), Pose2::IDENTITY);
        assert_eq!(s.state().locked_track(), Some(id));
        for ms in (1700..=2000).step_by(100) {
            let legs = if legs_after {
                let p = t.track(id).unwrap().position().mean;
                vec![Observation::laser(leg(p.x, p.y), true, false)]
            } else {
                vec![]
            };
            t.process(at(ms), &legs);
            s.update(at(ms), t.tracks(), Pose2::IDENTITY);
        }
        s.state()
    };
    // Seen again by the next scans: kept.
    assert_eq!(back(true).locked_track(), Some(id));
    // Not seen for longer than `handover_coast_s` (0.3 s): that leg was not them.
    assert!(matches!(back(false), TargetState::Lost { .. }));
}
