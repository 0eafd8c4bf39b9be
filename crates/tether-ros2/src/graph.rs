//! What is wrong between this node's topics and the graph's: a publisher or subscriber
//! of the same topic with another message type, or with a QoS that DDS will not match
//! (a `/tf_static` publisher that is not transient local, a `/cmd_vel` subscriber that
//! wants more than tether offers). DDS itself says nothing: the endpoints just never
//! connect. [`check`] compares the node's endpoints with the discovered remote ones and
//! says what to change.

use std::fmt;

use ros2_client::dds::rustdds::QosPolicies;
use ros2_client::dds::rustdds::policy::{Durability, Reliability};
use ros2_client::dds::rustdds::qos::QosPolicyId;

/// Which way an endpoint carries messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// A subscription (a DDS reader).
    Subscription,
    /// A publisher (a DDS writer).
    Publication,
}

/// One endpoint, this node's or a remote one, as discovery describes it.
#[derive(Debug, Clone)]
pub struct Endpoint {
    /// The ROS topic name (`/scan`).
    pub topic: String,
    /// The ROS type name (`sensor_msgs/msg/LaserScan`).
    pub type_name: String,
    /// Its QoS: offered for a publication, requested for a subscription.
    pub qos: QosPolicies,
    /// Reader or writer.
    pub direction: Direction,
}

impl Endpoint {
    /// A remote endpoint from its DDS names (`rt/scan`,
    /// `sensor_msgs::msg::dds_::LaserScan_`); `None` for topics that are not ROS
    /// topics (no `rt/` prefix, as DDS's and ROS's own service topics).
    pub fn from_dds(
        dds_topic: &str,
        dds_type: &str,
        qos: QosPolicies,
        direction: Direction,
    ) -> Option<Self> {
        let topic = dds_topic.strip_prefix("rt/")?;
        Some(Endpoint {
            topic: format!("/{topic}"),
            type_name: ros_type_name(dds_type),
            qos,
            direction,
        })
    }
}

/// `pkg::msg::dds_::Type_` as `pkg/msg/Type`; anything else as it is.
pub fn ros_type_name(dds_type: &str) -> String {
    let parts: Vec<&str> = dds_type.split("::").collect();
    match parts.as_slice() {
        [package, kind, "dds_", name] => {
            format!(
                "{package}/{kind}/{}",
                name.strip_suffix('_').unwrap_or(name)
            )
        }
        _ => dds_type.to_owned(),
    }
}

/// What does not fit.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Mismatch {
    /// The remote endpoint carries another type on the topic.
    WrongType {
        /// The topic.
        topic: String,
        /// This node's endpoint's direction.
        ours: Direction,
        /// This node's type.
        our_type: String,
        /// The remote's type.
        their_type: String,
    },
    /// DDS will not match the two: the writer offers less than the reader requests.
    IncompatibleQos {
        /// The topic.
        topic: String,
        /// This node's endpoint's direction.
        ours: Direction,
        /// The policy that fails.
        policy: String,
        /// What the writer offers and the reader requests, in words.
        offered: String,
        /// What the reader requests.
        requested: String,
    },
}

fn durability(q: &QosPolicies) -> &'static str {
    match q.durability() {
        None | Some(Durability::Volatile) => "volatile",
        Some(Durability::TransientLocal) => "transient local",
        Some(Durability::Transient) => "transient",
        Some(Durability::Persistent) => "persistent",
    }
}

fn reliability(q: &QosPolicies) -> &'static str {
    match q.reliability() {
        Some(Reliability::Reliable { .. }) => "reliable",
        // DDS's default for a reader is best effort; a writer announces its own.
        None | Some(Reliability::BestEffort) => "best effort",
    }
}

/// The offered and requested values of `policy` in words.
fn policy_words(policy: QosPolicyId, q: &QosPolicies) -> String {
    match policy {
        QosPolicyId::Durability => durability(q).to_owned(),
        QosPolicyId::Reliability => reliability(q).to_owned(),
        other => format!("{other:?}"),
    }
}

