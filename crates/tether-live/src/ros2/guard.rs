//! The `cmd_vel` guard (design 12, 13): a small process beside `tether ros2`, with a DDS
//! participant and a `cmd_vel` publisher of its own, that stops the robot when the node
//! stops talking.
//!
//! A base controller keeps its last `cmd_vel` until its own timeout, if it has one.
//! `tether ros2` publishes a stop on every exit it lives through, but not when it is
//! killed (`kill -KILL`, the OOM killer) or frozen (`kill -STOP`, a hung loop). The
//! guard covers those, as `tether run`'s base guard does for a serial base
//! ([`crate::guard`]):
//!
//! - `tether ros2` starts it (`tether cmd-vel-guard`, in a process group of its own)
//!   after joining the graph; the guard joins it too, as the node `<name>_guard` in the
//!   same namespace and domain, opens a publisher on the node's resolved `cmd_vel`
//!   (`Twist`, or `TwistStamped` in the base's frame, as the node publishes), and says
//!   `ready`.
//! - The node passes it every command line (the JSON of [`crate::base::CommandLine`],
//!   through a bounded queue that never holds up the loop).
//! - When the pipe closes (the node exited or was killed) the guard publishes
//!   [`ZERO_REPEATS`] zero commands [`ZERO_SPACING`] apart, waits [`LINGER`] for a
//!   reliable reader's resends, and exits; when no line comes for
//!   [`DEFAULT_SILENCE`] (the node is frozen) it publishes them too and keeps watching,
//!   so a node that recovers drives again. Repeating the zero reaches a best-effort
//!   subscriber that lost one. Before the node's first command the guard stops nothing:
//!   there is no motion of tether's to stop.
//!
//! Not started when the node publishes no `cmd_vel` (`-p publish_cmd_vel:=false`) or
//! with `-p cmd_vel_guard:=false`.

use std::io::{self, BufRead, Write};
use std::time::Duration;

use tether_msgs::{Header, TwistMsg, TwistStampedMsg};
use tether_ros2::{NodeIdentity, Ros2Error, RosNode, Wire, qos};

use crate::guard::{GuardReport, StopCause, watch_heartbeats};

/// The silence after which the guard stops the robot: five periods of the 20 Hz loop,
/// so that its stop reaches `cmd_vel` within half a second of a freeze.
pub const DEFAULT_SILENCE: Duration = Duration::from_millis(250);

/// Zero commands the guard publishes at each stop.
pub const ZERO_REPEATS: u32 = 5;

/// Time between two of the guard's zero commands.
pub const ZERO_SPACING: Duration = Duration::from_millis(40);

/// How long the guard stays on the graph after its last zero, so that a reliable
/// reader that missed one gets it resent.
pub const LINGER: Duration = Duration::from_millis(300);

/// Where the guard publishes and how long a silence it allows.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CmdVelGuardSpec {
    /// The guard's node: `<name>_guard` in the node's namespace and domain.
    pub identity: NodeIdentity,
    /// The node's resolved `cmd_vel` topic (absolute).
    pub topic: String,
    /// `Some(base_frame)`: zero `TwistStamped` commands in that frame; `None`: `Twist`.
    pub stamped_frame: Option<String>,
    /// Longest time without a command line before the guard stops the robot.
    pub silence: Duration,
}

impl CmdVelGuardSpec {
    /// The guard of the node `node` publishing on `topic`: named `<name>_guard`, beside
    /// it, with the [`DEFAULT_SILENCE`].
    pub fn beside(node: &NodeIdentity, topic: &str, stamped_frame: Option<String>) -> Self {
        CmdVelGuardSpec {
            identity: NodeIdentity {
                name: format!("{}_guard", node.name),
                ..node.clone()
            },
            topic: topic.to_owned(),
            stamped_frame,
            silence: DEFAULT_SILENCE,
        }
    }

    /// The arguments of `tether cmd-vel-guard` for this spec.
    pub fn args(&self) -> Vec<String> {
        let mut args = vec![
            "cmd-vel-guard".to_owned(),
            "--topic".to_owned(),
            self.topic.clone(),
            "--node".to_owned(),
            self.identity.name.clone(),
            "--namespace".to_owned(),
            self.identity.namespace.clone(),
            "--domain".to_owned(),
            self.identity.domain_id.to_string(),
            "--silence-ms".to_owned(),
            self.silence.as_millis().to_string(),
        ];
        if let Some(frame) = &self.stamped_frame {
            args.extend(["--stamped-frame".to_owned(), frame.clone()]);
        }
        args
    }
}

