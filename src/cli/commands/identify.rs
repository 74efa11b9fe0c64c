//! `identify`: identification from a readings file.

use crate::calibration::{self, Checks};
use crate::cli::console;
use crate::config::Config;
use crate::error::Result;
use crate::export::csv::csv_bytes;
use crate::export::rows::{
    identifiability_json, identified_csv, with_entry, with_hooke_axes, CovarianceJson, FittedAngles,
};
use crate::io::{self, Outputs, Source};
use crate::store;
use crate::store::names::{
    IDENTIFIABILITY_JSON, IDENTIFIED_CSV, IDENTIFY_FILES, SENSOR_CURVES_CSV,
};
use std::path::Path;

/// identify's result for scripts (`--json`).
#[derive(serde::Serialize)]
struct IdentifyJson<'a> {
    parameters: Vec<ParameterJson>,
    rank: usize,
    poses: usize,
    method: &'static str,
    checks: &'a Checks,
    /// The Hooke axes' angles, when identified (`second_class = true`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    hooke_axes: Vec<AngleJson>,
}

#[derive(serde::Serialize)]
struct AngleJson {
    parameter: &'static str,
    estimate_deg: f64,
    std_uncertainty_deg: Option<f64>,
    identifiable: bool,
}

#[derive(serde::Serialize)]
struct ParameterJson {
    parameter: &'static str,
    estimate_mm: f64,
    /// None (null) where it does not exist.
    std_uncertainty_mm: Option<f64>,
    identifiable: bool,
    /// Where the value comes from: readings, fixed, prior, unidentifiable.
    source: &'static str,
}

