//! `report.html`: one self-contained page (inline SVG, no scripts, no network) with,
//! per scenario, a top-down map of the true and estimated paths of target and robot,
//! the laser, vision and fused estimates with their covariance ellipses at a few
//! instants (the paper's Fig. 14), distance and bearing to the target over time (Fig.
//! 15) against the comfort band, the commands, and the measures; magnified views of
//! the target's estimates at a few instants show what fusion buys ([`insets`]).
//!
//! The pictures fit the page: a map's scale is chosen so that it is at most
//! [`MAP_MAX_WIDTH_PX`] wide (the page's width) and its map at most
//! [`MAP_MAX_HEIGHT_PX`] high, and every picture shrinks with a narrower window.

use std::fmt::Write as _;

use tether_core::{Gaussian2, Point2, World, wrap_angle_rad};
use tether_fusion::{TargetState, TargetStats};
use tether_live::target_log::{EventKind, TargetLog};
use tether_sim::svg::{LegendMark, MapSvg, person_color, xml_escape};
use tether_sim::{Scenario, StaticWorld};

use crate::closed_loop::{RunLog, StepKind};
use crate::metrics::{RunMetrics, band_m};
use crate::plot::{Plot, Series};

pub mod insets;

/// Widest map, px: within the page's 1,100 px.
pub const MAP_MAX_WIDTH_PX: f64 = 1040.0;
/// Highest map (without its title and legend), px.
pub const MAP_MAX_HEIGHT_PX: f64 = 720.0;
/// A map's largest scale, px per m.
const MAP_MAX_PX_PER_M: f64 = 50.0;

/// One scenario's material for the report.
pub struct ScenarioRun<'a> {
    /// The scenario.
    pub scenario: &'a Scenario,
    /// The run.
    pub log: &'a RunLog,
    /// Its measures.
    pub metrics: &'a RunMetrics,
}

const LASER: &str = "#1f77b4";
const VISION: &str = "#2ca02c";
const FUSED: &str = "#9467bd";
const ESTIMATE: &str = "#ff7f0e";

fn fmt_opt(v: Option<f64>, digits: usize) -> String {
    v.filter(|x| x.is_finite())
        .map_or("–".to_owned(), |x| format!("{x:.digits$}"))
}

/// The table of measures, one row per run.
pub fn metrics_table(rows: &[&RunMetrics]) -> String {
    let mut s = String::from(
        "<table><tr><th>scenario</th><th>seed</th><th>mean |d−d0| (m)</th><th>RMS d−d0 (m)</th><th>min d (m)</th>\
         <th>in band</th><th>target lost (s)</th><th>swaps</th><th>collisions</th><th>RMSE fused / laser / vision (m)</th>\
         <th>NEES</th><th>MOTA</th><th>MOTP (m)</th><th>ID sw.</th><th>RMS jerk (m/s³)</th></tr>\n",
    );
    for m in rows {
        let _ = writeln!(
            s,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:.2}</td><td>{}</td><td>{:.1}</td><td>{}</td><td>{}</td><td>{} / {} / {}</td><td>{}</td><td>{:.3}</td><td>{:.3}</td><td>{}</td><td>{:.1}</td></tr>",
            xml_escape(&m.scenario),
            m.seed,
            fmt_opt(m.mean_abs_distance_error_m, 3),
            fmt_opt(m.rms_distance_error_m, 3),
            m.min_distance_m,
            m.time_in_band_frac
                .map_or("–".to_owned(), |f| format!("{:.0} %", 100.0 * f)),
            m.target_lost_s,
            m.target_swaps,
            m.collisions,
            fmt_opt(m.rmse_fused_m, 3),
            fmt_opt(m.rmse_laser_m, 3),
            fmt_opt(m.rmse_vision_m, 3),
            fmt_opt(m.nees_mean, 2),
            m.mota,
            m.motp_m,
            m.id_switches,
            m.rms_jerk
        );
    }
    s.push_str("</table>\n");
    s
}

