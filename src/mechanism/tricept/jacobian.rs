//! First-order error model (docs/method.md §4; paper eqs. 2–9).
//!
//! Each limb gives (eq. 7)
//!   wiᵀw4·Δq4 + (bi×wi)ᵀ·Jθ·[Δψ4, Δθ4]ᵀ = wiᵀΔbi + Δqi − wiᵀR·Δa0i,
//! stacked as M·δ = D·Δε, so δ = J·Δε with J = M⁻¹·D (the paper's J1·J2),
//! here reduced to the 15 independent errors of §3 by the frame gauge.

use super::geometry::Machine;
use super::kinematics::{normalized_det, Joints, Pose};
use super::params::N_PARAMS;
use crate::error::KinematicsError;
use nalgebra::{Matrix3, SMatrix};

/// J: d(ψ4 rad, θ4 rad, q4 mm) / d(15 errors, mm).
pub type ErrorJacobian = SMatrix<f64, 3, N_PARAMS>;

/// M of eq. 9: rows [(bi×wi)ᵀJθ, wiᵀw4] (with pi×wi, equal at a solution).
pub fn passive_matrix(pose: &Pose) -> Matrix3<f64> {
    let mut m = Matrix3::zeros();
    for i in 0..3 {
        let pxw = pose.p[i].cross(&pose.w[i]);
        m[(i, 0)] = pose.e_psi.dot(&pxw);
        m[(i, 1)] = pose.e_theta.dot(&pxw);
        m[(i, 2)] = pose.w[i].dot(&pose.w4);
    }
    m
}

/// D·G: the right-hand side of eq. 9 reduced to the 15 errors.
pub fn error_matrix(pose: &Pose) -> ErrorJacobian {
    let mut d = ErrorJacobian::zeros();
    let w = &pose.w;
    // Base joints: ΔB1 = (dxB1, dyB1, 0), ΔB2 = (dxB1, dyB2, 0), ΔB3 = (dxB3, dyB3, dzB3).
    d[(0, 0)] = w[0].x;
    d[(1, 0)] = w[1].x;
    d[(0, 1)] = w[0].y;
    d[(1, 2)] = w[1].y;
    d[(2, 3)] = w[2].x;
    d[(2, 4)] = w[2].y;
    d[(2, 5)] = w[2].z;
    // Platform joints, in the platform frame: −wiᵀR·Δa0i with Δz'Ai = 0.
    for i in 0..3 {
        let rtw = pose.rot.transpose() * w[i];
        d[(i, 6 + 2 * i)] = -rtw.x;
        d[(i, 7 + 2 * i)] = -rtw.y;
        d[(i, 12 + i)] = 1.0;
    }
    d
}

/// J = M⁻¹·D at the configuration of `machine` with passive joints `joints`.
pub fn error_jacobian(
    machine: &Machine,
    joints: &Joints,
) -> Result<ErrorJacobian, KinematicsError> {
    let pose = machine.pose(joints);
    jacobian_at(&pose)
}

/// S = ∂r/∂(ψ4, θ4, q4) · J: how far O′ moves, per mm of each error, when
/// the machine is driven with the commands of `pose` (first order; docs/method.md §12
/// accuracy by propagation). r = q4·(sin θ, −sin ψ cos θ, cos ψ cos θ).
pub fn position_sensitivity(pose: &Pose) -> Result<ErrorJacobian, KinematicsError> {
    let j = jacobian_at(pose)?;
    let (sp, cp) = pose.joints.psi_rad.sin_cos();
    let (st, ct) = pose.joints.theta_rad.sin_cos();
    let q4 = pose.joints.q4_mm;
    let dr = Matrix3::new(
        0.0,
        q4 * ct,
        st,
        -q4 * cp * ct,
        q4 * sp * st,
        -sp * ct,
        -q4 * sp * ct,
        -q4 * cp * st,
        cp * ct,
    );
    Ok(dr * j)
}

/// J = M⁻¹·D for an already computed pose.
pub fn jacobian_at(pose: &Pose) -> Result<ErrorJacobian, KinematicsError> {
    let m = passive_matrix(pose);
    let det_n = normalized_det(&m);
    let singular = || KinematicsError::Singular {
        psi_deg: pose.joints.psi_rad.to_degrees(),
        theta_deg: pose.joints.theta_rad.to_degrees(),
        q4_mm: pose.joints.q4_mm,
        condition: 1.0 / det_n.abs().max(f64::MIN_POSITIVE),
    };
    if det_n.abs() < 1e-9 {
        return Err(singular());
    }
    m.lu().solve(&error_matrix(pose)).ok_or_else(singular)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::tricept::{ErrorVector, Geometry};
    use nalgebra::Vector3;

    /// δ(Δε): the passive joints the erroneous machine takes at the nominal
    /// commands for `r`, minus the nominal joints.
    fn delta(g: &Geometry, r: &Vector3<f64>, e: &ErrorVector) -> Vector3<f64> {
        let nominal = Machine::nominal(g);
        let pose = nominal.inverse(r).unwrap();
        let truth = Machine::with_errors(g, e);
        let j = truth.forward(&pose.legs_mm, &pose.joints).unwrap();
        j.as_vector() - pose.joints.as_vector()
    }

    #[test]
    fn jacobian_matches_central_differences() {
        let g = Geometry::paper();
        let r = Vector3::new(150.0, -220.0, 720.0);
        let nominal = Machine::nominal(&g);
        let pose = nominal.inverse(&r).unwrap();
        let j = jacobian_at(&pose).unwrap();
        let h = 1e-4;
        for k in 0..N_PARAMS {
            let mut e = ErrorVector::zeros();
            e[k] = h;
            let fd = (delta(&g, &r, &e) - delta(&g, &r, &(-e))) / (2.0 * h);
            let col = j.column(k);
            let err = (fd - col).norm() / col.norm().max(1e-300);
            assert!(err < 1e-6, "column {k}: fd {fd:?} vs {col:?} (rel {err:e})");
        }
    }
}

#[cfg(test)]
mod sensitivity_tests {
    use super::*;
    use crate::mechanism::tricept::geometry::Geometry;
    use crate::mechanism::tricept::params::ErrorVector;
    use nalgebra::Vector3;

    /// Where the machine with errors `e`, driven with nominal commands for
    /// `r`, puts O′ (exact FK).
    fn attained(g: &Geometry, r: &Vector3<f64>, e: &ErrorVector) -> Vector3<f64> {
        let nominal = Machine::nominal(g);
        let pose = nominal.inverse(r).unwrap();
        let truth = Machine::with_errors(g, e);
        let j = truth.forward(&pose.legs_mm, &pose.joints).unwrap();
        truth.position(&j)
    }

    #[test]
    fn position_sensitivity_matches_central_differences_of_exact_fk() {
        let g = Geometry::paper();
        for r in [
            Vector3::new(150.0, -220.0, 720.0),
            Vector3::new(-300.0, 100.0, 840.0),
            Vector3::new(0.0, 0.0, 650.0),
        ] {
            let pose = Machine::nominal(&g).inverse(&r).unwrap();
            let s = position_sensitivity(&pose).unwrap();
            let h = 1e-4;
            for k in 0..N_PARAMS {
                let mut e = ErrorVector::zeros();
                e[k] = h;
                let fd = (attained(&g, &r, &e) - attained(&g, &r, &(-e))) / (2.0 * h);
                let col = s.column(k);
                let err = (fd - col).norm();
                assert!(
                    err < 1e-6 * col.norm().max(1.0),
                    "{r:?} column {k}: fd {fd:?} vs {col:?}"
                );
            }
        }
    }
}
