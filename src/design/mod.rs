//! Pose-set design: choose N calibration poses from a candidate grid over the
//! workspace to maximise an observability index (O1–O5, see
//! [`crate::identify::analysis::Observability`]).
//!
//! Greedy start (D-optimal with a tiny ridge, so the first few poses, which
//! cannot identify anything yet, are still ranked), then a DETMAX/Fedorov
//! exchange: swap a chosen pose for a candidate while the index improves.
//! The index is computed on the noise-weighted design matrix (rows × 1/σ of
//! their sensor; with `method = "gls"` rows whitened by the sensors' error
//! covariance Σ of the chosen poses, so the index reads the information
//! HᵀΣ⁻¹H) with columns scaled by the candidate set's column norms, so it
//! measures real noise amplification and does not change with the units of
//! the parameters; parameters no candidate can identify are left out.

use crate::config::Config;
use crate::error::{Error, Result};
use crate::identify::analysis::{analyse_named, Observability};
use crate::identify::{stack_differences, Method, Weighting};
use crate::mechanism::tricept::check_pose;
use crate::mechanism::tricept::jacobian::jacobian_at;
use crate::mechanism::tricept::{ErrorJacobian, Joints, N_PARAMS};
use crate::sensors::{ObservationCovariance, SensorCovariance};
use nalgebra::{DMatrix, Vector3};
use rayon::prelude::*;

/// Candidate poses: `layers` planes from top to bottom of the workspace, on
/// each the centre and rings at 0.25, 0.5, 0.75 and 1.0 of the radius with
/// `per_ring` points (rotated by half a step on alternate rings).
pub fn candidate_grid(cfg: &Config, layers: usize, per_ring: usize) -> Vec<Vector3<f64>> {
    let ws = &cfg.workspace;
    let mut out = Vec::new();
    for k in 0..layers {
        let z = ws.layer_z(k, layers);
        out.push(Vector3::new(0.0, 0.0, z));
        for (ri, f) in [0.25, 0.5, 0.75, 1.0].iter().enumerate() {
            for p in 0..per_ring {
                let t = (360.0 * (p as f64 + 0.5 * (ri % 2) as f64) / per_ring as f64).to_radians();
                out.push(Vector3::new(
                    f * ws.radius_mm * t.cos(),
                    f * ws.radius_mm * t.sin(),
                    z,
                ));
            }
        }
    }
    let nominal = cfg.nominal();
    out.retain(|r| check_pose(&nominal, r, cfg.max_tilt_deg).is_ok());
    out
}

/// Everything the index needs about the candidates.
pub struct Designer {
    /// The reference pose's J and each candidate's J, rows weighted, columns
    /// scaled and restricted to the identifiable parameters.
    reference: DMatrix<f64>,
    candidates: Vec<DMatrix<f64>>,
    pub points: Vec<Vector3<f64>>,
    pub active: Vec<usize>,
    pub index: String,
    scale: Vec<f64>,
    row_w: Vector3<f64>,
    /// GLS: the sensors' covariances and the nominal joints of the
    /// reference and of each candidate (Σ depends on the poses together).
    gls: Option<Gls>,
}

/// What GLS whitens a design with.
struct Gls {
    cov: [SensorCovariance; 3],
    reference: Joints,
    candidates: Vec<Joints>,
}

impl Gls {
    /// L⁻¹·h for the poses `joints` (reference first).
    fn whiten(&self, h: DMatrix<f64>, joints: &[Joints]) -> Result<DMatrix<f64>> {
        let w = Weighting::whiten(&ObservationCovariance::new(&self.cov, joints))
            .map_err(Error::Internal)?;
        Ok(w.apply(&h))
    }
}

fn reduce(
    j: &ErrorJacobian,
    row_w: &Vector3<f64>,
    active: &[usize],
    scale: &[f64],
) -> DMatrix<f64> {
    DMatrix::from_fn(3, active.len(), |r, c| {
        j[(r, active[c])] * row_w[r] / scale[c]
    })
}

