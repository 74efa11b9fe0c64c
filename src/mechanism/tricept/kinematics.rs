//! Exact kinematics of the 3-DOF module (docs/method.md §2; paper eq. 1).
//!
//! The passive UP limb fixes the platform orientation R = Rx(ψ4)·Ry(θ4) and
//! position r = q4·w4 with w4 = R·ez. Limb i closes the loop
//! r = bi + qi·wi − R·a0i, so qi = |q4·w4 + R·a0i − bi|.
//! Forward kinematics solves the three closure equations for (ψ4, θ4, q4)
//! by Newton's method with the analytic Jacobian, whose rows are
//! [ex·(pi×ui), e'·(pi×ui), ui·w4] with pi = R·(q4·ez + a0i), ui the unit leg
//! vector and e' = Rx(ψ4)·ey — at a solution this is the paper's matrix J1 of
//! eq. 9 (pi×wi = bi×wi).

use super::geometry::Machine;
use crate::error::KinematicsError;
use nalgebra::{Matrix3, Vector3};

/// Newton iterations allowed before forward kinematics gives up.
pub const MAX_NEWTON_ITERATIONS: usize = 40;
/// Closure residual (mm) at which forward kinematics has converged.
pub const NEWTON_TOLERANCE_MM: f64 = 1e-11;
/// Column-normalised |det| below which the Jacobian counts as singular.
const SINGULAR_DET: f64 = 1e-9;

/// The passive limb's joint values: what the two encoders and the scale read.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Joints {
    pub psi_rad: f64,
    pub theta_rad: f64,
    pub q4_mm: f64,
}

/// One row of a readings file: the commanded target of O' and what the
/// controller reports.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reading {
    pub target: Vector3<f64>,
    pub joints: Joints,
}

impl From<Joints> for Vector3<f64> {
    /// [`Joints::as_vector`].
    #[inline]
    fn from(j: Joints) -> Self {
        j.as_vector()
    }
}

impl Joints {
    pub fn as_vector(&self) -> Vector3<f64> {
        Vector3::new(self.psi_rad, self.theta_rad, self.q4_mm)
    }
    pub fn from_vector(v: &Vector3<f64>) -> Self {
        Joints {
            psi_rad: v.x,
            theta_rad: v.y,
            q4_mm: v.z,
        }
    }
}

/// R = Rx(ψ)·Ry(θ).
#[inline]
pub fn rotation(psi: f64, theta: f64) -> Matrix3<f64> {
    let (sp, cp) = psi.sin_cos();
    let (st, ct) = theta.sin_cos();
    Matrix3::new(ct, 0.0, st, sp * st, cp, -sp * ct, -cp * st, sp, cp * ct)
}

/// O' = q4·w4 for the given joints.
#[inline]
pub fn platform_position(j: &Joints) -> Vector3<f64> {
    let (sp, cp) = j.psi_rad.sin_cos();
    let (st, ct) = j.theta_rad.sin_cos();
    j.q4_mm * Vector3::new(st, -sp * ct, cp * ct)
}

/// Inverse kinematics of the UP limb alone: q4 = |r|, w4 = r/q4,
/// θ4 = asin(w4x), ψ4 = atan2(−w4y, w4z).
pub fn passive_joints(r: &Vector3<f64>) -> Result<Joints, KinematicsError> {
    let unreachable = |reason: &str| KinematicsError::Unreachable {
        x: r.x,
        y: r.y,
        z: r.z,
        reason: reason.to_string(),
    };
    if !(r.x.is_finite() && r.y.is_finite() && r.z.is_finite()) {
        return Err(unreachable("a coordinate is not a finite number"));
    }
    if r.z <= 0.0 {
        return Err(unreachable(
            "the platform must lie in front of the base (z > 0)",
        ));
    }
    let q4 = r.norm();
    let w4 = r / q4;
    Ok(Joints {
        psi_rad: (-w4.y).atan2(w4.z),
        theta_rad: w4.x.clamp(-1.0, 1.0).asin(),
        q4_mm: q4,
    })
}

/// A configuration of a machine with everything the error model needs.
#[derive(Debug, Clone, Copy)]
pub struct Pose {
    pub joints: Joints,
    pub rot: Matrix3<f64>,
    pub w4: Vector3<f64>,
    /// pi = R·(q4·ez + a0i) = O' + R·a0i, the sphere centres in the base frame.
    pub p: [Vector3<f64>; 3],
    /// Geometric leg lengths |pi − bi|, mm.
    pub legs_mm: [f64; 3],
    /// Unit leg vectors wi.
    pub w: [Vector3<f64>; 3],
    /// The two Hooke axes in the base frame at this configuration (x and
    /// Rx(ψ4)·y for ideal axes): the columns of Jθ in eq. 8.
    pub e_psi: Vector3<f64>,
    pub e_theta: Vector3<f64>,
}

