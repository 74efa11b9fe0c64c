//! A machine's own sensor curves from its calibration (docs/method.md §11, §13): the
//! harmonic coefficients of each datasheet sensor, estimated from what the
//! geometric errors leave of the readings.
//!
//! One harmonic k of amplitude a·hk and random phase is A·sin(kωv) +
//! B·cos(kωv) with A, B independent, zero mean, variance (a·hk)²/2: the
//! curve part of Σ is Z·P·Zᵀ with Z the homed sines and cosines at the poses
//! (z(v_j) − z(v_0)) and P = diag((a·hk)²/2). Given the GLS estimate ε̂, the
//! best linear predictor of u = (A, B, …) and its error are (Henderson)
//!
//!   û = P·Zᵀ·Σ⁻¹·(l − H·ε̂),   Var(u − û) = P − P·Zᵀ·Q·Z·P,
//!   Q = Σ⁻¹ − Σ⁻¹H(HᵀΣ⁻¹H)⁻¹HᵀΣ⁻¹,
//!
//! computed on the whitened rows (W = L⁻¹: Zᵀ·Σ⁻¹·r = (WZ)ᵀ(Wr) and
//! ZᵀQZ = (WZ)ᵀ(I − B·Bᵀ)(WZ), B an orthonormal basis of W·H's identifiable
//! columns). A harmonic whose amplitude exceeds the datasheet's a·hk by more
//! than 3 of its standard deviations says the datasheet model does not fit
//! this machine's sensor.

use super::analysis::Identifiability;
use super::weighting::Weighting;
use crate::mechanism::{PoseReadings, ReadingFact};
use crate::sensors::{ObservationCovariance, SensorModel, Structured};
use nalgebra::{DMatrix, DVector};
use serde::Serialize;

/// One harmonic of one sensor, in the sensor's datasheet unit.
#[derive(Debug, Clone, Serialize)]
pub struct CurveEstimate {
    /// The sensor's key in its reading fact (the Tricept's "psi4_encoder",
    /// "theta4_encoder" or "scale").
    pub sensor: &'static str,
    /// Order of the harmonic (1: once per revolution or measuring length).
    pub harmonic: usize,
    /// "arcsec" or "um".
    pub unit: &'static str,
    /// Posterior mean and standard deviation of the sine coefficient A.
    pub sin_coef: f64,
    pub sin_std: f64,
    /// Posterior mean and standard deviation of the cosine coefficient B.
    pub cos_coef: f64,
    pub cos_std: f64,
    /// Correlation of the errors of A and B.
    pub sin_cos_correlation: f64,
    /// √(A² + B²), and the largest standard deviation of (A, B) in any
    /// direction (an upper bound on the amplitude's to first order).
    pub amplitude: f64,
    pub amplitude_std: f64,
    /// The datasheet's amplitude of this harmonic, a·hk.
    pub datasheet: f64,
    /// amplitude − datasheet > 3·amplitude_std.
    pub exceeds: bool,
}

/// Each datasheet sensor's harmonics from the residual `resid` = l − H·ε̃
/// of a fit (any ε̃: the predictor reads Q·resid = Q·l, Q·H = 0) with design
/// `h` and identifiable set `analysis`, for a mechanism whose readings a
/// pose are the sensors' slots (one sensor each, in the design's row order). The
/// curves and Σ are taken at joint values `joints` (reference first): the
/// fitted machine's, so that a curve is read where the sensor actually was. Σ is built here from `sensors`
/// at those values (the predictor's algebra needs Σ's curve part to be
/// Z·P·Zᵀ of the same Z). None when that Σ is not positive definite or a
/// value is not finite.
pub fn sensor_curves<const R: usize, J: PoseReadings<R>>(
    h: &DMatrix<f64>,
    analysis: &Identifiability,
    sensors: &SensorModel<R>,
    joints: &[J],
    resid: &DVector<f64>,
) -> Option<Vec<CurveEstimate>> {
    let st = sensors.structured.as_ref()?;
    let covariances = sensors.covariances();
    let facts = &sensors.slots[..];
    let weighting = Weighting::whiten(&ObservationCovariance::new(&covariances, joints)).ok()?;
    let curves = curves_of(h, &weighting, analysis, (st, facts), joints, resid);
    // Finite or nothing: the rows are written as they are.
    let finite = |c: &CurveEstimate| {
        [
            c.sin_coef,
            c.sin_std,
            c.cos_coef,
            c.cos_std,
            c.sin_cos_correlation,
        ]
        .iter()
        .chain(&[c.amplitude, c.amplitude_std, c.datasheet])
        .all(|v| v.is_finite())
    };
    curves.iter().all(finite).then_some(curves)
}

