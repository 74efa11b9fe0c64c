//! The estimators (docs/method.md §6, §13): OLS as the paper (eq. 12), WLS with rows
//! weighted by 1/σ of their sensor, GLS whitened by the covariance of the
//! sensors' datasheet model; and the options of an identification.
//!
//! This file is the estimator seam: [`Method::weighting`] builds, once per
//! grade × pose subset × product, the [`Weighting`] every solver reads (the
//! linear operator, Gauss–Newton, the predicted and a-posteriori
//! uncertainty, identifiability, pose design and the budget). A new
//! estimator is an arm here and, if it whitens otherwise, one in
//! [`Weighting`] (its own file: the solvers read it, and this file builds
//! them).

use super::constraints::Constraints;
use super::linear::Solver;
use super::weighting::Weighting;
use crate::mechanism::PoseReadings;
use crate::sensors::{ObservationCovariance, SensorModel};
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

/// The estimator.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Hash)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Ordinary least squares on rows that mix rad and mm (the paper).
    Ols,
    /// Each row weighted by 1/σ of its sensor.
    Wls,
    /// Generalised least squares: rows whitened by L⁻¹, L·Lᵀ = Σ the
    /// covariance of the sensors' model (docs/method.md §13).
    Gls,
}

impl Method {
    /// Every estimator, in the order studies list them.
    pub const ALL: [Method; 3] = [Method::Ols, Method::Wls, Method::Gls];

    /// The names a config may use, for messages.
    pub const NAMES: &'static str = "\"ols\", \"wls\" or \"gls\"";

    /// The estimator of a config name ("ols", "wls", "gls").
    pub fn parse(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }

    /// Heading of the estimator in figures.
    pub fn title(&self) -> &'static str {
        match self {
            Method::Ols => "OLS (the paper's estimator)",
            Method::Wls => "WLS (rows weighted by 1/σ)",
            Method::Gls => "GLS (the datasheet's error covariance)",
        }
    }

    pub fn name(&self) -> &'static str {
        match self {
            Method::Ols => "ols",
            Method::Wls => "wls",
            Method::Gls => "gls",
        }
    }

    /// Does the weighting depend on the sensors (so each sensor set needs
    /// its own operator)? OLS shares one across every set.
    pub fn reads_sensors(&self) -> bool {
        !matches!(self, Method::Ols)
    }

    /// Does the estimator trust its covariance as the sensors' own (so the
    /// a-posteriori uncertainty is that covariance, not rescaled by the
    /// residual)?
    pub fn knows_covariance(&self) -> bool {
        matches!(self, Method::Gls)
    }

    /// Can this estimator weight `sensors`? WLS divides by each sensor's
    /// σ, GLS whitens by its covariance: a sensor whose errors vanish (for
    /// GLS: whose white term is zero even after its floor) has no weight.
    /// Err says which, naming the estimator.
    pub fn check_sensors<const R: usize>(&self, sensors: &SensorModel<R>) -> Result<(), String> {
        let zero = match self {
            Method::Ols => None,
            Method::Wls => {
                let s = sensors.reading_sigma();
                (0..R).find(|&k| s[k].is_nan() || s[k] <= 0.0)
            }
            Method::Gls => {
                let c = sensors.covariances();
                (0..R).find(|&k| !c[k].is_positive())
            }
        };
        match zero {
            None => Ok(()),
            Some(k) => Err(format!(
                "= \"{}\" needs every sensor to have some error, but the {}'s is zero (its weight would be infinite)",
                self.name(),
                sensors.slots[k].sensor
            )),
        }
    }

    /// This estimator's operator for design `h` at the poses of nominal
    /// joints `joints` (reference first): its weighting, then the solver
    /// holding `constraints` on the errors named `names` — the one place
    /// both are built. Err as [`Method::weighting`].
    pub fn solver<const P: usize, const R: usize, J: PoseReadings<R>>(
        &self,
        (sensors, joints): (&SensorModel<R>, &[J]),
        h: &DMatrix<f64>,
        rank_tolerance: f64,
        held: (&Constraints<P>, &[&str]),
    ) -> Result<Solver<P, R>, String> {
        let weighting = self.weighting(sensors, joints)?;
        Ok(Solver::constrained_named(
            h,
            &weighting,
            rank_tolerance,
            held,
        ))
    }

    /// What the solvers need for this estimator with `sensors` at the poses
    /// of nominal joints `joints` (reference first; a row per reading slot
    /// of each later pose).
    /// Err names the sensor whose errors vanish, so no weight exists.
    pub fn weighting<const R: usize, J: PoseReadings<R>>(
        &self,
        sensors: &SensorModel<R>,
        joints: &[J],
    ) -> Result<Weighting, String> {
        let rows = R * joints.len().saturating_sub(1);
        self.check_sensors(sensors)?;
        match self {
            Method::Ols => Ok(Weighting::Rows(DVector::from_element(rows, 1.0))),
            Method::Wls => {
                let s = sensors.reading_sigma();
                Ok(Weighting::Rows(DVector::from_fn(rows, |r, _| {
                    1.0 / s[r % R]
                })))
            }
            Method::Gls => {
                Weighting::whiten(&ObservationCovariance::new(&sensors.covariances(), joints))
            }
        }
    }
}

