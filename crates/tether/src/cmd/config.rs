//! `tether config`: every pipeline parameter with its default and meaning (`defaults`),
//! and the configuration a run with a given file uses, each value with where it came
//! from (`show`).

use std::path::PathBuf;

use tether_live::config::OWNED_ELSEWHERE;
use tether_live::node_params;
use tether_live::pipeline_file;
use tether_pipeline::PipelineConfig;

/// What `tether config` shows.
#[derive(Debug, clap::Subcommand)]
pub enum ConfigCommand {
    /// Print every pipeline parameter with its default and one-line meaning (unit at
    /// the end), in the TOML layout `--config` and a robot's `[pipeline]` read.
    Defaults,
    /// Print the pipeline configuration a run given `--config FILE` uses (`run`,
    /// `ros2`, `track`, `replay`, `sim`, `eval-target`...), every key with its meaning
    /// and, at the end of its line, where its value came from: the file's
    /// `[pipeline]` (or a pipeline file's own tables), the robot's own tables
    /// (`[robot]`, `[laser] mount`, `[camera]`, `[follow]`), or the default.
    Show {
        /// The configuration file: a robot's (`tether run`'s, with `[robot]`) or a
        /// pipeline's (every table optional). Without it: the defaults.
        #[arg(long, value_name = "FILE")]
        config: Option<PathBuf>,
        /// A parameter of `tether ros2` that sets the pipeline, as the node takes it
        /// (`-p follow_distance:=1.0`; `docs/ros2.md` lists them): applied over the file,
        /// as the node applies it. Repeatable.
        #[arg(short = 'p', value_name = "NAME:=VALUE")]
        params: Vec<String>,
    },
}

/// Prints what was asked for.
pub fn run(command: ConfigCommand) -> anyhow::Result<()> {
    match command {
        ConfigCommand::Defaults => {
            let (text, _) = tether_live::config_docs::annotated_defaults()?;
            tether::outln!("{}", text.trim_end())?;
        }
        ConfigCommand::Show { config, params } => {
            tether::outln!("{}", show(config.as_ref(), &params)?.trim_end())?;
        }
    }
    Ok(())
}

/// `-p NAME:=VALUE` applied to `config`, as `tether ros2` applies it
/// ([`tether_live::node_params`]): the keys it set, each with the `-p` that set it.
fn apply_params(
    config: &mut PipelineConfig,
    params: &[String],
) -> anyhow::Result<Vec<(String, String)>> {
    let mut set = Vec::new();
    for p in params {
        let Some((name, value)) = p.split_once(":=") else {
            anyhow::bail!("-p {p}: expected NAME:=VALUE, e.g. -p follow_distance:=1.0");
        };
        let key = node_params::set_pipeline(config, name, value.trim().parse::<f64>().ok())
            .map_err(|e| anyhow::anyhow!("-p {p}: {e}"))?;
        set.retain(|(k, _): &(String, String)| k != key);
        set.push((key.to_owned(), format!("-p {name}")));
    }
    Ok(set)
}

