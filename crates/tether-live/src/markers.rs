//! One tick as a `visualization_msgs/msg/MarkerArray` for RViz and Foxglove, on
//! `/tether/markers` (live) and in the results MCAP:
//!
//! | namespace | shape | what |
//! |---|---|---|
//! | `tracks` | cylinder 1.7 m tall, id = track id | each confirmed track; green for the target, blue otherwise |
//! | `track_labels` | text above the track | `#id`, `#id target` |
//! | `track_covariance` | flat elliptic disc | the track's 95 % position ellipse |
//! | `target` | flat elliptic disc, id 0 | the target estimate's 95 % ellipse while locked (deleted otherwise) |
//! | `laser_people`, `vision_people` | spheres, id 0 | the observations of the latest scan and camera frame |
//!
//! Shapes carry a lifetime (0.5 s for tracks, 0.3 s for observations), so a track that
//! ends leaves the view by itself. Ellipse half-axes are `sqrt(chi2_2(0.95) * lambda)`
//! for the covariance's eigenvalues `lambda` (design 5.1's gate at 95 %).

use tether_core::{Gaussian2, World};
use tether_msgs::{ColorRgba, Header, MarkerArrayMsg, MarkerMsg, Pose3};
use tether_pipeline::{Tick, TickInput};

/// The 95 % quantile of the chi-square distribution with 2 degrees of freedom.
const CHI2_2_95: f64 = 5.991_464_547_107_979;
/// A person's height for the track cylinders, m.
const PERSON_HEIGHT_M: f64 = 1.7;
/// Track cylinders' diameter, m.
const PERSON_DIAMETER_M: f64 = 0.3;
/// How long a track's shapes stay without an update, ns.
const TRACK_LIFETIME_NS: i64 = 500_000_000;
/// How long an observation stays without an update, ns.
const OBSERVATION_LIFETIME_NS: i64 = 300_000_000;

const TARGET_GREEN: ColorRgba = [0.1, 0.8, 0.2, 0.8];
const TRACK_BLUE: ColorRgba = [0.2, 0.4, 1.0, 0.6];
const LASER_RED: ColorRgba = [0.9, 0.15, 0.1, 0.9];
const VISION_YELLOW: ColorRgba = [1.0, 0.8, 0.0, 0.9];
const LABEL_WHITE: ColorRgba = [1.0, 1.0, 1.0, 1.0];

/// The markers of `tick`, positions in `frame`.
pub fn tick_markers(tick: &Tick, frame: &str) -> MarkerArrayMsg {
    let header = Header::new(tick.stamp, frame);
    let target = tick.target.state.locked_track();
    let mut markers = Vec::new();
    for track in tick.tracks.iter().filter(|t| t.confirmed) {
        // Marker ids are int32; a track id past that wraps, which only reuses a
        // colour slot in the viewer.
        let id = track.id as i32;
        let is_target = target == Some(track.id);
        let colour = if is_target { TARGET_GREEN } else { TRACK_BLUE };
        let (x, y) = (track.position.mean.x, track.position.mean.y);

        let mut body = MarkerMsg::new(header.clone(), "tracks", id, MarkerMsg::CYLINDER);
        body.pose = at(x, y, 0.5 * PERSON_HEIGHT_M, 0.0);
        body.scale = [PERSON_DIAMETER_M, PERSON_DIAMETER_M, PERSON_HEIGHT_M];
        body.color = colour;
        body.lifetime_ns = TRACK_LIFETIME_NS;
        markers.push(body);

        let mut label = MarkerMsg::new(
            header.clone(),
            "track_labels",
            id,
            MarkerMsg::TEXT_VIEW_FACING,
        );
        label.pose = at(x, y, PERSON_HEIGHT_M + 0.2, 0.0);
        label.scale = [0.0, 0.0, 0.25];
        label.color = LABEL_WHITE;
        label.text = if is_target {
            format!("#{} target", track.id)
        } else {
            format!("#{}", track.id)
        };
        label.lifetime_ns = TRACK_LIFETIME_NS;
        markers.push(label);

        let mut ellipse = ellipse(&header, "track_covariance", id, &track.position);
        ellipse.color = [colour[0], colour[1], colour[2], 0.3];
        ellipse.lifetime_ns = TRACK_LIFETIME_NS;
        markers.push(ellipse);
    }
    match (target, tick.target.estimate) {
        (Some(_), Some(estimate)) => {
            let mut m = ellipse(&header, "target", 0, &estimate);
            m.color = [TARGET_GREEN[0], TARGET_GREEN[1], TARGET_GREEN[2], 0.5];
            m.lifetime_ns = TRACK_LIFETIME_NS;
            markers.push(m);
        }
        _ => {
            let mut m = MarkerMsg::new(header.clone(), "target", 0, MarkerMsg::CYLINDER);
            m.action = MarkerMsg::DELETE;
            markers.push(m);
        }
    }
    let observed = match tick.input {
        TickInput::Scan => Some(("laser_people", LASER_RED, &tick.laser_people)),
        TickInput::Camera => Some(("vision_people", VISION_YELLOW, &tick.vision_people)),
        TickInput::Timer => None,
    };
    if let Some((ns, colour, people)) = observed {
        markers.push(observations(&header, ns, colour, people));
    }
    MarkerArrayMsg { markers }
}

/// A pose at `(x, y, z)` turned by `yaw_rad` about z.
fn at(x: f64, y: f64, z: f64, yaw_rad: f64) -> Pose3 {
    let mut pose = Pose3::planar(x, y, yaw_rad);
    pose.position_m[2] = z;
    pose
}

