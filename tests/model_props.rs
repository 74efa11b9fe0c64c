//! Property tests of the maths against the exact model (docs/method.md §4, issue #2):
//! the analytic error Jacobian J = M⁻¹·D against central finite differences
//! of the exact forward kinematics, FK∘IK = identity, and identification
//! recovering known errors from exact (noise-free) readings.

use nalgebra::{DVector, Vector3};
use proptest::prelude::*;
use proptest::test_runner::RngSeed;
use rand::SeedableRng;
use tricept_calib::identify::tricept::simulate_readings;
use tricept_calib::identify::tricept::{design_matrix, identify, LinearSolver};
use tricept_calib::identify::{IdentifyOptions, Weighting};
use tricept_calib::mechanism::tricept::jacobian::jacobian_at;
use tricept_calib::mechanism::tricept::kinematics::platform_position;
use tricept_calib::mechanism::tricept::NominalPoses;
use tricept_calib::mechanism::tricept::{ErrorVector, Geometry, Machine, N_PARAMS};
use tricept_calib::metrics::mu;
use tricept_calib::sensors::observation_vector;

/// A random but sensible layout: B1B2 parallel to y (β1 = −β, β2 = β),
/// B3 anywhere on the far side, the platform rotated by an arbitrary angle.
fn layout() -> impl Strategy<Value = Geometry> {
    (
        60.0..150.0f64,
        200.0..400.0f64,
        30.0..80.0f64,
        150.0..210.0f64,
        -40.0..40.0f64,
        -20.0..20.0f64,
    )
        .prop_map(|(a, b, beta, beta3, rot, skew)| {
            Geometry::from_circles(
                a,
                b,
                [-beta, beta, beta3],
                [-beta + rot, beta + rot + skew, beta3 + rot],
            )
        })
}

/// A target inside the paper's workspace cylinder.
fn target() -> impl Strategy<Value = Vector3<f64>> {
    (0.0..1.0f64, 0.0..360.0f64, 650.0..850.0f64).prop_map(|(f, t, z)| {
        let r = 400.0 * f.sqrt();
        let t = t.to_radians();
        Vector3::new(r * t.cos(), r * t.sin(), z)
    })
}

fn errors(bound: f64) -> impl Strategy<Value = ErrorVector> {
    prop::collection::vec(-bound..bound, N_PARAMS).prop_map(|v| ErrorVector::from_row_slice(&v))
}

/// δ(Δε): passive joints of the erroneous machine at the nominal commands for
/// `r`, minus the nominal joints — exact FK, no linearisation.
fn delta(g: &Geometry, r: &Vector3<f64>, e: &ErrorVector) -> Vector3<f64> {
    let pose = Machine::nominal(g).inverse(r).unwrap();
    let truth = Machine::with_errors(g, e);
    truth
        .forward(&pose.legs_mm, &pose.joints)
        .unwrap()
        .as_vector()
        - pose.joints.as_vector()
}

