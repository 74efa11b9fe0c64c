//! Tests of the study context (`montecarlo/context.rs`).

use super::*;
use crate::config::{parse_raw, Config};
use crate::mechanism::tricept::{N_READINGS, SLOTS};
use crate::montecarlo::plan::{draw_classes, same_axes};

/// A product name is one CSV cell whatever it holds.
#[test]
fn text_cells_are_quoted_when_they_must_be() {
    assert_eq!(csv_text("angle-1as"), "angle-1as");
    assert_eq!(csv_text("a,b"), "\"a,b\"");
    assert_eq!(csv_text("say \"hi\""), "\"say \"\"hi\"\"\"");
    assert_eq!(csv_text("two\nlines"), "\"two\nlines\"");
}

/// Sets that draw alike share a class and their equal axes; a set of
/// another curve shape, of other samples or without datasheet models
/// (white noise) is a class of its own and shares no axis.
#[test]
fn sets_share_draws_and_axes_only_when_alike() {
    let text = "[sensors.encoder]\naccuracy_arcsec = 2.0\nharmonics = [0.8, 0.2]\nnoise_arcsec = 0.05\nresolution_arcsec = 0.01\n[sensors.scale]\naccuracy_um = 0.5\nnoise_um = 0.02\n";
    let cfg = Config::from_raw(parse_raw(text, "t").unwrap(), "t").unwrap();
    let base = SensorModel {
        slots: SLOTS,
        encoder_arcsec: 2.0,
        scale_um: 0.5,
        samples: 3,
        reading: crate::sensors::GradeReading::Sigma,
        structured: cfg.sensors.structured,
    };
    let st = base.structured.unwrap();
    let with = |st: crate::sensors::Structured<N_READINGS>, samples: u32| SensorModel {
        structured: Some(st),
        samples,
        ..base
    };
    // 0: the base; 1: finer encoders (same draws, the scale shared);
    // 2: another encoder curve (other draws); 3: the base with other
    // samples; 4: white noise; 5: a coarser scale (encoders shared).
    let mut shape = st;
    shape.axes[0].harmonics[0] = 0.5;
    let mut finer = st;
    finer.axes[0].accuracy *= 0.5;
    finer.axes[1].accuracy *= 0.5;
    let mut coarser = st;
    coarser.axes[2].accuracy *= 4.0;
    let sets = vec![
        with(st, 3),
        with(finer, 3),
        with(shape, 3),
        with(st, 2),
        SensorModel {
            structured: None,
            ..base
        },
        with(coarser, 3),
    ];
    assert_eq!(draw_classes(&sets), vec![0, 0, 2, 3, 4, 0]);
    assert_eq!(
        same_axes(&sets),
        vec![
            [0, 0, 0],
            [1, 1, 0],
            [2, 2, 2],
            [3, 3, 3],
            [4, 4, 4],
            [0, 0, 5]
        ]
    );
}
