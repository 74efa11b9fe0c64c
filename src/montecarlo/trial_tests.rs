//! Tests of the trial kernel against `simulate`, exact kinematics and the
//! identification it should equal.

/// Two forward-kinematics solutions from different starts agree to this
/// (mm or rad): a few times the closure tolerance of 1e-11 mm.
const FK_AGREEMENT: f64 = 5e-11;

/// The largest difference between sensor set `i`'s observation in the last
/// trial (k, formed by [`super::Scratch::form_observations`]) and the one
/// `simulate` reads of the machine `truth` from trial k's sensor stream.
fn simulated_minus_trial(
    ctx: &super::SweepContext,
    truth: &crate::model::Machine,
    s: &super::Scratch,
    i: usize,
    k: u64,
) -> f64 {
    let mut rng = super::stream(ctx.seed, k, 1);
    let readings =
        crate::sensors::simulate_readings(&ctx.poses, truth, Some(&ctx.sensors[i]), &mut rng)
            .unwrap();
    let joints: Vec<nalgebra::Vector3<f64>> =
        readings.iter().map(|r| r.joints.as_vector()).collect();
    crate::sensors::observation_vector(&ctx.poses.joints, &joints)
        .iter()
        .zip(s.observation(i))
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max)
}

mod simulate_and_trial {
    use super::super::*;
    use super::FK_AGREEMENT;
    use crate::config::{Config, ErrorDraw};
    use crate::identify::Method;
    use crate::sensors::{observation_vector, simulate_readings};

    fn paper_context(encoder_arcsec: f64) -> (Config, SweepContext) {
        let cfg = Config::paper().unwrap();
        let study = cfg
            .study()
            .errors(ErrorDraw::Fixed)
            .encoder_arcsec(&[encoder_arcsec])
            .scale_um(&[0.5])
            .methods(&[Method::Ols, Method::Wls])
            .trials(1)
            .build()
            .unwrap();
        let ctx = SweepContext::new(&cfg, &study).unwrap();
        (cfg, ctx)
    }

    #[test]
    fn trial_sees_what_simulate_reads_from_the_same_stream() {
        let (cfg, ctx) = paper_context(4.0);
        let mut s = Scratch::new(&ctx);
        let mut out = vec![Outcome::default(); ctx.grades.len()];
        let k = 17;
        run_trial(&ctx, k, &mut s, &mut out);
        assert!(ctx.linear, "white noise, one linearisation: the fast path");
        s.form_observations(&ctx);
        // The readings file `simulate` would write with the trial's noise stream.
        let mut rng = stream(ctx.seed, k, 1);
        let readings = simulate_readings(
            &ctx.poses,
            &cfg.truth("test").unwrap(),
            Some(&ctx.sensors[0]),
            &mut rng,
        )
        .unwrap();
        let joints: Vec<Vector3<f64>> = readings.iter().map(|r| r.joints.as_vector()).collect();
        let l = observation_vector(&ctx.poses.joints, &joints);
        let trial_l = s.observation(0);
        let diff = l
            .iter()
            .zip(trial_l)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        // The trial starts forward kinematics from the first-order prediction,
        // simulate from the nominal joints: both stop within FK's closure
        // tolerance (1e-11 mm), so their joints agree to a few times that.
        assert!(diff < FK_AGREEMENT, "readings and trial differ by {diff:e}");
        // Noise is really there: the trial's l is not the noise-free one.
        let exact: f64 = trial_l.iter().zip(&s.l0).map(|(a, b)| (a - b).abs()).sum();
        assert!(exact > 1e-6);
        // Both estimators identify from that observation: the fast path's
        // split estimate equals the estimate of the formed observation.
        let trial_l = DVector::from_column_slice(trial_l);
        for (gi, o) in out.iter().enumerate() {
            let est = ctx.solvers[gi].estimate(&trial_l);
            let from_simulate = ctx.solvers[gi].estimate(&l);
            // The operator amplifies FK's agreement by its row sums (≈ 300).
            assert!((from_simulate.values - est.values).amax() < 1e-7);
            let d = (mu(&cfg.errors, &est.values) - o.mu).abs();
            assert!(d < 1e-9, "grade {gi}: mu differs by {d:e}");
            assert_eq!(o.mu0, mu0(&cfg.errors));
            let de = (o.error - (est.values - cfg.errors)).amax();
            assert!(de < 1e-9, "grade {gi}: estimate differs by {de:e}");
            assert_eq!(o.failure, Failure::None);
        }
    }

