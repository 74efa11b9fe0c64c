//! One quantised axis of one machine in units of its resolution: the part of
//! the datasheet kernel ([`super::batch`]) that turns a sensor set's
//! amplitudes into mean quantised reading errors, a multiply-add per pose and
//! an add and a rounding per sample.

use super::trig::{round_even, round_small, ROUND_SMALL_MAX};

/// One quantised axis of one machine in units of the resolution r, so that a
/// sensor set's readings cost one multiply-add per pose and an add and a
/// rounding per sample: with v/r = N + f (N the nearest integer), a sample's
/// quantised value is r·(N + round(f + (a·h + i·s)/r + σ·z/r)), and the mean
/// error of `samples` samples is r·(Σ round(…)/samples − f). N drops out, so
/// the error is formed without the reading's magnitude (a scale's 650 mm).
#[derive(Debug, Clone, Default)]
pub(super) struct Units {
    /// (resolution, jitter σ, interpolation amplitude); NaN: not computed
    /// for the current draws.
    pub(super) key: [f64; 3],
    /// f, and f + i·s/r at each pose.
    frac: Vec<f64>,
    fixed: Vec<f64>,
    /// h/r at each pose.
    curve: Vec<f64>,
    /// σ·z/r, sample-major (`jitter[s·poses + j]`), empty without jitter.
    jitter: Vec<f64>,
    /// Some value of `fixed`, `curve` or `jitter` is beyond 2⁴⁹.
    big: bool,
}

impl Units {
    /// The draws of one axis (true joints v, shapes h and s, jitter z) in
    /// units of `key`'s resolution.
    #[inline(always)]
    pub(super) fn fill(&mut self, key: [f64; 3], v: &[f64], h: &[f64], s: &[f64], z: &[f64]) {
        let [step, noise, i] = key;
        let inv = 1.0 / step;
        let n = v.len();
        for x in [&mut self.frac, &mut self.fixed, &mut self.curve] {
            x.resize(n, 0.0);
        }
        // Is any value beyond 2⁴⁹ (compares folded by OR, in the same
        // vectorised pass)?
        let bound = ROUND_SMALL_MAX / 4.0;
        let mut big = false;
        let (frac, fixed, curve) = (
            &mut self.frac[..n],
            &mut self.fixed[..n],
            &mut self.curve[..n],
        );
        let (h, s) = (&h[..n], &s[..n]);
        for j in 0..n {
            let x = v[j] * inv;
            frac[j] = x - round_even(x);
            fixed[j] = frac[j] + i * s[j] * inv;
            curve[j] = h[j] * inv;
            big |= (fixed[j].abs() > bound) | (curve[j].abs() > bound);
        }
        // σ·z/r, checked in the same pass.
        self.jitter.resize(z.len(), 0.0);
        let scale = noise * inv;
        for (w, z) in self.jitter.iter_mut().zip(z) {
            *w = scale * z;
            big |= w.abs() > bound;
        }
        self.big = big;
        self.key = key;
    }

    /// The reading errors at each pose, for accuracy `a`, resolution
    /// r = `step` and `samples` samples (`base` is a work row):
    /// e = r·(mean of round(fixed + a·curve + jitter) − f).
    #[inline(always)]
    pub(super) fn errors(
        &self,
        err: &mut [f64],
        base: &mut [f64],
        a: f64,
        step: f64,
        samples: usize,
    ) {
        // With fixed, curve and jitter within 2⁴⁹ and |a| ≤ 2 (rad or mm)
        // every sample is within 2⁵¹ (always, for any sensor a datasheet
        // describes): the rounding needs no test of the sign or magnitude.
        if !self.big && a.abs() <= 2.0 {
            self.errors_by(err, base, a, step, samples, round_small);
        } else {
            self.errors_by(err, base, a, step, samples, round_even);
        }
    }

    /// [`Units::errors`] with the rounding `round`: the usual sample counts
    /// in one pass per pose (the samples summed in registers), more in
    /// passes over the poses; the same operations in the same order.
    #[inline(always)]
    fn errors_by(
        &self,
        err: &mut [f64],
        base: &mut [f64],
        a: f64,
        step: f64,
        samples: usize,
        round: impl Fn(f64) -> f64 + Copy,
    ) {
        match (samples, self.jitter.is_empty()) {
            (_, true) => self.unjittered(err, a, step, round),
            (1, _) => self.fused::<1>(err, a, step, round),
            (2, _) => self.fused::<2>(err, a, step, round),
            (3, _) => self.fused::<3>(err, a, step, round),
            (4, _) => self.fused::<4>(err, a, step, round),
            _ => self.passes(err, base, a, step, samples, round),
        }
    }

    /// Without jitter every sample is the base.
    #[inline(always)]
    fn unjittered(&self, err: &mut [f64], a: f64, step: f64, round: impl Fn(f64) -> f64) {
        let n = err.len();
        let (fixed, curve, frac) = (&self.fixed[..n], &self.curve[..n], &self.frac[..n]);
        for j in 0..n {
            err[j] = step * (round(fixed[j] + a * curve[j]) - frac[j]);
        }
    }

    /// S samples with jitter, a pose's samples summed in registers.
    #[inline(always)]
    fn fused<const S: usize>(
        &self,
        err: &mut [f64],
        a: f64,
        step: f64,
        round: impl Fn(f64) -> f64,
    ) {
        let n = err.len();
        let (fixed, curve, frac) = (&self.fixed[..n], &self.curve[..n], &self.frac[..n]);
        let jitter: [&[f64]; S] = std::array::from_fn(|s| &self.jitter[s * n..(s + 1) * n]);
        let mean = 1.0 / S as f64;
        for j in 0..n {
            let b = fixed[j] + a * curve[j];
            // The first sample starts the sum (0 + it is it: a rounding
            // never gives −0).
            let mut acc = round(b + jitter[0][j]);
            for w in &jitter[1..] {
                acc += round(b + w[j]);
            }
            err[j] = step * (acc * mean - frac[j]);
        }
    }

