//! The cascade as OpenCV's current XML (`opencv_traincascade`'s layout, which OpenCV 4.x's
//! `CascadeClassifier` and tether-vision load): `stageType BOOST`, `featureType HAAR`,
//! the window size, `stageParams`, `featureParams`, the `stages` (each with its
//! `stageThreshold` and `weakClassifiers` of `internalNodes` `0 -1 featureIndex
//! threshold` and `leafValues` `left right`) and the `features` used, each with its
//! `rects` (`x y w h weight`) and `tilted` flag.
//!
//! Numbers are written as OpenCV writes doubles (`%.16e`); every `f32` of the model
//! survives the round trip exactly (OpenCV reads a double and narrows it to `f32`).

use std::fmt::Write as _;

use crate::boost::StageParams;
use crate::features::Feature;
use crate::model::CascadeModel;

/// A double as OpenCV's `FileStorage` writes it: `-8.8677501678466797e-01`.
pub fn opencv_double(v: f64) -> String {
    let s = format!("{v:.16e}");
    match s.split_once('e') {
        Some((mantissa, exp)) => {
            let (sign, digits) = match exp.strip_prefix('-') {
                Some(d) => ('-', d),
                None => ('+', exp),
            };
            format!("{mantissa}e{sign}{digits:0>2}")
        }
        None => s,
    }
}

/// A rectangle weight as OpenCV writes it (`-1.`, `2.`, or a full double).
fn weight(v: f32) -> String {
    if v.fract() == 0.0 && v.abs() < 1e6 {
        format!("{}.", v as i64)
    } else {
        opencv_double(f64::from(v))
    }
}

