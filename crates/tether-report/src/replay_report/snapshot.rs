//! The snapshots: the scan at chosen instants, drawn as rviz shows it.

use std::fmt::Write as _;

use tether_core::{Gaussian2, Laser, LaserScan, Point2, Pose2, Robot, Stamp, World};
use tether_fusion::{LossReason, TargetState};
use tether_laser::{Leg, LegDetector};
use tether_pipeline::TrackView;
use tether_svg::xml_escape;

use super::frame::{Bounds, Labels, MapFrame};
use super::marks::{Mark, arrow, ellipse, legend_svg, robot_marker};
use super::{
    LEG, PERSON, ROBOT, SCAN, TARGET, TENTATIVE, TRACK_COLORS, count, stands_for, track_color,
};

/// Why a snapshot was drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Chosen {
    /// Evenly spaced over the recording.
    Evenly,
    /// At a loss of the target.
    Loss(LossReason),
}

/// What a snapshot draws: the last scan (in the laser's frame) with the robot's pose
/// at it, that scan's laser people, and the tracks and target of the tick.
#[derive(Debug, Clone)]
pub struct Snapshot {
    /// Seconds from the replay's first tick.
    pub t_s: f64,
    /// The tick's stamp.
    pub stamp: Stamp,
    /// Index of the scan among the scans replayed (from 0).
    pub scan_index: usize,
    /// Why it was chosen.
    pub chosen: Chosen,
    /// The scan.
    pub scan: LaserScan,
    /// The robot's pose at the scan.
    pub world_from_robot: Pose2<World, Robot>,
    /// Where the laser sits on the robot.
    pub robot_from_laser: Pose2<Robot, Laser>,
    /// The scan's person observations (world).
    pub laser_people: Vec<Gaussian2<World>>,
    /// The tracks after the tick.
    pub tracks: Vec<TrackView>,
    /// The target's state after the tick.
    pub target: TargetState,
    /// The target's estimate while locked.
    pub target_estimate: Option<Gaussian2<World>>,
}

impl Snapshot {
    /// One line on the target's state.
    fn target_text(&self) -> String {
        match self.target {
            TargetState::Searching => "no target chosen yet".to_owned(),
            TargetState::Locked { track } => format!("target locked on track {track}"),
            TargetState::Lost {
                track,
                reason,
                since,
                ..
            } => format!(
                "target lost ({}): track {track}, last updated {:.1} s before",
                reason.name(),
                self.stamp.secs_since(since).max(0.0)
            ),
        }
    }

    /// The caption: number, time, why chosen, the target's state and what is drawn.
    pub fn caption(&self, number: usize, legs: usize) -> String {
        let why = match self.chosen {
            Chosen::Evenly => "evenly spaced".to_owned(),
            Chosen::Loss(reason) => format!("at a loss of the target ({})", reason.name()),
        };
        let confirmed = self.tracks.iter().filter(|t| t.confirmed).count();
        format!(
            "S{number} · t = {:.1} s · {why} · {} · scan {}: {}, {}, {}; {}",
            self.t_s,
            self.target_text(),
            self.scan_index + 1,
            count(self.scan.returns(), "return", "returns"),
            count(legs, "leg", "legs"),
            count(self.laser_people.len(), "person", "people"),
            count(confirmed, "confirmed track", "confirmed tracks")
        )
    }

