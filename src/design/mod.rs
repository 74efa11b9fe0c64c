//! Pose-set design: choose N calibration poses from a candidate grid over the
//! workspace to maximise an observability index (O1–O5, see
//! [`crate::identify::analysis::Observability`]), for any [`Kinematic`]
//! topology whose targets are tool-point positions.
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

use crate::error::{Error, Result};
use crate::identify::analysis::{analyse_named, Observability};
use crate::identify::{stack_differences, Method, Weighting};
use crate::mechanism::{Homed, Kinematic, Workspace};
use crate::sensors::{ObservationCovariance, SensorCovariance, SensorModel};
use nalgebra::{DMatrix, SMatrix, SVector, Vector3};
use rayon::prelude::*;

/// Candidate poses: `layers` planes from top to bottom of the workspace
/// `ws`, on each the centre and rings at 0.25, 0.5, 0.75 and 1.0 of the
/// radius with `per_ring` points (rotated by half a step on alternate
/// rings); those the nominal machine of `mech` reaches within
/// `max_tilt_deg`.
pub fn candidate_grid<T: Kinematic<P, R>, const P: usize, const R: usize>(
    mech: &Homed<T, P, R>,
    (ws, max_tilt_deg): (&Workspace, f64),
    layers: usize,
    per_ring: usize,
) -> Vec<Vector3<f64>> {
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
    out.retain(|r| T::check_pose(mech.nominal(), r, max_tilt_deg).is_ok());
    out
}

/// How a design weights its rows: the config's sensors and estimator, its
/// rank tolerance, and the config file named in a refusal.
#[derive(Debug, Clone, Copy)]
pub struct Weights<'a, const R: usize> {
    pub sensors: &'a SensorModel<R>,
    pub method: Method,
    pub rank_tolerance: f64,
    pub source: &'a str,
}

/// Everything the index needs about the candidates.
pub struct Designer<const R: usize> {
    /// The reference pose's J and each candidate's J, rows weighted, columns
    /// scaled and restricted to the identifiable parameters.
    reference: DMatrix<f64>,
    candidates: Vec<DMatrix<f64>>,
    pub points: Vec<Vector3<f64>>,
    pub active: Vec<usize>,
    pub index: String,
    scale: Vec<f64>,
    row_w: SVector<f64, R>,
    /// GLS: the sensors' covariances and the nominal readings of the
    /// reference and of each candidate (Σ depends on the poses together).
    gls: Option<Gls<R>>,
}

/// What GLS whitens a design with.
struct Gls<const R: usize> {
    cov: [SensorCovariance; R],
    reference: SVector<f64, R>,
    candidates: Vec<SVector<f64, R>>,
}

impl<const R: usize> Gls<R> {
    /// L⁻¹·h for the poses whose readings are `x` (reference first).
    fn whiten(&self, h: DMatrix<f64>, x: &[SVector<f64, R>]) -> Result<DMatrix<f64>> {
        let w = Weighting::whiten(&ObservationCovariance::new(&self.cov, x))
            .map_err(Error::Internal)?;
        Ok(w.apply(&h))
    }
}

fn reduce<const P: usize, const R: usize>(
    j: &SMatrix<f64, R, P>,
    row_w: &SVector<f64, R>,
    active: &[usize],
    scale: &[f64],
) -> DMatrix<f64> {
    DMatrix::from_fn(R, active.len(), |r, c| {
        j[(r, active[c])] * row_w[r] / scale[c]
    })
}

/// The nominal machine's error Jacobian (R × P) at target `r`, and its
/// readings there.
fn jacobian<T: Kinematic<P, R>, const P: usize, const R: usize>(
    mech: &Homed<T, P, R>,
    r: &Vector3<f64>,
) -> Result<(SMatrix<f64, R, P>, SVector<f64, R>)> {
    let internal = |e: crate::error::KinematicsError| Error::Internal(e.to_string());
    let (_, x) = T::command(mech.nominal(), r).map_err(internal)?;
    Ok((T::error_jacobian(mech.nominal(), &x).map_err(internal)?, x))
}

