//! The static part of the transform tree (`/tf_static`): where each sensor sits on the
//! robot, as the robot's description publishes it (REP 105: `base_link` -> sensors).
//!
//! Transforms compose along the chain from a frame up to one of its ancestors:
//! `parent_from_grandchild = parent_from_child * child_from_grandchild`, that is
//! `t = t_pc + R_pc t_cg` and `q = q_pc q_cg` (Hamilton product).

use std::collections::BTreeMap;

use tether_msgs::{Pose3, TfMessage};

/// `a * b` for quaternions `[x, y, z, w]`.
fn quat_mul(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    let [ax, ay, az, aw] = a;
    let [bx, by, bz, bw] = b;
    [
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    ]
}

/// `v` rotated by the unit quaternion `q` (`q v q*`): a child frame's axis `v` in its
/// parent's axes, for the child's orientation `q`.
pub fn rotate(q: [f64; 4], v: [f64; 3]) -> [f64; 3] {
    let r = quat_mul(
        quat_mul(q, [v[0], v[1], v[2], 0.0]),
        [-q[0], -q[1], -q[2], q[3]],
    );
    [r[0], r[1], r[2]]
}

/// `parent_from_child * child_from_grandchild`.
pub fn compose(parent_from_child: &Pose3, child_from_grandchild: &Pose3) -> Pose3 {
    let t = rotate(
        parent_from_child.orientation,
        child_from_grandchild.position_m,
    );
    let p = parent_from_child.position_m;
    Pose3 {
        position_m: [p[0] + t[0], p[1] + t[1], p[2] + t[2]],
        orientation: quat_mul(
            parent_from_child.orientation,
            child_from_grandchild.orientation,
        ),
    }
}

/// The static transforms heard so far: each frame's parent and where it sits in it.
#[derive(Debug, Clone, Default)]
pub struct StaticTransforms {
    parent_of: BTreeMap<String, (String, Pose3)>,
}

/// Frame names without a leading `/` (tf2 refuses them; older publishers still send
/// them).
fn frame(name: &str) -> &str {
    name.trim_start_matches('/')
}

impl StaticTransforms {
    /// Takes in a `/tf_static` message; a transform with a non-finite or non-unit
    /// rotation is skipped and counted in the return value.
    pub fn insert(&mut self, msg: &TfMessage) -> usize {
        let mut skipped = 0;
        for t in &msg.transforms {
            let q = t.transform.orientation;
            let norm = q.iter().map(|c| c * c).sum::<f64>().sqrt();
            let finite = t.transform.position_m.iter().all(|c| c.is_finite());
            if !(finite && (norm - 1.0).abs() < 1e-3) || t.child_frame_id.is_empty() {
                skipped += 1;
                continue;
            }
            let mut pose = t.transform;
            pose.orientation = q.map(|c| c / norm);
            self.parent_of.insert(
                frame(&t.child_frame_id).to_owned(),
                (frame(&t.header.frame_id).to_owned(), pose),
            );
        }
        skipped
    }

    /// Where `child` sits in `ancestor` (`ancestor_from_child`), when `ancestor` is on
    /// the chain of parents above `child`.
    pub fn lookup(&self, ancestor: &str, child: &str) -> Option<Pose3> {
        let (ancestor, mut at) = (frame(ancestor), frame(child));
        let mut pose = Pose3::planar(0.0, 0.0, 0.0);
        // A chain longer than the tree has frames is a loop.
        for _ in 0..=self.parent_of.len() {
            if at == ancestor {
                return Some(pose);
            }
            let (parent, parent_from_at) = self.parent_of.get(at)?;
            pose = compose(parent_from_at, &pose);
            at = parent;
        }
        None
    }

    /// The frames heard of, for messages.
    pub fn frames(&self) -> Vec<String> {
        let mut names: Vec<String> = self.parent_of.keys().cloned().collect();
        for (parent, _) in self.parent_of.values() {
            if !names.contains(parent) {
                names.push(parent.clone());
            }
        }
        names
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, reason = "tests fail loudly")]

    use tether_core::Stamp;
    use tether_msgs::{Header, TransformStampedMsg};

    use super::*;

    fn tf(parent: &str, child: &str, pose: Pose3) -> TransformStampedMsg {
        TransformStampedMsg {
            header: Header::new(Stamp::ZERO, parent),
            child_frame_id: child.into(),
            transform: pose,
        }
    }

    #[test]
    fn a_chain_composes_to_the_mount_on_the_base() {
        let mut tree = StaticTransforms::default();
        let mut lifted = Pose3::planar(0.0, 0.0, 0.0);
        lifted.position_m[2] = 0.1;
        let mut laser = Pose3::planar(0.2, 0.0, std::f64::consts::FRAC_PI_2);
        laser.position_m[2] = 0.2;
        let msg = TfMessage {
            transforms: vec![
                tf("base_footprint", "base_link", lifted),
                tf("/base_link", "laser", laser),
            ],
        };
        assert_eq!(tree.insert(&msg), 0);
        let m = tree.lookup("base_footprint", "laser").unwrap();
        assert!((m.position_m[0] - 0.2).abs() < 1e-12);
        assert!((m.position_m[2] - 0.3).abs() < 1e-12);
        assert!((m.yaw_rad() - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        // A turned parent turns the child's offset.
        let turned = TfMessage {
            transforms: vec![
                tf(
                    "base",
                    "mast",
                    Pose3::planar(0.0, 0.0, std::f64::consts::PI),
                ),
                tf("mast", "cam", Pose3::planar(1.0, 0.0, 0.0)),
            ],
        };
        tree.insert(&turned);
        let c = tree.lookup("base", "cam").unwrap();
        assert!((c.position_m[0] + 1.0).abs() < 1e-12 && c.position_m[1].abs() < 1e-12);
        assert!(
            tree.lookup("laser", "base_footprint").is_none(),
            "only up the chain"
        );
        assert!(tree.lookup("base_link", "nowhere").is_none());
    }

    #[test]
    fn bad_rotations_and_loops_do_not_get_in() {
        let mut tree = StaticTransforms::default();
        let mut bad = Pose3::planar(0.0, 0.0, 0.0);
        bad.orientation = [0.0, 0.0, 0.0, 0.0];
        let msg = TfMessage {
            transforms: vec![
                tf("base_link", "laser", bad),
                tf("a", "b", Pose3::planar(1.0, 0.0, 0.0)),
                tf("b", "a", Pose3::planar(1.0, 0.0, 0.0)),
            ],
        };
        assert_eq!(tree.insert(&msg), 1);
        assert!(tree.lookup("base_link", "laser").is_none());
        assert!(tree.lookup("c", "a").is_none(), "a loop ends");
    }
}