impl Designer {
    pub fn new(cfg: &Config, points: Vec<Vector3<f64>>, index: &str) -> Result<Self> {
        let nominal = cfg.nominal();
        let jac = |r: &Vector3<f64>| -> Result<ErrorJacobian> {
            let pose = nominal
                .inverse(r)
                .map_err(|e| Error::Internal(e.to_string()))?;
            jacobian_at(&pose).map_err(|e| Error::Internal(e.to_string()))
        };
        let joints = |r: &Vector3<f64>| -> Result<Joints> {
            Ok(nominal
                .inverse(r)
                .map_err(|e| Error::Internal(e.to_string()))?
                .joints)
        };
        let j0 = jac(&cfg.poses[0])?;
        let method = cfg.identification.method;
        let bad = |why: String| Error::config(&cfg.source, format!("identification.method {why}"));
        method.check_sensors(&cfg.sensors).map_err(bad)?;
        let (row_w, gls) = if method == Method::Gls {
            let gls = Gls {
                // As the study that compares the designs weights: the
                // interpolation error white (docs/method.md §18).
                cov: cfg.sensors.white_interpolation().covariances(),
                reference: joints(&cfg.poses[0])?,
                candidates: points.iter().map(joints).collect::<Result<_>>()?,
            };
            method
                .weighting(&cfg.sensors, &[gls.reference])
                .map_err(bad)?;
            (Vector3::new(1.0, 1.0, 1.0), Some(gls))
        } else {
            let w = match Method::Wls.weighting(&cfg.sensors, &[Joints::default(); 2]) {
                Ok(Weighting::Rows(w)) => w,
                Ok(Weighting::Whiten(_)) => unreachable!("WLS weights rows"),
                Err(why) => return Err(bad(why)),
            };
            (Vector3::new(w[0], w[1], w[2]), None)
        };
        let cand: Vec<ErrorJacobian> = points.iter().map(jac).collect::<Result<_>>()?;
        // Full candidate design: which parameters can be identified at all,
        // and the column scale.
        let mut h = stack_differences(&j0, &cand);
        for (i, mut row) in h.row_iter_mut().enumerate() {
            row *= row_w[i % 3];
        }
        if let Some(g) = &gls {
            let all: Vec<Joints> = std::iter::once(g.reference)
                .chain(g.candidates.iter().copied())
                .collect();
            h = g.whiten(h, &all)?;
        }
        let a = analyse_named(
            &h,
            cfg.identification.rank_tolerance,
            &crate::mechanism::tricept::PARAM_NAMES,
        );
        let active: Vec<usize> = (0..N_PARAMS).filter(|&c| a.identifiable[c]).collect();
        let scale: Vec<f64> = active
            .iter()
            .map(|&c| a.column_norms[c] / (cand.len() as f64).sqrt())
            .collect();
        let reference = reduce(&j0, &row_w, &active, &scale);
        let candidates = cand
            .iter()
            .map(|j| reduce(j, &row_w, &active, &scale))
            .collect();
        Ok(Designer {
            reference,
            candidates,
            points,
            active,
            index: index.to_string(),
            scale,
            row_w,
            gls,
        })
    }

    fn stack(&self, chosen: &[usize]) -> DMatrix<f64> {
        let blocks: Vec<&DMatrix<f64>> = chosen.iter().map(|&c| &self.candidates[c]).collect();
        let h = stack_differences(&self.reference, &blocks);
        match &self.gls {
            Some(g) => {
                let joints: Vec<Joints> = std::iter::once(g.reference)
                    .chain(chosen.iter().map(|&c| g.candidates[c]))
                    .collect();
                // Σ of these poses was positive definite for all of them.
                g.whiten(h, &joints)
                    .expect("a principal block of a positive definite Σ is positive definite")
            }
            None => h,
        }
    }

    /// The chosen observability index of the design (reference + chosen).
    pub fn value(&self, chosen: &[usize]) -> f64 {
        let h = self.stack(chosen);
        let sv = h.singular_values();
        let mut sv: Vec<f64> = sv.iter().cloned().collect();
        sv.sort_by(|a, b| b.total_cmp(a));
        if sv.len() < self.active.len() {
            return 0.0;
        }
        Observability::from_singular_values(&sv, h.nrows())
            .get(&self.index)
            .unwrap_or(0.0)
    }

    /// log det(HᵀH + εI): ranks designs that cannot identify everything yet.
    fn ridge_logdet(&self, chosen: &[usize]) -> f64 {
        let h = self.stack(chosen);
        let sv = h.singular_values();
        let mut s = 0.0;
        for k in 0..self.active.len() {
            let v = if k < sv.len() { sv[k] } else { 0.0 };
            s += (v * v + 1e-9).ln();
        }
        s
    }

    /// Greedy start, then exchange until no swap improves the index.
    /// Returns the chosen candidate indices (the reference is not among them)
    /// and the number of exchange passes.
    pub fn design(&self, count: usize, max_passes: usize) -> (Vec<usize>, usize) {
        let n = self.candidates.len();
        let mut chosen: Vec<usize> = Vec::with_capacity(count);
        while chosen.len() < count.min(n) {
            let best = (0..n)
                .into_par_iter()
                .filter(|c| !chosen.contains(c))
                .map(|c| {
                    let mut t = chosen.clone();
                    t.push(c);
                    (self.ridge_logdet(&t), c)
                })
                .reduce(
                    || (f64::NEG_INFINITY, usize::MAX),
                    |a, b| {
                        if b.0 > a.0 || (b.0 == a.0 && b.1 < a.1) {
                            b
                        } else {
                            a
                        }
                    },
                );
            chosen.push(best.1);
        }
        let mut current = self.value(&chosen);
        let mut passes = 0;
        while passes < max_passes {
            passes += 1;
            let pairs: Vec<(usize, usize)> = (0..chosen.len())
                .flat_map(|i| (0..n).filter(|c| !chosen.contains(c)).map(move |c| (i, c)))
                .collect();
            let best = pairs
                .par_iter()
                .map(|&(i, c)| {
                    let mut t = chosen.clone();
                    t[i] = c;
                    (self.value(&t), i, c)
                })
                .reduce(
                    || (f64::NEG_INFINITY, usize::MAX, usize::MAX),
                    |a, b| {
                        if b.0 > a.0 || (b.0 == a.0 && (b.1, b.2) < (a.1, a.2)) {
                            b
                        } else {
                            a
                        }
                    },
                );
            if best.0 > current * (1.0 + 1e-9) && best.1 != usize::MAX {
                chosen[best.1] = best.2;
                current = best.0;
            } else {
                break;
            }
        }
        (chosen, passes)
    }

