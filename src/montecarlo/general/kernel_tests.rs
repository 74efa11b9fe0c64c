//! The hexapod's study through the one kernel ([`run_kernel`]) against
//! its own study (`Prepared`, the dense route this folder had): the same
//! machines (their errors before compensation, every combination), and
//! the same judgement after it in distribution, for every instrumentation,
//! pose count and estimator, with white encoders and with encoders of a
//! curve of unknown shape.

use super::*;
use crate::config::hexapod::{Estimator, Sensor, Spec};
use crate::mechanism::hexapod::tests::targets;
use crate::mechanism::hexapod::{Encoders, Hexapod, PHI_READINGS, PSI_READINGS, READINGS};
use crate::mechanism::Mechanism;
use crate::montecarlo::general::dense::Prepared;
use crate::sensors::structured::Shape;
use crate::sensors::{Axis, ARCSEC_PER_RAD};
use nalgebra::Vector3;

/// The hexapod's sizes in the kernel (its commands give them alike).
fn sizes(v: &VariantRun<'_, Hexapod>) -> Result<Vec<Vec<Judged>>, String> {
    match v.m.encoders {
        Encoders::Both => v.run::<33, 12>(&READINGS),
        Encoders::First => v.run::<33, 6>(&PHI_READINGS),
        Encoders::Second => v.run::<33, 6>(&PSI_READINGS),
    }
}

/// The hexapod's error called `name`.
fn error(name: &str) -> usize {
    let names = crate::mechanism::hexapod::error_names();
    names.iter().position(|n| n == name).unwrap()
}

/// A study of one encoder of jitter σ `noise_arcsec` (and a curve of
/// unknown shape of ±`curve_arcsec`) over `trials` machines.
fn spec(noise_arcsec: f64, curve_arcsec: f64, trials: u64) -> Spec {
    Spec {
        sensors: vec![Sensor {
            name: "encoder".into(),
            price: Some(1.0),
            axis: Axis {
                noise: noise_arcsec / ARCSEC_PER_RAD,
                accuracy: curve_arcsec / ARCSEC_PER_RAD,
                shape: Shape::Unknown,
                n_harmonics: if curve_arcsec > 0.0 { 6 } else { 0 },
                period: std::f64::consts::TAU,
                readheads: 1,
                ..Axis::default()
            },
            truth: None,
        }],
        variants: vec![Encoders::Both, Encoders::First],
        pose_counts: vec![12, 30],
        estimators: vec![Estimator::Linear, Estimator::Gls, Estimator::GaussNewton],
        trials,
        seed: 5,
        length_bound_mm: 0.05,
        zero_bound_deg: 0.01,
        samples: 1,
        workspace: targets(9, 6),
        tool_mm: Vector3::new(10.0, -20.0, 150.0),
        iterations: 5,
        fixed: Vec::new(),
        prior_std_mm: None,
        prior_std_deg: None,
    }
}

/// Every combination's machines are the hexapod's own study's (the
/// largest position and orientation errors before compensation agree
/// to 1e-9), and the medians of what compensation leaves agree over 500
/// machines, position and orientation, for white encoders and for a
/// curve of unknown shape (GLS then better than linear): each within
/// 12 % (the two medians' difference has a sampling spread of about
/// 3.2 %; the estimators of one instrumentation and pose count share
/// their draws, so their ratios move together) and their mean within 4 %
/// (measured: 1.03 white, 0.97 with the curve).
#[test]
fn the_kernel_judges_the_hexapods_study_as_its_own_study_does() {
    let hex = Hexapod::example();
    let poses = targets(1, 30);
    for (noise, curve) in [(2.0, 0.0), (0.2, 3.0)] {
        let s = spec(noise, curve, 500);
        let (combos, ours) = run_kernel(&hex, &poses, &s, 2, sizes).unwrap();
        let own = Prepared::new(&hex, &poses, &s).unwrap();
        assert_eq!(combos, own.combinations);
        let theirs = own.run(2).unwrap();
        assert_eq!((ours.len(), ours[0].len()), (500, combos.len()));
        let median = |v: &mut Vec<f64>| {
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        };
        let (mut medians, mut ratios) = (Vec::new(), Vec::new());
        for (ci, c) in combos.iter().enumerate() {
            for k in 0..500 {
                let (a, b) = (ours[k][ci], theirs[k][ci]);
                assert!(
                    (a.position_before - b.position_before).abs() < 1e-9,
                    "{c:?} trial {k}"
                );
                assert!(
                    (a.orientation_before - b.orientation_before).abs() < 1e-6,
                    "{c:?} trial {k}"
                );
            }
            let col = |r: &[Vec<Judged>], f: fn(&Judged) -> f64| {
                median(&mut r.iter().map(|t| f(&t[ci])).collect())
            };
            for (what, f) in [
                (
                    "position",
                    (|j: &Judged| j.position_after) as fn(&Judged) -> f64,
                ),
                ("orientation", |j: &Judged| j.orientation_after),
            ] {
                let (a, b) = (col(&ours, f), col(&theirs, f));
                assert!(
                    (a / b - 1.0).abs() < 0.12,
                    "{noise}″ {curve}″ {c:?} {what}: kernel {a} vs own {b}"
                );
                ratios.push(a / b);
            }
            medians.push((c, col(&ours, |j| j.position_after)));
        }
        let mean = ratios.iter().sum::<f64>() / ratios.len() as f64;
        assert!(
            (mean - 1.0).abs() < 0.04,
            "{noise}″ {curve}″: mean ratio {mean}"
        );
        if curve > 0.0 {
            for (c, m) in &medians {
                if c.estimator == Estimator::Gls {
                    let linear = medians.iter().find(|(d, _)| {
                        d.estimator == Estimator::Linear
                            && (d.variant, d.poses) == (c.variant, c.poses)
                    });
                    assert!(
                        linear.is_some_and(|(_, l)| m < l),
                        "{c:?}: GLS {m} not below linear"
                    );
                }
            }
        }
    }
}