impl Machine {
    /// Rotation of the UP limb and the two Hooke axes in the base frame.
    #[inline]
    pub fn hooke(&self, psi: f64, theta: f64) -> (Matrix3<f64>, Vector3<f64>, Vector3<f64>) {
        match &self.second {
            None => {
                let (sp, cp) = psi.sin_cos();
                (
                    rotation(psi, theta),
                    Vector3::x(),
                    Vector3::new(0.0, cp, sp),
                )
            }
            Some(s) => {
                let r1 = nalgebra::Rotation3::from_axis_angle(&s.axis1, psi);
                let r2 = nalgebra::Rotation3::from_axis_angle(&s.axis2, theta);
                (
                    (r1 * r2).into_inner(),
                    s.axis1.into_inner(),
                    r1 * s.axis2.into_inner(),
                )
            }
        }
    }

    /// Platform orientation for a given UP-limb rotation (guide twist applied).
    #[inline]
    fn platform_rotation(&self, hooke: &Matrix3<f64>) -> Matrix3<f64> {
        match &self.second {
            None => *hooke,
            Some(s) => hooke * s.twist,
        }
    }

    /// O' = q4·w4 for the given joints of this machine.
    pub fn position(&self, j: &Joints) -> Vector3<f64> {
        match self.second {
            None => platform_position(j),
            Some(_) => j.q4_mm * self.hooke(j.psi_rad, j.theta_rad).0.column(2).into_owned(),
        }
    }

    /// Everything about the configuration with the given passive joints.
    pub fn pose(&self, j: &Joints) -> Pose {
        let (hooke, e_psi, e_theta) = self.hooke(j.psi_rad, j.theta_rad);
        let rot = self.platform_rotation(&hooke);
        let w4 = hooke.column(2).into_owned();
        let r = j.q4_mm * w4;
        let mut p = [Vector3::zeros(); 3];
        let mut legs_mm = [0.0; 3];
        let mut w = [Vector3::zeros(); 3];
        for i in 0..3 {
            p[i] = r + rot * self.a[i];
            let v = p[i] - self.b[i];
            legs_mm[i] = v.norm();
            w[i] = v / legs_mm[i];
        }
        Pose {
            joints: *j,
            rot,
            w4,
            p,
            legs_mm,
            w,
            e_psi,
            e_theta,
        }
    }

    /// Exact inverse kinematics: the configuration that puts O' at `r`.
    /// (With second-class errors, by Newton: [`inverse_second_class`].)
    pub fn inverse(&self, r: &Vector3<f64>) -> Result<Pose, KinematicsError> {
        let pose = match self.second {
            None => self.pose(&passive_joints(r)?),
            Some(_) => inverse_second_class(self, r)?,
        };
        if pose.legs_mm.iter().any(|l| l.is_nan() || *l <= 1e-9) {
            return Err(KinematicsError::Unreachable {
                x: r.x,
                y: r.y,
                z: r.z,
                reason: "a leg would have zero length".into(),
            });
        }
        Ok(pose)
    }

    /// Leg lengths to command so that this machine puts O' at `r`
    /// (geometric length − Δqi).
    pub fn commands(&self, r: &Vector3<f64>) -> Result<[f64; 3], KinematicsError> {
        let pose = self.inverse(r)?;
        Ok([
            pose.legs_mm[0] - self.dq[0],
            pose.legs_mm[1] - self.dq[1],
            pose.legs_mm[2] - self.dq[2],
        ])
    }

    /// Closure residuals fi = |pi − bi| − (q_cmd,i + Δqi) and their analytic
    /// Jacobian with respect to (ψ4, θ4, q4).
    #[inline]
    pub fn closure(&self, q_cmd: &[f64; 3], j: &Joints) -> (Vector3<f64>, Matrix3<f64>) {
        let (hooke, e_psi, e_theta) = self.hooke(j.psi_rad, j.theta_rad);
        let rot = self.platform_rotation(&hooke);
        let w4 = hooke.column(2).into_owned();
        let r = j.q4_mm * w4;
        let mut f = Vector3::zeros();
        let mut m = Matrix3::zeros();
        for i in 0..3 {
            let p = r + rot * self.a[i];
            let v = p - self.b[i];
            let len = v.norm();
            let u = v / len;
            f[i] = len - (q_cmd[i] + self.dq[i]);
            let pxu = p.cross(&u);
            m[(i, 0)] = e_psi.dot(&pxu);
            m[(i, 1)] = e_theta.dot(&pxu);
            m[(i, 2)] = u.dot(&w4);
        }
        (f, m)
    }

