//! `tether cmd-vel-guard`: the process `tether ros2` starts beside itself to publish zero
//! commands on `cmd_vel` when the node dies or freezes (see `tether_live::ros2::guard`,
//! design 12). Not for direct use.

use std::time::Duration;

use anyhow::Context;
use tether_live::ros2::{CmdVelGuardSpec, watch_cmd_vel};
use tether_ros2::NodeIdentity;

/// Options of `tether cmd-vel-guard` (written by `tether ros2`).
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The node's resolved `cmd_vel` topic (absolute).
    #[arg(long, value_name = "TOPIC")]
    pub topic: String,
    /// The guard's node name.
    #[arg(long, value_name = "NAME")]
    pub node: String,
    /// The guard's namespace (the node's).
    #[arg(long, value_name = "NS", default_value = "/")]
    pub namespace: String,
    /// The DDS domain (the node's).
    #[arg(long, value_name = "ID", default_value_t = 0)]
    pub domain: u16,
    /// Publish `TwistStamped` zero commands in this frame (the base's) rather than
    /// `Twist`.
    #[arg(long, value_name = "FRAME")]
    pub stamped_frame: Option<String>,
    /// Publish zero commands after this long without a command line, ms.
    #[arg(long, default_value_t = 250, value_name = "MS")]
    pub silence_ms: u64,
}

/// Watches the node's command lines on stdin until they end; publishes zero commands
/// then (and after each silence).
pub fn run(args: Args) -> anyhow::Result<()> {
    anyhow::ensure!(
        (100..=2000).contains(&args.silence_ms),
        "--silence-ms must be in 100..=2000, got {}",
        args.silence_ms
    );
    let spec = CmdVelGuardSpec {
        identity: NodeIdentity {
            name: args.node,
            namespace: args.namespace,
            domain_id: args.domain,
        },
        topic: args.topic,
        stamped_frame: args.stamped_frame,
        silence: Duration::from_millis(args.silence_ms),
    };
    let stdin = std::io::BufReader::new(std::io::stdin());
    watch_cmd_vel(&spec, stdin, &mut std::io::stdout()).context("cmd_vel guard")?;
    Ok(())
}
