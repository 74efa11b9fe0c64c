//! The hexapod's commands (`[mechanism] kind = "hexapod"`): identifiability,
//! simulate, identify, compensate (corrected actuator commands) and export. The other commands refuse a hexapod config in
//! one sentence until they run it.

use crate::cli::{console, OutputFormat};
use crate::error::{Error, Result};
use crate::io;
use crate::mechanism::hexapod::config::HexapodConfig;
use crate::mechanism::hexapod::convention::{self, CONVENTION};
use crate::mechanism::hexapod::identify::{convention_rank, identifiability, identify, predict};
use crate::mechanism::hexapod::{error_names, is_angle, Errors, Pose, LEGS, N_ERRORS};
use nalgebra::DVector;
use rand::rngs::Xoshiro256PlusPlus;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use std::path::Path;

/// The most a reading may differ from the nominal machine's at its pose.
const MAX_READING_OFFSET_DEG: f64 = 10.0;

/// The readings' header: the target pose, then each instrumented angle.
pub fn header(cfg: &HexapodConfig) -> Vec<String> {
    let mut h: Vec<String> = ["x_mm", "y_mm", "z_mm", "a_deg", "b_deg", "c_deg"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    for i in 1..=LEGS {
        for (k, name) in ["phi", "psi"].iter().enumerate() {
            if cfg.hexapod.encoders.reads(k) {
                h.push(format!("{name}{i}_deg"));
            }
        }
    }
    h
}

/// `identifiability`: the rank over the 54 (or 48) errors at the config's
/// poses, the convention and the combinations no reading sees.
pub fn run_identifiability(cfg: &HexapodConfig, format: OutputFormat) -> Result<()> {
    let fail = |why: String| Error::config(&cfg.source, format!("poses: {why}"));
    let a = identifiability(&cfg.hexapod, &cfg.poses, cfg.rank_tolerance).map_err(fail)?;
    let (rank_free, free) =
        convention_rank(&cfg.hexapod, &cfg.poses, cfg.rank_tolerance).map_err(fail)?;
    match format {
        OutputFormat::Json => {
            let v = serde_json::json!({
                "mechanism": "hexapod",
                "poses": cfg.poses.len(),
                "readings_per_pose": cfg.hexapod.readings_per_pose(),
                "rank": a.rank,
                "parameters": a.parameters,
                "convention": CONVENTION,
                "free_after_convention": free,
                "rank_after_convention": rank_free,
                "condition_number_identifiable": finite_or_null(a.condition_number_identifiable),
                "singular_values": a.singular_values,
                "null_directions": a.unidentifiable_combinations,
            });
            let text = serde_json::to_string_pretty(&v)
                .map_err(|e| Error::Argument(format!("json: {e}")))?;
            console::text(format!("{text}\n"));
        }
        OutputFormat::Text => {
            let mut out = format!(
                "hexapod, {} poses, {} readings each: rank {} of {} errors\n",
                cfg.poses.len(),
                cfg.hexapod.readings_per_pose(),
                a.rank,
                a.parameters
            );
            out += &format!(
                "{} combinations no internal sensor sees; the convention fixes them: {CONVENTION}\n",
                a.parameters - a.rank
            );
            out += &format!(
                "after the convention: rank {rank_free} of {free} free errors{}\n",
                if rank_free == free {
                    " (every free error identified)"
                } else {
                    ": these poses leave some undetermined; add poses"
                }
            );
            if a.condition_number_identifiable.is_finite() {
                out += &format!(
                    "condition number over the identifiable errors: {:.3e}\n",
                    a.condition_number_identifiable
                );
            }
            console::text(out);
        }
    }
    Ok(())
}

fn finite_or_null(x: f64) -> serde_json::Value {
    if x.is_finite() {
        serde_json::json!(x)
    } else {
        serde_json::Value::Null
    }
}

/// `simulate`: the encoders' readings of the machine with the config's
/// [errors] at its poses, from exact forward kinematics, with white
/// reading noise of `sensors.encoder_noise_arcsec` unless `noise_free`.
pub fn run_simulate(cfg: &HexapodConfig, seed: u64, noise_free: bool, out: &Path) -> Result<()> {
    let errors = cfg.errors.ok_or_else(|| {
        Error::config(
            &cfg.source,
            "errors: simulate needs an [errors] table (the simulated machine's errors)",
        )
    })?;
    let sigma_deg = if noise_free {
        0.0
    } else {
        cfg.encoder_noise_arcsec / 3600.0
    };
    let normal = Normal::new(0.0, sigma_deg.max(f64::MIN_POSITIVE))
        .map_err(|e| Error::Argument(format!("noise: {e}")))?;
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let mut csv = header(cfg).join(",");
    csv.push('\n');
    for (j, (target, x)) in cfg.poses.iter().zip(&cfg.pose_list).enumerate() {
        let r = cfg
            .hexapod
            .readings(&errors, target)
            .map_err(|why| Error::config(&cfg.source, format!("poses.list[{}]: {why}", j + 1)))?;
        let cells: Vec<String> = x
            .iter()
            .copied()
            .chain(r.into_iter().map(|v| {
                v + if sigma_deg > 0.0 {
                    normal.sample(&mut rng)
                } else {
                    0.0
                }
            }))
            .map(|v| format!("{v}"))
            .collect();
        csv += &cells.join(",");
        csv.push('\n');
    }
    io::write_output(out, csv.as_bytes())?;
    let message = format!(
        "wrote {} hexapod poses' readings ({}) to {}",
        cfg.poses.len(),
        if sigma_deg > 0.0 {
            format!("σ {}″, seed {seed}", cfg.encoder_noise_arcsec)
        } else {
            "noise-free".into()
        },
        out.display()
    );
    if io::is_stdout(out) {
        console::note(message);
    } else {
        console::line(message);
    }
    Ok(())
}

/// `identify`: the errors from a readings file, by Gauss–Newton in the
/// convention's free directions; identified.csv in `out`.
pub fn run_identify(cfg: &HexapodConfig, readings: &Path, out: &Path) -> Result<()> {
    let (file, bytes) = io::read_bytes(readings)?;
    let head = header(cfg);
    let cols: Vec<&str> = head.iter().map(String::as_str).collect();
    let (table, _) = io::read_table(&file, &bytes, &cols, &[])?;
    let most = crate::mechanism::hexapod::config::MAX_POSES;
    if table.rows.len() > most {
        return Err(Error::csv(
            &file,
            format!(
                "has {} poses; identify reads at most {most} (a dense design of {} rows each): split the log",
                table.rows.len(),
                cfg.hexapod.readings_per_pose()
            ),
        ));
    }
    let mut targets = Vec::with_capacity(table.rows.len());
    let mut measured = Vec::with_capacity(table.rows.len() * cfg.hexapod.readings_per_pose());
    let zero = [0.0; N_ERRORS];
    for (line, cells) in &table.rows {
        let mut v = Vec::with_capacity(cells.len());
        for (c, cell) in cols.iter().zip(cells) {
            v.push(io::number(&file, *line, c, cell)?);
        }
        let x: [f64; 6] = std::array::from_fn(|k| v[k]);
        if x[3..].iter().any(|a| a.abs() > 90.0) {
            return Err(Error::csv(
                &file,
                format!("line {line}: the pose's angles must be within ±90°"),
            ));
        }
        let target = Pose::from_xyzabc(&x);
        // A reading far from what the nominal machine reads there is not a
        // calibration's error (a wrapped angle, a column swapped, a log of
        // another machine): named here, before any fit.
        let nominal = cfg
            .hexapod
            .readings(&zero, &target)
            .map_err(|why| Error::csv(&file, format!("line {line}: the target pose {why}")))?;
        for (k, (r, n)) in v[6..].iter().zip(&nominal).enumerate() {
            if (r - n).abs() > MAX_READING_OFFSET_DEG {
                return Err(Error::csv(
                    &file,
                    format!(
                        "line {line}: {} = {r}° is {:.3}° from what the nominal machine reads at that pose ({n:.4}°); a calibration moves a reading by well under {MAX_READING_OFFSET_DEG}°: is the angle wrapped, the column another, or the log another machine's?",
                        cols[6 + k],
                        r - n
                    ),
                ));
            }
        }
        targets.push(target);
        measured.extend_from_slice(&v[6..]);
    }
    let measured = DVector::from_vec(measured);
    let (rank_free, free) = convention_rank(&cfg.hexapod, &targets, cfg.rank_tolerance)
        .map_err(|why| Error::csv(&file, why))?;
    if rank_free < free {
        return Err(Error::csv(
            &file,
            format!(
                "its {} pose(s) determine {rank_free} of the {free} free errors: log more poses, spread in position and orientation",
                targets.len()
            ),
        ));
    }
    let sigma = (cfg.encoder_noise_arcsec > 0.0).then(|| cfg.encoder_noise_arcsec / 3600.0);
    let id = identify(&cfg.hexapod, &targets, &measured, cfg.iterations, sigma).map_err(|why| {
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
    let _lock = io::claim_dir(out)?;
    let path = out.join(crate::store::names::IDENTIFIED_CSV);
    let mut outputs = io::Outputs::default();
    // An earlier identify's other files in this directory are not this
    // run's: removed, as identify removes them.
    outputs.replace_all(out, &crate::store::names::IDENTIFY_FILES);
    outputs.add(path.clone(), identified_csv(cfg, &id).into_bytes());
    let summary = fit_json(cfg, &id, targets.len(), rank_free, free, sigma.is_some())?;
    let rejected = summary.contains("\"passed\": false");
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
            id.sigma_deg * 3600.0
        ));
    }
    console::line(format!(
        "identified {free} free errors of {} from {} poses ({} Gauss–Newton step(s)); readings' residual RMS {:.3}″ (σ {:.3}″ {}); the convention: {CONVENTION}; wrote {}",
        cfg.hexapod.error_indices().len(),
        targets.len(),
        id.iterations,
        rms * 3600.0,
        id.sigma_deg * 3600.0,
        if sigma.is_some() { "as sensors.encoder_noise_arcsec states" } else { "from the residuals" },
        path.display()
    ));
    Ok(())
}

