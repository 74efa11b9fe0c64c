use super::*;

/// A log scale puts equal ratios at equal distances; a linear one
/// equal differences; values outside or undefined take the ends.
#[test]
fn colour_scales_map_linearly_or_logarithmically() {
    let log = ColourScale::log(0.01, 10.0);
    assert!((log.t(0.1) - 1.0 / 3.0).abs() < 1e-12);
    assert!((log.t(1.0) - 2.0 / 3.0).abs() < 1e-12);
    assert_eq!((log.t(0.0), log.t(100.0), log.t(f64::NAN)), (0.0, 1.0, 0.0));
    let lin = ColourScale::linear(0.0, 10.0);
    assert!((lin.t(0.1) - 0.01).abs() < 1e-12);
    // 0.05 and 0.2 mm beside 9 mm: one colour linearly, far apart in log.
    let log9 = ColourScale::log_of(&[0.02, 0.05, 0.2, 9.0], 4.0);
    assert!(log9.t(0.2) - log9.t(0.05) > 0.2);
    assert!(ColourScale::linear(0.0, 9.0).t(0.2) < 0.03);
    // A value near zero does not stretch a log scale beyond its decades.
    assert_eq!(ColourScale::log_of(&[1e-12, 1.0], 3.0).range().0, 1e-3);
}

/// Ticks are round values inside the scale, labelled with the decimals
/// their spacing needs.
#[test]
fn ticks_are_round_values_inside_the_scale() {
    let t = ColourScale::linear(0.127, 0.153).ticks();
    assert_eq!(t.len(), 5, "{t:?}");
    assert!(t.iter().all(|v| (0.127..=0.153).contains(v)));
    assert_eq!(tick_label(t[0], &t), "0.130");
    let t = ColourScale::log(0.03, 6.0).ticks();
    assert_eq!(t, vec![0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0]);
    assert_eq!(tick_label(0.05, &t), "0.05");
    assert_eq!(tick_label(5.0, &t), "5.00");
    let t = ColourScale::log(0.005, 50.0).ticks();
    assert_eq!(t, vec![0.01, 0.1, 1.0, 10.0]);
}
