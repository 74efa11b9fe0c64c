//! `[sweep]`, `[workspace]` and `[decision]` of a hexapod config, checked
//! into the study and the workspace's poses.

use super::{
    DecisionSection, StudyConfig, SweepSection, WorkspaceSection, MAX_ERROR_DEG, MAX_ERROR_MM,
    MAX_RESULTS,
};
use crate::config::general::{Estimator, Sensor, Spec, WhatIf};
use crate::error::{Error, Result};
use crate::mechanism::hexapod::kinematics::Limits;
use crate::mechanism::hexapod::{Encoders, Hexapod, Pose, N_ERRORS};
use nalgebra::Vector3;

/// `[sweep]`, `[workspace]` and `[decision]` checked into a study.
#[allow(clippy::too_many_arguments)]
pub(super) fn study(
    fail: &dyn Fn(&str, String) -> Error,
    source: &str,
    sw: &SweepSection,
    (workspace, tool_mm): (Vec<Pose>, Vector3<f64>),
    dec: &DecisionSection,
    poses: usize,
    noise_arcsec: f64,
    iterations: usize,
) -> Result<StudyConfig> {
    use crate::sensors::ARCSEC_PER_RAD;
    let sensors: Vec<Sensor> = match (&sw.catalogue, &sw.encoder_arcsec) {
        (Some(_), Some(_)) => {
            return Err(fail(
                "sweep.encoder_arcsec",
                "is a grade list, and sweep.catalogue names products: give one of them".into(),
            ))
        }
        (None, None) => {
            return Err(fail(
                "sweep",
                "needs the encoders to compare: sweep.catalogue (products with prices) or sweep.encoder_arcsec (grades)".into(),
            ))
        }
        (Some(cat), None) => crate::config::encoder_products(source, cat, &sw.encoders)?
            .into_iter()
            .map(|(p, axis)| Sensor {
                name: p.name,
                price: Some(p.price),
                axis,
                truth: None,
            })
            .collect(),
        (None, Some(grades)) => {
            if sw.encoders.is_some() {
                return Err(fail(
                    "sweep.encoders",
                    "names catalogue products: set sweep.catalogue too".into(),
                ));
            }
            if grades.is_empty() || grades.len() > 64 {
                return Err(fail(
                    "sweep.encoder_arcsec",
                    format!("must list 1 to 64 grades (got {})", grades.len()),
                ));
            }
            let mut out = Vec::new();
            for (i, &g) in grades.iter().enumerate() {
                if !(g.is_finite() && g > 0.0 && g <= 3600.0) || grades[..i].contains(&g) {
                    return Err(fail(
                        "sweep.encoder_arcsec",
                        format!("must list distinct grades in (0, 3600] arc seconds (got {g})"),
                    ));
                }
                out.push(Sensor {
                    name: format!("±{g}″"),
                    price: None,
                    axis: crate::sensors::Axis {
                        accuracy: g / ARCSEC_PER_RAD,
                        shape: crate::sensors::structured::Shape::Unknown,
                        n_harmonics: 6,
                        period: std::f64::consts::TAU,
                        noise: noise_arcsec / ARCSEC_PER_RAD,
                        readheads: 1,
                        ..Default::default()
                    },
                    truth: None,
                });
            }
            out
        }
    };
    if sensors.len() > 64 {
        return Err(fail(
            "sweep.encoders",
            format!("compares at most 64 encoders (got {})", sensors.len()),
        ));
    }
    let per_joint = words(
        fail,
        "sweep.per_joint",
        &sw.per_joint,
        Encoders::parse,
        "\"both\", \"first\" or \"second\"",
    )?;
    let pose_counts = sw.pose_counts.clone().unwrap_or_else(|| vec![poses]);
    if pose_counts.is_empty()
        || pose_counts.len() > 32
        || pose_counts.iter().any(|&n| n < 1 || n > poses)
    {
        return Err(fail(
            "sweep.pose_counts",
            format!("must list 1 to 32 counts, each 1 to the {poses} poses of poses.list"),
        ));
    }
    let estimators = words(
        fail,
        "sweep.estimators",
        &sw.estimators,
        Estimator::parse,
        "\"linear\", \"gls\" or \"gauss-newton\"",
    )?;
    if !(1..=crate::config::general::MAX_STUDY_TRIALS).contains(&sw.trials) {
        return Err(fail(
            "sweep.trials",
            format!("must be 1 to 10000000 (got {})", sw.trials),
        ));
    }
    for (key, v, cap) in [
        ("sweep.length_bound_mm", sw.length_bound_mm, MAX_ERROR_MM),
        ("sweep.zero_bound_deg", sw.zero_bound_deg, MAX_ERROR_DEG),
    ] {
        if !(v.is_finite() && (0.0..=cap).contains(&v)) {
            return Err(fail(key, format!("must be in [0, {cap}] (got {v})")));
        }
    }
    if !(1..=1000).contains(&sw.samples) {
        return Err(fail(
            "sweep.samples",
            format!("must be 1 to 1000 (got {})", sw.samples),
        ));
    }
    let combos = sensors.len() * per_joint.len() * pose_counts.len() * estimators.len();
    if combos as u128 * sw.trials as u128 > MAX_RESULTS {
        return Err(fail(
            "sweep.trials",
            format!(
                "× {combos} combinations is {} machines' results, over the {MAX_RESULTS} that fit in 1 GiB: fewer trials or fewer combinations",
                combos as u128 * sw.trials as u128
            ),
        ));
    }
    for (key, v) in [
        ("decision.position_mm", dec.position_mm),
        ("decision.orientation_arcsec", dec.orientation_arcsec),
    ] {
        if let Some(v) = v {
            if !(v.is_finite() && v > 0.0) {
                return Err(fail(key, format!("must be a positive number (got {v})")));
            }
        }
    }
    let mut what_ifs = Vec::new();
    if let Some(f) = sw.truth_white {
        if !(f.is_finite() && f > 0.0 && f <= 100.0) {
            return Err(fail(
                "sweep.truth_white",
                format!("must be a factor in (0, 100] (got {f})"),
            ));
        }
        what_ifs.push(WhatIf::White(f));
    }
    if let Some(um) = sw.truth_eccentricity_um {
        if !(um.is_finite() && um > 0.0 && um <= 1000.0) {
            return Err(fail(
                "sweep.truth_eccentricity_um",
                format!("must be in (0, 1000] µm (got {um})"),
            ));
        }
        what_ifs.push(WhatIf::EccentricityUm(um));
    }
    let until_decided = match (sw.until_decided, sw.max_trials) {
        (false, None) => None,
        (false, Some(_)) => {
            return Err(fail(
                "sweep.max_trials",
                "bounds sweep.until_decided, which is not set: set until_decided = true or leave max_trials out".into(),
            ))
        }
        (true, max) => {
            // As many as fit, up to 200,000 (the Tricept's default), and
            // never fewer than sweep.trials.
            let fit = (MAX_RESULTS / combos as u128) as u64;
            let max = max.unwrap_or(fit.min(200_000).max(sw.trials));
            if max < sw.trials || combos as u128 * max as u128 > MAX_RESULTS {
                return Err(fail(
                    "sweep.max_trials",
                    format!(
                        "must be from sweep.trials ({}) to {fit} (× {combos} combinations at most {MAX_RESULTS} machines' results, 1 GiB) (got {max})",
                        sw.trials
                    ),
                ));
            }
            Some(max)
        }
    };
    Ok(StudyConfig {
        until_decided,
        what_ifs,
        spec: Spec {
            sensors,
            variants: per_joint,
            pose_counts,
            estimators,
            trials: sw.trials,
            seed: sw.seed,
            length_bound_mm: sw.length_bound_mm,
            zero_bound_deg: sw.zero_bound_deg,
            samples: sw.samples,
            workspace,
            tool_mm,
            iterations,
            fixed: Vec::new(),
            prior_std_mm: None,
            prior_std_deg: None,
        },
        position_mm: dec.position_mm,
        orientation_arcsec: dec.orientation_arcsec,
    })
}

