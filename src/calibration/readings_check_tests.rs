//! Each diagnosis, for the mechanism's readings and for a topology with
//! one angle only: the sentence a user reads, word for word.

use super::*;
use crate::mechanism::tricept::READINGS;

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

/// A readings file of the paper's machine, noise-free, and what
/// `check_readings` says of it after `edit` (None: accepted).
fn checked(
    rows: usize,
    edit: impl Fn(&mut [crate::mechanism::tricept::Reading]),
) -> Option<String> {
    use crate::config::Config;
    use crate::identify::tricept::simulate_readings;
    let cfg = Config::paper().unwrap();
    let mut poses = cfg.nominal_poses().unwrap();
    poses.targets.truncate(rows);
    let poses =
        crate::mechanism::tricept::NominalPoses::new(&cfg.nominal(), &poses.targets).unwrap();
    let truth = cfg.truth("test").unwrap();
    let mut rng = crate::montecarlo::simulate_stream(1);
    let mut readings = simulate_readings(&poses, &truth, None, &mut rng).unwrap();
    edit(&mut readings);
    super::check_readings(
        &cfg.homed(),
        &readings,
        crate::io::Source::new("r.csv", &[]),
    )
    .err()
    .map(|e| e.to_string())
}

fn swap_angles(r: &mut crate::mechanism::tricept::Reading) {
    std::mem::swap(&mut r.joints.psi_rad, &mut r.joints.theta_rad);
}

#[test]
fn the_row_blamed_is_the_one_that_is_off() {
    assert_eq!(checked(8, |_| {}), None);
    // One row off: that row (data line = index + 2), no homing offset said.
    let one = checked(8, |r| swap_angles(&mut r[5])).unwrap();
    assert!(one.contains("line 7: ") && one.contains("swapped"), "{one}");
    assert!(!one.contains("homing offset"), "{one}");
    // A homing offset logged in every row is no error; with it, a row that
    // is off is still that row, its readings shown less the offset.
    let shift = |r: &mut [crate::mechanism::tricept::Reading]| {
        r.iter_mut()
            .for_each(|x| x.joints.psi_rad += 5f64.to_radians())
    };
    assert_eq!(checked(8, shift), None);
    let both = checked(8, |r| {
        shift(r);
        swap_angles(&mut r[5]);
    })
    .unwrap();
    assert!(both.contains("line 7: "), "{both}");
    assert!(
        both.contains("less the reference row's homing offset"),
        "{both}"
    );
    // The reference row off: every other row is off relative to it, and
    // the reference row is blamed (line 2), with nothing taken off it.
    let first = checked(8, |r| r[0].joints.q4_mm += 50.0).unwrap();
    assert!(
        first.contains("line 2: ") && !first.contains("homing"),
        "{first}"
    );
    // With two rows there is no telling which one is off: the second is
    // named.
    let two = checked(2, |r| r[0].joints.q4_mm += 50.0).unwrap();
    assert!(two.contains("line 3: "), "{two}");
}

#[test]
fn rows_out_of_order_are_not_swapped_columns() {
    // Rows 9 and 15 ((400, 0) and (0, -400) mm at z = 650): their readings
    // exchanged look like each other's with ψ and θ swapped; they are rows
    // out of order, the first named by its line, with the line it fits.
    let ooo = checked(51, |r| {
        let (a, b) = (r[9].joints, r[15].joints);
        r[9].joints = b;
        r[15].joints = a;
    })
    .unwrap();
    assert!(
        ooo.contains("line 11: rows out of order: this row's readings")
            && ooo.contains(
                "fit the target of line 17 (0, -400, 650) mm, not this row's (400, 0, 650) mm"
            ),
        "{ooo}"
    );
    assert!(!ooo.contains("swapped"), "{ooo}");
    // The reference row's readings exchanged with the next row's.
    let first = checked(8, |r| {
        let (a, b) = (r[0].joints, r[1].joints);
        r[0].joints = b;
        r[1].joints = a;
    })
    .unwrap();
    assert!(
        first.contains("line 2: rows out of order") && first.contains("line 3"),
        "{first}"
    );
    // One row's angle columns swapped: still that (its twin row reads its
    // own target).
    let one = checked(51, |r| swap_angles(&mut r[9])).unwrap();
    assert!(
        one.contains("swapped") && !one.contains("out of order"),
        "{one}"
    );
}
