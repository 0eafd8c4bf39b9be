//! The plots of a run over time: distance and bearing to the target (the paper's Fig.
//! 15) and the commands.
//!
//! A long run (more than [`LONG_RUN_S`]) is drawn twice: over the whole run, each line
//! thinned to its least and greatest value per pixel column with the truth on top of
//! the estimate, and magnified over [`WINDOW_S`] around the moment the distance
//! departs most from d0 after the first lock (that window shaded in the first), where
//! every point is drawn.

use std::fmt::Write as _;

use tether_core::{Point2, wrap_angle_rad};
use tether_fusion::TargetState;

use crate::plot::{Plot, Series, View};
use tether_eval::closed_loop::{RunLog, StepKind};
use tether_eval::metrics::band_m;

use super::ESTIMATE;

/// A run longer than this is drawn whole and magnified, s.
pub const LONG_RUN_S: f64 = 90.0;
/// The magnified window of a long run, s.
pub const WINDOW_S: f64 = 30.0;
/// The shade of the magnified window in the whole run's plots.
pub const WINDOW_COLOR: &str = "#9edae5";

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

/// The window of a long run to magnify: [`WINDOW_S`] around the moment after the first
/// lock when the true distance departs most from d0 (the earliest of equals), within
/// the run; `None` for a run of at most [`LONG_RUN_S`].
pub fn window(plots: &[Plot], follow_distance_m: f64) -> Option<(f64, f64, f64)> {
    let distance = plots.first()?;
    let (truth, estimate) = (distance.series.first()?, distance.series.get(1)?);
    let (start, end) = (truth.points.first()?.0, truth.points.last()?.0);
    if end - start <= LONG_RUN_S {
        return None;
    }
    let first_lock = estimate
        .points
        .iter()
        .find(|p| p.1.is_some())
        .map_or(start, |p| p.0);
    let mut worst: Option<(f64, f64)> = None;
    for &(t, d) in truth.points.iter().filter(|p| p.0 >= first_lock) {
        let Some(off) = d.map(|d| (d - follow_distance_m).abs()) else {
            continue;
        };
        if off.is_finite() && worst.is_none_or(|(_, w)| off > w) {
            worst = Some((t, off));
        }
    }
    let at = worst.map_or(start, |w| w.0);
    let a = (at - WINDOW_S / 2.0).clamp(start, (end - WINDOW_S).max(start));
    Some((a, (a + WINDOW_S).min(end), at))
}

/// The plots of a run as HTML figures; a long run's whole and magnified (see the
/// module's documentation).
pub fn plots_html(log: &RunLog) -> String {
    let plots = run_plots(log);
    let mut s = String::new();
    let Some((a, b, at)) = window(&plots, log.follow_distance_m) else {
        for plot in &plots {
            let _ = writeln!(s, "<div class=\"figure\">{}</div>", plot.svg());
        }
        return s;
    };
    let _ = writeln!(
        s,
        "<p class=\"long-run\">A long run: each plot over the whole run shows, in every \
         pixel column, the least and the greatest value of each line (every peak stays), \
         the truth drawn over the estimate. The shaded {WINDOW_S:.0} s around t = {at:.1} \
         s, where the distance departs most from d0, is magnified below each, every point \
         drawn.</p>"
    );
    for (k, plot) in plots.iter().enumerate() {
        let mut whole = plot.clone();
        whole.spans.push((
            a,
            b,
            WINDOW_COLOR.to_owned(),
            format!("magnified below: {a:.0}–{b:.0} s"),
        ));
        // The commands have no truth: neither of their lines is drawn over the other.
        let overview = View {
            window: None,
            first_on_top: k < 2,
        };
        let mut zoom = plot.clone();
        zoom.title = format!("{}, {a:.0}–{b:.0} s magnified", plot.title);
        let _ = writeln!(
            s,
            "<div class=\"figure\">{}</div><div class=\"figure zoom\">{}</div>",
            whole.svg_view(&overview),
            zoom.svg_view(&View {
                window: Some((a, b)),
                first_on_top: false,
            })
        );
    }
    s
}