/// The annotated configuration of `tether config show`, with `-p` parameters `params`.
fn show(path: Option<&PathBuf>, params: &[String]) -> anyhow::Result<String> {
    let mut config = pipeline_file::load(path.map(PathBuf::as_path))?;
    let by_param = apply_params(&mut config, params)?;
    let from_param = |key: &str| {
        by_param
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, p)| p.clone())
    };
    let defaults = toml::Table::try_from(PipelineConfig::default())?;
    let effective = toml::Table::try_from(&config)?;
    let Some(path) = path else {
        let header = "# The pipeline configuration of a run without --config (`tether config show`):\n\
                      # every value is the default but for the -p parameters named.\n\n";
        // Sources are said only when a -p makes one value differ from the defaults.
        let source = |key: &str| match by_param.is_empty() {
            true => None,
            false => from_param(key).or_else(|| Some("default".to_owned())),
        };
        let (text, _) = tether_live::config_docs::annotated(header, &config, &source)?;
        return Ok(text);
    };
    let name = path.display().to_string();
    let file: toml::Table = toml::from_str(&std::fs::read_to_string(path)?)?;
    let robot = file.contains_key("robot");
    let empty = toml::Table::new();
    let pipeline = match robot {
        true => file
            .get("pipeline")
            .and_then(toml::Value::as_table)
            .unwrap_or(&empty),
        false => &file,
    };
    let tables = SourceTables {
        name: &name,
        robot,
        has_camera: file.contains_key("camera"),
        laser_list: file.get("laser").is_some_and(toml::Value::is_array),
        pipeline,
        defaults: &defaults,
        effective: &effective,
    };
    let source = |key: &str| from_param(key).or_else(|| Some(source_of(key, &tables)));
    let header = format!(
        "# The pipeline configuration a run given --config {name} uses (`tether config show`):\n\
         # every key with its meaning and, at the end of its line, where its value came from.\n{}\n",
        if robot {
            "# A robot's file: its [base] and [output] tables and the laser's port are the\n\
             # live run's own, not shown here.\n"
        } else {
            ""
        }
    );
    let (text, _) = tether_live::config_docs::annotated(&header, &config, &source)?;
    Ok(text)
}

/// What [`source_of`] looks at.
struct SourceTables<'a> {
    /// The file, as the user named it.
    name: &'a str,
    /// A robot's file (with `[robot]`).
    robot: bool,
    /// It has a `[camera]`.
    has_camera: bool,
    /// Its scanners are `[[laser]]` tables (the extra lasers are theirs).
    laser_list: bool,
    /// Its pipeline keys: a robot file's `[pipeline]`, or the whole of a pipeline file.
    pipeline: &'a toml::Table,
    /// The defaults and the configuration in use, as TOML.
    defaults: &'a toml::Table,
    effective: &'a toml::Table,
}

/// Where the value of the dotted pipeline key `key` came from.
fn source_of(key: &str, t: &SourceTables<'_>) -> String {
    if t.robot {
        // The robot's key: the owner's, with what follows the owned table (`laser.mount`
        // -> `laser.mount.x_m`); `[camera]` has the pipeline's layout.
        let owner = OWNED_ELSEWHERE.iter().find_map(|(owned, owner)| {
            let owned = owned.strip_prefix("pipeline.").unwrap_or(owned);
            let rest = key.strip_prefix(owned)?;
            if !(rest.is_empty() || rest.starts_with('.')) {
                return None;
            }
            Some(match owner.contains(' ') {
                true => key.to_owned(),
                false => format!("{owner}{rest}"),
            })
        });
        if let Some(owner) = owner {
            return format!("{}: {owner}", t.name);
        }
        if key == "fusion.use_vision" && !t.has_camera {
            return format!("{}: no [camera]", t.name);
        }
        if key == "extra_lasers" && t.laser_list && lookup(t.pipeline, key).is_none() {
            return format!("{}: [[laser]]", t.name);
        }
    }
    if lookup(t.pipeline, key).is_some() {
        return match t.robot {
            true => format!("{}: [pipeline]", t.name),
            false => t.name.to_owned(),
        };
    }
    if lookup(t.effective, key) != lookup(t.defaults, key) {
        return format!("{} (derived)", t.name);
    }
    "default".to_owned()
}

