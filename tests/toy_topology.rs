//! A second topology, outside the library: a planar two-limb mechanism with
//! one passive encoder, implementing only `Topology` and `Kinematic`, run
//! through the library's identification (`identify_poses`, the Gauss–Newton
//! `identify` uses; the one identify of any mechanism, `identify::general`,
//! through `Homed`), the study kernel of any mechanism
//! (`montecarlo::general::kernel`, which runs any mechanism through the
//! Tricept's study kernel) and that kernel directly, which runs any
//! `Kinematic` topology (`montecarlo::kinematic::KinematicStudy`).
//!
//! The toy: a passive link of length L turns about the origin O (encoder
//! angle φ) and carries the tool point T = L·(cos φ, sin φ, 0); an active
//! prismatic leg joins the base pivot B = (b, 0, 0) to T and is commanded to
//! length q. Its errors are ΔL, Δb and the leg's offset Δq (the leg is
//! q + Δq long); the frame gauge puts B on the x axis (ΔyB fixed). Closure:
//! (q + Δq)² = L² + b² − 2·L·b·cos φ.

use nalgebra::{DVector, SMatrix, SVector, Vector3};
use tricept_calib::config::general::{Estimator, HomedConfig, Sensor, Spec, StudyConfig};
use tricept_calib::error::KinematicsError;
use tricept_calib::identify::general::{self, Holds};
use tricept_calib::identify::{design_of, identify_poses, IdentifyOptions, Solver};
use tricept_calib::mechanism::tricept::Workspace;
use tricept_calib::mechanism::{
    AxisAngles, GeometryRule, Homed, Kinematic, LogRow, Mechanism, PoseSet, Quantity, Reach,
    ReadingFact, Topology, Unknowns,
};
use tricept_calib::montecarlo::general::kernel::{homed_sizes, run_kernel};
use tricept_calib::montecarlo::general::Judged;
use tricept_calib::sensors::{Axis, ARCSEC_PER_RAD};

const P: usize = 3;
const R: usize = 1;

#[derive(Debug)]
struct Toy;

#[derive(Debug, Clone, Copy)]
struct Layout {
    l: f64,
    b: f64,
}

#[derive(Debug, Clone, Copy)]
struct ToyMachine {
    l: f64,
    b: f64,
    dq: f64,
}

fn unreachable(r: &Vector3<f64>, reason: &str) -> KinematicsError {
    KinematicsError::Unreachable {
        x: r.x,
        y: r.y,
        z: r.z,
        reason: reason.into(),
    }
}

/// The toy's one reading: the link's angle.
const PHI: ReadingFact = ReadingFact {
    symbol: "φ",
    ascii: "phi",
    column: "phi_deg",
    quantity: Quantity::Angle,
    sensor: "φ encoder",
    sensor_ascii: "phi encoder",
    sensor_key: "phi_encoder",
    plausible: 2.0,
};

impl Topology for Toy {
    const NAME: &'static str = "toy";
    const ERROR_NAMES: &'static [&'static str] = &["dL", "db", "dq"];
    const GAUGE_FIXED: &'static [&'static str] = &["dyB"];
    const READINGS: &'static [ReadingFact] = &[PHI];
    const LEGS: usize = 1;
    const CONVENTION: &'static str = "O is the origin and B lies on its x axis (dyB = 0)";
    type Layout = Layout;
    type Machine = ToyMachine;
    type Workspace = Workspace;

    fn check_layout(g: &Layout) -> Result<(), GeometryRule> {
        if !(g.l > 0.0 && g.b > 0.0) || (g.l - g.b).abs() < 1e-6 * g.l {
            return Err(GeometryRule {
                base: true,
                why: "needs L > 0, b > 0 and b ≠ L (else T can sit on B)".into(),
            });
        }
        Ok(())
    }

    fn check_pose(m: &ToyMachine, r: &Vector3<f64>, _max_tilt_deg: f64) -> Result<(), String> {
        let x = Toy::command(m, r).map_err(|e| e.to_string())?.1;
        if x[0].sin().abs() < 0.1 {
            return Err("the leg is (nearly) along the link: singular".into());
        }
        Ok(())
    }

    /// No linear scale: the toy's one reading is an angle.
    fn length_travel(_ws: &Workspace) -> f64 {
        0.0
    }
}

impl Kinematic<P, R> for Toy {
    /// The leg's length command (mm).
    type Command = [f64; 1];

    fn machine(g: &Layout, e: &SVector<f64, P>) -> ToyMachine {
        ToyMachine {
            l: g.l + e[0],
            b: g.b + e[1],
            dq: e[2],
        }
    }

    fn command(
        m: &ToyMachine,
        r: &Vector3<f64>,
    ) -> Result<([f64; 1], SVector<f64, R>), KinematicsError> {
        if r.z.abs() > 1e-9 || (r.xy().norm() - m.l).abs() > 1e-6 * m.l {
            return Err(unreachable(
                r,
                "the tool point lies on the link's circle in z = 0",
            ));
        }
        let phi = r.y.atan2(r.x);
        let leg = (r - Vector3::new(m.b, 0.0, 0.0)).norm();
        Ok(([leg - m.dq], SVector::from([phi])))
    }

    fn readings(
        m: &ToyMachine,
        q: &[f64; 1],
        guess: &SVector<f64, R>,
    ) -> Result<SVector<f64, R>, KinematicsError> {
        let s = q[0] + m.dq;
        let c = (m.l * m.l + m.b * m.b - s * s) / (2.0 * m.l * m.b);
        if c.abs() > 1.0 {
            let r = Vector3::new(f64::NAN, f64::NAN, 0.0);
            return Err(unreachable(&r, "the leg cannot close the loop"));
        }
        Ok(SVector::from([c.acos().copysign(guess[0])]))
    }

    fn error_jacobian(
        m: &ToyMachine,
        x: &SVector<f64, R>,
    ) -> Result<SMatrix<f64, R, P>, KinematicsError> {
        // F = L² + b² − 2Lb·cos φ − s² = 0 differentiated implicitly.
        let (sin, cos) = x[0].sin_cos();
        let s = (m.l * m.l + m.b * m.b - 2.0 * m.l * m.b * cos).sqrt();
        let f_phi = 2.0 * m.l * m.b * sin;
        Ok(SMatrix::from_row_slice(&[
            -(2.0 * m.l - 2.0 * m.b * cos) / f_phi,
            -(2.0 * m.b - 2.0 * m.l * cos) / f_phi,
            2.0 * s / f_phi,
        ]))
    }

    fn position(m: &ToyMachine, x: &SVector<f64, R>) -> Vector3<f64> {
        Vector3::new(m.l * x[0].cos(), m.l * x[0].sin(), 0.0)
    }
}

const LAYOUT: Layout = Layout { l: 400.0, b: 250.0 };

/// Targets on the link's circle, φ from 20° to 160° (the reference first).
fn targets(n: usize) -> Vec<Vector3<f64>> {
    (0..n)
        .map(|k| {
            let phi = (20.0 + 140.0 * k as f64 / (n - 1) as f64).to_radians();
            Vector3::new(LAYOUT.l * phi.cos(), LAYOUT.l * phi.sin(), 0.0)
        })
        .collect()
}

fn nominal() -> ToyMachine {
    Toy::machine(&LAYOUT, &SVector::zeros())
}

fn ols_solver(poses: &PoseSet<Toy, P, R>) -> Solver<P, R> {
    let h = design_of::<Toy, P, R>(&nominal(), &poses.nominal).unwrap();
    Solver::ols_named(&h, 1e-9, Toy::ERROR_NAMES)
}

#[test]
fn the_toys_jacobian_is_its_forward_kinematics_differentiated() {
    let truth = SVector::<f64, P>::new(0.3, -0.2, 0.15);
    let m = Toy::machine(&LAYOUT, &truth);
    for r in targets(7) {
        let (q, guess) = Toy::command(&nominal(), &r).unwrap();
        let x = Toy::readings(&m, &q, &guess).unwrap();
        let j = Toy::error_jacobian(&m, &x).unwrap();
        for c in 0..P {
            let step = 1e-5;
            let mut e = truth;
            e[c] += step;
            let up = Toy::readings(&Toy::machine(&LAYOUT, &e), &q, &guess).unwrap();
            e[c] -= 2.0 * step;
            let down = Toy::readings(&Toy::machine(&LAYOUT, &e), &q, &guess).unwrap();
            let fd = (up[0] - down[0]) / (2.0 * step);
            assert!(
                (fd - j[(0, c)]).abs() < 1e-7 * j[(0, c)].abs().max(1e-3),
                "∂φ/∂{}: {fd} by differences, {} by the Jacobian",
                Toy::ERROR_NAMES[c],
                j[(0, c)]
            );
        }
        // The nominal machine reads what its inverse kinematics said.
        let back = Toy::readings(&nominal(), &q, &guess).unwrap();
        assert!((back - guess).amax() < 1e-12);
    }
}