/// identified.csv: one row per error the machine has; lengths in
/// `estimate_mm` and `std_uncertainty_mm`, the encoders' zeros in
/// `estimate_deg` and `std_uncertainty_deg`; `source` says what the
/// convention did with it.
fn identified_csv(
    cfg: &HexapodConfig,
    id: &crate::mechanism::hexapod::identify::Identified,
) -> String {
    let names = error_names();
    let sd = id.std();
    let mut s = String::from(
        "parameter,estimate_mm,std_uncertainty_mm,estimate_deg,std_uncertainty_deg,source\n",
    );
    for j in cfg.hexapod.error_indices() {
        let v = if id.errors[j] == 0.0 {
            0.0
        } else {
            id.errors[j]
        };
        let cells = format!("{v},{}", sd[j]);
        let (mm, deg) = if is_angle(j) {
            (",".to_string(), cells)
        } else {
            (cells, ",".to_string())
        };
        // A source with a comma ("in the plane of p1, p2, p3") is quoted.
        let source = convention::source(j);
        let source = if source.contains(',') {
            format!("\"{source}\"")
        } else {
            source.to_string()
        };
        s += &format!("{},{mm},{deg},{source}\n", names[j]);
    }
    s
}

/// The identified errors from `path` (identify's identified.csv): one row
/// per error this machine has, each once, lengths in `estimate_mm` and the
/// encoders' zeros in `estimate_deg`.
pub fn read_identified(cfg: &HexapodConfig, path: &Path) -> Result<Errors> {
    let (file, bytes) = io::read_bytes(path)?;
    let cols = ["parameter", "estimate_mm", "estimate_deg"];
    let (table, _) = io::read_table(&file, &bytes, &cols, &["source"])?;
    let names = error_names();
    let present = cfg.hexapod.error_indices();
    let mut e = [0.0; N_ERRORS];
    let mut seen = [false; N_ERRORS];
    for (line, cells) in &table.rows {
        let name = cells[0].as_str();
        let Some(j) = names
            .iter()
            .position(|n| n == name)
            .filter(|j| present.contains(j))
        else {
            return Err(Error::csv(
                &file,
                format!("line {line}: {name} is not an error of this hexapod (dbx1 … dpsi6, as hexapod.encoders reads)"),
            ));
        };
        if seen[j] {
            return Err(Error::csv(
                &file,
                format!("line {line}: {name} is listed twice"),
            ));
        }
        seen[j] = true;
        let (col, cell) = if is_angle(j) {
            ("estimate_deg", &cells[2])
        } else {
            ("estimate_mm", &cells[1])
        };
        let v = io::number(&file, *line, col, cell)?;
        let cap = if is_angle(j) { 5.0 } else { 10.0 };
        if v.abs() > cap {
            return Err(Error::csv(
                &file,
                format!("line {line}: {name} = {v} is beyond ±{cap}, not a calibration's size"),
            ));
        }
        e[j] = v;
    }
    if let Some(j) = present.iter().find(|&&j| !seen[j]) {
        return Err(Error::csv(
            &file,
            format!(
                "{} is missing: identified.csv lists every error of the machine",
                names[*j]
            ),
        ));
    }
    Ok(e)
}