/// The mismatches between `ours` and the remote endpoints `theirs` on the same topics.
/// Remote endpoints on other topics, and remote endpoints of the same direction
/// (two publishers do not talk to each other), are not compared.
pub fn check(ours: &[Endpoint], theirs: &[Endpoint]) -> Vec<Mismatch> {
    let mut found = Vec::new();
    for mine in ours {
        for other in theirs
            .iter()
            .filter(|t| t.topic == mine.topic && t.direction != mine.direction)
        {
            if other.type_name != mine.type_name {
                found.push(Mismatch::WrongType {
                    topic: mine.topic.clone(),
                    ours: mine.direction,
                    our_type: mine.type_name.clone(),
                    their_type: other.type_name.clone(),
                });
                continue;
            }
            let (writer, reader) = match mine.direction {
                Direction::Publication => (&mine.qos, &other.qos),
                Direction::Subscription => (&other.qos, &mine.qos),
            };
            if let Some(policy) = writer.compliance_failure_wrt(reader) {
                found.push(Mismatch::IncompatibleQos {
                    topic: mine.topic.clone(),
                    ours: mine.direction,
                    policy: format!("{policy:?}").to_lowercase(),
                    offered: policy_words(policy, writer),
                    requested: policy_words(policy, reader),
                });
            }
        }
    }
    found.sort_by_key(|m| format!("{m:?}"));
    found.dedup();
    found
}

