//! The validators of a study's sections: `[sweep]` (with its pose counts),
//! `[decision]` and `[reproduce]`. Same rules as [`super::validate`]: each
//! names the key and the allowed range on failure.

use super::raw::{DecisionSection, ReproduceSection, SweepSection};
use super::validate::{Check, MAX_ENCODER_ARCSEC, MAX_SCALE_UM, MAX_TRIALS};
use super::{ErrorDraw, ReproduceConfig, SweepConfig, Truth};
use crate::error::Result;
use crate::identify::Method;
use crate::mechanism::Workspace;
use crate::metrics::{Confidence, Decision, DecisionMetric};

/// The machines `until_decided` may run unless `sweep.max_trials` says.
pub const DEFAULT_DECIDE_MAX_TRIALS: u64 = 200_000;

/// `[sweep]`: the study's grades, trials, error draw and estimators.
pub(super) fn sweep<const R: usize>(
    c: &Check,
    sw: &SweepSection,
    layers: usize,
    workspace: &Workspace,
    method: Method,
    size_mm: f64,
) -> Result<SweepConfig<R>> {
    let errors_draw = match sw.errors.as_str() {
        "random" => ErrorDraw::Random,
        "fixed" => ErrorDraw::Fixed,
        other => {
            return c.fail(
                "sweep.errors",
                format_args!("must be \"random\" or \"fixed\" (got \"{other}\")"),
            )
        }
    };
    if sw.trials == 0 || sw.trials > MAX_TRIALS {
        return c.fail(
            "sweep.trials",
            format_args!("must be between 1 and 1000000000 (got {})", sw.trials),
        );
    }
    if sw.max_trials.is_some() && !sw.until_decided {
        return c.fail(
            "sweep.max_trials",
            "is the budget of sweep.until_decided = true: set that too, or remove it",
        );
    }
    let until_decided_max = if sw.until_decided {
        let max = sw.max_trials.unwrap_or(DEFAULT_DECIDE_MAX_TRIALS);
        if max == 0 || max > MAX_TRIALS {
            return c.fail(
                "sweep.max_trials",
                format_args!("must be from 1 to 1000000000 (got {max})"),
            );
        }
        // Never fewer than the study's own machines (`--trials` may raise them).
        Some(max.max(sw.trials))
    } else {
        None
    };
    let error_bound_mm = c.positive("sweep.error_bound", sw.error_bound)?;
    if error_bound_mm > 0.1 * size_mm {
        return c.fail(
            "sweep.error_bound",
            format_args!("must be below {} mm (got {error_bound_mm})", 0.1 * size_mm),
        );
    }
    let methods = match &sw.methods {
        None => vec![method],
        Some(list) if list.is_empty() => {
            return c.fail("sweep.methods", "must list at least one method")
        }
        Some(list) => {
            let mut out = Vec::new();
            for m in list {
                let m = c.method("sweep.methods", m)?;
                if out.contains(&m) {
                    return c.fail("sweep.methods", "lists a method twice");
                }
                out.push(m);
            }
            out
        }
    };
    let volumetric_step_mm = if sw.volumetric {
        let step = c.positive("sweep.volumetric_grid_step", sw.volumetric_grid_step)?;
        if step > workspace.radius_mm {
            return c.fail(
                "sweep.volumetric_grid_step",
                format_args!("must not exceed workspace.radius ({})", workspace.radius_mm),
            );
        }
        if (workspace.radius_mm / step).powi(2) > 1.0e5 / layers as f64 {
            return c.fail(
                "sweep.volumetric_grid_step",
                "is too fine for a sweep: the workspace grid would have more than 300000 points",
            );
        }
        Some(step)
    } else {
        // Keys that only act on a workspace study would do nothing: say so.
        let default = SweepSection::default();
        if sw.volumetric_exact {
            return c.fail(
                "sweep.volumetric_exact",
                "acts only with sweep.volumetric = true: set that, or remove the key",
            );
        }
        if sw.volumetric_grid_step != default.volumetric_grid_step {
            return c.fail(
                "sweep.volumetric_grid_step",
                "acts only with sweep.volumetric = true: set that, or remove the key",
            );
        }
        None
    };
    Ok(SweepConfig {
        volumetric_step_mm,
        volumetric_exact: sw.volumetric_exact,
        encoder_arcsec: c.grades(
            "sweep.encoder_arcsec",
            &sw.encoder_arcsec,
            MAX_ENCODER_ARCSEC,
        )?,
        scale_um: c.grades("sweep.scale_um", &sw.scale_um, MAX_SCALE_UM)?,
        trials: sw.trials,
        errors: errors_draw,
        error_bound_mm,
        seed: sw.seed,
        methods,
        products: None,
        pose_counts: Vec::new(),
        truth: vec![Truth::DATASHEET],
        second_class_tolerance_deg: Vec::new(),
        second_class_draw_deg: None,
        perfect_sensors: [false; R],
        follow_up: false,
        until_decided_max,
        gls_per_machine: sw.gls_per_machine,
    })
}

