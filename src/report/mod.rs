//! `reproduce`: the paper's case end to end, and `report.md` with our
//! numbers beside the paper's (docs/method.md §9). Every number in the report comes
//! from this run; the explanations that depend on a number are chosen by it.

mod markdown;

use crate::calibration;
use crate::config::{Config, ErrorDraw};
use crate::error::Result;
use crate::export::figures::{BandChart, Curve, Format, HLine, Marker, Panel};
use crate::export::rows::{identifiability_json, identified_truth_csv, readings_csv};
use crate::export::text::identifiability_text;
use crate::export::{csv_bytes, map_files};
use crate::identify::Method;
use crate::io::{self, Outputs};
use crate::mechanism::tricept::Machine;
use crate::metrics::{mu, mu0, GradeSummary};
use crate::montecarlo::run_in_memory;
use crate::store::names::*;
use markdown::{report_md, ReportData};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// The paper's published numbers (docs/method.md §9).
pub mod paper {
    pub const DV_BEFORE: [f64; 3] = [1.179, 0.573, 0.693];
    pub const DV_AFTER: [f64; 3] = [0.278, 0.171, 0.203];
    pub const MU0: f64 = 0.285;
    pub const MU_AT_4: f64 = 0.291;
    pub const CHOSEN_ENCODER: f64 = 2.0;
    pub const IDENTIFIABLE: usize = 15;
}

#[derive(Serialize, Clone)]
pub(crate) struct Fig4Row {
    encoder_arcsec: f64,
    draws: u64,
    mu_mean: f64,
    mu_mean_ci_low: f64,
    mu_mean_ci_high: f64,
    mu_p05: f64,
    mu_median: f64,
    mu_p95: f64,
    mu0: f64,
}

#[derive(Serialize)]
pub(crate) struct MethodRow {
    errors: String,
    method: String,
    encoder_arcsec: f64,
    draws: u64,
    mu_mean: f64,
    mu_median: f64,
    mu_p95: f64,
    not_converged: u64,
}

/// What one of the report's studies varies.
struct StudySpec<'a> {
    grades: &'a [f64],
    /// Pose counts (empty: every pose).
    pose_counts: &'a [usize],
    draws: u64,
    methods: &'a [Method],
    iterations: usize,
    scale_um: f64,
    random: bool,
}

/// A study on the config's fixed [errors] or (random) on machines drawn
/// uniformly in ±sweep.error_bound.
fn study(cfg: &Config, spec: StudySpec, threads: usize) -> Result<Vec<GradeSummary>> {
    let all = [cfg.poses.len()];
    let s = cfg
        .study()
        .encoder_arcsec(spec.grades)
        .scale_um(&[spec.scale_um.max(1e-6)])
        .trials(spec.draws)
        .errors(if spec.random {
            ErrorDraw::Random
        } else {
            ErrorDraw::Fixed
        })
        .seed(cfg.reproduce.seed)
        .methods(spec.methods)
        .iterations(spec.iterations)
        .pose_counts(if spec.pose_counts.is_empty() {
            &all
        } else {
            spec.pose_counts
        })
        .build()?;
    Ok(run_in_memory(cfg, &s, threads)?.summary)
}

/// One calibration from simulated readings and the two noise-free
/// references (one linearisation, Gauss–Newton).
struct Calibrations {
    readings: Vec<crate::mechanism::tricept::Reading>,
    single: calibration::Calibration,
    noise_free: crate::identify::tricept::Estimate,
    noise_free_gn: crate::identify::tricept::Estimate,
}

fn calibrations(cfg: &Config) -> Result<Calibrations> {
    let poses = cfg.nominal_poses()?;
    let readings = calibration::simulate(cfg, &poses, cfg.reproduce.seed, false)?;
    let single = calibration::identify_from(
        cfg,
        &readings,
        crate::io::Source::new("simulated readings", &[]),
    )?;
    let exact = calibration::simulate(cfg, &poses, cfg.reproduce.seed, true)?;
    let noise_free = calibration::identify_from(
        cfg,
        &exact,
        crate::io::Source::new("noise-free readings", &[]),
    )?
    .estimate;
    let gn = crate::identify::IdentifyOptions {
        iterations: 20,
        ..cfg.identification
    };
    let noise_free_gn = calibration::identify_with(
        cfg,
        &exact,
        crate::io::Source::new("noise-free readings", &[]),
        &gn,
    )?
    .estimate;
    Ok(Calibrations {
        readings,
        single,
        noise_free,
        noise_free_gn,
    })
}