impl fmt::Display for Mismatch {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Mismatch::WrongType {
                topic,
                ours: Direction::Subscription,
                our_type,
                their_type,
            } => write!(
                f,
                "{topic}: a publisher sends {their_type}, but tether reads {our_type} there, \
                 so nothing arrives; remap tether's topic to the one with {our_type} \
                 (--ros-args -r {}:=/the/right/topic)",
                topic.trim_start_matches('/')
            ),
            Mismatch::WrongType {
                topic,
                ours: Direction::Publication,
                our_type,
                their_type,
            } => {
                write!(
                    f,
                    "{topic}: a subscriber expects {their_type}, but tether publishes \
                     {our_type}, so it gets nothing"
                )?;
                if their_type == "geometry_msgs/msg/TwistStamped" {
                    write!(f, "; run tether with -p cmd_vel_stamped:=true")
                } else if their_type == "geometry_msgs/msg/Twist"
                    && our_type == "geometry_msgs/msg/TwistStamped"
                {
                    write!(f, "; run tether with -p cmd_vel_stamped:=false")
                } else {
                    write!(f, "; remap one of the two")
                }
            }
            Mismatch::IncompatibleQos {
                topic,
                ours,
                policy,
                offered,
                requested,
            } => {
                let (who, fix) = match ours {
                    Direction::Subscription => (
                        "a publisher offers",
                        format!("make the publisher {requested}"),
                    ),
                    Direction::Publication => (
                        "tether's publisher offers",
                        format!("make the subscriber ask for {offered}"),
                    ),
                };
                write!(
                    f,
                    "{topic}: {who} {policy} {offered} where the {} asks for {requested}, so \
                     DDS does not connect them; {fix}",
                    match ours {
                        Direction::Subscription => "tether subscription",
                        Direction::Publication => "subscriber",
                    }
                )
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use ros2_client::dds::rustdds::{Duration, QosPolicyBuilder};

    use super::*;

    fn qos(reliable: bool, latched: bool) -> QosPolicies {
        let mut b = QosPolicyBuilder::new();
        b = if reliable {
            b.reliability(Reliability::Reliable {
                max_blocking_time: Duration::from_millis(100),
            })
        } else {
            b.reliability(Reliability::BestEffort)
        };
        b = b.durability(if latched {
            Durability::TransientLocal
        } else {
            Durability::Volatile
        });
        b.build()
    }

    fn ep(topic: &str, ty: &str, q: QosPolicies, d: Direction) -> Endpoint {
        Endpoint {
            topic: topic.into(),
            type_name: ty.into(),
            qos: q,
            direction: d,
        }
    }

    const SCAN: &str = "sensor_msgs/msg/LaserScan";
    const TF: &str = "tf2_msgs/msg/TFMessage";
    const TWIST: &str = "geometry_msgs/msg/Twist";
    const STAMPED: &str = "geometry_msgs/msg/TwistStamped";

    #[test]
    fn dds_names_become_ros_names() {
        let e = Endpoint::from_dds(
            "rt/robot1/scan",
            "sensor_msgs::msg::dds_::LaserScan_",
            qos(false, false),
            Direction::Publication,
        )
        .unwrap();
        assert_eq!(e.topic, "/robot1/scan");
        assert_eq!(e.type_name, SCAN);
        assert!(
            Endpoint::from_dds(
                "DCPSParticipant",
                "x",
                qos(true, false),
                Direction::Publication
            )
            .is_none()
        );
        assert_eq!(ros_type_name("odd"), "odd");
    }

    #[test]
    fn a_matching_graph_has_nothing_to_say() {
        let ours = [
            ep("/scan", SCAN, qos(false, false), Direction::Subscription),
            ep("/cmd_vel", TWIST, qos(true, false), Direction::Publication),
        ];
        let theirs = [
            // Reliable and best-effort publishers both match a best-effort reader.
            ep("/scan", SCAN, qos(true, false), Direction::Publication),
            ep("/scan", SCAN, qos(false, false), Direction::Publication),
            // Another reader of the scans is none of our business.
            ep(
                "/scan",
                "std_msgs/msg/String",
                qos(false, false),
                Direction::Subscription,
            ),
            ep(
                "/cmd_vel",
                TWIST,
                qos(false, false),
                Direction::Subscription,
            ),
            ep("/other", SCAN, qos(false, false), Direction::Publication),
        ];
        assert!(check(&ours, &theirs).is_empty());
    }

    #[test]
    fn a_wrong_type_is_named_with_its_fix() {
        let ours = [
            ep("/scan", SCAN, qos(false, false), Direction::Subscription),
            ep("/cmd_vel", TWIST, qos(true, false), Direction::Publication),
        ];
        let theirs = [
            ep(
                "/scan",
                "sensor_msgs/msg/PointCloud2",
                qos(false, false),
                Direction::Publication,
            ),
            ep(
                "/cmd_vel",
                STAMPED,
                qos(true, false),
                Direction::Subscription,
            ),
        ];
        let found = check(&ours, &theirs);
        assert_eq!(found.len(), 2, "{found:?}");
        let text: Vec<String> = found.iter().map(ToString::to_string).collect();
        assert!(
            text.iter()
                .any(|t| t.contains("PointCloud2") && t.contains("-r scan:=")),
            "{text:?}"
        );
        assert!(
            text.iter().any(|t| t.contains("cmd_vel_stamped:=true")),
            "{text:?}"
        );
    }

    #[test]
    fn a_volatile_tf_static_and_a_latched_cmd_vel_reader_are_refused_qos() {
        let ours = [
            ep("/tf_static", TF, qos(true, true), Direction::Subscription),
            ep("/cmd_vel", TWIST, qos(true, false), Direction::Publication),
        ];
        let theirs = [
            ep("/tf_static", TF, qos(true, false), Direction::Publication),
            ep("/cmd_vel", TWIST, qos(true, true), Direction::Subscription),
        ];
        let found = check(&ours, &theirs);
        assert_eq!(found.len(), 2, "{found:?}");
        let text: Vec<String> = found.iter().map(ToString::to_string).collect();
        assert!(
            text.iter().any(|t| t.starts_with("/tf_static")
                && t.contains("volatile")
                && t.contains("make the publisher transient local")),
            "{text:?}"
        );
        assert!(
            text.iter()
                .any(|t| t.starts_with("/cmd_vel")
                    && t.contains("make the subscriber ask for volatile")),
            "{text:?}"
        );
        // A best-effort publisher to a reliable reader: the other policy that fails.
        let reliable_reader = [ep(
            "/tf_static",
            TF,
            qos(true, false),
            Direction::Subscription,
        )];
        let best_effort = [ep(
            "/tf_static",
            TF,
            qos(false, false),
            Direction::Publication,
        )];
        let found = check(&reliable_reader, &best_effort);
        assert!(
            matches!(&found[..], [Mismatch::IncompatibleQos { policy, .. }] if policy == "reliability"),
            "{found:?}"
        );
    }
}
