//! Sensors as their datasheets describe them (docs/method.md §11): a grade ±a is the
//! bound of a repeatable error curve over the sensor's period (harmonics per
//! revolution or per measuring length, with phases drawn per machine), plus
//! an interpolation error within each signal period, jitter on every sample
//! and quantisation to the resolution. A reading is the mean of `samples`
//! samples; the reference reading is a reading like any other.

use super::normal::Normals;
use super::trig::quantise;
use crate::model::N_READINGS;
use nalgebra::Vector3;
use rand::{Rng, RngExt};

/// Most harmonics a curve may have (a listed shape, or `curve_order` of
/// an unknown one).
pub const MAX_HARMONICS: usize = 32;

/// Most harmonics a listed shape (`harmonics = [..]`) may have.
pub const MAX_LISTED_HARMONICS: usize = 8;

/// Arc-seconds of once-per-revolution error per µm of eccentricity on a
/// ring of 1 mm graduation diameter (HEIDENHAIN's ±412·e/D).
pub const ECCENTRICITY_ARCSEC_PER_UM_MM: f64 = 412.0;

/// What is known of a curve's shape.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Shape {
    /// The datasheet's harmonic fractions (`harmonics = [..]`).
    #[default]
    Listed,
    /// Some periodic function bounded by ±a holding the first
    /// `n_harmonics` harmonics in unknown proportion (`harmonics =
    /// "unknown"`): each machine draws its fractions from Dirichlet(1, …, 1).
    Unknown,
}

/// One sensor's error model, in its internal unit (rad for an encoder, mm
/// for the scale).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Axis {
    /// Grade ±a: bound of the systematic curve.
    pub accuracy: f64,
    /// Listed or unknown shape.
    pub shape: Shape,
    /// Harmonic amplitudes as fractions of `accuracy` (Σ ≤ 1); unused for
    /// an unknown shape.
    pub harmonics: [f64; MAX_HARMONICS],
    /// The listed harmonics, or the curve order K of an unknown shape.
    pub n_harmonics: usize,
    /// Bound of the mounting eccentricity's once-per-revolution error,
    /// 412·e/D arc-seconds in rad (encoders; 0: none). Each machine draws
    /// it as bound·u·sin(v + φe), u uniform in [0, 1].
    pub eccentricity: f64,
    /// The ring's graduation diameter, mm (encoders; 0: not given).
    pub ring_diameter: f64,
    /// 1, or 2 diametrically opposite readheads averaged (encoders): the
    /// odd harmonics and the eccentricity cancel, each head's
    /// interpolation error is independent; `noise` and `resolution` are
    /// then already the pair's (σ/√2, r/√2).
    pub readheads: u8,
    /// Period of the curve: 2π rad for an encoder, the measuring length for the scale.
    pub period: f64,
    /// Amplitude of the error within one signal period, and that period.
    pub interpolation: f64,
    pub signal_period: f64,
    /// Jitter σ of each sample.
    pub noise: f64,
    /// Quantisation step of a sample (0: none).
    pub resolution: f64,
}

/// 2π·(t − the nearest integer to t), rad: the angle of t turns within one turn.
#[inline]
fn fractional_turn(t: f64) -> f64 {
    std::f64::consts::TAU * (t - t.round())
}

/// The phases of one machine's sensor: one per harmonic and the
/// interpolation error's; for an unknown shape the harmonics' fractions,
/// with eccentricity its size u and phase, with two readheads the second
/// head's interpolation phase.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Phases {
    pub harmonic: [f64; MAX_HARMONICS],
    pub interpolation: f64,
    /// Dirichlet(1, …, 1) fractions (unknown shape only).
    pub fractions: [f64; MAX_HARMONICS],
    /// Eccentricity: u uniform in [0, 1] and its phase.
    pub eccentric: f64,
    pub eccentric_phase: f64,
    /// The second readhead's interpolation phase.
    pub interpolation2: f64,
}