/// Fig. 4 rows from the study's summaries, with μ0 of the Table 2 errors.
fn fig4_rows(fig4: &[GradeSummary], m0: f64) -> Vec<Fig4Row> {
    fig4.iter()
        .map(|r| Fig4Row {
            encoder_arcsec: r.encoder_arcsec,
            draws: r.trials,
            mu_mean: r.mu_mean,
            mu_mean_ci_low: r.mu_mean_ci_low,
            mu_mean_ci_high: r.mu_mean_ci_high,
            mu_p05: r.mu_p05,
            mu_median: r.mu_median,
            mu_p95: r.mu_p95,
            mu0: m0,
        })
        .collect()
}

/// Pose counts of the Fig. 4 drawn per pose count (those below the
/// config's, then every pose).
const FIG4_POSE_COUNTS: [usize; 3] = [5, 9, 17];

/// One row of `fig4_poses.csv`.
#[derive(Serialize, Clone)]
pub(crate) struct Fig4PoseRow {
    pose_count: usize,
    encoder_arcsec: f64,
    draws: u64,
    mu_mean: f64,
    mu_p05: f64,
    mu_p95: f64,
    mu0: f64,
}

fn fig4_pose_rows(rows: &[GradeSummary], m0: f64) -> Vec<Fig4PoseRow> {
    rows.iter()
        .map(|r| Fig4PoseRow {
            pose_count: r.pose_count,
            encoder_arcsec: r.encoder_arcsec,
            draws: r.trials,
            mu_mean: r.mu_mean,
            mu_p05: r.mu_p05,
            mu_p95: r.mu_p95,
            mu0: m0,
        })
        .collect()
}

/// Fig. 4 per pose count: mean μ and its 5–95 % band, one curve per count.
fn fig4_pose_chart(
    rows: &[GradeSummary],
    counts: &[usize],
    m0: f64,
    draws: u64,
    method: Method,
) -> BandChart {
    let curves = counts
        .iter()
        .map(|&n| {
            let r: Vec<&GradeSummary> = rows.iter().filter(|r| r.pose_count == n).collect();
            Curve {
                label: format!("mean μ, {n} poses"),
                band_label: format!("5–95 % of noise draws, {n} poses"),
                x: r.iter().map(|r| r.encoder_arcsec).collect(),
                mid: r.iter().map(|r| r.mu_mean).collect(),
                lo: r.iter().map(|r| r.mu_p05).collect(),
                hi: r.iter().map(|r| r.mu_p95).collect(),
            }
        })
        .collect();
    BandChart {
        title: format!(
            "Fig. 4 per pose count: residual μ, Table 2 errors, {} ({draws} noise draws per grade)",
            method.name().to_uppercase()
        ),
        x_desc: "encoder accuracy (arc-seconds, noise σ)".into(),
        y_desc: "μ = ‖Δε − Δε_e‖₁ / 15 (mm)".into(),
        panels: vec![Panel {
            title: String::new(),
            curves,
        }],
        hlines: vec![mu0_line(m0)],
        markers: vec![paper_point()],
        log_x: false,
    }
}

/// The config with datasheet sensors of its grades (docs/method.md §11): encoders
/// whose grade bounds a curve of harmonics [0.8, 0.2] per revolution with
/// jitter of 1 % of the grade, a scale whose grade bounds one harmonic over
/// its measuring length with jitter of 1 % of the grade.
fn datasheet_config(cfg: &Config) -> Result<Config> {
    use crate::config::raw::{EncoderSection, ScaleSection};
    let mut raw = cfg.resolved().clone();
    raw.sensors.encoder = Some(EncoderSection {
        accuracy_arcsec: cfg.sensors.encoder_arcsec,
        harmonics: crate::config::raw::Harmonics::List(vec![0.8, 0.2]),
        noise_arcsec: 0.01 * cfg.sensors.encoder_arcsec,
        ..EncoderSection::default()
    });
    raw.sensors.scale = Some(ScaleSection {
        accuracy_um: cfg.sensors.scale_um,
        harmonics: crate::config::raw::Harmonics::List(vec![1.0]),
        noise_um: 0.01 * cfg.sensors.scale_um,
        ..ScaleSection::default()
    });
    Config::from_raw(raw, &cfg.source)
}

