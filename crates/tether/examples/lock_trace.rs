//! Prints, scan by scan, what the target lock did in one simulated closed-loop run
//! against the truth: the state, the locked track, its distance to the target and to
//! the nearest other person, and the tracks near the target. For finding out why a
//! seed that `tether eval-target` names went wrong.
//!
//! `cargo run --release -p tether --example lock_trace -- SCENARIO SEED [laser|fused]
//! [FROM_S TO_S]`

#![allow(clippy::unwrap_used, reason = "a diagnostic tool")]

use tether_eval::closed_loop::{self, StepKind};
use tether_eval::target_metrics::nearest_other;
use tether_fusion::TargetState;
use tether_pipeline::PipelineConfig;
use tether_sim::scenario::Scenario;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let name = args.first().map_or("occlusion", String::as_str);
    let seed: u64 = args.get(1).map_or(Ok(0), |s| s.parse())?;
    let laser_only = args.get(2).is_none_or(|m| m == "laser");
    let from_s: f64 = args.get(3).map_or(Ok(0.0), |s| s.parse())?;
    let to_s: f64 = args.get(4).map_or(Ok(f64::INFINITY), |s| s.parse())?;
    let (mut scenario, _) = Scenario::resolve(name)?;
    let mut config = closed_loop::config_for(&scenario, &PipelineConfig::default());
    if laser_only {
        scenario.camera_sim.enabled = false;
        config.fusion.use_vision = false;
    }
    let log = closed_loop::run(&scenario, seed, &config, &[], &[])?;
    for step in &log.steps {
        if step.kind != StepKind::Scan {
            continue;
        }
        let t = step.truth.stamp.secs_f64();
        if t < from_s || t > to_s {
            continue;
        }
        let truth = step.truth_in_estimate_frame();
        let Some(target) = truth.target() else {
            continue;
        };
        let Some(tick) = &step.tick else {
            println!("{t:7.2} (no tick)");
            continue;
        };
        let beams = target.laser_beams.unwrap_or(0);
        let state = match tick.target.state {
            TargetState::Searching => "search".to_owned(),
            TargetState::Locked { track } => format!("lock {track}"),
            TargetState::Lost { track, reason, .. } => {
                format!("LOST {track} {}", reason.name())
            }
        };
        let locked = tick.target.estimate.map(|e| e.mean);
        let d_target = locked.map(|p| (p - target.position).norm());
        let d_other = locked.and_then(|p| nearest_other(&truth, p));
        let near: Vec<String> = tick
            .tracks
            .iter()
            .filter(|tr| (tr.position.mean - target.position).norm() < 6.0)
            .map(|tr| {
                format!(
                    "{}{}({:.2},{:.2} v{:.1},{:.1})",
                    tr.id,
                    if tr.confirmed { "" } else { "?" },
                    tr.position.mean.x,
                    tr.position.mean.y,
                    tr.velocity.x,
                    tr.velocity.y
                )
            })
            .collect();
        let others: Vec<String> = truth
            .people
            .iter()
            .filter(|q| !q.target && (q.position - target.position).norm() < 2.5)
            .map(|q| format!("({:.2},{:.2})", q.position.x, q.position.y))
            .collect();
        let refusals: Vec<String> = tick
            .refusals
            .iter()
            .map(|(id, r)| format!("{id}:{}", r.name()))
            .collect();
        println!(
            "{t:7.2} beams {beams:2} target ({:.2},{:.2}) {state:<22} d_t {} d_o {} obs [{}] tracks [{}] others [{}] {}",
            target.position.x,
            target.position.y,
            d_target.map_or("-".into(), |d| format!("{d:.2}")),
            d_other.map_or("-".into(), |d| format!("{d:.2}")),
            tick.laser_people
                .iter()
                .filter(|o| (o.mean - target.position).norm() < 2.5)
                .map(|o| format!("({:.2},{:.2})", o.mean.x, o.mean.y))
                .collect::<Vec<_>>()
                .join(" "),
            near.join(" "),
            others.join(" "),
            refusals.join(" "),
        );
    }
    Ok(())
}
