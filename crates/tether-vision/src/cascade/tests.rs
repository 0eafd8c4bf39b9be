use super::*;

/// A tiny current-format cascade: a 6x4 window, two stages of stumps, one tilted
/// feature.
pub(crate) const TINY_TRAINCASCADE: &str = r#"<?xml version="1.0"?>
<opencv_storage>
<cascade type_id="opencv-cascade-classifier"><stageType>BOOST</stageType>
  <featureType>HAAR</featureType>
  <height>4</height>
  <width>6</width>
  <stageParams><maxWeakCount>2</maxWeakCount></stageParams>
  <featureParams><maxCatCount>0</maxCatCount></featureParams>
  <stageNum>2</stageNum>
  <stages>
    <_>
      <maxWeakCount>2</maxWeakCount>
      <stageThreshold>-0.5</stageThreshold>
      <weakClassifiers>
        <_><internalNodes>0 -1 0 1.5e-01</internalNodes><leafValues>-1. 1.</leafValues></_>
        <_><internalNodes>0 -1 1 -2.e-01</internalNodes><leafValues>0.5 -0.25</leafValues></_>
      </weakClassifiers></_>
    <_>
      <maxWeakCount>1</maxWeakCount>
      <stageThreshold>0.</stageThreshold>
      <weakClassifiers>
        <_><internalNodes>0 -1 2 0.</internalNodes><leafValues>0.75 -0.75</leafValues></_>
      </weakClassifiers></_></stages>
  <features>
    <_><rects><_>0 0 6 4 -1.</_><_>0 0 3 4 2.</_></rects></_>
    <_><rects><_>1 0 4 4 -1.</_><_>2 0 2 4 2.</_></rects></_>
    <_><rects><_>2 0 2 2 -1.</_><_>2 0 1 1 4.</_></rects><tilted>1</tilted></_>
  </features></cascade>
</opencv_storage>
"#;

/// The same cascade in the old haartraining layout.
pub(crate) const TINY_HAARTRAINING: &str = r#"<?xml version="1.0"?>
<opencv_storage>
<tiny type_id="opencv-haar-classifier">
  <size>6 4</size>
  <stages>
    <_>
      <trees>
        <_><_>
          <feature><rects><_>0 0 6 4 -1.</_><_>0 0 3 4 2.</_></rects><tilted>0</tilted></feature>
          <threshold>1.5e-01</threshold><left_val>-1.</left_val><right_val>1.</right_val></_></_>
        <_><_>
          <feature><rects><_>1 0 4 4 -1.</_><_>2 0 2 4 2.</_></rects><tilted>0</tilted></feature>
          <threshold>-2.e-01</threshold><left_val>0.5</left_val><right_val>-0.25</right_val></_></_>
      </trees>
      <stage_threshold>-0.5</stage_threshold><parent>-1</parent><next>-1</next></_>
    <_>
      <trees>
        <_><_>
          <feature><rects><_>2 0 2 2 -1.</_><_>2 0 1 1 4.</_></rects><tilted>1</tilted></feature>
          <threshold>0.</threshold><left_val>0.75</left_val><right_val>-0.75</right_val></_></_>
      </trees>
      <stage_threshold>0.</stage_threshold><parent>0</parent><next>-1</next></_>
  </stages>
</tiny>
</opencv_storage>
"#;

#[test]
fn reads_the_current_layout() {
    let c = Cascade::from_xml(TINY_TRAINCASCADE).unwrap();
    assert_eq!(c.format(), CascadeFormat::TrainCascade);
    assert_eq!((c.window_width_px(), c.window_height_px()), (6, 4));
    assert_eq!(c.stages().len(), 2);
    assert_eq!(c.trees().len(), 3);
    assert!(c.is_stump_based());
    assert!(c.has_tilted_features());
    assert_eq!(c.stages()[0].threshold, -0.5f32 - STAGE_THRESHOLD_EPS);
    assert_eq!(c.nodes()[1].threshold, -0.2f32);
    assert_eq!(c.leaves(), &[-1.0, 1.0, 0.5, -0.25, 0.75, -0.75]);
    assert_eq!(c.features()[0].rects[1].weight, 2.0);
    assert_eq!(c.features()[0].rects[2].weight, 0.0);
}

