//! `design-poses`: choose N calibration poses from a workspace grid to
//! maximise an observability index, and compare them with the config's
//! poses in a short sweep on the same machines.

use crate::cli::console;
use crate::config::Config;
use crate::design::{candidate_grid, Designer, Weights};
use crate::error::{Error, Result};
use crate::io;
use crate::metrics::GradeSummary;
use crate::montecarlo::run_in_memory;
use nalgebra::Vector3;
use std::path::Path;

/// The short comparison sweep of a pose list at the config's sensor grades.
fn short_study(
    cfg: &Config,
    list: &[Vector3<f64>],
    trials: u64,
    threads: usize,
) -> Result<GradeSummary> {
    let s = cfg
        .study()
        .poses(list)
        .encoder_arcsec(&[cfg.sensors.encoder_arcsec.max(1e-6)])
        .scale_um(&[cfg.sensors.scale_um.max(1e-6)])
        .trials(trials)
        .methods(&[cfg.identification.method])
        .build()?;
    let r = run_in_memory(cfg, &s, threads)?;
    Ok(r.summary[0].clone())
}

/// `design-poses`: a designed pose set, written as a `[poses]` list, and a
/// short sweep comparing it with the config's poses on the same machines.
/// What the designed pose set is compared with.
struct Comparison<'a> {
    index: &'a str,
    passes: usize,
    trials: u64,
    designed_value: f64,
    config_value: f64,
    designed: &'a GradeSummary,
    base: &'a GradeSummary,
}

/// The `[poses]` list, with how it was made and how it compares in comments.
fn pose_list(cfg: &Config, poses: &[Vector3<f64>], cmp: Comparison) -> String {
    let Comparison {
        index,
        passes,
        trials,
        designed_value,
        config_value,
        designed,
        base,
    } = cmp;
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
        "# short sweep ({trials} random machines, {}, {}): mean mu {:.5} mm designed vs {:.5} mm config poses; ratio_p95 {:.4} vs {:.4}",
        cfg.sensors.in_words(),
        cfg.identification.method.name(),
        designed.mu_mean,
        base.mu_mean,
        designed.ratio_p95,
        base.ratio_p95
    );
    let _ = writeln!(text, "[poses]\nlist = [");
    for p in poses {
        let _ = writeln!(text, "    [{:?}, {:?}, {:?}],", p.x, p.y, p.z);
    }
    let _ = writeln!(text, "]");
    text
}

pub fn run(
    cfg: &Config,
    count: usize,
    index: &str,
    trials: u64,
    threads: usize,
    out: &Path,
) -> Result<()> {
    if cfg.sensors.encoder_arcsec == 0.0 || cfg.sensors.scale_um == 0.0 {
        return Err(Error::config(
            &cfg.source,
            "sensors.encoder_arcsec and sensors.scale_um must be > 0 for design-poses: the design weights each reading by 1/σ of its sensor",
        ));
    }
    let mech = cfg.homed();
    let candidates = candidate_grid(&mech, (&cfg.workspace, cfg.max_tilt_deg), 5, 12);
    if count < 2 || count > candidates.len() + 1 {
        return Err(Error::Argument(format!(
            "--count must be between 2 and {} (the candidate grid has {} reachable poses), got {count}",
            candidates.len() + 1,
            candidates.len()
        )));
    }
    let weights = Weights {
        sensors: &cfg.sensors,
        method: cfg.identification.method,
        rank_tolerance: cfg.identification.rank_tolerance,
        source: &cfg.source,
    };
    let designer = Designer::new(&mech, weights, &cfg.poses[0], (candidates, index))?;
    let (chosen, passes) = designer.design(count - 1, 100);
    let mut poses = vec![cfg.poses[0]];
    poses.extend(chosen.iter().map(|&c| designer.points[c]));
    let designed_value = designer.value_of(&mech, &poses)?;
    let config_value = designer.value_of(&mech, &cfg.poses)?;
    // Short sweep on the same random machines and noise: config poses vs designed.
    let study = |list: &[Vector3<f64>]| short_study(cfg, list, trials, threads);
    let base = study(&cfg.poses)?;
    let designed = study(&poses)?;
    let text = pose_list(
        cfg,
        &poses,
        Comparison {
            index,
            passes,
            trials,
            designed_value,
            config_value,
            designed: &designed,
            base: &base,
        },
    );
    io::write_output(out, text.as_bytes())?;
    // With `--out -` the pose list is stdout; the comparison goes aside.
    let say = |s: String| {
        if io::is_stdout(out) {
            console::note(s)
        } else {
            console::line(s)
        }
    };
    say(format!(
        "{:<22} {:>8} {:>14} {:>12} {:>10}",
        "pose set", "poses", index, "mean mu mm", "ratio_p95"
    ));
    say(format!(
        "{:<22} {:>8} {:>14.6e} {:>12.5} {:>10.4}",
        "config poses",
        cfg.poses.len(),
        config_value,
        base.mu_mean,
        base.ratio_p95
    ));
    say(format!(
        "{:<22} {:>8} {:>14.6e} {:>12.5} {:>10.4}",
        "designed",
        poses.len(),
        designed_value,
        designed.mu_mean,
        designed.ratio_p95
    ));
    say(format!(
        "note: {index} here is of the noise-weighted design with columns scaled by the candidates' norms; `identifiability` scales H differently, so its O1–O5 are not comparable with these"
    ));
    say(format!(
        "wrote {} ({} exchange passes)",
        out.display(),
        passes
    ));
    Ok(())
}
