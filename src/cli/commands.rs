//! The commands of SPEC §10, each from a validated [`Config`].

use super::OutputFormat;
use crate::compensate::{volumetric_map, Stats, VolumetricMap};
use crate::config::{check_reachable, Config};
use crate::error::{Error, Result};
use crate::export::plot::{self, BandChart, Curve, Format, HLine, Panel};
use crate::export::{CsvExporter, Exporter, JsonExporter};
use crate::identify::solver::identify as identify_errors;
use crate::identify::{design_matrix, observation_vector, Estimate, Identifiability, LinearSolver};
use crate::io::{self, Outputs};
use crate::model::poses::midplane_grid;
use crate::model::{ErrorVector, Machine, PARAM_NAMES};
use crate::sensors::{simulate_readings, NominalPoses, Reading};
use crate::sweep::{self, SweepResult};
use nalgebra::{DMatrix, DVector, Vector3};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Nominal poses of a validated config (validation already checked them).
pub fn config_poses(cfg: &Config) -> Result<NominalPoses> {
    NominalPoses::new(&cfg.nominal(), &cfg.poses)
        .map_err(|(k, e)| Error::config(&cfg.source, format!("poses: pose {k}: {e}")))
}

/// H and the row weights of the config's method.
pub fn design(cfg: &Config, poses: &NominalPoses) -> Result<(DMatrix<f64>, DVector<f64>)> {
    let h = design_matrix(&cfg.nominal(), poses)
        .map_err(|(k, e)| Error::config(&cfg.source, format!("poses: pose {k}: {e}")))?;
    let w = cfg
        .identification
        .method
        .row_weights(h.nrows(), &cfg.sensors);
    Ok((h, w))
}

/// `simulate`: readings of the machine with the config's [errors].
pub fn simulate(cfg: &Config, seed: u64, noise_free: bool, out: &Path) -> Result<()> {
    let poses = config_poses(cfg)?;
    let readings = simulated(cfg, &poses, seed, noise_free)?;
    io::write_atomic(out, &io::readings_csv(&readings)?)?;
    println!(
        "wrote {} readings ({}) to {}",
        readings.len(),
        if noise_free {
            "noise-free".to_string()
        } else {
            format!(
                "encoder {}\", scale {} um, mean of {} samples, seed {seed}",
                cfg.sensors.encoder_arcsec, cfg.sensors.scale_um, cfg.sensors.samples
            )
        },
        out.display()
    );
    Ok(())
}

pub(crate) fn simulated(
    cfg: &Config,
    poses: &NominalPoses,
    seed: u64,
    noise_free: bool,
) -> Result<Vec<Reading>> {
    let mut rng = sweep::stream(seed, u64::MAX, 0);
    let sensors = if noise_free { None } else { Some(&cfg.sensors) };
    simulate_readings(poses, &cfg.truth(), sensors, &mut rng).map_err(|(k, e)| {
        Error::config(
            &cfg.source,
            format!("errors: the machine with these errors cannot reach pose {k}: {e}"),
        )
    })
}

#[derive(Serialize)]
struct IdentifiedRow {
    parameter: &'static str,
    estimate_mm: f64,
    std_uncertainty_mm: f64,
    identifiable: bool,
}

#[derive(Serialize)]
struct IdentifiedTruthRow {
    parameter: &'static str,
    estimate_mm: f64,
    std_uncertainty_mm: f64,
    identifiable: bool,
    true_mm: f64,
    error_mm: f64,
}

/// JSON of the identifiability analysis, with the pose set and method.
#[derive(Serialize)]
struct IdentifiabilityReport<'a> {
    poses: usize,
    rows: usize,
    method: &'static str,
    parameter_names: Vec<&'static str>,
    #[serde(flatten)]
    analysis: &'a Identifiability,
}

pub(crate) fn identifiability_json(
    cfg: &Config,
    poses: usize,
    rows: usize,
    a: &Identifiability,
) -> Result<Vec<u8>> {
    JsonExporter {
        name: "identifiability.json",
    }
    .render(&IdentifiabilityReport {
        poses,
        rows,
        method: cfg.identification.method.name(),
        parameter_names: PARAM_NAMES.to_vec(),
        analysis: a,
    })
}

