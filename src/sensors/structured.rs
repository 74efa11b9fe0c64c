//! Sensors as their datasheets describe them (docs/method.md §11): a grade ±a is the
//! bound of a repeatable error curve over the sensor's period (harmonics per
//! revolution or per measuring length, with phases drawn per machine), plus
//! an interpolation error within each signal period, jitter on every sample
//! and quantisation to the resolution. A reading is the mean of `samples`
//! samples; the reference reading is a reading like any other.

pub use super::jitter::JitterTable;
use super::trig::quantise;
use nalgebra::SVector;
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
    /// The coherence length GLS assumes for the interpolation error when it
    /// weights the readings (internal unit; 0: weighted as white noise):
    /// `[identification] interpolation_coherence_deg` / `_mm`.
    pub weight_coherence: f64,
    /// The interpolation error's own coherence length (internal unit; 0:
    /// stationary, one sinusoid of the signal period per machine): its
    /// amplitude and phase drift over this much travel (docs/method.md §18).
    pub coherence: f64,
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
    /// An interpolation error of finite coherence ([`Axis::coherence`]):
    /// each head's [`DRIFT_TERMS`] components (rate offset λ in rad per
    /// internal unit, phase θ), see [`Axis::drift`].
    pub drift: [[(f64, f64); DRIFT_TERMS]; 2],
}

