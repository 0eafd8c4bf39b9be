//! `tether urg-emulator`: a Hokuyo URG-04LX that speaks SCIP 2.0 byte for byte on a
//! pseudo-terminal or a TCP port, serving the scans of a simulated scene, so that a
//! driver (tether's own, `urg_node`, ...) can be run without the hardware.
//!
//! The scans come from a [`ScanSource`]. [`simulated_scans`]
//! (`tether_eval::scip_sim`) makes one from a scenario of `tether_sim`. Its robot stands still, or, with `--commands-stdin`,
//! drives the velocity commands read from stdin as JSON lines (`{"v_mps":..,
//! "w_radps":..}`, other keys ignored: the lines `tether run` prints), so that `tether
//! run | tether urg-emulator --commands-stdin` closes the loop without hardware. The
//! simulated base keeps a command until the next one, stops when none came for its
//! `command_timeout_s`, and stops when stdin ends. `--truth FILE` writes the ground
//! truth of every scan as a JSON line. `--extra-tcp FRAME=ADDR` serves more of the
//! scenario's lasers from the same simulation, each on a TCP port of its own: one robot
//! carrying several scanners, as `tether run` with several `[[laser]]` tables sees it.

use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use anyhow::Context;
use tether_eval::scip_sim::{CommandInbox, read_command_file, read_commands, simulated_scans};
use tether_scip::emulator::{Emulator, EmulatorConfig, EmulatorServer, Faults, ScanSource, Stall};
use tether_sim::{Command, Scenario};

/// Options of `tether urg-emulator`.
#[derive(Debug, clap::Args)]
#[command(group(clap::ArgGroup::new("endpoint").required(true).args(["pty", "tcp"])))]
pub struct Args {
    /// Serve on a new pseudo-terminal; its path is printed (open it as a serial port).
    #[arg(long)]
    pub pty: bool,
    /// Serve on this TCP address, like an Ethernet URG (e.g. 127.0.0.1:10940).
    #[arg(long, value_name = "ADDR")]
    pub tcp: Option<String>,
    /// Scenario whose laser scans are served: a built-in name (see `tether scenarios`)
    /// or a scenario .toml file. The robot stands still (unless `--commands-stdin`); the
    /// people walk; the scenario starts over at its end.
    #[arg(long, default_value = "office", value_name = "NAME")]
    pub scenario: String,
    /// Seed of the simulation's random draws.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Serve the scans of the scenario's extra laser of this frame (its
    /// `[[extra_lasers]]` entry) instead of its first laser's. For a robot with several
    /// scanners, `--extra-tcp` serves the others from the same simulation.
    #[arg(long, value_name = "FRAME")]
    pub laser: Option<String>,
    /// Also serve the scenario's extra laser of frame FRAME on the TCP address ADDR,
    /// from the same simulation (repeatable): one robot carrying every scanner, driven
    /// by the one command stream, so that the scanners see one world.
    #[arg(long, value_name = "FRAME=ADDR", value_parser = frame_at_address)]
    pub extra_tcp: Vec<(String, String)>,
    /// Boot in SCIP 1.1, as older URG-04LX firmware does (the host must send SCIP2.0).
    #[arg(long)]
    pub scip1: bool,
    /// Fault injection: a wrong check character on every N-th streamed scan.
    #[arg(long, value_name = "N")]
    pub bad_checksum_every: Option<u64>,
    /// Fault injection: a data line of every N-th streamed scan loses 3 characters.
    #[arg(long, value_name = "N")]
    pub truncated_line_every: Option<u64>,
    /// Fault injection: every N-th streamed scan is replaced by status `7Z`.
    #[arg(long, value_name = "N")]
    pub unknown_status_every: Option<u64>,
    /// Fault injection: garbage bytes before every N-th streamed scan.
    #[arg(long, value_name = "N")]
    pub garbage_every: Option<u64>,
    /// Fault injection: stop answering in the middle of this streamed scan (1 = first).
    #[arg(long, value_name = "N")]
    pub stall_at_scan: Option<u64>,
    /// How long the stall lasts, ms.
    #[arg(long, default_value_t = 2000, value_name = "MS")]
    pub stall_ms: u64,
    /// Drive the simulated robot by the commands read from stdin: one a line, either
    /// what `tether run` prints (`v_mps`, `w_radps`) or a wheels base's lines (JSON
    /// `left_mps`, `right_mps`, or text `LEFT RIGHT`, m/s, turned into a velocity with
    /// the scenario robot's track width); the robot stops when stdin ends.
    #[arg(long, conflicts_with = "commands")]
    pub commands_stdin: bool,
    /// Like `--commands-stdin`, from FILE: a FIFO that `tether run`'s `[base] kind =
    /// "wheels"` writes into (its own command stream, apart from stdout). The robot
    /// stops each time the writers close it, and the FIFO is opened again for the next
    /// run.
    #[arg(long, value_name = "FILE")]
    pub commands: Option<PathBuf>,
    /// Write the ground truth of every served scan to FILE, one JSON line each:
    /// `t_s` (simulated time, from 0 at each start of the scenario), `robot` (`x`, `y`,
    /// `yaw`), `v_mps`, `w_radps`, `collisions`, `people` (`id`, `name`, `target`, `x`,
    /// `y`).
    #[arg(long, value_name = "FILE")]
    pub truth: Option<PathBuf>,
}

