//! Datasheet sensors (docs/method.md §11) read at every pose of one machine at once:
//! the sweep's kernel. One machine's draws (phases, then each sample's
//! jitter, drawn as the reference draws them: [`Structured::draw_machine`])
//! and the curve shapes at its true joints are computed once and kept while
//! sensor sets that draw alike follow (a sweep's grades differ in amplitude
//! only); each set's reading errors are then a few passes over arrays
//! (quantisation included), with no libm call. [`Structured::reading`]
//! stays the reference, written straight from the formula of docs/method.md §11, and the
//! tests hold the two to agree.

use super::structured::{Axis, JitterTable, Phases, Structured, MAX_HARMONICS};
use super::trig::sin_cos_turns;
use super::units::Units;
use crate::mechanism::{sin_cos_near, MAX_OFFSET_RAD};
use nalgebra::SVector;
use rand::Rng;

/// One machine's draws for datasheet sensors and the curve shapes at its
/// true joints, axis by axis (a mechanism's `R` reading slots: the
/// Tricept's ψ4, θ4, q4), with the buffers the reading errors are formed
/// in. Reused across trials: no allocation once sized.
#[derive(Debug, Clone)]
pub struct MachineDraws<const R: usize> {
    /// The sensor set the draws were made for (None: nothing drawn yet).
    drawn_for: Option<(Structured<R>, u32)>,
    /// The class of sets it was drawn for by [`MachineDraws::prepare`].
    class: Option<usize>,
    poses: usize,
    /// The true joint at each pose.
    v: [Vec<f64>; R],
    /// Σk hk·sin(k·2π·v/T + φk) and sin(2π·v/P + φP) at each pose.
    h: [Vec<f64>; R],
    s: [Vec<f64>; R],
    /// Jitter draws, each axis sample-major (see [`JitterTable`]).
    z: JitterTable<R>,
    /// Each pose's reading error (reading − truth) and a work row.
    err: Vec<f64>,
    work: Vec<f64>,
    /// Two work rows for the curve shapes.
    rows: Vec<f64>,
    /// Each axis's nominal joint at each pose (see [`MachineDraws::anchor_at`]),
    /// and sin, cos of a whole curve period's angle there, one entry per
    /// period met (a catalogue's scales differ in length): computed once,
    /// kept for the whole run.
    nominal: [Vec<f64>; R],
    anchors: [Vec<Anchor>; R],
    /// Each quantised axis's draws in units of its resolution (see
    /// [`Units`]), for the resolution, jitter and interpolation they were
    /// computed with.
    units: [Units; R],
}

impl<const R: usize> Default for MachineDraws<R> {
    fn default() -> Self {
        let empty = || std::array::from_fn(|_| Vec::new());
        MachineDraws {
            drawn_for: None,
            class: None,
            poses: 0,
            v: empty(),
            h: empty(),
            s: empty(),
            z: JitterTable::default(),
            err: Vec::new(),
            work: Vec::new(),
            rows: Vec::new(),
            nominal: empty(),
            anchors: std::array::from_fn(|_| Vec::new()),
            units: std::array::from_fn(|_| Units::default()),
        }
    }
}

/// A curve period and sin, cos of its angle at each pose's nominal joint.
type Anchor = (f64, Vec<f64>, Vec<f64>);

/// Do sensor sets `a` and `b` take the same draws from the same stream and
/// have the same curve shapes (so one machine's draws serve both)?
pub fn draws_alike<const R: usize>(a: &Structured<R>, b: &Structured<R>) -> bool {
    a.axes.iter().zip(&b.axes).all(|(x, y)| {
        x.same_shape(y)
            && (x.noise > 0.0) == (y.noise > 0.0)
            && (x.resolution > 0.0) == (y.resolution > 0.0)
    })
}

