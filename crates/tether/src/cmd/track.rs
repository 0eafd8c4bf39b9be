//! `tether track`: detection, fusion and tracking over a recording, one JSON line per
//! scan message.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Context;
use serde::Serialize;
use tether_core::{Pose2, Robot, World};
use tether_io::rosbag::{Bag, LaserScanMsg};
use tether_pipeline::{Pipeline, PipelineConfig};

/// Options of `tether track`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The ROS 1 bag to read (chunks uncompressed, bz2 or lz4).
    pub bag: PathBuf,
    /// The `sensor_msgs/LaserScan` topic, e.g. `/scan`.
    #[arg(long)]
    pub scan_topic: String,
    /// A pipeline configuration (TOML; every table optional: `[legs]`, `[tracker]`,
    /// `[target]`, `[laser.noise]`...).
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Where to write one JSON line per scan message.
    #[arg(long, value_name = "FILE.jsonl")]
    pub out: PathBuf,
}

#[derive(Serialize)]
struct PersonLine {
    id: u64,
    x: f64,
    y: f64,
    vx: f64,
    vy: f64,
    cov: [f64; 4],
}

#[derive(Serialize)]
struct Line<'a> {
    stamp_ns: i64,
    frame: &'a str,
    people: Vec<PersonLine>,
    target: Option<u64>,
}

/// Reads a pipeline configuration file.
pub fn load_config(path: Option<&PathBuf>) -> anyhow::Result<PipelineConfig> {
    let Some(path) = path else {
        return Ok(PipelineConfig::default());
    };
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read config {}", path.display()))?;
    toml::from_str(&text).with_context(|| {
        format!(
            "config {} is not a valid tether configuration",
            path.display()
        )
    })
}

/// Runs the pipeline over the bag's scans. The recording is taken as seen from a still
/// sensor: the scan's frame is the robot's and the world's, so positions and velocities
/// come out in the scan's frame.
pub fn run(args: Args) -> anyhow::Result<()> {
    let mut config = load_config(args.config.as_ref())?;
    config.laser.mount.x_m = 0.0;
    config.laser.mount.y_m = 0.0;
    config.laser.mount.yaw_rad = 0.0;
    config.fusion.use_vision = false;
    let mut pipeline = Pipeline::new(config, None)?;
    let mut bag = Bag::open(&args.bag)?;
    if !bag.topics().contains(&args.scan_topic.as_str()) {
        anyhow::bail!(
            "bag {} has no topic {:?}; its topics are: {}",
            args.bag.display(),
            args.scan_topic,
            bag.topics().join(", ")
        );
    }
    let file = std::fs::File::create(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let mut out = std::io::BufWriter::new(file);
    let still: Pose2<World, Robot> = Pose2::IDENTITY;
    let (mut scans, mut with_target) = (0usize, 0usize);
    let mut ids = std::collections::BTreeSet::new();
    let mut messages = bag.decoded::<LaserScanMsg>(&[args.scan_topic.as_str()]);
    for message in &mut messages {
        let message = message?;
        let scan = &message.message.scan;
        let tick = pipeline.on_scan(scan, still);
        let people: Vec<PersonLine> = tick
            .tracks
            .iter()
            .filter(|t| t.confirmed)
            .map(|t| {
                ids.insert(t.id);
                PersonLine {
                    id: t.id,
                    x: t.position.mean.x,
                    y: t.position.mean.y,
                    vx: t.velocity.x,
                    vy: t.velocity.y,
                    cov: t.position.cov.to_array(),
                }
            })
            .collect();
        let target = tick.target.state.locked_track();
        with_target += usize::from(target.is_some());
        let line = Line {
            stamp_ns: scan.stamp.ns(),
            frame: &scan.frame_id,
            people,
            target,
        };
        serde_json::to_writer(&mut out, &line)?;
        out.write_all(b"\n")?;
        scans += 1;
    }
    let skipped = messages.bad_count();
    out.flush()
        .with_context(|| format!("writing {}", args.out.display()))?;
    let stats = pipeline.stats();
    if skipped > 0 {
        tracing::warn!("{skipped} messages could not be decoded and were skipped");
    }
    if stats.out_of_order_ticks > 0 || stats.malformed_beams > 0 {
        tracing::warn!(
            "{} scans arrived out of order (kept out of the tracks), {} beams were NaN or negative",
            stats.out_of_order_ticks,
            stats.malformed_beams
        );
    }
    println!(
        "{scans} scans, {} people tracked, a target in {with_target} scans -> {}",
        ids.len(),
        args.out.display()
    );
    Ok(())
}
