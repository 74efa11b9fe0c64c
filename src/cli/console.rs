//! All console output of the commands, in one place: tables on stdout,
//! warnings and notes on stderr.

use super::state::Adaptive;
use crate::compensate::VolumetricMap;
use crate::identify::{Estimate, Identifiability};
use crate::model::{ErrorVector, PARAM_NAMES};
use crate::montecarlo::SweepResult;

pub fn print_estimate(est: &Estimate, truth: Option<&ErrorVector>) {
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

pub fn warn_unidentifiable(a: &Identifiability) {
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

pub fn print_summary(result: &SweepResult) {
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
            r.method.name(),
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

/// Print the summary table, the decision, throughput and uncertainty notes.
pub fn sweep_report(result: &SweepResult) {
    print_summary(result);
    for p in &result.parameters {
        let disagree = !(0.8..=1.25).contains(&p.ratio_mc_to_predicted);
        if p.identifiable && disagree && result.trials >= 100 {
            println!(
                "note: {} at {}\" / {} um ({}): Monte-Carlo std {:.4} mm vs linear prediction {:.4} mm (ratio {:.2}) — the linear uncertainty model is not reliable here",
                p.parameter, p.encoder_arcsec, p.scale_um, p.method.name(), p.mc_std_mm, p.predicted_std_mm, p.ratio_mc_to_predicted
            );
        }
    }
}

/// dV statistics of a map, before and after compensation.
pub fn print_map(map: &VolumetricMap, plane_z_mm: f64) {
    let (b, a) = (map.before(), map.after());
    println!(
        "dV on z = {} mm ({} points)   max      min      mean (mm)",
        plane_z_mm,
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
}

/// One line on stdout.
pub fn line(text: impl std::fmt::Display) {
    println!("{text}");
}

/// Text already formatted (ends with its own newline).
pub fn text(text: impl std::fmt::Display) {
    print!("{text}");
}

/// A note or warning on stderr.
pub fn note(text: impl std::fmt::Display) {
    eprintln!("{text}");
}

/// What adaptive stopping achieved, per grade.
pub fn adaptive_report(a: &Adaptive, result: &SweepResult) {
    println!(
        "adaptive: {} trials used of at most {}; target half-width {} × mean {}",
        a.trials_used,
        a.max_trials,
        a.target_rel_half_width,
        if a.target_met {
            "met for every grade"
        } else {
            "NOT met: raise --max-trials"
        }
    );
    for r in &result.summary {
        println!(
            "  {}\" / {} um / {}: mean mu {:.5} ± {:.5} mm (relative {:.4})",
            r.encoder_arcsec,
            r.scale_um,
            r.method.name(),
            r.mu_mean,
            (r.mu_mean_ci_high - r.mu_mean_ci_low) / 2.0,
            (r.mu_mean_ci_high - r.mu_mean_ci_low) / 2.0 / r.mu_mean
        );
    }
}