/// `[sweep] second_class_tolerance_deg`: increasing tolerances in
/// (0, 1]°, each once; not with a fixed `[second_class]` section.
pub(super) fn second_class_tolerances(
    c: &Check,
    sw: &SweepSection,
    fixed: bool,
) -> Result<Vec<f64>> {
    let key = "sweep.second_class_tolerance_deg";
    let Some(list) = &sw.second_class_tolerance_deg else {
        return Ok(Vec::new());
    };
    if fixed {
        return c.fail(
            key,
            "draws the second-class errors of every machine, and [second_class] fixes them: keep one of the two",
        );
    }
    if list.is_empty() {
        return c.fail(key, "must list at least one tolerance (or be left out)");
    }
    for (i, &t) in list.iter().enumerate() {
        if !(t.is_finite() && t > 0.0 && t <= 1.0) {
            return c.fail(
                key,
                format_args!("must hold tolerances in (0, 1] degrees (got {t})"),
            );
        }
        if i > 0 && t <= list[i - 1] {
            return c.fail(key, "must be in increasing order, each once");
        }
    }
    Ok(list.clone())
}

/// Largest `[sweep] truth_amplitude`.
const MAX_TRUTH_AMPLITUDE: f64 = 100.0;

/// `[sweep] truth_amplitude`: the datasheet itself (1) and the other
/// multiples of its curves the true sensors may have, each once, in
/// (0, 100]; only for datasheet sensors (`datasheet`). Returned with 1
/// first, the others in the order given.
pub(super) fn truth(c: &Check, sw: &SweepSection, datasheet: bool) -> Result<Vec<Truth>> {
    let mut out = truth_amplitude(c, sw, datasheet)?;
    if let Some(f) = sw.truth_extra_harmonic {
        let key = "sweep.truth_extra_harmonic";
        if !datasheet {
            return c.fail(
                key,
                "needs datasheet sensors ([sensors.encoder] / [sensors.scale] or a catalogue): it adds to their error curves",
            );
        }
        if !(f.is_finite() && f > 0.0 && f <= 1.0) {
            return c.fail(
                key,
                format_args!("must be a fraction of the accuracy in (0, 1] (got {f})"),
            );
        }
        out.push(Truth {
            extra_harmonic: f,
            ..Truth::DATASHEET
        });
    }
    let needs = |key: &str, what: &str| -> Result<()> {
        if datasheet {
            Ok(())
        } else {
            c.fail(
                key,
                format_args!("needs datasheet sensors ([sensors.encoder] / [sensors.scale] or a catalogue): it {what}"),
            )
        }
    };
    if let Some(w) = sw.truth_white {
        let key = "sweep.truth_white";
        needs(key, "multiplies their interpolation error and jitter")?;
        if !(w.is_finite() && w > 0.0 && w <= MAX_TRUTH_AMPLITUDE && w != 1.0) {
            return c.fail(
                key,
                format_args!(
                    "must be a multiple in (0, {MAX_TRUTH_AMPLITUDE}] other than 1 (got {w})"
                ),
            );
        }
        out.push(Truth {
            white: w,
            ..Truth::DATASHEET
        });
    }
    if let Some(f) = sw.truth_coherence_fraction {
        let key = "sweep.truth_coherence_fraction";
        needs(key, "sets how far their interpolation errors stay coherent")?;
        if !(f.is_finite() && f > 0.0 && f <= MAX_TRUTH_AMPLITUDE) {
            return c.fail(
                key,
                format_args!(
                    "must be a fraction of the assumed coherence in (0, {MAX_TRUTH_AMPLITUDE}] (got {f})"
                ),
            );
        }
        out.push(Truth {
            coherence_fraction: Some(f),
            ..Truth::DATASHEET
        });
    }
    if sw.truth_outside_order {
        needs(
            "sweep.truth_outside_order",
            "moves their curves outside the model's orders",
        )?;
        out.push(Truth {
            outside_order: true,
            ..Truth::DATASHEET
        });
    }
    if let Some(e) = sw.truth_eccentricity_um {
        let key = "sweep.truth_eccentricity_um";
        needs(key, "mounts their encoder rings off centre")?;
        if !(e.is_finite() && e > 0.0 && e <= 1000.0) {
            return c.fail(
                key,
                format_args!("must be an eccentricity in (0, 1000] µm (got {e})"),
            );
        }
        out.push(Truth {
            eccentricity_um: Some(e),
            ..Truth::DATASHEET
        });
    }
    Ok(out)
}

