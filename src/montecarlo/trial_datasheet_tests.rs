//! Tests of the trial kernel with datasheet sensors (docs/method.md §11): the
//! trial's readings against `simulate`'s, shared axes and operators against
//! each set alone, the AVX2 kernels against the baseline's bits, the grade
//! axis and the validation of the datasheet sections.

use super::tests::{simulated_minus_trial, SweepContext, FK_AGREEMENT};
use super::*;
use crate::config::parse_raw;
use crate::config::{Config, ErrorDraw};
use crate::identify::Method;
use crate::mechanism::tricept::ErrorVector;
use crate::mechanism::tricept::Joints;
use crate::montecarlo::per_machine::reported_joints;
use crate::sensors::ARCSEC_PER_RAD;
const DATASHEETS: &str = "[sensors.encoder]\naccuracy_arcsec = 2.0\nharmonics = [0.8, 0.2]\nnoise_arcsec = 0.05\nresolution_arcsec = 0.01\n[sensors.scale]\naccuracy_um = 0.5\nnoise_um = 0.02\n[errors]\ndxB1 = 0.2\ndq2 = 0.3\n";

/// A grid of 2 encoder (1″, 4″) × 2 scale (0.5, 2 µm) grades, OLS and WLS,
/// of [`DATASHEETS`] with a quantised scale too, the encoders' jitter
/// `noise` (″) and `head` before it (say, a `[sensors]` section).
fn quantised_grid(head: &str, noise: &str, errors: ErrorDraw) -> (Config, SweepContext) {
    let text = format!(
        "{head}{}",
        DATASHEETS
            .replace(
                "noise_um = 0.02\n",
                "noise_um = 0.02\nresolution_um = 0.01\n"
            )
            .replace("noise_arcsec = 0.05", &format!("noise_arcsec = {noise}"))
    );
    let cfg = Config::from_raw(parse_raw(&text, "t").unwrap(), "t").unwrap();
    let study = cfg
        .study()
        .errors(errors)
        .encoder_arcsec(&[1.0, 4.0])
        .scale_um(&[0.5, 2.0])
        .methods(&[Method::Ols, Method::Wls])
        .trials(3)
        .build()
        .unwrap();
    let ctx = SweepContext::new(&cfg, &study).unwrap();
    assert!(matches!(ctx.plan.path, KernelPath::PerSensor { .. }));
    (cfg, ctx)
}

/// The trial's readings against `simulate`'s (the reference reading,
/// pose by pose) from the same stream: with quantised samples (a sensor
/// set's own errors) and without (the linear parts).
#[test]
fn trial_and_simulate_read_the_same_structured_sensors() {
    let unquantised = DATASHEETS.replace("resolution_arcsec = 0.01\n", "");
    for (text, linear) in [(DATASHEETS.to_string(), false), (unquantised, true)] {
        trial_and_simulate_read_alike(&text, linear);
    }
}

fn trial_and_simulate_read_alike(text: &str, linear: bool) {
    let cfg = Config::from_raw(parse_raw(text, "t").unwrap(), "t").unwrap();
    let st = cfg.sensors.structured.unwrap();
    assert_eq!(st.from_section, [true, true, true]);
    let study = cfg
        .study()
        .errors(ErrorDraw::Fixed)
        .encoder_arcsec(&[2.0])
        .scale_um(&[0.5])
        .trials(1)
        .build()
        .unwrap();
    let ctx = SweepContext::new(&cfg, &study).unwrap();
    assert_eq!(ctx.plan.path == KernelPath::DatasheetParts, linear);
    let mut s = Scratch::new(&ctx);
    let mut out = vec![Outcome::default(); 1];
    run_trial(&ctx, 4, &mut s, &mut out);
    s.form_observations(&ctx);
    let truth = cfg.truth("test").unwrap();
    let diff = simulated_minus_trial(&ctx, &truth, &s, 0, 4);
    assert!(diff < FK_AGREEMENT, "{diff:e}");
    // The curve is there: well beyond the jitter of 0.05″/√3 ≈ 0.03″.
    let exact: f64 = s
        .observation(0)
        .iter()
        .zip(&s.l0)
        .step_by(3)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(exact * ARCSEC_PER_RAD > 0.2, "{}", exact * ARCSEC_PER_RAD);
}

