use super::*;

#[test]
fn auto_window_follows_the_boxes_aspect() {
    let full = Rect {
        x: 0,
        y: 0,
        width: 50,
        height: 100,
    };
    assert_eq!(auto_window(&[full]), [16, 32]);
    assert_eq!(auto_window(&[upper_part(&full, 0.4)]), [25, 20]);
}

#[test]
fn fitted_boxes_have_the_window_aspect_and_stay_inside() {
    let b = Rect {
        x: 2,
        y: 5,
        width: 40,
        height: 100,
    };
    let r = fit_box(&b, [16, 32], 1.0, (0.0, 0.0), (768, 576)).unwrap();
    assert_eq!((r.width, r.height), (50, 100));
    assert_eq!((r.x, r.y), (0, 5));
    assert!(fit_box(&b, [16, 32], 1.0, (0.0, 0.0), (40, 90)).is_none());
}

#[test]
fn feature_subsets_are_seeded_and_sorted() {
    let pool = enumerate(8, 8, FeatureMode::Basic);
    let a = stage_features(&pool, 100, 3);
    assert_eq!(a, stage_features(&pool, 100, 3));
    assert_ne!(a, stage_features(&pool, 100, 4));
    assert_eq!(a.len(), 100);
    assert_eq!(stage_features(&pool, 0, 3).len(), pool.len());
}