#[test]
fn both_layouts_give_the_same_model() {
    let new = Cascade::from_xml(TINY_TRAINCASCADE).unwrap();
    let old = Cascade::from_xml(TINY_HAARTRAINING).unwrap();
    assert_eq!(old.format(), CascadeFormat::HaarTraining);
    assert_eq!(new.features(), old.features());
    assert_eq!(new.stages(), old.stages());
    assert_eq!(new.trees(), old.trees());
    assert_eq!(new.nodes(), old.nodes());
    assert_eq!(new.leaves(), old.leaves());
}

#[test]
fn old_layout_trees_number_their_leaves_in_order() {
    // A two-node tree: the root goes left to node 1 and right to a leaf; node 1 has
    // two leaves. Leaves are numbered in reading order, so the root's right leaf,
    // read first, is leaf 0.
    let xml = r#"<opencv_storage><t type_id="opencv-haar-classifier"><size>4 4</size>
          <stages><_><trees><_>
            <_><feature><rects><_>0 0 4 4 -1.</_><_>0 0 2 4 2.</_></rects></feature>
               <threshold>0.1</threshold><left_node>1</left_node><right_val>0.3</right_val></_>
            <_><feature><rects><_>0 0 4 4 -1.</_><_>0 0 4 2 2.</_></rects></feature>
               <threshold>0.2</threshold><left_val>0.1</left_val><right_val>0.2</right_val></_>
          </_></trees><stage_threshold>0.</stage_threshold></_></stages></t></opencv_storage>"#;
    let c = Cascade::from_xml(xml).unwrap();
    assert!(!c.is_stump_based());
    assert_eq!(c.nodes()[0].left, 1);
    assert_eq!(c.nodes()[0].right, 0);
    assert_eq!(c.nodes()[1].left, -1);
    assert_eq!(c.nodes()[1].right, -2);
    assert_eq!(c.leaves(), &[0.3, 0.1, 0.2]);
}

#[test]
fn refuses_lbp_hog_and_non_cascades() {
    let lbp = TINY_TRAINCASCADE.replace("<featureType>HAAR", "<featureType>LBP");
    let e = Cascade::from_xml(&lbp).unwrap_err();
    assert!(matches!(e, CascadeError::Unsupported { .. }), "{e}");
    assert!(e.to_string().contains("LBP"), "{e}");
    let hog = TINY_TRAINCASCADE.replace("<featureType>HAAR", "<featureType>HOG");
    assert!(
        Cascade::from_xml(&hog)
            .unwrap_err()
            .to_string()
            .contains("HOG")
    );
    let svm = r#"<?xml version="1.0"?><opencv_storage><my_svm type_id="opencv-ml-svm">
            <svmType>C_SVC</svmType></my_svm></opencv_storage>"#;
    let e = Cascade::from_xml(svm).unwrap_err();
    assert!(matches!(e, CascadeError::NotACascade { .. }), "{e}");
    assert!(e.to_string().contains("opencv-ml-svm"), "{e}");
    assert!(matches!(
        Cascade::from_xml("<html><body/></html>"),
        Err(CascadeError::NotACascade { .. })
    ));
    assert!(matches!(
        Cascade::from_xml("this is not xml <"),
        Err(CascadeError::Xml(_))
    ));
}