    /// The index of an arbitrary pose list (first = reference) under the same
    /// weighting and scaling.
    pub fn value_of(&self, cfg: &Config, poses: &[Vector3<f64>]) -> Result<f64> {
        let nominal = cfg.nominal();
        let reduced = |r: &Vector3<f64>| -> Result<DMatrix<f64>> {
            let pose = nominal
                .inverse(r)
                .map_err(|e| Error::Internal(e.to_string()))?;
            let j = jacobian_at(&pose).map_err(|e| Error::Internal(e.to_string()))?;
            Ok(reduce(&j, &self.row_w, &self.active, &self.scale))
        };
        let j0 = reduced(&poses[0])?;
        let p = self.active.len();
        let blocks: Vec<DMatrix<f64>> = poses[1..].iter().map(reduced).collect::<Result<_>>()?;
        let mut h = stack_differences(&j0, &blocks);
        if let Some(g) = &self.gls {
            let joints: Vec<Joints> = poses
                .iter()
                .map(|r| {
                    nominal
                        .inverse(r)
                        .map(|p| p.joints)
                        .map_err(|e| Error::Internal(e.to_string()))
                })
                .collect::<Result<_>>()?;
            h = g.whiten(h, &joints)?;
        }
        let mut sv: Vec<f64> = h.singular_values().iter().cloned().collect();
        sv.sort_by(|a, b| b.total_cmp(a));
        if sv.len() < p {
            return Ok(0.0);
        }
        Ok(Observability::from_singular_values(&sv, h.nrows())
            .get(&self.index)
            .unwrap_or(0.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::parse_raw;
    use crate::sensors::observation_covariance;

    /// With `method = "gls"` the index is of the information HᵀΣ⁻¹H of the
    /// chosen poses: its singular values are the square roots of that
    /// matrix's eigenvalues, Σ⁻¹ formed outright (an independent route).
    #[test]
    fn gls_designs_read_the_information_with_the_covariance() {
        let text = "[sensors.encoder]\naccuracy_arcsec = 5.0\nharmonics = [0.8, 0.2]\nnoise_arcsec = 0.1\n[sensors.scale]\naccuracy_um = 2.0\nnoise_um = 0.05\n[identification]\nmethod = \"gls\"\n";
        let cfg = Config::from_raw(parse_raw(text, "t").unwrap(), "t").unwrap();
        let points = candidate_grid(&cfg, 3, 6);
        let d = Designer::new(&cfg, points.clone(), "o1").unwrap();
        assert!(d.gls.is_some());
        let chosen = [0usize, 5, 11, 20, 27, 33, 40, 47, 52];
        let nominal = cfg.nominal();
        let pose = |r: &Vector3<f64>| nominal.inverse(r).unwrap();
        let reference = pose(&cfg.poses[0]);
        let others: Vec<_> = chosen.iter().map(|&c| pose(&points[c])).collect();
        // H of the chosen poses, the designer's columns and scale.
        let j0 = jacobian_at(&reference).unwrap();
        let js: Vec<ErrorJacobian> = others.iter().map(|p| jacobian_at(p).unwrap()).collect();
        let full = stack_differences(&j0, &js);
        let h = DMatrix::from_fn(full.nrows(), d.active.len(), |r, c| {
            full[(r, d.active[c])] / d.scale[c]
        });
        let joints: Vec<Joints> = std::iter::once(reference.joints)
            .chain(others.iter().map(|p| p.joints))
            .collect();
        let sigma =
            observation_covariance(&cfg.sensors.white_interpolation().covariances(), &joints);
        let info = h.transpose() * sigma.try_inverse().unwrap() * &h;
        let mut sv: Vec<f64> = info
            .symmetric_eigenvalues()
            .iter()
            .map(|e| e.max(0.0).sqrt())
            .collect();
        sv.sort_by(|a, b| b.total_cmp(a));
        let want = Observability::from_singular_values(&sv, h.nrows())
            .get("o1")
            .unwrap();
        let got = d.value(&chosen);
        assert!((got - want).abs() < 1e-6 * want, "{got} vs {want}");
        // Not the WLS index of the same poses.
        let wls = Config::from_raw(
            parse_raw(&text.replace("\"gls\"", "\"wls\""), "t").unwrap(),
            "t",
        )
        .unwrap();
        let dw = Designer::new(&wls, points, "o1").unwrap();
        assert!((dw.value(&chosen) - got).abs() > 1e-3 * got);
    }
}
