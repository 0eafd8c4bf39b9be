//! "What fusion buys": magnified views (insets) of the target's estimates at a few
//! instants of a run, each showing the laser's, the camera's and the fused estimate of
//! the target at one scale, as 2-sigma ellipses, with the true position, the direction
//! to the robot, a scale bar and a legend. On the run's map, a dashed square marks
//! where each inset is taken.
//!
//! # Which instants
//!
//! The candidates are the camera frames at which the laser (its person observation
//! from the last scan), the camera and their fusion each have an estimate within 1 m of
//! the true target. Preferred are frames whose fused estimate lies within 3 sigma of
//! both the laser's and the camera's (so that it is their fusion, not another
//! person's) and taken at most [`MAX_LASER_AGE_S`] after the scan (so that the laser's
//! estimate is of the same moment); failing those, frames that agree; failing those,
//! any. Of them, in this order, each at least [`MIN_APART_S`] from those chosen
//! before (when one is):
//!
//! - **A**, the laser alone uncertain: the greatest ratio of the laser's major axis
//!   to the fused one's;
//! - **B**, the camera alone uncertain: the same ratio for the camera;
//! - **C**, fusion's best gain: the greatest ratio of the smaller of the laser's and
//!   the camera's ellipse areas to the fused one's.
//!
//! Ties go to the earliest frame; the run's steps are gone through in order, so the
//! same run gives the same instants and the same bytes.

use std::fmt::Write as _;

use tether_core::{Gaussian2, Point2, Pose2, Robot, World};
use tether_svg::{length_text, round_length_m, xml_escape};

use tether_eval::closed_loop::{RunLog, StepKind};

use super::{FUSED, LASER, VISION};

/// Side of an inset's square view, px.
pub const INSET_PX: f64 = 300.0;
/// Least width (major axis, 2 sigma) of an ellipse in an inset, px: an inset's scale
/// is at least what makes every one of its ellipses this wide.
pub const MIN_ELLIPSE_PX: f64 = 40.0;
/// Free space between the widest reach of the ellipses and the view's edge, px.
pub const EDGE_PX: f64 = 12.0;
/// Largest scale of an inset, px per m (1 mm = 20 px), for degenerate covariances.
const MAX_PX_PER_M: f64 = 20_000.0;
/// Frames at most this long after the laser's scan are preferred, s.
pub const MAX_LASER_AGE_S: f64 = 0.02;
/// Least time between two chosen instants, s.
pub const MIN_APART_S: f64 = 1.0;
/// Padding around the view inside the picture, px.
const PAD_PX: f64 = 10.0;
/// Height of the legend below the view, px.
const LEGEND_PX: f64 = 48.0;
/// The outline of a sensor's ellipse.
const SENSOR_STROKE: &str = "stroke-width=\"2.5\"";
/// The outline of the fused ellipse, dashed.
const FUSED_STROKE: &str = "stroke-width=\"2\" stroke-dasharray=\"7 3\"";
/// Colour of the insets' marks on the map.
pub const ZOOM_COLOR: &str = "#444444";

/// Why an instant is shown.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Why {
    /// The laser alone is uncertain.
    LaserUncertain,
    /// The camera alone is uncertain.
    CameraUncertain,
    /// Fusion gains most over the better of the two.
    FusionGain,
}

impl Why {
    /// The insets in the order they are chosen.
    pub const ALL: [Why; 3] = [Why::LaserUncertain, Why::CameraUncertain, Why::FusionGain];

    /// A few words for the caption.
    pub fn text(self) -> &'static str {
        match self {
            Why::LaserUncertain => "the laser alone is uncertain",
            Why::CameraUncertain => "the camera alone is uncertain",
            Why::FusionGain => "fusion gains most over the better sensor",
        }
    }

    /// How much this instant shows it (greater is better).
    fn score(self, c: &Candidate) -> f64 {
        let major = |g: &Gaussian2<World>| semi_axes_2sigma(g).0;
        let area = |g: &Gaussian2<World>| {
            let (a, b) = semi_axes_2sigma(g);
            a * b
        };
        let ratio = |a: f64, b: f64| if b > 0.0 { a / b } else { 0.0 };
        match self {
            Why::LaserUncertain => ratio(major(&c.laser), major(&c.fused)),
            Why::CameraUncertain => ratio(major(&c.vision), major(&c.fused)),
            Why::FusionGain => ratio(area(&c.laser).min(area(&c.vision)), area(&c.fused)),
        }
    }
}

