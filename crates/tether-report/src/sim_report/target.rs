//! The report's section on the target: a band of its state over the run and the table
//! of its locks, losses and why.

use std::fmt::Write as _;

use tether_fusion::TargetStats;
use tether_live::target_log::{EventKind, TargetLog};
use tether_svg::xml_escape;

/// The report's section on the target (the simulator's and `replay`'s): a state band
/// over time and the table of events.
pub fn target_html(log: &TargetLog, counts: TargetStats) -> String {
    let s = log.summary(counts);
    let mut h = String::new();
    let _ = write!(
        h,
        "<p>Locked {:.1} s, lost {:.1} s, searching {:.1} s; {} locks, {} losses, {} \
         re-acquisitions ({} onto the same track), {} ambiguous candidate sets; longest \
         loss {:.1} s.</p>",
        s.locked_s,
        s.lost_s,
        s.searching_s,
        s.counts.locks,
        s.counts.losses,
        s.counts.reacquisitions,
        s.counts.reacquired_same_track,
        s.counts.ambiguous,
        s.longest_loss_s
    );
    h.push_str(&target_band(log));
    let _ = write!(
        h,
        "<table class=\"target-events\"><tr><th>t (s)</th><th>event</th><th>track</th>\
         <th>why</th></tr>"
    );
    for e in log.events() {
        let (what, track, why) = match &e.kind {
            EventKind::Locked { track } => ("locked", Some(*track), String::new()),
            EventKind::Lost { track, reason } => ("lost", Some(*track), reason.name().to_string()),
            EventKind::Reacquired {
                track,
                after_s,
                how,
            } => (
                "re-acquired",
                Some(*track),
                match how {
                    Some(how) => format!("{} after {after_s:.1} s", how.name()),
                    None => format!("after {after_s:.1} s"),
                },
            ),
            EventKind::HandedOver { from, track, how } => (
                "handed over",
                Some(*track),
                match how {
                    Some(how) => format!("from track {from}: {}", how.name()),
                    None => format!("from track {from}"),
                },
            ),
            EventKind::Searching => ("searching", None, "gave up".to_string()),
            EventKind::Refused {
                track,
                refusal,
                because,
            } => (
                "refused",
                Some(*track),
                match because {
                    Some(b) => format!("{} ({})", refusal.name(), b.name()),
                    None => refusal.name().to_string(),
                },
            ),
        };
        let _ = write!(
            h,
            "<tr class=\"{}\"><td>{:.1}</td><td>{what}</td><td>{}</td><td>{}</td></tr>",
            what.replace(' ', "-"),
            e.t_s,
            track.map_or(String::from("-"), |t| t.to_string()),
            xml_escape(&why)
        );
    }
    h.push_str("</table>");
    h
}

/// A band over the run: green while locked, red while lost, grey while searching.
fn target_band(log: &TargetLog) -> String {
    let end_s = log.span_s();
    let (width, height) = (720.0, 18.0);
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{width}\" height=\"{}\" \
         class=\"target-band\">",
        height + 14.0
    );
    let _ = write!(
        s,
        "<rect x=\"0\" y=\"0\" width=\"{width}\" height=\"{height}\" fill=\"#bbbbbb\"/>"
    );
    if end_s > 0.0 {
        let k = width / end_s;
        let mut state = ("#bbbbbb", 0.0);
        let mut spans = Vec::new();
        for e in log.events() {
            let color = match e.kind {
                EventKind::Locked { .. }
                | EventKind::Reacquired { .. }
                | EventKind::HandedOver { .. } => "#2ca02c",
                EventKind::Lost { .. } => "#d62728",
                EventKind::Searching => "#bbbbbb",
                EventKind::Refused { .. } => continue,
            };
            spans.push((state.0, state.1, e.t_s));
            state = (color, e.t_s);
        }
        spans.push((state.0, state.1, end_s));
        for (color, a, b) in spans {
            if b > a {
                let _ = write!(
                    s,
                    "<rect x=\"{:.1}\" y=\"0\" width=\"{:.1}\" height=\"{height}\" \
                     fill=\"{color}\"/>",
                    a * k,
                    (b - a) * k
                );
            }
        }
    }
    let _ = write!(
        s,
        "<text x=\"0\" y=\"{}\" font-size=\"11\">0 s; green: locked, red: lost, grey: \
         searching; {end_s:.1} s</text></svg>",
        height + 12.0
    );
    s
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, reason = "tests fail loudly")]

    use super::*;
    use tether_core::{Cov2, Gaussian2, Point2, Stamp, Vector2};
    use tether_fusion::{LossReason, Refusal, TargetState};

    #[test]
    fn the_target_section_says_what_happened_and_why() {
        let at = |ms: i64| Stamp::from_ns(ms * 1_000_000);
        let last = Gaussian2::new(Point2::new(1.0, 0.0), Cov2::isotropic(0.01).unwrap());
        let unseen = TargetState::Lost {
            track: 3,
            reason: LossReason::Unseen,
            since: at(1100),
            last: last.unwrap(),
            velocity: Vector2::ZERO,
            velocity_sigma_mps: 0.1,
        };
        let mut log = TargetLog::new();
        log.record(at(100), &TargetState::Locked { track: 3 }, &[]);
        log.record(at(1100), &unseen, &[]);
        log.record(at(1200), &unseen, &[(5, Refusal::NotWalking)]);
        log.record(at(1600), &TargetState::Locked { track: 5 }, &[]);
        let html = target_html(&log, log.counts_from_events());
        assert!(
            html.contains("unseen") && html.contains("not_walking"),
            "{html}"
        );
        assert!(html.contains("after 0.5 s"), "{html}");
        assert!(html.contains("class=\"target-band\""), "{html}");
    }
}