/// Identify from readings; the error names the readings file and line.
pub fn identify_from(
    cfg: &Config,
    readings: &[Reading],
    file: &str,
) -> Result<(Estimate, LinearSolver, NominalPoses)> {
    let nominal = cfg.nominal();
    for (k, r) in readings.iter().enumerate() {
        check_reachable(&nominal, &r.target, cfg.max_tilt_deg).map_err(|why| {
            Error::csv(
                file,
                format!(
                    "line {}: target ({}, {}, {}) mm is not reachable: {why}",
                    io::data_line(k),
                    r.target.x,
                    r.target.y,
                    r.target.z
                ),
            )
        })?;
    }
    let targets: Vec<Vector3<f64>> = readings.iter().map(|r| r.target).collect();
    let poses = NominalPoses::new(&nominal, &targets)
        .map_err(|(k, e)| Error::csv(file, format!("line {}: {e}", io::data_line(k))))?;
    let h = design_matrix(&nominal, &poses)
        .map_err(|(k, e)| Error::csv(file, format!("line {}: {e}", io::data_line(k))))?;
    let w = cfg
        .identification
        .method
        .row_weights(h.nrows(), &cfg.sensors);
    let joints: Vec<Vector3<f64>> = readings.iter().map(|r| r.joints.as_vector()).collect();
    let l = observation_vector(&poses.joints, &joints);
    let (est, solver) = identify_errors(&cfg.geometry, &poses, &h, &w, &l, &cfg.identification).map_err(|(k, e)| {
        Error::Internal(format!(
            "Gauss-Newton identification failed: the estimated machine cannot reach the pose of line {}: {e}",
            io::data_line(k)
        ))
    })?;
    Ok((est, solver, poses))
}

fn print_estimate(est: &Estimate, truth: Option<&ErrorVector>) {
    println!(
        "{:<6} {:>12} {:>12} {:>13}{}",
        "param",
        "estimate_mm",
        "std_mm",
        "identifiable",
        if truth.is_some() { "      true_mm" } else { "" }
    );
    for (k, name) in PARAM_NAMES.iter().enumerate() {
        print!(
            "{:<6} {:>12.6} {:>12.6} {:>13}",
            name, est.values[k], est.std_mm[k], est.identifiable[k]
        );
        if let Some(t) = truth {
            print!(" {:>12.6}", t[k]);
        }
        println!();
    }
}

fn warn_unidentifiable(a: &Identifiability) {
    if !a.unidentifiable.is_empty() {
        eprintln!(
            "warning: rank {} of {}: {} not identifiable from these poses and sensors (estimate set to 0); null directions: {}",
            a.rank,
            a.parameters,
            a.unidentifiable.join(", "),
            a.unidentifiable_combinations.join("; ")
        );
    }
}

/// `identify`: identification from a readings file.
pub fn identify(cfg: &Config, readings_path: &Path, out: &Path) -> Result<()> {
    let file = readings_path.display().to_string();
    let readings = io::read_readings(readings_path)?;
    let (est, solver, poses) = identify_from(cfg, &readings, &file)?;
    io::ensure_dir(out)?;
    let mut outputs = Outputs::default();
    outputs.add(out.join("identified.csv"), identified_csv(&est)?);
    outputs.add(
        out.join("identifiability.json"),
        identifiability_json(cfg, poses.len(), solver.rows(), &solver.analysis)?,
    );
    outputs.write()?;
    print_estimate(&est, None);
    warn_unidentifiable(&solver.analysis);
    if !est.converged {
        eprintln!(
            "warning: Gauss-Newton did not converge in {} iterations (tolerance {} mm); the last estimate is written",
            est.iterations, cfg.identification.tolerance_mm
        );
    }
    println!(
        "{} poses, method {}, {} linearisation(s), weighted residual RMS {:.3e}; wrote {}",
        poses.len(),
        cfg.identification.method.name(),
        est.iterations,
        est.residual_rms,
        out.join("identified.csv").display()
    );
    Ok(())
}