/// `FRAME=ADDR` of `--extra-tcp`.
fn frame_at_address(text: &str) -> Result<(String, String), String> {
    match text.split_once('=') {
        Some((frame, address)) if !frame.is_empty() && !address.is_empty() => {
            Ok((frame.to_owned(), address.to_owned()))
        }
        _ => Err(format!(
            "{text:?} is not FRAME=ADDR (e.g. rear_laser=127.0.0.1:10941)"
        )),
    }
}

/// Serves `source` on the endpoint the arguments name until the process is stopped.
/// `announce` gets the path or address once it is open.
pub fn serve<S: ScanSource + 'static>(
    args: &Args,
    config: EmulatorConfig,
    source: S,
    announce: impl FnOnce(&str),
) -> anyhow::Result<()> {
    let emulator = Emulator::new(config, source);
    let server = match &args.tcp {
        Some(addr) => EmulatorServer::tcp(emulator, addr.as_str())
            .with_context(|| format!("listening on {addr}"))?,
        None => EmulatorServer::pty(emulator).context("opening a pseudo-terminal")?,
    };
    announce(&server.endpoint().to_string());
    server.wait().context("the emulator stopped")?;
    Ok(())
}

/// Runs the emulator.
pub fn run(args: Args) -> anyhow::Result<()> {
    let (scenario, _) = Scenario::resolve(&args.scenario)?;
    let (mut scans, mut config) = simulated_scans(&scenario, args.seed, args.laser.as_deref())?;
    if let Some(path) = &args.truth {
        let file = std::fs::File::create(path)
            .with_context(|| format!("cannot create the truth file {}", path.display()))?;
        scans = scans.with_truth(Box::new(std::io::BufWriter::new(file)));
    }
    if args.commands_stdin || args.commands.is_some() {
        let inbox: CommandInbox = Arc::new(Mutex::new((
            0,
            Command {
                v_mps: 0.0,
                w_radps: 0.0,
            },
        )));
        let reader = Arc::clone(&inbox);
        let track_width_m = scenario.robot.track_width_m;
        let source = args.commands.clone();
        if let Some(path) = &source {
            // Refused now rather than in the reader thread.
            use std::os::unix::fs::FileTypeExt;
            let meta = std::fs::metadata(path).with_context(|| {
                format!(
                    "--commands {}: no such FIFO (mkfifo it first)",
                    path.display()
                )
            })?;
            anyhow::ensure!(
                meta.file_type().is_fifo(),
                "--commands {}: not a FIFO but a {}; a regular file there is likely left by a \
                 `tether run` started before the FIFO existed: remove it and `mkfifo {}`",
                path.display(),
                if meta.is_file() {
                    "regular file"
                } else {
                    "file of another kind"
                },
                path.display()
            );
        }
        std::thread::Builder::new()
            .name("commands".into())
            .spawn(move || match source {
                None => {
                    read_commands(std::io::stdin().lock(), &reader, track_width_m);
                }
                Some(path) => read_command_file(&path, &reader, track_width_m),
            })
            .context("starting the command reader")?;
        scans = scans.with_commands(inbox);
    }
    config.boot_in_scip1 = args.scip1;
    config.faults = Faults {
        bad_checksum_every: args.bad_checksum_every,
        truncated_line_every: args.truncated_line_every,
        unknown_status_every: args.unknown_status_every,
        garbage_every: args.garbage_every,
        stall: args.stall_at_scan.map(|at_scan| Stall {
            at_scan,
            duration_ms: args.stall_ms,
        }),
        seed: args.seed,
    };
    let name = scenario.name.clone();
    // One simulation for every scanner (`--extra-tcp`): each extra one listens before
    // the first announces itself, so that a client reading the first line may connect
    // to all.
    let mut configs = Vec::new();
    for (frame, _) in &args.extra_tcp {
        let (with_extra, extra_config) = scans.with_extra_laser(frame)?;
        scans = with_extra;
        configs.push(extra_config);
    }
    let mut sources = scans.shared().into_iter();
    let first = sources.next().context("no laser to serve")?;
    let mut extras = Vec::new();
    for (((frame, address), extra_config), source) in
        args.extra_tcp.iter().zip(configs).zip(sources)
    {
        let server = EmulatorServer::tcp(Emulator::new(extra_config, source), address.as_str())
            .with_context(|| format!("listening on {address} for the laser {frame}"))?;
        extras.push((frame.clone(), server));
    }
    serve(&args, config, first, |endpoint| {
        // The emulator serves on whether or not anybody reads where it listens.
        tether::outln!("URG-04LX emulator (SCIP 2.0, scenario `{name}`) on {endpoint}").ok();
        for (frame, server) in &extras {
            tether::outln!(
                "URG-04LX emulator (SCIP 2.0, scenario `{name}`, laser {frame}) on {}",
                server.endpoint()
            )
            .ok();
        }
    })
}