/// One camera frame's estimates of the target (in the world, mapped from the
/// pipeline's frame as the map draws them) and the truth.
#[derive(Debug, Clone, Copy)]
pub struct Candidate {
    /// The frame's time, s.
    pub stamp_s: f64,
    /// The target's true position.
    pub truth: Point2<World>,
    /// The robot's true pose.
    pub robot: Pose2<World, Robot>,
    /// The laser's estimate (its person observation of the last scan).
    pub laser: Gaussian2<World>,
    /// How long before the frame that scan was taken, s.
    pub laser_age_s: f64,
    /// The camera's estimate.
    pub vision: Gaussian2<World>,
    /// Their fusion.
    pub fused: Gaussian2<World>,
}

impl Candidate {
    /// The fused estimate lies within 3 sigma of the laser's and of the camera's: it
    /// is their fusion, not another person's.
    pub fn agrees(&self) -> bool {
        self.laser.mahalanobis_sq(self.fused.mean) <= 9.0
            && self.vision.mahalanobis_sq(self.fused.mean) <= 9.0
    }
}

/// An inset: the instant, why, its letter and its view.
#[derive(Debug, Clone)]
pub struct Inset {
    /// The instant.
    pub at: Candidate,
    /// Why it is shown.
    pub why: Why,
    /// "A", "B", "C".
    pub letter: char,
    /// What it shows.
    pub view: View,
}

/// The square an inset shows: its centre and scale.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct View {
    /// Centre of the view.
    pub center: Point2<World>,
    /// Pixels per metre.
    pub px_per_m: f64,
}

impl View {
    /// The view's side, m.
    pub fn side_m(&self) -> f64 {
        INSET_PX / self.px_per_m
    }
}

/// The 2-sigma semi-axes (major, minor) of an estimate, m.
pub fn semi_axes_2sigma(g: &Gaussian2<World>) -> (f64, f64) {
    let (major, minor, _) = g.cov.principal_axes();
    (2.0 * major.max(0.0).sqrt(), 2.0 * minor.max(0.0).sqrt())
}

/// The estimate of `list` nearest `p`, if within 1 m.
fn nearest(list: &[Gaussian2<World>], p: Point2<World>) -> Option<Gaussian2<World>> {
    list.iter()
        .filter(|g| g.mean.is_finite() && g.mean.distance_m(p) < 1.0)
        .min_by(|a, b| a.mean.distance_m(p).total_cmp(&b.mean.distance_m(p)))
        .copied()
}

/// Every camera frame of the run with a laser, a camera and a fused estimate of the
/// target, in time order.
pub fn candidates(log: &RunLog) -> Vec<Candidate> {
    let mut out = Vec::new();
    // The last scan's laser people, in the world, and its time.
    let mut last_scan: Option<(f64, Vec<Gaussian2<World>>)> = None;
    for step in &log.steps {
        let Some(tick) = &step.tick else {
            continue;
        };
        let to_world = step.world_from_estimates();
        let mapped = |gs: &[Gaussian2<World>]| -> Vec<Gaussian2<World>> {
            gs.iter().map(|g| g.transformed(to_world)).collect()
        };
        let stamp_s = step.truth.stamp.secs_f64();
        match step.kind {
            StepKind::Scan => last_scan = Some((stamp_s, mapped(&tick.laser_people))),
            StepKind::Camera if !tick.fused_people.is_empty() => {
                let (Some(target), Some((scan_s, laser_people))) =
                    (step.truth.target(), &last_scan)
                else {
                    continue;
                };
                let p = target.position;
                let (Some(laser), Some(vision), Some(fused)) = (
                    nearest(laser_people, p),
                    nearest(&mapped(&tick.vision_people), p),
                    nearest(&mapped(&tick.fused_people), p),
                ) else {
                    continue;
                };
                out.push(Candidate {
                    stamp_s,
                    truth: p,
                    robot: step.truth.world_from_robot,
                    laser,
                    laser_age_s: stamp_s - scan_s,
                    vision,
                    fused,
                });
            }
            _ => {}
        }
    }
    out
}

