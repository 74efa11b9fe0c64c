//! `report.md`: our numbers beside the paper's, each explanation chosen by
//! the numbers of this run.

use super::{paper, Fig4PoseRow, Fig4Row, MethodRow};
use crate::config::Config;
use crate::mechanism::tricept::{N_PARAMS, PARAM_NAMES};
use crate::metrics::GradeSummary;
use std::fmt::Write as _;

pub(crate) struct ReportData<'a> {
    pub(crate) cfg: &'a Config,
    pub(crate) est: &'a crate::identify::tricept::Estimate,
    pub(crate) mu_single: f64,
    pub(crate) mu_noise_free: f64,
    pub(crate) mu_noise_free_gn: f64,
    pub(crate) analysis_text: String,
    pub(crate) analysis: &'a crate::identify::Identifiability,
    pub(crate) map: &'a crate::compensate::VolumetricMap,
    pub(crate) fig4: &'a [Fig4Row],
    /// Fig. 4 per pose count, and with datasheet sensors of the same grades.
    pub(crate) fig4_poses: &'a [Fig4PoseRow],
    pub(crate) fig4_sheet: &'a [Fig4Row],
    pub(crate) fine_scale: &'a [GradeSummary],
    pub(crate) after_noise_free: crate::compensate::Stats,
    pub(crate) methods: &'a [MethodRow],
    pub(crate) mu0: f64,
}

fn interp_at(rows: &[Fig4Row], x: f64) -> Option<f64> {
    rows.iter()
        .find(|r| (r.encoder_arcsec - x).abs() < 1e-12)
        .map(|r| r.mu_mean)
}

pub(crate) fn report_md(d: &ReportData) -> String {
    let mut s = String::new();
    numbers(d, &mut s);
    pose_counts(d, &mut s);
    why_differ(d, &mut s);
    details(d, &mut s);
    s
}

/// The coarsest grade whose 95th percentile of μ is at most μ0/2.
fn chosen_grade(rows: &[Fig4Row], m0: f64) -> Option<f64> {
    rows.iter()
        .filter(|r| r.mu_p95 <= 0.5 * m0)
        .map(|r| r.encoder_arcsec)
        .fold(None, |m: Option<f64>, x| Some(m.map_or(x, |m| m.max(x))))
}

/// Fig. 4 per pose count (`fig4_poses.png`) and the datasheet reading.
fn pose_counts(d: &ReportData, s: &mut String) {
    let _ = writeln!(
        s,
        "## Fig. 4 per pose count, and with datasheet sensors
"
    );
    let _ = writeln!(
        s,
        "`fig4_poses.png` and `fig4_poses.csv`: the Fig. 4 study (Table 2 errors, method {}) with the calibration poses cut to subsets by the pose-count rule (docs/method.md §10).\n",
        d.cfg.identification.method.name()
    );
    let _ = writeln!(s, "| poses | mean μ at 4″ (mm) | μ/μ0 |\n|---|---|---|");
    let mut reach = None;
    let mut counts: Vec<usize> = d.fig4_poses.iter().map(|r| r.pose_count).collect();
    counts.dedup();
    for &n in &counts {
        if let Some(r) = d
            .fig4_poses
            .iter()
            .find(|r| r.pose_count == n && (r.encoder_arcsec - 4.0).abs() < 1e-12)
        {
            let _ = writeln!(s, "| {n} | {:.4} | {:.3} |", r.mu_mean, r.mu_mean / d.mu0);
            if r.mu_mean >= d.mu0 && reach.is_none() {
                reach = Some(n);
            }
        }
    }
    let smallest = counts.first().copied().unwrap_or(0);
    let closest = d
        .fig4_poses
        .iter()
        .find(|r| r.pose_count == smallest && (r.encoder_arcsec - 4.0).abs() < 1e-12)
        .map_or(f64::NAN, |r| r.mu_mean);
    let _ = writeln!(
        s,
        "\n{}\n",
        match reach {
            Some(n) => format!(
                "With {n} poses mean μ at 4″ reaches μ0 = {:.4} mm under this estimator, as the paper reports (μ = {} mm): a pose set that small makes the 4″ encoder no better than not calibrating.",
                d.mu0,
                paper::MU_AT_4
            ),
            None => format!(
                "No pose count studied (down to {smallest}) makes mean μ at 4″ reach μ0 = {:.4} mm under this estimator; the closest, {smallest} poses, gives {:.4} mm ({:.2} μ0) against the paper's {} mm. A pose set as small as the paper's plausibly was (it does not list it) comes close to its Fig. 4; the rest is its pose placement, units of the angle rows or noise level.",
                d.mu0,
                closest,
                closest / d.mu0,
                paper::MU_AT_4
            ),
        }
    );
    let fmt = |v: Option<f64>| {
        v.map_or("none of the grades studied".to_string(), |v| {
            format!("{v}″")
        })
    };
    let _ = writeln!(
        s,
        "**The paper's 2″ beside the datasheet reading.** The coarsest encoder whose 95th percentile of μ stays at or below μ0/2 is {} when the grade is read as white noise (the paper's reading) and {} when it is read as a datasheet's bound of a repeatable curve (harmonics [0.8, 0.2] per revolution, jitter 1 % of the grade; the scale likewise with one harmonic over its length; `sensors` in docs/method.md §11), on the same noise draws. The paper chose {}″.\n",
        fmt(chosen_grade(d.fig4, d.mu0)),
        fmt(chosen_grade(d.fig4_sheet, d.mu0)),
        paper::CHOSEN_ENCODER
    );
}