/// μ0, the residual without calibration, as a dashed reference line.
fn mu0_line(m0: f64) -> HLine {
    HLine {
        y: m0,
        label: format!("μ0 = {m0:.4} mm (no calibration)"),
        dashed: true,
        color: plotters::style::RGBColor(0, 0, 0),
    }
}

/// The paper's own point of Fig. 4: μ at 4″.
fn paper_point() -> Marker {
    Marker {
        x: 4.0,
        y: paper::MU_AT_4,
        label: format!("paper: μ = {} mm at 4″", paper::MU_AT_4),
    }
}

/// The paper's Fig. 4: mean μ and its 5–95 % band against encoder grade.
fn fig4_chart(fig4: &[GradeSummary], m0: f64, draws: u64, method: Method) -> BandChart {
    BandChart {
        title: format!("Fig. 4: residual μ after self-calibration, Table 2 errors ({draws} noise draws per grade)"),
        x_desc: "encoder accuracy (arc-seconds, noise σ)".into(),
        y_desc: "μ = ‖Δε − Δε_e‖₁ / 15 (mm)".into(),
        panels: vec![Panel {
            title: String::new(),
            curves: vec![Curve {
                label: format!("mean μ ({})", method.name().to_uppercase()),
                band_label: "5–95 % of noise draws".into(),
                x: fig4.iter().map(|r| r.encoder_arcsec).collect(),
                mid: fig4.iter().map(|r| r.mu_mean).collect(),
                lo: fig4.iter().map(|r| r.mu_p05).collect(),
                hi: fig4.iter().map(|r| r.mu_p95).collect(),
            }],
        }],
        hlines: vec![mu0_line(m0)],
        markers: vec![paper_point()],
        log_x: false,
    }
}

/// Estimators side by side on the same noise draws: OLS, WLS and GLS, with
/// and without Gauss–Newton, on Table 2 and on random machines.
fn compare_methods(cfg: &Config, draws: u64, threads: usize) -> Result<Vec<MethodRow>> {
    let mut methods = Vec::new();
    for (random, iterations, tag) in [
        (false, 1usize, ""),
        (false, 10, "+GN"),
        (true, 1, ""),
        (true, 10, "+GN"),
    ] {
        let spec = StudySpec {
            grades: &[1.0, 2.0, 4.0],
            pose_counts: &[],
            draws: draws.min(400),
            methods: &Method::ALL,
            iterations,
            scale_um: cfg.sensors.scale_um,
            random,
        };
        for r in study(cfg, spec, threads)? {
            methods.push(MethodRow {
                errors: if random {
                    format!("random ±{} mm", cfg.sweep.error_bound_mm)
                } else {
                    "Table 2".into()
                },
                method: format!("{}{tag}", r.method.name()),
                encoder_arcsec: r.encoder_arcsec,
                draws: r.trials,
                mu_mean: r.mu_mean,
                mu_median: r.mu_median,
                mu_p95: r.mu_p95,
                not_converged: r.not_converged,
            });
        }
    }
    Ok(methods)
}

