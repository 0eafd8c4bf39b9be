//! A ROS 2 node on DDS: the participant, its spinner (graph discovery, parameter
//! services), and typed publishers and subscriptions of tether's messages.
//!
//! The transport sits behind [`RosNode`]'s small surface (`subscribe`, `publisher`), so
//! another middleware (Zenoh) can be put in its place without touching the callers.

use std::sync::mpsc::{Receiver, SyncSender, TrySendError};
use std::thread::JoinHandle;

use futures::FutureExt;
use ros2_client::dds::{Context, ContextOptions, Node, Publisher, Subscription};
use ros2_client::qos::{Durability, History, WhenFull};
use ros2_client::{Name, NodeName, NodeOptions, QosProfile};
use tether_msgs::Ros2Message;

use crate::graph;
use crate::wire::{Wire, type_name};

/// Quality of service as ROS 2's profiles name it (design 12).
pub mod qos {
    use super::*;

    /// `rclcpp::SensorDataQoS`: best effort, volatile, keep last 5. It matches reliable
    /// and best-effort publishers alike.
    pub fn sensor_data() -> QosProfile {
        QosProfile::subscription_default().history(History::KeepLast { depth: 5 })
    }

    /// `rclcpp::ClockQoS` for `/clock`: best effort, volatile, keep last 1 (only the
    /// newest time matters). It matches reliable and best-effort publishers alike.
    pub fn clock() -> QosProfile {
        QosProfile::subscription_default().history(History::KeepLast { depth: 1 })
    }

    /// Reliable, volatile, keep last `depth` (`/cmd_vel`: 10; `/tf`: 100).
    pub fn reliable(depth: usize) -> QosProfile {
        QosProfile::publisher_default()
            .reliability_reliable(WhenFull::DEFAULT)
            .history(History::KeepLast { depth })
    }

    /// `/tf_static`: reliable and transient local, so a late joiner gets the mounts.
    pub fn latched(depth: usize) -> QosProfile {
        reliable(depth).durability(Durability::TransientLocal)
    }
}

/// Who the node is on the graph.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NodeIdentity {
    /// The node's name (`tether` unless `__node:=` says otherwise).
    pub name: String,
    /// Its namespace, absolute (`/` by default).
    pub namespace: String,
    /// The DDS domain (`ROS_DOMAIN_ID`, 0 by default).
    pub domain_id: u16,
}

/// What can go wrong on the graph.
#[derive(Debug, thiserror::Error)]
pub enum Ros2Error {
    /// The DDS participant or the node could not be made.
    #[error("cannot join ROS 2 domain {domain}: {message}")]
    Join {
        /// The domain.
        domain: u16,
        /// The middleware's reason.
        message: String,
    },
    /// A node name or namespace that ROS 2 refuses.
    #[error("node name {name:?} in namespace {namespace:?}: {message}")]
    Name {
        /// The name.
        name: String,
        /// The namespace.
        namespace: String,
        /// Why not.
        message: String,
    },
    /// A topic that cannot be made (a bad name, a type clash).
    #[error("topic {topic} ({kind}): {message}")]
    Topic {
        /// The topic's full name.
        topic: String,
        /// The ROS 2 type.
        kind: &'static str,
        /// The middleware's reason.
        message: String,
    },
}

/// A node on the graph, with its spinner on a thread of its own.
pub struct RosNode {
    identity: NodeIdentity,
    node: Node,
    spinner: Option<JoinHandle<()>>,
    /// This node's topics, to compare with the graph's ([`RosNode::graph_mismatches`]).
    endpoints: Vec<graph::Endpoint>,
    // Dropped last: the participant says goodbye to its peers when it goes.
    _context: Context,
}

