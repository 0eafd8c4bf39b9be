//! The map of a run: the true paths of the people and the robot, the tracked estimate
//! of the target, the laser's, camera's and fused estimates at a few instants, and
//! where the magnified views below it are taken.
//!
//! Every entry of its legend has a colour of its own: the target, the estimates, the
//! robot and the magnified views have theirs, and the bystanders take theirs from
//! [`BYSTANDERS`]; a crowd of more than that many is drawn in one colour under one
//! entry, "bystanders".

use tether_core::{Gaussian2, Point2, World};
use tether_sim::svg::{LegendMark, MapSvg};
use tether_sim::{Scenario, StaticWorld};

use tether_eval::closed_loop::{RunLog, StepKind};

use super::{ESTIMATE, FUSED, LASER, MAP_MAX_HEIGHT_PX, MAP_MAX_PX_PER_M, MAP_MAX_WIDTH_PX};
use super::{VISION, insets};

/// The target's colour on the map.
pub const TARGET: &str = "#d62728";
/// The robot's colour on the map.
pub const ROBOT: &str = "#222222";
/// The bystanders' colours, none of them another legend entry's; more bystanders than
/// these are drawn in the first, under one legend entry.
pub const BYSTANDERS: [&str; 4] = ["#17becf", "#8c564b", "#e377c2", "#bcbd22"];

/// Draws the people's true paths, each bystander in a colour of its own (or all in
/// one when they are more than [`BYSTANDERS`]).
fn people_paths(map: &mut MapSvg, scenario: &Scenario, paths: &[Vec<Point2<World>>]) {
    let bystanders = scenario.people.iter().filter(|p| !p.target).count();
    let crowd = bystanders > BYSTANDERS.len();
    let mut k = 0;
    for (path, spec) in paths.iter().zip(&scenario.people) {
        if spec.target {
            // ("target (target)" says it once.)
            let label = if spec.name.contains("target") {
                format!("{}, true", spec.name)
            } else {
                format!("{} (target), true", spec.name)
            };
            map.path(path, TARGET, false, &label, true);
        } else if crowd {
            map.draw_path(
                path,
                BYSTANDERS[0],
                false,
                &format!("{}, true", spec.name),
                true,
            );
        } else {
            let label = format!("{}, true", spec.name);
            map.path(path, BYSTANDERS[k % BYSTANDERS.len()], false, &label, true);
            k += 1;
        }
    }
    if crowd {
        map.legend(
            &format!("bystanders ({bystanders}), true"),
            BYSTANDERS[0],
            false,
        );
    }
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
    people_paths(&mut map, scenario, &paths);
    map.path(&estimate, ESTIMATE, true, "target, tracked estimate", false);
    map.draw_path(&robot, ROBOT, true, "robot", true);
    // Where the magnified views below the map are taken, before the labels, which keep
    // off their squares.
    let zooms = insets::insets(log);
    for inset in &zooms {
        map.zoom_box(
            inset.view.center,
            inset.view.side_m(),
            insets::ZOOM_COLOR,
            &inset.letter.to_string(),
        );
    }
    let instants = instants(&mut map, log);
    if instants > 0 {
        map.legend_mark("laser estimate (2σ)", LASER, LegendMark::Ellipse);
        map.legend_mark("vision estimate (2σ)", VISION, LegendMark::Ellipse);
        map.legend_mark("fused estimate (2σ)", FUSED, LegendMark::Ellipse);
        map.legend_mark(
            "robot, and its pose at the instants labelled with their time",
            ROBOT,
            LegendMark::RobotOnPath,
        );
    } else {
        map.legend("robot", ROBOT, true);
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

/// Ellipses at a few instants (the paper's Fig. 14): the camera frames nearest to five
/// evenly spaced times, each sensor's estimate nearest the true target, the robot, and
/// the time beside the target. Returns how many instants were drawn.
fn instants(map: &mut MapSvg, log: &RunLog) -> usize {
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
    instants
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_legend_colour_is_another() {
        let mut colors: Vec<&str> = vec![
            TARGET,
            ROBOT,
            ESTIMATE,
            LASER,
            VISION,
            FUSED,
            insets::ZOOM_COLOR,
        ];
        colors.extend(BYSTANDERS);
        let mut sorted = colors.clone();
        sorted.sort_unstable();
        sorted.dedup();
        assert_eq!(sorted.len(), colors.len(), "{colors:?}");
    }
}