/// A prior on the lengths is every estimator's in the kernel: one of
/// 10⁶ mm leaves every combination's judgement as without one (to 1e-9
/// of it), and one of 10⁻⁶ mm holds every estimate at the nominal
/// machine, so compensation leaves each machine as it was (to 1e-6 of
/// its error). A study that fixes an encoder's zero or puts a prior on
/// the zeros is refused in a sentence naming the key.
#[test]
fn a_prior_on_the_lengths_is_every_estimators_and_the_zeros_are_refused() {
    let hex = Hexapod::example();
    let poses = targets(1, 30);
    let mut s = spec(2.0, 3.0, 20);
    let (_, plain) = run_kernel(&hex, &poses, &s, 2, sizes).unwrap();
    s.prior_std_mm = Some(1e6);
    let (_, loose) = run_kernel(&hex, &poses, &s, 2, sizes).unwrap();
    s.prior_std_mm = Some(1e-6);
    let (combos, tight) = run_kernel(&hex, &poses, &s, 2, sizes).unwrap();
    for k in 0..20 {
        for (ci, c) in combos.iter().enumerate() {
            let (a, b, t) = (plain[k][ci], loose[k][ci], tight[k][ci]);
            let at = format!("trial {k} {c:?}");
            assert!(
                (a.position_after - b.position_after).abs() < 1e-9 * a.position_after,
                "{at}"
            );
            assert!(
                (t.position_after - t.position_before).abs() < 1e-6 * t.position_before,
                "{at}: {} left of {}",
                t.position_after,
                t.position_before
            );
        }
    }
    s.prior_std_mm = None;
    s.prior_std_deg = Some(0.01);
    let why = run_kernel(&hex, &poses, &s, 2, sizes).err().unwrap();
    assert!(
        why.starts_with("identification.prior_std_deg: the study homes"),
        "{why}"
    );
    s.prior_std_deg = None;
    let dphi2 = error("dphi2");
    s.fixed = vec![(dphi2, 0.0)];
    let why = run_kernel(&hex, &poses, &s, 2, sizes).err().unwrap();
    assert!(
        why.starts_with("identification.fix.dphi2: the study homes"),
        "{why}"
    );
}

/// A mechanism's sizes function that gives the kernel other than the
/// study's trials, or other than its combinations for each trial, is
/// refused in a sentence rather than padded or cut: one trial short, and
/// every trial one combination short, each refused; the right shape runs.
#[test]
fn sizes_of_another_shape_are_refused() {
    fn fewer_trials(v: &VariantRun<'_, Hexapod>) -> Result<Vec<Vec<Judged>>, String> {
        let mut out = sizes(v)?;
        out.pop();
        Ok(out)
    }
    fn narrower(v: &VariantRun<'_, Hexapod>) -> Result<Vec<Vec<Judged>>, String> {
        let mut out = sizes(v)?;
        out.iter_mut().for_each(|t| {
            t.pop();
        });
        Ok(out)
    }
    let hex = Hexapod::example();
    let poses = targets(1, 12);
    let mut s = spec(2.0, 0.0, 3);
    s.variants = vec![Encoders::Both];
    s.pose_counts = vec![12];
    s.estimators = vec![Estimator::Linear];
    let (combos, out) = run_kernel(&hex, &poses, &s, 1, sizes).unwrap();
    assert_eq!((combos.len(), out.len()), (1, 3));
    for wrong in [fewer_trials as KernelFn<Hexapod>, narrower] {
        let why = run_kernel(&hex, &poses, &s, 1, wrong).err().unwrap();
        assert!(
            why.contains("the study kernel gave the hexapod")
                && why.contains("other than 3 trials of 1 combinations"),
            "{why}"
        );
    }
}

