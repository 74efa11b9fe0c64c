//! The checks' held-out variances against the dense route.

use super::*;
use crate::mechanism::tricept::Joints;
use crate::sensors::{observation_covariance, SensorCovariance};
use nalgebra::DMatrix;

/// The held-out variances through the factored Σ against the dense
/// route: A·Σ·Aᵀ with A the prediction error's map of every row and Σ
/// built entry by entry.
#[test]
fn held_out_variances_are_the_dense_sandwich() {
    // Datasheet encoders of unknown shape with eccentricity, a scale:
    // the curves correlate every pair of poses.
    let enc = crate::sensors::Axis {
        accuracy: 1e-5,
        shape: crate::sensors::structured::Shape::Unknown,
        n_harmonics: 4,
        eccentricity: 2e-6,
        period: std::f64::consts::TAU,
        interpolation: 2e-7,
        signal_period: 1e-3,
        readheads: 1,
        ..crate::sensors::Axis::default()
    };
    let scale = crate::sensors::Axis {
        accuracy: 3e-3,
        period: 400.0,
        interpolation: 1e-4,
        signal_period: 0.02,
        eccentricity: 0.0,
        ..enc
    };
    let cov = [
        SensorCovariance::of_axis(&enc, 3),
        SensorCovariance::of_axis(&enc, 3),
        SensorCovariance::of_axis(&scale, 3),
    ];
    assert!(!cov[0].terms().is_empty());
    let joints: Vec<Joints> = (0..12)
        .map(|k| Joints {
            psi_rad: 0.2 * (k as f64).sin(),
            theta_rad: 0.15 * (1.7 * k as f64).cos(),
            q4_mm: 700.0 + 30.0 * (0.9 * k as f64).sin(),
        })
        .collect();
    let f = ObservationCovariance::new(&cov, &joints);
    let dense = observation_covariance(&cov, &joints);
    let m = f.rows();
    let rh: Vec<usize> = (0..m).filter(|r| (r / 3) % 4 == 1).collect();
    let rk: Vec<usize> = (0..m).filter(|r| (r / 3) % 4 != 1).collect();
    let hh = DMatrix::from_fn(rh.len(), 15, |i, c| ((i * 5 + c * 11) as f64 * 0.13).cos());
    let op = DMatrix::from_fn(15, rk.len(), |a, c| ((a * 3 + c * 7) as f64 * 0.29).sin());
    let got = prediction_variances(&f, &hh, &op, &rh, &rk);
    let mut a = DMatrix::zeros(rh.len(), m);
    let g = -(&hh * &op);
    for (c, &r) in rk.iter().enumerate() {
        a.set_column(r, &g.column(c));
    }
    for (i, &r) in rh.iter().enumerate() {
        a[(i, r)] += 1.0;
    }
    let want = &a * &dense * a.transpose();
    for (i, v) in got.iter().enumerate() {
        assert!(
            (v - want[(i, i)]).abs() < 1e-9 * want[(i, i)].abs(),
            "{i}: {v} vs {}",
            want[(i, i)]
        );
    }
}

