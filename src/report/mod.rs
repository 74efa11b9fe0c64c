//! `reproduce`: the paper's case end to end, and `report.md` with our
//! numbers beside the paper's (SPEC §9). Every number in the report comes
//! from this run; the explanations that depend on a number are chosen by it.

use crate::cli::commands::{identifiability_text, identified_truth_csv, shared};
use crate::config::Config;
use crate::error::Result;
use crate::export::plot::{BandChart, Curve, Format, HLine, Marker, Panel};
use crate::io::{self, Outputs};
use crate::model::params::{mu, mu0};
use crate::model::{Machine, PARAM_NAMES};
use crate::sweep::{self, GradeSummary};
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The paper's published numbers (SPEC §9).
pub mod paper {
    pub const DV_BEFORE: [f64; 3] = [1.179, 0.573, 0.693];
    pub const DV_AFTER: [f64; 3] = [0.278, 0.171, 0.203];
    pub const MU0: f64 = 0.285;
    pub const MU_AT_4: f64 = 0.291;
    pub const CHOSEN_ENCODER: f64 = 2.0;
    pub const IDENTIFIABLE: usize = 15;
}

#[derive(Serialize, Clone)]
struct Fig4Row {
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
struct MethodRow {
    errors: String,
    method: String,
    encoder_arcsec: f64,
    draws: u64,
    mu_mean: f64,
    mu_median: f64,
    mu_p95: f64,
    not_converged: u64,
}

/// A study on the config's fixed [errors] or (random) on machines drawn
/// uniformly in ±sweep.error_bound.
#[allow(clippy::too_many_arguments)]
fn study(
    cfg: &Config,
    grades: &[f64],
    draws: u64,
    methods: &[&str],
    iterations: usize,
    threads: usize,
    scale_um: f64,
    random: bool,
) -> Result<Vec<GradeSummary>> {
    let mut raw = cfg.raw.clone();
    raw.sweep.encoder_arcsec = grades.to_vec();
    raw.sweep.scale_um = vec![scale_um.max(1e-6)];
    raw.sweep.trials = draws;
    raw.sweep.errors = if random { "random" } else { "fixed" }.into();
    raw.sweep.seed = cfg.reproduce.seed;
    raw.sweep.methods = Some(methods.iter().map(|s| s.to_string()).collect());
    raw.identification.iterations = iterations;
    let study = Config::from_raw(raw, &cfg.source)?;
    let r = sweep::study(&study, threads)?;
    Ok(r.summary)
}

/// Run the paper case and write everything into `out`.
pub fn reproduce(cfg: &Config, out: &Path, threads: usize) -> Result<Vec<PathBuf>> {
    io::ensure_dir(out)?;
    let truth_e = cfg.errors;
    let poses = shared_poses(cfg)?;
    // 1. One complete self-calibration.
    let readings = shared::simulated(cfg, &poses, cfg.reproduce.seed, false)?;
    let (est, solver, _) = shared::identify_from(cfg, &readings, "simulated readings")?;
    let analysis = solver.analysis.clone();
    let identified = Machine::with_errors(&cfg.geometry, &est.values);
    let map = shared::map_for(cfg, &identified)?;
    let noise_free = shared::simulated(cfg, &poses, cfg.reproduce.seed, true)?;
    let (est_nf, _, _) = shared::identify_from(cfg, &noise_free, "noise-free readings")?;
    let mut gn_cfg = cfg.clone();
    gn_cfg.identification.iterations = 20;
    let (est_nf_gn, _, _) = shared::identify_from(&gn_cfg, &noise_free, "noise-free readings")?;
    // 2. Fig. 4: μ against encoder grade on the fixed Table 2 errors.
    let grades = &cfg.reproduce.fig4_encoder_arcsec;
    let draws = cfg.reproduce.fig4_draws;
    let method = cfg.identification.method.name();
    let fig4 = study(
        cfg,
        grades,
        draws,
        &[method],
        cfg.identification.iterations,
        threads,
        cfg.sensors.scale_um,
        false,
    )?;
    // Which sensor limits μ: the same study with a near-perfect linear scale.
    let fine_scale = study(
        cfg,
        &[1.0, 4.0, 8.0],
        draws.min(400),
        &[method],
        cfg.identification.iterations,
        threads,
        0.01,
        false,
    )?;
    // What compensation can do when only identifiability limits it.
    let identified_nf = Machine::with_errors(&cfg.geometry, &est_nf_gn.values);
    let map_nf = shared::map_for(cfg, &identified_nf)?;
    let m0 = mu0(&truth_e);
    let fig4_rows: Vec<Fig4Row> = fig4
        .iter()
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
        .collect();
    let chart = BandChart {
        title: format!("Fig. 4: residual μ after self-calibration, Table 2 errors ({draws} noise draws per grade)"),
        x_desc: "encoder accuracy (arc-seconds, noise σ)".into(),
        y_desc: "μ = ‖Δε − Δε_e‖₁ / 15 (mm)".into(),
        panels: vec![Panel {
            title: String::new(),
            curves: vec![Curve {
            label: format!("mean μ ({})", method.to_uppercase()),
            band_label: "5–95 % of noise draws".into(),
            x: fig4.iter().map(|r| r.encoder_arcsec).collect(),
            mid: fig4.iter().map(|r| r.mu_mean).collect(),
            lo: fig4.iter().map(|r| r.mu_p05).collect(),
            hi: fig4.iter().map(|r| r.mu_p95).collect(),
        }],
        }],
        hlines: vec![HLine {
            y: m0,
            label: format!("μ0 = {m0:.4} mm (no calibration)"),
            dashed: true,
            color: plotters::style::RGBColor(0, 0, 0),
        }],
        markers: vec![Marker {
            x: 4.0,
            y: paper::MU_AT_4,
            label: format!("paper: μ = {} mm at 4″", paper::MU_AT_4),
        }],
        log_x: false,
    };
    // 3. Estimators side by side on the same noise draws.
    let cmp_grades = [1.0, 2.0, 4.0];
    let cmp_draws = draws.min(400);
    let mut methods = Vec::new();
    for (random, iters, tag) in [
        (false, 1usize, ""),
        (false, 10, "+GN"),
        (true, 1, ""),
        (true, 10, "+GN"),
    ] {
        let s = study(
            cfg,
            &cmp_grades,
            cmp_draws,
            &["ols", "wls"],
            iters,
            threads,
            cfg.sensors.scale_um,
            random,
        )?;
        for r in s {
            methods.push(MethodRow {
                errors: if random {
                    format!("random ±{} mm", cfg.sweep.error_bound_mm)
                } else {
                    "Table 2".into()
                },
                method: format!("{}{tag}", r.method),
                encoder_arcsec: r.encoder_arcsec,
                draws: r.trials,
                mu_mean: r.mu_mean,
                mu_median: r.mu_median,
                mu_p95: r.mu_p95,
                not_converged: r.not_converged,
            });
        }
    }
    // 4. Write.
    let mut outputs = Outputs::default();
    outputs.add(out.join("readings.csv"), io::readings_csv(&readings)?);
    outputs.add(
        out.join("identified.csv"),
        identified_truth_csv(&est, &truth_e)?,
    );
    shared::volumetric_outputs(cfg, &map, out, &mut outputs)?;
    outputs.add(out.join("fig4.csv"), io::csv_bytes(&fig4_rows)?);
    outputs.add(out.join("fig4.png"), chart.render(Format::Png)?);
    outputs.add(out.join("methods.csv"), io::csv_bytes(&methods)?);
    outputs.add(
        out.join("identifiability.json"),
        shared::identifiability_json(cfg, poses.len(), solver.rows(), &analysis)?,
    );
    let ctx = ReportData {
        cfg,
        est: &est,
        mu_single: mu(&truth_e, &est.values),
        mu_noise_free: mu(&truth_e, &est_nf.values),
        mu_noise_free_gn: mu(&truth_e, &est_nf_gn.values),
        analysis_text: identifiability_text(cfg, poses.len(), &analysis),
        analysis: &analysis,
        map: &map,
        fig4: &fig4_rows,
        fine_scale: &fine_scale,
        after_noise_free: map_nf.after(),
        methods: &methods,
        mu0: m0,
    };
    outputs.add(out.join("report.md"), report_md(&ctx).into_bytes());
    outputs.write()
}

fn shared_poses(cfg: &Config) -> Result<crate::sensors::NominalPoses> {
    crate::cli::commands::config_poses(cfg)
}

struct ReportData<'a> {
    cfg: &'a Config,
    est: &'a crate::identify::Estimate,
    mu_single: f64,
    mu_noise_free: f64,
    mu_noise_free_gn: f64,
    analysis_text: String,
    analysis: &'a crate::identify::Identifiability,
    map: &'a crate::compensate::VolumetricMap,
    fig4: &'a [Fig4Row],
    fine_scale: &'a [GradeSummary],
    after_noise_free: crate::compensate::Stats,
    methods: &'a [MethodRow],
    mu0: f64,
}