/// Refuse a fit whose misfit check failed (identify's identifiability.json
/// beside identified.csv), unless the user accepts it.
fn gate_rejected_fit(identified: &Path, accept: bool) -> Result<()> {
    let beside = identified
        .parent()
        .unwrap_or(Path::new("."))
        .join(crate::store::names::IDENTIFIABILITY_JSON);
    let Ok((_, bytes)) = io::read_bytes(&beside) else {
        return Ok(());
    };
    let Ok(fit) = serde_json::from_slice::<serde_json::Value>(&bytes) else {
        return Ok(());
    };
    if fit["checks"]["misfit"]["passed"] != false {
        return Ok(());
    }
    let why = format!(
        "the readings' residual RMS {:.3}″ against a stated σ of {:.3}″, p = {:.2e}",
        fit["residual_rms_arcsec"].as_f64().unwrap_or(f64::NAN),
        fit["sigma_arcsec"].as_f64().unwrap_or(f64::NAN),
        fit["checks"]["misfit"]["p_value"].as_f64().unwrap_or(0.0)
    );
    if accept {
        console::note(format!(
            "warning: applying a fit its own checks rejected ({why}), as --accept-rejected-fit asks"
        ));
        return Ok(());
    }
    Err(Error::csv(
        identified.display().to_string(),
        format!("identify's misfit check rejected this fit ({why}): the readings do not fit the machine within their stated noise; find the cause and identify again, or pass --accept-rejected-fit to use it anyway"),
    ))
}

