//! criterion benchmarks: exact forward kinematics, one identification, one
//! sweep trial (7 grades; white-noise and datasheet sensors; workspace
//! judged) and one Monte-Carlo batch of the default study.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use nalgebra::Vector3;
use std::hint::black_box;
use tricept_calib::cli::load_config;
use tricept_calib::identify::Method;
use tricept_calib::mechanism::tricept::{ErrorVector, Machine, PAPER_ERRORS_MM};
use tricept_calib::montecarlo::{
    self, KernelPath, NoRows, Outcome, RunOptions, Scratch, SweepContext,
};
use tricept_calib::store::WriterSink;

fn benches(c: &mut Criterion) {
    let cfg = load_config(None, |raw| {
        raw.sweep.errors = "random".into();
    })
    .unwrap();
    let g = cfg.geometry;
    let truth = Machine::with_errors(&g, &ErrorVector::from_row_slice(&PAPER_ERRORS_MM));
    let nominal = Machine::nominal(&g);
    let r = Vector3::new(250.0, -180.0, 720.0);
    let pose = nominal.inverse(&r).unwrap();
    c.bench_function("forward_kinematics", |b| {
        b.iter(|| {
            truth
                .forward(black_box(&pose.legs_mm), black_box(&pose.joints))
                .unwrap()
        })
    });

    // The sweep's FK kernel: four poses near their nominal configurations in
    // lock-step (here the same pose four times, started from its nominal
    // joints; per pose: divide by 4).
    let anchor = tricept_calib::mechanism::tricept::near::Anchor::new(&pose.joints);
    let guess = pose.joints;
    c.bench_function("forward_kinematics_near_4_poses", |b| {
        b.iter(|| {
            truth.forward_near_group(
                [black_box(&pose.legs_mm); 4],
                [&anchor; 4],
                [black_box(&guess); 4],
            )
        })
    });

    let study = cfg.study().build().unwrap();
    let ctx = SweepContext::new(&cfg, &study).unwrap();
    let mut scratch = Scratch::new(&ctx);
    let mut out = vec![Outcome::default(); ctx.grades().len()];
    c.bench_function("one_identification_ols_51_poses", |b| {
        let l = vec![1e-4; ctx.rows()];
        let mut est = ErrorVector::zeros();
        b.iter(|| ctx.solvers()[0].apply(black_box(&l), &mut est))
    });
    c.bench_function("apply_by_sensor_51_poses", |b| {
        let e: Vec<f64> = (0..ctx.rows()).map(|r| 1e-4 * (r as f64).sin()).collect();
        b.iter(|| ctx.solvers()[0].apply_by_sensor(black_box(&e)))
    });
    let mut k = 0u64;
    c.bench_function("sweep_trial_7_grades", |b| {
        b.iter(|| {
            k += 1;
            montecarlo::run_trial(&ctx, black_box(k), &mut scratch, &mut out)
        })
    });

    // The same trial with datasheet sensors (benches/datasheet-study.toml:
    // curve, interpolation, jitter and quantisation of the example
    // catalogue's ±2″ encoder and ±0.5 µm scale; the grade axis sets the
    // encoders' accuracy).
    let sheet = load_config(
        Some(std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/benches/datasheet-study.toml"
        ))),
        |_| {},
    )
    .unwrap();
    let sstudy = sheet.study().build().unwrap();
    let sctx = SweepContext::new(&sheet, &sstudy).unwrap();
    let mut sscratch = Scratch::new(&sctx);
    let mut sout = vec![Outcome::default(); sctx.grades().len()];
    c.bench_function("sweep_trial_7_grades_datasheet_sensors", |b| {
        b.iter(|| {
            k += 1;
            montecarlo::run_trial(&sctx, black_box(k), &mut sscratch, &mut sout)
        })
    });

    // The same sensors without quantisation (resolution 0): every estimate
    // is linear in the parts of the machine's sensor errors.
    let unq = load_config(
        Some(std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/benches/datasheet-study.toml"
        ))),
        |raw| {
            if let Some(e) = raw.sensors.encoder.as_mut() {
                e.resolution_arcsec = 0.0;
            }
            if let Some(s) = raw.sensors.scale.as_mut() {
                s.resolution_um = 0.0;
            }
            // One operator per study (GLS weighted per machine has its
            // own path and figure).
            raw.sweep.gls_per_machine = Some(false);
        },
    )
    .unwrap();
    let uctx = SweepContext::new(&unq, &unq.study().build().unwrap()).unwrap();
    assert_eq!(uctx.plan().path, KernelPath::DatasheetParts);
    let mut uscratch = Scratch::new(&uctx);
    let mut uout = vec![Outcome::default(); uctx.grades().len()];
    c.bench_function("sweep_trial_7_grades_datasheet_unquantised", |b| {
        b.iter(|| {
            k += 1;
            montecarlo::run_trial(&uctx, black_box(k), &mut uscratch, &mut uout)
        })
    });

    // The unquantised datasheet study under WLS and under GLS: one
    // operator each, built before the trials, so a trial costs the same
    // (issue 19: within 10 %).
    for method in [Method::Wls, Method::Gls] {
        let study = unq.study().methods(&[method]).build().unwrap();
        let mctx = SweepContext::new(&unq, &study).unwrap();
        assert_eq!(mctx.plan().path, KernelPath::DatasheetParts);
        let mut mscratch = Scratch::new(&mctx);
        let mut mout = vec![Outcome::default(); mctx.grades().len()];
        c.bench_function(
            &format!("sweep_trial_7_grades_datasheet_{}", method.name()),
            |b| {
                b.iter(|| {
                    k += 1;
                    montecarlo::run_trial(&mctx, black_box(k), &mut mscratch, &mut mout)
                })
            },
        );
    }

    // One trial with the workspace judged by first-order propagation
    // (5 layers × 49 points + P1–P5, 7 grades).
    let mut vol = cfg.study().build().unwrap();
    vol.sweep.volumetric_step_mm = Some(100.0);
    let vctx = SweepContext::new(&cfg, &vol).unwrap();
    let mut vscratch = Scratch::new(&vctx);
    let mut vout = vec![Outcome::default(); vctx.grades().len()];
    c.bench_function("sweep_trial_7_grades_volumetric", |b| {
        b.iter(|| {
            k += 1;
            montecarlo::run_trial(&vctx, black_box(k), &mut vscratch, &mut vout)
        })
    });

    let mut group = c.benchmark_group("sweep_batch");
    let trials = 2000u64;
    group.throughput(Throughput::Elements(trials * ctx.grades().len() as u64));
    group.sample_size(10);
    let threads = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1);
    group.bench_function("2000_trials_7_grades_with_trials_csv", |b| {
        b.iter(|| {
            let mut sink = WriterSink::new(std::io::sink(), std::path::Path::new("trials.csv"));
            montecarlo::run(
                &ctx,
                &study,
                RunOptions {
                    trials,
                    threads,
                    progress: &montecarlo::Silent,
                    sink: &mut sink,
                    resume: None,
                },
            )
            .unwrap()
        })
    });
    // The sweep itself (runner, summaries, no trials.csv, as `sweep
    // --no-trials` runs it) at the example catalogue study's 20 000
    // machines, white noise and the datasheet study: the ratio benches/README.md
    // quotes for "the sweep keeps up with datasheet sensors".
    let study_trials = 20_000u64;
    group.throughput(Throughput::Elements(
        study_trials * ctx.grades().len() as u64,
    ));
    for (name, c, st) in [
        ("20000_trials_7_grades_no_trials_csv", &ctx, &study),
        (
            "20000_trials_7_grades_no_trials_csv_datasheet_sensors",
            &sctx,
            &sstudy,
        ),
    ] {
        group.bench_function(name, |b| {
            b.iter(|| {
                montecarlo::run(
                    c,
                    st,
                    RunOptions {
                        trials: study_trials,
                        threads,
                        progress: &montecarlo::Silent,
                        sink: &mut NoRows,
                        resume: None,
                    },
                )
                .unwrap()
            })
        });
    }
    group.finish();
}