/// One term of a curve's covariance: harmonic `order` of variance
/// `variance` (the mean of A²/2 over machines, A its amplitude) at angular
/// rate order·2π/T, and the largest amplitude the datasheet allows it
/// (`bound`: a·hk for a listed shape, a for an unknown one, plus the
/// eccentricity's bound on the first harmonic).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CurveTerm {
    pub order: usize,
    pub variance: f64,
    pub rate: f64,
    pub bound: f64,
}

impl Axis {
    /// Draw this machine's phases, uniform in [0, 2π): for an unknown
    /// shape first the K fractions (Dirichlet(1, …, 1), as normalised
    /// exponentials), then one phase per harmonic, the interpolation's,
    /// then (with eccentricity) its u and phase, then (with two heads) the
    /// second head's interpolation phase. A listed shape with one head and
    /// no eccentricity draws exactly as it always has.
    pub fn phases<R: Rng + ?Sized>(&self, rng: &mut R) -> Phases {
        let mut out = Phases::default();
        if self.shape == Shape::Unknown {
            let f = &mut out.fractions[..self.n_harmonics];
            for x in f.iter_mut() {
                *x = rng.sample(rand_distr::Exp1);
            }
            let sum: f64 = f.iter().sum();
            if sum > 0.0 {
                f.iter_mut().for_each(|x| *x /= sum);
            } else {
                f.iter_mut()
                    .for_each(|x| *x = 1.0 / self.n_harmonics as f64);
            }
        }
        for h in out.harmonic.iter_mut().take(self.n_harmonics) {
            *h = rng.random_range(0.0..std::f64::consts::TAU);
        }
        out.interpolation = rng.random_range(0.0..std::f64::consts::TAU);
        if self.eccentricity > 0.0 {
            out.eccentric = rng.random_range(0.0..1.0);
            out.eccentric_phase = rng.random_range(0.0..std::f64::consts::TAU);
        }
        if self.readheads == 2 {
            out.interpolation2 = rng.random_range(0.0..std::f64::consts::TAU);
        }
        out
    }

    /// Fraction k (0-based) of the grade this machine's curve holds: the
    /// datasheet's, or the machine's Dirichlet draw.
    #[inline]
    pub fn fraction(&self, ph: &Phases, k: usize) -> f64 {
        match self.shape {
            Shape::Listed => self.harmonics[k],
            Shape::Unknown => ph.fractions[k],
        }
    }

    /// The amplitude the curve shape is measured in: the grade plus the
    /// eccentricity's bound (the grade alone without eccentricity).
    #[inline]
    pub fn curve_scale(&self) -> f64 {
        if self.eccentricity > 0.0 {
            self.accuracy + self.eccentricity
        } else {
            self.accuracy
        }
    }

    /// The ring's own curve (graduation and eccentricity, one head) at
    /// x = 2π·v/T, in units of [`Axis::curve_scale`].
    fn ring(&self, ph: &Phases, x: f64) -> f64 {
        let scale = self.curve_scale();
        if scale <= 0.0 {
            return 0.0;
        }
        let mut e = 0.0;
        for k in 0..self.n_harmonics {
            e += self.fraction(ph, k) * ((k + 1) as f64 * x + ph.harmonic[k]).sin();
        }
        let mut e = e * (self.accuracy / scale);
        if self.eccentricity > 0.0 {
            e += self.eccentricity / scale * ph.eccentric * (x + ph.eccentric_phase).sin();
        }
        e
    }

    /// The systematic error at joint value `v`:
    /// e(v) = a·Σk hk·sin(k·2π·v/T + φk) + E·u·sin(v + φe) + i·sin(2π·v/P + φP),
    /// the mean of two heads 180° apart when there are two.
    pub fn systematic(&self, ph: &Phases, v: f64) -> f64 {
        let (h, i) = self.shape_at(ph, v);
        self.amplitudes(h, i)
    }

