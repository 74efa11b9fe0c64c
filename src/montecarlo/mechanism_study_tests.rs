//! The hexapod through the study kernel ([`MechanismStudy`]) against
//! routes formed apart from it: least squares on its absolute readings
//! with every reading's zero unknown (the hexapod's own identification,
//! which the kernel's homed GLS must equal), exact recovery by
//! Gauss–Newton from exact readings, the workspace judged through the
//! mechanism's own sensitivities of its 54 errors, and the machines the
//! mechanism's own study (`montecarlo::general`) draws.

use super::*;
use crate::config::hexapod::{Estimator, Sensor, Spec};
use crate::config::{ErrorDraw, Truth};
use crate::identify::Method;
use crate::mechanism::hexapod::tests::targets;
use crate::mechanism::hexapod::{Encoders, Hexapod, Pose, PHI_READINGS, PSI_READINGS, READINGS};
use crate::mechanism::ReadingFact;
use crate::montecarlo::context::{GradeAxes, GradeTable, Parts, SweepContext};
use crate::montecarlo::general::dense::Prepared;
use crate::montecarlo::trial::{run_trial, trial_machine, Outcome, Scratch};
use crate::sensors::{homed_unit_noise, Axis, GradeReading, SensorModel, ARCSEC_PER_RAD};

/// The geometry's coordinates along the convention's free directions,
/// with either instrumentation: both encoders on every joint (12 readings
/// a pose, 45 free directions of which 12 are the encoders' zeros) or one
/// (6, 39 and 6).
const P: usize = 33;
const POSES: usize = 30;
const BOUNDS: Bounds = Bounds {
    length_mm: 0.1,
    angle_deg: 0.02,
};
const SEED: u64 = 7;

type Context<'a, const R: usize> = SweepContext<MechanismStudy<'a, Hexapod, P, R>, P, R, 0>;

/// What a study of the hexapod is built on, kept apart from the study
/// that borrows it.
struct Bench {
    hex: Hexapod,
    names: Vec<String>,
    poses: Vec<Pose>,
    workspace: Vec<Pose>,
    subsets: Vec<PoseSubset>,
    tool: Vector3<f64>,
}

impl Bench {
    fn new(tool: Vector3<f64>) -> Self {
        Self::with(tool, Encoders::Both)
    }

    fn with(tool: Vector3<f64>, encoders: Encoders) -> Self {
        let hex = Hexapod {
            encoders,
            ..Hexapod::example()
        };
        let per = encoders.per_pose();
        Bench {
            names: hex.error_names(),
            hex,
            poses: targets(1, POSES),
            workspace: targets(9, 6),
            subsets: vec![
                PoseSubset::new(POSES, POSES, per),
                PoseSubset::new(POSES, 12, per),
            ],
            tool,
        }
    }

    /// The study: OLS and GLS of a 2″ encoder (`perfect`: read exactly,
    /// weighted all the same), Gauss–Newton when `iterations` > 1.
    fn study<'a, const R: usize>(
        &'a self,
        slots: &'static [ReadingFact; R],
        names: &'a [&'a str],
        iterations: usize,
        perfect: bool,
        exact: bool,
    ) -> Context<'a, R> {
        let (mech, grids) = MechanismStudy::<Hexapod, P, R>::new(Setup {
            m: &self.hex,
            names,
            targets: &self.poses,
            subsets: &self.subsets,
            workspace: &self.workspace,
            tool: self.tool,
            exact,
            bounds: Some(BOUNDS),
        })
        .unwrap();
        let h = mech.design().unwrap();
        let sensor = SensorModel::<R> {
            slots,
            encoder_arcsec: 2.0,
            scale_um: 1.0,
            samples: 1,
            reading: GradeReading::Sigma,
            structured: None,
        };
        let options = IdentifyOptions::<P> {
            iterations,
            ..IdentifyOptions::default()
        };
        let table = GradeTable::new(
            &GradeAxes {
                methods: &[Method::Ols, Method::Gls],
                truths: &[Truth::DATASHEET],
                assumed: std::slice::from_ref(&sensor),
                h: &h,
                nominal: mech.nominal(),
                subsets: &self.subsets,
                options: &options,
                names: mech.names(),
            },
            |i| format!("set {i}"),
        )
        .unwrap();
        SweepContext::assemble(Parts {
            mech,
            h,
            h_second: None,
            subsets: self.subsets.clone(),
            table,
            assumed: vec![sensor],
            sensors: vec![sensor],
            products: None,
            options,
            gls_per_machine: None,
            draw: ErrorDraw::Random,
            fixed_errors: SVector::zeros(),
            bound_mm: 0.0,
            seed: SEED,
            perfect: [perfect; R],
            grids: (grids.position, MapGrid::default()),
            orientation: grids.orientation,
            exact,
        })
        .unwrap()
    }
}