    /// Exact forward kinematics: the passive joints this machine takes when
    /// its legs are commanded to `q_cmd`, by Newton from `guess`.
    pub fn forward(&self, q_cmd: &[f64; 3], guess: &Joints) -> Result<Joints, KinematicsError> {
        let mut x = guess.as_vector();
        let mut residual = f64::INFINITY;
        for _ in 0..MAX_NEWTON_ITERATIONS {
            let j = Joints::from_vector(&x);
            let (f, m) = self.closure(q_cmd, &j);
            residual = f.amax();
            if !residual.is_finite() {
                break;
            }
            if residual < NEWTON_TOLERANCE_MM {
                return Ok(j);
            }
            match newton_step(&m, &f) {
                Some(step) => x -= step,
                None => {
                    let det_n = normalized_det(&m);
                    return Err(KinematicsError::Singular {
                        psi_deg: j.psi_rad.to_degrees(),
                        theta_deg: j.theta_rad.to_degrees(),
                        q4_mm: j.q4_mm,
                        condition: 1.0 / det_n.abs().max(f64::MIN_POSITIVE),
                    });
                }
            }
        }
        Err(KinematicsError::NotConverged {
            iterations: MAX_NEWTON_ITERATIONS,
            residual_mm: residual,
        })
    }
}

/// m⁻¹ by cofactors, or None when m is singular by [`normalized_det`]'s
/// measure (|det| ≤ 1e-9 once the columns are scaled to unit norm, tested
/// on squares so that no square root is taken).
#[inline]
pub(crate) fn invert3(m: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    let c0 = m.column(0).cross(&m.column(1));
    let c1 = m.column(1).cross(&m.column(2));
    let c2 = m.column(2).cross(&m.column(0));
    let det = m.column(2).dot(&c0);
    let norms2 =
        m.column(0).norm_squared() * m.column(1).norm_squared() * m.column(2).norm_squared();
    // NaN entries fail the comparison and count as singular.
    let regular = det * det > SINGULAR_DET * SINGULAR_DET * norms2;
    if !regular {
        return None;
    }
    // The rows of m⁻¹ are the cross products of m's columns over det.
    Some(Matrix3::from_rows(&[c1.transpose(), c2.transpose(), c0.transpose()]) * (1.0 / det))
}

/// The Newton step m⁻¹·f (None when m is singular).
#[inline]
fn newton_step(m: &Matrix3<f64>, f: &Vector3<f64>) -> Option<Vector3<f64>> {
    invert3(m).map(|inv| inv * f)
}

/// det of the matrix with unit-norm columns: 1 for orthogonal columns, 0 at a
/// singularity, independent of the columns' units.
pub fn normalized_det(m: &Matrix3<f64>) -> f64 {
    let mut n = *m;
    for c in 0..3 {
        let norm = n.column(c).norm();
        if norm == 0.0 {
            return 0.0;
        }
        n.column_mut(c).scale_mut(1.0 / norm);
    }
    n.determinant()
}