    /// The curve's shape at `v` without its amplitudes, in units of
    /// [`Axis::curve_scale`] and of the interpolation amplitude: the ring's
    /// curve and sin(2π·v/P + φP) (0 without interpolation); with two heads
    /// each the mean of the heads' (the second reads the ring half a turn
    /// on, with its own interpolation phase). Sensors of the same shape and
    /// draws share it, whatever their grade.
    #[inline]
    pub fn shape_at(&self, ph: &Phases, v: f64) -> (f64, f64) {
        // 2π·v/T with the whole turns of v/T removed first (the sines are
        // periodic): a scale read over 10⁸ signal periods keeps its phase.
        let x = fractional_turn(v / self.period);
        let e = match self.readheads {
            2 => 0.5 * (self.ring(ph, x) + self.ring(ph, x + std::f64::consts::PI)),
            _ => self.ring(ph, x),
        };
        let i = if self.interpolation > 0.0 && self.signal_period > 0.0 {
            let y = fractional_turn(v / self.signal_period);
            match self.readheads {
                2 => 0.5 * ((y + ph.interpolation).sin() + (y + ph.interpolation2).sin()),
                _ => (y + ph.interpolation).sin(),
            }
        } else {
            0.0
        };
        (e, i)
    }

    /// The harmonics of this machine's curve as the kernel sums them:
    /// (amplitude in units of [`Axis::curve_scale`], sin φ, cos φ) of each
    /// order, and how many orders; the eccentricity folded into the first,
    /// the odd orders dropped for two heads (they cancel).
    pub fn coefficients(
        &self,
        ph: &Phases,
        sin_cos: impl Fn(f64) -> (f64, f64),
    ) -> ([(f64, f64, f64); MAX_HARMONICS], usize) {
        let mut coef = [(0.0, 0.0, 0.0); MAX_HARMONICS];
        let scale = self.curve_scale();
        let n = if self.eccentricity > 0.0 {
            self.n_harmonics.max(1)
        } else {
            self.n_harmonics
        };
        if scale <= 0.0 {
            return (coef, n);
        }
        let plain = self.eccentricity <= 0.0 && self.readheads != 2;
        for (k, c) in coef.iter_mut().enumerate().take(self.n_harmonics) {
            let (sp, cp) = sin_cos(ph.harmonic[k]);
            if plain && self.shape == Shape::Listed {
                // Exactly the datasheet's fraction (a·h with h unscaled).
                *c = (self.harmonics[k], sp, cp);
            } else {
                let f = self.fraction(ph, k) * (self.accuracy / scale);
                *c = (1.0, f * sp, f * cp);
            }
        }
        if self.eccentricity > 0.0 {
            let f = self.eccentricity / scale * ph.eccentric;
            let (sp, cp) = sin_cos(ph.eccentric_phase);
            let (a, s0, c0) = coef[0];
            // a·sin(x + φ) = sin x·(a cos φ) + cos x·(a sin φ): add phasors.
            coef[0] = (1.0, a * s0 + f * sp, a * c0 + f * cp);
        }
        if self.readheads == 2 {
            for c in coef.iter_mut().step_by(2) {
                *c = (0.0, 0.0, 0.0);
            }
        }
        (coef, n)
    }

    /// The interpolation shape's phasor (sin, cos of its phase, the mean of
    /// two heads' when there are two): s = sin y·cos + cos y·sin.
    pub fn interpolation_phasor(
        &self,
        ph: &Phases,
        sin_cos: impl Fn(f64) -> (f64, f64),
    ) -> (f64, f64) {
        let (sp, cp) = sin_cos(ph.interpolation);
        match self.readheads {
            2 => {
                let (s2, c2) = sin_cos(ph.interpolation2);
                (0.5 * (sp + s2), 0.5 * (cp + c2))
            }
            _ => (sp, cp),
        }
    }