/// `reference`: a file of externally measured points and each
/// coordinate's standard uncertainty, mm (`--reference`, `--reference-sigma`).
pub fn run(
    cfg: &Config,
    readings_path: &Path,
    out: &Path,
    reference: Option<(&Path, f64)>,
    json: bool,
) -> Result<()> {
    let file = readings_path.display().to_string();
    // Memory counted before work: the file's rows first (its lines, counted
    // without holding it), then the log's poses once read.
    let file_bytes = std::fs::metadata(readings_path).map_or(0, |m| m.len());
    let weight_columns = calibration::weight_columns(cfg);
    if let Some(lines) = crate::io::count_lines(readings_path) {
        crate::montecarlo::memory::check_identify(
            lines.saturating_sub(1),
            file_bytes,
            weight_columns,
            &file,
        )?;
    }
    let (readings, lines) = store::inputs::read_readings(readings_path)?;
    crate::montecarlo::memory::check_identify(
        readings.len() as u64,
        file_bytes,
        weight_columns,
        &file,
    )?;
    let rows = readings.len();
    let by_pose = calibration::by_pose(&cfg.sensors, readings, &file, |rows| {
        calibration::check_log(cfg, rows, Source::new(&file, &lines))
    })?;
    if let Some(note) = &by_pose.note {
        console::note(note);
    }
    // Means of several loggings are fitted with their fresh noise averaged.
    let averaged = by_pose.averaged(&cfg.sensors).map(|sensors| {
        let mut c = cfg.clone();
        c.sensors = sensors;
        c
    });
    let cfg = averaged.as_ref().unwrap_or(cfg);
    let readings = by_pose.readings;
    // Each kept reading's line: its row's (its pose's first where repeats
    // were averaged).
    let kept_lines: Vec<u64> = by_pose.rows.iter().map(|&r| lines[r]).collect();
    let mut cal = calibration::identify_from(cfg, &readings, Source::new(&file, &kept_lines))?;
    cal.groups = by_pose.groups;
    // The log's distinct poses (its rows where each pose is once).
    let distinct = cal.groups.iter().max().map_or(cal.poses.len(), |g| g + 1);
    // Misfit is never hidden: when the residual is more than the declared
    // sensors explain (χ² rejects at 1 %), the uncertainties are scaled by
    // it and a warning names its size and likely cause.
    let mut checks = calibration::checks(cfg, &cal, &readings);
    // External points: further observations of what the passive limb
    // barely sees (after the readings' own checks, which judge the
    // readings; the predicted accuracy is the combined fit's).
    let reference_update = match reference {
        Some((path, sigma)) => {
            let (points, rlines) = store::inputs::read_reference(path)?;
            let rfile = path.display().to_string();
            let source = Source::new(&rfile, &rlines);
            let u = cal.add_reference(cfg, &points, sigma, source)?;
            let scale = checks
                .misfit
                .filter(|m| m.rejected)
                .map_or(1.0, |m| m.ratio);
            checks.predicted_accuracy = calibration::predicted_accuracy(cfg, &cal, scale);
            Some((u, rfile))
        }
        None => None,
    };
    // The worst held-out pose's line in the file (its first row where
    // repeats were averaged).
    if let Some(h) = checks.held_out.as_mut() {
        let kept = h.worst_line.saturating_sub(crate::io::data_line(0));
        h.worst_line = Source::new(&file, &kept_lines).line(kept) as usize;
    }
    let Checks {
        misfit,
        held_out,
        predicted_accuracy: predicted,
    } = checks;
    if let Some(m) = misfit.filter(|m| m.rejected) {
        cal.estimate.std_mm *= m.ratio;
        if let Some(a) = cal.axes.as_mut() {
            a.std_deg *= m.ratio;
        }
    }
    let (est, solver) = (&cal.estimate, &cal.solver);
    let scale = misfit.filter(|m| m.rejected).map_or(1.0, |m| m.ratio);
    let _lock = io::claim_dir(out)?;
    let mut outputs = Outputs::default();
    outputs.replace_all(out, &IDENTIFY_FILES);
    outputs.add(
        out.join(IDENTIFIED_CSV),
        identified_csv(
            est,
            cfg.unknowns(),
            cal.axes.as_ref().map(|a| FittedAngles {
                values: &a.angles,
                std_deg: &a.std_deg,
                identifiable: &a.identifiable,
            }),
        )?,
    );
    let hooke_axes = cal
        .axes
        .as_ref()
        .map(|a| calibration::AxesAnalysis::of(solver, &a.solver, &cal.stated, cal.unknowns));
    // The estimate's covariance (scaled like the uncertainties when the
    // misfit test rejects): verify sizes what it cannot see from it.
    let cov = calibration::estimate_covariance(&cal) * (scale * scale);
    let names = cfg.unknowns();
    let unknowns: Vec<&'static str> = names
        .errors
        .iter()
        .chain(names.angles.iter())
        .take(cov.nrows())
        .copied()
        .collect();
    let covariance = CovarianceJson {
        unknowns,
        matrix: (0..cov.nrows())
            .map(|i| (0..cov.ncols()).map(|j| cov[(i, j)]).collect())
            .collect(),
    };
    let json_bytes = with_entry(
        with_hooke_axes(
            identifiability_json(
                &cfg.unknowns().errors,
                cfg.identification.method,
                distinct,
                solver.rows(),
                &solver.analysis,
                Some(&checks),
                Some((&cfg.source, &cfg.nominal_keys(), rows)),
            )?,
            hooke_axes.as_ref(),
        )?,
        "covariance",
        &covariance,
    )?;
    outputs.add(out.join(IDENTIFIABILITY_JSON), json_bytes);
    let curves = calibration::sensor_curves(cfg, &cal, &readings);
    if let Some(c) = &curves {
        outputs.add(out.join(SENSOR_CURVES_CSV), csv_bytes(c)?);
    }
    outputs.write()?;
    console::print_estimate(est, &names.errors, None);
    if let Some((u, rfile)) = &reference_update {
        console::line(format_args!(
            "reference: {} externally measured point(s) in {rfile} added to the fit (largest distance from the readings' fit {:.4} mm; χ² = {:.1} on {} degrees of freedom, p = {:.2}){}",
            u.points,
            u.max_innovation_mm,
            u.chi2,
            u.dof,
            u.p_value,
            if u.p_value < crate::calibration::MISFIT_LEVEL {
                ": the points disagree with the readings beyond their uncertainties (--reference-sigma, the frame, or the target of each point)"
            } else {
                ""
            }
        ));
    }
    if let Some(a) = &cal.axes {
        console::line(a.in_words(cal.unknowns));
    }
    if let Some(c) = &curves {
        console::print_curves(c);
        if cal.axes.is_some() {
            console::note(format_args!(
                "note: sensor_curves.csv comes from a Gauss-Newton fit of the 15 errors alone (it does not carry the Hooke axes yet): a misalignment the axes' angles took up may show in the curves"
            ));
        }
    }
    match misfit {
        Some(m) if m.rejected => console::note(format_args!(
            "warning: the readings do not fit the model within the declared sensor noise: χ² = {:.1} on {} degrees of freedom ({}), the residual {:.2} × what [sensors] explains; the uncertainties written are scaled by {:.2}, and compensate will refuse this identified.csv unless --accept-rejected-fit. Likely cause: {}",
            m.chi2,
            m.dof,
            if m.p_value >= 1e-99 { format!("p = {:.1e}", m.p_value) } else { "p < 1e-99".to_string() },
            m.ratio,
            m.ratio,
            calibration::misfit_cause(
                &m,
                est.iterations,
                cal.axes.is_some(),
                &names
                    .errors
                    .iter()
                    .zip(&cfg.identification.constraints.fixed)
                    .filter(|(_, f)| f.is_some())
                    .map(|(n, _)| *n)
                    .collect::<Vec<_>>()
            )
        )),
        Some(m) => console::line(format_args!(
            "misfit: χ² = {:.1} on {} degrees of freedom (p = {:.2}): the residual is what the declared sensors explain ({:.2} × their noise)",
            m.chi2, m.dof, m.p_value, m.ratio
        )),
        None => console::note(format_args!(
            "note: no degrees of freedom or no sensor noise declared: the fit cannot be checked against the sensors"
        )),
    }
    // What compensate will refuse, said now.
    let loose = calibration::loose(&cal);
    if !loose.is_empty() {
        console::note(format_args!(
            "warning: these readings leave {} known to worse than ±{} mm (±{}° for an angle): compensate will refuse this identified.csv (log more poses spread over the workspace)",
            loose.join(", "),
            crate::store::inputs::MAX_USABLE_UNCERTAINTY_MM,
            crate::store::inputs::MAX_USABLE_UNCERTAINTY_DEG
        ));
    }
    if held_out.is_none() && distinct < 2 * calibration::HELD_OUT_FOLDS {
        console::note(format_args!(
            "note: {} poses are too few to leave poses out ({} are needed for the held-out check)",
            distinct,
            2 * calibration::HELD_OUT_FOLDS
        ));
    }
    if let Some(h) = held_out {
        console::line(format_args!(
            "held out: {} predicted from fits to the others ({} folds{}): RMS {:.2} of their predicted spread (1 is what the sensors allow), largest {:.1} at line {}",
            match cal.groups.is_empty() {
                true => format!("{} poses' readings", h.rows / cfg.sensors.slots.len()),
                false => format!("{} rows' readings (whole poses, {distinct} in the log)", h.rows / cfg.sensors.slots.len()),
            },
            h.folds,
            if h.folds_skipped > 0 { format!(", {} skipped: too few poses left", h.folds_skipped) } else { String::new() },
            h.rms_z,
            h.max_abs_z,
            h.worst_line
        ));
        if h.rms_z > crate::store::inputs::HELD_OUT_LIMIT {
            console::note(format_args!(
                "warning: poses left out are predicted {:.1} times worse than the sensors allow: the model does not carry over to poses it was not fitted to (too few poses, or errors it leaves out); compensate will refuse this identified.csv unless --accept-rejected-fit",
                h.rms_z
            ));
        }
    }
    if let Some(p) = predicted {
        console::line(format_args!(
            "predicted accuracy after compensation, from the estimate's uncertainty{} (first order, {} workspace points, {} draws; median and 95 % range): dV max {:.4} mm ({:.4}–{:.4}), p95 {:.4} mm ({:.4}–{:.4}), mean {:.4} mm ({:.4}–{:.4}){}",
            if scale > 1.0 { " scaled by the misfit" } else { "" },
            p.points,
            p.draws,
            p.max_mm[0], p.max_mm[1], p.max_mm[2],
            p.p95_mm[0], p.p95_mm[1], p.p95_mm[2],
            p.mean_mm[0], p.mean_mm[1], p.mean_mm[2],
            if solver.analysis.unidentifiable.is_empty() {
                String::new()
            } else {
                format!("; not counted: {} (unidentifiable: whatever its true value is stays as an error)", solver.analysis.unidentifiable.join(", "))
            }
        ));
    }
    if let Some(p) = predicted {
        console::line(format_args!(
            "of it: relative to the reference pose (what verify's homed rows test) p95 {:.4} mm ({:.4}–{:.4}); at the reference pose, shared by every pose (what only an external point tests, verify --reference) {:.4} mm ({:.4}–{:.4})",
            p.relative_p95_mm[0], p.relative_p95_mm[1], p.relative_p95_mm[2],
            p.at_reference_mm[0], p.at_reference_mm[1], p.at_reference_mm[2],
        ));
    }
    console::warn_unidentifiable(&solver.analysis);
    if let Some(x) = &hooke_axes {
        console::line(x.rank_in_words(solver.analysis.rank));
    }
    if !est.termination.converged() {
        console::note(format_args!(
            "warning: Gauss-Newton did not converge in {} iterations (tolerance {} mm); the last estimate is written",
            est.iterations, cfg.identification.tolerance_mm
        ));
    }
    console::line(format_args!(
        "{} poses{}, method {}, {} linearisation(s) ({}), weighted residual RMS {:.3e}; wrote {}",
        distinct,
        if rows > cal.poses.len() || !cal.groups.is_empty() {
            format!(" ({rows} rows)")
        } else {
            String::new()
        },
        cfg.identification.method.name(),
        est.iterations,
        est.termination.describe(),
        est.residual_rms,
        out.join(IDENTIFIED_CSV).display()
    ));
    if json {
        let est = &cal.estimate;
        console::json(&IdentifyJson {
            parameters: names
                .errors
                .iter()
                .enumerate()
                .map(|(k, name)| ParameterJson {
                    parameter: name,
                    estimate_mm: est.values[k],
                    std_uncertainty_mm: (est.identifiable[k] && est.std_mm[k].is_finite())
                        .then_some(est.std_mm[k]),
                    identifiable: est.identifiable[k],
                    source: est.source[k],
                })
                .collect(),
            rank: cal.solver.analysis.rank,
            poses: distinct,
            method: cfg.identification.method.name(),
            checks: &checks,
            hooke_axes: cal
                .axes
                .iter()
                .flat_map(|a| {
                    (0..a.angles.len()).map(move |k| AngleJson {
                        parameter: names.angles[k],
                        estimate_deg: a.angles[k],
                        std_uncertainty_deg: (a.identifiable[k] && a.std_deg[k].is_finite())
                            .then_some(a.std_deg[k]),
                        identifiable: a.identifiable[k],
                    })
                })
                .collect(),
        })?;
    }
    Ok(())
}