/// Run the paper case and write everything into `out`.
pub fn reproduce(cfg: &Config, out: &Path, threads: usize) -> Result<Vec<PathBuf>> {
    cfg.truth("reproduce")?;
    if mu0(&cfg.errors) == 0.0 {
        return Err(crate::error::Error::config(
            &cfg.source,
            "errors: reproduce compares μ with μ0 of the [errors] table, which is all zero",
        ));
    }
    let _lock = io::claim_dir(out)?;
    let truth_e = cfg.errors;
    // 1. One complete self-calibration, and what it would be without noise.
    let cal = calibrations(cfg)?;
    let (est, solver) = (&cal.single.estimate, &cal.single.solver);
    let analysis = &solver.analysis;
    let map = calibration::map(cfg, &Machine::with_errors(&cfg.geometry, &est.values))?;
    // What compensation can do when only identifiability limits it.
    let identified_nf = Machine::with_errors(&cfg.geometry, &cal.noise_free_gn.values);
    let map_nf = calibration::map(cfg, &identified_nf)?;
    // 2. Fig. 4: μ against encoder grade on the fixed Table 2 errors.
    let draws = cfg.reproduce.fig4_draws;
    let method = cfg.identification.method;
    let spec = |grades, draws, scale_um| StudySpec {
        grades,
        pose_counts: &[],
        draws,
        methods: std::slice::from_ref(&method),
        iterations: cfg.identification.iterations,
        scale_um,
        random: false,
    };
    let fig4 = study(
        cfg,
        spec(
            &cfg.reproduce.fig4_encoder_arcsec,
            draws,
            cfg.sensors.scale_um,
        ),
        threads,
    )?;
    // Which sensor limits μ: the same study with a near-perfect linear scale.
    let fine_scale = study(cfg, spec(&[1.0, 4.0, 8.0], draws.min(400), 0.01), threads)?;
    let m0 = mu0(&truth_e);
    let fig4_table = fig4_rows(&fig4, m0);
    let chart = fig4_chart(&fig4, m0, draws, method);
    // Fig. 4 as the paper drew it: one curve per pose count.
    let counts: Vec<usize> = FIG4_POSE_COUNTS
        .iter()
        .copied()
        .filter(|&n| n < cfg.poses.len())
        .chain([cfg.poses.len()])
        .collect();
    let by_count = study(
        cfg,
        StudySpec {
            pose_counts: &counts,
            ..spec(
                &cfg.reproduce.fig4_encoder_arcsec,
                draws.min(400),
                cfg.sensors.scale_um,
            )
        },
        threads,
    )?;
    let pose_rows = fig4_pose_rows(&by_count, m0);
    let pose_chart = fig4_pose_chart(&by_count, &counts, m0, draws.min(400), method);
    // The same Fig. 4 with datasheet sensors (docs/method.md §11) of the same grades.
    let sheet = datasheet_config(cfg)?;
    let fig4_sheet = study(
        &sheet,
        spec(
            &cfg.reproduce.fig4_encoder_arcsec,
            draws.min(400),
            cfg.sensors.scale_um,
        ),
        threads,
    )?;
    // 3. Estimators side by side.
    let methods = compare_methods(cfg, draws, threads)?;
    // 4. Write.
    let poses = cal.single.poses.len();
    let mut outputs = Outputs::default();
    outputs.replace_all(out, &REPRODUCE_FILES);
    outputs.add(out.join(READINGS_CSV), readings_csv(&cal.readings)?);
    outputs.add(
        out.join(IDENTIFIED_CSV),
        identified_truth_csv(est, &truth_e, &cfg.unknowns().errors)?,
    );
    for (name, bytes) in map_files(cfg, &map)? {
        outputs.add(out.join(name), bytes);
    }
    outputs.add(out.join(FIG4_CSV), csv_bytes(&fig4_table)?);
    outputs.add(out.join(FIG4_PNG), chart.render(Format::Png)?);
    outputs.add(out.join(FIG4_SVG), chart.render(Format::Svg)?);
    outputs.add(out.join(FIG4_POSES_CSV), csv_bytes(&pose_rows)?);
    outputs.add(out.join(FIG4_POSES_PNG), pose_chart.render(Format::Png)?);
    outputs.add(out.join(FIG4_POSES_SVG), pose_chart.render(Format::Svg)?);
    outputs.add(out.join(METHODS_CSV), csv_bytes(&methods)?);
    outputs.add(
        out.join(IDENTIFIABILITY_JSON),
        identifiability_json(
            &cfg.unknowns().errors,
            method,
            poses,
            solver.rows(),
            analysis,
            None::<&()>,
            Some((&cfg.source, &cfg.nominal_keys(), poses)),
        )?,
    );
    let data = ReportData {
        cfg,
        est,
        mu_single: mu(&truth_e, &est.values),
        mu_noise_free: mu(&truth_e, &cal.noise_free.values),
        mu_noise_free_gn: mu(&truth_e, &cal.noise_free_gn.values),
        analysis_text: identifiability_text(poses, &cfg.poses[0], method, analysis),
        analysis,
        map: &map,
        fig4: &fig4_table,
        fig4_poses: &pose_rows,
        fig4_sheet: &fig4_rows(&fig4_sheet, m0),
        fine_scale: &fine_scale,
        after_noise_free: map_nf.after(),
        methods: &methods,
        mu0: m0,
    };
    outputs.add(out.join(REPORT_MD), report_md(&data).into_bytes());
    outputs.write()
}
