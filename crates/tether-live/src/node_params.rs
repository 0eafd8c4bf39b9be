//! The parameters of `tether ros2` (`--ros-args -p NAME:=VALUE`), in one table: each
//! name with its default, unit, meaning and, for those that set the pipeline, the key of
//! the configuration file it overrides (`follow_distance` is `follower.follow_distance_m`),
//! whose unit, meaning and range are the configuration registry's for that key
//! ([`crate::config_docs::field_doc`]). The node reads its parameters through this table,
//! `tether config show -p` applies the pipeline's among them to the configuration it
//! prints, and a test holds `docs/ros2.md`'s table to it.

use tether_core::config_docs::ValueRange;
use tether_pipeline::PipelineConfig;

use crate::config_docs::{field_doc, unit_of_key};

/// What a parameter sets.
#[derive(Debug, Clone, Copy)]
pub enum Sets {
    /// A number of the pipeline's configuration: its dotted key in a configuration file
    /// and the field. Its value must be in the key's range.
    Pipeline {
        /// The key of the configuration file it overrides, e.g.
        /// `follower.follow_distance_m`.
        key: &'static str,
        /// The field.
        field: fn(&mut PipelineConfig) -> &mut f64,
    },
    /// A setting of the node itself (frames, topics, the guard).
    Node,
}

/// One parameter of `tether ros2`.
#[derive(Debug, Clone, Copy)]
pub struct NodeParam {
    /// The name after `-p`.
    pub name: &'static str,
    /// Its default, as `-p` would spell it (`-` when the configuration decides).
    pub default: &'static str,
    /// A setting of the node's: its unit, or the values it takes.
    node_unit: &'static str,
    /// A setting of the node's: what it does.
    node_meaning: &'static str,
    /// What it sets.
    pub sets: Sets,
}

impl NodeParam {
    /// Its unit, or the values it takes (a pipeline's number: its key's unit).
    pub fn unit(&self) -> &'static str {
        match self.sets {
            Sets::Pipeline { key, .. } => unit_of_key(key),
            Sets::Node => self.node_unit,
        }
    }

    /// What it does (a pipeline's number: its key's meaning).
    pub fn meaning(&self) -> &'static str {
        match self.sets {
            Sets::Pipeline { key, .. } => field_doc(key).map_or("", |d| d.doc),
            Sets::Node => self.node_meaning,
        }
    }

    /// The values it takes, when it sets a bounded number of the pipeline.
    pub fn range(&self) -> Option<ValueRange> {
        match self.sets {
            Sets::Pipeline { key, .. } => field_doc(key).and_then(|d| d.range),
            Sets::Node => None,
        }
    }
}

/// Every parameter of `tether ros2`.
pub const NODE_PARAMS: &[NodeParam] = &[
    node(
        "fixed_frame",
        "odom",
        "frame",
        "the frame of the results and the target",
    ),
    node(
        "base_frame",
        "base_link",
        "frame",
        "the robot's frame; the sensors' mounts are looked up in it",
    ),
    node(
        "cmd_vel_stamped",
        "false",
        "true or false",
        "the commands as TwistStamped in base_frame",
    ),
    node(
        "publish_cmd_vel",
        "true",
        "true or false",
        "false: no cmd_vel publisher at all (Nav2 drives)",
    ),
    node(
        "cmd_vel_guard",
        "true",
        "true or false",
        "the guard process that stops the base when the node dies",
    ),
    node(
        "target_frame",
        "target",
        "frame",
        "the target's frame on /tf, a child of fixed_frame",
    ),
    node(
        "image_transport",
        "raw",
        "raw or compressed",
        "compressed: the camera on image_raw/compressed",
    ),
    node(
        "camera_input",
        "-",
        "images or detections",
        "the camera's people from tether's cascade on the frames, or another node's boxes",
    ),
    node(
        "extra_scan_topics",
        "[]",
        "list of topics",
        "the scans of more scanners, each a laser of its own (its mount from /tf_static or the configuration)",
    ),
    node(
        "extra_camera_topics",
        "-",
        "list of topics",
        "the further cameras ([[camera]] after the first), one topic each, read like the first (default FRAME/image_raw or FRAME/detections)",
    ),
    node(
        "detection_class",
        "person",
        "class name",
        "the class of the boxes taken for people (empty: all)",
    ),
    pipeline("follow_distance", "follower.follow_distance_m", |p| {
        &mut p.follower.follow_distance_m
    }),
    pipeline("attach_ahead", "follower.attach_ahead_m", |p| {
        &mut p.follower.attach_ahead_m
    }),
    pipeline("distance_omega", "follower.distance_omega_radps", |p| {
        &mut p.follower.distance_omega_radps
    }),
    pipeline("bearing_omega", "follower.bearing_omega_radps", |p| {
        &mut p.follower.bearing_omega_radps
    }),
    node(
        "use_sim_time",
        "false",
        "true or false",
        "true: the time is /clock's",
    ),
];

