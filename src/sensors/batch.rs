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
use super::trig::{round_even, round_small, sin_cos_turns, ROUND_SMALL_MAX};
use crate::model::near::{sin_cos_near, MAX_OFFSET_RAD};
use nalgebra::Vector3;
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};

/// One machine's draws for datasheet sensors and the curve shapes at its
/// true joints, axis by axis (ψ4, θ4, q4), with the buffers the reading
/// errors are formed in. Reused across trials: no allocation once sized.
#[derive(Debug, Clone, Default)]
pub struct MachineDraws {
    /// The sensor set the draws were made for (None: nothing drawn yet).
    drawn_for: Option<(Structured, u32)>,
    /// The class of sets it was drawn for by [`MachineDraws::prepare`].
    class: Option<usize>,
    poses: usize,
    /// The true joint at each pose.
    v: [Vec<f64>; 3],
    /// Σk hk·sin(k·2π·v/T + φk) and sin(2π·v/P + φP) at each pose.
    h: [Vec<f64>; 3],
    s: [Vec<f64>; 3],
    /// Jitter draws, sample-major (`z[s·poses + j]`), empty without jitter.
    z: [Vec<f64>; 3],
    /// Every jitter draw in the order the reference takes them.
    flat: Vec<f64>,
    /// Each pose's reading error (reading − truth) and a work row.
    err: Vec<f64>,
    work: Vec<f64>,
    /// Three work rows for the curve shapes.
    rows: Vec<f64>,
    /// Each axis's nominal joint at each pose (see [`MachineDraws::anchor_at`]),
    /// and sin, cos of a whole curve period's angle there, one entry per
    /// period met (a catalogue's scales differ in length): computed once,
    /// kept for the whole run.
    nominal: [Vec<f64>; 3],
    anchors: [Vec<Anchor>; 3],
    /// Each quantised axis's draws in units of its resolution (see
    /// [`Units`]), for the resolution, jitter and interpolation they were
    /// computed with.
    units: [Units; 3],
}

/// A curve period and sin, cos of its angle at each pose's nominal joint.
type Anchor = (f64, Vec<f64>, Vec<f64>);

/// One quantised axis of one machine in units of the resolution r, so that a
/// sensor set's readings cost one multiply-add per pose and an add and a
/// rounding per sample: with v/r = N + f (N the nearest integer), a sample's
/// quantised value is r·(N + round(f + (a·h + i·s)/r + σ·z/r)), and the mean
/// error of `samples` samples is r·(Σ round(…)/samples − f). N drops out, so
/// the error is formed without the reading's magnitude (a scale's 650 mm).
#[derive(Debug, Clone, Default)]
struct Units {
    /// (resolution, jitter σ, interpolation amplitude); NaN: not computed
    /// for the current draws.
    key: [f64; 3],
    /// f, and f + i·s/r at each pose.
    frac: Vec<f64>,
    fixed: Vec<f64>,
    /// h/r at each pose.
    curve: Vec<f64>,
    /// σ·z/r, sample-major like `z`.
    jitter: Vec<f64>,
    /// Some value of `fixed`, `curve` or `jitter` is beyond 2⁴⁹.
    big: bool,
}

/// Do sensor sets `a` and `b` take the same draws from the same stream and
/// have the same curve shapes (so one machine's draws serve both)?
pub fn draws_alike(a: &Structured, b: &Structured) -> bool {
    a.axes.iter().zip(&b.axes).all(|(x, y)| {
        x.same_shape(y)
            && (x.noise > 0.0) == (y.noise > 0.0)
            && (x.resolution > 0.0) == (y.resolution > 0.0)
    })
}

impl MachineDraws {
    /// Make sure the draws serve sensor set `st` of `samples` samples at
    /// the true joints `actual`: kept when the last set drawn for was of the
    /// same `class` (the caller's number for the sets that draw alike, see
    /// [`draws_alike`] and `SweepContext::draw_class`), otherwise drawn
    /// afresh from `rng()`: a new stream positioned where every set's draws
    /// start.
    pub fn prepare<R: Rng + Clone>(
        &mut self,
        class: usize,
        st: &Structured,
        samples: u32,
        actual: &[Vector3<f64>],
        rng: impl FnOnce() -> R,
    ) {
        if self.class != Some(class) {
            self.draw(st, samples, &mut rng(), actual);
            self.class = Some(class);
        }
    }

