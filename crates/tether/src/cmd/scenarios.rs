//! `tether scenarios`: list the built-in scenarios.

use tether_sim::{BUILTIN_NAMES, Scenario};

/// Options of `tether scenarios`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Print the TOML of this scenario instead (a starting point for your own).
    #[arg(long, value_name = "NAME")]
    pub show: Option<String>,
}

/// Prints one line per built-in scenario, or one scenario's TOML.
pub fn run(args: Args) -> anyhow::Result<()> {
    if let Some(name) = args.show {
        let text = Scenario::builtin_toml(&name).ok_or_else(|| {
            anyhow::anyhow!(
                "no built-in scenario named `{name}`; run `tether scenarios` to list them"
            )
        })?;
        tether::outln!("{}", text.trim_end())?;
        return Ok(());
    }
    let width = BUILTIN_NAMES.iter().map(|n| n.len()).max().unwrap_or(0);
    for name in BUILTIN_NAMES {
        let scenario = Scenario::builtin(name)?;
        tether::outln!(
            "{name:<width$}  {:>4.0} s  {} {}  {}",
            scenario.duration_s,
            scenario.people.len(),
            if scenario.people.len() == 1 {
                "person, "
            } else {
                "people, "
            },
            scenario.description
        )?;
    }
    Ok(())
}