/// `export --format linuxcnc`: genhexkins.hal and joints.ini of the
/// identified geometry in `out`.
pub fn run_export(
    cfg: &HexapodConfig,
    identified: &Path,
    out: &Path,
    accept_rejected_fit: bool,
) -> Result<()> {
    gate_rejected_fit(identified, accept_rejected_fit)?;
    use crate::mechanism::hexapod::export::{genhexkins_hal, joints_ini};
    use crate::store::names::{GENHEXKINS_HAL, JOINTS_INI, LINUXCNC_FILES};
    let errors = read_identified(cfg, identified)?;
    let header = vec![
        format!(
            "tricept-calib {}: the hexapod geometry identified in {}",
            env!("CARGO_PKG_VERSION"),
            identified.display()
        ),
        format!("config {}; mm; the convention: {CONVENTION}", cfg.source),
    ];
    let mut hal_header = header.clone();
    hal_header.push("after `loadrt genhexkins`: base joints in world coordinates, platform joints in platform coordinates".into());
    let mut ini_header = header;
    ini_header.push("each strut's length at the home pose (the nominal length plus the identified leg offset), mm".into());
    let _lock = io::claim_dir(out)?;
    let mut outputs = io::Outputs::default();
    outputs.replace_all(out, &LINUXCNC_FILES);
    outputs.add(
        out.join(GENHEXKINS_HAL),
        genhexkins_hal(&cfg.hexapod, &errors, &hal_header).into_bytes(),
    );
    outputs.add(
        out.join(JOINTS_INI),
        joints_ini(&cfg.hexapod, &errors, &ini_header).into_bytes(),
    );
    outputs.write()?;
    console::line(format!(
        "wrote {} (36 genhexkins pins) and {} (6 joints' homes) to {}",
        GENHEXKINS_HAL,
        JOINTS_INI,
        out.display()
    ));
    Ok(())
}