    /// Any number of samples with jitter, one pass over the poses each.
    #[inline(always)]
    fn passes(
        &self,
        err: &mut [f64],
        base: &mut [f64],
        a: f64,
        step: f64,
        samples: usize,
        round: impl Fn(f64) -> f64,
    ) {
        let n = err.len();
        for (b, (f, c)) in base.iter_mut().zip(self.fixed.iter().zip(&self.curve)) {
            *b = f + a * c;
        }
        err.fill(0.0);
        for w in self.jitter.chunks_exact(n).take(samples) {
            for (e, (b, w)) in err.iter_mut().zip(base.iter().zip(w)) {
                *e += round(b + w);
            }
        }
        let mean = 1.0 / samples as f64;
        for (e, f) in err.iter_mut().zip(&self.frac) {
            *e = step * (*e * mean - f);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    /// Every way [`Units::errors`] takes (fused for 1–4 samples, passes
    /// for more, without jitter, and the full rounding when values are
    /// large) against the formula read straight, bit for bit: r·(mean of
    /// round_even(fixed + a·curve + jitter) − f).
    #[test]
    fn quantised_errors_are_the_formula_on_every_path() {
        let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(17);
        let n = 13;
        for case in 0..48 {
            let samples = 1 + case % 6;
            let jittered = case % 5 != 4;
            // Half-integers beyond 2⁵¹ (where only the full rounding is
            // right) in one case of four.
            let big = case % 4 == 3;
            let mut u = Units::default();
            let mut draw = |lo: f64, hi: f64| -> Vec<f64> {
                (0..n)
                    .map(|_| rng.random_range(lo..hi).round() + 0.5)
                    .collect()
            };
            u.frac = draw(-1.0, 0.0);
            u.fixed = if big {
                draw(2.4e15, 4.4e15)
            } else {
                draw(-60.0, 60.0)
            };
            u.curve = draw(-40.0, 40.0);
            u.jitter = if jittered {
                draw(-3.0, 3.0).repeat(samples)
            } else {
                Vec::new()
            };
            let large = |x: &[f64]| x.iter().any(|x| x.abs() > ROUND_SMALL_MAX / 4.0);
            u.big = large(&u.fixed) || large(&u.curve) || large(&u.jitter);
            assert_eq!(u.big, big);
            let (a, step) = (1.5, 0.01);
            let mut got = vec![0.0; n];
            u.errors(&mut got, &mut vec![0.0; n], a, step, samples);
            for j in 0..n {
                let b = u.fixed[j] + a * u.curve[j];
                let want = if jittered {
                    let mut acc = 0.0;
                    for s in 0..samples {
                        acc += round_even(b + u.jitter[s * n + j]);
                    }
                    step * (acc * (1.0 / samples as f64) - u.frac[j])
                } else {
                    step * (round_even(b) - u.frac[j])
                };
                assert_eq!(
                    got[j].to_bits(),
                    want.to_bits(),
                    "case {case} pose {j}: {} vs {want}",
                    got[j]
                );
            }
        }
    }

    /// An axis in units of its resolution: f is the fractional part of
    /// v/r (|f| ≤ 1/2, v/r − f an integer), the other rows are scaled by
    /// 1/r, and values beyond 2⁴⁹ are flagged (only then the full rounding).
    #[test]
    fn units_are_the_fraction_and_the_scaled_rows() {
        let v = [650.123_456_789, -0.3, 1e-7, 2.5e-6];
        let (h, s, z) = (
            [0.5, -1.0, 0.25, 0.0],
            [1.0, 0.5, -0.5, 0.0],
            [2.0, -1.0, 0.0, 3.0],
        );
        let mut u = Units::default();
        u.fill([1e-6, 3e-9, 4e-8], &v, &h, &s, &z);
        for j in 0..4 {
            let q = v[j] * 1e6;
            let f = u.frac[j];
            assert!(f.abs() <= 0.5, "{f}");
            assert_eq!(q - f, (q - f).round(), "{j}");
            assert!((u.fixed[j] - (f + 4e-8 * s[j] * 1e6)).abs() < 1e-12);
            assert!((u.curve[j] - h[j] * 1e6).abs() < 1e-9);
            assert!((u.jitter[j] - 3e-9 * z[j] * 1e6).abs() < 1e-12);
        }
        assert!(!u.big);
        assert_eq!(u.key, [1e-6, 3e-9, 4e-8]);
        // A resolution far below the values: flagged, by each row alone.
        for (k, r) in [(0, 1e-9), (1, 1e-9), (2, 1e-9), (3, 1e-9)] {
            let big = 1e6;
            let (mut h2, mut s2, mut z2) = (h, s, z);
            // Two large values in the row (a flag, not a parity).
            match k {
                0 => (s2[1], s2[2]) = (big, -big),
                1 => (h2[2], h2[0]) = (big, big),
                // Both rows large at one pose.
                3 => (s2[1], h2[1]) = (big, big),
                _ => (z2[3], z2[1]) = (big, -big),
            }
            u.fill([r, 1.0, 1.0], &v, &h2, &s2, &z2);
            assert!(u.big, "row {k}");
        }
    }
}