fn curves_of<const R: usize, J: PoseReadings<R>>(
    h: &DMatrix<f64>,
    weighting: &Weighting,
    analysis: &Identifiability,
    (sensors, facts): (&Structured<R>, &[ReadingFact]),
    joints: &[J],
    resid: &DVector<f64>,
) -> Vec<CurveEstimate> {
    let m = h.nrows();
    // The harmonics modelled: (sensor, order, variance, rate).
    let mut terms = Vec::new();
    for (k, axis) in sensors.axes.iter().enumerate() {
        if !sensors.from_section[k] {
            continue;
        }
        let (modelled, n) = axis.curve_terms();
        for t in &modelled[..n] {
            terms.push((k, t.order, t.variance, t.rate, t.bound));
        }
    }
    if terms.is_empty() || m == 0 {
        return Vec::new();
    }
    // Z: two columns (sin, cos) per term, rows of that term's sensor.
    let q = 2 * terms.len();
    let per = facts.len();
    let v0 = &joints[0];
    let mut z = DMatrix::zeros(m, q);
    for (t, &(k, _, _, rate, _)) in terms.iter().enumerate() {
        for pose in 1..joints.len() {
            let v = joints[pose].reading(k);
            let r = per * (pose - 1) + k;
            z[(r, 2 * t)] = (rate * v).sin() - (rate * v0.reading(k)).sin();
            z[(r, 2 * t + 1)] = (rate * v).cos() - (rate * v0.reading(k)).cos();
        }
    }
    let zw = weighting.apply(&z);
    let rw = weighting.apply_vector(resid);
    // Orthonormal basis of the whitened identifiable columns.
    let active: Vec<usize> = (0..h.ncols())
        .filter(|&c| analysis.identifiable[c])
        .collect();
    let hw = weighting.apply(&h.select_columns(&active));
    let basis = if active.is_empty() {
        DMatrix::zeros(m, 0)
    } else {
        hw.qr().q()
    };
    // (I − BBᵀ)·Zw, and Zwᵀ(I − BBᵀ)·rw = Zᵀ·Q·resid.
    let zp = &zw - &basis * (basis.transpose() * &zw);
    let p = DVector::from_fn(q, |i, _| terms[i / 2].2);
    let u = DVector::from_fn(q, |i, _| p[i] * zp.column(i).dot(&rw));
    let ztqz = zw.transpose() * &zp;
    let var = |a: usize, b: usize| {
        let prior = if a == b { p[a] } else { 0.0 };
        prior - p[a] * ztqz[(a, b)] * p[b]
    };
    terms
        .iter()
        .enumerate()
        .map(|(t, &(k, order, _, _, bound))| {
            let unit = facts[k].quantity.sensor_per_model();
            let (a, b) = (u[2 * t], u[2 * t + 1]);
            let (va, vb, cab) = (
                var(2 * t, 2 * t).max(0.0),
                var(2 * t + 1, 2 * t + 1).max(0.0),
                var(2 * t, 2 * t + 1),
            );
            let amp = a.hypot(b);
            // The largest variance of (A, B) in any direction (the larger
            // eigenvalue of their 2 × 2 covariance): the amplitude's own to
            // first order is its radial part, but the true amplitude of a
            // random-phase curve is fixed, not drawn, and where the data
            // leave (A, B) elongated the radial variance alone undercounts
            // how far a shrunk estimate may sit (tried: 5 false flags in 360
            // on a scale read over less than a period).
            let amp_var = (va + vb) / 2.0 + (((va - vb) / 2.0).powi(2) + cab * cab).sqrt();
            let amp_std = amp_var.sqrt();
            CurveEstimate {
                sensor: facts[k].sensor_key,
                harmonic: order,
                unit: facts[k].quantity.sensor_unit_ascii(),
                sin_coef: a * unit,
                sin_std: va.sqrt() * unit,
                cos_coef: b * unit,
                cos_std: vb.sqrt() * unit,
                sin_cos_correlation: if va > 0.0 && vb > 0.0 {
                    cab / (va * vb).sqrt()
                } else {
                    0.0
                },
                amplitude: amp * unit,
                amplitude_std: amp_std * unit,
                datasheet: bound * unit,
                exceeds: amp - bound > 3.0 * amp_std,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::tricept::{design_matrix, LinearSolver};
    use crate::identify::Method;
    use crate::mechanism::tricept::{
        ErrorVector, Geometry, Joints, Machine, NominalPoses, N_READINGS, READINGS,
    };
    use crate::sensors::structured::fixtures::{encoder, paper_span_mm, scale, sensors};
    use crate::sensors::{observation_vector, JitterTable};
    use nalgebra::Vector3;
    use rand::{RngExt, SeedableRng};

    /// Encoders ±5″ [0.7, 0.3] with 0.1″ jitter, a ±3 µm scale [0.8] over
    /// `length_mm` with 0.05 µm jitter, 3 samples.
    fn datasheet(length_mm: f64) -> SensorModel<N_READINGS> {
        let e = encoder(5.0, &[0.7, 0.3], 0.1);
        sensors([e, e, scale(3.0, &[0.8], length_mm, 0.05)], [true; 3], 3)
    }

    /// The paper's machine and its 51 default poses.
    fn paper() -> (Geometry, NominalPoses) {
        let g = Geometry::paper();
        let poses = NominalPoses::new(
            &Machine::nominal(&g),
            &crate::mechanism::tricept::poses::paper_targets(),
        )
        .unwrap();
        (g, poses)
    }

    /// Machines of random errors within ±`bound` mm and random sensor
    /// phases, read by sensors whose curves are `scale` × the datasheet's,
    /// fitted by GLS with Gauss–Newton (5 linearisations) when `gn`; for
    /// each, the estimated coefficients against the true ones: (z-scores,
    /// how many harmonics were flagged, how many estimated).
    fn trial(
        model: SensorModel<N_READINGS>,
        scale: f64,
        bound: f64,
        gn: bool,
        machines: usize,
        seed: u64,
    ) -> (Vec<f64>, usize, usize, Vec<(f64, f64)>) {
        let (geometry, poses) = paper();
        let h = design_matrix(&Machine::nominal(&geometry), &poses).unwrap();
        let datasheet = model.structured.unwrap();
        let truth_sensors = datasheet.with_curves_scaled(scale);
        let w = Method::Gls.weighting(&model, &poses.joints).unwrap();
        let solver = LinearSolver::new(&h, &w, 1e-9);
        let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(seed);
        let mut x = vec![Vector3::zeros(); poses.len()];
        let mut table = JitterTable::default();
        let (mut z, mut flagged, mut total) = (Vec::new(), 0, 0);
        let mut corr = Vec::new();
        for _ in 0..machines {
            let e = ErrorVector::from_fn(|_, _| rng.random_range(-bound..bound));
            poses
                .actual_joints_into(&Machine::with_errors(&geometry, &e), &mut x)
                .unwrap();
            let ph = truth_sensors.draw_machine(&mut rng, 3, poses.len(), &mut table);
            let read: Vec<Vector3<f64>> = (0..poses.len())
                .map(|j| truth_sensors.reading(&ph, &x[j], 3, &table, j))
                .collect();
            let l = observation_vector(&poses.joints, &read);
            let curves = if gn {
                let opts = crate::identify::IdentifyOptions {
                    method: Method::Gls,
                    iterations: 5,
                    ..Default::default()
                };
                let (est, last) =
                    crate::identify::tricept::identify(&geometry, &poses, &solver, &l, &opts)
                        .unwrap();
                let mut y = vec![Vector3::zeros(); poses.len()];
                poses
                    .actual_joints_into(&Machine::with_errors(&geometry, &est.values), &mut y)
                    .unwrap();
                let resid = &l - observation_vector(&poses.joints, &y);
                let at: Vec<Joints> = y.iter().map(Joints::from_vector).collect();
                sensor_curves(last.design(), &last.analysis, &model, &at, &resid).unwrap()
            } else {
                let est = solver.estimate(&l);
                let resid = &l - &h * est.values;
                sensor_curves(&h, &solver.analysis, &model, &poses.joints, &resid).unwrap()
            };
            assert!(curves.len() >= 5);
            for c in &curves {
                let k = READINGS
                    .iter()
                    .position(|r| r.sensor_key == c.sensor)
                    .unwrap();
                let axis = truth_sensors.axes[k];
                let amp = axis.accuracy * axis.harmonics[c.harmonic - 1];
                let phase = ph[k].harmonic[c.harmonic - 1];
                let unit = if k < 2 { 206_264.806_247_096_36 } else { 1e3 };
                let (a, b) = (amp * phase.cos() * unit, amp * phase.sin() * unit);
                z.push((c.sin_coef - a) / c.sin_std);
                z.push((c.cos_coef - b) / c.cos_std);
                assert_eq!(c.unit, ["arcsec", "arcsec", "um"][k]);
                let sheet =
                    datasheet.axes[k].accuracy * datasheet.axes[k].harmonics[c.harmonic - 1];
                assert!((c.datasheet - sheet * unit).abs() < 1e-12 * c.datasheet);
                let (za, zb) = ((c.sin_coef - a) / c.sin_std, (c.cos_coef - b) / c.cos_std);
                corr.push((za * zb, c.sin_cos_correlation));
                // The amplitude's std: the larger principal std of (A, B),
                // by nalgebra's eigen-decomposition of their covariance.
                let (s, co, r) = (c.sin_std, c.cos_std, c.sin_cos_correlation);
                let cov = nalgebra::Matrix2::new(s * s, r * s * co, r * s * co, co * co);
                let top = cov.symmetric_eigenvalues().max();
                assert!(
                    (c.amplitude_std - top.sqrt()).abs() < 1e-9 * c.amplitude_std,
                    "{} vs {}",
                    c.amplitude_std,
                    top.sqrt()
                );
                assert!(
                    (c.amplitude - c.sin_coef.hypot(c.cos_coef)).abs()
                        < 1e-12 * c.amplitude.max(1e-300)
                );
                flagged += c.exceeds as usize;
                total += 1;
            }
        }
        (z, flagged, total, corr)
    }

    /// With the datasheet's own curves the prediction errors have the
    /// stated variance (mean z² within 15 % of 1: 300 machines × 10
    /// coefficients at ±0.01 mm, one linearisation, 1.05 when written; 200
    /// machines at ±0.5 mm, Gauss–Newton and the fitted machine's joints,
    /// 1.00) and at most 1 % of harmonics are flagged (none when written);
    /// with curves 4× the datasheet's at least half are (234 of 300).
    #[test]
    fn the_curves_posterior_has_its_stated_variance_and_flags_a_misfit() {
        let (z, flagged, total, _) = trial(datasheet(paper_span_mm()), 1.0, 0.01, false, 300, 11);
        // A scale read over a small part of its measuring length: its
        // coefficients' errors are strongly correlated.
        let (_, _, _, corr) = trial(datasheet(2000.0), 1.0, 0.01, false, 300, 14);
        let msq = z.iter().map(|v| v * v).sum::<f64>() / z.len() as f64;
        // The errors of A and B go together as the reported correlation
        // says, harmonic by harmonic (mean of z_A·z_B over the machines
        // against the mean reported correlation; 300 machines: ±0.06).
        let per = corr.len() / 300;
        let mut largest: f64 = 0.0;
        for c in 0..per {
            let (sample, stated) = corr
                .iter()
                .skip(c)
                .step_by(per)
                .fold((0.0, 0.0), |(a, b), (x, y)| (a + x / 300.0, b + y / 300.0));
            assert!(
                (sample - stated).abs() < 0.2,
                "harmonic {c}: {sample} vs {stated}"
            );
            largest = largest.max(stated.abs());
        }
        assert!(
            largest > 0.2,
            "no harmonic with a correlation to test ({largest})"
        );
        assert!((0.85..1.15).contains(&msq), "mean z² = {msq}");
        assert!(flagged * 100 <= total, "{flagged} of {total} flagged");
        // At the paper's ±0.5 mm the converged fit (what `identify` reads
        // the curves from) keeps the stated variance.
        let (z, flagged, total, _) = trial(datasheet(paper_span_mm()), 1.0, 0.5, true, 200, 13);
        let msq = z.iter().map(|v| v * v).sum::<f64>() / z.len() as f64;
        assert!((0.85..1.15).contains(&msq), "mean z² at ±0.5 mm = {msq}");
        assert!(flagged * 100 <= total, "{flagged} of {total} flagged");
        let (_, flagged, total, _) = trial(datasheet(paper_span_mm()), 4.0, 0.01, false, 60, 12);
        assert!(
            flagged * 2 >= total,
            "only {flagged} of {total} flagged at 4×"
        );
    }

    /// Only the datasheet's harmonics of non-zero amplitude are estimated:
    /// none of a sensor read as white noise, none of a zero fraction.
    #[test]
    fn only_the_datasheets_harmonics_are_estimated() {
        // ψ4 from a datasheet, the others the paper's reading of 0.8″, 0.5 µm.
        let paper_axis = |g: f64| scale(0.0, &[], 1.0, g);
        let model = sensors(
            [
                encoder(5.0, &[0.8, 0.0, 0.1], 0.1),
                encoder(0.0, &[], 0.8),
                paper_axis(0.5),
            ],
            [true, false, false],
            3,
        );
        let (geometry, poses) = paper();
        let nominal = Machine::nominal(&geometry);
        let h = design_matrix(&nominal, &poses).unwrap();
        let w = Method::Gls.weighting(&model, &poses.joints).unwrap();
        let solver = LinearSolver::new(&h, &w, 1e-9);
        let resid = DVector::from_fn(h.nrows(), |r, _| 1e-7 * ((r * 13 % 7) as f64 - 3.0));
        let c = sensor_curves(&h, &solver.analysis, &model, &poses.joints, &resid).unwrap();
        let got: Vec<(&str, usize)> = c.iter().map(|c| (c.sensor, c.harmonic)).collect();
        assert_eq!(got, [("psi4_encoder", 1), ("psi4_encoder", 3)]);
        assert!(c
            .iter()
            .all(|c| c.amplitude.is_finite() && c.amplitude_std > 0.0));
        // White-noise sensors: nothing to estimate.
        let white = SensorModel {
            structured: None,
            ..model
        };
        assert!(sensor_curves(&h, &solver.analysis, &white, &poses.joints, &resid).is_none());
    }
}
