//! Tests of the trial kernel against `simulate`, exact kinematics and the
//! identification it should equal.

/// Two forward-kinematics solutions from different starts agree to this
/// (mm or rad): a few times the closure tolerance of 1e-11 mm.
pub(in crate::montecarlo) const FK_AGREEMENT: f64 = 5e-11;

/// The Tricept's study and a worker's buffers of it.
pub(in crate::montecarlo) type SweepContext = crate::montecarlo::tricept::TriceptContext;
pub(in crate::montecarlo) type TriceptScratch = super::Scratch<
    crate::montecarlo::tricept::TriceptStudy,
    { crate::mechanism::tricept::N_PARAMS },
    { crate::mechanism::tricept::N_READINGS },
    { crate::mechanism::tricept::second_class::N_ANGLES },
>;

/// The largest difference between sensor set `i`'s observation in the last
/// trial (k, formed by [`super::Scratch::form_observations`]) and the one
/// `simulate` reads of the machine `truth` from trial k's sensor stream.
pub(super) fn simulated_minus_trial(
    ctx: &crate::montecarlo::tricept::TriceptContext,
    truth: &crate::mechanism::tricept::Machine,
    s: &TriceptScratch,
    i: usize,
    k: u64,
) -> f64 {
    let mut rng = super::stream(ctx.seed, k, 1);
    let readings = crate::identify::tricept::simulate_readings(
        &ctx.mech.poses,
        truth,
        Some(&ctx.sensors[i]),
        &mut rng,
    )
    .unwrap();
    let joints: Vec<nalgebra::Vector3<f64>> =
        readings.iter().map(|r| r.joints.as_vector()).collect();
    crate::sensors::observation_vector(&ctx.mech.poses.joints, &joints)
        .iter()
        .zip(s.observation(i))
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max)
}