impl<const R: usize> Designer<R> {
    /// The designer of `points` for `mech`, with `reference` (the
    /// config's reference pose) first in every design.
    pub fn new<T: Kinematic<P, R>, const P: usize>(
        mech: &Homed<T, P, R>,
        weights: Weights<R>,
        reference: &Vector3<f64>,
        (points, index): (Vec<Vector3<f64>>, &str),
    ) -> Result<Self> {
        let (j0, x0) = jacobian(mech, reference)?;
        let method = weights.method;
        let sensors = weights.sensors;
        let bad =
            |why: String| Error::config(weights.source, format!("identification.method {why}"));
        method.check_sensors(sensors).map_err(bad)?;
        let mut cand = Vec::with_capacity(points.len());
        let mut readings = Vec::with_capacity(points.len());
        for r in &points {
            let (j, x) = jacobian(mech, r)?;
            cand.push(j);
            readings.push(x);
        }
        let (row_w, gls) = if method == Method::Gls {
            let gls = Gls {
                // As the study that compares the designs weights: the
                // interpolation error white (docs/method.md §18).
                cov: sensors.white_interpolation().covariances(),
                reference: x0,
                candidates: readings,
            };
            method.weighting(sensors, &[gls.reference]).map_err(bad)?;
            (SVector::repeat(1.0), Some(gls))
        } else {
            let w = match Method::Wls.weighting(sensors, &[SVector::<f64, R>::zeros(); 2]) {
                Ok(Weighting::Rows(w)) => w,
                Ok(Weighting::Whiten(_)) => unreachable!("WLS weights rows"),
                Err(why) => return Err(bad(why)),
            };
            (SVector::from_fn(|k, _| w[k]), None)
        };
        // Full candidate design: which parameters can be identified at all,
        // and the column scale.
        let mut h = stack_differences(&j0, &cand);
        for (i, mut row) in h.row_iter_mut().enumerate() {
            row *= row_w[i % R];
        }
        if let Some(g) = &gls {
            let all: Vec<SVector<f64, R>> = std::iter::once(g.reference)
                .chain(g.candidates.iter().copied())
                .collect();
            h = g.whiten(h, &all)?;
        }
        let a = analyse_named(&h, weights.rank_tolerance, T::ERROR_NAMES);
        let active: Vec<usize> = (0..P).filter(|&c| a.identifiable[c]).collect();
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
                let x: Vec<SVector<f64, R>> = std::iter::once(g.reference)
                    .chain(chosen.iter().map(|&c| g.candidates[c]))
                    .collect();
                // Σ of these poses was positive definite for all of them.
                g.whiten(h, &x)
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
    pub fn value_of<T: Kinematic<P, R>, const P: usize>(
        &self,
        mech: &Homed<T, P, R>,
        poses: &[Vector3<f64>],
    ) -> Result<f64> {
        let mut blocks = Vec::with_capacity(poses.len());
        let mut x = Vec::with_capacity(poses.len());
        for r in poses {
            let (j, xr) = jacobian(mech, r)?;
            blocks.push(reduce(&j, &self.row_w, &self.active, &self.scale));
            x.push(xr);
        }
        let p = self.active.len();
        let mut h = stack_differences(&blocks[0], &blocks[1..]);
        if let Some(g) = &self.gls {
            h = g.whiten(h, &x)?;
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
    use crate::config::{parse_raw, Config};
    use crate::mechanism::tricept::jacobian::jacobian_at;
    use crate::mechanism::tricept::{ErrorJacobian, Joints};

    /// The design of `points` for `cfg`, as design-poses makes it.
    fn designer(cfg: &Config, points: Vec<Vector3<f64>>) -> Designer<3> {
        let weights = Weights {
            sensors: &cfg.sensors,
            method: cfg.identification.method,
            rank_tolerance: cfg.identification.rank_tolerance,
            source: &cfg.source,
        };
        Designer::new(&cfg.homed(), weights, &cfg.poses[0], (points, "o1")).unwrap()
    }
    use crate::sensors::observation_covariance;

    /// With `method = "gls"` the index is of the information HᵀΣ⁻¹H of the
    /// chosen poses: its singular values are the square roots of that
    /// matrix's eigenvalues, Σ⁻¹ formed outright (an independent route).
    #[test]
    fn gls_designs_read_the_information_with_the_covariance() {
        let text = "[sensors.encoder]\naccuracy_arcsec = 5.0\nharmonics = [0.8, 0.2]\nnoise_arcsec = 0.1\n[sensors.scale]\naccuracy_um = 2.0\nnoise_um = 0.05\n[identification]\nmethod = \"gls\"\n";
        let cfg = Config::from_raw(parse_raw(text, "t").unwrap(), "t").unwrap();
        let points = candidate_grid(&cfg.homed(), (&cfg.workspace, cfg.max_tilt_deg), 3, 6);
        let d = designer(&cfg, points.clone());
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
        let dw = designer(&wls, points);
        assert!((dw.value(&chosen) - got).abs() > 1e-3 * got);
    }
}