    /// The terms of the curve's covariance over machines (see
    /// [`CurveTerm`]): a listed harmonic's (a·hk)²/2, an unknown shape's
    /// a²/(K(K+1)) for each of its K orders (E[hk²] = 2/(K(K+1))), the
    /// eccentricity's (E)²/6 added to the first; the odd orders and the
    /// eccentricity dropped for two heads. Terms of zero variance are left
    /// out.
    pub fn curve_terms(&self) -> ([CurveTerm; MAX_HARMONICS], usize) {
        let mut out = [CurveTerm::default(); MAX_HARMONICS];
        let mut n = 0;
        let k_count = self.n_harmonics.max(usize::from(self.eccentricity > 0.0));
        for k in 0..k_count {
            let order = k + 1;
            if self.readheads == 2 && order % 2 == 1 {
                continue;
            }
            let (mut variance, mut bound) = if k < self.n_harmonics {
                match self.shape {
                    Shape::Listed => {
                        let amp = self.accuracy * self.harmonics[k];
                        (amp * amp / 2.0, amp)
                    }
                    Shape::Unknown => {
                        let kk = self.n_harmonics as f64;
                        (
                            self.accuracy * self.accuracy / (kk * (kk + 1.0)),
                            self.accuracy,
                        )
                    }
                }
            } else {
                (0.0, 0.0)
            };
            if order == 1 && self.eccentricity > 0.0 {
                variance += self.eccentricity * self.eccentricity / 6.0;
                bound += self.eccentricity;
            }
            if variance > 0.0 {
                out[n] = CurveTerm {
                    order,
                    variance,
                    rate: order as f64 * std::f64::consts::TAU / self.period,
                    bound,
                };
                n += 1;
            }
        }
        (out, n)
    }

    /// The curve's shape in words for tables: the listed fractions, or
    /// "unknown, orders 1–K"; then "2 heads" and the eccentricity's bound in
    /// `unit` (`per_unit` of them per internal unit) when there are.
    pub fn shape_text(&self, per_unit: f64) -> String {
        let mut out = match self.shape {
            Shape::Listed => format!("{:?}", &self.harmonics[..self.n_harmonics]),
            Shape::Unknown => format!("unknown, orders 1–{}", self.n_harmonics),
        };
        if self.readheads == 2 {
            out.push_str("; 2 heads");
        }
        if self.eccentricity > 0.0 {
            out.push_str(&format!(
                "; eccentricity ≤ {:.3}",
                self.eccentricity * per_unit
            ));
        }
        out
    }

    /// The interpolation error's variance across poses: i²/2, halved for
    /// two heads (their errors are independent).
    pub fn interpolation_variance(&self) -> f64 {
        if self.interpolation > 0.0 && self.signal_period > 0.0 {
            let v = self.interpolation * self.interpolation / 2.0;
            match self.readheads {
                2 => v / 2.0,
                _ => v,
            }
        } else {
            0.0
        }
    }

    /// The systematic error from the curve's shape: A·h + i·s, A the
    /// [`Axis::curve_scale`].
    #[inline]
    fn amplitudes(&self, h: f64, s: f64) -> f64 {
        let mut out = self.curve_scale() * h;
        if self.interpolation > 0.0 && self.signal_period > 0.0 {
            out += self.interpolation * s;
        }
        out
    }

    /// Do `self` and `other` have the same shape (so the same curve for the
    /// same phases)?
    pub fn same_shape(&self, other: &Axis) -> bool {
        let ecc = |a: &Axis| match a.eccentricity > 0.0 {
            true => a.eccentricity / a.curve_scale(),
            false => 0.0,
        };
        self.harmonics == other.harmonics
            && self.shape == other.shape
            && self.n_harmonics == other.n_harmonics
            && self.readheads == other.readheads
            && ecc(self) == ecc(other)
            && self.period == other.period
            && self.signal_period == other.signal_period
            && (self.interpolation > 0.0) == (other.interpolation > 0.0)
    }

    /// One reading at true value `v`: the mean of `samples` samples, each
    /// v + e(v) + jitter, quantised to the resolution (the nearest multiple,
    /// ties to even). Without quantisation the mean of the samples' jitter
    /// is drawn as one normal of σ/√samples, which is exactly its law.
    /// `z(s)` is the reading's s-th standard normal draw (see
    /// [`JitterTable`]).
    pub fn reading(&self, ph: &Phases, v: f64, samples: u32, z: impl Fn(usize) -> f64) -> f64 {
        let (h, i) = self.shape_at(ph, v);
        let base = v + self.amplitudes(h, i);
        if self.resolution <= 0.0 {
            return match self.noise > 0.0 {
                true => base + self.mean_noise(samples) * z(0),
                false => base,
            };
        }
        let mut sum = 0.0;
        for k in 0..samples as usize {
            let mut s = base;
            if self.noise > 0.0 {
                s += self.noise * z(k);
            }
            sum += quantise(s, self.resolution, 1.0 / self.resolution);
        }
        sum / samples as f64
    }