/// Trial k through the kernel: the machine's coordinates, and each
/// grade's estimate and outcome.
fn through_kernel<const R: usize>(
    ctx: &Context<'_, R>,
    k: u64,
) -> (SVector<f64, P>, Vec<SVector<f64, P>>, Vec<Outcome>) {
    let mut s = Scratch::new(ctx);
    let mut out = vec![Outcome::default(); ctx.grades().len()];
    run_trial(ctx, k, &mut s, &mut out);
    let (truth, _) = trial_machine(ctx, k);
    let est = (0..out.len()).map(|gi| truth + s.error(gi)).collect();
    (truth, est, out)
}

/// Least squares on absolute readings with each reading's zero unknown
/// (the hexapod's own formulation, apart from the kernel's homing and
/// weighting): rows of every pose of `subset`, the geometry's columns
/// (the hexapod's design times the study's basis, radians) and one
/// column a reading slot; the right-hand side the homed observation `l`
/// of those poses with the reference row 0. The geometry's part.
fn least_squares_with_zeros<const R: usize>(
    bench: &Bench,
    study: &MechanismStudy<'_, Hexapod, P, R>,
    subset: &PoseSubset,
    l: &[f64],
) -> DVector<f64> {
    let picked: Vec<Pose> = subset.poses.iter().map(|&p| bench.poses[p]).collect();
    let n = picked.len();
    let design = bench.hex.design(&vec![0.0; 54], &picked).unwrap() * &study.basis;
    let a = DMatrix::from_fn(R * n, P + R, |r, c| match c < P {
        true => design[(r, c)].to_radians(),
        false => f64::from(u8::from(c - P == r % R)),
    });
    let y = DVector::from_fn(R * n, |r, _| if r < R { 0.0 } else { l[r - R] });
    a.svd(true, true)
        .solve(&y, 1e-14)
        .unwrap()
        .rows(0, P)
        .into_owned()
}

/// Trial k's homed observation of `subset`, formed apart from the kernel:
/// exact readings of the kernel's machine, homed at the reference, plus
/// the encoder's σ times the trial's unit noise (stream (seed, k, 1)).
fn observation<const R: usize>(
    ctx: &Context<'_, R>,
    bench: &Bench,
    subset: &PoseSubset,
    k: u64,
) -> Vec<f64> {
    let (truth, _) = trial_machine(ctx, k);
    let study = &ctx.mech;
    let errors = study.errors(&truth);
    let mut dz = vec![0.0; R * (POSES - 1)];
    homed_unit_noise(&ctx.sensors[0], &mut stream(SEED, k, 1), &mut dz);
    let sigma = ctx.sensors[0].reading_sigma();
    let read = |e: &[f64]| {
        let r = Mechanism::readings(&bench.hex, e, &bench.poses[0]).unwrap();
        let mut out = Vec::new();
        for j in 1..POSES {
            let x = Mechanism::readings(&bench.hex, e, &bench.poses[j]).unwrap();
            out.extend((0..R).map(|c| (x[c] - r[c]).to_radians()));
        }
        out
    };
    let (a, nominal) = (read(&errors), read(&vec![0.0; 54]));
    let full: Vec<f64> = (0..a.len())
        .map(|r| a[r] - nominal[r] + sigma[r % R] * dz[r])
        .collect();
    subset.rows.iter().map(|&r| full[r]).collect()
}

