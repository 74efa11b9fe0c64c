//! A calibration judged over the workspace (docs/method.md §12): dV at every point of
//! the grid and the worst ISO 9283 AP, before and after compensation, by
//! exact kinematics or by first-order propagation through sensitivities
//! computed once per study. [`Workspace`] holds the per-worker buffers; the
//! trial kernel ([`super::trial`]) calls in here once per trial.

use super::context::{Block, MapGrid, SweepContext, BLOCK};
use super::outcome::Outcome;
use super::plan::KernelPath;
use super::studied::{Judging, Studied};
use crate::identify::Split;
use crate::metrics::stats;
use nalgebra::{SMatrix, SVector};

/// Per-worker buffers of the workspace judgement, reused across trials.
pub struct Workspace<const P: usize> {
    /// dV at every grid point of each grade's calibration (grade-major).
    dv: Vec<f64>,
    /// The same by first-order propagation, as bit patterns (dV ≥ 0).
    dv_bits: Vec<u64>,
    /// The p95 of each grade's dV, alike across the grades (and trials).
    p95: stats::SimilarQuantiles,
    /// Max and sum of each grade's dV over the grid (first order).
    dv_max: Vec<f64>,
    dv_sum: Vec<f64>,
    /// The noise groups' directions (R per group; see [`super::NoiseGroup`]).
    directions: Vec<SVector<f64, P>>,
}

impl<const P: usize> Workspace<P> {
    pub fn new<M: Studied<P, R, A>, const R: usize, const A: usize>(
        ctx: &SweepContext<M, P, R, A>,
    ) -> Self {
        let (n, g) = (ctx.grid.points.len(), ctx.grades.len());
        Workspace {
            dv: vec![0.0; n],
            dv_bits: vec![0; n * g],
            p95: stats::SimilarQuantiles::default(),
            dv_max: vec![0.0; g],
            dv_sum: vec![0.0; g],
            directions: vec![SVector::zeros(); R * ctx.plan.noise_groups().len()],
        }
    }
}

/// Max dV before compensation (nominal commands) of the machine `truth`
/// with errors `truth_e`: exact or first order as the study asks, NaN when
/// the workspace is not judged or a point fails.
pub fn before_max<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>(
    ctx: &SweepContext<M, P, R, A>,
    truth: &M::Machine,
    truth_e: &SVector<f64, P>,
) -> f64 {
    match (ctx.volumetric(), ctx.exact) {
        (false, _) => f64::NAN,
        (true, true) => volumetric_before(ctx, truth),
        // A last block's spare lanes have zero sensitivity: dV 0, never the max.
        (true, false) => ctx
            .grid
            .blocks
            .iter()
            .flat_map(|block| block_dv(block, truth_e))
            .fold(0.0, f64::max),
    }
}

/// One calibration's accuracy after compensation by exact kinematics (all
/// NaN when the study does not ask for it or a point fails).
pub fn exact_after<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>(
    ctx: &SweepContext<M, P, R, A>,
    truth: &M::Machine,
    est: &SVector<f64, P>,
    angles: &SVector<f64, A>,
    ws: &mut Workspace<P>,
) -> Accuracy {
    match (ctx.volumetric(), ctx.exact) {
        (true, true) => volumetric_after(ctx, truth, est, angles, &mut ws.dv),
        _ => Accuracy::NONE,
    }
}

/// Max dV of `truth` commanded by the nominal model over the map (NaN if any
/// point fails).
fn volumetric_before<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>(
    ctx: &SweepContext<M, P, R, A>,
    truth: &M::Machine,
) -> f64 {
    let mut mx = 0.0f64;
    for i in 0..ctx.grid.points.len() {
        match ctx.mech.exact_dv(truth, None, Judging::Grid, i) {
            Some(dv) => mx = mx.max(dv),
            None => return f64::NAN,
        }
    }
    mx
}

/// One calibration's accuracy over the workspace.
#[derive(Debug, Clone, Copy)]
pub struct Accuracy {
    pub max: f64,
    pub mean: f64,
    pub p95: f64,
    pub ap_max: f64,
}