    /// The standard normal draws one reading takes: one per sample when
    /// samples are quantised, one for their mean otherwise, none without
    /// jitter.
    pub fn draws_per_reading(&self, samples: u32) -> usize {
        match (self.noise > 0.0, self.resolution > 0.0) {
            (false, _) => 0,
            (true, true) => samples as usize,
            (true, false) => 1,
        }
    }

    /// σ of the mean jitter of `samples` unquantised samples: noise/√samples.
    #[inline]
    pub fn mean_noise(&self, samples: u32) -> f64 {
        self.noise / (samples.max(1) as f64).sqrt()
    }

    /// The amplitudes of a reading's error e = a·h + i·s + σ̄·z (z standard
    /// normal) when it is not quantised: (a, i, σ̄) with i zero without an
    /// interpolation error (its shape is then zero too).
    pub fn linear_amplitudes(&self, samples: u32) -> [f64; 3] {
        let i = if self.interpolation > 0.0 && self.signal_period > 0.0 {
            self.interpolation
        } else {
            0.0
        };
        [self.curve_scale(), i, self.mean_noise(samples)]
    }

    /// The σ this sensor is weighted with (WLS): the RMS of its error over
    /// random phases — a·√(Σhk²/2) from the curve, i/√2 from interpolation —
    /// combined with the jitter and quantisation of a mean of `samples`.
    /// The curve does not average down over samples (it is repeatable), so
    /// it enters whole; this is the spread a reading has about the truth
    /// across machines, which is what the weights must equalise.
    pub fn sigma(&self, samples: u32) -> f64 {
        let (terms, n) = self.curve_terms();
        let curve: f64 =
            terms[..n].iter().map(|t| t.variance).sum::<f64>() + self.interpolation_variance();
        let random = (self.noise * self.noise + self.resolution * self.resolution / 12.0)
            / samples.max(1) as f64;
        (curve + random).sqrt()
    }
}

/// The three passive-limb sensors (ψ4 encoder, θ4 encoder, q4 scale).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Structured {
    pub axes: [Axis; N_READINGS],
    /// Which axes come from a datasheet section; the others are the paper's
    /// reading of their grade (jitter of σ = grade, no curve).
    pub from_section: [bool; N_READINGS],
}

/// One machine's jitter draws, standard normals in the order they are taken
/// from its generator: axis by axis (ψ4, θ4, q4), then each of the draws a
/// reading takes ([`Axis::draws_per_reading`]: a sample's, or the mean's),
/// then pose by pose. Draw s of axis k at pose j is `axis(k)[s·poses + j]`:
/// each axis is one row per sample, as the sweep's kernel reads them (drawn
/// pose by pose, they had to be laid out again: 6 % of a quantised trial's
/// instructions).
#[derive(Debug, Clone, Default)]
pub struct JitterTable {
    z: [Vec<f64>; 3],
    poses: usize,
}