impl<const R: usize> MachineDraws<R> {
    /// Make sure the draws serve sensor set `st` of `samples` samples at
    /// the true joints `actual`: kept when the last set drawn for was of the
    /// same `class` (the caller's number for the sets that draw alike, see
    /// [`draws_alike`] and `SweepContext::draw_class`), otherwise drawn
    /// afresh from `rng()`: a new stream positioned where every set's draws
    /// start.
    pub fn prepare<G: Rng + Clone>(
        &mut self,
        class: usize,
        st: &Structured<R>,
        samples: u32,
        actual: &[SVector<f64, R>],
        rng: impl FnOnce() -> G,
    ) {
        if self.class != Some(class) {
            self.draw(st, samples, &mut rng(), actual);
            self.class = Some(class);
        }
    }

    /// Anchor the curve shapes at the poses' nominal joints (every slot's
    /// reading at each pose): a machine's true joints lie within a few milliradians
    /// (or millimetres) of them, so the angle of a curve's first harmonic
    /// follows from its value there by a short series, not a full sine.
    pub fn anchor_at(&mut self, nominal: &[SVector<f64, R>]) {
        for k in 0..R {
            self.nominal[k] = nominal.iter().map(|v| v[k]).collect();
            self.anchors[k].clear();
        }
    }

    /// Forget the draws (a new machine).
    pub fn clear(&mut self) {
        self.drawn_for = None;
        self.class = None;
    }

    /// Draw this machine's phases (slot by slot) and every sample's jitter
    /// (as the reference draws them, [`Structured::draw_machine`]) and
    /// evaluate the curve shapes at `actual`.
    pub fn draw<G: Rng + Clone>(
        &mut self,
        st: &Structured<R>,
        samples: u32,
        rng: &mut G,
        actual: &[SVector<f64, R>],
    ) {
        let n = actual.len();
        let ph = st.draw_machine(rng, samples, n, &mut self.z);
        self.poses = n;
        for k in 0..R {
            self.v[k].resize(n, 0.0);
            self.h[k].resize(n, 0.0);
            self.s[k].resize(n, 0.0);
        }
        self.err.resize(n, 0.0);
        self.work.resize(n, 0.0);
        self.rows.resize(2 * n, 0.0);
        crate::cpu::wide(
            #[inline(always)]
            || self.shape_all(st, &ph, actual),
        );
        for u in &mut self.units {
            u.key = [f64::NAN; 3];
        }
        self.drawn_for = Some((*st, samples));
        self.class = None;
    }

    #[inline(always)]
    fn shape_all(&mut self, st: &Structured<R>, ph: &[Phases; R], actual: &[SVector<f64, R>]) {
        let n = actual.len();
        for k in 0..R {
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
    }

    /// Sensor set `st`'s homed reading errors, as rows of l − l0: row
    /// R(j−1)+k holds e_j − e_0 of axis k, e being reading − truth, for the
    /// axes k with `axes[k]` (the other rows are left as they are). The draws
    /// must have been prepared for a set that draws alike.
    pub fn homed_errors(
        &mut self,
        st: &Structured<R>,
        samples: u32,
        axes: [bool; R],
        out: &mut [f64],
    ) {
        crate::cpu::wide(
            #[inline(always)]
            || self.homed_errors_by(st, samples, axes, out),
        )
    }

    #[inline(always)]
    fn homed_errors_by(
        &mut self,
        st: &Structured<R>,
        samples: u32,
        axes: [bool; R],
        out: &mut [f64],
    ) {
        debug_assert!(self
            .drawn_for
            .as_ref()
            .is_some_and(|(d, n)| *n == samples && draws_alike(d, st)));
        let n = self.poses;
        let ns = samples as usize;
        for k in (0..R).filter(|&k| axes[k]) {
            let ax = &st.axes[k];
            let a = ax.curve_scale();
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
                    u.fill(key, &self.v[k], &self.h[k], &self.s[k], self.z.axis(k));
                }
                u.errors(err, &mut self.work[..n], a, ax.resolution, ns);
            } else {
                // Unquantised: e(v) plus the mean jitter (one draw of σ/√samples),
                // without v's rounding.
                let (h, s, z) = (&self.h[k], &self.s[k], self.z.axis(k));
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
            for (row, e) in out.chunks_exact_mut(R).zip(&err[1..]) {
                row[k] = e - e0;
            }
        }
    }
}