proptest! {
    // A fixed seed: the cases are the same on every run and every machine, so
    // a pass here is a pass in CI (a random seed once drew, in CI, errors
    // whose single linearisation fell just outside a fixed bound).
    #![proptest_config(ProptestConfig {
        cases: 64,
        rng_seed: RngSeed::Fixed(0x7152_1c3e),
        ..ProptestConfig::default()
    })]

    #[test]
    fn jacobian_matches_finite_differences(g in layout(), r in target()) {
        let pose = Machine::nominal(&g).inverse(&r).unwrap();
        let j = jacobian_at(&pose).unwrap();
        let scale = j.norm();
        // Central differences with one Richardson step: truncation error
        // O(h⁴), so what remains is the model's, not the difference's.
        let central = |k: usize, h: f64| {
            let mut e = ErrorVector::zeros();
            e[k] = h;
            (delta(&g, &r, &e) - delta(&g, &r, &(-e))) / (2.0 * h)
        };
        let h = 2e-3;
        for k in 0..N_PARAMS {
            let fd = (4.0 * central(k, h / 2.0) - central(k, h)) / 3.0;
            let col = j.column(k).into_owned();
            let rel = (fd - col).norm() / col.norm().max(1e-3 * scale);
            prop_assert!(rel <= 1e-6, "column {} rel {:e}: fd {:?} J {:?}", k, rel, fd, col);
        }
    }

    #[test]
    fn forward_inverts_inverse(g in layout(), r in target(), e in errors(0.5)) {
        let truth = Machine::with_errors(&g, &e);
        let q = truth.commands(&r).unwrap();
        let guess = Machine::nominal(&g).inverse(&r).unwrap().joints;
        let j = truth.forward(&q, &guess).unwrap();
        let err = (platform_position(&j) - r).norm();
        prop_assert!(err <= 1e-9, "round trip error {:e} mm", err);
    }

    #[test]
    fn identification_recovers_errors_from_exact_readings(e in errors(0.5)) {
        // Full-rank layout (A3 off the x' axis): every error is identifiable.
        let g = Geometry::from_circles(100.0, 288.7, [-60.0, 60.0, 180.0], [-30.0, 90.0, 210.0]);
        let nominal = Machine::nominal(&g);
        let poses = NominalPoses::new(&nominal, &tricept_calib::mechanism::tricept::poses::paper_targets()).unwrap();
        let h = design_matrix(&nominal, &poses).unwrap();
        let w = DVector::from_element(h.nrows(), 1.0);
        let solver = LinearSolver::new(&h, &Weighting::Rows(w.clone()), 1e-9);
        let observe = |e: &ErrorVector| {
            let truth = Machine::with_errors(&g, e);
            let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(0);
            let readings = simulate_readings(&poses, &truth, None, &mut rng).unwrap();
            let joints: Vec<_> = readings.iter().map(|r| r.joints.as_vector()).collect();
            observation_vector(&poses.joints, &joints)
        };
        let l = observe(&e);
        let one = identify(&g, &poses, &solver, &l, &IdentifyOptions::default()).unwrap().0;
        prop_assert!(one.identifiable.iter().all(|&b| b));
        // One linearisation leaves an error of second order in the errors:
        // halving them quarters it (3,000 uniform draws: ratio 3.97-4.03), and
        // it stays below 0.1·max|e|² (those draws: at most 0.039·max|e|²).
        let r = mu(&e, &one.values);
        let half = e / 2.0;
        let r_half = mu(&half, &identify(&g, &poses, &solver, &observe(&half), &IdentifyOptions::default()).unwrap().0.values);
        if e.amax() > 0.05 {
            prop_assert!((3.8..4.2).contains(&(r / r_half)), "halving the errors divides the residual by {} (second order: 4)", r / r_half);
        }
        prop_assert!(r <= 0.1 * e.amax().powi(2), "single linearisation mu {} for max|e| {}", r, e.amax());
        let opts = IdentifyOptions { iterations: 20, tolerance_mm: 1e-10, ..IdentifyOptions::default() };
        let gn = identify(&g, &poses, &solver, &l, &opts).unwrap().0;
        prop_assert!(gn.termination.converged());
        prop_assert!(mu(&e, &gn.values) < 1e-8, "Gauss-Newton mu {:e}", mu(&e, &gn.values));
    }
}

#[test]
fn default_layout_cannot_see_dya3() {
    // With β3 = α3 = 180°, R·ey' is perpendicular to leg 3 in every pose.
    let g = Geometry::paper();
    let nominal = Machine::nominal(&g);
    let poses = NominalPoses::new(
        &nominal,
        &tricept_calib::mechanism::tricept::poses::paper_targets(),
    )
    .unwrap();
    let h = design_matrix(&nominal, &poses).unwrap();
    assert!(
        h.column(11).amax() < 1e-12,
        "dyA3 column {}",
        h.column(11).amax()
    );
    let a = tricept_calib::identify::analyse_named(
        &h,
        1e-9,
        &tricept_calib::mechanism::tricept::PARAM_NAMES,
    );
    assert_eq!(a.rank, 14);
    assert_eq!(a.unidentifiable, vec!["dyA3".to_string()]);
}