#[test]
fn identify_recovers_a_toy_machine_from_its_exact_readings() {
    let poses = PoseSet::<Toy, P, R>::new(&nominal(), &targets(12)).unwrap();
    let solver = ols_solver(&poses);
    assert_eq!(
        solver.analysis.rank, P,
        "every error of the toy is identifiable"
    );
    assert_eq!(solver.analysis.parameters, P);
    let truth = SVector::<f64, P>::new(0.3, -0.2, 0.15);
    let mut x = vec![SVector::zeros(); poses.len()];
    poses
        .actual_into(&Toy::machine(&LAYOUT, &truth), &mut x)
        .unwrap();
    let mut l = DVector::zeros(poses.rows());
    poses.observation_into(&x, l.as_mut_slice());
    let opts = |iterations| IdentifyOptions {
        iterations,
        tolerance_mm: 1e-11,
        ..IdentifyOptions::default()
    };
    let (one, _) = identify_poses(&LAYOUT, &poses, &solver, &l, &opts(1)).unwrap();
    let (full, _) = identify_poses(&LAYOUT, &poses, &solver, &l, &opts(30)).unwrap();
    // One linearisation leaves the second-order part; Gauss–Newton removes it.
    let first = (one.values - truth).amax();
    let iterated = (full.values - truth).amax();
    assert!(
        first > 1e-6 && first < 1e-2,
        "one linearisation: {first:e} mm"
    );
    assert!(iterated < 1e-9, "Gauss–Newton: {iterated:e} mm");
    assert!(full.termination.converged() && full.iterations > 2);
    assert!(full.residual_rms < 1e-12);

    // The one identify every mechanism runs through (the toy's errors and
    // its encoder's zero, from absolute readings) finds the same machine,
    // and the same zero the homing absorbs.
    let toy = Homed::<Toy, P, R>::new(&LAYOUT);
    let mut e = truth.as_slice().to_vec();
    e.push(0.04);
    let read = general::predict(&toy, &e, &poses.targets).unwrap();
    for (k, xk) in x.iter().enumerate() {
        assert!((read[k] - (xk[0].to_degrees() + 0.04)).abs() < 1e-12);
    }
    let id = general::identify(&toy, &poses.targets, &read, 30, &[], &Holds::default()).unwrap();
    let miss = id
        .errors
        .iter()
        .zip(&e)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(miss < 1e-9, "{miss:e}");
    assert!((id.errors[..P].iter().zip(full.values.iter())).all(|(a, b)| (a - b).abs() < 1e-9));
    // Its accuracy is the tool point's, which a link error moves and the
    // encoder's zero does not.
    let s = toy
        .sensitivity(&poses.targets[3], &Vector3::zeros())
        .unwrap();
    // dT/dL at a fixed leg: the link grows and turns (dφ/dL, the Jacobian's).
    let phi = poses.nominal[3][0];
    let turn = Toy::error_jacobian(&nominal(), &poses.nominal[3]).unwrap()[(0, 0)];
    let want = [
        phi.cos() - LAYOUT.l * phi.sin() * turn,
        phi.sin() + LAYOUT.l * phi.cos() * turn,
    ];
    assert!((s[(0, 0)] - want[0]).abs() < 1e-6 && (s[(1, 0)] - want[1]).abs() < 1e-6);
    assert_eq!(s.column(P).amax(), 0.0);
}

/// A study of the toy through the one study kernel: one encoder of jitter
/// σ and no curve, `estimator`, machines within ±`bound` (mm, and degrees
/// for the encoder's zero).
fn toy_spec(
    targets: &[Vector3<f64>],
    sigma_arcsec: f64,
    bound: f64,
    estimator: Estimator,
    trials: u64,
) -> Spec<Vector3<f64>, ()> {
    Spec {
        sensors: vec![Sensor {
            name: "jitter".into(),
            price: None,
            axis: Axis {
                noise: sigma_arcsec / ARCSEC_PER_RAD,
                period: std::f64::consts::TAU,
                readheads: 1,
                ..Axis::default()
            },
            truth: None,
        }],
        variants: vec![()],
        pose_counts: vec![targets.len()],
        estimators: vec![estimator],
        trials,
        seed: 5,
        length_bound_mm: bound,
        zero_bound_deg: bound,
        samples: 1,
        workspace: targets.to_vec(),
        tool_mm: Vector3::zeros(),
        iterations: 10,
        fixed: Vec::new(),
        prior_std_mm: None,
        prior_std_deg: None,
    }
}

/// The toy's study through the one study kernel (`run_kernel`, the toy's
/// sizes by `homed_sizes`): trial by trial, each combination's judgements.
fn toy_study(
    toy: &Homed<'_, Toy, P, R>,
    targets: &[Vector3<f64>],
    spec: &Spec<Vector3<f64>, ()>,
    threads: usize,
) -> Vec<Vec<Judged>> {
    run_kernel(toy, targets, spec, threads, homed_sizes::<Toy, P, R>)
        .unwrap()
        .1
}

/// Through the kernel, a study of machines small enough for the linear
/// model to be exact spreads as least squares' covariance says: judged at
/// one workspace target, the tool point's error after compensation is
/// G·d, d the estimate's error, so its mean square over the machines is
/// tr(G·Σ·Gᵀ) with Σ = σ²(HᵀH)⁻¹ over the three errors and the encoder's
/// zero (homing it at the reference pose is least squares with the zero
/// unknown), G the target's sensitivity. Checked at each of three
/// targets, to 5 of the mean square's standard errors (√(2Σλ²/n)/Σλ of
/// it, λ the eigenvalues of G·Σ·Gᵀ: 2.2 % at 4,000 machines; the study gives
/// 1.004–1.005 of it).
#[test]
fn a_small_toy_sweep_spreads_as_its_covariance_predicts() {
    let targets = targets(9);
    let toy = Homed::<Toy, P, R>::new(&LAYOUT);
    let h = toy.design(&[0.0; P + R], &targets).unwrap();
    let sigma_deg = 5.0 / 3600.0;
    let cov = (h.transpose() * &h).try_inverse().unwrap() * sigma_deg * sigma_deg;
    for at in [1, 4, 7] {
        let mut spec = toy_spec(&targets, 5.0, 1e-4, Estimator::Linear, 4000);
        spec.workspace = vec![targets[at]];
        let out = toy_study(&toy, &targets, &spec, 2);
        let g = toy.sensitivity(&targets[at], &Vector3::zeros()).unwrap();
        let gsg = &g * &cov * g.transpose();
        let lambda = gsg.clone().symmetric_eigen().eigenvalues;
        let predicted = gsg.trace();
        let n = spec.trials as f64;
        let se = (2.0 * lambda.iter().map(|l| l * l).sum::<f64>() / n).sqrt() / predicted;
        let mean = out.iter().map(|t| t[0].position_after.powi(2)).sum::<f64>() / n;
        assert!(
            (mean / predicted - 1.0).abs() < 5.0 * se,
            "target {at}: mean square {mean:e} mm², predicted {predicted:e} (± {se:.3} of it)"
        );
    }
}

#[test]
fn a_toy_sweep_is_the_same_whatever_the_thread_count() {
    let targets = targets(6);
    let toy = Homed::<Toy, P, R>::new(&LAYOUT);
    let spec = toy_spec(&targets, 2.0, 0.5, Estimator::GaussNewton, 300);
    let bits = |threads| -> Vec<u64> {
        toy_study(&toy, &targets, &spec, threads)
            .iter()
            .flatten()
            .flat_map(|j| [j.position_before.to_bits(), j.position_after.to_bits()])
            .collect()
    };
    let one = bits(1);
    assert_eq!(one, bits(3));
    // Gauss–Newton removed the second-order part of half a millimetre of
    // error: the tool point ends where the noise alone leaves it (the same
    // study of machines too small to have a second-order part), which one
    // linearisation does not reach.
    let spec_of = |bound, estimator| toy_spec(&targets, 2.0, bound, estimator, 300);
    let after = |s: &Spec<Vector3<f64>, ()>| -> (f64, f64) {
        let out = toy_study(&toy, &targets, s, 2);
        let mean = |f: &dyn Fn(&Judged) -> f64| out.iter().map(|t| f(&t[0])).sum::<f64>() / 300.0;
        (mean(&|j| j.position_after), mean(&|j| j.position_before))
    };
    let (gn, before) = after(&spec);
    let (lin, _) = after(&spec_of(0.5, Estimator::Linear));
    // And in one study of both estimators, each row is its own estimator's.
    let mut both = spec.clone();
    both.estimators = vec![Estimator::GaussNewton, Estimator::Linear];
    let out = toy_study(&toy, &targets, &both, 2);
    let mean = |c: usize| out.iter().map(|t| t[c].position_after).sum::<f64>() / 300.0;
    assert_eq!((mean(0), mean(1)), (gn, lin));
    let (noise, _) = after(&spec_of(1e-4, Estimator::GaussNewton));
    eprintln!("mean position after: Gauss–Newton {gn} mm, linear {lin} mm, noise alone {noise} mm, before {before} mm");
    assert!(
        (gn / noise - 1.0).abs() < 0.05,
        "{gn} mm, the noise alone {noise} mm"
    );
    assert!(lin > 3.0 * gn, "linear {lin} mm, Gauss–Newton {gn} mm");
}