    /// Anchor the curve shapes at the poses' nominal joints (ψ4, θ4, q4 of
    /// each pose): a machine's true joints lie within a few milliradians
    /// (or millimetres) of them, so the angle of a curve's first harmonic
    /// follows from its value there by a short series, not a full sine.
    pub fn anchor_at(&mut self, nominal: &[Vector3<f64>]) {
        for k in 0..3 {
            self.nominal[k] = nominal.iter().map(|v| v[k]).collect();
            self.anchors[k].clear();
        }
    }

    /// Forget the draws (a new machine).
    pub fn clear(&mut self) {
        self.drawn_for = None;
        self.class = None;
    }

    /// Draw this machine's phases (ψ4, θ4, q4) and every sample's jitter
    /// (pose by pose, axis by axis, sample by sample, as the reference reads)
    /// and evaluate the curve shapes at `actual`.
    pub fn draw<R: Rng + Clone>(
        &mut self,
        st: &Structured,
        samples: u32,
        rng: &mut R,
        actual: &[Vector3<f64>],
    ) {
        let n = actual.len();
        // The generator's state in a local of its own (in registers through
        // the loop of draws, not reloaded after every store), handed back at
        // the end.
        let mut local = rng.clone();
        let ph = st.phases(&mut local);
        self.poses = n;
        for k in 0..3 {
            let jitter = st.axes[k].draws_per_reading(samples) * n;
            self.v[k].resize(n, 0.0);
            self.h[k].resize(n, 0.0);
            self.s[k].resize(n, 0.0);
            self.z[k].resize(jitter, 0.0);
        }
        self.err.resize(n, 0.0);
        self.work.resize(n, 0.0);
        self.rows.resize(3 * n, 0.0);
        // Drawn in the reference's order into one row (a tight loop), then
        // laid out axis by axis, sample-major.
        let draws = st.axes.map(|a| a.draws_per_reading(samples));
        let per_pose: usize = draws.iter().sum();
        self.flat.resize(per_pose * n, 0.0);
        for x in self.flat.iter_mut() {
            *x = StandardNormal.sample(&mut local);
        }
        *rng = local;
        for (j, pose) in self.flat.chunks_exact(per_pose.max(1)).enumerate() {
            let mut at = 0;
            for k in 0..3 {
                for s in 0..draws[k] {
                    self.z[k][s * n + j] = pose[at];
                    at += 1;
                }
            }
        }
        for k in 0..3 {
            for (v, a) in self.v[k].iter_mut().zip(actual) {
                *v = a[k];
            }
            let period = st.axes[k].period;
            let anchored = self.nominal[k].len() == n;
            let at = self.anchors[k].iter().position(|a| a.0 == period);
            let anchor = match (anchored, at) {
                (false, _) => None,
                (true, Some(at)) => Some(at),
                (true, None) => {
                    let (s0, c0): (Vec<f64>, Vec<f64>) = self.nominal[k]
                        .iter()
                        .map(|&vn| sin_cos_turns(vn / period))
                        .unzip();
                    self.anchors[k].push((period, s0, c0));
                    Some(self.anchors[k].len() - 1)
                }
            };
            let anchor = anchor.map(|at| {
                let (_, s0, c0) = &self.anchors[k][at];
                (&self.nominal[k][..], &s0[..], &c0[..])
            });
            shapes(
                anchor,
                &st.axes[k],
                &ph[k],
                &self.v[k],
                &mut self.h[k],
                &mut self.s[k],
                &mut self.rows,
            );
        }
        for u in &mut self.units {
            u.key = [f64::NAN; 3];
        }
        self.drawn_for = Some((*st, samples));
        self.class = None;
    }