/// `compensate`: each target pose's actuator commands by the identified
/// machine's inverse kinematics (the config's poses without `--targets`),
/// in `out`/commands.csv beside the nominal ones. With the config's
/// [errors] (a simulated machine), each row also says how far the true
/// machine lands from the target with either, by its exact forward
/// kinematics: the platform origin's position error (mm) and the
/// orientation error (arc seconds).
pub fn run_compensate(
    cfg: &HexapodConfig,
    identified: &Path,
    out: &Path,
    targets: Option<&Path>,
    accept_rejected_fit: bool,
) -> Result<()> {
    use crate::mechanism::hexapod::kinematics::rotation_angle;
    use crate::mechanism::hexapod::Hexapod;
    gate_rejected_fit(identified, accept_rejected_fit)?;
    let errors = read_identified(cfg, identified)?;
    let (list, poses) = match targets {
        None => (cfg.pose_list.clone(), cfg.poses.clone()),
        Some(path) => read_targets(path)?,
    };
    let hex = &cfg.hexapod;
    let model = hex.actual(&errors);
    // A simulated machine judged in the convention's frames, as the
    // identified one is: its errors carried into the convention by a
    // noise-free fit at the config's poses (the same leg lengths, so the
    // same machine, in the frames the convention fixes).
    let truth = match cfg.errors {
        None => None,
        Some(e) => {
            let exact =
                predict(hex, &e, &cfg.poses).map_err(|why| Error::config(&cfg.source, why))?;
            let fit = identify(hex, &cfg.poses, &exact, 30, None).map_err(|why| {
                Error::config(
                    &cfg.source,
                    format!("poses: the simulated machine cannot be put in the convention's frames at these poses ({why})"),
                )
            })?;
            Some(hex.actual(&fit.errors))
        }
    };
    let mut csv = String::from("x_mm,y_mm,z_mm,a_deg,b_deg,c_deg");
    for i in 1..=LEGS {
        csv += &format!(",q{i}_mm");
    }
    for i in 1..=LEGS {
        csv += &format!(",nominal_q{i}_mm");
    }
    if truth.is_some() {
        csv += ",position_before_mm,position_after_mm,orientation_before_arcsec,orientation_after_arcsec";
    }
    csv.push('\n');
    let mut worst = [0.0f64; 4];
    for (j, (x, target)) in list.iter().zip(&poses).enumerate() {
        let corrected = hex.commands_of(&model, target);
        let nominal = hex.commands(target);
        let mut cells: Vec<String> = x.iter().map(|v| format!("{v}")).collect();
        cells.extend(corrected.iter().chain(&nominal).map(|v| format!("{v}")));
        if let Some(m) = &truth {
            let reach = |q: &[f64; LEGS]| {
                Hexapod::forward(m, q, target).map_err(|why| {
                    Error::csv(
                        targets.map_or(cfg.source.clone(), |p| p.display().to_string()),
                        format!("target {}: the simulated machine {why}", j + 1),
                    )
                })
            };
            let (before, after) = (reach(&nominal)?, reach(&corrected)?);
            let errs = [
                (before.t - target.t).norm(),
                (after.t - target.t).norm(),
                rotation_angle(&(before.r * target.r.transpose())).to_degrees() * 3600.0,
                rotation_angle(&(after.r * target.r.transpose())).to_degrees() * 3600.0,
            ];
            for (w, e) in worst.iter_mut().zip(errs) {
                *w = w.max(e);
            }
            cells.extend(errs.iter().map(|v| format!("{v}")));
        }
        csv += &cells.join(",");
        csv.push('\n');
    }
    let _lock = io::claim_dir(out)?;
    let path = out.join(crate::store::names::COMMANDS_CSV);
    let mut outputs = io::Outputs::default();
    outputs.replace_all(out, &crate::store::names::COMPENSATE_FILES);
    outputs.add(path.clone(), csv.into_bytes());
    outputs.write()?;
    let mut msg = format!(
        "wrote {} targets' corrected actuator commands to {}",
        poses.len(),
        path.display()
    );
    if truth.is_some() {
        msg += &format!(
            "; the simulated machine, in the convention's frames ({CONVENTION}), lands within {:.4} mm and {:.2}″ of the targets with them, {:.4} mm and {:.1}″ with the nominal commands",
            worst[1], worst[3], worst[0], worst[2]
        );
    }
    console::line(msg);
    Ok(())
}