#[test]
fn the_toy_states_its_own_facts() {
    assert!(Toy::check_layout(&LAYOUT).is_ok());
    let bad = Layout { l: 250.0, b: 250.0 };
    assert!(Toy::check_layout(&bad).unwrap_err().why.contains("b ≠ L"));
    let m = nominal();
    assert!(Toy::check_pose(&m, &targets(5)[2], 30.0).is_ok());
    let off = Vector3::new(100.0, 100.0, 0.0);
    assert!(Toy::check_pose(&m, &off, 30.0)
        .unwrap_err()
        .contains("circle"));
    let flat = Vector3::new(LAYOUT.l, 0.0, 0.0);
    assert!(Toy::check_pose(&m, &flat, 30.0)
        .unwrap_err()
        .contains("singular"));
    // A pose set the nominal machine cannot reach names the pose.
    let mut t = targets(4);
    t[2] = off;
    let e = PoseSet::<Toy, P, R>::new(&m, &t).unwrap_err();
    assert_eq!(e.index, 2);
}

/// The toy as a config would give it: its machine, its poses, a
/// simulated machine, 5″ readings.
type ToyConfig = HomedConfig<Homed<'static, Toy, P, R>>;

fn toy_config(
    poses: Vec<Vector3<f64>>,
    errors: Option<Vec<f64>>,
    study: Option<StudyConfig<Vector3<f64>, ()>>,
) -> ToyConfig {
    HomedConfig {
        source: "the toy".into(),
        machine: Homed::new(&LAYOUT),
        poses,
        errors,
        sigma: (vec![5.0 / 3600.0], "toy.sigma_arcsec"),
        holds: Holds::default(),
        study,
    }
}

/// The commands of any mechanism run the toy: simulate writes its
/// readings by exact forward kinematics, identifiability finds its four
/// errors (three and the encoder's zero) identified, and identify reads
/// the file back to the simulated machine, states its σ-scaled checks and
/// names it in identifiability.json.
#[test]
fn the_commands_of_any_mechanism_run_the_toy() {
    use tricept_calib::cli::commands::general::{run_identify, run_simulate};
    let dir = tempfile::tempdir().unwrap();
    let truth = vec![0.3, -0.2, 0.15, 0.04];
    let cfg = toy_config(targets(12), Some(truth.clone()), None);
    let readings = dir.path().join("readings.csv");
    run_simulate(&cfg, 1, true, &readings).unwrap();
    let text = std::fs::read_to_string(&readings).unwrap();
    assert!(text.starts_with("x_mm,y_mm,z_mm,phi_deg\n"), "{text}");
    assert_eq!(text.lines().count(), 13);
    let out = dir.path().join("fit");
    run_identify(&cfg, &readings, &out).unwrap();
    let identified = std::fs::read_to_string(out.join("identified.csv")).unwrap();
    let rows: Vec<&str> = identified.lines().collect();
    assert_eq!(
        rows[0],
        "parameter,estimate_mm,std_uncertainty_mm,estimate_deg,std_uncertainty_deg,source"
    );
    for (row, (name, want)) in rows[1..]
        .iter()
        .zip(["dL", "db", "dq", "zero_phi"].iter().zip(&truth))
    {
        let cells: Vec<&str> = row.split(',').collect();
        assert_eq!(cells[0], *name);
        let got: f64 = if *name == "zero_phi" {
            cells[3]
        } else {
            cells[1]
        }
        .parse()
        .unwrap();
        assert!((got - want).abs() < 1e-8, "{name}: {got} vs {want}");
    }
    let fit: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("identifiability.json")).unwrap())
            .unwrap();
    assert_eq!(fit["mechanism"], "toy");
    assert_eq!(fit["rank_after_convention"], 4);
    assert_eq!(fit["sigma_arcsec"].as_f64().unwrap(), 5.0);
    // Noise-free readings fit far better than 5″: the misfit test passes
    // (χ² small), and the held-out check predicts the left-out poses.
    assert_eq!(fit["checks"]["misfit"]["passed"], true);
    assert!(
        fit["checks"]["predicted_accuracy"]["position_mm"]["p95"]
            .as_f64()
            .unwrap()
            > 0.0
    );
    assert!(fit["checks"]["predicted_accuracy"]
        .get("orientation_arcsec")
        .is_none());
}

/// The sweep of any mechanism runs the toy's study: two priced encoders,
/// the cheaper too coarse for the target; the verdict buys the finer one,
/// names the toy and its readings, and judges position alone (no
/// orientation in its sentence, summary.csv or report).
#[test]
fn the_sweep_of_any_mechanism_prices_the_toys_encoder() {
    use tricept_calib::cli::commands::general::run_sweep;
    let targets = targets(9);
    let mut spec = toy_spec(&targets, 1.0, 0.2, Estimator::Linear, 400);
    let coarse = Sensor {
        name: "coarse".into(),
        price: Some(100.0),
        axis: Axis {
            noise: 60.0 / ARCSEC_PER_RAD,
            ..spec.sensors[0].axis
        },
        truth: None,
    };
    spec.sensors[0].name = "fine".into();
    spec.sensors[0].price = Some(300.0);
    spec.sensors.insert(0, coarse);
    let cfg = toy_config(
        targets.clone(),
        None,
        Some(StudyConfig {
            spec,
            until_decided: None,
            what_ifs: Vec::new(),
            position_mm: Some(0.2),
            orientation_arcsec: None,
        }),
    );
    let dir = tempfile::tempdir().unwrap();
    run_sweep(
        &cfg,
        dir.path(),
        (2, homed_sizes::<Toy, P, R>),
        Default::default(),
    )
    .unwrap();
    let verdict: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("verdict.json")).unwrap())
            .unwrap();
    assert_eq!(verdict["mechanism"], "toy");
    assert_eq!(verdict["chosen"]["encoder"], "fine");
    assert_eq!(verdict["chosen"]["encoders_fitted"], 1);
    assert!(verdict["chosen"]["orientation_p95_arcsec"].is_null());
    let sentence = verdict["verdict"].as_str().unwrap();
    assert!(
        sentence.starts_with(
            "Buy 1 × fine (one per passive joint; total price 300, the catalogue's), calibrate"
        ),
        "{sentence}"
    );
    assert!(!sentence.contains('″'), "{sentence}");
    let summary = std::fs::read_to_string(dir.path().join("summary.csv")).unwrap();
    let rows: Vec<Vec<&str>> = summary.lines().map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 3);
    // The coarse encoder misses, the fine one meets; orientation empty.
    assert_eq!((rows[1][0], rows[1][14]), ("coarse", "false"));
    assert_eq!((rows[2][0], rows[2][14]), ("fine", "true"));
    assert_eq!(&rows[2][11..14], &["", "", ""]);
    let page = std::fs::read_to_string(dir.path().join("report.html")).unwrap();
    assert!(page.contains("Which encoder to buy for this toy"));
    assert!(!page.contains("orientation p95"));
}