/// The map of one run.
pub fn run_map(scenario: &Scenario, log: &RunLog) -> String {
    let world = StaticWorld::from_scenario(scenario);
    let people_n = scenario.people.len();
    let mut paths: Vec<Vec<Point2<World>>> = vec![Vec::new(); people_n];
    let mut robot = Vec::new();
    let mut estimate: Vec<Point2<World>> = Vec::new();
    for step in log.steps.iter().filter(|s| s.kind == StepKind::Scan) {
        for (k, p) in step.truth.people.iter().enumerate() {
            if let Some(path) = paths.get_mut(k) {
                path.push(p.position);
            }
        }
        robot.push(step.truth.world_from_robot.translation());
        if let Some(e) = step.tick.as_ref().and_then(|t| t.target.estimate) {
            estimate.push(step.world_from_estimates() * e.mean);
        }
    }
    let extent = paths
        .iter()
        .flatten()
        .chain(&robot)
        .copied()
        .collect::<Vec<_>>();
    let mut map = MapSvg::fitted(
        scenario,
        &world,
        extent,
        MAP_MAX_PX_PER_M,
        MAP_MAX_WIDTH_PX,
        MAP_MAX_HEIGHT_PX,
    );
    for (k, (path, spec)) in paths.iter().zip(&scenario.people).enumerate() {
        // ("target (target)" says it once.)
        let label = if spec.target && !spec.name.contains("target") {
            format!("{} (target), true", spec.name)
        } else {
            format!("{}, true", spec.name)
        };
        map.path(path, person_color(k, spec.target), false, &label, true);
    }
    map.path(&estimate, ESTIMATE, true, "target, tracked estimate", false);
    map.path(&robot, "#222222", true, "robot", true);
    // Ellipses at a few instants (the paper's Fig. 14): the camera frames nearest to
    // five evenly spaced times, each sensor's estimate nearest the true target.
    let frames: Vec<_> = log
        .steps
        .iter()
        .filter(|s| {
            s.kind == StepKind::Camera
                && s.tick.as_ref().is_some_and(|t| !t.fused_people.is_empty())
        })
        .collect();
    let nearest = |list: &[Gaussian2<World>], p: Point2<World>| {
        list.iter()
            .min_by(|a, b| a.mean.distance_m(p).total_cmp(&b.mean.distance_m(p)))
            .filter(|g| g.mean.distance_m(p) < 1.0)
            .copied()
    };
    let mut instants = 0;
    for k in 0..5 {
        let Some(step) = frames.get(k * frames.len().saturating_sub(1) / 4) else {
            break;
        };
        let (Some(tick), Some(target)) = (&step.tick, step.truth.target()) else {
            continue;
        };
        let to_world = step.world_from_estimates();
        let nearest = |gs: &[Gaussian2<World>], p: Point2<World>| {
            let mapped: Vec<Gaussian2<World>> =
                gs.iter().map(|g| g.transformed(to_world)).collect();
            nearest(&mapped, p)
        };
        let laser = log
            .steps
            .iter()
            .rev()
            .find(|s| s.kind == StepKind::Scan && s.truth.stamp <= step.truth.stamp)
            .and_then(|s| s.tick.as_ref())
            .and_then(|t| nearest(&t.laser_people, target.position));
        if let Some(g) = laser {
            map.ellipse(&g, LASER, 2.0);
        }
        if let Some(g) = nearest(&tick.vision_people, target.position) {
            map.ellipse(&g, VISION, 2.0);
        }
        if let Some(g) = nearest(&tick.fused_people, target.position) {
            map.ellipse(&g, FUSED, 2.0);
        }
        map.robot(step.truth.world_from_robot, 0.5);
        map.label(
            target.position,
            &format!("{:.1} s", step.truth.stamp.secs_f64()),
            "#444444",
        );
        instants += 1;
    }
    // Where the magnified views below the map are taken.
    let zooms = insets::insets(log);
    for inset in &zooms {
        map.zoom_box(
            inset.view.center,
            inset.view.side_m(),
            insets::ZOOM_COLOR,
            &inset.letter.to_string(),
        );
    }
    if instants > 0 {
        map.legend_mark("laser estimate (2σ)", LASER, LegendMark::Ellipse);
        map.legend_mark("vision estimate (2σ)", VISION, LegendMark::Ellipse);
        map.legend_mark("fused estimate (2σ)", FUSED, LegendMark::Ellipse);
        map.legend_mark(
            "robot at the instants labelled with their time",
            "#222222",
            LegendMark::Robot,
        );
    }
    if !zooms.is_empty() {
        let letters: Vec<String> = zooms.iter().map(|z| z.letter.to_string()).collect();
        map.legend_mark(
            &format!("magnified below ({})", letters.join(", ")),
            insets::ZOOM_COLOR,
            LegendMark::Square,
        );
    }
    map.finish()
}

