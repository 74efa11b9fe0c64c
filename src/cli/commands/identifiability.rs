//! `identifiability`: rank, singular values, condition number, O1–O5.

use crate::calibration::HookeAxes;
use crate::cli::{console, OutputFormat};
use crate::config::Config;
use crate::error::{Error, Result};
use crate::export::rows::{identifiability_json, with_hooke_axes};
use crate::export::text::identifiability_text;
use crate::identify::design_matrix;
use crate::identify::second_class::{angle_design, SecondClassSolver};
use crate::model::second_class::{Angles, ANGLE_NAMES, N_ANGLES};
use crate::model::N_PARAMS;

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
            let bytes = with_hooke_axes(bytes, axes.as_ref())?;
            console::text(String::from_utf8_lossy(&bytes));
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
                            match x.predicted_std_deg[k] {
                                Some(sd) => format!("{sd:.5}°"),
                                None => "n/a".into(),
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

fn hooke_axes(
    cfg: &Config,
    poses: &crate::model::NominalPoses,
    solver: &crate::identify::LinearSolver,
) -> Result<HookeAxes> {
    let h3 = angle_design(&cfg.nominal(), &Angles::zeros(), &poses.joints)
        .map_err(|e| Error::config(&cfg.source, format!("poses: {e}")))?;
    let ext = SecondClassSolver::new(solver, &h3, cfg.identification.rank_tolerance)
        .map_err(|why| Error::config(&cfg.source, format!("identification.second_class {why}")))?;
    let sigma =
        crate::sensors::ObservationCovariance::new(&cfg.sensors.covariances(), &poses.joints);
    Ok(HookeAxes::of(solver, &ext, &sigma))
}
