//! The angles' identification of any mechanism's sizes against one least
//! squares of the errors and angles together, its refusal in the
//! mechanism's words, and the words themselves.

use super::*;
use crate::identify::Solver;
use crate::sensors::SensorCovariance;
use nalgebra::{DMatrix, DVector, SVector};

/// Two errors, one reading a pose, one tilt angle.
const TILT: Unknowns<2, 1> = Unknowns {
    errors: ["da", "db"],
    angles: ["tilt"],
    angles_are: "the tilt",
    angle_is: "tilt",
    angles_turn: "the test's pivot",
    axes: "pivot axes",
    beyond: "the pivot's roll",
};

/// Eight rows of homed observation: the errors' columns and the angle's.
fn designs() -> (DMatrix<f64>, DMatrix<f64>) {
    let h = DMatrix::from_fn(8, 2, |i, c| {
        ((i * 3 + c * 5) as f64 * 0.37).sin() + c as f64
    });
    let h3 = DMatrix::from_fn(8, 1, |i, _| {
        (i as f64 * 0.91).cos() * (1.0 + 0.1 * i as f64)
    });
    (h, h3)
}

fn sigma() -> ObservationCovariance {
    let joints = vec![SVector::<f64, 1>::zeros(); 9];
    ObservationCovariance::new(&[SensorCovariance::white(0.01)], &joints)
}

fn inputs<'a>(h3: &'a DMatrix<f64>, layout: Option<[bool; 1]>) -> AxesInputs<'a, 2, 1> {
    AxesInputs {
        h3,
        rank_tolerance: 1e-9,
        layout,
        unknowns: &TILT,
        poses: 9,
        file: Source::new("log.csv", &[]),
        config: "test.toml",
    }
}

#[test]
fn the_angles_are_one_least_squares_with_the_errors() {
    let (h, h3) = designs();
    let (e, a) = (SVector::from([0.3, -0.2]), 0.05);
    let l = &h * e + &h3 * a;
    let solver = Solver::<2, 1>::ols_named(&h, 1e-9, &TILT.errors);
    let mut est = solver.estimate(&l);
    let fit = identify_axes(inputs(&h3, Some([true])), &solver, (&l, &sigma()), &mut est).unwrap();
    // The joint least squares by QR, an independent route.
    let mut full = DMatrix::zeros(8, 3);
    full.columns_mut(0, 2).copy_from(&h);
    full.columns_mut(2, 1).copy_from(&h3);
    let g = (full.transpose() * &full).try_inverse().unwrap() * full.transpose();
    let x = &g * &l;
    assert!((est.values - x.rows(0, 2)).amax() < 1e-12, "{}", est.values);
    assert!((fit.angles[0] - x[2]).abs() < 1e-12 && (fit.angles[0] - a).abs() < 1e-12);
    assert_eq!(fit.identifiable, [true]);
    // Its uncertainty is the white sensor's through the joint operator:
    // homed rows share the reference's reading, Σ = σ²(I + 11ᵀ).
    let homed = (DMatrix::identity(8, 8) + DMatrix::from_element(8, 8, 1.0)) * 1e-4;
    let cov = &g * homed * g.transpose();
    assert!((fit.std_deg[0] / cov[(2, 2)].sqrt() - 1.0).abs() < 1e-9);
    assert_eq!(est.dof, 8 - 3);
    // The errors' uncertainties are the joint fit's too, and an exact
    // observation leaves no residual.
    for k in 0..2 {
        assert!((est.std_mm[k] / cov[(k, k)].sqrt() - 1.0).abs() < 1e-9);
    }
    assert!(est.residual_rms < 1e-12, "{}", est.residual_rms);
    let words = fit.in_words(&TILT);
    assert!(
        words.starts_with("Pivot axes, identified with the 2 errors: tilt = 0.05000° ± ")
            && words.ends_with(
                "; the pivot's roll cannot be told from the 2 errors and is not identified"
            ),
        "{words}"
    );
    let said = AxesAnalysis::of(&solver, &fit.solver, &sigma(), &TILT);
    assert_eq!(
        (said.rank, said.errors, said.names.clone()),
        (3, 2, vec!["tilt"])
    );
    assert_eq!(
        said.rank_in_words(2),
        "with the pivot axes: rank 3 of 3 (the 2 errors' 2 and 1 of the 1 angles)"
    );
    assert!(said.in_words().starts_with(
        "With the pivot axes (second_class = true): rank 3 of 3; tilt identifiable ("
    ));
    assert!(said.in_words().ends_with(
        ". The pivot's roll is not among them: it moves the readings as the 2 errors do.\n"
    ));
}

