//! `tether base-guard`: the process `tether run` starts beside itself to stop the base
//! when tether dies or hangs (see `tether_live::guard`). Not for direct use.

use std::path::PathBuf;
use std::time::Duration;

use anyhow::Context;
use tether_live::config::WheelFormat;
use tether_live::guard::{GuardSpec, GuardedBase, watch};

/// Options of `tether base-guard` (written by `tether run`).
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The base's device (serial port, file or FIFO).
    #[arg(long, value_name = "PATH")]
    pub device: PathBuf,
    /// Baud rate of a serial port (none: a file).
    #[arg(long, value_name = "BAUD")]
    pub baud: Option<u32>,
    /// The base's protocol.
    #[arg(long, value_enum)]
    pub protocol: Protocol,
    /// Stop the base after this long without a command line, ms.
    #[arg(long, default_value_t = 500, value_name = "MS")]
    pub silence_ms: u64,
}

/// What the guard speaks to the base.
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum Protocol {
    /// iRobot Create Open Interface.
    Create,
    /// Wheel-speed JSON lines.
    Json,
    /// Wheel-speed text lines.
    Text,
}

/// Watches tether's command lines on stdin until they end; stops the base then (and
/// after each silence).
pub fn run(args: Args) -> anyhow::Result<()> {
    anyhow::ensure!(
        (100..=2000).contains(&args.silence_ms),
        "--silence-ms must be in 100..=2000, got {}",
        args.silence_ms
    );
    let spec = GuardSpec {
        device: args.device,
        baud: args.baud,
        base: match args.protocol {
            Protocol::Create => GuardedBase::Create,
            Protocol::Json => GuardedBase::Wheels(WheelFormat::Json),
            Protocol::Text => GuardedBase::Wheels(WheelFormat::Text),
        },
        silence: Duration::from_millis(args.silence_ms),
    };
    let stdin = std::io::BufReader::new(std::io::stdin());
    let report = watch(&spec, stdin, &mut std::io::stdout()).context("base guard")?;
    if !report.orderly {
        eprintln!(
            "base guard: tether ended without its final stop (killed?) after {} commands: \
             stop sent to {}",
            report.heartbeats,
            spec.device.display()
        );
    }
    Ok(())
}