fn identified_csv(est: &Estimate) -> Result<Vec<u8>> {
    let rows: Vec<IdentifiedRow> = (0..PARAM_NAMES.len())
        .map(|k| IdentifiedRow {
            parameter: PARAM_NAMES[k],
            estimate_mm: est.values[k],
            std_uncertainty_mm: est.std_mm[k],
            identifiable: est.identifiable[k],
        })
        .collect();
    CsvExporter {
        name: "identified.csv",
    }
    .render(&rows[..])
}

/// `identifiability`: rank, singular values, condition number, O1–O5.
pub fn identifiability(cfg: &Config, format: OutputFormat) -> Result<()> {
    let poses = config_poses(cfg)?;
    let (h, w) = design(cfg, &poses)?;
    let solver = LinearSolver::new(&h, &w, cfg.identification.rank_tolerance);
    let a = &solver.analysis;
    match format {
        OutputFormat::Json => {
            let bytes = identifiability_json(cfg, poses.len(), h.nrows(), a)?;
            print!("{}", String::from_utf8_lossy(&bytes));
        }
        OutputFormat::Text => print!("{}", identifiability_text(cfg, poses.len(), a)),
    }
    Ok(())
}

/// The identifiability analysis as readable text.
pub fn identifiability_text(cfg: &Config, poses: usize, a: &Identifiability) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{} poses (reference {:?} mm), {} rows, method {}",
        poses,
        cfg.poses[0].as_slice(),
        3 * (poses - 1),
        cfg.identification.method.name()
    );
    let _ = writeln!(
        s,
        "rank {} of {} (relative tolerance {:e})",
        a.rank, a.parameters, a.rank_tolerance
    );
    let _ = writeln!(
        s,
        "condition number {:.4e} (identified subset {:.4e}; columns equilibrated)",
        a.condition_number, a.condition_number_identifiable
    );
    let sv: Vec<String> = a
        .singular_values
        .iter()
        .map(|v| format!("{v:.4e}"))
        .collect();
    let _ = writeln!(s, "singular values: {}", sv.join(" "));
    if a.unidentifiable.is_empty() {
        let _ = writeln!(s, "unidentifiable: none — all 15 errors are identifiable");
    } else {
        let _ = writeln!(s, "unidentifiable: {}", a.unidentifiable.join(", "));
        for c in &a.unidentifiable_combinations {
            let _ = writeln!(s, "  null direction: {c}");
        }
    }
    let o = &a.observability;
    let _ = writeln!(
        s,
        "observability: O1 {:.4e}  O2 {:.4e}  O3 {:.4e}  O4 {:.4e}  O5 {:.4e}",
        o.o1, o.o2, o.o3, o.o4, o.o5
    );
    s
}

#[derive(Serialize)]
struct VolumetricRow {
    x_mm: f64,
    y_mm: f64,
    z_mm: f64,
    before_mm: f64,
    after_mm: f64,
}

#[derive(Serialize)]
struct StageRow {
    stage: &'static str,
    max_mm: f64,
    min_mm: f64,
    mean_mm: f64,
}

pub(crate) fn volumetric_outputs(
    cfg: &Config,
    map: &VolumetricMap,
    out: &Path,
    outputs: &mut Outputs,
) -> Result<()> {
    let rows: Vec<VolumetricRow> = map
        .points
        .iter()
        .zip(map.before_mm.iter().zip(&map.after_mm))
        .map(|(p, (b, a))| VolumetricRow {
            x_mm: p.x,
            y_mm: p.y,
            z_mm: p.z,
            before_mm: *b,
            after_mm: *a,
        })
        .collect();
    outputs.add(out.join("volumetric.csv"), io::csv_bytes(&rows)?);
    let stage = |stage, s: Stats| StageRow {
        stage,
        max_mm: s.max_mm,
        min_mm: s.min_mm,
        mean_mm: s.mean_mm,
    };
    outputs.add(
        out.join("volumetric_summary.csv"),
        io::csv_bytes([stage("before", map.before()), stage("after", map.after())])?,
    );
    outputs.add(
        out.join("fig3.png"),
        plot::fig3(
            map,
            cfg.grid_step_mm,
            cfg.workspace.radius_mm,
            cfg.plane_z_mm,
            Format::Png,
        )?,
    );
    Ok(())
}

