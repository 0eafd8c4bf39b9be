//! `--leg-model FILE`: the leg model of `tether train-legs` for every command that runs
//! the pipeline (`track`, `eval-track`, `replay`, `run`, `ros2`, `eval-target`, `sim`,
//! `demo`), in place of the config's `[legs] model` (`[pipeline.legs] model` in a
//! robot's config) and of the built-in model. `tether legs` and `eval-legs`, which run
//! the detector alone, take it as `--model`.

use std::path::PathBuf;

use tether_pipeline::PipelineConfig;

/// The option, flattened into each command's arguments.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct LegModelArg {
    /// A leg model of `tether train-legs` (JSON) for the learned leg detector, in place
    /// of the config's `[legs] model` and of the built-in model; read and checked at
    /// start (a model trained on other features must be retrained).
    #[arg(long, value_name = "FILE.json")]
    pub leg_model: Option<PathBuf>,
}

impl LegModelArg {
    /// Names the model in `config` (the pipeline reads it through
    /// `tether_live::leg_model`); without the option, `config` is left as it is.
    pub fn apply(&self, config: &mut PipelineConfig) {
        if let Some(path) = &self.leg_model {
            config.legs.model = Some(path.clone());
        }
    }

    /// [`LegModelArg::apply`] to each configuration.
    pub fn apply_all<'a>(&self, configs: impl IntoIterator<Item = &'a mut PipelineConfig>) {
        for config in configs {
            self.apply(config);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_option_overrides_the_config_and_its_absence_changes_nothing() {
        let mut config = PipelineConfig::default();
        config.legs.model = Some("from_config.json".into());
        LegModelArg::default().apply(&mut config);
        assert_eq!(config.legs.model, Some("from_config.json".into()));
        let arg = LegModelArg {
            leg_model: Some("from_flag.json".into()),
        };
        arg.apply(&mut config);
        assert_eq!(config.legs.model, Some("from_flag.json".into()));
    }
}