/// Why the guard could not watch.
#[derive(Debug, thiserror::Error)]
pub enum CmdVelGuardError {
    /// Joining the graph or opening the publisher failed.
    #[error(transparent)]
    Ros2(#[from] Ros2Error),
    /// The pipes failed, or a zero could not be published.
    #[error(transparent)]
    Io(#[from] io::Error),
}

/// The guard's publisher.
enum ZeroPublisher {
    Plain(ros2_client::dds::Publisher<Wire<TwistMsg>>),
    Stamped {
        publisher: ros2_client::dds::Publisher<Wire<TwistStampedMsg>>,
        frame: String,
    },
}

impl ZeroPublisher {
    /// One zero command, stamped `stamp_ns` on tether's clock when stamped.
    fn zero(&self, stamp_ns: i64) -> io::Result<()> {
        let zero = TwistMsg::unicycle(0.0, 0.0);
        let failed =
            |e: &dyn std::fmt::Debug| io::Error::other(format!("publishing a zero command: {e:?}"));
        match self {
            ZeroPublisher::Plain(p) => p.publish(Wire(zero)).map_err(|e| failed(&e)),
            ZeroPublisher::Stamped { publisher, frame } => publisher
                .publish(Wire(TwistStampedMsg {
                    header: Header::new(tether_core::Stamp::from_ns(stamp_ns), frame.as_str()),
                    twist: zero,
                }))
                .map_err(|e| failed(&e)),
        }
    }
}

/// The guard's watch (the `tether cmd-vel-guard` process): joins the graph, opens the
/// publisher, writes `ready` to `ready`, then reads command lines from `heartbeats`
/// until the pipe closes, publishing zero commands after each silence and at the end.
pub fn watch_cmd_vel<R: BufRead + Send + 'static>(
    spec: &CmdVelGuardSpec,
    heartbeats: R,
    ready: &mut dyn Write,
) -> Result<GuardReport, CmdVelGuardError> {
    let mut node = RosNode::start(spec.identity.clone())?;
    let publisher = match &spec.stamped_frame {
        None => ZeroPublisher::Plain(node.publisher::<TwistMsg>(&spec.topic, qos::reliable(10))?),
        Some(frame) => ZeroPublisher::Stamped {
            publisher: node.publisher::<TwistStampedMsg>(&spec.topic, qos::reliable(10))?,
            frame: frame.clone(),
        },
    };
    writeln!(ready, "ready")?;
    ready.flush()?;
    let report = watch_heartbeats(heartbeats, spec.silence, &mut |why, stamp_ns, report| {
        if report.heartbeats == 0 {
            return Ok(());
        }
        let started = std::time::Instant::now();
        for i in 0..ZERO_REPEATS {
            if i > 0 {
                std::thread::sleep(ZERO_SPACING);
            }
            let elapsed_ns = i64::try_from(started.elapsed().as_nanos()).unwrap_or(i64::MAX);
            publisher.zero(stamp_ns.saturating_add(elapsed_ns))?;
        }
        match why {
            StopCause::Silence => eprintln!(
                "cmd_vel guard: no command from tether ros2 for {} ms: zero commands \
                 published on {}",
                spec.silence.as_millis(),
                spec.topic
            ),
            StopCause::Gone if !report.orderly => eprintln!(
                "cmd_vel guard: tether ros2 ended without its final stop (killed?) after {} \
                 commands: zero commands published on {}",
                report.heartbeats, spec.topic
            ),
            StopCause::Gone => {}
        }
        Ok(())
    })?;
    std::thread::sleep(LINGER);
    drop(publisher);
    drop(node);
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_guard_is_a_node_beside_tether_s_on_its_topic() {
        let node = NodeIdentity {
            name: "follower".into(),
            namespace: "/robot1".into(),
            domain_id: 7,
        };
        let spec = CmdVelGuardSpec::beside(&node, "/robot1/cmd_vel", Some("base_link".into()));
        assert_eq!(spec.identity.name, "follower_guard");
        assert_eq!(spec.identity.namespace, "/robot1");
        assert_eq!(spec.identity.domain_id, 7);
        assert_eq!(
            spec.args().join(" "),
            "cmd-vel-guard --topic /robot1/cmd_vel --node follower_guard --namespace /robot1 \
             --domain 7 --silence-ms 250 --stamped-frame base_link"
        );
    }
}
