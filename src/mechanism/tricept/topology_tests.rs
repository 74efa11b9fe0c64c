//! Tests of the mechanism's facts (`tricept/topology.rs`), each against an
//! independent route: the kinematics themselves, or the facts' own units.

use super::*;
use crate::mechanism::tricept::jacobian::passive_matrix;
use crate::mechanism::tricept::kinematics::normalized_det;
use crate::mechanism::tricept::poses::workspace_grid;
use crate::mechanism::tricept::{Geometry, Machine};

/// The scale's travel is q4's span over the workspace: the largest minus
/// the smallest q4 that nominal inverse kinematics gives over the
/// workspace's boundary (top-face centre, bottom rim, points between).
#[test]
fn length_travel_is_the_span_of_q4_over_the_workspace() {
    for (ws, geometry) in [
        (
            crate::mechanism::tricept::poses::paper_workspace(),
            Geometry::paper(),
        ),
        (
            Workspace {
                radius_mm: 250.0,
                height_mm: 120.0,
                top_mm: 500.0,
            },
            Geometry::from_circles(90.0, 260.0, [-55.0, 55.0, 180.0], [-30.0, 90.0, 210.0]),
        ),
    ] {
        let machine = Machine::nominal(&geometry);
        let mut q4: Vec<f64> = Vec::new();
        for k in 0..=40 {
            let t = k as f64 / 40.0;
            for (r, z) in [
                (t * ws.radius_mm, ws.top_mm),
                (ws.radius_mm, ws.top_mm + t * ws.height_mm),
                (t * ws.radius_mm, ws.top_mm + ws.height_mm),
            ] {
                let p = machine.inverse(&Vector3::new(r, 0.0, z)).unwrap();
                q4.push(p.joints.q4_mm);
            }
        }
        let span = q4.iter().cloned().fold(f64::MIN, f64::max)
            - q4.iter().cloned().fold(f64::MAX, f64::min);
        let travel = length_travel(&ws);
        assert!((travel - span).abs() < 1e-9 * span, "{travel} vs {span}");
    }
}

/// The paper's layout obeys the rules; each rule, broken alone, is named on
/// its side.
#[test]
fn each_layout_rule_is_named_on_its_side() {
    assert_eq!(check_layout(&Geometry::paper()), Ok(()));
    let platform = [-60.0, 60.0, 180.0];
    let broken = |beta: [f64; 3], alpha: [f64; 3]| {
        check_layout(&Geometry::from_circles(100.0, 288.7, beta, alpha)).unwrap_err()
    };
    let skew = broken([-60.0, 50.0, 180.0], platform);
    assert!(
        skew.base && skew.why.contains("parallel to the y axis"),
        "{skew:?}"
    );
    let line = broken([-90.0, 90.0, 180.0], platform);
    assert!(line.base && line.why.contains("one line"), "{line:?}");
    let same = broken([-60.0, 60.0, 180.0], [-60.0, 60.0, 60.0]);
    assert!(
        !same.base && same.why.contains("joints 2 and 3"),
        "{same:?}"
    );
}

/// The rules hold to a relative tolerance, not to the bit: a layout a
/// hair off each rule passes, one off by more than the tolerance is refused.
#[test]
fn layout_rules_hold_to_their_tolerance() {
    let (a, b) = (100.0, 288.7);
    let platform = [-60.0, 60.0, 180.0];
    let check =
        |beta: [f64; 3], alpha: [f64; 3]| check_layout(&Geometry::from_circles(a, b, beta, alpha));
    // B1B2 ∥ y within 1e-9 of b: 1e-11 of a degree off passes, 1e-6 not.
    assert!(check([-60.0, 60.0 + 1e-11, 180.0], platform).is_ok());
    assert!(
        check([-60.0, 60.0 + 1e-6, 180.0], platform)
            .unwrap_err()
            .base
    );
    // B1, B2, B4 on one line within 1e-6 of b: ±(90 − 1e-3)° spans the
    // plane (x = 1.7e-5·b), ±(90 − 1e-6)° does not (x = 1.7e-8·b).
    assert!(check([-89.999, 89.999, 180.0], platform).is_ok());
    let line = check([-(90.0 - 1e-6), 90.0 - 1e-6, 180.0], platform).unwrap_err();
    assert!(line.why.contains("one line"), "{line:?}");
    // B1 and B2 closer than 1e-6 of b leave B1, B2, B4 on one line too:
    // ±1e-3° apart (0.01 mm) they span the plane, ±1e-5° (1e-4 mm) not.
    assert!(check([-1e-3, 1e-3, 180.0], platform).is_ok());
    let close = check([-1e-5, 1e-5, 180.0], platform).unwrap_err();
    assert!(close.base && close.why.contains("one line"), "{close:?}");
    // Two joints within 1e-6 of the larger radius are one point: 1e-2° apart
    // (0.017 mm on the platform) are two, 1e-7° apart are one.
    assert!(check([-60.0, 60.0, 180.0], [-60.0, 60.0, 60.01]).is_ok());
    let same = check([-60.0, 60.0, 180.0], [-60.0, 60.0, 60.0 + 1e-7]).unwrap_err();
    assert!(
        !same.base && same.why.contains("joints 2 and 3"),
        "{same:?}"
    );
    let base = check([-60.0, 60.0, 60.0 + 1e-7], platform).unwrap_err();
    assert!(base.base && base.why.contains("joints 2 and 3"), "{base:?}");
}

