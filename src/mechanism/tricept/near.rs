//! Forward kinematics near a known configuration: the sweep's hot path
//! (docs/method.md §10). A trial's machine differs from the nominal one by fractions
//! of a millimetre, so its passive joints lie within milliradians of the
//! nominal configuration of each pose. Two things make FK cheap there:
//! sin/cos of the joint angles by angle addition from the pose's nominal
//! angles (Taylor series of the small offset, exact to below one ulp within
//! [`MAX_OFFSET_RAD`]), and chord Newton: the closure Jacobian of the first
//! iterate is inverted once and reused, which converges as fast as Newton
//! from a first-order start. The stopping rule is [`NEWTON_TOLERANCE_MM`] on
//! the closure residual, as in [`Machine::forward`]; anything unusual (a
//! machine with second-class errors, an offset beyond the series' range, a
//! step that does not contract) is handed to [`Machine::forward`] itself.

use super::geometry::Machine;
use super::kinematics::{invert3, Joints, NEWTON_TOLERANCE_MM};
use crate::error::KinematicsError;
use crate::mechanism::kinematic::{sin_cos_near, MAX_OFFSET_RAD};
use nalgebra::{Matrix3, Vector3};

/// Chord iterations before handing over to the general FK.
const CHORD_ITERATIONS: usize = 8;

/// A nominal configuration prepared for [`Machine::forward_near`]: its
/// joint angles with their sines and cosines.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Anchor {
    psi: f64,
    theta: f64,
    sin_psi: f64,
    cos_psi: f64,
    sin_theta: f64,
    cos_theta: f64,
}

impl Anchor {
    pub fn new(j: &Joints) -> Self {
        let (sin_psi, cos_psi) = j.psi_rad.sin_cos();
        let (sin_theta, cos_theta) = j.theta_rad.sin_cos();
        Anchor {
            psi: j.psi_rad,
            theta: j.theta_rad,
            sin_psi,
            cos_psi,
            sin_theta,
            cos_theta,
        }
    }
}

/// Where one configuration's iteration stands.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Lane {
    Running,
    Converged,
    /// Hand over to the general FK.
    General,
}

impl Machine {
    /// Exact forward kinematics from `guess`, near the configuration
    /// `anchor` (see the module text). Same tolerance and the same errors as
    /// [`Machine::forward`], to which it falls back.
    pub fn forward_near(
        &self,
        q_cmd: &[f64; 3],
        anchor: &Anchor,
        guess: &Joints,
    ) -> Result<Joints, KinematicsError> {
        let [out] = self.forward_near_group([q_cmd], [anchor], [guess]);
        out
    }

    /// [`Machine::forward_near`] for N configurations iterated in lock-step,
    /// so that the processor overlaps their independent chains of
    /// dependent arithmetic. Each result is what `forward_near` gives alone.
    pub fn forward_near_group<const N: usize>(
        &self,
        q_cmd: [&[f64; 3]; N],
        anchor: [&Anchor; N],
        guess: [&Joints; N],
    ) -> [Result<Joints, KinematicsError>; N] {
        let near = self.near_lanes(q_cmd, anchor, guess);
        std::array::from_fn(|l| match near[l] {
            Some(j) => Ok(j),
            None => self.forward(q_cmd[l], guess[l]),
        })
    }

    /// The chord iterations of [`Machine::forward_near_group`] alone: a lane
    /// is None where they hand over to the general FK. Compiled for AVX2
    /// where the processor has it (a register holds the four lanes; without
    /// FMA, so the same bits as the baseline copy, tested).
    fn near_lanes<const N: usize>(
        &self,
        q_cmd: [&[f64; 3]; N],
        anchor: [&Anchor; N],
        guess: [&Joints; N],
    ) -> [Option<Joints>; N] {
        crate::cpu::wide(
            #[inline(always)]
            || self.near_lanes_by(q_cmd, anchor, guess),
        )
    }

