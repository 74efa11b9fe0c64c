//! The encoders as the study reads and weights them: one machine's
//! readings through each encoder's datasheet model ([`measured`]) and the
//! whitening of their datasheet covariance GLS weights by ([`whitening`]).

use crate::mechanism::Mechanism;
use crate::montecarlo::streams::stream;
use crate::sensors::batch::axis_shapes;
use crate::sensors::{Axis, Phases, SensorCovariance};
use nalgebra::DMatrix;
use rand::RngExt;

/// The readings an encoder of model `axis` reports (degrees): each exact
/// one plus what the encoder adds at the angle it stands at, its datasheet
/// reading ([`Axis::reading`]: curve and interpolation by the encoder's own
/// phases, the mean of `samples` samples of jitter, each quantised to the
/// resolution). Stream (seed, k, 1): every slot's encoder's phases
/// ([`Mechanism::slots`], fitted or not), then the readings' jitter draws
/// in reading order; `per_pose` readings a pose.
pub(super) fn measured<M: Mechanism>(
    axis: &Axis,
    (seed, samples): (u64, u32),
    k: u64,
    exact: &[f64],
    angles: &[f64],
    (m, per_pose): (&M, usize),
) -> Vec<f64> {
    let mut rng = stream(seed, k, 1);
    let phases: Vec<Phases> = (0..m.slots()).map(|_| axis.phases(&mut rng)).collect();
    let samples = samples.max(1);
    let poses = exact.len() / per_pose;
    // Which slot's encoder reading i of a pose is.
    let slot = |i: usize| m.slot(i);
    // Each encoder's curve shapes at the angles it stands at, by the
    // study kernel's recurrences (the readings' order: pose-major).
    let (mut v, mut w) = (vec![0.0; poses], vec![0.0; 2 * poses]);
    let (mut h, mut si) = (vec![0.0; exact.len()], vec![0.0; exact.len()]);
    let (mut hs, mut ss) = (vec![0.0; poses], vec![0.0; poses]);
    for i in 0..per_pose {
        for (p, x) in v.iter_mut().enumerate() {
            *x = angles[p * per_pose + i];
        }
        axis_shapes(axis, &phases[slot(i)], &v, &mut hs, &mut ss, &mut w);
        for p in 0..poses {
            h[p * per_pose + i] = hs[p];
            si[p * per_pose + i] = ss[p];
        }
    }
    let mut z = vec![0.0; axis.draws_per_reading(samples)];
    let mut out = Vec::with_capacity(exact.len());
    for (j, (&r, &a)) in exact.iter().zip(angles).enumerate() {
        for x in z.iter_mut() {
            *x = rng.sample(rand_distr::StandardNormal);
        }
        let err = axis.reading_of_shape(a, h[j], si[j], samples, |s| z[s]) - a;
        out.push(r + err.to_degrees());
    }
    out
}

/// W = Σ^(−1/2) of the readings' errors (degrees) of encoders with datasheet
/// model `axis` at the nominal readings `nominal` (degrees; pose-major,
/// `per_pose` encoders a pose, each its own draw): each encoder's block over
/// the poses is its curve's covariance between the angles it stands at, its
/// interpolation error's (white, or its kernel under an assumed coherence)
/// and its jitter and quantisation; W is the inverse of each block's
/// Cholesky factor. None when a block is not positive definite.
pub(super) fn whitening(
    axis: &Axis,
    samples: u32,
    nominal: &[f64],
    per_pose: usize,
) -> Option<DMatrix<f64>> {
    let c = SensorCovariance::of_axis(axis, samples);
    let deg2 = (180.0 / std::f64::consts::PI).powi(2);
    let m = nominal.len();
    let poses = m / per_pose.max(1);
    let mut w = DMatrix::zeros(m, m);
    for slot in 0..per_pose {
        let at = |j: usize| nominal[j * per_pose + slot].to_radians();
        let block = DMatrix::from_fn(poses, poses, |i, j| c.between(at(i), at(j), i == j) * deg2);
        let l = block.cholesky()?.l();
        let inv = l.solve_lower_triangular(&DMatrix::identity(poses, poses))?;
        for i in 0..poses {
            for j in 0..poses {
                w[(i * per_pose + slot, j * per_pose + slot)] = inv[(i, j)];
            }
        }
    }
    Some(w)
}