    /// Sensor set `st`'s homed reading errors, as rows of l − l0: row
    /// 3(j−1)+k holds e_j − e_0 of axis k, e being reading − truth, for the
    /// axes k with `axes[k]` (the other rows are left as they are). The draws
    /// must have been prepared for a set that draws alike.
    pub fn homed_errors(
        &mut self,
        st: &Structured,
        samples: u32,
        axes: [bool; 3],
        out: &mut [f64],
    ) {
        debug_assert!(self
            .drawn_for
            .as_ref()
            .is_some_and(|(d, n)| *n == samples && draws_alike(d, st)));
        let n = self.poses;
        let ns = samples as usize;
        for k in (0..3).filter(|&k| axes[k]) {
            let ax = &st.axes[k];
            let a = ax.accuracy;
            let i = if ax.interpolation > 0.0 && ax.signal_period > 0.0 {
                ax.interpolation
            } else {
                0.0
            };
            let err = &mut self.err[..n];
            if ax.resolution > 0.0 {
                // Each sample is quantised: the mean of Q(v + e(v) + jitter),
                // in units of the resolution (see [`Units`]).
                let u = &mut self.units[k];
                let key = [ax.resolution, ax.noise, i];
                if u.key != key {
                    u.fill(key, &self.v[k], &self.h[k], &self.s[k], &self.z[k]);
                }
                quantised_errors(err, &mut self.work[..n], u, a, ax.resolution, ns);
            } else {
                // Unquantised: e(v) plus the mean jitter (one draw of σ/√samples),
                // without v's rounding.
                let (h, s, z) = (&self.h[k], &self.s[k], &self.z[k]);
                for (e, (h, s)) in err.iter_mut().zip(h.iter().zip(s)) {
                    *e = a * h + i * s;
                }
                if !z.is_empty() {
                    let sigma = ax.mean_noise(samples);
                    for (e, zz) in err.iter_mut().zip(z) {
                        *e += sigma * zz;
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

/// One quantised axis's reading errors at each pose (see [`Units`]):
/// e = r·(mean of round(fixed + a·curve + jitter) − f), for accuracy `a`,
/// resolution r = `step` and `samples` samples; `base` is a work row.
fn quantised_errors(
    err: &mut [f64],
    base: &mut [f64],
    u: &Units,
    a: f64,
    step: f64,
    samples: usize,
) {
    // With fixed, curve and jitter within 2⁴⁹ and |a| ≤ 2 (rad or mm) every
    // sample is within 2⁵¹ (always, for any sensor a datasheet describes):
    // the rounding needs no test of the sign or the magnitude.
    let small = !u.big && a.abs() <= 2.0;
    // The usual sample counts in one pass per pose, the samples unrolled.
    match (small, samples, u.jitter.is_empty()) {
        (true, _, true) => unjittered(err, u, a, step),
        (true, 1, false) => fused::<1>(err, u, a, step),
        (true, 2, false) => fused::<2>(err, u, a, step),
        (true, 3, false) => fused::<3>(err, u, a, step),
        (true, 4, false) => fused::<4>(err, u, a, step),
        _ => {
            for (b, (f, c)) in base.iter_mut().zip(u.fixed.iter().zip(&u.curve)) {
                *b = f + a * c;
            }
            if small {
                quantised_sum(err, base, &u.jitter, samples, round_small);
            } else {
                quantised_sum(err, base, &u.jitter, samples, round_even);
            }
            for (e, f) in err.iter_mut().zip(&u.frac) {
                *e = step * (*e - f);
            }
        }
    }
}

/// [`quantised_errors`] for S samples with jitter, the samples of a pose
/// summed in registers; the same operations in the same order as the
/// general passes.
#[inline(always)]
fn fused<const S: usize>(err: &mut [f64], u: &Units, a: f64, step: f64) {
    let n = err.len();
    let (fixed, curve, frac) = (&u.fixed[..n], &u.curve[..n], &u.frac[..n]);
    let jitter: [&[f64]; S] = std::array::from_fn(|s| &u.jitter[s * n..(s + 1) * n]);
    let mean = 1.0 / S as f64;
    for j in 0..n {
        let b = fixed[j] + a * curve[j];
        let mut acc = 0.0;
        for w in &jitter {
            acc += round_small(b + w[j]);
        }
        err[j] = step * (acc * mean - frac[j]);
    }
}

/// [`quantised_errors`] without jitter: every sample is the base.
#[inline(always)]
fn unjittered(err: &mut [f64], u: &Units, a: f64, step: f64) {
    let n = err.len();
    let (fixed, curve, frac) = (&u.fixed[..n], &u.curve[..n], &u.frac[..n]);
    for j in 0..n {
        err[j] = step * (round_small(fixed[j] + a * curve[j]) - frac[j]);
    }
}

/// The mean of `samples` rounded samples at each pose, base + jitter (the
/// jitter sample-major; without jitter every sample is the base).
#[inline(always)]
fn quantised_sum(
    err: &mut [f64],
    base: &[f64],
    jitter: &[f64],
    samples: usize,
    round: impl Fn(f64) -> f64,
) {
    let n = err.len();
    if jitter.is_empty() {
        for (e, b) in err.iter_mut().zip(base) {
            *e = round(*b);
        }
        return;
    }
    err.fill(0.0);
    for w in jitter.chunks_exact(n).take(samples) {
        for (e, (b, w)) in err.iter_mut().zip(base.iter().zip(w)) {
            *e += round(b + w);
        }
    }
    let mean = 1.0 / samples as f64;
    for e in err.iter_mut() {
        *e *= mean;
    }
}

impl Units {
    /// The draws of one axis (true joints v, shapes h and s, jitter z) in
    /// units of `key`'s resolution.
    fn fill(&mut self, key: [f64; 3], v: &[f64], h: &[f64], s: &[f64], z: &[f64]) {
        let [step, noise, i] = key;
        let inv = 1.0 / step;
        self.frac.clear();
        self.frac
            .extend(v.iter().map(|&v| v * inv - round_even(v * inv)));
        self.fixed.clear();
        let fixed = self.frac.iter().zip(s).map(|(f, s)| f + i * s * inv);
        self.fixed.extend(fixed);
        self.curve.clear();
        self.curve.extend(h.iter().map(|h| h * inv));
        self.jitter.clear();
        self.jitter.extend(z.iter().map(|z| noise * inv * z));
        // Is any value beyond 2⁴⁹ (a loop of compares, which vectorises)?
        let big = |x: &[f64]| {
            x.iter()
                .fold(false, |b, x| b | (x.abs() > ROUND_SMALL_MAX / 4.0))
        };
        self.big = big(&self.fixed) || big(&self.curve) || big(&self.jitter);
        self.key = key;
    }
}

impl MachineDraws {
    /// The homed rows of each part of an unquantised reading's error
    /// e = a·h + i·s + σ̄·z (see [`Axis::linear_amplitudes`]): `parts[0]` the
    /// curve shape h, `parts[1]` the interpolation shape s, `parts[2]` the
    /// standard normal z, each as rows of l (row 3(j−1)+k: x_j − x_0 of axis
    /// k). A sensor set's errors are then Σ amplitude·part, axis by axis, and
    /// so is any linear estimate of them.
    pub fn linear_parts(&self, parts: [&mut [f64]; 3]) {
        debug_assert!(self
            .drawn_for
            .as_ref()
            .is_some_and(|(st, _)| st.axes.iter().all(|a| a.resolution <= 0.0)));
        let n = self.poses;
        for (part, c) in parts.into_iter().zip(0..) {
            for k in 0..3 {
                let x = match c {
                    0 => &self.h[k],
                    1 => &self.s[k],
                    _ => &self.z[k],
                };
                if x.len() < n {
                    // No jitter on this axis.
                    (1..n).for_each(|j| part[3 * (j - 1) + k] = 0.0);
                    continue;
                }
                for j in 1..n {
                    part[3 * (j - 1) + k] = x[j] - x[0];
                }
            }
        }
    }
}

/// The curve shapes of one axis at the joint values `v`: the harmonics by
/// powers of e^{i·2π·v/T} (one sine and cosine per pose), the interpolation
/// error by one more. Every loop runs over the poses, so it vectorises; `w`
/// holds three work rows of `v.len()` (s is the fourth until the end).
#[allow(clippy::type_complexity)]
fn shapes(
    anchor: Option<(&[f64], &[f64], &[f64])>,
    ax: &Axis,
    ph: &Phases,
    v: &[f64],
    h: &mut [f64],
    s: &mut [f64],
    w: &mut [f64],
) {
    let n = v.len();
    let (c, w) = w.split_at_mut(n);
    let (s1, c1) = w.split_at_mut(n);
    let c1 = &mut c1[..n];
    // s, c: sin and cos of k·2π·v/T for k = 1, 2, …; h accumulates. The
    // first from the anchor at the nominal joint when v is near it.
    match anchor {
        Some((nominal, s0, c0)) => {
            // Every pose by the series (a loop without branches), then the
            // rare pose too far from its anchor by the full sine.
            let scale = std::f64::consts::TAU / ax.period;
            let offset = |j: usize| (v[j] - nominal[j]) * scale;
            let mut far = false;
            for j in 0..n {
                let d = offset(j);
                (s1[j], c1[j]) = sin_cos_near(s0[j], c0[j], d);
                far |= d.abs() > MAX_OFFSET_RAD;
            }
            if far {
                for j in (0..n).filter(|&j| offset(j).abs() > MAX_OFFSET_RAD) {
                    (s1[j], c1[j]) = sin_cos_turns(v[j] / ax.period);
                }
            }
        }
        None => {
            for ((a, b), &vj) in s1.iter_mut().zip(c1.iter_mut()).zip(v) {
                (*a, *b) = sin_cos_turns(vj / ax.period);
            }
        }
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
            // Every other trial anchored at nominal joints near the true
            // ones (the scale's within 0.2 µm), the last pose far off
            // (1 rad and 150 mm: there the series would be wrong by far more
            // than the tolerance, so it must be the full sine).
            if trial % 2 == 0 {
                let mut nominal: Vec<Vector3<f64>> = actual
                    .iter()
                    .map(|a| a + Vector3::new(2e-3, -3e-3, 2e-4))
                    .collect();
                nominal[11] += Vector3::new(1.0, 0.0, 150.0);
                d.anchor_at(&nominal);
            } else {
                d.anchor_at(&[]);
            }
            d.draw(
                &st,
                samples,
                &mut rand::rngs::Xoshiro256PlusPlus::seed_from_u64(trial),
                &actual,
            );
            let mut got = vec![0.0; 33];
            d.homed_errors(&st, samples, [true; 3], &mut got);
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

    /// One machine's draws read by sets that differ in resolution, jitter,
    /// interpolation or accuracy, one after another and back: each set's
    /// errors are the reference's (the per-axis units are formed again when
    /// what they depend on changes, and only then).
    #[test]
    fn sets_alike_in_draws_but_not_in_units_read_as_the_reference() {
        let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(5);
        let actual = joints(10, &mut rng);
        let a = catalogue_like();
        let mut sets = vec![a];
        for change in 0..4 {
            let mut b = a;
            for ax in &mut b.axes {
                match change {
                    0 => ax.resolution *= 2.5,
                    1 => ax.noise *= 3.0,
                    2 => ax.interpolation *= 0.5,
                    _ => ax.accuracy *= 4.0,
                }
            }
            assert!(draws_alike(&a, &b));
            sets.extend([b, a]);
        }
        let mut d = MachineDraws::default();
        let stream = || rand::rngs::Xoshiro256PlusPlus::seed_from_u64(31);
        for st in &sets {
            d.prepare(0, st, 3, &actual, stream);
            let mut got = vec![0.0; 27];
            d.homed_errors(st, 3, [true; 3], &mut got);
            let want = reference(st, 3, 31, &actual);
            for (r, (g, w)) in got.iter().zip(&want).enumerate() {
                let tol = if r % 3 == 2 { 1e-12 } else { 1e-15 };
                assert!((g - w).abs() < tol, "row {r}: {g:e} vs {w:e}");
            }
        }
        // Only the axes asked for are written.
        let mut rows = vec![7.0; 27];
        d.homed_errors(&a, 3, [false, true, false], &mut rows);
        assert!(rows.iter().skip(1).step_by(3).all(|&x| x != 7.0));
        assert!(rows
            .iter()
            .enumerate()
            .all(|(r, &x)| (r % 3 == 1) != (x == 7.0)));
    }

    /// Every way [`quantised_errors`] takes (fused for 1–4 samples, passes
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
            quantised_errors(&mut got, &mut vec![0.0; n], &u, a, step, samples);
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

    /// Anchored draws for sets whose curve periods alternate (a catalogue's
    /// scales of different lengths): each period's anchors are computed once
    /// and found again, and every reading is the reference's.
    #[test]
    fn anchors_of_alternating_periods_read_as_the_reference() {
        let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(8);
        let actual = joints(7, &mut rng);
        let nominal: Vec<Vector3<f64>> = actual
            .iter()
            .map(|a| a + Vector3::new(1e-3, 2e-3, 1e-4))
            .collect();
        let mut d = MachineDraws::default();
        d.anchor_at(&nominal);
        let a = catalogue_like();
        let mut b = a;
        b.axes[2].period = 300.0;
        for (round, st) in [a, b, a, b].iter().enumerate() {
            let seed = 40 + round as u64;
            d.draw(
                st,
                2,
                &mut rand::rngs::Xoshiro256PlusPlus::seed_from_u64(seed),
                &actual,
            );
            let mut got = vec![0.0; 18];
            d.homed_errors(st, 2, [true; 3], &mut got);
            let want = reference(st, 2, seed, &actual);
            for (r, (g, w)) in got.iter().zip(&want).enumerate() {
                let tol = if r % 3 == 2 { 1e-12 } else { 1e-15 };
                assert!((g - w).abs() < tol, "round {round} row {r}: {g:e} vs {w:e}");
            }
        }
        assert_eq!(d.anchors[2].len(), 2);
        assert_eq!(d.anchors[0].len(), 1);
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
        for (k, r) in [(0, 1e-9), (1, 1e-9), (2, 1e-9)] {
            let big = 1e6;
            let (mut h2, mut s2, mut z2) = (h, s, z);
            // Two large values in the row (a flag, not a parity).
            match k {
                0 => (s2[1], s2[2]) = (big, -big),
                1 => (h2[2], h2[0]) = (big, big),
                _ => (z2[3], z2[1]) = (big, -big),
            }
            u.fill([r, 1.0, 1.0], &v, &h2, &s2, &z2);
            assert!(u.big, "row {k}");
        }
    }

    #[test]
    fn unquantised_errors_are_the_sum_of_their_parts() {
        let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(21);
        let mut st = catalogue_like();
        st.axes.iter_mut().for_each(|a| a.resolution = 0.0);
        st.axes[1].noise = 0.0;
        let actual = joints(9, &mut rng);
        let mut d = MachineDraws::default();
        d.draw(&st, 3, &mut rng, &actual);
        let m = 24;
        let (mut h, mut s, mut z) = (vec![1.0; m], vec![1.0; m], vec![1.0; m]);
        d.linear_parts([&mut h, &mut s, &mut z]);
        for grade in [0.5, 2.0, 7.0] {
            let g = st.at_grades(grade / ARCSEC_PER_RAD, grade * 1e-3);
            let mut e = vec![0.0; m];
            d.homed_errors(&g, 3, [true; 3], &mut e);
            for r in 0..m {
                let [a, i, n] = g.axes[r % 3].linear_amplitudes(3);
                let want = a * h[r] + i * s[r] + n * z[r];
                assert!((e[r] - want).abs() < 1e-18 + 1e-14 * want.abs(), "{r}");
            }
        }
        // The θ4 encoder has no jitter: its z rows are zero.
        assert!(z.iter().skip(1).step_by(3).all(|&x| x == 0.0));
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
        d.prepare(0, &a, 3, &actual, stream);
        // Kept for b, of a's class: b's errors are the reference's from the
        // same stream.
        let mut calls = 0;
        d.prepare(0, &b, 3, &actual, || {
            calls += 1;
            stream()
        });
        assert_eq!(calls, 0);
        let mut got = vec![0.0; 15];
        d.homed_errors(&b, 3, [true; 3], &mut got);
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
        d.prepare(1, &b, 3, &actual, || {
            calls += 1;
            stream()
        });
        d.prepare(2, &b, 2, &actual, || {
            calls += 1;
            stream()
        });
        assert_eq!(calls, 2);
        let mut c = a;
        c.axes[2].noise = 0.0;
        assert!(!draws_alike(&a, &c));
    }
}