impl<const R: usize> MachineDraws<R> {
    /// The homed rows of each part of an unquantised reading's error
    /// e = a·h + i·s + σ̄·z (see [`Axis::linear_amplitudes`]): `parts[0]` the
    /// curve shape h, `parts[1]` the interpolation shape s, `parts[2]` the
    /// standard normal z, each as rows of l (row R(j−1)+k: x_j − x_0 of axis
    /// k). A sensor set's errors are then Σ amplitude·part, axis by axis, and
    /// so is any linear estimate of them.
    pub fn linear_parts(&self, parts: [&mut [f64]; 3]) {
        debug_assert!(self
            .drawn_for
            .as_ref()
            .is_some_and(|(st, _)| st.axes.iter().all(|a| a.resolution <= 0.0)));
        let n = self.poses;
        for (part, c) in parts.into_iter().zip(0..) {
            for k in 0..R {
                let x = match c {
                    0 => &self.h[k],
                    1 => &self.s[k],
                    _ => self.z.axis(k),
                };
                if x.len() < n {
                    // No jitter on this axis.
                    (1..n).for_each(|j| part[R * (j - 1) + k] = 0.0);
                    continue;
                }
                for j in 1..n {
                    part[R * (j - 1) + k] = x[j] - x[0];
                }
            }
        }
    }
}

/// The curve shapes of axis `ax` with phases `ph` at the values `v`: `h`
/// the ring's (as [`Axis::shape_at`]'s first), `s` the interpolation's (its
/// second), by the study kernel's recurrences (one sine and cosine a value
/// for every harmonic). `w` is work space of 2·`v.len()`.
pub fn axis_shapes(ax: &Axis, ph: &Phases, v: &[f64], h: &mut [f64], s: &mut [f64], w: &mut [f64]) {
    shapes(None, ax, ph, v, h, s, w);
}

/// The curve shapes of one axis at the joint values `v`: the harmonics by
/// powers of e^{i·2π·v/T} (one sine and cosine per pose), the interpolation
/// error by one more. One pass over the poses with everything in registers
/// (it vectorises), then the rare pose too far from its anchor again with
/// the full sine; `w` holds two work rows of `v.len()`.
#[allow(clippy::type_complexity)]
#[inline(always)]
fn shapes(
    anchor: Option<(&[f64], &[f64], &[f64])>,
    ax: &Axis,
    ph: &Phases,
    v: &[f64],
    h: &mut [f64],
    s: &mut [f64],
    w: &mut [f64],
) {
    // sin φ, cos φ of a phase in [0, 2π), by the kernel's own sine (libm's
    // is a call, and nine of them were a tenth of the shapes' time).
    let sin_cos = |phase: f64| sin_cos_turns(phase * (0.5 * std::f64::consts::FRAC_1_PI));
    let (coef, n) = ax.coefficients(ph, sin_cos);
    // The usual harmonic counts with the count known to the compiler.
    match n {
        0 => h.fill(0.0),
        1 => curve::<1>(anchor, ax, &coef, v, h, w),
        2 => curve::<2>(anchor, ax, &coef, v, h, w),
        3 => curve::<3>(anchor, ax, &coef, v, h, w),
        4 => curve::<4>(anchor, ax, &coef, v, h, w),
        5 => curve::<5>(anchor, ax, &coef, v, h, w),
        6 => curve::<6>(anchor, ax, &coef, v, h, w),
        7 => curve::<7>(anchor, ax, &coef, v, h, w),
        8 => curve::<8>(anchor, ax, &coef, v, h, w),
        9..=16 => curve::<16>(anchor, ax, &coef, v, h, w),
        _ => curve::<MAX_HARMONICS>(anchor, ax, &coef, v, h, w),
    }
    if ax.interpolation > 0.0 && ax.signal_period > 0.0 && ax.coherence > 0.0 {
        // Finite coherence: the drifting components, pose by pose.
        let per_turn = 1.0 / ax.signal_period;
        for (sj, &vj) in s.iter_mut().zip(v) {
            let (si, ci) = sin_cos_turns(vj * per_turn);
            *sj = ax.drift(ph, vj, si, ci);
        }
    } else if ax.interpolation > 0.0 && ax.signal_period > 0.0 {
        let (sp, cp) = ax.interpolation_phasor(ph, sin_cos);
        // Turns by a multiply (a division per pose was the loop's slowest
        // step); the turn count differs from v/P by an ulp of it.
        let per_turn = 1.0 / ax.signal_period;
        for (sj, &vj) in s.iter_mut().zip(v) {
            let (si, ci) = sin_cos_turns(vj * per_turn);
            *sj = si * cp + ci * sp;
        }
    } else {
        s.fill(0.0);
    }
}