/// A targets CSV: x_mm,y_mm,z_mm,a_deg,b_deg,c_deg per row.
fn read_targets(path: &Path) -> Result<(Vec<[f64; 6]>, Vec<Pose>)> {
    let (file, bytes) = io::read_bytes(path)?;
    let cols = ["x_mm", "y_mm", "z_mm", "a_deg", "b_deg", "c_deg"];
    let (table, _) = io::read_table(&file, &bytes, &cols, &[])?;
    if table.rows.len() > crate::mechanism::hexapod::config::MAX_POSES {
        return Err(Error::csv(
            &file,
            format!(
                "has {} targets; at most {} are read",
                table.rows.len(),
                crate::mechanism::hexapod::config::MAX_POSES
            ),
        ));
    }
    let mut list = Vec::with_capacity(table.rows.len());
    for (line, cells) in &table.rows {
        let mut x = [0.0; 6];
        for (k, (c, cell)) in cols.iter().zip(cells).enumerate() {
            x[k] = io::number(&file, *line, c, cell)?;
        }
        if x[3..].iter().any(|a| a.abs() > 90.0) {
            return Err(Error::csv(
                &file,
                format!("line {line}: the pose's angles must be within ±90°"),
            ));
        }
        list.push(x);
    }
    let poses = list.iter().map(Pose::from_xyzabc).collect();
    Ok((list, poses))
}

/// identify's identifiability.json for the hexapod: the rank, the
/// convention, the readings' σ and the misfit check, and the free errors'
/// correlations.
fn fit_json(
    cfg: &HexapodConfig,
    id: &crate::mechanism::hexapod::identify::Identified,
    poses: usize,
    rank: usize,
    free: usize,
    stated_sigma: bool,
) -> Result<String> {
    use statrs::distribution::{ChiSquared, ContinuousCDF};
    let names = error_names();
    let sd = id.std();
    let kept: Vec<usize> = (0..N_ERRORS).filter(|&j| sd[j] > 0.0).collect();
    let matrix: Vec<Vec<f64>> = kept
        .iter()
        .map(|&a| {
            kept.iter()
                .map(|&b| id.covariance[(a, b)] / (sd[a] * sd[b]))
                .collect()
        })
        .collect();
    let m = poses * cfg.hexapod.readings_per_pose();
    let rss_over_sigma2 = if id.sigma_deg > 0.0 {
        id.residual_rms_deg.powi(2) * m as f64 / id.sigma_deg.powi(2)
    } else {
        0.0
    };
    let checks = if stated_sigma && id.dof > 0 {
        let p = ChiSquared::new(id.dof as f64)
            .map(|c| c.sf(rss_over_sigma2))
            .unwrap_or(f64::NAN);
        serde_json::json!({
            "misfit": {
                "chi2": rss_over_sigma2,
                "dof": id.dof,
                "p_value": if p.is_finite() { serde_json::json!(p) } else { serde_json::Value::Null },
                // The readings fit worse than their stated σ allows (1 in
                // 1,000 by chance): a model or sensor error beyond the noise.
                "passed": p.is_finite() && p >= 1e-3,
            }
        })
    } else {
        serde_json::json!({"misfit": "not tested: σ taken from the residuals (state sensors.encoder_noise_arcsec to test the fit)"})
    };
    let v = serde_json::json!({
        "mechanism": "hexapod",
        "poses": poses,
        "readings_per_pose": cfg.hexapod.readings_per_pose(),
        "rank_after_convention": rank,
        "free_after_convention": free,
        "convention": CONVENTION,
        "iterations": id.iterations,
        "sigma_arcsec": id.sigma_deg * 3600.0,
        "sigma_from": if stated_sigma { "sensors.encoder_noise_arcsec" } else { "residuals" },
        "residual_rms_arcsec": id.residual_rms_deg * 3600.0,
        "checks": checks,
        "correlations": {
            "names": kept.iter().map(|&j| names[j].clone()).collect::<Vec<_>>(),
            "matrix": matrix,
        },
    });
    serde_json::to_string_pretty(&v)
        .map(|t| t + "\n")
        .map_err(|e| Error::Argument(format!("json: {e}")))
}