    /// The picture: the scan's returns, the legs (in the laser's frame, as found in
    /// this scan), the laser people with 2-sigma ellipses, the tracks (confirmed: a
    /// disc with its id, its 2-sigma ellipse and where its velocity takes it in 1 s;
    /// tentative: a grey ring), the target (a red ring; while lost, a dashed ring at
    /// its last good estimate) and the robot; axes in metres and a scale bar. Every
    /// mark has a class, and the legend of [`snapshots_html`] one entry for each class
    /// and colour drawn.
    pub fn svg(&self, number: usize, legs: &[Leg], frame: &str) -> String {
        let world_from_laser = self.world_from_robot * self.robot_from_laser;
        let legs: Vec<(Point2<World>, f64)> = legs
            .iter()
            .map(|l| (world_from_laser * l.centre_in_laser, l.radius_m))
            .collect();
        let (map, points) = self.frame_and_returns(&legs);
        let clip = format!("snapshot-clip-{number}");
        let mut s = map.open("snapshot-map", &clip);
        s.push_str(&map.axes(frame));
        let _ = write!(s, "<g clip-path=\"url(#{clip})\">");
        // The returns: one path of round dots.
        let mut d = String::new();
        for p in &points {
            let (u, v) = map.px(p.x, p.y);
            let _ = write!(d, "M{u:.1} {v:.1}h0");
        }
        let _ = write!(
            s,
            "<path class=\"scan\" d=\"{d}\" stroke=\"{SCAN}\" stroke-width=\"2.6\" \
             stroke-linecap=\"round\" fill=\"none\"/>"
        );
        self.tracks_svg(&map, &mut s);
        self.target_svg(&map, &mut s);
        // The observations on top: they are what the tracks are made of.
        for g in &self.laser_people {
            let (u, v) = map.px(g.mean.x, g.mean.y);
            let _ = write!(
                s,
                "<path class=\"person\" d=\"M{:.1} {:.1}l8 8m0 -8l-8 8\" stroke=\"{PERSON}\" \
                 stroke-width=\"2\"/>",
                u - 4.0,
                v - 4.0
            );
        }
        for (p, r) in &legs {
            let (u, v) = map.px(p.x, p.y);
            let _ = write!(
                s,
                "<circle class=\"leg\" cx=\"{u:.1}\" cy=\"{v:.1}\" r=\"{:.1}\" fill=\"none\" \
                 stroke=\"{LEG}\" stroke-width=\"2\"/>",
                (r * map.k).max(4.5)
            );
        }
        s.push_str(&robot_marker(&map, self.world_from_robot));
        s.push_str("</g>");
        self.labels_svg(&map, &mut s);
        s.push_str(&map.scale_bar());
        s.push_str("</svg>");
        s
    }

    /// The picture's frame, fitted to what the scan saw near the robot, and the
    /// returns drawn (those within the people seen plus 2 m, at least 4, at most 12 m).
    fn frame_and_returns(&self, legs: &[(Point2<World>, f64)]) -> (MapFrame, Vec<Point2<World>>) {
        let world_from_laser = self.world_from_robot * self.robot_from_laser;
        let robot = self.world_from_robot.translation();
        let lost_at = self.lost_at();
        // What the picture is about, and the returns around it.
        let mut interest: Vec<Point2<World>> = self
            .tracks
            .iter()
            .filter(|t| t.confirmed)
            .map(|t| t.position.mean)
            .chain(self.laser_people.iter().map(|g| g.mean))
            .chain(legs.iter().map(|l| l.0))
            .chain(self.target_estimate.map(|g| g.mean))
            .chain(lost_at.map(|(_, g)| g.mean))
            .filter(|p| p.is_finite())
            .collect();
        let reach = interest
            .iter()
            .map(|p| p.distance_m(robot))
            .fold(0.0, f64::max);
        let radius = (reach + 2.0).clamp(4.0, 12.0);
        let points: Vec<Point2<World>> = self
            .scan
            .points()
            .map(|(_, p)| world_from_laser * p)
            .filter(|p| p.distance_m(robot) <= radius)
            .collect();
        let mut b = Bounds::EMPTY;
        b.add_disc(robot, 1.0);
        interest.retain(|p| p.distance_m(robot) <= radius);
        for p in &interest {
            b.add_disc(*p, 0.6);
        }
        for p in &points {
            b.add(p.x, p.y);
        }
        // Where the confirmed tracks' velocity arrows end.
        for t in self.tracks.iter().filter(|t| t.confirmed) {
            let p = t.position.mean + t.velocity;
            if p.distance_m(robot) <= radius {
                b.add_disc(p, 0.2);
            }
        }
        // Square, as rviz shows a scan: the pictures side by side at one size.
        (
            MapFrame::fit(b.padded(0.3).squared(), 470.0, 470.0, 8.0),
            points,
        )
    }