/// A parameter of the node itself.
const fn node(
    name: &'static str,
    default: &'static str,
    unit: &'static str,
    meaning: &'static str,
) -> NodeParam {
    NodeParam {
        name,
        default,
        node_unit: unit,
        node_meaning: meaning,
        sets: Sets::Node,
    }
}

/// A parameter that overrides a number of the pipeline's configuration, `key` (its
/// default, unit, meaning and range are the key's).
const fn pipeline(
    name: &'static str,
    key: &'static str,
    field: fn(&mut PipelineConfig) -> &mut f64,
) -> NodeParam {
    NodeParam {
        name,
        default: "-",
        node_unit: "",
        node_meaning: "",
        sets: Sets::Pipeline { key, field },
    }
}

/// The parameter called `name`.
pub fn param(name: &str) -> Option<&'static NodeParam> {
    NODE_PARAMS.iter().find(|p| p.name == name)
}

/// The names of every parameter, for messages.
pub fn names() -> String {
    NODE_PARAMS
        .iter()
        .map(|p| p.name)
        .collect::<Vec<_>>()
        .join(", ")
}

/// Sets the pipeline's number that parameter `name` overrides to `value`; the error says
/// why not (not a parameter, not one of the pipeline's, not a number in its key's range).
pub fn set_pipeline(
    config: &mut PipelineConfig,
    name: &str,
    value: Option<f64>,
) -> Result<&'static str, String> {
    let p = param(name)
        .ok_or_else(|| format!("{name} is not a parameter of tether ros2 ({})", names()))?;
    let Sets::Pipeline { key, field } = p.sets else {
        return Err(format!(
            "parameter {name} is a setting of the node, not of the pipeline"
        ));
    };
    let range = p.range();
    match value {
        Some(x) if x.is_finite() && range.is_none_or(|r| r.admits(x)) => {
            *field(config) = x;
            Ok(key)
        }
        _ => Err(format!(
            "parameter {name} must be a number{} in {}, got {}",
            range.map_or(String::new(), |r| format!(" {}", r.text)),
            p.unit(),
            value.map_or_else(|| "something else".to_owned(), |v| v.to_string())
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pipeline_s_parameters_set_the_keys_they_name() {
        for p in NODE_PARAMS {
            let Sets::Pipeline { key, .. } = p.sets else {
                continue;
            };
            let mut config = PipelineConfig::default();
            assert_eq!(set_pipeline(&mut config, p.name, Some(1.25)), Ok(key));
            let table = toml::Table::try_from(&config).unwrap();
            let mut value = &toml::Value::Table(table);
            for part in key.split('.') {
                value = value
                    .get(part)
                    .unwrap_or_else(|| panic!("{key}: no {part}"));
            }
            assert_eq!(value.as_float(), Some(1.25), "{key}");
        }
    }

    /// A pipeline's parameter says its key's unit and meaning, and refuses what the
    /// key's range refuses.
    #[test]
    fn a_pipeline_s_parameter_is_its_key_s() {
        let p = param("follow_distance").unwrap_or_else(|| panic!("no follow_distance"));
        assert_eq!(p.unit(), "m");
        assert!(
            p.meaning().starts_with("Follow distance"),
            "{}",
            p.meaning()
        );
        assert_eq!(p.range().map(|r| r.text), Some("> 0"));
        let mut config = PipelineConfig::default();
        let refused = set_pipeline(&mut config, "follow_distance", Some(0.0));
        assert_eq!(
            refused,
            Err("parameter follow_distance must be a number > 0 in m, got 0".to_owned())
        );
        for p in NODE_PARAMS
            .iter()
            .filter(|p| matches!(p.sets, Sets::Pipeline { .. }))
        {
            assert!(
                !p.unit().is_empty() && !p.meaning().is_empty(),
                "{}",
                p.name
            );
        }
    }

    #[test]
    fn what_is_not_a_positive_number_of_the_pipeline_is_refused() {
        let mut config = PipelineConfig::default();
        assert!(set_pipeline(&mut config, "follow_distance", Some(-1.0)).is_err());
        assert!(set_pipeline(&mut config, "follow_distance", None).is_err());
        assert!(set_pipeline(&mut config, "fixed_frame", Some(1.0)).is_err());
        assert!(set_pipeline(&mut config, "no_such", Some(1.0)).is_err());
        assert_eq!(config.follower, PipelineConfig::default().follower);
    }

    /// `docs/ros2.md` names every parameter in its table, with its unit.
    #[test]
    fn every_parameter_is_in_the_ros2_document() {
        let doc = include_str!("../../../docs/ros2.md");
        for p in NODE_PARAMS {
            assert!(
                doc.lines()
                    .any(|l| l.starts_with(&format!("| `{}` |", p.name)) && l.contains(p.unit())),
                "{} is not in docs/ros2.md's table of parameters",
                p.name
            );
        }
    }
}