/// The checks of a fit with angles, at sizes no mechanism shares (2
/// errors, 2 readings a pose, 1 angle): over fits of readings with the
/// declared white noise, χ² averages its m − (P + A) degrees of freedom,
/// every held-out reading is predicted (R per pose) to one standard
/// deviation on average, and the angle spreads as its stated variance.
#[test]
fn the_checks_of_a_fit_with_angles_hold_at_other_sizes() {
    use crate::calibration::{identify_axes, AxesInputs, CalibrationOf, Folds};
    use crate::identify::{Constraints, Method};
    use crate::io::Source;
    use crate::mechanism::{Quantity, ReadingFact, Unknowns};
    use crate::sensors::{GradeReading, SensorModel};
    use nalgebra::{DVector, SVector};
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};
    static SLOTS: [ReadingFact; 2] = [
        ReadingFact::named("an encoder", Quantity::Angle),
        ReadingFact::named("a scale", Quantity::Length),
    ];
    const NAMES: Unknowns<2, 1> = Unknowns {
        errors: ["da", "db"],
        angles: ["tilt"],
        angles_are: "the tilt",
        angle_is: "tilt",
        angles_turn: "the pivot",
        axes: "pivot axis",
        beyond: "",
    };
    let sensors = SensorModel {
        slots: &SLOTS,
        encoder_arcsec: 2.0,
        scale_um: 4.0,
        samples: 1,
        reading: GradeReading::Sigma,
        structured: None,
    };
    let sd = sensors.reading_sigma();
    let n = 40;
    let rows = 2 * (n - 1);
    // Homed rows: pose j's two readings at rows 2(j − 1) and 2(j − 1) + 1.
    let h = DMatrix::from_fn(rows, 2, |r, c| {
        let (j, k) = ((r / 2 + 1) as f64, r % 2);
        let scale = [1e-3, 1.0][k];
        scale * ((0.3 + 0.2 * c as f64) * j).sin() * (1.0 + c as f64)
    });
    let h3 = DMatrix::from_fn(rows, 1, |r, _| {
        let (j, k) = ((r / 2 + 1) as f64, r % 2);
        [2e-3, 0.5][k] * (0.17 * j).cos() * (0.11 * j).sin()
    });
    let (e, tilt) = (SVector::from([0.3, -0.2]), 0.04);
    let folds = Folds {
        sensors: &sensors,
        method: Method::Ols,
        rank_tolerance: 1e-9,
    };
    let mut rng = rand::rngs::StdRng::seed_from_u64(11);
    let trials = 200;
    let (mut chi2, mut z2, mut spread) = (0.0, 0.0, Vec::new());
    let mut last = None;
    for _ in 0..trials {
        let noise: Vec<SVector<f64, 2>> = (0..n)
            .map(|_| {
                SVector::from_fn(|k, _| {
                    let z: f64 = StandardNormal.sample(&mut rng);
                    sd[k] * z
                })
            })
            .collect();
        let l = DVector::from_fn(rows, |r, _| {
            let (j, k) = (r / 2 + 1, r % 2);
            (&h * e)[r] + h3[(r, 0)] * tilt + noise[j][k] - noise[0][k]
        });
        let solver = Method::Ols
            .solver(
                (&sensors, &noise),
                &h,
                1e-9,
                (&Constraints::default(), &NAMES.errors),
            )
            .unwrap();
        let stated = ObservationCovariance::new(&sensors.stated_covariances(), &noise);
        let mut estimate = solver.estimate(&l);
        let inputs = AxesInputs {
            h3: &h3,
            rank_tolerance: 1e-9,
            layout: Some([true]),
            unknowns: &NAMES,
            poses: n,
            file: Source::new("log.csv", &[]),
            config: "test.toml",
        };
        let axes = identify_axes(inputs, &solver, (&l, &stated), &mut estimate).unwrap();
        let resid = &l - &h * estimate.values - &h3 * axes.angles;
        let cal = CalibrationOf::<(), SVector<f64, 2>, 2, 2, 1> {
            estimate,
            solver,
            poses: (),
            axes: Some(axes),
            unknowns: &NAMES,
            stated: stated.clone(),
            measured: noise,
            covariance: None,
            groups: Vec::new(),
        };
        let f = FitInputs {
            sigma: stated,
            resid,
        };
        let m = misfit_of(&cal, &f).unwrap();
        assert_eq!(m.dof, rows - 3);
        chi2 += m.chi2 / m.dof as f64;
        let held = held_out_of(&folds, &cal, &f).unwrap();
        assert_eq!((held.rows, held.folds_skipped), (rows, 0));
        assert!(held.max_abs_z >= held.rms_z && held.worst_line >= 3);
        z2 += held.rms_z * held.rms_z;
        spread.push(cal.axes.as_ref().unwrap().angles[0] - tilt);
        last = Some(cal);
    }
    let t = trials as f64;
    assert!((chi2 / t - 1.0).abs() < 0.05, "mean χ²/dof {}", chi2 / t);
    assert!((z2 / t - 1.0).abs() < 0.1, "mean held-out z² {}", z2 / t);
    let cal = last.unwrap();
    let c = estimate_covariance(&cal);
    assert_eq!(c.shape(), (3, 3));
    let var = spread.iter().map(|d| d * d).sum::<f64>() / t;
    assert!(
        (var / c[(2, 2)] - 1.0).abs() < 0.25,
        "{var:e} vs {:e}",
        c[(2, 2)]
    );
    let sd_tilt = cal.axes.as_ref().unwrap().std_deg[0];
    assert!((sd_tilt / c[(2, 2)].sqrt() - 1.0).abs() < 1e-9);
    // What compensate refuses, by the angle's name, and the possessive of
    // a singular axis.
    let mut wide = cal.clone();
    wide.axes.as_mut().unwrap().std_deg[0] = 0.2;
    assert_eq!(loose(&wide), vec!["tilt ± 0.2000°".to_string()]);
    // An angle the readings do not identify is written as 0, not refused.
    let axes = wide.axes.as_mut().unwrap();
    axes.identifiable = [false];
    axes.std_deg[0] = f64::NAN;
    assert!(loose(&wide).is_empty());
}

/// A log whose poses identify fewer combinations than the layout's is
/// refused in one sentence: its rows, its rank, the layout's and how many
/// more poses (R rows each) at the least; as many as the layout's pass.
#[test]
fn a_log_below_its_layouts_rank_is_refused() {
    use crate::identify::Solver;
    use crate::io::Source;
    // Four rows of two readings' poses, three errors, rank 2.
    let h = DMatrix::from_fn(4, 3, |i, c| match c {
        2 => 0.0,
        _ => ((i * 2 + c) as f64 * 0.7).sin(),
    });
    let solver = Solver::<3, 2>::ols_named(&h, 1e-9, &["a", "b", "c"]);
    assert_eq!(solver.analysis.rank, 2);
    let file = Source::new("log.csv", &[]);
    assert!(refuse_below_layout(&solver, Some(2), 3, file).is_ok());
    assert!(refuse_below_layout(&solver, Some(1), 3, file).is_ok());
    assert!(refuse_below_layout(&solver, None, 3, file).is_ok());
    let why = refuse_below_layout(&solver, Some(9), 3, file)
        .unwrap_err()
        .to_string();
    assert!(
        why.contains("log.csv")
            && why.contains("3 poses (4 observation rows) identify 2 of the 9 error combinations")
            && why.contains("at least 3 more pose(s)"),
        "{why}"
    );
}