    #[test]
    fn every_sensor_grade_reads_the_trials_common_noise() {
        // Two encoder grades: both read stream 1 (common random numbers),
        // never the machine's stream, each scaled by its own grade.
        let cfg = Config::paper().unwrap();
        let study = cfg
            .study()
            .errors(ErrorDraw::Fixed)
            .encoder_arcsec(&[1.0, 4.0])
            .scale_um(&[0.5])
            .trials(1)
            .build()
            .unwrap();
        let ctx = SweepContext::new(&cfg, &study).unwrap();
        let mut s = Scratch::new(&ctx);
        let mut out = vec![Outcome::default(); ctx.grades.len()];
        run_trial(&ctx, 9, &mut s, &mut out);
        s.form_observations(&ctx);
        let truth = cfg.truth("test").unwrap();
        for si in 0..2 {
            let d = super::simulated_minus_trial(&ctx, &truth, &s, si, 9);
            assert!(d < FK_AGREEMENT, "sensor {si}: {d:e}");
        }
    }

    /// The same with the uniform reading of a grade (`noise_model =
    /// "uniform"`): its unit draws are averaged uniforms, not normals.
    #[test]
    fn a_uniform_grade_reads_what_simulate_reads() {
        let text =
            "[sensors]\nnoise_model = \"uniform\"\nsamples = 2\n[errors]\ndxB1 = 0.2\ndq2 = 0.3\n";
        let cfg = Config::from_raw(crate::config::parse_raw(text, "t").unwrap(), "t").unwrap();
        let study = cfg
            .study()
            .errors(ErrorDraw::Fixed)
            .encoder_arcsec(&[1.0, 4.0])
            .scale_um(&[0.5])
            .trials(1)
            .build()
            .unwrap();
        let ctx = SweepContext::new(&cfg, &study).unwrap();
        assert!(ctx.linear);
        let mut s = Scratch::new(&ctx);
        let mut out = vec![Outcome::default(); ctx.grades.len()];
        run_trial(&ctx, 9, &mut s, &mut out);
        s.form_observations(&ctx);
        let truth = cfg.truth("test").unwrap();
        for si in 0..2 {
            let d = super::simulated_minus_trial(&ctx, &truth, &s, si, 9);
            assert!(d < FK_AGREEMENT, "sensor {si}: {d:e}");
        }
    }

    #[test]
    fn failure_codes_round_trip() {
        for f in [
            Failure::None,
            Failure::ForwardKinematics,
            Failure::NotConverged,
        ] {
            assert_eq!(Failure::from_code(f.code()), Some(f));
        }
        assert_eq!(Failure::from_code(9), None);
        assert_eq!(Failure::NotConverged.label(), "not_converged");
    }

    /// A Gauss–Newton trial identifies from what `simulate` reads with the
    /// trial's stream (the independent route: readings file → observation →
    /// `identify`), with white noise and with datasheet sensors, for two
    /// encoder grades (the second set shares the first's scale: its rows
    /// must be copied for Gauss–Newton, which reads the whole observation).
    #[test]
    fn a_gauss_newton_trial_identifies_what_simulate_reads() {
        let datasheet = "[sensors.encoder]\naccuracy_arcsec = 3.0\nnoise_arcsec = 0.05\n[sensors.scale]\naccuracy_um = 1.0\n[errors]\ndxB1 = 0.2\ndq2 = 0.3\n";
        let configs = [
            Config::paper().unwrap(),
            Config::from_raw(crate::config::parse_raw(datasheet, "t").unwrap(), "t").unwrap(),
        ];
        for cfg in configs {
            let study = cfg
                .study()
                .errors(ErrorDraw::Fixed)
                .encoder_arcsec(&[4.0, 1.0])
                .scale_um(&[2.0])
                .trials(1)
                .iterations(5)
                .build()
                .unwrap();
            let ctx = SweepContext::new(&cfg, &study).unwrap();
            assert!(!ctx.linear && !ctx.datasheet_linear);
            let mut s = Scratch::new(&ctx);
            let mut out = vec![Outcome::default(); ctx.grades.len()];
            assert_eq!(out.len(), 2);
            run_trial(&ctx, 9, &mut s, &mut out);
            for (gi, g) in ctx.grades.iter().enumerate() {
                let readings = simulate_readings(
                    &ctx.poses,
                    &cfg.truth("test").unwrap(),
                    Some(&ctx.sensors[g.sensor_index]),
                    &mut stream(ctx.seed, 9, 1),
                )
                .unwrap();
                let joints: Vec<Vector3<f64>> =
                    readings.iter().map(|r| r.joints.as_vector()).collect();
                let l = observation_vector(&ctx.poses.joints, &joints);
                let (est, _) = crate::identify::identify(
                    &ctx.geometry,
                    &ctx.poses,
                    &ctx.solvers[gi],
                    &l,
                    &ctx.options,
                )
                .unwrap();
                let d = (out[gi].error - (est.values - cfg.errors)).amax();
                // The noise is far above this: the sign of the errors matters.
                assert!(d < 1e-7, "grade {gi}: estimate differs by {d:e}");
                assert!(out[gi].budget.iter().all(|b| b.is_nan()));
            }
        }
    }