/// A list of `key`'s words, each one `parse` knows (`expected` says
/// which), each once, at least one.
fn words<T: PartialEq>(
    fail: &dyn Fn(&str, String) -> Error,
    key: &str,
    list: &[String],
    parse: fn(&str) -> Option<T>,
    expected: &str,
) -> Result<Vec<T>> {
    let mut out = Vec::new();
    for w in list {
        let e = parse(w).ok_or_else(|| fail(key, format!("must list {expected} (got \"{w}\")")))?;
        if out.contains(&e) {
            return Err(fail(key, format!("lists \"{w}\" twice")));
        }
        out.push(e);
    }
    if out.is_empty() {
        return Err(fail(key, "must list at least one".into()));
    }
    Ok(out)
}

/// `[workspace]` checked into its poses: a grid of positions about the
/// home pose × the home orientation and ±tilt about each axis, each one the
/// nominal machine reaches.
pub(super) fn workspace(
    fail: &dyn Fn(&str, String) -> Error,
    ws: &WorkspaceSection,
    hex: &Hexapod,
    limits: &Limits,
) -> Result<Vec<Pose>> {
    if ws
        .half_extent_mm
        .iter()
        .any(|x| !(x.is_finite() && (0.0..=1e4).contains(x)))
        || !(ws.tilt_deg.is_finite() && (0.0..=45.0).contains(&ws.tilt_deg))
        || !(1..=9).contains(&ws.grid)
        || ws
            .tool_point_mm
            .iter()
            .any(|x| !(x.is_finite() && x.abs() <= 1e4))
    {
        return Err(fail(
            "workspace",
            "needs half_extent_mm of three lengths in [0, 10000], tilt_deg in [0, 45], grid 1 to 9 and tool_point_mm within ±10000 mm".into(),
        ));
    }
    let mut workspace = Vec::new();
    let h = hex.home.to_xyzabc();
    let steps: Vec<f64> = if ws.grid == 1 {
        vec![0.0]
    } else {
        (0..ws.grid)
            .map(|i| -1.0 + 2.0 * i as f64 / (ws.grid - 1) as f64)
            .collect()
    };
    let tilts = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
    ];
    let zero = hex.actual(&[0.0; N_ERRORS]);
    for &sx in &steps {
        for &sy in &steps {
            for &sz in &steps {
                for t in &tilts {
                    if ws.tilt_deg == 0.0 && t != &tilts[0] {
                        continue;
                    }
                    let x = [
                        h[0] + sx * ws.half_extent_mm[0],
                        h[1] + sy * ws.half_extent_mm[1],
                        h[2] + sz * ws.half_extent_mm[2],
                        h[3] + t[0] * ws.tilt_deg,
                        h[4] + t[1] * ws.tilt_deg,
                        h[5] + t[2] * ws.tilt_deg,
                    ];
                    let p = Pose::from_xyzabc(&x);
                    Hexapod::forward(&zero, &hex.commands(&p), &p).map_err(|why| {
                        fail(
                            "workspace",
                            format!("holds the pose {x:?}, which the machine cannot reach: {why}"),
                        )
                    })?;
                    limits.check(hex, &p).map_err(|why| {
                        fail(
                            "workspace",
                            format!("holds the pose {x:?}, which {why}: make half_extent_mm or tilt_deg smaller, or the limit larger"),
                        )
                    })?;
                    workspace.push(p);
                }
            }
        }
    }
    Ok(workspace)
}