pub(crate) fn map_for(cfg: &Config, identified: &Machine) -> Result<VolumetricMap> {
    let grid = midplane_grid(&cfg.workspace, cfg.grid_step_mm, cfg.plane_z_mm);
    volumetric_map(&cfg.nominal(), identified, &cfg.truth(), &grid).map_err(|(k, e)| {
        Error::config(
            &cfg.source,
            format!(
                "compensation: map point ({:.1}, {:.1}, {:.1}) mm fails: {e}",
                grid[k].x, grid[k].y, grid[k].z
            ),
        )
    })
}

#[derive(Serialize)]
struct CommandRow {
    x_mm: f64,
    y_mm: f64,
    z_mm: f64,
    q1_mm: f64,
    q2_mm: f64,
    q3_mm: f64,
}

/// `compensate`: maps before/after for the config's true errors; commands for targets.
pub fn compensate(
    cfg: &Config,
    identified_path: &Path,
    out: &Path,
    targets: Option<&Path>,
) -> Result<()> {
    let (est, _ident) = io::read_identified(identified_path)?;
    let identified = Machine::with_errors(&cfg.geometry, &est);
    let nominal = cfg.nominal();
    let mut commands = None;
    if let Some(tp) = targets {
        let file = tp.display().to_string();
        let list = io::read_targets(tp)?;
        let mut rows = Vec::with_capacity(list.len());
        for (k, r) in list.iter().enumerate() {
            let line = io::data_line(k);
            check_reachable(&nominal, r, cfg.max_tilt_deg).map_err(|why| {
                Error::csv(
                    &file,
                    format!(
                        "line {line}: target ({}, {}, {}) mm is not reachable: {why}",
                        r.x, r.y, r.z
                    ),
                )
            })?;
            let q = identified
                .commands(r)
                .map_err(|e| Error::csv(&file, format!("line {line}: {e}")))?;
            rows.push(CommandRow {
                x_mm: r.x,
                y_mm: r.y,
                z_mm: r.z,
                q1_mm: q[0],
                q2_mm: q[1],
                q3_mm: q[2],
            });
        }
        commands = Some(rows);
    }
    let map = map_for(cfg, &identified)?;
    io::ensure_dir(out)?;
    let mut outputs = Outputs::default();
    volumetric_outputs(cfg, &map, out, &mut outputs)?;
    if let Some(rows) = &commands {
        outputs.add(out.join("commands.csv"), io::csv_bytes(rows)?);
    }
    outputs.write()?;
    let (b, a) = (map.before(), map.after());
    println!(
        "dV on z = {} mm ({} points)   max      min      mean (mm)",
        cfg.plane_z_mm,
        map.points.len()
    );
    println!(
        "  before compensation      {:.4}   {:.4}   {:.4}",
        b.max_mm, b.min_mm, b.mean_mm
    );
    println!(
        "  after compensation       {:.4}   {:.4}   {:.4}",
        a.max_mm, a.min_mm, a.mean_mm
    );
    if let Some(rows) = commands {
        println!(
            "wrote {} leg commands to {}",
            rows.len(),
            out.join("commands.csv").display()
        );
    }
    println!(
        "wrote volumetric.csv, volumetric_summary.csv, fig3.png to {}",
        out.display()
    );
    Ok(())
}

