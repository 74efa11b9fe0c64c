//! Each diagnosis, for the mechanism's readings and for a topology with
//! one angle only: the sentence a user reads, word for word.

use super::*;
use crate::model::READINGS;

/// Nominal joints of a pose (ψ4, θ4 in degrees, q4 in mm).
const NOM: [f64; 3] = [12.5, -7.25, 700.0];

fn with(f: impl Fn(&mut [f64; 3])) -> [f64; 3] {
    let mut r = [NOM[0] + 0.01, NOM[1] - 0.02, NOM[2] + 0.3];
    f(&mut r);
    r
}

#[test]
fn each_slip_of_the_mechanisms_readings_is_named() {
    let c = |r: [f64; 3]| cause(READINGS, &r, &NOM);
    assert_eq!(
        c(with(|r| r.swap(0, 1))),
        "psi4_deg and theta4_deg look swapped"
    );
    assert_eq!(c(with(|r| r[0] = -r[0])), "psi4_deg's sign looks flipped");
    assert_eq!(c(with(|r| r[1] = -r[1])), "theta4_deg's sign looks flipped");
    assert_eq!(c(with(|r| r[2] = -r[2])), "q4_mm's sign looks flipped");
    assert_eq!(
        c(with(|r| r[2] /= 1000.0)),
        "q4_mm looks like metres (about a thousandth of the nominal length)"
    );
    assert_eq!(
        c(with(|r| {
            r[0] = r[0].to_radians();
            r[1] = r[1].to_radians();
        })),
        "the angles look like radians in the _deg columns"
    );
    assert_eq!(
        c(with(|r| r[0] += 40.0)),
        "check the units (degrees, mm), the column order and the signs"
    );
    // Within each rule's tolerance and no further: a swap of two angles
    // that are nearly equal is no swap; a small angle's flipped sign is no
    // flip (it is within the plausible distance).
    let close = [3.0, 2.0, 700.0];
    assert!(!cause(READINGS, &[2.0, 3.0, 700.0], &close).contains("swapped"));
    let small = [1.5, -7.25, 700.0];
    assert!(!cause(READINGS, &[-1.5, -7.25, 700.0], &small).contains("flipped"));
    let at_bound = [2.0, -7.25, 700.0];
    assert!(!cause(READINGS, &[-2.0, -7.25, 700.0], &at_bound).contains("flipped"));
    let past = [2.001, -7.25, 700.0];
    assert!(cause(READINGS, &[-2.001, -7.25, 700.0], &past).contains("flipped"));
    // Metres only when the angles agree: else it is not (only) the units.
    assert!(!c(with(|r| {
        r[2] /= 1000.0;
        r[0] += 10.0;
    }))
    .contains("metres"));
}

#[test]
fn the_sentence_lists_every_reading_its_difference_and_the_bounds() {
    let r = with(|r| r.swap(0, 1));
    assert_eq!(
        describe(READINGS, &r, &NOM, true),
        "the readings (psi4 -7.2700°, theta4 12.5100°, q4 700.3000 mm, less the reference row's homing offset) \
         differ from the nominal joints at this target by -19.770°, 19.760°, 0.300 mm — more than any geometric \
         error can (2°, 20 mm): psi4_deg and theta4_deg look swapped"
    );
    assert!(!describe(READINGS, &r, &NOM, false).contains("homing"));
    assert!(plausible(READINGS, &[2.0, -2.0, 20.0]));
    assert!(!plausible(READINGS, &[2.0, -2.001, 20.0]));
    assert!(!plausible(READINGS, &[0.0, 0.0, 20.001]));
}

#[test]
fn a_topology_with_one_angle_gets_its_own_diagnosis() {
    let facts = [READINGS[0]];
    assert_eq!(
        cause(&facts, &[-12.5], &[12.5]),
        "psi4_deg's sign looks flipped"
    );
    assert_eq!(
        cause(&facts, &[12.5f64.to_radians()], &[12.5]),
        "the angles look like radians in the _deg columns"
    );
    assert_eq!(
        cause(&facts, &[40.0], &[12.5]),
        "check the units (degrees), the column order and the signs"
    );
    assert_eq!(
        describe(&facts, &[40.0], &[12.5], false),
        "the readings (psi4 40.0000°) differ from the nominal joints at this target by 27.500° — more than any \
         geometric error can (2°): check the units (degrees), the column order and the signs"
    );
}

#[test]
fn a_swap_needs_the_two_values_further_apart_than_both_bounds() {
    // Two angles with bounds 1° and 3°: read as each other's nominal, they
    // are a swap only when their nominals differ by more than 1° + 3°.
    let mut facts = [READINGS[0], READINGS[1]];
    facts[0].plausible = 1.0;
    facts[1].plausible = 3.0;
    let swapped = |a: f64, b: f64| cause(&facts, &[b, a], &[a, b]).contains("swapped");
    assert!(!swapped(10.0, 13.5));
    assert!(!swapped(10.0, 14.0));
    assert!(swapped(10.0, 14.01));
    assert_eq!(
        describe(&facts, &[14.5, 10.0], &[10.0, 14.5], false)
            .split(" can (")
            .nth(1)
            .unwrap()
            .split(')')
            .next(),
        Some("1°, 3°")
    );
}