fn interp_at(rows: &[Fig4Row], x: f64) -> Option<f64> {
    rows.iter()
        .find(|r| (r.encoder_arcsec - x).abs() < 1e-12)
        .map(|r| r.mu_mean)
}

fn report_md(d: &ReportData) -> String {
    let cfg = d.cfg;
    let mut s = String::new();
    let (b, a) = (d.map.before(), d.map.after());
    let mu4 = interp_at(d.fig4, 4.0);
    // Break-even: the coarsest grade whose mean μ is below μ0.
    let break_even = d
        .fig4
        .iter()
        .filter(|r| r.mu_mean < d.mu0)
        .map(|r| r.encoder_arcsec)
        .fold(None, |m: Option<f64>, x| Some(m.map_or(x, |m| m.max(x))));
    // Engineering choice: coarsest grade whose 95th percentile of μ stays below μ0/2.
    let chosen = d
        .fig4
        .iter()
        .filter(|r| r.mu_p95 <= 0.5 * d.mu0)
        .map(|r| r.encoder_arcsec)
        .fold(None, |m: Option<f64>, x| Some(m.map_or(x, |m| m.max(x))));
    let fmt_opt = |v: Option<f64>, unit: &str| {
        v.map_or("none of the grades studied".to_string(), |v| {
            format!("{v}{unit}")
        })
    };
    let _ = writeln!(
        s,
        "# Paper reproduction: Hong (2009), Tricept self-calibration\n"
    );
    let _ = writeln!(
        s,
        "Generated by `tricept-calib reproduce` (version {}) from `{}`; seed {}; {} calibration poses (reference {:?} mm); sensors: encoder σ {}″, scale σ {} µm, mean of {} samples; method {} with {} linearisation(s). Every number below comes from this run.\n",
        env!("CARGO_PKG_VERSION"),
        cfg.source,
        cfg.reproduce.seed,
        cfg.poses.len(),
        cfg.poses[0].as_slice(),
        cfg.sensors.encoder_arcsec,
        cfg.sensors.scale_um,
        cfg.sensors.samples,
        cfg.identification.method.name(),
        cfg.identification.iterations
    );
    let _ = writeln!(s, "## Our numbers beside the paper's (SPEC §9)\n");
    let _ = writeln!(s, "| item | paper | ours |\n|---|---|---|");
    let _ = writeln!(
        s,
        "| dV before compensation, mid-plane: max / min / mean (mm) | {} / {} / {} | {:.3} / {:.3} / {:.3} |",
        paper::DV_BEFORE[0], paper::DV_BEFORE[1], paper::DV_BEFORE[2], b.max_mm, b.min_mm, b.mean_mm
    );
    let _ =
        writeln!(
        s,
        "| dV after compensation: max / min / mean (mm) | {} / {} / {} | {:.3} / {:.3} / {:.3} |",
        paper::DV_AFTER[0], paper::DV_AFTER[1], paper::DV_AFTER[2], a.max_mm, a.min_mm, a.mean_mm
    );
    let _ = writeln!(s, "| μ0 for Table 2 (mm) | {} | {:.4} |", paper::MU0, d.mu0);
    let _ = writeln!(
        s,
        "| μ at 4″ encoder (mm; ours: mean over {} noise draws) | {} | {} |",
        d.fig4.first().map_or(0, |r| r.draws),
        paper::MU_AT_4,
        mu4.map_or("not studied".into(), |v| format!("{v:.4}"))
    );
    let _ = writeln!(
        s,
        "| chosen encoder | {}″ | {} (coarsest grade with p95 of μ ≤ μ0/2); break-even (mean μ < μ0): {} |",
        paper::CHOSEN_ENCODER,
        fmt_opt(chosen, "″"),
        fmt_opt(break_even, "″")
    );
    let _ = writeln!(
        s,
        "| independent identifiable errors | {} | {} of 15 (rank of H){} |",
        paper::IDENTIFIABLE,
        d.analysis.rank,
        if d.analysis.unidentifiable.is_empty() {
            String::new()
        } else {
            format!(
                "; not identifiable: {}",
                d.analysis.unidentifiable.join(", ")
            )
        }
    );
    let _ = writeln!(s, "\n### Why the numbers differ\n");
    let _ = writeln!(
        s,
        "- **Conventions the paper leaves open.** The paper does not give its calibration poses, its joint numbering on the figure, the noise seed or how the 'before' map was commanded. We use SPEC §2–§5 (51 poses on 3 layers, B3 at 180°, nominal-IK commands) and do not tune them to match; so only the magnitudes are comparable."
    );
    let _ = writeln!(
        s,
        "- **dV before compensation** ({:.3} / {:.3} / {:.3} mm against the paper's {} / {} / {}) depends only on the geometry, Table 2 and the exact forward kinematics; a difference here means the paper's error signs, frame placement or numbering differ from SPEC's, which the paper does not state.",
        b.max_mm, b.min_mm, b.mean_mm, paper::DV_BEFORE[0], paper::DV_BEFORE[1], paper::DV_BEFORE[2]
    );
    let _ = writeln!(
        s,
        "- **dV after compensation** is {:.3} mm mean here against the paper's {}. With exact (noise-free) readings and Gauss–Newton the same pose set leaves {:.4} / {:.4} / {:.4} mm (max / min / mean). {}",
        a.mean_mm,
        paper::DV_AFTER[2],
        d.after_noise_free.max_mm,
        d.after_noise_free.min_mm,
        d.after_noise_free.mean_mm,
        if d.after_noise_free.max_mm < 1e-3 {
            "So the unidentifiable parameter costs no accuracy (it moves no leg length, hence not the platform, to first order) and all of our residual is sensor noise amplified by the identification: the incremental sensors lose every constant offset, so leg-length offsets are seen only through how their effect varies over the workspace. The paper's larger residual is consistent with a smaller or less spread pose set, which the paper does not list."
        } else {
            "That part is what the unidentifiable parameter(s) leave; the rest is sensor noise. The paper's larger residual is consistent with a smaller or less spread pose set, which the paper does not list."
        }
    );
    let fine4 = d
        .fine_scale
        .iter()
        .find(|r| r.encoder_arcsec == 4.0)
        .map(|r| r.mu_mean);
    let fine1 = d
        .fine_scale
        .iter()
        .find(|r| r.encoder_arcsec == 1.0)
        .map(|r| r.mu_mean);
    let fine8 = d
        .fine_scale
        .iter()
        .find(|r| r.encoder_arcsec == 8.0)
        .map(|r| r.mu_mean);
    let _ = writeln!(
        s,
        "- **μ at 4″**: the paper reports μ = {} > μ0. {}",
        paper::MU_AT_4,
        match mu4 {
            Some(v) if v < d.mu0 => format!(
                "Our mean μ at 4″ is {v:.4} mm, well below μ0 = {:.4}, and our curve is nearly flat in the encoder grade. The reason is the paper's estimator: OLS stacks rows in rad (ψ4, θ4, sensitivities ~10⁻³ rad/mm) with rows in mm (q4, sensitivity ~1), so the angle rows carry little weight and the {} µm scale noise dominates μ. With a near-perfect 0.01 µm scale the same study gives mean μ = {} / {} / {} mm at 1″ / 4″ / 8″: only then does the encoder grade show. We cannot say which choices (pose set, units of the angle rows, noise level) make the paper's curve cross μ0 at 4″; the paper does not list them.",
                d.mu0,
                cfg.sensors.scale_um,
                fine1.map_or("-".into(), |v| format!("{v:.4}")),
                fine4.map_or("-".into(), |v| format!("{v:.4}")),
                fine8.map_or("-".into(), |v| format!("{v:.4}")),
            ),
            Some(v) => format!("Our mean μ at 4″ is {v:.4} mm, also above μ0 = {:.4}.", d.mu0),
            None => "4″ was not among the grades studied.".into(),
        }
    );
    if !d.analysis.unidentifiable.is_empty() {
        let _ = writeln!(
            s,
            "- **15 identifiable errors**: the paper claims all 15; we find rank {} for this layout. {} cannot be identified: {}. The μ floor this sets for Table 2 is Σ|unidentifiable true errors|/15 = {:.4} mm.",
            d.analysis.rank,
            d.analysis.unidentifiable.join(", "),
            d.analysis.unidentifiable_combinations.join("; "),
            d.analysis
                .identifiable
                .iter()
                .zip(cfg.errors.iter())
                .filter(|(i, _)| !**i)
                .map(|(_, e)| e.abs())
                .sum::<f64>()
                / 15.0
        );
    }
    let _ = writeln!(
        s,
        "\n## Identifiability (SPEC §6)\n\n```\n{}```\n",
        d.analysis_text
    );
    if d.analysis.unidentifiable.iter().any(|n| n == "dyA3") {
        let _ = writeln!(
            s,
            "Why dyA3: with B3 on the base x axis and A3 on the platform x' axis (β3 = α3 = 180°), the Hooke joint's first axis is x, so R·ey' = (0, cos ψ4, sin ψ4) is perpendicular to leg 3 in every pose (its dot product with q4·w4 + R·a03 − b3 vanishes identically). A shift of A3 along y' therefore changes no leg length to first order, and the passive-limb readings cannot see it. Any platform layout that takes A3 off the x' axis (e.g. `platform_angles_deg = [-30, 90, 210]`) restores rank 15 — see the README.\n"
        );
    }
    let _ = writeln!(
        s,
        "## One complete self-calibration (Table 2 errors, seed {})\n",
        cfg.reproduce.seed
    );
    let _ = writeln!(s, "| parameter | true (mm) | estimate (mm) | std. uncertainty (mm) | identifiable |\n|---|---|---|---|---|");
    for k in 0..PARAM_NAMES.len() {
        let _ = writeln!(
            s,
            "| {} | {} | {:.4} | {:.4} | {} |",
            PARAM_NAMES[k], cfg.errors[k], d.est.values[k], d.est.std_mm[k], d.est.identifiable[k]
        );
    }
    let _ = writeln!(
        s,
        "\nμ of this calibration: {:.4} mm (μ0 = {:.4}). Without noise: {:.2e} mm with one linearisation, {:.2e} mm with Gauss–Newton — the part of μ that is model linearisation rather than noise or identifiability is the difference between these two.\n",
        d.mu_single, d.mu0, d.mu_noise_free, d.mu_noise_free_gn
    );
    let _ = writeln!(s, "## Fig. 4 data (`fig4.csv`)\n");
    let _ = writeln!(s, "| encoder (″) | mean μ (mm) | 95 % CI of mean | 5 % | median | 95 % |\n|---|---|---|---|---|---|");
    for r in d.fig4 {
        let _ = writeln!(
            s,
            "| {} | {:.4} | {:.4}–{:.4} | {:.4} | {:.4} | {:.4} |",
            r.encoder_arcsec,
            r.mu_mean,
            r.mu_mean_ci_low,
            r.mu_mean_ci_high,
            r.mu_p05,
            r.mu_median,
            r.mu_p95
        );
    }
    let _ = writeln!(
        s,
        "\n## Estimators compared on the same noise draws (`methods.csv`)\n"
    );
    let _ = writeln!(s, "OLS is the paper's estimator (rows in rad and mm unweighted); WLS weights each row by 1/σ of its sensor; +GN re-linearises at the estimate (Gauss–Newton, up to 10 linearisations). 'Table 2' rows repeat noise draws on the paper's machine; 'random' rows are a sweep over random machines (a new error set per trial, the same machines and noise for every method).\n");
    let _ = writeln!(s, "| errors | method | encoder (″) | trials | mean μ (mm) | median μ | p95 μ | not converged |\n|---|---|---|---|---|---|---|---|");
    for r in d.methods {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {:.4} | {:.4} | {:.4} | {} |",
            r.errors,
            r.method,
            r.encoder_arcsec,
            r.draws,
            r.mu_mean,
            r.mu_median,
            r.mu_p95,
            r.not_converged
        );
    }
    let _ = writeln!(s, "\nFiles: `identified.csv`, `readings.csv`, `volumetric.csv`, `volumetric_summary.csv`, `fig3.png`, `fig4.csv`, `fig4.png`, `methods.csv`, `identifiability.json`.");
    s
}