/// The sweep's Fig. 4: μ/μ0 median and 5–95 % band against encoder grade.
pub fn sweep_chart(cfg: &Config, result: &SweepResult) -> BandChart {
    let mut panels = Vec::new();
    for &method in &cfg.sweep.methods {
        let mut curves = Vec::new();
        for &scale in &cfg.sweep.scale_um {
            let mut rows: Vec<_> = result
                .summary
                .iter()
                .filter(|r| r.method == method.name() && r.scale_um == scale)
                .collect();
            rows.sort_by(|a, b| a.encoder_arcsec.total_cmp(&b.encoder_arcsec));
            curves.push(Curve {
                label: format!("median, scale {scale} µm"),
                band_label: format!("5–95 %, scale {scale} µm"),
                x: rows.iter().map(|r| r.encoder_arcsec).collect(),
                mid: rows.iter().map(|r| r.ratio_median).collect(),
                lo: rows.iter().map(|r| r.ratio_p05).collect(),
                hi: rows.iter().map(|r| r.ratio_p95).collect(),
            });
        }
        panels.push(Panel {
            title: match method {
                crate::identify::Method::Ols => "OLS (the paper's estimator)".to_string(),
                crate::identify::Method::Wls => "WLS (rows weighted by 1/σ)".to_string(),
            },
            curves,
        });
    }
    let mut hlines = vec![HLine {
        y: 1.0,
        label: "μ/μ0 = 1: no better than no calibration".into(),
        dashed: true,
        color: plotters::style::RGBColor(0, 0, 0),
    }];
    if cfg.decision.metric.starts_with("ratio") {
        hlines.push(HLine {
            y: cfg.decision.threshold,
            label: format!(
                "target: {} ≤ {}",
                cfg.decision.metric, cfg.decision.threshold
            ),
            dashed: true,
            color: plotters::style::RGBColor(200, 30, 30),
        });
    }
    let (lo, hi) = cfg
        .sweep
        .encoder_arcsec
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
    let errors = match cfg.sweep.errors {
        crate::config::ErrorDraw::Random => {
            format!("random errors ±{} mm", cfg.sweep.error_bound_mm)
        }
        crate::config::ErrorDraw::Fixed => "fixed [errors]".into(),
    };
    BandChart {
        title: format!(
            "μ/μ0 after self-calibration against encoder grade ({} trials, {errors})",
            result.trials
        ),
        x_desc: "encoder grade (arc-seconds)".into(),
        y_desc: "μ / μ0 (residual / uncalibrated)".into(),
        panels,
        hlines,
        markers: vec![],
        log_x: hi / lo >= 10.0,
    }
}

/// Encoder × scale heat map of the decision metric, one panel per method
/// (only when both grade lists have at least two entries).
pub fn grade_map(cfg: &Config, result: &SweepResult) -> Option<plot::GradeMap> {
    let enc = &cfg.sweep.encoder_arcsec;
    let sc = &cfg.sweep.scale_um;
    if enc.len() < 2 || sc.len() < 2 {
        return None;
    }
    let mut enc_sorted = enc.clone();
    enc_sorted.sort_by(f64::total_cmp);
    let mut sc_sorted = sc.clone();
    sc_sorted.sort_by(f64::total_cmp);
    let metric = &cfg.decision.metric;
    let panels = cfg
        .sweep
        .methods
        .iter()
        .map(|m| {
            let cell = |s: f64, e: f64| {
                result
                    .summary
                    .iter()
                    .find(|r| r.method == m.name() && r.scale_um == s && r.encoder_arcsec == e)
            };
            plot::GradeMapPanel {
                title: m.name().to_uppercase(),
                values: sc_sorted
                    .iter()
                    .map(|&s| {
                        enc_sorted
                            .iter()
                            .map(|&e| {
                                cell(s, e)
                                    .and_then(|r| r.metric(metric))
                                    .unwrap_or(f64::NAN)
                            })
                            .collect()
                    })
                    .collect(),
                feasible: sc_sorted
                    .iter()
                    .map(|&s| {
                        enc_sorted
                            .iter()
                            .map(|&e| cell(s, e).is_some_and(|r| r.meets_target))
                            .collect()
                    })
                    .collect(),
            }
        })
        .collect();
    Some(plot::GradeMap {
        title: format!(
            "{metric} by sensor grades (target {metric} ≤ {}, {} trials)",
            cfg.decision.threshold, result.trials
        ),
        metric: metric.clone(),
        encoder_arcsec: enc_sorted,
        scale_um: sc_sorted,
        panels,
    })
}