/// From noisy readings (5″, 40 poses) the commands of any mechanism state
/// what holds: each error's σ in identified.csv is σ²(HᵀH)⁻¹'s, the estimate
/// is within 4 of them of the simulated machine, the misfit test passes
/// and poses left out are predicted as well as 5″ allows (RMS z near 1).
#[test]
fn the_toys_identify_states_what_its_noise_allows() {
    use tricept_calib::cli::commands::general::{run_identify, run_simulate};
    let dir = tempfile::tempdir().unwrap();
    let truth = vec![0.3, -0.2, 0.15, 0.04];
    let cfg = toy_config(targets(40), Some(truth.clone()), None);
    let readings = dir.path().join("readings.csv");
    run_simulate(&cfg, 3, false, &readings).unwrap();
    let out = dir.path().join("fit");
    run_identify(&cfg, &readings, &out).unwrap();
    let h = cfg.machine.design(&truth, &cfg.poses).unwrap();
    let sigma = 5.0 / 3600.0;
    let cov = (h.transpose() * &h).try_inverse().unwrap() * sigma * sigma;
    let identified = std::fs::read_to_string(out.join("identified.csv")).unwrap();
    for (j, row) in identified.lines().skip(1).enumerate() {
        let cells: Vec<&str> = row.split(',').collect();
        let (est, sd): (f64, f64) = if j == P {
            (cells[3].parse().unwrap(), cells[4].parse().unwrap())
        } else {
            (cells[1].parse().unwrap(), cells[2].parse().unwrap())
        };
        let want = cov[(j, j)].sqrt();
        assert!(
            (sd / want - 1.0).abs() < 0.01,
            "{}: σ {sd} vs {want}",
            cells[0]
        );
        assert!(
            (est - truth[j]).abs() < 4.0 * want,
            "{}: {est} vs {}",
            cells[0],
            truth[j]
        );
    }
    let fit: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("identifiability.json")).unwrap())
            .unwrap();
    let checks = &fit["checks"];
    assert_eq!(checks["misfit"]["passed"], true, "{checks}");
    let z = checks["held_out"]["rms_z"].as_f64().unwrap();
    assert!((0.7..1.3).contains(&z), "held-out RMS z {z}");
    assert_eq!(checks["held_out"]["readings"], 40);
}

/// A mechanism judged by position alone refuses an orientation target in
/// a sentence that names it, rather than meeting it by default.
#[test]
fn an_orientation_target_is_refused_where_only_position_is_judged() {
    use tricept_calib::cli::commands::general::run_sweep;
    let targets = targets(9);
    let cfg = toy_config(
        targets.clone(),
        None,
        Some(StudyConfig {
            spec: toy_spec(&targets, 1.0, 0.2, Estimator::Linear, 10),
            until_decided: None,
            what_ifs: Vec::new(),
            position_mm: Some(0.2),
            orientation_arcsec: Some(20.0),
        }),
    );
    let dir = tempfile::tempdir().unwrap();
    let err = run_sweep(
        &cfg,
        dir.path(),
        (1, homed_sizes::<Toy, P, R>),
        Default::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        err.contains("decision.orientation_arcsec") && err.contains("position alone"),
        "{err}"
    );
    assert!(!dir.path().join("verdict.json").exists());
}

/// The toy through the study kernel the Tricept's sweep runs
/// (`montecarlo::kinematic::KinematicStudy`, assembled as any mechanism's
/// study is): each trial's machine is the one `trial_errors` draws, and
/// each grade's estimate is what the toy's own operator makes of that
/// machine's exact readings read by the trial's noise (OLS, and WLS by
/// the encoder's σ: the same with one reading), or what Gauss–Newton over
/// its pose set makes of them, formed here apart from the kernel.
#[test]
fn the_toy_runs_through_the_tricepts_study_kernel() {
    use tricept_calib::config::{ErrorDraw, Truth};
    use tricept_calib::identify::Method;
    use tricept_calib::montecarlo::context::{GradeAxes, GradeTable, Parts, PoseSubset};
    use tricept_calib::montecarlo::kinematic::KinematicStudy;
    use tricept_calib::montecarlo::{run_trial, stream, trial_errors, Outcome, Scratch};
    use tricept_calib::montecarlo::{Studied, SweepContext};
    use tricept_calib::sensors::{homed_unit_noise, GradeReading, SensorModel};

    let slots: &'static [ReadingFact; R] = Toy::READINGS.try_into().unwrap();
    let encoder = SensorModel {
        slots,
        encoder_arcsec: 20.0,
        scale_um: 1.0,
        samples: 1,
        reading: GradeReading::Sigma,
        structured: None,
    };
    let targets = targets(12);
    let poses = PoseSet::<Toy, P, R>::new(&nominal(), &targets).unwrap();
    let solver = ols_solver(&poses);
    for iterations in [1, 20] {
        let options = IdentifyOptions::<P> {
            iterations,
            tolerance_mm: 1e-11,
            rank_tolerance: 1e-9,
            ..IdentifyOptions::default()
        };
        let subsets = vec![PoseSubset::new(targets.len(), targets.len(), R)];
        let (mech, grids) =
            KinematicStudy::<Toy, P, R>::new(&LAYOUT, &targets, &subsets, (&[], &[])).unwrap();
        let h = design_of::<Toy, P, R>(&nominal(), mech.nominal()).unwrap();
        let sets = vec![encoder];
        let table = GradeTable::new(
            &GradeAxes {
                methods: &[Method::Ols, Method::Wls],
                truths: &[Truth::DATASHEET],
                assumed: &sets,
                h: &h,
                nominal: mech.nominal(),
                subsets: &subsets,
                options: &options,
                names: Toy::ERROR_NAMES,
            },
            |_| "the encoder".into(),
        )
        .unwrap();
        let (seed, bound) = (5, 0.4);
        let ctx: SweepContext<_, P, R, 0> = SweepContext::assemble(Parts {
            mech,
            h,
            h_second: None,
            subsets,
            table,
            assumed: sets.clone(),
            sensors: sets,
            products: None,
            options,
            gls_per_machine: None,
            draw: ErrorDraw::Random,
            fixed_errors: SVector::zeros(),
            bound_mm: bound,
            seed,
            perfect: [false; R],
            grids,
            orientation: Default::default(),
            exact: false,
        })
        .unwrap();
        let mut s = Scratch::new(&ctx);
        let mut out = vec![Outcome::default(); ctx.grades().len()];
        let sigma = 20.0 / ARCSEC_PER_RAD;
        for k in 0..6 {
            run_trial(&ctx, k, &mut s, &mut out);
            let truth = trial_errors(
                ErrorDraw::Random,
                &SVector::<f64, P>::zeros(),
                bound,
                seed,
                k,
            );
            let mut x = vec![SVector::zeros(); poses.len()];
            poses
                .actual_into(&Toy::machine(&LAYOUT, &truth), &mut x)
                .unwrap();
            let mut l = DVector::zeros(poses.rows());
            poses.observation_into(&x, l.as_mut_slice());
            let mut dz = vec![0.0; poses.rows()];
            homed_unit_noise(&encoder, &mut stream(seed, k, 1), &mut dz);
            for (v, d) in l.iter_mut().zip(&dz) {
                *v += sigma * d;
            }
            let want = match iterations {
                1 => {
                    let mut e = SVector::zeros();
                    solver.apply(l.as_slice(), &mut e);
                    e
                }
                _ => {
                    identify_poses(&LAYOUT, &poses, &solver, &l, &options)
                        .unwrap()
                        .0
                        .values
                }
            };
            for (gi, o) in out.iter().enumerate() {
                let est = s.error(gi) + truth;
                assert!(
                    (est - want).amax() < 1e-9,
                    "{iterations} iteration(s), trial {k}, grade {gi}: {est:?} vs {want:?}"
                );
                assert_eq!(o.mu0, truth.abs().sum() / P as f64);
            }
            // The noise is the encoder's: a calibration is not the truth.
            assert!((s.error(0)).amax() > 1e-6);
        }
    }
}

/// Pose design runs the toy as the Tricept's: each designed pose is one of
/// its candidates, the design beats a cluster of poses, and the index of
/// two pose lists of one size stands in the ratio an independent route
/// gives (the product of H's singular values, which the designer's column
/// scale multiplies alike for both).
#[test]
fn pose_design_runs_the_toy() {
    use tricept_calib::design::{Designer, Weights};
    use tricept_calib::identify::Method;
    use tricept_calib::sensors::{GradeReading, SensorModel};
    static SLOTS: [ReadingFact; 1] = [Toy::READINGS[0]];
    let sensors = SensorModel::<R> {
        slots: &SLOTS,
        encoder_arcsec: 2.0,
        scale_um: 1.0,
        samples: 1,
        reading: GradeReading::Sigma,
        structured: None,
    };
    let mech = Homed::<Toy, P, R>::new(&LAYOUT);
    let all = targets(41);
    let weights = Weights {
        sensors: &sensors,
        method: Method::Wls,
        rank_tolerance: 1e-9,
        source: "toy",
    };
    let d = Designer::new(&mech, weights, &all[0], (all[1..].to_vec(), "o1")).unwrap();
    assert_eq!(d.active, vec![0, 1, 2], "the toy's three errors are seen");
    let (chosen, _) = d.design(4, 100);
    let mut designed = vec![all[0]];
    designed.extend(chosen.iter().map(|&c| d.points[c]));
    let cluster: Vec<Vector3<f64>> = all[..5].to_vec();
    let (a, b) = (
        d.value_of(&mech, &designed).unwrap(),
        d.value_of(&mech, &cluster).unwrap(),
    );
    assert!((a - d.value(&chosen)).abs() <= 1e-12 * a, "{a}");
    assert!(a > 2.0 * b, "designed {a} vs clustered {b}");
    let o1 = |poses: &[Vector3<f64>]| -> f64 {
        let x: Vec<SVector<f64, R>> = poses
            .iter()
            .map(|r| Toy::command(&nominal(), r).unwrap().1)
            .collect();
        let h = design_of::<Toy, P, R>(&nominal(), &x).unwrap();
        h.singular_values()
            .iter()
            .product::<f64>()
            .powf(1.0 / P as f64)
    };
    let want = o1(&designed) / o1(&cluster);
    assert!((a / b - want).abs() < 1e-9 * want, "{} vs {want}", a / b);
}