/// How to identify a mechanism of `P` errors.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IdentifyOptions<const P: usize> {
    pub method: Method,
    /// 1 = one linearisation at the nominal poses (the paper); more =
    /// Gauss–Newton re-linearised at the current estimate.
    pub iterations: usize,
    /// Gauss–Newton stops when the largest step component is below this, mm.
    pub tolerance_mm: f64,
    /// Relative singular-value tolerance for rank decisions.
    pub rank_tolerance: f64,
    /// `fix` and `prior_std_mm` (none by default).
    pub constraints: Constraints<P>,
    /// Identify the mechanism's second-class unknowns beside its errors
    /// (`second_class = true`, [`super::second_class`]; the Tricept's: the
    /// first Hooke axis's yaw and pitch and the axes' skew).
    pub second_class: bool,
}

impl<const P: usize> Default for IdentifyOptions<P> {
    fn default() -> Self {
        IdentifyOptions {
            method: Method::Ols,
            iterations: 1,
            tolerance_mm: 1e-9,
            constraints: Default::default(),
            rank_tolerance: 1e-9,
            second_class: false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::tricept::{Geometry, Machine, NominalPoses};
    use crate::sensors::structured::fixtures::{encoder, paper_span_mm, scale, sensors};

    /// OLS weighs every row 1, WLS row r by 1/σ of sensor r mod 3, GLS
    /// whitens by a factor L with L·Lᵀ = Σ of the poses; names and titles
    /// tell the three apart.
    #[test]
    fn each_estimator_weights_as_it_says() {
        let e = encoder(3.0, &[0.8, 0.2], 0.1);
        let s = sensors(
            [e, e, scale(1.0, &[1.0], paper_span_mm(), 0.05)],
            [true; 3],
            3,
        );
        let targets = crate::mechanism::tricept::poses::paper_targets();
        let poses =
            NominalPoses::new(&Machine::nominal(&Geometry::paper()), &targets[..6]).unwrap();
        let sigma = s.reading_sigma();
        match Method::Ols.weighting(&s, &poses.joints).unwrap() {
            Weighting::Rows(w) => assert_eq!(w, DVector::from_element(15, 1.0)),
            Weighting::Whiten(_) => panic!("OLS whitens"),
        }
        match Method::Wls.weighting(&s, &poses.joints).unwrap() {
            Weighting::Rows(w) => {
                assert_eq!(w.len(), 15);
                for r in 0..15 {
                    assert_eq!(w[r], 1.0 / sigma[r % 3], "row {r}");
                }
            }
            Weighting::Whiten(_) => panic!("WLS whitens"),
        }
        let want = crate::sensors::observation_covariance(&s.covariances(), &poses.joints);
        match Method::Gls.weighting(&s, &poses.joints).unwrap() {
            Weighting::Whiten(w) => {
                // WᵀW·Σ = I against the dense Σ built entry by entry.
                let wd = w.apply(&DMatrix::identity(15, 15));
                let back = wd.transpose() * &wd * &want;
                assert!((back - DMatrix::identity(15, 15)).amax() < 1e-9);
            }
            Weighting::Rows(_) => panic!("GLS weighs rows"),
        }
        let names: Vec<&str> = Method::ALL.iter().map(|m| m.name()).collect();
        assert_eq!(names, ["ols", "wls", "gls"]);
        for m in Method::ALL {
            assert_eq!(Method::parse(m.name()), Some(m));
            assert!(
                m.title().starts_with(&m.name().to_uppercase()),
                "{}",
                m.title()
            );
        }
        assert_eq!(Method::parse("GLS"), None);
        assert!(
            !Method::Ols.reads_sensors()
                && Method::Wls.reads_sensors()
                && Method::Gls.reads_sensors()
        );
        assert!(!Method::Ols.knows_covariance() && !Method::Wls.knows_covariance());
        assert!(Method::Gls.knows_covariance());
    }

    /// A sensor without error has no weight: WLS when its σ is zero, GLS
    /// only when even its floor (10⁻³·a) is; OLS never asks.
    #[test]
    fn a_sensor_without_error_has_no_weight() {
        // Encoders ±3″ with no curve and no jitter; the scale the paper's 0.5 µm.
        let e = encoder(3.0, &[], 0.0);
        let bare = sensors([e, e, scale(0.0, &[], 1.0, 0.5)], [true, true, false], 3);
        assert!(Method::Wls
            .check_sensors(&bare)
            .unwrap_err()
            .contains("ψ4 encoder"));
        assert!(Method::Gls.check_sensors(&bare).is_ok());
        let mut zero = bare;
        zero.structured.as_mut().unwrap().axes[2].accuracy = 0.0;
        zero.structured.as_mut().unwrap().axes[2].noise = 0.0;
        let why = Method::Gls.check_sensors(&zero).unwrap_err();
        assert!(why.contains("\"gls\"") && why.contains("scale"), "{why}");
        assert!(Method::Ols.check_sensors(&zero).is_ok());
        assert!(Method::Gls
            .weighting(&zero, &[crate::mechanism::tricept::Joints::default(); 3])
            .is_err());
    }

    /// A layout that is not the Tricept's: two slots, a scale then an
    /// encoder. OLS and WLS give a row per slot of each later pose, WLS
    /// row r 1/σ of slot r mod 2 in the slot's own unit (the scale's 4 µm
    /// in mm, the encoder's 2″ in rad); GLS whitens the same rows; the
    /// solver is of the design's 2 errors; a sensor without error is named
    /// by its slot, for WLS and for GLS.
    #[test]
    fn the_estimators_read_any_slot_layout() {
        use crate::mechanism::{Quantity, ReadingFact, ARCSEC_PER_RAD};
        use crate::sensors::GradeReading;
        static SLOTS: [ReadingFact; 2] = [
            ReadingFact::named("first scale", Quantity::Length),
            ReadingFact::named("second encoder", Quantity::Angle),
        ];
        let s = SensorModel {
            slots: &SLOTS,
            encoder_arcsec: 2.0,
            scale_um: 4.0,
            samples: 4,
            reading: GradeReading::Sigma,
            structured: None,
        };
        let joints = [nalgebra::Vector2::<f64>::zeros(); 5];
        let Weighting::Rows(ones) = Method::Ols.weighting(&s, &joints).unwrap() else {
            panic!("OLS weights rows");
        };
        assert_eq!(ones.len(), 8);
        let Weighting::Rows(w) = Method::Wls.weighting(&s, &joints).unwrap() else {
            panic!("WLS weights rows");
        };
        let (sc, enc) = (4e-3 / 2.0, 2.0 / ARCSEC_PER_RAD / 2.0);
        assert_eq!(w.len(), 8);
        for (r, x) in w.iter().enumerate() {
            let want = if r % 2 == 0 { 1.0 / sc } else { 1.0 / enc };
            assert!(
                (x / want - 1.0).abs() < 1e-12,
                "row {r}: {x} against {want}"
            );
        }
        let gls = Method::Gls.weighting(&s, &joints).unwrap();
        let h = DMatrix::from_fn(8, 2, |r, c| ((r + 1) * (c + 2)) as f64 % 5.0 + c as f64);
        assert_eq!(gls.apply(&h).nrows(), 8);
        let held = (&Constraints::<2>::default(), &["u", "v"][..]);
        let solver: Solver<2, 2> = Method::Wls.solver((&s, &joints), &h, 1e-9, held).unwrap();
        assert_eq!(solver.analysis.rank, 2);
        let bare = SensorModel { scale_um: 0.0, ..s };
        let why = Method::Wls.check_sensors(&bare).unwrap_err();
        assert!(why.contains("first scale"), "{why}");
        let why = Method::Gls.check_sensors(&bare).unwrap_err();
        assert!(why.contains("first scale"), "{why}");
        let deaf = SensorModel {
            encoder_arcsec: 0.0,
            ..s
        };
        let why = Method::Wls.check_sensors(&deaf).unwrap_err();
        assert!(why.contains("second encoder"), "{why}");
    }
}
