//! The top view of the whole replay.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use super::frame::{Bounds, Labels, MapFrame};
use super::marks::{Mark, legend_svg};
use super::{ROBOT, TARGET, TRACK_COLORS, stands_for, track_color};

/// The top view of the whole replay: each confirmed track's trail (the target's in
/// red, the others coloured by id, the longest labelled with their ids), the robot's
/// path, metre axes and a scale bar, fitted at one scale both ways into the page.
pub fn overview_svg(
    trails: &BTreeMap<u64, Vec<(f64, f64)>>,
    robot_path: &[(f64, f64)],
    target_ids: &[u64],
    frame: &str,
) -> String {
    let mut b = Bounds::EMPTY;
    for &(x, y) in trails.values().flatten().chain(robot_path) {
        b.add(x, y);
    }
    if b.is_empty() {
        return String::from("<p>No tracks.</p>");
    }
    let map = MapFrame::fit(b.padded(0.3), 900.0, 680.0, 8.0);
    let mut s = map.open("map", "map-clip");
    s.push_str(&map.axes(frame));
    s.push_str("<g clip-path=\"url(#map-clip)\" fill=\"none\">");
    let points = |pts: &[(f64, f64)]| {
        pts.iter()
            .map(|&(x, y)| {
                let (u, v) = map.px(x, y);
                format!("{u:.1},{v:.1}")
            })
            .collect::<Vec<_>>()
            .join(" ")
    };
    // The target's trails last, on top.
    let order = trails
        .iter()
        .filter(|(id, _)| !target_ids.contains(id))
        .chain(trails.iter().filter(|(id, _)| target_ids.contains(id)));
    for (id, pts) in order {
        let target = target_ids.contains(id);
        let _ = write!(
            s,
            "<polyline class=\"trail\" stroke=\"{}\" stroke-width=\"{}\" stroke-opacity=\"0.85\" \
             points=\"{}\"><title>track {id}</title></polyline>",
            track_color(*id, target),
            if target { 2.2 } else { 1.2 },
            points(pts)
        );
    }
    let _ = write!(
        s,
        "<polyline class=\"robot-path\" stroke=\"{ROBOT}\" stroke-width=\"1.6\" stroke-dasharray=\"5 3\" \
         points=\"{}\"><title>robot</title></polyline>",
        points(robot_path)
    );
    if let Some(&(x, y)) = robot_path.first() {
        let (u, v) = map.px(x, y);
        let _ = write!(
            s,
            "<circle class=\"robot-start\" cx=\"{u:.1}\" cy=\"{v:.1}\" r=\"4\" fill=\"{ROBOT}\"><title>robot at \
             the start</title></circle>"
        );
    }
    s.push_str("</g>");
    // Ids at the end of the longest trails (and every target's).
    let mut by_length: Vec<(&u64, &Vec<(f64, f64)>)> = trails.iter().collect();
    by_length.sort_by(|a, b| {
        let key = |(id, pts): &(&u64, &Vec<(f64, f64)>)| (!target_ids.contains(id), pts.len());
        let (ta, la) = key(a);
        let (tb, lb) = key(b);
        ta.cmp(&tb).then(lb.cmp(&la)).then(a.0.cmp(b.0))
    });
    let mut labels = Labels::default();
    for (id, pts) in by_length.into_iter().take(20) {
        let Some(&(x, y)) = pts.last() else { continue };
        let (u, v) = map.px(x, y);
        let text = id.to_string();
        let (lx, ly) = labels.place(u, v, &text, map.area());
        let target = target_ids.contains(id);
        let _ = write!(
            s,
            "<text x=\"{lx:.1}\" y=\"{ly:.1}\" fill=\"{}\" font-weight=\"bold\" \
             stroke=\"#ffffff\" stroke-width=\"3\" paint-order=\"stroke\">{text}</text>",
            track_color(*id, target)
        );
    }
    s.push_str(&map.scale_bar());
    s.push_str("</svg>");
    let legend = legend_svg(
        &[
            (
                Mark::Line(TARGET, 2.2, false),
                "the target's tracks",
                stands_for("trail", &[TARGET]),
            ),
            (
                Mark::Lines(&TRACK_COLORS, 1.2),
                "other confirmed tracks (colour by id; ids at their ends)",
                stands_for("trail", &TRACK_COLORS),
            ),
            (
                Mark::Line(ROBOT, 1.6, true),
                "robot",
                stands_for("robot-path", &[ROBOT]),
            ),
            (
                Mark::Disc(ROBOT),
                "robot at the start",
                stands_for("robot-start", &[ROBOT]),
            ),
        ],
        map.width().max(520.0),
    );
    format!("<div class=\"figure\">{s}<br>{legend}</div>")
}