/// Each row of a study of several sensors, instrumentations, pose counts
/// and estimators is its own combination's: merged from the
/// instrumentations' studies in combination order, the quiet encoder's
/// rows are better than the noisy one's, both encoders a joint better
/// than one, and 30 poses better than 12 (medians over 60 machines),
/// every estimator alike; a pose count of 0 or of more poses than listed
/// is refused in a sentence naming the key, and a fixed leg offset is held
/// (only a fixed zero is refused).
#[test]
fn rows_are_their_combinations_and_pose_counts_are_checked() {
    let hex = Hexapod::example();
    let poses = targets(1, 30);
    let mut s = spec(0.5, 0.0, 60);
    let mut noisy = s.sensors[0].clone();
    noisy.name = "noisy".into();
    noisy.axis.noise *= 40.0;
    s.sensors.push(noisy);
    s.estimators = vec![Estimator::Linear, Estimator::Gls];
    let (combos, out) = run_kernel(&hex, &poses, &s, 2, sizes).unwrap();
    assert_eq!(combos.len(), 2 * 2 * 2 * 2);
    let median = |ci: usize| {
        let mut v: Vec<f64> = out.iter().map(|t| t[ci].position_after).collect();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let find = |sensor, variant, poses, estimator| {
        let c = Combination {
            sensor,
            variant,
            poses,
            estimator,
        };
        combos.iter().position(|d| *d == c).unwrap()
    };
    for e in [Estimator::Linear, Estimator::Gls] {
        for v in [Encoders::Both, Encoders::First] {
            for n in [12, 30] {
                let (quiet, loud) = (median(find(0, v, n, e)), median(find(1, v, n, e)));
                assert!(
                    5.0 * quiet < loud,
                    "{v:?} {n} {e:?}: {quiet} against {loud}"
                );
            }
        }
        for sensor in [0, 1] {
            for n in [12, 30] {
                let (both, one) = (
                    median(find(sensor, Encoders::Both, n, e)),
                    median(find(sensor, Encoders::First, n, e)),
                );
                assert!(
                    both < one,
                    "sensor {sensor} {n} {e:?}: {both} against {one}"
                );
            }
            for v in [Encoders::Both, Encoders::First] {
                let (few, many) = (
                    median(find(sensor, v, 12, e)),
                    median(find(sensor, v, 30, e)),
                );
                assert!(
                    many < few,
                    "sensor {sensor} {v:?} {e:?}: {many} against {few}"
                );
            }
        }
    }
    for bad in [vec![0], vec![31], vec![12, 31]] {
        s.pose_counts = bad;
        let why = run_kernel(&hex, &poses, &s, 2, sizes).err().unwrap();
        assert_eq!(
            why,
            "sweep.pose_counts must be 1 to the 30 poses of poses.list"
        );
    }
    // A fixed leg offset is every estimator's (not a zero: the study runs
    // it), where a fixed encoder zero is refused.
    s.pose_counts = vec![12];
    s.trials = 4;
    let dl3 = error("dl3");
    s.fixed = vec![(dl3, 0.0)];
    let (_, held) = run_kernel(&hex, &poses, &s, 2, sizes).unwrap();
    assert_eq!(held.len(), 4);
}

/// A progress that counts what it is told.
#[derive(Default)]
struct Counted {
    total: std::sync::atomic::AtomicU64,
    done: std::sync::atomic::AtomicU64,
    finished: std::sync::atomic::AtomicBool,
}

impl Progress for Counted {
    fn start(&self, total: u64, done: u64) {
        use std::sync::atomic::Ordering::SeqCst;
        self.total.store(total, SeqCst);
        self.done.store(done, SeqCst);
    }
    fn advance(&self, trials: u64) {
        self.done
            .fetch_add(trials, std::sync::atomic::Ordering::SeqCst);
    }
    fn finish(&self) {
        self.finished
            .store(true, std::sync::atomic::Ordering::SeqCst);
    }
}

/// Each instrumentation's studies run through the block runner: the
/// progress is told in machines, all of them once at the end, whether each
/// instrumentation runs two studies (Gauss–Newton asked with a one-step
/// estimator) or one; reporting changes no row, and a runner of 5-trial blocks
/// records every calibration (μ, failure, workspace and orientation) as
/// one block of them all does, to the bit. A block larger than the
/// runner's is refused, and a study with no workspace to judge over is
/// refused in a sentence.
#[test]
fn the_runner_reports_every_trial_and_its_blocks_change_no_record() {
    use std::sync::atomic::Ordering::SeqCst;
    let hex = Hexapod::example();
    let poses = targets(1, 12);
    let mut s = spec(2.0, 0.0, 37);
    s.pose_counts = vec![12];
    let told = Counted::default();
    let (_, reported) = run_reporting(&hex, &poses, &s, (2, &told), sizes).unwrap();
    assert_eq!(told.total.load(SeqCst), 37);
    assert_eq!(told.done.load(SeqCst), 37);
    assert!(told.finished.load(SeqCst));
    let (_, silent) = run_kernel(&hex, &poses, &s, 1, sizes).unwrap();
    assert_eq!(reported, silent);
    s.estimators = vec![Estimator::Gls];
    let told = Counted::default();
    run_reporting(&hex, &poses, &s, (1, &told), sizes).unwrap();
    assert_eq!(told.done.load(SeqCst), 37);

    let fitted = hex.with_variant(Encoders::Both);
    let run = VariantRun {
        m: &fitted,
        targets: &poses,
        spec: &s,
        threads: 2,
        progress: &Silent,
    };
    let owned = fitted.error_names();
    let names: Vec<&str> = owned.iter().map(String::as_str).collect();
    let study = run
        .context::<33, 12>(&READINGS, &names, &[Estimator::Linear, Estimator::Gls], 1)
        .unwrap();
    let records = |block: usize| {
        let mut none = NoRows;
        let mut r = BlockRunner::with_blocks(&study, (0, block), 2, &mut none).unwrap();
        r.run_trials(37).unwrap();
        let too_many = r.run_block(block + 1).err().map(|e| e.to_string());
        (std::mem::take(&mut r.partial), too_many)
    };
    let ((small, refused), (whole, _)) = (records(5), records(64));
    assert_eq!((small.blocks(), whole.blocks()), (8, 1));
    assert!(refused.is_some_and(|why| why.contains("a block of 6 trials in a runner of 5")));
    assert_eq!(small.trials, 37);
    assert_eq!(
        (&small.mu, &small.failure, &small.dv, &small.orientation),
        (&whole.mu, &whole.failure, &whole.dv, &whole.orientation)
    );
    assert!(whole.oriented && whole.orientation.len() == 37 * 2 * 2);
    assert!(whole.orientation.iter().all(|x| x.is_finite() && *x > 0.0));
    assert_eq!(whole.block_err_sum.len(), 2 * 33);
    // The records alone (what the study keeps), in blocks of 5 or of 1
    // (a block of 0 is one): the same records, no sums, no blocks.
    for block in [5, 0] {
        let mut none = NoRows;
        let mut r = BlockRunner::records_only(&study, block, 2, &mut none).unwrap();
        r.partial.reserve(37);
        r.run_trials(37).unwrap();
        let alone = std::mem::take(&mut r.partial);
        assert_eq!(
            (
                &alone.mu0,
                &alone.mu,
                &alone.failure,
                &alone.dv,
                &alone.orientation
            ),
            (
                &whole.mu0,
                &whole.mu,
                &whole.failure,
                &whole.dv,
                &whole.orientation
            )
        );
        assert_eq!((alone.trials, alone.errors, alone.blocks()), (37, 0, 0));
        assert!(alone.block_err_sum.is_empty() && alone.block_lin_sum.is_empty());
        // Reserved exactly: no capacity doubled past the records.
        assert_eq!(alone.mu.capacity(), 37 * 2);
        assert_eq!(alone.dv.capacity(), 37 * 2 * DV_PER_CALIBRATION);
    }

    s.workspace.clear();
    let why = run_kernel(&hex, &poses, &s, 1, sizes).err().unwrap();
    assert!(
        why.contains("judges each machine over its workspace, and has none"),
        "{why}"
    );
}