/// Components of an interpolation error of finite coherence: i/√M·Σ
/// sin((ω + λm)·v + θm), λm ~ N(0, 1/ℓ²), θm uniform, whose covariance over
/// machines is exactly (i²/2)·exp(−Δ²/(2ℓ²))·cos(ω·Δ) for any M (each
/// component's is); four make its amplitude drift as well as its phase.
pub const DRIFT_TERMS: usize = 4;

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
        // A finite coherence draws its components last, so that a
        // stationary interpolation error draws exactly as it always has.
        if self.coherence > 0.0 {
            for head in out
                .drift
                .iter_mut()
                .take(usize::from(self.readheads.max(1)))
            {
                for (rate, phase) in head.iter_mut() {
                    let z: f64 = rng.sample(rand_distr::StandardNormal);
                    *rate = z / self.coherence;
                    *phase = rng.random_range(0.0..std::f64::consts::TAU);
                }
            }
        }
        out
    }

    /// The interpolation shape of finite coherence at joint value `v`,
    /// given the carrier's sin and cos of 2π·v/P (`si`, `ci`): each head's
    /// (1/√M)·Σ sin(2π·v/P + λm·v + θm), the mean of two heads' when there
    /// are two.
    #[inline]
    pub fn drift(&self, ph: &Phases, v: f64, si: f64, ci: f64) -> f64 {
        let heads = usize::from(self.readheads.max(1));
        let norm = 1.0 / (DRIFT_TERMS as f64).sqrt() / heads as f64;
        let mut sum = 0.0;
        for head in ph.drift.iter().take(heads) {
            for &(rate, phase) in head {
                let (sd, cd) = (rate * v + phase).sin_cos();
                sum += si * cd + ci * sd;
            }
        }
        norm * sum
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
        let i = if self.interpolation > 0.0 && self.signal_period > 0.0 && self.coherence > 0.0 {
            let (si, ci) = fractional_turn(v / self.signal_period).sin_cos();
            self.drift(ph, v, si, ci)
        } else if self.interpolation > 0.0 && self.signal_period > 0.0 {
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

    /// One reading at true value `v`: the mean of `samples` samples, each
    /// v + e(v) + jitter, quantised to the resolution (the nearest multiple,
    /// ties to even). Without quantisation the mean of the samples' jitter
    /// is drawn as one normal of σ/√samples, which is exactly its law.
    /// `z(s)` is the reading's s-th standard normal draw (see
    /// [`JitterTable`]).
    pub fn reading(&self, ph: &Phases, v: f64, samples: u32, z: impl Fn(usize) -> f64) -> f64 {
        let (h, i) = self.shape_at(ph, v);
        self.reading_of_shape(v, h, i, samples, z)
    }

    /// [`Axis::reading`] from the curve's shape at `v` already evaluated
    /// (`h`, `i` as [`Axis::shape_at`] gives them, or as
    /// [`super::batch::axis_shapes`] gives them for many values at once).
    #[inline]
    pub fn reading_of_shape(
        &self,
        v: f64,
        h: f64,
        i: f64,
        samples: u32,
        z: impl Fn(usize) -> f64,
    ) -> f64 {
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

    /// The σ of the part of a reading drawn afresh at each reading (jitter
    /// and quantisation of a mean of `samples`): what repeats of a pose
    /// average; the curve and the interpolation error come back with it.
    pub fn fresh_sigma(&self, samples: u32) -> f64 {
        ((self.noise * self.noise + self.resolution * self.resolution / 12.0)
            / samples.max(1) as f64)
            .sqrt()
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

/// A mechanism's datasheet sensors, one axis a reading slot (`R` of them,
/// in the order of its reading facts: the Tricept's ψ4 encoder, θ4 encoder
/// and q4 scale).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Structured<const R: usize> {
    pub axes: [Axis; R],
    /// Which axes come from a datasheet section; the others are the paper's
    /// reading of their grade (jitter of σ = grade, no curve).
    pub from_section: [bool; R],
}

impl<const R: usize> Structured<R> {
    /// Each axis's phases for one machine, drawn axis by axis in slot order.
    pub fn phases<G: Rng + ?Sized>(&self, rng: &mut G) -> [Phases; R] {
        std::array::from_fn(|k| self.axes[k].phases(rng))
    }

    /// One machine's draws from its generator for readings of `samples`
    /// samples at `poses` poses: the phases (see [`Structured::phases`]),
    /// then the jitter (see [`JitterTable`]).
    pub fn draw_machine<G: Rng + Clone>(
        &self,
        rng: &mut G,
        samples: u32,
        poses: usize,
        jitter: &mut JitterTable<R>,
    ) -> [Phases; R] {
        let ph = self.phases(rng);
        let per_reading = self.axes.each_ref().map(|a| a.draws_per_reading(samples));
        jitter.fill(per_reading, poses, rng);
        ph
    }

    /// [`Structured::draw_machine`] into a new table.
    pub fn machine<G: Rng + Clone>(
        &self,
        rng: &mut G,
        samples: u32,
        poses: usize,
    ) -> ([Phases; R], JitterTable<R>) {
        let mut table = JitterTable::default();
        let ph = self.draw_machine(rng, samples, poses, &mut table);
        (ph, table)
    }

    /// The reading at pose `pose` of the true joints `v` there (each slot
    /// in its model unit, rad or mm), with the machine's phases and jitter.
    pub fn reading(
        &self,
        ph: &[Phases; R],
        v: &SVector<f64, R>,
        samples: u32,
        jitter: &JitterTable<R>,
        pose: usize,
    ) -> SVector<f64, R> {
        SVector::from_fn(|k, _| {
            self.axes[k].reading(&ph[k], v[k], samples, |s| jitter.draw(k, s, pose))
        })
    }

    /// The weighting σ of each slot; see [`Axis::sigma`].
    pub fn sigma(&self, samples: u32) -> SVector<f64, R> {
        SVector::from_fn(|k, _| self.axes[k].sigma(samples))
    }
}

/// The curve's terms, its shape in words and its interpolation variance.
#[path = "structured_terms.rs"]
mod terms;

#[cfg(test)]
#[path = "structured_tests.rs"]
mod tests;

/// Datasheet sensors for the tests of the modules above `sensors` that
/// must not read a config (`identify`): axes in internal units (rad, mm).
#[cfg(test)]
#[path = "structured_fixtures.rs"]
pub(crate) mod fixtures;
