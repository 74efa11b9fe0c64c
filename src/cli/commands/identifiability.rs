//! `identifiability`: rank, singular values, condition number, O1–O5.

use crate::cli::{console, OutputFormat};
use crate::config::Config;
use crate::error::{Error, Result};
use crate::export::rows::identifiability_json;
use crate::export::text::identifiability_text;
use crate::identify::design_matrix;
use crate::identify::second_class::{angle_design, SecondClassSolver};
use crate::model::second_class::{Angles, ANGLE_NAMES, N_ANGLES};
use crate::model::N_PARAMS;
use crate::sensors::ObservationCovariance;

pub fn run(cfg: &Config, format: OutputFormat) -> Result<()> {
    let poses = cfg.nominal_poses()?;
    let h = design_matrix(&cfg.nominal(), &poses)
        .map_err(|e| Error::config(&cfg.source, format!("poses: {e}")))?;
    let method = cfg.identification.method;
    // The readings' own rank: no fixed error or prior.
    let solver = method
        .solver(
            &cfg.sensors,
            &poses.joints,
            &h,
            cfg.identification.rank_tolerance,
            &Default::default(),
        )
        .map_err(|why| Error::config(&cfg.source, format!("identification.method {why}")))?;
    let a = &solver.analysis;
    let axes = if cfg.identification.second_class {
        Some(hooke_axes(cfg, &poses, &solver)?)
    } else {
        None
    };
    match format {
        OutputFormat::Json => {
            let bytes = identifiability_json(method, poses.len(), h.nrows(), a, None::<&()>)?;
            let Some(x) = &axes else {
                console::text(String::from_utf8_lossy(&bytes));
                return Ok(());
            };
            let json = |e: serde_json::Error| Error::Internal(format!("identifiability JSON: {e}"));
            let mut v: serde_json::Value = serde_json::from_slice(&bytes).map_err(json)?;
            if let Some(obj) = v.as_object_mut() {
                obj.insert("hooke_axes".into(), serde_json::to_value(x).map_err(json)?);
            }
            console::text(serde_json::to_string_pretty(&v).map_err(json)? + "\n");
        }
        OutputFormat::Text => {
            console::text(identifiability_text(poses.len(), &cfg.poses[0], method, a));
            if let Some(x) = &axes {
                let each: Vec<String> = (0..N_ANGLES)
                    .map(|k| {
                        format!(
                            "{} {} ({:.0} % of its effect unlike any error's; σ {})",
                            ANGLE_NAMES[k],
                            if x.identifiable[k] {
                                "identifiable"
                            } else {
                                "NOT identifiable"
                            },
                            100.0 * x.outside_span[k],
                            if x.identifiable[k] {
                                format!("{:.5}°", x.predicted_std_deg[k])
                            } else {
                                "n/a".into()
                            }
                        )
                    })
                    .collect();
                console::text(format!(
                    "With the Hooke axes (second_class = true): rank {} of {}; {}. The guide's twist is not among them: it moves the readings as the 15 errors do.\n",
                    x.rank,
                    N_PARAMS + N_ANGLES,
                    each.join("; ")
                ));
            }
        }
    }
    Ok(())
}

/// What the readings say of the Hooke axes' angles (`second_class = true`).
#[derive(serde::Serialize)]
struct HookeAxes {
    /// Rank of the 18-unknown design.
    rank: usize,
    names: [&'static str; N_ANGLES],
    identifiable: [bool; N_ANGLES],
    /// Share of each angle's weighted column the 15 errors cannot imitate.
    outside_span: [f64; N_ANGLES],
    /// Standard deviation of each estimate under the declared sensors, °.
    predicted_std_deg: [f64; N_ANGLES],
}

fn hooke_axes(
    cfg: &Config,
    poses: &crate::model::NominalPoses,
    solver: &crate::identify::LinearSolver,
) -> Result<HookeAxes> {
    let h3 = angle_design(&cfg.nominal(), &Angles::zeros(), &poses.joints)
        .map_err(|e| Error::config(&cfg.source, format!("poses: {e}")))?;
    let ext = SecondClassSolver::new(solver, &h3, cfg.identification.rank_tolerance)
        .map_err(|why| Error::config(&cfg.source, format!("identification.second_class {why}")))?;
    let sigma = ObservationCovariance::new(&cfg.sensors.covariances(), &poses.joints);
    let sd = ext.predicted_std(solver, &sigma);
    Ok(HookeAxes {
        rank: ext.rank(solver),
        names: ANGLE_NAMES,
        identifiable: ext.identifiable(),
        outside_span: ext.outside_span(solver),
        predicted_std_deg: std::array::from_fn(|k| sd[N_PARAMS + k]),
    })
}