/// A real machine's log of n poses with datasheet sensors of unknown curve
/// shape, identified with GLS and every check of the fit (misfit, five
/// held-out folds, predicted accuracy): what `identify` does after parsing.
/// Σ is factored, so the cost grows as n (README: rows against time and
/// memory, 100,000 poses included).
fn long_logs(c: &mut Criterion) {
    let mut group = c.benchmark_group("identify_log");
    group.sample_size(10);
    for (layers, points) in [(10, 33), (50, 66)] {
        let text = format!(
            "[poses]\nlayers = {layers}\nring_fractions = [0.3, 0.6, 1.0]\npoints_per_ring = {points}\n[sensors]\nsamples = 3\n[sensors.encoder]\naccuracy_arcsec = 5.0\nharmonics = \"unknown\"\ncurve_order = 6\ninterpolation_arcsec = 0.5\nsignal_period_arcsec = 72.0\nnoise_arcsec = 0.02\n[sensors.scale]\naccuracy_um = 2.0\nharmonics = \"unknown\"\ncurve_order = 6\ninterpolation_um = 0.05\nsignal_period_um = 20.0\nnoise_um = 0.005\n[identification]\nmethod = \"gls\"\n[errors]\ndxB1 = 0.2\ndyA2 = -0.3\ndq2 = 0.3\n"
        );
        let cfg = tricept_calib::config::Config::from_raw(
            tricept_calib::config::parse_raw(&text, "bench").unwrap(),
            "bench",
        )
        .unwrap();
        let poses = cfg.nominal_poses().unwrap();
        let readings = tricept_calib::calibration::simulate(&cfg, &poses, 1, false).unwrap();
        group.throughput(Throughput::Elements(readings.len() as u64));
        group.bench_function(format!("gls_checks_{}_poses", readings.len()), |b| {
            b.iter(|| {
                let cal = tricept_calib::calibration::identify_from(
                    &cfg,
                    black_box(&readings),
                    tricept_calib::io::Source::new("log", &[]),
                )
                .unwrap();
                black_box(tricept_calib::calibration::checks(&cfg, &cal, &readings))
            })
        });
    }
    group.finish();
}