/// Exact inverse kinematics of a machine with second-class errors: the
/// joints that put O′ at `r` (Newton on O′ = q4·w4 from the ideal limb's
/// joints; the derivatives are axis × w4 for the two Hooke rotations and
/// w4 for the guide).
fn inverse_second_class(m: &Machine, r: &Vector3<f64>) -> Result<Pose, KinematicsError> {
    let mut x = passive_joints(r)?.as_vector();
    for _ in 0..30 {
        let j = Joints::from_vector(&x);
        let (hooke, e_psi, e_theta) = m.hooke(j.psi_rad, j.theta_rad);
        let w4 = hooke.column(2).into_owned();
        let f = j.q4_mm * w4 - r;
        if f.amax() < 1e-11 {
            return Ok(m.pose(&j));
        }
        let jac =
            Matrix3::from_columns(&[j.q4_mm * e_psi.cross(&w4), j.q4_mm * e_theta.cross(&w4), w4]);
        let inv = invert3(&jac).ok_or(KinematicsError::Unreachable {
            x: r.x,
            y: r.y,
            z: r.z,
            reason: "the UP limb is singular there".into(),
        })?;
        x -= inv * f;
    }
    Err(KinematicsError::NotConverged {
        iterations: 30,
        residual_mm: f64::NAN,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::tricept::{Geometry, Machine};

    #[test]
    fn rotation_matches_definition() {
        let (psi, theta) = (0.3, -0.2);
        let rx = nalgebra::Rotation3::from_axis_angle(&Vector3::x_axis(), psi);
        let ry = nalgebra::Rotation3::from_axis_angle(&Vector3::y_axis(), theta);
        let r = (rx * ry).into_inner();
        assert!((rotation(psi, theta) - r).amax() < 1e-15);
    }

    #[test]
    fn passive_ik_roundtrip() {
        let r = Vector3::new(120.0, -250.0, 700.0);
        let j = passive_joints(&r).unwrap();
        assert!((platform_position(&j) - r).norm() < 1e-12);
    }

    #[test]
    fn fk_inverts_ik_at_centre() {
        let m = Machine::nominal(&Geometry::paper());
        let r = Vector3::new(0.0, 0.0, 750.0);
        let pose = m.inverse(&r).unwrap();
        let guess = Joints {
            psi_rad: 0.05,
            theta_rad: -0.05,
            q4_mm: 700.0,
        };
        let j = m.forward(&pose.legs_mm, &guess).unwrap();
        assert!((platform_position(&j) - r).norm() < 1e-9);
    }

    #[test]
    fn unreachable_below_base() {
        let m = Machine::nominal(&Geometry::paper());
        assert!(matches!(
            m.inverse(&Vector3::new(0.0, 0.0, -5.0)),
            Err(KinematicsError::Unreachable { .. })
        ));
        assert!(m.inverse(&Vector3::new(f64::NAN, 0.0, 5.0)).is_err());
    }
}

#[cfg(test)]
mod second_class_tests {
    use super::*;
    use crate::mechanism::tricept::geometry::SecondClass;
    use crate::mechanism::tricept::{ErrorVector, Geometry, Machine, PAPER_ERRORS_MM};

    #[test]
    fn closure_jacobian_matches_finite_differences_with_second_class_errors() {
        let g = Geometry::paper();
        let m = Machine {
            second: Some(SecondClass::from_angles_deg(0.3, -0.2, 0.4, 0.5)),
            ..Machine::with_errors(&g, &ErrorVector::from_row_slice(&PAPER_ERRORS_MM))
        };
        let j = Joints {
            psi_rad: 0.21,
            theta_rad: -0.13,
            q4_mm: 730.0,
        };
        let q = [700.0, 710.0, 690.0];
        let (_, jac) = m.closure(&q, &j);
        let h = 1e-6;
        for c in 0..3 {
            let mut xp = j.as_vector();
            let mut xm = j.as_vector();
            xp[c] += h;
            xm[c] -= h;
            let fd = (m.closure(&q, &Joints::from_vector(&xp)).0
                - m.closure(&q, &Joints::from_vector(&xm)).0)
                / (2.0 * h);
            let col = jac.column(c).into_owned();
            assert!(
                (fd - col).norm() <= 1e-6 * col.norm().max(1.0),
                "column {c}: {fd:?} vs {col:?}"
            );
        }
        // FK converges and the result closes every loop.
        let nominal = Machine::nominal(&g)
            .inverse(&Vector3::new(100.0, 50.0, 720.0))
            .unwrap();
        let sol = m.forward(&nominal.legs_mm, &nominal.joints).unwrap();
        assert!(m.closure(&nominal.legs_mm, &sol).0.amax() < 1e-10);
        // Ideal axes reproduce the closed-form rotation.
        let ideal = Machine {
            second: Some(SecondClass::from_angles_deg(0.0, 0.0, 0.0, 0.0)),
            ..m
        };
        let (r, _, _) = ideal.hooke(0.3, -0.2);
        assert!((r - rotation(0.3, -0.2)).amax() < 1e-15);
    }

    #[test]
    fn invert3_inverts_and_refuses_exactly_the_singular_matrices() {
        let m = Matrix3::new(2.0, -1.0, 0.5, 0.3, 4.0, -2.0, 1.0, 0.2, 3.0);
        let inv = invert3(&m).unwrap();
        assert!((inv * m - Matrix3::identity()).amax() < 1e-14);
        assert!((inv - m.try_inverse().unwrap()).amax() < 1e-14);
        // Columns of very different lengths: the measure is scale-free.
        let scaled =
            Matrix3::from_columns(&[m.column(0) * 1e6, m.column(1) * 1e-3, m.column(2).into()]);
        assert!((invert3(&scaled).unwrap() * scaled - Matrix3::identity()).amax() < 1e-9);
        // The third column tilted out of the plane of the first two by an
        // angle t: unit columns give a normalised det of about t, singular
        // below 1e-9.
        for (t, regular) in [(3e-9_f64, true), (3e-10, false), (0.0, false)] {
            let a = Vector3::new(1.0, 0.0, 0.0);
            let b = Vector3::new(0.0, 1.0, 0.0);
            let c = Vector3::new(0.6, 0.8 * (1.0 - t * t).sqrt(), t) * 5.0;
            let m = Matrix3::from_columns(&[a * 3.0, b * 0.2, c]);
            assert_eq!(invert3(&m).is_some(), regular, "t = {t}");
            assert_eq!(normalized_det(&m).abs() > 1e-9, regular, "t = {t}");
        }
        assert!(invert3(&Matrix3::zeros()).is_none());
    }
}