/// A grid of 2 encoder × 2 scale grades, OLS and WLS, all quantised:
/// each set's axes that an earlier set reads alike are copied, and each
/// sensor's op·e is shared by the grades of an operator that read it
/// alike. Every set's observation must still be `simulate`'s with that
/// set, and every grade's estimate and budget its own operator applied
/// to its own observation (an independent route: no sharing).
#[test]
fn shared_axes_read_and_identify_as_each_set_alone() {
    let (cfg, ctx) = quantised_grid("", "0.05", ErrorDraw::Fixed);
    // Sets are scale-major: (1″, 0.5), (4″, 0.5), (1″, 2), (4″, 2).
    let KernelPath::PerSensor {
        axes,
        sensor_split_of,
    } = &ctx.plan.path
    else {
        panic!(
            "quantised sensors take the per-sensor path, not {}",
            ctx.plan.name()
        );
    };
    assert_eq!(
        axes.axis_of,
        vec![[0, 0, 0], [1, 1, 0], [0, 0, 2], [1, 1, 2]]
    );
    assert_eq!(axes.draw_class, vec![0; 4]);
    let shared = (0..ctx.grades.len())
        .filter(|&gi| sensor_split_of[gi].iter().any(|&gj| gj != gi))
        .count();
    assert!(shared >= 3, "{sensor_split_of:?}");
    let mut s = Scratch::new(&ctx);
    let mut out = vec![Outcome::default(); ctx.grades.len()];
    let truth = cfg.truth("test").unwrap();
    for k in [4, 11] {
        run_trial(&ctx, k, &mut s, &mut out);
        s.form_observations(&ctx);
        for i in 0..ctx.sensors.len() {
            let diff = simulated_minus_trial(&ctx, &truth, &s, i, k);
            assert!(diff < FK_AGREEMENT, "set {i}: {diff:e}");
        }
        for (gi, g) in ctx.grades.iter().enumerate() {
            let l = s.observation(g.sensor_index);
            let mut est = crate::mechanism::tricept::ErrorVector::zeros();
            ctx.solvers[gi].apply(l, &mut est);
            let d = (s.error(gi) - (est - cfg.errors)).amax();
            assert!(d < 1e-12, "grade {gi}: {d:e}");
            let mut without = l.to_vec();
            for r in (2..without.len()).step_by(3) {
                without[r] = s.l0[r];
            }
            ctx.solvers[gi].apply(&without, &mut est);
            let b = mu(&cfg.errors, &est);
            assert!((out[gi].budget[3] - b).abs() < 1e-12, "grade {gi}");
        }
    }
}

/// The datasheet kernels' AVX2 copies (where the processor has AVX2)
/// give the baseline's bits: every outcome and every reading error of a
/// quantised grid with OLS and WLS, with the samples summed in registers
/// (3) and in passes (6), with and without jitter.
#[test]
fn the_wide_kernels_give_the_baseline_bits() {
    for (samples, noise) in [(3, "0.05"), (6, "0.05"), (2, "0.0")] {
        let (_, ctx) = quantised_grid(
            &format!("[sensors]\nsamples = {samples}\n"),
            noise,
            ErrorDraw::Random,
        );
        let mut s = Scratch::new(&ctx);
        let mut t = Scratch::new(&ctx);
        let mut wide = vec![Outcome::default(); ctx.grades.len()];
        let mut narrow = wide.clone();
        for k in 0..3 {
            run_trial(&ctx, k, &mut s, &mut wide);
            crate::cpu::baseline(|| run_trial(&ctx, k, &mut t, &mut narrow));
            assert!(wide.iter().all(|o| o.mu > 0.0), "{wide:?}");
            // Debug prints each double's shortest round trip: equal
            // strings are equal bits.
            assert_eq!(format!("{wide:?}"), format!("{narrow:?}"), "trial {k}");
            assert_eq!(format!("{:?}", s.e), format!("{:?}", t.e), "trial {k}");
        }
    }
}