/// Predicted against Monte-Carlo standard deviation per parameter, one panel
/// per method, for the finest, a middle and the coarsest encoder grade at the
/// first scale grade.
pub fn parameter_chart(cfg: &Config, result: &SweepResult) -> plot::ParamChart {
    let mut enc = cfg.sweep.encoder_arcsec.clone();
    enc.sort_by(f64::total_cmp);
    let mut pick = vec![enc[0]];
    if enc.len() > 2 {
        pick.push(enc[enc.len() / 2]);
    }
    if enc.len() > 1 {
        pick.push(enc[enc.len() - 1]);
    }
    let scale = cfg.sweep.scale_um[0];
    let panels = cfg
        .sweep
        .methods
        .iter()
        .map(|m| {
            let series = pick
                .iter()
                .map(|&e| {
                    let rows: Vec<_> = result
                        .parameters
                        .iter()
                        .filter(|p| {
                            p.method == m.name() && p.encoder_arcsec == e && p.scale_um == scale
                        })
                        .collect();
                    plot::ParamSeries {
                        label: format!("{e}″"),
                        // An unidentifiable parameter's spread is just the prior: not shown.
                        mc: rows
                            .iter()
                            .map(|p| {
                                if p.identifiable {
                                    p.mc_std_mm
                                } else {
                                    f64::NAN
                                }
                            })
                            .collect(),
                        predicted: rows.iter().map(|p| p.predicted_std_mm).collect(),
                    }
                })
                .collect();
            (
                format!("{}, scale {scale} µm", m.name().to_uppercase()),
                series,
            )
        })
        .collect();
    plot::ParamChart {
        title: format!("Parameter uncertainty: Monte-Carlo spread (●) against linear covariance (✕), {} trials", result.trials),
        names: PARAM_NAMES.iter().map(|s| s.to_string()).collect(),
        panels,
    }
}

pub(crate) fn print_summary(result: &SweepResult) {
    println!(
        "{:>8} {:>8} {:>6} {:>8} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9} {:>6}",
        "enc_as",
        "scale_um",
        "method",
        "trials",
        "mu_mean",
        "mu_med",
        "mu_p95",
        "mu0_mean",
        "ratio_med",
        "ratio_p95",
        "meets"
    );
    for r in &result.summary {
        println!(
            "{:>8} {:>8} {:>6} {:>8} {:>9.5} {:>9.5} {:>9.5} {:>9.5} {:>9.4} {:>9.4} {:>6}",
            r.encoder_arcsec,
            r.scale_um,
            r.method,
            r.trials,
            r.mu_mean,
            r.mu_median,
            r.mu_p95,
            r.mu0_mean,
            r.ratio_median,
            r.ratio_p95,
            r.meets_target
        );
        if let (Some(med), Some(p95), Some(before)) = (
            r.dv_after_max_median,
            r.dv_after_max_p95,
            r.dv_before_max_median,
        ) {
            println!("         dV after compensation, max over the map: median {med:.4} mm, p95 {p95:.4} mm (before: median {before:.4} mm)");
        }
        if r.failed > 0 || r.not_converged > 0 {
            println!(
                "         ({} failed, {} not converged)",
                r.failed, r.not_converged
            );
        }
    }
    for d in &result.decisions {
        println!("decision: {}", d.verdict);
    }
    println!(
        "throughput: {} calibrations in {:.3} s = {:.0} calibrations/s on {} thread(s)",
        result.calibrations,
        result.wall_seconds,
        result.calibrations_per_second(),
        result.threads
    );
}

/// Paths written by `reproduce`, for messages.
pub fn reproduce(cfg: &Config, out: &Path, threads: usize) -> Result<()> {
    crate::report::reproduce(cfg, out, threads).map(|files: Vec<PathBuf>| {
        println!("wrote {} files to {}", files.len(), out.display());
    })
}

/// Rows of `identified.csv` with the true values beside the estimates.
pub fn identified_truth_csv(est: &Estimate, truth: &ErrorVector) -> Result<Vec<u8>> {
    let rows: Vec<IdentifiedTruthRow> = (0..PARAM_NAMES.len())
        .map(|k| IdentifiedTruthRow {
            parameter: PARAM_NAMES[k],
            estimate_mm: est.values[k],
            std_uncertainty_mm: est.std_mm[k],
            identifiable: est.identifiable[k],
            true_mm: truth[k],
            error_mm: est.values[k] - truth[k],
        })
        .collect();
    io::csv_bytes(&rows)
}

