use super::*;
use tether_core::{Gaussian2, Pose2, Robot, World};

fn scan() -> LaserScan {
    LaserScan::new(
        Stamp::from_ns(1_700_000_000_250_000_000),
        "laser",
        -2.0862,
        0.006_135_923,
        0.02,
        5.6,
        vec![1.0, f32::INFINITY, 2.5, 0.001],
    )
    .unwrap()
}

#[test]
fn laser_scan_layout_is_cdr() {
    let msg = LaserScanMsg::new(scan(), 1e-4, 0.1);
    let bytes = to_cdr(&msg).unwrap();
    // header(4) + stamp(8) + frame "laser\0" with length (4 + 6), pad to 4 (2),
    // seven f32 (28), ranges (4 + 16), intensities (4).
    assert_eq!(bytes.len(), 4 + 8 + 10 + 2 + 28 + 20 + 4);
    assert_eq!(&bytes[..4], &[0, 1, 0, 0]);
    let back: LaserScanMsg = from_cdr(&bytes).unwrap();
    assert_eq!(back.scan.stamp, msg.scan.stamp);
    assert_eq!(back.scan.ranges_m(), msg.scan.ranges_m());
    assert_eq!(back.scan.len(), 4);
    for cut in 0..bytes.len() {
        assert!(
            from_cdr::<RawLaserScan>(&bytes[..cut]).is_err(),
            "cut {cut}"
        );
    }
}

#[test]
fn definitions_name_every_dependency_once() {
    for def in [
        LaserScanMsg::DEFINITION,
        ImageMsg::DEFINITION,
        CompressedImageMsg::DEFINITION,
        TwistMsg::DEFINITION,
        TwistStampedMsg::DEFINITION,
        TfMessage::DEFINITION,
        PoseArrayMsg::DEFINITION,
        PoseWithCovarianceStampedMsg::DEFINITION,
        OdometryMsg::DEFINITION,
    ] {
        let mut names: Vec<&str> = def
            .lines()
            .filter_map(|l| l.strip_prefix("MSG: "))
            .collect();
        let n = names.len();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), n, "{def}");
    }
    assert!(LaserScanMsg::DEFINITION.contains("MSG: std_msgs/Header\n"));
    assert!(LaserScanMsg::DEFINITION.contains("MSG: builtin_interfaces/Time\nint32 sec\n"));
    assert_eq!(OdometryMsg::DEFINITION.matches("MSG: ").count(), 9);
}

#[test]
fn images_convert_to_grey() {
    let header = Header::new(Stamp::ZERO, "camera");
    let rgb = ImageMsg::packed(
        header.clone(),
        PixelEncoding::Rgb8,
        2,
        1,
        vec![255, 0, 0, 10, 200, 30],
    )
    .unwrap();
    let g = rgb.to_gray().unwrap();
    // (4899 * 255 + 8192) >> 14 = 76; (4899*10 + 9617*200 + 1868*30 + 8192) >> 14 = 124.
    assert_eq!(g.pixels(), &[76, 124]);
    let mut bgr = rgb.clone();
    bgr.encoding = "bgr8".into();
    // (1868 * 255 + 8192) >> 14 = 29; (4899*30 + 9617*200 + 1868*10 + 8192) >> 14 = 128.
    assert_eq!(bgr.to_gray().unwrap().pixels(), &[29, 128]);
    let mono = ImageMsg::from_gray(header.clone(), &g);
    assert_eq!(mono.to_gray().unwrap(), g);
    let back: ImageMsg = from_cdr(&to_cdr(&rgb).unwrap()).unwrap();
    assert_eq!(back, rgb);
    let mut bad = rgb.clone();
    bad.step = 5;
    assert!(matches!(bad.to_gray(), Err(ImageMsgError::Layout { .. })));
    bad.encoding = "yuv422".into();
    assert!(matches!(bad.to_gray(), Err(ImageMsgError::Encoding(_))));
    // A padded row (step > width * channels) skips the padding.
    let padded = ImageMsg {
        step: 3,
        data: vec![1, 2, 99, 3, 4, 99],
        height: 2,
        width: 2,
        encoding: "mono8".into(),
        is_bigendian: 0,
        header,
    };
    assert_eq!(padded.to_gray().unwrap().pixels(), &[1, 2, 3, 4]);
}