mod simulate_and_trial {
    use super::super::*;
    use super::{SweepContext, FK_AGREEMENT};
    use crate::config::{Config, ErrorDraw};
    use crate::identify::tricept::simulate_readings;
    use crate::identify::Method;
    use crate::sensors::observation_vector;
    use nalgebra::Vector3;

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
        assert!(
            matches!(ctx.plan.path, KernelPath::WhiteNoise { .. }),
            "white noise, one linearisation: the fast path"
        );
        s.form_observations(&ctx);
        // The readings file `simulate` would write with the trial's noise stream.
        let mut rng = stream(ctx.seed, k, 1);
        let readings = simulate_readings(
            &ctx.mech.poses,
            &cfg.truth("test").unwrap(),
            Some(&ctx.sensors[0]),
            &mut rng,
        )
        .unwrap();
        let joints: Vec<Vector3<f64>> = readings.iter().map(|r| r.joints.as_vector()).collect();
        let l = observation_vector(&ctx.mech.poses.joints, &joints);
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
            let de = (s.error(gi) - (est.values - cfg.errors)).amax();
            assert!(de < 1e-9, "grade {gi}: estimate differs by {de:e}");
            assert_eq!(o.failure, Failure::None);
        }
    }

    #[test]
    fn every_sensor_grade_reads_the_trials_common_noise() {
        // Two encoder grades: both read stream 1 (common random numbers),
        // never the machine's stream, each scaled by its own grade.
        two_grades_read_what_simulate_reads(&Config::paper().unwrap());
    }

    /// Trial 9 of encoder grades 1″ and 4″: each sensor set's observation
    /// is what `simulate` reads with that grade (see
    /// `simulated_minus_trial`). Returns the study's context.
    fn two_grades_read_what_simulate_reads(cfg: &Config) -> SweepContext {
        let study = cfg
            .study()
            .errors(ErrorDraw::Fixed)
            .encoder_arcsec(&[1.0, 4.0])
            .scale_um(&[0.5])
            .trials(1)
            .build()
            .unwrap();
        let ctx = SweepContext::new(cfg, &study).unwrap();
        let mut s = Scratch::new(&ctx);
        let mut out = vec![Outcome::default(); ctx.grades.len()];
        run_trial(&ctx, 9, &mut s, &mut out);
        s.form_observations(&ctx);
        let truth = cfg.truth("test").unwrap();
        for si in 0..2 {
            let d = super::simulated_minus_trial(&ctx, &truth, &s, si, 9);
            assert!(d < FK_AGREEMENT, "sensor {si}: {d:e}");
        }
        ctx
    }

    /// The same with the uniform reading of a grade (`noise_model =
    /// "uniform"`): its unit draws are averaged uniforms, not normals.
    #[test]
    fn a_uniform_grade_reads_what_simulate_reads() {
        let text =
            "[sensors]\nnoise_model = \"uniform\"\nsamples = 2\n[errors]\ndxB1 = 0.2\ndq2 = 0.3\n";
        let cfg = Config::from_raw(crate::config::parse_raw(text, "t").unwrap(), "t").unwrap();
        let ctx = two_grades_read_what_simulate_reads(&cfg);
        assert!(matches!(ctx.plan.path, KernelPath::WhiteNoise { .. }));
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
            assert!(matches!(
                ctx.plan.path,
                KernelPath::PerSensor { .. } | KernelPath::GaussNewton { .. }
            ));
            let mut s = Scratch::new(&ctx);
            let mut out = vec![Outcome::default(); ctx.grades.len()];
            assert_eq!(out.len(), 2);
            run_trial(&ctx, 9, &mut s, &mut out);
            for (gi, g) in ctx.grades.iter().enumerate() {
                let readings = simulate_readings(
                    &ctx.mech.poses,
                    &cfg.truth("test").unwrap(),
                    Some(&ctx.sensors[g.sensor_index]),
                    &mut stream(ctx.seed, 9, 1),
                )
                .unwrap();
                let joints: Vec<Vector3<f64>> =
                    readings.iter().map(|r| r.joints.as_vector()).collect();
                let l = observation_vector(&ctx.mech.poses.joints, &joints);
                let (est, _) = crate::identify::tricept::identify(
                    &ctx.mech.geometry,
                    &ctx.mech.poses,
                    &ctx.solvers[gi],
                    &l,
                    &ctx.options,
                )
                .unwrap();
                let d = (s.error(gi) - (est.values - cfg.errors)).amax();
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

mod pose_subsets_and_budget {
    use super::super::*;
    use super::SweepContext;
    use crate::config::{Config, ErrorDraw};
    use crate::identify::tricept::{design_matrix, LinearSolver};
    use crate::mechanism::tricept::NominalPoses;
    use crate::montecarlo::context::spread_poses;

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
        let paths: Vec<&str> = configs()
            .iter()
            .map(|cfg| {
                let ctx = SweepContext::new(cfg, &cfg.study().trials(1).build().unwrap()).unwrap();
                ctx.plan.name()
            })
            .collect();
        assert_eq!(
            paths,
            [
                "white noise",
                "per sensor",
                "datasheet parts",
                "datasheet parts"
            ]
        );
        // More than one linearisation: every set's every shared axis is
        // copied, whatever the sensors.
        for cfg in &configs()[..2] {
            let study = cfg.study().trials(1).iterations(3).build().unwrap();
            let ctx = SweepContext::new(cfg, &study).unwrap();
            let KernelPath::GaussNewton { axes } = &ctx.plan.path else {
                panic!("iterations = 3 took the {} path", ctx.plan.name());
            };
            assert!(axes.rows_read.iter().flatten().all(|&r| r));
            assert_eq!(axes.rows_read.len(), ctx.sensors.len());
        }
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
        let solver = LinearSolver::unweighted(&h, 1e-9);
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
            let mut est = crate::mechanism::tricept::ErrorVector::zeros();
            solver.apply(&l, &mut est);
            let d = (s.error(gi) - (est - cfg.errors)).amax();
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
                let mut e = crate::mechanism::tricept::ErrorVector::zeros();
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

    /// The deciding metric's budget reads a sensor exactly (its rows of
    /// every error source zeroed in the kernel): on every path of the trial
    /// that calibration is the one the μ budget computes by subtracting
    /// the sensor's part of the estimate, an independent route.
    #[test]
    fn reading_a_sensor_exactly_is_the_budget_s_perfect_sensor() {
        for cfg in configs() {
            let study = cfg.study().trials(1).build().unwrap();
            let ctx = SweepContext::new(&cfg, &study).unwrap();
            let mut s = Scratch::new(&ctx);
            let mut out = vec![Outcome::default(); ctx.grades.len()];
            run_trial(&ctx, 5, &mut s, &mut out);
            let variants = [
                ([true; 3], 0),
                ([true, false, false], 1),
                ([false, true, false], 2),
                ([false, false, true], 3),
            ];
            for (perfect, slot) in variants {
                let mut exact = SweepContext::new(&cfg, &study).unwrap();
                exact.perfect = perfect;
                let mut s2 = Scratch::new(&exact);
                let mut out2 = vec![Outcome::default(); exact.grades.len()];
                run_trial(&exact, 5, &mut s2, &mut out2);
                for (a, b) in out.iter().zip(&out2) {
                    assert!(
                        (a.budget[slot] - b.mu).abs() < 1e-12 * a.mu.max(1e-3),
                        "{} {perfect:?}: {} vs {}",
                        exact.plan.name(),
                        a.budget[slot],
                        b.mu
                    );
                    assert!(b.mu < a.mu || slot != 0, "the floor is below μ");
                }
            }
        }
    }
}