/// The instants to show (see the module's documentation): indices into `candidates`
/// with why, in the order A, B, C; fewer when there are fewer candidates.
pub fn choose(candidates: &[Candidate]) -> Vec<(Why, usize)> {
    // Preferred: the fused estimate agrees with both (it is their fusion, not another
    // person's), and the scan is of the frame's moment; else agreeing; else any.
    let fresh = |c: &Candidate| c.laser_age_s <= MAX_LASER_AGE_S;
    let tiers: [&dyn Fn(&Candidate) -> bool; 3] =
        [&|c| c.agrees() && fresh(c), &|c| c.agrees(), &|_| true];
    let pool: Vec<usize> = tiers
        .iter()
        .map(|keep| {
            (0..candidates.len())
                .filter(|&i| keep(&candidates[i]))
                .collect::<Vec<_>>()
        })
        .find(|pool| !pool.is_empty())
        .unwrap_or_default();
    let mut chosen: Vec<(Why, usize)> = Vec::new();
    for why in Why::ALL {
        let taken = |i: usize, apart: f64| {
            chosen.iter().any(|&(_, j)| {
                i == j || (candidates[i].stamp_s - candidates[j].stamp_s).abs() < apart
            })
        };
        let best = |apart: f64| {
            let mut best: Option<(usize, f64)> = None;
            for &i in &pool {
                let score = why.score(&candidates[i]);
                if taken(i, apart) || !score.is_finite() {
                    continue;
                }
                if best.is_none_or(|(_, s)| score > s) {
                    best = Some((i, score));
                }
            }
            best
        };
        // Apart from those chosen before when one is, else only another frame.
        if let Some((i, _)) = best(MIN_APART_S).or_else(|| best(0.0)) {
            chosen.push((why, i));
        }
    }
    chosen
}

/// The view of an instant: centred on the fused estimate, at the scale that shows
/// every ellipse and the true position with [`EDGE_PX`] to spare, or larger when that
/// leaves an ellipse narrower than [`MIN_ELLIPSE_PX`] (the widest may then run off the
/// view).
pub fn view_for(c: &Candidate) -> View {
    let center = c.fused.mean;
    let ellipses = [c.laser, c.vision, c.fused];
    let reach = ellipses
        .iter()
        .map(|g| g.mean.distance_m(center) + semi_axes_2sigma(g).0)
        .fold(c.truth.distance_m(center), f64::max);
    let narrowest = ellipses
        .iter()
        .map(|g| semi_axes_2sigma(g).0)
        .fold(f64::INFINITY, f64::min);
    let fit = (INSET_PX / 2.0 - EDGE_PX) / reach;
    let wide_enough = MIN_ELLIPSE_PX / (2.0 * narrowest);
    let k = [fit, wide_enough]
        .into_iter()
        .filter(|k| k.is_finite() && *k > 0.0)
        .fold(0.0, f64::max);
    View {
        center,
        px_per_m: if k > 0.0 {
            k.min(MAX_PX_PER_M)
        } else {
            MAX_PX_PER_M
        },
    }
}

/// The insets of a run, in the order A, B, C.
pub fn insets(log: &RunLog) -> Vec<Inset> {
    let candidates = candidates(log);
    choose(&candidates)
        .into_iter()
        .zip('A'..='Z')
        .map(|((why, i), letter)| {
            let at = candidates[i];
            Inset {
                at,
                why,
                letter,
                view: view_for(&at),
            }
        })
        .collect()
}

/// An id from a name: its letters and digits, the rest as '-'.
fn id_part(name: &str) -> String {
    name.chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
        .collect()
}

