//! One machine's jitter draws for datasheet sensors, in the order its
//! generator gives them.

use super::normal::Normals;
use rand::Rng;

/// One machine's jitter draws, standard normals in the order they are taken
/// from its generator: axis by axis (a mechanism's reading slots in order: the Tricept's ψ4, θ4, q4), then each of the draws a
/// reading takes (`Axis::draws_per_reading`: a sample's, or the mean's),
/// then pose by pose. Draw s of axis k at pose j is `axis(k)[s·poses + j]`:
/// each axis is one row per sample, as the sweep's kernel reads them (drawn
/// pose by pose, they had to be laid out again: 6 % of a quantised trial's
/// instructions).
/// `R` is the number of axes, one a reading slot.
#[derive(Debug, Clone)]
pub struct JitterTable<const R: usize> {
    z: [Vec<f64>; R],
    poses: usize,
}

impl<const R: usize> Default for JitterTable<R> {
    fn default() -> Self {
        JitterTable {
            z: std::array::from_fn(|_| Vec::new()),
            poses: 0,
        }
    }
}

impl<const R: usize> JitterTable<R> {
    /// `per_reading[k]` draws of axis k at each of `poses` poses:
    /// `StandardNormal`'s from `rng`, in turn.
    pub fn fill<G: Rng + Clone>(&mut self, per_reading: [usize; R], poses: usize, rng: &mut G) {
        for (z, n) in self.z.iter_mut().zip(per_reading) {
            z.resize(n * poses, 0.0);
            Normals::get().fill(rng, z);
        }
        self.poses = poses;
    }

    /// Axis k's draws, sample-major (empty without jitter).
    pub fn axis(&self, k: usize) -> &[f64] {
        &self.z[k]
    }

    /// Draw s of axis k at pose j.
    pub fn draw(&self, k: usize, s: usize, j: usize) -> f64 {
        self.z[k][s * self.poses + j]
    }
}