/// The XML text of a cascade. `params` fills `stageParams` (informative: OpenCV's
/// detector does not read it).
pub fn to_xml(cascade: &CascadeModel, params: &StageParams) -> String {
    // The features used, in order of first use.
    let mut features: Vec<Feature> = Vec::new();
    let mut index_of = |f: &Feature| -> usize {
        match features.iter().position(|g| g == f) {
            Some(i) => i,
            None => {
                features.push(*f);
                features.len() - 1
            }
        }
    };
    let mut stages = String::new();
    for (si, stage) in cascade.stages.iter().enumerate() {
        let _ = write!(
            stages,
            "    <!-- stage {si} -->\n    <_>\n      <maxWeakCount>{}</maxWeakCount>\n      \
             <stageThreshold>{}</stageThreshold>\n      <weakClassifiers>\n",
            stage.stumps.len(),
            opencv_double(f64::from(stage.threshold))
        );
        for s in &stage.stumps {
            let fi = index_of(&s.feature);
            let _ = write!(
                stages,
                "        <_>\n          <internalNodes>\n            0 -1 {fi} {}</internalNodes>\n          \
                 <leafValues>\n            {} {}</leafValues></_>\n",
                opencv_double(f64::from(s.threshold)),
                opencv_double(f64::from(s.left)),
                opencv_double(f64::from(s.right))
            );
        }
        stages.push_str("      </weakClassifiers></_>\n");
    }
    let mut feats = String::new();
    for f in &features {
        feats.push_str("    <_>\n      <rects>\n");
        let n = f.rect_count();
        for (k, r) in f.rects[..n].iter().enumerate() {
            let _ = write!(
                feats,
                "        <_>\n          {} {} {} {} {}</_>{}",
                r.x,
                r.y,
                r.w,
                r.h,
                weight(r.weight),
                if k + 1 == n { "</rects>\n" } else { "\n" }
            );
        }
        let _ = writeln!(feats, "      <tilted>{}</tilted></_>", u8::from(f.tilted));
    }
    format!(
        "<?xml version=\"1.0\"?>\n<opencv_storage>\n<cascade type_id=\"opencv-cascade-classifier\">\n  \
         <stageType>BOOST</stageType>\n  <featureType>HAAR</featureType>\n  <height>{h}</height>\n  \
         <width>{w}</width>\n  <stageParams>\n    <boostType>{bt}</boostType>\n    \
         <minHitRate>{mhr}</minHitRate>\n    <maxFalseAlarm>{mfa}</maxFalseAlarm>\n    \
         <weightTrimRate>1.</weightTrimRate>\n    <maxDepth>1</maxDepth>\n    \
         <maxWeakCount>{mwc}</maxWeakCount></stageParams>\n  <featureParams>\n    \
         <maxCatCount>0</maxCatCount>\n    <featureSize>1</featureSize>\n    <mode>{mode}</mode></featureParams>\n  \
         <stageNum>{n}</stageNum>\n  <stages>\n{stages}  </stages>\n  <features>\n{feats}  </features>\n\
         </cascade>\n</opencv_storage>\n",
        h = cascade.height,
        w = cascade.width,
        bt = params.boost.opencv_name(),
        mhr = opencv_double(params.min_hit_rate),
        mfa = opencv_double(params.max_false_alarm),
        mwc = params.max_weak_count,
        mode = cascade.mode.opencv_name(),
        n = cascade.stages.len(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::boost::BoostType;
    use crate::features::{FeatureMode, enumerate};
    use crate::model::{Stage, Stump};
    use tether_vision::Cascade;
    use tether_vision::cascade::STAGE_THRESHOLD_EPS;

    fn params() -> StageParams {
        StageParams {
            boost: BoostType::Gentle,
            min_hit_rate: 0.995,
            max_false_alarm: 0.5,
            max_weak_count: 100,
        }
    }

    #[test]
    fn numbers_look_like_opencv() {
        assert_eq!(opencv_double(-0.886775016784668), "-8.8677501678466797e-01");
        assert_eq!(opencv_double(0.5), "5.0000000000000000e-01");
        assert_eq!(opencv_double(1234.0), "1.2340000000000000e+03");
        assert_eq!(weight(-1.0), "-1.");
        assert_eq!(weight(9.0), "9.");
    }

    #[test]
    fn tether_vision_loads_what_is_written() {
        let all = enumerate(10, 12, FeatureMode::All);
        let pick = |i: usize| all[(i * 7919) % all.len()];
        let tilted = *all.iter().find(|f| f.tilted).unwrap();
        let three = *all.iter().find(|f| f.rect_count() == 3).unwrap();
        let stump = |f: Feature, t: f32, l: f32, r: f32| Stump {
            feature: f,
            threshold: t,
            left: l,
            right: r,
        };
        let model = CascadeModel {
            width: 10,
            height: 12,
            mode: FeatureMode::All,
            stages: vec![
                Stage {
                    threshold: -0.123_456_79,
                    stumps: vec![
                        stump(pick(1), 0.1, -0.9, 0.8),
                        stump(tilted, -1.0e-3, 0.333_333_34, -0.7),
                    ],
                },
                Stage {
                    threshold: 1.5,
                    stumps: vec![
                        stump(three, 0.0, 1.0, -1.0),
                        stump(pick(1), 0.2, 0.25, 0.5),
                        stump(pick(2), 7.0e-7, -3.0e-8, 2.0),
                    ],
                },
            ],
        };
        let xml = to_xml(&model, &params());
        let c = Cascade::from_xml(&xml).unwrap();
        assert_eq!((c.window_width_px(), c.window_height_px()), (10, 12));
        assert!(c.is_stump_based());
        assert!(c.has_tilted_features());
        assert_eq!(c.stages().len(), 2);
        // The repeated feature is written once.
        assert_eq!(c.features().len(), 4);
        let mut tree = 0;
        for (stage, loaded) in model.stages.iter().zip(c.stages()) {
            assert_eq!(loaded.threshold, stage.threshold - STAGE_THRESHOLD_EPS);
            for s in &stage.stumps {
                let t = c.trees()[tree];
                let node = c.nodes()[t.first_node as usize];
                assert_eq!(node.threshold, s.threshold);
                let leaves = &c.leaves()[t.first_leaf as usize..t.first_leaf as usize + 2];
                assert_eq!(leaves, &[s.left, s.right]);
                let f = &c.features()[node.feature as usize];
                assert_eq!(f.tilted, s.feature.tilted);
                for (a, b) in f.rects.iter().zip(&s.feature.rects) {
                    assert_eq!(
                        (a.x, a.y, a.w, a.h, a.weight),
                        (b.x, b.y, b.w, b.h, b.weight)
                    );
                }
                tree += 1;
            }
        }
    }
}