#[test]
fn refuses_damaged_files_with_a_line_number() {
    let bad_feature = TINY_TRAINCASCADE.replace("0 -1 2 0.<", "0 -1 7 0.<");
    let e = Cascade::from_xml(&bad_feature).unwrap_err();
    assert!(e.to_string().contains("feature 7"), "{e}");
    let outside = TINY_TRAINCASCADE.replace("<_>1 0 4 4 -1.</_>", "<_>1 0 9 4 -1.</_>");
    assert!(
        Cascade::from_xml(&outside)
            .unwrap_err()
            .to_string()
            .contains("does not fit")
    );
    // A tilted rectangle needs x - h >= 0.
    let tilted = TINY_TRAINCASCADE.replace("<_>2 0 2 2 -1.</_>", "<_>1 0 2 2 -1.</_>");
    assert!(Cascade::from_xml(&tilted).is_err());
    let leaves = TINY_TRAINCASCADE.replace(
        "<leafValues>-1. 1.</leafValues>",
        "<leafValues>-1.</leafValues>",
    );
    let e = Cascade::from_xml(&leaves).unwrap_err();
    match e {
        CascadeError::Malformed { line, .. } => assert!(line > 10),
        other => panic!("{other}"),
    }
    let nan = TINY_TRAINCASCADE.replace("1.5e-01", "nan");
    assert!(Cascade::from_xml(&nan).is_err());
    let word = TINY_TRAINCASCADE.replace("1.5e-01", "abc");
    assert!(
        Cascade::from_xml(&word)
            .unwrap_err()
            .to_string()
            .contains("abc")
    );
    let no_stages = TINY_TRAINCASCADE
        .replace("<stages>", "<stagez>")
        .replace("</stages>", "</stagez>");
    assert!(
        Cascade::from_xml(&no_stages)
            .unwrap_err()
            .to_string()
            .contains("<stages>")
    );
}

#[test]
fn refuses_trees_that_loop() {
    let xml = r#"<opencv_storage><t type_id="opencv-haar-classifier"><size>4 4</size>
          <stages><_><trees><_>
            <_><feature><rects><_>0 0 4 4 -1.</_></rects></feature>
               <threshold>0.1</threshold><left_node>1</left_node><right_val>0.3</right_val></_>
            <_><feature><rects><_>0 0 4 4 -1.</_></rects></feature>
               <threshold>0.2</threshold><left_node>1</left_node><right_val>0.2</right_val></_>
          </_></trees><stage_threshold>0.</stage_threshold></_></stages></t></opencv_storage>"#;
    assert!(Cascade::from_xml(xml).is_err());
}

proptest::proptest! {
    /// Damaged files (of either layout) never panic: random bytes replaced, or
    /// numbers changed to other numbers (negative, huge, fractional), either load or
    /// give an error, and a cascade that loads can scan an image.
    #[test]
    fn damaged_files_never_panic(old_format in proptest::bool::ANY, edits in proptest::collection::vec((0usize..4000, 0usize..12), 1..6)) {
        let source = if old_format { TINY_HAARTRAINING } else { TINY_TRAINCASCADE };
        let mut text = source.as_bytes().to_vec();
        let replacements: [&[u8]; 12] = [b"-", b"9", b"<", b">", b"e9", b" ", b"-7 ", b"1e40", b"0.5", b"_", b"\"", b"99999999999"];
        for (pos, which) in edits {
            let at = pos % text.len();
            let r = replacements[which];
            text.splice(at..(at + 1).min(text.len()), r.iter().copied());
        }
        let text = String::from_utf8_lossy(&text).into_owned();
        if let Ok(cascade) = Cascade::from_xml(&text) {
            let image = tether_core::GrayImage::from_raw(31, 23, (0..31 * 23).map(|i| (i * 37 % 251) as u8).collect()).unwrap();
            let params = crate::DetectParams { min_neighbors: 0, ..crate::DetectParams::default() };
            let _ = crate::Detector::new(cascade).detect(&image, &params);
        }
    }
}

#[test]
fn missing_file_says_which() {
    let e = Cascade::load("/nonexistent/cascade.xml").unwrap_err();
    assert!(e.to_string().contains("/nonexistent/cascade.xml"), "{e}");
}