    #[inline(always)]
    fn near_lanes_by<const N: usize>(
        &self,
        q_cmd: [&[f64; 3]; N],
        anchor: [&Anchor; N],
        guess: [&Joints; N],
    ) -> [Option<Joints>; N] {
        let mut lane = [Lane::Running; N];
        if self.second.is_some() {
            lane = [Lane::General; N];
        }
        let q = q_cmd.map(|q| *q);
        let an = anchor.map(|a| *a);
        let mut x = guess.map(|g| g.as_vector());
        let mut inverse = [Matrix3::zeros(); N];
        let mut jacobian = [Matrix3::zeros(); N];
        let mut f = [[0.0; N]; 3];
        let mut in_range = [false; N];
        let mut last = [f64::INFINITY; N];
        for it in 0..CHORD_ITERATIONS {
            if lane.iter().all(|l| *l != Lane::Running) {
                break;
            }
            // Every lane is evaluated (vectorised); only running ones move.
            if it == 0 {
                self.closure_lanes::<N, true>(&q, &an, &x, &mut f, &mut in_range, &mut jacobian);
            } else {
                self.closure_lanes::<N, false>(&q, &an, &x, &mut f, &mut in_range, &mut jacobian);
            }
            for l in 0..N {
                if lane[l] != Lane::Running {
                    continue;
                }
                if !in_range[l] {
                    lane[l] = Lane::General;
                    continue;
                }
                let fl = Vector3::new(f[0][l], f[1][l], f[2][l]);
                let residual = fl.amax();
                if residual < NEWTON_TOLERANCE_MM {
                    lane[l] = Lane::Converged;
                    continue;
                }
                let contracting = residual < last[l]; // false for NaN
                if !contracting {
                    lane[l] = Lane::General;
                    continue;
                }
                last[l] = residual;
                if it == 0 {
                    match invert3(&jacobian[l]) {
                        Some(inv) => inverse[l] = inv,
                        None => {
                            lane[l] = Lane::General;
                            continue;
                        }
                    }
                }
                x[l] -= inverse[l] * fl;
            }
        }
        std::array::from_fn(|l| (lane[l] == Lane::Converged).then(|| Joints::from_vector(&x[l])))
    }