/// A flat disc on the ground whose rim is the 95 % ellipse of `g`.
fn ellipse(header: &Header, ns: &str, id: i32, g: &Gaussian2<World>) -> MarkerMsg {
    let (major_var, minor_var, angle_rad) = g.cov.principal_axes();
    let mut m = MarkerMsg::new(header.clone(), ns, id, MarkerMsg::CYLINDER);
    m.pose = at(g.mean.x, g.mean.y, 0.01, angle_rad);
    // Diameters; a floor keeps a degenerate covariance visible.
    let diameter = |var: f64| (2.0 * (CHI2_2_95 * var).sqrt()).max(0.02);
    m.scale = [diameter(major_var), diameter(minor_var), 0.02];
    m
}

/// A sphere at each observation, on the ground.
fn observations(
    header: &Header,
    ns: &str,
    colour: ColorRgba,
    people: &[Gaussian2<World>],
) -> MarkerMsg {
    let mut m = MarkerMsg::new(header.clone(), ns, 0, MarkerMsg::SPHERE_LIST);
    m.scale = [0.15; 3];
    m.color = colour;
    m.points = people.iter().map(|g| [g.mean.x, g.mean.y, 0.1]).collect();
    m.lifetime_ns = OBSERVATION_LIFETIME_NS;
    m
}

#[cfg(test)]
mod tests {
    use tether_control::Twist;
    use tether_core::{Cov2, Point2, Stamp, Vector2};
    use tether_fusion::TargetState;
    use tether_pipeline::{TargetView, TrackView};

    use super::*;

    fn gaussian(x: f64, y: f64, cov: Cov2) -> Gaussian2<World> {
        Gaussian2::new(Point2::new(x, y), cov).unwrap()
    }

    /// A scan tick with tracks 4 (confirmed, the target), 5 (confirmed) and 6
    /// (tentative), and two laser observations.
    fn tick(locked: bool) -> Tick {
        let elongated = Cov2::from_axes(0.4, 0.1, std::f64::consts::FRAC_PI_2).unwrap();
        let round = Cov2::isotropic(0.1).unwrap();
        let track = |id, confirmed, x, cov| TrackView {
            id,
            confirmed,
            position: gaussian(x, 1.0, cov),
            velocity: Vector2::new(0.0, 0.0),
        };
        Tick {
            stamp: Stamp::from_ns(3_000_000_000),
            input: TickInput::Scan,
            laser_people: vec![gaussian(2.0, 1.0, round), gaussian(5.0, 0.0, round)],
            vision_people: Vec::new(),
            fused_people: Vec::new(),
            tracks: vec![
                track(4, true, 2.0, elongated),
                track(5, true, 4.0, round),
                track(6, false, 6.0, round),
            ],
            target: TargetView {
                state: if locked {
                    TargetState::Locked { track: 4 }
                } else {
                    TargetState::Searching
                },
                id: locked.then_some(4),
                estimate: locked.then(|| gaussian(2.0, 1.0, elongated)),
                velocity: None,
            },
            command: Twist::STOP,
            wanted: Twist::STOP,
            stop: None,
            refusals: Vec::new(),
            somebody_else: Vec::new(),
            transition: None,
        }
    }

    fn find<'a>(m: &'a MarkerArrayMsg, ns: &str, id: i32) -> &'a MarkerMsg {
        m.markers
            .iter()
            .find(|k| k.ns == ns && k.id == id)
            .unwrap_or_else(|| panic!("no marker {ns}/{id}"))
    }

    #[test]
    fn confirmed_tracks_the_target_and_observations_are_drawn() {
        let m = tick_markers(&tick(true), "odom");
        // Two confirmed tracks x (body, label, ellipse), the target, the observations.
        assert_eq!(m.markers.len(), 3 * 2 + 1 + 1);
        assert!(m.markers.iter().all(|k| k.header.frame_id == "odom"));
        assert!(m.markers.iter().all(|k| k.ns != "tracks" || k.id != 6));
        assert_eq!(find(&m, "tracks", 4).color, TARGET_GREEN);
        assert_eq!(find(&m, "tracks", 5).color, TRACK_BLUE);
        assert_eq!(find(&m, "track_labels", 4).text, "#4 target");
        assert_eq!(find(&m, "track_labels", 5).text, "#5");
        assert_eq!(find(&m, "target", 0).action, MarkerMsg::ADD);
        let laser = find(&m, "laser_people", 0);
        assert_eq!(laser.marker_type, MarkerMsg::SPHERE_LIST);
        assert_eq!(laser.points.len(), 2);
        assert_eq!(laser.points[1][..2], [5.0, 0.0]);
    }

    #[test]
    fn an_ellipse_has_the_95_percent_axes_along_the_covariance() {
        let m = tick_markers(&tick(true), "odom");
        let e = find(&m, "track_covariance", 4);
        // Variances 0.16 along y and 0.01 along x: diameters 2 sqrt(5.99 var).
        assert!((e.scale[0] - 2.0 * (CHI2_2_95 * 0.16).sqrt()).abs() < 1e-9);
        assert!((e.scale[1] - 2.0 * (CHI2_2_95 * 0.01).sqrt()).abs() < 1e-9);
        // The major axis (the disc's x) points along world y.
        assert!((e.pose.yaw_rad().abs() - std::f64::consts::FRAC_PI_2).abs() < 1e-9);
        assert_eq!(e.pose.position_m[..2], [2.0, 1.0]);
    }

    #[test]
    fn without_a_lock_the_target_marker_is_deleted() {
        let m = tick_markers(&tick(false), "map");
        assert_eq!(find(&m, "target", 0).action, MarkerMsg::DELETE);
        assert_eq!(find(&m, "tracks", 4).color, TRACK_BLUE);
    }
}