/// Title, provenance and the table of our numbers beside the paper's.
fn numbers(d: &ReportData, s: &mut String) {
    let cfg = d.cfg;
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
    let chosen = chosen_grade(d.fig4, d.mu0);
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
    let _ = writeln!(s, "## Our numbers beside the paper's (docs/method.md §9)\n");
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
        "| independent identifiable errors | {} | {} of {N_PARAMS} (rank of H){} |",
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
}

/// Why our numbers differ from the paper's, chosen by this run's numbers.
fn why_differ(d: &ReportData, s: &mut String) {
    let cfg = d.cfg;
    let (b, a) = (d.map.before(), d.map.after());
    let mu4 = interp_at(d.fig4, 4.0);
    let _ = writeln!(s, "\n### Why the numbers differ\n");
    let _ = writeln!(
        s,
        "- **Conventions the paper leaves open.** The paper does not give its calibration poses, its joint numbering on the figure, the noise seed or how the 'before' map was commanded. We use docs/method.md §2–§5 (51 poses on 3 layers, B3 at 180°, nominal-IK commands) and do not tune them to match; so only the magnitudes are comparable."
    );
    let _ = writeln!(
        s,
        "- **dV before compensation** ({:.3} / {:.3} / {:.3} mm against the paper's {} / {} / {}) depends only on the geometry, Table 2 and the exact forward kinematics; a difference here means the paper's error signs, frame placement or numbering differ from ours (docs/method.md §2–§3), which the paper does not state.",
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
            "- **{} identifiable errors**: the paper claims all {}; we find rank {} for this layout. {} cannot be identified: {}. The μ floor this sets for Table 2 is Σ|unidentifiable true errors|/{N_PARAMS} = {:.4} mm.",
            paper::IDENTIFIABLE,
            paper::IDENTIFIABLE,
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
}

/// Identifiability, the single calibration, Fig. 4 data and the estimators.
fn details(d: &ReportData, s: &mut String) {
    let cfg = d.cfg;
    let _ = writeln!(
        s,
        "\n## Identifiability (docs/method.md §6)\n\n```\n{}```\n",
        d.analysis_text
    );
    if d.analysis.unidentifiable.iter().any(|n| n == "dyA3") {
        let _ = writeln!(
            s,
            "Why dyA3: with B3 on the base x axis and A3 on the platform x' axis (β3 = α3 = 180°), the Hooke joint's first axis is x, so R·ey' = (0, cos ψ4, sin ψ4) is perpendicular to leg 3 in every pose (its dot product with q4·w4 + R·a03 − b3 vanishes identically). A shift of A3 along y' therefore changes no leg length to first order, and the passive-limb readings cannot see it. Any platform layout that takes A3 off the x' axis (e.g. `platform_angles_deg = [-30, 90, 210]`) restores rank 15 (docs/method.md §6, configs/full-rank.toml).\n"
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
    let _ = writeln!(s, "OLS is the paper's estimator (rows in rad and mm unweighted); WLS weights each row by 1/σ of its sensor; GLS whitens the rows with the sensors' error covariance (docs/method.md §13; with the paper's white noise that covariance is σ²(I + 11ᵀ) per sensor, the reference reading's error shared by every row, which WLS ignores); +GN re-linearises at the estimate (Gauss–Newton, up to 10 linearisations). 'Table 2' rows repeat noise draws on the paper's machine; 'random' rows are a sweep over random machines (a new error set per trial, the same machines and noise for every method).\n");
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
}
