//! `tether config defaults`: every pipeline parameter with its default and meaning.

/// What `tether config` shows.
#[derive(Debug, clap::Subcommand)]
pub enum ConfigCommand {
    /// Print every pipeline parameter with its default and one-line meaning (unit at
    /// the end), in the TOML layout `--config` and a robot's `[pipeline]` read.
    Defaults,
}

/// Prints what was asked for.
pub fn run(command: ConfigCommand) -> anyhow::Result<()> {
    match command {
        ConfigCommand::Defaults => {
            let (text, _) = tether::config_docs::annotated_defaults()?;
            tether::outln!("{}", text.trim_end())?;
        }
    }
    Ok(())
}