/// `export --format json`: geometry.json from identified.csv and the
/// identifiability.json identify wrote beside it.
pub fn run_export_json(
    cfg: &HexapodConfig,
    identified: &Path,
    out: &Path,
    accept_rejected_fit: bool,
) -> Result<()> {
    gate_rejected_fit(identified, accept_rejected_fit)?;
    use crate::mechanism::hexapod::export::{geometry_json, Fit};
    let errors = read_identified(cfg, identified)?;
    let std = read_std(identified)?;
    let beside = identified
        .parent()
        .unwrap_or(Path::new("."))
        .join(crate::store::names::IDENTIFIABILITY_JSON);
    let (file, bytes) = io::read_bytes(&beside).map_err(|_| {
        Error::csv(
            beside.display().to_string(),
            "is missing: export --format json reads the identifiability.json identify wrote beside identified.csv (its correlations and checks)",
        )
    })?;
    let fit: serde_json::Value = serde_json::from_slice(&bytes)
        .map_err(|e| Error::csv(&file, format!("is not identify's JSON ({e})")))?;
    if fit["mechanism"] != "hexapod" {
        return Err(Error::csv(&file, "is not a hexapod's identify output"));
    }
    let names: Vec<String> = fit["correlations"]["names"]
        .as_array()
        .map(|a| {
            a.iter()
                .filter_map(|v| v.as_str().map(String::from))
                .collect()
        })
        .unwrap_or_default();
    let matrix: Vec<Vec<f64>> = fit["correlations"]["matrix"]
        .as_array()
        .map(|rows| {
            rows.iter()
                .map(|r| {
                    r.as_array()
                        .map(|c| c.iter().filter_map(|x| x.as_f64()).collect())
                        .unwrap_or_default()
                })
                .collect()
        })
        .unwrap_or_default();
    if matrix.len() != names.len() || matrix.iter().any(|r| r.len() != names.len()) {
        return Err(Error::csv(
            &file,
            "correlations: the matrix is not one row and column per name",
        ));
    }
    let geometry = geometry_json(
        &cfg.hexapod,
        &errors,
        &Fit {
            std: &std,
            correlations: (names, matrix),
            checks: fit["checks"].clone(),
            sources: (0..N_ERRORS).map(convention::source).collect(),
        },
        CONVENTION,
    );
    let text = serde_json::to_string_pretty(&geometry)
        .map_err(|e| Error::Argument(format!("json: {e}")))?
        + "\n";
    let _lock = io::claim_dir(out)?;
    let path = out.join(crate::store::names::GEOMETRY_JSON);
    let mut outputs = io::Outputs::default();
    outputs.add(path.clone(), text.into_bytes());
    outputs.write()?;
    console::line(format!(
        "wrote the calibrated geometry to {}",
        path.display()
    ));
    Ok(())
}