/// The toy has no second-class axes.
impl AxisAngles<P, R, 0> for Toy {
    fn with_angles(m: &ToyMachine, _: &SVector<f64, 0>) -> ToyMachine {
        *m
    }

    fn position_angle_sensitivity(
        _: &ToyMachine,
        _: &Vector3<f64>,
    ) -> Result<SMatrix<f64, 3, 0>, KinematicsError> {
        Ok(SMatrix::zeros())
    }
}

/// A row of the toy's log: its target and its encoder's angle.
#[derive(Debug, Clone, Copy)]
struct ToyRow {
    target: Vector3<f64>,
    x: SVector<f64, R>,
}

impl LogRow<R> for ToyRow {
    const FACTS: &'static [ReadingFact; R] = &[PHI];
    fn target(&self) -> Vector3<f64> {
        self.target
    }
    fn readings(&self) -> SVector<f64, R> {
        self.x
    }
    fn new(target: Vector3<f64>, x: &SVector<f64, R>) -> Self {
        ToyRow { target, x: *x }
    }
}

/// The log `truth` writes at `targets` driven by `commands`' machine (its
/// inverse kinematics), its encoder homed 0.01 rad off.
fn toy_log(truth: &ToyMachine, commands: &ToyMachine, targets: &[Vector3<f64>]) -> Vec<ToyRow> {
    targets
        .iter()
        .map(|t| {
            let (q, guess) = Toy::command(commands, t).unwrap();
            let x = Toy::readings(truth, &q, &guess).unwrap();
            ToyRow::new(*t, &x.add_scalar(0.01))
        })
        .collect()
}

/// The names of the toy's identified model: its errors, no angles.
const TOY_UNKNOWNS: Unknowns<P, 0> = Unknowns {
    errors: ["dL", "db", "dq"],
    angles: [],
    angles_are: "none",
    angle_is: "none",
    angles_turn: "none",
    axes: "none",
    beyond: "",
};

/// Where the toy's tool may go: its nominal machine (no tilt limit).
fn toy_reach() -> Reach<'static, Toy, P, R> {
    Reach {
        homed: Homed::new(&LAYOUT),
        max_tilt_deg: 90.0,
    }
}

/// Where `truth` puts the tool at each target's nominal commands, as an
/// external instrument measures it: (target, measured).
fn measured_points(truth: &ToyMachine, t: &[Vector3<f64>]) -> Vec<(Vector3<f64>, Vector3<f64>)> {
    t.iter()
        .map(|x| {
            let (q, guess) = Toy::command(&nominal(), x).unwrap();
            (
                *x,
                Toy::position(truth, &Toy::readings(truth, &q, &guess).unwrap()),
            )
        })
        .collect()
}

/// verify, reference_rows and what verify cannot see, for a mechanism that
/// is not the Tricept: a log of the true machine checks to zero against
/// the true model with either commands, and against the nominal model its
/// rows are the errors the toy's closed form gives; the bound at the
/// reference pose is the tool's sensitivity (the toy's own implicit
/// derivative) through the stated covariance.
#[test]
fn verify_runs_the_toy() {
    use tricept_calib::calibration::{reference_rows, untested, verify};
    use tricept_calib::io::Source;
    use tricept_calib::store::inputs::IdentifiedModel;
    let reach = toy_reach();
    let file = Source::new("toy.csv", &[]);
    // ΔL = 0: the true machine reaches the nominal circle.
    let truth = Toy::machine(&LAYOUT, &SVector::from([0.0, 0.4, -0.3]));
    let t = targets(9);
    for (commands, nominal_commands) in [(&truth, false), (&nominal(), true)] {
        let log = toy_log(&truth, commands, &t);
        let rows = verify(&reach, &truth, &log, nominal_commands, file).unwrap();
        let worst = rows.iter().map(|r| r.error_mm).fold(0.0, f64::max);
        assert!(
            rows.len() == 9 && worst < 1e-9,
            "{nominal_commands}: {worst}"
        );
    }
    // The nominal model against the true machine's nominal-command log:
    // the encoder says φ_k − φ_0 beyond the nominal reference angle.
    let log = toy_log(&truth, &nominal(), &t);
    let rows = verify(&reach, &nominal(), &log, true, file).unwrap();
    let phi0 = t[0].y.atan2(t[0].x);
    for (k, row) in rows.iter().enumerate() {
        let phi = log[k].x[0] - log[0].x[0] + phi0;
        let want = (Vector3::new(LAYOUT.l * phi.cos(), LAYOUT.l * phi.sin(), 0.0) - t[k]).norm();
        assert!(
            (row.error_mm - want).abs() < 1e-9,
            "row {k}: {} vs {want}",
            row.error_mm
        );
    }
    assert!(rows.iter().any(|r| r.error_mm > 0.1));
    // A target off the circle is refused naming its line; so is one the
    // machine reaches but the toy's pose check refuses (a link nearly
    // along the leg), before any row is compared.
    let mut off = log.clone();
    off[4].target.x += 5.0;
    let e = verify(&reach, &truth, &off, true, file)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("toy.csv") && e.contains("line 6") && e.contains("not reachable"),
        "{e}"
    );
    let phi = 3f64.to_radians();
    off[4] = toy_log(
        &truth,
        &nominal(),
        &[LAYOUT.l * Vector3::new(phi.cos(), phi.sin(), 0.0)],
    )[0];
    let e = verify(&reach, &truth, &off, true, file)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("line 6: target (") && e.contains("singular"),
        "{e}"
    );
    // Reference points: measured where the true machine put the tool.
    let points = measured_points(&truth, &t);
    let rows = reference_rows(&reach, &truth, &points, true, (file, 50.0)).unwrap();
    assert!(rows.len() == 9 && rows.iter().all(|r| r.error_mm < 1e-9));
    // With compensated commands the tool is expected at each target.
    let rows = reference_rows(&reach, &truth, &points, false, (file, 50.0)).unwrap();
    assert!(rows
        .iter()
        .zip(&points)
        .all(|(r, p)| (r.error_mm - (p.1 - p.0).norm()).abs() < 1e-12));
    // A point farther from its target than any error may put it is no
    // measurement of it.
    let mut far = points.clone();
    far[3].1.y -= 51.0;
    let e = reference_rows(&reach, &truth, &far, true, (file, 50.0)).unwrap_err();
    assert!(
        e.to_string()
            .contains("line 5: the measured position is 51"),
        "{e}"
    );
    let rows = reference_rows(&reach, &nominal(), &points, true, (file, 50.0)).unwrap();
    assert!(rows
        .iter()
        .zip(&points)
        .all(|(r, p)| (r.error_mm - (p.1 - p.0).norm()).abs() < 1e-9));
    // What the toy's rows cannot see: S at the reference pose from the
    // toy's implicit derivative of φ, through a stated covariance.
    let names = TOY_UNKNOWNS;
    let sd = [0.02, 0.05, 0.01];
    let mut model = IdentifiedModel::<P, 0> {
        errors: SVector::zeros(),
        identifiable: [true; P],
        std_mm: sd,
        angles: None,
        source: ["readings"; P],
    };
    let x0 = Toy::command(&nominal(), &t[0]).unwrap().1;
    let dphi = Toy::error_jacobian(&nominal(), &x0).unwrap();
    let (sin, cos) = x0[0].sin_cos();
    let mut s = SMatrix::<f64, 3, P>::zeros();
    for j in 0..P {
        let radial = if j == 0 {
            Vector3::new(cos, sin, 0.0)
        } else {
            Vector3::zeros()
        };
        s.set_column(
            j,
            &(radial + LAYOUT.l * dphi[j] * Vector3::new(-sin, cos, 0.0)),
        );
    }
    let c = nalgebra::DMatrix::from_fn(3, 3, |i, j| if i == j { sd[i] * sd[i] } else { 0.0 });
    let cov = (
        names.errors.iter().map(|n| n.to_string()).collect(),
        c.clone(),
    );
    let u = untested(&reach, &names, &model, Some(&cov), &t[0]).unwrap();
    let sc = nalgebra::DMatrix::from_column_slice(3, P, s.as_slice());
    let lmax = (&sc * &c * sc.transpose())
        .symmetric_eigen()
        .eigenvalues
        .max();
    let want = 2.795_483 * lmax.sqrt();
    assert_eq!(u.source, "covariance");
    assert!(
        (u.bound_mm.unwrap() - want).abs() < 1e-6 * want,
        "{:?} vs {want}",
        u.bound_mm
    );
    // Another fit's covariance (other names) is not read: the standard
    // uncertainties bound it axis by axis, |S|·σ.
    let other = (vec!["a".into(), "b".into(), "c".into()], c.clone());
    let u = untested(&reach, &names, &model, Some(&other), &t[0]).unwrap();
    let axis = sc.abs() * nalgebra::DVector::from_column_slice(&sd);
    assert_eq!(u.source, "standard uncertainties");
    assert!((u.bound_mm.unwrap() - 2.795_483 * axis.amax()).abs() < 1e-6 * axis.amax());
    // An error left unidentified that moves the tool is named.
    model.identifiable[1] = false;
    let u = untested(&reach, &names, &model, None, &t[0]).unwrap();
    // ... and bounds nothing: the others' |S|·σ alone.
    let axis = sc.abs() * nalgebra::DVector::from_column_slice(&[sd[0], 0.0, sd[2]]);
    assert!((u.bound_mm.unwrap() - 2.795_483 * axis.amax()).abs() < 1e-6 * axis.amax());
    assert_eq!(
        (u.unbounded, u.source),
        (vec!["db"], "standard uncertainties")
    );
}