/// Pieces `reproduce` reuses.
pub(crate) mod shared {
    pub(crate) use super::{
        identifiability_json, identify_from, map_for, simulated, volumetric_outputs,
    };
}

/// `design-poses`: a designed pose set, written as a `[poses]` list, and a
/// short sweep comparing it with the config's poses on the same machines.
pub fn design_poses(
    cfg: &Config,
    count: usize,
    index: &str,
    trials: u64,
    threads: usize,
    out: &Path,
) -> Result<()> {
    use crate::design::{candidate_grid, Designer};
    let candidates = candidate_grid(cfg, 5, 12);
    if count < 2 || count > candidates.len() + 1 {
        return Err(Error::Argument(format!(
            "--count must be between 2 and {} (the candidate grid has {} reachable poses), got {count}",
            candidates.len() + 1,
            candidates.len()
        )));
    }
    let designer = Designer::new(cfg, candidates, index)?;
    let (chosen, passes) = designer.design(count - 1, 100);
    let mut poses = vec![cfg.poses[0]];
    poses.extend(chosen.iter().map(|&c| designer.points[c]));
    let designed_value = designer.value_of(cfg, &poses)?;
    let config_value = designer.value_of(cfg, &cfg.poses)?;
    // Short sweep on the same random machines and noise: config poses vs designed.
    let study = |list: &[Vector3<f64>]| -> Result<sweep::GradeSummary> {
        let mut raw = cfg.raw.clone();
        raw.poses = crate::config::PosesSection {
            list: Some(list.iter().map(|p| vec![p.x, p.y, p.z]).collect()),
            ..Default::default()
        };
        raw.sweep.encoder_arcsec = vec![cfg.sensors.encoder_arcsec.max(1e-6)];
        raw.sweep.scale_um = vec![cfg.sensors.scale_um.max(1e-6)];
        raw.sweep.trials = trials;
        raw.sweep.methods = None;
        let c = Config::from_raw(raw, &cfg.source)?;
        let r = sweep::study(&c, threads)?;
        Ok(r.summary[0].clone())
    };
    let base = study(&cfg.poses)?;
    let designed = study(&poses)?;
    let mut text = String::new();
    use std::fmt::Write as _;
    let _ = writeln!(
        text,
        "# Designed by `tricept-calib design-poses` from {}",
        cfg.source
    );
    let _ = writeln!(
        text,
        "# {} poses (reference first) maximising {index} on the noise-weighted design matrix; {} exchange pass(es).",
        poses.len(),
        passes
    );
    let _ = writeln!(
        text,
        "# {index}: designed {designed_value:.6e}, config poses ({}) {config_value:.6e}",
        cfg.poses.len()
    );
    let _ = writeln!(
        text,
        "# short sweep ({trials} random machines, encoder {}\", scale {} um, {}): mean mu {:.5} mm designed vs {:.5} mm config poses; ratio_p95 {:.4} vs {:.4}",
        cfg.sensors.encoder_arcsec,
        cfg.sensors.scale_um,
        cfg.identification.method.name(),
        designed.mu_mean,
        base.mu_mean,
        designed.ratio_p95,
        base.ratio_p95
    );
    let _ = writeln!(text, "[poses]\nlist = [");
    for p in &poses {
        let _ = writeln!(text, "    [{:?}, {:?}, {:?}],", p.x, p.y, p.z);
    }
    let _ = writeln!(text, "]");
    io::write_atomic(out, text.as_bytes())?;
    println!(
        "{:<22} {:>8} {:>14} {:>12} {:>10}",
        "pose set", "poses", index, "mean mu mm", "ratio_p95"
    );
    println!(
        "{:<22} {:>8} {:>14.6e} {:>12.5} {:>10.4}",
        "config poses",
        cfg.poses.len(),
        config_value,
        base.mu_mean,
        base.ratio_p95
    );
    println!(
        "{:<22} {:>8} {:>14.6e} {:>12.5} {:>10.4}",
        "designed",
        poses.len(),
        designed_value,
        designed.mu_mean,
        designed.ratio_p95
    );
    println!("wrote {} ({} exchange passes)", out.display(), passes);
    Ok(())
}