#[test]
fn the_grade_axis_sets_the_datasheet_accuracy() {
    let cfg = Config::from_raw(parse_raw(DATASHEETS, "t").unwrap(), "t").unwrap();
    let study = cfg
        .study()
        .encoder_arcsec(&[1.0, 5.0])
        .scale_um(&[2.0])
        .trials(1)
        .build()
        .unwrap();
    let ctx = SweepContext::new(&cfg, &study).unwrap();
    let a = ctx.sensors[1].structured.unwrap();
    assert!((a.axes[0].accuracy * ARCSEC_PER_RAD - 5.0).abs() < 1e-12);
    assert!((a.axes[2].accuracy - 2e-3).abs() < 1e-15);
    // The other fields stay as written.
    assert!((a.axes[0].noise * ARCSEC_PER_RAD - 0.05).abs() < 1e-12);
    assert_eq!(a.axes[0].n_harmonics, 2);
}

#[test]
fn datasheet_validation_names_the_key() {
    let bad = [
        (
            "[sensors.encoder]\nharmonics = [0.8, 0.4]\n",
            "sensors.encoder.harmonics",
        ),
        (
            "[sensors.encoder_psi]\nharmonics = [-0.1]\n",
            "sensors.encoder_psi.harmonics",
        ),
        ("[sensors.scale]\nnoise_um = -1.0\n", "sensors.scale.noise"),
        (
            "[sensors.scale]\nsignal_period_um = 20.0\n",
            "sensors.scale.signal_period",
        ),
        (
            "[sensors.encoder]\ninterpolation_arcsec = 0.1\n",
            "sensors.encoder.interpolation",
        ),
        ("[sensors.encoder]\nlines = 3\n", "unknown field"),
    ];
    for (text, key) in bad {
        let err = parse_raw(text, "t")
            .and_then(|raw| Config::from_raw(raw, "t"))
            .unwrap_err()
            .to_string();
        assert!(err.contains(key), "{text}: {err}");
    }
    // One encoder alone: the other axis keeps the paper's reading.
    let one = Config::from_raw(
        parse_raw("[sensors.encoder_theta]\naccuracy_arcsec = 1.0\n", "t").unwrap(),
        "t",
    )
    .unwrap();
    assert_eq!(
        one.sensors.structured.unwrap().from_section,
        [false, true, false]
    );
}

/// Each estimator has its own operator (OLS one shared by every set, WLS
/// and GLS one per set and pose count, what-if sets sharing the datasheet's)
/// and `parameters.csv` predicts each one's spread with the datasheet's Σ:
/// on small errors (one linearisation exact to well under the sensors'
/// share) the Monte-Carlo spread over the prediction is within 15 % of 1
/// for every identifiable parameter and estimator.
#[test]
fn every_estimator_has_its_operator_and_its_predicted_spread() {
    let text = "[sensors]\nsamples = 3\n[sensors.encoder]\naccuracy_arcsec = 5.0\nharmonics = [0.6, 0.3]\nnoise_arcsec = 0.2\n[sensors.scale]\naccuracy_um = 2.0\nharmonics = [0.7, 0.2]\nnoise_um = 0.1\n[sweep]\nencoder_arcsec = [2.0, 5.0]\nscale_um = [2.0]\ntruth_amplitude = [1.0, 2.0]\nerror_bound = 0.002\n";
    let cfg = Config::from_raw(parse_raw(text, "t").unwrap(), "t").unwrap();
    let study = cfg
        .study()
        .methods(&[Method::Ols, Method::Wls, Method::Gls])
        .trials(3000)
        .build()
        .unwrap();
    let ctx = SweepContext::new(&cfg, &study).unwrap();
    // Per estimator: (1×: 2″, 5″), (2×: 2″, 5″).
    assert_eq!(ctx.grades.len(), 12);
    assert_eq!(ctx.plan.split_of, vec![0, 0, 0, 0, 4, 5, 4, 5, 8, 9, 8, 9]);
    let truth: Vec<f64> = ctx.grades.iter().map(|g| g.truth.amplitude).collect();
    assert_eq!(truth[..4], [1.0, 1.0, 2.0, 2.0]);
    let product: Vec<usize> = ctx.grades.iter().map(|g| g.product).collect();
    assert_eq!(product[..4], [0, 1, 0, 1]);
    let result = crate::montecarlo::run_in_memory(&cfg, &study, 2).unwrap();
    assert_eq!(result.summary.len(), 6);
    assert_eq!(result.truth.len(), 6);
    assert_eq!(result.parameters.len(), 6 * 15);
    for p in result.parameters.iter().filter(|p| p.identifiable) {
        assert!(
            (0.85..1.15).contains(&p.ratio_mc_to_predicted),
            "{} {} at {}″: {}",
            p.method.name(),
            p.parameter,
            p.encoder_arcsec,
            p.ratio_mc_to_predicted
        );
    }
}