/// Distance and bearing to the target over time (the paper's Fig. 15) and the
/// commands.
pub fn run_plots(log: &RunLog) -> Vec<Plot> {
    let mut d_true = Vec::new();
    let mut d_est = Vec::new();
    let mut b_true = Vec::new();
    let mut b_est = Vec::new();
    let mut v = Vec::new();
    let mut w = Vec::new();
    let mut lost_spans: Vec<(f64, f64)> = Vec::new();
    let mut lost_from: Option<f64> = None;
    for step in log.steps.iter().filter(|s| s.kind == StepKind::Timer) {
        let t = step.truth.stamp.secs_f64();
        let Some(target) = step.truth.target() else {
            continue;
        };
        let robot_from_world = step.truth.world_from_robot.inverse();
        let j = Point2::<tether_core::Robot>::new(log.attach_ahead_m, 0.0);
        let p = robot_from_world * target.position;
        d_true.push((t, Some(p.distance_m(j))));
        b_true.push((t, Some(wrap_angle_rad(p.bearing_rad()).to_degrees())));
        let tick = step.tick.as_ref();
        let est = tick.and_then(|k| match k.target.state {
            TargetState::Locked { .. } => k.target.estimate,
            _ => None,
        });
        // Estimates are in the frame of the pose the pipeline was given.
        let pe = est.map(|e| step.world_from_robot_given.inverse() * e.mean);
        d_est.push((t, pe.map(|q| q.distance_m(j))));
        b_est.push((t, pe.map(|q| wrap_angle_rad(q.bearing_rad()).to_degrees())));
        v.push((t, tick.map(|k| k.command.v_mps)));
        w.push((t, tick.map(|k| k.command.w_radps)));
        match (est.is_none(), lost_from) {
            (true, None) => lost_from = Some(t),
            (false, Some(a)) => {
                lost_spans.push((a, t));
                lost_from = None;
            }
            _ => {}
        }
    }
    if let (Some(a), Some(last)) = (lost_from, d_true.last()) {
        lost_spans.push((a, last.0));
    }
    let spans: Vec<(f64, f64, String, String)> = lost_spans
        .iter()
        .enumerate()
        .map(|(k, (a, b))| {
            (
                *a,
                *b,
                "#bbbbbb".to_owned(),
                if k == 0 {
                    "no locked target".to_owned()
                } else {
                    String::new()
                },
            )
        })
        .collect();
    let series = |label: &str, color: &str, dashed: bool, points: Vec<(f64, Option<f64>)>| Series {
        label: label.to_owned(),
        color: color.to_owned(),
        dashed,
        points,
    };
    vec![
        Plot {
            title: "Distance to the target (from the spring's attachment point)".into(),
            y_label: "d (m)".into(),
            series: vec![
                series("true", "#d62728", false, d_true),
                series("estimated", ESTIMATE, true, d_est),
            ],
            bands: vec![{
                let (low, high) = band_m(log.follow_distance_m);
                (
                    low,
                    high,
                    "#2ca02c".into(),
                    format!("comfort band {low:.1}–{high:.1} m"),
                )
            }],
            hlines: vec![(
                log.follow_distance_m,
                "#000000".into(),
                format!("d0 = {} m", log.follow_distance_m),
            )],
            spans: spans.clone(),
        },
        Plot {
            title: "Bearing to the target".into(),
            y_label: "bearing (deg)".into(),
            series: vec![
                series("true", "#d62728", false, b_true),
                series("estimated", ESTIMATE, true, b_est),
            ],
            bands: Vec::new(),
            hlines: vec![(0.0, "#888888".into(), "straight ahead".into())],
            spans: spans.clone(),
        },
        Plot {
            title: "Commands".into(),
            y_label: "v (m/s), w (rad/s)".into(),
            series: vec![
                series("v", "#1f77b4", false, v),
                series("w", "#ff7f0e", false, w),
            ],
            bands: Vec::new(),
            hlines: Vec::new(),
            spans,
        },
    ]
}