/// Each error's standard uncertainty from identified.csv (0 where absent).
fn read_std(path: &Path) -> Result<Errors> {
    let (file, bytes) = io::read_bytes(path)?;
    let cols = ["parameter", "std_uncertainty_mm", "std_uncertainty_deg"];
    let (table, _) = io::read_table(&file, &bytes, &cols, &[])?;
    let names = error_names();
    let mut sd = [0.0; N_ERRORS];
    for (line, cells) in &table.rows {
        if let Some(j) = names.iter().position(|n| *n == cells[0]) {
            let (col, cell) = if is_angle(j) {
                (cols[2], &cells[2])
            } else {
                (cols[1], &cells[1])
            };
            let v = io::number(&file, *line, col, cell)?;
            if v < 0.0 {
                return Err(Error::csv(&file, format!("line {line}: {col} is negative")));
            }
            sd[j] = v;
        }
    }
    Ok(sd)
}

/// `verify`: an identified hexapod against a fresh log. For each row the
/// pose the identified machine reaches with the commands it was given (the
/// identified machine's own, or with `--nominal-commands` the nominal
/// ones), against the pose its encoders' readings put it at (through the
/// same identified machine): their distance is how far the model's
/// prediction of the platform is from where the readings say it stood. It
/// passes when every row is within `threshold_mm` (exit 3 otherwise).
pub fn run_verify(
    cfg: &HexapodConfig,
    identified: &Path,
    readings: &Path,
    threshold_mm: f64,
    nominal_commands: bool,
) -> Result<()> {
    use crate::mechanism::hexapod::kinematics::{pose_from_readings, rotation_angle};
    use crate::mechanism::hexapod::Hexapod;
    if !(threshold_mm.is_finite() && threshold_mm > 0.0) {
        return Err(Error::Argument(format!(
            "--threshold must be a positive number of mm (got {threshold_mm})"
        )));
    }
    let errors = read_identified(cfg, identified)?;
    let model = cfg.hexapod.actual(&errors);
    let (file, bytes) = io::read_bytes(readings)?;
    let head = header(cfg);
    let cols: Vec<&str> = head.iter().map(String::as_str).collect();
    let (table, _) = io::read_table(&file, &bytes, &cols, &[])?;
    let most = crate::mechanism::hexapod::config::MAX_POSES;
    if table.rows.len() > most {
        return Err(Error::csv(
            &file,
            format!(
                "has {} poses; verify reads at most {most}",
                table.rows.len()
            ),
        ));
    }
    let mut worst = (0.0f64, 0.0f64, 0u64);
    for (line, cells) in &table.rows {
        let mut v = Vec::with_capacity(cells.len());
        for (c, cell) in cols.iter().zip(cells) {
            v.push(io::number(&file, *line, c, cell)?);
        }
        let x: [f64; 6] = std::array::from_fn(|k| v[k]);
        if x[3..].iter().any(|a| a.abs() > 90.0) {
            return Err(Error::csv(
                &file,
                format!("line {line}: the pose's angles must be within ±90°"),
            ));
        }
        let target = Pose::from_xyzabc(&x);
        let q = if nominal_commands {
            cfg.hexapod.commands(&target)
        } else {
            cfg.hexapod.commands_of(&model, &target)
        };
        let reached = Hexapod::forward(&model, &q, &target).map_err(|why| {
            Error::csv(&file, format!("line {line}: the identified machine {why}"))
        })?;
        let seen = pose_from_readings(&cfg.hexapod, &model, &v[6..], &reached)
            .map_err(|why| Error::csv(&file, format!("line {line}: {why}")))?;
        let d = (seen.t - reached.t).norm();
        let a = rotation_angle(&(seen.r * reached.r.transpose())).to_degrees() * 3600.0;
        if d > worst.0 {
            worst = (d, worst.1, *line);
        }
        worst.1 = worst.1.max(a);
    }
    let text = format!(
        "{} poses: the identified machine puts the platform within {:.4} mm and {:.2}″ of where the encoders say it stood (worst at line {}); threshold {threshold_mm} mm",
        table.rows.len(),
        worst.0,
        worst.1,
        worst.2
    );
    if worst.0 > threshold_mm {
        return Err(Error::TargetNotMet(format!("{file}: FAIL: {text}")));
    }
    console::line(format!("PASS: {text}"));
    Ok(())
}