    #[test]
    fn gauss_newton_in_a_trial_beats_one_linearisation_without_noise() {
        let cfg = Config::paper().unwrap();
        let mu_with = |iterations: usize| {
            let study = cfg
                .study()
                .errors(ErrorDraw::Fixed)
                .encoder_arcsec(&[1e-9])
                .scale_um(&[1e-9])
                .trials(1)
                .iterations(iterations)
                .build()
                .unwrap();
            let ctx = SweepContext::new(&cfg, &study).unwrap();
            let mut s = Scratch::new(&ctx);
            let mut out = vec![Outcome::default(); 1];
            run_trial(&ctx, 0, &mut s, &mut out);
            assert_eq!(out[0].failure, Failure::None);
            out[0].mu
        };
        let (one, gn) = (mu_with(1), mu_with(10));
        // dyA3 (0.2 mm in Table 2) cannot be identified: μ ≥ 0.2/15 ≈ 0.0133;
        // one linearisation leaves ≈ 0.0142, Gauss–Newton ≈ 0.0135.
        let floor = cfg.errors[11].abs() / 15.0;
        assert!(gn > floor && gn < floor + 2e-4, "Gauss-Newton mu {gn}");
        assert!(
            one > gn + 5e-4,
            "one linearisation {one} vs Gauss-Newton {gn}"
        );
    }
}