/// The shipped hexapod study (`configs/hexapod.toml`: 6 catalogue
/// encoders × one or two a joint × 12, 20, 30 poses × linear and gls = 72
/// calibrations of each machine, 189 workspace poses) through the study
/// kernel on one thread, 2,000 machines an iteration (the study's set-up,
/// its operators and sensitivities, about 0.1 s, is then a small part); and the same study
/// with one encoder, both a joint, 30 poses and the workspace reduced to
/// the home pose: the case of 30 poses, 12 readings, 45 errors.
/// Throughput: calibrations.
fn hexapod(c: &mut Criterion) {
    use tricept_calib::cli::commands::hexapod::sizes;
    use tricept_calib::config::hexapod::HexapodConfig;
    use tricept_calib::montecarlo::general::kernel::run_kernel;
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/configs/hexapod.toml");
    let text = std::fs::read_to_string(path).unwrap();
    let mut group = c.benchmark_group("hexapod");
    const MACHINES: u64 = 2000;
    group.sample_size(10);
    for (name, text) in [
        ("shipped_study_2000_machines", text.clone()),
        (
            "one_encoder_30_poses_home_only_2000_machines",
            text.replace(
                "per_joint = [\"both\", \"first\"]",
                "per_joint = [\"both\"]",
            )
            .replace("pose_counts = [12, 20, 30]", "pose_counts = [30]")
            .replace(
                "catalogue = \"sensors.toml\"",
                "catalogue = \"sensors.toml\"\nencoders = [\"angle-2as-d100\"]",
            )
            .replace("grid = 3", "grid = 1")
            .replace("tilt_deg = 8", "tilt_deg = 0"),
        ),
    ] {
        let cfg = HexapodConfig::parse(&text, path).unwrap();
        let mut spec = cfg.study.as_ref().unwrap().spec.clone();
        spec.trials = MACHINES;
        let combos = tricept_calib::montecarlo::general::kernel::combinations(&spec).len();
        group.throughput(Throughput::Elements(combos as u64 * MACHINES));
        let mut seed = 0u64;
        group.bench_function(name, |b| {
            b.iter(|| {
                seed += 1;
                spec.seed = seed;
                black_box(run_kernel(&cfg.hexapod, &cfg.poses, &spec, 1, sizes).unwrap())
            })
        });
    }
    group.finish();
}

criterion_group!(calibration, benches, long_logs, hexapod);
criterion_main!(calibration);