/// Reference points added to a toy's fit: exact points of the true machine
/// measured at σ = 1 µm take a nominal estimate to the truth (to 1 % of
/// the errors: one linear step) and shrink its uncertainty; χ² says
/// whether the points agree with the fit's stated covariance; points of
/// the nominal model itself leave it where it is, χ² 0.
#[test]
fn reference_points_calibrate_the_toy() {
    use tricept_calib::calibration::{add_reference, Fit};
    use tricept_calib::identify::{EstimateOf, Termination};
    use tricept_calib::io::Source;
    let reach = toy_reach();
    let e = SVector::from([0.02, 0.04, -0.03]);
    let truth = Toy::machine(&LAYOUT, &e);
    let t = targets(7);
    let points = measured_points(&truth, &t);
    let fresh = || EstimateOf::<P> {
        values: SVector::zeros(),
        std_mm: SVector::repeat(1.0),
        identifiable: [true; P],
        source: ["readings"; P],
        residual_rms: 0.0,
        dof: 0,
        iterations: 1,
        termination: Termination::SingleLinearisation,
    };
    let file = (Source::new("ref.csv", &[]), 50.0);
    // The toy's nominal estimate, its covariance `var`·I, updated by `pts`.
    let update = |fixed: [Option<f64>; P], var: f64, pts: &[(Vector3<f64>, Vector3<f64>)]| {
        let mut est = fresh();
        let fit = Fit {
            estimate: &mut est,
            fixed: &fixed,
            covariance: nalgebra::DMatrix::identity(P, P) * var,
        };
        let (done, c) = add_reference((&reach, &nominal()), fit, pts, 1e-3, file).unwrap();
        (est, done, c)
    };
    let (est, done, c) = update([None; P], 0.01, &points);
    let miss = (est.values - e).amax();
    assert!(miss < 5e-4, "{} vs {e}", est.values);
    assert!(
        est.std_mm.iter().all(|&s| s > 0.0 && s < 0.01),
        "{}",
        est.std_mm
    );
    assert!(c.nrows() == P && (c[(1, 1)].sqrt() - est.std_mm[1]).abs() < 1e-15);
    // The covariance is the information form's, (C⁻¹ + SᵀS/σ²)⁻¹, S the
    // tool's sensitivity at every point.
    let mut info = nalgebra::DMatrix::<f64>::identity(P, P) * 100.0;
    for (x, _) in &points {
        let s = Toy::position_sensitivity(&LAYOUT, x).unwrap();
        let s = nalgebra::DMatrix::from_column_slice(3, P, s.as_slice());
        info += s.transpose() * s / 1e-6;
    }
    let want = info.try_inverse().unwrap();
    assert!(
        (&c - &want).amax() < 1e-6 * want.amax() && (&c - c.transpose()).amax() == 0.0,
        "{c} vs {want}"
    );
    assert_eq!((done.points, done.dof), (7, 21));
    // Errors of 0.02–0.04 mm against a stated 0.1 mm: consistent.
    assert!(
        done.p_value > 0.01 && done.max_innovation_mm > 0.01,
        "{done:?}"
    );
    // A fit that claims 0.1 µm is contradicted by the points.
    let (_, done, _) = update([None; P], 1e-8, &points);
    assert!(done.p_value < 1e-6, "{done:?}");
    // An error held at a measured value stays; the model's own points
    // move nothing.
    let (est, _, _) = update([None, Some(0.0), None], 0.01, &points);
    assert!(est.values[1] == 0.0 && est.std_mm[1] == 1.0);
    // σ must be a standard uncertainty in (0, 10] mm; a point farther from
    // the fit than any error of this machine may put it is refused.
    for sigma in [0.0, -1.0, 10.5, f64::NAN, f64::INFINITY] {
        let mut est = fresh();
        let fit = Fit {
            estimate: &mut est,
            fixed: &[None; P],
            covariance: nalgebra::DMatrix::identity(P, P),
        };
        let e = add_reference((&reach, &nominal()), fit, &points, sigma, file).unwrap_err();
        assert!(e.to_string().contains("--reference-sigma"), "{sigma}: {e}");
    }
    let mut far = points.clone();
    far[2].1.x += 60.0;
    let mut est = fresh();
    let fit = Fit {
        estimate: &mut est,
        fixed: &[None; P],
        covariance: nalgebra::DMatrix::identity(P, P),
    };
    let e = add_reference((&reach, &nominal()), fit, &far, 10.0, file).unwrap_err();
    assert!(
        e.to_string()
            .contains("line 4: the measured position is 60"),
        "{e}"
    );
    let own: Vec<_> = t.iter().map(|x| (*x, *x)).collect();
    let (est, done, _) = update([None; P], 0.01, &own);
    assert!(
        est.values.amax() < 1e-9 && done.chi2 < 1e-9,
        "{}",
        done.chi2
    );
}

/// The toy's calibrated-geometry file comes from its facts alone: its
/// name, its convention, its errors with their σ and the correlations of
/// identify's covariance.
#[test]
fn the_toys_geometry_file_states_its_fit() {
    use tricept_calib::calibration::geometry::geometry_json;
    use tricept_calib::store::inputs::IdentifiedModel;
    let names = TOY_UNKNOWNS;
    let model = IdentifiedModel::<P, 0> {
        errors: SVector::from([0.25, -0.0, 0.1]),
        identifiable: [true, true, false],
        std_mm: [0.01, f64::NAN, 0.0],
        angles: None,
        source: ["readings", "readings", "unidentifiable"],
    };
    let fit = serde_json::json!({
        "covariance": {"unknowns": ["dL", "db", "dq"],
                       "matrix": [[4.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, 0.0]]},
        "checks": {"misfit": "ok"},
    });
    let homed = Homed::<Toy, P, R>::new(&LAYOUT);
    // The model's machine is the toy's with its errors.
    let m = model.machine(&homed);
    assert_eq!((m.l, m.b, m.dq), (400.25, 250.0, 0.1));
    let g = geometry_json(&homed, &names, &model, &fit);
    assert_eq!(g["mechanism"], "toy");
    assert_eq!(g["convention"], Toy::CONVENTION);
    assert_eq!(g["errors"][0]["estimate"], 0.25);
    assert_eq!(g["errors"][1]["estimate"].to_string(), "0.0");
    assert!(g["errors"][1]["std_uncertainty"].is_null());
    assert_eq!(g["errors"][2]["source"], "unidentifiable");
    assert_eq!(g["correlations"]["matrix"][0][1], 0.5);
    assert!(g["correlations"]["matrix"][2][2].is_null());
    assert_eq!(g["checks"]["misfit"], "ok");
    assert!(g.get("limbs").is_none());
}