/// An ellipse of an estimate in an inset, 2 sigma, with a dot at its mean; `stroke`
/// is the outline's width and dashes.
fn ellipse(
    g: &Gaussian2<World>,
    px: &impl Fn(Point2<World>) -> (f64, f64),
    k: f64,
    color: &str,
    stroke: &str,
) -> String {
    let (major, minor, angle) = g.cov.principal_axes();
    let (rx, ry) = (
        (2.0 * major.max(0.0).sqrt() * k).max(1.0),
        (2.0 * minor.max(0.0).sqrt() * k).max(1.0),
    );
    let (cx, cy) = px(g.mean);
    // SVG turns clockwise with y down: the world's angle maps to its negative.
    format!(
        "<ellipse cx=\"{cx:.1}\" cy=\"{cy:.1}\" rx=\"{rx:.1}\" ry=\"{ry:.1}\" \
         transform=\"rotate({:.1} {cx:.1} {cy:.1})\" fill=\"{color}\" fill-opacity=\"0.12\" \
         stroke=\"{color}\" {stroke}/><circle cx=\"{cx:.1}\" cy=\"{cy:.1}\" r=\"2.5\" \
         fill=\"{color}\"/>",
        -angle.to_degrees()
    )
}

/// The inset's picture.
pub fn inset_svg(inset: &Inset, id: &str) -> String {
    let View {
        center,
        px_per_m: k,
    } = inset.view;
    let (w, h) = (INSET_PX + 2.0 * PAD_PX, INSET_PX + 2.0 * PAD_PX + LEGEND_PX);
    let (l, t) = (PAD_PX, PAD_PX);
    let px = |p: Point2<World>| {
        (
            l + INSET_PX / 2.0 + (p.x - center.x) * k,
            t + INSET_PX / 2.0 - (p.y - center.y) * k,
        )
    };
    let mut s = String::new();
    let _ = write!(
        s,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" class=\"inset-zoom\" \
         style=\"max-width:100%;height:auto\" width=\"{w:.0}\" height=\"{h:.0}\" \
         viewBox=\"0 0 {w:.0} {h:.0}\" font-family=\"sans-serif\" font-size=\"11\">\
         <rect width=\"100%\" height=\"100%\" fill=\"#ffffff\"/><defs><clipPath id=\"{id}\">\
         <rect x=\"{l}\" y=\"{t}\" width=\"{INSET_PX}\" height=\"{INSET_PX}\"/></clipPath></defs>\
         <rect x=\"{l}\" y=\"{t}\" width=\"{INSET_PX}\" height=\"{INSET_PX}\" fill=\"#fcfcfc\" \
         stroke=\"#888888\"/><g clip-path=\"url(#{id})\">"
    );
    // A grid at the scale bar's length.
    let bar_m = round_length_m(0.3 * INSET_PX / k);
    let half = INSET_PX / 2.0 / k;
    let lines = |c: f64| {
        let (a, b) = (((c - half) / bar_m).ceil(), ((c + half) / bar_m).floor());
        (a as i64..=b as i64).map(move |i| i as f64 * bar_m)
    };
    for x in lines(center.x) {
        let (u, _) = px(Point2::new(x, center.y));
        let _ = write!(
            s,
            "<line x1=\"{u:.1}\" y1=\"{t}\" x2=\"{u:.1}\" y2=\"{:.1}\" stroke=\"#ececec\"/>",
            t + INSET_PX
        );
    }
    for y in lines(center.y) {
        let (_, v) = px(Point2::new(center.x, y));
        let _ = write!(
            s,
            "<line x1=\"{l}\" y1=\"{v:.1}\" x2=\"{:.1}\" y2=\"{v:.1}\" stroke=\"#ececec\"/>",
            l + INSET_PX
        );
    }
    // Towards the robot, from the true position: the camera's line of sight.
    let at = &inset.at;
    let robot = at.robot.translation();
    let (tu, tv) = px(at.truth);
    let d = robot.distance_m(at.truth);
    if d > 0.0 {
        let (dx, dy) = ((robot.x - at.truth.x) / d, -(robot.y - at.truth.y) / d);
        let reach = 2.0 * INSET_PX;
        let _ = write!(
            s,
            "<line class=\"sight\" x1=\"{tu:.1}\" y1=\"{tv:.1}\" x2=\"{:.1}\" y2=\"{:.1}\" \
             stroke=\"#999999\" stroke-dasharray=\"5 4\"/>",
            tu + dx * reach,
            tv + dy * reach
        );
    }
    // The fused outline dashed, so that a sensor's ellipse it coincides with shows
    // through.
    for (g, color, stroke) in [
        (&at.vision, VISION, SENSOR_STROKE),
        (&at.laser, LASER, SENSOR_STROKE),
        (&at.fused, FUSED, FUSED_STROKE),
    ] {
        s.push_str(&ellipse(g, &px, k, color, stroke));
    }
    let _ = write!(
        s,
        "<path class=\"truth\" d=\"M{:.1} {:.1}l10 10m0 -10l-10 10\" stroke=\"#000000\" \
         stroke-width=\"2\"/></g>",
        tu - 5.0,
        tv - 5.0
    );
    // The scale bar, lower right.
    let len = bar_m * k;
    let (x1, y) = (l + INSET_PX - 10.0, t + INSET_PX - 10.0);
    let x0 = x1 - len;
    let _ = write!(
        s,
        "<g class=\"scale-bar\"><rect x=\"{:.1}\" y=\"{:.1}\" width=\"{:.1}\" height=\"26\" \
         fill=\"#ffffff\" fill-opacity=\"0.85\"/><path d=\"M{x0:.1} {:.1}V{y:.1}H{x1:.1}V{:.1}\" \
         fill=\"none\" stroke=\"#000000\" stroke-width=\"2\"/><text x=\"{:.1}\" y=\"{:.1}\" \
         text-anchor=\"middle\" font-weight=\"bold\">{}</text></g>",
        x0 - 6.0,
        y - 20.0,
        len + 12.0,
        y - 5.0,
        y - 5.0,
        (x0 + x1) / 2.0,
        y - 8.0,
        length_text(bar_m)
    );
    // The legend, two columns.
    let entries: [(&str, String); 5] = [
        (
            "laser alone (2σ)",
            format!(
                "<ellipse cx=\"11\" cy=\"-4\" rx=\"10\" ry=\"5\" fill=\"{LASER}\" \
                 fill-opacity=\"0.12\" stroke=\"{LASER}\" {SENSOR_STROKE}/>"
            ),
        ),
        (
            "camera alone (2σ)",
            format!(
                "<ellipse cx=\"11\" cy=\"-4\" rx=\"10\" ry=\"5\" fill=\"{VISION}\" \
                 fill-opacity=\"0.12\" stroke=\"{VISION}\" {SENSOR_STROKE}/>"
            ),
        ),
        (
            "fused (2σ)",
            format!(
                "<ellipse cx=\"11\" cy=\"-4\" rx=\"10\" ry=\"5\" fill=\"{FUSED}\" \
                 fill-opacity=\"0.12\" stroke=\"{FUSED}\" {FUSED_STROKE}/>"
            ),
        ),
        (
            "true position",
            "<path d=\"M6 -9l10 10m0 -10l-10 10\" stroke=\"#000000\" stroke-width=\"2\"/>"
                .to_owned(),
        ),
        (
            "towards the robot",
            "<line x1=\"0\" y1=\"-4\" x2=\"22\" y2=\"-4\" stroke=\"#999999\" \
             stroke-dasharray=\"5 4\"/>"
                .to_owned(),
        ),
    ];
    for (n, (label, mark)) in entries.iter().enumerate() {
        let (x, y) = (
            l + (n % 2) as f64 * (INSET_PX / 2.0),
            t + INSET_PX + 20.0 + (n / 2) as f64 * 16.0,
        );
        let _ = write!(
            s,
            "<g class=\"legend-entry\" transform=\"translate({x:.1} {y:.1})\">{mark}\
             <text x=\"28\" y=\"0\">{}</text></g>",
            xml_escape(label)
        );
    }
    s.push_str("</svg>");
    s
}

