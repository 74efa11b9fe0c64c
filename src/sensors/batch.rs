//! Datasheet sensors (SPEC §11) read at every pose of one machine at once:
//! the sweep's kernel. One machine's draws — phases, then each sample's
//! jitter, in the order [`Structured::reading`] takes them pose by pose —
//! and the curve shapes at its true joints are computed once and kept while
//! sensor sets that draw alike follow (a sweep's grades differ in amplitude
//! only); each set's reading errors are then a few passes over arrays
//! (quantisation included), with no libm call. [`Structured::reading`]
//! stays the reference, written straight from the SPEC's formula, and the
//! tests hold the two to agree.

use super::structured::{Axis, Phases, Structured};
use super::trig::{quantise, sin_cos_turns};
use nalgebra::Vector3;
use rand::{Rng, RngExt};
use rand_distr::StandardNormal;

/// One machine's draws for datasheet sensors and the curve shapes at its
/// true joints, axis by axis (ψ4, θ4, q4), with the buffers the reading
/// errors are formed in. Reused across trials: no allocation once sized.
#[derive(Debug, Clone, Default)]
pub struct MachineDraws {
    /// The sensor set the draws were made for (None: nothing drawn yet).
    drawn_for: Option<(Structured, u32)>,
    poses: usize,
    /// The true joint at each pose.
    v: [Vec<f64>; 3],
    /// Σk hk·sin(k·2π·v/T + φk) and sin(2π·v/P + φP) at each pose.
    h: [Vec<f64>; 3],
    s: [Vec<f64>; 3],
    /// Jitter draws, sample-major (`z[s·poses + j]`), empty without jitter.
    z: [Vec<f64>; 3],
    /// Each pose's reading error (reading − truth) and a work row.
    err: Vec<f64>,
    work: Vec<f64>,
    /// Three work rows for the curve shapes.
    rows: Vec<f64>,
}

/// Do sensor sets `a` and `b` take the same draws from the same stream and
/// have the same curve shapes (so one machine's draws serve both)?
pub fn draws_alike(a: &Structured, b: &Structured) -> bool {
    a.axes
        .iter()
        .zip(&b.axes)
        .all(|(x, y)| x.same_shape(y) && (x.noise > 0.0) == (y.noise > 0.0))
}

impl MachineDraws {
    /// Make sure the draws serve sensor set `st` of `samples` samples at
    /// the true joints `actual`: kept when the last set drew alike (see
    /// [`draws_alike`]), otherwise drawn afresh from `rng()` — a new stream
    /// positioned where every set's draws start.
    pub fn prepare<R: Rng>(
        &mut self,
        st: &Structured,
        samples: u32,
        actual: &[Vector3<f64>],
        rng: impl FnOnce() -> R,
    ) {
        let kept = self
            .drawn_for
            .as_ref()
            .is_some_and(|(d, n)| *n == samples && draws_alike(d, st));
        if !kept {
            self.draw(st, samples, &mut rng(), actual);
        }
    }

    /// Forget the draws (a new machine).
    pub fn clear(&mut self) {
        self.drawn_for = None;
    }

    /// Draw this machine's phases (ψ4, θ4, q4) and every sample's jitter
    /// (pose by pose, axis by axis, sample by sample, as the reference reads)
    /// and evaluate the curve shapes at `actual`.
    pub fn draw<R: Rng + ?Sized>(
        &mut self,
        st: &Structured,
        samples: u32,
        rng: &mut R,
        actual: &[Vector3<f64>],
    ) {
        let n = actual.len();
        let ns = samples as usize;
        let ph = st.phases(rng);
        self.poses = n;
        for k in 0..3 {
            let jitter = if st.axes[k].noise > 0.0 { ns * n } else { 0 };
            self.v[k].resize(n, 0.0);
            self.h[k].resize(n, 0.0);
            self.s[k].resize(n, 0.0);
            self.z[k].resize(jitter, 0.0);
        }
        self.err.resize(n, 0.0);
        self.work.resize(n, 0.0);
        self.rows.resize(3 * n, 0.0);
        for j in 0..n {
            for k in 0..3 {
                if st.axes[k].noise > 0.0 {
                    for s in 0..ns {
                        self.z[k][s * n + j] = rng.sample(StandardNormal);
                    }
                }
            }
        }
        for k in 0..3 {
            for (v, a) in self.v[k].iter_mut().zip(actual) {
                *v = a[k];
            }
            shapes(
                &st.axes[k],
                &ph[k],
                &self.v[k],
                &mut self.h[k],
                &mut self.s[k],
                &mut self.rows,
            );
        }
        self.drawn_for = Some((*st, samples));
    }

