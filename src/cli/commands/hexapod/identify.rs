//! `identify` for the hexapod.

use super::files::{fit_json, identified_csv, misfit, read_log, Predicted, HELD_OUT_LIMIT};
use crate::cli::console;
use crate::config::hexapod::HexapodConfig;
use crate::error::{Error, Result};
use crate::identify::general::{convention_rank, held_out, identify, predict, predicted_accuracy};
use crate::io;
use crate::mechanism::hexapod::convention::CONVENTION;
use crate::mechanism::hexapod::{error_names, is_angle, N_ERRORS};
use nalgebra::DVector;
use std::path::Path;

/// `identify`: the errors from a readings file, by Gauss–Newton in the
/// convention's free directions; identified.csv in `out`.
pub fn run_identify(cfg: &HexapodConfig, readings: &Path, out: &Path) -> Result<()> {
    let log = read_log(cfg, readings, "identify")?;
    let (file, targets) = (log.file.clone(), log.targets.clone());
    let measured = DVector::from_vec(log.readings);
    let (rank_free, free) = convention_rank(&cfg.hexapod, &targets, cfg.rank_tolerance, &cfg.holds)
        .map_err(|why| Error::csv(&file, why))?;
    // A prior holds what the readings cannot see: the fit is taken.
    let prior = cfg.holds.prior_std_mm.is_some() || cfg.holds.prior_std_deg.is_some();
    if rank_free < free && !prior {
        return Err(Error::csv(
            &file,
            format!(
                "its {} pose(s) determine {rank_free} of the {free} free errors: log more poses, spread in position and orientation",
                targets.len()
            ),
        ));
    }
    let sigma = (cfg.encoder_noise_arcsec > 0.0).then(|| cfg.encoder_noise_arcsec / 3600.0);
    let stated: Vec<f64> = sigma.into_iter().collect();
    let id = identify(&cfg.hexapod, &targets, &measured, cfg.iterations, &stated, &cfg.holds).map_err(|why| {
        Error::csv(
            &file,
            format!("the fit failed ({why}): do the readings belong to this config's machine and poses?"),
        )
    })?;
    // A fit that ran beyond any calibration's size is not written.
    let names = error_names();
    if let Some(j) =
        (0..N_ERRORS).find(|&j| id.errors[j].abs() > if is_angle(j) { 5.0 } else { 10.0 })
    {
        return Err(Error::csv(
            &file,
            format!(
                "the fit ran away ({} = {:.3}{}): the readings do not fit this config's machine; check that the log is this machine's, its poses the config's, and its columns as named",
                names[j],
                id.errors[j],
                if is_angle(j) { "°" } else { " mm" }
            ),
        ));
    }
    // The accuracy the compensated machine is predicted to reach, from
    // the estimate's covariance (scaled by √(χ²/dof) where the misfit test
    // rejects the stated σ: the readings are noisier than stated).
    let test = misfit(cfg, &id, targets.len(), sigma.is_some());
    let rejected = test.as_ref().is_some_and(|m| !m.passed());
    let scale = match &test {
        Some(m) if rejected => (m.chi2 / m.dof as f64).sqrt(),
        _ => 1.0,
    };
    let accuracy = predicted_accuracy(
        &cfg.hexapod,
        &(&id.covariance * (scale * scale)),
        &cfg.workspace,
        &cfg.tool_mm,
    )
    .map_err(|why| Error::config(&cfg.source, format!("workspace: {why}")))?;
    let held_out = held_out(
        &cfg.hexapod,
        &targets,
        &measured,
        cfg.iterations,
        &[id.sigma],
        &cfg.holds,
    )
    .map(|h| (h, log.lines[h.worst_pose]));
    let predicted = Predicted {
        accuracy,
        scale,
        held_out,
    };
    let _lock = io::claim_dir(out)?;
    let path = out.join(crate::store::names::IDENTIFIED_CSV);
    let mut outputs = io::Outputs::default();
    // An earlier identify's other files in this directory are not this
    // run's: removed, as identify removes them.
    outputs.replace_all(out, &crate::store::names::IDENTIFY_FILES);
    outputs.add(path.clone(), identified_csv(cfg, &id).into_bytes());
    let summary = fit_json(
        cfg,
        &id,
        targets.len(),
        (rank_free, free),
        sigma.is_some(),
        &predicted,
    )?;
    outputs.add(
        out.join(crate::store::names::IDENTIFIABILITY_JSON),
        summary.into_bytes(),
    );
    outputs.write()?;
    // What the estimate predicts of the readings it was fitted to.
    let fit = predict(&cfg.hexapod, &id.errors, &targets).map_err(|why| Error::csv(&file, why))?;
    let rms = ((&measured - fit).norm_squared() / measured.len() as f64).sqrt();
    if rejected {
        console::note(format!(
            "warning: the readings fit worse than their stated noise allows (residual RMS {:.3}″ against σ {:.3}″): compensate and export refuse this fit unless --accept-rejected-fit",
            rms * 3600.0,
            id.sigma * 3600.0
        ));
    }
    console::line(format!(
        "identified {free} free errors of {} from {} poses ({} Gauss–Newton step(s)); readings' residual RMS {:.3}″ (σ {:.3}″ {}); the convention: {CONVENTION}; wrote {}",
        cfg.hexapod.error_indices().len(),
        targets.len(),
        id.iterations,
        rms * 3600.0,
        id.sigma * 3600.0,
        if sigma.is_some() { "as sensors.encoder_noise_arcsec states" } else { "from the residuals" },
        path.display()
    ));
    if let Some((h, line)) = &predicted.held_out {
        console::line(format!(
            "held out: {} readings predicted from fits to the other poses ({} folds{}): RMS {:.2} of their predicted spread (1 is what the encoders allow), largest {:.1} at line {line}",
            h.readings,
            h.folds,
            if h.folds_skipped > 0 { format!(", {} skipped: too few poses left", h.folds_skipped) } else { String::new() },
            h.rms_z,
            h.max_abs_z,
        ));
        if h.rms_z > HELD_OUT_LIMIT {
            console::note(format!(
                "warning: poses left out are predicted {:.1} times worse than the encoders allow: the model does not carry over to poses it was not fitted to (too few poses, or errors it leaves out); compensate and export refuse this fit unless --accept-rejected-fit",
                h.rms_z
            ));
        }
    }
    let a = &predicted.accuracy;
    console::line(format!(
        "predicted after compensation, from the estimate's uncertainty{}: within {:.4} mm and {:.2}″ everywhere in the workspace's {} poses in 95 % of {} draws (median {:.4} mm, {:.2}″); tool point {:?} mm",
        if predicted.scale > 1.0 {
            format!(" scaled by the misfit ({:.2}×)", predicted.scale)
        } else {
            String::new()
        },
        a.worst[0].1[1],
        a.worst[1].1[1],
        a.poses,
        a.draws,
        a.worst[0].1[0],
        a.worst[1].1[0],
        [cfg.tool_mm.x, cfg.tool_mm.y, cfg.tool_mm.z]
    ));
    Ok(())
}