    /// The lost target's track and last good estimate, while it is lost.
    fn lost_at(&self) -> Option<(u64, Gaussian2<World>)> {
        match self.target {
            TargetState::Lost { track, last, .. } => Some((track, last)),
            _ => None,
        }
    }

    /// The target's position: its track's, or its estimate's.
    fn target_at(&self) -> Option<Point2<World>> {
        self.target
            .locked_track()
            .and_then(|id| self.tracks.iter().find(|t| t.id == id))
            .map(|t| t.position.mean)
            .or(self.target_estimate.map(|g| g.mean))
    }

    /// The tracks: the confirmed ones' ellipses under everything, the laser people's
    /// ellipses, the tentative tracks' rings, and the confirmed ones' discs with their
    /// velocity arrows.
    fn tracks_svg(&self, map: &MapFrame, s: &mut String) {
        let target_track = self.target.locked_track();
        for t in self.tracks.iter().filter(|t| t.confirmed) {
            let color = track_color(t.id, Some(t.id) == target_track);
            s.push_str(&ellipse(map, &t.position, color, 0.10));
        }
        for g in &self.laser_people {
            s.push_str(&ellipse(map, g, PERSON, 0.0));
        }
        for t in self.tracks.iter().filter(|t| !t.confirmed) {
            let (u, v) = map.px(t.position.mean.x, t.position.mean.y);
            let _ = write!(
                s,
                "<circle class=\"tentative\" cx=\"{u:.1}\" cy=\"{v:.1}\" r=\"4\" fill=\"none\" \
                 stroke=\"{TENTATIVE}\" stroke-width=\"1.4\"><title>tentative track {}\
                 </title></circle>",
                t.id
            );
        }
        for t in self.tracks.iter().filter(|t| t.confirmed) {
            let color = track_color(t.id, Some(t.id) == target_track);
            let p = t.position.mean;
            let (u, v) = map.px(p.x, p.y);
            let speed = t.velocity.norm();
            if speed > 0.15 && speed.is_finite() {
                let (u2, v2) = map.px(p.x + t.velocity.x, p.y + t.velocity.y);
                let _ = write!(
                    s,
                    "<g class=\"velocity\">{}</g>",
                    arrow(u, v, u2, v2, color)
                );
            }
            let _ = write!(
                s,
                "<circle class=\"track\" cx=\"{u:.1}\" cy=\"{v:.1}\" r=\"5\" fill=\"{color}\" \
                 stroke=\"#ffffff\" stroke-width=\"1\"><title>track {} ({:.2} m/s)</title>\
                 </circle>",
                t.id, speed
            );
        }
    }

    /// The target's ring, and the lost target's dashed ring at its last estimate.
    fn target_svg(&self, map: &MapFrame, s: &mut String) {
        if let Some(p) = self.target_at() {
            let (u, v) = map.px(p.x, p.y);
            let _ = write!(
                s,
                "<circle class=\"target\" cx=\"{u:.1}\" cy=\"{v:.1}\" r=\"10\" fill=\"none\" \
                 stroke=\"{TARGET}\" stroke-width=\"2.5\"/>"
            );
        }
        if let Some((_, last)) = self.lost_at() {
            let (u, v) = map.px(last.mean.x, last.mean.y);
            let _ = write!(
                s,
                "<circle class=\"target-lost\" cx=\"{u:.1}\" cy=\"{v:.1}\" r=\"10\" \
                 fill=\"none\" stroke=\"{TARGET}\" stroke-width=\"2\" \
                 stroke-dasharray=\"4 3\"/>"
            );
        }
    }