    /// Sensor set `st`'s homed reading errors, as rows of l − l0: row
    /// 3(j−1)+k holds e_j − e_0 of axis k, e being reading − truth. The
    /// draws must have been prepared for a set that draws alike.
    pub fn homed_errors(&mut self, st: &Structured, samples: u32, out: &mut [f64]) {
        debug_assert!(self
            .drawn_for
            .as_ref()
            .is_some_and(|(d, n)| *n == samples && draws_alike(d, st)));
        let n = self.poses;
        let ns = samples as usize;
        for k in 0..3 {
            let ax = &st.axes[k];
            let (v, h, s, z) = (&self.v[k], &self.h[k], &self.s[k], &self.z[k]);
            let a = ax.accuracy;
            let i = if ax.interpolation > 0.0 && ax.signal_period > 0.0 {
                ax.interpolation
            } else {
                0.0
            };
            let err = &mut self.err[..n];
            let mean = 1.0 / ns as f64;
            if ax.resolution > 0.0 {
                // Each sample is quantised: the mean of Q(v + e(v) + jitter).
                let (step, inv) = (ax.resolution, 1.0 / ax.resolution);
                let base = &mut self.work[..n];
                for (b, ((v, h), s)) in base.iter_mut().zip(v.iter().zip(h).zip(s)) {
                    *b = v + (a * h + i * s);
                }
                err.fill(0.0);
                for smp in 0..ns {
                    if z.is_empty() {
                        for (e, b) in err.iter_mut().zip(base.iter()) {
                            *e += quantise(*b, step, inv);
                        }
                    } else {
                        let zs = &z[smp * n..(smp + 1) * n];
                        for (e, (b, zz)) in err.iter_mut().zip(base.iter().zip(zs)) {
                            *e += quantise(b + ax.noise * zz, step, inv);
                        }
                    }
                }
                for (e, v) in err.iter_mut().zip(v) {
                    *e = *e * mean - v;
                }
            } else {
                // Unquantised: e(v) plus the mean jitter, without v's rounding.
                for (e, (h, s)) in err.iter_mut().zip(h.iter().zip(s)) {
                    *e = a * h + i * s;
                }
                if !z.is_empty() {
                    let sum = &mut self.work[..n];
                    sum.fill(0.0);
                    for smp in 0..ns {
                        for (m, zz) in sum.iter_mut().zip(&z[smp * n..(smp + 1) * n]) {
                            *m += zz;
                        }
                    }
                    for (e, m) in err.iter_mut().zip(sum.iter()) {
                        *e += ax.noise * (m * mean);
                    }
                }
            }
            let e0 = err[0];
            for j in 1..n {
                out[3 * (j - 1) + k] = err[j] - e0;
            }
        }
    }
}