#[test]
fn poses_and_covariances_round_trip() {
    let g = Gaussian2::<World>::new(Point2::new(1.5, -2.0), Cov2::new(0.04, 0.01, 0.09).unwrap())
        .unwrap();
    let msg = PoseWithCovarianceStampedMsg::from_gaussian(
        Header::new(Stamp::from_ns(5), "world"),
        &g,
        0.5,
        0.1,
    );
    let back: PoseWithCovarianceStampedMsg = from_cdr(&to_cdr(&msg).unwrap()).unwrap();
    assert_eq!(back, msg);
    assert_eq!(back.gaussian::<World>().unwrap(), g);
    assert!((back.pose.yaw_rad() - 0.5).abs() < 1e-12);

    let odom = OdometryMsg::planar(
        Header::new(Stamp::from_ns(7), "odom"),
        "base_link",
        Pose2::<World, Robot>::new(3.0, 4.0, -1.0),
        0.5,
        0.25,
    );
    let back: OdometryMsg = from_cdr(&to_cdr(&odom).unwrap()).unwrap();
    assert_eq!(back, odom);
    let p = back.pose.pose2::<World, Robot>();
    assert!((p.yaw - -1.0).abs() < 1e-12 && p.x == 3.0);
    assert_eq!(back.twist.v_mps(), 0.5);

    let arr = PoseArrayMsg {
        header: Header::new(Stamp::ZERO, "laser"),
        poses: vec![Pose3::planar(1.0, 2.0, 0.0), Pose3::planar(-1.0, 0.5, 3.0)],
    };
    let bytes = to_cdr(&arr).unwrap();
    assert_eq!(from_cdr::<PoseArrayMsg>(&bytes).unwrap(), arr);
    let t = TwistMsg::unicycle(0.3, -0.2);
    assert_eq!(from_cdr::<TwistMsg>(&to_cdr(&t).unwrap()).unwrap(), t);
    let ts = TwistStampedMsg {
        header: Header::new(Stamp::from_ns(1_700_000_000_500_000_000), "base_link"),
        twist: t,
    };
    let bytes = to_cdr(&ts).unwrap();
    // header(4) + stamp(8) + "base_link\0" with length (4 + 10), pad to 8 (2), 6 f64.
    assert_eq!(bytes.len(), 4 + 8 + 14 + 2 + 48);
    assert_eq!(from_cdr::<TwistStampedMsg>(&bytes).unwrap(), ts);
    let tf = TfMessage {
        transforms: vec![
            TransformStampedMsg {
                header: Header::new(Stamp::from_ns(5), "base_link"),
                child_frame_id: "laser".into(),
                transform: Pose3::planar(0.1, -0.02, 0.5),
            },
            TransformStampedMsg {
                header: Header::new(Stamp::ZERO, "odom"),
                child_frame_id: "base_link".into(),
                transform: Pose3::planar(3.0, 1.0, -1.0),
            },
        ],
    };
    let bytes = to_cdr(&tf).unwrap();
    assert_eq!(from_cdr::<TfMessage>(&bytes).unwrap(), tf);
    for cut in 0..bytes.len() {
        assert!(from_cdr::<TfMessage>(&bytes[..cut]).is_err(), "cut {cut}");
    }
    assert_eq!(to_cdr(&t).unwrap().len(), 4 + 48);
}

#[test]
fn compressed_images_keep_their_bytes() {
    let png = b"\x89PNG\r\n\x1a\n rest".to_vec();
    let msg = CompressedImageMsg::new(
        Header::new(Stamp::ZERO, "camera"),
        CompressedFormat::Png,
        png.clone(),
    );
    let back: CompressedImageMsg = from_cdr(&to_cdr(&msg).unwrap()).unwrap();
    assert_eq!(back.data, png);
    assert_eq!(back.detected_format(), Some(CompressedFormat::Png));
    assert_eq!(back.format, "png");
}

#[test]
fn schema_names_match_both_spellings() {
    assert!(type_matches::<LaserScanMsg>("sensor_msgs/msg/LaserScan"));
    assert!(type_matches::<LaserScanMsg>("sensor_msgs/LaserScan"));
    assert!(!type_matches::<LaserScanMsg>("sensor_msgs/msg/Image"));
}

#[test]
fn a_string_round_trips_through_cdr() {
    let msg = StringMsg {
        data: "{\"state\":\"lost\",\"reason\":\"unseen\"}".into(),
    };
    let bytes = to_cdr(&msg).unwrap();
    // Encapsulation (4), length with the NUL (4), the text and its NUL.
    assert_eq!(bytes.len(), 8 + msg.data.len() + 1);
    assert_eq!(from_cdr::<StringMsg>(&bytes).unwrap(), msg);
    let nul = StringMsg {
        data: "a\0b".into(),
    };
    assert!(to_cdr(&nul).is_err());
}