impl RosNode {
    /// Joins the domain as `identity`.
    pub fn start(identity: NodeIdentity) -> Result<RosNode, Ros2Error> {
        let join = |e: &dyn std::fmt::Display| Ros2Error::Join {
            domain: identity.domain_id,
            message: e.to_string(),
        };
        // RustDDS announces the IPv4 addresses it finds when the participant is made,
        // once: with none (a network namespace whose loopback is still down, a robot
        // booting before its network) the node would be on no graph for its whole life.
        if !has_ipv4_address(&netdev::get_interfaces()) {
            return Err(join(
                &"no network interface has an IPv4 address, so DDS would announce none and \
                  no peer could reach this node; bring one up first (at least the loopback: \
                  `ip link set lo up`)",
            ));
        }
        let context = Context::with_options(ContextOptions::new().domain_id(identity.domain_id))
            .map_err(|e| join(&e))?;
        let name =
            NodeName::new(&identity.namespace, &identity.name).map_err(|e| Ros2Error::Name {
                name: identity.name.clone(),
                namespace: identity.namespace.clone(),
                message: format!("{e:?}"),
            })?;
        let mut node = context
            .new_node(name, NodeOptions::new().enable_rosout(false))
            .map_err(|e| join(&format!("{e:?}")))?;
        let spinner = node.spinner().map_err(|e| join(&e))?;
        let spinner = std::thread::Builder::new()
            .name("ros2-spinner".into())
            .spawn(move || {
                if let Err(e) = futures::executor::block_on(spinner.spin()) {
                    tracing::warn!("the ROS 2 node's spinner stopped: {e}");
                }
            })
            .map_err(|e| join(&e))?;
        Ok(RosNode {
            identity,
            node,
            spinner: Some(spinner),
            endpoints: Vec::new(),
            _context: context,
        })
    }

    /// Who the node is.
    pub fn identity(&self) -> &NodeIdentity {
        &self.identity
    }

    fn topic<M: Ros2Message>(
        &mut self,
        full_name: &str,
        qos: &QosProfile,
    ) -> Result<ros2_client::dds::rustdds::Topic, Ros2Error> {
        let error = |message: String| Ros2Error::Topic {
            topic: full_name.to_owned(),
            kind: M::TYPE,
            message,
        };
        let name = Name::parse(full_name).map_err(|e| error(format!("{e:?}")))?;
        self.node
            .create_topic(&name, type_name::<M>(), qos)
            .map_err(|e| error(e.to_string()))
    }

    /// Subscribes to `full_name` (absolute, remapped) carrying `M`.
    pub fn subscribe<M: Ros2Message + 'static>(
        &mut self,
        full_name: &str,
        qos: QosProfile,
    ) -> Result<Subscription<Wire<M>>, Ros2Error> {
        let topic = self.topic::<M>(full_name, &qos)?;
        self.remember::<M>(full_name, &qos, graph::Direction::Subscription);
        self.node
            .create_subscription(&topic, Some(qos))
            .map_err(|e| Ros2Error::Topic {
                topic: full_name.to_owned(),
                kind: M::TYPE,
                message: e.to_string(),
            })
    }

    /// A publisher of `M` on `full_name`.
    pub fn publisher<M: Ros2Message>(
        &mut self,
        full_name: &str,
        qos: QosProfile,
    ) -> Result<Publisher<Wire<M>>, Ros2Error> {
        let topic = self.topic::<M>(full_name, &qos)?;
        self.remember::<M>(full_name, &qos, graph::Direction::Publication);
        self.node
            .create_publisher(&topic, Some(qos))
            .map_err(|e| Ros2Error::Topic {
                topic: full_name.to_owned(),
                kind: M::TYPE,
                message: e.to_string(),
            })
    }

    fn remember<M: Ros2Message>(
        &mut self,
        full_name: &str,
        qos: &QosProfile,
        direction: graph::Direction,
    ) {
        self.endpoints.push(graph::Endpoint {
            topic: full_name.to_owned(),
            type_name: M::TYPE.to_owned(),
            qos: qos.into(),
            direction,
        });
    }

    /// A watcher of the graph against this node's topics as they are now; it can go to
    /// another thread.
    pub fn graph_watcher(&self) -> GraphWatcher {
        GraphWatcher {
            participant: self._context.domain_participant(),
            ours: self.endpoints.clone(),
        }
    }

    /// How many subscriptions on the graph match `full_name`.
    pub fn subscription_count(&self, full_name: &str) -> usize {
        self.node.subscription_count(full_name)
    }
}

impl Drop for RosNode {
    fn drop(&mut self) {
        self.node.stop_spinner();
        if let Some(spinner) = self.spinner.take() {
            let started = std::time::Instant::now();
            while !spinner.is_finished() && started.elapsed() < std::time::Duration::from_secs(1) {
                std::thread::sleep(std::time::Duration::from_millis(5));
            }
            if spinner.is_finished() {
                let _ = spinner.join();
            }
        }
    }
}