/// The curve shapes of one axis at the joint values `v`: the harmonics by
/// powers of e^{i·2π·v/T} (one sine and cosine per pose), the interpolation
/// error by one more. Every loop runs over the poses, so it vectorises; `w`
/// holds three work rows of `v.len()` (s is the fourth until the end).
fn shapes(ax: &Axis, ph: &Phases, v: &[f64], h: &mut [f64], s: &mut [f64], w: &mut [f64]) {
    let n = v.len();
    let (c, w) = w.split_at_mut(n);
    let (s1, c1) = w.split_at_mut(n);
    let c1 = &mut c1[..n];
    // s, c: sin and cos of k·2π·v/T for k = 1, 2, …; h accumulates.
    for ((a, b), &vj) in s1.iter_mut().zip(c1.iter_mut()).zip(v) {
        (*a, *b) = sin_cos_turns(vj / ax.period);
    }
    s.copy_from_slice(s1);
    c.copy_from_slice(c1);
    h.fill(0.0);
    for k in 0..ax.n_harmonics {
        // sin(kx + φ) = sin kx·cos φ + cos kx·sin φ
        let (hk, cp, sp) = (ax.harmonics[k], ph.harmonic[k].cos(), ph.harmonic[k].sin());
        for ((hj, sj), cj) in h.iter_mut().zip(s.iter()).zip(c.iter()) {
            *hj += hk * (sj * cp + cj * sp);
        }
        // (k+1)·x from k·x and x.
        for (((sj, cj), a), b) in s.iter_mut().zip(c.iter_mut()).zip(s1.iter()).zip(c1.iter()) {
            (*sj, *cj) = (*sj * b + *cj * a, *cj * b - *sj * a);
        }
    }
    if ax.interpolation > 0.0 && ax.signal_period > 0.0 {
        let (cp, sp) = (ph.interpolation.cos(), ph.interpolation.sin());
        for (sj, &vj) in s.iter_mut().zip(v) {
            let (si, ci) = sin_cos_turns(vj / ax.signal_period);
            *sj = si * cp + ci * sp;
        }
    } else {
        s.fill(0.0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensors::structured::MAX_HARMONICS;
    use crate::sensors::ARCSEC_PER_RAD;
    use rand::{RngExt, SeedableRng};

    fn axis(accuracy: f64, harmonics: &[f64], period: f64) -> Axis {
        let mut h = [0.0; MAX_HARMONICS];
        h[..harmonics.len()].copy_from_slice(harmonics);
        Axis {
            accuracy,
            harmonics: h,
            n_harmonics: harmonics.len(),
            period,
            interpolation: 0.0,
            signal_period: 0.0,
            noise: 0.0,
            resolution: 0.0,
        }
    }

    /// Encoders and scale of the example catalogue's ±2″ and ±0.5 µm
    /// classes (jitter, interpolation and quantisation all present).
    fn catalogue_like() -> Structured {
        let r = 1.0 / ARCSEC_PER_RAD;
        let mut enc = axis(2.0 * r, &[0.7, 0.3], std::f64::consts::TAU);
        enc.interpolation = 0.36 * r;
        enc.signal_period = 72.0 * r;
        enc.noise = 0.02 * r;
        enc.resolution = 0.0176 * r;
        let mut scale = axis(0.5e-3, &[0.8, 0.15, 0.0, 0.05], 400.0);
        scale.interpolation = 0.04e-3;
        scale.signal_period = 4e-3;
        scale.noise = 0.003e-3;
        scale.resolution = 1e-6;
        Structured {
            axes: [enc, enc, scale],
            from_section: [true; 3],
        }
    }

    fn joints(n: usize, rng: &mut impl Rng) -> Vec<Vector3<f64>> {
        (0..n)
            .map(|_| {
                Vector3::new(
                    rng.random_range(-0.6..0.6),
                    rng.random_range(-0.6..0.6),
                    rng.random_range(450.0..850.0),
                )
            })
            .collect()
    }

    /// The reference: each pose read by [`Structured::reading`] from the
    /// same stream, homed rows e_j − e_0.
    fn reference(st: &Structured, samples: u32, seed: u64, actual: &[Vector3<f64>]) -> Vec<f64> {
        let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(seed);
        let ph = st.phases(&mut rng);
        let e: Vec<Vector3<f64>> = actual
            .iter()
            .map(|a| st.reading(&ph, a, samples, &mut rng) - a)
            .collect();
        let mut out = vec![0.0; 3 * (actual.len() - 1)];
        for j in 1..actual.len() {
            for k in 0..3 {
                out[3 * (j - 1) + k] = e[j][k] - e[0][k];
            }
        }
        out
    }

    #[test]
    fn the_kernel_reads_what_the_reference_reads() {
        let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(9);
        let mut d = MachineDraws::default();
        let mut worst = [0.0f64; 3];
        for trial in 0..200u64 {
            let mut st = catalogue_like();
            // Vary what is present: no jitter, no quantisation, both.
            match trial % 4 {
                1 => st.axes.iter_mut().for_each(|a| a.resolution = 0.0),
                2 => st.axes.iter_mut().for_each(|a| a.noise = 0.0),
                3 => st.axes[1].interpolation = 0.0,
                _ => {}
            }
            let samples = 1 + (trial % 3) as u32;
            let actual = joints(12, &mut rng);
            d.draw(
                &st,
                samples,
                &mut rand::rngs::Xoshiro256PlusPlus::seed_from_u64(trial),
                &actual,
            );
            let mut got = vec![0.0; 33];
            d.homed_errors(&st, samples, &mut got);
            let want = reference(&st, samples, trial, &actual);
            for (r, (g, w)) in got.iter().zip(&want).enumerate() {
                worst[r % 3] = worst[r % 3].max((g - w).abs());
            }
        }
        // Encoders to 1e-15 rad; the scale to 1e-12 mm (a reading of
        // 650 mm rounds at 1e-13 mm before the truth is taken off).
        assert!(worst[0] < 1e-15 && worst[1] < 1e-15, "{worst:?}");
        assert!(worst[2] < 1e-12, "{worst:?}");
    }

    #[test]
    fn grades_that_draw_alike_share_the_draws() {
        let a = catalogue_like();
        let mut b = a.at_grades(5.0 / ARCSEC_PER_RAD, 2e-3);
        assert!(draws_alike(&a, &b));
        let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(1);
        let actual = joints(6, &mut rng);
        let mut d = MachineDraws::default();
        let stream = || rand::rngs::Xoshiro256PlusPlus::seed_from_u64(77);
        d.prepare(&a, 3, &actual, stream);
        // Kept for b: b's errors are the reference's from the same stream.
        let mut calls = 0;
        d.prepare(&b, 3, &actual, || {
            calls += 1;
            stream()
        });
        assert_eq!(calls, 0);
        let mut got = vec![0.0; 15];
        d.homed_errors(&b, 3, &mut got);
        let want = reference(&b, 3, 77, &actual);
        let diff = got
            .iter()
            .zip(&want)
            .map(|(g, w)| (g - w).abs())
            .fold(0.0, f64::max);
        assert!(diff < 1e-12, "{diff:e}");
        // Another shape, or other samples, draws afresh.
        b.axes[0].harmonics[0] = 0.5;
        assert!(!draws_alike(&a, &b));
        d.prepare(&b, 3, &actual, || {
            calls += 1;
            stream()
        });
        d.prepare(&b, 2, &actual, || {
            calls += 1;
            stream()
        });
        assert_eq!(calls, 2);
        let mut c = a;
        c.axes[2].noise = 0.0;
        assert!(!draws_alike(&a, &c));
    }
}