impl Accuracy {
    pub const NONE: Accuracy = Accuracy {
        max: f64::NAN,
        mean: f64::NAN,
        p95: f64::NAN,
        ap_max: f64::NAN,
    };

    /// Max, mean and p95 of the grid's dV (reorders `dv`), with the worst AP.
    fn of(dv: &mut [f64], ap_max: f64) -> Accuracy {
        let (mx, sum) = dv
            .iter()
            .fold((0.0f64, 0.0), |(m, s), &d| (m.max(d), s + d));
        Accuracy {
            max: mx,
            mean: sum / dv.len() as f64,
            p95: stats::quantile_unsorted(dv, 0.95),
            ap_max,
        }
    }
}

/// |S·e| at a point: the first-order position error of a machine whose
/// errors differ from the commanding model's by `e`.
#[inline]
pub(super) fn first_order_dv<const P: usize>(s: &SMatrix<f64, 3, P>, e: &SVector<f64, P>) -> f64 {
    first_order_dv2(s, e).sqrt()
}

/// |S·e|², see [`first_order_dv`].
#[inline]
fn first_order_dv2<const P: usize>(s: &SMatrix<f64, 3, P>, e: &SVector<f64, P>) -> f64 {
    // Fixed-size arrays: no bounds checks, the three dot products vectorise.
    let s: &[[f64; 3]; P] = &s.data.0;
    let e: &[f64; P] = &e.data.0[0];
    let (mut x, mut y, mut z) = (0.0, 0.0, 0.0);
    for c in 0..P {
        x += s[c][0] * e[c];
        y += s[c][1] * e[c];
        z += s[c][2] * e[c];
    }
    x * x + y * y + z * z
}

/// S·e at the points of one block of [`MapGrid::blocks`], by component:
/// the same arithmetic in the same order as [`first_order_dv2`] point by
/// point, vectorised across the block's points.
#[inline]
fn block_se<const P: usize>(block: &Block<P>, e: &SVector<f64, P>) -> [[f64; BLOCK]; 3] {
    let e: &[f64; P] = &e.data.0[0];
    // c outer: the three rows' twelve accumulator registers advance together
    // (each still sums over c in order).
    let mut acc = [[0.0; BLOCK]; 3];
    for (c, &ec) in e.iter().enumerate() {
        for (a, acc) in acc.iter_mut().enumerate() {
            let row = &block[a][c];
            for i in 0..BLOCK {
                acc[i] += row[i] * ec;
            }
        }
    }
    acc
}

/// |S·e| at the points of one block (see [`block_se`]).
#[inline]
fn block_dv<const P: usize>(block: &Block<P>, e: &SVector<f64, P>) -> [f64; BLOCK] {
    norms(&block_se(block, e))
}

/// The length of each point's vector of a block.
#[inline]
fn norms(v: &[[f64; BLOCK]; 3]) -> [f64; BLOCK] {
    let mut out = [0.0; BLOCK];
    for i in 0..BLOCK {
        out[i] = (v[0][i] * v[0][i] + v[1][i] * v[1][i] + v[2][i] * v[2][i]).sqrt();
    }
    out
}

/// Max of |S·e| over a grid (0 over none).
pub(super) fn first_order_max<const P: usize>(grid: &MapGrid<P>, e: &SVector<f64, P>) -> f64 {
    grid.sensitivity
        .iter()
        .map(|s| first_order_dv(s, e))
        .fold(0.0, f64::max)
}