#[test]
fn an_angle_the_layout_identifies_and_the_log_does_not_is_refused() {
    let (h, _) = designs();
    // The angle moves the readings as the first error does.
    let h3 = h.columns(0, 1).into_owned() * 2.0;
    let l = DVector::from_element(8, 0.1);
    let solver = Solver::<2, 1>::ols_named(&h, 1e-9, &TILT.errors);
    let mut est = solver.estimate(&l);
    let why = identify_axes(inputs(&h3, Some([true])), &solver, (&l, &sigma()), &mut est)
        .unwrap_err()
        .to_string();
    assert!(
        why.contains("log.csv")
            && why.contains("9 poses identify the 2 errors but not the pivot axes' tilt"),
        "{why}"
    );
    // Without a layout to compare, the angle is written as unidentified.
    let mut est = solver.estimate(&l);
    let fit = identify_axes(inputs(&h3, None), &solver, (&l, &sigma()), &mut est).unwrap();
    assert_eq!(fit.identifiable, [false]);
    assert!(fit.std_deg[0].is_nan() && fit.angles[0] == 0.0);
    assert!(fit
        .in_words(&TILT)
        .contains("tilt not identifiable (0 written)"));
}

/// The words of a singular axis and of angles that leave nothing out.
#[test]
fn the_words_follow_the_mechanisms_names() {
    const ONE: Unknowns<2, 1> = Unknowns {
        axes: "pivot axis",
        beyond: "",
        ..TILT
    };
    let (h, _) = designs();
    let h3 = h.columns(0, 1).into_owned();
    let l = DVector::from_element(8, 0.1);
    let solver = Solver::<2, 1>::ols_named(&h, 1e-9, &ONE.errors);
    let mut est = solver.estimate(&l);
    let mut inputs = inputs(&h3, Some([true]));
    inputs.unknowns = &ONE;
    let why = identify_axes(inputs, &solver, (&l, &sigma()), &mut est)
        .unwrap_err()
        .to_string();
    assert!(why.contains("but not the pivot axis's tilt"), "{why}");
    // An angle the layout does not identify either is not refused.
    let mut est = solver.estimate(&l);
    let mut inputs = super::tests::inputs(&h3, Some([false]));
    inputs.unknowns = &ONE;
    let fit = identify_axes(inputs, &solver, (&l, &sigma()), &mut est).unwrap();
    assert_eq!(
        fit.in_words(&ONE),
        "Pivot axis, identified with the 2 errors: tilt not identifiable (0 written)"
    );
    let said = AxesAnalysis::of(&solver, &fit.solver, &sigma(), &ONE);
    assert_eq!(
        said.in_words(),
        "With the pivot axis (second_class = true): rank 2 of 3; tilt NOT identifiable (0 % of its effect unlike any error's; σ n/a).\n"
    );
}

/// Two angles: each one's stated σ is its own diagonal of the joint
/// covariance, and an angle identified without a stated σ is written
/// without one.
#[test]
fn each_angle_states_its_own_uncertainty() {
    const TWO: Unknowns<2, 2> = Unknowns {
        errors: ["da", "db"],
        angles: ["tilt", "twist"],
        angles_are: "the angles",
        angle_is: "angle",
        angles_turn: "the pivot",
        axes: "pivot axes",
        beyond: "",
    };
    let (h, h3) = designs();
    let mut h32 = DMatrix::zeros(8, 2);
    h32.columns_mut(0, 1).copy_from(&h3);
    h32.set_column(
        1,
        &DVector::from_fn(8, |i, _| ((i * i) as f64 * 0.05).sin()),
    );
    let l = DVector::from_fn(8, |i, _| 0.01 * i as f64);
    let solver = Solver::<2, 1>::ols_named(&h, 1e-9, &TWO.errors);
    let mut est = solver.estimate(&l);
    let inputs = AxesInputs {
        h3: &h32,
        rank_tolerance: 1e-9,
        layout: None,
        unknowns: &TWO,
        poses: 9,
        file: Source::new("log.csv", &[]),
        config: "test.toml",
    };
    let mut fit = identify_axes(inputs, &solver, (&l, &sigma()), &mut est).unwrap();
    let mut full = DMatrix::zeros(8, 4);
    full.columns_mut(0, 2).copy_from(&h);
    full.columns_mut(2, 2).copy_from(&h32);
    let g = (full.transpose() * &full).try_inverse().unwrap() * full.transpose();
    let homed = (DMatrix::identity(8, 8) + DMatrix::from_element(8, 8, 1.0)) * 1e-4;
    let cov = &g * homed * g.transpose();
    let said = AxesAnalysis::of(&solver, &fit.solver, &sigma(), &TWO);
    for k in 0..2 {
        let want = cov[(2 + k, 2 + k)].sqrt();
        assert!((fit.std_deg[k] / want - 1.0).abs() < 1e-9, "{k}");
        let stated = said.predicted_std_deg[k].unwrap();
        assert!(
            (stated / want - 1.0).abs() < 1e-9,
            "{k}: {stated} vs {want}"
        );
    }
    fit.std_deg[1] = f64::NAN;
    let words = fit.in_words(&TWO);
    assert!(
        words.contains(&format!("twist = {:.5}°", fit.angles[1])),
        "{words}"
    );
    assert_eq!(words.matches('±').count(), 1, "{words}");
}