/// `[sweep] gls_per_machine`: each simulated machine is calibrated exactly
/// as identify calibrates a log of it — the trial's estimate against
/// identify on the readings the trial's sensors reported (nominal joints
/// plus the trial's observation, the reference reading nominal), through
/// identify's route from the readings (the poses and design matrix from
/// their targets, the weighting at their joint values, the observation
/// from them), not the study's tables.
#[test]
fn a_study_weighted_per_machine_calibrates_as_identify() {
    let text = "[sensors]\nsamples = 4\n[sensors.encoder]\naccuracy_arcsec = 5.0\nharmonics = \"unknown\"\ninterpolation_arcsec = 1.44\nsignal_period_arcsec = 144.0\nnoise_arcsec = 0.2\n[sensors.scale]\naccuracy_um = 3.0\nharmonics = \"unknown\"\ninterpolation_um = 0.2\nsignal_period_um = 20.0\nnoise_um = 0.02\n[identification]\nmethod = \"gls\"\n[sweep]\nmethods = [\"gls\"]\nencoder_arcsec = [5.0]\nscale_um = [3.0]\ngls_per_machine = true\nerror_bound = 0.05\ntrials = 3\n";
    let cfg = Config::from_raw(parse_raw(text, "t").unwrap(), "t").unwrap();
    let study = cfg.study().build().unwrap();
    let ctx = SweepContext::new(&cfg, &study).unwrap();
    assert_eq!(ctx.per_machine, vec![true]);
    let mut s = Scratch::new(&ctx);
    let mut out = vec![Outcome::default(); ctx.grades.len()];
    for k in 0..3 {
        run_trial(&ctx, k, &mut s, &mut out);
        let (truth, _) = trial_machine(&ctx, k);
        let est = s.error(0) + truth;
        let l = &s.l_sub[..ctx.rows()];
        let readings: Vec<crate::mechanism::tricept::Reading> = reported_joints(&ctx, 0, l)
            .into_iter()
            .zip(&ctx.mech.poses.targets)
            .map(|(j, &target)| crate::mechanism::tricept::Reading {
                target,
                joints: Joints::from_vector(&j),
            })
            .collect();
        let values = identify_readings(&cfg, &readings);
        let d = (values - est).amax();
        assert!(d < 1e-9, "trial {k}: {d:e} mm from identify");
        // And not what the study's one operator gives (the weighting moved).
        let mut white = ErrorVector::zeros();
        ctx.solvers[0].apply(l, &mut white);
        assert!(
            (white - est).amax() > 1e-6,
            "trial {k}: the weighting did not move"
        );
    }
}

/// The estimate identify makes of `readings` (the route of
/// `calibration::identify_with`, one linearisation, built from the
/// readings alone).
fn identify_readings(cfg: &Config, readings: &[crate::mechanism::tricept::Reading]) -> ErrorVector {
    let nominal = cfg.nominal();
    let targets: Vec<nalgebra::Vector3<f64>> = readings.iter().map(|r| r.target).collect();
    let poses = crate::mechanism::tricept::NominalPoses::new(&nominal, &targets).unwrap();
    let h = crate::identify::tricept::design_matrix(&nominal, &poses).unwrap();
    let joints: Vec<Joints> = readings.iter().map(|r| r.joints).collect();
    let id = &cfg.identification;
    let solver = id
        .method
        .solver(
            (&cfg.sensors, &joints),
            &h,
            id.rank_tolerance,
            (&id.constraints, &crate::mechanism::tricept::PARAM_NAMES),
        )
        .unwrap();
    let measured: Vec<nalgebra::Vector3<f64>> = joints.iter().map(|j| j.as_vector()).collect();
    let l = crate::sensors::observation_vector(&poses.joints, &measured);
    let mut est = ErrorVector::zeros();
    solver.apply(l.as_slice(), &mut est);
    est
}