/// The value at dotted `key` of `table`.
fn lookup<'a>(table: &'a toml::Table, key: &str) -> Option<&'a toml::Value> {
    let mut parts = key.split('.');
    let mut node = table.get(parts.next()?)?;
    for part in parts {
        node = node.as_table()?.get(part)?;
    }
    Some(node)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, reason = "tests fail loudly")]

    use super::*;

    fn shown(text: &str, file: &str) -> String {
        let dir = std::env::temp_dir().join(format!("tether-config-show-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(file);
        std::fs::write(&path, text).unwrap();
        show(Some(&path), &[]).unwrap()
    }

    /// The line of `key` in `[table]` of an annotated configuration.
    fn line<'a>(text: &'a str, table: &str, key: &str) -> &'a str {
        let section = text
            .split(&format!("\n[{table}]\n"))
            .nth(1)
            .unwrap_or_else(|| panic!("no [{table}] in\n{text}"));
        section
            .lines()
            .find(|l| l.starts_with(&format!("{key} = ")))
            .unwrap_or_else(|| panic!("no {key} in [{table}] of\n{text}"))
    }

    #[test]
    fn a_pipeline_file_s_keys_are_named_and_the_others_are_defaults() {
        let text = shown("[safety]\ntarget_timeout_s = 0.8\n", "pipeline.toml");
        let from = line(&text, "safety", "target_timeout_s");
        assert!(from.starts_with("target_timeout_s = 0.8  # "), "{from}");
        assert!(from.ends_with("pipeline.toml"), "{from}");
        assert!(
            line(&text, "safety", "laser_timeout_s").ends_with("# default"),
            "{text}"
        );
        // What is shown is what is used: it reads back as the file's configuration.
        let back: PipelineConfig = toml::from_str(&text).unwrap();
        assert_eq!(back.safety.target_timeout_s, 0.8);
        assert_eq!(back.limits, PipelineConfig::default().limits);
    }

    #[test]
    fn a_robot_file_names_the_table_each_value_came_from() {
        let example = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../configs/robot.example.toml");
        let text = show(Some(&example), &[]).unwrap();
        let name = example.display().to_string();
        assert!(
            line(&text, "limits", "max_speed_mps")
                .ends_with(&format!("# {name}: robot.max_speed_mps")),
            "{text}"
        );
        assert!(
            line(&text, "limits", "max_decel_mps2").ends_with(&format!("# {name}: [pipeline]")),
            "{text}"
        );
        assert!(
            line(&text, "laser.mount", "x_m").ends_with(&format!("# {name}: laser.mount.x_m")),
            "{text}"
        );
        assert!(
            line(&text, "limits", "max_jerk_mps3").ends_with("# default"),
            "{text}"
        );
        assert!(
            line(&text, "camera.intrinsics", "fx_px")
                .ends_with(&format!("# {name}: camera.intrinsics.fx_px")),
            "{text}"
        );
        assert!(text.contains("[base] and [output]"), "{text}");
    }

    #[test]
    fn a_robot_s_further_scanners_are_its_extra_lasers_from_its_laser_tables() {
        let example = std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../../configs/robot.example.toml"),
        )
        .unwrap()
        .replacen("\n[laser]\n", "\n[[laser]]\n", 1)
        .replacen(
            "\n[follow]\n",
            "\n[[laser]]\ntcp = \"10.0.0.2\"\nframe_id = \"rear_laser\"\n\
             mount = { x_m = -0.2, y_m = 0.0, yaw_rad = 3.0, height_m = 0.3 }\n\n[follow]\n",
            1,
        );
        let text = shown(&example, "two_lasers.toml");
        assert!(
            text.contains("\n[[extra_lasers]]  # ")
                && text.contains("two_lasers.toml: [[laser]]\n"),
            "{text}"
        );
        let back: PipelineConfig = toml::from_str(&text).unwrap();
        assert_eq!(back.extra_lasers.len(), 1);
        assert_eq!(back.extra_lasers[0].frame_id, "rear_laser");
        assert_eq!(back.extra_lasers[0].laser.mount.x_m, -0.2);
    }

    #[test]
    fn a_parameter_of_the_node_overrides_the_file_and_says_so() {
        let text = show(None, &["follow_distance:=1.3".to_owned()]).unwrap();
        let from = line(&text, "follower", "follow_distance_m");
        assert!(from.starts_with("follow_distance_m = 1.3  # "), "{from}");
        assert!(from.ends_with("# -p follow_distance"), "{from}");
        assert!(
            line(&text, "follower", "attach_ahead_m").ends_with("# default"),
            "{text}"
        );
        let back: PipelineConfig = toml::from_str(&text).unwrap();
        assert_eq!(back.follower.follow_distance_m, 1.3);
        for bad in [
            "follow_distance=1",
            "fixed_frame:=map",
            "follow_distance:=-2",
            "nope:=1",
        ] {
            assert!(show(None, &[bad.to_owned()]).is_err(), "{bad}");
        }
    }
}