/// Σk hk·sin(k·x + φk) from sin x, cos x, for the first `N` of `coef`
/// (hk, sin φk, cos φk; a harmonic past the axis's count has hk = 0):
/// sin(kx + φ) = sin kx·cos φ + cos kx·sin φ, and (k+1)·x from k·x and x.
#[inline(always)]
fn harmonics<const N: usize>(s1: f64, c1: f64, coef: &[(f64, f64, f64); MAX_HARMONICS]) -> f64 {
    let (mut s, mut c) = (s1, c1);
    let mut h = 0.0;
    for (k, &(hk, sp, cp)) in coef.iter().enumerate().take(N) {
        h += hk * (s * cp + c * sp);
        if k + 1 < N {
            (s, c) = (s * c1 + c * s1, c * c1 - s * s1);
        }
    }
    h
}

/// The harmonics' shape h at each pose (see [`shapes`]).
#[allow(clippy::type_complexity)]
#[inline(always)]
fn curve<const N: usize>(
    anchor: Option<(&[f64], &[f64], &[f64])>,
    ax: &Axis,
    coef: &[(f64, f64, f64); MAX_HARMONICS],
    v: &[f64],
    h: &mut [f64],
    w: &mut [f64],
) {
    let n = v.len();
    match anchor {
        Some((nominal, s0, c0)) => {
            // Every pose by the series (a loop without branches), then the
            // rare pose too far from its anchor by the full sine.
            let scale = std::f64::consts::TAU / ax.period;
            let offset = |j: usize| (v[j] - nominal[j]) * scale;
            let (s0, c0, h) = (&s0[..n], &c0[..n], &mut h[..n]);
            let mut far = false;
            for j in 0..n {
                let d = offset(j);
                let (s1, c1) = sin_cos_near(s0[j], c0[j], d);
                h[j] = harmonics::<N>(s1, c1, coef);
                far |= d.abs() > MAX_OFFSET_RAD;
            }
            if far {
                for j in (0..n).filter(|&j| offset(j).abs() > MAX_OFFSET_RAD) {
                    let (s1, c1) = sin_cos_turns(v[j] / ax.period);
                    h[j] = harmonics::<N>(s1, c1, coef);
                }
            }
        }
        None => {
            let (s1, c1) = w.split_at_mut(n);
            for ((a, b), &vj) in s1.iter_mut().zip(c1.iter_mut()).zip(v) {
                (*a, *b) = sin_cos_turns(vj / ax.period);
            }
            for ((hj, &a), &b) in h.iter_mut().zip(&*s1).zip(&*c1) {
                *hj = harmonics::<N>(a, b, coef);
            }
        }
    }
}

#[cfg(test)]
#[path = "batch_tests.rs"]
mod tests;