/// A scenario's section.
pub fn scenario_section(run: &ScenarioRun<'_>) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "<section id=\"{0}\"><h2>{0}</h2><p>{1}</p>",
        xml_escape(&run.scenario.name),
        xml_escape(&run.scenario.description)
    );
    let _ = writeln!(
        s,
        "<div class=\"figure\">{}</div>",
        run_map(run.scenario, run.log)
    );
    s.push_str(&insets::html(&run.scenario.name, &insets::insets(run.log)));
    for plot in run_plots(run.log) {
        let _ = writeln!(s, "<div class=\"figure\">{}</div>", plot.svg());
    }
    s.push_str(&metrics_table(&[run.metrics]));
    let mut target = TargetLog::new();
    for step in &run.log.steps {
        if let Some(tick) = &step.tick {
            target.record_tick(tick);
        }
    }
    let _ = writeln!(
        s,
        "<h3>Target: locks, losses and why</h3>{}",
        target_html(&target, target.counts_from_events())
    );
    s.push_str("</section>\n");
    s
}

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

/// The whole page. `extra` sections (title, HTML) come after the scenarios.
pub fn html(
    title: &str,
    intro_html: &str,
    runs: &[ScenarioRun<'_>],
    extra: &[(String, String)],
) -> String {
    let mut s = page_head(title);
    let _ = writeln!(s, "<h1>{}</h1>{intro_html}", xml_escape(title));
    s.push_str("<nav>");
    for r in runs {
        let _ = write!(s, "<a href=\"#{0}\">{0}</a>", xml_escape(&r.scenario.name));
    }
    s.push_str("</nav>\n<h2>Summary</h2>\n");
    s.push_str(&metrics_table(
        &runs.iter().map(|r| r.metrics).collect::<Vec<_>>(),
    ));
    for r in runs {
        s.push_str(&scenario_section(r));
    }
    for (t, body) in extra {
        let _ = writeln!(s, "<section><h2>{}</h2>{body}</section>", xml_escape(t));
    }
    s.push_str("</body></html>\n");
    s
}

/// A page of plain sections (title, HTML), in the report's style.
pub fn simple_page(title: &str, intro_html: &str, sections: &[(String, String)]) -> String {
    let mut s = page_head(title);
    let _ = writeln!(s, "<h1>{}</h1>{intro_html}", xml_escape(title));
    for (t, body) in sections {
        let _ = writeln!(s, "<section><h2>{}</h2>{body}</section>", xml_escape(t));
    }
    s.push_str("</body></html>\n");
    s
}

/// The document head with the report's style, and the opening `body` tag.
fn page_head(title: &str) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{}</title>\n<style>\n\
         body {{ font-family: sans-serif; margin: 24px auto; max-width: 1100px; color: #222; }}\n\
         table {{ border-collapse: collapse; margin: 12px 0; font-size: 13px; }}\n\
         th, td {{ border: 1px solid #ccc; padding: 3px 7px; text-align: right; }}\n\
         th {{ background: #f3f3f3; }} td:first-child {{ text-align: left; }}\n\
         .figure {{ margin: 10px 0; overflow-x: auto; }} nav a {{ margin-right: 12px; }}\n\
         .insets {{ display: flex; flex-wrap: wrap; gap: 14px; margin: 10px 0; }}\n\
         figure.inset {{ margin: 0; max-width: 320px; font-size: 13px; }}\n\
         section {{ border-top: 1px solid #ddd; margin-top: 28px; }}\n</style></head><body>",
        xml_escape(title)
    );
    s
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, reason = "tests fail loudly")]

    use super::*;
    use tether_core::{Cov2, Stamp, Vector2};
    use tether_fusion::{LossReason, Refusal};

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
