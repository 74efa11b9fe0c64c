//! `identify` for any mechanism: Gauss–Newton in the convention's free
//! directions with its checks (`identify::general`).

use super::files::{
    fit_json, identified_csv, misfit, read_log, runaway, sigma_unit, Predicted, HELD_OUT_LIMIT,
};
use crate::cli::console;
use crate::config::general::MechanismConfig;
use crate::error::{Error, Result};
use crate::identify::general::{convention_rank, held_out, identify, predicted_accuracy};
use crate::identify::repeats::{Counted, Unit};
use crate::io;
use crate::mechanism::Mechanism;
use nalgebra::DVector;
use std::path::Path;

/// `identify`: the errors from a readings file, by Gauss–Newton in the
/// convention's free directions; identified.csv in `out`.
pub fn run_identify<C: MechanismConfig>(cfg: &C, readings: &Path, out: &Path) -> Result<()> {
    let m = cfg.machine();
    let holds = cfg.holds();
    let log = read_log(cfg, readings, "identify")?;
    let rows = log.targets.len();
    let facts = m.reading_facts();
    let units: Vec<Unit> = facts
        .iter()
        // Readings in file units (deg, mm): a sensor unit per file unit.
        .map(|f| Unit {
            name: f.symbol,
            scale: f.quantity.sensor_per_model() / f.quantity.to_file(1.0),
            symbol: f.quantity.sensor_symbol(),
        })
        .collect();
    let (white, what) = cfg.reading_sigma();
    let (log, groups, counted, note) = log.by_pose(
        (m.target_columns().len(), m.reading_facts().len()),
        (&white, what),
        &units,
    )?;
    if let Some(note) = note {
        console::note(note);
    }
    let (file, targets) = (log.file.clone(), log.targets.clone());
    let measured = DVector::from_vec(log.readings);
    let (rank_free, free) = convention_rank(m, &targets, cfg.rank_tolerance(), holds)
        .map_err(|why| Error::csv(&file, why))?;
    // A prior holds what the readings cannot see: the fit is taken.
    let prior = holds.prior_std_mm.is_some() || holds.prior_std_deg.is_some();
    if rank_free < free && !prior {
        return Err(Error::csv(
            &file,
            format!(
                "its {} pose(s) determine {rank_free} of the {free} free errors: log more poses, spread over the workspace, or hold at a value (identification.fix) an error no pose can see (identifiability names it)",
                targets.len()
            ),
        ));
    }
    // A mean of n loggings states its fresh noise √n smaller.
    let averaged = match counted {
        Counted::Means(n) => (n as f64).sqrt(),
        Counted::Rows | Counted::Once => 1.0,
    };
    let stated: Vec<f64> = cfg.reading_sigma().0.iter().map(|s| s / averaged).collect();
    let id = identify(m, &targets, &measured, cfg.iterations(), &stated, holds).map_err(|why| {
        Error::csv(
            &file,
            format!("the fit failed ({why}): do the readings belong to this config's machine and poses?"),
        )
    })?;
    // A fit that ran beyond any calibration's size is not written.
    let names = m.error_names();
    if let Some(j) = (0..names.len()).find(|&j| id.errors[j].abs() > runaway(m, j)) {
        return Err(Error::csv(
            &file,
            format!(
                "the fit ran away ({} = {:.3}{}): the readings do not fit this config's machine; check that the log is this machine's, its poses the config's, and its columns as named",
                names[j],
                id.errors[j],
                if m.is_angle(j) { "°" } else { " mm" }
            ),
        ));
    }
    // The accuracy the compensated machine is predicted to reach, from
    // the estimate's covariance (scaled by √(χ²/dof) where the misfit test
    // rejects the stated σ: the readings are noisier than stated).
    let test = misfit(cfg, &id, targets.len(), !stated.is_empty());
    let rejected = test.as_ref().is_some_and(|m| !m.passed());
    let scale = match &test {
        Some(m) if rejected => (m.chi2 / m.dof as f64).sqrt(),
        _ => 1.0,
    };
    let accuracy = predicted_accuracy(
        m,
        &(&id.covariance * (scale * scale)),
        cfg.workspace(),
        &cfg.tool_mm(),
    )
    .map_err(|why| Error::config(cfg.source(), format!("workspace: {why}")))?;
    // Each reading's σ as stated, or the residuals' s for all.
    let sigma = if stated.is_empty() {
        vec![id.sigma]
    } else {
        stated.clone()
    };
    let held_out = held_out(
        m,
        &targets,
        &measured,
        cfg.iterations(),
        &sigma,
        holds,
        &groups,
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
        (
            targets.len(),
            rows,
            groups.iter().max().map_or(targets.len(), |g| g + 1),
        ),
        (rank_free, free),
        !stated.is_empty(),
        &predicted,
    )?;
    outputs.add(
        out.join(crate::store::names::IDENTIFIABILITY_JSON),
        summary.into_bytes(),
    );
    outputs.write()?;
    // The residual RMS at the estimate, weighted by σ₀/σₖ (σ₀'s unit).
    let rms = id.residual_rms;
    let (_, per, u) = sigma_unit(m);
    if rejected {
        console::note(format!(
            "warning: the readings fit worse than their stated noise allows (residual RMS {:.3}{u} against σ {:.3}{u}): compensate and export refuse this fit unless --accept-rejected-fit",
            id.residual_rms * per,
            id.sigma * per
        ));
    }
    console::line(format!(
        "identified {free} free errors of {} from {} poses ({}{} Gauss–Newton step(s)); readings' residual RMS {:.3}{u} (σ {:.3}{u} {}); the convention: {}; wrote {}",
        m.present().len(),
        groups.iter().max().map_or(targets.len(), |g| g + 1),
        if rows > targets.len() || !groups.is_empty() { format!("{rows} rows, ") } else { String::new() },
        id.iterations,
        rms * per,
        id.sigma * per,
        if stated.is_empty() { "from the residuals".into() } else { format!("as {} states", cfg.reading_sigma().1) },
        m.convention(),
        path.display()
    ));
    if let Some((h, line)) = &predicted.held_out {
        console::line(format!(
            "held out: {} readings predicted from fits to the other poses ({} folds{}): RMS {:.2} of their predicted spread (1 is what the readings' σ allows), largest {:.1} at line {line}",
            h.readings,
            h.folds,
            if h.folds_skipped > 0 { format!(", {} skipped: too few poses left", h.folds_skipped) } else { String::new() },
            h.rms_z,
            h.max_abs_z,
        ));
        if h.rms_z > HELD_OUT_LIMIT {
            console::note(format!(
                "warning: poses left out are predicted {:.1} times worse than the readings' σ allows: the model does not carry over to poses it was not fitted to (too few poses, or errors it leaves out); compensate and export refuse this fit unless --accept-rejected-fit",
                h.rms_z
            ));
        }
    }
    let a = &predicted.accuracy;
    // Each judged quantity's value k (0 median, 1 p95): "0.0123 mm", "4.56″".
    let said = |k: usize, join: &str| -> String {
        a.worst
            .iter()
            .map(|(q, v)| match q.unit {
                "mm" => format!("{:.4} mm", v[k]),
                _ => format!("{:.2}″", v[k]),
            })
            .collect::<Vec<_>>()
            .join(join)
    };
    let tool = cfg.tool_mm();
    console::line(format!(
        "predicted after compensation, from the estimate's uncertainty{}: within {} everywhere in the workspace's {} poses in 95 % of {} draws (median {}); tool point {:?} mm",
        if predicted.scale > 1.0 {
            format!(" scaled by the misfit ({:.2}×)", predicted.scale)
        } else {
            String::new()
        },
        said(1, " and "),
        a.poses,
        a.draws,
        said(0, ", "),
        [tool.x, tool.y, tool.z]
    ));
    Ok(())
}