/// The caption of an inset: when, why, the sizes of the ellipses and how far each
/// estimate is from the truth.
pub fn caption(inset: &Inset) -> String {
    let at = &inset.at;
    let axes = |g: &Gaussian2<World>| {
        let (a, b) = semi_axes_2sigma(g);
        format!("{:.0} × {:.0} cm", 100.0 * a, 100.0 * b)
    };
    let off = |g: &Gaussian2<World>| format!("{:.0} cm", 100.0 * g.mean.distance_m(at.truth));
    format!(
        "<b>{}</b> · t = {:.1} s: {}. Half-axes (2σ): laser {}, camera {}, fused {}. \
         Off the truth: laser {}, camera {}, fused {}. {}",
        inset.letter,
        at.stamp_s,
        inset.why.text(),
        axes(&at.laser),
        axes(&at.vision),
        axes(&at.fused),
        off(&at.laser),
        off(&at.vision),
        off(&at.fused),
        if at.laser_age_s < 0.0005 {
            "The laser's scan and the camera's frame are of the same instant.".to_owned()
        } else {
            format!(
                "The laser's scan is {:.0} ms older than the camera's frame.",
                1000.0 * at.laser_age_s
            )
        }
    )
}

/// The "what fusion buys" part of a scenario's section: the insets side by side, or
/// a line saying why there are none. A run driven by the laser alone (`laser_only`)
/// has no fusion: its part says so under a heading of its own.
pub fn html(scenario_name: &str, insets: &[Inset], laser_only: bool) -> String {
    if laser_only && insets.is_empty() {
        return String::from(
            "<h3>Laser only: no fusion to magnify</h3>\n<p class=\"no-insets\">The camera is \
             off in this run: the laser alone finds, tracks and follows the target, so there is \
             no camera estimate and no fused one to set beside the laser's. The same scenario \
             with the camera on shows what fusion buys.</p>\n",
        );
    }
    let mut s = String::from("<h3>What fusion buys</h3>\n");
    if insets.is_empty() {
        s.push_str(
            "<p class=\"no-insets\">No camera frame of this run has a laser, a camera and a \
             fused estimate of the target (the camera is off, or never saw the target): \
             nothing to magnify.</p>\n",
        );
        return s;
    }
    let letters: Vec<String> = insets.iter().map(|i| i.letter.to_string()).collect();
    let _ = writeln!(
        s,
        "<p>The target's estimates at {} instants of the run (dashed squares {} on the map), \
         magnified, each at its own scale (see its scale bar): the laser's person observation \
         (from the last scan), the camera's, and their fusion, as 2σ ellipses, with the true \
         position. The camera is uncertain along its line of sight (dashed), the laser \
         where the legs are hard to pair.</p>",
        insets.len(),
        letters.join(", ")
    );
    s.push_str("<div class=\"insets\">");
    for inset in insets {
        let id = format!("inset-{}-{}", id_part(scenario_name), inset.letter);
        let _ = write!(
            s,
            "<figure class=\"inset\" id=\"{id}-figure\">{}<figcaption>{}</figcaption></figure>",
            inset_svg(inset, &id),
            caption(inset)
        );
    }
    s.push_str("</div>\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use tether_core::Cov2;

    fn gaussian(x: f64, y: f64, sx: f64, sy: f64, angle: f64) -> Gaussian2<World> {
        let cov = Cov2::new(sx * sx, 0.0, sy * sy).unwrap().rotated(angle);
        Gaussian2::new(Point2::new(x, y), cov).unwrap()
    }

    fn candidate(t: f64, laser_sigma: f64, vision_sigma: f64) -> Candidate {
        Candidate {
            stamp_s: t,
            truth: Point2::new(5.0, 0.0),
            robot: Pose2::new(3.0, 0.0, 0.0),
            laser: gaussian(5.01, 0.0, laser_sigma, 0.02, 0.0),
            laser_age_s: 0.0,
            vision: gaussian(5.1, 0.02, vision_sigma, 0.03, 0.0),
            fused: gaussian(5.0, 0.0, 0.02, 0.02, 0.0),
        }
    }

    #[test]
    fn an_insets_scale_shows_every_ellipse_at_least_min_px_wide() {
        // A laser of 1.5 cm beside a camera of 60 cm (along its line of sight): fitting
        // the camera's ellipse alone would leave the laser's 9 px wide.
        for (laser, vision) in [(0.015, 0.6), (0.05, 0.3), (0.2, 0.2), (0.003, 2.0)] {
            let c = candidate(1.0, laser, vision);
            let view = view_for(&c);
            for g in [c.laser, c.vision, c.fused] {
                let width_px = 2.0 * semi_axes_2sigma(&g).0 * view.px_per_m;
                assert!(
                    width_px >= MIN_ELLIPSE_PX - 1e-9,
                    "{laser}/{vision}: {width_px} px"
                );
            }
        }
        // When they are alike, all of them fit in the view.
        let mut c = candidate(1.0, 0.1, 0.2);
        c.fused = gaussian(5.02, 0.0, 0.08, 0.03, 0.3);
        let view = view_for(&c);
        let reach_px =
            (c.vision.mean.distance_m(view.center) + semi_axes_2sigma(&c.vision).0) * view.px_per_m;
        assert!(reach_px <= INSET_PX / 2.0, "{reach_px}");
        // Degenerate covariances do not make an infinite scale.
        let mut c = candidate(1.0, 0.1, 0.2);
        c.laser = Gaussian2::new(Point2::new(5.0, 0.0), Cov2::isotropic(1e-9).unwrap()).unwrap();
        assert!(view_for(&c).px_per_m.is_finite());
    }

    #[test]
    fn instants_are_chosen_by_their_sensor_and_apart() {
        let candidates = vec![
            candidate(0.0, 0.02, 0.3),
            candidate(0.5, 0.15, 0.3), // the laser's worst, first
            candidate(0.6, 0.15, 0.9), // within 1 s of it: not for the camera
            candidate(2.0, 0.02, 0.8), // the camera's worst apart from it
            candidate(4.0, 0.15, 0.3), // ties with 0.5 s: the earlier one wins
        ];
        let chosen = choose(&candidates);
        assert_eq!(chosen[0], (Why::LaserUncertain, 1));
        assert_eq!(chosen[1], (Why::CameraUncertain, 3));
        assert_eq!(chosen.len(), 3);
        assert!(![1, 3].contains(&chosen[2].1));
        // A fused estimate of someone else (far outside the camera's ellipse) is
        // passed over.
        let mut other = candidates.clone();
        other[1].fused.mean = Point2::new(5.0, 0.5);
        assert!(!other[1].agrees() && other[2].agrees());
        assert_eq!(choose(&other)[0], (Why::LaserUncertain, 2));
        // Frames right after their scan are preferred.
        let mut stale = candidates.clone();
        stale[1].laser_age_s = 0.08;
        assert_eq!(choose(&stale)[0], (Why::LaserUncertain, 2));
        // The same input, the same choice.
        assert_eq!(choose(&candidates), chosen);
        assert!(choose(&[]).is_empty());
    }

    #[test]
    fn every_legend_entry_of_an_inset_has_text() {
        let c = candidate(1.0, 0.05, 0.4);
        let inset = Inset {
            at: c,
            why: Why::CameraUncertain,
            letter: 'B',
            view: view_for(&c),
        };
        let svg = inset_svg(&inset, "inset-test-B");
        let entries: Vec<&str> = svg.split("<g class=\"legend-entry\"").skip(1).collect();
        assert_eq!(entries.len(), 5);
        for e in entries {
            let text = e
                .split("<text")
                .nth(1)
                .and_then(|t| t.split('>').nth(1))
                .and_then(|t| t.split('<').next())
                .unwrap_or("");
            assert!(!text.trim().is_empty(), "{e}");
        }
        assert!(svg.contains("class=\"scale-bar\"") && svg.contains("class=\"truth\""));
        assert_eq!(svg.matches("<ellipse").count(), 3 + 3);
        let caption = caption(&inset);
        assert!(caption.starts_with("<b>B</b> · t = 1.0 s: the camera alone is uncertain"));
    }
}