fn truth_amplitude(c: &Check, sw: &SweepSection, datasheet: bool) -> Result<Vec<Truth>> {
    let key = "sweep.truth_amplitude";
    let at = |amplitude| Truth {
        amplitude,
        ..Truth::DATASHEET
    };
    let Some(list) = &sw.truth_amplitude else {
        return Ok(vec![Truth::DATASHEET]);
    };
    if !datasheet {
        return c.fail(
            key,
            "needs datasheet sensors ([sensors.encoder] / [sensors.scale] or a catalogue): it multiplies their error curves",
        );
    }
    for &a in list {
        if !(a.is_finite() && a > 0.0 && a <= MAX_TRUTH_AMPLITUDE) {
            return c.fail(
                key,
                format_args!("must hold multiples in (0, {MAX_TRUTH_AMPLITUDE}] (got {a})"),
            );
        }
    }
    if (1..list.len()).any(|i| list[..i].contains(&list[i])) {
        return c.fail(key, "lists a multiple twice");
    }
    if !list.contains(&1.0) {
        return c.fail(
            key,
            "must include 1 (the datasheet itself, on which the verdict is made)",
        );
    }
    let mut out = vec![Truth::DATASHEET];
    out.extend(list.iter().copied().filter(|&a| a != 1.0).map(at));
    Ok(out)
}

/// `[sweep] pose_counts`: ascending, each between 2 and the number of
/// poses (default: every pose); Gauss–Newton identifies each subset from
/// its own poses.
pub(super) fn pose_counts(c: &Check, sw: &SweepSection, poses: usize) -> Result<Vec<usize>> {
    let Some(list) = &sw.pose_counts else {
        return Ok(vec![poses]);
    };
    check_pose_counts(c, list, poses)?;
    Ok(list.clone())
}

/// Pose counts must increase, each between 2 and the number of poses
/// (config files and [`super::StudyBuilder`] alike).
pub(super) fn check_pose_counts(c: &Check, list: &[usize], poses: usize) -> Result<()> {
    if list.is_empty() {
        return c.fail("sweep.pose_counts", "must list at least one pose count");
    }
    for (i, &n) in list.iter().enumerate() {
        if n < 2 || n > poses {
            return c.fail(
                "sweep.pose_counts",
                format_args!("must be between 2 and the {poses} poses of the config (got {n})"),
            );
        }
        if i > 0 && n <= list[i - 1] {
            return c.fail(
                "sweep.pose_counts",
                "must be in increasing order, each once",
            );
        }
    }
    Ok(())
}

/// `[decision]`: metric and threshold.
pub(super) fn decision(c: &Check, d: &DecisionSection, volumetric: bool) -> Result<Decision> {
    let Some(metric) = DecisionMetric::parse(&d.metric) else {
        let names: Vec<&str> = DecisionMetric::ALL.iter().map(|m| m.name()).collect();
        return c.fail(
            "decision.metric",
            format_args!("must be one of {} (got \"{}\")", names.join(", "), d.metric),
        );
    };
    if metric.needs_volumetric() && !volumetric {
        return c.fail(
            "decision.metric",
            format_args!("= \"{metric}\" needs sweep.volumetric = true"),
        );
    }
    let confidence = match d.confidence.as_str() {
        "estimate" => Confidence::Estimate,
        "upper95" => Confidence::Upper95,
        "auto" if metric.upper_limit().is_some() => Confidence::Upper95,
        "auto" => Confidence::Estimate,
        other => {
            return c.fail(
                "decision.confidence",
                format_args!("must be \"auto\", \"estimate\" or \"upper95\" (got \"{other}\")"),
            )
        }
    };
    let deciding = match confidence {
        Confidence::Estimate => metric,
        Confidence::Upper95 => match metric.upper_limit() {
            Some(m) => m,
            None => {
                let with: Vec<&str> = DecisionMetric::ALL
                    .iter()
                    .filter(|m| m.upper_limit().is_some())
                    .map(|m| m.name())
                    .collect();
                return c.fail(
                    "decision.confidence",
                    format_args!(
                        "= \"upper95\" needs a metric with a confidence limit: one of {} (got \"{metric}\")",
                        with.join(", ")
                    ),
                );
            }
        },
    };
    Ok(Decision {
        metric: deciding,
        estimate: metric,
        confidence,
        threshold: c.positive("decision.threshold", d.threshold)?,
    })
}

/// `[reproduce]`: the Fig. 4 study of `reproduce`.
pub(super) fn reproduce(c: &Check, rp: &ReproduceSection) -> Result<ReproduceConfig> {
    Ok(ReproduceConfig {
        fig4_encoder_arcsec: c.grades(
            "reproduce.fig4_encoder_arcsec",
            &rp.fig4_encoder_arcsec,
            MAX_ENCODER_ARCSEC,
        )?,
        fig4_draws: if rp.fig4_draws == 0 || rp.fig4_draws > 10_000_000 {
            return c.fail(
                "reproduce.fig4_draws",
                format_args!("must be between 1 and 10000000 (got {})", rp.fig4_draws),
            );
        } else {
            rp.fig4_draws
        },
        seed: rp.seed,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pose_counts_from_two_to_every_pose_increasing() {
        let c = Check { source: "t" };
        let ok = |l: &[usize]| check_pose_counts(&c, l, 51).is_ok();
        assert!(ok(&[2]) && ok(&[2, 51]) && ok(&[9, 17, 51]));
        assert!(!ok(&[1, 51]) && !ok(&[9, 52]) && !ok(&[]));
        assert!(!ok(&[9, 9]) && !ok(&[17, 9]));
    }
}