    /// The closure residuals of N configurations at once (`f[leg][lane]`,
    /// arrays per quantity so that the arithmetic vectorises across lanes),
    /// whether each lies within the series' range, and with `JAC` the
    /// closure Jacobian of each (as in [`Machine::closure`]).
    #[inline(always)]
    fn closure_lanes<const N: usize, const JAC: bool>(
        &self,
        q: &[[f64; 3]; N],
        an: &[Anchor; N],
        x: &[Vector3<f64>; N],
        f: &mut [[f64; N]; 3],
        in_range: &mut [bool; N],
        jacobian: &mut [Matrix3<f64>; N],
    ) {
        for l in 0..N {
            let (dp, dt) = (x[l].x - an[l].psi, x[l].y - an[l].theta);
            in_range[l] = dp.abs() <= MAX_OFFSET_RAD && dt.abs() <= MAX_OFFSET_RAD;
            let (sp, cp) = sin_cos_near(an[l].sin_psi, an[l].cos_psi, dp);
            let (st, ct) = sin_cos_near(an[l].sin_theta, an[l].cos_theta, dt);
            // R = Rx(ψ)·Ry(θ); w4 is its third column.
            let w4 = [st, -sp * ct, cp * ct];
            let r = [x[l].z * w4[0], x[l].z * w4[1], x[l].z * w4[2]];
            let m = [
                [ct, 0.0, st],
                [sp * st, cp, -sp * ct],
                [-cp * st, sp, cp * ct],
            ];
            for i in 0..3 {
                let a = &self.a[i];
                let mut p = [0.0; 3];
                let mut v = [0.0; 3];
                for d in 0..3 {
                    p[d] = r[d] + m[d][0] * a.x + m[d][1] * a.y + m[d][2] * a.z;
                    v[d] = p[d] - self.b[i][d];
                }
                let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                f[i][l] = len - (q[l][i] + self.dq[i]);
                if JAC {
                    let u = Vector3::from(v) * (1.0 / len);
                    let pxu = Vector3::from(p).cross(&u);
                    jacobian[l][(i, 0)] = pxu.x;
                    jacobian[l][(i, 1)] = cp * pxu.y + sp * pxu.z;
                    jacobian[l][(i, 2)] = u.dot(&Vector3::from(w4));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::tricept::geometry::SecondClass;
    use crate::mechanism::tricept::jacobian::jacobian_at;
    use crate::mechanism::tricept::{ErrorVector, Geometry};
    use rand::{RngExt, SeedableRng};

    #[test]
    fn series_sin_cos_match_libm_within_the_range() {
        for &a0 in &[-0.6, -0.1, 0.0, 0.3, 0.55] {
            let (s0, c0) = f64::sin_cos(a0);
            for k in -40..=40 {
                let d = MAX_OFFSET_RAD * k as f64 / 40.0;
                let (s, c) = sin_cos_near(s0, c0, d);
                let (se, ce) = (a0 + d).sin_cos();
                assert!((s - se).abs() < 4e-16 && (c - ce).abs() < 4e-16, "{a0} {d}");
            }
        }
    }

    /// A random target in the paper's workspace: its nominal pose, the leg
    /// commands that reach it and the anchor of its joints.
    fn random_pose(
        rng: &mut rand::rngs::Xoshiro256PlusPlus,
        nominal: &Machine,
    ) -> (
        crate::mechanism::tricept::kinematics::Pose,
        [f64; 3],
        Anchor,
    ) {
        let r = Vector3::new(
            rng.random_range(-250.0..250.0),
            rng.random_range(-250.0..250.0),
            rng.random_range(650.0..950.0),
        );
        let pose = nominal.inverse(&r).unwrap();
        let q = [pose.legs_mm[0], pose.legs_mm[1], pose.legs_mm[2]];
        let anchor = Anchor::new(&pose.joints);
        (pose, q, anchor)
    }

    /// forward_near and forward agree to a few times the closure tolerance on
    /// random machines (errors up to ±0.5 mm), from the first-order start,
    /// from the nominal joints and from a start beyond the series' range;
    /// a machine with second-class errors goes to the general FK.
    #[test]
    fn agrees_with_general_forward_kinematics() {
        let g = Geometry::paper();
        let nominal = Machine::nominal(&g);
        let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(5);
        let mut worst = 0.0f64;
        for t in 0..300 {
            let e = ErrorVector::from_fn(|_, _| rng.random_range(-0.5..=0.5));
            let mut truth = Machine::with_errors(&g, &e);
            if t % 50 == 0 {
                truth.second = Some(SecondClass::from_angles_deg(0.1, -0.05, 0.02, 0.1));
            }
            let (pose, q, anchor) = random_pose(&mut rng, &nominal);
            let exact = truth.forward(&q, &pose.joints).unwrap().as_vector();
            let first = pose.joints.as_vector() + jacobian_at(&pose).unwrap() * e;
            let far = pose.joints.as_vector() + Vector3::new(0.05, -0.05, 3.0);
            // From the first-order start and from the nominal joints the chord
            // iterations converge by themselves (no hand-over to the general
            // FK, which would hide a wrong step), within 3 evaluations from
            // the first-order start.
            if truth.second.is_none() {
                for start in [first, pose.joints.as_vector()] {
                    let j = Joints::from_vector(&start);
                    let [near] = truth.near_lanes([&q], [&anchor], [&j]);
                    let near = near.expect("the chord iterations converge by themselves");
                    assert!((near.as_vector() - exact).amax() < 5e-11);
                }
            }
            for start in [first, pose.joints.as_vector(), far] {
                let j = truth
                    .forward_near(&q, &anchor, &Joints::from_vector(&start))
                    .unwrap();
                let (f, _) = truth.closure(&q, &j);
                assert!(f.amax() < 1.5e-11, "closure {:e}", f.amax());
                worst = worst.max((j.as_vector() - exact).amax());
            }
        }
        assert!(worst < 5e-11, "{worst:e}");
    }

    /// The chord iterations on the AVX2 copy (four poses in lock-step) give
    /// the baseline's bits, pose by pose alone: 200 random machines, four
    /// random poses each, from the first-order start.
    #[test]
    fn the_avx2_copy_gives_the_baselines_bits() {
        let g = Geometry::paper();
        let nominal = Machine::nominal(&g);
        let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(8);
        let mut converged = 0;
        for _ in 0..200 {
            let e = ErrorVector::from_fn(|_, _| rng.random_range(-0.5..=0.5));
            let truth = Machine::with_errors(&g, &e);
            let mut q = [[0.0; 3]; 4];
            let mut anchors = [Anchor::new(&Joints::from_vector(&Vector3::zeros())); 4];
            let mut starts = [Joints::from_vector(&Vector3::zeros()); 4];
            for l in 0..4 {
                let pose;
                (pose, q[l], anchors[l]) = random_pose(&mut rng, &nominal);
                starts[l] = Joints::from_vector(
                    &(pose.joints.as_vector() + jacobian_at(&pose).unwrap() * e),
                );
            }
            let group: [Option<Joints>; 4] = truth.near_lanes(
                std::array::from_fn(|l| &q[l]),
                std::array::from_fn(|l| &anchors[l]),
                std::array::from_fn(|l| &starts[l]),
            );
            for l in 0..4 {
                let [alone] =
                    crate::cpu::baseline(|| truth.near_lanes([&q[l]], [&anchors[l]], [&starts[l]]));
                let bits = |j: Option<Joints>| j.map(|j| j.as_vector().map(f64::to_bits));
                assert_eq!(bits(group[l]), bits(alone), "lane {l}");
                converged += usize::from(alone.is_some());
            }
        }
        assert_eq!(converged, 800);
    }

    /// A start beyond the series' range and a machine with second-class
    /// errors are handed over (None), never iterated with the series.
    #[test]
    fn out_of_range_and_second_class_are_handed_over() {
        let g = Geometry::paper();
        let nominal = Machine::nominal(&g);
        let pose = nominal.inverse(&Vector3::new(100.0, -50.0, 800.0)).unwrap();
        let q = [pose.legs_mm[0], pose.legs_mm[1], pose.legs_mm[2]];
        let anchor = Anchor::new(&pose.joints);
        let far = Joints::from_vector(
            &(pose.joints.as_vector() + Vector3::new(0.0, 1.5 * MAX_OFFSET_RAD, 0.0)),
        );
        assert_eq!(nominal.near_lanes([&q], [&anchor], [&far]), [None]);
        let [own] = nominal.near_lanes([&q], [&anchor], [&pose.joints]);
        assert!((own.unwrap().as_vector() - pose.joints.as_vector()).amax() < 1e-12);
        let mut twisted = nominal;
        twisted.second = Some(SecondClass::from_angles_deg(0.0, 0.0, 0.0, 0.0));
        assert_eq!(twisted.near_lanes([&q], [&anchor], [&pose.joints]), [None]);
    }

    #[test]
    fn failures_are_those_of_the_general_fk() {
        let g = Geometry::paper();
        let truth = Machine::nominal(&g);
        let j = Joints {
            psi_rad: 0.0,
            theta_rad: 0.0,
            q4_mm: 800.0,
        };
        // Commands no configuration near the anchor satisfies.
        let q = [-5.0, -5.0, -5.0];
        let near = truth.forward_near(&q, &Anchor::new(&j), &j);
        let general = truth.forward(&q, &j);
        assert_eq!(near.is_err(), general.is_err());
        assert_eq!(format!("{near:?}"), format!("{general:?}"));
    }
}