/// The checks of any mechanism's fit, on the toy: under its declared
/// encoder the misfit's χ² averages its degrees of freedom and its test
/// rejects about 1 % of fits, and rejects nearly every fit of readings
/// three times noisier, with a ratio of about 3; poses left out are
/// predicted to about one standard deviation; the estimate spreads over
/// fits as its stated covariance says, and the predicted error at the
/// reference pose is what the fits realise there (the toy's sensitivity
/// times each fit's error, an independent route).
#[test]
fn the_checks_of_any_fit_hold_on_the_toy() {
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    use tricept_calib::calibration::{
        checks_of, estimate_covariance, held_out_of, loose, misfit_of, predicted_of, CalibrationOf,
        FitInputs, Folds, Grid,
    };
    use tricept_calib::identify::{Constraints, Method};
    use tricept_calib::sensors::{GradeReading, ObservationCovariance, SensorModel};
    static SLOTS: [ReadingFact; R] = [PHI];
    let sigma_arcsec = 5.0;
    let sensors = SensorModel {
        slots: &SLOTS,
        encoder_arcsec: sigma_arcsec,
        scale_um: 0.0,
        samples: 1,
        reading: GradeReading::Sigma,
        structured: None,
    };
    let t = targets(30);
    let poses = PoseSet::<Toy, P, R>::new(&nominal(), &t).unwrap();
    let e = SVector::from([0.05, -0.04, 0.03]);
    let mut exact = vec![SVector::zeros(); poses.len()];
    poses
        .actual_into(&Toy::machine(&LAYOUT, &e), &mut exact)
        .unwrap();
    let h = design_of::<Toy, P, R>(&nominal(), &poses.nominal).unwrap();
    let homed = Homed::<Toy, P, R>::new(&LAYOUT);
    // The workspace from 61° on: the reference (20°) is none of its points.
    let points = targets(41)[12..].to_vec();
    let grid = Grid {
        homed: &homed,
        points: &points,
        reference: Some(t[0]),
    };
    let folds = Folds {
        sensors: &sensors,
        method: Method::Ols,
        rank_tolerance: 1e-9,
    };
    let mut rng = rand::rngs::StdRng::seed_from_u64(7);
    let sd = sigma_arcsec / ARCSEC_PER_RAD;
    // One fit of readings `times` as noisy as declared.
    let mut fit = |times: f64| {
        let noise = Normal::new(0.0, times * sd).unwrap();
        let measured: Vec<SVector<f64, R>> = exact
            .iter()
            .map(|x| x + SVector::from([noise.sample(&mut rng)]))
            .collect();
        let mut l = DVector::zeros(poses.rows());
        poses.observation_into(&measured, l.as_mut_slice());
        let solver = Method::Ols
            .solver(
                (&sensors, &measured),
                &h,
                1e-9,
                (&Constraints::default(), &TOY_UNKNOWNS.errors),
            )
            .unwrap();
        let options = IdentifyOptions::<P>::default();
        let (estimate, solver) = identify_poses(&LAYOUT, &poses, &solver, &l, &options).unwrap();
        let resid = &l - solver.design() * estimate.values;
        let stated = ObservationCovariance::new(&sensors.stated_covariances(), &measured);
        let cal = CalibrationOf::<_, _, P, R, 0> {
            estimate,
            solver,
            poses: poses.clone(),
            axes: None,
            unknowns: &TOY_UNKNOWNS,
            stated: stated.clone(),
            measured,
            covariance: None,
            groups: Vec::new(),
        };
        let f = FitInputs {
            sigma: stated,
            resid,
        };
        (cal, f)
    };
    let trials = 300;
    let (mut chi2, mut rejected, mut z2, mut spread) = (0.0, 0, 0.0, Vec::new());
    let mut first = None;
    for _ in 0..trials {
        let (cal, f) = fit(1.0);
        let m = misfit_of(&cal, &f).unwrap();
        assert_eq!(m.dof, 29 - P);
        chi2 += m.chi2 / m.dof as f64;
        rejected += usize::from(m.rejected);
        let held = held_out_of(&folds, &cal, &f).unwrap();
        assert_eq!((held.folds_skipped, held.rows), (0, 29));
        z2 += held.rms_z * held.rms_z;
        spread.push(cal.estimate.values - e);
        first.get_or_insert((cal, f));
    }
    let n = trials as f64;
    assert!((chi2 / n - 1.0).abs() < 0.08, "mean χ²/dof {}", chi2 / n);
    assert!(
        rejected <= 10,
        "{rejected} of {trials} fits rejected at 1 %"
    );
    assert!((z2 / n - 1.0).abs() < 0.1, "mean held-out z² {}", z2 / n);
    // Three times the declared noise: rejected, and by how much.
    let (mut caught, mut ratio) = (0, 0.0);
    for _ in 0..100 {
        let (cal, f) = fit(3.0);
        let m = misfit_of(&cal, &f).unwrap();
        caught += usize::from(m.rejected);
        ratio += m.ratio / 100.0;
    }
    assert!(caught >= 95, "{caught} of 100 noisy fits rejected");
    assert!((ratio - 3.0).abs() < 0.3, "ratio {ratio}");
    // A rejected fit's predicted accuracy is scaled by its misfit.
    let (noisy, f3) = fit(3.0);
    let m = misfit_of(&noisy, &f3).unwrap();
    assert!(m.rejected);
    let scaled = predicted_of(&grid, &noisy, m.ratio).unwrap();
    let said = checks_of(&noisy, Some(f3), &folds, &grid);
    assert_eq!(said.predicted_accuracy.unwrap().max_mm, scaled.max_mm);
    let unscaled = predicted_of(&grid, &noisy, 1.0).unwrap();
    assert!((scaled.max_mm[0] / unscaled.max_mm[0] - m.ratio).abs() < 1e-9);

    // The stated covariance against the fits' spread, error by error.
    let (cal, f) = first.unwrap();
    // A held error and a prior, against χ² computed independently: the
    // homed rows' covariance σ²(I + 11ᵀ) inverted densely.
    let l = &f.resid + cal.solver.design() * cal.estimate.values;
    let rows = l.len();
    let dense = (nalgebra::DMatrix::<f64>::identity(rows, rows)
        + nalgebra::DMatrix::from_element(rows, rows, 1.0))
        * (sd * sd);
    let inverse = dense.try_inverse().unwrap();
    // Weighted rows, so that a prior in mm weighs against readings
    // whitened by their σ.
    let with = |held: Constraints<P>| {
        let solver = Method::Wls
            .solver(
                (&sensors, &cal.measured),
                &h,
                1e-9,
                (&held, &TOY_UNKNOWNS.errors),
            )
            .unwrap();
        let estimate = solver.estimate(&l);
        let resid = &l - solver.design() * estimate.values;
        let fitted = CalibrationOf {
            estimate,
            solver,
            ..cal.clone()
        };
        let m = misfit_of(
            &fitted,
            &FitInputs {
                sigma: cal.stated.clone(),
                resid: resid.clone(),
            },
        )
        .unwrap();
        (fitted, resid, m)
    };
    let (prior, resid, m) = with(Constraints {
        fixed: [None; P],
        prior_std_mm: Some(0.1),
    });
    let own = (resid.transpose() * &inverse * &resid)[(0, 0)]
        + prior
            .estimate
            .values
            .iter()
            .map(|x| (x / 0.1).powi(2))
            .sum::<f64>();
    assert_eq!(m.dof, rows);
    assert!((m.chi2 / own - 1.0).abs() < 1e-9, "{} vs {own}", m.chi2);
    assert!(
        (m.ratio - (m.chi2 / rows as f64).sqrt()).abs() < 1e-12 && !m.rejected,
        "{m:?}"
    );
    // A prior far tighter than the machine's errors shows as misfit.
    let (_, _, tight) = with(Constraints {
        fixed: [None; P],
        prior_std_mm: Some(1e-4),
    });
    assert!(
        tight.rejected && tight.p_value < 0.01 && tight.ratio > 3.0,
        "{tight:?}"
    );
    let (_, resid, m) = with(Constraints {
        fixed: [None, Some(e[1]), None],
        prior_std_mm: None,
    });
    assert_eq!(m.dof, rows - (P - 1));
    assert!(m.chi2 <= (resid.transpose() * &inverse * &resid)[(0, 0)] + 1e-9);
    let c = estimate_covariance(&cal);
    for k in 0..P {
        let var = spread.iter().map(|d| d[k] * d[k]).sum::<f64>() / n;
        assert!(
            (var / c[(k, k)] - 1.0).abs() < 0.2,
            "{}: spread {var:e} vs stated {:e}",
            TOY_UNKNOWNS.errors[k],
            c[(k, k)]
        );
    }
    // The predicted error at the reference pose against the fits' own.
    let p = predicted_of(&grid, &cal, 1.0).unwrap();
    assert_eq!(p.points, points.len());
    let s0 = Toy::position_sensitivity(&LAYOUT, &t[0]).unwrap();
    let mut at_ref: Vec<f64> = spread.iter().map(|d| (s0 * d).norm()).collect();
    at_ref.sort_by(f64::total_cmp);
    let median = at_ref[at_ref.len() / 2];
    let [mid, lo, hi] = p.at_reference_mm;
    assert!(lo < mid && mid < hi, "{:?}", p.at_reference_mm);
    assert!(
        (median / mid - 1.0).abs() < 0.15,
        "realised median {median:e} mm, predicted {mid:e} mm"
    );
    // The workspace's mean error and the p95 of the error relative to the
    // reference pose, each fit's own, against the predicted medians.
    let sens: Vec<_> = points
        .iter()
        .map(|r| Toy::position_sensitivity(&LAYOUT, r).unwrap())
        .collect();
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let means = spread
        .iter()
        .map(|d| sens.iter().map(|sk| (sk * d).norm()).sum::<f64>() / sens.len() as f64)
        .collect();
    let rel95 = spread
        .iter()
        .map(|d| {
            let mut rel: Vec<f64> = sens.iter().map(|sk| (sk * d - s0 * d).norm()).collect();
            rel.sort_by(f64::total_cmp);
            rel[(0.95 * (rel.len() - 1) as f64).round() as usize]
        })
        .collect();
    let (mean, rel) = (median(means), median(rel95));
    assert!(
        (mean / p.mean_mm[0] - 1.0).abs() < 0.15,
        "mean {mean:e} vs {:e}",
        p.mean_mm[0]
    );
    assert!(
        (rel / p.relative_p95_mm[0] - 1.0).abs() < 0.15,
        "relative p95 {rel:e} vs {:e}",
        p.relative_p95_mm[0]
    );
    // Near the reference the relative error is a small part of the whole:
    // the same against points from 23.5° to 37.5°.
    let near = targets(41)[1..6].to_vec();
    let grid_near = Grid {
        homed: &homed,
        points: &near,
        reference: Some(t[0]),
    };
    let pn = predicted_of(&grid_near, &cal, 1.0).unwrap();
    let rel95 = spread
        .iter()
        .map(|d| {
            let mut rel: Vec<f64> = near
                .iter()
                .map(|r| (Toy::position_sensitivity(&LAYOUT, r).unwrap() * d - s0 * d).norm())
                .collect();
            rel.sort_by(f64::total_cmp);
            rel[(0.95 * (rel.len() - 1) as f64).round() as usize]
        })
        .collect();
    let rel = median(rel95);
    assert!(rel < 0.5 * pn.mean_mm[0], "{rel:e} vs {:e}", pn.mean_mm[0]);
    assert!(
        (rel / pn.relative_p95_mm[0] - 1.0).abs() < 0.15,
        "relative p95 near the reference {rel:e} vs {:e}",
        pn.relative_p95_mm[0]
    );
    // Twice the covariance's scale, twice the error.
    let p2 = predicted_of(&grid, &cal, 2.0).unwrap();
    assert!((p2.max_mm[0] / p.max_mm[0] - 2.0).abs() < 1e-9);
    // The whole checks, as identify states them.
    let all = checks_of(&cal, Some(f), &folds, &grid);
    assert!(all.misfit.is_some() && all.held_out.is_some());
    assert_eq!(all.predicted_accuracy.unwrap().max_mm, p.max_mm);
    let none = checks_of(&cal, None, &folds, &grid);
    assert!(none.misfit.is_none() && none.held_out.is_none() && none.predicted_accuracy.is_none());
    // What compensate would refuse, by the toy's own names.
    let mut wide = cal.clone();
    wide.estimate.std_mm[1] = 1.5;
    assert_eq!(loose(&wide), vec!["db ± 1.500 mm".to_string()]);
    assert!(loose(&cal).is_empty());
}