mod structured_sensors {
    use super::super::*;
    use crate::config::parse_raw;
    use crate::config::{Config, ErrorDraw};
    use crate::identify::Method;
    use crate::sensors::ARCSEC_PER_RAD;
    const DATASHEETS: &str = "[sensors.encoder]\naccuracy_arcsec = 2.0\nharmonics = [0.8, 0.2]\nnoise_arcsec = 0.05\nresolution_arcsec = 0.01\n[sensors.scale]\naccuracy_um = 0.5\nnoise_um = 0.02\n[errors]\ndxB1 = 0.2\ndq2 = 0.3\n";

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
        assert_eq!(ctx.datasheet_linear, linear);
        let mut s = Scratch::new(&ctx);
        let mut out = vec![Outcome::default(); 1];
        run_trial(&ctx, 4, &mut s, &mut out);
        s.form_observations(&ctx);
        let truth = cfg.truth("test").unwrap();
        let diff = super::simulated_minus_trial(&ctx, &truth, &s, 0, 4);
        assert!(diff < super::FK_AGREEMENT, "{diff:e}");
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
        let text = DATASHEETS.replace(
            "noise_um = 0.02\n",
            "noise_um = 0.02\nresolution_um = 0.01\n",
        );
        let cfg = Config::from_raw(parse_raw(&text, "t").unwrap(), "t").unwrap();
        let study = cfg
            .study()
            .errors(ErrorDraw::Fixed)
            .encoder_arcsec(&[1.0, 4.0])
            .scale_um(&[0.5, 2.0])
            .methods(&[Method::Ols, Method::Wls])
            .trials(1)
            .build()
            .unwrap();
        let ctx = SweepContext::new(&cfg, &study).unwrap();
        assert!(!ctx.linear && !ctx.datasheet_linear);
        // Sets are scale-major: (1″, 0.5), (4″, 0.5), (1″, 2), (4″, 2).
        assert_eq!(
            ctx.axis_of,
            vec![[0, 0, 0], [1, 1, 0], [0, 0, 2], [1, 1, 2]]
        );
        assert_eq!(ctx.draw_class, vec![0; 4]);
        let shared = (0..ctx.grades.len())
            .filter(|&gi| ctx.sensor_split_of[gi].iter().any(|&gj| gj != gi))
            .count();
        assert!(shared >= 3, "{:?}", ctx.sensor_split_of);
        let mut s = Scratch::new(&ctx);
        let mut out = vec![Outcome::default(); ctx.grades.len()];
        let truth = cfg.truth("test").unwrap();
        for k in [4, 11] {
            run_trial(&ctx, k, &mut s, &mut out);
            s.form_observations(&ctx);
            for i in 0..ctx.sensors.len() {
                let diff = super::simulated_minus_trial(&ctx, &truth, &s, i, k);
                assert!(diff < super::FK_AGREEMENT, "set {i}: {diff:e}");
            }
            for (gi, g) in ctx.grades.iter().enumerate() {
                let l = s.observation(g.sensor_index);
                let mut est = crate::model::ErrorVector::zeros();
                ctx.solvers[gi].apply(l, &mut est);
                let d = (out[gi].error - (est - cfg.errors)).amax();
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
            let text = format!(
                "[sensors]\nsamples = {samples}\n{}",
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
                .errors(ErrorDraw::Random)
                .encoder_arcsec(&[1.0, 4.0])
                .scale_um(&[0.5, 2.0])
                .methods(&[Method::Ols, Method::Wls])
                .trials(3)
                .build()
                .unwrap();
            let ctx = SweepContext::new(&cfg, &study).unwrap();
            assert!(!ctx.linear && !ctx.datasheet_linear);
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
}

mod pose_subsets_and_budget {
    use super::super::*;
    use crate::config::{Config, ErrorDraw};
    use crate::identify::{design_matrix, LinearSolver};
    use crate::model::NominalPoses;
    use crate::montecarlo::context::spread_poses;
    use nalgebra::DVector;

    /// The paper's machine with white-noise sensors, and with datasheet
    /// sensors (curve, interpolation, jitter, quantisation; the datasheet
    /// kernel's path, one of them with the ψ4 encoder alone on a datasheet).
    fn configs() -> Vec<Config> {
        // (Paths: white noise; datasheet per sensor set; the last two
        // unquantised, so the datasheet-linear path.)
        let datasheet = |sections: &str| {
            let text = format!("{sections}[errors]\ndxB1 = 0.2\ndyA2 = -0.3\ndq2 = 0.3\n");
            Config::from_raw(crate::config::parse_raw(&text, "t").unwrap(), "t").unwrap()
        };
        vec![
            Config::paper().unwrap(),
            datasheet("[sensors.encoder]\naccuracy_arcsec = 2.0\nharmonics = [0.7, 0.3]\ninterpolation_arcsec = 0.36\nsignal_period_arcsec = 72.0\nnoise_arcsec = 0.02\nresolution_arcsec = 0.0176\n[sensors.scale]\naccuracy_um = 0.5\nharmonics = [0.8, 0.2]\ninterpolation_um = 0.04\nsignal_period_um = 4.0\nnoise_um = 0.003\nresolution_um = 0.001\n"),
            datasheet("[sensors.encoder_psi]\naccuracy_arcsec = 3.0\n"),
            datasheet("[sensors.encoder]\naccuracy_arcsec = 2.0\nharmonics = [0.7, 0.3]\ninterpolation_arcsec = 0.36\nsignal_period_arcsec = 72.0\nnoise_arcsec = 0.02\n[sensors.scale]\naccuracy_um = 0.5\nharmonics = [1.0]\nnoise_um = 0.003\n"),
        ]
    }

    #[test]
    fn the_test_configs_take_every_path_of_the_trial() {
        let paths: Vec<(bool, bool)> = configs()
            .iter()
            .map(|cfg| {
                let ctx = SweepContext::new(cfg, &cfg.study().trials(1).build().unwrap()).unwrap();
                (ctx.linear, ctx.datasheet_linear)
            })
            .collect();
        assert_eq!(
            paths,
            vec![(true, false), (false, false), (false, true), (false, true)]
        );
    }

    #[test]
    fn the_pose_rule_spreads_the_subset_and_keeps_the_reference() {
        assert_eq!(spread_poses(51, 5), vec![0, 13, 25, 38, 50]);
        assert_eq!(spread_poses(51, 2), vec![0, 50]);
        assert_eq!(spread_poses(5, 5), vec![0, 1, 2, 3, 4]);
        for total in 2..60 {
            for count in 2..=total {
                let p = spread_poses(total, count);
                assert_eq!(p.len(), count);
                assert_eq!((p[0], p[count - 1]), (0, total - 1));
                assert!(p.windows(2).all(|w| w[0] < w[1]), "{total} {count}");
            }
        }
    }

    /// A pose-count grade identifies like a study whose poses are that
    /// subset (an independent route: its own poses, design matrix and
    /// operator), on the same machine and noise.
    #[test]
    fn a_pose_subset_identifies_like_a_study_of_those_poses() {
        for cfg in configs() {
            subset_identifies_like_a_study_of_those_poses(&cfg);
        }
    }

    fn subset_identifies_like_a_study_of_those_poses(cfg: &Config) {
        let study = cfg
            .study()
            .errors(ErrorDraw::Fixed)
            .pose_counts(&[9, 51])
            .trials(1)
            .build()
            .unwrap();
        let ctx = SweepContext::new(cfg, &study).unwrap();
        assert_eq!(ctx.grades.len(), 2 * 7);
        let mut s = Scratch::new(&ctx);
        let mut out = vec![Outcome::default(); ctx.grades.len()];
        run_trial(&ctx, 3, &mut s, &mut out);
        s.form_observations(&ctx);
        let keep = spread_poses(51, 9);
        let targets: Vec<_> = keep.iter().map(|&k| cfg.poses[k]).collect();
        let sub = NominalPoses::new(&cfg.nominal(), &targets).unwrap();
        let h = design_matrix(&cfg.nominal(), &sub).unwrap();
        let solver = LinearSolver::new(&h, &DVector::from_element(h.nrows(), 1.0), 1e-9);
        for (gi, g) in ctx
            .grades
            .iter()
            .enumerate()
            .filter(|(_, g)| g.pose_count == 9)
        {
            let full = s.observation(g.sensor_index);
            // l of the subset: rows of the kept poses, relative to the reference.
            let l: Vec<f64> = keep[1..]
                .iter()
                .flat_map(|&p| full[3 * (p - 1)..3 * p].to_vec())
                .collect();
            let mut est = crate::model::ErrorVector::zeros();
            solver.apply(&l, &mut est);
            let d = (out[gi].error - (est - cfg.errors)).amax();
            assert!(d < 1e-9, "grade {gi}: {d:e}");
        }
        // Fewer poses, larger error: over 200 noise draws of this machine.
        let (mut m9, mut m51) = (0.0, 0.0);
        for k in 0..200 {
            run_trial(&ctx, k, &mut s, &mut out);
            for (g, o) in ctx.grades.iter().zip(&out) {
                *if g.pose_count == 9 { &mut m9 } else { &mut m51 } += o.mu;
            }
        }
        assert!(m9 > m51, "{m9} {m51}");
    }

    /// The budget's terms by an independent route: identify from the
    /// observation with one sensor's noise removed (the scale rows of l set
    /// to the noise-free ones) and from the noise-free observation.
    #[test]
    fn the_budget_is_the_calibration_with_a_sensor_made_perfect() {
        for cfg in configs() {
            budget_is_the_calibration_with_a_sensor_made_perfect(&cfg);
        }
    }

    fn budget_is_the_calibration_with_a_sensor_made_perfect(cfg: &Config) {
        let study = cfg
            .study()
            .errors(ErrorDraw::Fixed)
            .trials(1)
            .build()
            .unwrap();
        let ctx = SweepContext::new(cfg, &study).unwrap();
        let mut s = Scratch::new(&ctx);
        let mut out = vec![Outcome::default(); ctx.grades.len()];
        run_trial(&ctx, 8, &mut s, &mut out);
        s.form_observations(&ctx);
        let l0 = s.l0.clone();
        for (gi, g) in ctx.grades.iter().enumerate() {
            let l = s.observation(g.sensor_index).to_vec();
            let solve = |v: &[f64]| {
                let mut e = crate::model::ErrorVector::zeros();
                ctx.solvers[gi].apply(v, &mut e);
                mu(&cfg.errors, &e)
            };
            let without = |k: usize| {
                let v: Vec<f64> = l
                    .iter()
                    .zip(&l0)
                    .enumerate()
                    .map(|(r, (a, b))| if r % 3 == k { *b } else { *a })
                    .collect();
                solve(&v)
            };
            let b = out[gi].budget;
            assert!((b[0] - solve(&l0)).abs() < 1e-12, "floor");
            for k in 0..3 {
                assert!(
                    (b[1 + k] - without(k)).abs() < 1e-12,
                    "sensor {k}: {} vs {}",
                    b[1 + k],
                    without(k)
                );
            }
            assert!(b[0] < out[gi].mu);
        }
    }
}