    /// The labels, last, on top, the target's first: its track's id, the lost
    /// target's, the other confirmed tracks' ids.
    fn labels_svg(&self, map: &MapFrame, s: &mut String) {
        let target_track = self.target.locked_track();
        let mut labels = Labels::default();
        let mut label = |p: Point2<World>, text: &str, color: &str, s: &mut String| {
            if !map.contains(p.x, p.y) {
                return;
            }
            let (u, v) = map.px(p.x, p.y);
            let (x, y) = labels.place(u, v, text, map.area());
            let _ = write!(
                s,
                "<text x=\"{x:.1}\" y=\"{y:.1}\" fill=\"{color}\" font-weight=\"bold\" \
                 stroke=\"#ffffff\" stroke-width=\"3\" paint-order=\"stroke\">{}</text>",
                xml_escape(text)
            );
        };
        if let Some(p) = self.target_at() {
            let text = match target_track {
                Some(id) => format!("{id} target"),
                None => "target".to_owned(),
            };
            label(p, &text, TARGET, s);
        }
        if let Some((track, last)) = self.lost_at() {
            label(last.mean, &format!("{track} target, last seen"), TARGET, s);
        }
        for t in self
            .tracks
            .iter()
            .filter(|t| t.confirmed && Some(t.id) != target_track)
        {
            label(
                t.position.mean,
                &t.id.to_string(),
                track_color(t.id, false),
                s,
            );
        }
    }
}

/// The snapshots' section: a legend, then each snapshot as a figure with its caption.
pub fn snapshots_html(snapshots: &[Snapshot], detector: &mut LegDetector, frame: &str) -> String {
    if snapshots.is_empty() {
        return String::from("<p>No scan was replayed.</p>");
    }
    let mut s = String::from(
        "<p>The scan at chosen instants, as rviz shows it: evenly spaced over the \
         recording, and at losses of the target (at most 8 in all, at most 4 losses, \
         spread over them). Each picture is centred on what the scan saw near the robot; \
         returns farther than the people seen plus 2 m (at least 4, at most 12 m) are \
         left out.</p>",
    );
    s.push_str(&legend_svg(
        &[
            (
                Mark::Dot(SCAN),
                "laser returns",
                stands_for("scan", &[SCAN]),
            ),
            (
                Mark::Ring(LEG, false),
                "legs found",
                stands_for("leg", &[LEG]),
            ),
            (
                Mark::Cross(PERSON),
                "laser person (2σ ellipse)",
                stands_for("person", &[PERSON]),
            ),
            (
                Mark::Discs(&TRACK_COLORS),
                "confirmed track (colour by id) and its id",
                stands_for("track", &TRACK_COLORS),
            ),
            (
                Mark::DiscInRing(TARGET),
                "the target's track",
                stands_for("track", &[TARGET]) + " " + &stands_for("target", &[TARGET]),
            ),
            (
                Mark::Arrow(track_color(1, false)),
                "a track's velocity (where in 1 s), in its colour",
                "velocity".to_owned(),
            ),
            (
                Mark::Ring(TENTATIVE, false),
                "tentative track",
                stands_for("tentative", &[TENTATIVE]),
            ),
            (
                Mark::Ring(TARGET, true),
                "lost target's last estimate",
                stands_for("target-lost", &[TARGET]),
            ),
            (
                Mark::Robot,
                "robot (pointing ahead)",
                stands_for("robot", &[ROBOT]),
            ),
        ],
        1050.0,
    ));
    s.push_str("<div class=\"snapshots\">");
    for (k, snap) in snapshots.iter().enumerate() {
        let legs = detector.detect(&snap.scan).legs;
        let _ = write!(
            s,
            "<figure class=\"snapshot\" id=\"snapshot-{0}\" style=\"display:inline-block;\
             vertical-align:top;margin:6px 8px;width:{1:.0}px\">{2}<figcaption \
             style=\"font-size:13px\">{3}</figcaption></figure>",
            k + 1,
            530.0,
            snap.svg(k + 1, &legs, frame),
            xml_escape(&snap.caption(k + 1, legs.len()))
        );
    }
    s.push_str("</div>");
    s
}