/// GLS on the homed rows under the encoders' homed covariance is least
/// squares with every zero unknown: the kernel's estimate of the 33
/// coordinates equals the one formed apart, at 30 poses and at 12, from
/// readings with 2″ noise, with both encoders a joint and with either
/// one; OLS on the homed rows does not (its weights ignore the
/// reference's share of every row).
#[test]
fn the_kernels_gls_is_least_squares_with_every_zero_unknown() {
    gls_is_least_squares_with_zeros(Encoders::Both, &READINGS);
    gls_is_least_squares_with_zeros(Encoders::First, &PHI_READINGS);
    gls_is_least_squares_with_zeros(Encoders::Second, &PSI_READINGS);
}

fn gls_is_least_squares_with_zeros<const R: usize>(
    encoders: Encoders,
    slots: &'static [ReadingFact; R],
) {
    let bench = Bench::with(Vector3::new(10.0, -20.0, 150.0), encoders);
    assert_eq!(
        bench.hex.reading_facts(),
        slots.to_vec(),
        "{encoders:?}'s slots"
    );
    let names: Vec<&str> = bench.names.iter().map(String::as_str).collect();
    let ctx = bench.study(slots, &names, 1, false, false);
    for k in 0..3 {
        let (_, est, _) = through_kernel(&ctx, k);
        for (gi, g) in ctx.grades().iter().enumerate() {
            let sub = &bench.subsets[g.subset];
            let l = observation(&ctx, &bench, sub, k);
            let want = least_squares_with_zeros(&bench, &ctx.mech, sub, &l);
            let scale = want.amax();
            let diff = (est[gi] - &want).amax();
            let at = format!(
                "{encoders:?}, trial {k}, {:?} at {} poses",
                g.method, g.pose_count
            );
            match g.method {
                Method::Gls => {
                    assert!(diff < 1e-9 * scale.max(1e-3), "{at}: {diff:e} of {scale:e}")
                }
                _ => assert!(
                    diff > 1e-6 * scale,
                    "{at}: OLS on homed rows agreed to {diff:e}"
                ),
            }
        }
    }
}

/// Exact readings (the encoders read perfectly) of a machine the model
/// can be: Gauss–Newton over the hexapod's own design recovers its 33
/// coordinates to 1e-9 mm, where one linearisation leaves its
/// second-order error (over 1e-7 mm at errors of ±0.1 mm).
#[test]
fn gauss_newton_recovers_the_machine_from_exact_readings() {
    let bench = Bench::new(Vector3::new(10.0, -20.0, 150.0));
    let names: Vec<&str> = bench.names.iter().map(String::as_str).collect();
    for (iterations, below) in [(10, true), (1, false)] {
        let ctx = bench.study(&READINGS, &names, iterations, true, false);
        for k in 0..2 {
            let (truth, est, out) = through_kernel(&ctx, k);
            for (gi, e) in est.iter().enumerate() {
                let off = (e - truth).amax();
                assert_eq!(out[gi].failure, crate::montecarlo::Failure::None);
                assert_eq!(
                    below,
                    off < 1e-9,
                    "{iterations} iterations, trial {k} grade {gi}: {off:e}"
                );
                if !below {
                    assert!(off > 1e-7, "trial {k} grade {gi}: {off:e}");
                }
            }
        }
    }
}

