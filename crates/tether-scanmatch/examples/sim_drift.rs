//! Drift of scan-matching odometry on a simulated scenario, for tuning:
//! `cargo run --release -p tether-scanmatch --example sim_drift -- office [seed] [key=value...]`
//! with keys `kf_m`, `kf_rad`, `overlap`, `huber`, `trim`, `span`, `flat`, `degen`,
//! `corr`, `spacing`, `tol`, `reuse`, `prior` (`cv` constant velocity or `cmd` commanded velocity),
//! `exclude` (0/1).

#![allow(clippy::unwrap_used, reason = "a tuning tool: fail loudly")]

#[path = "../tests/support/sim_drive.rs"]
#[allow(
    dead_code,
    reason = "shared by the drift test and the tuning example, which use different parts"
)]
mod sim_drive;

use tether_scanmatch::ScanMatcherConfig;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let name = args.first().map_or("office", String::as_str);
    let seed: u64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(1);
    let mut config = ScanMatcherConfig::default();
    let mut commanded = false;
    let mut exclude = true;
    for kv in args.iter().skip(2) {
        let Some((k, v)) = kv.split_once('=') else {
            eprintln!("ignoring {kv}: expected key=value");
            continue;
        };
        let x: f64 = v.parse().unwrap_or(f64::NAN);
        match k {
            "kf_m" => config.keyframe_translation_m = x,
            "kf_rad" => config.keyframe_rotation_rad = x,
            "overlap" => config.keyframe_min_overlap = x,
            "huber" => config.icp.huber_m = x,
            "trim" => config.icp.trim_fraction = x,
            "span" => config.icp.lines.half_span_m = x,
            "flat" => config.icp.lines.max_flatness = x,
            "degen" => config.icp.degeneracy_min_eigenvalue = x,
            "corr" => config.icp.max_correspondence_m = x,
            "spacing" => config.min_point_spacing_m = x,
            "tol" => {
                config.icp.translation_tolerance_m = x;
                config.icp.rotation_tolerance_rad = x;
            }
            "reuse" => {
                config.icp.reuse_correspondences_below_m = x;
                config.icp.reuse_correspondences_below_rad = x;
            }
            "prior" => commanded = v == "cmd",
            "exclude" => exclude = v == "1",
            _ => eprintln!("unknown key {k}"),
        }
    }
    let mut err = (0.0, 0.0);
    let mut distance_m = 0.0;
    let verbose = std::env::var("VERBOSE").is_ok();
    let matcher = sim_drive::drive(name, seed, config, exclude, commanded, |step| {
        distance_m = step.distance_m;
        let new_err = step.error();
        let e = step.estimate;
        if verbose && (new_err.0 - err.0).abs() > 0.02 {
            println!(
                "t {:.1}: error {:.3} -> {:.3} m; {} pts, matched {}, resid {:.4}, it {}, {:?}, kf {}, eig_min {:.4} speed {:.2} est step {:.3} true v {:.3}",
                step.scan.stamp.secs_f64(),
                err.0,
                new_err.0,
                step.points.len(),
                e.matched_points,
                e.mean_residual_m,
                e.iterations,
                e.quality,
                e.new_keyframe,
                e.min_eigenvalue,
                step.event.truth.robot_velocity.v_mps,
                e.robot_from_robot.x,
                step.event.truth.robot_velocity.v_mps * 0.1
            );
        }
        err = new_err;
    });
    println!(
        "{name} seed {seed}: driven {distance_m:.2} m, final error {:.3} m ({:.2} %), yaw {:.2} deg, {:?}",
        err.0,
        100.0 * err.0 / distance_m.max(1e-9),
        err.1.to_degrees(),
        matcher.counts()
    );
}
