//! GLS weighted at each simulated machine's own readings (`[sweep]
//! gls_per_machine`), as identify weights a real log: the joint values a
//! machine's sensors report, its operator there, and one calibration with
//! it beside the estimate from the noise-free readings (what one
//! linearisation leaves, which the statement counts).

use super::context::{Studied, SweepContext};
use crate::identify::Solver;
use nalgebra::SVector;

/// Grade `gi`'s estimate from observation `l` and from the noise-free one
/// `l0`, both with the operator weighted at the readings this machine's
/// sensors report: the study's design, active set and constraints under
/// that weighting (one QR, [`Solver::estimates_reweighted`]); where
/// it cannot be formed (not seen: Σ is positive definite and the design of
/// full rank on the active errors), the operator built whole, else the
/// study's own.
pub(super) fn calibrate<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>(
    ctx: &SweepContext<M, P, R, A>,
    gi: usize,
    l: &[f64],
    l0: &[f64],
) -> (SVector<f64, P>, SVector<f64, P>) {
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
    let (mut est, mut exact) = (SVector::zeros(), SVector::zeros());
    op.apply(l, &mut est);
    op.apply(l0, &mut exact);
    (est, exact)
}

/// The joint values grade `gi`'s sensors report at its pose subset: the
/// subset's nominal joints plus its observation `l` (row R(j−1)+k: reading
/// − nominal of axis k at pose j; the reference reads nominal after homing).
pub(super) fn reported_joints<
    M: Studied<P, R, A>,
    const P: usize,
    const R: usize,
    const A: usize,
>(
    ctx: &SweepContext<M, P, R, A>,
    gi: usize,
    l: &[f64],
) -> Vec<SVector<f64, R>> {
    let nominal = &ctx.subset_nominal[ctx.grades[gi].subset];
    nominal
        .iter()
        .enumerate()
        .map(|(j, n)| match j {
            0 => *n,
            _ => SVector::from_fn(|k, _| n[k] + l[R * (j - 1) + k]),
        })
        .collect()
}

/// Grade `gi`'s estimator weighted at the joint values `joints`.
pub(super) fn solver_at<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>(
    ctx: &SweepContext<M, P, R, A>,
    gi: usize,
    joints: &[SVector<f64, R>],
) -> Option<Solver<P, R>> {
    let g = &ctx.grades[gi];
    g.method
        .solver(
            (&ctx.assumed[g.product], joints),
            &ctx.subset_h[g.subset],
            ctx.options.rank_tolerance,
            (&ctx.options.constraints, ctx.mech.names()),
        )
        .ok()
}