/// Accuracy after compensation by first-order propagation for every grade
/// of the trial: the machine's errors minus the identified ones
/// (`residual`), through each point's sensitivity. Each block of
/// sensitivities is read once for all grades; on the white-noise path the
/// grades of an operator come from its first residual and the noise
/// `splits` (see [`super::NoiseGroup`]).
pub fn first_order_after<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>(
    ctx: &SweepContext<M, P, R, A>,
    residual: &[SVector<f64, P>],
    splits: &[Split<P, R>],
    s: &mut Workspace<P>,
    out: &mut [Outcome],
) {
    let n = ctx.grid.points.len();
    let g = out.len();
    s.dv_max[..g].fill(0.0);
    s.dv_sum[..g].fill(0.0);
    // Each grade's max and sum run along the points in order, the grades'
    // chains side by side (so the sums wait on no one's latency).
    let record = |s: &mut Workspace<P>, gi: usize, p0: usize, d: &[f64]| {
        // In registers along the block (through memory, each add would wait
        // on the store before it).
        let (mut mx, mut sum) = (s.dv_max[gi], s.dv_sum[gi]);
        for &x in d {
            if x > mx {
                mx = x;
            }
            sum += x;
        }
        (s.dv_max[gi], s.dv_sum[gi]) = (mx, sum);
        for (b, x) in s.dv_bits[gi * n + p0..gi * n + p0 + d.len()]
            .iter_mut()
            .zip(d)
        {
            *b = x.to_bits();
        }
    };
    // The white-noise path's groups (see NoiseGroup); none on the others.
    let groups = match &ctx.plan.path {
        KernelPath::WhiteNoise { groups } => Some(groups),
        _ => None,
    };
    if let Some(groups) = groups {
        // Each group's directions w = Σ n_k once per trial.
        for (i, grp) in groups.iter().enumerate() {
            let noise = &splits[grp.first].noise;
            for (j, dir) in grp.directions.iter().enumerate() {
                let mut w = noise[0] * dir[0];
                for k in 1..R {
                    w += noise[k] * dir[k];
                }
                s.directions[R * i + j] = w;
            }
        }
    }
    for (b, block) in ctx.grid.blocks.iter().enumerate() {
        let p0 = BLOCK * b;
        let count = BLOCK.min(n - p0);
        let Some(groups) = groups else {
            for gi in 0..g {
                let d = block_dv(block, &residual[gi]);
                record(s, gi, p0, &d[..count]);
            }
            continue;
        };
        for (i, grp) in groups.iter().enumerate() {
            // The base residual through S, then each direction; every other
            // grade of the group is base − Σ c·(S·w).
            let base = block_se(block, &residual[grp.first]);
            record(s, grp.first, p0, &norms(&base)[..count]);
            if grp.members.is_empty() {
                continue;
            }
            let mut sw = [[[0.0; BLOCK]; 3]; R];
            for (j, w) in sw
                .iter_mut()
                .zip(&s.directions[R * i..R * i + grp.directions.len()])
            {
                *j = block_se(block, w);
            }
            for (gi, coef) in &grp.members {
                let mut v = base;
                for (c, w) in coef.iter().zip(&sw) {
                    for a in 0..3 {
                        for k in 0..BLOCK {
                            v[a][k] -= c * w[a][k];
                        }
                    }
                }
                record(s, *gi, p0, &norms(&v)[..count]);
            }
        }
    }
    for (gi, o) in out.iter_mut().enumerate() {
        let ap = first_order_max(&ctx.iso, &residual[gi]);
        // dV ≥ 0 (a length): its bits order as its values.
        let dv = &s.dv_bits[gi * n..(gi + 1) * n];
        o.dv_after_max = s.dv_max[gi];
        o.dv_after_mean = s.dv_sum[gi] / n as f64;
        o.dv_after_p95 = s.p95.quantile(dv, 0.95);
        o.ap_after_max = ap;
    }
}

/// Accuracy after compensation by exact kinematics at every point (all NaN
/// if any point fails).
fn volumetric_after<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>(
    ctx: &SweepContext<M, P, R, A>,
    truth: &M::Machine,
    est: &SVector<f64, P>,
    angles: &SVector<f64, A>,
    dv: &mut [f64],
) -> Accuracy {
    let identified = ctx.mech.identified(est, angles);
    for (i, d) in dv.iter_mut().enumerate() {
        match ctx
            .mech
            .exact_dv(truth, Some(&identified), Judging::Grid, i)
        {
            Some(x) => *d = x,
            None => return Accuracy::NONE,
        }
    }
    let mut ap = 0.0f64;
    for i in 0..ctx.iso.points.len() {
        match ctx.mech.exact_dv(truth, Some(&identified), Judging::Iso, i) {
            Some(x) => ap = ap.max(x),
            None => return Accuracy::NONE,
        }
    }
    Accuracy::of(dv, ap)
}

#[cfg(test)]
#[path = "workspace_tests.rs"]
mod tests;