/// The workspace judged by the kernel, against the hexapod's own
/// sensitivities of its 54 errors at every workspace pose (the tool
/// point 150 mm out): the largest position and orientation errors before
/// compensation (the machine's errors) and after (what each estimate
/// leaves).
#[test]
fn the_workspace_is_judged_through_the_mechanisms_own_sensitivities() {
    let tool = Vector3::new(10.0, -20.0, 150.0);
    let bench = Bench::new(tool);
    let names: Vec<&str> = bench.names.iter().map(String::as_str).collect();
    let ctx = bench.study(&READINGS, &names, 1, false, false);
    let worst = |e: &[f64], q: usize| {
        let e = DVector::from_column_slice(e);
        bench
            .workspace
            .iter()
            .map(|t| {
                let s = bench.hex.sensitivity(t, &tool).unwrap();
                (s.rows(3 * q, 3) * &e).norm()
            })
            .fold(0.0, f64::max)
    };
    let near = |a: f64, b: f64, tol: f64| assert!((a - b).abs() <= tol * b, "{a} vs {b}");
    for k in 0..3 {
        let (truth, est, out) = through_kernel(&ctx, k);
        let machine = ctx.mech.errors(&truth);
        for (gi, o) in out.iter().enumerate() {
            let left = ctx.mech.errors(&(est[gi] - truth));
            near(o.dv_before_max, worst(&machine, 0), 1e-12);
            near(o.dv_after_max, worst(&left, 0), 1e-9);
            near(o.orientation_before_max, worst(&machine, 1), 1e-12);
            near(o.orientation_after_max, worst(&left, 1), 1e-9);
        }
    }
}

/// Exact kinematics judges the moving frame's origin as first order
/// does, within 2 % at errors of ±0.1 mm; with a tool point away from it
/// the exact judgement is refused in a sentence.
#[test]
fn the_exact_judgement_agrees_with_first_order_at_the_frames_origin() {
    let bench = Bench::new(Vector3::zeros());
    let names: Vec<&str> = bench.names.iter().map(String::as_str).collect();
    let first = bench.study(&READINGS, &names, 1, false, false);
    let exact = bench.study(&READINGS, &names, 1, false, true);
    for k in 0..2 {
        let (_, _, a) = through_kernel(&first, k);
        let (_, _, b) = through_kernel(&exact, k);
        for (x, y) in a.iter().zip(&b) {
            for (u, v) in [
                (x.dv_before_max, y.dv_before_max),
                (x.dv_after_max, y.dv_after_max),
            ] {
                assert!(
                    v.is_finite() && (u - v).abs() < 0.02 * u,
                    "first order {u} vs exact {v}"
                );
            }
        }
    }
    let away = Bench::new(Vector3::new(0.0, 0.0, 150.0));
    let why = MechanismStudy::<Hexapod, P, 12>::new(Setup {
        m: &away.hex,
        names: &names,
        targets: &away.poses,
        subsets: &away.subsets,
        workspace: &away.workspace,
        tool: away.tool,
        exact: true,
        bounds: None,
    })
    .err()
    .unwrap();
    assert!(why.contains("moving frame's origin"), "{why}");
}