/// A log's readings check, for a mechanism that is not the Tricept: a log
/// of a machine near nominal passes whatever homing offset it carries; a
/// reading further from its nominal value than the toy's plausible 2° is
/// refused naming its line, in degrees; a log whose every row is off by
/// the same story blames its reference row.
#[test]
fn a_toy_log_no_machine_could_read_is_refused() {
    use tricept_calib::calibration::readings_check::check_readings;
    use tricept_calib::io::Source;
    let homed = Homed::<Toy, P, R>::new(&LAYOUT);
    let truth = Toy::machine(&LAYOUT, &SVector::from([0.2, -0.1, 0.3]));
    let t = targets(8);
    let lines: Vec<u64> = (2..10).collect();
    let file = Source::new("toy.csv", &lines);
    let log = toy_log(&truth, &nominal(), &t);
    check_readings(&homed, &log, file).unwrap();
    // Off by 5° at the fifth row (line 6).
    let mut off = toy_log(&truth, &nominal(), &t);
    let x = off[4].readings().add_scalar(5f64.to_radians());
    off[4] = ToyRow::new(t[4], &x);
    let why = check_readings(&homed, &off, file).unwrap_err().to_string();
    assert!(why.contains("toy.csv") && why.contains("line 6"), "{why}");
    assert!(why.contains("phi") && why.contains('°'), "{why}");
    // 1.5° is within what a geometric error can do.
    let mut near = toy_log(&truth, &nominal(), &t);
    let x = near[4].readings().add_scalar(1.5f64.to_radians());
    near[4] = ToyRow::new(t[4], &x);
    check_readings(&homed, &near, file).unwrap();
    // The reference row off, every other row fine: the reference is blamed.
    let mut first = toy_log(&truth, &nominal(), &t);
    let x = first[0].readings().add_scalar(5f64.to_radians());
    first[0] = ToyRow::new(t[0], &x);
    let why = check_readings(&homed, &first, file)
        .unwrap_err()
        .to_string();
    assert!(why.contains("line 2"), "{why}");
}

/// The compensation maps and commands of any mechanism, on the toy: a
/// model that is the true machine compensates it to round-off; the error
/// before is where the nominal commands take the true tool (the toy's own
/// forward kinematics, an independent route); the correction vectors of a
/// model are that error's vectors; a compensated command is the leg
/// length the identified toy needs, and a target off the link's circle is
/// refused by line.
#[test]
fn maps_and_commands_run_the_toy() {
    use tricept_calib::calibration::{commands, correction_vectors, map_of};
    use tricept_calib::io::Source;
    let reach = toy_reach();
    // The link's length as nominal: a one-joint toy reaches only its own
    // circle, so only the pivot and the leg's offset can be compensated.
    let truth = Toy::machine(&LAYOUT, &SVector::from([0.0, -0.1, 0.3]));
    let points = targets(9);
    let map = map_of(&reach.homed, (&truth, &truth), &points, "toy.toml").unwrap();
    assert_eq!(map.points, points);
    for (k, (r, m)) in measured_points(&truth, &points).iter().enumerate() {
        assert!((map.before_mm[k] - (m - r).norm()).abs() < 1e-9);
        assert!(map.before_mm[k] > 0.05, "{}", map.before_mm[k]);
        assert!(map.after_mm[k] < 1e-9, "{}", map.after_mm[k]);
    }
    // A model that is not the machine: the map's after is the machine
    // commanded by the model, not the model's own.
    let model = Toy::machine(&LAYOUT, &SVector::from([0.0, -0.05, 0.1]));
    let part = map_of(&reach.homed, (&model, &truth), &points, "toy.toml").unwrap();
    for (k, r) in points.iter().enumerate() {
        let (q, guess) = Toy::command(&model, r).unwrap();
        let at = Toy::position(&truth, &Toy::readings(&truth, &q, &guess).unwrap());
        assert!((part.after_mm[k] - (at - r).norm()).abs() < 1e-9);
        assert!(part.after_mm[k] > 1e-3 && part.after_mm[k] < map.before_mm[k]);
        assert_eq!(part.before_mm[k], map.before_mm[k]);
    }
    let v = correction_vectors(&reach.homed, &truth, &map, "toy.toml").unwrap();
    assert_eq!(v.len(), points.len());
    for ((vk, (r, m)), b) in v
        .iter()
        .zip(measured_points(&truth, &points))
        .zip(&map.before_mm)
    {
        assert!((vk - (m - r)).norm() < 1e-9 && (vk.norm() - b).abs() < 1e-9);
    }
    let lines = [2, 3, 4];
    let file = Source::new("targets.csv", &lines);
    let q = commands(&reach, &truth, &points[..3], file).unwrap();
    for (qk, r) in q.iter().zip(&points) {
        // The leg from B to the target, less the leg's own offset.
        let leg = (r - Vector3::new(truth.b, 0.0, 0.0)).norm() - truth.dq;
        assert!((qk[0] - leg).abs() < 1e-12);
    }
    let off = [points[0], Vector3::new(0.0, 0.0, 900.0), points[2]];
    let why = commands(&reach, &truth, &off, file)
        .unwrap_err()
        .to_string();
    assert!(
        why.contains("targets.csv") && why.contains("line 3"),
        "{why}"
    );
}