/// A pose is refused for each reason a nominal machine can give: out of
/// reach, tilted too far, and (inside) accepted.
#[test]
fn a_pose_is_checked_for_reach_tilt_and_singularity() {
    let machine = Machine::nominal(&Geometry::paper());
    let ws = crate::mechanism::tricept::poses::paper_workspace();
    for r in workspace_grid(&ws, 100.0, 2) {
        assert_eq!(check_pose(&machine, &r, 45.0), Ok(()), "{r:?}");
    }
    let tilted = Vector3::new(400.0, 0.0, 650.0);
    let why = check_pose(&machine, &tilted, 20.0).unwrap_err();
    assert!(why.contains("tilt") && why.contains("31.6"), "{why}");
    assert!(check_pose(&machine, &Vector3::new(0.0, 0.0, -650.0), 89.0).is_err());
    // Near the base plane the passive limb's matrix loses rank (found by a
    // scan of x, z: normalised det 2.7e-7 at (284.6, 0, 0.72), 5e-4 at
    // (240, 0, 10)); the tilt bound is opened so that only that decides.
    let near = Vector3::new(284.6, 0.0, 0.72);
    let det = normalized_det(&passive_matrix(&machine.inverse(&near).unwrap())).abs();
    assert!(det < 1e-6, "{det}");
    let why = check_pose(&machine, &near, 89.99).unwrap_err();
    assert!(why.contains("singular"), "{why}");
    assert_eq!(
        check_pose(&machine, &Vector3::new(240.0, 0.0, 10.0), 89.99),
        Ok(())
    );
}

/// Each reading's column is in its file unit, and the files' values come
/// back as the same joints.
#[test]
fn readings_are_named_in_their_units_and_round_trip() {
    for r in READINGS {
        assert_eq!(r.column, format!("{}_{}", r.ascii, r.quantity.file_unit()));
    }
    assert_eq!(READINGS[LENGTH_READING].quantity, Quantity::Length);
    // Sensor units against their definitions: 1″ = π/648000 rad, 1 µm =
    // 1e-3 mm, and each way back.
    let (angle, length) = (Quantity::Angle, Quantity::Length);
    assert!((angle.from_sensor(1.0) - std::f64::consts::PI / 648_000.0).abs() < 1e-20);
    assert_eq!(length.from_sensor(2.5), 2.5e-3);
    for q in [angle, length] {
        assert!((q.from_sensor(7.0) * q.sensor_per_model() - 7.0).abs() < 1e-12);
    }
    assert_eq!(
        (angle.sensor_unit_ascii(), length.sensor_unit_ascii()),
        ("arcsec", "um")
    );
    let j = Joints {
        psi_rad: 0.25,
        theta_rad: -0.125,
        q4_mm: 812.5,
    };
    let v = file_values(&j);
    assert_eq!(v, [0.25f64.to_degrees(), (-0.125f64).to_degrees(), 812.5]);
    let back = from_file_values(v);
    assert!((back.as_vector() - j.as_vector()).norm() < 1e-15);
    let mut names = GAUGE_FIXED.to_vec();
    names.extend(<Mechanism as Topology>::ERROR_NAMES);
    let n = names.len();
    names.sort_unstable();
    names.dedup();
    assert_eq!(names.len(), n, "an error is both estimated and fixed");
}
