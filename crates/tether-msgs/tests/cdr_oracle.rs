//! tether's CDR of `geometry_msgs/msg/TwistStamped`, `tf2_msgs/msg/TFMessage`,
//! `visualization_msgs/msg/MarkerArray`, `rosgraph_msgs/msg/Clock`,
//! `vision_msgs/msg/Detection2DArray` and `geometry_msgs/msg/PoseStamped` (what `tether
//! ros2` publishes on `cmd_vel`, `tether/markers`, `tether/target_pose` and `/tf`, reads
//! from `/tf_static`, `/clock` and `detections`) against Python
//! `rosbags`' serializer, byte for byte (`tests/cdr_oracle.py` builds the same
//! messages). Skips, printing why, without `rosbags`, unless `TETHER_REQUIRE_SHARED=1`.

#![allow(clippy::unwrap_used, reason = "tests fail loudly")]

use std::process::Command;

use tether_core::Stamp;
use tether_msgs::{
    ClockMsg, Detection2DArrayMsg, Detection2DMsg, Header, MarkerArrayMsg, MarkerMsg, MeshFile,
    ObjectHypothesisMsg, Pose3, PoseStampedMsg, TfMessage, TransformStampedMsg, TwistMsg,
    TwistStampedMsg, from_cdr, to_cdr,
};

fn rosbags_payloads() -> Option<Vec<Vec<u8>>> {
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/cdr_oracle.py");
    let out = Command::new("python3").arg(script).output().ok()?;
    if !out.status.success() {
        let reason = format!(
            "python3 with `rosbags` is not available (python3 -m pip install rosbags): {}",
            String::from_utf8_lossy(&out.stderr)
        );
        tether_testkit::skip(&reason);
        return None;
    }
    let text = String::from_utf8(out.stdout).unwrap();
    Some(
        text.lines()
            .map(|hex| {
                (0..hex.len())
                    .step_by(2)
                    .map(|i| u8::from_str_radix(&hex[i..i + 2], 16).unwrap())
                    .collect()
            })
            .collect(),
    )
}

fn transform(
    parent: &str,
    sec_ns: i64,
    child: &str,
    t: [f64; 3],
    q: [f64; 4],
) -> TransformStampedMsg {
    TransformStampedMsg {
        header: Header::new(Stamp::from_ns(sec_ns), parent),
        child_frame_id: child.into(),
        transform: Pose3 {
            position_m: t,
            orientation: q,
        },
    }
}

/// The markers `cdr_oracle.py` builds.
fn marker(
    ns: &str,
    id: i32,
    marker_type: i32,
    points: &[[f64; 3]],
    text: &str,
    uv: &[[f32; 2]],
    mesh: &str,
) -> MarkerMsg {
    let mut m = MarkerMsg::new(
        Header::new(Stamp::from_ns(7_250_000_000), "odom"),
        ns,
        id,
        marker_type,
    );
    m.pose = Pose3 {
        position_m: [1.5, -0.5, 0.9],
        orientation: [0.0, 0.0, 0.25, 0.968_245_836_551_854_3],
    };
    m.scale = [0.3, 0.2, 1.7];
    m.color = [0.25, 0.5, 1.0, 0.75];
    m.lifetime_ns = 500_000_000;
    m.points = points.to_vec();
    m.colors = vec![[1.0, 0.0, 0.0, 1.0]; points.len()];
    m.uv_coordinates = uv.to_vec();
    m.text = text.into();
    if !mesh.is_empty() {
        m.mesh_file = MeshFile {
            filename: mesh.into(),
            data: vec![1, 2, 3],
        };
        m.mesh_use_embedded_materials = true;
    }
    m
}

#[test]
fn published_and_subscribed_messages_are_rosbags_cdr_byte_for_byte() {
    let Some(expected) = rosbags_payloads() else {
        return;
    };
    let twist = TwistStampedMsg {
        header: Header::new(Stamp::from_ns(1_700_000_000_500_000_000), "base_link"),
        twist: TwistMsg::unicycle(0.25, -0.5),
    };
    let tf = TfMessage {
        transforms: vec![
            transform(
                "base_link",
                12_000_000_034,
                "laser",
                [0.1, -0.02, 0.3],
                [0.0, 0.0, 0.25, 0.968_245_836_551_854_3],
            ),
            transform(
                "odom",
                0,
                "base_link_with_a_longer_name",
                [3.0, 1.0, 0.0],
                [0.0, 0.0, 0.0, 1.0],
            ),
        ],
    };
    let markers = MarkerArrayMsg {
        markers: vec![
            marker("tracks", 3, MarkerMsg::CYLINDER, &[], "", &[], ""),
            marker(
                "laser",
                0,
                MarkerMsg::SPHERE_LIST,
                &[[1.0, 2.0, 0.0], [3.0, -1.0, 0.5]],
                "#3",
                &[[0.5, 0.25]],
                "m.stl",
            ),
        ],
    };
    let clock = ClockMsg {
        clock: Stamp::from_ns(42_000_000_007),
    };
    let camera = Header::new(Stamp::from_ns(7_250_000_000), "camera");
    let b = tether_core::PixelBox {
        x: 100.0,
        y: 40.5,
        w: 80.0,
        h: 96.0,
    };
    let mut first = Detection2DMsg::from_box(
        camera.clone(),
        &b,
        ObjectHypothesisMsg::class("person", 0.9),
        "3",
    );
    first
        .results
        .push(ObjectHypothesisMsg::class("chair", 0.125));
    let second = Detection2DMsg {
        results: Vec::new(),
        theta_rad: 0.5,
        id: String::new(),
        ..first.clone()
    };
    let detections = Detection2DArrayMsg {
        header: camera,
        detections: vec![first, second],
    };
    let target_pose = PoseStampedMsg {
        header: Header::new(Stamp::from_ns(1_700_000_001_250_000_000), "odom"),
        pose: Pose3 {
            position_m: [4.5, -1.25, 0.0],
            orientation: [0.0, 0.0, -0.25, 0.968_245_836_551_854_3],
        },
    };
    let ours = [
        to_cdr(&twist).unwrap(),
        to_cdr(&tf).unwrap(),
        to_cdr(&TfMessage::default()).unwrap(),
        to_cdr(&markers).unwrap(),
        to_cdr(&clock).unwrap(),
        to_cdr(&detections).unwrap(),
        to_cdr(&target_pose).unwrap(),
    ];
    assert_eq!(expected.len(), ours.len());
    for (i, (theirs, ours)) in expected.iter().zip(&ours).enumerate() {
        assert_eq!(theirs, ours, "message {i}");
    }
    // And rosbags' bytes read back as the messages.
    assert_eq!(from_cdr::<TwistStampedMsg>(&expected[0]).unwrap(), twist);
    assert_eq!(from_cdr::<TfMessage>(&expected[1]).unwrap(), tf);
    assert_eq!(from_cdr::<MarkerArrayMsg>(&expected[3]).unwrap(), markers);
    assert_eq!(from_cdr::<ClockMsg>(&expected[4]).unwrap(), clock);
    assert_eq!(
        from_cdr::<Detection2DArrayMsg>(&expected[5]).unwrap(),
        detections
    );
    assert_eq!(
        from_cdr::<PoseStampedMsg>(&expected[6]).unwrap(),
        target_pose
    );
    assert!(
        from_cdr::<TfMessage>(&expected[2])
            .unwrap()
            .transforms
            .is_empty()
    );
}
