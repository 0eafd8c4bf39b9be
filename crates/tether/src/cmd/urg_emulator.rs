//! `tether urg-emulator`: a Hokuyo URG-04LX that speaks SCIP 2.0 byte for byte on a
//! pseudo-terminal or a TCP port, serving the scans of a simulated scene, so that a
//! driver (tether's own, `urg_node`, ...) can be run without the hardware.
//!
//! The scans come from a [`ScanSource`]. [`simulated_scans`] makes one from a
//! scenario of `tether_sim` with the robot standing still; a caller that wants other
//! scans (a moving robot driven by the commands tether sends back, a recording) passes
//! its own source to [`serve`].

use anyhow::Context;
use tether_io::scip::emulator::{
    Emulator, EmulatorConfig, EmulatorServer, Faults, ScanSource, Stall,
};
use tether_sim::{Scenario, SensorData, Simulation};

/// Options of `tether urg-emulator`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Serve on a new pseudo-terminal; its path is printed (open it as a serial port).
    #[arg(long, conflicts_with = "tcp", required_unless_present = "tcp")]
    pub pty: bool,
    /// Serve on this TCP address, like an Ethernet URG (e.g. 127.0.0.1:10940).
    #[arg(long, value_name = "ADDR")]
    pub tcp: Option<String>,
    /// Scenario whose laser scans are served: a built-in name (see `tether scenarios`)
    /// or a scenario .toml file. The robot stands still; the people walk; the scenario
    /// starts over at its end.
    #[arg(long, default_value = "office", value_name = "NAME")]
    pub scenario: String,
    /// Seed of the simulation's random draws.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
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
}

/// Laser scans of a scenario with a still robot, in millimetres for the emulator.
pub struct SimulatedScans {
    scenario: Scenario,
    seed: u64,
    sim: Simulation,
    beams: usize,
}

/// What the emulator sends for a beam without return: an error code (below `DMIN`).
const NO_ECHO_CODE_MM: u32 = 1;

impl ScanSource for SimulatedScans {
    fn scan(&mut self, _scan_index: u64, ranges_mm: &mut Vec<u32>) {
        // At most two passes: the scenario may end and start over once.
        for _ in 0..2 {
            while let Some(event) = self.sim.advance() {
                if let SensorData::Scan(scan) = event.data {
                    ranges_mm.extend(scan.ranges_m().iter().map(|&r| {
                        if r.is_finite() {
                            (f64::from(r) * 1000.0).round().max(0.0) as u32
                        } else {
                            NO_ECHO_CODE_MM
                        }
                    }));
                    ranges_mm.resize(self.beams, NO_ECHO_CODE_MM);
                    return;
                }
            }
            match Simulation::new(&self.scenario, self.seed) {
                Ok(sim) => self.sim = sim,
                Err(_) => break,
            }
        }
        ranges_mm.resize(self.beams, NO_ECHO_CODE_MM);
    }
}

/// The scans of `scenario` (robot still) and the emulator configuration of its laser
/// (step geometry, range limits, scan rate).
pub fn simulated_scans(
    scenario: &Scenario,
    seed: u64,
) -> anyhow::Result<(SimulatedScans, EmulatorConfig)> {
    anyhow::ensure!(
        scenario.laser_sim.enabled,
        "scenario `{}` has no simulated laser (laser_sim.enabled = false)",
        scenario.name
    );
    let sim = Simulation::new(scenario, seed)
        .with_context(|| format!("building scenario `{}`", scenario.name))?;
    let laser = &scenario.laser;
    let config = EmulatorConfig {
        geometry: laser.geometry,
        // A URG-04LX accepts steps up to 768, 43 past its last measured one.
        max_step: (laser.geometry.last_step + 43).min(9999) as u16,
        range_min_mm: (laser.range_min_m * 1000.0).round() as u32,
        range_max_mm: (laser.range_max_m * 1000.0).round() as u32,
        scan_rpm: (60.0 / laser.scan_period_s).round().max(1.0) as u32,
        ..EmulatorConfig::default()
    };
    let scans = SimulatedScans {
        scenario: scenario.clone(),
        seed,
        sim,
        beams: laser.geometry.beam_count(),
    };
    Ok((scans, config))
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
    let (scans, mut config) = simulated_scans(&scenario, args.seed)?;
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
    serve(&args, config, scans, |endpoint| {
        println!("URG-04LX emulator (SCIP 2.0, scenario `{name}`) on {endpoint}");
    })
}
