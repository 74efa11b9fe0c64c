//! A datasheet axis's curve as the kernel, a fit and a report see it: the
//! harmonics the kernel sums, the interpolation phasor, the curve's terms
//! for a fit, its shape in words, the interpolation variance, and whether
//! two axes share a shape. A child of structured.rs, on the same fields.

use super::*;

impl Axis {
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
    /// `unit` (`per_unit` of them per internal unit) when there are: the
    /// angle a mounting eccentricity turns the reading by, for an encoder
    /// ("; eccentricity ≤ 4.120″").
    pub fn shape_text(&self, per_unit: f64, unit: &str) -> String {
        let mut out = match self.shape {
            Shape::Listed => format!("{:?}", &self.harmonics[..self.n_harmonics]),
            Shape::Unknown => format!("unknown, orders 1–{}", self.n_harmonics),
        };
        if self.readheads == 2 {
            out.push_str("; 2 heads");
        }
        if self.eccentricity > 0.0 {
            out.push_str(&format!(
                "; eccentricity ≤ {:.3}{}{unit}",
                self.eccentricity * per_unit,
                if unit == "″" { "" } else { " " }
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
            && self.coherence == other.coherence
    }
}