impl JitterTable {
    /// The draws of `st`'s axes for `samples` samples at `poses` poses:
    /// `StandardNormal`'s from `rng`, in turn.
    pub fn fill<R: Rng + Clone>(
        &mut self,
        st: &Structured,
        samples: u32,
        poses: usize,
        rng: &mut R,
    ) {
        for (z, axis) in self.z.iter_mut().zip(&st.axes) {
            z.resize(axis.draws_per_reading(samples) * poses, 0.0);
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

impl Structured {
    /// Each axis's phases for one machine, drawn in the order ψ4, θ4, q4.
    pub fn phases<R: Rng + ?Sized>(&self, rng: &mut R) -> [Phases; 3] {
        [
            self.axes[0].phases(rng),
            self.axes[1].phases(rng),
            self.axes[2].phases(rng),
        ]
    }

    /// One machine's draws from its generator for readings of `samples`
    /// samples at `poses` poses: the phases (see [`Structured::phases`]),
    /// then the jitter (see [`JitterTable`]).
    pub fn draw_machine<R: Rng + Clone>(
        &self,
        rng: &mut R,
        samples: u32,
        poses: usize,
        jitter: &mut JitterTable,
    ) -> [Phases; 3] {
        let ph = self.phases(rng);
        jitter.fill(self, samples, poses, rng);
        ph
    }

    /// [`Structured::draw_machine`] into a new table.
    pub fn machine<R: Rng + Clone>(
        &self,
        rng: &mut R,
        samples: u32,
        poses: usize,
    ) -> ([Phases; 3], JitterTable) {
        let mut table = JitterTable::default();
        let ph = self.draw_machine(rng, samples, poses, &mut table);
        (ph, table)
    }

    /// The reading at pose `pose` of the true joints `v` there (ψ4 rad, θ4
    /// rad, q4 mm), with the machine's phases and jitter.
    pub fn reading(
        &self,
        ph: &[Phases; 3],
        v: &Vector3<f64>,
        samples: u32,
        jitter: &JitterTable,
        pose: usize,
    ) -> Vector3<f64> {
        let read = |k: usize, x: f64| {
            self.axes[k].reading(&ph[k], x, samples, |s| jitter.draw(k, s, pose))
        };
        Vector3::new(read(0, v.x), read(1, v.y), read(2, v.z))
    }

    /// The weighting σ of (ψ4, θ4, q4); see [`Axis::sigma`].
    pub fn sigma(&self, samples: u32) -> Vector3<f64> {
        Vector3::new(
            self.axes[0].sigma(samples),
            self.axes[1].sigma(samples),
            self.axes[2].sigma(samples),
        )
    }

    /// The same sensors with every systematic curve (harmonics and
    /// interpolation) `factor` times the datasheet's; jitter and
    /// quantisation as they are.
    pub fn with_curves_scaled(&self, factor: f64) -> Self {
        let mut s = *self;
        for a in s.axes.iter_mut() {
            a.accuracy *= factor;
            a.interpolation *= factor;
            a.eccentricity *= factor;
        }
        s
    }

    /// The same sensors with one more harmonic (one order above the last)
    /// of `fraction` × the accuracy on each datasheet axis that has room.
    pub fn with_extra_harmonic(&self, fraction: f64) -> Self {
        let mut s = *self;
        for (a, &from) in s.axes.iter_mut().zip(&self.from_section) {
            if from && a.n_harmonics < MAX_HARMONICS {
                a.harmonics[a.n_harmonics] = fraction;
                a.n_harmonics += 1;
            }
        }
        s
    }

    /// The same sensors with their white terms (interpolation error and
    /// jitter) `factor` times the datasheet's.
    pub fn with_white_scaled(&self, factor: f64) -> Self {
        let mut s = *self;
        for (a, &from) in s.axes.iter_mut().zip(&self.from_section) {
            if from {
                a.interpolation *= factor;
                a.noise *= factor;
            }
        }
        s
    }

    /// The same sensors with each datasheet curve whole at the grade's
    /// bound in one harmonic just outside the orders its model holds: order
    /// K + 1 (K + 2 when two heads would cancel an odd K + 1), phase drawn
    /// per machine as ever; eccentricity as it was.
    pub fn with_curve_outside_order(&self) -> Self {
        let mut s = *self;
        for (a, &from) in s.axes.iter_mut().zip(&self.from_section) {
            if !from {
                continue;
            }
            let mut order = a.n_harmonics + 1;
            if a.readheads == 2 && order % 2 == 1 {
                order += 1;
            }
            let order = order.min(MAX_HARMONICS);
            a.shape = Shape::Listed;
            a.harmonics = [0.0; MAX_HARMONICS];
            a.harmonics[order - 1] = 1.0;
            a.n_harmonics = order;
        }
        s
    }

    /// The same sensors with each installed encoder ring (one whose
    /// datasheet states a mounting eccentricity) mounted with up to `um` µm
    /// of eccentricity instead (412·e/D arc-seconds on its diameter D);
    /// encoders with integral bearing are left as they are.
    pub fn with_eccentricity_um(&self, um: f64) -> Self {
        let mut s = *self;
        for (a, &from) in s.axes.iter_mut().zip(&self.from_section).take(2) {
            if from && a.eccentricity > 0.0 && a.ring_diameter > 0.0 {
                a.eccentricity =
                    ECCENTRICITY_ARCSEC_PER_UM_MM * um / a.ring_diameter / super::ARCSEC_PER_RAD;
            }
        }
        s
    }

    /// The same sensors at other grades (the sweep's axis): the encoders'
    /// accuracy set to `encoder_rad`, the scale's to `scale_mm`.
    pub fn at_grades(&self, encoder_rad: f64, scale_mm: f64) -> Self {
        let mut s = *self;
        for (k, grade) in [encoder_rad, encoder_rad, scale_mm].into_iter().enumerate() {
            if s.from_section[k] {
                s.axes[k].accuracy = grade;
            } else {
                s.axes[k].noise = grade;
            }
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    fn axis() -> Axis {
        let mut harmonics = [0.0; MAX_HARMONICS];
        harmonics[0] = 0.8;
        harmonics[1] = 0.2;
        Axis {
            accuracy: 2.0,
            harmonics,
            n_harmonics: 2,
            period: std::f64::consts::TAU,
            interpolation: 0.3,
            signal_period: 0.01,
            noise: 0.0,
            resolution: 0.0,
            readheads: 1,
            ..Axis::default()
        }
    }

    #[test]
    fn the_curve_stays_within_its_bound_and_phases_are_uniform() {
        let a = axis();
        let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(1);
        let mut bins = [0usize; 8];
        let n = 4000;
        for _ in 0..n {
            let ph = a.phases(&mut rng);
            for k in 0..200 {
                let v = -0.6 + 1.2 * k as f64 / 200.0;
                // |e| ≤ a·Σh + i.
                assert!(a.systematic(&ph, v).abs() <= 2.0 * 1.0 + 0.3 + 1e-12);
            }
            bins[(ph.harmonic[0] / std::f64::consts::TAU * 8.0) as usize] += 1;
        }
        // Each eighth of [0, 2π) holds 1/8 of the phases (±5 σ of a binomial).
        let sd = (n as f64 * 0.125 * 0.875).sqrt();
        for b in bins {
            assert!((b as f64 - n as f64 / 8.0).abs() < 5.0 * sd, "{bins:?}");
        }
    }

    #[test]
    fn the_curve_is_what_the_formula_says() {
        let a = axis();
        let ph = Phases {
            harmonic: std::array::from_fn(|k| [0.5, 1.0].get(k).copied().unwrap_or(0.0)),
            interpolation: 0.25,
            ..Phases::default()
        };
        let v = 0.3;
        let want = 2.0 * (0.8 * (v + 0.5f64).sin() + 0.2 * (2.0 * v + 1.0f64).sin())
            + 0.3 * (std::f64::consts::TAU * v / 0.01 + 0.25).sin();
        assert!((a.systematic(&ph, v) - want).abs() < 1e-12);
        // RMS over random phases: a·√(Σh²/2) and i/√2.
        let want_sigma = (4.0 * (0.64 + 0.04) / 2.0 + 0.09 / 2.0f64).sqrt();
        assert!((a.sigma(3) - want_sigma).abs() < 1e-12);
    }

    /// A machine's jitter is `StandardNormal`'s draws from its generator
    /// after the phases, axis by axis, then sample by sample, then pose by
    /// pose: a quantised axis takes a draw per sample, an unquantised one
    /// one for the mean, one without jitter none.
    #[test]
    fn the_jitter_table_is_standard_normals_axis_then_sample_then_pose() {
        let mut st = Structured {
            axes: [axis(); 3],
            from_section: [true; 3],
        };
        st.axes[0].noise = 0.1;
        st.axes[0].resolution = 0.01;
        st.axes[1].noise = 0.1;
        let (samples, poses) = (3, 5);
        let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(8);
        let mut straight = rng.clone();
        let (ph, table) = st.machine(&mut rng, samples, poses);
        assert_eq!(ph, st.phases(&mut straight));
        for (k, draws) in [(0, 3), (1, 1)] {
            assert_eq!(table.axis(k).len(), draws * poses);
            for s in 0..draws {
                for j in 0..poses {
                    let want: f64 = straight.sample(rand_distr::StandardNormal);
                    assert_eq!(table.draw(k, s, j).to_bits(), want.to_bits());
                }
            }
        }
        assert!(table.axis(2).is_empty());
        // The generator is left where the last draw leaves it.
        assert_eq!(rng.next_u64(), straight.next_u64());
    }

    #[test]
    fn samples_average_the_jitter_not_the_curve_and_quantise() {
        let mut a = axis();
        a.noise = 0.5;
        let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(2);
        let ph = a.phases(&mut rng);
        let v = 0.2;
        let e = a.systematic(&ph, v);
        let n = 20000;
        let (mut sum, mut sq) = (0.0, 0.0);
        for _ in 0..n {
            let z: [f64; 4] = std::array::from_fn(|_| rng.sample(rand_distr::StandardNormal));
            let r = a.reading(&ph, v, 4, |s| z[s]) - v - e;
            sum += r;
            sq += r * r;
        }
        let (mean, var) = (sum / n as f64, sq / n as f64 - (sum / n as f64).powi(2));
        // The curve is repeatable: the readings centre on v + e(v); the
        // jitter of a mean of 4 samples has σ = 0.5/2.
        assert!(mean.abs() < 5.0 * 0.25 / (n as f64).sqrt(), "{mean}");
        assert!((var.sqrt() / 0.25 - 1.0).abs() < 0.03, "{}", var.sqrt());
        // Quantised samples: one sample is a multiple of the resolution.
        a.noise = 0.0;
        a.resolution = 0.125;
        let r = a.reading(&ph, v, 1, |_| unreachable!("no jitter"));
        assert!(((r / 0.125) - (r / 0.125).round()).abs() < 1e-9);
        assert!((r - (v + e)).abs() <= 0.0625 + 1e-12);
    }
}

/// Datasheet sensors for the tests of the modules above `sensors` that
/// must not read a config (`identify`): axes in internal units (rad, mm).
#[cfg(test)]
pub(crate) mod fixtures {
    use super::{Axis, Structured, MAX_HARMONICS};
    use crate::sensors::{GradeReading, SensorModel, ARCSEC_PER_RAD};

    /// The q4 span of the paper's workspace (the scale's default measuring
    /// length, mm): from the top face's centre to the far bottom edge.
    pub fn paper_span_mm() -> f64 {
        (850.0f64.powi(2) + 400.0f64.powi(2)).sqrt() - 650.0
    }

    /// An encoder axis of grade ±`arcsec` with these harmonic fractions and
    /// jitter σ `noise_arcsec`.
    pub fn encoder(arcsec: f64, harmonics: &[f64], noise_arcsec: f64) -> Axis {
        axis(
            arcsec / ARCSEC_PER_RAD,
            harmonics,
            std::f64::consts::TAU,
            noise_arcsec / ARCSEC_PER_RAD,
        )
    }

    /// A scale axis of grade ±`um` over `length_mm`, jitter σ `noise_um`.
    pub fn scale(um: f64, harmonics: &[f64], length_mm: f64, noise_um: f64) -> Axis {
        axis(um * 1e-3, harmonics, length_mm, noise_um * 1e-3)
    }

    fn axis(accuracy: f64, harmonics: &[f64], period: f64, noise: f64) -> Axis {
        let mut h = [0.0; MAX_HARMONICS];
        h[..harmonics.len()].copy_from_slice(harmonics);
        Axis {
            accuracy,
            harmonics: h,
            n_harmonics: harmonics.len(),
            period,
            interpolation: 0.0,
            signal_period: 0.0,
            noise,
            resolution: 0.0,
            readheads: 1,
            ..Axis::default()
        }
    }

    /// The three sensors (`from_section`: which are datasheet axes) read
    /// as the mean of `samples` samples.
    pub fn sensors(axes: [Axis; 3], from_section: [bool; 3], samples: u32) -> SensorModel {
        SensorModel {
            encoder_arcsec: axes[0].accuracy * ARCSEC_PER_RAD,
            scale_um: axes[2].accuracy * 1e3,
            samples,
            reading: GradeReading::Sigma,
            structured: Some(Structured { axes, from_section }),
        }
    }
}