/// Whether any interface that is up has an IPv4 address (RustDDS's unicast transport is
/// IPv4 only).
fn has_ipv4_address(interfaces: &[netdev::Interface]) -> bool {
    interfaces.iter().any(|i| i.is_up() && !i.ipv4.is_empty())
}

/// Compares a node's topics with what discovery has found on the graph.
pub struct GraphWatcher {
    participant: ros2_client::dds::rustdds::DomainParticipant,
    ours: Vec<graph::Endpoint>,
}

impl GraphWatcher {
    /// What does not fit between the node's topics and the publishers and subscribers
    /// discovered so far on the same topics (other types, QoS that DDS will not match).
    pub fn mismatches(&self) -> Vec<graph::Mismatch> {
        use ros2_client::dds::rustdds::RTPSEntity;
        let own = self.participant.guid().prefix;
        let mut theirs = Vec::new();
        for w in self.participant.discovered_writers() {
            if w.writer_proxy.remote_writer_guid.prefix == own {
                continue;
            }
            let t = &w.publication_topic_data;
            theirs.extend(graph::Endpoint::from_dds(
                &t.topic_name,
                &t.type_name,
                t.qos(),
                graph::Direction::Publication,
            ));
        }
        for r in self.participant.discovered_readers() {
            if r.reader_proxy.remote_reader_guid.prefix == own {
                continue;
            }
            let t = &r.subscription_topic_data;
            // ros2-client nodes read `/clock` as a bare `builtin_interfaces/Time`: a
            // quirk of theirs, not a subscriber tether could serve.
            if t.topic_name() == "rt/clock" && t.type_name().contains("builtin_interfaces") {
                continue;
            }
            theirs.extend(graph::Endpoint::from_dds(
                t.topic_name(),
                t.type_name(),
                t.qos(),
                graph::Direction::Subscription,
            ));
        }
        graph::check(&self.ours, &theirs)
    }
}

/// What a subscription thread met.
#[derive(Debug)]
pub enum Received<M> {
    /// A message, with the time it arrived (ns since the UNIX epoch).
    Message {
        /// The message.
        message: M,
        /// Arrival, host system time, ns.
        arrived_unix_ns: i64,
    },
    /// A sample that could not be decoded (malformed CDR, a bad header): skipped.
    Malformed(String),
}

fn unix_now_ns() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| i64::try_from(d.as_nanos()).unwrap_or(i64::MAX))
}

/// Takes the messages of `subscription` on a thread of its own and hands each to
/// `deliver` (which returns `false` to stop), until `stop` fires or `deliver` refuses.
pub fn spawn_reader<M, F>(
    name: &str,
    subscription: Subscription<Wire<M>>,
    stop: Receiver<()>,
    mut deliver: F,
) -> std::io::Result<JoinHandle<()>>
where
    M: Ros2Message + Send + 'static,
    F: FnMut(Received<M>) -> bool + Send + 'static,
{
    std::thread::Builder::new()
        .name(name.to_owned())
        .spawn(move || {
            let (wake_tx, wake_rx) = futures::channel::oneshot::channel::<()>();
            // The std receiver's stop becomes a future the take can race with.
            let watcher = std::thread::spawn(move || {
                let _ = stop.recv();
                let _ = wake_tx.send(());
            });
            let mut wake = wake_rx.fuse();
            loop {
                let taken = futures::executor::block_on(async {
                    futures::select! {
                        taken = subscription.async_take().fuse() => Some(taken),
                        _ = wake => None,
                    }
                });
                let received = match taken {
                    None => break,
                    Some(Ok((Wire(message), _info))) => Received::Message {
                        message,
                        arrived_unix_ns: unix_now_ns(),
                    },
                    Some(Err(e)) => Received::Malformed(e.to_string()),
                };
                if !deliver(received) {
                    break;
                }
            }
            drop(watcher);
        })
}

/// Hands `item` to a bounded queue without blocking: a full queue drops it (the
/// caller counts that) rather than let a flood stall DDS. `false` when the queue's
/// reader is gone.
pub fn offer<T>(queue: &SyncSender<T>, item: T, dropped: &mut u64) -> bool {
    match queue.try_send(item) {
        Ok(()) => true,
        Err(TrySendError::Full(_)) => {
            *dropped += 1;
            true
        }
        Err(TrySendError::Disconnected(_)) => false,
    }
}
