//! The hexapod's design matrix: how each encoder reading moves with each of
//! the 54 errors, at a target pose commanded by nominal inverse kinematics,
//! for a machine with given errors (the nominal one for one linearisation,
//! the current estimate for Gauss–Newton).
//!
//! The reached pose moves with the errors through the six leg lengths
//! g_i = |L_i| − (ℓ0_i + dl_i + q_i) = 0: with a twist (δt, δθ) of the pose,
//! J_X·(δt, δθ) = −J_ε·δε, J_X's row i = [n_iᵀ, ((R·p_i) × n_i)ᵀ]. Each leg
//! vector then moves by δt + δθ × R·p_i + R·δp_i − δb_i, its direction n by
//! (I − n·nᵀ)·δL/|L|, and the angles by the derivatives of atan2 and asin.

use super::kinematics::Frame;
use super::{error_index, Errors, Hexapod, Pose, LEGS, N_ERRORS};
use nalgebra::{DMatrix, Matrix3, Matrix6, SMatrix, Vector3};

/// ∂(readings)/∂(errors) at one pose: `readings_per_pose()` rows × 54
/// (degrees per mm, or per degree for the encoders' zeros).
pub fn pose_design(hex: &Hexapod, errors: &Errors, target: &Pose) -> Result<DMatrix<f64>, String> {
    let m = hex.actual(errors);
    let pose = Hexapod::forward(&m, &hex.commands(target), target)?;
    let frames = hex.frames();
    let mut legs = [Vector3::zeros(); LEGS];
    let mut jx = Matrix6::zeros();
    // J_ε: each constraint's direct derivative in the errors.
    let mut je = SMatrix::<f64, LEGS, N_ERRORS>::zeros();
    for i in 0..LEGS {
        let l = pose.t + pose.r * m.platform[i] - m.base[i];
        let n = l.normalize();
        legs[i] = l;
        let rp = pose.r * m.platform[i];
        let c = rp.cross(&n);
        for k in 0..3 {
            jx[(i, k)] = n[k];
            jx[(i, 3 + k)] = c[k];
        }
        let rn = pose.r.transpose() * n;
        for k in 0..3 {
            je[(i, error_index(i, k))] = -n[k];
            je[(i, error_index(i, 3 + k))] = rn[k];
        }
        je[(i, error_index(i, 6))] = -1.0;
    }
    let lu = jx.lu();
    let dx = lu
        .solve(&(-je))
        .ok_or_else(|| "the legs' Jacobian is singular at this pose".to_string())?;
    let mut out = DMatrix::zeros(hex.readings_per_pose(), N_ERRORS);
    let mut row = 0;
    for i in 0..LEGS {
        let l = legs[i];
        let len = l.norm();
        let n = l / len;
        let rp = pose.r * m.platform[i];
        // δL = δt − [R·p]×·δθ (+ R·δp_i − δb_i for this leg's joints).
        let mut dl = SMatrix::<f64, 3, N_ERRORS>::zeros();
        let skew = rp.cross_matrix();
        for col in 0..N_ERRORS {
            let t = dx.fixed_view::<3, 1>(0, col).into_owned();
            let w = dx.fixed_view::<3, 1>(3, col).into_owned();
            dl.set_column(col, &(t - skew * w));
        }
        for k in 0..3 {
            dl[(k, error_index(i, k))] -= 1.0;
            for j in 0..3 {
                dl[(k, error_index(i, 3 + j))] += pose.r[(k, j)];
            }
        }
        let proj = (Matrix3::identity() - n * n.transpose()) / len;
        let dn = proj * dl;
        let [d_phi, d_psi] = angle_gradients(&n, &frames[i]);
        for (k, grad) in [d_phi, d_psi].iter().enumerate() {
            if !hex.encoders.reads(k) {
                continue;
            }
            let g = grad.transpose() * dn;
            for col in 0..N_ERRORS {
                out[(row, col)] = g[col].to_degrees();
            }
            out[(row, error_index(i, 7 + k))] += 1.0;
            row += 1;
        }
    }
    Ok(out)
}

/// The stacked design over `targets` (pose after pose).
pub fn design(hex: &Hexapod, errors: &Errors, targets: &[Pose]) -> Result<DMatrix<f64>, String> {
    let r = hex.readings_per_pose();
    let mut h = DMatrix::zeros(r * targets.len(), N_ERRORS);
    for (j, t) in targets.iter().enumerate() {
        let block = pose_design(hex, errors, t).map_err(|e| format!("pose {}: {e}", j + 1))?;
        h.view_mut((r * j, 0), (r, N_ERRORS)).copy_from(&block);
    }
    Ok(h)
}

/// ∂φ/∂n and ∂ψ/∂n (radians) at leg direction `n` in frame `f`.
fn angle_gradients(n: &Vector3<f64>, f: &Frame) -> [Vector3<f64>; 2] {
    let (x, y) = (n.dot(&f[2]), -n.dot(&f[1]));
    let d_phi = (f[2] * y * -1.0 - f[1] * x) / (x * x + y * y);
    let s = n.dot(&f[0]);
    let d_psi = f[0] / (1.0 - s * s).sqrt();
    [d_phi, d_psi]
}