/// The kernel's machines are the ones the hexapod's own study draws:
/// trial k's 54 errors in the convention's frames, every zero aside, and
/// the same largest position and orientation errors before
/// compensation; and the two studies judge alike after it: over 400
/// machines the medians of the largest position and orientation errors
/// the kernel's GLS leaves are the hexapod's own study's (least squares
/// with the zeros unknown, the same estimator with noise of its own
/// draws) within 8 % (the medians' sampling spread is about 3.5 %
/// each).
#[test]
fn the_kernel_draws_the_machines_the_mechanisms_own_study_draws() {
    let bench = Bench::new(Vector3::new(10.0, -20.0, 150.0));
    let names: Vec<&str> = bench.names.iter().map(String::as_str).collect();
    let ctx = bench.study(&READINGS, &names, 1, false, false);
    let spec = Spec {
        sensors: vec![Sensor {
            name: "jitter".into(),
            price: Some(1.0),
            axis: Axis {
                noise: 2.0 / ARCSEC_PER_RAD,
                period: std::f64::consts::TAU,
                readheads: 1,
                ..Axis::default()
            },
            truth: None,
        }],
        variants: vec![Encoders::Both],
        pose_counts: vec![POSES],
        estimators: vec![Estimator::Linear],
        trials: 3,
        seed: SEED,
        length_bound_mm: BOUNDS.length_mm,
        zero_bound_deg: BOUNDS.angle_deg,
        samples: 1,
        workspace: bench.workspace.clone(),
        tool_mm: bench.tool,
        iterations: 1,
        fixed: Vec::new(),
        prior_std_mm: None,
        prior_std_deg: None,
    };
    let general = Prepared::new(&bench.hex, &bench.poses, &spec).unwrap();
    // Per trial: the position (mm) and orientation (″) the kernel's GLS
    // and the hexapod's own study leave.
    let mut after: [Vec<f64>; 4] = Default::default();
    for k in 0..400 {
        let j = general.trial(k).unwrap()[0];
        let (_, _, out) = through_kernel(&ctx, k);
        let gls = out[1];
        assert_eq!(ctx.grades()[1].method, Method::Gls);
        let turn = gls.orientation_before_max * ARCSEC_PER_RAD;
        assert!(
            (gls.dv_before_max - j.position_before).abs() < 1e-12,
            "trial {k}"
        );
        assert!(
            (turn - j.orientation_before).abs() < 1e-9,
            "trial {k}: {turn}″"
        );
        after[0].push(gls.dv_after_max);
        after[1].push(j.position_after);
        after[2].push(gls.orientation_after_max * ARCSEC_PER_RAD);
        after[3].push(j.orientation_after);
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let m: Vec<f64> = after.iter_mut().map(median).collect();
    for (a, b) in [(m[0], m[1]), (m[2], m[3])] {
        assert!(
            (a / b - 1.0).abs() < 0.08,
            "kernel {a} vs the hexapod's own {b}"
        );
    }
    let zeros: Vec<usize> = (0..12).filter_map(|k| bench.hex.zero_of(k)).collect();
    for k in 0..3 {
        let (machines, _) = general.estimates(k).unwrap();
        let (truth, _) = trial_machine(&ctx, k);
        let ours = ctx.mech.errors(&truth);
        let mut theirs = machines[0].clone();
        for &z in &zeros {
            assert!(theirs[z] != 0.0, "the general study draws zero {z}");
            theirs[z] = 0.0;
        }
        let diff = (DVector::from_vec(ours) - theirs).amax();
        assert!(diff < 1e-13, "trial {k}: {diff:e}");
    }
}

/// A machine's errors are drawn from its trial's stream in order, each
/// uniform within its bound (an angle's ±zero bound, a length's ±length
/// bound); an error whose bound is 0 is 0 and takes no draw, so the
/// others' draws are the stream's in order; a fixed error is its value.
#[test]
fn drawn_errors_take_the_streams_draws_in_order() {
    let angles = [false, true, false, true];
    let e = drawn(&angles, (0.1, 0.0), &[(3, 0.5)], (9, 4));
    let mut rng = stream(9, 4, 0);
    let (a, b) = (rng.random_range(-0.1..=0.1), rng.random_range(-0.1..=0.1));
    assert_eq!(e, vec![a, 0.0, b, 0.5]);
    let e = drawn(&angles, (0.1, 0.02), &[], (9, 4));
    let mut rng = stream(9, 4, 0);
    let want: Vec<f64> = (angles.iter())
        .map(|&angle| {
            let bound = if angle { 0.02 } else { 0.1 };
            rng.random_range(-bound..=bound)
        })
        .collect();
    assert_eq!(e, want);
    assert!(e
        .iter()
        .zip(angles)
        .all(|(x, angle)| x.abs() <= if angle { 0.02 } else { 0.1 }));
}
