//! GLS weighted at each simulated machine's own readings (`[sweep]
//! gls_per_machine`), as identify weights a real log: the joint values a
//! machine's sensors report, its operator there, and one calibration with
//! it beside the estimate from the noise-free readings (what one
//! linearisation leaves, which the statement counts).

use super::context::SweepContext;
use crate::identify::tricept::LinearSolver;
use crate::mechanism::tricept::{ErrorVector, Joints, PARAM_NAMES};

/// Grade `gi`'s estimate from observation `l` and from the noise-free one
/// `l0`, both with the operator weighted at the readings this machine's
/// sensors report: the study's design, active set and constraints under
/// that weighting (one QR, [`LinearSolver::estimates_reweighted`]); where
/// it cannot be formed (not seen: Σ is positive definite and the design of
/// full rank on the active errors), the operator built whole, else the
/// study's own.
pub(super) fn calibrate(
    ctx: &SweepContext,
    gi: usize,
    l: &[f64],
    l0: &[f64],
) -> (ErrorVector, ErrorVector) {
    let g = &ctx.grades[gi];
    let solver = &ctx.solvers[gi];
    let joints = reported_joints(ctx, gi, l);
    if let Some([est, exact]) = g
        .method
        .weighting(&ctx.assumed[g.product], &joints)
        .ok()
        .and_then(|w| solver.estimates_reweighted(&w, [l, l0]))
    {
        return (est, exact);
    }
    let own = solver_at(ctx, gi, &joints);
    let op = own.as_ref().unwrap_or(solver);
    let (mut est, mut exact) = (ErrorVector::zeros(), ErrorVector::zeros());
    op.apply(l, &mut est);
    op.apply(l0, &mut exact);
    (est, exact)
}

/// The joint values grade `gi`'s sensors report at its pose subset: the
/// subset's nominal joints plus its observation `l` (row 3(j−1)+k: reading
/// − nominal of axis k at pose j; the reference reads nominal after homing).
pub(super) fn reported_joints(ctx: &SweepContext, gi: usize, l: &[f64]) -> Vec<Joints> {
    let nominal = &ctx.subset_poses[ctx.grades[gi].subset].joints;
    nominal
        .iter()
        .enumerate()
        .map(|(j, n)| match j {
            0 => *n,
            _ => Joints {
                psi_rad: n.psi_rad + l[3 * (j - 1)],
                theta_rad: n.theta_rad + l[3 * (j - 1) + 1],
                q4_mm: n.q4_mm + l[3 * (j - 1) + 2],
            },
        })
        .collect()
}

/// Grade `gi`'s estimator weighted at the joint values `joints`.
pub(super) fn solver_at(ctx: &SweepContext, gi: usize, joints: &[Joints]) -> Option<LinearSolver> {
    let g = &ctx.grades[gi];
    g.method
        .solver(
            (&ctx.assumed[g.product], joints),
            &ctx.subset_h[g.subset],
            ctx.options.rank_tolerance,
            (&ctx.options.constraints, &PARAM_NAMES),
        )
        .ok()
}
