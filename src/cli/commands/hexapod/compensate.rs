//! `compensate` and `verify` for the hexapod: the identified machine's
//! commands for target poses, and a fresh log against it.

use super::files::{gate_rejected_fit, read_identified, read_log, read_targets};
use crate::cli::console;
use crate::error::{Error, Result};
use crate::io;
use crate::mechanism::hexapod::config::HexapodConfig;
use crate::mechanism::hexapod::convention::CONVENTION;
use crate::mechanism::hexapod::identify::{identify, predict};
use crate::mechanism::hexapod::LEGS;
use std::path::Path;

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
    let log = read_log(cfg, readings, "verify")?;
    let (file, per) = (&log.file, cfg.hexapod.readings_per_pose());
    let mut worst = (0.0f64, 0.0f64, 0u64);
    for (k, (target, line)) in log.targets.iter().zip(&log.lines).enumerate() {
        let read = &log.readings[k * per..(k + 1) * per];
        let q = if nominal_commands {
            cfg.hexapod.commands(target)
        } else {
            cfg.hexapod.commands_of(&model, target)
        };
        let reached = Hexapod::forward(&model, &q, target).map_err(|why| {
            Error::csv(file, format!("line {line}: the identified machine {why}"))
        })?;
        let seen = pose_from_readings(&cfg.hexapod, &model, read, &reached)
            .map_err(|why| Error::csv(file, format!("line {line}: {why}")))?;
        let d = (seen.t - reached.t).norm();
        let a = rotation_angle(&(seen.r * reached.r.transpose())).to_degrees() * 3600.0;
        if d > worst.0 {
            worst = (d, worst.1, *line);
        }
        worst.1 = worst.1.max(a);
    }
    let text = format!(
        "{} poses: the identified machine puts the platform within {:.4} mm and {:.2}″ of where the encoders say it stood (worst at line {}); threshold {threshold_mm} mm",
        log.targets.len(),
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
